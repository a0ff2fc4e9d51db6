//! Motion as HaDaGe makes it: the agent only moves forward 0.06 m or turns 4°, each
//! action split into sub-steps with one frame per sub-step, and never leaves the
//! navigable area. [`Walker`] turns a plan (paths, headings to face, sweeps to look
//! around) into those frames; `coverage` decides the plan.

use serde::{Deserialize, Serialize};

use super::navigation::NavGrid;

/// Motion settings (HaDaGe's defaults) and the frame budget.
#[derive(Debug, Clone, Copy, Serialize, Deserialize)]
pub struct MotionSettings {
    pub move_amount: f64,
    pub turn_degrees: f64,
    pub sub_steps: u32,
    /// Navigation goals at least (the planner adds viewpoints until there are this many).
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

impl MotionSettings {
    /// Metres moved per frame.
    pub fn step_per_frame(&self) -> f64 {
        self.move_amount / self.sub_steps as f64
    }

    /// Radians turned per frame.
    pub fn turn_per_frame(&self) -> f64 {
        (self.turn_degrees / self.sub_steps as f64).to_radians()
    }
}

/// One frame's agent state: position on the floor, heading, which goal it heads for,
/// and the action it is part of.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct AgentState {
    pub x: f64,
    pub z: f64,
    /// Rotation about +y; 0 looks along −z.
    pub yaw: f64,
    /// The navigation goal (segment) the frame belongs to; lights switch by it.
    pub goal_index: usize,
    pub action: Action,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
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

/// The heading (yaw) that looks from `from` towards `to`.
pub fn heading_towards(from: [f64; 2], to: [f64; 2]) -> f64 {
    (-(to[0] - from[0])).atan2(-(to[1] - from[1]))
}

/// `angle` wrapped to (−π, π].
pub fn wrap(angle: f64) -> f64 {
    let a = (angle + std::f64::consts::PI).rem_euclid(std::f64::consts::TAU) - std::f64::consts::PI;
    if a == -std::f64::consts::PI { std::f64::consts::PI } else { a }
}

/// The agent walking a plan into frames, within the frame budget.
pub struct Walker<'a> {
    grid: &'a NavGrid,
    settings: MotionSettings,
    pub x: f64,
    pub z: f64,
    pub yaw: f64,
    /// The goal the next frames belong to.
    pub goal: usize,
    pub frames: Vec<AgentState>,
    /// Metres walked.
    pub travelled: f64,
}

impl<'a> Walker<'a> {
    pub fn new(grid: &'a NavGrid, settings: MotionSettings, start: [f64; 2], yaw: f64) -> Self {
        Self { grid, settings, x: start[0], z: start[1], yaw, goal: 0, frames: Vec::new(), travelled: 0.0 }
    }

    pub fn position(&self) -> [f64; 2] {
        [self.x, self.z]
    }

    /// Frames left in the budget.
    pub fn budget_left(&self) -> usize {
        self.settings.max_frames.saturating_sub(self.frames.len())
    }

    /// One action: its sub-steps, one frame each. False when the budget is spent (no
    /// frame of it is taken) or a forward move would leave the navigable area.
    fn act(&mut self, action: Action) -> bool {
        let s = &self.settings;
        if self.frames.len() + s.sub_steps as usize > s.max_frames {
            return false;
        }
        if action == Action::MoveForward && !self.grid.navigable(self.x - self.yaw.sin() * s.move_amount, self.z - self.yaw.cos() * s.move_amount) {
            return false;
        }
        let (step, turn) = (s.step_per_frame(), s.turn_per_frame());
        for _ in 0..s.sub_steps {
            match action {
                Action::MoveForward => {
                    self.x -= self.yaw.sin() * step;
                    self.z -= self.yaw.cos() * step;
                    self.travelled += step;
                }
                Action::TurnLeft => self.yaw += turn,
                Action::TurnRight => self.yaw -= turn,
            }
            self.frames.push(AgentState { x: self.x, z: self.z, yaw: self.yaw, goal_index: self.goal, action });
        }
        true
    }

