//! The staged side of a release build: every stage keeps its output under `.work/` with
//! a completion marker, so an interrupted build resumes where it stopped, and one
//! sequence can be rendered by itself (a fan-out job) between the shared stages before
//! it and the assembly after it.
//!
//! One file, over 400 lines, on purpose: each stage is a few lines around one staging
//! protocol (marker, inputs, resume), and they read top to bottom in build order.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use osmab_evaluator::formats::npy::{NpyArray, write_npy_file};
use osmab_evaluator::formats::sequence::Sequence;
use osmab_evaluator::ground_truth::GroundTruth;
use osmab_evaluator::{InputError, Result};
use serde::{Deserialize, Serialize};
use serde_json::json;

use super::config::ReleaseConfig;
use super::instances::label_instances;
use super::manifest::{self, digest, list_files};
use super::quality::{Replaced, planned_problems};
use super::split::{SPLIT_SECRET_VARIABLE, SplitSecret};
use crate::convert::habitat::{ConversionReport, ConvertOptions, write_habitat_scene};
use crate::convert::scene::load_scene;
use crate::embedding::{Embedder, HashingEmbedder, ServiceEmbedder};
use crate::openai::ServiceClient;
use crate::prompts::{PromptPool, ScenePrompt, grammar_pool_with, llm::llm_pool};
use crate::render::coverage::{CoverageGoals, Plan};
use crate::render::mesh::World;
use crate::render::sequence::SequenceSummary;
use crate::selection::select;
use crate::spec::Regime;
use crate::synthesis::source::AssetSource;
use osmab_evaluator::scores::{ReleaseLighting, Split};

/// Where the build keeps its intermediate stages (not part of the release).
pub const WORK: &str = ".work";

pub(super) use osmab_evaluator::formats::json::{read as read_json, write_pretty as write_json};

/// The fingerprint of a stage's output (a directory or one file): the digest of its files.
fn fingerprint(output: &Path) -> Result<String> {
    if output.is_dir() {
        Ok(digest(&list_files(output, &[])?))
    } else if output.is_file() {
        manifest::hash_file(output).map(|(_, sha256)| sha256)
    } else {
        Ok("missing".into())
    }
}

/// Where the build in `work` keeps the archive of a sequence, and its stage marker.
fn archive_paths(work: &Path, lighting: ReleaseLighting, scene: &str) -> (PathBuf, PathBuf) {
    let dir = work.join("archives").join(lighting.name());
    (dir.join(format!("{scene}.tar")), dir.join(format!("{scene}.done")))
}

/// What a sequence's archive is made from: the sequence as its marker records it, and
/// the split whose public files it holds.
fn archive_inputs(sequence_marker: &str, split: Split) -> String {
    format!("sequence {} public files of {split}", sequence_marker.replace('\n', " "))
}

/// The archive of sequence `lighting`/`scene` (a scene of `split`) that the build of the
/// release in `out` packed when it rendered it, with its size and SHA-256 as its stage
/// marker recorded them, if there is one made from the sequence as its marker says it is
/// now, of that split's public files (a release built without the service's render jobs
/// has none: its import packs the archives).
pub fn packed_sequence_archive(out: &Path, lighting: ReleaseLighting, scene: &str, split: Split) -> Option<(PathBuf, u64, String)> {
    let work = out.join(WORK);
    let rendered = std::fs::read_to_string(work.join("rendered").join(lighting.name()).join(format!("{scene}.done"))).ok()?;
    let (archive, marker) = archive_paths(&work, lighting, scene);
    let recorded = std::fs::read_to_string(&marker).ok()?;
    let sha256 = recorded.strip_prefix(&format!("inputs {}\noutput ", archive_inputs(&rendered, split)))?.strip_suffix('\n')?;
    let size = std::fs::metadata(&archive).ok()?.len();
    (sha256.len() == 64 && sha256.bytes().all(|b| b.is_ascii_hexdigit())).then(|| (archive, size, sha256.to_string()))
}

/// A stage marker: what the stage was built from and the fingerprint of what it wrote.
fn marker_text(inputs: &str, output: &Path) -> Result<String> {
    Ok(format!("inputs {inputs}\noutput {}\n", fingerprint(output)?))
}

/// Run `stage` unless its marker says it finished from the same `inputs` and its output
/// is still what the marker recorded; a partial output (no marker), a changed one
/// (corrupted, edited) or one built from other inputs is removed and built again.
pub(super) fn staged(marker: &Path, inputs: &str, output: &Path, stage: impl FnOnce() -> Result<()>) -> Result<bool> {
    if current_or_cleared(marker, inputs, output)? {
        return Ok(false);
    }
    stage()?;
    mark_done(marker, inputs, output)?;
    Ok(true)
}

/// The first half of [`staged`]: whether the stage behind `marker` finished from `inputs`
/// and `output` is what it recorded; when not, its marker and output are removed.
fn current_or_cleared(marker: &Path, inputs: &str, output: &Path) -> Result<bool> {
    if let Ok(recorded) = std::fs::read_to_string(marker) {
        if recorded == marker_text(inputs, output)? {
            return Ok(true);
        }
        std::fs::remove_file(marker).map_err(|e| InputError::io(marker, &e))?;
    }
    if output.is_dir() {
        std::fs::remove_dir_all(output).map_err(|e| InputError::io(output, &e))?;
    } else if output.exists() {
        std::fs::remove_file(output).map_err(|e| InputError::io(output, &e))?;
    }
    Ok(false)
}

