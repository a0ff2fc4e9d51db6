//! What the classifier is told about a region: what its pixels show (colour, brightness,
//! texture) and the geometry its depth gives (height above the floor and below the
//! ceiling, surface orientation, metric size and range).

use crate::frame::{Frame, luminance};
use crate::regions::{NONE, Regions};

/// Which features the mapper uses.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum FeatureSet {
    /// Colour, texture and geometry: the reference mapper.
    Seeing,
    /// Geometry only: the twin that shows what seeing adds.
    GeometryOnly,
}

impl FeatureSet {
    /// Number of features of a region.
    pub fn len(self) -> usize {
        match self {
            FeatureSet::Seeing => APPEARANCE + GEOMETRY,
            FeatureSet::GeometryOnly => GEOMETRY,
        }
    }

    /// Whether the set is empty (never).
    pub fn is_empty(self) -> bool {
        false
    }
}

const APPEARANCE: usize = 10;
const GEOMETRY: usize = 10;

/// The floor and ceiling heights of a sequence (world y is up), from its own depth.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Levels {
    /// Height of the floor.
    pub floor: f32,
    /// Height of the ceiling (or the highest surface seen).
    pub ceiling: f32,
}

impl Levels {
    /// The 2nd and 98th percentiles of the heights of every block with depth in `frames`.
    pub fn of(frames: &[Frame]) -> Levels {
        let mut heights: Vec<f32> = frames.iter().flat_map(|f| f.world.iter().zip(&f.depth).filter(|(_, d)| **d > 0.0).map(|(p, _)| p[1])).collect();
        if heights.is_empty() {
            return Levels { floor: 0.0, ceiling: 2.5 };
        }
        heights.sort_by(f32::total_cmp);
        let at = |q: f32| heights[((heights.len() - 1) as f32 * q) as usize];
        Levels { floor: at(0.02), ceiling: at(0.98) }
    }
}

/// Sums over one region's blocks.
#[derive(Default, Clone)]
struct Sums {
    n: f64,
    rgb: [f64; 3],
    luma: f64,
    luma2: f64,
    texture: f64,
    gradient: f64,
    normal: [f64; 3],
    normals: f64,
    height: f64,
    low: f32,
    high: f32,
    area: f64,
    range: f64,
    xz_lo: [f32; 2],
    xz_hi: [f32; 2],
}

/// One row of features per region of `frame`.
pub fn region_features(frame: &Frame, regions: &Regions, levels: Levels, set: FeatureSet, metres_per_block_at_1m: f32) -> Vec<Vec<f64>> {
    let mut sums =
        vec![Sums { low: f32::INFINITY, high: f32::NEG_INFINITY, xz_lo: [f32::INFINITY; 2], xz_hi: [f32::NEG_INFINITY; 2], ..Sums::default() }; regions.count];
    for (i, &r) in regions.of_block.iter().enumerate() {
        if r == NONE {
            continue;
        }
        add_block(&mut sums[r as usize], frame, i, metres_per_block_at_1m);
    }
    sums.iter().map(|s| row(s, levels, set)).collect()
}

fn add_block(s: &mut Sums, frame: &Frame, i: usize, metres_per_block_at_1m: f32) {
    let (rgb, p) = (frame.rgb[i], frame.world[i]);
    let l = luminance(rgb) as f64;
    s.n += 1.0;
    for c in 0..3 {
        s.rgb[c] += rgb[c] as f64;
    }
    s.luma += l;
    s.luma2 += l * l;
    s.texture += frame.texture[i] as f64;
    s.gradient += gradient(frame, i) as f64;
    if let Some(n) = normal(frame, i) {
        for c in 0..3 {
            s.normal[c] += n[c] as f64;
        }
        s.normals += 1.0;
    }
    s.height += p[1] as f64;
    s.low = s.low.min(p[1]);
    s.high = s.high.max(p[1]);
    let side = frame.depth[i] * metres_per_block_at_1m;
    s.area += (side * side) as f64;
    s.range += frame.depth[i] as f64;
    for (k, axis) in [0, 2].into_iter().enumerate() {
        s.xz_lo[k] = s.xz_lo[k].min(p[axis]);
        s.xz_hi[k] = s.xz_hi[k].max(p[axis]);
    }
}

