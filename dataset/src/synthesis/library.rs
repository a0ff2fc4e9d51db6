//! Procedural assets: every furniture and manipuland category as a recognisable shape
//! assembled from boxes and cylinders, each part with its own material, in the
//! SceneSmith object frame (Drake axes: up +Z, front +Y; bottom at z = 0, centred in
//! x and y). Sizes vary with the seed within each class's plausible range of the class
//! table (`dataset/classes.toml`); the main material takes a finish of the class's palette.
//!
//! One file, over 400 lines, on purpose: it is a catalogue, one short builder per category,
//! read like a table.

use std::path::PathBuf;

use osmab_evaluator::synthetic::Rng;

use super::finishes::{Look, finish_drawn};
use crate::classes;

/// A material: a name and a base colour.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Material {
    pub name: &'static str,
    pub color: [f32; 4],
}

pub const WOOD: Material = Material { name: "wood", color: [0.55, 0.38, 0.22, 1.0] };
pub const DARK_WOOD: Material = Material { name: "dark_wood", color: [0.33, 0.22, 0.14, 1.0] };
pub const FABRIC: Material = Material { name: "fabric", color: [0.36, 0.45, 0.58, 1.0] };
pub const CUSHION: Material = Material { name: "cushion", color: [0.78, 0.74, 0.66, 1.0] };
pub const METAL: Material = Material { name: "metal", color: [0.62, 0.64, 0.67, 1.0] };
pub const BLACK: Material = Material { name: "black_plastic", color: [0.08, 0.08, 0.09, 1.0] };
pub const WHITE: Material = Material { name: "white_paint", color: [0.92, 0.92, 0.90, 1.0] };
pub const CERAMIC: Material = Material { name: "ceramic", color: [0.95, 0.95, 0.97, 1.0] };
pub const RED: Material = Material { name: "red", color: [0.72, 0.16, 0.14, 1.0] };
pub const GREEN_GLASS: Material = Material { name: "green_glass", color: [0.20, 0.52, 0.30, 1.0] };
pub const CARDBOARD: Material = Material { name: "cardboard", color: [0.70, 0.55, 0.36, 1.0] };
pub const PAPER: Material = Material { name: "paper", color: [0.96, 0.94, 0.86, 1.0] };
pub const STONE: Material = Material { name: "stone", color: [0.80, 0.79, 0.76, 1.0] };
pub const SCREEN: Material = Material { name: "screen", color: [0.05, 0.06, 0.08, 1.0] };
pub const SHADE: Material = Material { name: "shade", color: [0.92, 0.88, 0.78, 1.0] };
pub const LEAVES: Material = Material { name: "leaves", color: [0.22, 0.36, 0.20, 1.0] };
pub const DOOR_LEAF: Material = Material { name: "door_leaf", color: [0.86, 0.85, 0.82, 1.0] };
pub const DAYLIGHT: Material = Material { name: "daylight", color: [0.82, 0.87, 0.92, 1.0] };
pub const CANVAS: Material = Material { name: "canvas", color: [0.55, 0.60, 0.66, 1.0] };

/// A pack mesh an asset is drawn with.
#[derive(Debug, Clone, PartialEq)]
pub struct PackMesh {
    /// The mesh file (glTF/GLB) in the pack.
    pub file: PathBuf,
    /// The uniform scale from the pack's size to the instance's.
    pub scale: f64,
    /// How its texture is drawn: its own colours, its main material in a finish, or toned.
    pub look: Look,
    /// Where the geometry comes from ("infinigen", "scan", …) and what made it.
    pub source: String,
    pub generator: String,
}

/// A shape of an asset.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Shape {
    /// A box: centre and size.
    Box { center: [f64; 3], size: [f64; 3] },
    /// A vertical cylinder: centre of its base, radius, height.
    Cylinder { base: [f64; 3], radius: f64, height: f64 },
}

/// A coloured part.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Part {
    pub shape: Shape,
    pub material: Material,
}

