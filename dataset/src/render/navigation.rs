//! The navigable-area map written by the converter, and the ways across it: the largest
//! connected free region, each cell's clearance (distance to the nearest obstacle), and
//! shortest paths that keep away from walls and furniture where the room allows, so a
//! camera carried along them looks into the room rather than at a surface an arm's
//! length away.

use std::collections::BinaryHeap;
use std::path::Path;

use osmab_evaluator::{InputError, Result};
use serde::Deserialize;

/// The navigable-area map: 255 navigable, 0 blocked; rows along +z.
#[derive(Debug, Clone)]
pub struct NavGrid {
    pub origin_xz: [f64; 2],
    pub cell_size: f64,
    pub width: usize,
    pub height: usize,
    pub floor_height: f64,
    pub cells: Vec<u8>,
    /// Per cell, the distance in metres to the nearest blocked cell or the map's edge
    /// (0 for blocked cells).
    pub clearance: Vec<f64>,
    /// Per cell, how much more a step onto it costs beyond its closeness to obstacles
    /// (empty: nothing more): what a planner wants walked around.
    pub penalty: Vec<f64>,
}

#[derive(Deserialize)]
struct NavMeta {
    origin_xz: [f64; 2],
    cell_size: f64,
    width: usize,
    height: usize,
    floor_height: f64,
    png: String,
}

/// Clearance at or above which a path costs only its length.
const COMFORTABLE_CLEARANCE: f64 = 0.6;
/// How much more a step costs right at an obstacle than in the open.
const CLOSE_PENALTY: f64 = 3.0;

/// Shortest-path costs from one cell: `cost` (length weighted by closeness to
/// obstacles), `length` (metres along that path) and the previous cell of each.
pub struct Distances {
    pub cost: Vec<f64>,
    pub length: Vec<f64>,
    from: Vec<usize>,
}

impl NavGrid {
    /// Read `navigation/<scene>.navigable.json` and its PNG.
    pub fn read(dir: &Path, scene: &str) -> Result<Self> {
        let meta_path = dir.join("navigation").join(format!("{scene}.navigable.json"));
        let meta: NavMeta = serde_json::from_slice(&std::fs::read(&meta_path).map_err(|e| InputError::io(&meta_path, &e))?)
            .map_err(|e| InputError::new(&meta_path, "(json)", e.to_string()))?;
        if !(meta.cell_size > 0.0 && meta.cell_size.is_finite()) || meta.width == 0 || meta.height == 0 || meta.width * meta.height > 1 << 26 {
            return Err(InputError::new(&meta_path, "cell_size", "expected a positive cell size and 1 to 2^26 cells"));
        }
        let png_path = dir.join("navigation").join(&meta.png);
        let file = std::fs::File::open(&png_path).map_err(|e| InputError::io(&png_path, &e))?;
        let mut reader = png::Decoder::new(std::io::BufReader::new(file)).read_info().map_err(|e| InputError::new(&png_path, "(png)", e.to_string()))?;
        let mut cells = vec![0; reader.output_buffer_size().ok_or_else(|| InputError::new(&png_path, "(png)", "too large"))?];
        reader.next_frame(&mut cells).map_err(|e| InputError::new(&png_path, "(png)", e.to_string()))?;
        if cells.len() != meta.width * meta.height {
            return Err(InputError::new(&png_path, "size", format!("expected {}x{} one-byte cells", meta.width, meta.height)));
        }
        Ok(Self::new(meta.origin_xz, meta.cell_size, meta.width, meta.height, meta.floor_height, cells))
    }

    /// A grid from its cells (255 navigable).
    pub fn new(origin_xz: [f64; 2], cell_size: f64, width: usize, height: usize, floor_height: f64, cells: Vec<u8>) -> Self {
        let mut grid = Self { origin_xz, cell_size, width, height, floor_height, cells, clearance: Vec::new(), penalty: Vec::new() };
        grid.clearance = grid.clearances();
        grid
    }

