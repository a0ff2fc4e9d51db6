//! The staged side of a release build: every stage keeps its output under `.work/` with
//! a completion marker, so an interrupted build resumes where it stopped, and one
//! sequence can be rendered by itself (a fan-out job) between the shared stages before
//! it and the assembly after it.

use std::path::{Path, PathBuf};

use osmab_evaluator::{InputError, Result};
use serde::{Deserialize, Serialize};
use serde_json::json;

use super::config::ReleaseConfig;
use super::manifest::{self, digest, list_files};
use crate::convert::habitat::{ConvertOptions, write_habitat_scene};
use crate::convert::scene::load_scene;
use crate::embedding::{Embedder, HashingEmbedder, ServiceEmbedder};
use crate::openai::ServiceClient;
use crate::prompts::{PromptPool, ScenePrompt, grammar_pool, llm::llm_pool};
use crate::render::sequence::SequenceSummary;
use crate::render::trajectory::MotionSettings;
use crate::selection::select;
use crate::spec::Regime;
use osmab_evaluator::formats::sequence::Sequence;
use osmab_evaluator::ground_truth::GroundTruth;

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

/// A release build in progress: its config and folders.
pub struct Build {
    pub config: ReleaseConfig,
    pub config_text: String,
    config_path: PathBuf,
    pub out: PathBuf,
    pub work: PathBuf,
    inputs: String,
}

/// The name of the scene at `index` of the selection.
pub fn scene_name(index: usize) -> String {
    format!("scene_{index:03}")
}

impl Build {
    /// Open the build of `config_path` into `out`.
    pub fn open(config_path: &Path, out: &Path) -> Result<Build> {
        let (config, config_text) = ReleaseConfig::read(config_path)?;
        let work = out.join(WORK);
        std::fs::create_dir_all(&work).map_err(|e| InputError::io(&work, &e))?;
        let inputs = inputs_digest(&config);
        Ok(Build { config, config_text, config_path: config_path.to_path_buf(), out: out.to_path_buf(), work, inputs })
    }

