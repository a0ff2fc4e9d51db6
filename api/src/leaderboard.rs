//! The leaderboard of a release's split as the API serves it (`GET /api/v1/leaderboard`):
//! every entry with the summary of its latest score, its rank and rank group, and how
//! robust it is to the lighting. The service ranks it (`osmab::leaderboard`); the client
//! and anyone's scripts read it.
//!
//! Wire structs declare their fields in the order of their JSON keys.

use osmab_evaluator::scores::{Aggregate, Lighting, Metric, Regime, Scores, Split};
use serde::{Deserialize, Serialize};

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
    /// [`osmab_evaluator::scores::MIN_TEST_SCENES`] scenes they do not: entries are grouped only with equal
    /// values, and pages show neither groups nor intervals.
    #[serde(default)]
    pub significance: bool,
}

impl Leaderboard {
    /// Entries with VQA scores, in rank order.
    pub fn with_vqa(&self) -> impl Iterator<Item = &Entry> {
        self.entries.iter().filter(|e| e.scores.vqa.is_some())
    }
}

/// How an entry holds up across lightings: pooled mIoU over every scene.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize, schemars::JsonSchema)]
pub struct Robustness {
    /// The largest relative drop of mIoU against the baseline lighting, `(baseline − value)
    /// / baseline` (0.25 is a quarter lost; negative when every lighting is above baseline).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub largest_drop: Option<f64>,
    /// The lighting of that drop.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub largest_drop_lighting: Option<Lighting>,
    /// The lighting with the lowest mIoU.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub worst_lighting: Option<Lighting>,
    /// mIoU under that lighting.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub worst_miou: Option<f64>,
}

impl Robustness {
    /// The robustness of `scores` over `lightings`.
    pub fn of(scores: &Scores, lightings: &[Lighting]) -> Self {
        let miou = |l: Lighting| scores.semseg(l, None, Aggregate::Overall, Metric::Miou);
        let worst = lightings.iter().filter_map(|&l| Some((l, miou(l)?))).min_by(|a, b| a.1.total_cmp(&b.1)); // the first of equals
        let drop = lightings
            .iter()
            .filter(|&&l| l != Lighting::BASELINE)
            .filter_map(|&l| Some((l, 0.0 - scores.relative_change(l, Aggregate::Overall, Metric::Miou)?)))
            .min_by(|a, b| b.1.total_cmp(&a.1)); // the first of equal drops, and no -0
        Robustness {
            largest_drop: drop.map(|d| d.1),
            largest_drop_lighting: drop.map(|d| d.0),
            worst_lighting: worst.map(|w| w.0),
            worst_miou: worst.map(|w| w.1),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn robustness_names_the_worst_lighting_and_the_largest_drop() {
        let scores: Scores = serde_json::from_value(serde_json::json!({
            "complete": true, "evaluator_version": "x", "release": "r",
            "semseg": {
                "baseline": {"overall": {"fmiou": 0.5, "macc": 0.5, "miou": 0.40}, "overall_mean": {"fmiou": 0.5, "macc": 0.5, "miou": 0.4}},
                "camera": {"overall": {"fmiou": 0.5, "macc": 0.5, "miou": 0.30}, "overall_mean": {"fmiou": 0.5, "macc": 0.5, "miou": 0.3}},
                "no_lights": {"overall": {"fmiou": 0.5, "macc": 0.5, "miou": 0.35}, "overall_mean": {"fmiou": 0.5, "macc": 0.5, "miou": 0.35}}
            },
            "relative_change": {
                "camera": {"overall": {"fmiou": 0.0, "macc": 0.0, "miou": -0.25}, "overall_mean": {"fmiou": 0.0, "macc": 0.0, "miou": -0.25}},
                "no_lights": {"overall": {"fmiou": 0.0, "macc": 0.0, "miou": -0.125}, "overall_mean": {"fmiou": 0.0, "macc": 0.0, "miou": -0.125}}
            }
        }))
        .unwrap();
        let r = Robustness::of(&scores, &[Lighting::Baseline, Lighting::Camera, Lighting::NoLights]);
        assert_eq!(
            r,
            Robustness {
                largest_drop: Some(0.25),
                largest_drop_lighting: Some(Lighting::Camera),
                worst_lighting: Some(Lighting::Camera),
                worst_miou: Some(0.30)
            }
        );
        assert_eq!(Robustness::of(&scores, &[]), Robustness::default());
    }
}
