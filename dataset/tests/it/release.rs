//! Building, resuming and verifying releases.

use std::path::Path;

use osmab_dataset::release::split::SplitSecret;
use osmab_dataset::release::{GROUND_TRUTH, WORK, build_release, verify_release};
use osmab_evaluator::formats::classes::ClassList;
use osmab_evaluator::formats::manifest::ReleaseManifest;
use osmab_evaluator::formats::map::{MapSemantics, PredictedMap};
use osmab_evaluator::ground_truth::GroundTruth;
use osmab_evaluator::scores::{ReleaseLighting, Split};
use osmab_evaluator::semseg::score_scene;

/// Where the configs' relative asset pack paths are read: the repository, whose `assets/`
/// the demo config names (the tests run in `dataset/`).
fn assets_root() -> std::path::PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("..")
}

const TINY: &str = r#"
version = "test-1"
created = "2026-11-22"
seed = 5
[prompts]
furniture_pool = 6
manipuland_pool = 4
[selection]
furniture = 1
manipuland = 1
[render]
width = 64
height = 48
goals_furniture = 1
goals_manipuland = 1
max_frames = 24
lightings = ["baseline", "no_lights"]
[quality]
enforce = false
"#;

fn build(dir: &Path, out: &str) -> ReleaseManifest {
    let config = dir.join("release.toml");
    std::fs::write(&config, TINY).unwrap();
    build_release(&config, &dir.join(out), None, &assets_root(), &|_| {}).unwrap()
}

/// [`build`] with `threads` threads: one builds one scene after another, several build
/// scenes side by side.
fn build_on_threads(threads: usize, dir: &Path, out: &str) -> ReleaseManifest {
    rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap().install(|| build(dir, out))
}

#[test]
fn a_release_is_complete_verified_and_scores_its_oracle_at_one() {
    let dir = tempfile::tempdir().unwrap();
    let manifest = build(dir.path(), "rel");
    let rel = dir.path().join("rel");
    assert_eq!(manifest.scenes.len(), 2);
    assert_eq!(manifest.lightings, [ReleaseLighting::Baseline, ReleaseLighting::NoLights]);
    let written = std::fs::read_to_string(rel.join("manifest.json")).unwrap();
    assert_eq!(ReleaseManifest::read(&rel.join("manifest.json")).unwrap().to_json(), written, "the manifest reads back to the same bytes");
    assert_eq!(ReleaseManifest::read(&rel.join("manifest.json")).unwrap(), manifest);
    let untyped: serde_json::Value = serde_json::from_str(&written).unwrap();
    assert_eq!(serde_json::to_string_pretty(&untyped).unwrap() + "\n", written, "keys as an untyped manifest writes them");
    let files = &manifest.files;
    let path = |f: &osmab_evaluator::formats::manifest::FileEntry| f.path.clone();
    assert!(files.iter().all(|f| !path(f).starts_with(WORK)), "work files are not public");
    // Without a test split every scene is val: its ground truth is public, the full quality
    // report and the ground truth's own manifest are not.
    assert!(manifest.scenes.iter().all(|s| s.split == Split::Val));
    assert!(files.iter().any(|f| path(f) == "ground_truth/scene_001/semantic.npy"));
    assert!(!files.iter().any(|f| path(f) == "ground_truth/manifest.json" || path(f) == "ground_truth/quality_report.json"));
    for expected in [
        "classes.json",
        "quality/quality_report.json",
        "scenes/scene_000/prompt.json",
        "sequences/baseline/scene_000/traj.txt",
        "quality/contact_sheets/no_lights/scene_001.png",
        "README.md",
        "LICENSE",
        "CITATION.cff",
    ] {
        assert!(files.iter().any(|f| f.path == expected), "{expected} missing from the manifest");
    }
    assert_eq!(verify_release(&rel).unwrap(), files.len());

    // Its front matter says what it is, its terms and how to cite it.
    let read = |name: &str| std::fs::read_to_string(rel.join(name)).unwrap();
    let version = &manifest.version;
    let readme = read("README.md");
    assert!(readme.starts_with(&format!("# OSMa-Bench++ release {version}\n")), "{readme}");
    assert!(readme.contains("2 scenes: 0 in the hidden **test** split") && readme.contains("2 in the open **val** split"), "{readme}");
    assert!(readme.contains("Lightings: baseline, no_lights."), "{readme}");
    assert!(read("LICENSE").contains("named no licence"), "this config names none: {}", read("LICENSE"));
    let citation = read("CITATION.cff");
    assert!(citation.contains("type: dataset") && citation.contains(&format!("version: \"{version}\"")) && !citation.contains("license:"), "{citation}");

    // The oracle (the ground truth as a map) scores 1 on every scene.
    for scene in ["scene_000", "scene_001"] {
        let gt_dir = rel.join(GROUND_TRUTH).join(scene);
        let classes = ClassList::read(&gt_dir.join("embed_semseg_classes.json")).unwrap();
        let gt = GroundTruth::read(&gt_dir, &classes).unwrap();
        let ids: Vec<i64> = classes.entries().iter().map(|c| c.id).collect();
        let oracle = PredictedMap {
            source: "oracle".into(),
            points: gt.points.clone(),
            semantics: MapSemantics::ObjectLabels {
                object_ids: gt.labels.iter().map(|l| ids.iter().position(|c| c == l).unwrap() as u32).collect(),
                labels: ids,
            },
        };
        let m = score_scene(&gt, &oracle, &classes, None).unwrap().metrics;
        // f-mIoU sums frequency × IoU in floating point, as the reference does: 1 up to rounding.
        assert_eq!((m.miou, m.macc), (1.0, 1.0), "{scene}");
        assert!((m.fmiou - 1.0).abs() < 1e-12, "{scene}: f-mIoU {}", m.fmiou);
    }

    // A corrupted file is caught by name.
    let traj = rel.join("sequences/baseline/scene_000/traj.txt");
    std::fs::write(&traj, "tampered").unwrap();
    let err = verify_release(&rel).unwrap_err();
    assert!(err.file.ends_with("traj.txt") && err.message.contains("SHA-256"), "{err}");
}