    /// The cell holding (x, z).
    pub fn cell_of(&self, x: f64, z: f64) -> Option<usize> {
        let (c, r) = ((x - self.origin_xz[0]) / self.cell_size, (z - self.origin_xz[1]) / self.cell_size);
        (c >= 0.0 && r >= 0.0 && (c as usize) < self.width && (r as usize) < self.height).then(|| r as usize * self.width + c as usize)
    }

    /// Whether the agent may stand at (x, z).
    pub fn navigable(&self, x: f64, z: f64) -> bool {
        self.cell_of(x, z).is_some_and(|i| self.cells[i] == 255)
    }

    /// The clearance at (x, z), 0 off the map.
    pub fn clearance_at(&self, x: f64, z: f64) -> f64 {
        self.cell_of(x, z).map_or(0.0, |i| self.clearance[i])
    }

    /// The centre of cell `i` as (x, z).
    pub fn centre(&self, i: usize) -> [f64; 2] {
        [self.origin_xz[0] + ((i % self.width) as f64 + 0.5) * self.cell_size, self.origin_xz[1] + ((i / self.width) as f64 + 0.5) * self.cell_size]
    }

    /// Chamfer distances (3-4 weights, within 8 % of Euclidean) from every free cell to
    /// the nearest blocked cell or the edge of the map.
    fn clearances(&self) -> Vec<f64> {
        let (w, h) = (self.width, self.height);
        let far = u32::MAX / 2;
        let mut d: Vec<u32> = (0..w * h)
            .map(|i| {
                let (c, r) = (i % w, i / w);
                if self.cells[i] != 255 {
                    0
                } else if c == 0 || r == 0 || c + 1 == w || r + 1 == h {
                    3
                } else {
                    far
                }
            })
            .collect();
        let relax = |d: &mut Vec<u32>, i: usize, j: usize, step: u32| {
            if d[j] + step < d[i] {
                d[i] = d[j] + step;
            }
        };
        for r in 0..h {
            for c in 0..w {
                let i = r * w + c;
                if c > 0 {
                    relax(&mut d, i, i - 1, 3);
                }
                if r > 0 {
                    relax(&mut d, i, i - w, 3);
                    if c > 0 {
                        relax(&mut d, i, i - w - 1, 4);
                    }
                    if c + 1 < w {
                        relax(&mut d, i, i - w + 1, 4);
                    }
                }
            }
        }
        for r in (0..h).rev() {
            for c in (0..w).rev() {
                let i = r * w + c;
                if c + 1 < w {
                    relax(&mut d, i, i + 1, 3);
                }
                if r + 1 < h {
                    relax(&mut d, i, i + w, 3);
                    if c + 1 < w {
                        relax(&mut d, i, i + w + 1, 4);
                    }
                    if c > 0 {
                        relax(&mut d, i, i + w - 1, 4);
                    }
                }
            }
        }
        d.into_iter().map(|v| v as f64 / 3.0 * self.cell_size).collect()
    }

    /// The free cells of the largest connected free region, ascending. (With diagonals
    /// unable to cut corners, the agent's 8-connected moves connect what 4-neighbours do.)
    pub fn largest_region(&self) -> Vec<usize> {
        let mut region_of = vec![usize::MAX; self.cells.len()];
        let mut best: Vec<usize> = Vec::new();
        for seed in 0..self.cells.len() {
            if self.cells[seed] != 255 || region_of[seed] != usize::MAX {
                continue;
            }
            let mut region = vec![seed];
            region_of[seed] = seed;
            let mut next = 0;
            while next < region.len() {
                let i = region[next];
                next += 1;
                for j in self.neighbours4(i) {
                    if self.cells[j] == 255 && region_of[j] == usize::MAX {
                        region_of[j] = seed;
                        region.push(j);
                    }
                }
            }
            if region.len() > best.len() {
                best = region;
            }
        }
        best.sort_unstable();
        best
    }

