//! Scoring one map against one ground truth.

use std::path::PathBuf;

use osmab_evaluator::formats::map::{FeatureMatrix, MapSemantics, PredictedMap, TextFeatures};
use osmab_evaluator::ground_truth::GroundTruth;
use osmab_evaluator::semseg::score_scene;
use osmab_evaluator::synthetic::Rng;

use crate::common::classes;

/// Three clusters of ground truth: class 1 near x=0, class 2 near x=10, class 0 at x=20.
fn ground_truth() -> GroundTruth {
    let mut rng = Rng::new(3);
    let mut points = Vec::new();
    let mut labels = Vec::new();
    for (center, label, n) in [(0.0, 1, 300), (10.0, 2, 200), (20.0, 0, 50)] {
        for _ in 0..n {
            points.push([center + rng.range(-1.0, 1.0) as f32, rng.range(-1.0, 1.0) as f32, rng.range(-1.0, 1.0) as f32]);
            labels.push(label);
        }
    }
    GroundTruth { source: PathBuf::from("gt"), points, colors: None, labels }
}

fn labelled_map(gt: &GroundTruth, object_of: impl Fn(i64) -> u32, labels: Vec<i64>) -> PredictedMap {
    PredictedMap {
        source: PathBuf::from("map.npz"),
        points: gt.points.clone(),
        semantics: MapSemantics::ObjectLabels { object_ids: gt.labels.iter().map(|&l| object_of(l)).collect(), labels },
    }
}

fn one_hot_text(classes: &[i64], dim: usize) -> TextFeatures {
    let mut values = vec![0.0f32; classes.len() * dim];
    for (row, _) in classes.iter().enumerate() {
        values[row * dim + row] = 1.0;
    }
    TextFeatures { source: PathBuf::from("text_features.npz"), class_ids: classes.to_vec(), features: FeatureMatrix { rows: classes.len(), dim, values } }
}

#[test]
fn a_perfect_map_scores_one() {
    let gt = ground_truth();
    let map = labelled_map(&gt, |l| l as u32, vec![0, 1, 2]);
    let score = score_scene(&gt, &map, &classes(5), None).unwrap();
    assert_eq!((score.metrics.miou, score.metrics.fmiou, score.metrics.macc), (1.0, 1.0, 1.0));
    assert_eq!(score.confusion.labels(), &[1, 2, -1]);
    assert_eq!(score.confusion.total(), 500, "class-0 points are not scored");
}

#[test]
fn features_and_labels_give_the_same_result_when_they_agree() {
    let gt = ground_truth();
    // Object 0 is class 1, object 1 is class 2, object 2 (the class-0 cloud) is called class 2.
    let object_of = |l: i64| match l {
        1 => 0,
        2 => 1,
        _ => 2,
    };
    let by_labels = score_scene(&gt, &labelled_map(&gt, object_of, vec![1, 2, 2]), &classes(5), None).unwrap();
    let dim = 8;
    let text = one_hot_text(&[1, 2, 3, 4, 5], dim);
    let mut features = vec![0.0f32; 3 * dim];
    features[0] = 0.9; // object 0 points along class 1
    features[1] = 0.2;
    features[dim + 1] = 2.0; // object 1 along class 2
    features[2 * dim + 1] = 0.5; // object 2 along class 2
    let feature_map = PredictedMap {
        source: PathBuf::from("map.npz"),
        points: gt.points.clone(),
        semantics: MapSemantics::ObjectFeatures {
            object_ids: gt.labels.iter().map(|&l| object_of(l)).collect(),
            features: FeatureMatrix { rows: 3, dim, values: features },
        },
    };
    let by_features = score_scene(&gt, &feature_map, &classes(5), Some(&text)).unwrap();
    assert_eq!(by_features.confusion, by_labels.confusion);
    assert_eq!(by_features.metrics, by_labels.metrics);
}

