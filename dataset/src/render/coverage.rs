//! Trajectories planned for coverage, not only for reaching goals. The planner renders
//! low-resolution probe views (depth, classes, instances) from candidate viewpoints — a
//! lattice of navigable positions, twelve headings each — and then walks, greedily, to
//! the viewpoint that adds the most coverage per frame it costs:
//!
//! 1. a look-around at the start, from the position that overlooks the most objects,
//!    turning through the arc where objects are rather than into bare walls;
//! 2. then viewpoint after viewpoint until every object is seen from at least
//!    [`CoverageGoals::views`] viewpoints at least [`CoverageGoals::separation`] apart
//!    and is predicted to leave enough ground-truth points to be mapped (prompted
//!    objects weigh more; small ones need close views for that); each viewpoint is a
//!    navigation goal: a clearance-keeping path, a turn to face it, a short sweep;
//! 3. then more viewpoints, if needed, until the sequence has its minimum number of
//!    goals and has travelled its minimum distance.
//!
//! What the frames actually show is credited by probing every walked frame, so the
//! plan's predicted coverage is what the rendered sequence will hold (at probe
//! resolution). Everything is deterministic; the seed picks among near-equal starts.
//!
//! One file, over 400 lines, on purpose: it is one algorithm, its steps in the order above.

use std::collections::HashMap;

use osmab_evaluator::synthetic::Rng;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use super::camera::{SensorSettings, camera_pose};
use super::mesh::World;
use super::navigation::{Distances, NavGrid};
use super::raster::{Frame, render_visibility};
use super::trajectory::{AgentState, MotionSettings, Walker, heading_towards, wrap};
use super::view::{Observed, View, ViewpointRule};
use osmab_evaluator::ground_truth::{FRAME_STRIDE, POINT_STRIDE};

/// An object the trajectory must observe.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Target {
    pub instance_id: u16,
    pub class: String,
    /// Named by the scene's prompt: observed first.
    pub prompted: bool,
}

/// What "observed" means for the planner.
#[derive(Debug, Clone, Copy, Serialize, Deserialize)]
pub struct CoverageGoals {
    /// Distinct viewpoints each object is seen from.
    pub views: usize,
    /// Viewpoints closer than this (metres) count as one.
    pub separation: f64,
    /// A viewpoint counts when the object covers at least this share of the image.
    pub view_fraction: f64,
    /// Ground-truth points each object should leave (predicted at probe resolution).
    pub points: f64,
    /// Metres the camera travels at least.
    pub min_travel: f64,
    /// Half-angle (degrees) of the sweep at each viewpoint.
    pub sweep_degrees: f64,
}

impl Default for CoverageGoals {
    fn default() -> Self {
        Self { views: 2, separation: 0.5, view_fraction: 0.0005, points: 30.0, min_travel: 2.0, sweep_degrees: 10.0 }
    }
}

/// One planned viewpoint.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct PlannedView {
    pub goal: usize,
    pub position: [f64; 2],
    pub heading_deg: f64,
    /// The objects it was chosen for.
    pub for_instances: Vec<u16>,
}

/// An object's predicted coverage.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct PredictedCoverage {
    pub instance_id: u16,
    pub class: String,
    pub prompted: bool,
    /// Frames in which it is visible.
    pub frames: usize,
    /// Distinct viewpoints it is seen from.
    pub viewpoints: usize,
    /// Ground-truth points it should leave.
    pub points: f64,
    /// Nearest the camera came to it (metres of depth), if seen.
    pub closest: Option<f64>,
}

impl PredictedCoverage {
    pub fn satisfied(&self, goals: &CoverageGoals) -> bool {
        self.viewpoints >= goals.views && self.points >= goals.points
    }
}

