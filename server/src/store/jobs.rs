//! The job queue: a `jobs` table with leases. A worker claims the oldest ready job (or
//! one whose lease expired because its worker died) and holds it by heartbeats; only
//! the lease holder may finish it. Claiming is one statement: PostgreSQL skips rows
//! other workers have locked (`FOR UPDATE SKIP LOCKED`), SQLite serialises writers.

use super::{JobKind, JobRecord, JobState, Store, StoreError, StoreResult, on_pool};

pub(super) const JOB_COLUMNS: &str =
    "id, kind, subject, payload, state, attempts, max_attempts, run_after, lease_owner, lease_expires, progress, error, created_at, updated_at";

/// A job to enqueue.
#[derive(Debug, Clone)]
pub struct NewJob {
    pub id: String,
    /// What to do (`score_submission`, `build_release`).
    pub kind: JobKind,
    /// What it is about (a submission id or release version).
    pub subject: String,
    /// JSON parameters.
    pub payload: String,
    pub max_attempts: i64,
    pub created_at: i64,
}

/// A job a worker holds.
#[derive(Debug, Clone, PartialEq, Eq, sqlx::FromRow)]
pub struct ClaimedJob {
    pub id: String,
    pub kind: JobKind,
    pub subject: String,
    pub payload: String,
    /// Attempts including this one.
    pub attempts: i64,
    pub max_attempts: i64,
    pub progress: String,
}

/// The insert statement of `$job`, for either backend (a macro so each backend infers its own types).
macro_rules! insert_job_query {
    ($job:expr) => {
        sqlx::query(
            "INSERT INTO jobs (id, kind, subject, payload, state, attempts, max_attempts, run_after, progress, created_at, updated_at) \
             VALUES ($1, $2, $3, $4, $7, 0, $5, $6, '{}', $6, $6)",
        )
        .bind(&$job.id)
        .bind($job.kind)
        .bind(&$job.subject)
        .bind(&$job.payload)
        .bind($job.max_attempts)
        .bind($job.created_at)
        .bind($crate::store::JobState::Queued)
    };
}
pub(super) use insert_job_query;

/// `$4` is [`JobState::Running`], `$5` [`JobState::Queued`].
const CLAIM_SQLITE: &str = "UPDATE jobs SET state = $4, lease_owner = $1, lease_expires = $2, attempts = attempts + 1, updated_at = $3 \
     WHERE id = (SELECT id FROM jobs WHERE (state = $5 AND run_after <= $3) OR (state = $4 AND lease_expires < $3) \
                 ORDER BY created_at, id LIMIT 1) \
     RETURNING id, kind, subject, payload, attempts, max_attempts, progress";

const CLAIM_POSTGRES: &str = "UPDATE jobs SET state = $4, lease_owner = $1, lease_expires = $2, attempts = attempts + 1, updated_at = $3 \
     WHERE id = (SELECT id FROM jobs WHERE (state = $5 AND run_after <= $3) OR (state = $4 AND lease_expires < $3) \
                 ORDER BY created_at, id LIMIT 1 FOR UPDATE SKIP LOCKED) \
     RETURNING id, kind, subject, payload, attempts, max_attempts, progress";

impl Store {
    /// Enqueue a job.
    pub async fn enqueue(&self, job: &NewJob) -> StoreResult<()> {
        on_pool!(self, |pool| insert_job_query!(job).execute(pool).await.map(|_| ()))?;
        Ok(())
    }

    /// Claim the next ready job for `owner` with a lease until `lease_expires`.
    pub async fn claim_next_job(&self, owner: &str, now: i64, lease_expires: i64) -> StoreResult<Option<ClaimedJob>> {
        // SQLite has no row locks: its writers are serialised already.
        let sql = if matches!(self, Store::Postgres(_)) { CLAIM_POSTGRES } else { CLAIM_SQLITE };
        Ok(on_pool!(self, |pool| sqlx::query_as(sql)
            .bind(owner)
            .bind(lease_expires)
            .bind(now)
            .bind(JobState::Running)
            .bind(JobState::Queued)
            .fetch_optional(pool)
            .await)?)
    }

    /// Extend `owner`'s lease on job `id`; false when the lease was lost (expired and taken).
    pub async fn heartbeat(&self, id: &str, owner: &str, lease_expires: i64, now: i64) -> StoreResult<bool> {
        let done = on_pool!(self, |pool| sqlx::query("UPDATE jobs SET lease_expires = $3, updated_at = $4 WHERE id = $1 AND lease_owner = $2 AND state = $5")
            .bind(id)
            .bind(owner)
            .bind(lease_expires)
            .bind(now)
            .bind(JobState::Running)
            .execute(pool)
            .await
            .map(|r| r.rows_affected()))?;
        Ok(done == 1)
    }

