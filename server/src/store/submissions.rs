//! Submissions and their history: recording an upload with its scoring job, state
//! changes (each with one history event), scoring results and failures, quota counts.

use super::{
    JobRecord, JobState, NewJob, NewSubmission, Recorded, Store, StoreError, StoreResult, StoredCard, SubmissionEvent, SubmissionRecord, SubmissionState,
    on_pool,
};
use osmab_evaluator::scores::{Scores, Split};

/// A team's earlier submission to the split `$5` with the idempotency key `$2` (first) or,
/// active, of the archive `$3`: its id, archive and key. Keys are scoped by split: the
/// same key to the other split is a new submission, as the same archive is.
/// `$4` is a submission to leave out (the one just inserted, in the recording transaction);
/// `$6` and `$7` are the states that are not active ([`SubmissionState::Failed`],
/// [`SubmissionState::Cancelled`]).
const REPEAT_QUERY: &str = "SELECT id, archive_sha256, idempotency_key FROM submissions \
     WHERE team_id = $1 AND id <> $4 AND split = $5 AND (idempotency_key = $2 OR (archive_sha256 = $3 AND state NOT IN ($6, $7))) \
     ORDER BY CASE WHEN idempotency_key = $2 THEN 0 ELSE 1 END, created_at LIMIT 1";

/// What an earlier submission `(id, archive, key)` found by [`REPEAT_QUERY`] makes of an
/// upload of `archive`.
fn repeat_of((id, earlier_archive, _key): (String, String, Option<String>), archive: &str) -> Recorded {
    if earlier_archive == archive { Recorded::Repeat(id) } else { Recorded::KeyReused(id) }
}

const SUBMISSION_COLUMNS: &str = "id, team_id, release, state, reason, public, baseline, complete, archive_size, archive_sha256, created_at, updated_at";

/// Columns later migrations added, read with the others.
const SUBMISSION_LATER_COLUMNS: &str = "quota_refunded, flag, split";

/// Every column a submission record reads: its own, and its method card's.
fn record_columns() -> String {
    format!("{SUBMISSION_COLUMNS}, {SUBMISSION_LATER_COLUMNS}, {}", StoredCard::COLUMNS.join(", "))
}

/// `$query` with the columns of the method card `$card` bound next, in [`StoredCard::COLUMNS`]' order.
macro_rules! bind_card {
    ($query:expr, $card:expr) => {
        $query
            .bind(&$card.name)
            .bind(&$card.description)
            .bind(&$card.paper_url)
            .bind(&$card.code_url)
            .bind(&$card.external_data)
            .bind(&$card.compute)
            .bind($card.anonymous)
    };
}

/// The history event of `$submission` entering `$state` (a [`SubmissionState`]) with
/// `$reason` at `$at`, for either backend (a macro so each infers its own types).
macro_rules! insert_event_query {
    ($submission:expr, $state:expr, $reason:expr, $at:expr) => {
        sqlx::query("INSERT INTO submission_events (submission_id, state, reason, at) VALUES ($1, $2, $3, $4)")
            .bind($submission)
            .bind($state)
            .bind($reason)
            .bind($at)
    };
}

/// Move submission `$id` from state `$from` to `$to` with `$reason` at `$at` inside the
/// transaction `$tx`, with its history event; evaluates to whether it moved (another
/// writer may have moved it first).
macro_rules! transition {
    ($tx:ident, $id:expr, $from:expr, $to:expr, $reason:expr, $at:expr) => {{
        let moved = sqlx::query("UPDATE submissions SET state = $2, reason = $3, updated_at = $4 WHERE id = $1 AND state = $5")
            .bind($id)
            .bind($to)
            .bind($reason)
            .bind($at)
            .bind($from)
            .execute(&mut *$tx)
            .await?
            .rows_affected()
            == 1;
        if moved {
            insert_event_query!($id, $to, $reason, $at).execute(&mut *$tx).await?;
        }
        moved
    }};
}

impl Store {
    /// The team's earlier submission a new upload repeats: the one made with the same
    /// idempotency key (any state), else an active one (not failed or cancelled) of the
    /// same archive. `Repeat` or `KeyReused` (the key with another archive), if any.
    pub async fn repeated_submission(&self, team_id: &str, archive_sha256: &str, split: Split, idempotency_key: Option<&str>) -> StoreResult<Option<Recorded>> {
        let row: Option<(String, String, Option<String>)> = on_pool!(self, |pool| sqlx::query_as(REPEAT_QUERY)
            .bind(team_id)
            .bind(idempotency_key)
            .bind(archive_sha256)
            .bind("")
            .bind(split.name())
            .bind(SubmissionState::Failed)
            .bind(SubmissionState::Cancelled)
            .fetch_optional(pool)
            .await)?;
        Ok(row.map(|row| repeat_of(row, archive_sha256)))
    }