#[test]
fn a_test_split_publishes_no_semantics_and_only_the_operators_secret_rebuilds_it() {
    let dir = tempfile::tempdir().unwrap();
    let config = dir.path().join("split.toml");
    std::fs::write(&config, format!("{TINY}\n[splits]\ntest_manipuland = 1\n")).unwrap();
    let refused = build_release(&config, &dir.path().join("none"), None, &assets_root(), &|_| {}).unwrap_err();
    assert!(refused.message.contains("OSMAB_SPLIT_SECRET"), "{refused}");
    let secret = SplitSecret::new("the operator's own secret", "test").unwrap();
    let first = build_release(&config, &dir.path().join("a"), Some(&secret), &assets_root(), &|_| {}).unwrap();
    let again = build_release(&config, &dir.path().join("b"), Some(&secret), &assets_root(), &|_| {}).unwrap();
    assert_eq!(first.digest, again.digest, "the same config and secret give the same release");
    let splits: Vec<Split> = first.scenes.iter().map(|s| s.split).collect();
    assert_eq!(splits, [Split::Val, Split::Test]);
    let listed = |m: &ReleaseManifest| -> std::collections::BTreeMap<String, String> { m.files.iter().map(|f| (f.path.clone(), f.sha256.clone())).collect() };
    let files = listed(&first);
    assert!(!files.keys().any(|p| p.contains("scene_001/results/semantic")), "no semantic frame of the test scene is listed");
    // Nor its prompt, spec or questions: they would tell its answers. The server keeps them.
    let test_entry = &first.scenes[1];
    assert!(test_entry.prompt.is_none() && test_entry.questions.is_none(), "{test_entry:?}");
    assert!(first.scenes[0].prompt.is_some(), "the val scene's prompt is public");
    for hidden in ["scenes/scene_001/prompt.json", "questions/scene_001.json"] {
        assert!(!files.contains_key(hidden) && !dir.path().join("a").join(hidden).exists(), "{hidden}");
    }
    for kept in ["ground_truth/scenes/scene_001/prompt.json", "ground_truth/questions/scene_001.json"] {
        assert!(dir.path().join("a").join(kept).is_file(), "{kept} stays with the ground truth");
    }
    let quality: serde_json::Value = serde_json::from_slice(&std::fs::read(dir.path().join("a/quality/quality_report.json")).unwrap()).unwrap();
    let test_quality = quality["per_scene"].as_array().unwrap().iter().find(|s| s["scene"] == "scene_001").unwrap();
    assert!(test_quality.get("prompt_id").is_none(), "a prompt id names a prompt of the pool anyone rebuilds: {test_quality}");
    assert_eq!(first.generator.split_secret_id, Some(secret.id()));
    // The archive a render job packs holds exactly the manifest's files of its sequence.
    let unit = osmab_dataset::release::SequenceUnit { scene_index: 1, scene: "scene_001".into(), lighting: ReleaseLighting::Baseline };
    let build = osmab_dataset::release::Build::open(&config, &dir.path().join("a"), Some(&secret), &assets_root()).unwrap();
    osmab_dataset::release::render_release_scene(&build, &[unit], &|_| {}).unwrap();
    let (archive, _, _) = osmab_dataset::release::packed_sequence_archive(&dir.path().join("a"), ReleaseLighting::Baseline, "scene_001", Split::Test).unwrap();
    let held = osmab_evaluator::submission::tar_file_names(std::fs::File::open(&archive).unwrap(), &archive).unwrap();
    let expected: Vec<&String> = files.keys().filter(|p| p.starts_with("sequences/baseline/scene_001/")).collect();
    assert_eq!(held.iter().collect::<Vec<_>>(), expected);
    assert!(dir.path().join("a/sequences/baseline/scene_001/results/semantic000000.png").is_file(), "the operator's copy keeps them");
    assert!(files.contains_key("ground_truth/scene_000/semantic.npy") && !files.keys().any(|p| p.starts_with("ground_truth/") && p.contains("scene_001")));
    assert_eq!(verify_release(&dir.path().join("a")).unwrap(), files.len());
    // Another secret: the same val scene, another test room.
    let other = SplitSecret::new("somebody's guess at it", "test").unwrap();
    let guessed = listed(&build_release(&config, &dir.path().join("c"), Some(&other), &assets_root(), &|_| {}).unwrap());
    let traj = |scene: &str| format!("sequences/baseline/{scene}/traj.txt");
    assert_eq!(guessed[&traj("scene_000")], files[&traj("scene_000")]);
    assert_ne!(guessed[&traj("scene_001")], files[&traj("scene_001")]);
    assert!(files.iter().filter(|(p, _)| p.contains("scene_000")).all(|(p, sha)| guessed.get(p) == Some(sha)), "every val file is the same");
}

