//! The leaderboard of a release: every scored public submission (and the baselines) with
//! the summary of its latest score, ranked by pooled mIoU under the release's first
//! lighting. [`cache`] builds it at most once per second per release and serves it from
//! memory as ready JSON and CSV ([`csv`]); [`vqa`] derives the paper's VQA tables.
//!
//! Wire structs declare their fields in the order of their JSON keys.

pub mod cache;
pub mod csv;
pub mod vqa;

use osmab_evaluator::scores::{Aggregate, Lighting, Metric, Regime, Scores};
use serde::{Deserialize, Serialize};

pub use cache::{LeaderboardCache, Rendered};

use crate::store::LeaderboardRow;

/// The team shown for an entry that stays anonymous.
pub const ANONYMOUS: &str = "Anonymous";

/// One row of the leaderboard.
#[derive(Debug, Clone, Serialize, Deserialize, schemars::JsonSchema)]
pub struct Entry {
    /// The team has not revealed itself yet: `team` is "Anonymous" and there are no links.
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub anonymous: bool,
    pub baseline: bool,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub code_url: Option<String>,
    pub complete: bool,
    /// Why the organisers flagged the entry, if they did.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub flagged: Option<String>,
    pub method: String,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub paper_url: Option<String>,
    /// The summary of the latest score (no per-scene tables).
    pub scores: Scores,
    pub submission_id: String,
    pub submitted_at: String,
    pub team: String,
}

impl Entry {
    /// A segmentation metric over every scene (`subset` `None`) or one subset.
    pub fn metric(&self, lighting: Lighting, subset: Option<Regime>, aggregate: Aggregate, metric: Metric) -> Option<f64> {
        self.scores.semseg(lighting, subset, aggregate, metric)
    }
}

/// The leaderboard of one release.
#[derive(Debug, Clone, Serialize, Deserialize, schemars::JsonSchema)]
pub struct Leaderboard {
    pub entries: Vec<Entry>,
    /// The release's lightings in manifest order.
    pub lightings: Vec<Lighting>,
    pub release: String,
}

impl Leaderboard {
    /// Rank `rows` of `release`: pooled mIoU under the first lighting, best first, then
    /// the earlier submission; an entry without that metric last.
    pub fn new(release: &str, lightings: Vec<Lighting>, rows: Vec<LeaderboardRow>) -> Self {
        let mut entries: Vec<Entry> = rows
            .into_iter()
            .map(|row| Entry {
                anonymous: row.anonymous,
                baseline: row.baseline,
                code_url: row.code_url.filter(|_| !row.anonymous),
                complete: row.complete,
                flagged: row.flag,
                method: row.method_name,
                paper_url: row.paper_url.filter(|_| !row.anonymous),
                scores: row.scores.summary(),
                submission_id: row.submission_id,
                submitted_at: crate::clock::rfc3339(row.created_at),
                team: if row.anonymous { ANONYMOUS.to_string() } else { row.team },
            })
            .collect();
        let key = lightings.first().copied().unwrap_or(Lighting::BASELINE);
        let rank_metric = |e: &Entry| e.metric(key, None, Aggregate::Overall, Metric::Miou).unwrap_or(f64::NEG_INFINITY);
        entries.sort_by(|a, b| rank_metric(b).total_cmp(&rank_metric(a)).then_with(|| a.submitted_at.cmp(&b.submitted_at)));
        Self { entries, lightings, release: release.to_string() }
    }

    /// Entries with VQA scores, in rank order.
    pub fn with_vqa(&self) -> impl Iterator<Item = &Entry> {
        self.entries.iter().filter(|e| e.scores.vqa.is_some())
    }
}