/// The second half of [`staged`]: record that the stage made `output` from `inputs`.
fn mark_done(marker: &Path, inputs: &str, output: &Path) -> Result<()> {
    if let Some(parent) = marker.parent() {
        std::fs::create_dir_all(parent).map_err(|e| InputError::io(parent, &e))?;
    }
    std::fs::write(marker, marker_text(inputs, output)?).map_err(|e| InputError::io(marker, &e))
}

/// One sequence of a release: a scene (by its place in the selection) under one lighting.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct SequenceUnit {
    pub scene_index: usize,
    pub scene: String,
    pub lighting: ReleaseLighting,
}

/// The selected prompts (one per scene, furniture first) and the spares of each regime
/// that replace a scene missing the quality bar, in farthest-first order: val scenes take
/// `spares`, test scenes `test_spares` (drawn in the secret order, never published).
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct Selection {
    pub scenes: Vec<ScenePrompt>,
    pub spares: BTreeMap<Regime, Vec<ScenePrompt>>,
    #[serde(default)]
    pub test_spares: BTreeMap<Regime, Vec<ScenePrompt>>,
}

impl Selection {
    /// The spares a scene of `regime` and `split` may be replaced from.
    pub fn spares_for(&self, regime: Regime, split: Split) -> &[ScenePrompt] {
        let spares = if split == Split::Test { &self.test_spares } else { &self.spares };
        spares.get(&regime).map(Vec::as_slice).unwrap_or(&[])
    }
}

/// The keys selection knows a pool's accepted prompts by: id and position.
fn pool_keys(pool: &PromptPool) -> Vec<String> {
    pool.accepted.iter().enumerate().map(|(i, p)| format!("{}#{i}", p.id)).collect()
}

/// The accepted prompt of `pool` that `key` (of [`pool_keys`]) names.
fn prompt_of_key(pool: &PromptPool, key: &str) -> ScenePrompt {
    let index: usize = key.rsplit('#').next().and_then(|i| i.parse().ok()).expect("keys end in their position");
    pool.accepted[index].clone()
}

/// One side's selection as a stage keeps it: per subset its scenes' prompts in order and
/// its spares (and, for the val side, the selection's keys and embeddings, which the test
/// side's draw continues from).
#[derive(Debug, Clone, Default, Serialize, Deserialize)]
struct OpenSelection {
    scenes: BTreeMap<Regime, Vec<ScenePrompt>>,
    spares: BTreeMap<Regime, Vec<ScenePrompt>>,
    #[serde(default, skip_serializing_if = "BTreeMap::is_empty")]
    keys: BTreeMap<Regime, Vec<String>>,
    #[serde(default, skip_serializing_if = "BTreeMap::is_empty")]
    embeddings: BTreeMap<Regime, Vec<Vec<f32>>>,
}

/// The prompt a scene was settled on, which placement of it, and the candidates replaced
/// before it.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct SettledScene {
    pub prompt: ScenePrompt,
    pub replaced: Vec<Replaced>,
    /// The placement (0: the scene's own seed; n: the n-th seed derived from it).
    #[serde(default)]
    pub placement: usize,
}

/// A release build in progress: its config and folders.
pub struct Build {
    pub config: ReleaseConfig,
    pub config_text: String,
    config_path: PathBuf,
    pub out: PathBuf,
    pub work: PathBuf,
    inputs: String,
    secret: Option<SplitSecret>,
    /// Where the built-in synthesizer takes its assets from.
    assets: AssetSource,
}

/// The name of the scene at `index` of the selection.
pub fn scene_name(index: usize) -> String {
    format!("scene_{index:03}")
}

/// Spare prompts selected beyond the wanted number, per regime and split (the test split
/// keeps the rest of its draw as spares too); none where none is wanted.
fn spare_count(wanted: usize) -> usize {
    if wanted == 0 { 0 } else { wanted.max(6) }
}

impl Build {
    /// Open the build of `config_path` into `out`; a config with a test split needs the
    /// operator's `secret`.
    pub fn open(config_path: &Path, out: &Path, secret: Option<&SplitSecret>, assets_root: &Path) -> Result<Build> {
        let (config, config_text) = ReleaseConfig::read(config_path)?;
        if !config.splits.is_empty() && secret.is_none() {
            return Err(InputError::new(
                config_path,
                "splits",
                format!(
                    "the config holds a hidden test split, whose scenes are shaped by the operator's secret: set {SPLIT_SECRET_VARIABLE} (the server keeps one in its data folder)"
                ),
            ));
        }
        let work = out.join(WORK);
        std::fs::create_dir_all(&work).map_err(|e| InputError::io(&work, &e))?;
        let assets = AssetSource::for_config(config.synthesis.assets.as_deref(), assets_root)
            .map_err(|e| InputError::new(config_path, "synthesis.assets", format!("the asset pack cannot be used: {e}")))?;
        // The pack's content, not its path, is what the scenes are made of.
        let inputs = match assets.digest() {
            Some(pack) => format!("{} assets {pack}", config.content_digest()),
            None => config.content_digest(),
        };
        let secret = if config.splits.is_empty() { None } else { secret.cloned() };
        Ok(Build { config, config_text, config_path: config_path.to_path_buf(), out: out.to_path_buf(), work, inputs, secret, assets })
    }