#[test]
fn the_same_config_gives_a_byte_identical_release_on_one_thread_or_several_and_interrupted_builds_resume() {
    let dir = tempfile::tempdir().unwrap();
    let first = build_on_threads(1, dir.path(), "a");
    let second = build_on_threads(4, dir.path(), "b");
    assert_eq!(first.digest, second.digest);
    assert_eq!(first, second, "the same manifest");
    let gt_manifest = |d: &str| std::fs::read(dir.path().join(d).join(GROUND_TRUTH).join("manifest.json")).unwrap();
    assert_eq!(gt_manifest("a"), gt_manifest("b"), "the same hidden ground truth");

    // Interrupt a stage: its marker gone and its output half written.
    let b = dir.path().join("b");
    std::fs::remove_file(b.join(WORK).join("rendered/no_lights/scene_001.done")).unwrap();
    std::fs::remove_file(b.join("sequences/no_lights/scene_001/results/depth000003.png")).unwrap();
    std::fs::write(b.join("sequences/no_lights/scene_001/results/frame000004.jpg"), b"partial").unwrap();
    let resumed = build(dir.path(), "b");
    assert_eq!(resumed.digest, first.digest, "the rebuilt stage is identical");
    assert_eq!(verify_release(&b).unwrap(), first.files.len());

    // Corrupt a finished stage's output (its marker still there): it is noticed and rebuilt.
    std::fs::write(b.join("sequences/baseline/scene_000/results/semantic000002.png"), b"garbage").unwrap();
    std::fs::write(b.join(GROUND_TRUTH).join("scene_001/semantic.npy"), b"garbage").unwrap();
    let repaired = build(dir.path(), "b");
    assert_eq!(repaired.digest, first.digest);
    assert_eq!(verify_release(&b).unwrap(), first.files.len());
    assert_eq!(gt_manifest("a"), gt_manifest("b"), "the ground truth is rebuilt too");

    // A sequence the config does not build (left from a build with more lightings) is not published.
    std::fs::create_dir_all(b.join("sequences/camera/scene_000")).unwrap();
    std::fs::write(b.join("sequences/camera/scene_000/traj.txt"), b"old").unwrap();
    let config = dir.path().join("release.toml");
    let err = build_release(&config, &b, None, &assets_root(), &|_| {}).unwrap_err();
    assert!(err.message.contains("sequences/camera/scene_000/traj.txt") && err.message.contains("fresh directory"), "{err}");

    // A changed config rebuilds what it changes instead of reusing the old stages.
    std::fs::remove_dir_all(b.join("sequences/camera")).unwrap();
    std::fs::write(&config, TINY.replace("max_frames = 24", "max_frames = 12")).unwrap();
    let shorter = build_release(&config, &b, None, &assets_root(), &|_| {}).unwrap();
    assert_ne!(shorter.digest, first.digest);
    let frames = std::fs::read_to_string(b.join("sequences/baseline/scene_000/traj.txt")).unwrap().lines().count();
    assert!(frames <= 12, "{frames} poses after lowering max_frames to 12");
}

