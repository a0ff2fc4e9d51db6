//! The bootstrap over scenes that every interval and every rank comparison uses: scenes
//! resampled with replacement, [`ROUNDS`] rounds, a fixed generator (SplitMix64) so a
//! figure is reproducible everywhere, NumPy's linear percentiles.
//!
//! [`Resamples`] depend on nothing but the number of scenes, so two submissions scored on
//! the same scenes see the same resamples: the difference of their replicates round by
//! round is a paired bootstrap of their difference.

/// Resampling rounds.
pub const ROUNDS: usize = 1000;

/// SplitMix64: a small, fixed generator.
pub struct SplitMix(u64);

impl SplitMix {
    pub fn new(seed: u64) -> Self {
        Self(seed)
    }

    pub fn next(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }

    /// Uniform in `0..n`.
    pub fn below(&mut self, n: usize) -> usize {
        ((self.next() >> 11) as f64 / (1u64 << 53) as f64 * n as f64) as usize
    }
}

/// NumPy's default (linear) percentile of sorted values.
pub fn percentile(sorted: &[f64], q: f64) -> f64 {
    let position = q / 100.0 * (sorted.len() - 1) as f64;
    let (lo, hi) = (position.floor() as usize, position.ceil() as usize);
    sorted[lo] + (sorted[hi] - sorted[lo]) * (position - lo as f64)
}

/// The central 95 % interval of the finite `estimates`; `None` with fewer than two.
pub fn interval95(estimates: impl IntoIterator<Item = f64>) -> Option<[f64; 2]> {
    let mut finite: Vec<f64> = estimates.into_iter().filter(|v| v.is_finite()).collect();
    if finite.len() < 2 {
        return None;
    }
    finite.sort_by(f64::total_cmp);
    Some([percentile(&finite, 2.5), percentile(&finite, 97.5)])
}

/// The 95 % interval of the relative change `(b − a) / a` over the rounds of paired
/// replicates `a` and `b` (rounds where either is undefined, or `a` is 0, left out).
pub fn change_interval95(a: &[Option<f64>], b: &[Option<f64>]) -> Option<[f64; 2]> {
    interval95(a.iter().zip(b).filter_map(|(x, y)| {
        let (x, y) = ((*x)?, (*y)?);
        (x != 0.0).then(|| (y - x) / x)
    }))
}

/// The scene indices of each round when `n` scenes are resampled: the same for every
/// caller with the same `n`.
pub struct Resamples {
    rng: SplitMix,
    n: usize,
    left: usize,
}

impl Resamples {
    pub fn of(n: usize) -> Self {
        Self { rng: SplitMix(0x5EED_05AB_u64 ^ (n as u64) << 32), n, left: if n >= 2 { ROUNDS } else { 0 } }
    }
}

impl Iterator for Resamples {
    type Item = Vec<usize>;

    fn next(&mut self) -> Option<Vec<usize>> {
        if self.left == 0 {
            return None;
        }
        self.left -= 1;
        Some((0..self.n).map(|_| self.rng.below(self.n)).collect())
    }
}