    /// That `units` are sequences of one scene of this build, each under a lighting of its
    /// config.
    pub fn check_scene_units(&self, units: &[SequenceUnit]) -> Result<()> {
        for unit in units {
            if !self.config.render.lightings.contains(&unit.lighting) {
                return Err(InputError::new(&self.config_path, "render.lightings", format!("'{}' is not a lighting of this release", unit.lighting)));
            }
            if (&unit.scene, unit.scene_index) != (&units[0].scene, units[0].scene_index) {
                return Err(InputError::new(&self.config_path, "(render job)", format!("{} and {} are sequences of two scenes", units[0].scene, unit.scene)));
            }
        }
        Ok(())
    }

    /// The digest of the asset pack the scenes are drawn from, when there is one.
    pub fn assets_digest(&self) -> Option<&str> {
        self.assets.digest()
    }

    /// The public id of the operator's secret, when the release has a test split.
    pub fn secret_id(&self) -> Option<String> {
        self.secret.as_ref().map(SplitSecret::id)
    }

    /// The split of scene `index`.
    pub fn split_of(&self, index: usize) -> Split {
        self.config.splits.split_of(index, self.config.selection.furniture, self.config.selection.manipuland)
    }

    /// What a scene's stages are built from beyond the config: for a test scene, the
    /// secret's id, so a build resumed under another secret redoes it.
    fn split_inputs(&self, index: usize) -> String {
        match (self.split_of(index), &self.secret) {
            (Split::Test, Some(secret)) => format!("{} split test {}", self.inputs, secret.id()),
            _ => self.inputs.clone(),
        }
    }

    /// The synthesis seed of placement `attempt` of scene `index`: the config's for a val
    /// scene, one derived from the operator's secret for a test scene; later attempts
    /// derive further seeds from the first.
    fn synthesis_seed(&self, index: usize, attempt: usize) -> u64 {
        match (self.split_of(index), &self.secret) {
            (Split::Test, Some(secret)) => secret.attempt_seed(self.config.seed, index, attempt),
            _ if attempt == 0 => self.config.seed.wrapping_add(index as u64),
            _ => {
                let mut hasher = <sha2::Sha256 as sha2::Digest>::new();
                sha2::Digest::update(&mut hasher, format!("osmab val scene placement\0{}\0{index}\0{attempt}", self.config.seed).as_bytes());
                u64::from_le_bytes(sha2::Digest::finalize(hasher)[..8].try_into().expect("8 bytes"))
            }
        }
    }

    /// What the test scenes' stages are built from: the config's content and the secret's id.
    fn test_inputs(&self) -> String {
        match &self.secret {
            Some(secret) => format!("{} split test {}", self.inputs, secret.id()),
            None => self.inputs.clone(),
        }
    }

    /// How many scenes of `regime` the test split takes.
    fn test_count(&self, regime: Regime) -> usize {
        let (selected, test) = match regime {
            Regime::Furniture => (self.config.selection.furniture, self.config.splits.test_furniture),
            Regime::Manipuland => (self.config.selection.manipuland, self.config.splits.test_manipuland),
        };
        test.min(selected)
    }

    /// Stages 1 and 2: the prompt pools, then the selected prompts with their spares. Val
    /// scenes take the pool's farthest-first selection, which the published config rebuilds;
    /// test scenes draw theirs in the operator's secret order from the rest of the pool, so
    /// no public file tells which prompt a test scene was built from.
    pub fn prompts(&self, progress: &dyn Fn(&str)) -> Result<Selection> {
        let pools = self.prompt_pools(progress)?;
        let open = self.select_val_prompts(&pools, progress)?;
        let test = match &self.secret {
            Some(secret) => self.draw_test_prompts(&pools, &open, secret, progress)?,
            None => OpenSelection::default(),
        };
        let scenes = self.assign_prompts(&open, &test)?;
        Ok(Selection { scenes, spares: open.spares, test_spares: test.spares })
    }

    /// Stage 1: the prompt pool of each regime, written by the configured LLM or the grammar.
    fn prompt_pools(&self, progress: &dyn Fn(&str)) -> Result<Vec<PromptPool>> {
        let (config, config_path, work) = (&self.config, &self.config_path, &self.work);
        let mut pools: Vec<PromptPool> = Vec::new();
        for (regime, count) in [(Regime::Furniture, config.prompts.furniture_pool), (Regime::Manipuland, config.prompts.manipuland_pool)] {
            let path = work.join(format!("prompts/{}.json", regime.name()));
            staged(&work.join(format!("prompts/{}.done", regime.name())), &self.inputs, &path, || {
                progress(&format!("prompts: writing {count} {} prompts", regime.name()));
                let pool = match &config.prompts.llm {
                    Some(llm) => {
                        let client = ServiceClient::new(llm.clone()).map_err(|e| InputError::new(config_path, "prompts.llm", e.to_string()))?;
                        llm_pool(&client, regime, count, 12, 80).map_err(|(_, e)| InputError::new(config_path, "prompts.llm", e.to_string()))?
                    }
                    None => grammar_pool_with(regime, count, config.seed, &self.assets),
                };
                write_json(&path, &pool)
            })?;
            pools.push(read_json(&path)?);
        }
        Ok(pools)
    }

