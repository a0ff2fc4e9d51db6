//! Whether a finished layout satisfies each relation of its spec, checked on the
//! geometry (footprints, heights, fronts), so a scene never silently disagrees with
//! its prompt.

use super::layout::{Layout, PlacedObject};
use crate::spec::{Relation, RelationKind, SceneSpec};

fn center(o: &PlacedObject) -> [f64; 2] {
    [o.position[0], o.position[1]]
}

/// The gap between two footprints (0 when they touch or overlap).
fn gap(a: &PlacedObject, b: &PlacedObject) -> f64 {
    let ((alo, ahi), (blo, bhi)) = (a.footprint(), b.footprint());
    let dx = (blo[0] - ahi[0]).max(alo[0] - bhi[0]).max(0.0);
    let dy = (blo[1] - ahi[1]).max(alo[1] - bhi[1]).max(0.0);
    (dx * dx + dy * dy).sqrt()
}

fn contains(outer: &PlacedObject, p: [f64; 2]) -> bool {
    let (lo, hi) = outer.footprint();
    p[0] >= lo[0] - 1e-6 && p[0] <= hi[0] + 1e-6 && p[1] >= lo[1] - 1e-6 && p[1] <= hi[1] + 1e-6
}

fn wall_distances(o: &PlacedObject, room: [f64; 2]) -> [f64; 4] {
    let (lo, hi) = o.footprint();
    [lo[0] + room[0] / 2.0, room[0] / 2.0 - hi[0], lo[1] + room[1] / 2.0, room[1] / 2.0 - hi[1]]
}

/// Whether `s` stands in relation `kind` to `targets` (one object each; two for
/// between) in a room of `room` = [width, depth].
pub fn holds(kind: RelationKind, s: &PlacedObject, targets: &[&PlacedObject], room: [f64; 2]) -> bool {
    let sc = center(s);
    match (kind, targets) {
        (RelationKind::CenterOfRoom, _) => sc[0].abs() <= room[0] / 4.0 && sc[1].abs() <= room[1] / 4.0,
        (RelationKind::AgainstWall | RelationKind::AlongWall, _) => wall_distances(s, room).iter().any(|&d| d <= 0.25),
        (RelationKind::InCorner, _) => {
            let d = wall_distances(s, room);
            (d[0] <= 0.4 || d[1] <= 0.4) && (d[2] <= 0.4 || d[3] <= 0.4)
        }
        (RelationKind::On, [t]) => {
            s.host.as_deref() == Some(t.object_id.as_str())
                && s.position[2] > 0.01
                && t.asset.supports.iter().any(|x| (!x.inside || x.open) && (x.height - s.position[2]).abs() < 1e-6)
        }
        (RelationKind::Inside, [t]) => {
            s.host.as_deref() == Some(t.object_id.as_str()) && t.asset.supports.iter().any(|x| x.inside && (x.height - s.position[2]).abs() < 1e-6)
        }
        (RelationKind::Under, [t]) => s.position[2] == 0.0 && contains(t, sc),
        (RelationKind::NextTo | RelationKind::Around, [t]) => gap(s, t) <= 0.5,
        (RelationKind::Near, [t]) => gap(s, t) <= 1.2,
        (RelationKind::Behind | RelationKind::InFrontOf, [t]) => {
            let (tc, f) = (center(t), t.front());
            let along = (sc[0] - tc[0]) * f[0] + (sc[1] - tc[1]) * f[1];
            let side = if kind == RelationKind::Behind { -along } else { along };
            side > 0.1 && gap(s, t) <= 1.5
        }
        (RelationKind::Facing, [t]) => {
            let (tc, f) = (center(t), s.front());
            let d = [tc[0] - sc[0], tc[1] - sc[1]];
            let n = (d[0] * d[0] + d[1] * d[1]).sqrt();
            n > 0.0 && (f[0] * d[0] + f[1] * d[1]) / n > 0.5
        }
        (RelationKind::Opposite, [t]) => {
            let tc = center(t);
            sc[0] * tc[0] + sc[1] * tc[1] < 0.0
        }
        (RelationKind::ParallelTo, [t]) => ((s.yaw_deg - t.yaw_deg) / 180.0).fract().abs() < 1e-6,
        (RelationKind::Between, [a, b]) => {
            let (p, q) = (center(a), center(b));
            let d = [q[0] - p[0], q[1] - p[1]];
            let len2 = d[0] * d[0] + d[1] * d[1];
            if len2 == 0.0 {
                return false;
            }
            let t = ((sc[0] - p[0]) * d[0] + (sc[1] - p[1]) * d[1]) / len2;
            let closest = [p[0] + t * d[0], p[1] + t * d[1]];
            (0.0..=1.0).contains(&t) && ((sc[0] - closest[0]).powi(2) + (sc[1] - closest[1]).powi(2)).sqrt() <= 0.8
        }
        _ => false,
    }
}

/// Whether `s` satisfies `r` with some of `objects` as targets (true when a target
/// category has no object yet, so a placer can ask before everything is placed).
pub fn satisfied_by(r: &Relation, s: &PlacedObject, objects: &[PlacedObject], room: [f64; 2], require_targets: bool) -> bool {
    let target_sets: Vec<Vec<&PlacedObject>> =
        r.targets.iter().map(|t| objects.iter().filter(|o| &o.category == t && o.object_id != s.object_id).collect()).collect();
    if target_sets.iter().any(Vec::is_empty) {
        return !require_targets;
    }
    match target_sets.as_slice() {
        [] => holds(r.kind, s, &[], room),
        [one] => one.iter().any(|t| holds(r.kind, s, &[t], room)),
        [a, b] => a.iter().any(|x| b.iter().any(|y| x.object_id != y.object_id && holds(r.kind, s, &[x, y], room))),
        _ => false,
    }
}

/// Every relation of `spec` that `layout` does not satisfy: each subject object must
/// satisfy it with some target object.
pub fn unmet_relations(spec: &SceneSpec, layout: &Layout) -> Vec<String> {
    let room = [layout.width, layout.depth];
    let of = |category: &str| layout.objects.iter().filter(|o| o.category == category).collect::<Vec<_>>();
    let describe = |r: &Relation| {
        let targets = if r.targets.is_empty() { String::new() } else { format!(" {}", r.targets.join(" and ")) };
        format!("{} {}{}", r.subject, r.kind.phrase(), targets)
    };
    let mut unmet = Vec::new();
    for r in &spec.relations {
        let subjects = of(&r.subject);
        let ok = !subjects.is_empty() && subjects.iter().all(|s| satisfied_by(r, s, &layout.objects, room, true));
        if !ok {
            unmet.push(describe(r));
        }
    }
    unmet
}
