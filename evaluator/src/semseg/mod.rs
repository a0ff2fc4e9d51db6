//! Semantic-segmentation scoring of one map against one ground-truth cloud, and the
//! dataset-level tables built from the resulting confusion matrices.
//!
//! Per scene: vocabulary = classes of the ground truth minus 0; each predicted point
//! gets a class ([`labels`]); every ground-truth point takes the class of its nearest
//! predicted point ([`nearest`]); the [`ConfusionMatrix`] over `[vocabulary..., -1]`
//! gives the [`SegmentationMetrics`].

pub mod background_store;
pub mod bootstrap;
pub mod confusion;
pub mod labels;
pub mod metrics;
pub mod nearest;
pub mod prepared_cache;
pub mod report;
pub mod reused_buffers;
pub mod scratch;
pub mod vocabulary;
pub mod z_order;

use std::time::{Duration, Instant};

pub use confusion::{ConfusionMatrix, NearestCount};
pub use metrics::{ClassScore, SegmentationMetrics};
pub use nearest::{NearestIndex, PointClasses};
pub use report::{LightingComparison, MetricTriple, MetricsTable};
pub use scratch::Scratch;
pub use vocabulary::Vocabulary;

use rayon::prelude::*;

use crate::error::{InputError, Result};
use crate::formats::classes::ClassList;
use crate::formats::map::{PredictedMap, TextFeatures};
use crate::ground_truth::GroundTruth;

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

impl std::ops::Add for StageTimings {
    type Output = StageTimings;
    fn add(self, other: StageTimings) -> StageTimings {
        StageTimings {
            labels: self.labels + other.labels,
            index: self.index + other.index,
            query: self.query + other.query,
            confusion: self.confusion + other.confusion,
        }
    }
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
    check_finite(ground_truth)?;
    let vocabulary = scored_vocabulary(ground_truth, classes)?;
    let cloud = Cloud { points: &ground_truth.points, labels: &ground_truth.labels, vocabulary: &vocabulary, in_z_order: false };
    score_cloud(cloud, map, classes, text, &mut Scratch::default())
}

/// A scene's ground truth prepared once for scoring several maps against it (the maps
/// of its lightings): its points checked, its scored vocabulary found, and its points
/// with their labels put in Z-order, so that every map's association visits them in
/// that order without sorting them again. A confusion matrix does not depend on the
/// order of the points, so the scores are those of [`score_scene`].
pub struct PreparedGroundTruth {
    /// Where it came from, for messages.
    source: std::path::PathBuf,
    points: Vec<[f32; 3]>,
    labels: Vec<i64>,
    vocabulary: Vocabulary,
}

impl PreparedGroundTruth {
    /// Check and reorder `ground_truth` (its colours, never scored, are dropped).
    pub fn new(ground_truth: GroundTruth, classes: &ClassList) -> Result<Self> {
        check_finite(&ground_truth)?;
        let vocabulary = scored_vocabulary(&ground_truth, classes)?;
        let order = z_order::z_order(&ground_truth.points);
        let points = order.par_iter().map(|&i| ground_truth.points[i as usize]).collect();
        let labels = order.par_iter().map(|&i| ground_truth.labels[i as usize]).collect();
        Ok(Self { source: ground_truth.source, points, labels, vocabulary })
    }

    /// Points already in Z-order (an entry of a [`prepared_cache::PreparedCache`]) from
    /// `source`, checked as [`GroundTruth::read`] and [`PreparedGroundTruth::new`] check them.
    pub(crate) fn from_z_ordered(source: &std::path::Path, points: Vec<[f32; 3]>, labels: Vec<i64>, classes: &ClassList) -> Result<Self> {
        let ground_truth = GroundTruth { source: source.to_path_buf(), points, colors: None, labels };
        crate::ground_truth::check_labels(&ground_truth.labels, classes, &source.join("semantic.npy"))?;
        check_finite(&ground_truth)?;
        let vocabulary = scored_vocabulary(&ground_truth, classes)?;
        Ok(Self { source: ground_truth.source, points: ground_truth.points, labels: ground_truth.labels, vocabulary })
    }

    /// Its points' and labels' memory, for another cloud to be read into.
    pub(crate) fn into_buffers(self) -> (Vec<[f32; 3]>, Vec<i64>) {
        (self.points, self.labels)
    }

    /// The directory of the release's ground-truth files it was prepared from.
    pub fn source(&self) -> &std::path::Path {
        &self.source
    }

    /// The points, in Z-order.
    pub fn points(&self) -> &[[f32; 3]] {
        &self.points
    }

    /// Each point's class id.
    pub fn labels(&self) -> &[i64] {
        &self.labels
    }

    /// Number of ground-truth points.
    pub fn len(&self) -> usize {
        self.points.len()
    }

    /// Whether there are no points (never, for a prepared cloud).
    pub fn is_empty(&self) -> bool {
        self.points.is_empty()
    }
}

/// Score `map` against a prepared ground truth.
pub fn score_prepared(ground_truth: &PreparedGroundTruth, map: &PredictedMap, classes: &ClassList, text: Option<&TextFeatures>) -> Result<SceneScore> {
    score_prepared_reusing(ground_truth, map, classes, text, &mut Scratch::default())
}