#[test]
fn equal_similarities_pick_the_first_class() {
    let gt = ground_truth();
    let dim = 4;
    let text = one_hot_text(&[1, 2], dim);
    // Exactly between classes 1 and 2: the first (lowest id) wins.
    let map = PredictedMap {
        source: PathBuf::from("map.npz"),
        points: gt.points.clone(),
        semantics: MapSemantics::PointFeatures(FeatureMatrix {
            rows: gt.points.len(),
            dim,
            values: gt.points.iter().flat_map(|_| [1.0, 1.0, 0.0, 0.0]).collect(),
        }),
    };
    let score = score_scene(&gt, &map, &classes(5), Some(&text)).unwrap();
    assert_eq!(score.confusion.column_sum(0), 500, "every point predicted as class 1");
}

#[test]
fn a_label_outside_the_scene_vocabulary_is_a_miss() {
    let gt = ground_truth();
    // Class 4 exists in the release but not in this scene: counts in the -1 column.
    let map = labelled_map(&gt, |l| l as u32, vec![0, 4, 2]);
    let score = score_scene(&gt, &map, &classes(5), None).unwrap();
    assert_eq!(score.confusion.count(0, 2), 300);
    assert_eq!(score.metrics.classes[0].recall, 0.0);
}

#[test]
fn a_label_outside_the_class_list_is_an_error() {
    let gt = ground_truth();
    let map = labelled_map(&gt, |l| l as u32, vec![0, 1, 99]);
    let err = score_scene(&gt, &map, &classes(5), None).unwrap_err();
    assert_eq!((err.file.as_str(), err.field.as_str()), ("map.npz", "labels"));
    assert!(err.message.contains("object 2 has label 99"), "{err}");
}

#[test]
fn features_without_text_features_are_an_error() {
    let gt = ground_truth();
    let map = PredictedMap {
        source: PathBuf::from("map.npz"),
        points: gt.points.clone(),
        semantics: MapSemantics::PointFeatures(FeatureMatrix { rows: gt.points.len(), dim: 2, values: vec![1.0; gt.points.len() * 2] }),
    };
    let err = score_scene(&gt, &map, &classes(5), None).unwrap_err();
    assert!(err.message.contains("text features"), "{err}");
}

#[test]
fn text_features_must_cover_the_scene_and_match_dimensions() {
    let gt = ground_truth();
    let map = PredictedMap {
        source: PathBuf::from("map.npz"),
        points: gt.points.clone(),
        semantics: MapSemantics::PointFeatures(FeatureMatrix { rows: gt.points.len(), dim: 4, values: vec![1.0; gt.points.len() * 4] }),
    };
    let missing = score_scene(&gt, &map, &classes(5), Some(&one_hot_text(&[1, 3], 4))).unwrap_err();
    assert_eq!(missing.field, "class_ids");
    assert!(missing.message.contains("class 2"), "{missing}");
    let narrow = score_scene(&gt, &map, &classes(5), Some(&one_hot_text(&[1, 2], 3))).unwrap_err();
    assert!(narrow.message.contains("3 dimensions"), "{narrow}");
}

#[test]
fn a_worse_map_never_scores_higher() {
    let gt = ground_truth();
    let perfect = score_scene(&gt, &labelled_map(&gt, |l| l as u32, vec![0, 1, 2]), &classes(5), None).unwrap();
    let swapped = score_scene(&gt, &labelled_map(&gt, |l| l as u32, vec![0, 2, 1]), &classes(5), None).unwrap();
    assert!(swapped.metrics.miou < perfect.metrics.miou);
    assert_eq!(swapped.metrics.miou, 0.0);
}

