//! `osmab release build`: the whole pipeline from a config to a frozen release in the
//! layout of product.md section 4. Every stage keeps its output under `.work/` with a
//! completion marker, so an interrupted build resumes where it stopped and a partial
//! stage output (no marker) is rebuilt.

pub mod config;
pub mod contact;
pub mod manifest;

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use osmab_evaluator::formats::classes::ClassList;
use osmab_evaluator::formats::sequence::Sequence;
use osmab_evaluator::ground_truth::GroundTruth;
use osmab_evaluator::{InputError, Result};
use serde::Serialize;
use serde_json::{Value, json};

use crate::convert::habitat::{ConversionReport, ConvertOptions, write_habitat_scene};
use crate::convert::lexicon::normalise_name;
use crate::convert::scene::load_scene;
use crate::embedding::{Embedder, HashingEmbedder, ServiceEmbedder};
use crate::openai::ServiceClient;
use crate::prompts::{PromptPool, ScenePrompt, grammar_pool, llm::llm_pool};
use crate::render::sequence::SequenceSummary;
use crate::render::trajectory::MotionSettings;
use crate::selection::select;
use crate::spec::Regime;
use config::ReleaseConfig;
use manifest::{digest, list_files};

/// Where the build keeps its intermediate stages (not part of the release).
pub const WORK: &str = ".work";
/// Ground truth, kept by the server and never served (not in the public manifest).
pub const GROUND_TRUTH: &str = "ground_truth";

fn write_json(path: &Path, value: &impl Serialize) -> Result<()> {
    if let Some(dir) = path.parent() {
        std::fs::create_dir_all(dir).map_err(|e| InputError::io(dir, &e))?;
    }
    std::fs::write(path, serde_json::to_string_pretty(value).expect("serialisable") + "\n").map_err(|e| InputError::io(path, &e))
}

