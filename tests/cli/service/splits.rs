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

/// The test release's config grown to six scenes, five of them held out as the test split
/// (the fewest a test score's numbers may pool): scene_001 is val, the others test.
fn split_config() -> String {
    TEST_RELEASE_CONFIG
        .replace("version = \"e2e-1\"", "version = \"e2e-split-1\"")
        .replace("furniture_pool = 12", "furniture_pool = 24")
        .replace("manipuland_pool = 8", "manipuland_pool = 16")
        .replace("furniture = 1\nmanipuland = 1", "furniture = 4\nmanipuland = 2")
        + "\n[splits]\ntest_furniture = 3\ntest_manipuland = 2\n"
}

/// The scenes of the split release: the val one, and the test ones.
pub(super) const VAL_SCENE: &str = "scene_001";
pub(super) const TEST_SCENES: [&str; 5] = ["scene_000", "scene_002", "scene_003", "scene_004", "scene_005"];

fn build(config: &Path, out: &Path, secret: Option<&str>) -> Output {
    let mut command = Command::new(env!("CARGO_BIN_EXE_osmab"));
    command.args(["release", "build", "--config", crate::path(config), "--out", crate::path(out)]).env_remove("OSMAB_SPLIT_SECRET").stdout(Stdio::null());
    if let Some(secret) = secret {
        command.env("OSMAB_SPLIT_SECRET", secret);
    }
    command.output().unwrap()
}