/// A planned trajectory and what it is predicted to observe.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct Plan {
    pub frames: Vec<AgentState>,
    pub goals: usize,
    pub travelled: f64,
    pub viewpoints: Vec<PlannedView>,
    pub coverage: Vec<PredictedCoverage>,
    /// Frames the probes found dominated by one class or short of depth.
    pub degenerate_frames: usize,
    /// Their indices.
    #[serde(default)]
    pub degenerate: Vec<usize>,
    /// Objects no candidate viewpoint sees at all.
    pub never_visible: Vec<u16>,
}

/// Probe image width: enough for a mug across a room to cover a few pixels.
const PROBE_WIDTH: u32 = 120;
/// Headings per candidate position.
const HEADINGS: usize = 12;
/// Candidate positions per scene at most (the lattice widens in large rooms).
const MAX_POSITIONS: usize = 160;
/// Frames a viewpoint costs before its travel (its turn and sweep are added), so a far
/// viewpoint that covers much beats a near one that covers little.
const FIXED_COST: f64 = 40.0;
/// How much more a prompted object weighs.
const PROMPTED_WEIGHT: f64 = 4.0;
/// Viewpoints keep at least this clearance where the room allows (metres).
const VIEWPOINT_CLEARANCE: f64 = 0.3;
/// A viewpoint that one object fills beyond this share of the image is too close to it.
const CROWDED_VIEW: f64 = 0.5;
/// A frame facing a bare wall costs this many frames in choosing a viewpoint.
const DEGENERATE_COST: f64 = 3.0;
/// Frames of an arrival facing the way the path came.
const ARRIVAL_FRAMES: f64 = 20.0;

/// The way to turn at a position from heading index `from` to `to` (of [`HEADINGS`]):
/// left or not, and how many of the headings on the way (both ends included) show a
/// degenerate view — the direction with fewer, the shorter one on a tie.
fn turn_direction(degenerate: &[bool], from: usize, to: usize) -> (bool, usize) {
    let n = degenerate.len();
    let left_steps = (to + n - from) % n;
    let right_steps = (from + n - to) % n;
    let left: usize = (0..=left_steps).map(|j| degenerate[(from + j) % n] as usize).sum();
    let right: usize = (0..=right_steps).map(|j| degenerate[(from + n * n - j) % n] as usize).sum();
    if (left, left_steps) <= (right, right_steps) { (true, left) } else { (false, right) }
}

/// The index of the candidate heading nearest `yaw`.
fn heading_index(yaw: f64) -> usize {
    ((yaw.rem_euclid(std::f64::consts::TAU) / (std::f64::consts::TAU / HEADINGS as f64)).round() as usize) % HEADINGS
}

struct Candidate {
    cell: usize,
    position: [f64; 2],
    heading: f64,
    view: View,
}

/// Renders probe views.
struct Probe<'a> {
    world: &'a World,
    floor_height: f64,
    sensor: SensorSettings,
    /// Full-resolution pixels per probe pixel.
    scale: f64,
}

impl Probe<'_> {
    fn view(&self, state: &AgentState, frame: &mut Frame) -> View {
        let camera = self.sensor.camera(camera_pose(state, self.floor_height, &self.sensor));
        render_visibility(self.world, &camera, frame);
        View::of(frame)
    }
}

impl CoverageGoals {
    /// When a frame of a sequence at `width` × `height` counts as a viewpoint of an object.
    pub fn viewpoint_rule(&self, width: u32, height: u32) -> ViewpointRule {
        ViewpointRule { min_pixels: self.view_fraction * width as f64 * height as f64, separation: self.separation }
    }
}

/// Per object, what the walked frames have shown so far.
struct Tally {
    target: Target,
    weight: f64,
    seen: Observed,
}

impl Tally {
    fn needs_view_at(&self, goals: &CoverageGoals, p: [f64; 2]) -> bool {
        self.seen.viewpoints.len() < goals.views && self.seen.far_from_viewpoints(p, goals.separation)
    }
    fn satisfied(&self, goals: &CoverageGoals) -> bool {
        self.seen.viewpoints.len() >= goals.views && self.seen.points >= goals.points
    }
}

