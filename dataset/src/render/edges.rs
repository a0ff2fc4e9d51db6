//! Which pixel centres a screen triangle covers: its three edges as signed distances in
//! pixels, set up in f64 at the first pixel of its box and stepped in f32, and the one run
//! of covered pixels each row of the box holds.

/// A pixel centre within 10⁻³ pixel of an edge counts as inside: on an edge shared by two
/// triangles, at least one draws it.
const EDGE_TOLERANCE_PIXELS: f32 = -1e-3;

/// Whether a pixel centre, at these signed distances in pixels from a triangle's three
/// edges, is covered. Either winding is: both faces are drawn. A NaN distance does not
/// rule a pixel out.
fn covers(distances: [f32; 3]) -> bool {
    !distances.iter().any(|&d| d < EDGE_TOLERANCE_PIXELS)
}

/// A column (or row) offset inside a box, as a float: exact, since boxes are clamped to the
/// image. (Through `u32`, which converts in one instruction, where `usize` takes several.)
pub(super) fn column(offset: usize) -> f32 {
    offset as u32 as f32
}

/// Each edge's distance at (`dx`, `dy`) from its value at the box's first pixel and its
/// steps: e₀ + e₁·dx + e₂·dy, in this order (the rounding is part of what the pixels are).
#[inline]
fn distances_at(distance: &[[f32; 3]; 3], dx: f32, dy: f32) -> [f32; 3] {
    distance.map(|e| e[0] + e[1] * dx + e[2] * dy)
}

/// A triangle's edges over the columns `first..=last` of its box, as signed distances in
/// pixels: each barycentric coordinate divided by the length of its gradient, so their
/// rounding is a fraction of a pixel however large the triangle.
#[derive(Debug, Clone)]
pub(super) struct Edges {
    /// Per edge (opposite vertex k): the distance at the box's first pixel, its change per
    /// pixel to the right and per pixel down.
    distance: [[f32; 3]; 3],
    /// Lengths of the gradients of barycentrics 1 and 2: a distance times its length is
    /// the barycentric coordinate again.
    pub(super) gradient_lengths: [f32; 2],
    first: usize,
    last: usize,
    /// Every distance is finite, hence monotone along a row (see `for_each_covered_in_row`).
    finite: bool,
    /// Where the last covered run began: the next row's walk starts there.
    start: usize,
}

impl Edges {
    /// The edges of the screen triangle `xy`, of doubled signed area `area` (not zero), over
    /// a box whose first pixel is (`first`, `top`) and whose last column is `last`.
    #[inline]
    pub(super) fn new(xy: [[f64; 2]; 3], area: f64, first: usize, top: usize, last: usize) -> Self {
        let [a, b, c] = xy;
        let inv_area = 1.0 / area;
        let (x0, y0) = (first as f64, top as f64);
        let l0 = [((b[0] - x0) * (c[1] - y0) - (b[1] - y0) * (c[0] - x0)) * inv_area, (b[1] - c[1]) * inv_area, (c[0] - b[0]) * inv_area];
        let l1 = [((c[0] - x0) * (a[1] - y0) - (c[1] - y0) * (a[0] - x0)) * inv_area, (c[1] - a[1]) * inv_area, (a[0] - c[0]) * inv_area];
        let l2 = [1.0 - l0[0] - l1[0], -l0[1] - l1[1], -l0[2] - l1[2]];
        let per_pixel = |l: [f64; 3]| {
            let g = (l[1] * l[1] + l[2] * l[2]).sqrt();
            (g as f32, [(l[0] / g) as f32, (l[1] / g) as f32, (l[2] / g) as f32])
        };
        let ((_, e0), (g1, e1), (g2, e2)) = (per_pixel(l0), per_pixel(l1), per_pixel(l2));
        let distance = [e0, e1, e2];
        let finite = distance.iter().flatten().all(|v| v.is_finite());
        Edges { distance, gradient_lengths: [g1, g2], first, last, finite, start: first }
    }

    /// The distances of the pixel `dx` columns right of and `dy` rows below the box's first.
    pub(super) fn at(&self, dx: f32, dy: f32) -> [f32; 3] {
        distances_at(&self.distance, dx, dy)
    }

