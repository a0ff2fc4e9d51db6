//! End-to-end tests of the `osmab` binary: real files in, real processes, real output.

mod cpu;
mod service;
mod vqa;
mod warm;

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

use osmab_evaluator::formats::camera::CameraParams;
use osmab_evaluator::formats::classes::ClassList;
use osmab_evaluator::formats::image::{GrayImage16, RgbImage, write_jpeg_rgb, write_png_gray16};
use osmab_evaluator::formats::map::{MapSemantics, PredictedMap, TextFeatures};
use osmab_evaluator::formats::npy::ReadLimits;
use osmab_evaluator::formats::sequence::frame_path;
use osmab_evaluator::formats::trajectory::Trajectory;
use osmab_evaluator::ground_truth::GroundTruth;
use osmab_evaluator::semseg::score_scene;

fn osmab(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_osmab")).args(args).output().expect("osmab runs")
}

fn stdout(out: &Output) -> String {
    assert!(out.status.success(), "osmab failed: {}", String::from_utf8_lossy(&out.stderr));
    String::from_utf8(out.stdout.clone()).unwrap()
}

fn fixtures() -> PathBuf {
    let dir = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../shared/fixtures");
    assert!(dir.is_dir(), "fixtures missing at {}", dir.display());
    dir
}

fn path(p: &Path) -> &str {
    p.to_str().unwrap()
}

#[test]
fn eval_metrics_prints_the_published_csv() {
    let dir = fixtures().join("osmabench-v1/semseg-confusion/openscene/replica_cad/camera_lights");
    let published = std::fs::read_to_string(dir.join("metrics.csv")).unwrap();
    assert_eq!(stdout(&osmab(&["eval", "metrics", path(&dir)])), published);
}

#[test]
fn eval_metrics_names_a_malformed_matrix() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("scene_a.confusion.json"), r#"{"labels": [1, -1], "matrix": [[1, 2]]}"#).unwrap();
    let out = osmab(&["eval", "metrics", path(dir.path())]);
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("scene_a.confusion.json") && err.contains("expected 2 rows"), "{err}");

    let empty = tempfile::tempdir().unwrap();
    let out = osmab(&["eval", "metrics", path(empty.path())]);
    assert!(String::from_utf8_lossy(&out.stderr).contains("no *.confusion.json"));
}

#[test]
fn eval_lightings_compares_every_lighting_with_baseline() {
    let dir = fixtures().join("osmabench-v1/semseg-confusion/conceptgraphs/replica_cad");
    let csv = stdout(&osmab(&["eval", "lightings", path(&dir)]));
    let rows: Vec<Vec<&str>> = csv.lines().skip(1).map(|l| l.split(',').collect()).collect();
    assert_eq!(rows.len(), 10, "two aggregates for each of five lightings:\n{csv}");
    assert_eq!((rows[0][0], rows[0][1], rows[0][5]), ("baseline", "overall", "0.0"));
    // The pooled row of each lighting is its published `overall` row.
    for row in rows.iter().filter(|r| r[1] == "overall") {
        let published = std::fs::read_to_string(dir.join(row[0]).join("metrics.csv")).unwrap();
        let overall = published.lines().last().unwrap();
        assert_eq!(overall, format!("{},{},{},overall", row[2], row[3], row[4]));
    }
    // Change = (lighting − baseline) / baseline, for the same aggregate.
    let camera = rows.iter().find(|r| r[0] == "camera_lights" && r[1] == "overall").unwrap();
    let (value, base): (f64, f64) = (camera[3].parse().unwrap(), rows[0][3].parse().unwrap());
    assert_eq!(camera[6].parse::<f64>().unwrap(), (value - base) / base);

    let out = osmab(&["eval", "lightings", path(&dir), "--baseline", "sunny"]);
    assert!(String::from_utf8_lossy(&out.stderr).contains("no 'sunny' lighting"));
}

/// A small synthetic scene written by `osmab bench synth`.
fn synth(dir: &Path) {
    stdout(&osmab(&["bench", "synth", "--gt-points", "20000", "--map-points", "4000", "--objects", "12", "--feature-dim", "16", "--out", path(dir)]));
}

