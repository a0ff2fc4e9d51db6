//! The leaderboard of a release's split (the hidden test split is the main board, the
//! open val split has its own): every scored public submission to it (and the baselines) with
//! the summary of its latest score, ranked by pooled mIoU under the release's first
//! lighting, with rank groups and robustness columns ([`ranking`]). [`cache`] builds it
//! at most once per second per release and serves it from memory as ready JSON and CSV
//! ([`csv`]); [`vqa`] derives the paper's VQA tables.
//!
//! Wire structs declare their fields in the order of their JSON keys.

pub mod cache;
pub mod csv;
pub mod ranking;
pub mod vqa;

use osmab_evaluator::scores::{Aggregate, Lighting, Metric, Regime, Scores, Split};
use serde::{Deserialize, Serialize};

pub use cache::{LeaderboardCache, Rendered};
pub use ranking::Robustness;
use ranking::{MIN_SCENES_FOR_GROUPS, Standing, rank_groups};

use crate::store::LeaderboardRow;

pub use crate::reserved_names::ANONYMOUS;

/// One row of the leaderboard.
#[derive(Debug, Clone, Serialize, Deserialize, schemars::JsonSchema)]
pub struct Entry {
    /// The team has not revealed itself yet: `team` is "Anonymous" and there are no links.
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub anonymous: bool,
    /// An entry the service makes itself: the reference mapper or a control.
    pub baseline: bool,
    /// The project's reference mapper, which maps from the frames alone as a team's method
    /// does. An entry with `baseline` and not `reference` is a control made from the
    /// ground truth: it shows the scale, not what lighting does to a method.
    #[serde(default)]
    pub reference: bool,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub code_url: Option<String>,
    pub complete: bool,
    /// Why the organisers flagged the entry, if they did.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub flagged: Option<String>,
    pub method: String,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub paper_url: Option<String>,
    /// Position in the ranking, from 1 (0 from a server before rank groups).
    #[serde(default)]
    pub rank: usize,
    /// 1 + the number of entries significantly above this one (paired bootstrap over
    /// scenes): entries whose difference is within noise share a group.
    #[serde(default)]
    pub rank_group: usize,
    /// The worst lighting and the largest drop against the baseline lighting.
    #[serde(default)]
    pub robustness: Robustness,
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

    /// The 95 % interval of a pooled metric over every scene or one subset.
    pub fn interval(&self, lighting: Lighting, subset: Option<Regime>, metric: Metric) -> Option<[f64; 2]> {
        self.scores.semseg_interval(lighting, subset, metric)
    }
}

/// The leaderboard of one split of one release.
#[derive(Debug, Clone, Serialize, Deserialize, schemars::JsonSchema)]
pub struct Leaderboard {
    pub entries: Vec<Entry>,
    /// The release's lightings in manifest order.
    pub lightings: Vec<Lighting>,
    pub release: String,
    /// The split ranked here (`val` from a server before splits).
    #[serde(default)]
    pub split: Split,
    /// Every split of the release, test first: each has a board (`?split=`).
    #[serde(default)]
    pub splits: Vec<Split>,
    /// How many scenes the ranking metric pools (the most of any entry).
    #[serde(default)]
    pub scenes: usize,
    /// Whether the rank groups come from the paired bootstrap over scenes. With fewer than
    /// [`MIN_SCENES_FOR_GROUPS`] scenes they do not: entries are grouped only with equal
    /// values, and pages show neither groups nor intervals.
    #[serde(default)]
    pub significance: bool,
}

impl Leaderboard {
    /// Rank the `rows` of `release` made to `split` (of the release's `splits`): pooled
    /// mIoU under the first lighting, best first, then the earlier submission; an entry
    /// without that metric last.
    pub fn new(release: &str, lightings: Vec<Lighting>, split: Split, splits: Vec<Split>, rows: Vec<LeaderboardRow>) -> Self {
        let key = lightings.first().copied().unwrap_or(Lighting::BASELINE);
        let scenes = rows
            .iter()
            .filter(|row| row.split == split)
            .filter_map(|row| row.scores.semseg.get(&key).map(|l| l.pooled.unwrap_or(l.scenes.len())))
            .max()
            .unwrap_or(0);
        let significance = scenes >= MIN_SCENES_FOR_GROUPS;
        let mut ranked: Vec<(Entry, Standing)> = rows
            .into_iter()
            .filter(|row| row.split == split)
            .map(|row| {
                // Shown and ranked by what may be shown (Scores::disclosed); the replicates,
                // never shown, still tell which entries are within noise of each other.
                let shown = row.scores.disclosed();
                let standing = Standing {
                    value: shown.semseg(key, None, Aggregate::Overall, Metric::Miou),
                    replicates: row
                        .scores
                        .semseg
                        .get(&key)
                        .filter(|_| significance && shown.semseg.contains_key(&key))
                        .map(|l| l.bootstrap_miou.clone())
                        .unwrap_or_default(),
                };
                let reference = row.baseline && crate::reserved_names::is_reference_mapper(&row.method_name);
                let entry = Entry {
                    anonymous: row.anonymous,
                    baseline: row.baseline,
                    code_url: row.code_url.filter(|_| !row.anonymous),
                    complete: row.complete,
                    flagged: row.flag,
                    method: row.method_name,
                    paper_url: row.paper_url.filter(|_| !row.anonymous),
                    rank: 0,
                    rank_group: 0,
                    reference,
                    robustness: Robustness::of(&shown, &lightings),
                    scores: if significance { shown.summary() } else { shown.summary().without_intervals() },
                    submission_id: row.submission_id,
                    submitted_at: crate::clock::rfc3339(row.created_at),
                    team: if row.anonymous { ANONYMOUS.to_string() } else { row.team },
                };
                (entry, standing)
            })
            .collect();
        let rank_metric = |s: &Standing| s.value.unwrap_or(f64::NEG_INFINITY);
        ranked.sort_by(|(a, sa), (b, sb)| rank_metric(sb).total_cmp(&rank_metric(sa)).then_with(|| a.submitted_at.cmp(&b.submitted_at)));
        let (mut entries, standings): (Vec<Entry>, Vec<Standing>) = ranked.into_iter().unzip();
        for ((rank, entry), group) in entries.iter_mut().enumerate().zip(rank_groups(&standings)) {
            entry.rank = rank + 1;
            entry.rank_group = group;
        }
        Self { entries, lightings, release: release.to_string(), split, splits, scenes, significance }
    }

    /// Entries with VQA scores, in rank order.
    pub fn with_vqa(&self) -> impl Iterator<Item = &Entry> {
        self.entries.iter().filter(|e| e.scores.vqa.is_some())
    }
}
