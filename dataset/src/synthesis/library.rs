//! Procedural assets: every furniture and manipuland category as a recognisable shape
//! assembled from boxes and cylinders, each part with its own material, in the
//! SceneSmith object frame (Drake axes: up +Z, front +Y; bottom at z = 0, centred in
//! x and y). Sizes vary with the seed within each category's plausible range.
//!
//! One file, over 400 lines, on purpose: it is a catalogue, one short builder per category,
//! read like a table.

use std::path::PathBuf;

use osmab_evaluator::synthetic::Rng;

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

/// The finishes an instance's main material is drawn from, one per colour name the
/// questions use: every class draws from the same list with the same odds, so a class
/// says nothing of an instance's colour. Muted, as furniture is painted or upholstered
/// (burgundy, terracotta, mustard, sage, navy, plum, walnut): saturated primaries made
/// rooms look like toys and detectors trained on photographs found fewer objects
/// (docs/performance.md). Each is named by its own name with room to spare (a test).
pub const FINISHES: [Material; 10] = [
    Material { name: "finish_red", color: [0.54, 0.14, 0.12, 1.0] },
    Material { name: "finish_orange", color: [0.82, 0.45, 0.18, 1.0] },
    Material { name: "finish_yellow", color: [0.82, 0.73, 0.26, 1.0] },
    Material { name: "finish_green", color: [0.28, 0.45, 0.26, 1.0] },
    Material { name: "finish_blue", color: [0.17, 0.26, 0.46, 1.0] },
    Material { name: "finish_purple", color: [0.36, 0.22, 0.45, 1.0] },
    Material { name: "finish_white", color: [0.90, 0.89, 0.86, 1.0] },
    Material { name: "finish_black", color: [0.08, 0.08, 0.09, 1.0] },
    Material { name: "finish_grey", color: [0.48, 0.48, 0.49, 1.0] },
    Material { name: "finish_brown", color: [0.42, 0.27, 0.16, 1.0] },
];

