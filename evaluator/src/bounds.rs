//! The axis-aligned bounding box of a point set.

use rayon::prelude::*;

/// The smallest and largest coordinate along each axis of `points`, computed in parallel
/// (`f32::min`/`max`: a NaN coordinate never wins). An empty set gives `+∞` minima and
/// `−∞` maxima.
pub fn bounding_box(points: &[[f32; 3]]) -> ([f32; 3], [f32; 3]) {
    let empty = || ([f32::INFINITY; 3], [f32::NEG_INFINITY; 3]);
    points
        .par_iter()
        .fold(empty, |(lo, hi), p| (std::array::from_fn(|a| lo[a].min(p[a])), std::array::from_fn(|a| hi[a].max(p[a]))))
        .reduce(empty, |(lo, hi), (l, h)| (std::array::from_fn(|a| lo[a].min(l[a])), std::array::from_fn(|a| hi[a].max(h[a]))))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_box_holds_every_point_and_touches_each_extreme() {
        let points: Vec<[f32; 3]> = (0..100_000).map(|i| [(i % 7) as f32 - 3.0, (i % 11) as f32 * 0.5, -(i as f32)]).collect();
        assert_eq!(bounding_box(&points), ([-3.0, 0.0, -99_999.0], [3.0, 5.0, 0.0]));
        assert_eq!(bounding_box(&[]), ([f32::INFINITY; 3], [f32::NEG_INFINITY; 3]));
    }
}
