//! The reference mapper (`osmab baseline perceive`): it maps from what a team downloads
//! and nothing else, writes the same bytes every time, and is the reference entry of the
//! boards of a release built with its reference entries, beside the controls made from
//! the ground truth.

use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::{Duration, Instant};

use serde_json::{Value, json};

use super::splits::{TEST_SCENES, VAL_SCENE, split_release};
use super::{Backend, Deployment, TEST_RELEASE_CONFIG};

fn perceive(release: &Path, out: &Path) -> String {
    let run = Command::new(env!("CARGO_BIN_EXE_osmab"))
        .args(["baseline", "perceive", "--release", crate::path(release), "--out", crate::path(out)])
        .output()
        .unwrap();
    assert!(run.status.success(), "{}", String::from_utf8_lossy(&run.stderr));
    String::from_utf8_lossy(&run.stdout).into_owned()
}

/// Every file under `dir`, by its path inside it, with its bytes.
fn files_of(dir: &Path) -> Vec<(PathBuf, Vec<u8>)> {
    let mut files = Vec::new();
    let mut folders = vec![PathBuf::new()];
    while let Some(folder) = folders.pop() {
        for entry in std::fs::read_dir(dir.join(&folder)).unwrap() {
            let relative = folder.join(entry.unwrap().file_name());
            if dir.join(&relative).is_dir() {
                folders.push(relative);
            } else {
                files.push((relative.clone(), std::fs::read(dir.join(&relative)).unwrap()));
            }
        }
    }
    files.sort();
    files
}

/// A team's copy of `release`: the manifest and the files it lists, nothing else.
fn public_copy(release: &Path) -> tempfile::TempDir {
    let copy = tempfile::tempdir().unwrap();
    let manifest: Value = serde_json::from_slice(&std::fs::read(release.join("manifest.json")).unwrap()).unwrap();
    std::fs::copy(release.join("manifest.json"), copy.path().join("manifest.json")).unwrap();
    for file in manifest["files"].as_array().unwrap() {
        let path = file["path"].as_str().unwrap();
        let target = copy.path().join(path);
        std::fs::create_dir_all(target.parent().unwrap()).unwrap();
        std::fs::copy(release.join(path), target).unwrap();
    }
    copy
}

#[test]
fn the_reference_mapper_reads_only_what_a_team_downloads_and_writes_the_same_bytes() {
    let release = split_release();
    let team_copy = public_copy(release);
    for scene in TEST_SCENES {
        let results = team_copy.path().join("sequences/baseline").join(scene).join("results");
        assert!(std::fs::read_dir(&results).unwrap().all(|f| !f.unwrap().file_name().to_string_lossy().starts_with("semantic")), "{scene}: no semantics");
    }
    assert!(!team_copy.path().join("ground_truth").join(TEST_SCENES[0]).exists());
    assert!(team_copy.path().join("sequences/baseline").join(VAL_SCENE).join("results/semantic000000.png").is_file(), "val semantics are public");

    let (on_server_copy, on_team_copy) = (tempfile::tempdir().unwrap(), tempfile::tempdir().unwrap());
    let said = perceive(release, on_server_copy.path());
    assert!(said.contains("baseline-perceive with 24 maps"), "six scenes under four lightings: {said}");
    perceive(team_copy.path(), on_team_copy.path());
    let (a, b) = (files_of(on_server_copy.path()), files_of(on_team_copy.path()));
    assert_eq!(a.len(), 1 + 24 + 24, "submission.json, a map and a scene graph per scene and lighting");
    assert!(a == b, "the same bytes from the service's copy (with the test split's semantics) and from a team's copy");

    // A submission as a team's: valid for both splits, every scene and lighting covered; the
    // whole score documents written where asked (the release folder has both splits' ground truth).
    let documents = tempfile::tempdir().unwrap();
    for split in ["test", "val"] {
        let out = Command::new(env!("CARGO_BIN_EXE_osmab"))
            .args(["client", "validate", crate::path(on_team_copy.path()), "--release-dir", crate::path(release), "--split", split])
            .args(["--scores-out", crate::path(documents.path())])
            .output()
            .unwrap();
        let said = String::from_utf8_lossy(&out.stdout);
        assert!(out.status.success() && said.contains("every scene and lighting covered"), "{split}: {said}{}", String::from_utf8_lossy(&out.stderr));
        assert!(said.contains("camera against baseline: pooled mIoU") && said.contains("(95 %:"), "each lighting's change with its interval: {said}");
    }
    let val: Value = serde_json::from_slice(&std::fs::read(documents.path().join("scores-val.json")).unwrap()).unwrap();
    assert!(val["semseg"]["baseline"]["scenes"][VAL_SCENE]["miou"].is_number(), "per-scene rows in the whole document: {val}");
    assert!(val["vqa"]["lightings"]["baseline"]["standard"]["categories"].as_object().is_some_and(|c| !c.is_empty()), "VQA categories: {val}");
    let card: Value = serde_json::from_slice(&std::fs::read(on_team_copy.path().join("submission.json")).unwrap()).unwrap();
    assert_eq!(card["release"], "e2e-split-1");
    assert_eq!(card["method"]["name"], "baseline-perceive");
    let graph: Value = serde_json::from_slice(&std::fs::read(on_team_copy.path().join("graphs/camera").join(format!("{VAL_SCENE}.json"))).unwrap()).unwrap();
    let nodes = graph["objects"].as_array().unwrap();
    assert!(!nodes.is_empty() && nodes.iter().all(|n| n["label"].is_string() && n["bbox_extent"].as_array().unwrap().len() == 3), "{graph}");
}

