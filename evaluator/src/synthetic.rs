//! Synthetic scenes of realistic structure for benchmarks and tests: a room of
//! boxes scanned by a pinhole camera (so ground-truth points arrive frame by frame,
//! row by row, as in a real sequence), and a predicted map made of the objects'
//! surfaces with noise, features and some mistakes, as a mapping method would give.

use crate::formats::classes::{ClassEntry, ClassList};
use crate::formats::map::{FeatureMatrix, MapSemantics, PredictedMap, TextFeatures};
use crate::ground_truth::GroundTruth;

/// Class ids of the room's shell.
const FLOOR: i64 = 31;
const WALL: i64 = 32;
const CEILING: i64 = 33;
/// Object classes are 1..=OBJECT_CLASSES.
const OBJECT_CLASSES: i64 = 30;
/// Room size in metres.
const ROOM: [f32; 3] = [10.0, 3.0, 8.0];

/// A small deterministic generator (SplitMix64), so data is identical on every machine.
#[derive(Debug, Clone)]
pub struct Rng(u64);

impl Rng {
    /// A generator from `seed`.
    pub fn new(seed: u64) -> Self {
        Self(seed ^ 0x9E37_79B9_7F4A_7C15)
    }

    /// Next 64 random bits.
    pub fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }

    /// Uniform in [0, 1).
    pub fn unit(&mut self) -> f64 {
        (self.next_u64() >> 11) as f64 / (1u64 << 53) as f64
    }

    /// Uniform in [lo, hi).
    pub fn range(&mut self, lo: f64, hi: f64) -> f64 {
        lo + (hi - lo) * self.unit()
    }

    /// Standard normal (Box–Muller).
    pub fn normal(&mut self) -> f64 {
        let u = self.unit().max(1e-300);
        (-2.0 * u.ln()).sqrt() * (std::f64::consts::TAU * self.unit()).cos()
    }

    /// Uniform index below `n`.
    pub fn below(&mut self, n: usize) -> usize {
        (self.unit() * n as f64) as usize % n.max(1)
    }
}

/// An axis-aligned box standing on the floor (y up): an object of the room.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SyntheticObject {
    pub min: [f32; 3],
    pub max: [f32; 3],
    pub class: i64,
}

type Block = SyntheticObject;

/// Sizes and seed of a synthetic scene.
#[derive(Debug, Clone, Copy)]
pub struct SceneSpec {
    /// Ground-truth points to produce.
    pub gt_points: usize,
    /// Predicted map points to produce.
    pub map_points: usize,
    /// Objects in the room.
    pub objects: usize,
    /// Feature dimension of the map and text features.
    pub feature_dim: usize,
    /// Seed of everything random.
    pub seed: u64,
    /// Whether the map also covers the floor, walls and ceiling (every ground-truth
    /// point then has a predicted point nearby; otherwise, as with many methods,
    /// the room's shell is mostly missing from the map).
    pub map_covers_room: bool,
}

/// A generated scene: ground truth, class list, map and text features.
pub struct SyntheticScene {
    /// The objects standing in the room (boxes with their class).
    pub objects: Vec<SyntheticObject>,
    /// The classes (0 other, objects, floor, wall, ceiling).
    pub classes: ClassList,
    /// The scanned ground truth.
    pub ground_truth: GroundTruth,
    /// The predicted map (objects with features).
    pub map: PredictedMap,
    /// Text features of every class.
    pub text: TextFeatures,
}

/// Generate a scene.
pub fn generate(spec: SceneSpec) -> SyntheticScene {
    let mut rng = Rng::new(spec.seed);
    let blocks = place_blocks(&mut rng, spec.objects);
    let mut entries = vec![ClassEntry { name: "other".into(), id: 0 }];
    entries.extend((1..=OBJECT_CLASSES).map(|id| ClassEntry { name: format!("object_{id}"), id }));
    entries.extend([(FLOOR, "floor"), (WALL, "wall"), (CEILING, "ceiling")].map(|(id, n)| ClassEntry { name: n.into(), id }));
    let classes = ClassList::new(entries).expect("unique synthetic ids");
    let ground_truth = scan(&mut rng, &blocks, spec.gt_points);
    let text = text_features(&mut rng, &classes, spec.feature_dim);
    let map = map_of(&mut rng, &blocks, &text, spec.map_points, spec.map_covers_room);
    SyntheticScene { objects: blocks, classes, ground_truth, map, text }
}

