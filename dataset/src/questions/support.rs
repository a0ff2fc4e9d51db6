//! What each object of a scene physically rests on, from its geometry: the object whose
//! upward-facing surface lies at the object's base height under its footprint (a
//! sofa's seat, a shelf, a table top), or the floor. Questions about support are asked
//! from this, never from the tops of bounding boxes.

use std::collections::BTreeMap;

use crate::convert::habitat::ConversionReport;
use crate::convert::lexicon::is_shell_class;
use crate::render::mesh::World;

/// What an object rests on.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Support {
    Floor,
    /// Another object, by instance id.
    Object(i64),
    /// Nothing found under it (hanging, or floating in a broken scene).
    Nothing,
}

/// A surface counts as under an object's base when within this height of it (metres).
pub const BASE_TOLERANCE: f32 = 0.03;
/// Triangles whose normal is this close to vertical are surfaces to rest on.
const UPWARD: f32 = 0.9;

/// Points of a footprint to test: the centre and four points halfway to its corners.
pub fn footprint_samples(lo: [f64; 3], hi: [f64; 3]) -> [[f32; 2]; 5] {
    let (cx, cz) = ((lo[0] + hi[0]) / 2.0, (lo[2] + hi[2]) / 2.0);
    let (hx, hz) = ((hi[0] - lo[0]) / 4.0, (hi[2] - lo[2]) / 4.0);
    [[cx, cz], [cx - hx, cz - hz], [cx + hx, cz - hz], [cx - hx, cz + hz], [cx + hx, cz + hz]].map(|p| [p[0] as f32, p[1] as f32])
}

/// The height of triangle `p` at (x, z), if (x, z) lies inside its footprint.
fn height_at(p: &[[f32; 3]; 3], x: f32, z: f32) -> Option<f32> {
    let (a, b, c) = (p[0], p[1], p[2]);
    let det = (b[0] - a[0]) * (c[2] - a[2]) - (c[0] - a[0]) * (b[2] - a[2]);
    if det.abs() < 1e-12 {
        return None;
    }
    let u = ((x - a[0]) * (c[2] - a[2]) - (c[0] - a[0]) * (z - a[2])) / det;
    let v = ((b[0] - a[0]) * (z - a[2]) - (x - a[0]) * (b[2] - a[2])) / det;
    (u >= -1e-4 && v >= -1e-4 && u + v <= 1.0 + 1e-4).then(|| a[1] + u * (b[1] - a[1]) + v * (c[1] - a[1]))
}