    fn neighbours4(&self, i: usize) -> impl Iterator<Item = usize> {
        let (c, r, w, h) = (i % self.width, i / self.width, self.width, self.height);
        [(c > 0).then(|| i - 1), (c + 1 < w).then(|| i + 1), (r > 0).then(|| i - w), (r + 1 < h).then(|| i + w)].into_iter().flatten()
    }

    /// The cost of one step onto cell `j` of length `step` metres.
    fn step_cost(&self, j: usize, step: f64) -> f64 {
        let closeness = ((COMFORTABLE_CLEARANCE - self.clearance[j]) / COMFORTABLE_CLEARANCE).clamp(0.0, 1.0);
        step * (1.0 + CLOSE_PENALTY * closeness + self.penalty.get(j).copied().unwrap_or(0.0))
    }

    /// This grid with `penalty` (per cell) added to the cost of every step onto a cell.
    pub fn with_penalty(mut self, penalty: Vec<f64>) -> Self {
        self.penalty = penalty;
        self
    }

    /// Shortest paths (Dijkstra, 8-connected, no corner cutting) from cell `start` to
    /// every cell, their cost weighted by closeness to obstacles.
    pub fn distances_from(&self, start: usize) -> Distances {
        let n = self.cells.len();
        let mut out = Distances { cost: vec![f64::INFINITY; n], length: vec![f64::INFINITY; n], from: vec![usize::MAX; n] };
        if start >= n || self.cells[start] != 255 {
            return out;
        }
        #[derive(PartialEq)]
        struct Entry(f64, usize);
        impl Eq for Entry {}
        impl PartialOrd for Entry {
            fn partial_cmp(&self, o: &Self) -> Option<std::cmp::Ordering> {
                Some(self.cmp(o))
            }
        }
        impl Ord for Entry {
            fn cmp(&self, o: &Self) -> std::cmp::Ordering {
                o.0.total_cmp(&self.0).then(o.1.cmp(&self.1))
            }
        }
        out.cost[start] = 0.0;
        out.length[start] = 0.0;
        let mut open = BinaryHeap::from([Entry(0.0, start)]);
        let w = self.width as i64;
        while let Some(Entry(cost, i)) = open.pop() {
            if cost > out.cost[i] {
                continue;
            }
            let (c, r) = ((i % self.width) as i64, (i / self.width) as i64);
            for (dc, dr) in [(-1, 0), (1, 0), (0, -1), (0, 1), (-1, -1), (1, -1), (-1, 1), (1, 1)] {
                let (nc, nr) = (c + dc, r + dr);
                if nc < 0 || nr < 0 || nc >= w || nr >= self.height as i64 {
                    continue;
                }
                let j = (nr * w + nc) as usize;
                // Diagonals may not cut a blocked corner.
                let corner_free = dc == 0 || dr == 0 || (self.cells[(r * w + nc) as usize] == 255 && self.cells[(nr * w + c) as usize] == 255);
                if self.cells[j] != 255 || !corner_free {
                    continue;
                }
                let step = if dc != 0 && dr != 0 { std::f64::consts::SQRT_2 } else { 1.0 } * self.cell_size;
                let next = cost + self.step_cost(j, step);
                if next < out.cost[j] {
                    out.cost[j] = next;
                    out.length[j] = out.length[i] + step;
                    out.from[j] = i;
                    open.push(Entry(next, j));
                }
            }
        }
        out
    }

