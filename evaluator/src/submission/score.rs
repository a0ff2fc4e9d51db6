//! Scoring a valid submission: every map against its scene's ground truth, then per
//! lighting the scene rows, `overall_mean` and the pooled `overall`, per subset the same
//! two aggregates, and the relative change of each lighting against `baseline`; the
//! pooled aggregates carry bootstrap intervals over the release's scenes.

use std::collections::BTreeMap;
use std::path::Path;
use std::sync::Arc;
use std::time::{Duration, Instant};

use super::release::ReleaseIndex;
use super::validate::{SubmissionLimits, ValidSubmission};
use crate::EVALUATOR_VERSION;
use crate::error::{InputError, Result, ScoreError};
use crate::formats::classes::ClassList;
use crate::formats::map::{PredictedMap, TextFeatures};
use crate::ground_truth::GroundTruth;
use crate::scores::{Lighting, LightingScores, Regime, RelativeChange, Scores, SubsetScores};
use crate::semseg::background_store::BackgroundStore;
use crate::semseg::bootstrap::Replicates;
use crate::semseg::confusion::ConfusionMatrix;
use crate::semseg::metrics::ClassCount;
use crate::semseg::prepared_cache::{CacheKey, CacheMiss, PreparedCache};
use crate::semseg::report::{MetricTriple, MetricsTable};
use crate::semseg::{PreparedGroundTruth, Scratch, StageTimings, score_prepared_reusing};

/// Where the time of scoring a submission went, summed over its maps.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct ScoringTimings {
    /// Maps scored.
    pub maps: usize,
    /// Ground-truth points associated, over all maps.
    pub ground_truth_points: u64,
    /// Reading the ground truth of each scene (once a scene), from the release or
    /// already prepared from the cache.
    pub read_ground_truth: Duration,
    /// Scenes whose prepared ground truth came from the cache.
    pub ground_truth_cached: usize,
    /// Why a scene's ground truth was not taken from the cache (at most one line a scene).
    pub cache_misses: Vec<String>,
    /// Why a scene's prepared ground truth could not be kept in the cache (at most one line
    /// a scene; the next scoring prepares it again).
    pub not_kept: Vec<String>,
    /// Checking each scene's ground truth and putting it in Z-order (once a scene).
    pub prepare_ground_truth: Duration,
    /// Keeping each scene's prepared ground truth in the cache (when it was not there), on a
    /// thread of its own beside the scoring: not part of the scoring's time.
    pub keep_ground_truth: Duration,
    /// What the scoring waited for that thread: to hand it a scene while it was still
    /// writing the one before, and at the end, for the last one.
    pub wait_for_cache: Duration,
    /// Waiting for the maps: each is read on a thread of its own while the one before it is
    /// scored, so this is the part of reading them that the scoring did not hide.
    pub read_maps: Duration,
    /// The stages of [`score_scene`], summed.
    pub scenes: StageTimings,
    /// Per-lighting tables, subsets, bootstrap intervals and relative changes.
    pub tables: Duration,
    /// Answering and judging the questions.
    pub vqa: Duration,
}

/// Score `submission` against the ground truth in `release`; `progress` hears of each
/// (lighting, scene) done and the number in all.
/// VQA is scored from the graphs and answers (see [`crate::vqa::score`]) with `open`'s
/// optional LLM answerer and judge.
pub fn score_submission(
    submission: &ValidSubmission,
    release: &ReleaseIndex,
    limits: SubmissionLimits,
    open: crate::vqa::score::OpenBackends,
    progress: &dyn Fn(usize, usize),
) -> std::result::Result<Scores, ScoreError> {
    score_submission_timed(submission, release, limits, open, None, progress).map(|(scores, _)| scores)
}

/// The ground truth in `dir` prepared for scoring: from `keeper`'s cache when it holds it
/// (read into `spare`'s memory, the scene scored before, when no one else holds that), else
/// read and put in Z-order, and handed to `keeper` to keep.
fn prepared_ground_truth(
    dir: &Path,
    classes: &ClassList,
    keeper: Option<&BackgroundStore>,
    spare: Option<Arc<PreparedGroundTruth>>,
    timings: &mut ScoringTimings,
) -> Result<Arc<PreparedGroundTruth>> {
    let clock = Instant::now();
    // The background store may still hold the scene before while it writes it.
    let spare = spare.and_then(|gt| Arc::try_unwrap(gt).ok());
    let cached = keeper.and_then(|keeper| CacheKey::of(dir).map(|key| (keeper, key)));
    if let Some((keeper, key)) = &cached {
        match keeper.cache().load_reusing(key, dir, classes, spare) {
            Ok(gt) => {
                timings.read_ground_truth += clock.elapsed();
                timings.ground_truth_cached += 1;
                return Ok(Arc::new(gt));
            }
            Err(CacheMiss(why)) => timings.cache_misses.push(format!("{}: {why}", dir.display())),
        }
    } else {
        drop(spare);
    }
    let clock = Instant::now();
    let gt = GroundTruth::read(dir, classes)?;
    timings.read_ground_truth += clock.elapsed();
    let clock = Instant::now();
    let gt = Arc::new(PreparedGroundTruth::new(gt, classes)?);
    timings.prepare_ground_truth += clock.elapsed();
    if let Some((keeper, key)) = cached {
        let clock = Instant::now();
        keeper.keep(key, Arc::clone(&gt));
        timings.wait_for_cache += clock.elapsed();
    }
    Ok(gt)
}