    /// Record a validated submission, its history so far and its scoring job in one
    /// transaction — unless it repeats an earlier one ([`Store::repeated_submission`],
    /// checked inside the transaction, so two parallel uploads of one archive make one
    /// submission). With `quota = Some((limit, since))` the submission is only recorded
    /// while the team has fewer than `limit` submissions since `since` (counted inside the
    /// transaction, so parallel uploads cannot overrun it).
    pub async fn create_submission(&self, s: &NewSubmission, job: &NewJob, quota: Option<(i64, i64)>) -> StoreResult<Recorded> {
        let sql = format!(
            "INSERT INTO submissions ({SUBMISSION_COLUMNS}, idempotency_key, split, {}) \
             VALUES ($1, $2, $3, $4, NULL, $5, $6, $7, $8, $9, $10, $11, $12, $13, $14, $15, $16, $17, $18, $19, $20)",
            StoredCard::COLUMNS.join(", ")
        );
        let postgres = matches!(self, Store::Postgres(_));
        on_pool!(self, |pool| {
            let mut tx = pool.begin().await?;
            if postgres {
                // Serialise a team's concurrent uploads (SQLite serialises every writer already).
                sqlx::query("SELECT id FROM teams WHERE id = $1 FOR UPDATE").bind(&s.team_id).execute(&mut *tx).await?;
            }
            // The insert comes first: on SQLite a transaction that reads before it writes
            // cannot wait for another writer (it fails "database is locked" at once).
            let insert = sqlx::query(sqlx::AssertSqlSafe(sql.clone()))
                .bind(&s.id)
                .bind(&s.team_id)
                .bind(&s.release)
                .bind(SubmissionState::Queued)
                .bind(s.public)
                .bind(s.baseline)
                .bind(s.complete)
                .bind(s.archive_size)
                .bind(&s.archive_sha256)
                // created_at is when it is recorded (what quotas count): a resumable upload may
                // have begun long before (its start is the `received` event's time).
                .bind(s.queued_at)
                .bind(s.queued_at)
                .bind(&s.idempotency_key)
                .bind(s.split.name());
            bind_card!(insert, s.card).execute(&mut *tx).await?;
            let earlier: Option<(String, String, Option<String>)> = sqlx::query_as(REPEAT_QUERY)
                .bind(&s.team_id)
                .bind(&s.idempotency_key)
                .bind(&s.archive_sha256)
                .bind(&s.id)
                .bind(s.split.name())
                .bind(SubmissionState::Failed)
                .bind(SubmissionState::Cancelled)
                .fetch_optional(&mut *tx)
                .await?;
            if let Some(row) = earlier {
                tx.rollback().await?;
                return Ok(repeat_of(row, &s.archive_sha256));
            }
            if let Some((limit, since)) = quota {
                let used: i64 = sqlx::query_scalar(
                    "SELECT COUNT(*) FROM submissions WHERE team_id = $1 AND created_at >= $2 AND split = $3 AND baseline = FALSE AND quota_refunded = FALSE",
                )
                .bind(&s.team_id)
                .bind(since)
                .bind(s.split.name())
                .fetch_one(&mut *tx)
                .await?;
                if used > limit {
                    tx.rollback().await?;
                    return Ok(Recorded::QuotaExceeded);
                }
            }
            for (state, at) in
                [(SubmissionState::Received, s.received_at), (SubmissionState::Validating, s.validating_at), (SubmissionState::Queued, s.queued_at)]
            {
                insert_event_query!(&s.id, state, None::<&str>, at).execute(&mut *tx).await?;
            }
            super::jobs::insert_job_query!(job).execute(&mut *tx).await?;
            tx.commit().await?;
            Ok(Recorded::New(s.id.clone()))
        })
    }

