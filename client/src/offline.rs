//! `osmab client validate`: the server's own validation, offline — and, for every split
//! whose ground truth the release folder holds (a downloaded release holds the val
//! split's), the server's own scoring — so a team knows what the server will say before
//! spending quota. Without `--release-dir`, the public release facts (manifest, classes,
//! questions) are fetched from the server.

use std::path::Path;

use anyhow::{Context, anyhow};
use osmab_evaluator::formats::manifest::ReleaseManifest;
use osmab_evaluator::scores::Split;
use osmab_evaluator::submission::archive::{ArchiveLimits, unpack};
use osmab_evaluator::submission::release::ReleaseIndex;
use osmab_evaluator::submission::score_submission;
use osmab_evaluator::submission::validate::{SubmissionLimits, validate};
use serde_json::Value;

use super::api::Api;

/// Fetch the public facts of `version` (or of the release the submission names) into `dir`.
fn fetch_release_facts(api: &Api, submission_release: &str, dir: &Path) -> anyhow::Result<()> {
    let manifest_text = api.get_retrying(&format!("/api/v1/releases/{submission_release}/manifest.json"))?.text()?;
    let manifest = ReleaseManifest::parse(&manifest_text, Path::new(&format!("the manifest of {submission_release}"))).map_err(|e| anyhow::anyhow!("{e}"))?;
    std::fs::write(dir.join("manifest.json"), &manifest_text)?;
    for file in &manifest.files {
        let path = file.path.as_str();
        let wanted = path == "classes.json" || (path.starts_with("questions/") && !path[10..].contains('/'));
        if wanted {
            let bytes = api.get_retrying(&format!("/api/v1/releases/{submission_release}/files/{path}"))?.bytes()?;
            let target = dir.join(path);
            std::fs::create_dir_all(target.parent().expect("nested"))?;
            std::fs::write(target, bytes)?;
        }
    }
    Ok(())
}

/// The release a submission folder names in its submission.json.
fn named_release(root: &Path) -> Option<String> {
    let text = std::fs::read_to_string(root.join("submission.json")).ok()?;
    serde_json::from_str::<Value>(&text).ok()?["release"].as_str().map(str::to_string)
}