#[test]
fn baselines_are_submissions_that_rank_below_the_oracle() {
    use osmab_dataset::baselines::{Control, write_baseline};
    use osmab_evaluator::formats::npy::ReadLimits;
    let dir = tempfile::tempdir().unwrap();
    build(dir.path(), "rel");
    let rel = dir.path().join("rel");
    let mut scores = Vec::new();
    for control in Control::ALL {
        let out = dir.path().join(control.name());
        assert_eq!(write_baseline(control, &rel, &out).unwrap(), 4, "2 scenes × 2 lightings");
        let submission: serde_json::Value = serde_json::from_slice(&std::fs::read(out.join("submission.json")).unwrap()).unwrap();
        assert_eq!((submission["format"].as_str(), submission["release"].as_str()), (Some("osmab-submission/1"), Some("test-1")));
        let graph: serde_json::Value = serde_json::from_slice(&std::fs::read(out.join("graphs/no_lights/scene_000.json")).unwrap()).unwrap();
        assert!(!graph["objects"].as_array().unwrap().is_empty());
        // Mean mIoU over both scenes (the manipuland scene has the small objects).
        let mut total = 0.0;
        for scene in ["scene_000", "scene_001"] {
            let gt_dir = rel.join(GROUND_TRUTH).join(scene);
            let classes = ClassList::read(&gt_dir.join("embed_semseg_classes.json")).unwrap();
            let gt = GroundTruth::read(&gt_dir, &classes).unwrap();
            let map = PredictedMap::read(&out.join(format!("maps/baseline/{scene}.npz")), ReadLimits::default()).unwrap();
            total += score_scene(&gt, &map, &classes, None).unwrap().metrics.miou;
        }
        scores.push((control, total / 2.0));
    }
    assert_eq!(scores[0], (Control::Oracle, 1.0));
    for (name, miou) in &scores[1..] {
        assert!(*miou < 1.0 && *miou > 0.0, "{name}: {miou}");
    }
    assert_eq!(
        "telepathy".parse::<Control>().unwrap_err(),
        "unknown baseline 'telepathy' (expected one of oracle, drop-small, merge, label-noise, pose-drift)"
    );
    assert!(Control::ALL.iter().all(|c| c.name().parse::<Control>() == Ok(*c)));
}

