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
//!
//! Queries are answered in batches of neighbours: visited along a Z-order curve
//! ([`super::z_order`]: block by block, or once for a cloud scored against several maps),
//! consecutive queries whose box spans about two leaves share one search for the leaves
//! that can hold their answers. The members are laid out as lanes ([`Members`]) and meet each
//! candidate leaf together, a point at a time, with the same float32 operations and tie
//! rule lane by lane: first the leaf holding the batch's centre, whose nearest point to
//! each member bounds every answer's distance, then every leaf within that bound of the
//! batch's box, skipped by each group of lanes none of whose best so far it can beat.
//! Where that leaf bounds too loosely (queries away from every point: a room's walls
//! that a map leaves out), the batch's centre is searched for exactly and the leaf of its
//! answer bounds the members instead. Queries so far from every point that even then
//! their candidate leaves are too many to share are searched one by one, the first
//! warm-started from the centre's answer, each next from its predecessor's.
//!
//! Scoring needs only the class of each answer. Given the class of every indexed point
//! ([`PointClasses`]), a batch all of whose candidate leaves hold points of one class takes
//! that class without its members meeting those leaves: every member's answer lies in one
//! of them, whichever it is. In other batches, a group of lanes whose bests are all of one
//! class passes over the leaves of that class unless a leaf of another class changes a
//! lane's class. The classes are those of the exact answers, ties included.

use std::sync::atomic::{AtomicU64, Ordering::Relaxed};

use rayon::prelude::*;

use super::reused_buffers::{refill, resize_to_overwrite};
use super::z_order::{ZGrid, ZOrderKeys, position_of};

/// Points per leaf at most; every leaf has this many slots, the unused ones padded with
/// points at infinity that never win, so a leaf is scanned with fixed-width arithmetic.
const LEAF_SIZE: usize = 16;
/// Queries handled in order by one thread.
const QUERY_CHUNK: usize = 4096;
/// Fewest queries put in Z-order together: enough that neighbours in space fall in one
/// block even when the input has no order (the ordering costs 16 bytes a query of a
/// block: its key, and the sort's scratch space, which then holds its answer).
const SMALLEST_LOCALITY_BLOCK: usize = 1 << 20;
/// Most queries put in Z-order together. A block of a large cloud that arrives frame by
/// frame or in random order holds the scene at a fraction of its density, and its
/// batches of neighbours are smaller: on 20 M frame-ordered queries blocks of 2²² took
/// 0.91 of the time of blocks of 2²⁰.
const LARGEST_LOCALITY_BLOCK: usize = 1 << 22;
/// Blocks a cloud is split into at least, unless that makes them smaller than
/// [`SMALLEST_LOCALITY_BLOCK`]: a block's 16 bytes a query then take no more memory than an answer
/// array for every query would (4 bytes a query), which scoring does not hold (see
/// [`NearestIndex::nearest_by_block`]).
const FEWEST_BLOCKS: usize = 4;

/// Queries put in Z-order together, out of `queries`.
fn locality_block(queries: usize) -> usize {
    queries.div_ceil(FEWEST_BLOCKS).clamp(SMALLEST_LOCALITY_BLOCK, LARGEST_LOCALITY_BLOCK)
}

/// Most queries answered together as one batch.
const BATCH_QUERIES: usize = 128;
/// Most leaves a batch shares within the bound of its home leaf (the leaf at its centre).
/// A batch whose neighbourhood reaches more is bounded again by the exact answer of its
/// centre.
const BATCH_LEAVES: usize = 64;
/// Most leaves a batch shares within the bound of its centre's exact answer; a batch whose
/// neighbourhood reaches more still (queries far from every indexed point, where the
/// answer's distance is large) is answered query by query. Measured on maps that leave a
/// room's shell out (a tenth of the batches bounded this way): 256 shares all of them
/// there, and no case measured was faster with 64 or 1,024.
const FAR_BATCH_LEAVES: usize = 256;
/// How far a batch may spread: its box's squared diagonal at most this many times the
/// median leaf's (measured: 1, 2 and 3 against 64 and 128 queries a batch; 2 with 128 was
/// fastest on surfaces, in scan and in random order, and where the map leaves gaps).
const BATCH_SPAN_LEAVES: f32 = 2.0;
/// Queries a group of lanes holds: members meet a leaf's points this many at a time, with
/// arithmetic the compiler keeps in vector registers.
const LANES: usize = 8;
/// Groups of lanes a batch needs at most.
const GROUPS: usize = BATCH_QUERIES / LANES;

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
    /// Points indexed.
    len: usize,
    /// Leaves are at this level (the root, node 1, is level 0; node i has children 2i, 2i+1).
    depth: u32,
    /// Positions in tree order, structure of arrays, [`LEAF_SIZE`] slots a leaf (leaf
    /// `l` holds slots `l·LEAF_SIZE ..`); unused slots are at +∞.
    xs: Vec<f32>,
    ys: Vec<f32>,
    zs: Vec<f32>,
    /// Original index of the point in each slot (`u32::MAX` in unused slots).
    ids: Vec<u32>,
    /// Split of each internal node (index 0 unused).
    splits: Vec<Split>,
    /// Box of every node, heap-numbered from 1.
    nodes: Vec<Node>,
    /// Squared diagonal a batch of queries may span: about two leaves', so that the
    /// leaves near a batch are few.
    batch_span: f32,
    /// The build's working copy of the points, kept by [`NearestIndex::rebuild`] for the next.
    build_order: Vec<IndexedPoint>,
}

/// Squared distance exactly as pytorch3d accumulates it in float32.
#[inline(always)]
fn squared_distance(q: [f32; 3], x: f32, y: f32, z: f32) -> f32 {
    let dx = q[0] - x;
    let dy = q[1] - y;
    let dz = q[2] - z;
    (dx * dx + dy * dy) + dz * dz
}

/// The larger of `a` and `b`, for finite values (every coordinate and bound here): one
/// instruction, where `f32::max` adds two to handle NaN. For ±0 it may give the other
/// zero, which squares to the same bound.
#[inline(always)]
fn larger(a: f32, b: f32) -> f32 {
    if a > b { a } else { b }
}

/// The smaller of `a` and `b`, for finite values (as [`larger`]).
#[inline(always)]
fn smaller(a: f32, b: f32) -> f32 {
    if a < b { a } else { b }
}

