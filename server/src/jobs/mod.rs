//! Background jobs: a [`Job`] is a kind constant and a typed payload, enqueued with
//! [`enqueue`] and run by [`worker`]s that hold a lease on it while it runs. A run ends
//! in success, a [`JobError`] that says whether retrying can help, or a wait. What a
//! failure does beyond the job (a scoring job fails its submission) is the kind's own
//! ([`Job::fail`], [`Job::retrying`]); the worker knows no kind but in the one match that
//! runs each by its type.

pub mod progress;
pub mod reference_entries;
pub mod release_build;
pub mod scoring;
pub mod warmup;
pub mod worker;

use std::future::Future;
use std::time::Duration;

use serde::Serialize;
use serde::de::DeserializeOwned;

use crate::clock::{new_id, now_ms};
use crate::state::AppState;
use crate::store::{ClaimedJob, JobKind, NewJob, StoreError};
use progress::Progress;

/// A kind of background job: its payload is the job's parameters, stored as JSON.
pub trait Job: Serialize + DeserializeOwned + Send + 'static {
    /// The kind as stored in the queue.
    const KIND: JobKind;

    /// What the job is about (a submission id, a release version): the queue holds at
    /// most one live job per kind and subject.
    fn subject(&self) -> String;

    /// Whether each run's start is news to an operator following the log (INFO), rather
    /// than one of the many runs a coordinator fans out (DEBUG).
    const STARTS_ARE_NEWS: bool = true;

    /// Do the work.
    fn run(self, ctx: JobContext) -> impl Future<Output = Result<(), JobError>> + Send;

    /// Record that `failed.job` failed for good, with what depends on it, in one store
    /// transaction; `false` when the lease was lost meanwhile. By default only the job.
    fn fail(state: &AppState, failed: &Failed<'_>) -> impl Future<Output = Result<bool, StoreError>> + Send {
        async move { state.store.fail_job(&failed.job.id, failed.owner, failed.message, None, false, failed.now).await }
    }

    /// After a failed attempt of `job` went back to the queue to be retried (`message`
    /// says why and when): what its subject shows meanwhile. By default nothing.
    fn retrying(state: &AppState, job: &ClaimedJob, message: &str, now: i64) -> impl Future<Output = ()> + Send {
        let _ = (state, job, message, now);
        async {}
    }
}

/// Whose fault a failure is.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Fault {
    /// The input's (the job's own payload, or what a participant uploaded).
    Input,
    /// The infrastructure's: workers that kept dying, failures retrying could not cure.
    Service,
}

/// A job failing for good.
#[derive(Debug, Clone, Copy)]
pub struct Failed<'a> {
    pub job: &'a ClaimedJob,
    /// The worker holding its lease.
    pub owner: &'a str,
    /// Why, in words for whoever follows the job.
    pub message: &'a str,
    pub fault: Fault,
    pub now: i64,
}

/// How a job run ended when it did not succeed.
#[derive(Debug)]
pub enum JobError {
    /// The input is wrong; retrying cannot help. The message is for the participant.
    Permanent(String),
    /// Something outside the input failed (disk, database); retried with backoff.
    Retryable(String),
    /// A coordinator waits for the jobs it fanned out: back to the queue without
    /// counting an attempt, to run again after the delay.
    Waiting(Duration),
}

impl JobError {
    /// A failure retrying can cure (the disk, the network, another process).
    pub fn retryable(e: impl std::fmt::Display) -> Self {
        JobError::Retryable(e.to_string())
    }
}

/// The database failing is the infrastructure failing: retried.
impl From<StoreError> for JobError {
    fn from(e: StoreError) -> Self {
        JobError::Retryable(e.to_string())
    }
}

/// The queue record of `job`, ready to enqueue (alone or inside a transaction).
pub fn new_job<J: Job>(job: &J, state: &AppState) -> NewJob {
    NewJob {
        id: new_id("job"),
        kind: J::KIND,
        subject: job.subject(),
        payload: serde_json::to_string(job).expect("a job payload serialises"),
        max_attempts: state.settings.job_max_attempts,
        created_at: now_ms(),
    }
}

/// Enqueue `job`; returns its id. A live job of the same kind and subject is a conflict.
pub async fn enqueue<J: Job>(state: &AppState, job: &J) -> Result<String, StoreError> {
    let record = new_job(job, state);
    state.store.enqueue(&record).await?;
    Ok(record.id)
}

/// What a running job may do besides its work: report progress.
#[derive(Clone)]
pub struct JobContext {
    pub state: AppState,
    pub job: ClaimedJob,
    pub owner: String,
    /// When this attempt began (ms since the epoch; for a build taken up again while it
    /// waits for its render jobs, when it first began).
    pub started_at: i64,
}

impl JobContext {
    /// Record `progress` on the job (visible in `GET /api/v1/jobs/{id}`), with the worker
    /// and the time this attempt began (a build waiting for its render jobs keeps the
    /// start of the attempt that began it).
    pub async fn progress(&self, progress: &Progress) {
        let mut progress = progress.clone();
        progress.worker.get_or_insert_with(|| self.owner.clone());
        progress.started_at.get_or_insert(self.started_at);
        let text = serde_json::to_string(&progress).expect("progress serialises");
        if let Err(e) = self.state.store.set_job_progress(&self.job.id, &self.owner, &text, now_ms()).await {
            tracing::warn!(job = %self.job.id, error = %e, "could not record progress");
        }
    }

    /// As [`JobContext::progress`], from blocking code.
    pub fn progress_blocking(&self, progress: &Progress) {
        tokio::runtime::Handle::current().block_on(self.progress(progress));
    }
}
