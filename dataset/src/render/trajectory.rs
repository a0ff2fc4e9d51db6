//! Trajectories as HaDaGe makes them: a seeded random navigable start and goals on the
//! navigable-area map, shortest paths on its grid, and a greedy follower that only
//! moves forward 0.06 m or turns 4°, each action split into sub-steps with one frame
//! per sub-step. Unreachable goals are skipped; the camera never leaves free space.

use std::collections::BinaryHeap;
use std::path::Path;

use osmab_evaluator::synthetic::Rng;
use osmab_evaluator::{InputError, Result};
use serde::{Deserialize, Serialize};

/// The navigable-area map written by the converter.
#[derive(Debug, Clone)]
pub struct NavGrid {
    pub origin_xz: [f64; 2],
    pub cell_size: f64,
    pub width: usize,
    pub height: usize,
    pub floor_height: f64,
    /// 255 navigable, 0 blocked; rows along +z.
    pub cells: Vec<u8>,
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

impl NavGrid {
    /// Read `navigation/<scene>.navigable.json` and its PNG.
    pub fn read(dir: &Path, scene: &str) -> Result<Self> {
        let meta_path = dir.join("navigation").join(format!("{scene}.navigable.json"));
        let meta: NavMeta = serde_json::from_slice(&std::fs::read(&meta_path).map_err(|e| InputError::io(&meta_path, &e))?)
            .map_err(|e| InputError::new(&meta_path, "(json)", e.to_string()))?;
        let png_path = dir.join("navigation").join(&meta.png);
        let file = std::fs::File::open(&png_path).map_err(|e| InputError::io(&png_path, &e))?;
        let mut reader = png::Decoder::new(std::io::BufReader::new(file)).read_info().map_err(|e| InputError::new(&png_path, "(png)", e.to_string()))?;
        let mut cells = vec![0; reader.output_buffer_size().ok_or_else(|| InputError::new(&png_path, "(png)", "too large"))?];
        reader.next_frame(&mut cells).map_err(|e| InputError::new(&png_path, "(png)", e.to_string()))?;
        if cells.len() != meta.width * meta.height {
            return Err(InputError::new(&png_path, "size", format!("expected {}x{} one-byte cells", meta.width, meta.height)));
        }
        Ok(Self { origin_xz: meta.origin_xz, cell_size: meta.cell_size, width: meta.width, height: meta.height, floor_height: meta.floor_height, cells })
    }

    fn cell_of(&self, x: f64, z: f64) -> Option<usize> {
        let (c, r) = ((x - self.origin_xz[0]) / self.cell_size, (z - self.origin_xz[1]) / self.cell_size);
        (c >= 0.0 && r >= 0.0 && (c as usize) < self.width && (r as usize) < self.height).then(|| r as usize * self.width + c as usize)
    }

    /// Whether the agent may stand at (x, z).
    pub fn navigable(&self, x: f64, z: f64) -> bool {
        self.cell_of(x, z).is_some_and(|i| self.cells[i] == 255)
    }

    fn centre(&self, i: usize) -> [f64; 2] {
        [self.origin_xz[0] + ((i % self.width) as f64 + 0.5) * self.cell_size, self.origin_xz[1] + ((i / self.width) as f64 + 0.5) * self.cell_size]
    }