/// A lower bound of `squared_distance` from `q` to any point inside the node's box.
/// Per axis the gap is `min − q` below the box, `q − max` above it and 0 inside.
#[inline(always)]
fn box_bound(q: [f32; 3], node: &Node) -> f32 {
    let gap = |a: usize| larger(larger(node.min[a] - q[a], q[a] - node.max[a]), 0.0);
    let (gx, gy, gz) = (gap(0), gap(1), gap(2));
    (gx * gx + gy * gy) + gz * gz
}

/// A lower bound of `squared_distance` from any query inside the box `lo..=hi` to any
/// point inside the node's box. Rounding is monotone, so for such a query and point
/// each computed coordinate difference is at least the computed gap between the boxes.
#[inline(always)]
fn box_box_bound(lo: [f32; 3], hi: [f32; 3], node: &Node) -> f32 {
    let gap = |a: usize| larger(larger(node.min[a] - hi[a], lo[a] - node.max[a]), 0.0);
    let (gx, gy, gz) = (gap(0), gap(1), gap(2));
    (gx * gx + gy * gy) + gz * gz
}

/// The squared diagonal of the box `lo..=hi`.
#[inline(always)]
fn span(lo: [f32; 3], hi: [f32; 3]) -> f32 {
    squared_distance(lo, hi[0], hi[1], hi[2])
}

/// Lanes of queries: [`LANES`] to a group, each with its best candidate so far.
type Lanes<T> = [[T; LANES]; GROUPS];

/// The members of one batch, [`LANES`] to a group, each coordinate and each part of the
/// best candidate in an array of its own. The last group's spare lanes repeat its last
/// member (they do the same work and their answers are dropped).
struct Members {
    x: Lanes<f32>,
    y: Lanes<f32>,
    z: Lanes<f32>,
    distance: Lanes<f32>,
    id: Lanes<u32>,
    /// The class every answer of a group has, where it is known without its lanes' answers
    /// ([`PointClasses::MIXED`] where it is not).
    class: [u32; GROUPS],
    /// Groups in use.
    groups: usize,
    /// Members in use.
    count: usize,
    /// The first slot of the batch's home leaf, or its centre's answer once that was
    /// searched for: where the members' one-by-one search starts if the batch gives up.
    warm_slot: usize,
}

impl Members {
    fn new() -> Self {
        let (zero, far) = ([[0.0; LANES]; GROUPS], [[f32::INFINITY; LANES]; GROUPS]);
        let (id, class) = ([[u32::MAX; LANES]; GROUPS], [PointClasses::MIXED; GROUPS]);
        Self { x: zero, y: zero, z: zero, distance: far, id, class, groups: 0, count: 0, warm_slot: 0 }
    }

    /// Take a batch's queries (at least one, at most [`BATCH_QUERIES`]), none answered yet.
    fn gather(&mut self, queries: impl ExactSizeIterator<Item = [f32; 3]>) {
        self.count = queries.len();
        assert!((1..=BATCH_QUERIES).contains(&self.count), "a batch holds 1 to {BATCH_QUERIES} queries");
        self.groups = self.count.div_ceil(LANES);
        let mut queries = queries;
        let mut last = [0.0; 3];
        for g in 0..self.groups {
            for l in 0..LANES {
                last = queries.next().unwrap_or(last);
                (self.x[g][l], self.y[g][l], self.z[g][l]) = (last[0], last[1], last[2]);
            }
            self.distance[g] = [f32::INFINITY; LANES];
            self.id[g] = [u32::MAX; LANES];
            self.class[g] = PointClasses::MIXED;
        }
    }

    /// Whether a point in `node`'s box could beat the best of some lane of group `g`:
    /// [`box_bound`] and [`better`], lane by lane.
    #[inline(always)]
    fn may_improve(&self, g: usize, node: &Node) -> bool {
        let (x, y, z, distance, id) = (&self.x[g], &self.y[g], &self.z[g], &self.distance[g], &self.id[g]);
        let mut any = false;
        for l in 0..LANES {
            let gx = larger(larger(node.min[0] - x[l], x[l] - node.max[0]), 0.0);
            let gy = larger(larger(node.min[1] - y[l], y[l] - node.max[1]), 0.0);
            let gz = larger(larger(node.min[2] - z[l], z[l] - node.max[2]), 0.0);
            let bound = (gx * gx + gy * gy) + gz * gz;
            any |= (bound < distance[l]) | ((bound == distance[l]) & (node.min_id < id[l]));
        }
        any
    }

    /// The largest best distance of any member: no answer is farther.
    fn reach(&self) -> f32 {
        // Lane by lane first (one vector instruction a group), then across the lanes.
        let mut most = [0.0f32; LANES];
        for distances in &self.distance[..self.groups] {
            for l in 0..LANES {
                most[l] = larger(most[l], distances[l]);
            }
        }
        most.into_iter().fold(0.0, larger)
    }

    /// Each member's answer, in the batch's order: its nearest point, or that point's class.
    fn answers<'a>(&'a self, answer: Answer<'a>) -> impl Iterator<Item = u32> + 'a {
        let groups = self.id[..self.groups].iter().zip(&self.class[..self.groups]);
        groups.flat_map(move |(ids, &class)| ids.iter().map(move |&id| if class == PointClasses::MIXED { answer.of(id) } else { class })).take(self.count)
    }
}

/// [`squared_distance`] from each lane's query to the point `(px, py, pz)` with original
/// index `p_id`, and [`better`], lane by lane and without branches. The arrays are meant
/// to be a group's copies on the stack (see [`NearestIndex::scan_leaf_for_members`]):
/// working on [`Members`] in place, the compiler vectorised across the point's
/// coordinates instead of across the lanes and branched lane by lane (batches took 1.5×
/// as long).
#[inline(always)]
#[allow(clippy::too_many_arguments)]
fn offer_to_lanes(
    x: &[f32; LANES],
    y: &[f32; LANES],
    z: &[f32; LANES],
    distance: &mut [f32; LANES],
    id: &mut [u32; LANES],
    px: f32,
    py: f32,
    pz: f32,
    p_id: u32,
) {
    for l in 0..LANES {
        let (dx, dy, dz) = (x[l] - px, y[l] - py, z[l] - pz);
        let d = (dx * dx + dy * dy) + dz * dz;
        let wins = (d < distance[l]) | ((d == distance[l]) & (p_id < id[l]));
        distance[l] = if wins { d } else { distance[l] };
        id[l] = if wins { p_id } else { id[l] };
    }
}