    /// Finish a scoring job: mark the job succeeded (only while `owner` holds its lease),
    /// add the score and move the submission from `scoring` to `scored`, all or nothing.
    /// Returns false (and changes nothing) when the lease was lost or the submission left
    /// `scoring` (cancelled meanwhile).
    pub async fn complete_scoring(&self, job_id: &str, owner: &str, submission_id: &str, scores: &Scores, at: i64) -> StoreResult<bool> {
        let body = super::scores::score_text(scores);
        on_pool!(self, |pool| {
            let mut tx = pool.begin().await?;
            let job = sqlx::query(
                "UPDATE jobs SET state = $4, error = NULL, lease_owner = NULL, lease_expires = NULL, updated_at = $3 \
                 WHERE id = $1 AND lease_owner = $2 AND state = $5",
            )
            .bind(job_id)
            .bind(owner)
            .bind(at)
            .bind(JobState::Succeeded)
            .bind(JobState::Running)
            .execute(&mut *tx)
            .await?
            .rows_affected();
            let moved = sqlx::query("UPDATE submissions SET state = $3, reason = NULL, updated_at = $2 WHERE id = $1 AND state = $4")
                .bind(submission_id)
                .bind(at)
                .bind(SubmissionState::Scored)
                .bind(SubmissionState::Scoring)
                .execute(&mut *tx)
                .await?
                .rows_affected();
            if job != 1 || moved != 1 {
                tx.rollback().await?;
                return Ok(false);
            }
            sqlx::query("INSERT INTO scores (submission_id, release, evaluator_version, body, created_at) VALUES ($1, $2, $3, $4, $5)")
                .bind(submission_id)
                .bind(&scores.release)
                .bind(&scores.evaluator_version)
                .bind(&body)
                .bind(at)
                .execute(&mut *tx)
                .await?;
            insert_event_query!(submission_id, SubmissionState::Scored, None::<&str>, at).execute(&mut *tx).await?;
            tx.commit().await?;
            Ok(true)
        })
    }

    /// Fail a job for good (only while `owner` holds its lease) and, for a scoring job, its
    /// submission with the same message, all or nothing; with `refund` (no fault of the
    /// team's) the submission gives its quota unit back. Returns whether it happened.
    pub async fn fail_job(&self, job_id: &str, owner: &str, message: &str, submission_id: Option<&str>, refund: bool, at: i64) -> StoreResult<bool> {
        on_pool!(self, |pool| {
            let mut tx = pool.begin().await?;
            let job = sqlx::query(
                "UPDATE jobs SET state = $5, error = $3, lease_owner = NULL, lease_expires = NULL, updated_at = $4 \
                 WHERE id = $1 AND lease_owner = $2 AND state = $6",
            )
            .bind(job_id)
            .bind(owner)
            .bind(message)
            .bind(at)
            .bind(JobState::Failed)
            .bind(JobState::Running)
            .execute(&mut *tx)
            .await?
            .rows_affected();
            if job != 1 {
                tx.rollback().await?;
                return Ok(false);
            }
            if let Some(id) = submission_id {
                let moved =
                    sqlx::query("UPDATE submissions SET state = $5, reason = $2, updated_at = $3, quota_refunded = $4 WHERE id = $1 AND state IN ($6, $7)")
                        .bind(id)
                        .bind(message)
                        .bind(at)
                        .bind(refund)
                        .bind(SubmissionState::Failed)
                        .bind(SubmissionState::Queued)
                        .bind(SubmissionState::Scoring)
                        .execute(&mut *tx)
                        .await?
                        .rows_affected();
                if moved == 1 {
                    insert_event_query!(id, SubmissionState::Failed, Some(message), at).execute(&mut *tx).await?;
                }
            }
            tx.commit().await?;
            Ok(true)
        })
    }

    /// Queue a submission for scoring again with `job`, from one of `from`; fails with a
    /// conflict while another scoring job of it is live. Returns whether it was queued.
    pub async fn requeue_submission(&self, id: &str, from: &[SubmissionState], reason: &str, job: &NewJob, at: i64) -> StoreResult<bool> {
        let current = self.submission(id).await?;
        if !from.contains(&current.state) {
            return Ok(false);
        }
        on_pool!(self, |pool| {
            let mut tx = pool.begin().await?;
            if !transition!(tx, id, current.state, SubmissionState::Queued, Some(reason), at) {
                tx.rollback().await?;
                return Ok(false);
            }
            super::jobs::insert_job_query!(job).execute(&mut *tx).await?;
            tx.commit().await?;
            Ok(true)
        })
    }

    /// Submission `id`.
    pub async fn submission(&self, id: &str) -> StoreResult<SubmissionRecord> {
        let sql = format!("SELECT {} FROM submissions WHERE id = $1", record_columns());
        Ok(on_pool!(self, |pool| sqlx::query_as(sqlx::AssertSqlSafe(sql)).bind(id).fetch_one(pool).await)?)
    }

    /// Submissions of a team (all teams for `None`), newest first.
    pub async fn submissions(&self, team_id: Option<&str>, limit: i64) -> StoreResult<Vec<SubmissionRecord>> {
        Ok(match team_id {
            Some(team) => {
                let sql = format!("SELECT {} FROM submissions WHERE team_id = $1 ORDER BY created_at DESC, id LIMIT $2", record_columns());
                on_pool!(self, |pool| sqlx::query_as(sqlx::AssertSqlSafe(sql)).bind(team).bind(limit).fetch_all(pool).await)?
            }
            None => {
                let sql = format!("SELECT {} FROM submissions ORDER BY created_at DESC, id LIMIT $1", record_columns());
                on_pool!(self, |pool| sqlx::query_as(sqlx::AssertSqlSafe(sql)).bind(limit).fetch_all(pool).await)?
            }
        })
    }

