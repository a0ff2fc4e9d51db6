//! The `score_submission` job: unpack the stored upload, validate it again with the very
//! code that accepted it, score every map, and record the score (a new row each time, so
//! re-scoring never overwrites).

use osmab_evaluator::EVALUATOR_VERSION;
use osmab_evaluator::submission::{ArchiveLimits, ReleaseIndex, SubmissionLimits, score_submission, unpack, validate};
use serde_json::json;

use super::{JobContext, JobError};
use crate::clock::now_ms;
use crate::intake::Scratch;
use crate::releases::release_dir;

pub async fn run(ctx: JobContext) -> Result<(), JobError> {
    let state = &ctx.state;
    let submission = state.store.submission(&ctx.job.subject).await?;
    if submission.state == "cancelled" {
        return Ok(());
    }
    state.store.set_submission_state(&submission.id, &["queued", "scoring"], "scoring", None, now_ms()).await?;
    let archive = state.blobs.path(&format!("submissions/{}/upload", submission.id))?;
    let release = release_dir(&state.blobs, &submission.release)?;
    let unpack_to = Scratch(state.blobs.scratch("score"));
    let max_unpacked = state.settings.max_unpacked_bytes;
    let blocking_ctx = ctx.clone();
    let body = tokio::task::spawn_blocking(move || -> Result<serde_json::Value, JobError> {
        let permanent = |e: osmab_evaluator::InputError| JobError::Permanent(e.to_string());
        unpack(&archive, &unpack_to.0, ArchiveLimits { max_entries: 20_000, max_total_bytes: max_unpacked }).map_err(permanent)?;
        let index = ReleaseIndex::read(&release).map_err(|e| JobError::Retryable(e.to_string()))?;
        let valid = validate(&unpack_to.0, &index, SubmissionLimits::default())
            .map_err(|problems| JobError::Permanent(problems.iter().map(ToString::to_string).collect::<Vec<_>>().join("; ")))?;
        let progress = |done: usize, total: usize| {
            blocking_ctx.progress_blocking(&json!({"stage": "scoring", "done": done, "total": total, "message": format!("scored {done} of {total} maps")}));
        };
        score_submission(&valid, &index, SubmissionLimits::default(), &progress).map_err(permanent)
    })
    .await??;
    let now = now_ms();
    if !state.store.heartbeat(&ctx.job.id, &ctx.owner, now + (state.settings.job_lease_secs * 1000) as i64, now).await? {
        return Err(JobError::Retryable("the lease was lost while scoring".into()));
    }
    state.store.add_score(&submission.id, &submission.release, EVALUATOR_VERSION, &body.to_string(), now).await?;
    state.leaderboard.invalidate();
    Ok(())
}
