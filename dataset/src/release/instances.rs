//! Which object instance every ground-truth point lies on. The ground truth holds
//! classes (as OSMa-Bench's does); the release also needs instances, to count what the
//! camera saw of each object exactly and to build the oracle's scene graph from real
//! objects. The frames behind the points are drawn again with instance ids — the same
//! rasteriser, poses and intrinsics give the same pixels, which is checked against the
//! published semantic frames class by class — and a point whose class disagrees (a
//! sequence from an external renderer) is given the object of its class whose box holds
//! it.

use std::collections::BTreeMap;

use osmab_evaluator::formats::sequence::Sequence;
use osmab_evaluator::ground_truth::{GroundTruth, kept_pixels};
use osmab_evaluator::{InputError, Result};
use serde::{Deserialize, Serialize};

use crate::convert::habitat::ConversionReport;
use crate::questions::{InstancePoints, colour_name};
use crate::render::mesh::World;
use crate::render::raster::{Camera, Frame, Shading, render};

/// Instance labels of a ground truth.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct InstanceLabels {
    /// Per instance id, its points and the albedo of its dominant colour.
    pub instances: BTreeMap<i64, InstancePoints>,
    /// Points labelled from the redrawn frames (their class agreed).
    pub drawn: usize,
    /// Points labelled by the boxes of their class.
    pub by_box: usize,
    /// Points no object could be found for (kept with instance 0).
    pub unknown: usize,
    /// Per point, its instance id (0: unknown), in the cloud's order.
    #[serde(skip)]
    pub per_point: Vec<i64>,
}

/// Label the points of `gt` (built from `sequence`) with the instances of `world`.
pub fn label_instances(world: &World, sequence: &Sequence, gt: &GroundTruth, report: &ConversionReport) -> Result<InstanceLabels> {
    let camera = &sequence.camera;
    let mut labels = InstanceLabels { per_point: Vec::with_capacity(gt.points.len()), ..Default::default() };
    let mut albedo: BTreeMap<i64, ColourTally> = BTreeMap::new();
    let mut frame = Frame::default();
    for (index, pixels) in kept_pixels(sequence)? {
        let view = Camera {
            width: camera.image_width,
            height: camera.image_height,
            fx: camera.fx,
            fy: camera.fy,
            cx: camera.cx,
            cy: camera.cy,
            pose: sequence.trajectory.poses[index],
        };
        // Flat shading: the colour drawn is the surface's albedo.
        render(world, &view, &Shading::Flat, &mut frame);
        for &p in &pixels {
            let (p, k) = (p as usize, labels.per_point.len());
            let Some(&class) = gt.labels.get(k) else {
                return Err(InputError::new(&gt.source, "points", "the ground truth has fewer points than its frames keep"));
            };
            let instance = if frame.semantic[p] as i64 == class && frame.instance[p] != 0 {
                labels.drawn += 1;
                albedo.entry(frame.instance[p] as i64).or_default().add([frame.rgb[3 * p], frame.rgb[3 * p + 1], frame.rgb[3 * p + 2]]);
                frame.instance[p] as i64
            } else {
                match box_of(report, class, gt.points[k]) {
                    Some(id) => {
                        labels.by_box += 1;
                        id
                    }
                    None => {
                        labels.unknown += 1;
                        0
                    }
                }
            };
            labels.per_point.push(instance);
        }
    }
    if labels.per_point.len() != gt.points.len() {
        return Err(InputError::new(&gt.source, "points", format!("{} ground-truth points, but the frames keep {}", gt.points.len(), labels.per_point.len())));
    }
    for &id in labels.per_point.iter().filter(|&&id| id != 0) {
        labels.instances.entry(id).or_default().points += 1;
    }
    for (id, tally) in albedo {
        if let Some(entry) = labels.instances.get_mut(&id) {
            entry.albedo = tally.dominant().map(|mean| mean.map(|v| (v * 10.0).round() / 10.0));
        }
    }
    Ok(labels)
}

/// The albedo an object shows, tallied by colour name: what the camera saw of a chair with a
/// white seat and black legs is white, not the grey of their mean.
#[derive(Debug, Default)]
struct ColourTally {
    /// Per colour name (`None`: between names), the sum of its texels and their number.
    by_name: BTreeMap<Option<&'static str>, ([f64; 3], usize)>,
    total: usize,
}

impl ColourTally {
    fn add(&mut self, rgb: [u8; 3]) {
        let rgb = rgb.map(f64::from);
        let entry = self.by_name.entry(colour_name(rgb)).or_insert(([0.0; 3], 0));
        for c in 0..3 {
            entry.0[c] += rgb[c];
        }
        entry.1 += 1;
        self.total += 1;
    }

    /// The mean albedo of the named colour that covers at least half of what was seen;
    /// `None` when no colour does (a two-tone or patterned object has no one colour).
    fn dominant(&self) -> Option<[f64; 3]> {
        let (_, (sum, n)) = self.by_name.iter().filter(|(name, _)| name.is_some()).max_by_key(|(_, (_, n))| *n)?;
        (2 * n >= self.total).then(|| sum.map(|s| s / *n as f64))
    }
}

/// The object of class `class` whose box (with 5 cm to spare) holds `point`.
fn box_of(report: &ConversionReport, class: i64, point: [f32; 3]) -> Option<i64> {
    const MARGIN: f64 = 0.05;
    report
        .objects
        .iter()
        .find(|o| o.class_id == class && (0..3).all(|a| point[a] as f64 >= o.bbox_min[a] - MARGIN && point[a] as f64 <= o.bbox_max[a] + MARGIN))
        .map(|o| o.instance_id)
}
