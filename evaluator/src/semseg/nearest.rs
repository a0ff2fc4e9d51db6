//! Exact nearest-neighbour association: for every ground-truth point, the predicted
//! point at the smallest squared distance, computed exactly as pytorch3d's
//! `knn_points` does (float32, `((dx² + dy²) + dz²)`, no fused multiply-add), with
//! equal distances going to the lowest point index.
//!
//! The index is a balanced k-d tree (median splits on the widest axis) whose nodes
//! also keep tight bounding boxes and the smallest point index below them. Pruning is
//! exact, not approximate: every lower bound (distance to a split plane or to a box)
//! is computed with the same float32 operations as a point's distance, and rounding
//! is monotone, so no point behind a pruned bound can have a smaller computed
//! distance, nor an equal one with a lower index.

use rayon::prelude::*;

/// Points per leaf at most.
const LEAF_SIZE: usize = 16;
/// Queries handled in order by one thread (each warm-starts from its predecessor).
const QUERY_CHUNK: usize = 4096;
/// Queries put in Z-order together: large enough that neighbours in space fall in one
/// block even when the input has no order, small enough that the ordering costs a few
/// megabytes (8 bytes a query, plus 4 for its answer).
const LOCALITY_BLOCK: usize = 1 << 20;
/// Bits per axis of the Z-order key (3 × 10 = 30 bits: 1,024 cells per axis).
const MORTON_BITS: u32 = 10;

/// Whether consecutive queries of `block` are already neighbours (a cloud read frame by
/// frame and row by row): their mean step, over up to 4,096 evenly spaced pairs, is within
/// four times the spacing `block` would have if spread evenly over `bounds`. Such a
/// block is answered in its own order; any other is put in Z-order first.
fn is_coherent(block: &[[f32; 3]], bounds: &Node) -> bool {
    if block.len() < 2 {
        return true;
    }
    let pairs = (block.len() - 1).min(4096);
    let stride = (block.len() - 1) / pairs;
    let step: f64 = (0..pairs)
        .map(|k| {
            let (a, b) = (block[k * stride], block[k * stride + 1]);
            (((a[0] - b[0]) as f64).powi(2) + ((a[1] - b[1]) as f64).powi(2) + ((a[2] - b[2]) as f64).powi(2)).sqrt()
        })
        .sum::<f64>()
        / pairs as f64;
    let extent: [f64; 3] = std::array::from_fn(|a| ((bounds.max[a] - bounds.min[a]) as f64).max(1e-6));
    let spacing = (extent[0] * extent[1] * extent[2] / block.len() as f64).cbrt();
    step <= 4.0 * spacing
}

/// Spread the low 10 bits of `v` to every third bit.
#[inline(always)]
fn spread_bits(v: u32) -> u32 {
    let mut x = v & 0x3FF;
    x = (x | (x << 16)) & 0x030000FF;
    x = (x | (x << 8)) & 0x0300F00F;
    x = (x | (x << 4)) & 0x030C30C3;
    x = (x | (x << 2)) & 0x09249249;
    x
}

/// The Z-order (Morton) key of `q` in the grid of `2^MORTON_BITS` cells per axis over
/// `bounds` (queries outside it are clamped to its faces).
#[inline(always)]
fn morton_key(q: &[f32; 3], bounds: &Node) -> u32 {
    let cells = ((1u32 << MORTON_BITS) - 1) as f32;
    let cell = |a: usize| {
        let extent = bounds.max[a] - bounds.min[a];
        let t = if extent > 0.0 { (q[a] - bounds.min[a]) / extent } else { 0.0 };
        (t.clamp(0.0, 1.0) * cells) as u32
    };
    spread_bits(cell(0)) | (spread_bits(cell(1)) << 1) | (spread_bits(cell(2)) << 2)
}

/// A node's bounding box and the smallest original index below it.
#[derive(Debug, Clone, Copy)]
#[repr(C, align(32))]
struct Node {
    min: [f32; 3],
    max: [f32; 3],
    min_id: u32,
}

