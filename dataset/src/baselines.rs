//! Reference submissions made from a release's ground truth, so the leaderboard shows
//! meaningful differences before any team submits: the oracle (scores 1.0) and
//! degraded variants (small objects dropped, neighbouring objects merged, label noise,
//! pose drift), each in the submission format of product.md section 5. The degradations
//! grow with the lighting's difficulty ([`lighting_severity`]), so the relative change
//! against the baseline lighting has the paper's shape on the demo leaderboard.

use std::collections::BTreeMap;
use std::path::Path;

use osmab_evaluator::formats::classes::ClassList;
use osmab_evaluator::formats::manifest::ReleaseManifest;
use osmab_evaluator::formats::map::{MapSemantics, PredictedMap};
use osmab_evaluator::ground_truth::GroundTruth;
use osmab_evaluator::scores::{ReleaseLighting, Split};
use osmab_evaluator::synthetic::Rng;
use osmab_evaluator::{InputError, Result};
use serde_json::{Value, json};

use crate::questions::{SceneObject, oracle_graph};
use crate::release::GROUND_TRUTH;
use crate::release::stages::INSTANCES_NPY;
use osmab_evaluator::formats::npy::{ReadLimits, read_npy_file};

/// A control: a reference submission made from the ground truth.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Control {
    /// The ground truth itself.
    Oracle,
    /// The ground truth without its small classes.
    DropSmall,
    /// The ground truth with its small classes merged into their nearest neighbours.
    Merge,
    /// The ground truth with some objects given another class.
    LabelNoise,
    /// The ground truth moved by a small pose drift.
    PoseDrift,
}

impl Control {
    /// Every control, in the order the board lists them.
    pub const ALL: [Control; 5] = [Control::Oracle, Control::DropSmall, Control::Merge, Control::LabelNoise, Control::PoseDrift];

    /// The name a submission's method takes after `baseline-`.
    pub const fn name(self) -> &'static str {
        match self {
            Control::Oracle => "oracle",
            Control::DropSmall => "drop-small",
            Control::Merge => "merge",
            Control::LabelNoise => "label-noise",
            Control::PoseDrift => "pose-drift",
        }
    }

    /// What the control is, as its method card says.
    pub const fn description(self) -> &'static str {
        match self {
            Control::Oracle => "The ground truth itself: every ground-truth point labelled with its class (scores 1.0).",
            Control::DropSmall => "The ground truth without classes under 2% of the points (small objects missed).",
            Control::Merge => "The ground truth with about half the classes merged into their nearest neighbour class.",
            Control::LabelNoise => "The ground truth split into objects, every fourth given another class of the scene.",
            Control::PoseDrift => "The ground truth moved by a 1.5 degree, 8 cm pose drift.",
        }
    }
}