/// Plan a trajectory through `grid` that observes `targets` in `world`.
pub fn plan(world: &World, grid: &NavGrid, sensor: &SensorSettings, motion: &MotionSettings, targets: &[Target], goals: &CoverageGoals) -> Plan {
    let region = grid.largest_region();
    if region.is_empty() {
        return Plan::empty();
    }
    let planner = Planner::new(world, grid, sensor, motion, goals, targets);
    let candidates = planner.probe_candidates(&candidate_cells(grid, &region));
    let never_visible = planner.never_visible(targets, &candidates);
    let mut tallies: Vec<Tally> =
        targets.iter().map(|t| Tally { target: t.clone(), weight: if t.prompted { PROMPTED_WEIGHT } else { 1.0 }, seen: Observed::default() }).collect();

    let start_cell = planner.start_cell(&candidates, &tallies);
    let mut walker = planner.look_around(&candidates, start_cell);
    let mut crediting = Crediting { frame: Frame::default(), credited: 0, degenerate: Vec::new() };
    crediting.credit_new_frames(&planner, &walker, &mut tallies);
    let mut viewpoints = planner.visit_viewpoints(&candidates, &never_visible, &mut walker, &mut tallies, &mut crediting);

    renumber_goals(&mut walker.frames, &mut viewpoints);
    let goal_count = split_goals(&mut walker.frames, &mut viewpoints, motion.goals);
    Plan {
        goals: goal_count,
        travelled: walker.travelled,
        frames: walker.frames,
        viewpoints,
        coverage: tallies.into_iter().map(Tally::predicted).collect(),
        degenerate_frames: crediting.degenerate.len(),
        degenerate: crediting.degenerate,
        never_visible,
    }
}

impl Plan {
    /// The plan of a scene with nowhere to stand: no frames, nothing observed.
    fn empty() -> Plan {
        Plan {
            frames: Vec::new(),
            goals: 0,
            travelled: 0.0,
            viewpoints: Vec::new(),
            coverage: Vec::new(),
            degenerate_frames: 0,
            degenerate: Vec::new(),
            never_visible: Vec::new(),
        }
    }
}

impl Tally {
    /// What the walked frames showed of this object, as the plan reports it.
    fn predicted(self) -> PredictedCoverage {
        PredictedCoverage {
            instance_id: self.target.instance_id,
            class: self.target.class,
            prompted: self.target.prompted,
            frames: self.seen.frames,
            viewpoints: self.seen.viewpoints.len(),
            points: self.seen.points,
            closest: self.seen.closest,
        }
    }
}

/// Candidate viewpoint cells: a lattice over the largest free `region`, keeping clearance
/// where it can; the lattice alone, or the single clearest cell, where it cannot.
fn candidate_cells(grid: &NavGrid, region: &[usize]) -> Vec<usize> {
    let area = region.len() as f64 * grid.cell_size * grid.cell_size;
    let spacing = (area / MAX_POSITIONS as f64).sqrt().max(0.35);
    let stride = ((spacing / grid.cell_size).round() as usize).max(1);
    let on_lattice = |i: usize| (i % grid.width) % stride == stride / 2 && (i / grid.width) % stride == stride / 2;
    let mut cells: Vec<usize> = region.iter().copied().filter(|&i| on_lattice(i) && grid.clearance[i] >= VIEWPOINT_CLEARANCE).collect();
    if cells.is_empty() {
        cells = region.iter().copied().filter(|&i| on_lattice(i)).collect();
    }
    if cells.is_empty() {
        cells.push(*region.iter().max_by(|&&a, &&b| grid.clearance[a].total_cmp(&grid.clearance[b]).then(b.cmp(&a))).expect("non-empty"));
    }
    cells
}

