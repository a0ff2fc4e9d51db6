//! Exact nearest-neighbour association: for every ground-truth point, the predicted
//! point at the smallest squared distance, computed exactly as pytorch3d's
//! `knn_points` does (float32, `((dx² + dy²) + dz²)`, no fused multiply-add), with
//! equal distances going to the lowest point index.
//!
//! The index is a balanced k-d tree with tight bounding boxes. Pruning is exact, not
//! approximate: a box's lower bound is computed with the same float32 operations as a
//! point's distance, and rounding is monotone, so no point inside a pruned box can
//! have a smaller (or equal and lower-indexed) computed distance.

use rayon::prelude::*;

/// Points per leaf at most.
const LEAF_SIZE: usize = 12;
/// Queries handled together by one thread (they share a warm start).
const QUERY_CHUNK: usize = 4096;

/// A k-d tree over predicted points, answering exact nearest-point queries.
pub struct NearestIndex {
    /// Tree depth: leaves are at this level (the root is level 0).
    depth: u32,
    /// Number of indexed points.
    len: usize,
    /// Positions in tree order, structure of arrays.
    xs: Vec<f32>,
    ys: Vec<f32>,
    zs: Vec<f32>,
    /// Original index of each point in tree order.
    ids: Vec<u32>,
    /// Positions in original order (warm starts look points up by id).
    original: Vec<[f32; 3]>,
    /// Start of each leaf's points in tree order, plus the end (leaves left to right).
    leaf_bounds: Vec<usize>,
    /// Per node (heap numbering from 1): bounding box and smallest original index.
    box_min: Vec<[f32; 3]>,
    box_max: Vec<[f32; 3]>,
    min_id: Vec<u32>,
}

/// Squared distance exactly as pytorch3d accumulates it in float32.
#[inline(always)]
fn squared_distance(q: [f32; 3], x: f32, y: f32, z: f32) -> f32 {
    let dx = q[0] - x;
    let dy = q[1] - y;
    let dz = q[2] - z;
    (dx * dx + dy * dy) + dz * dz
}

/// A lower bound of `squared_distance` from `q` to any point inside the box.
#[inline(always)]
fn box_bound(q: [f32; 3], min: [f32; 3], max: [f32; 3]) -> f32 {
    let gap = |a: usize| {
        if q[a] < min[a] {
            min[a] - q[a]
        } else if q[a] > max[a] {
            q[a] - max[a]
        } else {
            0.0
        }
    };
    let (gx, gy, gz) = (gap(0), gap(1), gap(2));
    (gx * gx + gy * gy) + gz * gz
}

/// Whether candidate (distance, id) beats the current best under the tie rule.
#[inline(always)]
fn better(d: f32, id: u32, best_d: f32, best_id: u32) -> bool {
    d < best_d || (d == best_d && id < best_id)
}

impl NearestIndex {
    /// Build the index. Points must be finite (the map readers guarantee it) and fewer than 2³² − 1.
    pub fn build(points: &[[f32; 3]]) -> Self {
        assert!(!points.is_empty(), "cannot index an empty map");
        assert!(points.len() < u32::MAX as usize, "too many points for 32-bit ids");
        let n = points.len();
        let mut depth = 0u32;
        while (n >> depth) > LEAF_SIZE {
            depth += 1;
        }
        let mut order: Vec<u32> = (0..n as u32).collect();
        split(points, &mut order, depth);
        let xs = order.iter().map(|&i| points[i as usize][0]).collect();
        let ys = order.iter().map(|&i| points[i as usize][1]).collect();
        let zs = order.iter().map(|&i| points[i as usize][2]).collect();
        let nodes = 1usize << (depth + 1);
        let mut index = Self {
            depth,
            len: n,
            xs,
            ys,
            zs,
            ids: order,
            original: points.to_vec(),
            leaf_bounds: Vec::new(),
            box_min: vec![[f32::INFINITY; 3]; nodes],
            box_max: vec![[f32::NEG_INFINITY; 3]; nodes],
            min_id: vec![u32::MAX; nodes],
        };
        index.fill_boxes();
        index
    }

    /// The point range of node `node` at level `level`.
    fn range(&self, node: usize, level: u32) -> (usize, usize) {
        // Walk from the root following the bits of the heap index.
        let (mut start, mut end) = (0usize, self.len);
        for bit in (0..level).rev() {
            let mid = start + (end - start) / 2;
            if (node >> bit) & 1 == 0 {
                end = mid;
            } else {
                start = mid;
            }
        }
        (start, end)
    }