#[test]
fn an_external_renderer_can_replace_the_built_in_one() {
    let dir = tempfile::tempdir().unwrap();
    let built_in = build(dir.path(), "built-in");
    // "HaDaGe" here copies the sequences the built-in renderer wrote: the release must hold
    // the same files (its quality report measures the copies from their images, without
    // object instances, so only that report differs).
    let source = dir.path().join("built-in/sequences");
    let command = format!("command = [\"cp\", \"-r\", \"{}/{{lighting}}/{{scene}}/.\", \"{{out}}\"]\n", source.display());
    let path = dir.path().join("external.toml");
    std::fs::write(&path, TINY.replace("[quality]", &format!("{command}[quality]"))).unwrap();
    let external = build_release(&path, &dir.path().join("external"), None, &assets_root(), &|_| {}).unwrap();
    let files = |m: &ReleaseManifest| -> Vec<osmab_evaluator::formats::manifest::FileEntry> {
        m.files.iter().filter(|f| f.path != "quality/quality_report.json").cloned().collect()
    };
    assert_eq!(files(&external), files(&built_in));
    let gt_manifest = |d: &str| std::fs::read(dir.path().join(d).join(GROUND_TRUTH).join("manifest.json")).unwrap();
    let gt_files = |d: &str| -> Vec<serde_json::Value> {
        let files = serde_json::from_slice::<serde_json::Value>(&gt_manifest(d)).unwrap()["files"].clone();
        files.as_array().unwrap().iter().filter(|f| f["path"] != "quality_report.json").cloned().collect()
    };
    assert_eq!(gt_files("external"), gt_files("built-in"), "the same ground truth, instances included");
    // A renderer that writes nothing usable is named.
    let broken = TINY.replace("[quality]", "command = [\"true\"]\n[quality]");
    std::fs::write(&path, broken).unwrap();
    let err = build_release(&path, &dir.path().join("broken"), None, &assets_root(), &|_| {}).unwrap_err();
    assert!(err.to_string().contains("camera_params.yaml"), "{err}");
}

#[test]
fn release_configs_with_secrets_or_impossible_cameras_are_rejected_by_field() {
    use osmab_dataset::release::config::ReleaseConfig;
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("release.toml");
    let secret = TINY
        .replace("manipuland_pool = 4\n", "manipuland_pool = 4\n[prompts.llm]\nbase_url = \"http://127.0.0.1:1/v1\"\nmodel = \"m\"\napi_key = \"sk-secret\"\n");
    for (text, field, expectation) in [
        (secret.as_str(), "prompts.llm.api_key", "OSMAB_LLM_API_KEY"),
        (&TINY.replace("height = 48\n", "height = 48\nhfov = 180.0\n"), "render.hfov", "(0, 180)"),
        (&TINY.replace("height = 48\n", "height = 48\nsensor_height = 0.0\n"), "render.sensor_height", "(0, 1.5)"),
        (&TINY.replace("width = 64", "width = 0"), "render.width", "16..=4096"),
        (&TINY.replace("width = 64", "width = 8192"), "render.width", "16..=4096"),
        // Every size is bounded, the bound named: a posted config cannot queue unbounded work.
        (&TINY.replace("furniture_pool = 6", "furniture_pool = 1000000000"), "prompts.furniture_pool", "at most 5000"),
        (&TINY.replace("furniture = 1\n", "furniture = 100000\n"), "selection.furniture", "at most 200"),
        (&TINY.replace("max_frames = 24", "max_frames = 1000000000"), "render.max_frames", "at most 100000"),
        (&TINY.replace("goals_manipuland = 1", "goals_manipuland = 5000"), "render.goals_manipuland", "at most 100"),
        (
            &TINY
                .replace("furniture = 1\nmanipuland = 1", "furniture = 200\nmanipuland = 200")
                .replace("max_frames = 24", "max_frames = 100000")
                .replace("width = 64\nheight = 48", "width = 4096\nheight = 4096"),
            "render.max_frames",
            "scenes × lightings × max_frames × width × height at most",
        ),
        (&format!("{TINY}\n[splits]\ntest_furniture = 2\n"), "splits.test_furniture", "at most the subset's 1"),
        (
            &format!(
                "{}\n[splits]\ntest_manipuland = 1\n",
                TINY.replace("[render]", "[synthesis]\ncommand = [\"scenesmith\", \"{prompt}\", \"{out}\"]\n[render]")
            ),
            "synthesis.command",
            "{seed}",
        ),
    ] {
        std::fs::write(&path, text).unwrap();
        let message = ReleaseConfig::read(&path).unwrap_err().to_string();
        assert!(message.contains("release.toml") && message.contains(field) && message.contains(expectation), "{message}");
    }
}