/// The heading indices of candidate `k`'s position (candidates come HEADINGS at a time)
/// whose probe view is degenerate.
fn degenerate_headings(candidates: &[Candidate], k: usize) -> Vec<bool> {
    candidates[k - k % HEADINGS..k - k % HEADINGS + HEADINGS].iter().map(|c| c.view.degenerate()).collect()
}

/// What the planner consults throughout: the scene, the probe, the motion, the goals and
/// what makes a view of an object count.
struct Planner<'a> {
    grid: &'a NavGrid,
    motion: &'a MotionSettings,
    goals: &'a CoverageGoals,
    probe: Probe<'a>,
    rule: ViewpointRule,
    /// Full-resolution pixels an object covers in a view that counts as a viewpoint.
    view_pixels: f64,
    /// Pixels of a "good" view: enough that the frames of a viewpoint leave the points wanted.
    good_pixels: f64,
    /// The index into the targets (and tallies) of each instance id.
    index: HashMap<u16, usize>,
}

/// Whether the walk is still covering objects, and how far it has yet to travel.
#[derive(Clone, Copy)]
struct Need {
    covering: bool,
    travel: f64,
}

impl<'a> Planner<'a> {
    /// The planner for `targets` seen through `sensor` at probe resolution.
    fn new(world: &'a World, grid: &'a NavGrid, sensor: &SensorSettings, motion: &'a MotionSettings, goals: &'a CoverageGoals, targets: &[Target]) -> Self {
        let probe_sensor = sensor.scaled_to(PROBE_WIDTH);
        let probe = Probe {
            world,
            floor_height: grid.floor_height,
            scale: (sensor.width as f64 * sensor.height as f64) / (probe_sensor.width as f64 * probe_sensor.height as f64),
            sensor: probe_sensor,
        };
        let rule = goals.viewpoint_rule(sensor.width, sensor.height);
        let view_pixels = rule.min_pixels;
        let dwell_gt_frames = ((4.0 * goals.sweep_degrees / (motion.turn_degrees / motion.sub_steps as f64)) / FRAME_STRIDE as f64).max(1.0);
        let good_pixels = (goals.points * POINT_STRIDE as f64 / dwell_gt_frames).max(view_pixels);
        let index = targets.iter().enumerate().map(|(i, t)| (t.instance_id, i)).collect();
        Planner { grid, motion, goals, probe, rule, view_pixels, good_pixels, index }
    }

    /// Probe views from every heading at each of `cells`, position by position.
    fn probe_candidates(&self, cells: &[usize]) -> Vec<Candidate> {
        let jobs: Vec<(usize, usize)> = cells.iter().flat_map(|&c| (0..HEADINGS).map(move |h| (c, h))).collect();
        jobs.par_iter()
            .map_init(Frame::default, |frame, &(cell, h)| {
                let position = self.grid.centre(cell);
                let heading = wrap(h as f64 * std::f64::consts::TAU / HEADINGS as f64);
                let state = AgentState { x: position[0], z: position[1], yaw: heading, goal_index: 0, action: super::trajectory::Action::TurnLeft };
                Candidate { cell, position, heading, view: self.probe.view(&state, frame) }
            })
            .collect()
    }

    /// The targets no candidate sees well enough for a viewpoint.
    fn never_visible(&self, targets: &[Target], candidates: &[Candidate]) -> Vec<u16> {
        targets
            .iter()
            .filter(|t| candidates.iter().all(|c| (c.view.pixels_of(t.instance_id) as f64) * self.probe.scale < self.view_pixels))
            .map(|t| t.instance_id)
            .collect()
    }

