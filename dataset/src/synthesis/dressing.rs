//! Dressing: what a furnished room holds beyond what its prompt names. A door and windows
//! (with curtains) on its walls, a rug, pictures, a plant in a corner, a floor lamp by a
//! seat, lamps, books and small things on tables, desks, counters and shelves — each from
//! the asset pack (or the procedural library), each an object of its own class in the
//! scene's ground truth. Dressing never adds an instance of a class the prompt names, so
//! the prompt's counts stay exact, and it never moves what the prompt placed, so the
//! prompt's relations hold as they did. Everything is drawn from the scene's seed.

use std::collections::BTreeSet;

use osmab_evaluator::synthetic::Rng;

use super::layout::{Layout, PlacedObject};
use super::library::Asset;
use super::placement::{MAX_REST_HEIGHT, overlaps, place, yaw_towards};
use super::source::AssetSource;
use crate::classes::table;
use crate::convert::lexicon::normalise_name;
use crate::spec::{ObjectKind, SceneSpec};

/// Walls are 10 cm thick, centred on the room's edges: their inner faces are this far in.
const WALL_HALF: f64 = 0.05;
/// The floor added furniture keeps clear around it, metres: a walkway, so the room's free
/// floor stays one piece a camera can walk around.
const WALKWAY: f64 = 0.65;

/// The least height of a window set high over furniture, metres.
const MIN_CLERESTORY: f64 = 0.45;

/// A window's sill height, metres.
const SILL: f64 = 0.85;
/// Floor in front of a door kept free to open it.
const DOOR_CLEARANCE: f64 = 0.9;
/// A picture's centre height where nothing stands below it.
const PICTURE_CENTRE: f64 = 1.5;
/// Small things per surface at most.
const PER_SURFACE: usize = 2;

/// What a room of type `room` has on its tables, desks and counters.
fn tabletop_classes(room: &str) -> &'static [&'static str] {
    match room {
        "dining room" => &["vase", "bowl", "plate", "bottle", "plant"],
        "kitchen" => &["bowl", "plate", "mug", "bottle", "vase", "box"],
        "bedroom" => &["lamp", "book", "clock", "vase", "plant"],
        "office" | "study" => &["lamp", "book", "mug", "plant", "clock", "box"],
        "meeting room" | "conference room" => &["bottle", "book", "plant", "mug"],
        "workshop" | "garage" => &["box", "can", "bottle", "bucket"],
        "laundry room" => &["box", "bottle", "towel", "bucket"],
        _ => &["vase", "bowl", "book", "plant", "clock", "lamp"],
    }
}

/// Furniture a room of type `room` commonly has, which the dressing adds against its walls
/// (what the prompt does not name) while its floor is sparsely furnished.
fn room_furniture(room: &str) -> &'static [&'static str] {
    match room {
        "bedroom" => &["dresser", "wardrobe", "nightstand", "armchair", "bookshelf"],
        "living room" => &["bookshelf", "sideboard", "armchair", "tv stand", "console table"],
        "dining room" => &["sideboard", "cabinet", "console table", "bookshelf"],
        "office" | "study" => &["bookshelf", "filing cabinet", "cabinet", "armchair", "shelf"],
        "kitchen" => &["counter", "cabinet", "shelf"],
        "meeting room" | "conference room" => &["credenza", "cabinet", "bookshelf", "console table"],
        "workshop" | "garage" => &["storage rack", "cabinet", "shelf", "workbench"],
        "laundry room" => &["cabinet", "shelf", "storage rack"],
        "reception area" => &["sofa", "armchair", "console table", "bookshelf"],
        _ => &["bookshelf", "cabinet", "sideboard", "armchair"],
    }
}

/// The share of a room's floor its furniture may cover before the dressing adds none, and
/// how many pieces it adds at most (against the barest walls).
const CROWDED_FLOOR: f64 = 0.35;
const MAX_ADDED_FURNITURE: usize = 3;

