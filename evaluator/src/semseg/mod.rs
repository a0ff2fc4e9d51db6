//! Semantic-segmentation scoring of one map against one ground-truth cloud, and the
//! dataset-level tables built from the resulting confusion matrices.
//!
//! Per scene: vocabulary = classes of the ground truth minus 0; each predicted point
//! gets a class ([`labels`]); every ground-truth point takes the class of its nearest
//! predicted point ([`nearest`]); the [`ConfusionMatrix`] over `[vocabulary..., -1]`
//! gives the [`SegmentationMetrics`].

pub mod bootstrap;
pub mod confusion;
pub mod labels;
pub mod metrics;
pub mod nearest;
pub mod report;

use std::time::{Duration, Instant};

use rayon::prelude::*;

pub use confusion::ConfusionMatrix;
pub use metrics::{ClassScore, SegmentationMetrics};
pub use nearest::NearestIndex;
pub use report::{LightingComparison, MetricTriple, MetricsTable};

use crate::error::{InputError, Result};
use crate::formats::classes::ClassList;
use crate::formats::map::{PredictedMap, TextFeatures};
use crate::ground_truth::GroundTruth;

/// The classes a scene is scored on: those present in its ground truth, except 0.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Vocabulary {
    ids: Vec<i64>,
}

impl Vocabulary {
    /// Sorted unique ground-truth labels that are classes of the release, without 0
    /// ("other") and -1 ("none"): the reference's `(classes & present) - excluded`.
    pub fn from_ground_truth(labels: &[i64], classes: &ClassList) -> Self {
        let ids = crate::label_set::unique_labels(labels).into_iter().filter(|l| !metrics::EXCLUDED_LABELS.contains(l) && classes.contains(*l)).collect();
        Self { ids }
    }

    /// Class ids, ascending.
    pub fn ids(&self) -> &[i64] {
        &self.ids
    }

    /// Whether `id` is scored in this scene.
    pub fn contains(&self, id: i64) -> bool {
        self.ids.binary_search(&id).is_ok()
    }

    /// Number of classes.
    pub fn len(&self) -> usize {
        self.ids.len()
    }

    /// Whether no class is scored.
    pub fn is_empty(&self) -> bool {
        self.ids.is_empty()
    }
}

/// Wall-clock time of each scoring stage.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct StageTimings {
    /// Classifying predicted objects or points.
    pub labels: Duration,
    /// Building the nearest-neighbour index.
    pub index: Duration,
    /// Querying every ground-truth point.
    pub query: Duration,
    /// Counting the confusion matrix and computing metrics.
    pub confusion: Duration,
}

/// The outcome of scoring one scene.
#[derive(Debug, Clone, PartialEq)]
pub struct SceneScore {
    /// Counts over `[vocabulary..., -1]`.
    pub confusion: ConfusionMatrix,
    /// Metrics of `confusion`.
    pub metrics: SegmentationMetrics,
    /// Where the time went.
    pub timings: StageTimings,
}

/// Score `map` against `ground_truth`.
pub fn score_scene(ground_truth: &GroundTruth, map: &PredictedMap, classes: &ClassList, text: Option<&TextFeatures>) -> Result<SceneScore> {
    if let Some(i) = ground_truth.points.iter().position(|p| !p.iter().all(|c| c.is_finite())) {
        return Err(InputError::new(&ground_truth.source, "points", format!("point {i} has a non-finite coordinate")));
    }
    if map.points.len() >= u32::MAX as usize {
        return Err(InputError::new(&map.source, "points", format!("{} points are more than the evaluator indexes (2^32 - 1)", map.points.len())));
    }
    let vocabulary = Vocabulary::from_ground_truth(&ground_truth.labels, classes);
    if vocabulary.is_empty() {
        return Err(InputError::new(&ground_truth.source, "labels", "the ground truth has no scored class (every point is class 0)"));
    }
    let mut timings = StageTimings::default();
    let clock = Instant::now();
    let point_labels = labels::predicted_point_labels(map, &vocabulary, classes, text)?;
    timings.labels = clock.elapsed();

    let clock = Instant::now();
    let index = NearestIndex::build(&map.points);
    timings.index = clock.elapsed();
    let clock = Instant::now();
    let nearest = index.nearest_all(&ground_truth.points);
    drop(index);
    timings.query = clock.elapsed();

    let clock = Instant::now();
    let predicted: Vec<i64> = nearest.par_iter().map(|&i| point_labels[i as usize]).collect();
    drop(nearest);
    let confusion = ConfusionMatrix::from_labels(&ground_truth.labels, &predicted, vocabulary.ids());
    let metrics = SegmentationMetrics::from_confusion(&confusion);
    timings.confusion = clock.elapsed();
    Ok(SceneScore { confusion, metrics, timings })
}
