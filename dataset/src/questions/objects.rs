//! The objects of a scene as its questions see them: each instance with its class, caption,
//! exact box, colour (its albedo where the camera saw it), ground-truth points and what it
//! rests on; and the scene graph a perfect map builds of them.

use std::collections::BTreeMap;

use serde::{Deserialize, Serialize};
use serde_json::{Value, json};

use super::support::Support;
pub use crate::colour::colour_name;
use crate::convert::habitat::ConversionReport;
use crate::convert::lexicon::is_shell_class;

/// Ground-truth points an object needs to count as seen (mapped) by the trajectory.
pub const MIN_SEEN_POINTS: usize = 10;

/// What the ground truth holds of one object instance.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct InstancePoints {
    /// Its ground-truth points.
    pub points: usize,
    /// The mean albedo (sRGB, 0–255) of the colour covering most of its surface where those
    /// points lie (`None` when no one colour covers half of it).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub albedo: Option<[f64; 3]>,
}

/// An object of the scene (not its shell) and how much of it the trajectory saw.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SceneObject {
    pub id: String,
    pub label: String,
    /// Box of the object (from the scene), world frame, y up.
    pub bbox_center: [f64; 3],
    pub bbox_extent: [f64; 3],
    /// Its ground-truth points (0: the camera never saw it).
    pub points: usize,
    /// The colour name of its albedo where it was seen, when clear.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub colour: Option<String>,
    /// A caption in the style of ConceptGraphs' (`a red chair`).
    pub caption: String,
    /// What it rests on: another object's id, `floor`, or nothing known.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub rests_on: Option<String>,
}

impl SceneObject {
    /// Whether the trajectory saw it (at least [`MIN_SEEN_POINTS`] ground-truth points).
    pub fn seen(&self) -> bool {
        self.points >= MIN_SEEN_POINTS
    }
    pub fn min(&self, axis: usize) -> f64 {
        self.bbox_center[axis] - self.bbox_extent[axis] / 2.0
    }
    pub fn max(&self, axis: usize) -> f64 {
        self.bbox_center[axis] + self.bbox_extent[axis] / 2.0
    }
}

/// The scene's objects (not the shell), each with its ground-truth points (`instances`,
/// by instance id), the colour of its albedo and what it rests on (`supports`).
pub fn scene_objects(report: &ConversionReport, instances: &BTreeMap<i64, InstancePoints>, supports: &BTreeMap<i64, Support>) -> Vec<SceneObject> {
    report
        .objects
        .iter()
        .filter(|o| !is_shell_class(&o.class))
        .map(|o| {
            let seen = instances.get(&o.instance_id).cloned().unwrap_or_default();
            // Screens, leaves and clock faces keep their own colours, which follow from the
            // class: no colour is named (or asked) for them.
            let own_colours = crate::synthesis::finishes::keeps_own_colours(&o.class);
            let colour = seen.albedo.filter(|_| seen.points >= MIN_SEEN_POINTS && !own_colours).and_then(colour_name).map(str::to_string);
            let center = std::array::from_fn(|a| (o.bbox_min[a] + o.bbox_max[a]) / 2.0);
            let extent = std::array::from_fn(|a| o.bbox_max[a] - o.bbox_min[a]);
            let caption = match &colour {
                Some(c) => format!("a {c} {}", o.class),
                None => format!("a {}", o.class),
            };
            let rests_on = match supports.get(&o.instance_id) {
                Some(Support::Floor) => Some("floor".to_string()),
                Some(Support::Object(id)) => Some(object_id(*id)),
                Some(Support::Nothing) | None => None,
            };
            SceneObject {
                id: object_id(o.instance_id),
                label: o.class.clone(),
                bbox_center: center,
                bbox_extent: extent,
                points: seen.points,
                colour,
                caption,
                rests_on,
            }
        })
        .collect()
}

/// The scene graph a perfect map builds: every seen object with its class, caption and
/// box (to the millimetre, as a submission would carry it).
pub fn oracle_graph(objects: &[SceneObject]) -> Value {
    let mm = to_millimetre;
    let nodes: Vec<Value> = objects
        .iter()
        .filter(|o| o.seen())
        .map(|o| json!({"id": o.id, "label": o.label, "caption": o.caption, "bbox_center": mm(o.bbox_center), "bbox_extent": mm(o.bbox_extent)}))
        .collect();
    json!({"objects": nodes})
}

/// `v` (metres) rounded to the millimetre, as the oracle's graph carries boxes.
pub(crate) fn to_millimetre(v: [f64; 3]) -> [f64; 3] {
    v.map(|x| (x * 1000.0).round() / 1000.0)
}

/// The id of the object with instance id `instance`.
pub fn object_id(instance: i64) -> String {
    format!("obj_{instance}")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn objects_carry_their_exact_points_albedo_colour_and_support() {
        use crate::convert::habitat::ConvertedObject;
        let o = |id: i64, class: &str| ConvertedObject::spanning(id, class, [0.0, 0.0, 0.0], [1.0, 0.5, 2.0]);
        let report = ConversionReport { objects: vec![o(1, "floor"), o(2, "table"), o(3, "mug"), o(4, "chair")], ..Default::default() };
        let instances = BTreeMap::from([
            (2, InstancePoints { points: 500, albedo: Some([120.0, 80.0, 40.0]) }),
            (3, InstancePoints { points: 12, albedo: Some([200.0, 30.0, 30.0]) }),
            (4, InstancePoints { points: 9, albedo: Some([200.0, 30.0, 30.0]) }),
        ]);
        let supports = BTreeMap::from([(2, Support::Floor), (3, Support::Object(2)), (4, Support::Nothing)]);
        let objects = scene_objects(&report, &instances, &supports);
        assert_eq!(objects.iter().map(|o| o.id.as_str()).collect::<Vec<_>>(), ["obj_2", "obj_3", "obj_4"], "the shell is not an object");
        assert_eq!((objects[0].caption.as_str(), objects[0].rests_on.as_deref()), ("a brown table", Some("floor")));
        assert_eq!((objects[1].colour.as_deref(), objects[1].rests_on.as_deref(), objects[1].seen()), (Some("red"), Some("obj_2"), true));
        assert_eq!((objects[2].colour.as_deref(), objects[2].seen()), (None, false), "unseen objects get no colour");
        assert_eq!((objects[0].bbox_center, objects[0].bbox_extent), ([0.5, 0.25, 1.0], [1.0, 0.5, 2.0]));
    }

    #[test]
    fn colours_are_named_only_when_clear() {
        assert_eq!(colour_name([200.0, 30.0, 30.0]), Some("red"));
        assert_eq!(colour_name([120.0, 80.0, 40.0]), Some("brown"));
        assert_eq!(colour_name([240.0, 240.0, 238.0]), Some("white"));
        assert_eq!(colour_name([20.0, 20.0, 25.0]), Some("black"));
        assert_eq!(colour_name([40.0, 90.0, 200.0]), Some("blue"));
        assert_eq!(colour_name([150.0, 140.0, 125.0]), None, "greyish beige is neither grey nor a hue");
        assert_eq!(colour_name([168.0, 138.0, 102.0]), Some("brown"), "light oak is brown, not orange");
        assert_eq!(colour_name([215.0, 200.0, 170.0]), None, "pale tan (beige) has no name");
        assert_eq!(colour_name([230.0, 120.0, 40.0]), Some("orange"), "a vivid orange is orange");
    }
}
