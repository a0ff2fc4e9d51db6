//! The calling team's account: who it is, and what it may still submit to each split.

use osmab_evaluator::scores::Split;
use serde::{Deserialize, Serialize};

/// The calling team.
#[derive(Debug, Serialize, Deserialize, schemars::JsonSchema)]
pub struct TeamRef {
    pub id: String,
    pub name: String,
}

/// `GET /api/v1/me`.
#[derive(Debug, Serialize, Deserialize, schemars::JsonSchema)]
pub struct Me {
    /// The quota of the split uploads go to by default (the current release's test split
    /// when it has one).
    pub quota: QuotaView,
    pub team: TeamRef,
}

/// `GET /api/v1/quota`.
#[derive(Debug, Serialize, Deserialize, schemars::JsonSchema)]
pub struct Quotas {
    /// The split an upload that names none goes to.
    pub default_split: Split,
    /// The team's quota of every split, test first.
    pub splits: Vec<QuotaView>,
    pub team: TeamRef,
}

/// The quota as the API shows it (fields in the order of their keys).
#[derive(Debug, Clone, Serialize, Deserialize, schemars::JsonSchema)]
pub struct QuotaView {
    pub limit: i64,
    /// When the next submission is possible again, while none is left.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub next_at: Option<String>,
    pub remaining: i64,
    /// When the oldest counted submission leaves the window (one more remains then);
    /// absent while none is counted.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub resets_at: Option<String>,
    pub split: Split,
    pub used: i64,
    pub window_hours: f64,
}
