//! Over-segmentation of a frame into regions: SLIC superpixels on the block image, whose
//! distance weighs colour, image position and depth (a depth step of a few percent
//! separates regions as strongly as a change of colour), then split into connected
//! pieces. Blocks without depth belong to no region.

use crate::frame::Frame;

/// Seeds are laid on a grid of this many blocks.
pub const SEED_STEP: usize = 8;
const ITERATIONS: usize = 6;
/// A colour difference (RGB in [0, 1]) worth one seed step of image distance.
const COLOUR_SCALE: f32 = 0.12;
/// A relative depth difference worth one seed step of image distance.
const DEPTH_SCALE: f32 = 0.04;
/// Marks a block of no region.
pub const NONE: u32 = u32::MAX;

/// The regions of a frame.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Regions {
    /// The region of each block ([`NONE`] where there is no depth).
    pub of_block: Vec<u32>,
    /// Number of regions (ids `0..count`).
    pub count: usize,
}

#[derive(Clone, Copy)]
struct Centre {
    x: f32,
    y: f32,
    rgb: [f32; 3],
    z: f32,
}

/// Segment `frame` into regions.
pub fn segment(frame: &Frame) -> Regions {
    let mut centres = seeds(frame);
    let mut assigned = vec![NONE; frame.depth.len()];
    for _ in 0..ITERATIONS {
        assign(frame, &centres, &mut assigned);
        centres = recentred(frame, &centres, &assigned);
    }
    connected_pieces(frame, &assigned)
}

fn seeds(frame: &Frame) -> Vec<Centre> {
    let mut centres = Vec::new();
    for y in (SEED_STEP / 2..frame.height).step_by(SEED_STEP) {
        for x in (SEED_STEP / 2..frame.width).step_by(SEED_STEP) {
            let i = y * frame.width + x;
            centres.push(Centre { x: x as f32, y: y as f32, rgb: frame.rgb[i], z: frame.depth[i] });
        }
    }
    centres
}

fn distance(frame: &Frame, i: usize, x: usize, y: usize, c: &Centre) -> f32 {
    let colour: f32 = (0..3).map(|k| (frame.rgb[i][k] - c.rgb[k]).powi(2)).sum::<f32>() / (COLOUR_SCALE * COLOUR_SCALE);
    let image = ((x as f32 - c.x).powi(2) + (y as f32 - c.y).powi(2)) / (SEED_STEP * SEED_STEP) as f32;
    let depth = if c.z > 0.0 { ((frame.depth[i] - c.z) / c.z).powi(2) / (DEPTH_SCALE * DEPTH_SCALE) } else { 0.0 };
    colour + image + depth
}

fn assign(frame: &Frame, centres: &[Centre], assigned: &mut [u32]) {
    let mut best = vec![f32::INFINITY; assigned.len()];
    assigned.fill(NONE);
    let reach = SEED_STEP as f32;
    for (k, c) in centres.iter().enumerate() {
        let (x0, x1) = ((c.x - reach).max(0.0) as usize, ((c.x + reach) as usize + 1).min(frame.width));
        let (y0, y1) = ((c.y - reach).max(0.0) as usize, ((c.y + reach) as usize + 1).min(frame.height));
        for y in y0..y1 {
            for x in x0..x1 {
                let i = y * frame.width + x;
                if !frame.valid(i) {
                    continue;
                }
                let d = distance(frame, i, x, y, c);
                if d < best[i] {
                    best[i] = d;
                    assigned[i] = k as u32;
                }
            }
        }
    }
}

fn recentred(frame: &Frame, centres: &[Centre], assigned: &[u32]) -> Vec<Centre> {
    let mut sums = vec![(0.0f64, 0.0f64, [0.0f64; 3], 0.0f64, 0usize); centres.len()];
    for (i, &k) in assigned.iter().enumerate() {
        if k == NONE {
            continue;
        }
        let s = &mut sums[k as usize];
        s.0 += (i % frame.width) as f64;
        s.1 += (i / frame.width) as f64;
        for c in 0..3 {
            s.2[c] += frame.rgb[i][c] as f64;
        }
        s.3 += frame.depth[i] as f64;
        s.4 += 1;
    }
    centres
        .iter()
        .zip(&sums)
        .map(|(old, s)| {
            if s.4 == 0 {
                return *old;
            }
            let n = s.4 as f64;
            Centre { x: (s.0 / n) as f32, y: (s.1 / n) as f32, rgb: s.2.map(|v| (v / n) as f32), z: (s.3 / n) as f32 }
        })
        .collect()
}