    /// Stage 2 for val scenes: the pool's farthest-first selection without near-duplicates,
    /// each regime's scenes then its spares.
    fn select_val_prompts(&self, pools: &[PromptPool], progress: &dyn Fn(&str)) -> Result<OpenSelection> {
        let (config, config_path, work) = (&self.config, &self.config_path, &self.work);
        let open_dir = work.join("selection/out");
        staged(&work.join("selection/.done"), &self.inputs, &open_dir, || {
            progress("selection: removing near-duplicates, choosing diverse scenes");
            let embedder: Box<dyn Embedder> = match &config.selection.embeddings {
                Some(e) => Box::new(ServiceEmbedder {
                    client: ServiceClient::new(e.clone()).map_err(|e| InputError::new(config_path, "selection.embeddings", e.to_string()))?,
                    batch: 64,
                }),
                None => Box::new(HashingEmbedder::default()),
            };
            let mut open = OpenSelection::default();
            let mut reports = BTreeMap::new();
            for pool in pools {
                let regime = pool.regime;
                let target = self.wanted(regime) - self.test_count(regime);
                let texts: Vec<String> = pool.accepted.iter().map(|p| p.text.clone()).collect();
                let keys = pool_keys(pool);
                let embeddings = embedder.embed(&texts).map_err(|e| InputError::new(config_path, "selection.embeddings", e.to_string()))?;
                // Farthest-first is greedy: the first `target` are the val scenes, the rest spares
                // (as many as the pool has beside what the test scenes need, twice over).
                let spares = spare_count(target).min(keys.len().saturating_sub(target + 2 * self.test_count(regime)));
                let report = select(&keys, &embeddings, target + spares, config.selection.threshold);
                if report.selected.len() < target {
                    return Err(InputError::new(
                        config_path,
                        "selection",
                        format!("only {} {} prompts survive selection, {target} wanted; enlarge the pool", report.selected.len(), regime.name()),
                    ));
                }
                for (k, chosen) in report.selected.iter().enumerate() {
                    let list = if k < target { open.scenes.entry(regime).or_default() } else { open.spares.entry(regime).or_default() };
                    list.push(prompt_of_key(pool, &chosen.id));
                }
                open.keys.insert(regime, report.selected.iter().map(|s| s.id.clone()).collect());
                open.embeddings.insert(regime, embeddings);
                reports.insert(regime.name(), report);
            }
            write_json(&open_dir.join("selection.json"), &json!({"embedder": embedder.name(), "regimes": reports}))?;
            write_json(&open_dir.join("open_selection.json"), &open)
        })?;
        read_json(&open_dir.join("open_selection.json"))
    }

    /// Stage 2 for test scenes: the rest of each pool (beside the val selection `open`) in
    /// the order of the operator's `secret`.
    fn draw_test_prompts(&self, pools: &[PromptPool], open: &OpenSelection, secret: &SplitSecret, progress: &dyn Fn(&str)) -> Result<OpenSelection> {
        let (config, config_path, work) = (&self.config, &self.config_path, &self.work);
        let test_dir = work.join("selection/test");
        staged(&work.join("selection/test.done"), &self.test_inputs(), &test_dir, || {
            progress("selection: drawing the test scenes' prompts in the secret order");
            let mut drawn = OpenSelection::default();
            for pool in pools {
                let regime = pool.regime;
                let target = self.test_count(regime);
                if target == 0 {
                    continue;
                }
                let keys = pool_keys(pool);
                let earlier = open.keys.get(&regime).cloned().unwrap_or_default();
                let embeddings = open.embeddings.get(&regime).cloned().unwrap_or_default();
                // The rest of the pool in the secret's order (no near-duplicate of a kept
                // prompt: one of a val prompt would all but publish the scene's). A uniform
                // draw, not farthest-first: test scenes are drawn like the pool's prompts,
                // so the odds questions are drawn against (the pool's) hold for them.
                let report = select(&keys, &embeddings, 0, config.selection.threshold);
                let duplicates: Vec<&str> = report.near_duplicates.iter().map(|d| d.id.as_str()).collect();
                let mut order: Vec<usize> = (0..keys.len()).filter(|&i| !earlier.contains(&keys[i]) && !duplicates.contains(&keys[i].as_str())).collect();
                order.sort_by_key(|&i| (secret.test_prompt_rank(&pool.accepted[i].id), i));
                let order: Vec<String> = order.into_iter().map(|i| keys[i].clone()).collect();
                if order.len() < target {
                    return Err(InputError::new(
                        config_path,
                        "selection",
                        format!(
                            "only {} {} prompts are left for the {target} test scenes beside the val selection; enlarge the pool",
                            order.len(),
                            regime.name()
                        ),
                    ));
                }
                for (k, key) in order.iter().enumerate() {
                    let list = if k < target { drawn.scenes.entry(regime).or_default() } else { drawn.spares.entry(regime).or_default() };
                    list.push(prompt_of_key(pool, key));
                }
            }
            write_json(&test_dir.join("test_selection.json"), &drawn)
        })?;
        read_json(&test_dir.join("test_selection.json"))
    }

    /// Scene by scene in the config's order: each takes the next prompt of its subset and
    /// split (from `test` for a test scene, else from `open`).
    fn assign_prompts(&self, open: &OpenSelection, test: &OpenSelection) -> Result<Vec<ScenePrompt>> {
        let config_path = &self.config_path;
        let mut scenes = Vec::new();
        let mut taken: BTreeMap<(Regime, Split), usize> = BTreeMap::new();
        for regime in [Regime::Furniture, Regime::Manipuland] {
            for _ in 0..self.wanted(regime) {
                let index = scenes.len();
                let split = self.split_of(index);
                let source = if split == Split::Test { test } else { open };
                let next = taken.entry((regime, split)).or_default();
                let prompt = source.scenes.get(&regime).and_then(|list| list.get(*next)).cloned().ok_or_else(|| {
                    InputError::new(config_path, "selection", format!("no {split} prompt of the {} pool is left for scene {index}", regime.name()))
                })?;
                *next += 1;
                scenes.push(prompt);
            }
        }
        Ok(scenes)
    }

