//! `osmab release build`: the whole pipeline from a config to a frozen release in the
//! layout of product.md section 4. Every stage keeps its output under `.work/` with a
//! completion marker (see `stages`), so an interrupted build resumes where it stopped
//! and a partial stage output (no marker) is rebuilt. A service spreads the rendering
//! over workers: [`prepare_release`], then [`render_release_scene`] per scene,
//! then [`build_release`], which finds everything before the assembly done.

pub mod config;
pub mod contact;
pub mod front_matter;
pub mod instances;
pub mod manifest;
pub mod pipeline;
pub mod publication;
pub mod quality;
pub mod quality_report;
pub mod split;
pub mod stages;

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use osmab_evaluator::formats::classes::ClassList;
use osmab_evaluator::formats::manifest::{Generator, ManifestScene, ReleaseManifest};
use osmab_evaluator::ground_truth::GroundTruth;
use osmab_evaluator::scores::ReleaseLighting;
use osmab_evaluator::{InputError, Result};
use serde_json::{Value, json};

use crate::convert::habitat::ConversionReport;
use crate::prompts::ScenePrompt;
use crate::questions::priors::QuestionPriors;
use crate::questions::support::resting_on;
use crate::questions::{SceneObject, scene_objects, scene_questions};
use crate::render::mesh::World;
use crate::render::sequence::SequenceSummary;
use instances::InstanceLabels;
use manifest::{digest, list_files};
use osmab_evaluator::scores::Split;
use osmab_evaluator::vqa::{SceneQuestions, is_prompt_grounded};
use quality::{Rendered, SceneQuality, oracle_ceiling};
use split::SplitSecret;
pub use stages::{Build, SequenceUnit, WORK, packed_sequence_archive};
use stages::{INSTANCES_JSON, SettledScene, read_json, scene_name, write_json};

pub use publication::GROUND_TRUTH;
/// The quality report with every measure of every scene (the public one leaves out what
/// tells a test scene's ground truth), kept with the ground truth.
pub const FULL_QUALITY_REPORT: &str = "quality_report.json";
/// Every scene's preview frame under every lighting, one row per scene.
pub const OVERVIEW: &str = "quality/contact_sheets/overview.png";

/// Stages 1–4 of the build of `config_path` into `out` (prompts, selection, and every
/// scene's synthesis, conversion and trajectory, each scene settled on a prompt that
/// passes the planned quality check); returns every sequence of the release and
/// whether it is rendered already.
pub fn prepare_release(
    config_path: &Path,
    out: &Path,
    secret: Option<&SplitSecret>,
    assets_root: &Path,
    progress: &dyn Fn(&str),
) -> Result<Vec<(SequenceUnit, bool)>> {
    let build = Build::open(config_path, out, secret, assets_root)?;
    let selection = build.prompts(progress)?;
    let mut units = Vec::new();
    for index in 0..selection.scenes.len() {
        build.settle_scene(index, &selection, progress)?;
        for lighting in &build.config.render.lightings {
            let unit = SequenceUnit { scene_index: index, scene: scene_name(index), lighting: *lighting };
            let done = build.sequence_rendered(&unit)?;
            units.push((unit, done));
        }
    }
    Ok(units)
}

/// Stage 5 for sequences of one scene of a prepared build (see [`prepare_release`]),
/// drawn together, with what depends on each sequence alone: its contact sheet, its
/// download archive and, from the sequence the ground truth comes from, the scene's ground
/// truth (stage 6), so that the work left to the build's assembly does not grow with the
/// frames.
///
/// `build` is the prepared build ([`Build::open`]): a config that cannot be used fails
/// there, the same way every time, and sequences that are not of one scene of it fail
/// [`Build::check_scene_units`]; what fails after those checks (rendering, an external
/// renderer's timeout, the disk) may pass another time.
pub fn render_release_scene(build: &Build, units: &[SequenceUnit], progress: &dyn Fn(&str)) -> Result<()> {
    build.check_scene_units(units)?;
    let summaries = build.render_scene_sequences(units, progress)?;
    for (unit, summary) in units.iter().zip(&summaries) {
        build.contact_sheet(unit, summary)?;
        build.sequence_archive(unit)?;
        if unit.lighting == build.ground_truth_lighting() {
            build.ground_truth(unit.scene_index, progress)?;
        }
    }
    Ok(())
}

