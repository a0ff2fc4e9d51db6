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
    // |a|² = 1 + 2⁻²⁴ rounds to exactly 1.0 in float32, the same as |b|², so the two
    // tie and the lower index (a) wins; in float64 b would be strictly nearer.
    let a = [1.0f32, 2f32.powi(-12), 0.0];
    let b = [1.0f32, 0.0, 0.0];
    let q = [0.0f32; 3];
    assert!(1.0f64 + 2f64.powi(-24) > 1.0, "float64 tells them apart");
    assert_eq!(NearestIndex::build(&[a, b]).nearest(q), 0);
    // The same tie deep inside a large tree: 5,000 far points around the pair.
    let mut rng = Rng::new(9);
    let mut points = random_points(&mut rng, 5000, 50.0, None).into_iter().map(|p| p.map(|c| c + 100.0)).collect::<Vec<_>>();
    points.insert(1234, a);
    points.insert(4321, b);
    let index = NearestIndex::build(&points);
    assert_eq!(index.nearest(q), 1234);
    let ia = points.iter().position(|p| *p == a).unwrap() as u32;
    assert_eq!(ia, 1234);
}

#[test]
fn duplicate_points_spread_over_many_leaves_resolve_to_the_lowest_index() {
    // 2,000 copies of one point among 3,000 others: the copies fill many leaves of the
    // tree, and only the smallest index among them may be returned.
    let mut rng = Rng::new(21);
    let mut points = random_points(&mut rng, 3000, 5.0, None);
    let copy = [0.5f32, 0.25, -0.75];
    for k in 0..2000 {
        points.insert(1 + k * 2, copy);
    }
    let index = NearestIndex::build(&points);
    let first = points.iter().position(|p| *p == copy).unwrap() as u32;
    for q in [copy, [0.5, 0.25, -0.70], [0.6, 0.3, -0.8]] {
        assert_eq!(index.nearest(q), first, "query {q:?}");
        assert_eq!(nearest_brute_force(&points, q), first);
    }
}

#[test]
fn shuffled_queries_get_the_answers_of_the_same_queries_in_scan_order() {
    // A scan-like cloud (neighbouring queries one after another, answered in their own
    // order) and the same queries shuffled (put in Z-order block by block, more than one
    // block): the same answer for every query.
    let mut rng = Rng::new(21);
    let points = random_points(&mut rng, 20_000, 2.0, None);
    let index = NearestIndex::build(&points);
    let scan: Vec<[f32; 3]> = (0..1_200_000)
        .map(|i| {
            let t = i as f32 / 1_200_000.0;
            [2.0 * (t * 40.0).sin() * (1.0 - t), 2.0 * (t * 31.0).cos(), 4.0 * t - 2.0]
        })
        .collect();
    let in_order = index.nearest_all(&scan);
    let mut permutation: Vec<usize> = (0..scan.len()).collect();
    for i in (1..permutation.len()).rev() {
        permutation.swap(i, (rng.range(0.0, 1.0) * (i + 1) as f64) as usize % (i + 1));
    }
    let shuffled: Vec<[f32; 3]> = permutation.iter().map(|&i| scan[i]).collect();
    let answers = index.nearest_all(&shuffled);
    assert!(permutation.iter().zip(&answers).all(|(&i, &a)| in_order[i] == a), "every shuffled query has its scan-order answer");
    for k in (0..scan.len()).step_by(99_991) {
        assert_eq!(in_order[k], nearest_brute_force(&points, scan[k]), "query {k}");
    }
}

/// Points near the plane z = 0 (a scanned wall): `n` of them over `extent` × `extent`,
/// with `noise` out of the plane, coordinates snapped to `grid` when given.
fn surface_points(rng: &mut Rng, n: usize, extent: f64, noise: f64, grid: Option<f64>) -> Vec<[f32; 3]> {
    let snap = |v: f64| grid.map_or(v, |g| (v / g).round() * g) as f32;
    (0..n).map(|_| [snap(rng.range(0.0, extent)), snap(rng.range(0.0, extent)), snap(rng.range(-noise, noise))]).collect()
}

#[test]
fn dense_queries_answered_in_batches_agree_with_exhaustive_search() {
    // Ten queries per indexed point on the same surface: neighbouring queries share a
    // leaf-sized box and are answered together from one set of candidate leaves.
    let mut rng = Rng::new(33);
    let points = surface_points(&mut rng, 20_000, 4.0, 0.01, None);
    let index = NearestIndex::build(&points);
    let queries = surface_points(&mut rng, 200_000, 4.0, 0.02, None);
    let answers = index.nearest_all(&queries);
    for k in (0..queries.len()).step_by(7) {
        assert_eq!(answers[k], nearest_brute_force(&points, queries[k]), "query {k} {:?}", queries[k]);
    }
}

