//! Placing a scene spec's objects in a room: furniture on the floor by its relations
//! (centre, walls, corners, around, next to, in front of, behind, facing, opposite,
//! parallel, near, between) without interpenetration, small objects on, inside or
//! under their hosts' support surfaces. Whatever cannot be satisfied is recorded.

use osmab_evaluator::synthetic::Rng;

pub use super::layout::{Layout, PlacedObject};
use super::library::Asset;
use super::source::AssetSource;
use crate::spec::{ObjectKind, RelationKind, SceneSpec};

const GAP: f64 = 0.08;
/// Small objects go on surfaces at most this high, where a robot's camera (about 1 m up)
/// sees them, at about [`REST_HEIGHT`] when the host offers a choice.
pub const MAX_REST_HEIGHT: f64 = 1.25;
const REST_HEIGHT: f64 = 0.75;
const TRIES: usize = 200;

pub(super) fn overlaps(a: ([f64; 2], [f64; 2]), b: ([f64; 2], [f64; 2])) -> bool {
    a.0[0] < b.1[0] - 1e-6 && b.0[0] < a.1[0] - 1e-6 && a.0[1] < b.1[1] - 1e-6 && b.0[1] < a.1[1] - 1e-6
}

/// Yaw (degrees, multiple of 90) whose front points most along `dir`.
pub(super) fn yaw_towards(dir: [f64; 2]) -> f64 {
    let angle = (-dir[0]).atan2(dir[1]).to_degrees();
    (angle / 90.0).round() * 90.0
}

struct Placer<'a> {
    spec: &'a SceneSpec,
    assets: &'a AssetSource,
    rng: Rng,
    width: f64,
    depth: f64,
    placed: Vec<PlacedObject>,
    notes: Vec<String>,
    /// Set when some object found no room: the placement restarts in a larger room.
    crowded: bool,
}

