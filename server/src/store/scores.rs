//! Scores: one row per scoring of a submission (re-scoring adds rows). The score document
//! is kept as its JSON text and read back typed; nothing outside the store sees the text.

use osmab_evaluator::scores::Scores;

use super::{LeaderboardRow, ScoreRecord, Store, StoreResult, SubmissionState, on_pool};

/// The JSON text a score document is stored as.
pub(super) fn score_text(scores: &Scores) -> String {
    serde_json::to_string(scores).expect("a score document serialises")
}

/// A stored score document, read back; one that does not read (written by something
/// else than this service) is logged and left out, so it cannot take a page down with it.
fn parse(score_id: i64, body: &str) -> Option<Scores> {
    match serde_json::from_str(body) {
        Ok(scores) => Some(scores),
        Err(e) => {
            tracing::error!(score = score_id, error = %e, "a stored score document does not read as scores; it is left out");
            None
        }
    }
}

#[derive(sqlx::FromRow)]
struct ScoreRow {
    id: i64,
    submission_id: String,
    release: String,
    evaluator_version: String,
    body: String,
    created_at: i64,
}

/// A board's row as queried: the entry, and the id and text of its latest score.
#[derive(sqlx::FromRow)]
struct BoardRow {
    #[sqlx(flatten)]
    entry: LeaderboardRow,
    score_id: i64,
    body: String,
}

impl Store {
    /// Every score of a submission, oldest first (a document that does not read is `None`).
    pub async fn scores(&self, submission_id: &str) -> StoreResult<Vec<ScoreRecord>> {
        let rows: Vec<ScoreRow> = on_pool!(self, |pool| sqlx::query_as(
            "SELECT id, submission_id, release, evaluator_version, body, created_at FROM scores WHERE submission_id = $1 ORDER BY id"
        )
        .bind(submission_id)
        .fetch_all(pool)
        .await)?;
        Ok(rows
            .into_iter()
            .map(|r| ScoreRecord {
                scores: parse(r.id, &r.body),
                id: r.id,
                submission_id: r.submission_id,
                release: r.release,
                evaluator_version: r.evaluator_version,
                created_at: r.created_at,
            })
            .collect())
    }

    /// Public submissions of `release` that have a score, with their latest one (a
    /// submission being re-scored keeps its place with its previous score); one whose
    /// latest document does not read is left out (and logged).
    pub async fn leaderboard_rows(&self, release: &str) -> StoreResult<Vec<LeaderboardRow>> {
        let rows: Vec<BoardRow> = on_pool!(self, |pool| {
            sqlx::query_as(
            "SELECT c.id AS score_id, s.id AS submission_id, t.name AS team, s.method_name, s.method_description, s.paper_url, s.code_url, s.external_data, s.compute, s.anonymous, s.baseline, s.complete, s.flag, s.created_at, s.split, c.body \
             FROM submissions s JOIN teams t ON t.id = s.team_id \
             JOIN scores c ON c.id = (SELECT MAX(id) FROM scores WHERE submission_id = s.id) \
             WHERE s.release = $1 AND s.state <> $2 AND (s.public = TRUE OR s.baseline = TRUE) \
             ORDER BY s.created_at, s.id"
        )
        .bind(release)
        .bind(SubmissionState::Cancelled)
        .fetch_all(pool)
        .await
        })?;
        Ok(rows.into_iter().filter_map(|r| Some(LeaderboardRow { scores: parse(r.score_id, &r.body)?, ..r.entry })).collect())
    }
}