    /// The start: the position overlooking the most (weighted) objects; the seed picks
    /// among the best three.
    fn start_cell(&self, candidates: &[Candidate], tallies: &[Tally]) -> usize {
        // (Candidates come position by position, HEADINGS at a time.)
        let overlook = |headings: &[Candidate]| -> f64 {
            tallies
                .iter()
                .filter(|t| headings.iter().any(|c| c.view.pixels_of(t.target.instance_id) as f64 * self.probe.scale >= self.view_pixels))
                .map(|t| t.weight)
                .sum::<f64>()
                + self.grid.clearance[headings[0].cell].min(1.0) * 0.5
        };
        let mut starts: Vec<(f64, usize)> = candidates.chunks(HEADINGS).map(|h| (overlook(h), h[0].cell)).collect();
        starts.sort_by(|a, b| b.0.total_cmp(&a.0).then(a.1.cmp(&b.1)));
        let mut rng = Rng::new(self.motion.seed);
        starts[rng.below(starts.len().min(3))].1
    }

    /// A walker at `start_cell` that has looked around: the shortest arc of headings
    /// holding every heading that sees an object, or the whole turn when objects are all around.
    fn look_around(&self, candidates: &[Candidate], start_cell: usize) -> Walker<'a> {
        let at_start: Vec<&Candidate> = candidates.iter().filter(|c| c.cell == start_cell).collect();
        let useful: Vec<bool> = at_start
            .iter()
            .map(|c| {
                !c.view.degenerate()
                    && c.view.objects.iter().any(|v| self.index.contains_key(&v.instance_id) && v.pixels as f64 * self.probe.scale >= self.view_pixels)
            })
            .collect();
        let step = std::f64::consts::TAU / HEADINGS as f64;
        let (arc_start, arc_len) = look_around_arc(&useful);
        let first_heading = at_start.get(arc_start).map_or(0.0, |c| c.heading);
        let mut walker = Walker::new(self.grid, *self.motion, self.grid.centre(start_cell), first_heading);
        walker.turn_by(arc_len as f64 * step);
        walker
    }

    /// Walk viewpoint after viewpoint, each the best value for its cost, until every object
    /// is covered and the camera has travelled enough (or the frames run out).
    fn visit_viewpoints(
        &self,
        candidates: &[Candidate],
        never_visible: &[u16],
        walker: &mut Walker,
        tallies: &mut [Tally],
        crediting: &mut Crediting,
    ) -> Vec<PlannedView> {
        let mut used = vec![false; candidates.len()];
        let mut viewpoints = Vec::new();
        for _ in 0..candidates.len() {
            if walker.budget_left() < self.motion.sub_steps as usize {
                break;
            }
            let covering = tallies.iter().any(|t| !t.satisfied(self.goals) && !never_visible.contains(&t.target.instance_id));
            if !covering && walker.travelled >= self.goals.min_travel {
                break;
            }
            let here = walker.position();
            let Some(here_cell) = self.grid.cell_of(here[0], here[1]) else { break };
            let distances = self.grid.distances_from(here_cell);
            let need = Need { covering, travel: (self.goals.min_travel - walker.travelled).max(0.0) };
            let Some((k, why)) = self.best_viewpoint(candidates, &used, &distances, walker, tallies, need) else { break };
            used[k] = true;
            let (arrived, view) = self.go_to_viewpoint(candidates, k, why, &distances, walker);
            viewpoints.push(view);
            crediting.credit_new_frames(self, walker, tallies);
            if !arrived && walker.budget_left() < self.motion.sub_steps as usize {
                break;
            }
        }
        viewpoints
    }

    /// The unused candidate with the most gain per frame it costs, and the objects it is
    /// for: views that show something well first; any view when none does (an empty room
    /// still needs its goals and its travel).
    fn best_viewpoint(
        &self,
        candidates: &[Candidate],
        used: &[bool],
        distances: &Distances,
        walker: &Walker,
        tallies: &[Tally],
        need: Need,
    ) -> Option<(usize, Vec<u16>)> {
        let mut best: Option<(f64, usize, Vec<u16>)> = None;
        for picky in [true, false] {
            for (k, c) in candidates.iter().enumerate() {
                if used[k] || (picky && (c.view.degenerate() || c.view.largest_object_fraction > CROWDED_VIEW)) {
                    continue;
                }
                let length = distances.length[c.cell];
                if !length.is_finite() {
                    continue;
                }
                let (g, why) = self.gain(c, length, tallies, need);
                if g <= 0.0 {
                    continue;
                }
                let score = g / self.cost(candidates, k, length, walker, why.is_empty());
                if best.as_ref().is_none_or(|b| score > b.0) {
                    best = Some((score, k, why));
                }
            }
            if best.is_some() {
                break;
            }
        }
        best.map(|(_, k, why)| (k, why))
    }

    /// The gain of a candidate `length` metres away, and the objects it adds to: while
    /// covering, what it adds to objects still short of views or points; afterwards further
    /// distinct viewpoints of anything well seen, or, while the camera has not travelled
    /// far enough, the distance it adds.
    fn gain(&self, c: &Candidate, length: f64, tallies: &[Tally], need: Need) -> (f64, Vec<u16>) {
        if !need.covering && need.travel > 0.0 {
            return (length.min(need.travel) + 0.01, Vec::new());
        }
        let mut gain = 0.0;
        let mut why = Vec::new();
        for v in &c.view.objects {
            let Some(&t) = self.index.get(&v.instance_id) else { continue };
            let tally = &tallies[t];
            let pixels = v.pixels as f64 * self.probe.scale;
            let g = if need.covering {
                if tally.satisfied(self.goals) {
                    0.0
                } else {
                    let view = (pixels >= self.view_pixels && tally.needs_view_at(self.goals, c.position)) as u8 as f64;
                    let points = if tally.seen.points < self.goals.points { (pixels / self.good_pixels).min(1.0) } else { 0.0 };
                    view + points
                }
            } else {
                (pixels >= self.good_pixels && tally.seen.far_from_viewpoints(c.position, self.goals.separation)) as u8 as f64 * 0.5
            };
            if g > 0.0 {
                gain += tally.weight * g;
                why.push(v.instance_id);
            }
        }
        // Once covered, a goal that only adds a goal still counts.
        if !need.covering {
            gain += 0.01;
        }
        (gain, why)
    }

    /// The frames candidate `k`, `length` metres away, costs: its travel, its turns, its
    /// sweep and a fixed cost, with frames facing bare walls (arriving towards one, turning
    /// past them) costing more. A goal `only_for_travel` is not turned to or swept.
    fn cost(&self, candidates: &[Candidate], k: usize, length: f64, walker: &Walker, only_for_travel: bool) -> f64 {
        let c = &candidates[k];
        let (step_m, turn_rad) = (self.motion.step_per_frame(), self.motion.turn_per_frame());
        let travel_heading = if length > 0.1 { heading_towards(walker.position(), c.position) } else { walker.yaw };
        let walls = degenerate_headings(candidates, k);
        let arrival = heading_index(travel_heading);
        let arrival_walls = if length > 0.1 && walls[arrival] { ARRIVAL_FRAMES } else { 0.0 };
        if only_for_travel {
            length / step_m + wrap(travel_heading - walker.yaw).abs() / turn_rad + FIXED_COST + DEGENERATE_COST * arrival_walls
        } else {
            let sweep_frames = 4.0 * self.goals.sweep_degrees.to_radians() / turn_rad;
            let frames_per_heading = std::f64::consts::TAU / HEADINGS as f64 / turn_rad;
            let turns = wrap(travel_heading - walker.yaw).abs() + wrap(c.heading - travel_heading).abs();
            let (_, passed) = turn_direction(&walls, arrival, k % HEADINGS);
            let degenerate_frames = arrival_walls + passed as f64 * frames_per_heading;
            length / step_m + turns / turn_rad + sweep_frames + FIXED_COST + DEGENERATE_COST * degenerate_frames
        }
    }

    /// Walk to candidate `k` as a new goal: its path, then (unless it is only for travel)
    /// a turn to its heading and a sweep. Returns whether it got there, and the viewpoint.
    fn go_to_viewpoint(&self, candidates: &[Candidate], k: usize, why: Vec<u16>, distances: &Distances, walker: &mut Walker) -> (bool, PlannedView) {
        let c = &candidates[k];
        walker.goal += 1;
        let path = self.grid.path_to(distances, c.cell).unwrap_or_default();
        let walls = degenerate_headings(candidates, k);
        // Within a heading step the short way; further, the way past fewer bare walls.
        let arrived = walker.follow(&path)
            && if why.is_empty() {
                true
            } else if heading_index(walker.yaw) == k % HEADINGS {
                walker.turn_to(c.heading)
            } else {
                walker.turn_towards(c.heading, turn_direction(&walls, heading_index(walker.yaw), k % HEADINGS).0)
            }
            && (why.is_empty() || walker.sweep(self.goals.sweep_degrees.to_radians()));
        let heading_deg = if why.is_empty() { wrap(walker.yaw).to_degrees() } else { c.heading.to_degrees() };
        (arrived, PlannedView { goal: walker.goal, position: c.position, heading_deg, for_instances: why })
    }
}