    /// The state history of a submission, oldest first.
    pub async fn submission_events(&self, id: &str) -> StoreResult<Vec<SubmissionEvent>> {
        Ok(on_pool!(self, |pool| sqlx::query_as("SELECT state, reason, at FROM submission_events WHERE submission_id = $1 ORDER BY id")
            .bind(id)
            .fetch_all(pool)
            .await)?)
    }

    /// Move a submission to `state` with `reason`, recording the change in its history.
    /// `from` restricts the change to submissions in one of those states; returns whether it happened.
    pub async fn set_submission_state(&self, id: &str, from: &[SubmissionState], state: SubmissionState, reason: Option<&str>, at: i64) -> StoreResult<bool> {
        let current = self.submission(id).await?;
        if !from.is_empty() && !from.contains(&current.state) {
            return Ok(false);
        }
        on_pool!(self, |pool| {
            let mut tx = pool.begin().await?;
            let moved = transition!(tx, id, current.state, state, reason, at);
            tx.commit().await?;
            Ok(moved)
        })
    }

    /// Edit the method card and visibility of a submission.
    pub async fn update_method_card(&self, id: &str, s: &SubmissionRecord, at: i64) -> StoreResult<()> {
        let card: Vec<String> = StoredCard::COLUMNS.iter().enumerate().map(|(k, column)| format!("{column} = ${}", k + 4)).collect();
        let sql = format!("UPDATE submissions SET public = $2, updated_at = $3, {} WHERE id = $1", card.join(", "));
        let done = on_pool!(self, |pool| bind_card!(sqlx::query(sqlx::AssertSqlSafe(sql.clone())).bind(id).bind(s.public).bind(at), s.card)
            .execute(pool)
            .await
            .map(|r| r.rows_affected()))?;
        if done == 0 { Err(StoreError::NotFound) } else { Ok(()) }
    }

    /// Flag submission `id` on the leaderboard with `reason`, or clear its flag (`None`).
    pub async fn set_flag(&self, id: &str, reason: Option<&str>, at: i64) -> StoreResult<()> {
        let done = on_pool!(self, |pool| sqlx::query("UPDATE submissions SET flag = $2, updated_at = $3 WHERE id = $1")
            .bind(id)
            .bind(reason)
            .bind(at)
            .execute(pool)
            .await
            .map(|r| r.rows_affected()))?;
        if done == 0 { Err(StoreError::NotFound) } else { Ok(()) }
    }

    /// Give back the quota a submission used (an organiser's decision); false when it had
    /// been given back already.
    pub async fn refund_quota(&self, id: &str, at: i64) -> StoreResult<bool> {
        let done =
            on_pool!(self, |pool| sqlx::query("UPDATE submissions SET quota_refunded = TRUE, updated_at = $2 WHERE id = $1 AND quota_refunded = FALSE")
                .bind(id)
                .bind(at)
                .execute(pool)
                .await
                .map(|r| r.rows_affected()))?;
        if done == 1 {
            return Ok(true);
        }
        self.submission(id).await.map(|_| false)
    }

    /// When the submissions a team made to `split` since `since` were made, oldest first
    /// (what its quota counts): baselines, dry runs and refunded ones never count.
    pub async fn submissions_since(&self, team_id: &str, split: Split, since: i64) -> StoreResult<Vec<i64>> {
        Ok(on_pool!(self, |pool| sqlx::query_scalar(
            "SELECT created_at FROM submissions WHERE team_id = $1 AND created_at >= $2 AND split = $3 AND baseline = FALSE AND quota_refunded = FALSE \
             ORDER BY created_at"
        )
        .bind(team_id)
        .bind(since)
        .bind(split.name())
        .fetch_all(pool)
        .await)?)
    }

    /// Jobs whose subject is `subject` (a submission or release), newest first.
    pub async fn jobs_for(&self, subject: &str) -> StoreResult<Vec<JobRecord>> {
        Ok(on_pool!(self, |pool| sqlx::query_as(sqlx::AssertSqlSafe(format!(
            "SELECT {} FROM jobs WHERE subject = $1 ORDER BY created_at DESC, id",
            super::jobs::JOB_COLUMNS
        )))
        .bind(subject)
        .fetch_all(pool)
        .await)?)
    }

    /// Count submissions per state (for /metrics).
    pub async fn submission_state_counts(&self) -> StoreResult<Vec<(String, i64)>> {
        Ok(on_pool!(self, |pool| sqlx::query_as("SELECT state, COUNT(*) FROM submissions GROUP BY state ORDER BY state").fetch_all(pool).await)?)
    }
}
