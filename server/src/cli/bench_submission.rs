//! `osmab bench submission`: a whole submission at a full release's sizes — every scene
//! under every lighting with a map and a scene graph, and the scenes' questions — taken
//! from its archive the way the worker takes it (unpack, read the release, validate,
//! score with VQA), timed stage by stage.
//!
//! The data (a release directory with ground truth and questions, and the submission's
//! archive) is generated once under `--data` and reused while the sizes stay the same.

use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

use anyhow::{Context, bail};
use osmab_dataset::questions::SceneObject;
use osmab_dataset::questions::priors::{PoolLayouts, QuestionPriors};
use osmab_dataset::questions::scene_questions;
use osmab_dataset::spec::SceneSpec as PromptSpec;
use osmab_evaluator::formats::manifest::{ManifestScene, ReleaseManifest};
use osmab_evaluator::formats::map::TextFeatures;
use osmab_evaluator::scores::{Lighting, Regime, ReleaseLighting, Split};
use osmab_evaluator::semseg::prepared_cache::PreparedCache;
use osmab_evaluator::submission::score::ScoringTimings;
use osmab_evaluator::submission::warm::{Warmed, warm_release};
use osmab_evaluator::submission::{ArchiveLimits, ReleaseIndex, SubmissionLimits, pack_directory, score_submission_timed, unpack, validate};
use osmab_evaluator::synthetic::{SceneSpec, SyntheticScene, generate};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use serde_json::json;

/// The release version the generated data carries.
const VERSION: &str = "bench-submission";

/// Sizes of the generated release and submission.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SubmissionBenchSize {
    /// Scenes; the first 60 % are furniture scenes, the rest manipuland (24 + 16 of 40).
    pub scenes: usize,
    /// Ground-truth points of each scene.
    pub gt_points: usize,
    /// Points of each map.
    pub map_points: usize,
    /// Objects standing in each room.
    pub objects: usize,
    /// Whether each map also covers the room's floor, walls and ceiling.
    pub map_covers_room: bool,
}

/// The furniture scenes among `scenes` (24 of 40, as the release).
fn furniture_scenes(scenes: usize) -> usize {
    (scenes * 3).div_ceil(5)
}

fn scene_id(i: usize) -> String {
    format!("scene_{i:03}")
}

/// The node the submissions are scored on.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Node {
    /// No cache of prepared ground truth: every run prepares every scene.
    WithoutCache,
    /// The cache emptied at the start: the first run fills it, later runs read it.
    Cold,
    /// The cache emptied, then filled before the first run as an idle worker fills it.
    Warmed,
    /// The cache as an earlier bench left it: runs read what it holds for this release.
    Kept,
}

/// Generate the data (unless `data` already holds it at these sizes) and time `repeat`
/// scorings on `node`, printing a table of stages for each; the prepared ground truth is
/// kept in `data`'s cache, emptied first, as a worker keeps it.
pub fn run(size: &SubmissionBenchSize, data: &Path, node: Node, repeat: usize) -> anyhow::Result<()> {
    let archive = ensure_data(size, data)?;
    let release = data.join("release");
    let cache_dir = data.join("prepared-ground-truth");
    if cache_dir.exists() && node != Node::Kept {
        std::fs::remove_dir_all(&cache_dir).with_context(|| format!("emptying {}", cache_dir.display()))?;
    }
    let cache = (node != Node::WithoutCache).then(|| PreparedCache::new(&cache_dir, 1 << 40));
    let lightings = Lighting::RELEASE.len();
    println!(
        "{} scenes × {lightings} lightings, {} ground-truth points a scene, {} points a map ({}), threads {}",
        size.scenes,
        size.gt_points,
        size.map_points,
        if size.map_covers_room { "map covers the room" } else { "room shell unmapped" },
        rayon::current_num_threads()
    );
    if let (Node::Warmed, Some(cache)) = (node, &cache) {
        let clock = Instant::now();
        let index = ReleaseIndex::read(&release).map_err(|e| anyhow::anyhow!("{e}"))?;
        let mut prepared = 0;
        warm_release(&index, cache, |_, warmed| prepared += usize::from(*warmed == Warmed::Prepared)).map_err(|e| anyhow::anyhow!("{e}"))?;
        println!(
            "node made ready before any submission, as an idle worker does: {prepared} of {} scenes' ground truth prepared in {:.2} s",
            size.scenes,
            clock.elapsed().as_secs_f64()
        );
    }
    for run in 0..repeat {
        let unpacked = data.join("unpacked");
        if unpacked.exists() {
            std::fs::remove_dir_all(&unpacked).with_context(|| format!("removing {}", unpacked.display()))?;
        }
        let started = Instant::now();
        let clock = Instant::now();
        unpack(&archive, &unpacked, ArchiveLimits { max_entries: 20_000, max_total_bytes: 1 << 40, max_expansion_ratio: None })
            .map_err(|e| anyhow::anyhow!("{e}"))?;
        let unpack_time = clock.elapsed();
        let clock = Instant::now();
        let index = ReleaseIndex::read(&release).map_err(|e| anyhow::anyhow!("{e}"))?;
        let limits = SubmissionLimits::default();
        let valid = validate(&unpacked, &index, limits).map_err(|problems| anyhow::anyhow!("{}", problems[0]))?;
        let validate_time = clock.elapsed();
        let (scores, t) = score_submission_timed(&valid, &index, limits, Default::default(), cache.as_ref(), &|_, _| {}).map_err(|e| anyhow::anyhow!("{e}"))?;
        let total = started.elapsed();
        let _ = std::fs::remove_dir_all(&unpacked);
        let miou = scores.semseg.get(&Lighting::BASELINE).map_or(f64::NAN, |s| s.overall.miou);
        let vqa = scores.vqa.as_ref().and_then(|v| v.all_lightings.overall.accuracy).unwrap_or(f64::NAN);
        let questions = scores.vqa.as_ref().map_or(0, |v| v.all_lightings.overall.total);
        println!(
            "run {run}: {} maps, {:.0} M ground-truth points associated, {questions} questions judged; baseline mIoU {miou:.4}, VQA accuracy {vqa:.4}; {} of {} scenes' ground truth from the cache",
            t.maps,
            t.ground_truth_points as f64 / 1e6,
            t.ground_truth_cached,
            size.scenes
        );
        if let Some(why) = t.cache_misses.iter().find(|why| !why.ends_with("not cached yet")).or(t.not_kept.first()) {
            println!("  (cache: {why})");
        }
        print_stages(unpack_time, validate_time, &t, total);
    }
    Ok(())
}

