//! Quality control of a release: what every scene must reach before it is published,
//! checked twice. Before rendering, on the plan ([`planned_problems`]): the prompt's
//! objects present in the scene with their counts, its relations met, and the planned
//! trajectory predicted to map every prompted object, with few degenerate frames and
//! enough travel — a scene that misses this is replaced from the selection's spare
//! prompts. After rendering, on what was rendered ([`SceneQuality::measure`]): every
//! prompted instance mapped (ground-truth points counted per instance), degenerate
//! frames, travel, saturation per lighting, how `dynamic_lights` differs from
//! `baseline`, identical depth and semantics across lightings, and the oracle's VQA
//! accuracy; a miss there fails the build, naming the scene and the measure.

use std::collections::BTreeMap;

use osmab_evaluator::scores::{ReleaseLighting, Split};
use osmab_evaluator::vqa::SceneQuestions;
use osmab_evaluator::vqa::answer::ClassifiedGraph;
use osmab_evaluator::vqa::judge::judge_text_without_llm;
use serde::{Deserialize, Serialize};
use serde_json::Value;

use super::config::QualityConfig;
use super::instances::InstanceLabels;
use crate::convert::habitat::ConversionReport;
use crate::convert::lexicon::{class_id, normalise_name};
use crate::questions::facts::oracle_scene_graph;
use crate::questions::{MIN_SEEN_POINTS, SceneObject, object_id};
use crate::render::coverage::Plan;
use crate::render::sequence::SequenceSummary;
use crate::spec::{Regime, SceneSpec};

/// A prompted class: what the prompt asks for and what the scene holds.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct PromptedClass {
    /// The prompt's categories of this class.
    pub categories: Vec<String>,
    /// The release class (none: outside the lexicon, cannot be checked).
    pub class: Option<String>,
    pub expected: u32,
    pub present: u32,
    /// Instances with enough ground-truth points to be mapped.
    pub mapped: u32,
    pub ok: bool,
}

/// How the trajectory observed one object instance.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct InstanceCoverage {
    pub id: String,
    pub class: String,
    pub prompted: bool,
    /// Frames it is visible in.
    pub frames: usize,
    /// Distinct camera positions it was seen well from (≥ 0.05 % of the image, 0.5 m apart).
    pub viewpoints: usize,
    /// Nearest depth of its pixels, metres.
    pub closest_m: Option<f64>,
    pub gt_points: usize,
    pub mapped: bool,
}

/// One lighting of a scene.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct LightingQuality {
    /// Median and mean over frames of the share of saturated pixels.
    pub median_saturated: f64,
    pub mean_saturated: f64,
    /// Mean luma over frames (0–255).
    pub mean_luma: f64,
    /// Share of frames whose colour differs from the same frame under baseline.
    pub differs_from_baseline: f64,
    /// Lowest and highest per-frame luma relative to baseline.
    pub luma_vs_baseline: [f64; 2],
    /// Frames whose depth or semantic image differs from baseline's (must be 0).
    pub geometry_differs: usize,
}

/// The oracle's answers to a scene's questions.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct OracleVqa {
    /// Per category: [correct, asked].
    pub per_category: BTreeMap<String, [usize; 2]>,
    /// Questions the oracle's graph answers wrong: id, expected, given.
    pub misses: Vec<[String; 3]>,
}

/// A candidate prompt that missed the bar before rendering, and why.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Replaced {
    pub prompt_id: String,
    pub problems: Vec<String>,
}

/// Everything the quality report says of one scene.
#[derive(Debug, Clone, Serialize)]
pub struct SceneQuality {
    pub scene: String,
    pub subset: Regime,
    pub split: Split,
    pub prompt_id: String,
    /// Prompts tried for this scene before this one, and why they were replaced.
    pub replaced: Vec<Replaced>,
    pub prompted: Vec<PromptedClass>,
    pub instances: Vec<InstanceCoverage>,
    pub unmet_relations: Vec<String>,
    pub frames: usize,
    pub travelled_m: f64,
    /// Share of frames dominated by one class (> 85 %) or short of depth (< 50 %).
    pub degenerate_fraction: f64,
    pub lightings: BTreeMap<ReleaseLighting, LightingQuality>,
    pub oracle_vqa: OracleVqa,
    /// Pixels per class over the baseline sequence, and ground-truth points per class.
    pub class_pixels: BTreeMap<u16, u64>,
    pub gt_points: BTreeMap<i64, u64>,
    /// Every prompted instance present and mapped, every relation met.
    pub full_match: bool,
    /// What misses the bar (empty for a good scene).
    pub problems: Vec<String>,
}

