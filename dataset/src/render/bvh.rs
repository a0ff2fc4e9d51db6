//! A bounding volume hierarchy over a world's triangles, for the rays the light bake casts
//! (ambient occlusion, shadows of the ceiling lights): built once per world with binned
//! surface-area splits, traversed nearest child first, each query told which triangles to
//! pass through (an object's own surface, the ceiling's fixtures).

use super::surface::Triangle;

/// Triangles a leaf holds at most.
const LEAF: usize = 4;
/// Candidate split planes per axis.
const BINS: usize = 12;

#[derive(Debug, Clone, Copy)]
struct Node {
    min: [f32; 3],
    max: [f32; 3],
    /// Leaf: first triangle (in `order`) and count; inner: the first child's index (the
    /// second follows it) and count 0.
    start: u32,
    count: u32,
}

/// A triangle as the intersection test wants it: a vertex and two edges.
#[derive(Debug, Clone, Copy)]
struct Tri {
    v0: [f32; 3],
    e1: [f32; 3],
    e2: [f32; 3],
}

/// The hierarchy: nodes, and the triangles in the order the leaves list them.
#[derive(Debug, Clone)]
pub struct Bvh {
    nodes: Vec<Node>,
    tris: Vec<Tri>,
    /// Each leaf slot's triangle index in the world.
    order: Vec<u32>,
}

/// A ray: origin, unit direction and how far it reaches.
#[derive(Debug, Clone, Copy)]
pub struct Ray {
    pub origin: [f32; 3],
    pub dir: [f32; 3],
    pub far: f32,
}

