//! `osmab release build`: the whole pipeline from a config to a frozen release in the
//! layout of product.md section 4. Every stage keeps its output under `.work/` with a
//! completion marker (see `stages`), so an interrupted build resumes where it stopped
//! and a partial stage output (no marker) is rebuilt. A service spreads the rendering
//! over workers: [`prepare_release`], then [`render_release_sequence`] per sequence,
//! then [`build_release`], which finds everything before the assembly done.

pub mod config;
pub mod contact;
pub mod manifest;
pub mod stages;

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use osmab_evaluator::formats::classes::ClassList;
use osmab_evaluator::formats::sequence::Sequence;
use osmab_evaluator::ground_truth::GroundTruth;
use osmab_evaluator::{InputError, Result};
use serde::Serialize;
use serde_json::{Value, json};

use crate::convert::habitat::ConversionReport;
use crate::convert::lexicon::normalise_name;
use crate::prompts::ScenePrompt;
use crate::questions::{scene_objects, scene_questions};
use crate::render::sequence::SequenceSummary;
use crate::spec::Regime;
use manifest::{digest, list_files};
use osmab_evaluator::vqa::is_prompt_grounded;
use stages::{Build, read_json, scene_name, write_json};
pub use stages::{SequenceUnit, WORK};

/// Ground truth, kept by the server and never served (not in the public manifest).
pub const GROUND_TRUTH: &str = "ground_truth";

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

/// Stages 1–4 of the build of `config_path` into `out` (prompts, selection, and every
/// scene's synthesis and conversion); returns every sequence of the release and
/// whether it is rendered already.
pub fn prepare_release(config_path: &Path, out: &Path, progress: &dyn Fn(&str)) -> Result<Vec<(SequenceUnit, bool)>> {
    let build = Build::open(config_path, out)?;
    let prompts = build.prompts(progress)?;
    let mut units = Vec::new();
    for (index, prompt) in prompts.iter().enumerate() {
        build.scene_assets(index, prompt, progress)?;
        for lighting in &build.config.render.lightings {
            let unit = SequenceUnit { scene_index: index, scene: scene_name(index), lighting: lighting.clone() };
            let done = build.sequence_rendered(&unit)?;
            units.push((unit, done));
        }
    }
    Ok(units)
}

/// Stage 5 for one sequence of a prepared build (see [`prepare_release`]).
pub fn render_release_sequence(config_path: &Path, out: &Path, unit: &SequenceUnit, progress: &dyn Fn(&str)) -> Result<()> {
    let build = Build::open(config_path, out)?;
    let prompts: Vec<ScenePrompt> = read_json(&build.work.join("selection/final_prompts.json"))?;
    let prompt = prompts.get(unit.scene_index).ok_or_else(|| {
        InputError::new(config_path, "(selection)", format!("the selection has {} scenes; there is no scene {}", prompts.len(), unit.scene_index))
    })?;
    if !build.config.render.lightings.contains(&unit.lighting) {
        return Err(InputError::new(config_path, "render.lightings", format!("'{}' is not a lighting of this release", unit.lighting)));
    }
    build.render_sequence(unit, prompt.spec.regime, progress).map(|_| ())
}

/// Build the release of `config_path` into `out`.
pub fn build_release(config_path: &Path, out: &Path, progress: &dyn Fn(&str)) -> Result<Value> {
    let build = Build::open(config_path, out)?;
    let (config, config_text) = (&build.config, &build.config_text);
    let work = &build.work;
    let prompts = build.prompts(progress)?;

    // 3–6. Per scene: synthesis, conversion, sequences, ground truth.
    let lightings: Vec<&str> = config.render.lightings.iter().map(String::as_str).collect();
    let lexicon: Vec<String> = crate::convert::lexicon::classes().into_iter().map(|c| c.name).collect();
    let mut quality = Vec::new();
    let mut scenes_json = Vec::new();
    for (i, prompt) in prompts.iter().enumerate() {
        let scene = scene_name(i);
        build.scene_assets(i, prompt, progress)?;
        let unmet_path = build.unmet_path(i);
        let habitat = build.habitat_dir(i);
        let mut summaries: BTreeMap<String, SequenceSummary> = BTreeMap::new();
        for lighting in &lightings {
            let unit = SequenceUnit { scene_index: i, scene: scene.clone(), lighting: lighting.to_string() };
            let summary = build.render_sequence(&unit, prompt.spec.regime, progress)?;
            let sequence_dir = out.join("sequences").join(lighting).join(&scene);
            let sheet = out.join("quality/contact_sheets").join(lighting).join(format!("{scene}.png"));
            if !sheet.exists() {
                contact::write_contact_sheet(&sequence_dir, summary.frames, &sheet)?;
            }
            summaries.insert(lighting.to_string(), summary);
        }
        let gt_dir = build.ground_truth(i, progress)?;
        write_json(
            &out.join("scenes").join(&scene).join("prompt.json"),
            &json!({"scene": scene, "prompt_id": prompt.id, "subset": prompt.spec.regime, "prompt": prompt.text, "spec": prompt.spec}),
        )?;
        scenes_json.push(json!({"id": scene, "subset": prompt.spec.regime, "prompt": prompt.text, "questions": format!("questions/{scene}.json")}));

        // Quality: what the prompt asked for, what the scene has, what the camera saw.
        let conversion: ConversionReport = read_json(&habitat.join("conversion_report.json"))?;
        let baseline = summaries.get("baseline").or_else(|| summaries.values().next()).cloned().unwrap_or_default();
        let classes = ClassList::read(&gt_dir.join("embed_semseg_classes.json"))?;
        let gt = GroundTruth::read(&gt_dir, &classes)?;

        // Questions: prompt-grounded and standard, public without their answers; the
        // answers and the scene objects stay with the ground truth.
        let objects = scene_objects(&conversion, &gt);
        let questions = scene_questions(&scene, &prompt.spec, &objects, &lexicon, config.seed.wrapping_add(i as u64));
        write_json(&out.join("questions").join(format!("{scene}.json")), &questions.without_answers())?;
        write_json(&out.join(GROUND_TRUTH).join("questions").join(format!("{scene}.json")), &questions)?;
        write_json(&out.join(GROUND_TRUTH).join("objects").join(format!("{scene}.json")), &json!({"scene": scene, "objects": objects}))?;
        progress(&format!(
            "{scene}: {} questions ({} prompt-grounded), {} objects seen",
            questions.questions.len(),
            questions.questions.iter().filter(|q| is_prompt_grounded(&q.category)).count(),
            objects.iter().filter(|o| o.seen()).count()
        ));

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
    let mut gt_expected: Vec<String> = scene_names.iter().map(|s| format!("{s}/")).collect();
    for scene in &scene_names {
        gt_expected.extend([format!("questions/{scene}.json"), format!("objects/{scene}.json")]);
    }
    refuse_leftovers(&out.join(GROUND_TRUTH), &gt_files, &gt_expected)?;
    write_json(&out.join(GROUND_TRUTH).join("manifest.json"), &json!({"version": config.version, "files": gt_files, "digest": digest(&gt_files)}))?;
    let files = list_files(out, &["manifest.json", WORK, GROUND_TRUTH])?;
    let mut expected: Vec<String> = vec!["classes.json".into(), "quality/quality_report.json".into()];
    for scene in &scene_names {
        expected.extend([format!("scenes/{scene}/"), format!("questions/{scene}.json")]);
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