#[test]
fn dense_queries_on_a_grid_of_duplicates_resolve_ties_to_the_lowest_index() {
    // Indexed points and queries snapped to grids: every batch meets equal distances
    // (duplicates, and queries halfway between grid points).
    let mut rng = Rng::new(34);
    let points = surface_points(&mut rng, 8_000, 1.0, 0.05, Some(0.05));
    let index = NearestIndex::build(&points);
    let queries = surface_points(&mut rng, 100_000, 1.0, 0.06, Some(0.025));
    let answers = index.nearest_all(&queries);
    for k in (0..queries.len()).step_by(3) {
        assert_eq!(answers[k], nearest_brute_force(&points, queries[k]), "query {k} {:?}", queries[k]);
    }
}

#[test]
fn dense_queries_half_a_metre_from_every_point_are_answered_exactly() {
    // A layer of queries half a metre above an indexed surface (a ceiling over a map that
    // leaves it out): the leaf at a batch's centre bounds its answers too loosely to share
    // the leaves within that bound, so the batch is bounded by its centre's exact answer.
    let mut rng = Rng::new(38);
    let points = surface_points(&mut rng, 30_000, 2.0, 0.01, None);
    let index = NearestIndex::build(&points);
    let queries: Vec<[f32; 3]> = surface_points(&mut rng, 100_000, 2.0, 0.02, None).into_iter().map(|q| [q[0], q[1], q[2] + 0.5]).collect();
    let answers = index.nearest_all(&queries);
    for k in (0..queries.len()).step_by(5) {
        assert_eq!(answers[k], nearest_brute_force(&points, queries[k]), "query {k} {:?}", queries[k]);
    }
}

#[test]
fn dense_queries_far_from_every_point_are_answered_exactly() {
    // A cluster of queries metres away from a small indexed surface: their candidate
    // leaves are too many to share, so they are answered one by one.
    let mut rng = Rng::new(35);
    let points = surface_points(&mut rng, 30_000, 2.0, 0.01, None);
    let index = NearestIndex::build(&points);
    let queries: Vec<[f32; 3]> = surface_points(&mut rng, 50_000, 0.3, 0.3, None).into_iter().map(|q| [q[0] + 0.8, q[1] + 0.8, q[2] + 3.0]).collect();
    let answers = index.nearest_all(&queries);
    for k in (0..queries.len()).step_by(5) {
        assert_eq!(answers[k], nearest_brute_force(&points, queries[k]), "query {k} {:?}", queries[k]);
    }
}

#[test]
fn z_order_is_a_permutation_that_keeps_neighbours_together() {
    use osmab_evaluator::semseg::z_order::z_order;
    let mut rng = Rng::new(36);
    let points = random_points(&mut rng, 50_000, 4.0, None);
    let order = z_order(&points);
    let mut seen = vec![false; points.len()];
    for &i in &order {
        assert!(!std::mem::replace(&mut seen[i as usize], true), "index {i} twice");
    }
    assert!(seen.iter().all(|&s| s), "every point once");
    // Consecutive points along the curve are far closer than in the random input.
    let mean_step = |visit: &mut dyn Iterator<Item = usize>| {
        let path: Vec<[f32; 3]> = visit.map(|i| points[i]).collect();
        path.windows(2).map(|w| (0..3).map(|a| (w[0][a] - w[1][a]).powi(2)).sum::<f32>().sqrt()).sum::<f32>() / (path.len() - 1) as f32
    };
    let (input, curve) = (mean_step(&mut (0..points.len())), mean_step(&mut order.iter().map(|&i| i as usize)));
    assert!(curve < input / 10.0, "mean step {curve} along the curve, {input} in input order");
}

#[test]
fn queries_in_z_order_get_the_answers_of_any_order() {
    use osmab_evaluator::semseg::z_order::z_order;
    let mut rng = Rng::new(37);
    let points = surface_points(&mut rng, 30_000, 3.0, 0.01, Some(0.004));
    let index = NearestIndex::build(&points);
    let queries = surface_points(&mut rng, 300_000, 3.2, 0.3, Some(0.002));
    let any_order = index.nearest_all(&queries);
    let order = z_order(&queries);
    let sorted: Vec<[f32; 3]> = order.iter().map(|&i| queries[i as usize]).collect();
    let in_order = index.nearest_all_in_order(&sorted);
    assert!(order.iter().zip(&in_order).all(|(&i, &a)| any_order[i as usize] == a), "the same answer for every query");
    for k in (0..queries.len()).step_by(97) {
        assert_eq!(any_order[k], nearest_brute_force(&points, queries[k]), "query {k}");
    }
}