    /// The prompt pools' layouts the odds of questions are read from (stage 1's output,
    /// which the published config rebuilds; see [`crate::questions::priors`]).
    pub fn pool_layouts(&self) -> Result<crate::questions::priors::PoolLayouts> {
        let pools: Vec<PromptPool> = [Regime::Furniture, Regime::Manipuland]
            .iter()
            .map(|regime| read_json(&self.work.join(format!("prompts/{}.json", regime.name()))))
            .collect::<Result<_>>()?;
        Ok(crate::questions::priors::PoolLayouts::place(&pools, self.config.seed, &self.assets))
    }

    /// How many scenes of `regime` the config selects.
    fn wanted(&self, regime: Regime) -> usize {
        match regime {
            Regime::Furniture => self.config.selection.furniture,
            Regime::Manipuland => self.config.selection.manipuland,
        }
    }

    /// The inputs of a scene's stages: the config's content, its split, its prompt and
    /// which placement of it.
    fn scene_inputs(&self, index: usize, prompt: &ScenePrompt, placement: usize) -> String {
        match placement {
            0 => format!("{} prompt {}", self.split_inputs(index), prompt.id),
            n => format!("{} prompt {} placement {n}", self.split_inputs(index), prompt.id),
        }
    }

    /// The inputs of the stages of settled scene `index` (see [`Build::settle_scene`]).
    fn settled_inputs(&self, index: usize) -> Result<String> {
        let settled = self.settled(index)?;
        Ok(self.scene_inputs(index, &settled.prompt, settled.placement))
    }

    fn settled_path(&self, index: usize) -> PathBuf {
        self.work.join("scenes").join(format!("{}.json", scene_name(index)))
    }

    /// The settled prompt of scene `index` (see [`Build::settle_scene`]).
    pub fn settled(&self, index: usize) -> Result<SettledScene> {
        let path = self.settled_path(index);
        if !self.work.join("scenes").join(format!("{}.done", scene_name(index))).is_file() {
            return Err(InputError::new(&path, "(scene)", "the scene is not settled yet; the build's preparation runs before rendering"));
        }
        read_json(&path)
    }

    /// Stages 3 and 4 and the trajectory plan for scene `index`, settled on the first
    /// candidate — the selected prompt, then every spare of its subset and split not used
    /// by an earlier scene — and the first of its placements (up to `quality.placements`,
    /// each from a seed derived from the scene's, each honouring every relation of the
    /// prompt) that passes the planned quality check. Scenes must be settled in order; a
    /// scene that no candidate settles fails the build naming every candidate tried.
    pub fn settle_scene(&self, index: usize, selection: &Selection, progress: &dyn Fn(&str)) -> Result<SettledScene> {
        let scene = scene_name(index);
        let selected = selection.scenes.get(index).ok_or_else(|| {
            InputError::new(&self.config_path, "(selection)", format!("the selection has {} scenes; there is no scene {index}", selection.scenes.len()))
        })?;
        let path = self.settled_path(index);
        staged(&self.work.join("scenes").join(format!("{scene}.done")), &self.split_inputs(index), &path, || {
            // Spares taken or rejected by earlier scenes are not tried again.
            let mut used: Vec<String> = Vec::new();
            for earlier in 0..index {
                let settled = self.settled(earlier)?;
                used.push(settled.prompt.id);
                used.extend(settled.replaced.into_iter().map(|r| r.prompt_id));
            }
            let spares = selection.spares_for(selected.spec.regime, self.split_of(index));
            let candidates = std::iter::once(selected)
                .chain(spares.iter().filter(|p| !used.contains(&p.id)))
                .take(self.config.quality.replacements.map_or(usize::MAX, |n| n.saturating_add(1)));
            let mut replaced = Vec::new();
            for candidate in candidates {
                let mut misses = Vec::new();
                for placement in 0..self.config.quality.placements.max(1) {
                    self.scene_assets(index, candidate, placement, progress)?;
                    let plan = self.plan(index, candidate, placement, progress)?;
                    let conversion: ConversionReport = read_json(&self.habitat_dir(index).join("conversion_report.json"))?;
                    let unmet: Vec<String> = read_json(&self.unmet_path(index))?;
                    let problems = planned_problems(&candidate.spec, &conversion, &unmet, &plan, &self.config.quality);
                    if problems.is_empty() || !self.config.quality.enforce {
                        return write_json(&path, &SettledScene { prompt: candidate.clone(), replaced, placement });
                    }
                    misses.push(format!("placement {placement}: {}", problems.join("; ")));
                }
                progress(&format!("{scene}: {} misses the bar in every placement ({}); trying a spare prompt", candidate.id, misses.join(" / ")));
                replaced.push(Replaced { prompt_id: candidate.id.clone(), problems: misses });
            }
            let tried: Vec<String> = replaced.iter().map(|r| format!("{}: {}", r.prompt_id, r.problems.join(" / "))).collect();
            let hints = settings_that_help(&self.config, &replaced.iter().flat_map(|r| r.problems.iter().cloned()).collect::<Vec<_>>());
            Err(InputError::new(
                &path,
                "quality",
                format!(
                    "no prompt for {scene} passes the quality check; tried all {} candidates: {}. Settings that would help: {}",
                    tried.len(),
                    tried.join(" | "),
                    hints.join("; ")
                ),
            ))
        })?;
        read_json(&path)
    }