/// [`score_submission`], also telling where the time went, with each scene's ground truth
/// taken from `cache` when it holds it (and kept there when it does not). Maps are scored
/// scene by scene, so one scene's ground truth is read once and held only while its maps
/// are scored.
pub fn score_submission_timed(
    submission: &ValidSubmission,
    release: &ReleaseIndex,
    limits: SubmissionLimits,
    open: crate::vqa::score::OpenBackends,
    cache: Option<&PreparedCache>,
    progress: &dyn Fn(usize, usize),
) -> std::result::Result<(Scores, ScoringTimings), ScoreError> {
    if !release.has_ground_truth() {
        return Err(ScoreError::Service(InputError::new(&release.root, "ground_truth", "this copy of the release has no ground truth to score against")));
    }
    let mut timings = ScoringTimings::default();
    let by_lighting = score_maps(submission, release, limits, cache, &mut timings, progress)?;
    let clock = Instant::now();
    let mut semseg = BTreeMap::new();
    let mut tables: BTreeMap<Lighting, MetricsTable> = BTreeMap::new();
    for (lighting, scenes) in by_lighting {
        let (scores, table) = lighting_scores(release, scenes);
        semseg.insert(lighting, scores);
        tables.insert(lighting, table);
    }
    let relative_change = relative_changes(&tables);
    timings.tables = clock.elapsed();
    let clock = Instant::now();
    let vqa = published_vqa(submission, release, open)?;
    timings.vqa = clock.elapsed();
    let scores = Scores {
        complete: submission.complete,
        evaluator_version: EVALUATOR_VERSION.to_string(),
        missing_maps: submission.missing_maps.clone(),
        relative_change,
        release: release.version.clone(),
        semseg,
        split: release.split,
        vqa,
        withheld: None,
    };
    Ok((scores, timings))
}

/// Every map of `submission` scored against its scene's ground truth, scene by scene (the
/// ground truth from `cache` when it holds it, and kept there when it does not): per
/// lighting, each scene's confusion matrix.
fn score_maps(
    submission: &ValidSubmission,
    release: &ReleaseIndex,
    limits: SubmissionLimits,
    cache: Option<&PreparedCache>,
    timings: &mut ScoringTimings,
    progress: &dyn Fn(usize, usize),
) -> std::result::Result<BTreeMap<Lighting, Vec<(String, ConfusionMatrix)>>, ScoreError> {
    let text = submission.text_features.as_deref().map(|p| TextFeatures::read(p, limits.arrays)).transpose().map_err(ScoreError::Submission)?;
    let mut maps: Vec<_> = submission.entries.iter().filter_map(|e| e.map.as_ref().map(|m| (e, m))).collect();
    maps.sort_by(|(a, _), (b, _)| (&a.scene, a.lighting).cmp(&(&b.scene, b.lighting)));
    let keeper = cache.map(|cache| BackgroundStore::start(cache.clone()));
    let mut ground_truth: Option<(&str, Arc<PreparedGroundTruth>, ClassList)> = None;
    let mut by_lighting: BTreeMap<Lighting, Vec<(String, ConfusionMatrix)>> = BTreeMap::new();
    // Memory kept from map to map (see `semseg::scratch`).
    let mut scratch = Scratch::default();
    std::thread::scope(|scope| -> std::result::Result<(), ScoreError> {
        // Each map is read on a thread of its own while the one before it is scored, one map
        // ahead at most: reading a map is one core's work, which the scoring would leave
        // the other cores waiting for.
        let (send_map, next_map) = std::sync::mpsc::sync_channel(0);
        let paths: Vec<&Path> = maps.iter().map(|(_, path)| path.as_path()).collect();
        scope.spawn(move || {
            for path in paths {
                // A scorer that stopped (at an error) takes no more maps.
                if send_map.send(PredictedMap::read(path, limits.arrays)).is_err() {
                    break;
                }
            }
        });
        for (done, (entry, _)) in maps.iter().enumerate() {
            if ground_truth.as_ref().is_none_or(|(scene, _, _)| *scene != entry.scene) {
                // The scorer lets go of the previous scene's cloud before the next one is
                // read, into its memory where it can.
                let spare = ground_truth.take().map(|(_, gt, _)| gt);
                let classes = release.scene_classes(&entry.scene).map_err(ScoreError::Service)?;
                let dir = release.ground_truth_dir(&entry.scene);
                let gt = prepared_ground_truth(&dir, &classes, keeper.as_ref(), spare, timings).map_err(ScoreError::Service)?;
                ground_truth = Some((entry.scene.as_str(), gt, classes));
            }
            let (_, gt, classes) = ground_truth.as_ref().expect("read above");
            let clock = Instant::now();
            let map = next_map.recv().expect("the reader sends every map until the scorer stops").map_err(ScoreError::Submission)?;
            timings.read_maps += clock.elapsed();
            let scored = score_prepared_reusing(gt, &map, classes, text.as_ref(), &mut scratch).map_err(ScoreError::Submission)?;
            timings.scenes = timings.scenes + scored.timings;
            timings.maps += 1;
            timings.ground_truth_points += gt.len() as u64;
            by_lighting.entry(entry.lighting).or_default().push((entry.scene.clone(), scored.confusion));
            progress(done + 1, maps.len());
        }
        Ok(())
    })?;
    drop(ground_truth);
    if let Some(keeper) = keeper {
        let clock = Instant::now();
        let kept = keeper.finish();
        timings.wait_for_cache += clock.elapsed();
        timings.keep_ground_truth = kept.writing;
        timings.not_kept.extend(kept.misses);
    }
    Ok(by_lighting)
}

