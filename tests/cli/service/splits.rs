//! A release with a hidden test split, end to end: its public files rebuild the val
//! ground truth but not the test one (no semantic frames, no answers, and the published
//! config without the operator's secret builds other test rooms); a submission goes to one
//! split, is scored on that split's scenes and ranked on that split's board; quotas are
//! counted per split and window, and an administrator sets them.

use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};
use std::sync::OnceLock;

use serde_json::{Value, json};

use super::client::client;
use super::{Backend, Deployment, TEST_RELEASE_CONFIG, baseline_dir_of, on_both_backends, problem, tar_of};

/// The operator's secret the split release is built with.
const SPLIT_SECRET: &str = "e2e-split-secret-0123456789";

/// The test release's config with its manipuland scene held out as the test split.
fn split_config() -> String {
    TEST_RELEASE_CONFIG.replace("version = \"e2e-1\"", "version = \"e2e-split-1\"") + "\n[splits]\ntest_manipuland = 1\n"
}

fn build(config: &Path, out: &Path, secret: Option<&str>) -> Output {
    let mut command = Command::new(env!("CARGO_BIN_EXE_osmab"));
    command.args(["release", "build", "--config", crate::path(config), "--out", crate::path(out)]).env_remove("OSMAB_SPLIT_SECRET").stdout(Stdio::null());
    if let Some(secret) = secret {
        command.env("OSMAB_SPLIT_SECRET", secret);
    }
    command.output().unwrap()
}

/// The split release (scene_000 val, scene_001 test), built once per test run.
fn split_release() -> &'static Path {
    static RELEASE: OnceLock<PathBuf> = OnceLock::new();
    RELEASE.get_or_init(|| {
        let root = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("e2e-split-release");
        std::fs::create_dir_all(&root).unwrap();
        let config = root.join("config.toml");
        std::fs::write(&config, split_config()).unwrap();
        let out = root.join("release");
        let built = build(&config, &out, Some(SPLIT_SECRET));
        assert!(built.status.success(), "the split release builds: {}", String::from_utf8_lossy(&built.stderr));
        out
    })
}

fn said(out: &Output) -> String {
    format!("{}{}", String::from_utf8_lossy(&out.stdout), String::from_utf8_lossy(&out.stderr))
}