    /// The path of `distances` to cell `goal` as points (x, z), from its start to `goal`,
    /// straightened where a straight line keeps as much clearance; `None` when unreachable.
    pub fn path_to(&self, distances: &Distances, goal: usize) -> Option<Vec<[f64; 2]>> {
        if goal >= self.cells.len() || !distances.cost[goal].is_finite() {
            return None;
        }
        let mut cells = vec![goal];
        while distances.from[*cells.last().expect("non-empty")] != usize::MAX {
            cells.push(distances.from[*cells.last().expect("non-empty")]);
        }
        cells.reverse();
        // String pulling: from each kept cell, the farthest later cell in straight sight
        // whose line keeps the smallest clearance of the cells it replaces.
        let mut kept = vec![cells[0]];
        let mut i = 0;
        while i + 1 < cells.len() {
            let mut j = i + 1;
            let mut floor = self.clearance[cells[i]].min(self.clearance[cells[j]]);
            for k in (i + 2)..cells.len() {
                floor = floor.min(self.clearance[cells[k - 1]]).min(self.clearance[cells[k]]);
                if self.line_keeps(cells[i], cells[k], floor - 1e-9) {
                    j = k;
                } else {
                    break;
                }
            }
            kept.push(cells[j]);
            i = j;
        }
        Some(kept.into_iter().map(|c| self.centre(c)).collect())
    }

    /// Whether every point of the straight line between two cell centres is navigable
    /// with at least `clearance`.
    fn line_keeps(&self, a: usize, b: usize, clearance: f64) -> bool {
        let (pa, pb) = (self.centre(a), self.centre(b));
        let length = ((pb[0] - pa[0]).powi(2) + (pb[1] - pa[1]).powi(2)).sqrt();
        let samples = (length / (self.cell_size / 2.0)).ceil().max(1.0) as usize;
        (0..=samples).all(|s| {
            let t = s as f64 / samples as f64;
            self.cell_of(pa[0] + t * (pb[0] - pa[0]), pa[1] + t * (pb[1] - pa[1])).is_some_and(|i| self.cells[i] == 255 && self.clearance[i] >= clearance)
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A 3 m × 2 m room of 5 cm cells with a 1 m wall stub from the top edge at x = 1.5 m.
    fn room() -> NavGrid {
        let (w, h) = (60, 40);
        let mut cells = vec![255u8; w * h];
        for r in 0..20 {
            for c in 29..31 {
                cells[r * w + c] = 0;
            }
        }
        NavGrid::new([0.0, 0.0], 0.05, w, h, 0.0, cells)
    }

    #[test]
    fn clearance_is_the_distance_to_the_nearest_obstacle_or_edge() {
        let g = room();
        let centre_of_bottom_half = g.cell_of(0.775, 1.5).unwrap();
        assert!((g.clearance[centre_of_bottom_half] - 0.5).abs() < 0.06, "{}", g.clearance[centre_of_bottom_half]);
        assert_eq!(g.clearance[g.cell_of(1.5, 0.5).unwrap()], 0.0, "blocked");
        assert!(g.clearance[g.cell_of(0.025, 1.0).unwrap()] <= 0.05, "at the edge");
    }

    #[test]
    fn paths_go_around_obstacles_straightened_and_away_from_them() {
        let g = room();
        let start = g.cell_of(0.5, 0.3).unwrap();
        let goal = g.cell_of(2.5, 0.3).unwrap();
        let d = g.distances_from(start);
        let path = g.path_to(&d, goal).unwrap();
        assert!(path.len() <= 6, "straightened: {path:?}");
        // Around the stub's end (z = 1 m), keeping off it where the room allows.
        let lowest = path.iter().map(|p| p[1]).fold(0.0, f64::max);
        assert!(lowest > 1.1, "{path:?}");
        for pair in path.windows(2) {
            for s in 0..=20 {
                let t = s as f64 / 20.0;
                assert!(g.navigable(pair[0][0] + t * (pair[1][0] - pair[0][0]), pair[0][1] + t * (pair[1][1] - pair[0][1])));
            }
        }
        assert!(d.length[goal] > 2.0 && d.length[goal] < 4.0, "{}", d.length[goal]);
        assert!(g.path_to(&d, g.cell_of(1.5, 0.5).unwrap()).is_none(), "blocked cells are unreachable");
    }
}
