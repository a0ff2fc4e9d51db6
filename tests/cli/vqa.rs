//! `osmab eval vqa` on the published OSMa-Bench judgements: every verdict the reference
//! decided locally is reproduced, recorded verdicts are kept for the rest, and the
//! metrics rows are the accuracies counted from the files.

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

use serde_json::Value;

use super::{fixtures, osmab, path, stdout};

fn published() -> PathBuf {
    fixtures().join("osmabench-v1/vqa-evaluated")
}

fn json_files(dir: &Path) -> Vec<PathBuf> {
    let mut out = Vec::new();
    for entry in std::fs::read_dir(dir).unwrap() {
        let p = entry.unwrap().path();
        if p.is_dir() {
            out.extend(json_files(&p));
        } else if p.extension().is_some_and(|e| e == "json") {
            out.push(p);
        }
    }
    out.sort();
    out
}

fn entries(file: &Path) -> Vec<Value> {
    serde_json::from_slice::<Value>(&std::fs::read(file).unwrap()).unwrap().as_array().unwrap().clone()
}

/// Python's `f"{x:.2%}"` of a count ratio.
fn pct(right: usize, total: usize) -> String {
    format!("{:.2}%", if total == 0 { 0.0 } else { right as f64 / total as f64 } * 100.0)
}

#[test]
fn with_recorded_verdicts_kept_the_rows_are_the_counted_accuracies() {
    let dir = published().join("conceptgraphs/replica_cad");
    let csv = stdout(&osmab(&["eval", "vqa", path(&dir)]));
    let mut lines = csv.split("\r\n").filter(|l| !l.is_empty());
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    assert_eq!(&header[..3], ["File Name", "Overall Accuracy", "Accuracy (No Spatial)"]);
    let categories = &header[3..];
    let mut sorted = categories.to_vec();
    sorted.sort();
    assert_eq!(categories, sorted.as_slice(), "category columns are sorted");
    assert_eq!(categories.len(), 8);
    let rows: BTreeMap<String, Vec<String>> = lines.map(|l| l.split(',').map(str::to_string).collect::<Vec<_>>()).map(|r| (r[0].clone(), r)).collect();
    let files = json_files(&dir);
    assert_eq!(rows.len(), files.len());
    for file in files {
        let items = entries(&file);
        let right = |f: &dyn Fn(&Value) -> bool| items.iter().filter(|e| f(e) && e["similar"].as_str().unwrap().eq_ignore_ascii_case("yes")).count();
        let total = |f: &dyn Fn(&Value) -> bool| items.iter().filter(|e| f(e)).count();
        let mut want = vec![file.file_name().unwrap().to_str().unwrap().to_string()];
        want.push(pct(right(&|_| true), total(&|_| true)));
        let not_spatial = |e: &Value| e["category"] != "Object Relations - Spatial";
        want.push(pct(right(&not_spatial), total(&not_spatial)));
        for category in categories {
            let of = |e: &Value| e["category"] == *category;
            want.push(pct(right(&of), total(&of)));
        }
        assert_eq!(rows[&want[0]], want);
    }
}

#[test]
fn with_recorded_verdicts_removed_every_local_verdict_is_reproduced() {
    let stripped = tempfile::tempdir().unwrap();
    for file in json_files(&published()) {
        let relative = file.strip_prefix(published()).unwrap();
        let mut items = entries(&file);
        for item in &mut items {
            item.as_object_mut().unwrap().remove("similar");
        }
        let target = stripped.path().join(relative);
        std::fs::create_dir_all(target.parent().unwrap()).unwrap();
        std::fs::write(&target, serde_json::to_vec(&items).unwrap()).unwrap();
    }
    let judged = tempfile::tempdir().unwrap();
    let out = osmab(&["eval", "vqa", path(stripped.path()), "--judged-out", path(judged.path())]);
    let csv = stdout(&out);
    assert_eq!(csv.split("\r\n").filter(|l| !l.is_empty()).count(), 221, "a header and 220 rows");

    let is_number = |s: &str| {
        let (whole, fraction) = s.split_once('.').map_or((s, None), |(w, f)| (w, Some(f)));
        !whole.is_empty() && whole.bytes().all(|b| b.is_ascii_digit()) && fraction.is_none_or(|f| !f.is_empty() && f.bytes().all(|b| b.is_ascii_digit()))
    };
    let (mut local, mut undecided) = (0, 0);
    let mut by_kinds = BTreeSet::new();
    for file in json_files(&published()) {
        let original = entries(&file);
        let written = entries(&judged.path().join(file.strip_prefix(published()).unwrap()));
        assert_eq!(original.len(), written.len(), "{}", file.display());
        for (before, after) in original.iter().zip(&written) {
            assert_eq!(before["question"], after["question"], "entries keep their order");
            let gt = before["answer"].as_str().unwrap().trim().to_lowercase();
            let pred = before["scene_graph_answer"].as_str().unwrap().trim().to_lowercase();
            let decidable = (["yes", "no"].contains(&gt.as_str()) && ["yes", "no"].contains(&pred.as_str())) || (is_number(&gt) && is_number(&pred));
            by_kinds.insert(after["judged_by"].as_str().unwrap().to_string());
            if decidable {
                local += 1;
                assert_eq!(after["judged_by"], "local");
                assert_eq!(after["similar"], before["similar"], "{}: {}", file.display(), before["question"]);
            } else {
                undecided += 1;
                assert_eq!((after["judged_by"].as_str(), after["similar"].as_str()), (Some("none"), Some("N/A")));
            }
        }
    }
    assert_eq!((local, undecided), (23_413, 17_137));
    assert_eq!(by_kinds, BTreeSet::from(["local".to_string(), "none".to_string()]));
}

#[test]
fn malformed_answer_files_are_refused_with_file_and_entry() {
    let dir = tempfile::tempdir().unwrap();
    for (name, body, expected) in [
        ("object.json", r#"{"question": "q"}"#, "expected a list"),
        ("missing.json", r#"[{"question": "q", "answer": "Yes"}, {"question": "q2"}]"#, "[1].answer"),
        ("broken.json", r#"[{"question": "#, "not valid JSON"),
    ] {
        let file = dir.path().join(name);
        std::fs::write(&file, body).unwrap();
        let out = osmab(&["eval", "vqa", path(&file)]);
        assert!(!out.status.success());
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert!(stderr.contains(name) && stderr.contains(expected), "{stderr}");
    }
}