    /// The SceneSmith-format folder of scene `index`.
    pub fn scenesmith_dir(&self, index: usize) -> PathBuf {
        self.work.join("scenesmith").join(scene_name(index))
    }

    /// The relations of scene `index`'s prompt that synthesis could not meet.
    pub fn unmet_path(&self, index: usize) -> PathBuf {
        self.work.join("scenesmith").join(format!("{}.unmet.json", scene_name(index)))
    }

    /// The Habitat-style folder of scene `index`.
    pub fn habitat_dir(&self, index: usize) -> PathBuf {
        self.work.join("habitat").join(scene_name(index))
    }

    /// The planned trajectory of scene `index`.
    pub fn plan_path(&self, index: usize) -> PathBuf {
        self.work.join("plans").join(format!("{}.json", scene_name(index)))
    }

    /// Stages 3 and 4 for scene `index` from `prompt`'s placement `placement`: synthesis
    /// and conversion.
    pub fn scene_assets(&self, index: usize, prompt: &ScenePrompt, placement: usize, progress: &dyn Fn(&str)) -> Result<()> {
        let (config, scene) = (&self.config, scene_name(index));
        let inputs = self.scene_inputs(index, prompt, placement);
        let scenesmith = self.scenesmith_dir(index);
        let unmet_path = self.unmet_path(index);
        staged(&self.work.join("scenesmith").join(format!("{scene}.done")), &inputs, &scenesmith, || {
            progress(&format!("{scene}: synthesis ({}, placement {placement})", prompt.id));
            let unmet = if config.synthesis.command.is_empty() {
                // A grammar prompt carries the seed of the layout it was written from, and the
                // pool is public: a test scene is placed afresh from its secret seed instead,
                // honouring every relation the prompt states, as is any later placement.
                let placed = match (self.split_of(index), placement) {
                    (Split::Val, 0) => prompt.clone(),
                    _ => ScenePrompt { layout_seed: None, ..prompt.clone() },
                };
                crate::synthesis::synthesize(&placed, self.synthesis_seed(index, placement), &scenesmith, config.synthesis.ceiling, &self.assets)?
            } else {
                crate::synthesis::external::run_external(
                    &config.synthesis.command,
                    &prompt.text,
                    self.synthesis_seed(index, placement),
                    &scenesmith,
                    std::time::Duration::from_secs(config.synthesis.timeout_secs),
                )?;
                Vec::new()
            };
            write_json(&unmet_path, &unmet)
        })?;
        let habitat = self.habitat_dir(index);
        staged(&self.work.join("habitat").join(format!("{scene}.done")), &inputs, &habitat, || {
            progress(&format!("{scene}: conversion"));
            let mut loaded = load_scene(&scenesmith)?;
            loaded.name = scene.clone();
            write_habitat_scene(&loaded, &habitat, &ConvertOptions::default()).map(|_| ())
        })?;
        Ok(())
    }

    /// The trajectory of scene `index` (one for all its lightings), planned to observe
    /// every object, the prompted ones first.
    pub fn plan(&self, index: usize, prompt: &ScenePrompt, placement: usize, progress: &dyn Fn(&str)) -> Result<Plan> {
        let (config, scene) = (&self.config, scene_name(index));
        let path = self.plan_path(index);
        staged(&self.work.join("plans").join(format!("{scene}.done")), &self.scene_inputs(index, prompt, placement), &path, || {
            progress(&format!("{scene}: planning the trajectory"));
            let motion = config.render.motion(prompt.spec.regime, config.seed.wrapping_add(index as u64));
            let coverage = CoverageGoals { min_travel: config.quality.min_travel, ..Default::default() };
            let prompted: Vec<String> = prompt.spec.objects.iter().map(|o| o.category.clone()).collect();
            let plan = crate::render::plan_scene(&self.habitat_dir(index), &scene, &config.render.sensor(), &motion, &prompted, &coverage)?;
            write_json(&path, &plan)
        })?;
        read_json(&path)
    }

    fn sequence_paths(&self, unit: &SequenceUnit) -> (PathBuf, PathBuf, PathBuf) {
        let rendered = self.work.join("rendered").join(unit.lighting.name());
        (
            self.out.join("sequences").join(unit.lighting.name()).join(&unit.scene),
            rendered.join(format!("{}.json", unit.scene)),
            rendered.join(format!("{}.done", unit.scene)),
        )
    }

    /// Whether `unit` is rendered (its marker matches the config, the scene's prompt and
    /// what is on disk).
    pub fn sequence_rendered(&self, unit: &SequenceUnit) -> Result<bool> {
        let inputs = self.settled_inputs(unit.scene_index)?;
        let (sequence_dir, _, marker) = self.sequence_paths(unit);
        Ok(std::fs::read_to_string(&marker).is_ok_and(|recorded| marker_text(&inputs, &sequence_dir).is_ok_and(|now| now == recorded)))
    }