/// What stands on a room's shelves.
const SHELF_CLASSES: [&str; 4] = ["book", "box", "vase", "plant"];

/// Furniture whose inner shelves are open to the room (not behind a cabinet's doors, where
/// no camera would see what the dressing put there).
const OPEN_SHELVING: [&str; 3] = ["bookshelf", "shelf", "storage rack"];

/// Furniture people sit or lie on: the dressing puts nothing on it.
const SEATS: [&str; 7] = ["bed", "chair", "dining chair", "office chair", "armchair", "sofa", "bench"];

/// Whether `class` is furniture (what small things stand on), not a fixture of the room.
fn is_furniture(class: &str) -> bool {
    table().class(class).is_some_and(|c| c.role == crate::classes::Role::Furniture)
}

/// One of the room's four walls: 0 at −y, 1 at +y, 2 at −x, 3 at +x (as placement numbers
/// them).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
struct Wall(usize);

impl Wall {
    const ALL: [Wall; 4] = [Wall(0), Wall(1), Wall(2), Wall(3)];

    fn inward(self) -> [f64; 2] {
        [[0.0, 1.0], [0.0, -1.0], [1.0, 0.0], [-1.0, 0.0]][self.0]
    }

    /// The usable length of its inner face.
    fn length(self, layout: &Layout) -> f64 {
        (if self.0 < 2 { layout.width } else { layout.depth }) - 2.0 * WALL_HALF
    }

    /// The point `along` its face (from its centre) `out` metres into the room.
    fn point(self, layout: &Layout, along: f64, out: f64) -> [f64; 2] {
        let (hw, hd) = (layout.width / 2.0 - WALL_HALF, layout.depth / 2.0 - WALL_HALF);
        match self.0 {
            0 => [along, -hd + out],
            1 => [along, hd - out],
            2 => [-hw + out, along],
            _ => [hw - out, along],
        }
    }

    /// Where along this wall a point of the room is.
    fn along(self, p: [f64; 2]) -> f64 {
        if self.0 < 2 { p[0] } else { p[1] }
    }

    /// How far from this wall's inner face a footprint's nearest side is.
    fn distance(self, layout: &Layout, (lo, hi): ([f64; 2], [f64; 2])) -> f64 {
        let (hw, hd) = (layout.width / 2.0 - WALL_HALF, layout.depth / 2.0 - WALL_HALF);
        match self.0 {
            0 => lo[1] + hd,
            1 => hd - hi[1],
            2 => lo[0] + hw,
            _ => hw - hi[0],
        }
    }
}

/// A span along a wall taken by something on it or in front of it, and how high it reaches.
#[derive(Debug, Clone, Copy)]
struct Taken {
    wall: Wall,
    lo: f64,
    hi: f64,
    top: f64,
}

/// `spec` placed ([`place`]) and dressed: the room a scene is built from.
pub fn furnished(spec: &SceneSpec, seed: u64, assets: &AssetSource) -> Layout {
    let mut layout = place(spec, seed, assets);
    dress(&mut layout, spec, seed, assets);
    layout
}

/// Dress `layout` (placed from `spec` with `seed`) with what a room of its type has.
pub fn dress(layout: &mut Layout, spec: &SceneSpec, seed: u64, assets: &AssetSource) {
    let named: BTreeSet<&'static str> = spec.objects.iter().filter_map(|o| normalise_name(&o.category)).collect();
    let mut d = Dresser { layout, assets, rng: Rng::new(seed ^ 0xD2E5_5ED), named, room: spec.room.clone(), reserved: Vec::new(), taken: Vec::new() };
    d.note_furniture_by_walls();
    d.door();
    d.furniture();
    d.windows();
    d.pictures();
    d.rug();
    d.floor_plant();
    d.floor_lamp();
    d.tabletops();
    d.shelves();
}

