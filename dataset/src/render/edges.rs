//! Which pixel centres a screen triangle covers: its three edges as signed distances in
//! pixels, set up in f64 at the first pixel of its box and stepped in f32, and, while
//! every distance is finite, the one run of covered pixels each row of the box holds.

/// A pixel centre within 10⁻³ pixel of an edge counts as inside: on an edge shared by two
/// triangles, at least one draws it.
const EDGE_TOLERANCE_PIXELS: f32 = -1e-3;

/// Whether a pixel centre, at these signed distances in pixels from a triangle's three
/// edges, is covered. Either winding is: both faces are drawn. A NaN distance does not
/// rule a pixel out.
fn covers(distances: [f32; 3]) -> bool {
    !distances.into_iter().any(beyond_the_edge)
}

/// Whether a pixel centre at this signed distance from an edge lies beyond it (not a NaN).
fn beyond_the_edge(distance: f32) -> bool {
    distance < EDGE_TOLERANCE_PIXELS
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
    distance.map(|e| distance_at(e, dx, dy))
}

/// One edge's distance at (`dx`, `dy`): e₀ + e₁·dx + e₂·dy, in this order.
#[inline]
pub(super) fn distance_at(e: [f32; 3], dx: f32, dy: f32) -> f32 {
    e[0] + e[1] * dx + e[2] * dy
}

/// A triangle's edges over the columns `first..=last` of its box, as signed distances in
/// pixels: each barycentric coordinate divided by the length of its gradient, so their
/// rounding is a fraction of a pixel however large the triangle.
#[derive(Debug, Clone)]
pub(super) struct Edges {
    /// Per edge (opposite vertex k): the distance at the box's first pixel, its change per
    /// pixel to the right and per pixel down.
    pub(super) distance: [[f32; 3]; 3],
    /// Lengths of the gradients of barycentrics 1 and 2: a distance times its length is
    /// the barycentric coordinate again.
    pub(super) gradient_lengths: [f32; 2],
    /// 1/e₁ per edge, for estimating where an edge crosses a row.
    inverse_steps: [f32; 3],
    first: usize,
    last: usize,
    /// Every distance is finite, hence monotone along a row (see `row`).
    finite: bool,
}

/// The covered pixels of one row of a triangle's box.
#[derive(Debug, Clone, PartialEq)]
pub(super) enum Row {
    /// Exactly these columns (the range may be empty).
    Run(std::ops::Range<usize>),
    /// A distance is not finite, so the covered pixels need not form one run: test each
    /// pixel of the box's row with `Edges::covered`.
    TestEachPixel,
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
        let inverse_steps = distance.map(|e| 1.0 / e[1]);
        Edges { distance, gradient_lengths: [g1, g2], inverse_steps, first, last, finite }
    }

    /// The distances of the pixel `dx` columns right of and `dy` rows below the box's first.
    pub(super) fn at(&self, dx: f32, dy: f32) -> [f32; 3] {
        distances_at(&self.distance, dx, dy)
    }

    /// The distances of the pixel in column `px` of the row `dy` below the box's first, if
    /// it is covered.
    pub(super) fn covered(&self, px: usize, dy: f32) -> Option<[f32; 3]> {
        let d = self.at(column(px - self.first), dy);
        covers(d).then_some(d)
    }

    /// The covered pixels of the row `dy` below the box's first: exactly the pixels of the
    /// box's row for which `covers` holds.
    ///
    /// Along a row each distance e₀ + e₁·dx + e₂·dy is monotone in dx, rounding included
    /// (each rounding step is monotone), so each edge passes the pixels on one side of a
    /// column and the covered pixels form one run. Each edge's column is estimated from
    /// where its line crosses the row, then settled by testing the pixels beside it: the
    /// estimate only saves steps, the tests decide. With a distance that is not finite the
    /// argument fails, and every pixel must be tested.
    #[inline]
    pub(super) fn row(&self, dy: f32) -> Row {
        if !self.finite {
            return Row::TestEachPixel;
        }
        let first = self.first;
        // Columns lo..hi, counted from the box's first, may still be covered.
        let (mut lo, mut hi) = (0usize, self.last - first + 1);
        for (e, inverse_step) in self.distance.iter().zip(self.inverse_steps) {
            let passes = |x: usize| !beyond_the_edge(distance_at(*e, column(x), dy));
            // Where the edge's distance reaches the tolerance, as a column near which the
            // tests start (any value would do: a NaN or a huge one is clamped).
            let crossing = (EDGE_TOLERANCE_PIXELS - e[2] * dy - e[0]) * inverse_step;
            let near = |lo: usize, hi: usize| (crossing as i32).clamp(lo as i32, hi as i32) as usize;
            if e[1] > 0.0 {
                lo = first_passing(lo..hi, near(lo, hi), passes);
            } else if e[1] < 0.0 {
                hi = end_of_passing(lo..hi, near(lo, hi), passes);
            } else if !passes(lo) {
                // Constant along the row, and failing.
                hi = lo;
            }
            if hi <= lo {
                return Row::Run(first..first);
            }
        }
        Row::Run(first + lo..first + hi)
    }
}