/// Each connected (4-neighbour) piece of one assignment becomes a region, numbered in
/// scan order of its first block.
fn connected_pieces(frame: &Frame, assigned: &[u32]) -> Regions {
    let mut of_block = vec![NONE; assigned.len()];
    let mut count = 0u32;
    let mut stack = Vec::new();
    for start in 0..assigned.len() {
        if assigned[start] == NONE || of_block[start] != NONE {
            continue;
        }
        of_block[start] = count;
        stack.push(start);
        while let Some(i) = stack.pop() {
            let (x, y) = (i % frame.width, i / frame.width);
            let neighbours = [
                (x > 0).then(|| i - 1),
                (x + 1 < frame.width).then(|| i + 1),
                (y > 0).then(|| i - frame.width),
                (y + 1 < frame.height).then(|| i + frame.width),
            ];
            for j in neighbours.into_iter().flatten() {
                if of_block[j] == NONE && assigned[j] == assigned[start] {
                    of_block[j] = count;
                    stack.push(j);
                }
            }
        }
        count += 1;
    }
    Regions { of_block, count: count as usize }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn frame(width: usize, height: usize, colour: impl Fn(usize, usize) -> [f32; 3], depth: impl Fn(usize, usize) -> f32) -> Frame {
        let mut f = Frame { width, height, rgb: vec![], depth: vec![], world: vec![], eye: [0.0; 3], classes: None, texture: vec![] };
        for y in 0..height {
            for x in 0..width {
                f.rgb.push(colour(x, y));
                f.depth.push(depth(x, y));
                f.world.push([x as f32, y as f32, depth(x, y)]);
                f.texture.push(0.0);
            }
        }
        f
    }

    #[test]
    fn a_colour_edge_and_a_depth_step_both_bound_regions() {
        // Left half red, right half blue; the bottom rows are a step nearer.
        let f = frame(32, 16, |x, _| if x < 16 { [0.8, 0.1, 0.1] } else { [0.1, 0.1, 0.8] }, |_, y| if y < 8 { 3.0 } else { 2.0 });
        let regions = segment(&f);
        let quadrant = |i: usize| ((i % 32) < 16, (i / 32) < 8);
        let mut seen: std::collections::BTreeMap<u32, (bool, bool)> = std::collections::BTreeMap::new();
        for (i, &r) in regions.of_block.iter().enumerate() {
            assert_ne!(r, NONE, "every block with depth is in a region");
            assert_eq!(*seen.entry(r).or_insert(quadrant(i)), quadrant(i), "region {r} crosses an edge");
        }
        assert!(regions.count >= 4);
    }

    #[test]
    fn blocks_without_depth_belong_to_no_region_and_pieces_are_connected() {
        let f = frame(24, 8, |_, _| [0.5; 3], |x, _| if (10..14).contains(&x) { 0.0 } else { 2.0 });
        let regions = segment(&f);
        for y in 0..8 {
            for x in 10..14 {
                assert_eq!(regions.of_block[y * 24 + x], NONE);
            }
        }
        let left: std::collections::BTreeSet<u32> = (0..8).flat_map(|y| (0..10).map(move |x| y * 24 + x)).map(|i| regions.of_block[i]).collect();
        let right: std::collections::BTreeSet<u32> = (0..8).flat_map(|y| (14..24).map(move |x| y * 24 + x)).map(|i| regions.of_block[i]).collect();
        assert!(left.is_disjoint(&right), "a gap in depth separates regions");
        assert_eq!(regions.count, left.len() + right.len());
    }
}