/// A surface other objects can rest on: height and x/y extent, in the object frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SupportSurface {
    pub height: f64,
    pub min: [f64; 2],
    pub max: [f64; 2],
    /// Whether it is inside the object (a shelf in a cabinet) rather than on top.
    pub inside: bool,
    /// Whether it can be seen and reached from outside: the top of anything, the shelves
    /// of open-fronted shelving; not the shelves behind a cabinet's doors.
    pub open: bool,
    /// Free height above the surface (unbounded on top of an object).
    pub clear_height: f64,
}

/// An asset: procedural parts, or a pack mesh ([`super::source`]).
#[derive(Debug, Clone, PartialEq)]
pub struct Asset {
    pub category: String,
    pub parts: Vec<Part>,
    /// Width (x), depth (y), height (z).
    pub size: [f64; 3],
    pub supports: Vec<SupportSurface>,
    /// Free height under the object (tables, desks, benches on legs): things can go under it.
    pub clearance: f64,
    /// The floor area under the object that is free up to `clearance` (x/y min, max).
    pub under: Option<([f64; 2], [f64; 2])>,
    pub description: String,
    /// The pack mesh it is drawn with (then `parts` is empty).
    pub mesh: Option<PackMesh>,
}

impl Asset {
    /// The asset scaled uniformly by `f`: its parts or mesh, size, surfaces and free floor.
    pub fn scaled(mut self, f: f64) -> Asset {
        for part in &mut self.parts {
            part.shape = match part.shape {
                Shape::Box { center, size } => Shape::Box { center: center.map(|v| v * f), size: size.map(|v| v * f) },
                Shape::Cylinder { base, radius, height } => Shape::Cylinder { base: base.map(|v| v * f), radius: radius * f, height: height * f },
            };
        }
        self.size = self.size.map(|v| v * f);
        for s in &mut self.supports {
            s.height *= f;
            s.min = s.min.map(|v| v * f);
            s.max = s.max.map(|v| v * f);
            s.clear_height *= f;
        }
        self.clearance *= f;
        self.under = self.under.map(|(lo, hi)| (lo.map(|v| v * f), hi.map(|v| v * f)));
        if let Some(mesh) = &mut self.mesh {
            mesh.scale *= f;
        }
        self
    }
}

fn bx(center: [f64; 3], size: [f64; 3], material: Material) -> Part {
    Part { shape: Shape::Box { center, size }, material }
}

fn cyl(base: [f64; 3], radius: f64, height: f64, material: Material) -> Part {
    Part { shape: Shape::Cylinder { base, radius, height }, material }
}

fn vary(rng: &mut Rng, lo: f64, hi: f64) -> f64 {
    ((lo + (hi - lo) * rng.unit()) * 1000.0).round() / 1000.0
}

/// Four legs at the corners of a w × d footprint.
fn legs(w: f64, d: f64, h: f64, t: f64, material: Material) -> Vec<Part> {
    let (x, y) = (w / 2.0 - t, d / 2.0 - t);
    [(-x, -y), (x, -y), (-x, y), (x, y)].iter().map(|&(px, py)| bx([px, py, h / 2.0], [t, t, h], material)).collect()
}

/// A table-like object: top slab on four legs.
fn table(category: &str, w: f64, d: f64, h: f64, top: Material, leg: Material) -> Asset {
    let t = 0.04;
    let mut parts = vec![bx([0.0, 0.0, h - t / 2.0], [w, d, t], top)];
    parts.extend(legs(w, d, h - t, 0.05, leg));
    Asset {
        category: category.into(),
        parts,
        size: [w, d, h],
        supports: vec![SupportSurface {
            height: h,
            min: [-w / 2.0 + 0.05, -d / 2.0 + 0.05],
            max: [w / 2.0 - 0.05, d / 2.0 - 0.05],
            inside: false,
            open: true,
            clear_height: f64::INFINITY,
        }],
        clearance: h - t - 0.02,
        under: Some(([-w / 2.0 + 0.08, -d / 2.0 + 0.08], [w / 2.0 - 0.08, d / 2.0 - 0.08])),
        description: format!("A {category} with a flat top on four legs."),
        mesh: None,
    }
}