/// The split plane of an internal node: left points have `p[axis] <= pivot`, right
/// points `>= pivot`. Kept apart from the boxes so the descent touches little memory.
#[derive(Debug, Clone, Copy)]
struct Split {
    pivot: f32,
    axis: u32,
}

/// A k-d tree over predicted points, answering exact nearest-point queries.
pub struct NearestIndex {
    /// Leaves are at this level (the root, node 1, is level 0; node i has children 2i, 2i+1).
    depth: u32,
    /// Positions in tree order, structure of arrays.
    xs: Vec<f32>,
    ys: Vec<f32>,
    zs: Vec<f32>,
    /// Original index of each point in tree order.
    ids: Vec<u32>,
    /// Start of each leaf's points in tree order, then the end (leaves left to right).
    leaf_bounds: Vec<usize>,
    /// Split of each internal node (index 0 unused).
    splits: Vec<Split>,
    /// Box of every node, heap-numbered from 1.
    nodes: Vec<Node>,
}

/// Squared distance exactly as pytorch3d accumulates it in float32.
#[inline(always)]
fn squared_distance(q: [f32; 3], x: f32, y: f32, z: f32) -> f32 {
    let dx = q[0] - x;
    let dy = q[1] - y;
    let dz = q[2] - z;
    (dx * dx + dy * dy) + dz * dz
}

/// A lower bound of `squared_distance` from `q` to any point inside the node's box.
/// Per axis the gap is `min − q` below the box, `q − max` above it and 0 inside.
#[inline(always)]
fn box_bound(q: [f32; 3], node: &Node) -> f32 {
    let gap = |a: usize| (node.min[a] - q[a]).max(q[a] - node.max[a]).max(0.0);
    let (gx, gy, gz) = (gap(0), gap(1), gap(2));
    (gx * gx + gy * gy) + gz * gz
}

/// The best candidate so far: its distance, original index and position in tree order.
#[derive(Debug, Clone, Copy)]
struct Best {
    distance: f32,
    id: u32,
    position: usize,
}

/// Whether candidate (distance, id) beats the current best under the tie rule.
#[inline(always)]
fn better(d: f32, id: u32, best: &Best) -> bool {
    d < best.distance || (d == best.distance && id < best.id)
}

/// The axis along which a box is widest (the split rule of the build).
fn widest_axis(lo: [f32; 3], hi: [f32; 3]) -> usize {
    (0..3).max_by(|&a, &b| (hi[a] - lo[a]).total_cmp(&(hi[b] - lo[b]))).expect("three axes")
}

impl NearestIndex {
    /// Build the index. Points must be finite (the map readers guarantee it) and fewer than 2³² − 1.
    pub fn build(points: &[[f32; 3]]) -> Self {
        assert!(!points.is_empty(), "cannot index an empty map");
        assert!(points.len() < u32::MAX as usize, "too many points for 32-bit ids");
        let n = points.len();
        let mut depth = 0u32;
        while n.div_ceil(1 << depth) > LEAF_SIZE {
            depth += 1;
        }
        let mut order: Vec<u32> = (0..n as u32).collect();
        split(points, &mut order, depth);
        let first_leaf = 1usize << depth;
        let mut index = Self {
            depth,
            xs: order.iter().map(|&i| points[i as usize][0]).collect(),
            ys: order.iter().map(|&i| points[i as usize][1]).collect(),
            zs: order.iter().map(|&i| points[i as usize][2]).collect(),
            ids: order,
            leaf_bounds: Vec::with_capacity(first_leaf + 1),
            splits: vec![Split { pivot: 0.0, axis: 0 }; first_leaf],
            nodes: vec![Node { min: [f32::INFINITY; 3], max: [f32::NEG_INFINITY; 3], min_id: u32::MAX }; 2 * first_leaf],
        };
        index.fill_nodes(n);
        index
    }

