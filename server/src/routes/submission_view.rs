//! A submission as the API shows it and its page renders it: the record, its history,
//! its jobs, its scores (the latest document in full, and the list of earlier ones).
//! Built from the store's records once; the page reads these fields, not the JSON, and the
//! client (`osmab client status|results`) reads the JSON back into them.
//!
//! The answers to an upload (the submission created, or a dry run's report) are here too.
//!
//! Fields are declared in the order of their JSON keys.

use osmab_evaluator::scores::{Lighting, Scores, Split};
use serde::{Deserialize, Serialize};

use crate::auth::Caller;
use crate::clock::{now_ms, rfc3339};
use crate::intake::QuotaView;
use crate::jobs::Job;
use crate::jobs::scoring::ScoreSubmission;
use crate::problem::ApiResult;
use crate::queue::{self, QueueView};
use crate::state::AppState;
use crate::store::{JobKind, JobRecord, JobState, SubmissionRecord, SubmissionState};

/// The uploaded archive.
#[derive(Debug, Clone, Serialize, Deserialize, schemars::JsonSchema)]
pub struct ArchiveView {
    pub sha256: String,
    pub size: i64,
}

/// One state change.
#[derive(Debug, Clone, Serialize, Deserialize, schemars::JsonSchema)]
pub struct EventView {
    pub at: String,
    pub reason: Option<String>,
    pub state: SubmissionState,
}

/// A job of the submission.
#[derive(Debug, Clone, Serialize, Deserialize, schemars::JsonSchema)]
pub struct JobLink {
    pub attempts: i64,
    pub id: String,
    pub kind: JobKind,
    pub state: JobState,
    pub url: String,
}

/// The method card.
#[derive(Debug, Clone, Serialize, Deserialize, schemars::JsonSchema)]
pub struct MethodView {
    /// Shown as "Anonymous" (no team, no links) to everyone but its team and the organisers.
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub anonymous: bool,
    pub code_url: Option<String>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub compute: Option<String>,
    pub description: String,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub external_data: Option<String>,
    pub name: String,
    pub paper_url: Option<String>,
}

/// One recorded score (the latest is in full under `scores`).
#[derive(Debug, Clone, Serialize, Deserialize, schemars::JsonSchema)]
pub struct ScoreLink {
    pub at: String,
    pub evaluator_version: String,
    pub id: i64,
    pub release: String,
}

/// `GET /api/v1/submissions/{id}`.
#[derive(Debug, Clone, Serialize, Deserialize, schemars::JsonSchema)]
pub struct SubmissionView {
    pub archive: ArchiveView,
    pub baseline: bool,
    /// Of an anonymous entry, shown to its team and the organisers only: the code that proves
    /// the entry the team's against its receipt's `team_commitment`
    /// (`osmab client verify RECEIPT --keys … --team NAME --claim-code CODE`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub claim_code: Option<String>,
    pub complete: bool,
    pub created_at: String,
    /// Why the organisers flagged the entry, if they did.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub flagged: Option<String>,
    pub history: Vec<EventView>,
    pub id: String,
    pub jobs: Vec<JobLink>,
    pub method: MethodView,
    pub public: bool,
    /// Where it stands while queued or being scored, with an estimated end.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub queue: Option<QueueView>,
    /// It failed through no fault of the team and does not count against its quota.
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub quota_refunded: bool,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub reason: Option<String>,
    pub release: String,
    pub score_history: Vec<ScoreLink>,
    /// The latest score, when scored.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub scores: Option<Scores>,
    /// The split it was made to (its board).
    pub split: Split,
    pub state: SubmissionState,
    /// The team's name.
    pub team: String,
    pub updated_at: String,
}

impl SubmissionView {
    /// The view of `s` from the store, as `caller` may see it (an anonymous entry's team
    /// and links only for its team and the organisers).
    pub async fn load(state: &AppState, s: &SubmissionRecord, caller: &Caller) -> ApiResult<Self> {
        let hidden = s.anonymous && !caller.can_see_team(&s.team_id);
        let team = state.store.team(&s.team_id).await?;
        let history =
            state.store.submission_events(&s.id).await?.into_iter().map(|e| EventView { at: rfc3339(e.at), reason: e.reason, state: e.state }).collect();
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
            claim_code: (s.anonymous && caller.can_see_team(&s.team_id)).then(|| state.receipts.claim_code(&s.id)),
            complete: s.complete,
            created_at: rfc3339(s.created_at),
            history,
            id: s.id.clone(),
            jobs,
            flagged: s.flag.clone(),
            method: MethodView {
                anonymous: s.anonymous,
                code_url: s.code_url.clone().filter(|_| !hidden),
                compute: s.compute.clone(),
                description: s.method_description.clone(),
                external_data: s.external_data.clone(),
                name: s.method_name.clone(),
                paper_url: s.paper_url.clone().filter(|_| !hidden),
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

/// One of a team's submissions in `GET /api/v1/submissions`.
#[derive(Debug, Clone, Serialize, Deserialize, schemars::JsonSchema)]
pub struct SubmissionItem {
    pub complete: bool,
    pub created_at: String,
    pub id: String,
    /// The method's name.
    pub method: String,
    pub public: bool,
    pub reason: Option<String>,
    pub release: String,
    pub split: Split,
    pub state: SubmissionState,
    pub url: String,
}

impl From<&SubmissionRecord> for SubmissionItem {
    fn from(s: &SubmissionRecord) -> Self {
        SubmissionItem {
            complete: s.complete,
            created_at: rfc3339(s.created_at),
            id: s.id.clone(),
            method: s.method_name.clone(),
            public: s.public,
            reason: s.reason.clone(),
            release: s.release.clone(),
            split: s.split,
            state: s.state,
            url: format!("/api/v1/submissions/{}", s.id),
        }
    }
}

/// `GET /api/v1/submissions`.
#[derive(Debug, Clone, Serialize, Deserialize, schemars::JsonSchema)]
pub struct SubmissionList {
    pub submissions: Vec<SubmissionItem>,
}

/// The answer to an accepted upload (202) or to one that repeats an earlier submission
/// (200, `repeat: true`, no quota used).
#[derive(Debug, Serialize, Deserialize, schemars::JsonSchema)]
pub struct Created {
    pub complete: bool,
    pub id: String,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub missing_maps: Option<Vec<String>>,
    pub quota: QuotaView,
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub repeat: bool,
    pub split: Split,
    pub state: SubmissionState,
    pub url: String,
}

/// One (lighting, scene) a valid upload covers.
#[derive(Debug, Serialize, Deserialize, schemars::JsonSchema)]
pub struct CoveredEntry {
    pub answers: bool,
    pub graph: bool,
    pub lighting: Lighting,
    pub map: bool,
    pub scene: String,
}

/// The answer to a dry run of a valid upload.
#[derive(Debug, Serialize, Deserialize, schemars::JsonSchema)]
pub struct DryRun {
    pub complete: bool,
    pub entries: Vec<CoveredEntry>,
    pub method: osmab_evaluator::submission::MethodCard,
    pub missing_maps: Vec<String>,
    /// Files for scenes of the release's other split, which this split ignores.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub outside_split: Vec<String>,
    pub points: u64,
    pub release: String,
    pub sha256: String,
    pub size: u64,
    pub split: Split,
    pub valid: bool,
}

/// The answer to an upload: a submission (new, or the earlier one repeated) or, for a
/// dry run, the validation report.
#[derive(schemars::JsonSchema)]
#[serde(untagged)]
#[allow(dead_code)] // described in the OpenAPI document, never built
pub enum UploadAnswer {
    Submission(Created),
    DryRun(DryRun),
}