fn a_test_split_keeps_its_ground_truth_on_the_server(backend: Backend) {
    let deployment = Deployment::new(backend, &[("OSMAB_DAILY_QUOTA", "1"), ("OSMAB_VAL_QUOTA", "3")]);
    let server = deployment.serve();
    let request = server.post("/api/v1/admin/releases/import").timeout(std::time::Duration::from_secs(600));
    let imported = server.admin(request.json(&json!({"path": split_release(), "publish": true})));
    assert_eq!(imported.status(), 201, "{}", imported.text().unwrap());
    let version = "e2e-split-1";

    // The manifest: each scene's split; no semantic frame and no ground truth of the test scene.
    let manifest: Value = server.get(&format!("/api/v1/releases/{version}/manifest.json")).send().unwrap().json().unwrap();
    let splits: Vec<(&str, &str)> = manifest["scenes"].as_array().unwrap().iter().map(|s| (s["id"].as_str().unwrap(), s["split"].as_str().unwrap())).collect();
    assert_eq!(splits, [("scene_000", "val"), ("scene_001", "test")]);
    let files: Vec<&str> = manifest["files"].as_array().unwrap().iter().map(|f| f["path"].as_str().unwrap()).collect();
    assert!(files.iter().any(|f| f.starts_with("sequences/baseline/scene_001/results/depth")), "test scenes keep their RGB-D frames");
    assert!(!files.iter().any(|f| f.contains("scene_001/results/semantic")), "no semantic frame of the test scene is public");
    assert!(files.contains(&"ground_truth/scene_000/semantic.npy") && files.contains(&"ground_truth/questions/scene_000.json"), "val ground truth is public");
    assert!(!files.iter().any(|f| f.starts_with("ground_truth/") && f.contains("scene_001")), "test ground truth is not");
    for hidden in ["ground_truth/scene_001/semantic.npy", "ground_truth/questions/scene_001.json", "sequences/baseline/scene_001/results/semantic000000.png"] {
        let response = server.get(&format!("/api/v1/releases/{version}/files/{hidden}")).send().unwrap();
        assert_eq!(response.status(), 404, "{hidden} is not served");
    }
    let quality: Value = server.get(&format!("/api/v1/releases/{version}/files/quality/quality_report.json")).send().unwrap().json().unwrap();
    let test_scene = quality["per_scene"].as_array().unwrap().iter().find(|s| s["scene"] == "scene_001").unwrap();
    assert!(test_scene.get("class_pixels").is_none() && test_scene.get("instances").is_none() && test_scene.get("oracle_vqa").is_none(), "{test_scene}");
    let questions: Value = server.get(&format!("/api/v1/releases/{version}/files/questions/scene_001.json")).send().unwrap().json().unwrap();
    assert!(!questions.to_string().contains("\"answer\""), "test questions carry no answers");

    // A team downloads the public release: `osmab gt build` rebuilds val, not test.
    let token = server.team("Team Split");
    let home = tempfile::tempdir().unwrap();
    let config = home.path().join("client.toml");
    assert!(client(&config, &["login", "--url", &server.url, "--token", &token]).status.success());
    let public = tempfile::tempdir().unwrap();
    let download = client(&config, &["download", "--out", crate::path(public.path())]);
    assert!(download.status.success(), "{}", said(&download));
    let gt = tempfile::tempdir().unwrap();
    let test_gt = crate::osmab(&["gt", "build", crate::path(&public.path().join("sequences/baseline/scene_001")), "--out", crate::path(gt.path())]);
    assert!(!test_gt.status.success() && said(&test_gt).contains("no semantic frames"), "{}", said(&test_gt));
    assert!(!gt.path().join("semantic.npy").exists(), "nothing was written");
    let val_gt = crate::osmab(&["gt", "build", crate::path(&public.path().join("sequences/baseline/scene_000")), "--out", crate::path(gt.path())]);
    assert!(val_gt.status.success(), "{}", said(&val_gt));
    assert_eq!(std::fs::read(gt.path().join("semantic.npy")).unwrap(), std::fs::read(public.path().join("ground_truth/scene_000/semantic.npy")).unwrap());
    // The oracle anyone can make from the public files covers val only.
    let public_oracle = baseline_dir_of(public.path(), "oracle");
    assert!(public_oracle.path().join("maps/baseline/scene_000.npz").is_file() && !public_oracle.path().join("maps/baseline/scene_001.npz").exists());

    if backend == Backend::Sqlite {
        // The published config, rebuilt without the secret, is refused; with another secret
        // it builds the same val scene and another test room.
        let rebuild = tempfile::tempdir().unwrap();
        let published = rebuild.path().join("published.toml");
        std::fs::write(&published, manifest["generator"]["config"].as_str().unwrap()).unwrap();
        let refused = build(&published, &rebuild.path().join("none"), None);
        assert!(!refused.status.success() && said(&refused).contains("OSMAB_SPLIT_SECRET"), "{}", said(&refused));
        let guess = rebuild.path().join("guess");
        assert!(build(&published, &guess, Some("a-guess-at-the-secret-1234")).status.success());
        let depth = |root: &Path, scene: &str| std::fs::read(root.join(format!("sequences/baseline/{scene}/traj.txt"))).unwrap();
        assert_eq!(depth(&guess, "scene_000"), depth(public.path(), "scene_000"), "the val scene is rebuilt exactly");
        assert_ne!(depth(&guess, "scene_001"), depth(public.path(), "scene_001"), "the test scene is not");
    }

    // Quotas, shown before uploading: test is the default split.
    let quota: Value = server.get("/api/v1/quota").bearer_auth(&token).send().unwrap().json().unwrap();
    assert_eq!(quota["default_split"], "test");
    let limits: Vec<(&str, i64, i64)> = quota["splits"]
        .as_array()
        .unwrap()
        .iter()
        .map(|q| (q["split"].as_str().unwrap(), q["limit"].as_i64().unwrap(), q["remaining"].as_i64().unwrap()))
        .collect();
    assert_eq!(limits, [("test", 1, 1), ("val", 3, 3)]);

    // Offline: the server's own validation for test, and the val split scored locally.
    let oracle = baseline_dir_of(split_release(), "oracle");
    let offline = client(&config, &["validate", crate::path(oracle.path()), "--release-dir", crate::path(public.path())]);
    let text = said(&offline);
    assert!(offline.status.success() && text.contains("Valid for the test split") && text.contains("Scored the val split"), "{text}");
    assert!(text.contains("baseline: pooled mIoU 100.0") && text.contains("test split's ground truth is hidden"), "{text}");

    // One archive to each split: two submissions, each scored on its split's scenes.
    let archive = tar_of(oracle.path());
    let to_val = server.upload(&token, &archive, "?split=val");
    assert_eq!(to_val.status(), 202);
    let to_val: Value = to_val.json().unwrap();
    assert_eq!((to_val["split"].as_str(), to_val["quota"]["remaining"].as_i64()), (Some("val"), Some(2)), "{to_val}");
    let to_test = server.upload(&token, &archive, "");
    assert_eq!(to_test.status(), 202, "the same archive to the other split is a new submission");
    let to_test: Value = to_test.json().unwrap();
    assert_eq!((to_test["split"].as_str(), to_test["quota"]["remaining"].as_i64()), (Some("test"), Some(0)), "{to_test}");
    for (answer, scene) in [(&to_val, "scene_000"), (&to_test, "scene_001")] {
        let done = server.wait_done(answer["id"].as_str().unwrap(), &token);
        assert_eq!(done["state"], "scored", "{done}");
        let scenes: Vec<&String> = done["scores"]["semseg"]["baseline"]["scenes"].as_object().unwrap().keys().collect();
        assert_eq!(scenes, [scene], "scored on its split's scenes only");
        assert_eq!((done["split"].as_str(), done["scores"]["split"].as_str()), (answer["split"].as_str(), answer["split"].as_str()));
        // Per question, the answer given and whether it was right (and per scene, how many):
        // shown for val, never for test (the oracle's results document would list the
        // hidden answers), public or not; the pooled accuracies are there for both.
        let id = answer["id"].as_str().unwrap();
        let results: Value = server.get(&format!("/api/v1/submissions/{id}/results.json")).send().unwrap().json().unwrap();
        for document in [&done["scores"], &results] {
            assert!(document["vqa"]["lightings"]["baseline"]["overall"]["total"].as_u64().unwrap() > 0, "{}", document["vqa"]);
            let listed = document["vqa"]["scenes"]["baseline"][scene]["answers"].as_array().map_or(0, Vec::len);
            assert_eq!(listed > 0, scene == "scene_000", "{scene}: {listed} answers listed");
            assert_eq!(document["vqa"].get("scenes").is_some(), scene == "scene_000");
        }
    }

    // The test quota is used: refused with problem+json and Retry-After; dry runs stay free.
    let other = tar_of(baseline_dir_of(split_release(), "label-noise").path());
    let refused = server.upload(&token, &other, "?split=test");
    let retry: u64 = refused.headers()["retry-after"].to_str().unwrap().parse().unwrap();
    assert!((82_000..=86_401).contains(&retry), "{retry}");
    let body = problem(refused, 429, "quota_exceeded");
    assert!(body["detail"].as_str().unwrap().contains("test split") && body["quota"]["split"] == "test", "{body}");
    assert_eq!(server.upload(&token, &other, "?split=val").status(), 202, "val has its own quota");
    let dry: Value = server.upload(&token, &other, "?split=test&dry_run=true").json().unwrap();
    assert_eq!((dry["valid"].as_bool(), dry["split"].as_str()), (Some(true), Some("test")));

    // An administrator sets the test split's policy.
    let policy = |split: &str, body: Value| server.admin(server.client.put(format!("{}/api/v1/admin/quotas/{split}", server.url)).json(&body));
    problem(policy("test", json!({"limit": 2, "window_hours": 0})), 422, "invalid_request");
    problem(policy("holdout", json!({"limit": 2, "window_hours": 1})), 404, "not_found");
    let set: Value = policy("test", json!({"limit": 2, "window_hours": 1})).json().unwrap();
    assert_eq!((set["limit"].as_i64(), set["window_hours"].as_i64(), set["set"].as_bool()), (Some(2), Some(1), Some(true)));
    let accepted = server.upload(&token, &other, "?split=test");
    assert_eq!(accepted.status(), 202, "the raised limit admits one more");
    let id = accepted.json::<Value>().unwrap()["id"].as_str().unwrap().to_string();
    server.wait_done(&id, &token);

    // Two boards: test (the default) and val, each ranking its own submissions.
    let board = |query: &str| -> Value { server.get(&format!("/api/v1/leaderboard{query}")).send().unwrap().json().unwrap() };
    let test_board = board("");
    assert_eq!((test_board["split"].as_str(), test_board["splits"].clone()), (Some("test"), json!(["test", "val"])));
    let ids = |b: &Value| -> Vec<String> { b["entries"].as_array().unwrap().iter().map(|e| e["submission_id"].as_str().unwrap().to_string()).collect() };
    assert_eq!(ids(&test_board).len(), 2, "{test_board}");
    assert!(ids(&test_board).contains(&to_test["id"].as_str().unwrap().to_string()) && !ids(&test_board).contains(&to_val["id"].as_str().unwrap().to_string()));
    let val_board = board("?split=val");
    assert_eq!(val_board["split"], "val");
    assert!(ids(&val_board).contains(&to_val["id"].as_str().unwrap().to_string()) && !ids(&val_board).contains(&to_test["id"].as_str().unwrap().to_string()));
    let csv = server.get("/api/v1/leaderboard.csv?split=val").send().unwrap();
    assert!(csv.headers()["content-disposition"].to_str().unwrap().contains("leaderboard-e2e-split-1-val.csv"));
    let page = server.get("/?split=val").send().unwrap().text().unwrap();
    assert!(page.contains("data-split=\"val\"") && page.contains("Validation split") && page.contains("split=test"), "the page links the other board");
    let page = server.get("/").send().unwrap().text().unwrap();
    assert!(page.contains("data-split=\"test\""));
}

on_both_backends!(a_test_split_release_hides_its_ground_truth_and_ranks_each_split_apart, super::a_test_split_keeps_its_ground_truth_on_the_server);
