//! Where a job stands in the queue, and how long scoring has taken: the facts behind a
//! submission's queue position and its estimated end (`crate::queue`).

use super::{JobState, Store, StoreResult, SubmissionState, on_pool};

/// A queued job's standing: jobs a worker takes before it, jobs running now, and the
/// workers holding them.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Standing {
    /// Queued jobs claimed before this one (claim order: creation time, then id).
    pub ahead: i64,
    /// Jobs running now.
    pub running: i64,
    /// Distinct workers holding a running job.
    pub busy_workers: i64,
}

impl Store {
    /// The standing of queued job `id` (`None` when it is not queued).
    pub async fn standing(&self, id: &str) -> StoreResult<Option<Standing>> {
        let row: Option<(i64, i64, i64)> = on_pool!(self, |pool| sqlx::query_as(
            "SELECT \
               (SELECT COUNT(*) FROM jobs o WHERE o.state = $2 AND (o.created_at < j.created_at OR (o.created_at = j.created_at AND o.id < j.id))), \
               (SELECT COUNT(*) FROM jobs r WHERE r.state = $3), \
               (SELECT COUNT(DISTINCT r.lease_owner) FROM jobs r WHERE r.state = $3) \
             FROM jobs j WHERE j.id = $1 AND j.state = $2"
        )
        .bind(id)
        .bind(JobState::Queued)
        .bind(JobState::Running)
        .fetch_optional(pool)
        .await)?;
        Ok(row.map(|(ahead, running, busy_workers)| Standing { ahead, running, busy_workers }))
    }

    /// How long the `limit` most recent scorings took (ms), newest first: from a submission
    /// entering `scoring` to its `scored` event.
    pub async fn recent_scoring_durations(&self, limit: i64) -> StoreResult<Vec<i64>> {
        let rows: Vec<(Option<i64>,)> = on_pool!(self, |pool| sqlx::query_as(
            "SELECT e.at - (SELECT MAX(s.at) FROM submission_events s WHERE s.submission_id = e.submission_id AND s.state = $2 AND s.at <= e.at) \
             FROM submission_events e WHERE e.state = $3 ORDER BY e.id DESC LIMIT $1"
        )
        .bind(limit)
        .bind(SubmissionState::Scoring)
        .bind(SubmissionState::Scored)
        .fetch_all(pool)
        .await)?;
        Ok(rows.into_iter().filter_map(|(d,)| d).filter(|d| *d >= 0).collect())
    }

    /// When submission `id` last entered `scoring`, if it did.
    pub async fn scoring_since(&self, id: &str) -> StoreResult<Option<i64>> {
        let row: (Option<i64>,) = on_pool!(self, |pool| sqlx::query_as("SELECT MAX(at) FROM submission_events WHERE submission_id = $1 AND state = $2")
            .bind(id)
            .bind(SubmissionState::Scoring)
            .fetch_one(pool)
            .await)?;
        Ok(row.0)
    }
}