/// A pack mesh an asset is drawn with.
#[derive(Debug, Clone, PartialEq)]
pub struct PackMesh {
    /// The mesh file (glTF/GLB) in the pack.
    pub file: PathBuf,
    /// The uniform scale from the pack's size to the instance's.
    pub scale: f64,
    /// The colour its texture is recoloured in; `None` keeps its own colours.
    pub finish: Option<Material>,
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

/// A chair: seat on four legs, backrest at the back (+y).
fn chair(category: &str, rng: &mut Rng, seat: Material, frame: Material) -> Asset {
    let (w, d, h, seat_h) = (vary(rng, 0.42, 0.5), vary(rng, 0.44, 0.52), vary(rng, 0.82, 0.95), 0.46);
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
fn sofa(category: &str, w: f64, d: f64, fabric: Material, cushion: Material) -> Asset {
    let h = 0.85;
    let parts = vec![
        bx([0.0, 0.0, 0.2], [w, d, 0.4], fabric),
        bx([0.0, -0.05, 0.45], [w - 0.3, d - 0.25, 0.1], cushion),
        bx([0.0, d / 2.0 - 0.1, 0.62], [w, 0.2, 0.46], fabric),
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

/// Make the asset of `category`, sized by `rng`, its main material a finish drawn from the
/// state of `rng` (see [`FINISHES`]), facing +y (SceneSmith's front).
pub fn make_asset(category: &str, rng: &mut Rng) -> Option<Asset> {
    let asset = build(category, rng)?;
    Some(face_plus_y(with_finish(asset, finish_drawn(rng))))
}

/// An instance's finish, drawn evenly from [`FINISHES`] off the state of `rng` without
/// advancing it: sizes and layouts stay those of the seed.
pub fn finish_drawn(rng: &Rng) -> Material {
    FINISHES[Rng::new(rng.clone().next_u64() ^ 0xF1_215E).below(FINISHES.len())]
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
    tables_and_desks(category, rng).or_else(|| seats_and_beds(category, rng)).or_else(|| storage_furniture(category, rng)).or_else(|| manipuland(category, rng))
}

/// A table, desk, workbench or counter of `category`.
fn tables_and_desks(category: &str, rng: &mut Rng) -> Option<Asset> {
    let a = match category {
        "dining table" => table(category, vary(rng, 1.4, 2.0), vary(rng, 0.85, 1.0), 0.76, WOOD, WOOD),
        "conference table" => table(category, vary(rng, 2.2, 3.0), vary(rng, 1.0, 1.3), 0.75, DARK_WOOD, METAL),
        "coffee table" => table(category, vary(rng, 0.9, 1.2), vary(rng, 0.5, 0.7), 0.42, WOOD, DARK_WOOD),
        "console table" => table(category, vary(rng, 1.0, 1.4), vary(rng, 0.32, 0.4), 0.8, DARK_WOOD, DARK_WOOD),
        "table" => table(category, vary(rng, 0.9, 1.4), vary(rng, 0.7, 0.9), 0.75, WOOD, METAL),
        "desk" | "reception desk" => {
            let (w, d, h) = (vary(rng, 1.2, 1.6), vary(rng, 0.6, 0.75), 0.75);
            let mut a = table(category, w, d, h, WOOD, WOOD);
            a.parts.push(bx([w / 2.0 - 0.2, 0.0, h / 2.0], [0.38, d - 0.06, h - 0.06], WOOD));
            a.under = Some(([-w / 2.0 + 0.08, -d / 2.0 + 0.08], [w / 2.0 - 0.45, d / 2.0 - 0.08]));
            a.description = format!("A {category} with a drawer unit.");
            a
        }
        "workbench" => table(category, vary(rng, 1.6, 2.2), vary(rng, 0.7, 0.8), 0.9, WOOD, METAL),
        "kitchen island" | "counter" => {
            let (w, d, h) = (vary(rng, 1.5, 2.4), vary(rng, 0.6, if category == "counter" { 0.65 } else { 1.0 }), 0.9);
            let mut a = cabinet(category, w, d, h - 0.04, WHITE, METAL, 1, false);
            a.parts.push(bx([0.0, 0.0, h - 0.02], [w + 0.04, d + 0.04, 0.04], STONE));
            a.size = [w + 0.04, d + 0.04, h];
            a.supports[0] =
                SupportSurface { height: h, min: [-w / 2.0, -d / 2.0], max: [w / 2.0, d / 2.0], inside: false, open: true, clear_height: f64::INFINITY };
            a.description = format!("A {category} with a stone top over cabinets.");
            a
        }
        _ => return None,
    };
    Some(a)
}

/// A chair, sofa, bench or bed of `category`.
fn seats_and_beds(category: &str, rng: &mut Rng) -> Option<Asset> {
    let a = match category {
        "dining chair" | "chair" => chair(category, rng, WOOD, WOOD),
        "office chair" => {
            let (w, h) = (0.55, vary(rng, 0.95, 1.1));
            Asset {
                category: category.into(),
                parts: vec![
                    cyl([0.0, 0.0, 0.0], 0.3, 0.06, BLACK),
                    cyl([0.0, 0.0, 0.06], 0.03, 0.38, METAL),
                    bx([0.0, 0.0, 0.47], [w, 0.5, 0.08], FABRIC),
                    bx([0.0, 0.22, (0.51 + h) / 2.0], [w - 0.05, 0.06, h - 0.51], FABRIC),
                ],
                size: [0.6, 0.6, h],
                supports: vec![],
                clearance: 0.0,
                under: None,
                description: "A swivel office chair on a five-star base.".into(),
                mesh: None,
            }
        }
        "armchair" => sofa(category, vary(rng, 0.8, 0.95), vary(rng, 0.8, 0.9), FABRIC, CUSHION),
        "sofa" => sofa(category, vary(rng, 1.8, 2.3), vary(rng, 0.85, 0.95), FABRIC, CUSHION),
        "bench" => {
            let (w, d, h) = (vary(rng, 1.0, 1.5), vary(rng, 0.35, 0.45), 0.45);
            let mut a = table(category, w, d, h, WOOD, DARK_WOOD);
            a.description = "A wooden bench.".into();
            a
        }
        "bed" => {
            let (w, d) = (vary(rng, 1.4, 1.9), vary(rng, 2.0, 2.15));
            Asset {
                category: category.into(),
                parts: vec![
                    bx([0.0, 0.0, 0.15], [w, d, 0.3], DARK_WOOD),
                    bx([0.0, -0.05, 0.4], [w - 0.06, d - 0.12, 0.2], WHITE),
                    bx([0.0, d / 2.0 - 0.04, 0.55], [w, 0.08, 1.1], DARK_WOOD),
                    bx([0.0, d / 2.0 - 0.3, 0.56], [w - 0.3, 0.35, 0.12], CUSHION),
                ],
                size: [w, d, 1.1],
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
            }
        }
        _ => return None,
    };
    Some(a)
}

/// A cabinet, shelf or other storage furniture of `category`.
fn storage_furniture(category: &str, rng: &mut Rng) -> Option<Asset> {
    let a = match category {
        "nightstand" => cabinet(category, vary(rng, 0.4, 0.5), 0.4, vary(rng, 0.5, 0.6), WOOD, METAL, 1, false),
        "dresser" => cabinet(category, vary(rng, 1.0, 1.4), 0.5, vary(rng, 0.8, 1.0), WOOD, METAL, 2, false),
        "wardrobe" => cabinet(category, vary(rng, 1.0, 1.5), 0.6, vary(rng, 1.9, 2.1), WHITE, METAL, 3, false),
        "cabinet" | "storage cabinet" | "sideboard" | "credenza" | "tv stand" => {
            let (w, h) = match category {
                "sideboard" | "credenza" => (vary(rng, 1.4, 1.9), 0.8),
                "tv stand" => (vary(rng, 1.4, 1.8), 0.5),
                _ => (vary(rng, 0.8, 1.2), vary(rng, 0.9, 1.8)),
            };
            cabinet(category, w, vary(rng, 0.4, 0.5), h, if category == "storage cabinet" { METAL } else { DARK_WOOD }, METAL, 1, false)
        }
        "filing cabinet" => cabinet(category, 0.45, 0.6, vary(rng, 0.7, 1.3), METAL, BLACK, 2, false),
        "bookshelf" | "shelf" => cabinet(category, vary(rng, 0.8, 1.2), 0.35, vary(rng, 1.6, 2.0), WOOD, METAL, 4, true),
        "storage rack" => cabinet(category, vary(rng, 1.0, 1.5), 0.5, vary(rng, 1.7, 2.0), METAL, METAL, 3, true),
        _ => return None,
    };
    Some(a)
}

/// A small object of `category` that can be picked up.
fn manipuland(category: &str, rng: &mut Rng) -> Option<Asset> {
    let a = match category {
        "mug" => small_object(
            category,
            vec![cyl([0.0, 0.0, 0.0], 0.04, 0.1, CERAMIC), bx([0.055, 0.0, 0.05], [0.02, 0.012, 0.06], CERAMIC)],
            [0.12, 0.08, 0.1],
            "A ceramic mug with a handle.",
        ),
        "book" => {
            let (w, d, h) = (vary(rng, 0.15, 0.22), vary(rng, 0.2, 0.28), vary(rng, 0.02, 0.05));
            small_object(
                category,
                vec![bx([0.0, 0.0, h / 2.0], [w, d, h], RED), bx([0.005, 0.0, h / 2.0], [w - 0.01, d - 0.01, h - 0.006], PAPER)],
                [w, d, h],
                "A hardcover book.",
            )
        }
        "laptop" => small_object(
            category,
            vec![bx([0.0, 0.0, 0.01], [0.34, 0.24, 0.02], METAL), bx([0.0, 0.12, 0.13], [0.34, 0.01, 0.22], BLACK)],
            [0.34, 0.25, 0.24],
            "An open laptop.",
        ),
        "plate" => small_object(category, vec![cyl([0.0, 0.0, 0.0], 0.12, 0.02, CERAMIC)], [0.24, 0.24, 0.02], "A round plate."),
        "bowl" => small_object(
            category,
            vec![cyl([0.0, 0.0, 0.0], 0.05, 0.02, CERAMIC), cyl([0.0, 0.0, 0.02], 0.08, 0.05, CERAMIC)],
            [0.16, 0.16, 0.07],
            "A ceramic bowl.",
        ),
        "bottle" => small_object(
            category,
            vec![cyl([0.0, 0.0, 0.0], 0.035, 0.2, GREEN_GLASS), cyl([0.0, 0.0, 0.2], 0.013, 0.08, GREEN_GLASS)],
            [0.07, 0.07, 0.28],
            "A glass bottle.",
        ),
        "can" => small_object(category, vec![cyl([0.0, 0.0, 0.0], 0.033, 0.12, RED)], [0.066, 0.066, 0.12], "A metal can."),
        "box" => {
            let s = [vary(rng, 0.25, 0.45), vary(rng, 0.2, 0.35), vary(rng, 0.15, 0.3)];
            small_object(category, vec![bx([0.0, 0.0, s[2] / 2.0], s, CARDBOARD)], s, "A cardboard box.")
        }
        "bucket" => small_object(
            category,
            vec![cyl([0.0, 0.0, 0.0], 0.14, 0.3, METAL), bx([0.0, 0.0, 0.33], [0.28, 0.01, 0.01], BLACK)],
            [0.28, 0.28, 0.34],
            "A metal bucket with a handle.",
        ),
        "towel" => small_object(category, vec![bx([0.0, 0.0, 0.03], [0.3, 0.2, 0.06], WHITE)], [0.3, 0.2, 0.06], "A folded towel."),
        "pillow" => small_object(category, vec![bx([0.0, 0.0, 0.06], [0.5, 0.35, 0.12], CUSHION)], [0.5, 0.35, 0.12], "A pillow."),
        "blanket" => small_object(category, vec![bx([0.0, 0.0, 0.04], [0.6, 0.4, 0.08], FABRIC)], [0.6, 0.4, 0.08], "A folded blanket."),
        "backpack" => small_object(
            category,
            vec![bx([0.0, 0.0, 0.22], [0.3, 0.18, 0.44], FABRIC), bx([0.0, -0.1, 0.15], [0.24, 0.04, 0.2], BLACK)],
            [0.3, 0.22, 0.44],
            "A backpack with a front pocket.",
        ),
        "suitcase" => small_object(
            category,
            vec![bx([0.0, 0.0, 0.33], [0.42, 0.25, 0.66], BLACK), bx([0.0, 0.0, 0.7], [0.15, 0.03, 0.06], METAL)],
            [0.42, 0.25, 0.72],
            "A hard-shell suitcase.",
        ),
        "helmet" => {
            small_object(category, vec![cyl([0.0, 0.0, 0.0], 0.12, 0.12, RED), cyl([0.0, 0.0, 0.12], 0.08, 0.06, RED)], [0.24, 0.24, 0.18], "A helmet.")
        }
        "clock" => small_object(
            category,
            vec![bx([0.0, 0.0, 0.1], [0.2, 0.06, 0.2], WHITE), bx([0.0, -0.031, 0.1], [0.16, 0.002, 0.16], PAPER)],
            [0.2, 0.06, 0.2],
            "A desk clock.",
        ),
        _ => return None,
    };
    Some(a)
}

/// An object with no support surfaces, nothing under it and no mesh of its own.
fn small_object(category: &str, parts: Vec<Part>, size: [f64; 3], description: &str) -> Asset {
    Asset { category: category.into(), parts, size, supports: vec![], clearance: 0.0, under: None, description: description.into(), mesh: None }
}
