//! The score document of a submission, as typed values: what the scorer produces, the
//! store keeps, the API serves and every reader (leaderboards, pages, the client) reads.
//! It has one serialised form — the JSON the service has always served — and no reader
//! looks into it by string paths.
//!
//! Struct fields are declared in the order of their JSON keys, and the axes
//! ([`axes`]) sort as their names do, so a document serialises byte for byte as the
//! untyped one did (a test round-trips stored documents).

pub mod axes;
pub mod disclosure;
mod vqa;

use std::collections::BTreeMap;

use serde::{Deserialize, Serialize};

pub use axes::{Aggregate, Lighting, Metric, QuestionGroup, QuestionSet, Regime, ReleaseLighting, Split};
pub use disclosure::{MIN_TEST_SCENES, Withheld};
pub use vqa::{Accuracy, AnswerRow, QuestionSetScores, SceneAnswers, SetsScores, VqaCell, VqaScores};

use crate::semseg::report::MetricTriple;

/// The scores of one submission.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize, schemars::JsonSchema)]
pub struct Scores {
    /// Every (lighting, scene) of the release has a map.
    pub complete: bool,
    pub evaluator_version: String,
    /// `maps/<lighting>/<scene>` the submission lacks.
    #[serde(default)]
    pub missing_maps: Vec<String>,
    /// Per lighting, the change of each aggregate against the baseline lighting.
    #[serde(default)]
    pub relative_change: BTreeMap<Lighting, RelativeChange>,
    /// The release scored against.
    pub release: String,
    /// Semantic segmentation, per lighting.
    #[serde(default)]
    pub semseg: BTreeMap<Lighting, LightingScores>,
    /// The split whose scenes were scored (absent when scored against every scene, as
    /// before releases had splits).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub split: Option<Split>,
    /// VQA, when the submission has scene graphs or answers and the release questions.
    #[serde(default)]
    pub vqa: Option<VqaScores>,
    /// What a shown score of a test submission leaves out ([`Scores::disclosed`]).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub withheld: Option<Withheld>,
}

/// The segmentation scores of one lighting.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize, schemars::JsonSchema)]
pub struct LightingScores {
    /// Pooled mIoU of each bootstrap resample of the release's scenes (null where a
    /// resample scores no class). Every submission of a release sees the same resamples,
    /// so two lists compared round by round are a paired bootstrap (rank groups); left
    /// out of summaries.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub bootstrap_miou: Vec<Option<f64>>,
    /// Metrics of the pooled confusion matrix, with 95 % bootstrap intervals over scenes.
    pub overall: MetricTriple,
    /// Mean of the scene rows.
    pub overall_mean: MetricTriple,
    /// How many scenes the aggregates pool, where a shown score of a test submission no
    /// longer lists them ([`Scores::disclosed`]).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub pooled: Option<usize>,
    /// Per scene; left out of summaries ([`Scores::summary`]).
    #[serde(default, skip_serializing_if = "BTreeMap::is_empty")]
    pub scenes: BTreeMap<String, MetricTriple>,
    /// The same aggregates over each subset's scenes (subsets without scenes absent).
    #[serde(default)]
    pub subsets: BTreeMap<Regime, SubsetScores>,
}

/// The segmentation aggregates of one subset under one lighting.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize, schemars::JsonSchema)]
pub struct SubsetScores {
    /// With 95 % bootstrap intervals over the subset's scenes.
    pub overall: MetricTriple,
    pub overall_mean: MetricTriple,
    /// How many scenes the aggregates cover.
    pub scenes: usize,
}

/// The relative change, (value − baseline) / baseline, of both aggregates.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize, schemars::JsonSchema)]
pub struct RelativeChange {
    pub overall: MetricTriple,
    pub overall_mean: MetricTriple,
}

/// `overall` or `overall_mean`, as `aggregate` names.
fn pick<'a>(aggregate: Aggregate, overall: &'a MetricTriple, overall_mean: &'a MetricTriple) -> &'a MetricTriple {
    match aggregate {
        Aggregate::Overall => overall,
        Aggregate::OverallMean => overall_mean,
    }
}