    /// Leaf ranges, boxes bottom-up, and the split plane the build used at each node.
    fn fill_nodes(&mut self, n: usize) {
        let first_leaf = 1usize << self.depth;
        // Ranges follow the build's rule: a range splits at its middle position.
        let mut ranges = vec![(0usize, n); 2 * first_leaf];
        for node in 1..first_leaf {
            let (start, end) = ranges[node];
            let mid = start + (end - start) / 2;
            ranges[2 * node] = (start, mid);
            ranges[2 * node + 1] = (mid, end);
        }
        self.leaf_bounds = (first_leaf..2 * first_leaf).map(|node| ranges[node].0).collect();
        self.leaf_bounds.push(n);
        for node in first_leaf..2 * first_leaf {
            let (start, end) = ranges[node];
            let leaf = &mut self.nodes[node];
            for i in start..end {
                let p = [self.xs[i], self.ys[i], self.zs[i]];
                for a in 0..3 {
                    leaf.min[a] = leaf.min[a].min(p[a]);
                    leaf.max[a] = leaf.max[a].max(p[a]);
                }
                leaf.min_id = leaf.min_id.min(self.ids[i]);
            }
        }
        for node in (1..first_leaf).rev() {
            let (l, r) = (self.nodes[2 * node], self.nodes[2 * node + 1]);
            let min = std::array::from_fn(|a| l.min[a].min(r.min[a]));
            let max = std::array::from_fn(|a| l.max[a].max(r.max[a]));
            // The node's box is the box of its points, so this is the axis the build chose.
            let axis = widest_axis(min, max);
            // Left points are <= the median element, which is among the right points and
            // the smallest of them along the axis (later splits move it, not its value).
            self.splits[node] = Split { pivot: r.min[axis], axis: axis as u32 };
            self.nodes[node] = Node { min, max, min_id: l.min_id.min(r.min_id) };
        }
    }

    /// Improve `best` with every point of leaf `leaf` (0-based, left to right).
    #[inline(always)]
    fn scan_leaf(&self, q: [f32; 3], leaf: usize, best: &mut Best) {
        for i in self.leaf_bounds[leaf]..self.leaf_bounds[leaf + 1] {
            let d = squared_distance(q, self.xs[i], self.ys[i], self.zs[i]);
            if better(d, self.ids[i], best) {
                *best = Best { distance: d, id: self.ids[i], position: i };
            }
        }
    }

    /// Search the subtree of `node`, nearer child first.
    fn search(&self, q: [f32; 3], node: usize, best: &mut Best) {
        let first_leaf = 1usize << self.depth;
        if node >= first_leaf {
            self.scan_leaf(q, node - first_leaf, best);
            return;
        }
        let Split { pivot, axis } = self.splits[node];
        let axis = axis as usize;
        let (near, far, gap) = if q[axis] <= pivot { (2 * node, 2 * node + 1, pivot - q[axis]) } else { (2 * node + 1, 2 * node, q[axis] - pivot) };
        // The near side holds q's own region: descending without a bound check is
        // cheaper than the check, which almost always passes.
        self.search(q, near, best);
        // The far side lies beyond the split plane (a bound needing no memory beyond
        // the split); only if that cannot rule it out is its box consulted.
        let plane = gap * gap;
        if plane > best.distance {
            return;
        }
        let far_node = &self.nodes[far];
        if better(plane, far_node.min_id, best) && better(box_bound(q, far_node), far_node.min_id, best) {
            self.search(q, far, best);
        }
    }

    /// The nearest point to `q`, starting from the candidate at tree position `hint`
    /// (a neighbour's answer, whose coordinates are still in cache).
    fn nearest_from(&self, q: [f32; 3], hint: usize) -> Best {
        let distance = squared_distance(q, self.xs[hint], self.ys[hint], self.zs[hint]);
        let mut best = Best { distance, id: self.ids[hint], position: hint };
        self.search(q, 1, &mut best);
        best
    }

    /// Index of the nearest indexed point to `q` (ties to the lowest index).
    pub fn nearest(&self, q: [f32; 3]) -> u32 {
        self.nearest_from(q, 0).id
    }