/// The split release (see [`split_config`]), built once per test run.
pub(super) fn split_release() -> &'static Path {
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

    // The manifest: each scene's split; no semantic frame, ground truth, prompt or question of a test scene.
    let manifest: Value = server.get(&format!("/api/v1/releases/{version}/manifest.json")).send().unwrap().json().unwrap();
    let splits: Vec<(&str, &str)> = manifest["scenes"].as_array().unwrap().iter().map(|s| (s["id"].as_str().unwrap(), s["split"].as_str().unwrap())).collect();
    let expected: Vec<(&str, &str)> = ["scene_000", "scene_001", "scene_002", "scene_003", "scene_004", "scene_005"]
        .iter()
        .map(|s| (*s, if *s == VAL_SCENE { "val" } else { "test" }))
        .collect();
    assert_eq!(splits, expected);
    for scene in manifest["scenes"].as_array().unwrap() {
        let open = scene["id"] == VAL_SCENE;
        assert_eq!((scene.get("prompt").is_some(), scene.get("questions").is_some()), (open, open), "{scene}: a test scene's prompt tells its answers");
    }
    let files: Vec<&str> = manifest["files"].as_array().unwrap().iter().map(|f| f["path"].as_str().unwrap()).collect();
    let test = TEST_SCENES[0];
    assert!(files.iter().any(|f| f.starts_with(&format!("sequences/baseline/{test}/results/depth"))), "test scenes keep their RGB-D frames");
    for test in TEST_SCENES {
        assert!(!files.iter().any(|f| f.contains(&format!("{test}/results/semantic"))), "no semantic frame of {test} is public");
        assert!(
            !files.iter().any(|f| f.contains(test) && (f.starts_with("ground_truth/") || f.starts_with("scenes/") || f.starts_with("questions/"))),
            "{test}"
        );
    }
    assert!(files.contains(&"ground_truth/scene_001/semantic.npy") && files.contains(&"ground_truth/questions/scene_001.json"), "val ground truth is public");
    for hidden in [
        format!("ground_truth/{test}/semantic.npy"),
        format!("ground_truth/questions/{test}.json"),
        format!("ground_truth/scenes/{test}/prompt.json"),
        format!("questions/{test}.json"),
        format!("scenes/{test}/prompt.json"),
        format!("sequences/baseline/{test}/results/semantic000000.png"),
    ] {
        let response = server.get(&format!("/api/v1/releases/{version}/files/{hidden}")).send().unwrap();
        assert_eq!(response.status(), 404, "{hidden} is not served");
    }
    // Every archive holds exactly the manifest's files of its sequence (a test scene's: no semantic frame).
    for archive in manifest["archives"].as_array().unwrap() {
        let bytes = server.get(&format!("/api/v1/releases/{version}/files/{}", archive["path"].as_str().unwrap())).send().unwrap().bytes().unwrap();
        let held = osmab_evaluator::submission::tar_file_names(&bytes[..], Path::new("archive")).unwrap();
        let prefix = format!("sequences/{}/{}/", archive["lighting"].as_str().unwrap(), archive["scene"].as_str().unwrap());
        let listed: Vec<&str> = files.iter().copied().filter(|f| f.starts_with(&prefix)).collect();
        assert_eq!(held.iter().map(String::as_str).collect::<Vec<_>>(), listed, "{prefix}");
    }
    let quality: Value = server.get(&format!("/api/v1/releases/{version}/files/quality/quality_report.json")).send().unwrap().json().unwrap();
    let test_scene = quality["per_scene"].as_array().unwrap().iter().find(|s| s["scene"] == test).unwrap();
    assert!(["class_pixels", "instances", "oracle_vqa", "prompt_id", "prompted"].iter().all(|k| test_scene.get(k).is_none()), "{test_scene}");

    // A team downloads the public release: `osmab gt build` rebuilds val, not test.
    let token = server.team("Team Split");
    let home = tempfile::tempdir().unwrap();
    let config = home.path().join("client.toml");
    assert!(client(&config, &["login", "--url", &server.url, "--token", &token]).status.success());
    let public = tempfile::tempdir().unwrap();
    let download = client(&config, &["download", "--out", crate::path(public.path())]);
    assert!(download.status.success(), "{}", said(&download));
    let gt = tempfile::tempdir().unwrap();
    let test_gt = crate::osmab(&["gt", "build", crate::path(&public.path().join(format!("sequences/baseline/{test}"))), "--out", crate::path(gt.path())]);
    assert!(!test_gt.status.success() && said(&test_gt).contains("no semantic frames"), "{}", said(&test_gt));
    assert!(!gt.path().join("semantic.npy").exists(), "nothing was written");
    let val_gt = crate::osmab(&["gt", "build", crate::path(&public.path().join("sequences/baseline/scene_001")), "--out", crate::path(gt.path())]);
    assert!(val_gt.status.success(), "{}", said(&val_gt));
    assert_eq!(std::fs::read(gt.path().join("semantic.npy")).unwrap(), std::fs::read(public.path().join("ground_truth/scene_001/semantic.npy")).unwrap());
    // The oracle anyone can make from the public files covers val only.
    let public_oracle = baseline_dir_of(public.path(), "oracle");
    assert!(public_oracle.path().join("maps/baseline/scene_001.npz").is_file() && !public_oracle.path().join(format!("maps/baseline/{test}.npz")).exists());

    if backend == Backend::Sqlite {
        // The published config, rebuilt without the secret, is refused; with another secret
        // it builds the same val scene and other test rooms.
        let rebuild = tempfile::tempdir().unwrap();
        let published = rebuild.path().join("published.toml");
        std::fs::write(&published, manifest["generator"]["config"].as_str().unwrap()).unwrap();
        let refused = build(&published, &rebuild.path().join("none"), None);
        assert!(!refused.status.success() && said(&refused).contains("OSMAB_SPLIT_SECRET"), "{}", said(&refused));
        let guess = rebuild.path().join("guess");
        assert!(build(&published, &guess, Some("a-guess-at-the-secret-1234")).status.success());
        let traj = |root: &Path, scene: &str| std::fs::read(root.join(format!("sequences/baseline/{scene}/traj.txt"))).unwrap();
        assert_eq!(traj(&guess, VAL_SCENE), traj(public.path(), VAL_SCENE), "the val scene is rebuilt exactly");
        for test in TEST_SCENES {
            assert_ne!(traj(&guess, test), traj(public.path(), test), "{test} is not");
        }
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

    // Answers of a test scene are refused: its questions are hidden, the server answers them.
    let with_answers = baseline_dir_of(split_release(), "oracle");
    let answers = with_answers.path().join(format!("answers/baseline/{test}.json"));
    std::fs::create_dir_all(answers.parent().unwrap()).unwrap();
    std::fs::write(&answers, r#"[{"question_id": "q", "answer": "Yes"}]"#).unwrap();
    let refused = problem(server.upload(&token, &tar_of(with_answers.path()), "?split=test&dry_run=true"), 422, "invalid_submission");
    assert!(refused.to_string().contains(&format!("{test} is a test scene")) && refused.to_string().contains("answers/ is for val scenes only"), "{refused}");

    // Maps of val scenes only, sent to the test split: the refusal says which split they are for.
    let val_only = baseline_dir_of(split_release(), "oracle");
    for folder in ["maps", "graphs", "answers"] {
        for lighting in std::fs::read_dir(val_only.path().join(folder)).into_iter().flatten().flatten() {
            for file in std::fs::read_dir(lighting.path()).unwrap().flatten() {
                if TEST_SCENES.iter().any(|t| file.file_name().to_string_lossy().starts_with(t)) {
                    std::fs::remove_file(file.path()).unwrap();
                }
            }
        }
    }
    let refused = problem(server.upload(&token, &tar_of(val_only.path()), "?split=test&dry_run=true"), 422, "invalid_submission");
    let detail = refused["errors"].to_string();
    assert!(detail.contains("no scene graphs for the test split") && detail.contains("are for val scenes") && detail.contains("--split val"), "{refused}");

    // One archive to each split, with one idempotency key: two submissions (the key is
    // scoped by split), each scored on its split's scenes.
    let archive = tar_of(oracle.path());
    let keyed = |query: &str| {
        server
            .post(&format!("/api/v1/submissions{query}"))
            .bearer_auth(&token)
            .header("content-type", "application/x-tar")
            .header("idempotency-key", "one-key-for-both-splits")
            .body(archive.clone())
            .send()
            .unwrap()
    };
    let to_val = keyed("?split=val");
    assert_eq!(to_val.status(), 202);
    let to_val: Value = to_val.json().unwrap();
    assert_eq!((to_val["split"].as_str(), to_val["quota"]["remaining"].as_i64()), (Some("val"), Some(2)), "{to_val}");
    let to_test = keyed("");
    assert_eq!(to_test.status(), 202, "the same archive and key to the other split is a new submission");
    let to_test: Value = to_test.json().unwrap();
    assert_ne!(to_test["id"], to_val["id"]);
    assert_eq!((to_test["split"].as_str(), to_test["quota"]["remaining"].as_i64()), (Some("test"), Some(0)), "{to_test}");
    assert_eq!(keyed("").status(), 200, "the key again to test is the test submission's repeat");
    for answer in [&to_val, &to_test] {
        let id = answer["id"].as_str().unwrap();
        let done = server.wait_done(id, &token);
        assert_eq!(done["state"], "scored", "{done}");
        assert_eq!((done["split"].as_str(), done["scores"]["split"].as_str()), (answer["split"].as_str(), answer["split"].as_str()));
        let results: Value = server.get(&format!("/api/v1/submissions/{id}/results.json")).send().unwrap().json().unwrap();
        let receipt: Value = server.get(&format!("/api/v1/submissions/{id}/receipt")).send().unwrap().json().unwrap();
        if answer["split"] == "val" {
            // Val: everything, per scene and question, per lighting.
            let scenes: Vec<&String> = done["scores"]["semseg"]["baseline"]["scenes"].as_object().unwrap().keys().collect();
            assert_eq!(scenes, [VAL_SCENE], "scored on its split's scenes only");
            for document in [&done["scores"], &results] {
                assert!(document["vqa"]["lightings"]["baseline"]["overall"]["total"].as_u64().unwrap() > 0, "{}", document["vqa"]);
                assert!(document["vqa"]["scenes"]["baseline"][VAL_SCENE]["answers"].as_array().is_some_and(|a| !a.is_empty()));
            }
            continue;
        }
        // Test: no number that depends on fewer than five test scenes, published or private —
        // no per-scene rows, no replicates, no subset of three or two scenes, VQA over all
        // lightings only (a cell per lighting lets one submission try four answer sets).
        for document in [&done["scores"], &results] {
            let baseline = &document["semseg"]["baseline"];
            assert!(baseline.get("scenes").is_none() && baseline.get("bootstrap_miou").is_none(), "{baseline}");
            assert_eq!(baseline["pooled"], 5, "{baseline}");
            assert!(baseline["overall"]["miou"].as_f64().unwrap() > 0.99, "the oracle's pooled score is shown");
            assert_eq!(baseline["subsets"], json!({}), "three furniture and two manipuland scenes: no subset is shown");
            let vqa = &document["vqa"];
            assert_eq!(vqa["lightings"], json!({}), "{vqa}");
            assert!(vqa.get("scenes").is_none());
            assert_eq!(vqa["all_lightings"]["overall"]["scenes"], 5, "{vqa}");
            assert_eq!(vqa["all_lightings"]["subsets"], json!({}));
            assert_eq!(document["withheld"]["min_scenes"], 5);
        }
        assert!(receipt["receipt"]["summary"].get("vqa").is_none() && receipt["receipt"]["summary"]["vqa_all_lightings"].is_number(), "{receipt}");
        let page = server.get(&format!("/submissions/{id}")).send().unwrap().text().unwrap();
        assert!(page.contains("id=\"withheld\"") && !page.contains(&format!("<td>{test}</td>")), "the page shows no test scene's row");
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

    // The About page: linked from every page, naming the current release, its splits and the
    // commands for this server.
    let about = server.get("/about").send().unwrap().text().unwrap();
    let scenes = TEST_SCENES.len();
    assert!(about.contains(&format!("{scenes} of them in the hidden test split")) && about.contains("e2e-split-1"), "{about}");
    assert!(
        about.contains(&format!("osmab-client login --url {}", server.url))
            && about.contains("pip install osmab-client")
            && about.contains("id=\"cite\"")
            && about.contains("id=\"licence\""),
        "{about}"
    );
    for path in ["/", "/?split=val", "/releases/e2e-split-1", "/api/docs", "/about", "/admin/login"] {
        let page = server.get(path).send().unwrap().text().unwrap();
        assert!(page.contains("href=\"/about\""), "{path} links the About page");
    }
    let page = server.get("/").send().unwrap().text().unwrap();
    assert!(page.contains("data-split=\"test\""));
}

on_both_backends!(a_test_split_release_hides_its_ground_truth_and_ranks_each_split_apart, super::a_test_split_keeps_its_ground_truth_on_the_server);

/// The differencing attack of a hostile review, played against the service: a test
/// submission whose maps are the same under every lighting but `camera` in one scene (all
/// its points one class) makes the difference of the two lightings' numbers that scene's
/// alone. A second submission whose one scene differs from the first's by a single point
/// must show exactly the same numbers: what the attack reads is no finer than the board's
/// 0.1 %. And no shown part of a partition leaves a withheld part to subtract.
fn differencing_lightings_learns_nothing_finer_than_the_rounding(backend: Backend) {
    use osmab_evaluator::formats::map::{MapSemantics, PredictedMap};
    let deployment = Deployment::new(backend, &[("OSMAB_DAILY_QUOTA", "2")]);
    let server = deployment.serve();
    let request = server.post("/api/v1/admin/releases/import").timeout(std::time::Duration::from_secs(600));
    let imported = server.admin(request.json(&json!({"path": split_release(), "publish": true})));
    assert_eq!(imported.status(), 201, "{}", imported.text().unwrap());
    let token = server.team("Team Difference");
    let target = TEST_SCENES[2];

    // `moved` points of the target scene under camera take another class than the rest.
    let attack = |moved: usize| {
        let dir = baseline_dir_of(split_release(), "oracle");
        for test in TEST_SCENES {
            for lighting in ["camera", "dynamic_lights", "no_lights"] {
                std::fs::copy(dir.path().join(format!("maps/baseline/{test}.npz")), dir.path().join(format!("maps/{lighting}/{test}.npz"))).unwrap();
            }
        }
        let path = dir.path().join(format!("maps/camera/{target}.npz"));
        let mut map = PredictedMap::read(&path, Default::default()).unwrap();
        let MapSemantics::ObjectLabels { object_ids, labels } = &mut map.semantics else { panic!("the oracle labels objects") };
        let one = labels[0];
        let other = *labels.iter().find(|l| **l != one).expect("two classes in the scene");
        labels.iter_mut().for_each(|l| *l = one);
        let odd = labels.len() as u32;
        labels.push(other);
        object_ids.iter_mut().take(moved).for_each(|id| *id = odd);
        map.write(&path, true).unwrap();
        let accepted = server.upload(&token, &tar_of(dir.path()), "?split=test");
        assert_eq!(accepted.status(), 202);
        let id = accepted.json::<Value>().unwrap()["id"].as_str().unwrap().to_string();
        let done = server.wait_done(&id, &token);
        assert_eq!(done["state"], "scored", "{done}");
        done["scores"].clone()
    };
    let (first, second) = (attack(0), attack(1));
    assert!(first["semseg"]["camera"]["overall"]["miou"].as_f64().unwrap() < first["semseg"]["baseline"]["overall"]["miou"].as_f64().unwrap());

    // Every shown fraction is a whole tenth of a percent (at full precision the two
    // submissions differed in the fifth digit and the difference of the lightings told the
    // scene's class fractions), and the two show the same numbers or, where the hidden value
    // sits at a rounding boundary, numbers one tenth of a percent apart: nothing finer.
    fn fractions(value: &Value, out: &mut Vec<f64>) {
        match value {
            Value::Number(n) if n.is_f64() => out.push(n.as_f64().unwrap()),
            Value::Array(items) => items.iter().for_each(|v| fractions(v, out)),
            Value::Object(map) => {
                map.iter().filter(|(k, _)| !["correct", "total", "scenes", "pooled", "min_scenes"].contains(&k.as_str())).for_each(|(_, v)| fractions(v, out))
            }
            _ => {}
        }
    }
    let (mut shown, mut other) = (Vec::new(), Vec::new());
    fractions(&first["semseg"], &mut shown);
    fractions(&first["relative_change"], &mut shown);
    fractions(&second["semseg"], &mut other);
    fractions(&second["relative_change"], &mut other);
    let whole_tenths = |xs: &[f64]| xs.iter().all(|x| ((x * 1000.0).round() / 1000.0 - x).abs() < 1e-12);
    assert!(shown.len() > 20 && whole_tenths(&shown) && whole_tenths(&other), "{shown:?}");
    assert_eq!(shown.len(), other.len());
    let steps: Vec<f64> = shown.iter().zip(&other).map(|(a, b)| (a - b).abs()).collect();
    assert!(steps.iter().all(|d| *d < 0.001 + 1e-9), "{steps:?}");
    assert!(steps.iter().filter(|d| **d > 0.0).count() <= 2, "a one-point change moves at most a number at a boundary: {steps:?}");
    let mut all = Vec::new();
    fractions(&first, &mut all);
    assert!(whole_tenths(&all), "{all:?}");

    // Categories and subsets: every part shown, or none (nothing to subtract); groups, which
    // leave some categories out, never more than the set.
    let cell = &first["vqa"]["all_lightings"];
    for set in ["prompt_grounded", "standard"] {
        let total = |partition: &str| -> u64 { cell[set][partition].as_object().unwrap().values().map(|a| a["total"].as_u64().unwrap()).sum() };
        let overall = cell[set]["overall"]["total"].as_u64().unwrap();
        assert!(cell[set]["categories"].as_object().unwrap().is_empty() || total("categories") == overall, "{set}: {cell}");
        assert!(total("groups") <= overall, "{set}: {cell}");
    }
    let subsets = cell["subsets"].as_object().unwrap();
    assert!(subsets.is_empty() || subsets.values().map(|s| s["overall"]["total"].as_u64().unwrap()).sum::<u64>() == cell["overall"]["total"].as_u64().unwrap());
}

on_both_backends!(
    a_test_submission_differencing_two_lightings_reads_nothing_finer_than_the_board,
    super::differencing_lightings_learns_nothing_finer_than_the_rounding
);

/// A sequence archive packed from the whole sequence folder (what imports did before
/// archives followed the manifest): the test scene's semantic frames included.
fn archive_of_the_whole_folder(lighting: &str, scene: &str, out: &Path) -> (u64, String) {
    let sequence = split_release().join("sequences").join(lighting).join(scene);
    osmab_evaluator::submission::pack_directory_as(&sequence, &format!("sequences/{lighting}/{scene}/"), out).unwrap();
    let bytes = std::fs::read(out).unwrap();
    (bytes.len() as u64, super::sha256_hex(&bytes))
}

/// Record in `database_url` that the archive `path` of `version` is `size` bytes with
/// `sha256`, as an import before the rule recorded it (release_files and the served manifest).
fn record_archive(database_url: &str, version: &str, path: &str, size: u64, sha256: &str) {
    super::block_on(async {
        let sql = ["UPDATE release_files SET size = $3, sha256 = $4 WHERE version = $1 AND path = $2", "SELECT manifest FROM releases WHERE version = $1"];
        let manifest: String = if database_url.starts_with("sqlite") {
            let pool = sqlx::SqlitePool::connect(database_url).await.unwrap();
            sqlx::query(sql[0]).bind(version).bind(path).bind(size as i64).bind(sha256).execute(&pool).await.unwrap();
            let (manifest,): (String,) = sqlx::query_as(sql[1]).bind(version).fetch_one(&pool).await.unwrap();
            pool.close().await;
            manifest
        } else {
            let pool = sqlx::PgPool::connect(database_url).await.unwrap();
            sqlx::query(sql[0]).bind(version).bind(path).bind(size as i64).bind(sha256).execute(&pool).await.unwrap();
            let (manifest,): (String,) = sqlx::query_as(sql[1]).bind(version).fetch_one(&pool).await.unwrap();
            pool.close().await;
            manifest
        };
        let mut manifest: Value = serde_json::from_str(&manifest).unwrap();
        for archive in manifest["archives"].as_array_mut().unwrap() {
            if archive["path"] == path {
                archive["size"] = json!(size);
                archive["sha256"] = json!(sha256);
            }
        }
        let text = serde_json::to_string_pretty(&manifest).unwrap();
        let update = "UPDATE releases SET manifest = $2 WHERE version = $1";
        if database_url.starts_with("sqlite") {
            let pool = sqlx::SqlitePool::connect(database_url).await.unwrap();
            sqlx::query(update).bind(version).bind(&text).execute(&pool).await.unwrap();
            pool.close().await;
        } else {
            let pool = sqlx::PgPool::connect(database_url).await.unwrap();
            sqlx::query(update).bind(version).bind(&text).execute(&pool).await.unwrap();
            pool.close().await;
        }
    });
}

fn an_archive_that_holds_more_than_its_manifest_is_refused_by_the_client_and_repacked_at_start(backend: Backend) {
    let deployment = Deployment::new(backend, &[]);
    let version = "e2e-split-1";
    let (test, lighting) = (TEST_SCENES[0], "baseline");
    let path = format!("archives/sequences/{lighting}/{test}.tar");
    let server = deployment.serve();
    let request = server.post("/api/v1/admin/releases/import").timeout(std::time::Duration::from_secs(600));
    assert_eq!(server.admin(request.json(&json!({"path": split_release(), "publish": true}))).status(), 201);
    let healthy: Value = server.get(&format!("/api/v1/releases/{version}/manifest.json")).send().unwrap().json().unwrap();
    let healthy_archive = healthy["archives"].as_array().unwrap().iter().find(|a| a["path"] == path.as_str()).unwrap().clone();

    // An import from before the rule: the archive packed from the folder, semantic frames and all.
    let blob = deployment.data.path().join("blobs/releases").join(version).join(&path);
    let (size, sha256) = archive_of_the_whole_folder(lighting, test, &blob);
    assert!(size > healthy_archive["size"].as_u64().unwrap());
    let database_url = deployment.env.iter().find(|(k, _)| k == "DATABASE_URL").map(|(_, v)| v.clone()).unwrap();
    record_archive(&database_url, version, &path, size, &sha256);

    // The client checks an archive against the manifest before unpacking it.
    let token = server.team("Team Archive");
    let home = tempfile::tempdir().unwrap();
    let config = home.path().join("client.toml");
    assert!(client(&config, &["login", "--url", &server.url, "--token", &token]).status.success());
    let out = tempfile::tempdir().unwrap();
    let args = ["download", "--scene", test, "--lighting", lighting, "--out", crate::path(out.path())];
    let refused = client(&config, &args);
    let text = said(&refused);
    assert!(!refused.status.success() && text.contains("where the manifest lists") && text.contains("semantic"), "{text}");
    assert!(!out.path().join(format!("sequences/{lighting}/{test}/results/semantic000000.png")).exists(), "nothing of it was unpacked");
    drop(server);

    // At start the server repacks it from the stored public files, and says so.
    let server = deployment.serve();
    let manifest: Value = server.get(&format!("/api/v1/releases/{version}/manifest.json")).send().unwrap().json().unwrap();
    let archive = manifest["archives"].as_array().unwrap().iter().find(|a| a["path"] == path.as_str()).unwrap();
    assert_eq!(archive, &healthy_archive, "the archive is the one a fresh import packs");
    let served = server.get(&format!("/api/v1/releases/{version}/files/{path}")).send().unwrap().bytes().unwrap();
    assert_eq!((served.len() as u64, super::sha256_hex(&served)), (archive["size"].as_u64().unwrap(), archive["sha256"].as_str().unwrap().to_string()));
    let held = osmab_evaluator::submission::tar_file_names(&served[..], Path::new("archive")).unwrap();
    assert!(!held.iter().any(|name| name.contains("semantic")), "{held:?}");
    assert!(deployment.log("serve").contains("repacked"), "{}", deployment.log("serve"));
    // The restarted server listens elsewhere: the client follows it, and the archive unpacks.
    assert!(client(&config, &["login", "--url", &server.url, "--token", &token]).status.success());
    let downloaded = client(&config, &args);
    assert!(downloaded.status.success(), "{}", said(&downloaded));
    assert!(out.path().join(format!("sequences/{lighting}/{test}/results/depth000000.png")).is_file());
}

on_both_backends!(
    an_archive_holding_more_than_its_manifest_is_repacked_at_start,
    super::an_archive_that_holds_more_than_its_manifest_is_refused_by_the_client_and_repacked_at_start
);