impl LightingScores {
    /// The triple of `aggregate`.
    pub fn aggregate(&self, aggregate: Aggregate) -> &MetricTriple {
        pick(aggregate, &self.overall, &self.overall_mean)
    }
}

impl SubsetScores {
    /// The triple of `aggregate`.
    pub fn aggregate(&self, aggregate: Aggregate) -> &MetricTriple {
        pick(aggregate, &self.overall, &self.overall_mean)
    }
}

impl RelativeChange {
    /// The triple of `aggregate`.
    pub fn aggregate(&self, aggregate: Aggregate) -> &MetricTriple {
        pick(aggregate, &self.overall, &self.overall_mean)
    }
}

impl Scores {
    /// A segmentation metric under `lighting`, over every scene (`subset` `None`) or one
    /// subset; `None` where absent or undefined.
    pub fn semseg(&self, lighting: Lighting, subset: Option<Regime>, aggregate: Aggregate, metric: Metric) -> Option<f64> {
        self.semseg_triple(lighting, subset, aggregate)?.defined(metric)
    }

    /// The metrics of `lighting` over every scene (`subset` `None`) or one subset.
    fn semseg_triple(&self, lighting: Lighting, subset: Option<Regime>, aggregate: Aggregate) -> Option<&MetricTriple> {
        let at = self.semseg.get(&lighting)?;
        Some(match subset {
            None => at.aggregate(aggregate),
            Some(subset) => at.subsets.get(&subset)?.aggregate(aggregate),
        })
    }

    /// The relative change of `metric` under `lighting` against the baseline lighting, for
    /// any aggregate over every scene or one subset, by the rule the stored
    /// `relative_change` is made with ([`MetricTriple::relative_change`]); none where a
    /// value is undefined or the baseline is zero.
    pub fn change_against_baseline(&self, lighting: Lighting, subset: Option<Regime>, aggregate: Aggregate, metric: Metric) -> Option<f64> {
        let baseline = self.semseg_triple(Lighting::BASELINE, subset, aggregate)?;
        self.semseg_triple(lighting, subset, aggregate)?.relative_change(baseline).defined(metric)
    }

    /// The 95 % bootstrap interval of a pooled metric under `lighting`, over every scene or
    /// one subset, where the score has one.
    pub fn semseg_interval(&self, lighting: Lighting, subset: Option<Regime>, metric: Metric) -> Option<[f64; 2]> {
        let at = self.semseg.get(&lighting)?;
        let triple = match subset {
            None => &at.overall,
            Some(subset) => &at.subsets.get(&subset)?.overall,
        };
        triple.interval(metric)
    }

    /// The relative change of a metric under `lighting` against the baseline lighting.
    pub fn relative_change(&self, lighting: Lighting, aggregate: Aggregate, metric: Metric) -> Option<f64> {
        self.relative_change.get(&lighting)?.aggregate(aggregate).defined(metric)
    }

    /// The document without its 95 % intervals: what a board that pools too few scenes for
    /// them shows (pages, API and client alike).
    pub fn without_intervals(mut self) -> Scores {
        for lighting in self.semseg.values_mut() {
            lighting.overall.ci95 = None;
            for subset in lighting.subsets.values_mut() {
                subset.overall.ci95 = None;
            }
        }
        if let Some(vqa) = &mut self.vqa {
            for cell in std::iter::once(&mut vqa.all_lightings).chain(vqa.lightings.values_mut()) {
                cell.for_each_accuracy(&mut |a| a.ci95 = None);
            }
        }
        self
    }

    /// The document without its per-scene tables (scene counts stay): what a leaderboard
    /// carries; a submission's own page and API have the details.
    pub fn summary(mut self) -> Scores {
        for lighting in self.semseg.values_mut() {
            lighting.scenes.clear();
            lighting.bootstrap_miou.clear();
        }
        if let Some(vqa) = &mut self.vqa {
            vqa.scenes.clear();
        }
        self
    }
}

#[cfg(test)]
mod tests;