/// Build the release of `config_path` into `out` (a config with a test split needs the
/// operator's `secret`; a relative asset pack path is read under `assets_root`).
pub fn build_release(config_path: &Path, out: &Path, secret: Option<&SplitSecret>, assets_root: &Path, progress: &dyn Fn(&str)) -> Result<ReleaseManifest> {
    let build = Build::open(config_path, out, secret, assets_root)?;
    let config = &build.config;
    let selection = build.prompts(progress)?;

    // 3–6. Per scene: synthesis, conversion, trajectory, sequences, ground truth, questions.
    let lightings: &[ReleaseLighting] = &config.render.lightings;
    let lexicon: Vec<String> = crate::convert::lexicon::classes().into_iter().map(|c| c.name).collect();
    let layouts = build.pool_layouts()?;
    let priors = crate::questions::calibrated_priors(&layouts, &lexicon);
    progress(&format!("questions: odds from {} simulated layouts of the prompt pool, calibrated on {} held out", priors.layouts(), layouts.held_out().len()));
    let assembly = SceneAssembly { build: &build, out, lightings, lexicon: &lexicon, priors: &priors };
    let scenes = pipeline::assemble_in_order(
        selection.scenes.len(),
        |i, say| build.settle_scene(i, &selection, say),
        |i, settled, say| assembly.assemble(i, &settled, say),
        progress,
    )?;
    let mut quality = Vec::new();
    let mut manifest_scenes = Vec::new();
    let mut previews: Vec<(String, usize)> = Vec::new();
    for scene in scenes {
        manifest_scenes.push(scene.entry);
        previews.push(scene.preview);
        quality.push(scene.quality);
    }

    // The bar: every scene, and the oracle's answers over all of them.
    let (oracle_accuracy, oracle_problems) = oracle_ceiling(&quality, config.quality.min_oracle_vqa);
    let mut failures: Vec<String> = quality.iter().flat_map(|q| q.problems.iter().map(move |p| format!("{}: {p}", q.scene))).collect();
    failures.extend(oracle_problems.iter().cloned());

    write_public_tree(&build, out, &quality, &previews, lightings)?;
    write_quality_reports(out, config, &quality, &oracle_accuracy, &failures)?;
    if config.quality.enforce && !failures.is_empty() {
        return Err(InputError::new(
            out.join("quality/quality_report.json"),
            "quality",
            format!("the release misses its quality bar (nothing was published): {}", failures.join("; ")),
        ));
    }
    let gt_files = seal_ground_truth(out, config, &quality)?;
    let files = list_files(out, &["manifest.json", WORK, GROUND_TRUTH])?;
    refuse_leftovers(out, &files, &expected_public_files(&quality, lightings))?;
    let splits: BTreeMap<&str, Split> = quality.iter().map(|q| (q.scene.as_str(), q.split)).collect();
    let files = public_files(files, &gt_files, &splits);
    let manifest = ReleaseManifest {
        archives: Vec::new(),
        created: config.created.clone(),
        digest: digest(&files),
        generator: generator(&build.config_text, config, build.secret_id(), build.assets_digest()),
        lightings: lightings.to_vec(),
        scenes: manifest_scenes,
        version: config.version.clone(),
        files,
    };
    manifest.write(&out.join("manifest.json"))?;
    let full = quality.iter().filter(|q| q.full_match).count();
    progress(&format!("release {}: {} scenes, {full} full matches, {} files, digest {}", config.version, quality.len(), manifest.files.len(), manifest.digest));
    Ok(manifest)
}

/// What the assembly of every scene shares: the build, the lightings, the class lexicon
/// and the question odds of the prompt pool.
struct SceneAssembly<'a> {
    build: &'a Build,
    out: &'a Path,
    lightings: &'a [ReleaseLighting],
    lexicon: &'a [String],
    priors: &'a QuestionPriors<'a>,
}

/// One assembled scene: its manifest entry, its preview frame and its measured quality.
struct AssembledScene {
    entry: ManifestScene,
    preview: (String, usize),
    quality: SceneQuality,
}

/// A scene's objects as the questions see them, with what they were made from.
struct SceneTruth {
    conversion: ConversionReport,
    gt: GroundTruth,
    labels: InstanceLabels,
    objects: Vec<SceneObject>,
}