struct Dresser<'a> {
    layout: &'a mut Layout,
    assets: &'a AssetSource,
    rng: Rng,
    /// Classes the prompt names: dressing adds none of them.
    named: BTreeSet<&'static str>,
    room: String,
    /// Floor kept free (in front of the door).
    reserved: Vec<([f64; 2], [f64; 2])>,
    /// Wall spans taken.
    taken: Vec<Taken>,
}

impl Dresser<'_> {
    /// Whether dressing may add an instance of `class`.
    fn may_add(&self, class: &str) -> bool {
        !self.named.contains(class) && table().class(class).is_some()
    }

    /// An asset of `class` whose size `fits`, from a few draws; `None` when none fits.
    fn asset(&mut self, class: &str, fits: impl Fn([f64; 3]) -> bool) -> Option<Asset> {
        (0..8).find_map(|_| {
            let mut draw = Rng::new(self.rng.next_u64());
            self.assets.make(class, &mut draw).filter(|a| fits(a.size))
        })
    }

    fn add(&mut self, class: &str, asset: Asset, position: [f64; 3], yaw_deg: f64, host: Option<String>) {
        // Standing on the floor or hanging on a wall, it is welded like furniture; resting on
        // a host, it is a manipuland.
        let kind = if host.is_none() { ObjectKind::Furniture } else { ObjectKind::Manipuland };
        let object_id = format!("{}_{}", class.replace(' ', "_"), self.layout.objects.len());
        self.layout.objects.push(PlacedObject { object_id, category: class.into(), kind, asset, position, yaw_deg, host, dressing: true });
    }

    /// Spans of walls that furniture stands in front of (within 0.6 m), with its height.
    fn note_furniture_by_walls(&mut self) {
        for o in self.layout.objects.iter().filter(|o| o.kind == ObjectKind::Furniture) {
            let fp = o.footprint();
            for wall in Wall::ALL {
                if wall.distance(self.layout, fp) < 0.6 {
                    let (a, b) = (wall.along(fp.0), wall.along(fp.1));
                    self.taken.push(Taken { wall, lo: a.min(b), hi: a.max(b), top: o.asset.size[2] });
                }
            }
        }
    }

    /// Whether the span `lo..hi` of `wall` is free of what reaches above `below` (and of
    /// anything mounted on the wall), keeping `margin` clear.
    fn wall_free(&self, wall: Wall, lo: f64, hi: f64, below: f64, margin: f64) -> bool {
        let half = wall.length(self.layout) / 2.0;
        lo - margin >= -half
            && hi + margin <= half
            && self.taken.iter().filter(|t| t.wall == wall).all(|t| t.top <= below || t.hi + margin <= lo || hi + margin <= t.lo)
    }

    /// Whether a floor footprint is inside the room, clear of furniture, of the door's
    /// clearance and of floor-standing dressing.
    fn floor_free(&self, fp: ([f64; 2], [f64; 2]), gap: f64) -> bool {
        let (hw, hd) = (self.layout.width / 2.0 - WALL_HALF, self.layout.depth / 2.0 - WALL_HALF);
        let grown = ([fp.0[0] - gap, fp.0[1] - gap], [fp.1[0] + gap, fp.1[1] + gap]);
        fp.0[0] >= -hw
            && fp.1[0] <= hw
            && fp.0[1] >= -hd
            && fp.1[1] <= hd
            && self.layout.objects.iter().filter(|o| o.kind == ObjectKind::Furniture && o.category != "rug").all(|o| !overlaps(grown, o.footprint()))
            && self.reserved.iter().all(|r| !overlaps(fp, *r))
    }

    /// Mount `asset` of `class` on `wall`, centred `along` it with its bottom at `bottom`,
    /// its back against the wall and its front into the room.
    fn mount(&mut self, class: &str, asset: Asset, wall: Wall, along: f64, bottom: f64) {
        let [w, depth, h] = asset.size;
        let p = wall.point(self.layout, along, depth / 2.0 + 0.005);
        self.taken.push(Taken { wall, lo: along - w / 2.0, hi: along + w / 2.0, top: bottom + h });
        self.add(class, asset, [p[0], p[1], bottom], yaw_towards(wall.inward()), None);
    }

    /// A span of `width` on some wall free up to `below` (margin `margin`), tried in a drawn
    /// order of walls and positions.
    fn free_span(&mut self, width: f64, below: f64, margin: f64, walls: &[Wall]) -> Option<(Wall, f64)> {
        let start = self.rng.below(walls.len().max(1));
        for k in 0..walls.len() {
            let wall = walls[(start + k) % walls.len()];
            let half = wall.length(self.layout) / 2.0 - width / 2.0 - margin;
            if half < 0.0 {
                continue;
            }
            for _ in 0..24 {
                let along = self.rng.range(-half, half);
                if self.wall_free(wall, along - width / 2.0, along + width / 2.0, below, margin) {
                    return Some((wall, along));
                }
            }
        }
        None
    }

    /// The door: on a wall with floor free in front of it, kept free.
    fn door(&mut self) {
        let Some(door) = self.asset("door", |_| true) else { return };
        let [w, _, _] = door.size;
        let walls = Wall::ALL;
        let start = self.rng.below(4);
        for k in 0..4 {
            let wall = walls[(start + k) % 4];
            let half = wall.length(self.layout) / 2.0 - w / 2.0 - 0.15;
            if half < 0.0 {
                continue;
            }
            for _ in 0..24 {
                let along = self.rng.range(-half, half);
                let near = wall.point(self.layout, along - w / 2.0 - 0.1, 0.0);
                let far = wall.point(self.layout, along + w / 2.0 + 0.1, DOOR_CLEARANCE);
                let clearance = ([near[0].min(far[0]), near[1].min(far[1])], [near[0].max(far[0]), near[1].max(far[1])]);
                if self.floor_free(clearance, 0.0) && self.wall_free(wall, along - w / 2.0, along + w / 2.0, 0.0, 0.1) {
                    self.reserved.push(clearance);
                    self.mount("door", door, wall, along, 0.0);
                    return;
                }
            }
        }
    }

    /// Furniture the room type commonly has, against the barest walls (where the least
    /// furniture stands), while the room's floor is not crowded.
    fn furniture(&mut self) {
        let mut classes: Vec<&str> = room_furniture(&self.room).iter().copied().filter(|c| self.may_add(c)).collect();
        let floor = (self.layout.width - 2.0 * WALL_HALF) * (self.layout.depth - 2.0 * WALL_HALF);
        for _ in 0..MAX_ADDED_FURNITURE {
            let covered: f64 = self.layout.objects.iter().filter(|o| is_furniture(&o.category)).map(|o| o.asset.size[0] * o.asset.size[1]).sum();
            if classes.is_empty() || covered / floor >= CROWDED_FLOOR {
                return;
            }
            let class = classes.remove(self.rng.below(classes.len()));
            let top = self.layout.wall_height - 0.2;
            let Some(asset) = self.asset(class, |s| s[2] < top) else { continue };
            let mut walls = Wall::ALL.to_vec();
            walls.sort_by(|a, b| self.wall_taken(*a).total_cmp(&self.wall_taken(*b)).then(a.0.cmp(&b.0)));
            for wall in walls {
                if self.against_wall(class, &asset, wall) {
                    break;
                }
            }
        }
    }

    /// The share of `wall`'s length something stands in front of or hangs on.
    fn wall_taken(&self, wall: Wall) -> f64 {
        self.taken.iter().filter(|t| t.wall == wall).map(|t| t.hi - t.lo).sum::<f64>() / wall.length(self.layout)
    }

    /// `asset` of `class` with its back against a free stretch of `wall`, a [`WALKWAY`] from
    /// the floor's other furniture; whether it found one.
    fn against_wall(&mut self, class: &str, asset: &Asset, wall: Wall) -> bool {
        let [w, depth, _] = asset.size;
        let half = wall.length(self.layout) / 2.0 - w / 2.0 - 0.1;
        if half < 0.0 {
            return false;
        }
        for _ in 0..24 {
            let along = self.rng.range(-half, half);
            if !self.wall_free(wall, along - w / 2.0, along + w / 2.0, 0.0, 0.1) {
                continue;
            }
            let p = wall.point(self.layout, along, depth / 2.0 + 0.03);
            let yaw = yaw_towards(wall.inward());
            let quarter = ((yaw / 90.0).round() as i64).rem_euclid(2) == 1;
            let (hx, hy) = if quarter { (depth / 2.0, w / 2.0) } else { (w / 2.0, depth / 2.0) };
            if self.floor_free(([p[0] - hx, p[1] - hy], [p[0] + hx, p[1] + hy]), WALKWAY) {
                self.taken.push(Taken { wall, lo: along - w / 2.0, hi: along + w / 2.0, top: asset.size[2] });
                self.add(class, asset.clone(), [p[0], p[1], 0.0], yaw, None);
                return true;
            }
        }
        false
    }

    /// One or two windows at sill height where nothing in front reaches above the sill,
    /// each with a curtain on either side.
    fn windows(&mut self) {
        let count = if self.layout.width.max(self.layout.depth) > 4.5 { 2 } else { 1 };
        for k in 0..count {
            let top = self.layout.wall_height - 0.2;
            let Some(window) = self.asset("window", |s| s[2] + SILL < top) else { return };
            let curtains = self.may_add("curtain");
            let margin = if curtains { 0.45 } else { 0.15 };
            let w = window.size[0];
            match self.free_span(w, SILL, margin, &Wall::ALL).or_else(|| self.free_span(w, SILL, 0.15, &Wall::ALL)) {
                Some((wall, along)) => {
                    let room_for_curtains = self.wall_free(wall, along - w / 2.0, along + w / 2.0, SILL, 0.45);
                    let top = SILL + window.size[2];
                    self.mount("window", window, wall, along, SILL);
                    if curtains && room_for_curtains {
                        self.curtains(wall, along, w, top);
                    }
                }
                // The first window at least: higher, over whatever stands below it.
                None if k == 0 => self.window_over_furniture(window),
                None => return,
            }
        }
    }

    /// `window` where its sill clears what stands in front of the wall, as low as that
    /// allows; where even the lowest such sill leaves too little wall below the ceiling, a
    /// smaller window (a clerestory at least [`MIN_CLERESTORY`] tall).
    fn window_over_furniture(&mut self, window: Asset) {
        let [w, _, h] = window.size;
        let ceiling = self.layout.wall_height - 0.15;
        // (height it can keep, -sill, wall, along): the tallest window, then the lowest.
        let mut best: Option<(f64, f64, Wall, f64)> = None;
        for wall in Wall::ALL {
            let half = wall.length(self.layout) / 2.0 - w / 2.0 - 0.15;
            for step in 0..=20 {
                let along = if half <= 0.0 { 0.0 } else { -half + 2.0 * half * step as f64 / 20.0 };
                let below = self
                    .taken
                    .iter()
                    .filter(|t| t.wall == wall && t.hi + 0.1 > along - w / 2.0 && along + w / 2.0 + 0.1 > t.lo)
                    .map(|t| t.top)
                    .fold(0.0f64, f64::max);
                let sill = (below + 0.1).max(SILL);
                let kept = (ceiling - sill).min(h);
                if kept >= MIN_CLERESTORY && best.is_none_or(|(k, s, _, _)| (kept, -sill) > (k, s)) {
                    best = Some((kept, -sill, wall, along));
                }
            }
        }
        if let Some((kept, sill, wall, along)) = best {
            self.mount("window", window.scaled(kept / h), wall, along, -sill);
        }
    }

    /// Curtains either side of a window `w` wide centred `along` `wall`, hanging from above
    /// its `top` to just above the floor, in one fabric.
    fn curtains(&mut self, wall: Wall, along: f64, w: f64, top: f64) {
        let height = (top + 0.2).min(self.layout.wall_height - 0.08) - 0.02;
        let mut draw = Rng::new(self.rng.next_u64());
        let Some(proto) = self.assets.make("curtain", &mut draw) else { return };
        let scale = height / proto.size[2];
        let panel = proto.scaled(scale);
        let pw = panel.size[0];
        for side in [-1.0, 1.0] {
            // Each panel overlaps the window's edge by a sixth of its width.
            let centre = along + side * (w / 2.0 + pw / 2.0 - pw / 6.0);
            let half = wall.length(self.layout) / 2.0;
            if (centre - pw / 2.0) < -half || centre + pw / 2.0 > half {
                continue;
            }
            let p = wall.point(self.layout, centre, panel.size[1] / 2.0 + 0.02);
            self.taken.push(Taken { wall, lo: centre - pw / 2.0, hi: centre + pw / 2.0, top: 0.02 + height });
            self.add("curtain", panel.clone(), [p[0], p[1], 0.02], yaw_towards(wall.inward()), None);
        }
    }

    /// Pictures: above a sofa, bed, sideboard or desk against a wall if there is one, and on
    /// a free stretch of wall.
    fn pictures(&mut self) {
        if !self.may_add("picture") {
            return;
        }
        let wanted = 1 + usize::from(self.rng.unit() < 0.5);
        for _ in 0..wanted {
            let Some(picture) = self.asset("picture", |_| true) else { return };
            let [w, _, h] = picture.size;
            // Over low furniture, or where nothing stands.
            let low = self.taken.iter().filter(|t| t.top <= 1.2 && t.top > 0.3).copied().collect::<Vec<_>>();
            let over = low
                .iter()
                .find(|t| t.hi - t.lo >= w * 0.8 && self.wall_free(t.wall, (t.lo + t.hi) / 2.0 - w / 2.0, (t.lo + t.hi) / 2.0 + w / 2.0, t.top + 0.2, 0.1));
            let (wall, along, bottom) = match over {
                Some(t) => (t.wall, (t.lo + t.hi) / 2.0, (t.top + 0.25).max(PICTURE_CENTRE - h / 2.0)),
                None => match self.free_span(w, 1.0, 0.2, &Wall::ALL) {
                    Some((wall, along)) => (wall, along, PICTURE_CENTRE - h / 2.0),
                    None => return,
                },
            };
            if bottom + h > self.layout.wall_height - 0.15 {
                return;
            }
            self.mount("picture", picture, wall, along, bottom);
        }
    }

    /// A rug under the room's central group (what stands nearest the centre), or in the
    /// middle of its free floor.
    fn rug(&mut self) {
        if !self.may_add("rug") || self.rng.unit() < 0.2 {
            return;
        }
        let Some(rug) = self.asset("rug", |_| true) else { return };
        let (room_w, room_d) = (self.layout.width - 2.0 * WALL_HALF, self.layout.depth - 2.0 * WALL_HALF);
        let centre = self
            .layout
            .objects
            .iter()
            .filter(|o| o.kind == ObjectKind::Furniture && !o.dressing && o.position[0].abs() < room_w / 3.0 && o.position[1].abs() < room_d / 3.0)
            .min_by(|a, b| (a.position[0].hypot(a.position[1])).total_cmp(&b.position[0].hypot(b.position[1])))
            .map_or([0.0, 0.0], |o| [o.position[0], o.position[1]]);
        // At most 60 % of the room either way, turned to the room's long side.
        let long_x = room_w >= room_d;
        let (along_x, along_y) = if long_x { (rug.size[1], rug.size[0]) } else { (rug.size[0], rug.size[1]) };
        let fit = (0.6 * room_w / along_x).min(0.6 * room_d / along_y).min(1.0);
        let rug = rug.scaled(fit);
        let yaw = if long_x { 90.0 } else { 0.0 };
        let (hx, hy) = if long_x { (rug.size[1] / 2.0, rug.size[0] / 2.0) } else { (rug.size[0] / 2.0, rug.size[1] / 2.0) };
        let c = [centre[0].clamp(-room_w / 2.0 + hx + 0.1, room_w / 2.0 - hx - 0.1), centre[1].clamp(-room_d / 2.0 + hy + 0.1, room_d / 2.0 - hy - 0.1)];
        let fp = ([c[0] - hx, c[1] - hy], [c[0] + hx, c[1] + hy]);
        if self.reserved.iter().any(|r| overlaps(fp, *r)) {
            return;
        }
        self.add("rug", rug, [c[0], c[1], 0.0], yaw, None);
    }

    /// A plant in a free corner.
    fn floor_plant(&mut self) {
        if !self.may_add("plant") || self.rng.unit() < 0.3 {
            return;
        }
        let Some(plant) = self.asset("plant", |s| s[2] >= 0.45) else { return };
        let (hw, hd) = (self.layout.width / 2.0 - WALL_HALF, self.layout.depth / 2.0 - WALL_HALF);
        let corners = [[-1.0, -1.0], [1.0, -1.0], [-1.0, 1.0], [1.0, 1.0]];
        let start = self.rng.below(4);
        for k in 0..4 {
            let [sx, sy]: [f64; 2] = corners[(start + k) % 4];
            let (hx, hy) = (plant.size[0] / 2.0 + 0.08, plant.size[1] / 2.0 + 0.08);
            let c = [sx * (hw - hx), sy * (hd - hy)];
            let fp = ([c[0] - plant.size[0] / 2.0, c[1] - plant.size[1] / 2.0], [c[0] + plant.size[0] / 2.0, c[1] + plant.size[1] / 2.0]);
            if self.floor_free(fp, 0.05) {
                self.add("plant", plant, [c[0], c[1], 0.0], 0.0, None);
                return;
            }
        }
    }

    /// A floor lamp beside a sofa, armchair or bed.
    fn floor_lamp(&mut self) {
        if !self.may_add("lamp") || self.rng.unit() < 0.35 {
            return;
        }
        let seats: Vec<PlacedObject> = self.layout.objects.iter().filter(|o| matches!(o.category.as_str(), "sofa" | "armchair" | "bed")).cloned().collect();
        let Some(seat) = seats.first() else { return };
        let Some(lamp) = self.asset("lamp", |s| s[2] >= 1.2) else { return };
        let (lo, hi) = seat.footprint();
        let f = seat.front();
        let side = [f[1], -f[0]];
        let reach = (hi[0] - lo[0]).abs().max(hi[1] - lo[1]) / 2.0 + lamp.size[0] / 2.0 + 0.12;
        for sign in [1.0, -1.0] {
            let c = [seat.position[0] + side[0] * sign * reach - f[0] * 0.15, seat.position[1] + side[1] * sign * reach - f[1] * 0.15];
            let fp = ([c[0] - lamp.size[0] / 2.0, c[1] - lamp.size[1] / 2.0], [c[0] + lamp.size[0] / 2.0, c[1] + lamp.size[1] / 2.0]);
            if self.floor_free(fp, 0.04) {
                self.add("lamp", lamp, [c[0], c[1], 0.0], seat.yaw_deg, None);
                return;
            }
        }
    }

    /// One or two small things on each table, desk, counter and cabinet top (never on a
    /// seat: [`SEATS`]).
    fn tabletops(&mut self) {
        let classes: Vec<&str> = tabletop_classes(&self.room).iter().copied().filter(|c| self.may_add(c)).collect();
        if classes.is_empty() {
            return;
        }
        let hosts: Vec<usize> = (0..self.layout.objects.len())
            .filter(|&i| {
                let o = &self.layout.objects[i];
                is_furniture(&o.category)
                    && !SEATS.contains(&o.category.as_str())
                    && o.asset.supports.iter().any(|s| !s.inside && s.open && (0.35..=MAX_REST_HEIGHT).contains(&s.height))
            })
            .collect();
        for h in hosts {
            if self.rng.unit() < 0.25 {
                continue;
            }
            let n = 1 + self.rng.below(PER_SURFACE);
            for _ in 0..n {
                let class = classes[self.rng.below(classes.len())];
                let Some(item) = self.asset(class, |s| s[2] <= 0.6) else { continue };
                self.put_on(h, class, item, false);
            }
        }
    }

    /// Books, boxes and vases on the open shelves of bookshelves, shelves and racks
    /// ([`OPEN_SHELVING`]).
    fn shelves(&mut self) {
        let classes: Vec<&str> = SHELF_CLASSES.iter().copied().filter(|c| self.may_add(c)).collect();
        if classes.is_empty() {
            return;
        }
        let hosts: Vec<usize> = (0..self.layout.objects.len())
            .filter(|&i| {
                OPEN_SHELVING.contains(&self.layout.objects[i].category.as_str()) && self.layout.objects[i].asset.supports.iter().any(|s| s.inside && s.open)
            })
            .collect();
        for h in hosts {
            let levels = self.layout.objects[h].asset.supports.iter().filter(|s| s.inside && s.open).count();
            for _ in 0..levels.min(6) {
                let class = classes[self.rng.below(classes.len())];
                let Some(item) = self.asset(class, |s| s[2] <= 0.3) else { continue };
                self.put_on(h, class, item, true);
            }
        }
    }

    /// `item` of `class` on a surface of host `h` (an open shelf inside it when `inside`,
    /// else its top), clear of what already rests there.
    fn put_on(&mut self, h: usize, class: &str, item: Asset, inside: bool) {
        let host = self.layout.objects[h].clone();
        let surfaces: Vec<_> =
            host.asset.supports.iter().filter(|s| s.inside == inside && s.open && s.clear_height >= item.size[2] + 0.02 && s.height <= 2.0).copied().collect();
        if surfaces.is_empty() {
            return;
        }
        let s = surfaces[self.rng.below(surfaces.len())];
        let (hw, hd) = (item.size[0] / 2.0, item.size[1] / 2.0);
        if s.max[0] - s.min[0] < 2.0 * hw + 0.04 || s.max[1] - s.min[1] < 2.0 * hd + 0.04 {
            return;
        }
        let a = host.yaw_deg.to_radians();
        let (c, sn) = (a.cos(), a.sin());
        for _ in 0..20 {
            let local = [self.rng.range(s.min[0] + hw + 0.02, s.max[0] - hw - 0.02), self.rng.range(s.min[1] + hd + 0.02, s.max[1] - hd - 0.02)];
            let p = [host.position[0] + c * local[0] - sn * local[1], host.position[1] + sn * local[0] + c * local[1], host.position[2] + s.height];
            let candidate = PlacedObject {
                object_id: String::new(),
                category: class.into(),
                kind: ObjectKind::Manipuland,
                asset: item.clone(),
                position: p,
                yaw_deg: host.yaw_deg,
                host: Some(host.object_id.clone()),
                dressing: true,
            };
            let fp = candidate.footprint();
            let grown = ([fp.0[0] - 0.03, fp.0[1] - 0.03], [fp.1[0] + 0.03, fp.1[1] + 0.03]);
            let clash = self
                .layout
                .objects
                .iter()
                .filter(|o| o.kind == ObjectKind::Manipuland && (o.position[2] - p[2]).abs() < 0.05)
                .any(|o| overlaps(grown, o.footprint()));
            if !clash {
                self.add(class, item, p, host.yaw_deg, Some(host.object_id));
                return;
            }
        }
    }
}