/// Credits the walked frames, as they come, to the objects their probe views show.
struct Crediting {
    frame: Frame,
    /// Frames of the walker credited so far.
    credited: usize,
    /// Indices of the walked frames whose probe view is degenerate.
    degenerate: Vec<usize>,
}

impl Crediting {
    /// Probe the frames walked since the last call and credit what each shows to `tallies`.
    fn credit_new_frames(&mut self, planner: &Planner, walker: &Walker, tallies: &mut [Tally]) {
        for (i, state) in walker.frames.iter().enumerate().skip(self.credited) {
            let view = planner.probe.view(state, &mut self.frame);
            if view.degenerate() {
                self.degenerate.push(i);
            }
            for v in &view.objects {
                let Some(&t) = planner.index.get(&v.instance_id) else { continue };
                tallies[t].seen.add(i, [state.x, state.z], v.pixels as f64 * planner.probe.scale, v.nearest as f64, &planner.rule);
            }
        }
        self.credited = walker.frames.len();
    }
}

/// Number the goals that have frames 0, 1, 2, ... in order (a viewpoint reached without
/// a frame — already there — adds no goal); a viewpoint keeps the goal of its frames.
fn renumber_goals(frames: &mut [AgentState], viewpoints: &mut [PlannedView]) {
    let mut map: std::collections::BTreeMap<usize, usize> = std::collections::BTreeMap::new();
    for f in frames.iter() {
        let next = map.len();
        map.entry(f.goal_index).or_insert(next);
    }
    for f in frames.iter_mut() {
        f.goal_index = map[&f.goal_index];
    }
    for v in viewpoints.iter_mut() {
        // The goal itself, or the last goal with frames before it.
        v.goal = map.range(..=v.goal).next_back().map_or(0, |(_, &g)| g);
    }
}