    /// The free cells of the largest connected free region, ascending. (With diagonals
    /// unable to cut corners, the agent's 8-connected moves connect what 4-neighbours do.)
    fn largest_region(&self) -> Vec<usize> {
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
                let (c, r) = (i % self.width, i / self.width);
                let neighbours = [
                    (c > 0).then(|| i - 1),
                    (c + 1 < self.width).then(|| i + 1),
                    (r > 0).then(|| i - self.width),
                    (r + 1 < self.height).then(|| i + self.width),
                ];
                for j in neighbours.into_iter().flatten() {
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

    /// Shortest 8-connected path of cell centres from `a` to `b` (A*), if any.
    fn path(&self, a: [f64; 2], b: [f64; 2]) -> Option<Vec<[f64; 2]>> {
        let (start, goal) = (self.cell_of(a[0], a[1])?, self.cell_of(b[0], b[1])?);
        let mut cost = vec![f64::INFINITY; self.cells.len()];
        let mut from = vec![usize::MAX; self.cells.len()];
        let h = |i: usize| {
            let (dc, dr) = ((i % self.width) as f64 - (goal % self.width) as f64, (i / self.width) as f64 - (goal / self.width) as f64);
            (dc * dc + dr * dr).sqrt()
        };
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
        let mut open = BinaryHeap::from([Entry(h(start), start)]);
        cost[start] = 0.0;
        while let Some(Entry(_, i)) = open.pop() {
            if i == goal {
                let mut path = vec![self.centre(goal)];
                let mut k = goal;
                while from[k] != usize::MAX {
                    k = from[k];
                    path.push(self.centre(k));
                }
                path.reverse();
                return Some(path);
            }
            let (c, r) = ((i % self.width) as i64, (i / self.width) as i64);
            for (dc, dr) in [(-1, 0), (1, 0), (0, -1), (0, 1), (-1, -1), (1, -1), (-1, 1), (1, 1)] {
                let (nc, nr) = (c + dc, r + dr);
                if nc < 0 || nr < 0 || nc >= self.width as i64 || nr >= self.height as i64 {
                    continue;
                }
                let j = nr as usize * self.width + nc as usize;
                // Diagonals may not cut a blocked corner.
                let corner_free = dc == 0
                    || dr == 0
                    || (self.cells[r as usize * self.width + nc as usize] == 255 && self.cells[nr as usize * self.width + c as usize] == 255);
                if self.cells[j] != 255 || !corner_free {
                    continue;
                }
                let step = if dc != 0 && dr != 0 { std::f64::consts::SQRT_2 } else { 1.0 };
                if cost[i] + step < cost[j] {
                    cost[j] = cost[i] + step;
                    from[j] = i;
                    open.push(Entry(cost[j] + h(j), j));
                }
            }
        }
        None
    }
}

/// Motion settings (HaDaGe's defaults).
#[derive(Debug, Clone, Copy, Serialize, Deserialize)]
pub struct MotionSettings {
    pub move_amount: f64,
    pub turn_degrees: f64,
    pub sub_steps: u32,
    pub goals: usize,
    pub seed: u64,
    /// Frames at most, over all goals.
    pub max_frames: usize,
}

impl Default for MotionSettings {
    fn default() -> Self {
        Self { move_amount: 0.06, turn_degrees: 4.0, sub_steps: 2, goals: 5, seed: 73, max_frames: 20_000 }
    }
}

/// One frame's agent state: position on the floor, heading, which goal it heads for,
/// and the action it is part of.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct AgentState {
    pub x: f64,
    pub z: f64,
    /// Rotation about +y; 0 looks along −z.
    pub yaw: f64,
    pub goal_index: usize,
    pub action: Action,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Action {
    MoveForward,
    TurnLeft,
    TurnRight,
}

impl Action {
    pub fn name(self) -> &'static str {
        match self {
            Action::MoveForward => "move_forward",
            Action::TurnLeft => "turn_left",
            Action::TurnRight => "turn_right",
        }
    }
}

/// The frames of a trajectory through `grid`.
pub fn trajectory(grid: &NavGrid, settings: &MotionSettings) -> Vec<AgentState> {
    let mut rng = Rng::new(settings.seed);
    // Start and goals in the largest free region: an isolated pocket would reach no goal.
    let region = grid.largest_region();
    if region.is_empty() {
        return Vec::new();
    }
    let mut random_point = || grid.centre(region[rng.below(region.len())]);
    let start = random_point();
    let goals: Vec<[f64; 2]> = (0..settings.goals).map(|_| random_point()).collect();
    let (mut x, mut z, mut yaw) = (start[0], start[1], 0.0f64);
    let mut frames = Vec::new();
    let step = settings.move_amount / settings.sub_steps as f64;
    let turn = (settings.turn_degrees / settings.sub_steps as f64).to_radians();
    for (g, goal) in goals.iter().enumerate() {
        let Some(path) = grid.path([x, z], *goal) else { continue };
        let mut next = 0;
        let mut stuck = 0;
        while frames.len() < settings.max_frames && stuck < 200 {
            // Aim at the first waypoint at least 15 cm ahead.
            while next + 1 < path.len() && ((path[next][0] - x).powi(2) + (path[next][1] - z).powi(2)).sqrt() < 0.15 {
                next += 1;
            }
            let target = path[next];
            let (dx, dz) = (target[0] - x, target[1] - z);
            if next + 1 == path.len() && (dx * dx + dz * dz).sqrt() < 0.75 * settings.move_amount + grid.cell_size {
                break;
            }
            // Heading error: forward is (−sin yaw, −cos yaw).
            let desired = (-dx).atan2(-dz);
            let error = (desired - yaw + std::f64::consts::PI).rem_euclid(std::f64::consts::TAU) - std::f64::consts::PI;
            let action = if error.abs() > settings.turn_degrees.to_radians() / 2.0 {
                if error > 0.0 { Action::TurnLeft } else { Action::TurnRight }
            } else {
                Action::MoveForward
            };
            if action == Action::MoveForward && !grid.navigable(x - yaw.sin() * settings.move_amount, z - yaw.cos() * settings.move_amount) {
                stuck += 1;
                next = (next + 1).min(path.len() - 1);
                continue;
            }
            for _ in 0..settings.sub_steps {
                match action {
                    Action::MoveForward => {
                        x -= yaw.sin() * step;
                        z -= yaw.cos() * step;
                    }
                    Action::TurnLeft => yaw += turn,
                    Action::TurnRight => yaw -= turn,
                }
                frames.push(AgentState { x, z, yaw, goal_index: g, action });
            }
        }
    }
    frames
}