#[test]
fn ground_truth_classes_outside_the_class_list_are_not_scored() {
    // The reference's vocabulary is (classes & present) - {0}: a mesh object whose class
    // is not in the list neither enters the vocabulary nor counts as a miss.
    let mut gt = ground_truth();
    gt.labels.iter_mut().filter(|l| **l == 2).for_each(|l| *l = 77);
    let map = labelled_map(&gt, |l| if l == 1 { 1 } else { 0 }, vec![0, 1]);
    let score = score_scene(&gt, &map, &classes(5), None).unwrap();
    assert_eq!(score.confusion.labels(), &[1, -1]);
    assert_eq!(score.confusion.total(), 300);
    assert_eq!(score.metrics.miou, 1.0);
}

#[test]
fn non_finite_ground_truth_is_an_error_not_a_panic() {
    let mut gt = ground_truth();
    gt.points[17] = [f32::NAN, 0.0, 0.0];
    let map = labelled_map(&gt, |l| l as u32, vec![0, 1, 2]);
    let err = score_scene(&gt, &map, &classes(5), None).unwrap_err();
    assert!(err.message.contains("point 17"), "{err}");
}

#[test]
fn a_prepared_ground_truth_scores_every_map_as_scoring_it_alone_does() {
    // A synthetic room scanned frame by frame and three maps of it: putting the ground
    // truth in Z-order once changes the order points are visited in, not the counts.
    use osmab_evaluator::semseg::{PreparedGroundTruth, score_prepared};
    use osmab_evaluator::synthetic::{SceneSpec, generate};
    let spec = SceneSpec { gt_points: 60_000, map_points: 6_000, objects: 10, feature_dim: 8, seed: 4, map_covers_room: false };
    let scene = generate(spec);
    let prepared = PreparedGroundTruth::new(scene.ground_truth.clone(), &scene.classes).unwrap();
    assert_eq!(prepared.len(), scene.ground_truth.points.len());
    for seed in [1, 2, 3] {
        let map = scene.another_map(spec, &scene.text, seed);
        let alone = score_scene(&scene.ground_truth, &map, &scene.classes, Some(&scene.text)).unwrap();
        let shared = score_prepared(&prepared, &map, &scene.classes, Some(&scene.text)).unwrap();
        assert_eq!(shared.confusion, alone.confusion, "map {seed}");
        assert_eq!(shared.metrics, alone.metrics, "map {seed}");
    }
}

#[test]
fn maps_scored_one_after_another_in_the_same_memory_score_as_each_alone() {
    // A scorer keeps one index and one answer array from map to map (`Scratch`): maps of
    // other sizes, in any order, and a map of another scene in between, score as each does
    // alone.
    use osmab_evaluator::semseg::{PreparedGroundTruth, Scratch, score_prepared, score_prepared_reusing};
    use osmab_evaluator::synthetic::{SceneSpec, generate};
    let spec = |gt_points, map_points, seed| SceneSpec { gt_points, map_points, objects: 10, feature_dim: 8, seed, map_covers_room: false };
    let (large, small) = (generate(spec(50_000, 8_000, 4)), generate(spec(9_000, 700, 5)));
    let (large_gt, small_gt) = (
        PreparedGroundTruth::new(large.ground_truth.clone(), &large.classes).unwrap(),
        PreparedGroundTruth::new(small.ground_truth.clone(), &small.classes).unwrap(),
    );
    let mut scratch = Scratch::default();
    for (scene, gt, spec, seed) in
        [(&large, &large_gt, spec(50_000, 8_000, 4), 1), (&small, &small_gt, spec(9_000, 700, 5), 2), (&large, &large_gt, spec(50_000, 3_000, 4), 3)]
    {
        let map = scene.another_map(spec, &scene.text, seed);
        let alone = score_prepared(gt, &map, &scene.classes, Some(&scene.text)).unwrap();
        let reusing = score_prepared_reusing(gt, &map, &scene.classes, Some(&scene.text), &mut scratch).unwrap();
        assert_eq!(reusing.confusion, alone.confusion, "map {seed}");
        assert_eq!(reusing.metrics, alone.metrics, "map {seed}");
    }
}