    /// Stage 5 for one sequence (its scene must be settled); returns its summary.
    pub fn render_sequence(&self, unit: &SequenceUnit, progress: &dyn Fn(&str)) -> Result<SequenceSummary> {
        let config = &self.config;
        let (scene, lighting) = (&unit.scene, unit.lighting);
        let inputs = self.settled_inputs(unit.scene_index)?;
        let habitat = self.habitat_dir(unit.scene_index);
        let (sequence_dir, summary_path, marker) = self.sequence_paths(unit);
        let sensor = config.render.sensor();
        staged(&marker, &inputs, &sequence_dir, || {
            progress(&format!("{scene}: rendering {lighting}"));
            let plan: Plan = read_json(&self.plan_path(unit.scene_index))?;
            if config.render.command.is_empty() {
                let rendered = crate::render::render_scene(&habitat, scene, &[lighting], &sensor, &plan.frames, &self.out.join("sequences"))?;
                return write_json(&summary_path, &rendered[0].1);
            }
            let substitutions = [
                ("scene_dir", habitat.display().to_string()),
                ("scene", scene.clone()),
                ("lighting", lighting.to_string()),
                ("out", sequence_dir.display().to_string()),
                ("width", sensor.width.to_string()),
                ("height", sensor.height.to_string()),
                ("goals", plan.goals.to_string()),
                ("seed", config.seed.wrapping_add(unit.scene_index as u64).to_string()),
                ("trajectory", self.plan_path(unit.scene_index).display().to_string()),
            ];
            std::fs::create_dir_all(&sequence_dir).map_err(|e| InputError::io(&sequence_dir, &e))?;
            let log = self.work.join("rendered").join(lighting.name()).join(format!("{scene}.log"));
            crate::external::run_command(&config.render.command, &substitutions, &log, std::time::Duration::from_secs(config.render.timeout_secs))?;
            // Whatever rendered it, it must be a sequence the evaluator reads.
            write_json(&summary_path, &crate::render::sequence::summarize_sequence(&sequence_dir)?)
        })?;
        read_json(&summary_path)
    }

    /// Stage 5 for every one of `units`, the sequences of one settled scene; returns their
    /// summaries in order. With the built-in renderer, the sequences not yet rendered are
    /// drawn together (one visibility pass a frame for all their lightings: the same bytes
    /// as one at a time); an external renderer renders one sequence at a time.
    pub fn render_scene_sequences(&self, units: &[SequenceUnit], progress: &dyn Fn(&str)) -> Result<Vec<SequenceSummary>> {
        let Some(first) = units.first() else { return Ok(Vec::new()) };
        assert!(units.iter().all(|u| u.scene_index == first.scene_index), "the units of one scene");
        if !self.config.render.command.is_empty() {
            return units.iter().map(|unit| self.render_sequence(unit, progress)).collect();
        }
        let inputs = self.settled_inputs(first.scene_index)?;
        let mut stale = Vec::new();
        for unit in units {
            let (sequence_dir, _, marker) = self.sequence_paths(unit);
            if !current_or_cleared(&marker, &inputs, &sequence_dir)? {
                stale.push(unit);
            }
        }
        if !stale.is_empty() {
            let lightings: Vec<ReleaseLighting> = stale.iter().map(|u| u.lighting).collect();
            progress(&format!("{}: rendering {}", first.scene, lightings.iter().map(|l| l.name()).collect::<Vec<_>>().join(", ")));
            let plan: Plan = read_json(&self.plan_path(first.scene_index))?;
            let habitat = self.habitat_dir(first.scene_index);
            let rendered =
                crate::render::render_scene(&habitat, &first.scene, &lightings, &self.config.render.sensor(), &plan.frames, &self.out.join("sequences"))?;
            for (unit, (_, summary)) in stale.iter().zip(rendered) {
                let (sequence_dir, summary_path, marker) = self.sequence_paths(unit);
                write_json(&summary_path, &summary)?;
                mark_done(&marker, &inputs, &sequence_dir)?;
            }
        }
        units.iter().map(|unit| read_json(&self.sequence_paths(unit).1)).collect()
    }

    /// The contact sheet of a rendered sequence (a grid of its telling frames), made again
    /// whenever the sequence is.
    pub fn contact_sheet(&self, unit: &SequenceUnit, summary: &SequenceSummary) -> Result<PathBuf> {
        let (sequence_dir, _, sequence_marker) = self.sequence_paths(unit);
        let sheet = self.out.join("quality/contact_sheets").join(unit.lighting.name()).join(format!("{}.png", unit.scene));
        let marker = self.work.join("contact_sheets").join(unit.lighting.name()).join(format!("{}.done", unit.scene));
        let rendered = std::fs::read_to_string(&sequence_marker).map_err(|e| InputError::io(&sequence_marker, &e))?;
        staged(&marker, &format!("sequence {}", rendered.replace('\n', " ")), &sheet, || super::contact::write_contact_sheet(&sequence_dir, summary, &sheet))?;
        Ok(sheet)
    }