/// [`score_prepared`] in the memory `scratch` kept from the map scored before (the same
/// score), keeping this map's for the next.
pub fn score_prepared_reusing(
    ground_truth: &PreparedGroundTruth,
    map: &PredictedMap,
    classes: &ClassList,
    text: Option<&TextFeatures>,
    scratch: &mut Scratch,
) -> Result<SceneScore> {
    let cloud = Cloud { points: &ground_truth.points, labels: &ground_truth.labels, vocabulary: &ground_truth.vocabulary, in_z_order: true };
    score_cloud(cloud, map, classes, text, scratch)
}

fn check_finite(ground_truth: &GroundTruth) -> Result<()> {
    match ground_truth.points.iter().position(|p| !p.iter().all(|c| c.is_finite())) {
        Some(i) => Err(InputError::new(&ground_truth.source, "points", format!("point {i} has a non-finite coordinate"))),
        None => Ok(()),
    }
}

fn scored_vocabulary(ground_truth: &GroundTruth, classes: &ClassList) -> Result<Vocabulary> {
    let vocabulary = Vocabulary::from_ground_truth(&ground_truth.labels, classes);
    if vocabulary.is_empty() {
        return Err(InputError::new(&ground_truth.source, "labels", "the ground truth has no scored class (every point is class 0)"));
    }
    Ok(vocabulary)
}

/// Ground-truth points with their labels and scored vocabulary, as a scene is scored.
struct Cloud<'a> {
    points: &'a [[f32; 3]],
    labels: &'a [i64],
    vocabulary: &'a Vocabulary,
    /// Whether the points already visit neighbours one after another.
    in_z_order: bool,
}

fn score_cloud(ground_truth: Cloud<'_>, map: &PredictedMap, classes: &ClassList, text: Option<&TextFeatures>, scratch: &mut Scratch) -> Result<SceneScore> {
    if map.points.len() >= u32::MAX as usize {
        return Err(InputError::new(&map.source, "points", format!("{} points are more than the evaluator indexes (2^32 - 1)", map.points.len())));
    }
    assert_eq!(ground_truth.points.len(), ground_truth.labels.len(), "one label per ground-truth point");
    let vocabulary = ground_truth.vocabulary;
    let mut timings = StageTimings::default();
    let clock = Instant::now();
    let point_labels = labels::predicted_point_labels(map, vocabulary, classes, text)?;
    timings.labels = clock.elapsed();

    let clock = Instant::now();
    let index = match scratch.index.take() {
        Some(mut index) => {
            index.rebuild(&map.points);
            index
        }
        None => NearestIndex::build(&map.points),
    };
    timings.index = clock.elapsed();
    let confusion = if ground_truth.in_z_order {
        count_in_order(&ground_truth, &index, &point_labels, &mut scratch.answers, &mut timings)
    } else {
        count_by_block(&ground_truth, &index, &point_labels, &mut timings)
    };
    scratch.index = Some(index);
    let clock = Instant::now();
    let metrics = SegmentationMetrics::from_confusion(&confusion);
    timings.confusion += clock.elapsed();
    Ok(SceneScore { confusion, metrics, timings })
}

/// The confusion matrix of a cloud already in Z-order: the class of every point's nearest
/// map point, answered in the cloud's order into `columns`, then counted.
fn count_in_order(ground_truth: &Cloud<'_>, index: &NearestIndex, point_labels: &[i64], columns: &mut Vec<u32>, timings: &mut StageTimings) -> ConfusionMatrix {
    let clock = Instant::now();
    let mut count = NearestCount::new(ground_truth.vocabulary.ids(), point_labels);
    let classes = index.point_classes(count.point_columns());
    timings.confusion = clock.elapsed();
    let clock = Instant::now();
    index.nearest_classes_in_order_into(ground_truth.points, &classes, columns);
    timings.query = clock.elapsed();
    let clock = Instant::now();
    let parts = ground_truth.labels.par_chunks(confusion::COUNT_CHUNK).zip(columns.par_chunks(confusion::COUNT_CHUNK));
    count.add_columns(parts.map(|(labels, columns)| labels.iter().copied().zip(columns.iter().copied())));
    timings.confusion += clock.elapsed();
    count.into_matrix()
}

/// The confusion matrix of a cloud in any order: each block's answers are counted as they
/// come, so there is no answer array for the whole cloud (4 bytes a point), which pays for
/// the association's larger blocks.
fn count_by_block(ground_truth: &Cloud<'_>, index: &NearestIndex, point_labels: &[i64], timings: &mut StageTimings) -> ConfusionMatrix {
    let clock = Instant::now();
    let mut count = NearestCount::new(ground_truth.vocabulary.ids(), point_labels);
    let classes = index.point_classes(count.point_columns());
    let mut counting = clock.elapsed();
    let clock = Instant::now();
    let labels = ground_truth.labels;
    index.nearest_classes_by_block(ground_truth.points, &classes, |answers| {
        let block = Instant::now();
        count.add_columns(answers.par_parts(confusion::COUNT_CHUNK).map(|part| part.map(|(point, column)| (labels[point], column))));
        counting += block.elapsed();
    });
    timings.query = clock.elapsed().saturating_sub(counting);
    timings.confusion = counting;
    count.into_matrix()
}