    /// Visits the covered pixels of the row `dy` below the box's first, left to right, with
    /// their columns right of the box's first (as `dx`) and their distances: exactly the
    /// pixels of the box's row for which `covers` holds.
    ///
    /// Along a row each distance e₀ + e₁·dx + e₂·dy is monotone in dx, rounding included
    /// (each rounding step is monotone), so the covered pixels form one run, and a pixel
    /// outside tells by its failing edges on which side the run lies. The row is walked from
    /// where the last row's run began to a covered pixel, back to the run's start, and on
    /// until the first pixel outside: about two tests more than the run's length, where
    /// testing the box's row costs its whole width. With a distance that is not finite the
    /// argument fails, and every pixel of the row is tested.
    #[inline]
    pub(super) fn for_each_covered_in_row(&mut self, dy: f32, mut visit: impl FnMut(usize, f32, [f32; 3])) {
        // Copies, kept in registers while `visit` writes the caller's buffers.
        let (distance, first, last) = (self.distance, self.first, self.last);
        let at = move |px: usize| {
            let dx = column(px - first);
            (dx, distances_at(&distance, dx, dy))
        };
        if !self.finite {
            for px in first..=last {
                let (dx, d) = at(px);
                if covers(d) {
                    visit(px, dx, d);
                }
            }
            return;
        }
        let Some(mut px) = self.walk_to_run(dy) else {
            return;
        };
        while px > first && covers(at(px - 1).1) {
            px -= 1;
        }
        self.start = px;
        while px <= last {
            let (dx, d) = at(px);
            if !covers(d) {
                break;
            }
            visit(px, dx, d);
            px += 1;
        }
    }