/// Prompted classes of `spec` against `conversion`, each instance mapped when
/// `mapped(instance_id)`.
pub fn prompted_classes(spec: &SceneSpec, conversion: &ConversionReport, mapped: impl Fn(i64) -> bool) -> Vec<PromptedClass> {
    let mut by_class: BTreeMap<Option<&str>, (Vec<String>, u32)> = BTreeMap::new();
    for o in &spec.objects {
        // A category outside the lexicon cannot be checked: it is reported unmatched.
        let class = normalise_name(&o.category).filter(|c| class_id(c).is_some_and(|id| id != 0));
        let entry = by_class.entry(class).or_default();
        entry.0.push(o.category.clone());
        entry.1 += o.count;
    }
    by_class
        .into_iter()
        .map(|(class, (categories, expected))| {
            let instances: Vec<i64> = class.map(|c| conversion.objects.iter().filter(|o| o.class == c).map(|o| o.instance_id).collect()).unwrap_or_default();
            let present = instances.len() as u32;
            let mapped = instances.iter().filter(|&&id| mapped(id)).count() as u32;
            let ok = class.is_some() && present == expected && mapped == present;
            PromptedClass { categories, class: class.map(str::to_string), expected, present, mapped, ok }
        })
        .collect()
}

fn describe(p: &PromptedClass) -> String {
    match &p.class {
        None => format!("prompted {}: not a class of the lexicon", p.categories.join(", ")),
        Some(c) if p.present != p.expected => format!("prompted {c}: {} in the scene, {} asked for", p.present, p.expected),
        Some(c) => format!("prompted {c}: {} of {} instances mapped", p.mapped, p.present),
    }
}

/// How far below the bar a plan's degenerate frames must stay: the rendered frames differ
/// from the plan's probes by up to half a point (200 scenes of five 160×90 builds of the
/// full release, docs/performance.md), and a scene that misses the bar once rendered stops
/// the whole release.
const PLANNED_DEGENERATE_MARGIN: f64 = 0.01;

/// Why a candidate scene cannot be published, judged on its plan before rendering:
/// empty when it can.
pub fn planned_problems(spec: &SceneSpec, conversion: &ConversionReport, unmet: &[String], plan: &Plan, config: &QualityConfig) -> Vec<String> {
    // The probes see at lower resolution than the frames: ask twice the points.
    let predicted = |id: i64| plan.coverage.iter().any(|c| c.instance_id as i64 == id && c.points >= 2.0 * MIN_SEEN_POINTS as f64);
    let mut problems: Vec<String> =
        prompted_classes(spec, conversion, predicted).iter().filter(|p| !p.ok).map(|p| format!("{} (planned)", describe(p))).collect();
    problems.extend(unmet.iter().map(|r| format!("relation not met: {r}")));
    let degenerate = plan.degenerate_frames as f64 / plan.frames.len().max(1) as f64;
    let planned_bar = config.max_degenerate_fraction - PLANNED_DEGENERATE_MARGIN;
    if degenerate > planned_bar {
        problems.push(format!(
            "degenerate frames: {:.1} % planned (at most {:.0} % rendered, so at most {:.0} % planned)",
            100.0 * degenerate,
            100.0 * config.max_degenerate_fraction,
            100.0 * planned_bar
        ));
    }
    if plan.travelled < config.min_travel {
        problems.push(format!("camera travel: {:.2} m planned (at least {} m)", plan.travelled, config.min_travel));
    }
    problems
}

fn median(values: &mut [f64]) -> f64 {
    if values.is_empty() {
        return 0.0;
    }
    values.sort_by(f64::total_cmp);
    let n = values.len();
    if n % 2 == 1 { values[n / 2] } else { (values[n / 2 - 1] + values[n / 2]) / 2.0 }
}

/// Each lighting's exposure and its differences from `baseline` (frame by frame).
pub fn lighting_quality(summaries: &BTreeMap<ReleaseLighting, SequenceSummary>) -> BTreeMap<ReleaseLighting, LightingQuality> {
    let baseline = summaries.get(&ReleaseLighting::BASELINE);
    summaries
        .iter()
        .map(|(lighting, s)| {
            let mut saturated: Vec<f64> = s.per_frame.iter().map(|f| f.saturated as f64).collect();
            let n = s.per_frame.len().max(1) as f64;
            let mean_saturated = saturated.iter().sum::<f64>() / n;
            let mean_luma = s.per_frame.iter().map(|f| f.luma as f64).sum::<f64>() / n;
            let (mut differs, mut geometry_differs, mut lo, mut hi) = (0usize, 0usize, f64::INFINITY, f64::NEG_INFINITY);
            if let Some(b) = baseline {
                for (f, g) in s.per_frame.iter().zip(&b.per_frame) {
                    differs += (f.colour_digest != g.colour_digest) as usize;
                    geometry_differs += (f.geometry_digest != g.geometry_digest) as usize;
                    if g.luma > 0.5 {
                        let ratio = f.luma as f64 / g.luma as f64;
                        lo = lo.min(ratio);
                        hi = hi.max(ratio);
                    }
                }
                geometry_differs += s.per_frame.len().abs_diff(b.per_frame.len());
            }
            let round = |v: f64| if v.is_finite() { (v * 1e4).round() / 1e4 } else { 1.0 };
            let quality = LightingQuality {
                median_saturated: round(median(&mut saturated)),
                mean_saturated: round(mean_saturated),
                mean_luma: (mean_luma * 10.0).round() / 10.0,
                differs_from_baseline: round(differs as f64 / n),
                luma_vs_baseline: [round(lo), round(hi)],
                geometry_differs,
            };
            (lighting.clone(), quality)
        })
        .collect()
}