/// A box-bodied cabinet with `shelves` internal levels and door panels on its front.
fn cabinet(category: &str, w: f64, d: f64, h: f64, body: Material, handle: Material, shelves: usize, open_front: bool) -> Asset {
    let t = 0.02;
    let mut parts = vec![
        bx([-(w - t) / 2.0, 0.0, h / 2.0], [t, d, h], body),
        bx([(w - t) / 2.0, 0.0, h / 2.0], [t, d, h], body),
        bx([0.0, (d - t) / 2.0, h / 2.0], [w, t, h], body),
        bx([0.0, 0.0, h - t / 2.0], [w, d, t], body),
        bx([0.0, 0.0, 0.05], [w, d, 0.1], body),
    ];
    let mut supports = vec![SupportSurface {
        height: h,
        min: [-w / 2.0 + 0.03, -d / 2.0 + 0.03],
        max: [w / 2.0 - 0.03, d / 2.0 - 0.03],
        inside: false,
        open: true,
        clear_height: f64::INFINITY,
    }];
    // Levels: the bottom panel (top at 0.1), each shelf, and the underside of the top panel.
    let spacing = (h - 0.12) / (shelves + 1) as f64;
    for s in 1..=shelves {
        let z = 0.1 + spacing * s as f64;
        parts.push(bx([0.0, 0.0, z], [w - 2.0 * t, d - t, t], body));
        supports.push(SupportSurface {
            height: z + t / 2.0,
            min: [-w / 2.0 + 0.05, -d / 2.0 + 0.05],
            max: [w / 2.0 - 0.05, d / 2.0 - 0.06],
            inside: true,
            open: open_front,
            clear_height: spacing - t - 0.01,
        });
    }
    supports.push(SupportSurface {
        height: 0.1,
        min: [-w / 2.0 + 0.05, -d / 2.0 + 0.05],
        max: [w / 2.0 - 0.05, d / 2.0 - 0.06],
        inside: true,
        open: open_front,
        clear_height: spacing - t / 2.0 - 0.01,
    });
    if !open_front {
        // Two doors on the front (−y face) with handles.
        for side in [-1.0, 1.0] {
            parts.push(bx([side * w / 4.0, -d / 2.0 + t / 2.0, h / 2.0 + 0.05], [w / 2.0 - 0.01, t, h - 0.12], body));
            parts.push(bx([side * 0.04, -d / 2.0 - 0.01, h / 2.0 + 0.05], [0.02, 0.02, 0.12], handle));
        }
    }
    Asset {
        category: category.into(),
        parts,
        size: [w, d, h],
        supports,
        clearance: 0.0,
        under: None,
        description: format!("A {category} with {shelves} shelves."),
        mesh: None,
    }
}

/// A chair of `size`: seat on four legs, backrest at the back (+y).
fn chair(category: &str, [w, d, h]: [f64; 3], seat: Material, frame: Material) -> Asset {
    let seat_h = 0.46;
    let mut parts = vec![bx([0.0, 0.0, seat_h - 0.03], [w, d, 0.06], seat), bx([0.0, d / 2.0 - 0.03, (seat_h + h) / 2.0], [w, 0.05, h - seat_h], frame)];
    parts.extend(legs(w, d, seat_h - 0.06, 0.04, frame));
    Asset {
        category: category.into(),
        parts,
        size: [w, d, h],
        supports: vec![],
        clearance: 0.0,
        under: None,
        description: format!("A {category} with a backrest."),
        mesh: None,
    }
}

/// A sofa or armchair: base, back cushion and two arms.
fn sofa(category: &str, [w, d, h]: [f64; 3], fabric: Material, cushion: Material) -> Asset {
    let parts = vec![
        bx([0.0, 0.0, 0.2], [w, d, 0.4], fabric),
        bx([0.0, -0.05, 0.45], [w - 0.3, d - 0.25, 0.1], cushion),
        bx([0.0, d / 2.0 - 0.1, (0.4 + h) / 2.0], [w, 0.2, h - 0.4], fabric),
        bx([-(w - 0.15) / 2.0, 0.0, 0.5], [0.15, d, 0.2], fabric),
        bx([(w - 0.15) / 2.0, 0.0, 0.5], [0.15, d, 0.2], fabric),
    ];
    Asset {
        category: category.into(),
        parts,
        size: [w, d, h],
        supports: vec![SupportSurface {
            height: 0.5,
            min: [-(w - 0.3) / 2.0, -d / 2.0 + 0.05],
            max: [(w - 0.3) / 2.0, d / 2.0 - 0.2],
            inside: false,
            open: true,
            clear_height: f64::INFINITY,
        }],
        clearance: 0.0,
        under: None,
        description: format!("An upholstered {category} with arms."),
        mesh: None,
    }
}

