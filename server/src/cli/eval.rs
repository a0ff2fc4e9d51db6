//! `osmab eval metrics`, `osmab eval lightings` and `osmab eval semseg` (`osmab eval vqa` is in eval_vqa.rs).

use std::path::{Path, PathBuf};
use std::time::Instant;

use anyhow::{Context, bail};
use clap::{Args, Subcommand};
use osmab_evaluator::formats::classes::ClassList;
use osmab_evaluator::formats::confusion::{ConfusionDocument, read_confusion};
use osmab_evaluator::formats::map::{PredictedMap, TextFeatures};
use osmab_evaluator::formats::npy::ReadLimits;
use osmab_evaluator::ground_truth::GroundTruth;
use osmab_evaluator::numeric::python_repr;
use osmab_evaluator::semseg::{LightingComparison, MetricsTable, SceneScore, score_scene};

#[derive(Debug, Subcommand)]
pub enum EvalCommand {
    /// Print metrics.csv (miou,fmiou,macc,scene; overall_mean; overall) for a directory of *.confusion.json.
    Metrics {
        /// Directory holding one `<scene>.confusion.json` per scene.
        dir: PathBuf,
    },
    /// Compare lightings: DIR/<lighting>/*.confusion.json; pooled and mean metrics per lighting with their relative change against the baseline.
    Lightings {
        /// Directory holding one sub-directory of confusion matrices per lighting.
        dir: PathBuf,
        /// The lighting the others are compared with.
        #[arg(long, default_value = "baseline")]
        baseline: String,
    },
    /// Score one map against one ground-truth directory.
    Semseg(SemsegArgs),
    /// Judge OSMa-Bench VQA answer files and print one metrics.csv row per file.
    Vqa(super::eval_vqa::VqaArgs),
}

#[derive(Debug, Args)]
pub struct SemsegArgs {
    /// Ground-truth directory: pointcloud.pcd + semantic.npy, or a Replica-style
    /// mesh_semantic.ply + info_semantic.json.
    #[arg(long)]
    gt: PathBuf,
    /// The map (.npz: points, object_ids, labels | features, or point_features).
    #[arg(long)]
    map: PathBuf,
    /// Class text features (.npz: class_ids, features); needed when the map carries features.
    #[arg(long)]
    text_features: Option<PathBuf>,
    /// Class list; defaults to embed_semseg_classes.json beside the ground truth (or, for a
    /// mesh, info_semantic.json).
    #[arg(long)]
    classes: Option<PathBuf>,
    /// Write labels, matrix and metrics as one JSON object to this file.
    #[arg(long)]
    json: Option<PathBuf>,
    /// Print stage timings as one JSON line on stderr.
    #[arg(long)]
    timings: bool,
}

pub fn run(cmd: EvalCommand) -> anyhow::Result<()> {
    match cmd {
        EvalCommand::Metrics { dir } => metrics(&dir),
        EvalCommand::Lightings { dir, baseline } => lightings(&dir, &baseline),
        EvalCommand::Semseg(args) => semseg(&args),
        EvalCommand::Vqa(args) => super::eval_vqa::run(&args),
    }
}

const CONFUSION_SUFFIX: &str = ".confusion.json";

fn metrics(dir: &Path) -> anyhow::Result<()> {
    print!("{}", metrics_table(dir)?.to_csv());
    Ok(())
}

fn lightings(dir: &Path, baseline: &str) -> anyhow::Result<()> {
    let mut tables = Vec::new();
    for entry in std::fs::read_dir(dir).with_context(|| format!("{}: cannot read directory", dir.display()))? {
        let path = entry.with_context(|| format!("{}: cannot list directory", dir.display()))?.path();
        if path.is_dir() {
            let name = path.file_name().and_then(|n| n.to_str()).unwrap_or_default().to_string();
            tables.push((name, metrics_table(&path)?));
        }
    }
    let names: Vec<String> = tables.iter().map(|(n, _)| n.clone()).collect();
    let Some(comparison) = LightingComparison::new(baseline, tables) else {
        bail!("{}: no '{baseline}' lighting to compare with (found: {})", dir.display(), names.join(", "));
    };
    print!("{}", comparison.to_csv());
    Ok(())
}

