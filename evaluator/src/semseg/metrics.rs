//! IoU, mIoU, f-mIoU and mAcc from a confusion matrix, exactly as OSMa-Bench's
//! `compute_metrics.py` computes them (NumPy pairwise sums, float64 divisions).

use super::confusion::{ConfusionMatrix, UNMATCHED};
use crate::numeric::{mean, pairwise_sum};

/// Labels never scored: "no class" (-1) and "other" (0).
pub const EXCLUDED_LABELS: [i64; 2] = [UNMATCHED, 0];

/// The scores of one class.
#[derive(Debug, Clone, PartialEq)]
pub struct ClassScore {
    /// Class id.
    pub label: i64,
    /// Ground-truth points of the class (TP + FN).
    pub ground_truth: u64,
    /// Points predicted as the class (TP + FP).
    pub predicted: u64,
    /// Correctly labelled points.
    pub true_positive: u64,
    /// TP / (TP + FP + FN).
    pub iou: f64,
    /// TP / (TP + FN).
    pub recall: f64,
}

/// The three published metrics plus the per-class scores they come from.
#[derive(Debug, Clone, PartialEq)]
pub struct SegmentationMetrics {
    /// Mean IoU over scored classes.
    pub miou: f64,
    /// IoU weighted by each class's share of ground-truth points.
    pub fmiou: f64,
    /// Mean per-class recall.
    pub macc: f64,
    /// Scored classes (ground truth present, label not excluded) in label order.
    pub classes: Vec<ClassScore>,
}

/// The counts of one class that the metrics need: a row sum, a column sum and the
/// diagonal of a confusion matrix. Counts of several scenes add up to those of their
/// pooled matrix.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct ClassCount {
    pub label: i64,
    pub ground_truth: u64,
    pub predicted: u64,
    pub true_positive: u64,
}

impl ClassCount {
    /// Every label of `matrix` in its order.
    pub fn of(matrix: &ConfusionMatrix) -> Vec<ClassCount> {
        (0..matrix.labels().len())
            .map(|i| ClassCount {
                label: matrix.labels()[i],
                ground_truth: matrix.row_sum(i),
                predicted: matrix.column_sum(i),
                true_positive: matrix.count(i, i),
            })
            .collect()
    }
}

impl SegmentationMetrics {
    /// Score `matrix`, leaving out [`EXCLUDED_LABELS`] and classes without ground truth.
    /// With no scored class, mIoU and mAcc are NaN and f-mIoU is 0, as NumPy gives.
    pub fn from_confusion(matrix: &ConfusionMatrix) -> Self {
        Self::from_counts(ClassCount::of(matrix))
    }

    /// Score per-class counts given in ascending label order (the order of a matrix's
    /// labels), as [`Self::from_confusion`] scores a matrix.
    pub fn from_counts(counts: impl IntoIterator<Item = ClassCount>) -> Self {
        let classes: Vec<ClassScore> = counts
            .into_iter()
            .filter(|c| !EXCLUDED_LABELS.contains(&c.label) && c.ground_truth > 0)
            .map(|ClassCount { label, ground_truth, predicted, true_positive }| {
                let union = ground_truth + predicted - true_positive;
                ClassScore {
                    label,
                    ground_truth,
                    predicted,
                    true_positive,
                    iou: true_positive as f64 / (union as f64).max(1e-7),
                    recall: true_positive as f64 / (ground_truth as f64).max(1e-7),
                }
            })
            .collect();
        let ious: Vec<f64> = classes.iter().map(|c| c.iou).collect();
        let recalls: Vec<f64> = classes.iter().map(|c| c.recall).collect();
        let total: u64 = classes.iter().map(|c| c.ground_truth).sum();
        let weighted: Vec<f64> = classes.iter().map(|c| (c.iou * c.ground_truth as f64) / total as f64).collect();
        Self { miou: mean(&ious), fmiou: pairwise_sum(&weighted), macc: mean(&recalls), classes }
    }
}