#[test]
fn eval_semseg_scores_a_map_and_writes_the_fixture_format() {
    let dir = tempfile::tempdir().unwrap();
    synth(dir.path());
    let json = dir.path().join("out.json");
    let out = osmab(&[
        "eval",
        "semseg",
        "--gt",
        path(&dir.path().join("gt")),
        "--map",
        path(&dir.path().join("map.npz")),
        "--text-features",
        path(&dir.path().join("text_features.npz")),
        "--json",
        path(&json),
    ]);
    let printed = stdout(&out);
    assert!(printed.contains("miou") && printed.contains("floor"), "{printed}");
    let result: serde_json::Value = serde_json::from_slice(&std::fs::read(&json).unwrap()).unwrap();
    let labels = result["labels"].as_array().unwrap();
    assert_eq!(labels.last().unwrap(), -1);
    let matrix = result["matrix"].as_array().unwrap();
    assert_eq!(matrix.len(), labels.len());
    let total: u64 = matrix.iter().flat_map(|r| r.as_array().unwrap()).map(|v| v.as_u64().unwrap()).sum();
    let classes = ClassList::read(&dir.path().join("gt/embed_semseg_classes.json")).unwrap();
    let gt = GroundTruth::read(&dir.path().join("gt"), &classes).unwrap();
    assert_eq!(total, gt.labels.iter().filter(|&&l| l != 0).count() as u64, "every scored ground-truth point is counted once");
    // The binary reports exactly what the library computes from the same files.
    let map = PredictedMap::read(&dir.path().join("map.npz"), ReadLimits::default()).unwrap();
    let text = TextFeatures::read(&dir.path().join("text_features.npz"), ReadLimits::default()).unwrap();
    let score = score_scene(&gt, &map, &classes, Some(&text)).unwrap();
    assert_eq!(result["labels"], serde_json::json!(score.confusion.labels()));
    assert_eq!(result["metrics"], serde_json::json!({"miou": score.metrics.miou, "fmiou": score.metrics.fmiou, "macc": score.metrics.macc}));
    assert!(score.metrics.miou > 0.0 && score.metrics.miou < 1.0, "a noisy map is neither perfect nor useless");
}

#[test]
fn eval_semseg_gives_one_for_the_ground_truth_itself() {
    let dir = tempfile::tempdir().unwrap();
    synth(dir.path());
    let classes = ClassList::read(&dir.path().join("gt/embed_semseg_classes.json")).unwrap();
    let gt = GroundTruth::read(&dir.path().join("gt"), &classes).unwrap();
    let ids: Vec<i64> = classes.entries().iter().map(|c| c.id).collect();
    let map = PredictedMap {
        source: dir.path().join("perfect.npz"),
        points: gt.points.clone(),
        semantics: MapSemantics::ObjectLabels { object_ids: gt.labels.iter().map(|l| ids.iter().position(|c| c == l).unwrap() as u32).collect(), labels: ids },
    };
    map.write(&dir.path().join("perfect.npz"), true).unwrap();
    let json = dir.path().join("perfect.json");
    stdout(&osmab(&["eval", "semseg", "--gt", path(&dir.path().join("gt")), "--map", path(&dir.path().join("perfect.npz")), "--json", path(&json)]));
    let result: serde_json::Value = serde_json::from_slice(&std::fs::read(&json).unwrap()).unwrap();
    assert_eq!(result["metrics"], serde_json::json!({"miou": 1.0, "fmiou": 1.0, "macc": 1.0}));
}

#[test]
fn eval_semseg_explains_what_is_missing() {
    let dir = tempfile::tempdir().unwrap();
    synth(dir.path());
    let out = osmab(&["eval", "semseg", "--gt", path(&dir.path().join("gt")), "--map", path(&dir.path().join("map.npz"))]);
    assert_eq!(out.status.code(), Some(1));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("map.npz") && err.contains("text features"), "{err}");

    let out = osmab(&["eval", "semseg", "--gt", path(&dir.path().join("nowhere")), "--map", path(&dir.path().join("map.npz"))]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("embed_semseg_classes.json") && err.contains("file not found"), "{err}");
}