/// The first column of `columns` from which on `passes` holds (given that it holds from
/// some column on), or the end of `columns`; searched from `start`, in `columns` or at its
/// end, one column at a time.
#[inline]
fn first_passing(columns: std::ops::Range<usize>, start: usize, passes: impl Fn(usize) -> bool) -> usize {
    let mut x = start;
    while x > columns.start && passes(x - 1) {
        x -= 1;
    }
    while x < columns.end && !passes(x) {
        x += 1;
    }
    x
}

/// The end of the columns of `columns` up to which `passes` holds (given that it holds up
/// to some column), or the start of `columns`; searched from `start` as `first_passing`.
#[inline]
fn end_of_passing(columns: std::ops::Range<usize>, start: usize, passes: impl Fn(usize) -> bool) -> usize {
    let mut x = start;
    while x < columns.end && passes(x) {
        x += 1;
    }
    while x > columns.start && !passes(x - 1) {
        x -= 1;
    }
    x
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every pixel of the box's rows, tested one by one.
    fn covered_by_testing_every_pixel(edges: &Edges, rows: usize) -> Vec<(usize, usize)> {
        let mut covered = Vec::new();
        for row in 0..rows {
            for px in edges.first..=edges.last {
                let d = edges.at((px - edges.first) as f32, row as f32);
                if covers(d) {
                    covered.push((row, px));
                }
            }
        }
        covered
    }

    /// The pixels of each row's run.
    fn covered_by_runs(edges: &Edges, rows: usize) -> Vec<(usize, usize)> {
        let mut covered = Vec::new();
        for row in 0..rows {
            let Row::Run(run) = edges.row(row as f32) else { panic!("finite distances give runs") };
            covered.extend(run.map(|px| (row, px)));
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
            let Some((edges, rows)) = edges_in_band(xy) else { continue };
            triangles += 1;
            let expected = covered_by_testing_every_pixel(&edges, rows);
            assert_eq!(covered_by_runs(&edges, rows), expected, "triangle {xy:?}");
            covered += expected.len();
            let rows_hit = expected.iter().map(|p| p.0).collect::<std::collections::BTreeSet<_>>();
            if case % 5 == 0 && rows_hit.len() < rows && !rows_hit.is_empty() {
                slivers_with_empty_rows += 1;
            }
        }
        // The cases are not vacuous: many triangles, pixels, and slivers whose box holds
        // rows they miss (whose runs must come out empty).
        assert!(
            triangles > 12_000 && covered > 500_000 && slivers_with_empty_rows > 100,
            "{triangles} triangles, {covered} pixels, {slivers_with_empty_rows} slivers"
        );
    }

    #[test]
    fn an_edges_first_and_last_passing_columns_are_found_from_any_start() {
        for columns in [0..0, 3..4, 2..9] {
            for boundary in 0..=10 {
                for start in columns.start..=columns.end {
                    let from = first_passing(columns.clone(), start, |x| x >= boundary);
                    assert_eq!(from, boundary.clamp(columns.start, columns.end), "{columns:?} passing from {boundary}, start {start}");
                    let end = end_of_passing(columns.clone(), start, |x| x < boundary);
                    assert_eq!(end, boundary.clamp(columns.start, columns.end), "{columns:?} passing before {boundary}, start {start}");
                }
            }
        }
    }

    #[test]
    fn an_edge_parallel_to_the_rows_keeps_or_empties_a_row_whole() {
        let mut edges = Edges::new([[0.0, 0.0], [10.0, 0.0], [0.0, 10.0]], 100.0, 0, 0, 10);
        edges.distance[2] = [0.5, 0.0, 0.0];
        assert_eq!(edges.row(0.0), Row::Run(0..11));
        edges.distance[2] = [-0.5, 0.0, 0.0];
        assert_eq!(edges.row(0.0), Row::Run(0..0));
    }

    #[test]
    fn a_distance_that_is_not_finite_makes_every_pixel_of_the_row_tested() {
        let mut edges = Edges::new([[0.0, 0.0], [10.0, 0.0], [0.0, 10.0]], 100.0, 0, 0, 10);
        assert_eq!(edges.row(0.0), Row::Run(0..11));
        let covered = |edges: &Edges| (0..=10).filter(|&px| edges.covered(px, 0.0).is_some()).collect::<Vec<_>>();
        // A NaN distance does not rule a pixel out, in a run or not.
        edges.distance[0] = [f32::NAN, 0.0, 0.0];
        edges.finite = false;
        assert_eq!(edges.row(0.0), Row::TestEachPixel);
        assert_eq!(covered(&edges), (0..=10).collect::<Vec<_>>());
        edges.distance[1] = [-5.0, 1.0, 0.0];
        assert_eq!(covered(&edges), (5..=10).collect::<Vec<_>>());
    }
}