/// The time of every stage of one scoring, one line each.
fn print_stages(unpack_time: Duration, validate_time: Duration, t: &ScoringTimings, total: Duration) {
    let rows: [(&str, Duration); 14] = [
        ("unpack the archive", unpack_time),
        ("read the release, validate every file", validate_time),
        ("read ground truth (once a scene; cached: prepared)", t.read_ground_truth),
        ("put ground truth in Z-order (once a scene, uncached)", t.prepare_ground_truth),
        ("  keep it in the node's cache (beside the rest, not in the sum)", t.keep_ground_truth),
        ("  wait for the cache's writer", t.wait_for_cache),
        ("wait for maps (read while the one before is scored)", t.read_maps),
        ("label map points", t.scenes.labels),
        ("build nearest-neighbour indexes", t.scenes.index),
        ("associate ground-truth points", t.scenes.query),
        ("confusion matrices", t.scenes.confusion),
        ("tables, subsets, bootstrap intervals", t.tables),
        ("VQA: answer and judge", t.vqa),
        ("whole submission", total),
    ];
    for (stage, time) in rows {
        println!("  {stage:<54} {:>8.2} s", time.as_secs_f64());
    }
}

/// The submission archive in `data`, generated with the release beside it first if
/// `data` does not hold them at `size`.
fn ensure_data(size: &SubmissionBenchSize, data: &Path) -> anyhow::Result<PathBuf> {
    let archive = data.join("submission.tar");
    let sizes_path = data.join("sizes.json");
    let recorded: Option<SubmissionBenchSize> = std::fs::read(&sizes_path).ok().and_then(|b| serde_json::from_slice(&b).ok());
    if recorded.as_ref() == Some(size) && archive.is_file() {
        return Ok(archive);
    }
    if size.scenes == 0 {
        bail!("--scenes must be at least 1");
    }
    let clock = Instant::now();
    for stale in ["release", "submission", "submission.tar", "sizes.json"] {
        let path = data.join(stale);
        if path.is_dir() {
            std::fs::remove_dir_all(&path)?;
        } else if path.exists() {
            std::fs::remove_file(&path)?;
        }
    }
    let (release, submission) = (data.join("release"), data.join("submission"));
    std::fs::create_dir_all(&release)?;
    std::fs::create_dir_all(&submission)?;
    let spec = |i: usize| SceneSpec {
        gt_points: size.gt_points,
        map_points: size.map_points,
        objects: size.objects,
        feature_dim: 1024,
        seed: 1000 + i as u64,
        map_covers_room: size.map_covers_room,
    };
    // One text embedding of the classes for the whole submission (the first scene's):
    // every scene's maps carry object features near it.
    let text = generate(SceneSpec { gt_points: 1, map_points: 1, ..spec(0) }).text;
    text.write(&submission.join("text_features.npz"))?;
    (0..size.scenes).into_par_iter().try_for_each(|i| write_scene(i, spec(i), &text, &release, &submission))?;
    let furniture = furniture_scenes(size.scenes);
    let scenes = (0..size.scenes)
        .map(|i| ManifestScene {
            id: scene_id(i),
            preview: None,
            prompt: None,
            questions: None,
            split: Split::Val,
            subset: if i < furniture { Regime::Furniture } else { Regime::Manipuland },
        })
        .collect();
    let manifest = ReleaseManifest { version: VERSION.to_string(), scenes, lightings: ReleaseLighting::ALL.to_vec(), ..ReleaseManifest::default() };
    manifest.write(&release.join("manifest.json"))?;
    generate(SceneSpec { gt_points: 1, map_points: 1, ..spec(0) }).classes.write(&release.join("classes.json"))?;
    let card =
        json!({"format": "osmab-submission/1", "release": VERSION, "method": {"name": "bench", "description": "Synthetic maps at a full release's sizes."}});
    std::fs::write(submission.join("submission.json"), serde_json::to_vec_pretty(&card)?)?;
    pack_directory(&submission, &archive)?;
    std::fs::remove_dir_all(&submission)?;
    std::fs::write(&sizes_path, serde_json::to_vec_pretty(size)?)?;
    println!("generated {} in {:.0} s", data.display(), clock.elapsed().as_secs_f64());
    Ok(archive)
}