/// What every object of the scene (not its shell) rests on, by instance id.
pub fn resting_on(world: &World, report: &ConversionReport) -> BTreeMap<i64, Support> {
    let class_of: BTreeMap<i64, &str> = report.objects.iter().map(|o| (o.instance_id, o.class.as_str())).collect();
    // Upward-facing triangles (either winding), by instance.
    let surfaces: Vec<(i64, [[f32; 3]; 3])> = world
        .triangles()
        .iter()
        .filter(|t| {
            let [a, b, c] = t.positions;
            let (u, v) = ([b[0] - a[0], b[1] - a[1], b[2] - a[2]], [c[0] - a[0], c[1] - a[1], c[2] - a[2]]);
            let n = [u[1] * v[2] - u[2] * v[1], u[2] * v[0] - u[0] * v[2], u[0] * v[1] - u[1] * v[0]];
            let len = (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt();
            len > 0.0 && (n[1] / len).abs() >= UPWARD
        })
        .map(|t| (t.instance_id as i64, t.positions))
        .collect();
    let mut out = BTreeMap::new();
    for object in report.objects.iter().filter(|o| !is_shell_class(&o.class)) {
        let base = object.bbox_min[1] as f32;
        let mut votes: BTreeMap<i64, usize> = BTreeMap::new();
        for [x, z] in footprint_samples(object.bbox_min, object.bbox_max) {
            // The highest surface at the base under this point, of another instance.
            let under = surfaces
                .iter()
                .filter(|(id, _)| *id != object.instance_id)
                .filter_map(|(id, p)| height_at(p, x, z).filter(|y| (y - base).abs() <= BASE_TOLERANCE).map(|y| (y, *id)))
                .max_by(|a, b| a.0.total_cmp(&b.0).then(b.1.cmp(&a.1)));
            if let Some((_, id)) = under {
                *votes.entry(id).or_default() += 1;
            }
        }
        let support = match votes.iter().max_by(|a, b| a.1.cmp(b.1).then(b.0.cmp(a.0))) {
            None => Support::Nothing,
            Some((id, _)) if class_of.get(id) == Some(&"floor") => Support::Floor,
            Some((id, _)) => Support::Object(*id),
        };
        out.insert(object.instance_id, support);
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::convert::habitat::ConvertedObject;
    use crate::render::mesh::{Surface, Triangle};

    /// Two triangles making a horizontal rectangle at height `y`, of instance `id`.
    fn rectangle(id: u16, lo: [f32; 2], hi: [f32; 2], y: f32) -> [Triangle; 2] {
        let t = |p: [[f32; 3]; 3]| Triangle { positions: p, normals: [[0.0, 1.0, 0.0]; 3], uvs: [[0.0; 2]; 3], surface: 0, class_id: 0, instance_id: id };
        [
            t([[lo[0], y, lo[1]], [hi[0], y, lo[1]], [hi[0], y, hi[1]]]),
            t([[lo[0], y, lo[1]], [lo[0], y, hi[1]], [hi[0], y, hi[1]]]), // the other winding
        ]
    }

    fn object(id: i64, class: &str, lo: [f64; 3], hi: [f64; 3]) -> ConvertedObject {
        ConvertedObject::spanning(id, class, lo, hi)
    }

    #[test]
    fn objects_rest_on_the_surface_at_their_base_not_on_box_tops() {
        // A sofa whose seat is at 0.45 m and back at 0.9 m; a book on the seat; a mug on a
        // tray on a table; a lamp hanging from nothing.
        let mut triangles = Vec::new();
        triangles.extend(rectangle(1, [-5.0, -5.0], [5.0, 5.0], 0.0)); // floor
        triangles.extend(rectangle(2, [0.0, 0.0], [2.0, 0.7], 0.45)); // sofa seat
        triangles.extend(rectangle(2, [0.0, 0.7], [2.0, 0.9], 0.9)); // sofa back top
        triangles.extend(rectangle(4, [3.0, 0.0], [4.2, 0.8], 0.75)); // table top
        triangles.extend(rectangle(5, [3.2, 0.2], [3.6, 0.5], 0.77)); // tray top
        let world = World::new(triangles, vec![Surface { color: [1.0; 3], texture: None, occlusion_in_alpha: false }]);
        let report = ConversionReport {
            objects: vec![
                object(1, "floor", [-5.0, -0.1, -5.0], [5.0, 0.0, 5.0]),
                object(2, "sofa", [0.0, 0.0, 0.0], [2.0, 0.9, 0.9]),
                object(3, "book", [0.5, 0.45, 0.2], [0.7, 0.49, 0.5]),
                object(4, "table", [3.0, 0.0, 0.0], [4.2, 0.75, 0.8]),
                object(5, "tray", [3.2, 0.75, 0.2], [3.6, 0.77, 0.5]),
                object(6, "mug", [3.35, 0.77, 0.3], [3.45, 0.87, 0.4]),
                object(7, "lamp", [-3.0, 1.5, -3.0], [-2.8, 1.8, -2.8]),
            ],
            ..Default::default()
        };
        let on = resting_on(&world, &report);
        assert_eq!(on[&3], Support::Object(2), "the book rests on the sofa's seat, far below its box top");
        assert_eq!(on[&2], Support::Floor);
        assert_eq!(on[&4], Support::Floor);
        assert_eq!(on[&5], Support::Object(4));
        assert_eq!(on[&6], Support::Object(5), "the mug rests on the tray, not the table under it");
        assert_eq!(on[&7], Support::Nothing);
        assert!(!on.contains_key(&1), "the shell rests on nothing we ask about");
    }
}