impl SceneAssembly<'_> {
    /// Stages 5 and 6 of `settled` scene `i` and what the release says of it: its
    /// sequences, ground truth, prompt, questions and measured quality.
    fn assemble(&self, i: usize, settled: &SettledScene, progress: &dyn Fn(&str)) -> Result<AssembledScene> {
        let build = self.build;
        let scene = scene_name(i);
        let split = build.split_of(i);
        let prompt = &settled.prompt;
        let summaries = self.render_sequences(i, &scene, progress)?;
        let gt_dir = build.ground_truth(i, progress)?;
        // A test scene's prompt tells its prompt-grounded answers: it stays with the ground truth.
        let open = publication::publishes_prompt_and_questions(split);
        let prompt_root = if open { self.out.to_path_buf() } else { self.out.join(GROUND_TRUTH) };
        write_json(
            &prompt_root.join("scenes").join(&scene).join("prompt.json"),
            &json!({"scene": scene, "prompt_id": prompt.id, "subset": prompt.spec.regime, "split": split, "prompt": prompt.text, "spec": prompt.spec}),
        )?;
        let (entry, preview) = scene_entry(&scene, prompt, split, &summaries, open);
        let truth = scene_truth(&build.habitat_dir(i), &gt_dir, &scene)?;
        let questions = self.write_questions(i, &scene, prompt, &truth.objects, open)?;
        let unmet: Vec<String> = read_json(&build.unmet_path(i))?;
        let rendered = Rendered {
            split,
            spec: &prompt.spec,
            conversion: &truth.conversion,
            unmet: &unmet,
            summaries: &summaries,
            instances: &truth.labels,
            gt_labels: &truth.gt.labels,
            objects: &truth.objects,
            questions: &questions,
            lexicon: self.lexicon,
        };
        let measured = SceneQuality::measure(&scene, &prompt.id, settled.replaced.clone(), &rendered, &build.config.quality);
        progress(&scene_progress_line(&scene, &measured, &questions, &truth.objects));
        Ok(AssembledScene { entry, preview: (scene, preview), quality: measured })
    }

    /// Stage 5 of scene `i`: its sequences under every lighting (drawn together), each
    /// with its contact sheet; returns each sequence's summary by lighting.
    fn render_sequences(&self, i: usize, scene: &str, progress: &dyn Fn(&str)) -> Result<BTreeMap<ReleaseLighting, SequenceSummary>> {
        let units: Vec<SequenceUnit> = self.lightings.iter().map(|&lighting| SequenceUnit { scene_index: i, scene: scene.to_string(), lighting }).collect();
        let rendered = self.build.render_scene_sequences(&units, progress)?;
        let mut summaries: BTreeMap<ReleaseLighting, SequenceSummary> = BTreeMap::new();
        for (unit, summary) in units.into_iter().zip(rendered) {
            self.build.contact_sheet(&unit, &summary)?;
            summaries.insert(unit.lighting, summary);
        }
        Ok(summaries)
    }

    /// Questions of scene `i`, prompt-grounded and standard, written where they belong: a
    /// val scene's are public without their answers, a test scene's are not published at
    /// all (the server answers them from a submission's scene graph). The answers and the
    /// scene objects stay with the ground truth.
    fn write_questions(&self, i: usize, scene: &str, prompt: &ScenePrompt, objects: &[SceneObject], open: bool) -> Result<SceneQuestions> {
        let seed = self.build.config.seed.wrapping_add(i as u64);
        let questions = scene_questions(scene, &prompt.spec, objects, self.lexicon, self.priors, seed);
        if open {
            write_json(&self.out.join("questions").join(format!("{scene}.json")), &questions.without_answers())?;
        }
        write_json(&self.out.join(GROUND_TRUTH).join("questions").join(format!("{scene}.json")), &questions)?;
        write_json(&self.out.join(GROUND_TRUTH).join("objects").join(format!("{scene}.json")), &json!({"scene": scene, "objects": objects}))?;
        Ok(questions)
    }
}

/// A scene's entry in the manifest, and its preview frame (from the baseline sequence if
/// there is one, else the first).
fn scene_entry(scene: &str, prompt: &ScenePrompt, split: Split, summaries: &BTreeMap<ReleaseLighting, SequenceSummary>, open: bool) -> (ManifestScene, usize) {
    let preview_lighting =
        summaries.keys().copied().find(|l| *l == ReleaseLighting::BASELINE).or_else(|| summaries.keys().next().copied()).unwrap_or(ReleaseLighting::BASELINE);
    let preview = summaries.get(&preview_lighting).map_or(0, SequenceSummary::preview_frame);
    let entry = ManifestScene {
        id: scene.to_string(),
        preview: Some(format!("sequences/{preview_lighting}/{scene}/results/frame{preview:06}.jpg")),
        prompt: open.then(|| prompt.text.clone()),
        questions: open.then(|| format!("questions/{scene}.json")),
        split,
        subset: prompt.spec.regime,
    };
    (entry, preview)
}