#[test]
fn the_reference_mapper_without_a_val_scene_to_learn_from_says_so() {
    let release = split_release();
    let copy = public_copy(release);
    let manifest_path = copy.path().join("manifest.json");
    let mut manifest: Value = serde_json::from_slice(&std::fs::read(&manifest_path).unwrap()).unwrap();
    for scene in manifest["scenes"].as_array_mut().unwrap() {
        scene["split"] = json!("test");
    }
    std::fs::write(&manifest_path, serde_json::to_vec(&manifest).unwrap()).unwrap();
    let out = tempfile::tempdir().unwrap();
    let run = Command::new(env!("CARGO_BIN_EXE_osmab"))
        .args(["baseline", "perceive", "--release", crate::path(copy.path()), "--out", crate::path(out.path())])
        .output()
        .unwrap();
    let said = String::from_utf8_lossy(&run.stderr);
    assert!(!run.status.success() && said.contains("manifest.json") && said.contains("no val scene to learn from"), "{said}");
}

#[test]
fn a_release_built_with_its_reference_entries_ranks_the_mapper_as_the_reference_and_the_ground_truth_ones_as_controls() {
    let deployment = Deployment::new(Backend::Sqlite, &[("OSMAB_POLL_MS", "20")]);
    let server = deployment.serve();
    let config = TEST_RELEASE_CONFIG.replace("version = \"e2e-1\"", "version = \"ref-1\"");
    let response = server.admin(server.post("/api/v1/admin/releases").json(&json!({"config": config, "publish": true, "baselines": true})));
    assert_eq!(response.status(), 202, "{}", response.text().unwrap());
    let started = Instant::now();
    let board = loop {
        let board: Value = server.get("/api/v1/leaderboard?release=ref-1").send().unwrap().json().unwrap();
        if board["entries"].as_array().is_some_and(|e| e.len() == 6) {
            break board;
        }
        assert!(started.elapsed() < Duration::from_secs(600), "the reference entries were not all scored: {board}\n{}", deployment.log("serve"));
        std::thread::sleep(Duration::from_millis(200));
    };
    let entries = board["entries"].as_array().unwrap();
    let methods: Vec<(&str, bool, bool)> =
        entries.iter().map(|e| (e["method"].as_str().unwrap(), e["baseline"].as_bool().unwrap(), e["reference"].as_bool().unwrap())).collect();
    let mapper = entries.iter().find(|e| e["method"] == "baseline-perceive").unwrap_or_else(|| panic!("{methods:?}"));
    assert_eq!((mapper["baseline"].as_bool(), mapper["reference"].as_bool(), mapper["complete"].as_bool()), (Some(true), Some(true), Some(true)));
    assert!(methods.iter().filter(|m| m.0 != "baseline-perceive").all(|m| m.1 && !m.2), "every other entry is a control: {methods:?}");
    let miou = |e: &Value, lighting: &str| e["scores"]["semseg"][lighting]["overall"]["miou"].as_f64().unwrap();
    assert!(miou(mapper, "baseline") > 0.2 && miou(mapper, "baseline") < 1.0, "it sees, and is no oracle: {mapper}");

    let page = server.get("/?release=ref-1").send().unwrap().text().unwrap();
    let row_of =
        |method: &str| page.split("<tr").find(|row| row.contains(&format!(">{method}</a>"))).unwrap_or_else(|| panic!("{method} on the page")).to_string();
    assert!(row_of("baseline-perceive").contains(">reference</span>"), "{}", row_of("baseline-perceive"));
    assert!(row_of("baseline-oracle").contains(">control</span>"), "{}", row_of("baseline-oracle"));
    let chart = &page[page.find("Robustness to lighting").expect("the robustness chart")..];
    let chart = &chart[..chart.find("</figure>").unwrap()];
    assert!(chart.contains("baseline-perceive") && !chart.contains("baseline-oracle"), "controls are kept out of the chart: {chart}");
}
