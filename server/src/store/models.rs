//! Records as the store returns them.

use osmab_evaluator::scores::{Scores, Split};
use serde::Serialize;

use super::{JobKind, JobState, ReleaseFileKind, ReleaseState, SubmissionState, TokenScope};

/// A participating team.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, sqlx::FromRow)]
pub struct Team {
    pub id: String,
    pub name: String,
    /// Submissions per UTC day; `None` uses the service default.
    pub daily_quota: Option<i64>,
    pub created_at: i64,
}

/// A stored API token: only its SHA-256 and a short hint are kept.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, sqlx::FromRow)]
pub struct TokenRecord {
    pub id: String,
    pub team_id: Option<String>,
    pub scope: TokenScope,
    #[serde(skip)]
    pub sha256: String,
    /// The first characters of the token, to tell tokens apart in lists.
    pub hint: String,
    pub created_at: i64,
    pub expires_at: Option<i64>,
    pub revoked_at: Option<i64>,
}

/// A registered release.
#[derive(Debug, Clone, PartialEq, Eq, sqlx::FromRow)]
pub struct ReleaseRecord {
    pub version: String,
    pub state: ReleaseState,
    pub is_current: bool,
    pub digest: String,
    /// The manifest JSON as served (with the sequence archives added).
    pub manifest: String,
    pub created_at: i64,
    pub published_at: Option<i64>,
}

/// A public file of a release (a manifest file or a sequence archive).
#[derive(Debug, Clone, PartialEq, Eq, sqlx::FromRow)]
pub struct ReleaseFile {
    pub version: String,
    pub path: String,
    pub size: i64,
    pub sha256: String,
    pub kind: ReleaseFileKind,
}

/// A submission's method card as the store keeps it: the columns of the card a team
/// writes (`osmab_evaluator::submission::MethodCard`), read, written and edited together.
#[derive(Debug, Clone, PartialEq, Eq, sqlx::FromRow)]
pub struct StoredCard {
    #[sqlx(rename = "method_name")]
    pub name: String,
    #[sqlx(rename = "method_description")]
    pub description: String,
    pub paper_url: Option<String>,
    pub code_url: Option<String>,
    /// Data used beyond the release, in the team's words.
    pub external_data: Option<String>,
    /// Compute used, in the team's words.
    pub compute: Option<String>,
    /// Shown without its team and links until the team reveals it.
    pub anonymous: bool,
}

impl StoredCard {
    /// The columns, in the order [`StoredCard::bind`]s them.
    pub const COLUMNS: [&str; 7] = ["method_name", "method_description", "paper_url", "code_url", "external_data", "compute", "anonymous"];
}

/// The card's fields, the same in the store's card and the team's: both conversions copy them.
macro_rules! card_copy {
    ($card:expr => $to:path) => {{
        let card = $card;
        $to {
            name: card.name.clone(),
            description: card.description.clone(),
            paper_url: card.paper_url.clone(),
            code_url: card.code_url.clone(),
            external_data: card.external_data.clone(),
            compute: card.compute.clone(),
            anonymous: card.anonymous,
        }
    }};
}

/// The card a team wrote, as stored (its name trimmed).
impl From<&osmab_evaluator::submission::MethodCard> for StoredCard {
    fn from(card: &osmab_evaluator::submission::MethodCard) -> Self {
        let stored = card_copy!(card => StoredCard);
        StoredCard { name: stored.name.trim().to_string(), ..stored }
    }
}

/// The stored card as the team's, to check it as an upload's is checked.
impl From<&StoredCard> for osmab_evaluator::submission::MethodCard {
    fn from(card: &StoredCard) -> Self {
        card_copy!(card => osmab_evaluator::submission::MethodCard)
    }
}

/// A submission.
#[derive(Debug, Clone, PartialEq, Eq, sqlx::FromRow)]
pub struct SubmissionRecord {
    pub id: String,
    pub team_id: String,
    pub release: String,
    pub state: SubmissionState,
    pub reason: Option<String>,
    #[sqlx(flatten)]
    pub card: StoredCard,
    pub public: bool,
    pub baseline: bool,
    pub complete: bool,
    pub archive_size: i64,
    pub archive_sha256: String,
    pub created_at: i64,
    pub updated_at: i64,
    /// It failed through no fault of its team and does not count against the quota.
    pub quota_refunded: bool,
    /// An organiser's flag on the entry (its reason).
    pub flag: Option<String>,
    /// The split it was made to.
    #[sqlx(try_from = "String")]
    pub split: Split,
}

/// One state change of a submission.
#[derive(Debug, Clone, PartialEq, Eq, sqlx::FromRow)]
pub struct SubmissionEvent {
    pub state: SubmissionState,
    pub reason: Option<String>,
    pub at: i64,
}

/// One score of a submission (re-scoring adds rows).
#[derive(Debug, Clone, PartialEq)]
pub struct ScoreRecord {
    pub id: i64,
    pub submission_id: String,
    pub release: String,
    pub evaluator_version: String,
    /// The document; `None` when the stored text does not read as one (logged).
    pub scores: Option<Scores>,
    pub created_at: i64,
}

/// A job as listed or shown.
#[derive(Debug, Clone, PartialEq, Eq, sqlx::FromRow)]
pub struct JobRecord {
    pub id: String,
    pub kind: JobKind,
    pub subject: String,
    pub payload: String,
    pub state: JobState,
    pub attempts: i64,
    pub max_attempts: i64,
    pub run_after: i64,
    pub lease_owner: Option<String>,
    pub lease_expires: Option<i64>,
    pub progress: String,
    pub error: Option<String>,
    pub created_at: i64,
    pub updated_at: i64,
}

/// A scored submission with its latest score and team, for the leaderboard. The store reads
/// every field but the scores from the row, and the scores from the row's stored document.
#[derive(Debug, Clone, PartialEq, sqlx::FromRow)]
pub struct LeaderboardRow {
    pub submission_id: String,
    pub team: String,
    #[sqlx(flatten)]
    pub card: StoredCard,
    pub baseline: bool,
    pub complete: bool,
    pub flag: Option<String>,
    pub created_at: i64,
    #[sqlx(try_from = "String")]
    pub split: Split,
    #[sqlx(skip)]
    pub scores: Scores,
}

/// A new submission to record together with its scoring job.
#[derive(Debug, Clone)]
pub struct NewSubmission {
    pub id: String,
    pub team_id: String,
    pub release: String,
    pub card: StoredCard,
    pub public: bool,
    pub baseline: bool,
    pub complete: bool,
    pub archive_size: i64,
    pub archive_sha256: String,
    /// The client's `Idempotency-Key`, when it sent one.
    pub idempotency_key: Option<String>,
    /// The split it is made to.
    pub split: Split,
    /// When the upload began and when validation began and ended (history timestamps).
    pub received_at: i64,
    pub validating_at: i64,
    pub queued_at: i64,
}

/// What recording a submission did.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Recorded {
    /// A new submission (its id).
    New(String),
    /// Nothing new: the team's earlier submission (its id) of the same archive, still
    /// active, or made with the same idempotency key and archive.
    Repeat(String),
    /// Nothing new: the idempotency key names the team's earlier submission (its id) of
    /// another archive.
    KeyReused(String),
    /// Nothing new: the team's quota is used up.
    QuotaExceeded,
}