#[test]
fn external_tools_that_fail_or_overrun_are_reported_and_stopped_with_their_children() {
    use osmab_dataset::external::run_command;
    use std::time::Duration;
    let dir = tempfile::tempdir().unwrap();
    let log = dir.path().join("logs/tool.log");
    let sh = |script: &str| vec!["sh".to_string(), "-c".to_string(), script.to_string()];

    let failed = run_command(&sh("echo step one; echo 'no GPU found' >&2; exit 3"), &[], &log, Duration::from_secs(10)).unwrap_err().to_string();
    assert!(failed.contains("tool.log") && failed.contains("exit status: 3") && failed.contains("no GPU found"), "{failed}");

    // A child left running in the background would keep writing into rebuilt output.
    let late = dir.path().join("written-after-the-timeout");
    let script = format!("(sleep 2; touch {}) & sleep 30", late.display());
    let overran = run_command(&sh(&script), &[], &log, Duration::from_millis(300)).unwrap_err().to_string();
    assert!(overran.contains("ran longer than"), "{overran}");
    std::thread::sleep(Duration::from_millis(2500));
    assert!(!late.exists(), "the tool's child outlived the timeout");
}

#[test]
fn a_release_that_misses_its_quality_bar_is_not_published_and_says_why() {
    // 24 frames of 64×48 pixels cannot map a room: every candidate prompt is tried, then
    // the build stops naming the scene, the prompts and the measures.
    let dir = tempfile::tempdir().unwrap();
    let config = dir.path().join("release.toml");
    std::fs::write(&config, TINY.replace("enforce = false", "enforce = true\nreplacements = 2")).unwrap();
    let out = dir.path().join("rel");
    let err = build_release(&config, &out, None, &assets_root(), &|_| {}).unwrap_err().to_string();
    assert!(err.contains("scene_000") && err.contains("no prompt for scene_000 passes"), "{err}");
    assert!(err.contains("camera travel") || err.contains("instances mapped"), "{err}");
    assert_eq!(err.matches(" | ").count(), 2, "the selected prompt and two spares were tried: {err}");
    assert!(!out.join("manifest.json").exists(), "nothing is published");
}