    /// Half a turn step, with room for the rounding of the sub-steps' angles: a heading
    /// error within it is as close as turning gets (without the room, an error of exactly
    /// half a step could be turned back and forth for ever).
    fn half_turn(&self) -> f64 {
        self.settings.turn_degrees.to_radians() / 2.0 + 1e-9
    }

    /// Turn in place until facing `heading` within half a turn step. False when the
    /// budget ran out.
    pub fn turn_to(&mut self, heading: f64) -> bool {
        let half_turn = self.half_turn();
        // Half a circle at most is ever needed.
        for _ in 0..=(180.0 / self.settings.turn_degrees).ceil() as usize + 1 {
            let error = wrap(heading - self.yaw);
            if error.abs() <= half_turn {
                return true;
            }
            if !self.act(if error > 0.0 { Action::TurnLeft } else { Action::TurnRight }) {
                return false;
            }
        }
        true
    }

    /// Turn in place towards `heading` the way given (left or right), until facing it
    /// within half a turn step. False when the budget ran out.
    pub fn turn_towards(&mut self, heading: f64, left: bool) -> bool {
        let half_turn = self.half_turn();
        let action = if left { Action::TurnLeft } else { Action::TurnRight };
        for _ in 0..=(360.0 / self.settings.turn_degrees).ceil() as usize + 1 {
            if wrap(heading - self.yaw).abs() <= half_turn {
                return true;
            }
            if !self.act(action) {
                return false;
            }
        }
        true
    }

    /// Turn by `radians` (positive: left), in whole turn actions.
    pub fn turn_by(&mut self, radians: f64) -> bool {
        let actions = (radians.abs() / self.settings.turn_degrees.to_radians()).round() as usize;
        let action = if radians > 0.0 { Action::TurnLeft } else { Action::TurnRight };
        (0..actions).all(|_| self.act(action))
    }

    /// Look around the current heading: `half` radians left, back past it to the right,
    /// and back to where it started.
    pub fn sweep(&mut self, half: f64) -> bool {
        self.turn_by(half) && self.turn_by(-2.0 * half) && self.turn_by(half)
    }