/// One lighting's scores from its `scenes`' confusion matrices: the scene rows, the
/// aggregates with bootstrap intervals, the same per subset; and its metrics table.
fn lighting_scores(release: &ReleaseIndex, scenes: Vec<(String, ConfusionMatrix)>) -> (LightingScores, MetricsTable) {
    let counts: BTreeMap<String, Vec<ClassCount>> = scenes.iter().map(|(s, m)| (s.clone(), ClassCount::of(m))).collect();
    // Resamples are drawn over the release's scenes in manifest order, so every
    // submission of the release is resampled alike; a scene without a map adds nothing.
    let in_release = |subset: Option<Regime>| -> Vec<Vec<ClassCount>> {
        release.scenes.iter().filter(|s| subset.is_none_or(|r| s.subset == r)).map(|s| counts.get(&s.id).cloned().unwrap_or_default()).collect()
    };
    let mut subsets = BTreeMap::new();
    for subset in Regime::ALL {
        let members: Vec<(String, ConfusionMatrix)> =
            scenes.iter().filter(|(s, _)| release.scene(s).is_some_and(|r| r.subset == subset)).map(|(s, m)| (s.clone(), m.clone())).collect();
        if !members.is_empty() {
            let table = MetricsTable::from_scenes(members);
            let overall = MetricTriple { ci95: Replicates::of(&in_release(Some(subset))).intervals(), ..(&table.overall).into() };
            subsets.insert(subset, SubsetScores { overall, overall_mean: table.overall_mean, scenes: table.scenes.len() });
        }
    }
    let table = MetricsTable::from_scenes(scenes);
    let replicates = Replicates::of(&in_release(None));
    let scores = LightingScores {
        bootstrap_miou: replicates.miou(),
        overall: MetricTriple { ci95: replicates.intervals(), ..(&table.overall).into() },
        overall_mean: table.overall_mean,
        pooled: None,
        scenes: table.scenes.iter().map(|(s, m)| (s.clone(), m.into())).collect(),
        subsets,
    };
    (scores, table)
}

/// The relative change of each lighting's aggregates against the baseline lighting's
/// (none without a baseline).
fn relative_changes(tables: &BTreeMap<Lighting, MetricsTable>) -> BTreeMap<Lighting, RelativeChange> {
    let mut relative_change = BTreeMap::new();
    if let Some(base) = tables.get(&Lighting::BASELINE) {
        for (lighting, table) in tables {
            relative_change.insert(
                *lighting,
                RelativeChange {
                    overall: MetricTriple::from(&table.overall).relative_change(&(&base.overall).into()),
                    overall_mean: table.overall_mean.relative_change(&base.overall_mean),
                },
            );
        }
    }
    relative_change
}

/// The VQA scores as published. A test scene's answers stay hidden: per question, the
/// answer given and whether it was right would tell them (the oracle's document would
/// list them all), and per scene and lighting the number right lets one submission try
/// four answer sets. The pooled accuracies (per category, group and lighting) stay.
fn published_vqa(
    submission: &ValidSubmission,
    release: &ReleaseIndex,
    open: crate::vqa::score::OpenBackends,
) -> std::result::Result<Option<crate::scores::VqaScores>, ScoreError> {
    let mut vqa = crate::vqa::score::score_vqa(submission, release, open)?;
    if release.split == Some(crate::scores::Split::Test) {
        for v in vqa.iter_mut() {
            v.scenes.clear();
        }
    }
    Ok(vqa)
}