/// The oracle's graph (every seen object) answering `questions`.
pub fn oracle_vqa(questions: &SceneQuestions, objects: &[SceneObject], lexicon: &[String]) -> OracleVqa {
    let graph = oracle_scene_graph(objects);
    let answerer = ClassifiedGraph::new(&graph, lexicon);
    let mut out = OracleVqa::default();
    for q in &questions.questions {
        let (Some(form), Some(answer)) = (&q.form, &q.answer) else { continue };
        let given = answerer.answer(form);
        let correct = judge_text_without_llm(answer, &given, Some(form)).is_some_and(|v| v.correct);
        let tally = out.per_category.entry(q.category.clone()).or_default();
        tally[0] += correct as usize;
        tally[1] += 1;
        if !correct {
            out.misses.push([q.id.clone(), answer.clone(), given]);
        }
    }
    out
}

/// Everything measured of a rendered scene, for [`SceneQuality::measure`].
pub struct Rendered<'a> {
    pub split: Split,
    pub spec: &'a SceneSpec,
    pub conversion: &'a ConversionReport,
    pub unmet: &'a [String],
    pub summaries: &'a BTreeMap<ReleaseLighting, SequenceSummary>,
    pub instances: &'a InstanceLabels,
    pub gt_labels: &'a [i64],
    pub objects: &'a [SceneObject],
    pub questions: &'a SceneQuestions,
    pub lexicon: &'a [String],
}

/// What the public quality report shows of a test scene: the measures of its frames and
/// path, not those of its semantics (classes, instances, relations met, the oracle's
/// answers) nor its prompt's id (which names a prompt of the pool the published config
/// rebuilds), which would tell its hidden ground truth and answers.
#[derive(Serialize)]
struct PublicTestScene<'a> {
    scene: &'a str,
    subset: Regime,
    split: Split,
    frames: usize,
    travelled_m: f64,
    degenerate_fraction: f64,
    lightings: &'a BTreeMap<ReleaseLighting, LightingQuality>,
}

impl SceneQuality {
    /// This scene as the public quality report shows it: everything for a val scene,
    /// the frame and path measures only for a test scene.
    pub fn public(&self) -> Value {
        match self.split {
            Split::Val => serde_json::to_value(self),
            Split::Test => serde_json::to_value(PublicTestScene {
                scene: &self.scene,
                subset: self.subset,
                split: self.split,
                frames: self.frames,
                travelled_m: self.travelled_m,
                degenerate_fraction: self.degenerate_fraction,
                lightings: &self.lightings,
            }),
        }
        .expect("serialisable")
    }