/// The class of each point of `points`: the cell of a `cell`-sized grid over the surface it
/// lies in, among `classes` classes (regions of one class, as a map's objects are).
fn classes_by_region(points: &[[f32; 3]], cell: f32, classes: u32) -> Vec<u32> {
    points.iter().map(|p| ((p[0] / cell) as u32 * 7 + (p[1] / cell) as u32 * 13) % classes).collect()
}

#[test]
fn the_class_of_each_query_s_nearest_point_is_that_of_its_exact_answer() {
    use osmab_evaluator::semseg::z_order::z_order;
    let mut rng = Rng::new(39);
    let points = surface_points(&mut rng, 30_000, 3.0, 0.01, Some(0.004));
    let index = NearestIndex::build(&points);
    // On the surface (batches inside one region share its class), half a metre above it
    // (batches bounded by their centre's answer) and far away (queries one by one).
    let mut queries = surface_points(&mut rng, 200_000, 3.2, 0.02, Some(0.002));
    queries.extend(surface_points(&mut rng, 50_000, 3.0, 0.01, None).into_iter().map(|[x, y, z]| [x, y, z + 0.5]));
    queries.extend(random_points(&mut rng, 2_000, 40.0, None));
    let order = z_order(&queries);
    let sorted: Vec<[f32; 3]> = order.iter().map(|&i| queries[i as usize]).collect();
    let nearest = index.nearest_all_in_order(&sorted);
    for (cell, count) in [(0.5, 5), (0.05, 3), (100.0, 1)] {
        let of_point = classes_by_region(&points, cell, count);
        let classes = index.point_classes(&of_point);
        let expected: Vec<u32> = nearest.iter().map(|&id| of_point[id as usize]).collect();
        assert_eq!(index.nearest_classes_in_order(&sorted, &classes), expected, "regions of {cell} m, in order");
        let mut by_block = vec![u32::MAX; queries.len()];
        index.nearest_classes_by_block(&queries, &classes, |answers| answers.pairs().for_each(|(q, class)| by_block[q] = class));
        let expected_by_query: Vec<u32> = index.nearest_all(&queries).iter().map(|&id| of_point[id as usize]).collect();
        assert_eq!(by_block, expected_by_query, "regions of {cell} m, by block");
    }
}

#[test]
fn tied_points_of_different_classes_give_the_class_of_the_lowest_index() {
    // Duplicated grid points, each copy of another class: only the tie rule decides.
    let mut rng = Rng::new(40);
    let grid = surface_points(&mut rng, 4_000, 1.0, 0.05, Some(0.05));
    let points: Vec<[f32; 3]> = grid.iter().chain(&grid).copied().collect();
    let of_point: Vec<u32> = (0..points.len()).map(|i| u32::from(i >= grid.len())).collect();
    let index = NearestIndex::build(&points);
    let classes = index.point_classes(&of_point);
    let queries = surface_points(&mut rng, 40_000, 1.0, 0.05, Some(0.025));
    let mut by_block = vec![u32::MAX; queries.len()];
    index.nearest_classes_by_block(&queries, &classes, |answers| answers.pairs().for_each(|(q, class)| by_block[q] = class));
    assert!(by_block.iter().all(|&class| class == 0), "every answer is a first copy, of class 0");
}

#[test]
fn an_index_rebuilt_in_the_memory_of_another_answers_as_one_built_afresh() {
    // A scorer rebuilds one index map after map: larger, smaller, then with ties and ±0
    // coordinates, each in the memory of the index before.
    let mut rng = Rng::new(23);
    let mut reused = NearestIndex::build(&random_points(&mut rng, 9_000, 2.0, None));
    let mut signed_zeros = random_points(&mut rng, 2_000, 1.0, Some(0.5));
    for (i, p) in signed_zeros.iter_mut().enumerate() {
        p[i % 3] = if i % 2 == 0 { 0.0 } else { -0.0 };
    }
    let maps =
        [random_points(&mut rng, 20_000, 2.0, None), random_points(&mut rng, 37, 1.0, None), random_points(&mut rng, 3_000, 1.0, Some(0.25)), signed_zeros];
    for (m, points) in maps.iter().enumerate() {
        reused.rebuild(points);
        let fresh = NearestIndex::build(points);
        let qs = random_points(&mut rng, 3_000, 1.5, Some(0.125));
        let answers = reused.nearest_all(&qs);
        assert_eq!(answers, fresh.nearest_all(&qs), "map {m}");
        for (q, &a) in qs.iter().zip(&answers) {
            assert_eq!(a, nearest_brute_force(points, *q), "map {m}, query {q:?}");
        }
    }
}