/// The metrics table of every `<scene>.confusion.json` in `dir`.
fn metrics_table(dir: &Path) -> anyhow::Result<MetricsTable> {
    let entries = std::fs::read_dir(dir).with_context(|| format!("{}: cannot read directory", dir.display()))?;
    let mut scenes = Vec::new();
    for entry in entries {
        let path = entry.with_context(|| format!("{}: cannot list directory", dir.display()))?.path();
        let Some(scene) = path.file_name().and_then(|n| n.to_str()).and_then(|n| n.strip_suffix(CONFUSION_SUFFIX)) else {
            continue;
        };
        scenes.push((scene.to_string(), read_confusion(&path)?));
    }
    if scenes.is_empty() {
        bail!("{}: no *{CONFUSION_SUFFIX} files found", dir.display());
    }
    Ok(MetricsTable::from_scenes(scenes))
}

fn semseg(args: &SemsegArgs) -> anyhow::Result<()> {
    let started = Instant::now();
    let mesh = args.gt.join("mesh_semantic.ply");
    let mesh_info = args.gt.join("info_semantic.json");
    let is_mesh = !args.gt.join("pointcloud.pcd").exists() && mesh.exists();
    let default_classes = args.gt.join("embed_semseg_classes.json");
    let classes_path = match &args.classes {
        Some(path) => path.clone(),
        None if is_mesh && !default_classes.exists() => mesh_info.clone(),
        None => default_classes,
    };
    let classes = ClassList::read(&classes_path)?;
    let limits = ReadLimits::default();
    let read_ground_truth = || if is_mesh { GroundTruth::read_mesh(&mesh, &mesh_info) } else { GroundTruth::read(&args.gt, &classes) };
    // The ground truth and the map are independent files: read them on both cores.
    let (ground_truth, map) = rayon::join(read_ground_truth, || PredictedMap::read(&args.map, limits));
    let (ground_truth, map) = (ground_truth?, map?);
    let text = args.text_features.as_deref().map(|p| TextFeatures::read(p, limits)).transpose()?;
    let load = started.elapsed();

    let score = score_scene(&ground_truth, &map, &classes, text.as_ref())?;
    print_scores(&score, &classes, ground_truth.points.len(), map.points.len());
    if let Some(out) = &args.json {
        let metrics = Headline { fmiou: score.metrics.fmiou, macc: score.metrics.macc, miou: score.metrics.miou };
        let json = EvalDocument { confusion: ConfusionDocument::from(&score.confusion), metrics };
        std::fs::write(out, serde_json::to_string(&json)?).with_context(|| format!("{}: cannot write", out.display()))?;
    }
    if args.timings {
        let t = &score.timings;
        eprintln!(
            "{}",
            serde_json::json!({
                "load_s": load.as_secs_f64(),
                "labels_s": t.labels.as_secs_f64(),
                "index_s": t.index.as_secs_f64(),
                "query_s": t.query.as_secs_f64(),
                "nearest_s": (t.index + t.query).as_secs_f64(),
                "confusion_metrics_s": t.confusion.as_secs_f64(),
                "total_s": started.elapsed().as_secs_f64(),
            })
        );
    }
    Ok(())
}

fn print_scores(score: &SceneScore, classes: &ClassList, gt_points: usize, map_points: usize) {
    let m = &score.metrics;
    println!("ground truth: {gt_points} points ({} scored), map: {map_points} points", score.confusion.total());
    println!("miou   {}", python_repr(m.miou));
    println!("fmiou  {}", python_repr(m.fmiou));
    println!("macc   {}", python_repr(m.macc));
    println!();
    println!("{:>6}  {:<24} {:>10} {:>10} {:>8} {:>8}", "class", "name", "gt", "predicted", "iou", "recall");
    for c in &m.classes {
        println!("{:>6}  {:<24} {:>10} {:>10} {:>8.4} {:>8.4}", c.label, classes.name(c.label).unwrap_or("?"), c.ground_truth, c.predicted, c.iou, c.recall);
    }
}

/// What `--json` writes: the scene's confusion matrix and its headline metrics (keys sorted,
/// a metric that is undefined as `null`).
#[derive(serde::Serialize)]
struct EvalDocument {
    #[serde(flatten)]
    confusion: ConfusionDocument,
    metrics: Headline,
}

#[derive(serde::Serialize)]
struct Headline {
    fmiou: f64,
    macc: f64,
    miou: f64,
}