#[test]
fn runs_of_equal_pairs_and_pairs_that_change_at_every_point_count_alike() {
    // The counter adds a run of equal (label, prediction) pairs at once: sorted labels
    // (long runs), alternating ones (no runs), and a run across the end of a part.
    use osmab_evaluator::semseg::ConfusionMatrix;
    use osmab_evaluator::semseg::confusion::COUNT_CHUNK;
    let vocabulary = [1i64, 2, 5];
    let n = 3 * COUNT_CHUNK + 17;
    let labels: Vec<i64> = (0..n).map(|i| [1, 2, 5, 0, -1, 9][(i / 1000) % 6]).collect();
    let predicted: Vec<i64> = (0..n).map(|i| [1, 2, 5, 7][(i / 700) % 4]).collect();
    let alternating: Vec<i64> = (0..n).map(|i| [1, 2, 5, 0, -1, 9][i % 6]).collect();
    for (name, gt) in [("runs", &labels), ("alternating", &alternating)] {
        let matrix = ConfusionMatrix::from_labels(gt, &predicted, &vocabulary);
        let mut expected = vec![0u64; 16];
        let (row, column) = (|l: i64| [1, 2, 5, -1].iter().position(|&v| v == l), |p: i64| [1, 2, 5].iter().position(|&v| v == p).unwrap_or(3));
        for (&g, &p) in gt.iter().zip(&predicted) {
            if let Some(r) = row(g) {
                expected[r * 4 + column(p)] += 1;
            }
        }
        let counted: Vec<u64> = (0..4).flat_map(|r| matrix.row(r).to_vec()).collect();
        assert_eq!(counted, expected, "{name}");
    }
}

#[test]
fn preparing_a_ground_truth_refuses_what_scoring_refuses() {
    use osmab_evaluator::semseg::PreparedGroundTruth;
    let mut gt = ground_truth();
    gt.points[7][1] = f32::NAN;
    let err = PreparedGroundTruth::new(gt, &classes(5)).err().unwrap();
    assert!(err.to_string().contains("point 7 has a non-finite coordinate"), "{err}");
    let mut gt = ground_truth();
    gt.labels.iter_mut().for_each(|l| *l = 0);
    let err = PreparedGroundTruth::new(gt, &classes(5)).err().unwrap();
    assert!(err.to_string().contains("no scored class"), "{err}");
}

#[test]
fn counting_through_the_nearest_points_equals_counting_their_labels() {
    use osmab_evaluator::semseg::ConfusionMatrix;
    // Ground truth with an unscored class (0) and a map with a class outside the vocabulary (9).
    let ground_truth = [1, 1, 2, 0, 2, 3, 1];
    let point_labels = [1, 2, 9, 3];
    let nearest = [0u32, 1, 1, 2, 3, 3, 2];
    let predicted: Vec<i64> = nearest.iter().map(|&i| point_labels[i as usize]).collect();
    let by_nearest = ConfusionMatrix::from_nearest(&ground_truth, &nearest, &point_labels, &[1, 2, 3]);
    assert_eq!(by_nearest, ConfusionMatrix::from_labels(&ground_truth, &predicted, &[1, 2, 3]));
    // Row 1 (class 1): one right, one predicted 2, one outside the vocabulary (-1 column).
    assert_eq!((by_nearest.count(0, 0), by_nearest.count(0, 1), by_nearest.count(0, 3)), (1, 1, 1));
}

