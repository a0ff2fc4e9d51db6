//! The `score_submission` job: unpack the stored upload, validate it again with the very
//! code that accepted it, score every map, and record the score (a new row each time, so
//! re-scoring never overwrites) together with the job's success, fenced on its lease.

use std::path::Path;

use osmab_evaluator::submission::{ArchiveLimits, ReleaseIndex, SubmissionLimits, score_submission, unpack, validate};
use osmab_evaluator::vqa::score::OpenBackends;
use osmab_evaluator::{EVALUATOR_VERSION, InputError};
use serde_json::json;

use super::{JobContext, JobError};
use crate::clock::now_ms;
use crate::intake::Scratch;
use crate::releases::release_dir;

/// A scoring error is the participant's when it is about a file of the submission (then
/// it is shown relative to the submission); anything else (the release, the disk) is the
/// server's and is retried.
fn classify(e: InputError, unpacked: &Path) -> JobError {
    let prefix = format!("{}/", unpacked.display());
    match e.file.strip_prefix(&prefix) {
        Some(inside) => JobError::Permanent(InputError { file: inside.to_string(), ..e }.to_string()),
        None => JobError::Retryable(e.to_string()),
    }
}

pub async fn run(ctx: JobContext) -> Result<(), JobError> {
    let state = &ctx.state;
    let submission = state.store.submission(&ctx.job.subject).await?;
    // A later attempt says why: a failed one put the submission back in the queue with
    // its failure as the reason; one that left no reason was lost with its worker.
    let (attempt, of) = (ctx.job.attempts, ctx.job.max_attempts);
    let reason = match (attempt, submission.state.as_str(), &submission.reason) {
        (1, _, _) => None,
        (_, "queued", Some(_)) => Some(format!("attempt {attempt} of {of}")),
        _ => Some(format!("attempt {attempt} of {of}: the worker of the previous attempt stopped responding (its lease expired); scoring again")),
    };
    if !state.store.set_submission_state(&submission.id, &["queued", "scoring"], "scoring", reason.as_deref(), now_ms()).await? {
        let now = state.store.submission(&submission.id).await?;
        if now.state != "scoring" {
            tracing::info!(state = %now.state, "nothing to score: the submission left the queue");
            return Ok(());
        }
    }
    let archive = state.blobs.path(&format!("submissions/{}/upload", submission.id))?;
    if !archive.is_file() {
        return Err(JobError::Retryable(format!("the stored upload of {} is missing", submission.id)));
    }
    let release = release_dir(&state.blobs, &submission.release)?;
    let unpack_to = Scratch(state.blobs.scratch("score"));
    let max_unpacked = state.settings.max_unpacked_bytes;
    let llm = crate::llm::from_settings(&state.settings).map_err(|e| JobError::Retryable(format!("LLM settings: {e}")))?;
    let blocking_ctx = ctx.clone();
    let body = tokio::task::spawn_blocking(move || -> Result<serde_json::Value, JobError> {
        let root = unpack_to.0.clone();
        // The upload passed these checks when it arrived: failing now is the server's problem.
        unpack(&archive, &root, ArchiveLimits { max_entries: 20_000, max_total_bytes: max_unpacked }).map_err(|e| JobError::Retryable(e.to_string()))?;
        let index = ReleaseIndex::read(&release).map_err(|e| JobError::Retryable(e.to_string()))?;
        let limits = SubmissionLimits::for_release(&index, max_unpacked);
        let valid =
            validate(&root, &index, limits).map_err(|problems| JobError::Permanent(problems.iter().map(ToString::to_string).collect::<Vec<_>>().join("; ")))?;
        let progress = |done: usize, total: usize| {
            blocking_ctx.progress_blocking(&json!({"stage": "scoring", "done": done, "total": total, "message": format!("scored {done} of {total} maps")}));
        };
        let open = match &llm {
            Some((answerer, judge)) => OpenBackends { answerer: Some(answerer), judge: Some(judge) },
            None => OpenBackends::default(),
        };
        let scored = score_submission(&valid, &index, limits, open, &progress).map_err(|e| classify(e, &valid.root));
        drop(unpack_to);
        scored
    })
    .await??;
    let recorded =
        state.store.complete_scoring(&ctx.job.id, &ctx.owner, &submission.id, &submission.release, EVALUATOR_VERSION, &body.to_string(), now_ms()).await?;
    if recorded {
        state.leaderboard.invalidate();
    } else {
        tracing::warn!("the score was not recorded: the lease was lost or the submission was cancelled meanwhile");
    }
    Ok(())
}