fn read_json<T: serde::de::DeserializeOwned>(path: &Path) -> Result<T> {
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
fn staged(marker: &Path, inputs: &str, output: &Path, stage: impl FnOnce() -> Result<()>) -> Result<bool> {
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

/// What one scene of the release holds and how well it matches its prompt.
#[derive(Debug, Clone, Serialize)]
pub struct SceneQuality {
    pub scene: String,
    pub subset: Regime,
    pub prompt_id: String,
    /// Per prompted category: class, expected and present counts, whether seen in a frame.
    pub objects: Vec<Value>,
    pub unmet_relations: Vec<String>,
    /// Pixels per class over the baseline sequence, and ground-truth points per class.
    pub class_pixels: BTreeMap<u16, u64>,
    pub gt_points: BTreeMap<i64, u64>,
    pub full_match: bool,
}

/// Build the release of `config_path` into `out`.
pub fn build_release(config_path: &Path, out: &Path, progress: &dyn Fn(&str)) -> Result<Value> {
    let (config, config_text) = ReleaseConfig::read(config_path)?;
    let work = out.join(WORK);
    let inputs = inputs_digest(&config);
    std::fs::create_dir_all(&work).map_err(|e| InputError::io(&work, &e))?;

    // 1. Prompt pools.
    let mut pools: Vec<PromptPool> = Vec::new();
    for (regime, count) in [(Regime::Furniture, config.prompts.furniture_pool), (Regime::Manipuland, config.prompts.manipuland_pool)] {
        let path = work.join(format!("prompts/{}.json", regime.name()));
        staged(&work.join(format!("prompts/{}.done", regime.name())), &inputs, &path, || {
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

    // 2. Selection.
    let selected_path = work.join("selection/final_prompts.json");
    staged(&work.join("selection/.done"), &inputs, &selected_path, || {
        progress("selection: removing near-duplicates, choosing diverse scenes");
        let embedder: Box<dyn Embedder> = match &config.selection.embeddings {
            Some(e) => Box::new(ServiceEmbedder {
                client: ServiceClient::new(e.clone()).map_err(|e| InputError::new(config_path, "selection.embeddings", e.to_string()))?,
                batch: 64,
            }),
            None => Box::new(HashingEmbedder::default()),
        };
        let mut chosen: Vec<ScenePrompt> = Vec::new();
        let mut reports = BTreeMap::new();
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
    let prompts: Vec<ScenePrompt> = read_json(&selected_path)?;

    // 3–6. Per scene: synthesis, conversion, sequences, ground truth.
    let lightings: Vec<&str> = config.render.lightings.iter().map(String::as_str).collect();
    let mut quality = Vec::new();
    let mut scenes_json = Vec::new();
    for (i, prompt) in prompts.iter().enumerate() {
        let scene = format!("scene_{i:03}");
        let scenesmith = work.join("scenesmith").join(&scene);
        let unmet_path = work.join("scenesmith").join(format!("{scene}.unmet.json"));
        staged(&work.join("scenesmith").join(format!("{scene}.done")), &inputs, &scenesmith, || {
            progress(&format!("{scene}: synthesis ({})", prompt.id));
            let unmet = if config.synthesis.command.is_empty() {
                crate::synthesis::synthesize(prompt, config.seed.wrapping_add(i as u64), &scenesmith, config.synthesis.ceiling)?
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
        let habitat = work.join("habitat").join(&scene);
        staged(&work.join("habitat").join(format!("{scene}.done")), &inputs, &habitat, || {
            progress(&format!("{scene}: conversion"));
            let mut loaded = load_scene(&scenesmith)?;
            loaded.name = scene.clone();
            write_habitat_scene(&loaded, &habitat, &ConvertOptions::default()).map(|_| ())
        })?;
        let sensor = config.render.sensor();
        let goals = if prompt.spec.regime == Regime::Furniture { config.render.goals_furniture } else { config.render.goals_manipuland };
        let motion = MotionSettings { goals, seed: config.seed.wrapping_add(i as u64), max_frames: config.render.max_frames, ..Default::default() };
        let mut summaries: BTreeMap<String, SequenceSummary> = BTreeMap::new();
        for lighting in &lightings {
            let sequence_dir = out.join("sequences").join(lighting).join(&scene);
            let summary_path = work.join("rendered").join(lighting).join(format!("{scene}.json"));
            staged(&work.join("rendered").join(lighting).join(format!("{scene}.done")), &inputs, &sequence_dir, || {
                progress(&format!("{scene}: rendering {lighting}"));
                if config.render.command.is_empty() {
                    let rendered = crate::render::render_scene(&habitat, &scene, &[lighting], &sensor, &motion, &out.join("sequences"))?;
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
                let log = work.join("rendered").join(lighting).join(format!("{scene}.log"));
                crate::external::run_command(&config.render.command, &substitutions, &log, std::time::Duration::from_secs(config.render.timeout_secs))?;
                // Whatever rendered it, it must be a sequence the evaluator reads.
                write_json(&summary_path, &summarize_sequence(&sequence_dir)?)
            })?;
            let summary: SequenceSummary = read_json(&summary_path)?;
            let sheet = out.join("quality/contact_sheets").join(lighting).join(format!("{scene}.png"));
            if !sheet.exists() {
                contact::write_contact_sheet(&sequence_dir, summary.frames, &sheet)?;
            }
            summaries.insert(lighting.to_string(), summary);
        }
        let gt_dir = out.join(GROUND_TRUTH).join(&scene);
        let gt_source = out.join("sequences").join(if lightings.contains(&"baseline") { "baseline" } else { lightings[0] }).join(&scene);
        staged(&work.join("gt").join(format!("{scene}.done")), &inputs, &gt_dir, || {
            progress(&format!("{scene}: ground truth"));
            let sequence = Sequence::open(&gt_source)?;
            let gt = GroundTruth::build(&sequence)?;
            gt.write(&gt_dir)?;
            sequence.classes()?.write(&gt_dir.join("embed_semseg_classes.json"))
        })?;
        write_json(
            &out.join("scenes").join(&scene).join("prompt.json"),
            &json!({"scene": scene, "prompt_id": prompt.id, "subset": prompt.spec.regime, "prompt": prompt.text, "spec": prompt.spec}),
        )?;
        scenes_json.push(json!({"id": scene, "subset": prompt.spec.regime, "prompt": prompt.text}));

        // Quality: what the prompt asked for, what the scene has, what the camera saw.
        let conversion: ConversionReport = read_json(&habitat.join("conversion_report.json"))?;
        let baseline = summaries.get("baseline").or_else(|| summaries.values().next()).cloned().unwrap_or_default();
        let classes = ClassList::read(&gt_dir.join("embed_semseg_classes.json"))?;
        let gt = GroundTruth::read(&gt_dir, &classes)?;
        let mut gt_points: BTreeMap<i64, u64> = BTreeMap::new();
        for &l in &gt.labels {
            *gt_points.entry(l).or_default() += 1;
        }
        let mut full_match = true;
        let objects: Vec<Value> = prompt
            .spec
            .objects
            .iter()
            .map(|o| {
                // A category outside the lexicon cannot be checked: it is reported unmatched.
                let Some(class) = normalise_name(&o.category).filter(|c| crate::convert::lexicon::class_id(c).is_some_and(|id| id != 0)) else {
                    full_match = false;
                    return json!({"category": o.category, "class": null, "expected": o.count, "present": 0, "visible": false, "match": false});
                };
                let class_id = crate::convert::lexicon::class_id(class).unwrap_or(0);
                let expected: u32 = prompt.spec.objects.iter().filter(|p| normalise_name(&p.category) == Some(class)).map(|p| p.count).sum();
                let present = conversion.objects.iter().filter(|c| c.class == class).count() as u32;
                let visible = baseline.class_pixels.get(&(class_id as u16)).copied().unwrap_or(0) > 0;
                let ok = present == expected && visible;
                full_match &= ok;
                json!({"category": o.category, "class": class, "expected": expected, "present": present, "visible": visible, "match": ok})
            })
            .collect();
        let unmet_relations: Vec<String> = read_json(&unmet_path)?;
        full_match &= unmet_relations.is_empty();
        quality.push(SceneQuality {
            scene: scene.clone(),
            subset: prompt.spec.regime,
            prompt_id: prompt.id.clone(),
            objects,
            unmet_relations,
            class_pixels: baseline.class_pixels,
            gt_points,
            full_match,
        });
    }

    // The public tree: classes, quality report, manifest.
    let classes_json: Value =
        read_json(&work.join("habitat/scene_000/semantics/classes.json")).unwrap_or_else(|_| json!({"classes": crate::convert::lexicon::classes()}));
    write_json(&out.join("classes.json"), &classes_json)?;
    let full = quality.iter().filter(|q| q.full_match).count();
    write_json(&out.join("quality/quality_report.json"), &json!({"scenes": quality.len(), "full_match": full, "per_scene": quality}))?;
    let scene_names: Vec<&str> = quality.iter().map(|q| q.scene.as_str()).collect();
    let gt_files = list_files(&out.join(GROUND_TRUTH), &["manifest.json"])?;
    let gt_expected: Vec<String> = scene_names.iter().map(|s| format!("{s}/")).collect();
    refuse_leftovers(&out.join(GROUND_TRUTH), &gt_files, &gt_expected)?;
    write_json(&out.join(GROUND_TRUTH).join("manifest.json"), &json!({"version": config.version, "files": gt_files, "digest": digest(&gt_files)}))?;
    let files = list_files(out, &["manifest.json", WORK, GROUND_TRUTH])?;
    let mut expected: Vec<String> = vec!["classes.json".into(), "quality/quality_report.json".into()];
    for scene in &scene_names {
        expected.push(format!("scenes/{scene}/"));
        for lighting in &lightings {
            expected.extend([format!("sequences/{lighting}/{scene}/"), format!("quality/contact_sheets/{lighting}/{scene}.png")]);
        }
    }
    refuse_leftovers(out, &files, &expected)?;
    let manifest = json!({
        "version": config.version,
        "created": config.created,
        "digest": digest(&files),
        "generator": {"config": config_text, "seed": config.seed, "code_version": env!("CARGO_PKG_VERSION")},
        "scenes": scenes_json,
        "lightings": lightings,
        "files": files,
    });
    write_json(&out.join("manifest.json"), &manifest)?;
    progress(&format!(
        "release {}: {} scenes, {full} full matches, {} files, digest {}",
        config.version,
        quality.len(),
        files.len(),
        manifest["digest"].as_str().unwrap_or("")
    ));
    Ok(manifest)
}

/// A release lists exactly what its config built: a file no scene or lighting of the
/// config accounts for (left by a build with another config, or put there by hand)
/// stops the build rather than being published. `expected` holds file paths and
/// directory prefixes ending in '/'.
fn refuse_leftovers(root: &Path, files: &[manifest::FileEntry], expected: &[String]) -> Result<()> {
    let stray: Vec<&str> =
        files.iter().map(|f| f.path.as_str()).filter(|p| !expected.iter().any(|e| if e.ends_with('/') { p.starts_with(e.as_str()) } else { p == e })).collect();
    match stray.first() {
        None => Ok(()),
        Some(first) => Err(InputError::new(
            root.join(first),
            "release",
            format!(
                "{} file(s) the config does not build ({}); remove them or build into a fresh directory",
                stray.len(),
                stray.iter().take(5).copied().collect::<Vec<_>>().join(", ")
            ),
        )),
    }
}

/// Frames and class pixels of a sequence on disk (one rendered by an external tool).
pub fn summarize_sequence(dir: &Path) -> Result<SequenceSummary> {
    let sequence = Sequence::open(dir)?;
    let mut summary = SequenceSummary { frames: sequence.len(), ..Default::default() };
    let size = Some((sequence.camera.image_width, sequence.camera.image_height));
    for path in &sequence.semantic_frames {
        for &c in &osmab_evaluator::formats::image::read_png_gray16(path, size)?.pixels {
            *summary.class_pixels.entry(c).or_default() += 1;
        }
    }
    Ok(summary)
}

/// Check a built release: every manifest entry's size and SHA-256, and the digest.
pub fn verify_release(dir: &Path) -> Result<usize> {
    let path: PathBuf = dir.join("manifest.json");
    let manifest: Value = read_json(&path)?;
    let files: Vec<manifest::FileEntry> = serde_json::from_value(manifest["files"].clone()).map_err(|e| InputError::new(&path, "files", e.to_string()))?;
    for f in &files {
        if f.path.contains("..") || f.path.starts_with('/') {
            return Err(InputError::new(&path, "files", format!("'{}' is not a path inside the release", f.path)));
        }
        let (size, sha) = manifest::hash_file(&dir.join(&f.path))?;
        if size != f.size || sha != f.sha256 {
            return Err(InputError::new(
                dir.join(&f.path),
                "sha256",
                format!("expected {} bytes with SHA-256 {}, found {size} bytes with {sha}", f.size, f.sha256),
            ));
        }
    }
    if manifest["digest"].as_str() != Some(digest(&files).as_str()) {
        return Err(InputError::new(&path, "digest", "the digest does not match the listed files"));
    }
    Ok(files.len())
}