/// Make the asset of `category`, sized by `rng` within the class table's range, its main
/// material a finish of the class's palette drawn from the state of `rng`
/// ([`finish_drawn`]), facing +y (SceneSmith's front).
pub fn make_asset(category: &str, rng: &mut Rng) -> Option<Asset> {
    let asset = build(category, rng)?;
    Some(face_plus_y(match finish_drawn(category, rng) {
        Some(finish) => with_finish(asset, Material { name: finish.name.as_str(), color: [finish.colour[0], finish.colour[1], finish.colour[2], 1.0] }),
        None => asset,
    }))
}

/// Width, depth and height of a new `category`, drawn within the class table's range.
fn drawn_size(category: &str, rng: &mut Rng) -> [f64; 3] {
    let range = classes::table().class(category).and_then(|c| c.size).unwrap_or([[0.3, 0.3], [0.3, 0.3], [0.3, 0.3]]);
    range.map(|[lo, hi]| vary(rng, lo, hi))
}

/// The surface area of a part (a box's six faces, a cylinder's side and caps).
fn area(shape: &Shape) -> f64 {
    match *shape {
        Shape::Box { size: [x, y, z], .. } => 2.0 * (x * y + y * z + x * z),
        Shape::Cylinder { radius, height, .. } => std::f64::consts::TAU * radius * (radius + height),
    }
}

