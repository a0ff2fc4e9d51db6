//! Workers: claim a job, hold its lease with heartbeats while the work runs off the
//! async runtime, then record success, a retry with backoff, or a failure in words. A
//! job whose worker died is claimed again once its lease expires; after
//! `job_max_attempts` it fails with an explanation instead of looping.

use std::sync::Arc;
use std::time::Duration;

use tokio::sync::{Mutex, watch};
use tracing::Instrument;

use super::warmup::Warmup;
use super::{Failed, Fault, Job, JobContext, JobError, release_build, scoring};
use crate::clock::now_ms;
use crate::state::AppState;
use crate::store::{ClaimedJob, JobKind, JobState};

/// Delay before attempt `attempts + 1`: 5 s doubling, at most 5 minutes.
pub fn backoff(attempts: i64) -> Duration {
    Duration::from_secs((5u64 << attempts.clamp(0, 6) as u64).min(300))
}

/// Run one claimed job to its end (or until shutdown releases it), as the kind it is: the
/// one place the worker names the kinds.
async fn process(state: &AppState, owner: &str, job: ClaimedJob, shutdown: watch::Receiver<bool>) {
    match job.kind {
        JobKind::ScoreSubmission => process_as::<scoring::ScoreSubmission>(state, owner, job, shutdown).await,
        JobKind::BuildRelease => process_as::<release_build::BuildRelease>(state, owner, job, shutdown).await,
        JobKind::RenderSequence => process_as::<release_build::RenderSequence>(state, owner, job, shutdown).await,
    }
}

/// Fail `job` for good with `message`, as its kind fails.
async fn fail<J: Job>(state: &AppState, owner: &str, job: &ClaimedJob, message: &str, fault: Fault) {
    match J::fail(state, &Failed { job, owner, message, fault, now: now_ms() }).await {
        Ok(true) => {}
        Ok(false) => tracing::warn!("the lease was lost; another worker owns the job now"),
        Err(e) => tracing::error!(error = %e, "could not record the failure; the job is retried when its lease expires"),
    }
}

/// [`process`] for a job of kind `J`.
async fn process_as<J: Job>(state: &AppState, owner: &str, job: ClaimedJob, shutdown: watch::Receiver<bool>) {
    if job.attempts > job.max_attempts {
        let message = format!(
            "Stopped after {} attempts: the worker running it stopped responding each time (its lease expired). The organisers have been alerted by the logs.",
            job.max_attempts
        );
        tracing::error!("{message}");
        fail::<J>(state, owner, &job, &message, Fault::Service).await;
        return;
    }
    // One line per job, at INFO for the jobs a person follows (a build fans out into many
    // render jobs, which say so at DEBUG, and takes itself up again every few seconds while
    // it waits for them, which is no new start).
    let earlier = super::progress::Progress::read(&job.progress);
    let resumed = earlier.waiting_for.is_some();
    if !J::STARTS_ARE_NEWS {
        tracing::debug!(attempt = job.attempts, "{} job started", job.kind);
    } else if resumed {
        tracing::debug!(attempt = job.attempts, "{} job resumed", job.kind);
    } else {
        tracing::info!("{} job started (attempt {} of {})", job.kind, job.attempts, job.max_attempts);
    }
    let started_at = if resumed { earlier.started_at.unwrap_or_else(now_ms) } else { now_ms() };
    let Some(result) = run_leased::<J>(state, owner, &job, started_at, shutdown).await else {
        let now = now_ms();
        match state.store.release_job(&job.id, owner, now, now).await {
            Ok(_) => tracing::warn!("released the unfinished job for another worker"),
            Err(e) => tracing::error!(error = %e, "could not release the job; it is taken up again when its lease expires"),
        }
        return;
    };
    record_outcome::<J>(state, owner, &job, result).await;
}