impl Placer<'_> {
    fn inside_room(&self, fp: ([f64; 2], [f64; 2])) -> bool {
        fp.0[0] >= -self.width / 2.0 + 0.06 && fp.1[0] <= self.width / 2.0 - 0.06 && fp.0[1] >= -self.depth / 2.0 + 0.06 && fp.1[1] <= self.depth / 2.0 - 0.06
    }

    fn free(&self, candidate: &PlacedObject) -> bool {
        let fp = candidate.footprint();
        let grown = ([fp.0[0] - GAP, fp.0[1] - GAP], [fp.1[0] + GAP, fp.1[1] + GAP]);
        self.inside_room(fp) && self.placed.iter().filter(|o| o.kind == ObjectKind::Furniture).all(|o| !overlaps(grown, o.footprint()))
    }

    /// Whether `candidate` satisfies every relation of its category after the first.
    fn honours_others(&self, candidate: &PlacedObject) -> bool {
        let room = [self.width, self.depth];
        self.spec
            .relations
            .iter()
            .filter(|r| r.subject == candidate.category)
            .skip(1)
            .all(|r| super::relations::satisfied_by(r, candidate, &self.placed, room, false))
    }

    fn instances(&self, category: &str) -> Vec<usize> {
        self.placed.iter().enumerate().filter(|(_, o)| o.category == category).map(|(i, _)| i).collect()
    }

    /// A candidate pose for instance `k` of `count` under `kind` relative to `targets`.
    fn propose(&mut self, asset: &Asset, kind: RelationKind, targets: &[usize], k: usize, count: usize, attempt: usize) -> ([f64; 2], f64) {
        let (w, d) = (self.width / 2.0, self.depth / 2.0);
        let jitter = (attempt as f64 * 0.07).min(2.5);
        let rand = |rng: &mut Rng, r: f64| rng.range(-r, r);
        match (kind, targets) {
            (RelationKind::CenterOfRoom, _) => ([rand(&mut self.rng, jitter), rand(&mut self.rng, jitter)], 0.0),
            (RelationKind::AgainstWall | RelationKind::AlongWall | RelationKind::InCorner, _) => {
                let wall = (k + attempt + self.rng.below(4)) % 4;
                let along = if kind == RelationKind::InCorner { (if self.rng.unit() < 0.5 { -1.0 } else { 1.0 }) * 10.0 } else { self.rng.range(-1.0, 1.0) };
                let off = asset.size[1] / 2.0 + 0.07;
                let (half_len, inward): (f64, [f64; 2]) = match wall {
                    0 => (w, [0.0, 1.0]),
                    1 => (w, [0.0, -1.0]),
                    2 => (d, [1.0, 0.0]),
                    _ => (d, [-1.0, 0.0]),
                };
                let reach = (half_len - asset.size[0] / 2.0 - 0.07).max(0.0);
                let t = (along * reach).clamp(-reach, reach);
                let pos = match wall {
                    0 => [t, -d + off],
                    1 => [t, d - off],
                    2 => [-w + off, t],
                    _ => [w - off, t],
                };
                (pos, yaw_towards(inward))
            }
            (_, [target, rest @ ..]) => {
                let t = &self.placed[*target];
                let (tc, tf) = ([t.position[0], t.position[1]], t.front());
                let (tfp_lo, tfp_hi) = t.footprint();
                let half = [(tfp_hi[0] - tfp_lo[0]) / 2.0, (tfp_hi[1] - tfp_lo[1]) / 2.0];
                let side = [tf[1], -tf[0]];
                let reach_front = (half[0] * tf[0].abs() + half[1] * tf[1].abs()) + asset.size[1] / 2.0 + 0.1 + jitter * 0.3;
                let reach_side = (half[0] * side[0].abs() + half[1] * side[1].abs()) + asset.size[0] / 2.0 + 0.1 + jitter * 0.3;
                let along = |v: [f64; 2], s: f64| [tc[0] + v[0] * s, tc[1] + v[1] * s];
                let yaw_to_target = |p: [f64; 2]| yaw_towards([tc[0] - p[0], tc[1] - p[1]]);
                match kind {
                    RelationKind::Around => {
                        // Around the target's four sides, in turn.
                        let dirs = [tf, [-tf[0], -tf[1]], side, [-side[0], -side[1]]];
                        let dir = dirs[(k + attempt) % 4];
                        let lateral = [dir[1], -dir[0]];
                        let span = (half[0] * lateral[0].abs() + half[1] * lateral[1].abs()) * 0.8;
                        let per_side = count.div_ceil(4).max(1);
                        let slot = (k / 4) as f64 - (per_side as f64 - 1.0) / 2.0;
                        let offset = if per_side > 1 { slot * (2.0 * span / per_side as f64) } else { 0.0 } + rand(&mut self.rng, jitter * 0.2);
                        let reach = (half[0] * dir[0].abs() + half[1] * dir[1].abs()) + asset.size[1] / 2.0 + 0.05 + jitter * 0.2;
                        let p = [tc[0] + dir[0] * reach + lateral[0] * offset, tc[1] + dir[1] * reach + lateral[1] * offset];
                        (p, yaw_to_target(p))
                    }
                    RelationKind::InFrontOf | RelationKind::Facing => {
                        let extra = if kind == RelationKind::Facing { 0.8 } else { 0.0 };
                        let p = along(tf, reach_front + extra);
                        let p = [
                            p[0] + side[0] * (k as f64 - (count as f64 - 1.0) / 2.0) * (asset.size[0] + 0.1),
                            p[1] + side[1] * (k as f64 - (count as f64 - 1.0) / 2.0) * (asset.size[0] + 0.1),
                        ];
                        (p, yaw_to_target(p))
                    }
                    RelationKind::Behind => (along([-tf[0], -tf[1]], reach_front), t.yaw_deg),
                    RelationKind::NextTo | RelationKind::ParallelTo => {
                        let sign = if (k + attempt) % 2 == 0 { 1.0 } else { -1.0 };
                        let step = reach_side + (k / 2) as f64 * (asset.size[0] + 0.1);
                        (along([side[0] * sign, side[1] * sign], step), t.yaw_deg)
                    }
                    RelationKind::Opposite => {
                        let p = [-tc[0] * 0.9 + rand(&mut self.rng, jitter), -tc[1] * 0.9 + rand(&mut self.rng, jitter)];
                        (p, yaw_to_target(p))
                    }
                    RelationKind::Near => {
                        let a = self.rng.range(0.0, std::f64::consts::TAU);
                        let r = reach_front.max(reach_side) + 0.2 + jitter * 0.3;
                        let p = along([a.cos(), a.sin()], r);
                        (p, yaw_to_target(p))
                    }
                    RelationKind::Between => {
                        let other = rest.first().map_or(tc, |&o| [self.placed[o].position[0], self.placed[o].position[1]]);
                        let p = [(tc[0] + other[0]) / 2.0 + rand(&mut self.rng, jitter * 0.3), (tc[1] + other[1]) / 2.0 + rand(&mut self.rng, jitter * 0.3)];
                        (p, yaw_towards([tc[0] - p[0], tc[1] - p[1]]))
                    }
                    _ => ([rand(&mut self.rng, w), rand(&mut self.rng, d)], 0.0),
                }
            }
            _ => ([rand(&mut self.rng, w), rand(&mut self.rng, d)], 0.0),
        }
    }

    fn place_furniture(&mut self, category: &str, count: u32, asset_seed: &mut Rng) {
        let relation = self.spec.relations.iter().find(|r| r.subject == category).cloned();
        for k in 0..count as usize {
            let asset = self.assets.make(category, asset_seed).unwrap_or_else(|| {
                self.notes.push(format!("no asset for '{category}'; a cabinet stands in"));
                let mut a = self.assets.make("cabinet", asset_seed).expect("cabinets exist");
                a.category = category.into();
                a
            });
            let object_id = format!("{}_{}", category.replace(' ', "_"), self.placed.len());
            let (kind, targets) = match &relation {
                Some(r) => {
                    let targets: Vec<usize> = r.targets.iter().filter_map(|t| self.instances(t).first().copied()).collect();
                    (r.kind, if targets.len() == r.targets.len() { targets } else { vec![] })
                }
                None => (RelationKind::Near, vec![]),
            };
            // The first free pose that also honours the subject's other relations (to
            // objects already placed); else the first free pose.
            let mut chosen = None;
            let mut fallback = None;
            for attempt in 0..TRIES {
                let (p, yaw) = self.propose(&asset, kind, &targets, k, count as usize, attempt);
                let candidate = PlacedObject {
                    object_id: object_id.clone(),
                    category: category.into(),
                    kind: ObjectKind::Furniture,
                    asset: asset.clone(),
                    position: [p[0], p[1], 0.0],
                    yaw_deg: yaw,
                    host: None,
                    dressing: false,
                };
                if self.free(&candidate) {
                    if self.honours_others(&candidate) {
                        chosen = Some(candidate);
                        break;
                    }
                    fallback.get_or_insert(candidate);
                }
            }
            let chosen = chosen.or(fallback);
            let placed = chosen.unwrap_or_else(|| {
                self.notes.push(format!("{object_id}: {} could not be honoured; placed where there was room", kind.phrase()));
                self.anywhere(&object_id, category, &asset)
            });
            self.placed.push(placed);
        }
    }

    /// Any free floor spot (the room grows if there is none).
    fn anywhere(&mut self, object_id: &str, category: &str, asset: &Asset) -> PlacedObject {
        loop {
            for _ in 0..TRIES {
                let p = [self.rng.range(-self.width / 2.0, self.width / 2.0), self.rng.range(-self.depth / 2.0, self.depth / 2.0)];
                let yaw = 90.0 * self.rng.below(4) as f64;
                let c = PlacedObject {
                    object_id: object_id.into(),
                    category: category.into(),
                    kind: ObjectKind::Furniture,
                    asset: asset.clone(),
                    position: [p[0], p[1], 0.0],
                    yaw_deg: yaw,
                    host: None,
                    dressing: false,
                };
                if self.free(&c) {
                    return c;
                }
            }
            // No room at all: grow, and let `place` start over in the bigger room so
            // nothing placed earlier loses its wall.
            self.crowded = true;
            self.width += 0.5;
            self.depth += 0.5;
        }
    }

    fn place_small(&mut self, category: &str, count: u32, asset_seed: &mut Rng) {
        let relation = self
            .spec
            .relations
            .iter()
            .find(|r| r.subject == category && matches!(r.kind, RelationKind::On | RelationKind::Inside | RelationKind::Under))
            .cloned();
        for _ in 0..count {
            let asset = self.assets.make(category, asset_seed).unwrap_or_else(|| {
                self.notes.push(format!("no asset for '{category}'; a box stands in"));
                let mut a = self.assets.make("box", asset_seed).expect("boxes exist");
                a.category = category.into();
                a
            });
            let object_id = format!("{}_{}", category.replace(' ', "_"), self.placed.len());
            let host = relation.as_ref().and_then(|r| r.targets.first()).and_then(|t| self.instances(t).first().copied());
            let kind = relation.as_ref().map_or(RelationKind::On, |r| r.kind);
            let placed = host.and_then(|h| self.on_host(&object_id, category, &asset, h, kind));
            let placed = placed.unwrap_or_else(|| {
                self.notes.push(format!("{object_id}: no room {} its host; placed on the floor", kind.phrase()));
                let mut o = self.anywhere(&object_id, category, &asset);
                o.kind = ObjectKind::Manipuland;
                o
            });
            self.placed.push(placed);
        }
    }

    /// A spot on a support surface of host `h` (or on the floor under it).
    fn on_host(&mut self, object_id: &str, category: &str, asset: &Asset, h: usize, kind: RelationKind) -> Option<PlacedObject> {
        let host = self.placed[h].clone();
        let surfaces: Vec<(f64, [f64; 2], [f64; 2])> = match (kind, host.asset.under) {
            (RelationKind::Under, Some((lo, hi))) if host.asset.clearance > asset.size[2] + 0.02 => vec![(0.0, lo, hi)],
            (RelationKind::Under, _) => return None,
            _ => {
                // Inside: a shelf in it; on: its top, or a shelf of open shelving — only
                // surfaces a camera sees and an arm reaches (open, not too high).
                let fits = |s: &&super::library::SupportSurface| {
                    let relation = if kind == RelationKind::Inside { s.inside } else { !s.inside || s.open };
                    relation && s.open && s.height <= MAX_REST_HEIGHT && s.clear_height >= asset.size[2] + 0.01
                };
                let mut s: Vec<_> = host.asset.supports.iter().filter(fits).map(|s| (s.height, s.min, s.max)).collect();
                s.sort_by(|a, b| (a.0 - REST_HEIGHT).abs().total_cmp(&(b.0 - REST_HEIGHT).abs()).then(a.0.total_cmp(&b.0)));
                s
            }
        };
        let a = host.yaw_deg.to_radians();
        let (c, s) = (a.cos(), a.sin());
        // Aligned with the host, or turned a quarter when only that fits (a book across a
        // shallow shelf).
        let orientations = [(0.0, asset.size[0] / 2.0, asset.size[1] / 2.0), (90.0, asset.size[1] / 2.0, asset.size[0] / 2.0)];
        for (height, lo, hi) in surfaces {
            let Some(&(turn, hw, hd)) = orientations.iter().find(|(_, hw, hd)| hi[0] - lo[0] >= 2.0 * hw && hi[1] - lo[1] >= 2.0 * hd) else {
                continue;
            };
            let mut fallback = None;
            for _ in 0..TRIES {
                let local = [self.rng.range(lo[0] + hw, hi[0] - hw), self.rng.range(lo[1] + hd, hi[1] - hd)];
                let p = [host.position[0] + c * local[0] - s * local[1], host.position[1] + s * local[0] + c * local[1], height];
                let candidate = PlacedObject {
                    object_id: object_id.into(),
                    category: category.into(),
                    kind: ObjectKind::Manipuland,
                    asset: asset.clone(),
                    position: p,
                    yaw_deg: host.yaw_deg + turn,
                    host: Some(host.object_id.clone()),
                    dressing: false,
                };
                let fp = candidate.footprint();
                let clash = self
                    .placed
                    .iter()
                    .filter(|o| o.kind == ObjectKind::Manipuland && (o.position[2] - height).abs() < 0.05)
                    .any(|o| overlaps(fp, o.footprint()));
                if !clash {
                    if self.honours_others(&candidate) {
                        return Some(candidate);
                    }
                    fallback.get_or_insert(candidate);
                }
            }
            if fallback.is_some() {
                return fallback;
            }
        }
        None
    }
}