    /// Answer `queries` in their own order, in parallel chunks, each query warm-started
    /// from its predecessor's answer.
    fn nearest_in_order(&self, queries: &[[f32; 3]], answers: &mut [u32]) {
        answers.par_chunks_mut(QUERY_CHUNK).zip(queries.par_chunks(QUERY_CHUNK)).for_each(|(found, qs)| {
            let mut hint = 0;
            for (answer, &q) in found.iter_mut().zip(qs) {
                let best = self.nearest_from(q, hint);
                hint = best.position;
                *answer = best.id;
            }
        });
    }

    /// The nearest indexed point of every query, in parallel, whatever the queries'
    /// order: each block of [`LOCALITY_BLOCK`] queries is visited along a Z-order curve
    /// over the index's box, so consecutive queries are neighbours — each warm-starts from
    /// its predecessor's answer and finds the tree's path in cache — as in a scanned cloud
    /// read frame by frame, but also for a shuffled or voxel-downsampled one.
    pub fn nearest_all(&self, queries: &[[f32; 3]]) -> Vec<u32> {
        let mut out = vec![0u32; queries.len()];
        let root = self.nodes[1];
        let mut order: Vec<u64> = Vec::with_capacity(LOCALITY_BLOCK.min(queries.len()));
        let mut sorted_answers: Vec<u32> = Vec::with_capacity(LOCALITY_BLOCK.min(queries.len()));
        for (answers, block) in out.chunks_mut(LOCALITY_BLOCK).zip(queries.chunks(LOCALITY_BLOCK)) {
            if is_coherent(block, &root) {
                self.nearest_in_order(block, answers);
                continue;
            }
            order.clear();
            order.par_extend(block.par_iter().enumerate().map(|(i, q)| (u64::from(morton_key(q, &root)) << 32) | i as u64));
            order.par_sort_unstable();
            sorted_answers.clear();
            sorted_answers.resize(block.len(), 0);
            sorted_answers.par_chunks_mut(QUERY_CHUNK).zip(order.par_chunks(QUERY_CHUNK)).for_each(|(found, keys)| {
                let mut hint = 0;
                for (answer, key) in found.iter_mut().zip(keys) {
                    let best = self.nearest_from(block[(key & 0xFFFF_FFFF) as usize], hint);
                    hint = best.position;
                    *answer = best.id;
                }
            });
            for (key, &answer) in order.iter().zip(&sorted_answers) {
                answers[(key & 0xFFFF_FFFF) as usize] = answer;
            }
        }
        out
    }
}

/// Reorder `order` into a balanced k-d tree of `depth` levels: each range is split at
/// its middle position along the widest axis of its points.
fn split(points: &[[f32; 3]], order: &mut [u32], depth: u32) {
    if depth == 0 || order.len() < 2 {
        return;
    }
    let (mut lo, mut hi) = ([f32::INFINITY; 3], [f32::NEG_INFINITY; 3]);
    for &i in order.iter() {
        let p = points[i as usize];
        for a in 0..3 {
            lo[a] = lo[a].min(p[a]);
            hi[a] = hi[a].max(p[a]);
        }
    }
    let axis = widest_axis(lo, hi);
    let mid = order.len() / 2;
    order.select_nth_unstable_by(mid, |&a, &b| points[a as usize][axis].total_cmp(&points[b as usize][axis]));
    let (left, right) = order.split_at_mut(mid);
    if left.len() > 1 << 15 {
        rayon::join(|| split(points, left, depth - 1), || split(points, right, depth - 1));
    } else {
        split(points, left, depth - 1);
        split(points, right, depth - 1);
    }
}

/// The nearest point by exhaustive search (the specification the index must match).
pub fn nearest_brute_force(points: &[[f32; 3]], q: [f32; 3]) -> u32 {
    let mut best = Best { distance: f32::INFINITY, id: u32::MAX, position: 0 };
    for (i, p) in points.iter().enumerate() {
        let d = squared_distance(q, p[0], p[1], p[2]);
        if better(d, i as u32, &best) {
            best = Best { distance: d, id: i as u32, position: i };
        }
    }
    best.id
}