/// The scene's objects: what the ground truth holds of each, what it rests on.
fn scene_truth(habitat: &Path, gt_dir: &Path, scene: &str) -> Result<SceneTruth> {
    let conversion: ConversionReport = read_json(&habitat.join("conversion_report.json"))?;
    let classes = ClassList::read(&gt_dir.join("embed_semseg_classes.json"))?;
    let gt = GroundTruth::read(gt_dir, &classes)?;
    let labels: InstanceLabels = read_json(&gt_dir.join(INSTANCES_JSON))?;
    let world = World::load_habitat_scene(habitat, scene)?;
    let objects = scene_objects(&conversion, &labels.instances, &resting_on(&world, &conversion));
    Ok(SceneTruth { conversion, gt, labels, objects })
}

/// The progress line of a finished scene: its frames, path, questions, objects mapped and misses.
fn scene_progress_line(scene: &str, measured: &SceneQuality, questions: &SceneQuestions, objects: &[SceneObject]) -> String {
    format!(
        "{scene}: {} frames, {:.1} m, {} questions ({} prompt-grounded), {} of {} objects mapped{}",
        measured.frames,
        measured.travelled_m,
        questions.questions.len(),
        questions.questions.iter().filter(|q| is_prompt_grounded(&q.category)).count(),
        objects.iter().filter(|o| o.seen()).count(),
        objects.len(),
        if measured.problems.is_empty() { String::new() } else { format!("; misses: {}", measured.problems.join("; ")) }
    )
}

/// The public tree around the scenes: the overview contact sheet, the classes and the front matter.
fn write_public_tree(build: &Build, out: &Path, quality: &[SceneQuality], previews: &[(String, usize)], lightings: &[ReleaseLighting]) -> Result<()> {
    contact::write_overview(out, previews, lightings, &out.join(OVERVIEW))?;
    let classes_json: Value =
        read_json(&build.work.join("habitat/scene_000/semantics/classes.json")).unwrap_or_else(|_| json!({"classes": crate::convert::lexicon::classes()}));
    write_json(&out.join("classes.json"), &classes_json)?;
    let scene_splits: Vec<Split> = quality.iter().map(|q| q.split).collect();
    front_matter::write(out, &front_matter::Contents { config: &build.config, splits: &scene_splits, lightings })
}

/// The full quality report (kept with the ground truth) and the public one.
fn write_quality_reports(
    out: &Path,
    config: &config::ReleaseConfig,
    quality: &[SceneQuality],
    oracle_accuracy: &BTreeMap<String, f64>,
    failures: &[String],
) -> Result<()> {
    write_json(
        &out.join(GROUND_TRUTH).join(FULL_QUALITY_REPORT),
        &json!({
            "scenes": quality.len(),
            "full_match": quality.iter().filter(|q| q.full_match).count(),
            "passed": quality.iter().filter(|q| q.problems.is_empty()).count(),
            "bar": config.quality,
            "oracle_vqa": oracle_accuracy,
            "problems": failures,
            "per_scene": quality,
        }),
    )?;
    write_json(&out.join("quality/quality_report.json"), &public_quality_report(quality, config))
}

/// Check the ground truth holds only what the scenes made and write its own manifest;
/// returns its files.
fn seal_ground_truth(out: &Path, config: &config::ReleaseConfig, quality: &[SceneQuality]) -> Result<Vec<manifest::FileEntry>> {
    let gt_files = list_files(&out.join(GROUND_TRUTH), &["manifest.json"])?;
    let mut gt_expected: Vec<String> = quality.iter().map(|q| format!("{}/", q.scene)).collect();
    gt_expected.push(FULL_QUALITY_REPORT.into());
    for q in quality {
        gt_expected.extend([format!("questions/{}.json", q.scene), format!("objects/{}.json", q.scene)]);
        if !publication::publishes_prompt_and_questions(q.split) {
            gt_expected.push(format!("scenes/{}/prompt.json", q.scene));
        }
    }
    refuse_leftovers(&out.join(GROUND_TRUTH), &gt_files, &gt_expected)?;
    write_json(&out.join(GROUND_TRUTH).join("manifest.json"), &json!({"version": config.version, "files": gt_files, "digest": digest(&gt_files)}))?;
    Ok(gt_files)
}

/// The files and folders the public tree of the release should hold, and nothing else.
fn expected_public_files(quality: &[SceneQuality], lightings: &[ReleaseLighting]) -> Vec<String> {
    let mut expected: Vec<String> = vec!["classes.json".into(), "quality/quality_report.json".into(), OVERVIEW.into()];
    expected.extend(front_matter::FILES.iter().map(|f| f.to_string()));
    for q in quality {
        let scene = &q.scene;
        if publication::publishes_prompt_and_questions(q.split) {
            expected.extend([format!("scenes/{scene}/"), format!("questions/{scene}.json")]);
        }
        for lighting in lightings {
            expected.extend([format!("sequences/{lighting}/{scene}/"), format!("quality/contact_sheets/{lighting}/{scene}.png")]);
        }
    }
    expected
}

