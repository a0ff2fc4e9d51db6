//! The association: the exact nearest predicted point, ties to the lowest index.

use osmab_evaluator::semseg::NearestIndex;
use osmab_evaluator::semseg::nearest::nearest_brute_force;
use osmab_evaluator::synthetic::Rng;

fn random_points(rng: &mut Rng, n: usize, scale: f64, grid: Option<f64>) -> Vec<[f32; 3]> {
    (0..n)
        .map(|_| {
            std::array::from_fn(|_| {
                let v = rng.range(-scale, scale);
                grid.map_or(v, |g| (v / g).round() * g) as f32
            })
        })
        .collect()
}

#[test]
fn index_agrees_with_exhaustive_search_on_random_clouds() {
    let mut rng = Rng::new(11);
    for (n, queries) in [(1, 50), (7, 200), (100, 500), (5000, 3000)] {
        let points = random_points(&mut rng, n, 2.0, None);
        let index = NearestIndex::build(&points);
        let qs = random_points(&mut rng, queries, 3.0, None);
        let answers = index.nearest_all(&qs);
        for (q, &a) in qs.iter().zip(&answers) {
            assert_eq!(a, nearest_brute_force(&points, *q), "query {q:?} against {n} points");
        }
    }
}

#[test]
fn equal_distances_go_to_the_lowest_point_index() {
    // Points on a coarse grid with many duplicates: ties everywhere.
    let mut rng = Rng::new(5);
    let points = random_points(&mut rng, 3000, 1.0, Some(0.25));
    let index = NearestIndex::build(&points);
    let qs = random_points(&mut rng, 4000, 1.2, Some(0.125));
    for (q, a) in qs.iter().zip(index.nearest_all(&qs)) {
        assert_eq!(a, nearest_brute_force(&points, *q), "query {q:?}");
    }
    // Two copies of the same point: the first one wins, wherever the query is.
    let twins = vec![[1.0, 0.0, 0.0], [0.0, 0.0, 0.0], [0.0, 0.0, 0.0]];
    assert_eq!(NearestIndex::build(&twins).nearest([0.1, 0.0, 0.0]), 1);
    // Equidistant points: the lower index wins.
    let pair = vec![[1.0, 0.0, 0.0], [-1.0, 0.0, 0.0]];
    assert_eq!(NearestIndex::build(&pair).nearest([0.0, 5.0, 0.0]), 0);
}

#[test]
fn distances_are_float32_as_pytorch3d_computes_them() {
    // In float64 the second point is nearer; in float32 ((dx² + dy²) + dz²) both round
    // to the same distance, so the tie rule picks index 0, as the reference does.
    let q = [0.0f32, 0.0, 0.0];
    let a = [1.0f32, 0.0, 0.0];
    let b = [0.99999997f32, 0.0, 0.0]; // the float32 just below 1.0
    let d = |p: [f32; 3]| (p[0] * p[0] + p[1] * p[1]) + p[2] * p[2];
    assert!(d(b) <= d(a));
    let expected = if d(b) < d(a) { 1 } else { 0 };
    assert_eq!(NearestIndex::build(&[a, b]).nearest(q), expected);
}