fn sub(a: [f32; 3], b: [f32; 3]) -> [f32; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

fn cross(a: [f32; 3], b: [f32; 3]) -> [f32; 3] {
    [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]
}

fn dot(a: [f32; 3], b: [f32; 3]) -> f32 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

fn area(min: [f32; 3], max: [f32; 3]) -> f32 {
    let d = sub(max, min);
    if d.iter().any(|v| *v < 0.0) { 0.0 } else { d[0] * d[1] + d[1] * d[2] + d[2] * d[0] }
}

#[derive(Clone, Copy)]
struct Bounds {
    min: [f32; 3],
    max: [f32; 3],
}

impl Bounds {
    const EMPTY: Bounds = Bounds { min: [f32::INFINITY; 3], max: [f32::NEG_INFINITY; 3] };

    fn grow(&mut self, p: [f32; 3]) {
        for k in 0..3 {
            self.min[k] = self.min[k].min(p[k]);
            self.max[k] = self.max[k].max(p[k]);
        }
    }

    fn join(&mut self, o: &Bounds) {
        self.grow(o.min);
        self.grow(o.max);
    }
}

impl Bvh {
    /// The hierarchy of `triangles`.
    pub fn build(triangles: &[Triangle]) -> Bvh {
        let positions: Vec<[[f32; 3]; 3]> = triangles.iter().map(|t| t.positions).collect();
        let boxes: Vec<Bounds> = positions
            .iter()
            .map(|t| {
                let mut b = Bounds::EMPTY;
                t.iter().for_each(|p| b.grow(*p));
                b
            })
            .collect();
        let centres: Vec<[f32; 3]> = boxes.iter().map(|b| std::array::from_fn(|k| (b.min[k] + b.max[k]) / 2.0)).collect();
        let mut order: Vec<u32> = (0..positions.len() as u32).collect();
        let mut nodes = vec![Node { min: [0.0; 3], max: [0.0; 3], start: 0, count: 0 }];
        let mut stack = vec![(0usize, 0usize, order.len())];
        while let Some((node, start, end)) = stack.pop() {
            let mut bounds = Bounds::EMPTY;
            let mut centre_bounds = Bounds::EMPTY;
            for &t in &order[start..end] {
                bounds.join(&boxes[t as usize]);
                centre_bounds.grow(centres[t as usize]);
            }
            nodes[node].min = bounds.min;
            nodes[node].max = bounds.max;
            let split = if end - start > LEAF { best_split(&order[start..end], &boxes, &centres, &centre_bounds) } else { None };
            let Some((axis, plane)) = split else {
                nodes[node].start = start as u32;
                nodes[node].count = (end - start) as u32;
                continue;
            };
            let mid = start + partition(&mut order[start..end], |t| centres[t as usize][axis] < plane);
            let mid = if mid == start || mid == end { start + (end - start) / 2 } else { mid };
            let first = nodes.len();
            nodes.push(Node { min: [0.0; 3], max: [0.0; 3], start: 0, count: 0 });
            nodes.push(Node { min: [0.0; 3], max: [0.0; 3], start: 0, count: 0 });
            nodes[node].start = first as u32;
            nodes[node].count = 0;
            stack.push((first, start, mid));
            stack.push((first + 1, mid, end));
        }
        let tris = order
            .iter()
            .map(|&t| {
                let [a, b, c] = positions[t as usize];
                Tri { v0: a, e1: sub(b, a), e2: sub(c, a) }
            })
            .collect();
        Bvh { nodes, tris, order }
    }

    /// The nearest hit of `ray` within its reach on a triangle `passes` does not let
    /// through (called with the world's triangle index), as its distance.
    pub fn nearest(&self, ray: &Ray, passes: impl Fn(u32) -> bool) -> Option<f32> {
        let mut far = ray.far;
        let mut hit = None;
        self.walk(ray, &mut far, &mut |slot, t| {
            if !passes(self.order[slot]) {
                hit = Some(t);
                return Some(t);
            }
            None
        });
        hit
    }

    /// Whether `ray` hits, within its reach, a triangle `passes` does not let through.
    pub fn occluded(&self, ray: &Ray, passes: impl Fn(u32) -> bool) -> bool {
        let mut far = ray.far;
        let mut found = false;
        self.walk(ray, &mut far, &mut |slot, _| {
            if !passes(self.order[slot]) {
                found = true;
                return Some(0.0);
            }
            None
        });
        found
    }

    /// Every triangle slot `ray` hits nearer than `far`, nearest boxes first; `on_hit` may
    /// shorten the ray (returning the new reach).
    fn walk(&self, ray: &Ray, far: &mut f32, on_hit: &mut dyn FnMut(usize, f32) -> Option<f32>) {
        let inv = ray.dir.map(|d| if d.abs() > 1e-12 { 1.0 / d } else { f32::INFINITY.copysign(d) });
        let mut stack = [0u32; 64];
        let mut top = 1;
        while top > 0 {
            top -= 1;
            let node = &self.nodes[stack[top] as usize];
            if node.count > 0 {
                for slot in node.start as usize..(node.start + node.count) as usize {
                    if let Some(t) = intersect(&self.tris[slot], ray, *far) {
                        if let Some(new_far) = on_hit(slot, t) {
                            *far = new_far;
                            if new_far <= 0.0 {
                                return;
                            }
                        }
                    }
                }
                continue;
            }
            let (a, b) = (node.start as usize, node.start as usize + 1);
            let (ta, tb) = (slab(&self.nodes[a], ray.origin, inv, *far), slab(&self.nodes[b], ray.origin, inv, *far));
            match (ta, tb) {
                (Some(x), Some(y)) => {
                    let (near, other) = if x <= y { (a, b) } else { (b, a) };
                    stack[top] = other as u32;
                    stack[top + 1] = near as u32;
                    top += 2;
                }
                (Some(_), None) => {
                    stack[top] = a as u32;
                    top += 1;
                }
                (None, Some(_)) => {
                    stack[top] = b as u32;
                    top += 1;
                }
                (None, None) => {}
            }
        }
    }
}

/// The best of [`BINS`] split planes per axis by the surface-area heuristic, if splitting
/// beats a leaf.
fn best_split(tris: &[u32], boxes: &[Bounds], centres: &[[f32; 3]], centre_bounds: &Bounds) -> Option<(usize, f32)> {
    let mut best: Option<(f32, usize, f32)> = None;
    for axis in 0..3 {
        let (lo, hi) = (centre_bounds.min[axis], centre_bounds.max[axis]);
        if hi - lo < 1e-6 {
            continue;
        }
        let mut bins = [(Bounds::EMPTY, 0usize); BINS];
        let scale = BINS as f32 / (hi - lo);
        for &t in tris {
            let b = (((centres[t as usize][axis] - lo) * scale) as usize).min(BINS - 1);
            bins[b].0.join(&boxes[t as usize]);
            bins[b].1 += 1;
        }
        for split in 1..BINS {
            let (mut left, mut right) = (Bounds::EMPTY, Bounds::EMPTY);
            let (mut nl, mut nr) = (0, 0);
            for (b, (bounds, n)) in bins.iter().enumerate() {
                if *n == 0 {
                    continue;
                }
                if b < split {
                    left.join(bounds);
                    nl += n;
                } else {
                    right.join(bounds);
                    nr += n;
                }
            }
            if nl == 0 || nr == 0 {
                continue;
            }
            let cost = area(left.min, left.max) * nl as f32 + area(right.min, right.max) * nr as f32;
            if best.is_none_or(|(c, _, _)| cost < c) {
                best = Some((cost, axis, lo + split as f32 / scale));
            }
        }
    }
    best.map(|(_, axis, plane)| (axis, plane))
}

/// Reorder `items` so those `left` accepts come first; returns how many.
fn partition(items: &mut [u32], left: impl Fn(u32) -> bool) -> usize {
    let mut first = 0;
    for i in 0..items.len() {
        if left(items[i]) {
            items.swap(first, i);
            first += 1;
        }
    }
    first
}

/// Where `ray` enters the box of `node` (before `far`), if it does.
fn slab(node: &Node, origin: [f32; 3], inv: [f32; 3], far: f32) -> Option<f32> {
    let (mut t0, mut t1) = (0.0f32, far);
    for k in 0..3 {
        let (a, b) = ((node.min[k] - origin[k]) * inv[k], (node.max[k] - origin[k]) * inv[k]);
        let (a, b) = if a <= b { (a, b) } else { (b, a) };
        // NaN (0 · ∞ on a box face) keeps the bound.
        if a > t0 {
            t0 = a;
        }
        if b < t1 {
            t1 = b;
        }
        if t0 > t1 {
            return None;
        }
    }
    Some(t0)
}

/// Möller–Trumbore: the distance along `ray` to `tri`, in (1e-5, far), either side.
fn intersect(tri: &Tri, ray: &Ray, far: f32) -> Option<f32> {
    let p = cross(ray.dir, tri.e2);
    let det = dot(tri.e1, p);
    if det.abs() < 1e-12 {
        return None;
    }
    let inv = 1.0 / det;
    let s = sub(ray.origin, tri.v0);
    let u = dot(s, p) * inv;
    if !(0.0..=1.0).contains(&u) {
        return None;
    }
    let q = cross(s, tri.e1);
    let v = dot(ray.dir, q) * inv;
    if v < 0.0 || u + v > 1.0 {
        return None;
    }
    let t = dot(tri.e2, q) * inv;
    (t > 1e-5 && t < far).then_some(t)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn quad(id: u16, y: f32, lo: f32, hi: f32) -> [Triangle; 2] {
        let t = |p: [[f32; 3]; 3]| Triangle { positions: p, normals: [[0.0, 1.0, 0.0]; 3], uvs: [[0.0; 2]; 3], surface: 0, class_id: 1, instance_id: id };
        [t([[lo, y, lo], [hi, y, lo], [hi, y, hi]]), t([[lo, y, lo], [hi, y, hi], [lo, y, hi]])]
    }

    #[test]
    fn rays_find_the_nearest_surface_they_do_not_pass_through_among_many() {
        // A stack of 40 horizontal squares, 10 cm apart, of alternating instances.
        let triangles: Vec<Triangle> = (0..40).flat_map(|k| quad((k % 2) as u16 + 1, k as f32 * 0.1, -1.0, 1.0)).collect();
        let bvh = Bvh::build(&triangles);
        let up = Ray { origin: [0.3, 0.05, -0.2], dir: [0.0, 1.0, 0.0], far: 10.0 };
        let t = bvh.nearest(&up, |_| false).unwrap();
        assert!((t - 0.05).abs() < 1e-5, "{t}");
        // Passing through instance 2 (odd squares): the next is at 0.2.
        let t = bvh.nearest(&up, |i| triangles[i as usize].instance_id == 2).unwrap();
        assert!((t - 0.15).abs() < 1e-5, "{t}");
        assert!(bvh.occluded(&up, |_| false));
        assert!(!bvh.occluded(&Ray { far: 0.04, ..up }, |_| false), "nothing within its reach");
        let beside = Ray { origin: [1.5, 0.05, 0.0], dir: [0.0, 1.0, 0.0], far: 10.0 };
        assert!(bvh.nearest(&beside, |_| false).is_none(), "beside the stack");
        let slanted = Ray { origin: [-0.9, 0.05, 0.0], dir: [0.6, 0.8, 0.0], far: 10.0 };
        let t = bvh.nearest(&slanted, |_| false).unwrap();
        assert!((t - 0.0625).abs() < 1e-4, "{t}");
    }
}