    /// Measure a rendered scene and judge it against `config`.
    pub fn measure(scene: &str, prompt_id: &str, replaced: Vec<Replaced>, r: &Rendered, config: &QualityConfig) -> SceneQuality {
        let points = |id: i64| r.instances.instances.get(&id).map_or(0, |p| p.points);
        let prompted = prompted_classes(r.spec, r.conversion, |id| points(id) >= MIN_SEEN_POINTS);
        let prompted_names: Vec<&str> = prompted.iter().filter_map(|p| p.class.as_deref()).collect();
        let baseline = r.summaries.get(&ReleaseLighting::BASELINE).or_else(|| r.summaries.values().next()).cloned().unwrap_or_default();
        let instances: Vec<InstanceCoverage> = r
            .objects
            .iter()
            .map(|o| {
                let instance: i64 = o.id.trim_start_matches("obj_").parse().unwrap_or(0);
                let seen = baseline.objects.get(&(instance as u16));
                InstanceCoverage {
                    id: object_id(instance),
                    class: o.label.clone(),
                    prompted: prompted_names.contains(&o.label.as_str()),
                    frames: seen.map_or(0, |s| s.frames),
                    viewpoints: seen.map_or(0, |s| s.viewpoints.len()),
                    closest_m: seen.and_then(|s| s.closest).map(|c| (c * 1000.0).round() / 1000.0),
                    gt_points: o.points,
                    mapped: o.seen(),
                }
            })
            .collect();
        let degenerate_fraction = baseline.per_frame.iter().filter(|f| f.degenerate()).count() as f64 / baseline.per_frame.len().max(1) as f64;
        let lightings = lighting_quality(r.summaries);
        let mut gt_points: BTreeMap<i64, u64> = BTreeMap::new();
        for &l in r.gt_labels {
            *gt_points.entry(l).or_default() += 1;
        }
        let full_match = prompted.iter().all(|p| p.ok) && r.unmet.is_empty();
        let mut quality = SceneQuality {
            scene: scene.to_string(),
            subset: r.spec.regime,
            split: r.split,
            prompt_id: prompt_id.to_string(),
            replaced,
            prompted,
            instances,
            unmet_relations: r.unmet.to_vec(),
            frames: baseline.frames,
            travelled_m: (baseline.travelled * 1000.0).round() / 1000.0,
            degenerate_fraction: (degenerate_fraction * 1e4).round() / 1e4,
            lightings,
            oracle_vqa: oracle_vqa(r.questions, r.objects, r.lexicon),
            class_pixels: baseline.class_pixels.clone(),
            gt_points,
            full_match,
            problems: Vec::new(),
        };
        quality.problems = quality.misses(config);
        quality
    }

    /// What misses the bar of `config`.
    fn misses(&self, config: &QualityConfig) -> Vec<String> {
        let mut problems: Vec<String> = self.prompted.iter().filter(|p| !p.ok).map(describe).collect();
        problems.extend(self.unmet_relations.iter().map(|r| format!("relation not met: {r}")));
        if self.degenerate_fraction > config.max_degenerate_fraction {
            problems.push(format!("degenerate frames: {:.1} % (at most {:.0} %)", 100.0 * self.degenerate_fraction, 100.0 * config.max_degenerate_fraction));
        }
        if self.travelled_m < config.min_travel {
            problems.push(format!("camera travel: {:.2} m (at least {} m)", self.travelled_m, config.min_travel));
        }
        for (lighting, q) in &self.lightings {
            if q.median_saturated > config.max_median_saturated {
                problems.push(format!(
                    "{lighting}: median saturated pixels {:.1} % (at most {:.0} %)",
                    100.0 * q.median_saturated,
                    100.0 * config.max_median_saturated
                ));
            }
            if q.geometry_differs > 0 {
                problems.push(format!("{lighting}: depth or semantics differ from baseline in {} frames", q.geometry_differs));
            }
        }
        if let Some(q) = self.lightings.get(&ReleaseLighting::DynamicLights).filter(|_| self.lightings.contains_key(&ReleaseLighting::BASELINE)) {
            if q.differs_from_baseline < config.min_dynamic_changed_fraction {
                problems.push(format!(
                    "dynamic_lights: {:.1} % of frames differ from baseline (at least {:.0} %)",
                    100.0 * q.differs_from_baseline,
                    100.0 * config.min_dynamic_changed_fraction
                ));
            }
            if q.luma_vs_baseline[1] - q.luma_vs_baseline[0] < 0.1 {
                problems.push(format!(
                    "dynamic_lights: brightness relative to baseline stays within {:.2}–{:.2} along the sequence",
                    q.luma_vs_baseline[0], q.luma_vs_baseline[1]
                ));
            }
        }
        problems
    }
}

/// The oracle's accuracy per category over all scenes, and the categories under
/// `min_accuracy` as problems.
pub fn oracle_ceiling(scenes: &[SceneQuality], min_accuracy: f64) -> (BTreeMap<String, f64>, Vec<String>) {
    let mut totals: BTreeMap<String, [usize; 2]> = BTreeMap::new();
    for s in scenes {
        for (category, [correct, asked]) in &s.oracle_vqa.per_category {
            let t = totals.entry(category.clone()).or_default();
            t[0] += correct;
            t[1] += asked;
        }
    }
    let accuracy: BTreeMap<String, f64> = totals.iter().map(|(c, [k, n])| (c.clone(), *k as f64 / (*n).max(1) as f64)).collect();
    let problems = accuracy
        .iter()
        .filter(|(_, a)| **a < min_accuracy)
        .map(|(c, a)| {
            let misses: Vec<String> = scenes.iter().flat_map(|s| s.oracle_vqa.misses.iter().map(|m| m[0].clone())).take(5).collect();
            format!("oracle VQA, {c}: {:.1} % (at least {:.0} %); missed {}", 100.0 * a, 100.0 * min_accuracy, misses.join(", "))
        })
        .collect();
    (accuracy, problems)
}
