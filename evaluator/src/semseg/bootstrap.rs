//! Bootstrap over scenes of the pooled metrics: each resample of a release's scenes
//! (under one lighting, all scenes or one subset) pools the per-class counts of the scenes
//! drawn and scores them as the pooled matrix is scored. The replicates give the 95 %
//! intervals of mAcc, f-mIoU and mIoU, and the replicates of mIoU are kept for paired
//! comparisons between submissions ([`crate::bootstrap`]).

use std::collections::{BTreeMap, BTreeSet};

use super::metrics::{ClassCount, SegmentationMetrics};
use super::report::{MetricIntervals, MetricTriple};
use crate::bootstrap::{Resamples, interval95};

/// The replicates of one set of scenes.
#[derive(Debug, Clone, PartialEq)]
pub struct Replicates(Vec<MetricTriple>);

impl Replicates {
    /// Resample `scenes` — the per-class counts of each scene in the release's order, a
    /// scene without a map with none — and score every resample.
    pub fn of(scenes: &[Vec<ClassCount>]) -> Self {
        let labels: Vec<i64> = scenes.iter().flatten().map(|c| c.label).collect::<BTreeSet<_>>().into_iter().collect();
        let slot: BTreeMap<i64, usize> = labels.iter().enumerate().map(|(i, &l)| (l, i)).collect();
        let dense: Vec<Vec<[u64; 3]>> = scenes
            .iter()
            .map(|counts| {
                let mut row = vec![[0u64; 3]; labels.len()];
                for c in counts {
                    let cell = &mut row[slot[&c.label]];
                    cell[0] += c.ground_truth;
                    cell[1] += c.predicted;
                    cell[2] += c.true_positive;
                }
                row
            })
            .collect();
        let mut sums = vec![[0u64; 3]; labels.len()];
        let replicates = Resamples::of(scenes.len())
            .map(|drawn| {
                sums.iter_mut().for_each(|s| *s = [0; 3]);
                for &scene in &drawn {
                    for (sum, cell) in sums.iter_mut().zip(&dense[scene]) {
                        sum[0] += cell[0];
                        sum[1] += cell[1];
                        sum[2] += cell[2];
                    }
                }
                let counts = labels.iter().zip(&sums).map(|(&label, s)| ClassCount { label, ground_truth: s[0], predicted: s[1], true_positive: s[2] });
                MetricTriple::from(&SegmentationMetrics::from_counts(counts))
            })
            .collect();
        Self(replicates)
    }

    /// The 95 % interval of each metric; `None` when no metric has one.
    pub fn intervals(&self) -> Option<MetricIntervals> {
        let of = |f: fn(&MetricTriple) -> f64| interval95(self.0.iter().map(f));
        let intervals = MetricIntervals { fmiou: of(|t| t.fmiou), macc: of(|t| t.macc), miou: of(|t| t.miou) };
        (intervals != MetricIntervals::default()).then_some(intervals)
    }

    /// mIoU of every resample, `None` where a resample scores no class.
    pub fn miou(&self) -> Vec<Option<f64>> {
        self.0.iter().map(|t| t.defined(crate::scores::Metric::Miou)).collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::semseg::ConfusionMatrix;

    fn scene(labels: Vec<i64>, counts: Vec<u64>) -> ConfusionMatrix {
        ConfusionMatrix::new(labels, counts).unwrap()
    }

    #[test]
    fn every_resample_scores_like_a_pooled_matrix_and_the_interval_holds_the_pooled_value() {
        // Three scenes with different vocabularies, each with unmatched points (-1).
        let scenes = [
            scene(vec![1, 2, -1], vec![8, 1, 1, 2, 5, 3, 0, 1, 0]),
            scene(vec![2, 3, -1], vec![4, 4, 2, 1, 9, 0, 1, 0, 0]),
            scene(vec![1, 3, -1], vec![2, 6, 2, 0, 7, 1, 0, 0, 0]),
        ];
        let counts: Vec<Vec<ClassCount>> = scenes.iter().map(ClassCount::of).collect();
        let replicates = Replicates::of(&counts);
        assert_eq!(replicates.0.len(), crate::bootstrap::ROUNDS);
        // Replaying the resamples with real pooled matrices gives the same numbers, bit for bit.
        for (drawn, replicate) in Resamples::of(3).zip(&replicates.0).take(50) {
            let pooled = ConfusionMatrix::pooled(drawn.iter().map(|&i| &scenes[i]));
            let expected = MetricTriple::from(&SegmentationMetrics::from_confusion(&pooled));
            assert_eq!(
                (replicate.miou.to_bits(), replicate.fmiou.to_bits(), replicate.macc.to_bits()),
                (expected.miou.to_bits(), expected.fmiou.to_bits(), expected.macc.to_bits())
            );
        }
        let overall = MetricTriple::from(&SegmentationMetrics::from_confusion(&ConfusionMatrix::pooled(&scenes)));
        let ci = replicates.intervals().unwrap();
        for (metric, value) in [(ci.miou, overall.miou), (ci.fmiou, overall.fmiou), (ci.macc, overall.macc)] {
            let [lo, hi] = metric.unwrap();
            assert!(lo <= value && value <= hi && lo < hi, "{lo} {value} {hi}");
        }
    }

    #[test]
    fn a_scene_without_a_map_counts_as_nothing_and_one_scene_has_no_interval() {
        let one = ClassCount::of(&scene(vec![1, -1], vec![3, 1, 0, 0]));
        assert_eq!(Replicates::of(std::slice::from_ref(&one)).intervals(), None);
        let with_gap = Replicates::of(&[one.clone(), Vec::new()]);
        assert!(with_gap.miou().iter().any(Option::is_none), "a resample of only the empty scene has no mIoU");
        assert!(with_gap.miou().iter().flatten().all(|&m| m == 0.75));
    }
}