    /// Follow `path` (points (x, z), starting near the agent) as HaDaGe's greedy
    /// follower does: aim at the first waypoint at least 15 cm ahead, turn when the
    /// heading is off by more than half a turn, otherwise move forward. Stops at the
    /// last waypoint, when the budget is spent, or when forward moves keep failing.
    pub fn follow(&mut self, path: &[[f64; 2]]) -> bool {
        let Some(&last) = path.last() else { return true };
        let s = self.settings;
        let half_turn = self.half_turn();
        let length: f64 = path.windows(2).map(|w| ((w[1][0] - w[0][0]).powi(2) + (w[1][1] - w[0][1]).powi(2)).sqrt()).sum();
        // Actions enough for the path's length and a half turn at each waypoint, and then some.
        let max_actions = 4 * ((length / s.move_amount) as usize + path.len() * (180.0 / s.turn_degrees) as usize) + 100;
        let mut next = 0;
        let mut stuck = 0;
        for _ in 0..max_actions {
            if stuck >= 200 {
                break;
            }
            while next + 1 < path.len() && ((path[next][0] - self.x).powi(2) + (path[next][1] - self.z).powi(2)).sqrt() < 0.15 {
                next += 1;
            }
            let target = path[next];
            let (dx, dz) = (target[0] - self.x, target[1] - self.z);
            let distance = (dx * dx + dz * dz).sqrt();
            if next + 1 == path.len() && distance < 0.75 * s.move_amount + self.grid.cell_size {
                return true;
            }
            let error = wrap(heading_towards([self.x, self.z], target) - self.yaw);
            let action = if error.abs() > half_turn { if error > 0.0 { Action::TurnLeft } else { Action::TurnRight } } else { Action::MoveForward };
            if !self.act(action) {
                if self.budget_left() < s.sub_steps as usize {
                    return false;
                }
                stuck += 1;
                next = (next + 1).min(path.len() - 1);
            }
        }
        ((last[0] - self.x).powi(2) + (last[1] - self.z).powi(2)).sqrt() < 0.3
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn open_room() -> NavGrid {
        NavGrid::new([-2.0, -2.0], 0.05, 80, 80, 0.0, vec![255; 6400])
    }

    #[test]
    fn frames_move_3_cm_or_turn_2_degrees_and_stay_in_the_budget() {
        let grid = open_room();
        let settings = MotionSettings { max_frames: 400, ..Default::default() };
        let mut w = Walker::new(&grid, settings, [0.0, 0.0], 0.0);
        assert!(w.follow(&[[0.0, 0.0], [1.0, 1.0]]));
        assert!(((w.x - 1.0).powi(2) + (w.z - 1.0).powi(2)).sqrt() < 0.1, "reached ({}, {})", w.x, w.z);
        assert!(w.turn_to(0.0));
        assert!(w.sweep(20f64.to_radians()));
        let mut previous = AgentState { x: 0.0, z: 0.0, yaw: 0.0, goal_index: 0, action: Action::MoveForward };
        for f in &w.frames {
            let moved = ((f.x - previous.x).powi(2) + (f.z - previous.z).powi(2)).sqrt();
            let turned = wrap(f.yaw - previous.yaw).abs();
            match f.action {
                Action::MoveForward => assert!((moved - 0.03).abs() < 1e-9 && turned < 1e-12),
                _ => assert!(moved < 1e-12 && (turned - 2f64.to_radians()).abs() < 1e-9),
            }
            previous = *f;
        }
        assert!(wrap(w.yaw).abs() < 2f64.to_radians() + 1e-9, "the sweep ends where it started");
        let mut short = Walker::new(&grid, MotionSettings { max_frames: 10, ..settings }, [0.0, 0.0], 0.0);
        assert!(!short.follow(&[[0.0, 0.0], [1.5, 0.0]]));
        assert_eq!(short.frames.len(), 10);
    }

    #[test]
    fn a_heading_half_a_step_away_is_reached_not_turned_around_for_ever() {
        let grid = open_room();
        // 28° reached in fourteen 2° sub-steps (with their rounding), heading 30°: either
        // neighbour of 30° is as close as turning gets.
        let yaw = (0..14).fold(0.0f64, |y, _| y + 2f64.to_radians());
        for heading in [30f64, 26.0, 30.000000001, 29.99999999] {
            let mut w = Walker::new(&grid, MotionSettings { max_frames: 10_000, ..Default::default() }, [0.0, 0.0], yaw);
            assert!(w.turn_to(heading.to_radians()));
            assert!(w.frames.len() <= 2, "{heading}°: {} frames", w.frames.len());
            assert!(w.follow(&[[0.0, 0.0], [-(heading.to_radians().sin()), -(heading.to_radians().cos())]]));
            assert!(w.frames.len() < 100, "{heading}°: {} frames to walk 1 m", w.frames.len());
        }
    }

    #[test]
    fn forward_moves_never_leave_the_navigable_area() {
        let mut cells = vec![255u8; 6400];
        for r in 0..80 {
            cells[r * 80 + 60] = 0; // a wall at x = 1.0
        }
        let grid = NavGrid::new([-2.0, -2.0], 0.05, 80, 80, 0.0, cells);
        let mut w = Walker::new(&grid, MotionSettings { max_frames: 600, ..Default::default() }, [0.0, 0.0], 0.0);
        w.follow(&[[0.0, 0.0], [1.8, 0.0]]);
        assert!(w.frames.iter().all(|f| grid.navigable(f.x, f.z)));
        assert!(w.x < 1.0);
    }
}
