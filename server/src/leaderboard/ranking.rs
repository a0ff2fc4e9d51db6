//! Where an entry stands: its rank, its rank group (entries whose difference is not
//! significant share one) and how robust it is to the lighting.
//!
//! An entry's rank group is 1 + the number of entries significantly above it in a
//! paired bootstrap over scenes of the ranking metric (pooled mIoU under the release's
//! first lighting): every submission of a release is resampled alike, so the
//! round-by-round difference of two entries' replicates is the bootstrap of their
//! difference ([`osmab_evaluator::bootstrap::significantly_above`]). The rule is the
//! one of Chatbot Arena's "rank (UB)": two entries within noise of each other never get
//! different groups because of each other, and a clearly better entry always comes first.
//! Scores from before the replicates existed compare by value alone.

use osmab_evaluator::bootstrap::significantly_above;

/// The fewest scenes a board's rank groups and intervals mean something with: a bootstrap
/// over fewer scenes has a handful of distinct resamples, and "significantly above" then
/// says only "above in every scene" (the same floor as a test score's disclosure).
pub const MIN_SCENES_FOR_GROUPS: usize = osmab_evaluator::scores::MIN_TEST_SCENES;

/// What ranking one entry needs: the ranking metric and its bootstrap replicates.
pub struct Standing {
    pub value: Option<f64>,
    pub replicates: Vec<Option<f64>>,
}

impl Standing {
    /// Whether this entry is significantly above `other`.
    fn above(&self, other: &Standing) -> bool {
        match (self.value, other.value) {
            (Some(_), None) => true,
            (None, _) => false,
            (Some(a), Some(b)) if self.replicates.is_empty() || other.replicates.is_empty() => a > b,
            (Some(_), Some(_)) => significantly_above(&self.replicates, &other.replicates),
        }
    }
}

/// The rank group of each of `standings`, given best first.
pub fn rank_groups(standings: &[Standing]) -> Vec<usize> {
    standings.iter().enumerate().map(|(i, s)| 1 + standings[..i].iter().filter(|above| above.above(s)).count()).collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use osmab_evaluator::bootstrap::ROUNDS;

    /// Replicates around `center`: one shared pattern of scene noise of `spread`, as
    /// submissions scored on the same resamples have, plus a little of their own.
    fn standing(center: f64, spread: f64, own: u64) -> Standing {
        let replicates = (0..ROUNDS as u64)
            .map(|i| {
                let shared = ((i * 7919) % 1000) as f64 / 1000.0 - 0.5;
                let private = (((i + own) * 104_729) % 997) as f64 / 997.0 - 0.5;
                Some(center + spread * shared + spread * 0.2 * private)
            })
            .collect();
        Standing { value: Some(center), replicates }
    }

    #[test]
    fn entries_within_noise_share_a_group_and_a_clearly_better_one_does_not() {
        let clearly_best = standing(0.60, 0.2, 1);
        let a = standing(0.45, 0.2, 2);
        let b = standing(0.449, 0.2, 3);
        let far_below = standing(0.20, 0.2, 4);
        assert_eq!(rank_groups(&[clearly_best, a, b, far_below]), vec![1, 2, 2, 4]);
    }

    #[test]
    fn scores_without_replicates_compare_by_value_and_missing_metrics_come_last() {
        let plain = |v: Option<f64>| Standing { value: v, replicates: Vec::new() };
        assert_eq!(rank_groups(&[plain(Some(0.5)), plain(Some(0.5)), plain(Some(0.4)), plain(None), plain(None)]), vec![1, 1, 3, 4, 4]);
    }
}