/// Make the trajectory's goals at least `min`: while short, the longest goal's frames are
/// split in two at the middle (a point on the way is a navigation goal as good as its
/// end; lights switch by goal). Returns the number of goals.
fn split_goals(frames: &mut [AgentState], viewpoints: &mut [PlannedView], min: usize) -> usize {
    let mut count = frames.last().map_or(0, |f| f.goal_index + 1);
    while count < min {
        // The longest run of one goal.
        let mut best = (0usize, 0usize); // (length, start)
        let mut start = 0;
        for i in 1..=frames.len() {
            if i == frames.len() || frames[i].goal_index != frames[start].goal_index {
                if i - start > best.0 {
                    best = (i - start, start);
                }
                start = i;
            }
        }
        if best.0 < 2 {
            break;
        }
        let (split_at, goal) = (best.1 + best.0 / 2, frames[best.1].goal_index);
        for f in frames[split_at..].iter_mut() {
            f.goal_index += 1;
        }
        for v in viewpoints.iter_mut().filter(|v| v.goal >= goal + 1 || (v.goal == goal && goal > 0)) {
            v.goal += 1;
        }
        count += 1;
    }
    count
}

/// The arc of headings (first index, number of steps to turn left) to look around
/// through: the longest circular run of useful headings (ones that show objects and are
/// not bare walls), the whole turn when every heading is useful, none when none is.
fn look_around_arc(useful: &[bool]) -> (usize, usize) {
    let n = useful.len();
    if n == 0 || !useful.iter().any(|&u| u) {
        return (0, 0);
    }
    if useful.iter().all(|&u| u) {
        return (0, n);
    }
    let (mut best_len, mut best_end) = (0, 0);
    let mut run = 0;
    for i in 0..2 * n {
        if useful[i % n] {
            run += 1;
            if run > best_len {
                best_len = run;
                best_end = i % n;
            }
        } else {
            run = 0;
        }
    }
    ((best_end + n + 1 - best_len) % n, best_len - 1)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn short_trajectories_get_their_goals_by_splitting_the_longest() {
        let state = |goal_index| AgentState { x: 0.0, z: 0.0, yaw: 0.0, goal_index, action: super::super::trajectory::Action::TurnLeft };
        let mut frames: Vec<AgentState> = [0, 0, 1, 1, 1, 1, 1, 1, 2, 2].into_iter().map(state).collect();
        let mut views = vec![
            PlannedView { goal: 1, position: [0.0; 2], heading_deg: 0.0, for_instances: vec![] },
            PlannedView { goal: 2, position: [0.0; 2], heading_deg: 0.0, for_instances: vec![] },
        ];
        assert_eq!(split_goals(&mut frames, &mut views, 5), 5);
        let goals: Vec<usize> = frames.iter().map(|f| f.goal_index).collect();
        assert_eq!(goals, [0, 0, 1, 2, 2, 3, 3, 3, 4, 4]);
        assert_eq!(views.iter().map(|v| v.goal).collect::<Vec<_>>(), [3, 4], "a viewpoint ends the goal that reaches it");
        assert_eq!(split_goals(&mut frames, &mut views, 2), 5, "enough goals are left alone");
    }

    #[test]
    fn turns_go_the_way_that_passes_fewer_bare_walls() {
        let mut walls = [false; 12];
        // From heading 0 to heading 3: left passes 1, 2; right passes 11 .. 4.
        assert_eq!(turn_direction(&walls, 0, 3), (true, 0), "the shorter way when nothing differs");
        walls[1] = true;
        walls[2] = true;
        assert_eq!(turn_direction(&walls, 0, 3), (false, 0), "the long way round, past no wall");
        walls[8] = true;
        walls[9] = true;
        walls[10] = true;
        assert_eq!(turn_direction(&walls, 0, 3), (true, 2));
        assert_eq!(heading_index(-std::f64::consts::FRAC_PI_2), 9);
    }

    #[test]
    fn the_look_around_turns_through_the_longest_useful_arc() {
        // Useful headings 2..=5 of 12: start at 2, turn 3 steps to reach 5.
        let mut useful = [false; 12];
        for u in &mut useful[2..=5] {
            *u = true;
        }
        assert_eq!(look_around_arc(&useful), (2, 3));
        useful[8] = true;
        assert_eq!(look_around_arc(&useful), (2, 3), "a lone useful heading elsewhere is left to the viewpoints");
        // Wrapping around 0.
        let mut wrapped = [false; 12];
        for i in [10, 11, 0, 1] {
            wrapped[i] = true;
        }
        assert_eq!(look_around_arc(&wrapped), (10, 3));
        assert_eq!(look_around_arc(&[true; 12]), (0, 12));
        assert_eq!(look_around_arc(&[false; 12]), (0, 0));
    }
}