    /// Record the progress JSON of a running job.
    pub async fn set_job_progress(&self, id: &str, owner: &str, progress: &str, now: i64) -> StoreResult<bool> {
        let done = on_pool!(self, |pool| sqlx::query("UPDATE jobs SET progress = $3, updated_at = $4 WHERE id = $1 AND lease_owner = $2 AND state = $5")
            .bind(id)
            .bind(owner)
            .bind(progress)
            .bind(now)
            .bind(JobState::Running)
            .execute(pool)
            .await
            .map(|r| r.rows_affected()))?;
        Ok(done == 1)
    }

    /// Finish a job `owner` holds: succeeded, failed for good, or back to the queue at `retry_at`.
    pub async fn finish_job(&self, id: &str, owner: &str, state: JobState, error: Option<&str>, retry_at: Option<i64>, now: i64) -> StoreResult<bool> {
        let done = on_pool!(self, |pool| sqlx::query(
            "UPDATE jobs SET state = $3, error = $4, run_after = COALESCE($5, run_after), lease_owner = NULL, lease_expires = NULL, updated_at = $6 \
             WHERE id = $1 AND lease_owner = $2 AND state = $7"
        )
        .bind(id)
        .bind(owner)
        .bind(state)
        .bind(error)
        .bind(retry_at)
        .bind(now)
        .bind(JobState::Running)
        .execute(pool)
        .await
        .map(|r| r.rows_affected()))?;
        Ok(done == 1)
    }

    /// Give a running job back to the queue without counting the attempt, ready again at
    /// `run_after` (graceful shutdown: now; a coordinator waiting for its parts: later).
    pub async fn release_job(&self, id: &str, owner: &str, run_after: i64, now: i64) -> StoreResult<bool> {
        let done = on_pool!(self, |pool| sqlx::query(
            "UPDATE jobs SET state = $5, attempts = attempts - 1, lease_owner = NULL, lease_expires = NULL, run_after = $3, updated_at = $4 \
             WHERE id = $1 AND lease_owner = $2 AND state = $6"
        )
        .bind(id)
        .bind(owner)
        .bind(run_after)
        .bind(now)
        .bind(JobState::Queued)
        .bind(JobState::Running)
        .execute(pool)
        .await
        .map(|r| r.rows_affected()))?;
        Ok(done == 1)
    }

    /// Job `id`.
    pub async fn job(&self, id: &str) -> StoreResult<JobRecord> {
        let sql = format!("SELECT {JOB_COLUMNS} FROM jobs WHERE id = $1");
        Ok(on_pool!(self, |pool| sqlx::query_as(sqlx::AssertSqlSafe(sql)).bind(id).fetch_one(pool).await)?)
    }

    /// Jobs of `kind` whose subject starts with `subject_prefix`, created at or after
    /// `since` (the parts a coordinator fanned out), in subject order.
    pub async fn jobs_of(&self, kind: JobKind, subject_prefix: &str, since: i64) -> StoreResult<Vec<JobRecord>> {
        let sql = format!(
            "SELECT {JOB_COLUMNS} FROM jobs WHERE kind = $1 AND substr(subject, 1, CAST($2 AS INTEGER)) = $3 AND created_at >= $4 ORDER BY subject, created_at"
        );
        let prefix_len = subject_prefix.chars().count() as i32;
        Ok(on_pool!(self, |pool| sqlx::query_as(sqlx::AssertSqlSafe(sql)).bind(kind).bind(prefix_len).bind(subject_prefix).bind(since).fetch_all(pool).await)?)
    }

    /// Jobs, newest first.
    pub async fn jobs(&self, limit: i64) -> StoreResult<Vec<JobRecord>> {
        let sql = format!("SELECT {JOB_COLUMNS} FROM jobs ORDER BY created_at DESC, id LIMIT $1");
        Ok(on_pool!(self, |pool| sqlx::query_as(sqlx::AssertSqlSafe(sql)).bind(limit).fetch_all(pool).await)?)
    }

    /// Count jobs per state (for /metrics).
    pub async fn job_state_counts(&self) -> StoreResult<Vec<(String, i64)>> {
        Ok(on_pool!(self, |pool| sqlx::query_as("SELECT state, COUNT(*) FROM jobs GROUP BY state ORDER BY state").fetch_all(pool).await)?)
    }

    /// Cancel a queued job (a running one finishes or fails on its own).
    pub async fn cancel_job(&self, id: &str, now: i64) -> StoreResult<()> {
        let done = on_pool!(self, |pool| sqlx::query("UPDATE jobs SET state = $3, updated_at = $2 WHERE id = $1 AND state = $4")
            .bind(id)
            .bind(now)
            .bind(JobState::Cancelled)
            .bind(JobState::Queued)
            .execute(pool)
            .await
            .map(|r| r.rows_affected()))?;
        if done == 0 { Err(StoreError::NotFound) } else { Ok(()) }
    }
}