/// Independent bests a group keeps while it meets a leaf (a power of two dividing
/// [`LEAF_SIZE`]).
const CHAINS: usize = 2;

/// Each lane keeps the better of its best and `other`'s, by [`better`]'s rule.
#[inline(always)]
fn keep_better_of_lanes(distance: &mut [f32; LANES], id: &mut [u32; LANES], other_distance: &[f32; LANES], other_id: &[u32; LANES]) {
    for l in 0..LANES {
        let wins = (other_distance[l] < distance[l]) | ((other_distance[l] == distance[l]) & (other_id[l] < id[l]));
        distance[l] = if wins { other_distance[l] } else { distance[l] };
        id[l] = if wins { other_id[l] } else { id[l] };
    }
}

/// A leaf's [`LEAF_SIZE`] slots, borrowed from the index's arrays.
struct LeafSlots<'a> {
    xs: &'a [f32; LEAF_SIZE],
    ys: &'a [f32; LEAF_SIZE],
    zs: &'a [f32; LEAF_SIZE],
    ids: &'a [u32; LEAF_SIZE],
}

/// The best candidate so far: its distance, original index and slot in tree order.
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

/// The class of every indexed point, and of every leaf whose points share one: what lets
/// an association answer a query's class without finding its nearest point.
pub struct PointClasses {
    /// The class of each point, by its index in the map.
    of_point: Vec<u32>,
    /// The class every point of a leaf has, [`PointClasses::MIXED`] where they differ.
    of_leaf: Vec<u32>,
}

impl PointClasses {
    /// A leaf whose points are of more than one class.
    const MIXED: u32 = u32::MAX;

    /// The class of every lane's best point, [`PointClasses::MIXED`] unless they share one.
    #[inline]
    fn group_class(&self, ids: &[u32; LANES]) -> u32 {
        let class = self.of_point[ids[0] as usize];
        if ids[1..].iter().all(|&id| self.of_point[id as usize] == class) { class } else { Self::MIXED }
    }

    /// The one class of every point in `leaves`, if they share one.
    #[inline]
    fn shared_by(&self, mut leaves: impl Iterator<Item = usize>) -> Option<u32> {
        let first = self.of_leaf[leaves.next()?];
        (first != Self::MIXED && leaves.all(|leaf| self.of_leaf[leaf] == first)).then_some(first)
    }
}

/// What an association gives each query: its nearest point's index, or that point's class.
#[derive(Clone, Copy)]
enum Answer<'a> {
    Point,
    Class(&'a PointClasses),
}

impl Answer<'_> {
    /// The answer for the indexed point `id`.
    #[inline(always)]
    fn of(self, id: u32) -> u32 {
        match self {
            Answer::Point => id,
            Answer::Class(classes) => classes.of_point[id as usize],
        }
    }
}

/// How a batch of queries was answered.
enum Batch {
    /// Each member holds its nearest point.
    Answered,
    /// Every candidate leaf's points are of this class, so every member's answer is.
    OneClass(u32),
    /// The members are too far from every point to share their search: answer them one by one.
    GaveUp,
}

/// The axis along which a box is widest (the split rule of the build).
fn widest_axis(lo: [f32; 3], hi: [f32; 3]) -> usize {
    (0..3).max_by(|&a, &b| (hi[a] - lo[a]).total_cmp(&(hi[b] - lo[b]))).expect("three axes")
}

impl NearestIndex {
    /// Build the index. Points must be finite (the map readers guarantee it) and fewer than 2³² − 1.
    pub fn build(points: &[[f32; 3]]) -> Self {
        let mut index = Self {
            len: 0,
            depth: 0,
            xs: Vec::new(),
            ys: Vec::new(),
            zs: Vec::new(),
            ids: Vec::new(),
            splits: Vec::new(),
            nodes: Vec::new(),
            batch_span: 0.0,
            build_order: Vec::new(),
        };
        index.rebuild(points);
        // Kept only by an index that is rebuilt.
        index.build_order = Vec::new();
        index
    }

    /// Index `points` instead, in the memory of the index before: the same index as
    /// [`NearestIndex::build`] makes. A scorer rebuilds one index map after map, since the
    /// fresh pages of a new one's arrays (about 30 bytes a point, build included) cost more
    /// to fault in than to fill on the virtual machines measured (docs/performance.md).
    pub fn rebuild(&mut self, points: &[[f32; 3]]) {
        assert!(!points.is_empty(), "cannot index an empty map");
        assert!(points.len() < u32::MAX as usize, "too many points for 32-bit ids");
        let n = points.len();
        let mut depth = 0u32;
        while n.div_ceil(1 << depth) > LEAF_SIZE {
            depth += 1;
        }
        // The build moves the points themselves (with their indices), not indices into
        // them: each level's passes then read memory in order.
        let mut order = std::mem::take(&mut self.build_order);
        order.clear();
        order.par_extend(points.par_iter().enumerate().map(|(id, &p)| IndexedPoint { p, id: id as u32 }));
        split(&mut order, depth);
        let first_leaf = 1usize << depth;
        let slots = first_leaf * LEAF_SIZE;
        (self.len, self.depth) = (n, depth);
        refill(&mut self.xs, slots, f32::INFINITY);
        refill(&mut self.ys, slots, f32::INFINITY);
        refill(&mut self.zs, slots, f32::INFINITY);
        refill(&mut self.ids, slots, u32::MAX);
        refill(&mut self.splits, first_leaf, Split { pivot: 0.0, axis: 0 });
        refill(&mut self.nodes, 2 * first_leaf, Node { min: [f32::INFINITY; 3], max: [f32::NEG_INFINITY; 3], min_id: u32::MAX });
        self.fill_leaves(&order, 1, 0..n);
        self.build_order = order;
        self.fill_inner_nodes();
        self.batch_span = BATCH_SPAN_LEAVES * self.typical_leaf_span();
    }

    /// Put the points `order[range]` of node `node` into its leaves, with their boxes: a
    /// range splits at its middle position, as the build split it.
    fn fill_leaves(&mut self, order: &[IndexedPoint], node: usize, range: std::ops::Range<usize>) {
        let first_leaf = 1usize << self.depth;
        if node < first_leaf {
            let mid = range.start + range.len() / 2;
            self.fill_leaves(order, 2 * node, range.start..mid);
            self.fill_leaves(order, 2 * node + 1, mid..range.end);
            return;
        }
        let leaf = node - first_leaf;
        let box_ = &mut self.nodes[node];
        for (slot, &IndexedPoint { p, id }) in (leaf * LEAF_SIZE..).zip(&order[range]) {
            (self.xs[slot], self.ys[slot], self.zs[slot], self.ids[slot]) = (p[0], p[1], p[2], id);
            for a in 0..3 {
                box_.min[a] = box_.min[a].min(p[a]);
                box_.max[a] = box_.max[a].max(p[a]);
            }
            box_.min_id = box_.min_id.min(id);
        }
    }

