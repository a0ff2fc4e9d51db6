//! The `score_submission` job: unpack the stored upload, validate it again with the very
//! code that accepted it, score every map, and record the score (a new row each time, so
//! re-scoring never overwrites) together with the job's success, fenced on its lease.

use std::path::{Path, PathBuf};

use osmab_evaluator::ScoreError;
use osmab_evaluator::scores::{Scores, Split};
use osmab_evaluator::semseg::prepared_cache::PreparedCache;
use osmab_evaluator::submission::score::ScoringTimings;
use osmab_evaluator::submission::{ArchiveLimits, ReleaseIndex, SubmissionLimits, score_submission_timed, unpack, validate};
use osmab_evaluator::vqa::score::OpenBackends;
use serde::{Deserialize, Serialize};

use super::progress::{Progress, Stage};
use super::{Failed, Fault, Job, JobContext, JobError};
use crate::blobs::{Fetched, Scratch};
use crate::clock::now_ms;
use crate::llm::{LlmAnswerer, LlmJudge};
use crate::state::AppState;
use crate::store::{ClaimedJob, JobKind, StoreError, SubmissionRecord, SubmissionState};

/// Score submission `submission_id` (again, with `rescore`).
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct ScoreSubmission {
    pub submission_id: String,
    /// Asked for by an admin after an earlier score.
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub rescore: bool,
}

impl Job for ScoreSubmission {
    const KIND: JobKind = JobKind::ScoreSubmission;

    fn subject(&self) -> String {
        self.submission_id.clone()
    }

    async fn run(self, ctx: JobContext) -> Result<(), JobError> {
        score(ctx, &self.submission_id).await
    }

    /// The submission fails with its job; when the service is at fault, the team's quota
    /// unit is given back, and the message says so.
    async fn fail(state: &AppState, failed: &Failed<'_>) -> Result<bool, StoreError> {
        let refund = failed.fault == Fault::Service;
        let message = if refund { format!("{} It does not count against the team's quota.", failed.message) } else { failed.message.to_string() };
        state.store.fail_job(&failed.job.id, failed.owner, &message, Some(&failed.job.subject), refund, failed.now).await
    }

    /// The submission goes back to the queue, saying why.
    async fn retrying(state: &AppState, job: &ClaimedJob, message: &str, now: i64) {
        let back = state.store.set_submission_state(&job.subject, &[SubmissionState::Scoring], SubmissionState::Queued, Some(message), now).await;
        if let Err(e) = back {
            tracing::warn!(error = %e, "could not put the submission back in the queue; it shows as scoring until the next attempt");
        }
    }
}

/// A scoring error about a file of the submission is the participant's (shown relative to
/// the submission); one about the release or the machine is the server's and is retried.
fn classify(e: ScoreError, unpacked: &Path) -> JobError {
    match e {
        ScoreError::Submission(e) => JobError::Permanent(e.relative_to(unpacked).to_string()),
        ScoreError::Service(e) => JobError::Retryable(e.to_string()),
    }
}

async fn score(ctx: JobContext, submission_id: &str) -> Result<(), JobError> {
    let state = &ctx.state;
    let submission = state.store.submission(submission_id).await?;
    if !start_scoring(&ctx, &submission).await? {
        return Ok(());
    }
    let stored = state.blobs.fetch(&format!("submissions/{}/upload", submission.id)).await.map_err(|e| match e.kind() {
        std::io::ErrorKind::NotFound => JobError::Retryable(format!("the stored upload of {} is missing", submission.id)),
        _ => JobError::Retryable(format!("the stored upload of {}: {e}", submission.id)),
    })?;
    let release = match state.blobs.release(&submission.release).await.map_err(JobError::retryable)? {
        Some(release) => release,
        None => return Err(JobError::Retryable(format!("release {} is missing from the blob store", submission.release))),
    };
    let work = Scoring {
        stored,
        release,
        split: submission.split,
        unpack_to: Scratch(state.blobs.scratch("score")),
        max_unpacked: state.settings.max_unpacked_bytes,
        llm: crate::llm::from_settings(&state.settings).map_err(|e| JobError::Retryable(format!("LLM settings: {e}")))?,
        cache: ground_truth_cache(&state.settings),
        ctx: ctx.clone(),
    };
    let scores = tokio::task::spawn_blocking(move || work.run()).await.map_err(|e| JobError::Retryable(format!("the scoring thread ended: {e}")))??;
    let recorded = state.store.complete_scoring(&ctx.job.id, &ctx.owner, &submission.id, &scores, now_ms()).await?;
    if recorded {
        state.leaderboard.invalidate();
    } else {
        tracing::warn!("the score was not recorded: the lease was lost or the submission was cancelled meanwhile");
    }
    Ok(())
}

