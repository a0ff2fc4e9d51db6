//! The types a synthesized scene is made of — a room and the objects placed in it — which
//! placement produces and the relation checks, the prompt grammar and the writer read.
//! Which relations a layout leaves unmet is computed once, by
//! [`super::relations::unmet_relations`], against the spec the caller cares about.

use serde::Serialize;

use super::library::Asset;
use crate::spec::ObjectKind;

/// A placed object, in the room frame (Drake axes, z up, floor at z = 0).
#[derive(Debug, Clone)]
pub struct PlacedObject {
    /// `<category_with_underscores>_<n>`, unique in the scene.
    pub object_id: String,
    pub category: String,
    pub kind: ObjectKind,
    pub asset: Asset,
    /// Position of the object frame (bottom centre).
    pub position: [f64; 3],
    /// Rotation about z, a multiple of 90° for furniture.
    pub yaw_deg: f64,
    /// The object it rests on, in or under.
    pub host: Option<String>,
    /// Part of the room's dressing ([`super::dressing`]), not named by the prompt.
    pub dressing: bool,
}

impl PlacedObject {
    /// The footprint in the room: min and max x, y.
    pub fn footprint(&self) -> ([f64; 2], [f64; 2]) {
        let (w, d) = (self.asset.size[0], self.asset.size[1]);
        let quarter = ((self.yaw_deg / 90.0).round() as i64).rem_euclid(2) == 1;
        let (hw, hd) = if quarter { (d / 2.0, w / 2.0) } else { (w / 2.0, d / 2.0) };
        ([self.position[0] - hw, self.position[1] - hd], [self.position[0] + hw, self.position[1] + hd])
    }

    /// Unit vector of the object's front (+y turned by the yaw).
    pub fn front(&self) -> [f64; 2] {
        let a = self.yaw_deg.to_radians();
        [-a.sin(), a.cos()]
    }
}

/// The room and everything in it.
#[derive(Debug, Clone, Serialize)]
pub struct Layout {
    /// Room extent along x and y; walls at ±width/2, ±depth/2.
    pub width: f64,
    pub depth: f64,
    pub wall_height: f64,
    #[serde(skip)]
    pub objects: Vec<PlacedObject>,
    /// What the placement had to improvise (stand-in assets, fallbacks).
    pub notes: Vec<String>,
}
