//! `perceive`: learn from the val split, map every scene under every lighting, and write
//! the submission (product.md section 5) exactly as a team would.

use std::path::Path;

use osmab_dataset::colour::colour_name;
use osmab_evaluator::formats::classes::ClassList;
use osmab_evaluator::formats::map::{MapSemantics, PredictedMap};
use osmab_evaluator::scores::Lighting;
use osmab_evaluator::submission::release::ReleaseScene;
use osmab_evaluator::{InputError, Result};
use rayon::prelude::*;
use serde_json::{Value, json};

use crate::features::FeatureSet;
use crate::learn::{RegionClassifier, Votes, see};
use crate::public::PublicSequence;
use crate::regions::NONE;
use crate::voxels::{CutMap, GRAPH_MIN_VOXELS, VoxelMap};

/// What a run of the mapper did.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Perceived {
    /// Maps written (scenes × lightings).
    pub maps: usize,
    /// Regions the classifier learned from.
    pub training_regions: usize,
    /// Classes among them.
    pub training_classes: usize,
}

/// The method's name on the board for each feature set.
pub fn method_name(set: FeatureSet) -> &'static str {
    match set {
        FeatureSet::Seeing => "baseline-perceive",
        FeatureSet::GeometryOnly => "baseline-perceive-geometry",
    }
}

fn method_description(set: FeatureSet) -> &'static str {
    match set {
        FeatureSet::Seeing => {
            "The project's reference mapper: image regions (colour superpixels cut at depth steps) classified by two random forests \
             whose trees vote together, one from the regions' colour, texture and geometry, one from their geometry alone, learned on \
             the val split's frames under baseline lighting; lifted with depth and pose into 5 cm voxels that sum the trees' votes; \
             objects are connected voxels of one class. Reads only what a team downloads."
        }
        FeatureSet::GeometryOnly => {
            "The reference mapper without colour and texture: regions classified by two forests from their geometry alone (height, orientation, size, range)."
        }
    }
}

/// Map the release in `release` with feature set `set` and write the submission to `out`.
pub fn perceive(release: &Path, out: &Path, set: FeatureSet) -> Result<Perceived> {
    let index = osmab_evaluator::submission::ReleaseIndex::read(release)?;
    let classifier = RegionClassifier::train(release, &index, set)?;
    std::fs::create_dir_all(out).map_err(|e| InputError::io(out, &e))?;
    let submission = json!({
        "format": "osmab-submission/1",
        "release": index.version,
        "method": {"name": method_name(set), "description": method_description(set)},
    });
    write_json(&out.join("submission.json"), &submission, true)?;
    let mut maps = 0;
    for scene in &index.scenes {
        for &lighting in &index.lightings {
            let cut = map_sequence(release, scene, lighting, &classifier)?;
            write_map(out, scene, lighting, &cut, &index.classes)?;
            maps += 1;
        }
    }
    Ok(Perceived { maps, training_regions: classifier.examples.values().sum(), training_classes: classifier.examples.len() })
}

/// The cut voxel map of `scene` under `lighting`.
pub fn map_sequence(release: &Path, scene: &ReleaseScene, lighting: Lighting, classifier: &RegionClassifier) -> Result<CutMap> {
    let sequence = PublicSequence::open(release, lighting, &scene.id, scene.split)?;
    let seen = see(&sequence, false)?;
    let region_votes: Vec<Vec<Votes>> = (0..seen.frames.len()).into_par_iter().map(|k| classifier.votes(&seen.features(k, classifier.set))).collect();
    let mut map = VoxelMap::default();
    for ((frame, regions), votes) in seen.frames.iter().zip(&seen.regions).zip(&region_votes) {
        for (i, &r) in regions.of_block.iter().enumerate() {
            if r != NONE {
                map.add(frame.world[i], &votes[r as usize], frame.rgb[i]);
            }
        }
    }
    if map.is_empty() {
        return Err(InputError::new(&sequence.dir, "results/depth*.png", "no block of any used frame has a depth within range"));
    }
    Ok(map.cut())
}

fn write_map(out: &Path, scene: &ReleaseScene, lighting: Lighting, cut: &CutMap, classes: &ClassList) -> Result<()> {
    let map_path = out.join("maps").join(lighting.name()).join(format!("{}.npz", scene.id));
    std::fs::create_dir_all(map_path.parent().expect("nested")).map_err(|e| InputError::io(&map_path, &e))?;
    let labels = cut.objects.iter().map(|o| o.class as i64).collect();
    let map = PredictedMap {
        source: map_path.clone(),
        points: cut.points.clone(),
        semantics: MapSemantics::ObjectLabels { object_ids: cut.object_ids.clone(), labels },
    };
    map.write(&map_path, true)?;
    let graph_path = out.join("graphs").join(lighting.name()).join(format!("{}.json", scene.id));
    std::fs::create_dir_all(graph_path.parent().expect("nested")).map_err(|e| InputError::io(&graph_path, &e))?;
    write_json(&graph_path, &scene_graph(cut, classes), false)
}

/// One node per object of at least [`GRAPH_MIN_VOXELS`] voxels: its class, the colour its
/// pixels showed under this lighting, and its box.
pub fn scene_graph(cut: &CutMap, classes: &ClassList) -> Value {
    let round = |v: f64| (v * 1000.0).round() / 1000.0;
    let nodes: Vec<Value> = cut
        .objects
        .iter()
        .enumerate()
        .filter(|(_, o)| o.voxels >= GRAPH_MIN_VOXELS && o.class != 0)
        .map(|(id, o)| {
            let label = classes.name(o.class as i64).unwrap_or("other");
            let caption = match colour_name(o.rgb) {
                Some(colour) => format!("a {colour} {label}"),
                None => format!("a {label}"),
            };
            json!({"id": id, "label": label, "caption": caption, "bbox_center": o.centre.map(round), "bbox_extent": o.extent.map(round)})
        })
        .collect();
    json!({"objects": nodes})
}

fn write_json(path: &Path, value: &Value, pretty: bool) -> Result<()> {
    let text = if pretty { serde_json::to_string_pretty(value).expect("json") + "\n" } else { serde_json::to_string(value).expect("json") };
    std::fs::write(path, text).map_err(|e| InputError::io(path, &e))
}