    /// Boxes bottom-up, and the split plane the build used at each node.
    fn fill_inner_nodes(&mut self) {
        let first_leaf = 1usize << self.depth;
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

    /// The median squared diagonal of the leaves' boxes.
    fn typical_leaf_span(&self) -> f32 {
        let first_leaf = 1usize << self.depth;
        let mut spans: Vec<f32> = self.nodes[first_leaf..].iter().map(|n| span(n.min, n.max)).collect();
        let mid = spans.len() / 2;
        *spans.select_nth_unstable_by(mid, f32::total_cmp).1
    }

    /// The slots of leaf `leaf` (0-based, left to right): coordinates and original indices.
    #[inline(always)]
    fn leaf_slots(&self, leaf: usize) -> LeafSlots<'_> {
        let slots = leaf * LEAF_SIZE..(leaf + 1) * LEAF_SIZE;
        LeafSlots {
            xs: self.xs[slots.clone()].try_into().expect("a leaf's slots"),
            ys: self.ys[slots.clone()].try_into().expect("a leaf's slots"),
            zs: self.zs[slots.clone()].try_into().expect("a leaf's slots"),
            ids: self.ids[slots].try_into().expect("a leaf's slots"),
        }
    }

    /// Improve `best` with every point of leaf `leaf` (0-based, left to right): the
    /// distances of all slots with fixed-width arithmetic, then, only if one of them can
    /// win, the tie rule slot by slot.
    #[inline(always)]
    fn scan_leaf(&self, q: [f32; 3], leaf: usize, best: &mut Best) {
        let start = leaf * LEAF_SIZE;
        let LeafSlots { xs, ys, zs, ids } = self.leaf_slots(leaf);
        let distances: [f32; LEAF_SIZE] = std::array::from_fn(|i| squared_distance(q, xs[i], ys[i], zs[i]));
        let reach = best.distance;
        if !distances.iter().fold(false, |hit, &d| hit | (d <= reach)) {
            return;
        }
        for (i, (&d, &id)) in distances.iter().zip(ids).enumerate() {
            if better(d, id, best) {
                *best = Best { distance: d, id, position: start + i };
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

    /// The candidate at slot `position`, as seen from `q`.
    #[inline(always)]
    fn candidate(&self, q: [f32; 3], position: usize) -> Best {
        Best { distance: squared_distance(q, self.xs[position], self.ys[position], self.zs[position]), id: self.ids[position], position }
    }

    /// The nearest point to `q`, starting from the candidate at slot `hint` (a
    /// neighbour's answer, whose coordinates are still in cache).
    fn nearest_from(&self, q: [f32; 3], hint: usize) -> Best {
        let mut best = self.candidate(q, hint);
        self.search(q, 1, &mut best);
        best
    }

    /// Index of the nearest indexed point to `q` (ties to the lowest index).
    pub fn nearest(&self, q: [f32; 3]) -> u32 {
        self.nearest_from(q, 0).id
    }

    /// The classes of the indexed points (`of_point[i]` is point `i`'s, below `u32::MAX`),
    /// for the associations that answer classes.
    pub fn point_classes(&self, of_point: &[u32]) -> PointClasses {
        assert_eq!(of_point.len(), self.len, "one class per indexed point");
        assert!(!of_point.contains(&PointClasses::MIXED), "classes are below u32::MAX");
        let of_leaf = self
            .ids
            .chunks_exact(LEAF_SIZE)
            .map(|leaf| {
                let mut classes = leaf.iter().take_while(|&&id| id != u32::MAX).map(|&id| of_point[id as usize]);
                let first = classes.next().expect("every leaf holds points");
                if classes.all(|class| class == first) { first } else { PointClasses::MIXED }
            })
            .collect();
        PointClasses { of_point: of_point.to_vec(), of_leaf }
    }

    /// The leaves whose boxes come within `reach` (squared) of the box `lo..=hi`, into
    /// `leaves`; false, with `leaves` incomplete, if there are more than `most`.
    fn leaves_within(&self, lo: [f32; 3], hi: [f32; 3], reach: f32, most: usize, leaves: &mut Vec<u32>) -> bool {
        leaves.clear();
        let first_leaf = 1usize << self.depth;
        // Down from the root while the split planes alone leave one side within reach: the
        // points on the other side are beyond the plane, and rounding is monotone, so their
        // boxes' bounds would exceed `reach` too.
        let mut start = 1;
        while start < first_leaf {
            let Split { pivot, axis } = self.splits[start];
            let axis = axis as usize;
            let (below, above) = (pivot - hi[axis], lo[axis] - pivot);
            if below > 0.0 && below * below > reach {
                start *= 2;
            } else if above > 0.0 && above * above > reach {
                start = 2 * start + 1;
            } else {
                break;
            }
        }
        // Depth-first: each step pops one node and pushes at most two, so the stack
        // never holds more than one node a level plus one.
        let mut stack = [0usize; 66];
        let mut top = 1;
        stack[0] = start;
        while top > 0 {
            top -= 1;
            let node = stack[top];
            if box_box_bound(lo, hi, &self.nodes[node]) > reach {
                continue;
            }
            if node >= first_leaf {
                if leaves.len() == most {
                    return false;
                }
                leaves.push((node - first_leaf) as u32);
            } else {
                stack[top] = 2 * node + 1;
                stack[top + 1] = 2 * node;
                top += 2;
            }
        }
        true
    }

    /// Answer queries `0..count` (neighbours in space follow each other), giving each
    /// query's answer to `record`. Consecutive queries whose box stays within about two
    /// leaves' size form a batch, answered together ([`NearestIndex::answer_batch`]).
    fn answer_batches(&self, count: usize, query: impl Fn(usize) -> [f32; 3], answer: Answer<'_>, mut record: impl FnMut(usize, u32)) {
        let mut leaves = Vec::with_capacity(FAR_BATCH_LEAVES);
        let mut members = Members::new();
        let mut start = 0;
        while start < count {
            let (end, lo, hi) = self.next_batch(start, count, &query);
            members.gather((start..end).map(&query));
            match self.answer_batch(&mut members, lo, hi, &mut leaves, answer) {
                Batch::Answered => {
                    for (k, value) in (start..end).zip(members.answers(answer)) {
                        record(k, value);
                    }
                }
                Batch::OneClass(class) => (start..end).for_each(|k| record(k, class)),
                Batch::GaveUp => {
                    // The batch's centre was searched for before it gave up: its answer is
                    // the nearest start.
                    let mut hint = members.warm_slot;
                    for k in start..end {
                        let best = self.nearest_from(query(k), hint);
                        hint = best.position;
                        record(k, answer.of(best.id));
                    }
                }
            }
            start = end;
        }
    }

    /// The batch of queries from `start`: up to `end`, the first query that would make its
    /// box `lo..=hi` span more than the batch may (or [`BATCH_QUERIES`] of them, or the
    /// last query). Queries join [`LANES`] at a time while their box stays within the span
    /// (the boxes of fewer are inside it, and their computed spans no larger), then one by
    /// one: the batch is the same as one query at a time makes, with one check in eight.
    #[inline(always)]
    fn next_batch(&self, start: usize, count: usize, query: &impl Fn(usize) -> [f32; 3]) -> (usize, [f32; 3], [f32; 3]) {
        let grow = |lo: [f32; 3], hi: [f32; 3], q: [f32; 3]| -> ([f32; 3], [f32; 3]) {
            (std::array::from_fn(|a| smaller(lo[a], q[a])), std::array::from_fn(|a| larger(hi[a], q[a])))
        };
        let last = count.min(start + BATCH_QUERIES);
        let (mut lo, mut hi) = (query(start), query(start));
        let mut end = start + 1;
        while end + LANES <= last {
            let (mut chunk_lo, mut chunk_hi) = (lo, hi);
            for k in end..end + LANES {
                (chunk_lo, chunk_hi) = grow(chunk_lo, chunk_hi, query(k));
            }
            if span(chunk_lo, chunk_hi) > self.batch_span {
                break;
            }
            (lo, hi, end) = (chunk_lo, chunk_hi, end + LANES);
        }
        while end < last {
            let (grown_lo, grown_hi) = grow(lo, hi, query(end));
            if span(grown_lo, grown_hi) > self.batch_span {
                break;
            }
            (lo, hi, end) = (grown_lo, grown_hi, end + 1);
        }
        (end, lo, hi)
    }

    /// Answer a batch of `members` inside the box `lo..=hi`: the leaf holding the box's
    /// centre first (each member's nearest point in it bounds that member's answer, so
    /// the largest of those bounds every answer), then every other leaf within that bound
    /// of the box. If those leaves are more than [`BATCH_LEAVES`], the centre's own nearest
    /// point is found first and the members meet its leaf, a bound as tight as the batch is
    /// small. [`Batch::GaveUp`], with the answers incomplete, if the leaves within that
    /// bound are more than [`FAR_BATCH_LEAVES`]: the members are then better searched one
    /// by one. When classes are the answer and every leaf that can hold an answer holds
    /// points of one class, [`Batch::OneClass`] before the members meet them.
    fn answer_batch(&self, members: &mut Members, lo: [f32; 3], hi: [f32; 3], leaves: &mut Vec<u32>, answer: Answer<'_>) -> Batch {
        let center: [f32; 3] = std::array::from_fn(|a| 0.5 * (lo[a] + hi[a]));
        let home = self.home_leaf(center);
        members.warm_slot = home * LEAF_SIZE;
        self.scan_leaf_for_members(home, members);
        // Every leaf holds points, so every member's best is now a real point.
        let mut anchor = home;
        if !self.leaves_within(lo, hi, members.reach(), BATCH_LEAVES, leaves) {
            let center_answer = self.nearest_from(center, members.warm_slot);
            members.warm_slot = center_answer.position;
            anchor = center_answer.position / LEAF_SIZE;
            if anchor != home {
                self.scan_leaf_for_members(anchor, members);
            }
            if !self.leaves_within(lo, hi, members.reach(), FAR_BATCH_LEAVES, leaves) {
                return Batch::GaveUp;
            }
        }
        // Every member's answer lies in one of these leaves.
        if let Answer::Class(classes) = answer
            && let Some(class) = classes.shared_by([home, anchor].into_iter().chain(leaves.iter().map(|&leaf| leaf as usize)))
        {
            return Batch::OneClass(class);
        }
        let others = leaves.iter().map(|&leaf| leaf as usize).filter(|&leaf| leaf != home && leaf != anchor);
        match answer {
            Answer::Point => others.for_each(|leaf| self.scan_leaf_for_members(leaf, members)),
            Answer::Class(classes) => (0..members.groups).for_each(|g| self.settle_class_of_group(members, g, others.clone(), classes)),
        }
        Batch::Answered
    }

    /// Meet group `g` with `leaves` (those that may hold its answers and it has not met),
    /// when classes are the answer. While every lane's best is of one class, a leaf of that
    /// class cannot change any answer's class: it is passed over. If a leaf of another class
    /// then gives a lane a best of another class, the group meets the leaves passed over;
    /// else every answer is of the class, which the group keeps instead of its lanes' points.
    fn settle_class_of_group(&self, members: &mut Members, g: usize, leaves: impl Iterator<Item = usize> + Clone, classes: &PointClasses) {
        let class = classes.group_class(&members.id[g]);
        // Where the class stopped being every lane's (at once if it never was).
        let mut broken_at = (class == PointClasses::MIXED).then_some(0);
        for (k, leaf) in leaves.clone().enumerate() {
            if broken_at.is_none() && classes.of_leaf[leaf] == class {
                continue;
            }
            if self.scan_leaf_for_group(leaf, members, g) && broken_at.is_none() && classes.group_class(&members.id[g]) != class {
                broken_at = Some(k);
            }
        }
        match broken_at {
            None => members.class[g] = class,
            Some(k) => leaves.take(k).filter(|&leaf| classes.of_leaf[leaf] == class).for_each(|leaf| _ = self.scan_leaf_for_group(leaf, members, g)),
        }
    }

    /// The home leaf of `q`: the leaf whose cell holds it, found by split planes alone,
    /// no box consulted.
    fn home_leaf(&self, q: [f32; 3]) -> usize {
        let first_leaf = 1usize << self.depth;
        let mut node = 1;
        while node < first_leaf {
            let Split { pivot, axis } = self.splits[node];
            node = 2 * node + usize::from(q[axis as usize] > pivot);
        }
        node - first_leaf
    }

    /// Improve every member's best with the points of leaf `leaf`, skipping the groups
    /// of lanes of which the leaf's box cannot improve any.
    #[inline(always)]
    fn scan_leaf_for_members(&self, leaf: usize, members: &mut Members) {
        for g in 0..members.groups {
            self.scan_leaf_for_group(leaf, members, g);
        }
    }

    /// Improve the best of every lane of group `g` with the points of leaf `leaf`, unless
    /// the leaf's box cannot improve any; whether it was met.
    #[inline(always)]
    fn scan_leaf_for_group(&self, leaf: usize, members: &mut Members, g: usize) -> bool {
        let node = &self.nodes[(1usize << self.depth) + leaf];
        let improves = members.may_improve(g, node);
        if improves {
            let LeafSlots { xs, ys, zs, ids } = self.leaf_slots(leaf);
            // The group on the stack while it meets the leaf: the compiler then keeps its
            // lanes in vector registers (working on `members` in place, it did not).
            let (x, y, z) = (members.x[g], members.y[g], members.z[g]);
            // Each lane's best is the least (distance, index) pair, whatever the order the
            // pairs are compared in: the slots go to [`CHAINS`] bests at once, merged at
            // the end, so no slot waits for the one before it.
            let mut distance = [[f32::INFINITY; LANES]; CHAINS];
            let mut id = [[u32::MAX; LANES]; CHAINS];
            (distance[0], id[0]) = (members.distance[g], members.id[g]);
            for slots in (0..LEAF_SIZE).step_by(CHAINS) {
                for c in 0..CHAINS {
                    let slot = slots + c;
                    offer_to_lanes(&x, &y, &z, &mut distance[c], &mut id[c], xs[slot], ys[slot], zs[slot], ids[slot]);
                }
            }
            let mut width = CHAINS;
            while width > 1 {
                width /= 2;
                for c in 0..width {
                    let (other_distance, other_id) = (distance[c + width], id[c + width]);
                    keep_better_of_lanes(&mut distance[c], &mut id[c], &other_distance, &other_id);
                }
            }
            (members.distance[g], members.id[g]) = (distance[0], id[0]);
        }
        improves
    }

    /// The nearest indexed point of every query, in parallel, whatever the queries'
    /// order (as [`NearestIndex::nearest_by_block`], gathered in the queries' order).
    pub fn nearest_all(&self, queries: &[[f32; 3]]) -> Vec<u32> {
        let mut out = vec![0u32; queries.len()];
        self.nearest_by_block(queries, |answers| {
            for (query, id) in answers.pairs() {
                out[query] = id;
            }
        });
        out
    }

    /// The nearest indexed point of every query, in parallel, whatever the queries' order,
    /// given to `visit` block by block ([`BlockAnswers`], each query once): each block of
    /// queries is visited along a Z-order curve over the index's box, so consecutive
    /// queries are neighbours, and answered in batches of neighbours that share the search
    /// for their candidate leaves. A block is a quarter of the queries, kept within 2²⁰ to
    /// 2²², so the ordering takes no more memory than an answer array would for a large
    /// cloud.
    pub fn nearest_by_block(&self, queries: &[[f32; 3]], visit: impl FnMut(BlockAnswers<'_>)) {
        self.answer_by_block(queries, Answer::Point, visit);
    }

    /// As [`NearestIndex::nearest_by_block`], each query given the class of its nearest
    /// point instead of its index.
    pub fn nearest_classes_by_block(&self, queries: &[[f32; 3]], classes: &PointClasses, visit: impl FnMut(BlockAnswers<'_>)) {
        self.answer_by_block(queries, Answer::Class(classes), visit);
    }

    fn answer_by_block(&self, queries: &[[f32; 3]], answer: Answer<'_>, mut visit: impl FnMut(BlockAnswers<'_>)) {
        let grid = ZGrid::over(self.nodes[1].min, self.nodes[1].max);
        let block_len = locality_block(queries.len());
        // The block's keys in Z-order, then its answers in that order in the sort's spare buffer.
        let mut keys = ZOrderKeys::default();
        for (first, block) in (0..).step_by(block_len).zip(queries.chunks(block_len)) {
            keys.sort(&grid, block);
            let (sorted, found) = (&keys.sorted, &keys.spare);
            found.par_chunks(QUERY_CHUNK).zip(sorted.par_chunks(QUERY_CHUNK)).for_each(|(found, keys)| {
                // The chunk's queries gathered first, in a loop of independent loads
                // (48 KiB): read as batches form, each one waited for, the same
                // answers took 1.2-1.3x as long in random order.
                let chunk: Vec<[f32; 3]> = keys.iter().map(|key| block[position_of(key)]).collect();
                self.answer_batches(
                    chunk.len(),
                    |k| chunk[k],
                    answer,
                    |k, found_k| found[k].store(((position_of(&keys[k]) as u64) << 32) | u64::from(found_k), Relaxed),
                )
            });
            visit(BlockAnswers { first, pairs: found });
        }
    }
}

/// The answers of one block of queries, in the order they were answered (along the
/// curve, not the queries' order): each query of the block with its nearest point (or
/// that point's class).
pub struct BlockAnswers<'a> {
    /// The block's first query.
    first: usize,
    /// A query's position in the block in the high half, its answer in the low half.
    pairs: &'a [AtomicU64],
}

impl BlockAnswers<'_> {
    /// Every (query, index of its nearest point) pair of the block, queries numbered in
    /// all the queries.
    pub fn pairs(&self) -> impl Iterator<Item = (usize, u32)> + '_ {
        self.pairs.iter().map(|pair| self.pair(pair))
    }

    /// The pairs in parts of at most `part` pairs, to be taken in parallel.
    pub fn par_parts(&self, part: usize) -> impl IndexedParallelIterator<Item = impl Iterator<Item = (usize, u32)> + '_> + '_ {
        self.pairs.par_chunks(part).map(move |pairs| pairs.iter().map(move |pair| self.pair(pair)))
    }

    #[inline(always)]
    fn pair(&self, pair: &AtomicU64) -> (usize, u32) {
        let pair = pair.load(Relaxed);
        (self.first + (pair >> 32) as usize, pair as u32)
    }
}

impl NearestIndex {
    /// The nearest indexed point of every query, in parallel, answered in the queries' own
    /// order, which must already visit neighbours in space one after another — a cloud put
    /// in [`super::z_order::z_order`] once and scored against several maps — else this is
    /// slower than [`NearestIndex::nearest_all`] (the answers are the same).
    pub fn nearest_all_in_order(&self, queries: &[[f32; 3]]) -> Vec<u32> {
        let mut out = Vec::new();
        self.answer_in_order(queries, Answer::Point, &mut out);
        out
    }