    /// The sequence's download archive (`.work/archives/LIGHTING/SCENE.tar`, names under
    /// `sequences/LIGHTING/SCENE/`): the public files of the sequence for its scene's split
    /// ([`super::publication`]), exactly those the manifest lists, packed by the job that
    /// rendered it so the import of the release need not (see [`packed_sequence_archive`]);
    /// made again whenever the sequence is.
    pub fn sequence_archive(&self, unit: &SequenceUnit) -> Result<PathBuf> {
        let (sequence_dir, _, sequence_marker) = self.sequence_paths(unit);
        let (archive, marker) = archive_paths(&self.work, unit.lighting, &unit.scene);
        let rendered = std::fs::read_to_string(&sequence_marker).map_err(|e| InputError::io(&sequence_marker, &e))?;
        let split = self.split_of(unit.scene_index);
        staged(&marker, &archive_inputs(&rendered, split), &archive, || {
            std::fs::create_dir_all(archive.parent().expect("in the archives folder")).map_err(|e| InputError::io(&archive, &e))?;
            let prefix = osmab_evaluator::formats::manifest::sequence_prefix(unit.lighting, &unit.scene);
            let files = super::publication::public_sequence_files(split, &sequence_dir)?;
            osmab_evaluator::submission::pack_files_as(&sequence_dir, &files, &prefix, &archive).map(|_| ())
        })?;
        Ok(archive)
    }

    /// The lighting whose sequence the ground truth is built from: baseline when the
    /// release has it.
    pub fn ground_truth_lighting(&self) -> ReleaseLighting {
        let lightings = &self.config.render.lightings;
        if lightings.contains(&ReleaseLighting::BASELINE) { ReleaseLighting::BASELINE } else { lightings[0] }
    }

    /// Stage 6 for scene `index`: the ground truth from the baseline sequence, with the
    /// object instance of every point.
    pub fn ground_truth(&self, index: usize, progress: &dyn Fn(&str)) -> Result<PathBuf> {
        let scene = scene_name(index);
        let inputs = self.settled_inputs(index)?;
        let gt_dir = self.out.join(super::publication::GROUND_TRUTH).join(&scene);
        let gt_source = self.out.join("sequences").join(self.ground_truth_lighting().name()).join(&scene);
        let habitat = self.habitat_dir(index);
        staged(&self.work.join("gt").join(format!("{scene}.done")), &inputs, &gt_dir, || {
            progress(&format!("{scene}: ground truth"));
            let sequence = Sequence::open(&gt_source)?;
            let gt = GroundTruth::build(&sequence)?;
            gt.write(&gt_dir)?;
            sequence.classes()?.write(&gt_dir.join("embed_semseg_classes.json"))?;
            let world = World::load_habitat_scene(&habitat, &scene)?;
            let conversion: ConversionReport = read_json(&habitat.join("conversion_report.json"))?;
            let labels = label_instances(&world, &sequence, &gt, &conversion)?;
            write_npy_file(&gt_dir.join(INSTANCES_NPY), &NpyArray::from_i64(labels.per_point.clone()))?;
            write_json(&gt_dir.join(INSTANCES_JSON), &labels)
        })?;
        Ok(gt_dir)
    }
}

/// Per ground-truth point, its object instance id (int64; 0 unknown).
pub const INSTANCES_NPY: &str = "instances.npy";
/// Per instance, its ground-truth points and albedo, and how the points were labelled.
pub const INSTANCES_JSON: &str = "instances.json";

/// The settings of `config` that would let a scene pass, given what its candidates missed
/// (`problems`, as [`planned_problems`] words them): the most specific first, then the
/// ones that help any miss.
fn settings_that_help(config: &ReleaseConfig, problems: &[String]) -> Vec<String> {
    let (render, quality) = (&config.render, &config.quality);
    let missed = |what: &str| problems.iter().any(|p| p.contains(what));
    let mut hints = Vec::new();
    if missed("camera travel") {
        hints.push(format!(
            "more goals for the camera (render.goals_furniture = {}, render.goals_manipuland = {}) or a lower quality.min_travel (now {} m)",
            render.goals_furniture, render.goals_manipuland, quality.min_travel
        ));
    }
    if missed("(planned)") {
        hints.push(format!(
            "more goals or frames so the camera sees every prompted object (render.goals_furniture = {}, render.goals_manipuland = {}, render.max_frames = {})",
            render.goals_furniture, render.goals_manipuland, render.max_frames
        ));
    }
    if missed("degenerate frames") {
        hints.push(format!("a higher quality.max_degenerate_fraction (now {})", quality.max_degenerate_fraction));
    }
    if missed("relation not met") {
        hints.push(format!("more placements per prompt (quality.placements = {})", quality.placements));
    }
    hints.push(format!(
        "more spare prompts (prompts.furniture_pool = {}, prompts.manipuland_pool = {}{})",
        config.prompts.furniture_pool,
        config.prompts.manipuland_pool,
        quality.replacements.map_or(String::new(), |n| format!(", quality.replacements = {n}"))
    ));
    hints.push("for a test build only, quality.enforce = false builds anyway and lists the misses in the quality report".into());
    hints
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_scene_that_no_candidate_settles_names_the_settings_that_would_help() {
        let text = include_str!("../../../configs/release-demo.toml");
        let (config, _) = ReleaseConfig::parse(text, Path::new("release-demo.toml")).unwrap();
        let hints = settings_that_help(&config, &["camera travel: 1.38 m planned (at least 2 m)".into(), "relation not met: cup on table".into()]);
        assert!(hints[0].contains("render.goals_furniture = 3") && hints[0].contains("quality.min_travel (now 2 m)"), "{hints:?}");
        assert!(hints[1].contains("quality.placements = 4"), "{hints:?}");
        assert!(hints[2].contains("prompts.furniture_pool = 40") && hints.last().unwrap().contains("quality.enforce = false"), "{hints:?}");
        assert!(!hints.iter().any(|h| h.contains("max_degenerate_fraction")), "only what was missed: {hints:?}");
    }
}
