//! A submission as the API shows it and its page renders it ([`osmab_api::submissions`]),
//! built from the store's records once: the record, its history, its jobs, its scores (the
//! latest document in full, and the list of earlier ones). The page reads these fields, not
//! the JSON, and the client (`osmab client status|results`) reads the JSON back into them.

pub use osmab_api::submissions::{
    ArchiveView, CoveredEntry, Created, DryRun, EventView, JobLink, MethodView, ScoreLink, SubmissionItem, SubmissionList, SubmissionView, UploadAnswer,
};

use crate::auth::Caller;
use crate::clock::{now_ms, rfc3339};
use crate::jobs::Job;
use crate::jobs::scoring::ScoreSubmission;
use crate::problem::ApiResult;
use crate::queue::{self, QueueView};
use crate::state::AppState;
use crate::store::{JobRecord, JobState, SubmissionRecord, SubmissionState};

/// The view of `s` from the store, as `caller` may see it (an anonymous entry's team
/// and links only for its team and the organisers).
pub async fn load(state: &AppState, s: &SubmissionRecord, caller: &Caller) -> ApiResult<SubmissionView> {
    let hidden = s.card.anonymous && !caller.can_see_team(&s.team_id);
    let team = state.store.team(&s.team_id).await?;
    let history = state.store.submission_events(&s.id).await?.into_iter().map(|e| EventView { at: rfc3339(e.at), reason: e.reason, state: e.state }).collect();
    let mut scores = state.store.scores(&s.id).await?;
    let score_history = scores
        .iter()
        .map(|c| ScoreLink { at: rfc3339(c.created_at), evaluator_version: c.evaluator_version.clone(), id: c.id, release: c.release.clone() })
        .collect();
    let job_records = state.store.jobs_for(&s.id).await?;
    let in_queue = queue_of(state, s, &job_records).await?;
    let jobs = job_records
        .into_iter()
        .map(|j| JobLink { attempts: j.attempts, url: format!("/api/v1/jobs/{}", j.id), id: j.id, kind: j.kind, state: j.state })
        .collect();
    Ok(SubmissionView {
        archive: ArchiveView { sha256: s.archive_sha256.clone(), size: s.archive_size },
        baseline: s.baseline,
        claim_code: (s.card.anonymous && caller.can_see_team(&s.team_id)).then(|| state.receipts.claim_code(&s.id)),
        complete: s.complete,
        created_at: rfc3339(s.created_at),
        history,
        id: s.id.clone(),
        jobs,
        flagged: s.flag.clone(),
        method: MethodView {
            anonymous: s.card.anonymous,
            code_url: s.card.code_url.clone().filter(|_| !hidden),
            compute: s.card.compute.clone(),
            description: s.card.description.clone(),
            external_data: s.card.external_data.clone(),
            name: s.card.name.clone(),
            paper_url: s.card.paper_url.clone().filter(|_| !hidden),
        },
        public: s.public,
        queue: in_queue,
        quota_refunded: s.quota_refunded,
        reason: s.reason.clone(),
        release: s.release.clone(),
        score_history,
        // Of a test submission, only what pools enough hidden scenes (Scores::disclosed).
        scores: scores.pop().and_then(|c| c.scores).map(|s| s.disclosed()),
        split: s.split,
        state: s.state,
        team: if hidden { crate::leaderboard::ANONYMOUS.to_string() } else { team.name },
        updated_at: rfc3339(s.updated_at),
    })
}

/// Where submission `s` stands, while it waits for or undergoes scoring.
async fn queue_of(state: &AppState, s: &SubmissionRecord, jobs: &[JobRecord]) -> ApiResult<Option<QueueView>> {
    let now = now_ms();
    let waiting = jobs.iter().find(|j| j.kind == ScoreSubmission::KIND && j.state == JobState::Queued);
    Ok(match (s.state, waiting) {
        (SubmissionState::Queued, Some(job)) => match state.store.standing(&job.id).await? {
            Some(standing) => Some(queue::queued(standing, &state.store.recent_scoring_durations(queue::HISTORY).await?, now)),
            None => None,
        },
        (SubmissionState::Scoring, _) => match state.store.scoring_since(&s.id).await? {
            Some(since) => Some(queue::scoring(since, &state.store.recent_scoring_durations(queue::HISTORY).await?, now)),
            None => None,
        },
        _ => None,
    })
}

impl From<&SubmissionRecord> for SubmissionItem {
    fn from(s: &SubmissionRecord) -> Self {
        SubmissionItem {
            complete: s.complete,
            created_at: rfc3339(s.created_at),
            id: s.id.clone(),
            method: s.card.name.clone(),
            public: s.public,
            reason: s.reason.clone(),
            release: s.release.clone(),
            split: s.split,
            state: s.state,
            url: format!("/api/v1/submissions/{}", s.id),
        }
    }
}
