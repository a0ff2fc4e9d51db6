//! A submission as the API shows it (`GET /api/v1/submissions/{id}`, the list of a team's
//! submissions) and the answers to an upload: the submission created, or a dry run's
//! report. The service builds them from its records (`osmab::routes::submission_view`);
//! the client reads them back.
//!
//! Fields are declared in the order of their JSON keys.

use osmab_evaluator::scores::{Lighting, Scores, Split};
use serde::{Deserialize, Serialize};

use crate::account::QuotaView;
use crate::queue::QueueView;
use crate::states::{JobKind, JobState, SubmissionState};

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
