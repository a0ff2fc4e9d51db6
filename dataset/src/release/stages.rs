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
use crate::prompts::{PromptPool, ScenePrompt, grammar_pool, llm::llm_pool};
use crate::render::coverage::{CoverageGoals, Plan};
use crate::render::mesh::World;
use crate::render::sequence::SequenceSummary;
use crate::selection::select;
use crate::spec::Regime;
use osmab_evaluator::scores::Split;

/// Where the build keeps its intermediate stages (not part of the release).
pub const WORK: &str = ".work";

pub(super) fn write_json(path: &Path, value: &impl Serialize) -> Result<()> {
    if let Some(dir) = path.parent() {
        std::fs::create_dir_all(dir).map_err(|e| InputError::io(dir, &e))?;
    }
    std::fs::write(path, serde_json::to_string_pretty(value).expect("serialisable") + "\n").map_err(|e| InputError::io(path, &e))
}

pub(super) fn read_json<T: serde::de::DeserializeOwned>(path: &Path) -> Result<T> {
    let bytes = std::fs::read(path).map_err(|e| InputError::io(path, &e))?;
    serde_json::from_slice(&bytes).map_err(|e| InputError::new(path, "(json)", e.to_string()))
}

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
fn archive_paths(work: &Path, lighting: &str, scene: &str) -> (PathBuf, PathBuf) {
    let dir = work.join("archives").join(lighting);
    (dir.join(format!("{scene}.tar")), dir.join(format!("{scene}.done")))
}

/// What a sequence's archive is made from: the sequence as its marker records it.
fn archive_inputs(sequence_marker: &str) -> String {
    format!("sequence {}", sequence_marker.replace('\n', " "))
}

/// The archive of sequence `lighting`/`scene` that the build of the release in `out`
/// packed when it rendered it, with its size and SHA-256 as its stage marker recorded
/// them, if there is one made from the sequence as its marker says it is now (a release
/// built without the service's render jobs has none: its import packs the archives).
pub fn packed_sequence_archive(out: &Path, lighting: &str, scene: &str) -> Option<(PathBuf, u64, String)> {
    let work = out.join(WORK);
    let rendered = std::fs::read_to_string(work.join("rendered").join(lighting).join(format!("{scene}.done"))).ok()?;
    let (archive, marker) = archive_paths(&work, lighting, scene);
    let recorded = std::fs::read_to_string(&marker).ok()?;
    let sha256 = recorded.strip_prefix(&format!("inputs {}\noutput ", archive_inputs(&rendered)))?.strip_suffix('\n')?;
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
    if let Ok(recorded) = std::fs::read_to_string(marker) {
        if recorded == marker_text(inputs, output)? {
            return Ok(false);
        }
        std::fs::remove_file(marker).map_err(|e| InputError::io(marker, &e))?;
    }
    if output.is_dir() {
        std::fs::remove_dir_all(output).map_err(|e| InputError::io(output, &e))?;
    } else if output.exists() {
        std::fs::remove_file(output).map_err(|e| InputError::io(output, &e))?;
    }
    stage()?;
    if let Some(parent) = marker.parent() {
        std::fs::create_dir_all(parent).map_err(|e| InputError::io(parent, &e))?;
    }
    std::fs::write(marker, marker_text(inputs, output)?).map_err(|e| InputError::io(marker, &e))?;
    Ok(true)
}

/// The digest of everything in a config that shapes the release's content (not its
/// name, date or secrets): a stage built from another config is rebuilt.
fn inputs_digest(config: &ReleaseConfig) -> String {
    let mut content = config.clone();
    content.version.clear();
    content.created.clear();
    for service in [&mut content.prompts.llm, &mut content.selection.embeddings].into_iter().flatten() {
        service.api_key = None;
    }
    manifest::hex(&<sha2::Sha256 as sha2::Digest>::digest(serde_json::to_vec(&content).expect("serialisable")))
}

/// One sequence of a release: a scene (by its place in the selection) under one lighting.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct SequenceUnit {
    pub scene_index: usize,
    pub scene: String,
    pub lighting: String,
}

/// The selected prompts (one per scene, furniture first) and the spares of each regime
/// that replace a scene missing the quality bar, in farthest-first order.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct Selection {
    pub scenes: Vec<ScenePrompt>,
    pub spares: BTreeMap<Regime, Vec<ScenePrompt>>,
}