fn row(s: &Sums, levels: Levels, set: FeatureSet) -> Vec<f64> {
    let n = s.n.max(1.0);
    let rgb = s.rgb.map(|v| v / n);
    let luma = s.luma / n;
    let sum = rgb.iter().sum::<f64>().max(1e-6);
    let (max, min) = (rgb.iter().cloned().fold(0.0, f64::max), rgb.iter().cloned().fold(1.0, f64::min));
    let appearance = [
        rgb[0],
        rgb[1],
        rgb[2],
        luma,
        (s.luma2 / n - luma * luma).max(0.0).sqrt(),
        s.texture / n,
        s.gradient / n,
        rgb[0] / sum,
        rgb[1] / sum,
        if max > 0.0 { (max - min) / max } else { 0.0 },
    ];
    let normal_length = s.normal.iter().map(|v| v * v).sum::<f64>().sqrt();
    let floor = levels.floor as f64;
    let geometry = [
        s.height / n - floor,
        s.low as f64 - floor,
        s.high as f64 - floor,
        levels.ceiling as f64 - s.high as f64,
        if normal_length > 0.0 { (s.normal[1] / normal_length).abs() } else { 0.5 },
        if s.normals > 0.0 { normal_length / s.normals } else { 0.0 },
        s.area.sqrt(),
        s.range / n,
        ((s.xz_hi[0] - s.xz_lo[0]).powi(2) + (s.xz_hi[1] - s.xz_lo[1]).powi(2)).sqrt() as f64,
        (s.high - s.low) as f64,
    ];
    match set {
        FeatureSet::Seeing => appearance.into_iter().chain(geometry).collect(),
        FeatureSet::GeometryOnly => geometry.to_vec(),
    }
}

/// Luminance change across block `i` (central differences; 0 at the border).
fn gradient(frame: &Frame, i: usize) -> f32 {
    let (x, y, w) = (i % frame.width, i / frame.width, frame.width);
    if x == 0 || y == 0 || x + 1 == w || y + 1 == frame.height {
        return 0.0;
    }
    let l = |j: usize| luminance(frame.rgb[j]);
    (l(i + 1) - l(i - 1)).abs() + (l(i + w) - l(i - w)).abs()
}

/// The unit surface normal at block `i` from its neighbours' world points, where all four
/// have depth within 10 % of its own.
fn normal(frame: &Frame, i: usize) -> Option<[f32; 3]> {
    let (x, y, w) = (i % frame.width, i / frame.width, frame.width);
    if x == 0 || y == 0 || x + 1 == w || y + 1 == frame.height {
        return None;
    }
    let z = frame.depth[i];
    let near = |j: usize| frame.depth[j] > 0.0 && (frame.depth[j] - z).abs() < 0.1 * z;
    if ![i - 1, i + 1, i - w, i + w].into_iter().all(near) {
        return None;
    }
    let d = |a: usize, b: usize| std::array::from_fn::<f32, 3, _>(|c| frame.world[a][c] - frame.world[b][c]);
    let (u, v) = (d(i + 1, i - 1), d(i + w, i - w));
    let n = [u[1] * v[2] - u[2] * v[1], u[2] * v[0] - u[0] * v[2], u[0] * v[1] - u[1] * v[0]];
    let length = n.iter().map(|c| c * c).sum::<f32>().sqrt();
    // Oriented towards the camera, so opposite sides of one surface agree.
    let towards: f32 = (0..3).map(|c| (frame.eye[c] - frame.world[i][c]) * n[c]).sum();
    (length > 0.0).then(|| n.map(|c| c / length * towards.signum()))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn flat_floor() -> Frame {
        // A 12×12 patch of floor (y = 0) one to two metres ahead, seen from 1 m up.
        let mut f = Frame { width: 12, height: 12, rgb: vec![], texture: vec![], depth: vec![], world: vec![], eye: [0.0, 1.0, 0.0], classes: None };
        for y in 0..12 {
            for x in 0..12 {
                f.rgb.push([0.6, 0.4, 0.2]);
                f.texture.push(0.01);
                f.depth.push(1.0 + y as f32 / 12.0);
                f.world.push([x as f32 * 0.1, 0.0, 1.0 + y as f32 * 0.1]);
            }
        }
        f
    }

    #[test]
    fn a_floor_region_is_low_level_and_faces_up() {
        let frame = flat_floor();
        let regions = Regions { of_block: vec![0; 144], count: 1 };
        let levels = Levels { floor: 0.0, ceiling: 2.5 };
        let rows = region_features(&frame, &regions, levels, FeatureSet::Seeing, 0.01);
        let row = &rows[0];
        assert_eq!(row.len(), FeatureSet::Seeing.len());
        assert!((row[0] - 0.6).abs() < 1e-6 && (row[2] - 0.2).abs() < 1e-6, "mean colour: {row:?}");
        let geometry = &row[APPEARANCE..];
        assert!(geometry[0].abs() < 1e-6, "centroid on the floor");
        assert!((geometry[3] - 2.5).abs() < 1e-6, "2.5 m below the ceiling");
        assert!((geometry[4] - 1.0).abs() < 1e-6, "the normal is vertical: {}", geometry[4]);
        let twin = region_features(&frame, &regions, levels, FeatureSet::GeometryOnly, 0.01);
        assert_eq!(twin[0], geometry.to_vec(), "the twin sees the same geometry and no colour");
    }

    #[test]
    fn levels_are_robust_percentiles_of_the_heights_seen() {
        let mut frame = flat_floor();
        frame.world[0][1] = -5.0; // one stray point below the floor
        frame.world[143][1] = 2.4;
        let levels = Levels::of(&[frame]);
        assert_eq!(levels.floor, 0.0);
        assert_eq!(levels.ceiling, 0.0, "one point is not a ceiling");
    }
}