/// Validate (and, with ground truth, score) `submission`; prints the report, returns
/// whether it is valid.
/// With `scores_out`, each scored split's score document is written there too.
pub fn validate_offline(
    submission: &Path,
    release_dir: Option<&Path>,
    split: Option<Split>,
    api: Option<&Api>,
    scores_out: Option<&Path>,
) -> anyhow::Result<bool> {
    let unpacked;
    let root = if submission.is_dir() {
        submission.to_path_buf()
    } else {
        unpacked = tempfile::tempdir()?;
        unpack(submission, unpacked.path(), ArchiveLimits { max_entries: 20_000, max_total_bytes: 64 << 30, max_expansion_ratio: None })
            .map_err(|e| anyhow!("{e}"))?;
        unpacked.path().to_path_buf()
    };
    let facts;
    let release_root = match release_dir {
        Some(dir) => dir.to_path_buf(),
        None => {
            let api = api.context("give --release-dir (a downloaded release) or log in so the release facts can be fetched")?;
            let version = named_release(&root).context("submission.json is missing or names no release")?;
            facts = tempfile::tempdir()?;
            fetch_release_facts(api, &version, facts.path())?;
            facts.path().to_path_buf()
        }
    };
    let release = ReleaseIndex::read(&release_root).map_err(|e| anyhow!("{e}"))?;
    let split = split.unwrap_or_else(|| release.primary_split());
    let index = release.for_split(split).map_err(|e| anyhow!("{e}"))?;
    // The server's own checks (its configured size limit is not known here).
    let limits = SubmissionLimits::for_release(&index, u64::MAX);
    let valid = match validate(&root, &index, limits) {
        Ok(valid) => valid,
        Err(problems) => {
            println!("The submission is not valid; the server would refuse it with these {} problem(s):", problems.len());
            for p in &problems {
                println!("  - {}: {}: {}", p.file, p.field, p.message);
            }
            return Ok(false);
        }
    };
    let maps = valid.entries.iter().filter(|e| e.map.is_some()).count();
    let graphs = valid.entries.iter().filter(|e| e.graph.is_some()).count();
    let answers = valid.entries.iter().filter(|e| e.answers.is_some()).count();
    println!(
        "Valid for the {split} split of release {}: {maps} maps, {graphs} scene graphs, {answers} answer files, {} points; {}",
        index.version,
        valid.points,
        if valid.complete { "every scene and lighting covered".to_string() } else { format!("incomplete, no map for {}", valid.missing_maps.join(", ")) }
    );
    let mut scored_any = false;
    for other in release.splits() {
        let Ok(index) = release.for_split(other) else { continue };
        if !index.has_ground_truth() {
            continue;
        }
        // Another split is scored when the submission carries maps for its scenes too.
        let valid = match (other == split).then(|| Ok(valid.clone())).unwrap_or_else(|| validate(&root, &index, limits)) {
            Ok(valid) if valid.entries.iter().any(|e| e.map.is_some() || e.graph.is_some()) => valid,
            _ => continue,
        };
        let scores = score_submission(&valid, &index, limits, Default::default(), &|_, _| {}).map_err(|e| anyhow!("{e}"))?;
        println!("Scored the {other} split against the local ground truth ({} scenes; what the server will compute):", index.scenes.len());
        for (lighting, table) in &scores.semseg {
            println!("  {lighting}: {}", super::view::pooled_line(&table.overall));
        }
        print_lighting_changes(&scores);
        if let Some(dir) = scores_out {
            std::fs::create_dir_all(dir).with_context(|| format!("--scores-out {}", dir.display()))?;
            let path = dir.join(format!("scores-{other}.json"));
            std::fs::write(&path, serde_json::to_string_pretty(&scores)? + "\n").with_context(|| format!("writing {}", path.display()))?;
            println!("  (the whole score document: {})", path.display());
        }
        for (lighting, v) in scores.vqa.iter().flat_map(|v| &v.lightings) {
            println!("  {lighting}: VQA accuracy {:.1} % ({} of {} questions)", v.overall.accuracy.unwrap_or(0.0) * 100.0, v.overall.correct, v.overall.total);
        }
        scored_any = true;
    }
    if !scored_any {
        println!("(The release folder has no ground truth for the scenes submitted, so scores are computed on the server only.)");
    } else if release.splits().contains(&Split::Test) && !release.for_split(Split::Test).is_ok_and(|t| t.has_ground_truth()) {
        println!("(The test split's ground truth is hidden: its scores are computed on the server only.)");
    }
    Ok(true)
}

/// Each lighting's relative change of pooled mIoU against the baseline lighting, with the
/// 95 % interval of the paired bootstrap over scenes (every lighting resamples the same scenes).
fn print_lighting_changes(scores: &osmab_evaluator::scores::Scores) {
    use osmab_evaluator::scores::{Aggregate, Lighting, Metric};
    let Some(base) = scores.semseg.get(&Lighting::Baseline) else { return };
    for (lighting, table) in scores.semseg.iter().filter(|(l, _)| **l != Lighting::Baseline) {
        let Some(change) = scores.change_against_baseline(*lighting, None, Aggregate::Overall, Metric::Miou) else { continue };
        let interval = osmab_evaluator::bootstrap::change_interval95(&base.bootstrap_miou, &table.bootstrap_miou)
            .map_or(String::new(), |[low, high]| format!(" (95 %: {:+.1} to {:+.1} %)", low * 100.0, high * 100.0));
        println!("  {lighting} against baseline: pooled mIoU {:+.1} %{interval}", change * 100.0);
    }
}