/// The manifest's provenance: the config, its seed and content digest, the code version
/// and, with a test split, the public id of the operator's secret (a hash that tells
/// nothing of it: which secret shaped the test scenes, for rotating it).
fn generator(config_text: &str, config: &config::ReleaseConfig, secret_id: Option<String>, assets_digest: Option<&str>) -> Generator {
    Generator {
        assets_digest: assets_digest.map(str::to_string),
        code_version: env!("CARGO_PKG_VERSION").to_string(),
        config: config_text.to_string(),
        content_digest: config.content_digest(),
        seed: config.seed,
        split_secret_id: secret_id,
    }
}

/// The public files of a release: everything built outside the ground truth that the
/// scene's split publishes ([`publication::is_public_in_sequence`]; a test sequence keeps
/// its colour and depth frames), and the ground truth of val scenes (under `ground_truth/`,
/// where the scorer reads it), sorted by path.
fn public_files(built: Vec<manifest::FileEntry>, ground_truth: &[manifest::FileEntry], splits: &BTreeMap<&str, Split>) -> Vec<manifest::FileEntry> {
    let split_of = |scene: &str| splits.get(scene).copied().unwrap_or(Split::Test);
    let public = |path: &str| match path.split('/').collect::<Vec<&str>>().as_slice() {
        ["sequences", _, scene, rest @ ..] => publication::is_public_in_sequence(split_of(scene), &rest.join("/")),
        _ => true,
    };
    let open = |path: &str| {
        let scene = path.split('/').next().unwrap_or_default();
        let file_scene = path.rsplit('/').next().and_then(|n| n.strip_suffix(".json")).unwrap_or_default();
        splits.get(scene) == Some(&Split::Val)
            || ((path.starts_with("questions/") || path.starts_with("objects/")) && splits.get(file_scene) == Some(&Split::Val))
    };
    let mut files: Vec<manifest::FileEntry> = built.into_iter().filter(|f| public(&f.path)).collect();
    files.extend(ground_truth.iter().filter(|f| open(&f.path)).map(|f| manifest::FileEntry {
        path: format!("{GROUND_TRUTH}/{}", f.path),
        size: f.size,
        sha256: f.sha256.clone(),
    }));
    files.sort_by(|a, b| a.path.cmp(&b.path));
    files
}

/// The quality report as published: every measure of val scenes, the frame and path
/// measures of test scenes (see [`SceneQuality::public`]); the counts, the oracle's
/// accuracy and the problems are those of the val scenes (the oracle's misses name
/// questions) when the release has a test split.
fn public_quality_report(quality: &[SceneQuality], config: &config::ReleaseConfig) -> Value {
    let test: Vec<&str> = quality.iter().filter(|q| q.split == Split::Test).map(|q| q.scene.as_str()).collect();
    let open: Vec<SceneQuality> = quality.iter().filter(|q| q.split == Split::Val).cloned().collect();
    let (oracle, oracle_problems) = oracle_ceiling(&open, config.quality.min_oracle_vqa);
    let problems: Vec<String> = open.iter().flat_map(|q| q.problems.iter().map(move |p| format!("{}: {p}", q.scene))).chain(oracle_problems).collect();
    let mut report = json!({
        "scenes": quality.len(),
        "full_match": open.iter().filter(|q| q.full_match).count(),
        "passed": open.iter().filter(|q| q.problems.is_empty()).count(),
        "bar": config.quality,
        "oracle_vqa": oracle,
        "problems": problems,
        "per_scene": quality.iter().map(SceneQuality::public).collect::<Vec<_>>(),
    });
    if !test.is_empty() {
        report["test_scenes"] = json!(test);
        report["counted_over"] = json!("val scenes: the test scenes' semantic measures are kept with the hidden ground truth");
    }
    report
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

/// Check a built release: every manifest entry's size and SHA-256, and the digest.
pub fn verify_release(dir: &Path) -> Result<usize> {
    let path: PathBuf = dir.join("manifest.json");
    let manifest = ReleaseManifest::read(&path)?;
    for f in &manifest.files {
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
    if !manifest.digest_matches() {
        return Err(InputError::new(&path, "digest", "the digest does not match the listed files"));
    }
    Ok(manifest.files.len())
}