impl SyntheticScene {
    /// Another map of the same room (a method run again, e.g. under another lighting):
    /// `spec`'s map size and coverage, object features near `text`'s (which may be
    /// another scene's, for one embedding over many scenes), drawn from `seed`.
    pub fn another_map(&self, spec: SceneSpec, text: &TextFeatures, seed: u64) -> PredictedMap {
        map_of(&mut Rng::new(seed), &self.objects, text, spec.map_points, spec.map_covers_room)
    }
}

fn place_blocks(rng: &mut Rng, count: usize) -> Vec<Block> {
    let mut blocks = Vec::with_capacity(count);
    while blocks.len() < count {
        let size = [rng.range(0.3, 2.0) as f32, rng.range(0.3, 1.8) as f32, rng.range(0.3, 2.0) as f32];
        let x = rng.range(0.1, (ROOM[0] - size[0]) as f64 - 0.1) as f32;
        let z = rng.range(0.1, (ROOM[2] - size[2]) as f64 - 0.1) as f32;
        let class = 1 + rng.below(OBJECT_CLASSES as usize) as i64;
        blocks.push(Block { min: [x, 0.0, z], max: [x + size[0], size[1], z + size[2]], class });
    }
    blocks
}

/// Distance along `dir` from `origin` to where the ray enters `b`, if it does.
fn ray_box(origin: [f32; 3], dir: [f32; 3], b: &Block) -> Option<f32> {
    let (mut near, mut far) = (0.0f32, f32::INFINITY);
    for a in 0..3 {
        let inv = 1.0 / dir[a];
        let (mut t0, mut t1) = ((b.min[a] - origin[a]) * inv, (b.max[a] - origin[a]) * inv);
        if t0 > t1 {
            std::mem::swap(&mut t0, &mut t1);
        }
        near = near.max(t0);
        far = far.min(t1);
    }
    (near <= far && near > 1e-4).then_some(near)
}

/// Scan the room with a 1200×680 camera, keeping every 10th pixel (as the reference's
/// down-sampling does), until enough points; small scenes keep fewer pixels a frame so
/// that they still see the room from at least 8 viewpoints.
fn scan(rng: &mut Rng, blocks: &[Block], wanted: usize) -> GroundTruth {
    let (w, h, f) = (1200usize, 680usize, 600.0f32);
    let step = 10.max((w * h * 8).div_ceil(wanted.max(1)));
    let mut points = Vec::with_capacity(wanted);
    let mut labels = Vec::with_capacity(wanted);
    while points.len() < wanted {
        let origin = loop {
            let p = [rng.range(0.3, ROOM[0] as f64 - 0.3) as f32, rng.range(1.0, 1.6) as f32, rng.range(0.3, ROOM[2] as f64 - 0.3) as f32];
            if !blocks.iter().any(|b| (0..3).all(|a| p[a] >= b.min[a] && p[a] <= b.max[a])) {
                break p;
            }
        };
        let (yaw, pitch) = (rng.range(0.0, std::f64::consts::TAU) as f32, rng.range(-0.4, 0.1) as f32);
        let forward = [yaw.cos() * pitch.cos(), pitch.sin(), yaw.sin() * pitch.cos()];
        let right = [-yaw.sin(), 0.0, yaw.cos()];
        let up = [right[1] * forward[2] - right[2] * forward[1], right[2] * forward[0] - right[0] * forward[2], right[0] * forward[1] - right[1] * forward[0]];
        for pixel in (0..w * h).step_by(step) {
            let (u, v) = ((pixel % w) as f32, (pixel / w) as f32);
            let (cx, cy) = ((u - 599.5) / f, (v - 339.5) / f);
            let dir: [f32; 3] = std::array::from_fn(|a| forward[a] + cx * right[a] - cy * up[a]);
            // The room shell: the ray leaves the room through the nearest boundary.
            let (mut t, mut class) = (f32::INFINITY, 0);
            for a in 0..3 {
                if dir[a] != 0.0 {
                    let bound = if dir[a] > 0.0 { ROOM[a] } else { 0.0 };
                    let ta = (bound - origin[a]) / dir[a];
                    if ta < t {
                        t = ta;
                        class = match (a, dir[a] > 0.0) {
                            (1, false) => FLOOR,
                            (1, true) => CEILING,
                            _ => WALL,
                        };
                    }
                }
            }
            for b in blocks {
                if let Some(tb) = ray_box(origin, dir, b)
                    && tb < t
                {
                    (t, class) = (tb, b.class);
                }
            }
            points.push(std::array::from_fn(|a| origin[a] + t * dir[a]));
            labels.push(class);
            if points.len() == wanted {
                break;
            }
        }
    }
    GroundTruth { source: "synthetic".into(), points, colors: None, labels }
}