/// Whether `a` is significantly above `b` at the 5 % level: the lower end of the 95 %
/// interval of the round-by-round differences of their paired replicates is above zero.
/// Rounds where either replicate is undefined are left out; with fewer than two usable
/// rounds nothing is significant.
pub fn significantly_above(a: &[Option<f64>], b: &[Option<f64>]) -> bool {
    // A board compares every pair of entries, so this is its inner loop: two passes, no
    // allocation, the same answer as `percentile(sorted differences, 2.5) > 0` bit for bit.
    let differences = || a.iter().zip(b).filter_map(|(x, y)| Some((*x)? - (*y)?)).filter(|d| d.is_finite());
    let count = differences().count();
    if count < 2 {
        return false;
    }
    let position = 2.5 / 100.0 * (count - 1) as f64;
    let (lo, hi) = (position.floor() as usize, position.ceil() as usize);
    // Sorted, the differences ≤ 0 come first: `at_most_zero` of them.
    let (mut at_most_zero, mut largest_non_positive, mut smallest_positive) = (0usize, f64::NEG_INFINITY, f64::INFINITY);
    for d in differences() {
        if d <= 0.0 {
            at_most_zero += 1;
            largest_non_positive = largest_non_positive.max(d);
        } else {
            smallest_positive = smallest_positive.min(d);
        }
    }
    if at_most_zero <= lo {
        true // sorted[lo] > 0
    } else if at_most_zero > hi {
        false // sorted[hi] <= 0
    } else {
        // sorted[lo] is the largest difference ≤ 0, sorted[hi] the smallest one above.
        largest_non_positive + (smallest_positive - largest_non_positive) * (position - lo as f64) > 0.0
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn resamples_depend_only_on_the_number_of_scenes() {
        let first: Vec<Vec<usize>> = Resamples::of(5).collect();
        assert_eq!(first.len(), ROUNDS);
        assert_eq!(first, Resamples::of(5).collect::<Vec<_>>(), "reproducible");
        assert_ne!(first[..3], Resamples::of(6).take(3).collect::<Vec<_>>()[..], "another scene count, other resamples");
        assert!(first.iter().all(|r| r.len() == 5 && r.iter().all(|&i| i < 5)));
        assert_eq!(Resamples::of(1).count(), 0, "one scene cannot be resampled");
    }

    #[test]
    fn intervals_follow_numpy_linear_percentiles() {
        let values = (0..=100).map(f64::from);
        assert_eq!(interval95(values), Some([2.5, 97.5]));
        assert_eq!(interval95([1.0, f64::NAN]), None, "one finite estimate is no interval");
        assert_eq!(percentile(&[0.0, 10.0], 25.0), 2.5);
    }

    #[test]
    fn a_relative_change_interval_pairs_the_rounds_and_skips_undefined_ones() {
        // Round by round the second lighting keeps 80 % of the first, then 90 %.
        let a = [Some(0.5), Some(0.4), None, Some(0.0)];
        let b = [Some(0.4), Some(0.36), Some(0.3), Some(0.1)];
        let [low, high] = change_interval95(&a, &b).unwrap();
        assert!((low - (-0.2 + 0.1 * 0.025)).abs() < 1e-12 && (high - (-0.2 + 0.1 * 0.975)).abs() < 1e-12, "{low} {high}");
        assert_eq!(change_interval95(&a[..1], &b[..1]), None, "one round is no interval");
    }

    #[test]
    fn significance_is_the_sorted_percentile_test_exactly() {
        let mut rng = SplitMix::new(7);
        let mut uniform = move || rng.next() as f64 / u64::MAX as f64;
        let (mut outcomes, mut on_the_boundary) = ([0usize; 2], 0);
        for case in 0..2000 {
            let n = [2usize, 3, 41, 999, 1000][case % 5];
            // Centred so that the count of differences ≤ 0 lands near the 2.5th percentile.
            let shift = (uniform() - 0.5) * 0.2;
            let a: Vec<Option<f64>> = (0..n).map(|i| if i % 97 == 5 { None } else { Some(uniform() + shift) }).collect();
            let b: Vec<Option<f64>> = (0..n).map(|_| Some(uniform() * 0.1)).collect();
            let mut differences: Vec<f64> = a.iter().zip(&b).filter_map(|(x, y)| Some((*x)? - (*y)?)).collect();
            differences.sort_by(f64::total_cmp);
            let expected = differences.len() >= 2 && percentile(&differences, 2.5) > 0.0;
            assert_eq!(significantly_above(&a, &b), expected, "case {case}");
            outcomes[expected as usize] += 1;
            let position = 0.025 * (differences.len() - 1) as f64;
            on_the_boundary += usize::from(position.fract() > 0.0 && differences.iter().filter(|d| **d <= 0.0).count() == position.ceil() as usize);
        }
        assert!(outcomes[0] > 200 && outcomes[1] > 200, "both answers are exercised: {outcomes:?}");
        assert!(on_the_boundary > 10, "the interpolated case is exercised: {on_the_boundary}");
    }

    #[test]
    fn a_paired_difference_is_significant_only_when_it_is_consistent() {
        let noise: Vec<Option<f64>> = (0..ROUNDS).map(|i| Some(((i * 7919) % 1000) as f64 / 1000.0)).collect();
        let shifted: Vec<Option<f64>> = noise.iter().map(|v| v.map(|v| v + 0.01)).collect();
        assert!(significantly_above(&shifted, &noise), "always 0.01 better in the same resamples");
        assert!(!significantly_above(&noise, &shifted));
        let reversed: Vec<Option<f64>> = noise.iter().rev().copied().collect();
        assert!(!significantly_above(&reversed, &noise) && !significantly_above(&noise, &reversed), "unpaired noise is not a difference");
        assert!(!significantly_above(&[None; 3], &[Some(1.0); 3]));
    }
}