/// `asset` with its main material (the one covering most of its surface) replaced by `finish`.
fn with_finish(mut asset: Asset, finish: Material) -> Asset {
    let mut by_material: Vec<(&'static str, f64)> = Vec::new();
    for part in &asset.parts {
        match by_material.iter_mut().find(|(name, _)| *name == part.material.name) {
            Some((_, total)) => *total += area(&part.shape),
            None => by_material.push((part.material.name, area(&part.shape))),
        }
    }
    let main = by_material.iter().fold(None, |best: Option<(&str, f64)>, &(name, a)| match best {
        Some((_, b)) if b >= a => best,
        _ => Some((name, a)),
    });
    if let Some((main, _)) = main {
        for part in asset.parts.iter_mut().filter(|p| p.material.name == main) {
            part.material = finish;
        }
    }
    asset
}

/// The builders put fronts (doors, seats) at −y; turn the asset half way round.
fn face_plus_y(mut asset: Asset) -> Asset {
    for part in &mut asset.parts {
        match &mut part.shape {
            Shape::Box { center, .. } => (center[0], center[1]) = (-center[0], -center[1]),
            Shape::Cylinder { base, .. } => (base[0], base[1]) = (-base[0], -base[1]),
        }
    }
    for s in &mut asset.supports {
        (s.min, s.max) = ([-s.max[0], -s.max[1]], [-s.min[0], -s.min[1]]);
    }
    if let Some((lo, hi)) = asset.under {
        asset.under = Some(([-hi[0], -hi[1]], [-lo[0], -lo[1]]));
    }
    asset
}

/// A new asset of `category` from the procedural library, if it has one.
fn build(category: &str, rng: &mut Rng) -> Option<Asset> {
    tables_and_desks(category, rng)
        .or_else(|| seats_and_beds(category, rng))
        .or_else(|| storage_furniture(category, rng))
        .or_else(|| manipuland(category, rng))
        .or_else(|| decor(category, rng))
}

/// A table, desk, workbench or counter of `category`.
fn tables_and_desks(category: &str, rng: &mut Rng) -> Option<Asset> {
    if !matches!(
        category,
        "dining table" | "conference table" | "coffee table" | "console table" | "table" | "desk" | "workbench" | "kitchen island" | "counter"
    ) {
        return None;
    }
    let [w, d, h] = drawn_size(category, rng);
    let a = match category {
        "dining table" => table(category, w, d, h, WOOD, WOOD),
        "conference table" => table(category, w, d, h, DARK_WOOD, METAL),
        "coffee table" => table(category, w, d, h, WOOD, DARK_WOOD),
        "console table" => table(category, w, d, h, DARK_WOOD, DARK_WOOD),
        "table" => table(category, w, d, h, WOOD, METAL),
        "desk" => {
            let mut a = table(category, w, d, h, WOOD, WOOD);
            a.parts.push(bx([w / 2.0 - 0.2, 0.0, h / 2.0], [0.38, d - 0.06, h - 0.06], WOOD));
            a.under = Some(([-w / 2.0 + 0.08, -d / 2.0 + 0.08], [w / 2.0 - 0.45, d / 2.0 - 0.08]));
            a.description = format!("A {category} with a drawer unit.");
            a
        }
        "workbench" => table(category, w, d, h, WOOD, METAL),
        _ => {
            let (w, d) = (w - 0.04, d - 0.04);
            let mut a = cabinet(category, w, d, h - 0.04, WHITE, METAL, 1, false);
            a.parts.push(bx([0.0, 0.0, h - 0.02], [w + 0.04, d + 0.04, 0.04], STONE));
            a.size = [w + 0.04, d + 0.04, h];
            a.supports[0] =
                SupportSurface { height: h, min: [-w / 2.0, -d / 2.0], max: [w / 2.0, d / 2.0], inside: false, open: true, clear_height: f64::INFINITY };
            a.description = format!("A {category} with a stone top over cabinets.");
            a
        }
    };
    Some(a)
}

/// A chair, sofa, bench or bed of `category`.
fn seats_and_beds(category: &str, rng: &mut Rng) -> Option<Asset> {
    if !matches!(category, "dining chair" | "chair" | "office chair" | "armchair" | "sofa" | "bench" | "bed") {
        return None;
    }
    let [w, d, h] = drawn_size(category, rng);
    let a = match category {
        "dining chair" | "chair" => chair(category, [w, d, h], WOOD, WOOD),
        "office chair" => Asset {
            category: category.into(),
            parts: vec![
                cyl([0.0, 0.0, 0.0], w / 2.0, 0.06, BLACK),
                cyl([0.0, 0.0, 0.06], 0.03, 0.38, METAL),
                bx([0.0, 0.0, 0.47], [w - 0.05, d - 0.1, 0.08], FABRIC),
                bx([0.0, d / 2.0 - 0.08, (0.51 + h) / 2.0], [w - 0.1, 0.06, h - 0.51], FABRIC),
            ],
            size: [w, d, h],
            supports: vec![],
            clearance: 0.0,
            under: None,
            description: "A swivel office chair on a five-star base.".into(),
            mesh: None,
        },
        "armchair" | "sofa" => sofa(category, [w, d, h], FABRIC, CUSHION),
        "bench" => {
            let mut a = table(category, w, d, h, WOOD, DARK_WOOD);
            a.description = "A wooden bench.".into();
            a
        }
        _ => Asset {
            category: category.into(),
            parts: vec![
                bx([0.0, 0.0, 0.15], [w, d, 0.3], DARK_WOOD),
                bx([0.0, -0.05, 0.4], [w - 0.06, d - 0.12, 0.2], WHITE),
                bx([0.0, d / 2.0 - 0.04, h / 2.0], [w, 0.08, h], DARK_WOOD),
                bx([0.0, d / 2.0 - 0.3, 0.56], [w - 0.3, 0.35, 0.12], CUSHION),
            ],
            size: [w, d, h],
            supports: vec![SupportSurface {
                height: 0.5,
                min: [-w / 2.0 + 0.1, -d / 2.0 + 0.1],
                max: [w / 2.0 - 0.1, d / 2.0 - 0.5],
                inside: false,
                open: true,
                clear_height: f64::INFINITY,
            }],
            clearance: 0.0,
            under: None,
            description: "A bed with a headboard.".into(),
            mesh: None,
        },
    };
    Some(a)
}

/// A cabinet, shelf or other storage furniture of `category`.
fn storage_furniture(category: &str, rng: &mut Rng) -> Option<Asset> {
    let (body, shelves, open) = match category {
        "nightstand" => (WOOD, 1, false),
        "dresser" => (WOOD, 2, false),
        "wardrobe" => (WHITE, 3, false),
        "cabinet" | "sideboard" | "credenza" | "tv stand" => (DARK_WOOD, 1, false),
        "storage cabinet" => (METAL, 1, false),
        "filing cabinet" => (METAL, 2, false),
        "bookshelf" | "shelf" => (WOOD, 4, true),
        "storage rack" => (METAL, 3, true),
        _ => return None,
    };
    let [w, d, h] = drawn_size(category, rng);
    Some(cabinet(category, w, d, h, body, if category == "filing cabinet" { BLACK } else { METAL }, shelves, open))
}

/// A small object of `category` that can be picked up: tableware, books, boxes.
fn manipuland(category: &str, rng: &mut Rng) -> Option<Asset> {
    if !matches!(category, "mug" | "book" | "laptop" | "plate" | "bowl" | "bottle" | "can" | "box" | "bucket") {
        return soft_goods_and_bags(category, rng);
    }
    let [w, d, h] = drawn_size(category, rng);
    let r = w.min(d) / 2.0;
    let a = match category {
        "mug" => small_object(
            category,
            vec![cyl([-0.01, 0.0, 0.0], r * 0.8, h, CERAMIC), bx([w / 2.0 - 0.015, 0.0, h / 2.0], [0.02, 0.012, h * 0.6], CERAMIC)],
            [w, d, h],
            "A ceramic mug with a handle.",
        ),
        "book" => small_object(
            category,
            vec![bx([0.0, 0.0, h / 2.0], [w, d, h], RED), bx([0.005, 0.0, h / 2.0], [w - 0.01, d - 0.01, h - 0.006], PAPER)],
            [w, d, h],
            "A hardcover book.",
        ),
        "laptop" => small_object(
            category,
            vec![bx([0.0, 0.0, 0.01], [w, d, 0.02], METAL), bx([0.0, d / 2.0 - 0.005, h / 2.0 + 0.01], [w, 0.01, h - 0.02], BLACK)],
            [w, d, h],
            "An open laptop.",
        ),
        "plate" => small_object(category, vec![cyl([0.0, 0.0, 0.0], r, h, CERAMIC)], [2.0 * r, 2.0 * r, h], "A round plate."),
        "bowl" => small_object(
            category,
            vec![cyl([0.0, 0.0, 0.0], r * 0.6, h * 0.3, CERAMIC), cyl([0.0, 0.0, h * 0.3], r, h * 0.7, CERAMIC)],
            [2.0 * r, 2.0 * r, h],
            "A ceramic bowl.",
        ),
        "bottle" => small_object(
            category,
            vec![cyl([0.0, 0.0, 0.0], r, h * 0.7, GREEN_GLASS), cyl([0.0, 0.0, h * 0.7], r * 0.4, h * 0.3, GREEN_GLASS)],
            [2.0 * r, 2.0 * r, h],
            "A glass bottle.",
        ),
        "can" => small_object(category, vec![cyl([0.0, 0.0, 0.0], r, h, RED)], [2.0 * r, 2.0 * r, h], "A metal can."),
        "box" => small_object(category, vec![bx([0.0, 0.0, h / 2.0], [w, d, h], CARDBOARD)], [w, d, h], "A cardboard box."),
        _ => small_object(
            category,
            vec![cyl([0.0, 0.0, 0.0], r, h - 0.04, METAL), bx([0.0, 0.0, h - 0.01], [2.0 * r, 0.01, 0.01], BLACK)],
            [2.0 * r, 2.0 * r, h],
            "A metal bucket with a handle.",
        ),
    };
    Some(a)
}

/// Towels, pillows, blankets, bags, helmets and clocks.
fn soft_goods_and_bags(category: &str, rng: &mut Rng) -> Option<Asset> {
    if !matches!(category, "towel" | "pillow" | "blanket" | "backpack" | "suitcase" | "helmet" | "clock") {
        return None;
    }
    let [w, d, h] = drawn_size(category, rng);
    let r = w.min(d) / 2.0;
    let a = match category {
        "towel" => small_object(category, vec![bx([0.0, 0.0, h / 2.0], [w, d, h], WHITE)], [w, d, h], "A folded towel."),
        "pillow" => small_object(category, vec![bx([0.0, 0.0, h / 2.0], [w, d, h], CUSHION)], [w, d, h], "A pillow."),
        "blanket" => small_object(category, vec![bx([0.0, 0.0, h / 2.0], [w, d, h], FABRIC)], [w, d, h], "A folded blanket."),
        "backpack" => small_object(
            category,
            vec![bx([0.0, 0.02, h / 2.0], [w, d - 0.04, h], FABRIC), bx([0.0, -d / 2.0 + 0.02, h * 0.35], [w * 0.8, 0.04, h * 0.45], BLACK)],
            [w, d, h],
            "A backpack with a front pocket.",
        ),
        "suitcase" => small_object(
            category,
            vec![bx([0.0, 0.0, (h - 0.06) / 2.0], [w, d, h - 0.06], BLACK), bx([0.0, 0.0, h - 0.03], [0.15, 0.03, 0.06], METAL)],
            [w, d, h],
            "A hard-shell suitcase.",
        ),
        "helmet" => small_object(
            category,
            vec![cyl([0.0, 0.0, 0.0], r, h * 0.65, RED), cyl([0.0, 0.0, h * 0.65], r * 0.7, h * 0.35, RED)],
            [2.0 * r, 2.0 * r, h],
            "A helmet.",
        ),
        _ => small_object(
            category,
            vec![bx([0.0, 0.0, h / 2.0], [w, d, h], WHITE), bx([0.0, -d / 2.0 - 0.001, h / 2.0], [w * 0.8, 0.002, h * 0.8], PAPER)],
            [w, d + 0.002, h],
            "A desk clock.",
        ),
    };
    Some(a)
}

/// Screens, lamps, plants and the room's dressing: what the pack usually draws, kept here
/// so no class is ever drawn as a stand-in box.
fn decor(category: &str, rng: &mut Rng) -> Option<Asset> {
    if !matches!(category, "monitor" | "television" | "printer" | "lamp" | "plant" | "vase" | "rug" | "picture" | "curtain") {
        return openings(category, rng);
    }
    let [w, d, h] = drawn_size(category, rng);
    let a = match category {
        "monitor" | "television" => small_object(
            category,
            vec![
                bx([0.0, 0.0, 0.01], [w * 0.3, d, 0.02], BLACK),
                bx([0.0, 0.0, 0.08], [0.04, 0.03, 0.14], BLACK),
                bx([0.0, 0.0, h * 0.6], [w, 0.03, h * 0.8], SCREEN),
            ],
            [w, d, h],
            "A flat screen on a stand.",
        ),
        "printer" => small_object(
            category,
            vec![bx([0.0, 0.0, h / 2.0], [w, d, h], WHITE), bx([0.0, -d / 2.0, h * 0.3], [w * 0.6, 0.02, 0.02], BLACK)],
            [w, d + 0.02, h],
            "A desktop printer.",
        ),
        // Round things: as wide as deep, stacked cylinders.
        "lamp" | "plant" | "vase" => {
            let r = w.min(d) / 2.0;
            let (parts, description) = match category {
                "lamp" => (
                    vec![
                        cyl([0.0, 0.0, 0.0], r * 0.6, 0.03, METAL),
                        cyl([0.0, 0.0, 0.03], 0.012, h * 0.7, METAL),
                        cyl([0.0, 0.0, h * 0.72], r, h * 0.28, SHADE),
                    ],
                    "A lamp with a shade.",
                ),
                "plant" => (vec![cyl([0.0, 0.0, 0.0], r * 0.6, h * 0.3, CERAMIC), cyl([0.0, 0.0, h * 0.3], r, h * 0.7, LEAVES)], "A potted plant."),
                _ => (vec![cyl([0.0, 0.0, 0.0], r, h * 0.8, CERAMIC), cyl([0.0, 0.0, h * 0.8], r * 0.6, h * 0.2, CERAMIC)], "A vase."),
            };
            small_object(category, parts, [2.0 * r, 2.0 * r, h], description)
        }
        "rug" => small_object(
            category,
            vec![bx([0.0, 0.0, h / 2.0], [w, d, h], FABRIC), bx([0.0, 0.0, h + 0.0005], [w * 0.8, d * 0.8, 0.001], CUSHION)],
            [w, d, h + 0.001],
            "A rug.",
        ),
        "picture" => small_object(
            category,
            vec![bx([0.0, 0.0, h / 2.0], [w, d, h], DARK_WOOD), bx([0.0, -d / 2.0 - 0.0005, h / 2.0], [w - 0.08, 0.001, h - 0.08], CANVAS)],
            [w, d + 0.001, h],
            "A framed picture.",
        ),
        _ => {
            // Pleats: slim vertical slabs set alternately forward and back.
            let folds = ((w / 0.12).round() as usize).max(3);
            let step = w / folds as f64;
            let parts = (0..folds)
                .map(|k| bx([-w / 2.0 + step * (k as f64 + 0.5), if k % 2 == 0 { -d / 4.0 } else { d / 4.0 }, h / 2.0], [step * 1.05, d / 2.0, h], FABRIC))
                .collect();
            small_object(category, parts, [w, d, h], "A curtain.")
        }
    };
    Some(a)
}

/// A door in its casing, or a window with its sill: the room's openings.
fn openings(category: &str, rng: &mut Rng) -> Option<Asset> {
    if !matches!(category, "door" | "window") {
        return None;
    }
    let [w, d, h] = drawn_size(category, rng);
    let a = match category {
        "door" => {
            // Casing around a leaf with two raised panels and a handle, front at −y.
            let c = 0.06;
            let mut parts = vec![
                bx([-(w - c) / 2.0, 0.0, h / 2.0], [c, d, h], WHITE),
                bx([(w - c) / 2.0, 0.0, h / 2.0], [c, d, h], WHITE),
                bx([0.0, 0.0, h - c / 2.0], [w, d, c], WHITE),
                bx([0.0, 0.005, (h - c) / 2.0], [w - 2.0 * c, d - 0.01, h - c], DOOR_LEAF),
            ];
            let panel_w = w - 2.0 * c - 0.16;
            let lower = (h - c) * 0.45;
            for (z, ph) in [(0.1 + lower / 2.0, lower - 0.1), (lower + 0.1 + (h - c - lower - 0.2) / 2.0, h - c - lower - 0.3)] {
                parts.push(bx([0.0, -d / 2.0, z], [panel_w, 0.012, ph], DOOR_LEAF));
            }
            parts.push(bx([w / 2.0 - c - 0.08, -d / 2.0 - 0.03, 1.0], [0.12, 0.05, 0.025], METAL));
            small_object(category, parts, [w, d + 0.05, h], "A panelled door in its casing.")
        }
        _ => {
            // A frame with a cross of mullions over a bright pane, a sill below, front at −y.
            let f = 0.06;
            let parts = vec![
                bx([0.0, 0.01, h / 2.0], [w - 2.0 * f, 0.01, h - 2.0 * f], DAYLIGHT),
                bx([-(w - f) / 2.0, 0.0, h / 2.0], [f, d, h], WHITE),
                bx([(w - f) / 2.0, 0.0, h / 2.0], [f, d, h], WHITE),
                bx([0.0, 0.0, h - f / 2.0], [w, d, f], WHITE),
                bx([0.0, 0.0, f / 2.0], [w, d, f], WHITE),
                bx([0.0, -0.005, h / 2.0], [0.03, d - 0.01, h - 2.0 * f], WHITE),
                bx([0.0, -0.005, h * 0.6], [w - 2.0 * f, d - 0.01, 0.03], WHITE),
                bx([0.0, -d / 2.0 - 0.03, -0.01], [w + 0.08, 0.08, 0.02], WHITE),
            ];
            small_object(category, parts, [w + 0.08, d + 0.06, h], "A window with a sill.")
        }
    };
    Some(a)
}

/// An object with no support surfaces, nothing under it and no mesh of its own.
fn small_object(category: &str, parts: Vec<Part>, size: [f64; 3], description: &str) -> Asset {
    Asset { category: category.into(), parts, size, supports: vec![], clearance: 0.0, under: None, description: description.into(), mesh: None }
}