    /// Stages 1 and 2: the prompt pools and the selected prompts, one per scene.
    pub fn prompts(&self, progress: &dyn Fn(&str)) -> Result<Vec<ScenePrompt>> {
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

        let selected_path = work.join("selection/final_prompts.json");
        staged(&work.join("selection/.done"), &self.inputs, &selected_path, || {
            progress("selection: removing near-duplicates, choosing diverse scenes");
            let embedder: Box<dyn Embedder> = match &config.selection.embeddings {
                Some(e) => Box::new(ServiceEmbedder {
                    client: ServiceClient::new(e.clone()).map_err(|e| InputError::new(config_path, "selection.embeddings", e.to_string()))?,
                    batch: 64,
                }),
                None => Box::new(HashingEmbedder::default()),
            };
            let mut chosen: Vec<ScenePrompt> = Vec::new();
            let mut reports = std::collections::BTreeMap::new();
            for (pool, target) in pools.iter().zip([config.selection.furniture, config.selection.manipuland]) {
                let texts: Vec<String> = pool.accepted.iter().map(|p| p.text.clone()).collect();
                let keys: Vec<String> = pool.accepted.iter().enumerate().map(|(i, p)| format!("{}#{i}", p.id)).collect();
                let embeddings = embedder.embed(&texts).map_err(|e| InputError::new(config_path, "selection.embeddings", e.to_string()))?;
                let report = select(&keys, &embeddings, target, config.selection.threshold);
                if report.shortfall > 0 {
                    return Err(InputError::new(
                        config_path,
                        "selection",
                        format!("only {} {} prompts survive selection, {target} wanted; enlarge the pool", report.selected.len(), pool.regime.name()),
                    ));
                }
                for s in &report.selected {
                    let index: usize = s.id.rsplit('#').next().and_then(|i| i.parse().ok()).expect("keys end in their position");
                    chosen.push(pool.accepted[index].clone());
                }
                reports.insert(pool.regime.name(), report);
            }
            write_json(&work.join("selection/selection.json"), &json!({"embedder": embedder.name(), "regimes": reports}))?;
            write_json(&selected_path, &chosen)
        })?;
        read_json(&selected_path)
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

    /// Stages 3 and 4 for scene `index`: synthesis and conversion.
    pub fn scene_assets(&self, index: usize, prompt: &ScenePrompt, progress: &dyn Fn(&str)) -> Result<()> {
        let (config, scene) = (&self.config, scene_name(index));
        let scenesmith = self.scenesmith_dir(index);
        let unmet_path = self.unmet_path(index);
        staged(&self.work.join("scenesmith").join(format!("{scene}.done")), &self.inputs, &scenesmith, || {
            progress(&format!("{scene}: synthesis ({})", prompt.id));
            let unmet = if config.synthesis.command.is_empty() {
                crate::synthesis::synthesize(prompt, config.seed.wrapping_add(index as u64), &scenesmith, config.synthesis.ceiling)?
            } else {
                crate::synthesis::external::run_external(
                    &config.synthesis.command,
                    &prompt.text,
                    &scenesmith,
                    std::time::Duration::from_secs(config.synthesis.timeout_secs),
                )?;
                Vec::new()
            };
            write_json(&unmet_path, &unmet)
        })?;
        let habitat = self.habitat_dir(index);
        staged(&self.work.join("habitat").join(format!("{scene}.done")), &self.inputs, &habitat, || {
            progress(&format!("{scene}: conversion"));
            let mut loaded = load_scene(&scenesmith)?;
            loaded.name = scene.clone();
            write_habitat_scene(&loaded, &habitat, &ConvertOptions::default()).map(|_| ())
        })?;
        Ok(())
    }

    fn sequence_paths(&self, unit: &SequenceUnit) -> (PathBuf, PathBuf, PathBuf) {
        let rendered = self.work.join("rendered").join(&unit.lighting);
        (
            self.out.join("sequences").join(&unit.lighting).join(&unit.scene),
            rendered.join(format!("{}.json", unit.scene)),
            rendered.join(format!("{}.done", unit.scene)),
        )
    }

    /// Whether `unit` is rendered (its marker matches the config and what is on disk).
    pub fn sequence_rendered(&self, unit: &SequenceUnit) -> Result<bool> {
        let (sequence_dir, _, marker) = self.sequence_paths(unit);
        Ok(std::fs::read_to_string(&marker).is_ok_and(|recorded| marker_text(&self.inputs, &sequence_dir).is_ok_and(|now| now == recorded)))
    }

    /// Stage 5 for one sequence (the scene's assets must be built); returns its summary.
    pub fn render_sequence(&self, unit: &SequenceUnit, regime: Regime, progress: &dyn Fn(&str)) -> Result<SequenceSummary> {
        let config = &self.config;
        let (scene, lighting) = (&unit.scene, unit.lighting.as_str());
        let habitat = self.habitat_dir(unit.scene_index);
        if !self.work.join("habitat").join(format!("{scene}.done")).is_file() {
            return Err(InputError::new(&habitat, "(scene)", "the scene is not converted yet; its synthesis and conversion run before rendering"));
        }
        let (sequence_dir, summary_path, marker) = self.sequence_paths(unit);
        let sensor = config.render.sensor();
        let goals = if regime == Regime::Furniture { config.render.goals_furniture } else { config.render.goals_manipuland };
        let motion =
            MotionSettings { goals, seed: config.seed.wrapping_add(unit.scene_index as u64), max_frames: config.render.max_frames, ..Default::default() };
        staged(&marker, &self.inputs, &sequence_dir, || {
            progress(&format!("{scene}: rendering {lighting}"));
            if config.render.command.is_empty() {
                let rendered = crate::render::render_scene(&habitat, scene, &[lighting], &sensor, &motion, &self.out.join("sequences"))?;
                return write_json(&summary_path, &rendered[0].1);
            }
            let substitutions = [
                ("scene_dir", habitat.display().to_string()),
                ("scene", scene.clone()),
                ("lighting", lighting.to_string()),
                ("out", sequence_dir.display().to_string()),
                ("width", sensor.width.to_string()),
                ("height", sensor.height.to_string()),
                ("goals", motion.goals.to_string()),
                ("seed", motion.seed.to_string()),
            ];
            std::fs::create_dir_all(&sequence_dir).map_err(|e| InputError::io(&sequence_dir, &e))?;
            let log = self.work.join("rendered").join(lighting).join(format!("{scene}.log"));
            crate::external::run_command(&config.render.command, &substitutions, &log, std::time::Duration::from_secs(config.render.timeout_secs))?;
            // Whatever rendered it, it must be a sequence the evaluator reads.
            write_json(&summary_path, &super::summarize_sequence(&sequence_dir)?)
        })?;
        read_json(&summary_path)
    }

    /// Stage 6 for scene `index`: the ground truth from the baseline sequence.
    pub fn ground_truth(&self, index: usize, progress: &dyn Fn(&str)) -> Result<PathBuf> {
        let scene = scene_name(index);
        let lightings = &self.config.render.lightings;
        let gt_dir = self.out.join(super::GROUND_TRUTH).join(&scene);
        let source = if lightings.iter().any(|l| l == "baseline") { "baseline" } else { lightings[0].as_str() };
        let gt_source = self.out.join("sequences").join(source).join(&scene);
        staged(&self.work.join("gt").join(format!("{scene}.done")), &self.inputs, &gt_dir, || {
            progress(&format!("{scene}: ground truth"));
            let sequence = Sequence::open(&gt_source)?;
            let gt = GroundTruth::build(&sequence)?;
            gt.write(&gt_dir)?;
            sequence.classes()?.write(&gt_dir.join("embed_semseg_classes.json"))
        })?;
        Ok(gt_dir)
    }
}