/// Furniture categories in an order where the targets of a category's relations come
/// before it: first considering all its relations, then only its first (primary) one,
/// then spec order (for cycles).
fn placement_order(spec: &SceneSpec) -> Vec<(String, u32)> {
    let furniture: Vec<(String, u32)> = spec.objects.iter().filter(|o| o.kind == ObjectKind::Furniture).map(|o| (o.category.clone(), o.count)).collect();
    let mut order: Vec<(String, u32)> = Vec::new();
    let mut pending = furniture.clone();
    let placed_before = |order: &[(String, u32)], c: &str, t: &str| t == c || order.iter().any(|(o, _)| o == t) || !furniture.iter().any(|(f, _)| f == t);
    while !pending.is_empty() {
        let all =
            pending.iter().position(|(c, _)| spec.relations.iter().filter(|r| &r.subject == c).flat_map(|r| &r.targets).all(|t| placed_before(&order, c, t)));
        let primary = || {
            pending
                .iter()
                .position(|(c, _)| spec.relations.iter().filter(|r| &r.subject == c).take(1).flat_map(|r| &r.targets).all(|t| placed_before(&order, c, t)))
        };
        let next = all.or_else(primary).unwrap_or(0);
        order.push(pending.remove(next));
    }
    order
}

/// Place `spec` in a room sized for it (starting over in a larger room when it is
/// too crowded): the prompt's objects only ([`super::dressing::furnished`] adds what else
/// the room holds). Which relations the result leaves unmet is for the caller to check
/// ([`super::relations::unmet_relations`]) against the spec it cares about.
pub fn place(spec: &SceneSpec, seed: u64, assets: &AssetSource) -> Layout {
    let sizing_rng = Rng::new(seed ^ 0xA55E_7);
    // The room's floor: its type's plausible size, fitted to its furniture's footprint.
    let footprint: f64 = spec
        .objects
        .iter()
        .filter(|o| o.kind == ObjectKind::Furniture)
        .map(|o| assets.make(&o.category, &mut sizing_rng.clone()).map_or(0.5, |a| a.size[0] * a.size[1]) * o.count as f64)
        .sum();
    let mut rng = Rng::new(seed);
    let (mut width, mut depth) = super::room::fitted_floor(&spec.room, footprint, &mut rng);
    let order = placement_order(spec);
    for attempt in 0.. {
        let mut asset_rng = Rng::new(seed ^ 0xA55E_7);
        let mut placer = Placer { spec, assets, rng: rng.clone(), width, depth, placed: Vec::new(), notes: Vec::new(), crowded: false };
        for (category, count) in &order {
            placer.place_furniture(category, *count, &mut asset_rng);
        }
        if placer.crowded && attempt < 8 {
            width = placer.width;
            depth = placer.depth;
            continue;
        }
        for o in spec.objects.iter().filter(|o| o.kind == ObjectKind::Manipuland) {
            placer.place_small(&o.category, o.count, &mut asset_rng);
        }
        return Layout { width: placer.width, depth: placer.depth, wall_height: 2.5, objects: placer.placed, notes: placer.notes };
    }
    unreachable!("the loop returns")
}