/// The prompt a scene was settled on, and the candidates replaced before it.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct SettledScene {
    pub prompt: ScenePrompt,
    pub replaced: Vec<Replaced>,
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
}

/// The name of the scene at `index` of the selection.
pub fn scene_name(index: usize) -> String {
    format!("scene_{index:03}")
}

/// Spare prompts selected beyond the wanted number, per regime.
fn spare_count(wanted: usize) -> usize {
    (wanted / 2).max(4)
}

impl Build {
    /// Open the build of `config_path` into `out`; a config with a test split needs the
    /// operator's `secret`.
    pub fn open(config_path: &Path, out: &Path, secret: Option<&SplitSecret>) -> Result<Build> {
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
        let inputs = inputs_digest(&config);
        let secret = if config.splits.is_empty() { None } else { secret.cloned() };
        Ok(Build { config, config_text, config_path: config_path.to_path_buf(), out: out.to_path_buf(), work, inputs, secret })
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

    /// The synthesis seed of scene `index`: the config's for a val scene, one derived
    /// from the operator's secret for a test scene.
    fn synthesis_seed(&self, index: usize) -> u64 {
        match (self.split_of(index), &self.secret) {
            (Split::Test, Some(secret)) => secret.scene_seed(self.config.seed, index),
            _ => self.config.seed.wrapping_add(index as u64),
        }
    }

    /// Stages 1 and 2: the prompt pools, then the selected prompts with their spares.
    pub fn prompts(&self, progress: &dyn Fn(&str)) -> Result<Selection> {
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
                    None => grammar_pool(regime, count, config.seed),
                };
                write_json(&path, &pool)
            })?;
            pools.push(read_json(&path)?);
        }

        let selected_dir = work.join("selection/out");
        staged(&work.join("selection/.done"), &self.inputs, &selected_dir, || {
            progress("selection: removing near-duplicates, choosing diverse scenes");
            let embedder: Box<dyn Embedder> = match &config.selection.embeddings {
                Some(e) => Box::new(ServiceEmbedder {
                    client: ServiceClient::new(e.clone()).map_err(|e| InputError::new(config_path, "selection.embeddings", e.to_string()))?,
                    batch: 64,
                }),
                None => Box::new(HashingEmbedder::default()),
            };
            let mut selection = Selection { scenes: Vec::new(), spares: BTreeMap::new() };
            let mut reports = BTreeMap::new();
            for (pool, target) in pools.iter().zip([config.selection.furniture, config.selection.manipuland]) {
                let texts: Vec<String> = pool.accepted.iter().map(|p| p.text.clone()).collect();
                let keys: Vec<String> = pool.accepted.iter().enumerate().map(|(i, p)| format!("{}#{i}", p.id)).collect();
                let embeddings = embedder.embed(&texts).map_err(|e| InputError::new(config_path, "selection.embeddings", e.to_string()))?;
                // Farthest-first is greedy: the first `target` are the selection, the rest spares.
                let report = select(&keys, &embeddings, target + spare_count(target), config.selection.threshold);
                if report.selected.len() < target {
                    return Err(InputError::new(
                        config_path,
                        "selection",
                        format!("only {} {} prompts survive selection, {target} wanted; enlarge the pool", report.selected.len(), pool.regime.name()),
                    ));
                }
                for (k, s) in report.selected.iter().enumerate() {
                    let index: usize = s.id.rsplit('#').next().and_then(|i| i.parse().ok()).expect("keys end in their position");
                    let prompt = pool.accepted[index].clone();
                    if k < target {
                        selection.scenes.push(prompt);
                    } else {
                        selection.spares.entry(pool.regime).or_default().push(prompt);
                    }
                }
                reports.insert(pool.regime.name(), report);
            }
            write_json(&selected_dir.join("selection.json"), &json!({"embedder": embedder.name(), "regimes": reports}))?;
            write_json(&selected_dir.join("final_prompts.json"), &selection.scenes)?;
            write_json(&selected_dir.join("spare_prompts.json"), &selection.spares)
        })?;
        Ok(Selection { scenes: read_json(&selected_dir.join("final_prompts.json"))?, spares: read_json(&selected_dir.join("spare_prompts.json"))? })
    }

    /// The inputs of a scene's stages: the config's content, its split and its prompt.
    fn scene_inputs(&self, index: usize, prompt: &ScenePrompt) -> String {
        format!("{} prompt {}", self.split_inputs(index), prompt.id)
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
    /// candidate — the selected prompt, then the spares of its regime not used by an
    /// earlier scene — that passes the planned quality check. Scenes must be settled
    /// in order.
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
            let spares = selection.spares.get(&selected.spec.regime).map(Vec::as_slice).unwrap_or(&[]);
            let candidates = std::iter::once(selected).chain(spares.iter().filter(|p| !used.contains(&p.id))).take(1 + self.config.quality.replacements);
            let mut replaced = Vec::new();
            for candidate in candidates {
                self.scene_assets(index, candidate, progress)?;
                let plan = self.plan(index, candidate, progress)?;
                let conversion: ConversionReport = read_json(&self.habitat_dir(index).join("conversion_report.json"))?;
                let unmet: Vec<String> = read_json(&self.unmet_path(index))?;
                let problems = planned_problems(&candidate.spec, &conversion, &unmet, &plan, &self.config.quality);
                if problems.is_empty() || !self.config.quality.enforce {
                    return write_json(&path, &SettledScene { prompt: candidate.clone(), replaced });
                }
                progress(&format!("{scene}: {} misses the bar ({}); trying a spare prompt", candidate.id, problems.join("; ")));
                replaced.push(Replaced { prompt_id: candidate.id.clone(), problems });
            }
            let tried: Vec<String> = replaced.iter().map(|r| format!("{}: {}", r.prompt_id, r.problems.join("; "))).collect();
            Err(InputError::new(&path, "quality", format!("no prompt for {scene} passes the quality check; tried {}", tried.join(" | "))))
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

    /// Stages 3 and 4 for scene `index` from `prompt`: synthesis and conversion.
    pub fn scene_assets(&self, index: usize, prompt: &ScenePrompt, progress: &dyn Fn(&str)) -> Result<()> {
        let (config, scene) = (&self.config, scene_name(index));
        let inputs = self.scene_inputs(index, prompt);
        let scenesmith = self.scenesmith_dir(index);
        let unmet_path = self.unmet_path(index);
        staged(&self.work.join("scenesmith").join(format!("{scene}.done")), &inputs, &scenesmith, || {
            progress(&format!("{scene}: synthesis ({})", prompt.id));
            let unmet = if config.synthesis.command.is_empty() {
                // A grammar prompt carries the seed of the layout it was written from, and the
                // pool is public: a test scene is placed afresh from its secret seed instead,
                // honouring every relation the prompt states.
                let placed = match self.split_of(index) {
                    Split::Test => ScenePrompt { layout_seed: None, ..prompt.clone() },
                    Split::Val => prompt.clone(),
                };
                crate::synthesis::synthesize(&placed, self.synthesis_seed(index), &scenesmith, config.synthesis.ceiling)?
            } else {
                crate::synthesis::external::run_external(
                    &config.synthesis.command,
                    &prompt.text,
                    self.synthesis_seed(index),
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
    pub fn plan(&self, index: usize, prompt: &ScenePrompt, progress: &dyn Fn(&str)) -> Result<Plan> {
        let (config, scene) = (&self.config, scene_name(index));
        let path = self.plan_path(index);
        staged(&self.work.join("plans").join(format!("{scene}.done")), &self.scene_inputs(index, prompt), &path, || {
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
        let rendered = self.work.join("rendered").join(&unit.lighting);
        (
            self.out.join("sequences").join(&unit.lighting).join(&unit.scene),
            rendered.join(format!("{}.json", unit.scene)),
            rendered.join(format!("{}.done", unit.scene)),
        )
    }

    /// Whether `unit` is rendered (its marker matches the config, the scene's prompt and
    /// what is on disk).
    pub fn sequence_rendered(&self, unit: &SequenceUnit) -> Result<bool> {
        let prompt = self.settled(unit.scene_index)?.prompt;
        let (sequence_dir, _, marker) = self.sequence_paths(unit);
        Ok(std::fs::read_to_string(&marker)
            .is_ok_and(|recorded| marker_text(&self.scene_inputs(unit.scene_index, &prompt), &sequence_dir).is_ok_and(|now| now == recorded)))
    }

    /// Stage 5 for one sequence (its scene must be settled); returns its summary.
    pub fn render_sequence(&self, unit: &SequenceUnit, progress: &dyn Fn(&str)) -> Result<SequenceSummary> {
        let config = &self.config;
        let (scene, lighting) = (&unit.scene, unit.lighting.as_str());
        let prompt = self.settled(unit.scene_index)?.prompt;
        let habitat = self.habitat_dir(unit.scene_index);
        let (sequence_dir, summary_path, marker) = self.sequence_paths(unit);
        let sensor = config.render.sensor();
        staged(&marker, &self.scene_inputs(unit.scene_index, &prompt), &sequence_dir, || {
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
            let log = self.work.join("rendered").join(lighting).join(format!("{scene}.log"));
            crate::external::run_command(&config.render.command, &substitutions, &log, std::time::Duration::from_secs(config.render.timeout_secs))?;
            // Whatever rendered it, it must be a sequence the evaluator reads.
            write_json(&summary_path, &super::summarize_sequence(&sequence_dir)?)
        })?;
        read_json(&summary_path)
    }

    /// The contact sheet of a rendered sequence (a grid of its telling frames), made again
    /// whenever the sequence is.
    pub fn contact_sheet(&self, unit: &SequenceUnit, summary: &SequenceSummary) -> Result<PathBuf> {
        let (sequence_dir, _, sequence_marker) = self.sequence_paths(unit);
        let sheet = self.out.join("quality/contact_sheets").join(&unit.lighting).join(format!("{}.png", unit.scene));
        let marker = self.work.join("contact_sheets").join(&unit.lighting).join(format!("{}.done", unit.scene));
        let rendered = std::fs::read_to_string(&sequence_marker).map_err(|e| InputError::io(&sequence_marker, &e))?;
        staged(&marker, &format!("sequence {}", rendered.replace('\n', " ")), &sheet, || super::contact::write_contact_sheet(&sequence_dir, summary, &sheet))?;
        Ok(sheet)
    }

    /// The sequence's download archive (`.work/archives/LIGHTING/SCENE.tar`, names under
    /// `sequences/LIGHTING/SCENE/`), packed by the job that rendered it so the import of
    /// the release need not (see [`packed_sequence_archive`]); made again whenever the
    /// sequence is.
    pub fn sequence_archive(&self, unit: &SequenceUnit) -> Result<PathBuf> {
        let (sequence_dir, _, sequence_marker) = self.sequence_paths(unit);
        let (archive, marker) = archive_paths(&self.work, &unit.lighting, &unit.scene);
        let rendered = std::fs::read_to_string(&sequence_marker).map_err(|e| InputError::io(&sequence_marker, &e))?;
        staged(&marker, &archive_inputs(&rendered), &archive, || {
            std::fs::create_dir_all(archive.parent().expect("in the archives folder")).map_err(|e| InputError::io(&archive, &e))?;
            let prefix = format!("sequences/{}/{}/", unit.lighting, unit.scene);
            osmab_evaluator::submission::pack_directory_as(&sequence_dir, &prefix, &archive).map(|_| ())
        })?;
        Ok(archive)
    }

    /// The lighting whose sequence the ground truth is built from: baseline when the
    /// release has it.
    pub fn ground_truth_lighting(&self) -> &str {
        let lightings = &self.config.render.lightings;
        if lightings.iter().any(|l| l == "baseline") { "baseline" } else { lightings[0].as_str() }
    }

    /// Stage 6 for scene `index`: the ground truth from the baseline sequence, with the
    /// object instance of every point.
    pub fn ground_truth(&self, index: usize, progress: &dyn Fn(&str)) -> Result<PathBuf> {
        let scene = scene_name(index);
        let prompt = self.settled(index)?.prompt;
        let gt_dir = self.out.join(super::GROUND_TRUTH).join(&scene);
        let gt_source = self.out.join("sequences").join(self.ground_truth_lighting()).join(&scene);
        let habitat = self.habitat_dir(index);
        staged(&self.work.join("gt").join(format!("{scene}.done")), &self.scene_inputs(index, &prompt), &gt_dir, || {
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