    fn fill_boxes(&mut self) {
        let first_leaf = 1usize << self.depth;
        self.leaf_bounds = (first_leaf..first_leaf * 2).map(|node| self.range(node, self.depth).0).collect();
        self.leaf_bounds.push(self.len);
        for node in first_leaf..first_leaf * 2 {
            let (start, end) = (self.leaf_bounds[node - first_leaf], self.leaf_bounds[node - first_leaf + 1]);
            let (mut lo, mut hi, mut min_id) = ([f32::INFINITY; 3], [f32::NEG_INFINITY; 3], u32::MAX);
            for i in start..end {
                let p = [self.xs[i], self.ys[i], self.zs[i]];
                for a in 0..3 {
                    lo[a] = lo[a].min(p[a]);
                    hi[a] = hi[a].max(p[a]);
                }
                min_id = min_id.min(self.ids[i]);
            }
            self.box_min[node] = lo;
            self.box_max[node] = hi;
            self.min_id[node] = min_id;
        }
        for node in (1..first_leaf).rev() {
            let (l, r) = (2 * node, 2 * node + 1);
            for a in 0..3 {
                self.box_min[node][a] = self.box_min[l][a].min(self.box_min[r][a]);
                self.box_max[node][a] = self.box_max[l][a].max(self.box_max[r][a]);
            }
            self.min_id[node] = self.min_id[l].min(self.min_id[r]);
        }
    }

    /// Index of the nearest point to `q`, starting from a known candidate `hint`.
    fn nearest_from(&self, q: [f32; 3], hint: u32) -> u32 {
        let h = self.original[hint as usize];
        let (mut best_d, mut best_id) = (squared_distance(q, h[0], h[1], h[2]), hint);
        let first_leaf = 1usize << self.depth;
        // (node, lower bound) still to visit; the nearer child is visited first.
        let mut stack = [(0usize, 0f32); 64];
        let mut top = 1;
        stack[0] = (1, box_bound(q, self.box_min[1], self.box_max[1]));
        while top > 0 {
            top -= 1;
            let (node, bound) = stack[top];
            if !better(bound, self.min_id[node], best_d, best_id) {
                continue;
            }
            if node >= first_leaf {
                let (start, end) = (self.leaf_bounds[node - first_leaf], self.leaf_bounds[node - first_leaf + 1]);
                for i in start..end {
                    let d = squared_distance(q, self.xs[i], self.ys[i], self.zs[i]);
                    if better(d, self.ids[i], best_d, best_id) {
                        best_d = d;
                        best_id = self.ids[i];
                    }
                }
                continue;
            }
            let (l, r) = (2 * node, 2 * node + 1);
            let bl = box_bound(q, self.box_min[l], self.box_max[l]);
            let br = box_bound(q, self.box_min[r], self.box_max[r]);
            let (near, near_b, far, far_b) = if bl <= br { (l, bl, r, br) } else { (r, br, l, bl) };
            stack[top] = (far, far_b);
            stack[top + 1] = (near, near_b);
            top += 2;
        }
        best_id
    }

    /// Index of the nearest indexed point to `q` (ties to the lowest index).
    pub fn nearest(&self, q: [f32; 3]) -> u32 {
        self.nearest_from(q, self.ids[0])
    }

    /// The nearest indexed point of every query, in parallel. Consecutive queries
    /// (as in scanned clouds) warm-start from their predecessor's answer.
    pub fn nearest_all(&self, queries: &[[f32; 3]]) -> Vec<u32> {
        let mut out = vec![0u32; queries.len()];
        out.par_chunks_mut(QUERY_CHUNK).zip(queries.par_chunks(QUERY_CHUNK)).for_each(|(answers, qs)| {
            let mut hint = self.ids[0];
            for (answer, &q) in answers.iter_mut().zip(qs) {
                hint = self.nearest_from(q, hint);
                *answer = hint;
            }
        });
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
    let axis = (0..3).max_by(|&a, &b| (hi[a] - lo[a]).total_cmp(&(hi[b] - lo[b]))).expect("three axes");
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
    let mut best = (f32::INFINITY, u32::MAX);
    for (i, p) in points.iter().enumerate() {
        let d = squared_distance(q, p[0], p[1], p[2]);
        if better(d, i as u32, best.0, best.1) {
            best = (d, i as u32);
        }
    }
    best.1
}