/// Scene `i`: its ground truth, classes and answered questions into the release, and
/// for every lighting a map (a fresh draw, sharing `text`) and a scene graph (80 % of
/// the objects) into the submission.
fn write_scene(i: usize, spec: SceneSpec, text: &TextFeatures, release: &Path, submission: &Path) -> anyhow::Result<()> {
    let scene = generate(spec);
    let id = scene_id(i);
    let gt_dir = release.join("ground_truth").join(&id);
    scene.ground_truth.write(&gt_dir)?;
    scene.classes.write(&gt_dir.join("embed_semseg_classes.json"))?;
    let objects = scene_objects(&scene);
    let lexicon: Vec<String> = scene.classes.entries().into_iter().map(|c| c.name).filter(|n| n != "other").collect();
    let room = PromptSpec { regime: Regime::Furniture, room: "room".into(), objects: Vec::new(), relations: Vec::new() };
    let layouts = PoolLayouts::none();
    let questions = scene_questions(&id, &room, &objects, &lexicon, &QuestionPriors::new(&layouts, &lexicon), spec.seed);
    let questions_path = release.join("ground_truth").join("questions").join(format!("{id}.json"));
    std::fs::create_dir_all(questions_path.parent().expect("nested"))?;
    std::fs::write(&questions_path, serde_json::to_vec(&questions)?)?;
    for (k, lighting) in Lighting::RELEASE.iter().enumerate() {
        let map = scene.another_map(spec, text, spec.seed * 16 + k as u64);
        let map_path = submission.join("maps").join(lighting.name()).join(format!("{id}.npz"));
        std::fs::create_dir_all(map_path.parent().expect("nested"))?;
        map.write(&map_path, false)?;
        let kept: Vec<_> = objects
            .iter()
            .enumerate()
            .filter(|(j, _)| (j * 7 + k * 3 + i) % 5 != 0)
            .map(|(_, o)| json!({"id": o.id, "label": o.label, "caption": o.caption, "bbox_center": o.bbox_center, "bbox_extent": o.bbox_extent}))
            .collect();
        let graph_path = submission.join("graphs").join(lighting.name()).join(format!("{id}.json"));
        std::fs::create_dir_all(graph_path.parent().expect("nested"))?;
        std::fs::write(&graph_path, serde_json::to_vec(&json!({"objects": kept}))?)?;
    }
    Ok(())
}

/// The room's objects as the question generator sees them (every one seen, standing on
/// the floor).
fn scene_objects(scene: &SyntheticScene) -> Vec<SceneObject> {
    scene
        .objects
        .iter()
        .enumerate()
        .map(|(j, o)| {
            let label = scene.classes.name(o.class).unwrap_or("other").to_string();
            SceneObject {
                id: format!("obj_{j}"),
                caption: format!("a {label}"),
                label,
                bbox_center: std::array::from_fn(|a| f64::from(o.min[a] + o.max[a]) / 2.0),
                bbox_extent: std::array::from_fn(|a| f64::from(o.max[a] - o.min[a])),
                points: 1000,
                colour: None,
                rests_on: Some("floor".into()),
            }
        })
        .collect()
}