/// Run `job`, renewing its lease meanwhile; `None` when shutdown's grace period ended
/// before the job did. Until shutdown there is no deadline; then the running job has the
/// grace period, and the lease is still renewed so no other worker takes the job over.
async fn run_leased<J: Job>(
    state: &AppState,
    owner: &str,
    job: &ClaimedJob,
    started_at: i64,
    mut shutdown: watch::Receiver<bool>,
) -> Option<Result<(), JobError>> {
    let lease = Duration::from_secs(state.settings.job_lease_secs);
    let ctx = JobContext { state: state.clone(), job: job.clone(), owner: owner.to_string(), started_at };
    let mut work = tokio::spawn(dispatch::<J>(ctx));
    let mut heartbeat = tokio::time::interval(lease / 3);
    heartbeat.tick().await;
    let mut deadline: Option<tokio::time::Instant> = None;
    let outcome = loop {
        let grace_over = async {
            match deadline {
                Some(at) => tokio::time::sleep_until(at).await,
                None => std::future::pending().await,
            }
        };
        tokio::select! {
            result = &mut work => break Some(result),
            _ = heartbeat.tick() => {
                let now = now_ms();
                match state.store.heartbeat(&job.id, owner, now + lease.as_millis() as i64, now).await {
                    Ok(true) => {}
                    Ok(false) => tracing::warn!("lost the lease (expired and taken by another worker); the result will be discarded"),
                    Err(e) => tracing::warn!(error = %e, "heartbeat failed"),
                }
            }
            _ = shutdown.changed(), if deadline.is_none() => {
                let grace = Duration::from_secs(state.settings.shutdown_grace_secs);
                tracing::info!(grace_secs = grace.as_secs(), "shutting down: waiting for the running job");
                deadline = Some(tokio::time::Instant::now() + grace);
            }
            _ = grace_over => break None,
        }
    };
    outcome.map(|result| result.unwrap_or_else(|panic| Err(JobError::Retryable(format!("the job panicked: {panic}")))))
}

/// Record how a run of `job` ended: succeeded, back in the queue (waiting, or to retry
/// with backoff), or failed for good.
async fn record_outcome<J: Job>(state: &AppState, owner: &str, job: &ClaimedJob, result: Result<(), JobError>) {
    let now = now_ms();
    match result {
        Ok(()) => {
            tracing::info!("job succeeded");
            let _ = state.store.finish_job(&job.id, owner, JobState::Succeeded, None, None, now).await;
        }
        Err(JobError::Waiting(delay)) => {
            if let Err(e) = state.store.release_job(&job.id, owner, now + delay.as_millis() as i64, now).await {
                tracing::warn!(error = %e, "could not put the waiting job back; it is taken up again when its lease expires");
            }
        }
        Err(JobError::Permanent(message)) => {
            tracing::warn!(%message, "job failed");
            fail::<J>(state, owner, job, &message, Fault::Input).await;
        }
        Err(JobError::Retryable(cause)) if job.attempts >= job.max_attempts => {
            let message = format!("Failed {} times; the last failure: {cause}. The organisers can re-run it.", job.attempts);
            tracing::error!(%message, "job failed for good");
            fail::<J>(state, owner, job, &message, Fault::Service).await;
        }
        Err(JobError::Retryable(cause)) => {
            let retry_at = now + backoff(job.attempts).as_millis() as i64;
            tracing::warn!(%cause, retry_at = %crate::clock::rfc3339(retry_at), "job failed; will retry");
            let message = format!("attempt {} failed ({cause}); retrying at {}", job.attempts, crate::clock::rfc3339(retry_at));
            match state.store.finish_job(&job.id, owner, JobState::Queued, Some(&message), Some(retry_at), now).await {
                Ok(_) => J::retrying(state, job, &message, now).await,
                Err(e) => tracing::warn!(error = %e, "could not queue the retry; the job is taken up again when its lease expires"),
            }
        }
    }
}

/// Run a claimed job of kind `J`: its payload parsed, then its work.
async fn dispatch<J: Job>(ctx: JobContext) -> Result<(), JobError> {
    let job: J = serde_json::from_str(&ctx.job.payload).map_err(|e| JobError::Permanent(format!("{} payload: {e}", J::KIND)))?;
    job.run(ctx).await
}

/// Claim and run jobs until `shutdown` turns true; while idle, make the current release
/// ready to score (`warmup`, shared by the process's workers so one at a time does it).
pub async fn run_worker(state: AppState, owner: String, warmup: Arc<Mutex<Warmup>>, mut shutdown: watch::Receiver<bool>) {
    tracing::info!(worker = %owner, "worker started");
    let poll = Duration::from_millis(state.settings.poll_ms);
    let lease_ms = (state.settings.job_lease_secs * 1000) as i64;
    while !*shutdown.borrow() {
        let now = now_ms();
        match state.store.claim_next_job(&owner, now, now + lease_ms).await {
            Ok(Some(job)) => {
                let span = tracing::info_span!("job", id = %job.id, kind = %job.kind, subject = %job.subject, attempt = job.attempts);
                process(&state, &owner, job, shutdown.clone()).instrument(span).await
            }
            Ok(None) => {
                if super::warmup::warm_next_scene(&state, &warmup).await {
                    continue;
                }
                tokio::select! {
                    _ = tokio::time::sleep(poll) => {}
                    _ = shutdown.changed() => {}
                }
            }
            Err(e) => {
                tracing::warn!(error = %e, "could not claim a job; retrying");
                tokio::time::sleep(poll * 4).await;
            }
        }
    }
    tracing::info!(worker = %owner, "worker stopped");
}