#[test]
fn eval_semseg_reads_a_replica_style_semantic_mesh() {
    use osmab_evaluator::formats::ply::{SemanticMesh, write_semantic_mesh};
    let dir = tempfile::tempdir().unwrap();
    let gt = dir.path().join("replica");
    std::fs::create_dir_all(&gt).unwrap();
    // Two triangles of object 1 (class 3) and one of object 2 (class 5, far away).
    let mesh = SemanticMesh {
        vertices: vec![[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [1.0, 1.0, 0.0], [9.0, 9.0, 9.0], [9.5, 9.0, 9.0], [9.0, 9.5, 9.0]],
        face_vertices: vec![0, 1, 2, 1, 3, 2, 4, 5, 6],
        face_offsets: vec![0, 3, 6, 9],
        face_objects: vec![1, 1, 2],
    };
    write_semantic_mesh(&gt.join("mesh_semantic.ply"), &mesh).unwrap();
    std::fs::write(
        gt.join("info_semantic.json"),
        r#"{"classes": [{"id": 3, "name": "chair"}, {"id": 5, "name": "lamp"}], "objects": [{"id": 1, "class_id": 3}, {"id": 2, "class_id": 5}]}"#,
    )
    .unwrap();
    // A map that calls everything a chair: chair recall 1, lamp recall 0.
    let map = PredictedMap {
        source: dir.path().join("map.npz"),
        points: vec![[0.5, 0.5, 0.0], [9.2, 9.2, 9.0]],
        semantics: MapSemantics::ObjectLabels { object_ids: vec![0, 0], labels: vec![3] },
    };
    map.write(&dir.path().join("map.npz"), false).unwrap();
    let json = dir.path().join("out.json");
    stdout(&osmab(&["eval", "semseg", "--gt", path(&gt), "--map", path(&dir.path().join("map.npz")), "--json", path(&json)]));
    let result: serde_json::Value = serde_json::from_slice(&std::fs::read(&json).unwrap()).unwrap();
    assert_eq!(result["labels"], serde_json::json!([3, 5, -1]));
    assert_eq!(result["matrix"], serde_json::json!([[4, 0, 0], [3, 0, 0], [0, 0, 0]]));
    assert_eq!(result["metrics"]["macc"], 0.5);
}

/// An 11-frame sequence of 8×6 images in HaDaGe's layout (the last frame, 10, lies on
/// the stride and must still be left out).
fn write_sequence(dir: &Path) {
    std::fs::create_dir_all(dir.join("results")).unwrap();
    CameraParams::from_hfov(8, 6, 90.0, 6553.5).write(&dir.join("camera_params.yaml")).unwrap();
    std::fs::write(
        dir.join("embed_semseg_classes.json"),
        r#"{"classes": [{"name": "other", "id": 0}, {"name": "chair", "id": 3}, {"name": "table", "id": 5}]}"#,
    )
    .unwrap();
    let poses = (0..11).map(|f| nalgebra::Matrix4::new_translation(&nalgebra::Vector3::new(0.1 * f as f64, 1.0, 0.0))).collect();
    Trajectory { poses }.write(&dir.join("traj.txt")).unwrap();
    for f in 0..11 {
        let depth = GrayImage16 { width: 8, height: 6, pixels: (0..48).map(|i| if i % 7 == 0 { 0 } else { 6553 + i as u16 }).collect() };
        write_png_gray16(&frame_path(dir, "depth", f), &depth).unwrap();
        let semantic = GrayImage16 { width: 8, height: 6, pixels: (0..48).map(|i| [0, 3, 5][i % 3]).collect() };
        write_png_gray16(&frame_path(dir, "semantic", f), &semantic).unwrap();
        write_jpeg_rgb(&frame_path(dir, "frame", f), &RgbImage { width: 8, height: 6, pixels: vec![200; 144] }, 90).unwrap();
    }
}

#[test]
fn gt_build_writes_a_cloud_that_eval_semseg_reads() {
    let dir = tempfile::tempdir().unwrap();
    let sequence = dir.path().join("seq");
    write_sequence(&sequence);
    let gt_dir = dir.path().join("gt");
    let printed = stdout(&osmab(&["gt", "build", path(&sequence), "--out", path(&gt_dir)]));
    // Frames 0 and 5 (frame 10 is the last and excluded), 41 valid pixels each, every 10th point.
    assert!(printed.contains("9 points from 11 frames"), "{printed}");
    let classes = ClassList::read(&gt_dir.join("embed_semseg_classes.json")).unwrap();
    let gt = GroundTruth::read(&gt_dir, &classes).unwrap();
    assert_eq!(gt.points.len(), 9);
    assert!(gt.labels.iter().all(|l| [0, 3, 5].contains(l)));

    let out = osmab(&["gt", "build", path(&dir.path().join("absent")), "--out", path(&gt_dir)]);
    assert!(String::from_utf8_lossy(&out.stderr).contains("camera_params.yaml"), "the missing file is named");
}

#[test]
fn bench_submission_scores_a_generated_submission_stage_by_stage() {
    // A tiny whole submission (2 scenes × 4 lightings): generated once, then scored from
    // its archive with a line for every stage; a second run reuses the data.
    let dir = tempfile::tempdir().unwrap();
    let args = ["bench", "submission", "--data", path(dir.path()), "--scenes", "2", "--gt-points", "30000", "--map-points", "3000", "--objects", "8"];
    let first = stdout(&osmab(&args));
    assert!(first.starts_with("generated "), "{first}");
    assert!(first.contains("run 0: 8 maps, 0 M ground-truth points associated"), "{first}");
    for stage in ["unpack the archive", "validate every file", "associate ground-truth points", "VQA: answer and judge", "whole submission"] {
        assert!(first.lines().any(|l| l.contains(stage) && l.trim_end().ends_with(" s")), "{stage}:\n{first}");
    }
    let scores = |out: &str| out.lines().find(|l| l.starts_with("run 0")).map(str::to_string).unwrap();
    let second = stdout(&osmab(&args));
    assert!(!second.contains("generated "), "the data is reused:\n{second}");
    assert_eq!(scores(&second), scores(&first), "the same submission scores the same");
    assert!(dir.path().join("submission.tar").is_file() && dir.path().join("release/ground_truth/scene_001/semantic.npy").is_file());
    assert!(scores(&first).ends_with("0 of 2 scenes' ground truth from the cache"), "{first}");
    // On a node made ready first, as an idle worker makes it, the first run reads every
    // scene's ground truth prepared, and scores the same.
    let warmed = stdout(&osmab(&[&args[..], &["--warm-node"]].concat()));
    assert!(warmed.contains("node made ready before any submission, as an idle worker does: 2 of 2 scenes' ground truth prepared in "), "{warmed}");
    assert!(scores(&warmed).ends_with("2 of 2 scenes' ground truth from the cache"), "{warmed}");
    let without_cache_note = |line: String| line.rsplit_once("; ").unwrap().0.to_string();
    assert_eq!(without_cache_note(scores(&warmed)), without_cache_note(scores(&first)));
}

#[test]
fn a_command_whose_reader_went_away_stops_quietly() {
    // `osmab eval metrics DIR | head -0`: the pipe's reading end is closed before it prints.
    let dir = fixtures().join("osmabench-v1/semseg-confusion/openscene/replica_cad/camera_lights");
    let (reader, writer) = std::io::pipe().unwrap();
    drop(reader);
    let out = Command::new(env!("CARGO_BIN_EXE_osmab")).args(["eval", "metrics", path(&dir)]).stdout(writer).output().unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(!stderr.contains("panicked") && stderr.is_empty(), "no panic message: {stderr}");
    assert_eq!(out.status.code(), Some(141), "the status of a tool stopped by SIGPIPE");
}