    /// A covered pixel of the row `dy`, found by walking from `start` the way the failing
    /// edges point, or `None` when the row has none: the failing edges point both ways, the
    /// walk would turn back (the run would lie between two neighbouring pixels), or it would
    /// leave the box.
    #[inline]
    fn walk_to_run(&self, dy: f32) -> Option<usize> {
        let mut px = self.start;
        let mut heading = None;
        loop {
            let d = self.at(column(px - self.first), dy);
            let (mut left, mut right) = (false, false);
            for (e, d) in self.distance.iter().zip(d) {
                if d < EDGE_TOLERANCE_PIXELS {
                    right |= e[1] >= 0.0;
                    left |= e[1] <= 0.0;
                }
            }
            let step_right = match (left, right) {
                (false, false) => return Some(px),
                (true, true) => return None,
                (_, right) => right,
            };
            if heading.is_some_and(|h| h != step_right) {
                return None;
            }
            heading = Some(step_right);
            match step_right {
                true if px < self.last => px += 1,
                false if px > self.first => px -= 1,
                _ => return None,
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every pixel of the box's rows, tested one by one.
    fn covered_by_testing_every_pixel(edges: &Edges, rows: usize) -> Vec<(usize, usize, [f32; 3])> {
        let mut covered = Vec::new();
        for row in 0..rows {
            for px in edges.first..=edges.last {
                let d = edges.at((px - edges.first) as f32, row as f32);
                if covers(d) {
                    covered.push((row, px, d));
                }
            }
        }
        covered
    }

    fn covered_by_walking(edges: &mut Edges, rows: usize) -> Vec<(usize, usize, [f32; 3])> {
        let mut covered = Vec::new();
        for row in 0..rows {
            edges.for_each_covered_in_row(row as f32, |px, _, d| covered.push((row, px, d)));
        }
        covered
    }

    /// A screen triangle's edges over its box, clamped to a 64 × 16 band as the renderer
    /// does; `None` for a degenerate triangle or an empty box.
    fn edges_in_band(xy: [[f64; 2]; 3]) -> Option<(Edges, usize)> {
        let [a, b, c] = xy;
        let area = (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0]);
        let (xs, ys) = (xy.map(|p| p[0]), xy.map(|p| p[1]));
        let (xmin, xmax) = (xs.iter().copied().fold(f64::INFINITY, f64::min), xs.iter().copied().fold(f64::NEG_INFINITY, f64::max));
        let (ymin, ymax) = (ys.iter().copied().fold(f64::INFINITY, f64::min), ys.iter().copied().fold(f64::NEG_INFINITY, f64::max));
        let (first, last) = (xmin.ceil().max(0.0), xmax.floor().min(63.0));
        let (top, bottom) = (ymin.ceil().max(0.0), ymax.floor().min(15.0));
        if area.abs() < 1e-9 || last < first || bottom < top {
            return None;
        }
        let edges = Edges::new(xy, area, first as usize, top as usize, last as usize);
        Some((edges, (bottom - top) as usize + 1))
    }

    #[test]
    fn the_runs_of_a_triangles_rows_are_exactly_the_pixels_testing_every_pixel_finds() {
        let mut state = 0x9e37_79b9_7f4a_7c15u64;
        let mut uniform = move || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            (state >> 11) as f64 / (1u64 << 53) as f64
        };
        let (mut triangles, mut covered, mut slivers_with_empty_rows) = (0, 0, 0);
        for case in 0..20_000 {
            // Small, large, huge (clipped floors reach 10⁶ pixels) and sliver triangles,
            // some with an exactly horizontal or vertical edge.
            let scale = [4.0, 40.0, 2e6][case % 3];
            let mut xy: [[f64; 2]; 3] = std::array::from_fn(|_| [32.0 + (uniform() - 0.5) * scale, 8.0 + (uniform() - 0.5) * scale]);
            if case % 5 == 0 {
                // A sliver: the third vertex near the line through the first two.
                let t = uniform();
                xy[2] = [xy[0][0] + t * (xy[1][0] - xy[0][0]) + uniform() * 0.3, xy[0][1] + t * (xy[1][1] - xy[0][1])];
            }
            if case % 7 == 0 {
                xy[1][1] = xy[0][1];
            }
            if case % 11 == 0 {
                xy[2][0] = xy[1][0];
            }
            let Some((mut edges, rows)) = edges_in_band(xy) else { continue };
            triangles += 1;
            let expected = covered_by_testing_every_pixel(&edges, rows);
            let walked = covered_by_walking(&mut edges, rows);
            assert_eq!(walked.len(), expected.len(), "triangle {xy:?}");
            for (w, e) in walked.iter().zip(&expected) {
                assert!(w.0 == e.0 && w.1 == e.1 && w.2.map(f32::to_bits) == e.2.map(f32::to_bits), "triangle {xy:?}: {w:?} against {e:?}");
            }
            covered += expected.len();
            let rows_hit = expected.iter().map(|p| p.0).collect::<std::collections::BTreeSet<_>>();
            if case % 5 == 0 && rows_hit.len() < rows && !rows_hit.is_empty() {
                slivers_with_empty_rows += 1;
            }
        }
        // The cases are not vacuous: many triangles, pixels, and slivers whose box holds
        // rows they miss (where a walk must stop rather than turn back).
        assert!(
            triangles > 12_000 && covered > 500_000 && slivers_with_empty_rows > 100,
            "{triangles} triangles, {covered} pixels, {slivers_with_empty_rows} slivers"
        );
    }

    #[test]
    fn a_distance_that_is_not_finite_makes_every_pixel_of_the_row_tested() {
        let mut edges = Edges::new([[0.0, 0.0], [10.0, 0.0], [0.0, 10.0]], 100.0, 0, 0, 10);
        let row = |edges: &mut Edges| {
            let mut covered = Vec::new();
            edges.for_each_covered_in_row(0.0, |px, _, _| covered.push(px));
            covered
        };
        let monotone = row(&mut edges);
        assert_eq!(monotone, (0..=10).collect::<Vec<_>>());
        // A NaN distance does not rule a pixel out, in a run or not.
        edges.distance[0] = [f32::NAN, 0.0, 0.0];
        edges.finite = false;
        let all = row(&mut edges);
        assert_eq!(all, (0..=10).collect::<Vec<_>>());
        edges.distance[1] = [-5.0, 1.0, 0.0];
        let right_of_five = row(&mut edges);
        assert_eq!(right_of_five, (5..=10).collect::<Vec<_>>());
    }
}