    /// The class of the nearest indexed point of every query (`classes` of
    /// [`NearestIndex::nearest_all_in_order`]'s answers), in the queries' own order, which
    /// must visit neighbours one after another. Batches whose candidate leaves all hold
    /// points of one class are answered without searching for each member's nearest point.
    pub fn nearest_classes_in_order(&self, queries: &[[f32; 3]], classes: &PointClasses) -> Vec<u32> {
        let mut out = Vec::new();
        self.nearest_classes_in_order_into(queries, classes, &mut out);
        out
    }

    /// [`NearestIndex::nearest_classes_in_order`] into `out` (made as long as `queries`),
    /// in the memory `out` has when that is enough: a scorer keeps one answer array from
    /// map to map.
    pub fn nearest_classes_in_order_into(&self, queries: &[[f32; 3]], classes: &PointClasses, out: &mut Vec<u32>) {
        self.answer_in_order(queries, Answer::Class(classes), out);
    }

    fn answer_in_order(&self, queries: &[[f32; 3]], answer: Answer<'_>, out: &mut Vec<u32>) {
        resize_to_overwrite(out, queries.len());
        out.par_chunks_mut(QUERY_CHUNK)
            .zip(queries.par_chunks(QUERY_CHUNK))
            .for_each(|(found, qs)| self.answer_batches(qs.len(), |k| qs[k], answer, |k, value| found[k] = value));
    }
}

/// A point with its index in the map, as the build moves it.
#[derive(Debug, Clone, Copy)]
struct IndexedPoint {
    p: [f32; 3],
    id: u32,
}

/// Reorder `order` into a balanced k-d tree of `depth` levels: each range is split at
/// its middle position along the widest axis of its points.
fn split(order: &mut [IndexedPoint], depth: u32) {
    if depth == 0 || order.len() < 2 {
        return;
    }
    let (mut lo, mut hi) = ([f32::INFINITY; 3], [f32::NEG_INFINITY; 3]);
    for item in order.iter() {
        for a in 0..3 {
            // Plain comparisons: the same box as `f32::min` and `f32::max` give, up to
            // the sign of zero (a NaN never wins), with less work for the NaN check.
            let v = item.p[a];
            lo[a] = if v < lo[a] { v } else { lo[a] };
            hi[a] = if v > hi[a] { v } else { hi[a] };
        }
    }
    let axis = widest_axis(lo, hi);
    let mid = order.len() / 2;
    // Coordinates are finite, so `<` orders them totally (±0 as equals, as a split plane
    // compares them too), in fewer instructions than `total_cmp`.
    order.select_nth_unstable_by(mid, |a, b| {
        let (x, y) = (a.p[axis], b.p[axis]);
        if x < y {
            std::cmp::Ordering::Less
        } else if x > y {
            std::cmp::Ordering::Greater
        } else {
            std::cmp::Ordering::Equal
        }
    });
    let (left, right) = order.split_at_mut(mid);
    if left.len() > 1 << 14 {
        rayon::join(|| split(left, depth - 1), || split(right, depth - 1));
    } else {
        split(left, depth - 1);
        split(right, depth - 1);
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::synthetic::Rng;

    /// A thin noisy surface of `n` points over 2 m × 2 m, as a map of a floor is.
    fn surface(rng: &mut Rng, n: usize) -> Vec<[f32; 3]> {
        (0..n).map(|_| [rng.range(0.0, 2.0) as f32, rng.range(0.0, 2.0) as f32, rng.range(-0.01, 0.01) as f32]).collect()
    }

    #[test]
    fn batches_half_a_metre_above_a_surface_are_bounded_by_their_centres_answer() {
        // The geometry of `dense_queries_half_a_metre_from_every_point_are_answered_exactly`
        // (tests/it/nearest.rs), which relies on this: for most batches the home leaf's
        // bound reaches more than BATCH_LEAVES leaves, the bound of the centre's answer
        // at most FAR_BATCH_LEAVES, and the answers are exact.
        let mut rng = Rng::new(38);
        let points = surface(&mut rng, 30_000);
        let index = NearestIndex::build(&points);
        let (mut members, mut leaves) = (Members::new(), Vec::new());
        let mut bounded_by_centre = 0;
        for place in 0..100 {
            // 64 queries 7 mm apart, 2 cm up and down, at a place on a 10 × 10 grid over
            // the surface: a box about as large as a batch may be.
            let corner = [0.1 + 0.18 * (place % 10) as f32, 0.1 + 0.18 * (place / 10) as f32];
            let queries: Vec<[f32; 3]> =
                (0..64).map(|i| [corner[0] + 0.007 * (i % 8) as f32, corner[1] + 0.007 * (i / 8) as f32, 0.48 + 0.04 * (i % 2) as f32]).collect();
            let lo: [f32; 3] = std::array::from_fn(|a| queries.iter().map(|q| q[a]).fold(f32::INFINITY, f32::min));
            let hi: [f32; 3] = std::array::from_fn(|a| queries.iter().map(|q| q[a]).fold(f32::NEG_INFINITY, f32::max));
            assert!(span(lo, hi) <= index.batch_span, "one batch: {} > {}", span(lo, hi), index.batch_span);
            members.gather(queries.iter().copied());
            let home = index.home_leaf(std::array::from_fn(|a| 0.5 * (lo[a] + hi[a])));
            index.scan_leaf_for_members(home, &mut members);
            if index.leaves_within(lo, hi, members.reach(), BATCH_LEAVES, &mut leaves) {
                continue;
            }
            members.gather(queries.iter().copied());
            let shared = index.answer_batch(&mut members, lo, hi, &mut leaves, Answer::Point);
            assert!(matches!(shared, Batch::Answered), "place {place}: shared within the centre's answer's bound");
            let exhaustive: Vec<u32> = queries.iter().map(|&q| nearest_brute_force(&points, q)).collect();
            assert_eq!(members.answers(Answer::Point).collect::<Vec<_>>(), exhaustive, "place {place}");
            bounded_by_centre += 1;
        }
        assert!(bounded_by_centre >= 50, "{bounded_by_centre} of 100 batches bounded by their centre's answer");
    }

    #[test]
    fn a_batch_whose_candidate_leaves_share_a_class_takes_it_without_searching() {
        // Two halves of a surface, class 0 left of x = 1 and class 1 right of it.
        let mut rng = Rng::new(41);
        let points = surface(&mut rng, 30_000);
        let of_point: Vec<u32> = points.iter().map(|p| u32::from(p[0] > 1.0)).collect();
        let index = NearestIndex::build(&points);
        let classes = index.point_classes(&of_point);
        let (mut members, mut leaves) = (Members::new(), Vec::new());
        let mut outcome = |x: f32, step: f32| {
            // 16 queries `step` apart on the surface, from (x, 1) on.
            let queries: Vec<[f32; 3]> = (0..16).map(|i| [x + step * (i % 4) as f32, 1.0 + 0.002 * (i / 4) as f32, 0.0]).collect();
            let lo: [f32; 3] = std::array::from_fn(|a| queries.iter().map(|q| q[a]).fold(f32::INFINITY, f32::min));
            let hi: [f32; 3] = std::array::from_fn(|a| queries.iter().map(|q| q[a]).fold(f32::NEG_INFINITY, f32::max));
            members.gather(queries.iter().copied());
            let batch = index.answer_batch(&mut members, lo, hi, &mut leaves, Answer::Class(&classes));
            let exact: Vec<u32> = queries.iter().map(|&q| of_point[nearest_brute_force(&points, q) as usize]).collect();
            let answered: Vec<u32> = match batch {
                Batch::OneClass(class) => vec![class; queries.len()],
                _ => members.answers(Answer::Class(&classes)).collect(),
            };
            assert_eq!(answered, exact, "the classes of the exact answers");
            (batch, exact)
        };
        for x in [0.3, 1.6] {
            let (batch, _) = outcome(x, 0.002);
            let class = u32::from(x > 1.0);
            assert!(matches!(batch, Batch::OneClass(c) if c == class), "inside the half of class {class}");
        }
        let (batch, exact) = outcome(0.985, 0.01);
        assert!(matches!(batch, Batch::Answered), "across the border the members are searched");
        assert!(exact.contains(&0) && exact.contains(&1), "the border's answers are of both classes");
    }

    #[test]
    fn a_block_is_a_quarter_of_the_queries_within_its_bounds() {
        assert_eq!(locality_block(1_000), 1 << 20, "small clouds: one block of the smallest size");
        assert_eq!(locality_block(5_000_000), 1_250_000, "four blocks of 5 M");
        assert_eq!(locality_block(20_000_000), 1 << 22, "a 20 M cloud: blocks of the largest size");
        assert_eq!(locality_block(5_000_003), 1_250_001, "no block of a few queries left over");
        // The ordering's 16 bytes a query of a block never exceed 4 bytes a query of the
        // cloud (but for rounding up), once blocks are above the smallest size.
        for queries in [4 << 20, 10_000_000, 10_000_003, 16 << 20, 100_000_000] {
            assert!(16 * locality_block(queries) <= 4 * queries + 16, "{queries} queries");
        }
    }

    #[test]
    fn the_leaves_within_reach_are_those_whose_boxes_are_within_it() {
        let mut rng = Rng::new(7);
        let index = NearestIndex::build(&surface(&mut rng, 20_000));
        let first_leaf = 1usize << index.depth;
        let mut leaves = Vec::new();
        let mut descended = 0;
        for case in 0..300 {
            let corner = [rng.range(-0.2, 2.2) as f32, rng.range(-0.2, 2.2) as f32, rng.range(-0.3, 0.3) as f32];
            let size = rng.range(0.0, 0.05) as f32;
            let (lo, hi) = (corner, corner.map(|c| c + size));
            let reach = (rng.range(0.0, 0.2) as f32).powi(2);
            let complete = index.leaves_within(lo, hi, reach, usize::MAX, &mut leaves);
            assert!(complete);
            let every: Vec<u32> = (0..first_leaf as u32).filter(|&l| box_box_bound(lo, hi, &index.nodes[first_leaf + l as usize]) <= reach).collect();
            let mut found = leaves.clone();
            found.sort_unstable();
            assert_eq!(found, every, "case {case}: reach {reach} of {lo:?}..{hi:?}");
            descended += usize::from(every.len() < first_leaf / 4);
        }
        assert!(descended > 100, "most cases need a part of the tree: {descended}");
    }

    #[test]
    fn a_batch_takes_queries_while_their_box_stays_within_the_span_as_one_at_a_time_would() {
        let mut rng = Rng::new(11);
        let index = NearestIndex::build(&surface(&mut rng, 20_000));
        // A walk in stretches of small, middling and large steps: batches end at every length.
        let mut q = [1.0f32, 1.0, 0.0];
        let queries: Vec<[f32; 3]> = (0..20_000)
            .map(|i| {
                let step = [0.0005, 0.005, 0.02][(i / 500) % 3];
                q = [q[0] + rng.range(-step, step) as f32, q[1] + rng.range(-step, step) as f32, rng.range(-0.01, 0.01) as f32];
                q
            })
            .collect();
        let mut start = 0;
        let mut lengths = std::collections::BTreeSet::new();
        while start < queries.len() {
            let (end, lo, hi) = index.next_batch(start, queries.len(), &|k| queries[k]);
            // One at a time: the longest run from `start` whose box spans no more than the batch may.
            let (mut one_lo, mut one_hi, mut one_end) = (queries[start], queries[start], start + 1);
            while one_end < queries.len() && one_end - start < BATCH_QUERIES {
                let p = queries[one_end];
                let (grown_lo, grown_hi) = (std::array::from_fn(|a| one_lo[a].min(p[a])), std::array::from_fn(|a| one_hi[a].max(p[a])));
                if span(grown_lo, grown_hi) > index.batch_span {
                    break;
                }
                (one_lo, one_hi, one_end) = (grown_lo, grown_hi, one_end + 1);
            }
            assert_eq!((end, lo, hi), (one_end, one_lo, one_hi), "batch from {start}");
            lengths.insert(end - start);
            start = end;
        }
        assert!(lengths.len() > 40 && lengths.contains(&BATCH_QUERIES), "batches of many lengths: {lengths:?}");
    }
}