/// The demo release (configs/release-demo.toml, the one `osmab serve` builds on its
/// first start) measured against the bar of the release-fidelity issue.
#[test]
fn the_demo_release_observes_every_prompted_object_under_four_distinct_lightings() {
    let dir = tempfile::tempdir().unwrap();
    let config = Path::new(env!("CARGO_MANIFEST_DIR")).join("../configs/release-demo.toml");
    let out = dir.path().join("demo");
    let secret = SplitSecret::new("the demo test's secret", "test").unwrap();
    build_release(&config, &out, Some(&secret), &assets_root(), &|_| {}).expect("the demo release passes its quality bar");
    let public: serde_json::Value = serde_json::from_slice(&std::fs::read(out.join("quality/quality_report.json")).unwrap()).unwrap();
    let test_scenes = serde_json::json!(["scene_000", "scene_002", "scene_003", "scene_004", "scene_006"]);
    assert_eq!((public["full_match"].as_u64(), public["test_scenes"].clone()), (Some(2), test_scenes), "five test scenes, val counted");
    let report: serde_json::Value = serde_json::from_slice(&std::fs::read(out.join(GROUND_TRUTH).join("quality_report.json")).unwrap()).unwrap();
    assert_eq!((report["scenes"].as_u64(), report["full_match"].as_u64(), report["passed"].as_u64()), (Some(7), Some(7), Some(7)));
    for (category, accuracy) in report["oracle_vqa"].as_object().unwrap() {
        assert_eq!(accuracy.as_f64(), Some(1.0), "the oracle answers every {category} question");
    }
    for scene in report["per_scene"].as_array().unwrap() {
        let name = scene["scene"].as_str().unwrap();
        assert!(scene["full_match"].as_bool().unwrap(), "{name}");
        // Prompted objects are mapped from two viewpoints; most of the room's dressing is
        // mapped too (a book deep in a shelf may stay out of sight).
        let instances = scene["instances"].as_array().unwrap();
        for instance in instances.iter().filter(|i| i["prompted"] == true) {
            assert!(instance["gt_points"].as_u64().unwrap() >= 10 && instance["viewpoints"].as_u64().unwrap() >= 2, "{name}: {instance}");
        }
        let dressing: Vec<_> = instances.iter().filter(|i| i["prompted"] == false).collect();
        let mapped = dressing.iter().filter(|i| i["mapped"] == true).count();
        assert!(mapped * 4 >= dressing.len() * 3, "{name}: {mapped} of {} dressing objects mapped", dressing.len());
        assert!(scene["degenerate_fraction"].as_f64().unwrap() <= 0.10, "{name}");
        assert!(scene["travelled_m"].as_f64().unwrap() >= 2.0, "{name}");
        let lightings = &scene["lightings"];
        for lighting in ["baseline", "camera", "dynamic_lights", "no_lights"] {
            assert!(lightings[lighting]["median_saturated"].as_f64().unwrap() <= 0.05, "{name} {lighting}");
            assert_eq!(lightings[lighting]["geometry_differs"], 0, "{name} {lighting}: depth and semantics are the baseline's");
        }
        let dynamic = &lightings["dynamic_lights"];
        assert!(dynamic["differs_from_baseline"].as_f64().unwrap() >= 0.2, "{name}: {dynamic}");
        let [low, high] = [0, 1].map(|i| dynamic["luma_vs_baseline"][i].as_f64().unwrap());
        assert!(high - low >= 0.1 && high < 1.0, "{name}: dynamic lights vary along the sequence and never brighten it: {dynamic}");
        let camera = &lightings["camera"];
        assert!(camera["differs_from_baseline"].as_f64().unwrap() >= 0.9, "{name}: {camera}");
    }
    // The oracle's scene graph is the hidden objects file: it answers what the questions ask.
    assert!(out.join(GROUND_TRUTH).join("scene_000/instances.npy").is_file());
}

#[test]
fn a_config_naming_an_asset_pack_that_is_not_there_is_refused_before_anything_is_built() {
    let dir = tempfile::tempdir().unwrap();
    let config = dir.path().join("release.toml");
    std::fs::write(&config, TINY.replace("[render]", "[synthesis]\nassets = \"no-such-pack\"\n[render]")).unwrap();
    let err = build_release(&config, &dir.path().join("rel"), None, &assets_root(), &|_| {}).unwrap_err().to_string();
    assert!(err.contains("synthesis.assets") && err.contains("no-such-pack/catalogue.json"), "{err}");
    assert!(!dir.path().join("rel/manifest.json").exists());
}

#[test]
fn a_release_drawn_from_a_pack_records_the_pack_s_digest() {
    let dir = tempfile::tempdir().unwrap();
    let config = dir.path().join("release.toml");
    let pack = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/fixtures/pack");
    std::fs::write(&config, TINY.replace("[render]", &format!("[synthesis]\nassets = {:?}\n[render]", pack.display().to_string()))).unwrap();
    let manifest = build_release(&config, &dir.path().join("rel"), None, &assets_root(), &|_| {}).unwrap();
    let digest = osmab_dataset::assets::AssetPack::open(&pack).unwrap().digest().to_string();
    assert_eq!(manifest.generator.assets_digest, Some(digest));
}
