//! The published OSMa-Bench figures, reproduced exactly from the published matrices.

use std::path::Path;

use osmab_evaluator::formats::confusion::read_confusion;
use osmab_evaluator::semseg::{ConfusionMatrix, MetricsTable};

use crate::common::fixtures;

fn table_of(dir: &Path) -> MetricsTable {
    let mut scenes = Vec::new();
    for entry in std::fs::read_dir(dir).unwrap() {
        let path = entry.unwrap().path();
        let name = path.file_name().unwrap().to_str().unwrap().to_string();
        if let Some(scene) = name.strip_suffix(".confusion.json") {
            scenes.push((scene.to_string(), read_confusion(&path).unwrap()));
        }
    }
    MetricsTable::from_scenes(scenes)
}

#[test]
fn every_published_metric_is_reproduced_bit_for_bit() {
    let root = fixtures().join("osmabench-v1/semseg-confusion");
    let mut values = 0;
    for method in ["bbq", "conceptgraphs", "openscene"] {
        for lighting in ["baseline", "camera_lights", "dynamic_lights", "no_lights", "velocity"] {
            let dir = root.join(method).join("replica_cad").join(lighting);
            let published = std::fs::read_to_string(dir.join("metrics.csv")).unwrap();
            let ours = table_of(&dir).to_csv();
            for (row, (a, b)) in ours.lines().zip(published.lines()).enumerate().skip(1) {
                let (a, b): (Vec<&str>, Vec<&str>) = (a.split(',').collect(), b.split(',').collect());
                assert_eq!(a[3], b[3], "{method}/{lighting}: row {row} scene order");
                for col in 0..3 {
                    let (x, y): (f64, f64) = (a[col].parse().unwrap(), b[col].parse().unwrap());
                    assert_eq!(x.to_bits(), y.to_bits(), "{method}/{lighting}/{}: column {col}", b[3]);
                    values += 1;
                }
            }
            assert_eq!(ours, published, "{method}/{lighting}: the CSV text itself is identical");
        }
    }
    assert_eq!(values, 1080, "every published value was compared");
}

#[test]
fn worked_example_of_the_reference_is_reproduced() {
    // docs/osmabench-reference.md 1.10: ConceptGraphs, ReplicaCAD, baseline, v3_sc0_staging_20.
    let path = fixtures().join("osmabench-v1/semseg-confusion/conceptgraphs/replica_cad/baseline/v3_sc0_staging_20.confusion.json");
    let matrix = read_confusion(&path).unwrap();
    let metrics = osmab_evaluator::semseg::SegmentationMetrics::from_confusion(&matrix);
    let chair = metrics.classes.iter().find(|c| c.label == 20).unwrap();
    assert_eq!((chair.ground_truth, chair.predicted, chair.true_positive), (120687, 125506, 120558));
    let wall = metrics.classes.iter().find(|c| c.label == 93).unwrap();
    assert_eq!((wall.ground_truth, wall.predicted, wall.true_positive), (4036232, 0, 0));
    assert_eq!(format!("{:.6}", metrics.miou), "0.308773");
    assert_eq!(format!("{:.6}", metrics.fmiou), "0.310278");
    assert_eq!(format!("{:.6}", metrics.macc), "0.410156");
}

#[test]
fn pooled_matrix_sums_scenes_by_label_with_minus_one_first() {
    let a = ConfusionMatrix::new(vec![2, 5, -1], vec![3, 1, 0, 0, 4, 2, 0, 0, 0]).unwrap();
    let b = ConfusionMatrix::new(vec![5, 7, -1], vec![1, 0, 1, 2, 6, 0, 0, 0, 0]).unwrap();
    let pooled = ConfusionMatrix::pooled([&a, &b]);
    assert_eq!(pooled.labels(), &[-1, 2, 5, 7]);
    assert_eq!(pooled.row(1), &[0, 3, 1, 0]);
    assert_eq!(pooled.row(2), &[2 + 1, 0, 4 + 1, 0]);
    assert_eq!(pooled.row(3), &[0, 0, 2, 6]);
    assert_eq!(pooled.total(), a.total() + b.total());
}

#[test]
fn a_scene_without_scored_classes_is_nan_and_skipped_in_the_mean() {
    let empty = ConfusionMatrix::new(vec![4, -1], vec![0, 0, 0, 0]).unwrap();
    let full = ConfusionMatrix::new(vec![4, -1], vec![5, 5, 0, 0]).unwrap();
    let table = MetricsTable::from_scenes(vec![("b".into(), empty), ("a".into(), full)]);
    assert_eq!(table.scenes[0].0, "a");
    assert!(table.scenes[1].1.miou.is_nan());
    assert_eq!(table.overall_mean.miou, 0.5);
    assert_eq!(table.overall_mean.macc, 0.5);
    assert!(table.to_csv().contains("\n,0.0,,b\n"), "NaN cells are empty, as pandas writes them:\n{}", table.to_csv());
}

#[test]
fn scene_names_are_quoted_as_pandas_quotes_them() {
    let m = ConfusionMatrix::new(vec![4, -1], vec![5, 5, 0, 0]).unwrap();
    let table = MetricsTable::from_scenes(vec![("a,b".into(), m.clone()), ("say \"hi\"".into(), m)]);
    let csv = table.to_csv();
    assert!(csv.contains(",\"a,b\"\n") && csv.contains(",\"say \"\"hi\"\"\"\n"), "{csv}");
}

#[test]
fn matrices_whose_counts_overflow_float64_exactness_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("big.confusion.json");
    std::fs::write(&path, format!(r#"{{"labels": [1, -1], "matrix": [[{}, 1], [0, 0]]}}"#, 1u64 << 53)).unwrap();
    let err = read_confusion(&path).unwrap_err();
    assert!(err.message.contains("2^53"), "{err}");
}