#[test]
fn counting_drops_unscored_classes_keeps_the_unmatched_row_and_takes_labels_of_any_size() {
    use osmab_evaluator::semseg::ConfusionMatrix;
    // A vocabulary with a label beyond any dense table (3,000,000) and ground truth with
    // labels outside it: 0, 7, a negative one (-5) and one far beyond it (9,000,000) are
    // dropped; -1 ground truth (mesh ground truth) is counted in the -1 row.
    let vocabulary = [2, 3_000_000];
    let ground_truth = [2, 3_000_000, 0, 7, -5, 9_000_000, -1, 2, 3_000_000];
    let predicted = [2, 2, 2, 2, 2, 2, 3_000_000, -7, 9_000_000];
    let matrix = ConfusionMatrix::from_labels(&ground_truth, &predicted, &vocabulary);
    assert_eq!(matrix.labels(), &[2, 3_000_000, -1]);
    assert_eq!(matrix.row(0), &[1, 0, 1], "class 2: one right, one predicted outside the vocabulary");
    assert_eq!(matrix.row(1), &[1, 0, 1], "class 3,000,000: one predicted 2, one outside the vocabulary");
    assert_eq!(matrix.row(2), &[0, 1, 0], "the -1 row");
    assert_eq!(matrix.total(), 5, "the four points of classes outside the vocabulary are not counted");
}

#[test]
fn counts_over_many_parallel_chunks_add_up_exactly() {
    use osmab_evaluator::semseg::ConfusionMatrix;
    // 3.5 million points, more than three counting chunks: class k of the ground truth
    // (1..=4, and 0 every 5th point) predicted through map point k % 3.
    let n = 3_500_000usize;
    let ground_truth: Vec<i64> = (0..n).map(|i| (i % 5) as i64).collect();
    let nearest: Vec<u32> = (0..n).map(|i| ((i % 5) % 3) as u32).collect();
    let point_labels = [1, 2, 3];
    let matrix = ConfusionMatrix::from_nearest(&ground_truth, &nearest, &point_labels, &[1, 2, 3, 4]);
    let per_class = (n / 5) as u64;
    // Class 1 → map point 1 (label 2), 2 → 2 (3), 3 → 0 (1), 4 → 1 (2).
    assert_eq!(matrix.row(0), &[0, per_class, 0, 0, 0]);
    assert_eq!(matrix.row(1), &[0, 0, per_class, 0, 0]);
    assert_eq!(matrix.row(2), &[per_class, 0, 0, 0, 0]);
    assert_eq!(matrix.row(3), &[0, per_class, 0, 0, 0]);
    assert_eq!(matrix.total(), 4 * per_class);
}

#[test]
fn counting_nearest_points_part_by_part_in_any_order_equals_counting_them_at_once() {
    use osmab_evaluator::semseg::{ConfusionMatrix, NearestCount};
    use rayon::prelude::*;
    // 2.5 million points of classes 0..=5 (0 unscored, 5 outside the vocabulary), their
    // nearest map points labelled 1, 2, 3 and 9 (outside the vocabulary).
    let n = 2_500_000usize;
    let ground_truth: Vec<i64> = (0..n).map(|i| ((i * 7) % 6) as i64).collect();
    let nearest: Vec<u32> = (0..n).map(|i| ((i * 13) % 4) as u32).collect();
    let point_labels = [1, 2, 3, 9];
    let vocabulary = [1, 2, 3, 4];
    let at_once = ConfusionMatrix::from_nearest(&ground_truth, &nearest, &point_labels, &vocabulary);
    // The same points in two blocks, each in a scrambled order and in parts of 1,000.
    let mut count = NearestCount::new(&vocabulary, &point_labels);
    for block in [0..1_000_000, 1_000_000..n] {
        let order: Vec<usize> = block.clone().rev().step_by(2).chain(block.clone().step_by(2)).collect();
        assert_eq!(order.len(), block.len());
        count.add(order.par_chunks(1000).map(|part| part.iter().map(|&i| (ground_truth[i], nearest[i]))));
    }
    let part_by_part = count.into_matrix();
    assert_eq!(part_by_part, at_once);
    assert_eq!(at_once.labels(), &[1, 2, 3, 4, -1]);
    // Classes 1..=4 are counted (0 and 5 are not); each point once.
    let counted = (0..n).filter(|i| (1..=4).contains(&((i * 7) % 6))).count() as u64;
    assert_eq!(part_by_part.total(), counted);
}