/// Mark the submission as being scored; `false` when it left the queue meanwhile
/// (cancelled), so there is nothing to score. A later attempt says why: a failed one put
/// the submission back in the queue with its failure as the reason; one that left no
/// reason was lost with its worker.
async fn start_scoring(ctx: &JobContext, submission: &SubmissionRecord) -> Result<bool, JobError> {
    let state = &ctx.state;
    let (attempt, of) = (ctx.job.attempts, ctx.job.max_attempts);
    let reason = match (attempt, submission.state, &submission.reason) {
        (1, _, _) => None,
        (_, SubmissionState::Queued, Some(_)) => Some(format!("attempt {attempt} of {of}")),
        _ => Some(format!("attempt {attempt} of {of}: the worker of the previous attempt stopped responding (its lease expired); scoring again")),
    };
    let (from, to) = ([SubmissionState::Queued, SubmissionState::Scoring], SubmissionState::Scoring);
    if !state.store.set_submission_state(&submission.id, &from, to, reason.as_deref(), now_ms()).await? {
        let now = state.store.submission(&submission.id).await?;
        if now.state != SubmissionState::Scoring {
            tracing::info!(state = %now.state, "nothing to score: the submission left the queue");
            return Ok(false);
        }
    }
    Ok(true)
}

/// The blocking part of scoring a submission: its stored upload unpacked, validated
/// against its release's split and scored.
struct Scoring {
    stored: Fetched,
    release: PathBuf,
    split: Split,
    /// Where the upload is unpacked (removed when scored).
    unpack_to: Scratch,
    max_unpacked: u64,
    llm: Option<(LlmAnswerer, LlmJudge)>,
    cache: Option<PreparedCache>,
    ctx: JobContext,
}

impl Scoring {
    fn run(self) -> Result<Scores, JobError> {
        let root = self.unpack_to.0.clone();
        // The upload passed these checks when it arrived: failing now is the server's problem.
        let limits = ArchiveLimits { max_entries: 20_000, max_total_bytes: self.max_unpacked, max_expansion_ratio: None };
        unpack(self.stored.path(), &root, limits).map_err(|e| JobError::Retryable(e.to_string()))?;
        let index = ReleaseIndex::read(&self.release).and_then(|index| index.for_split(self.split)).map_err(|e| JobError::Retryable(e.to_string()))?;
        let limits = SubmissionLimits::for_release(&index, self.max_unpacked);
        let valid =
            validate(&root, &index, limits).map_err(|problems| JobError::Permanent(problems.iter().map(ToString::to_string).collect::<Vec<_>>().join("; ")))?;
        let progress = |done: usize, total: usize| {
            self.ctx.progress_blocking(&Progress {
                done: Some(done),
                total: Some(total),
                ..Progress::at(Stage::Scoring, format!("scored {done} of {total} maps"))
            });
        };
        let open = match &self.llm {
            Some((answerer, judge)) => OpenBackends { answerer: Some(answerer), judge: Some(judge) },
            None => OpenBackends::default(),
        };
        let scored = score_submission_timed(&valid, &index, limits, open, self.cache.as_ref(), &progress).map_err(|e| classify(e, &valid.root));
        drop(self.unpack_to);
        let (scores, timings) = scored?;
        log_timings(&timings);
        Ok(scores)
    }
}

/// Where the time of a scoring went, and why prepared ground truth was not reused.
fn log_timings(timings: &ScoringTimings) {
    for why in &timings.cache_misses {
        // A first preparation is the cache filling, not news; anything else says why
        // prepared ground truth could not be reused.
        if why.ends_with("not cached yet") {
            tracing::debug!(%why, "ground truth prepared for the first time on this node");
        } else {
            tracing::info!(%why, "ground truth prepared again (the cached copy could not be used)");
        }
    }
    for why in &timings.not_kept {
        tracing::warn!(%why, "prepared ground truth not kept in this node's cache");
    }
    tracing::info!(
        maps = timings.maps,
        ground_truth_cached = timings.ground_truth_cached,
        read_ground_truth_s = timings.read_ground_truth.as_secs_f64(),
        prepare_ground_truth_s = timings.prepare_ground_truth.as_secs_f64(),
        keep_ground_truth_s = timings.keep_ground_truth.as_secs_f64(),
        wait_for_cache_s = timings.wait_for_cache.as_secs_f64(),
        associate_s = timings.scenes.query.as_secs_f64(),
        "scored"
    );
}

/// This node's cache of ground truth prepared for scoring, unless it is turned off.
pub(super) fn ground_truth_cache(settings: &crate::config::Settings) -> Option<PreparedCache> {
    (settings.ground_truth_cache_bytes > 0)
        .then(|| PreparedCache::new(settings.data_dir.join("cache").join("prepared-ground-truth"), settings.ground_truth_cache_bytes))
}

#[cfg(test)]
mod tests {
    use osmab_evaluator::InputError;

    use super::*;

    #[test]
    fn a_submission_s_file_fails_for_good_named_inside_it_and_the_release_s_is_retried() {
        let unpacked = Path::new("/data/scratch/score-1");
        let map = InputError::new(unpacked.join("maps/baseline/scene_000.npz"), "points", "not finite");
        match classify(ScoreError::Submission(map), unpacked) {
            JobError::Permanent(message) => assert_eq!(message, "maps/baseline/scene_000.npz: points: not finite"),
            other => panic!("{other:?}"),
        }
        // Named relative already (a graph, as the VQA scorer names it): still the team's.
        let graph = InputError::new("graphs/camera/scene_001.json", "(json)", "expected value");
        assert!(matches!(classify(ScoreError::Submission(graph), unpacked), JobError::Permanent(m) if m.starts_with("graphs/camera/scene_001.json")));
        let truth = InputError::new("/data/releases/v1/ground_truth/scene_000/semantic.npy", "(file)", "file not found");
        assert!(matches!(classify(ScoreError::Service(truth), unpacked), JobError::Retryable(m) if m.contains("semantic.npy")));
    }
}