impl std::fmt::Display for Control {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

impl std::str::FromStr for Control {
    type Err = String;
    fn from_str(name: &str) -> std::result::Result<Self, String> {
        Control::ALL
            .into_iter()
            .find(|c| c.name() == name)
            .ok_or_else(|| format!("unknown baseline '{name}' (expected one of {})", Control::ALL.map(Control::name).join(", ")))
    }
}

/// Objects of a map: points grouped by class and 2 m cell (an instance-like split).
struct Objects {
    object_ids: Vec<u32>,
    labels: Vec<i64>,
}

fn objects_of(points: &[[f32; 3]], labels: &[i64]) -> Objects {
    let mut index: BTreeMap<(i64, i32, i32), u32> = BTreeMap::new();
    let mut object_ids = Vec::with_capacity(points.len());
    for (p, &l) in points.iter().zip(labels) {
        let key = (l, (p[0] / 2.0).floor() as i32, (p[2] / 2.0).floor() as i32);
        let next = index.len() as u32;
        object_ids.push(*index.entry(key).or_insert(next));
    }
    let mut object_labels = vec![0; index.len()];
    for ((l, _, _), id) in &index {
        object_labels[*id as usize] = *l;
    }
    Objects { object_ids, labels: object_labels }
}

/// How much harder a lighting makes mapping for the degraded baselines (1 = baseline
/// lighting; the order follows OSMa-Bench's findings: no lights hurts most).
pub const fn lighting_severity(lighting: ReleaseLighting) -> f64 {
    match lighting {
        ReleaseLighting::Baseline => 1.0,
        ReleaseLighting::Camera => 1.2,
        ReleaseLighting::DynamicLights => 1.4,
        ReleaseLighting::NoLights => 1.8,
    }
}

/// The pose-drift baseline's motion of a point: a 1.5° yaw and an 8 cm shift, times `severity`.
fn pose_drift(p: [f64; 3], severity: f64) -> [f64; 3] {
    let (s, c) = (1.5 * severity).to_radians().sin_cos();
    [c * p[0] + s * p[2] + 0.08 * severity, p[1], -s * p[0] + c * p[2] + 0.03 * severity]
}

/// The map of `control` for one scene's ground truth under a lighting of `severity`,
/// and for each of its points the ground-truth point it came from.
fn baseline_map(control: Control, gt: &GroundTruth, seed: u64, severity: f64) -> Result<(PredictedMap, Vec<usize>)> {
    let mut origin: Vec<usize> = (0..gt.points.len()).collect();
    let mut points = gt.points.clone();
    let mut labels = gt.labels.clone();
    match control {
        Control::Oracle => {}
        Control::DropSmall => drop_small_classes(gt, &mut points, &mut labels, &mut origin, severity)?,
        Control::Merge => merge_small_classes(&points, &mut labels, severity),
        Control::LabelNoise => {
            let objects = objects_of(&points, &labels);
            let noisy = mislabelled_objects(&objects, &mut Rng::new(seed), severity);
            let map =
                PredictedMap { source: gt.source.clone(), points, semantics: MapSemantics::ObjectLabels { object_ids: objects.object_ids, labels: noisy } };
            return Ok((map, origin));
        }
        Control::PoseDrift => {
            // A 1.5° yaw and 8 cm shift of the whole map (more under harder lightings):
            // geometry near boundaries mislabels.
            for p in &mut points {
                let moved = pose_drift([p[0] as f64, p[1] as f64, p[2] as f64], severity);
                *p = moved.map(|v| v as f32);
            }
        }
    }
    let objects = objects_of(&points, &labels);
    let map =
        PredictedMap { source: gt.source.clone(), points, semantics: MapSemantics::ObjectLabels { object_ids: objects.object_ids, labels: objects.labels } };
    Ok((map, origin))
}

/// The drop-small baseline: classes with under 2 % of the points (times `severity`)
/// vanish from the map, with their points' origins.
fn drop_small_classes(gt: &GroundTruth, points: &mut Vec<[f32; 3]>, labels: &mut Vec<i64>, origin: &mut Vec<usize>, severity: f64) -> Result<()> {
    let mut counts: BTreeMap<i64, usize> = BTreeMap::new();
    for &l in labels.iter() {
        *counts.entry(l).or_default() += 1;
    }
    let small: Vec<i64> = counts.iter().filter(|(_, c)| (**c as f64) < 0.02 * severity * labels.len() as f64).map(|(l, _)| *l).collect();
    let keep: Vec<bool> = labels.iter().map(|l| !small.contains(l)).collect();
    if keep.iter().all(|k| !k) {
        return Err(InputError::new(&gt.source, "labels", "every class is small; nothing would be left"));
    }
    *points = points.iter().zip(&keep).filter(|(_, k)| **k).map(|(p, _)| *p).collect();
    *labels = labels.iter().zip(&keep).filter(|(_, k)| **k).map(|(l, _)| *l).collect();
    *origin = origin.iter().zip(&keep).filter(|(_, k)| **k).map(|(o, _)| *o).collect();
    Ok(())
}

/// The merge baseline: the smaller half of the classes (at least one, never the largest;
/// more under harder lightings) take the label of the class whose centroid is nearest.
fn merge_small_classes(points: &[[f32; 3]], labels: &mut [i64], severity: f64) {
    let mut sums: BTreeMap<i64, ([f64; 3], usize)> = BTreeMap::new();
    for (p, &l) in points.iter().zip(labels.iter()) {
        let e = sums.entry(l).or_insert(([0.0; 3], 0));
        for a in 0..3 {
            e.0[a] += p[a] as f64;
        }
        e.1 += 1;
    }
    let centroids: Vec<(i64, [f64; 3], usize)> = sums.iter().map(|(&l, (s, n))| (l, s.map(|v| v / *n as f64), *n)).collect();
    let mut by_size: Vec<&(i64, [f64; 3], usize)> = centroids.iter().collect();
    by_size.sort_by_key(|c| (c.2, c.0));
    let extra = ((severity - 1.0) * 2.5).floor() as usize;
    let merging: Vec<i64> =
        by_size.iter().take((centroids.len().saturating_sub(1) / 2 + extra).max(1).min(centroids.len().saturating_sub(1))).map(|c| c.0).collect();
    let merged: BTreeMap<i64, i64> = centroids
        .iter()
        .filter(|c| merging.contains(&c.0))
        .filter_map(|c| {
            centroids
                .iter()
                .filter(|o| o.0 != c.0)
                .min_by(|a, b| {
                    let d = |o: &[f64; 3]| (0..3).map(|k| (o[k] - c.1[k]).powi(2)).sum::<f64>();
                    d(&a.1).total_cmp(&d(&b.1))
                })
                .map(|o| (c.0, o.0))
        })
        .collect();
    for l in labels.iter_mut() {
        if let Some(&m) = merged.get(l) {
            *l = m;
        }
    }
}

/// The label-noise baseline's object labels: every fourth object (from a phase drawn from
/// `rng`) takes the next class of the scene; harder lightings mislabel part of a second
/// quarter too.
fn mislabelled_objects(objects: &Objects, rng: &mut Rng, severity: f64) -> Vec<i64> {
    let vocabulary: Vec<i64> = objects.labels.iter().copied().collect::<std::collections::BTreeSet<_>>().into_iter().collect();
    let phase = rng.below(4);
    let extra_tenths = ((severity - 1.0) * 10.0).round() as usize;
    let next = |l: i64| vocabulary[(vocabulary.iter().position(|&v| v == l).unwrap_or(0) + 1) % vocabulary.len()];
    let is_noisy = |i: usize| i % 4 == phase || (i % 4 == (phase + 2) % 4 && (i / 4) % 10 < extra_tenths);
    objects.labels.iter().enumerate().map(|(i, &l)| if is_noisy(i) { next(l) } else { l }).collect()
}

/// The scene graph of a baseline from the scene's objects (the release's hidden
/// `objects/<scene>.json`) and the instance of every ground-truth point: the oracle's is
/// the seen objects as they are; a degraded baseline names each seen object by the
/// majority label its map gives the object's own points (so a merged or mislabelled
/// object is named wrongly, a dropped one is missing) and, for pose-drift, moves its box
/// by the drift.
fn graph_from_objects(
    control: Control,
    objects: &[SceneObject],
    map: &PredictedMap,
    origin: &[usize],
    instances: &[i64],
    classes: &ClassList,
    severity: f64,
) -> Value {
    if control == Control::Oracle {
        return oracle_graph(objects);
    }
    let MapSemantics::ObjectLabels { object_ids, labels } = &map.semantics else { return json!({"objects": []}) };
    let mut votes: BTreeMap<i64, BTreeMap<i64, usize>> = BTreeMap::new();
    for (k, &o) in origin.iter().enumerate() {
        if let Some(&instance) = instances.get(o) {
            *votes.entry(instance).or_default().entry(labels[object_ids[k] as usize]).or_default() += 1;
        }
    }
    let round = |v: f64| (v * 1000.0).round() / 1000.0;
    let nodes: Vec<Value> = objects
        .iter()
        .filter(|o| o.seen())
        .filter_map(|o| {
            let instance: i64 = o.id.trim_start_matches("obj_").parse().ok()?;
            let class = votes.get(&instance)?.iter().max_by_key(|(l, n)| (**n, std::cmp::Reverse(**l))).map(|(l, _)| *l)?;
            let label = classes.name(class).unwrap_or("other").to_string();
            let caption = if label == o.label { o.caption.clone() } else { format!("a {label}") };
            let center = if control == Control::PoseDrift { pose_drift(o.bbox_center, severity) } else { o.bbox_center };
            Some(json!({"id": o.id, "label": label, "caption": caption, "bbox_center": center.map(round), "bbox_extent": o.bbox_extent.map(round)}))
        })
        .collect();
    json!({"objects": nodes})
}

/// The scene graph of a map: one node per object with its class name and box (for
/// releases without the seen objects).
fn scene_graph(map: &PredictedMap, classes: &ClassList) -> Value {
    let MapSemantics::ObjectLabels { object_ids, labels } = &map.semantics else { return json!({"objects": []}) };
    let mut boxes = vec![([f32::INFINITY; 3], [f32::NEG_INFINITY; 3]); labels.len()];
    for (p, &o) in map.points.iter().zip(object_ids) {
        let b = &mut boxes[o as usize];
        for a in 0..3 {
            b.0[a] = b.0[a].min(p[a]);
            b.1[a] = b.1[a].max(p[a]);
        }
    }
    let objects: Vec<Value> = labels
        .iter()
        .zip(&boxes)
        .enumerate()
        .filter(|(_, (_, b))| b.0[0].is_finite())
        .map(|(i, (&l, (lo, hi)))| {
            let round = |v: f32| (v as f64 * 1000.0).round() / 1000.0;
            json!({"id": i, "label": classes.name(l).unwrap_or("other"), "bbox_center": (0..3).map(|a| round((lo[a] + hi[a]) / 2.0)).collect::<Vec<_>>(), "bbox_extent": (0..3).map(|a| round(hi[a] - lo[a])).collect::<Vec<_>>()})
        })
        .collect();
    json!({"objects": objects})
}

/// Write `control` for the release in `release` as a submission directory; returns the
/// maps written.
pub fn write_baseline(control: Control, release: &Path, out: &Path) -> Result<usize> {
    let manifest = ReleaseManifest::read(&release.join("manifest.json"))?;
    std::fs::create_dir_all(out).map_err(|e| InputError::io(out, &e))?;
    let submission = json!({"format": "osmab-submission/1", "release": manifest.version, "method": {"name": format!("baseline-{control}"), "description": control.description()}});
    std::fs::write(out.join("submission.json"), serde_json::to_string_pretty(&submission).expect("json") + "\n").map_err(|e| InputError::io(out, &e))?;
    let mut written = 0;
    for (i, entry) in manifest.scenes.iter().enumerate() {
        let scene = entry.id.as_str();
        let gt_dir = release.join(GROUND_TRUTH).join(scene);
        // A public copy of a release has no ground truth for its test scenes: the
        // baseline covers the val split there (the server's copy covers both).
        if entry.split == Split::Test && !gt_dir.is_dir() {
            continue;
        }
        let classes = ClassList::read(&gt_dir.join("embed_semseg_classes.json"))?;
        let gt = GroundTruth::read(&gt_dir, &classes)?;
        // The scene's objects and the instance of every ground-truth point, when the
        // release has them.
        let objects_path = release.join(GROUND_TRUTH).join("objects").join(format!("{scene}.json"));
        let instances_path = gt_dir.join(INSTANCES_NPY);
        let known: Option<(Vec<SceneObject>, Vec<i64>)> = match (std::fs::read(&objects_path), instances_path.is_file()) {
            (Ok(bytes), true) => {
                let value: Value = serde_json::from_slice(&bytes).map_err(|e| InputError::new(&objects_path, "(json)", e.to_string()))?;
                let objects = serde_json::from_value(value["objects"].clone()).map_err(|e| InputError::new(&objects_path, "objects", e.to_string()))?;
                let instances = read_npy_file(&instances_path, ReadLimits::default())?.into_i64_vec(&instances_path, "instances")?;
                if instances.len() != gt.points.len() {
                    return Err(InputError::new(
                        &instances_path,
                        "instances",
                        format!("expected one per ground-truth point ({}), found {}", gt.points.len(), instances.len()),
                    ));
                }
                Some((objects, instances))
            }
            _ => None,
        };
        for &lighting in &manifest.lightings {
            let severity = lighting_severity(lighting);
            let (map, origin) = baseline_map(control, &gt, 1000 + i as u64, severity)?;
            let graph = match &known {
                Some((objects, instances)) => graph_from_objects(control, objects, &map, &origin, instances, &classes, severity),
                None => scene_graph(&map, &classes),
            };
            let map_path = out.join("maps").join(lighting.name()).join(format!("{scene}.npz"));
            std::fs::create_dir_all(map_path.parent().expect("nested")).map_err(|e| InputError::io(&map_path, &e))?;
            map.write(&map_path, true)?;
            let graph_path = out.join("graphs").join(lighting.name()).join(format!("{scene}.json"));
            std::fs::create_dir_all(graph_path.parent().expect("nested")).map_err(|e| InputError::io(&graph_path, &e))?;
            std::fs::write(&graph_path, serde_json::to_string(&graph).expect("json")).map_err(|e| InputError::io(&graph_path, &e))?;
            written += 1;
        }
    }
    Ok(written)
}