fn unit_vector(rng: &mut Rng, dim: usize) -> Vec<f32> {
    let v: Vec<f64> = (0..dim).map(|_| rng.normal()).collect();
    let norm = v.iter().map(|x| x * x).sum::<f64>().sqrt();
    v.iter().map(|x| (x / norm) as f32).collect()
}

fn text_features(rng: &mut Rng, classes: &ClassList, dim: usize) -> TextFeatures {
    let class_ids: Vec<i64> = classes.entries().iter().map(|c| c.id).filter(|&id| id != 0).collect();
    let values: Vec<f32> = class_ids.iter().flat_map(|_| unit_vector(rng, dim)).collect();
    TextFeatures { source: "synthetic".into(), features: FeatureMatrix { rows: class_ids.len(), dim, values }, class_ids }
}

/// Map objects: every block's surface plus floor patches, noisy, 80 % with a feature
/// near their true class and 20 % near another class.
fn map_of(rng: &mut Rng, blocks: &[Block], text: &TextFeatures, wanted: usize, covers_room: bool) -> PredictedMap {
    let mut objects: Vec<Block> = blocks.to_vec();
    if covers_room {
        let [x, y, z] = ROOM;
        objects.extend([
            Block { min: [0.0, 0.0, 0.0], max: [x, 0.0, z], class: FLOOR },
            Block { min: [0.0, y, 0.0], max: [x, y, z], class: CEILING },
            Block { min: [0.0, 0.0, 0.0], max: [x, y, 0.0], class: WALL },
            Block { min: [0.0, 0.0, z], max: [x, y, z], class: WALL },
            Block { min: [0.0, 0.0, 0.0], max: [0.0, y, z], class: WALL },
            Block { min: [x, 0.0, 0.0], max: [x, y, z], class: WALL },
        ]);
    }
    for _ in 0..blocks.len() / 4 + 1 {
        let x = rng.range(0.0, ROOM[0] as f64 - 2.0) as f32;
        let z = rng.range(0.0, ROOM[2] as f64 - 2.0) as f32;
        objects.push(Block { min: [x, 0.0, z], max: [x + 2.0, 0.0, z + 2.0], class: FLOOR });
    }
    let area = |b: &Block| {
        let s = [b.max[0] - b.min[0], b.max[1] - b.min[1], b.max[2] - b.min[2]];
        (s[0] * s[1] + s[1] * s[2] + s[0] * s[2]).max(0.01) as f64
    };
    let total: f64 = objects.iter().map(area).sum();
    let mut points = Vec::with_capacity(wanted);
    let mut object_ids = Vec::with_capacity(wanted);
    for (o, b) in objects.iter().enumerate() {
        let share = if o + 1 == objects.len() { wanted - points.len() } else { ((area(b) / total) * wanted as f64) as usize };
        for _ in 0..share.min(wanted - points.len()) {
            // A point on a random face of the box, with 1 cm noise.
            let axis = rng.below(3);
            let mut p: [f32; 3] = std::array::from_fn(|a| rng.range(b.min[a] as f64, b.max[a] as f64 + 1e-6) as f32);
            p[axis] = if rng.unit() < 0.5 { b.min[axis] } else { b.max[axis] };
            points.push(std::array::from_fn(|a| p[a] + (0.01 * rng.normal()) as f32));
            object_ids.push(o as u32);
        }
    }
    let dim = text.features.dim;
    let mut values = Vec::with_capacity(objects.len() * dim);
    for b in &objects {
        let class = if rng.unit() < 0.8 { b.class } else { text.class_ids[rng.below(text.class_ids.len())] };
        let row = text.class_ids.iter().position(|&c| c == class).expect("every class has text");
        let noise = unit_vector(rng, dim);
        values.extend(text.features.row(row).iter().zip(&noise).map(|(&t, &n)| t + 0.5 * n));
    }
    PredictedMap {
        source: "synthetic".into(),
        points,
        semantics: MapSemantics::ObjectFeatures { object_ids, features: FeatureMatrix { rows: objects.len(), dim, values } },
    }
}
