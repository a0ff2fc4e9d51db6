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
    /// Whether the plan observes it enough: a prompted object from the goals' viewpoints
    /// with their points, the room's dressing from one viewpoint with a third of them.
    pub fn satisfied(&self, goals: &CoverageGoals) -> bool {
        let (views, points) = if self.prompted { (goals.views, goals.points) } else { (1, goals.points / 3.0) };
        self.viewpoints >= views && self.points >= points
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
/// How much more a step costs in a nook whose every view is bare.
const NOOK_PENALTY: f64 = 4.0;
/// How far apart the walk to a viewpoint is looked along for bare views, metres.
const PATH_SAMPLE: f64 = 0.25;
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
    /// The viewpoints it needs: the goal's for a prompted object; one for the rest (the
    /// room's dressing: a vase on a shelf need not be walked up to from two sides).
    fn views_wanted(&self, goals: &CoverageGoals) -> usize {
        if self.target.prompted { goals.views } else { 1 }
    }
    /// The ground-truth points it needs: the goal's for a prompted object, a third of them
    /// for the rest.
    fn points_wanted(&self, goals: &CoverageGoals) -> f64 {
        if self.target.prompted { goals.points } else { goals.points / 3.0 }
    }
    fn needs_view_at(&self, goals: &CoverageGoals, p: [f64; 2]) -> bool {
        self.seen.viewpoints.len() < self.views_wanted(goals) && self.seen.far_from_viewpoints(p, goals.separation)
    }
    fn satisfied(&self, goals: &CoverageGoals) -> bool {
        self.seen.viewpoints.len() >= self.views_wanted(goals) && self.seen.points >= self.points_wanted(goals)
    }
}

/// Plan a trajectory through `grid` that observes `targets` in `world`.
pub fn plan(world: &World, grid: &NavGrid, sensor: &SensorSettings, motion: &MotionSettings, targets: &[Target], goals: &CoverageGoals) -> Plan {
    let region = grid.largest_region();
    if region.is_empty() {
        return Plan::empty();
    }
    let candidates = Planner::new(world, grid, sensor, motion, goals, targets).probe_candidates(&candidate_cells(grid, &region));
    let nearest_position = nearest_positions(grid, &candidates);
    // Paths and viewpoints keep out of nooks where the camera sees only walls.
    let grid = &grid.clone().with_penalty(nook_penalty(&candidates, &nearest_position));
    let mut planner = Planner::new(world, grid, sensor, motion, goals, targets);
    planner.nearest_position = nearest_position;
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

/// Per cell, what a step onto it costs more where the views from the nearest probed
/// position (`nearest`) are mostly bare: nothing while half or fewer of its headings are,
/// up to [`NOOK_PENALTY`] where all are.
fn nook_penalty(candidates: &[Candidate], nearest: &[usize]) -> Vec<f64> {
    let bare_share: Vec<f64> = candidates.chunks(HEADINGS).map(|c| c.iter().filter(|c| c.view.bare()).count() as f64 / HEADINGS as f64).collect();
    nearest.iter().map(|&p| bare_share.get(p).map_or(0.0, |s| NOOK_PENALTY * (2.0 * s - 1.0).max(0.0))).collect()
}

/// Per cell of `grid`, the index of the nearest of the probed positions (candidates come
/// [`HEADINGS`] at a time).
fn nearest_positions(grid: &NavGrid, candidates: &[Candidate]) -> Vec<usize> {
    let positions: Vec<[f64; 2]> = candidates.chunks(HEADINGS).map(|c| c[0].position).collect();
    (0..grid.width * grid.height)
        .map(|i| {
            let p = grid.centre(i);
            let d2 = |q: &[f64; 2]| (q[0] - p[0]).powi(2) + (q[1] - p[1]).powi(2);
            (0..positions.len()).min_by(|&a, &b| d2(&positions[a]).total_cmp(&d2(&positions[b])).then(a.cmp(&b))).unwrap_or(usize::MAX)
        })
        .collect()
}

/// Candidate viewpoint cells: one per square of a lattice over the largest free `region`,
/// the cell nearest the square's centre among those keeping [`VIEWPOINT_CLEARANCE`] (or
/// as much clearance as the square has), so narrow passages between furniture get
/// viewpoints too.
fn candidate_cells(grid: &NavGrid, region: &[usize]) -> Vec<usize> {
    let area = region.len() as f64 * grid.cell_size * grid.cell_size;
    let spacing = (area / MAX_POSITIONS as f64).sqrt().max(0.35);
    let stride = ((spacing / grid.cell_size).round() as usize).max(1);
    let square = |i: usize| ((i % grid.width) / stride, (i / grid.width) / stride);
    let off_centre = |i: usize| {
        let from_centre = |v: usize| v as i64 - (v / stride * stride + stride / 2) as i64;
        from_centre(i % grid.width).pow(2) + from_centre(i / grid.width).pow(2)
    };
    let mut best: std::collections::BTreeMap<(usize, usize), usize> = std::collections::BTreeMap::new();
    for &i in region {
        let better = |j: usize| {
            let clear = |c: usize| grid.clearance[c].min(VIEWPOINT_CLEARANCE);
            clear(i).total_cmp(&clear(j)).then(off_centre(j).cmp(&off_centre(i))).then(j.cmp(&i)).is_gt()
        };
        best.entry(square(i))
            .and_modify(|j| {
                if better(*j) {
                    *j = i
                }
            })
            .or_insert(i);
    }
    let mut cells: Vec<usize> = best.into_values().collect();
    cells.sort_unstable();
    cells
}

/// The heading indices of candidate `k`'s position (candidates come HEADINGS at a time)
/// whose probe view is bare (a wall, a floor, too little of any object).
fn bare_headings(candidates: &[Candidate], k: usize) -> Vec<bool> {
    candidates[k - k % HEADINGS..k - k % HEADINGS + HEADINGS].iter().map(|c| c.view.bare()).collect()
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
    /// Per navigation cell, the nearest candidate position (its index among the positions,
    /// candidates coming [`HEADINGS`] at a time); `usize::MAX` before they are probed.
    nearest_position: Vec<usize>,
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
        Planner { grid, motion, goals, probe, rule, view_pixels, good_pixels, index, nearest_position: Vec::new() }
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
                !c.view.bare()
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
            if why.is_empty() {
                // A goal only for travel uses up its position: travel goes somewhere new.
                used[k - k % HEADINGS..k - k % HEADINGS + HEADINGS].fill(true);
            }
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
                if used[k] || (picky && (c.view.bare() || c.view.largest_object_fraction > CROWDED_VIEW)) {
                    continue;
                }
                let length = distances.length[c.cell];
                if !length.is_finite() {
                    continue;
                }
                let (g, why) = self.gain(c, length, tallies, need);
                if g <= 0.0 || (picky && why.is_empty() && self.arrives_facing_bare(candidates, k, length, walker)) {
                    continue;
                }
                let score = g / self.cost(candidates, k, distances, walker, why.is_empty());
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
                    let points = if tally.seen.points < tally.points_wanted(self.goals) { (pixels / self.good_pixels).min(1.0) } else { 0.0 };
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

    /// The frames candidate `k` costs: its travel, its turn to the candidate's heading, its
    /// sweep and a fixed cost, with frames facing bare walls (on the way there, arriving
    /// towards one, turning past them) costing more. A goal `only_for_travel` is turned to
    /// its heading (so it ends on a view of something) but not swept.
    fn cost(&self, candidates: &[Candidate], k: usize, distances: &Distances, walker: &Walker, only_for_travel: bool) -> f64 {
        let c = &candidates[k];
        let length = distances.length[c.cell];
        let on_the_way = DEGENERATE_COST * self.bare_frames_on_the_way(candidates, distances, c.cell);
        let (step_m, turn_rad) = (self.motion.step_per_frame(), self.motion.turn_per_frame());
        let travel_heading = if length > 0.1 { heading_towards(walker.position(), c.position) } else { walker.yaw };
        let walls = bare_headings(candidates, k);
        let arrival = heading_index(travel_heading);
        let arrival_walls = if length > 0.1 && walls[arrival] { ARRIVAL_FRAMES } else { 0.0 };
        let sweep_frames = if only_for_travel { 0.0 } else { 4.0 * self.goals.sweep_degrees.to_radians() / turn_rad };
        let frames_per_heading = std::f64::consts::TAU / HEADINGS as f64 / turn_rad;
        let turns = wrap(travel_heading - walker.yaw).abs() + wrap(c.heading - travel_heading).abs();
        let (_, passed) = turn_direction(&walls, arrival, k % HEADINGS);
        let degenerate_frames = arrival_walls + passed as f64 * frames_per_heading;
        length / step_m + on_the_way + turns / turn_rad + sweep_frames + FIXED_COST + DEGENERATE_COST * degenerate_frames
    }

    /// Whether walking `length` metres to candidate `k` ends facing a bare view (a goal only
    /// for travel is not worth walking up to a wall for).
    fn arrives_facing_bare(&self, candidates: &[Candidate], k: usize, length: f64, walker: &Walker) -> bool {
        // The candidate at the same position facing the way the walk arrives.
        let arriving = k - k % HEADINGS + heading_index(heading_towards(walker.position(), candidates[k].position));
        length > 0.1 && candidates[arriving].view.bare()
    }

    /// How many of the frames walking to `cell` would face a bare view: along the path, the
    /// probe of the nearest candidate position in the walking direction, every
    /// [`PATH_SAMPLE`] metres.
    fn bare_frames_on_the_way(&self, candidates: &[Candidate], distances: &Distances, cell: usize) -> f64 {
        let Some(path) = self.grid.path_to(distances, cell) else { return 0.0 };
        let frames_per_sample = PATH_SAMPLE / self.motion.step_per_frame();
        let mut bare = 0.0;
        for w in path.windows(2) {
            let (a, b) = (w[0], w[1]);
            let length = ((b[0] - a[0]).powi(2) + (b[1] - a[1]).powi(2)).sqrt();
            let heading = heading_towards(a, b);
            let samples = (length / PATH_SAMPLE).ceil() as usize;
            for s in 0..samples {
                let t = (s as f64 + 0.5) / samples as f64;
                let Some(at) = self.grid.cell_of(a[0] + t * (b[0] - a[0]), a[1] + t * (b[1] - a[1])) else { continue };
                let position = self.nearest_position[at];
                if position != usize::MAX && candidates[position * HEADINGS + heading_index(heading)].view.bare() {
                    bare += frames_per_sample * (length / samples as f64) / PATH_SAMPLE;
                }
            }
        }
        bare
    }

    /// Walk to candidate `k` as a new goal: its path, a turn to its heading and (unless it
    /// is only for travel) a sweep. Returns whether it got there, and the viewpoint.
    fn go_to_viewpoint(&self, candidates: &[Candidate], k: usize, why: Vec<u16>, distances: &Distances, walker: &mut Walker) -> (bool, PlannedView) {
        let c = &candidates[k];
        walker.goal += 1;
        let path = self.grid.path_to(distances, c.cell).unwrap_or_default();
        let walls = bare_headings(candidates, k);
        // Within a heading step the short way; further, the way past fewer bare walls.
        // A goal only for travel still ends facing its heading, a view of something.
        let arrived = walker.follow(&path)
            && if heading_index(walker.yaw) == k % HEADINGS {
                walker.turn_to(c.heading)
            } else {
                walker.turn_towards(c.heading, turn_direction(&walls, heading_index(walker.yaw), k % HEADINGS).0)
            }
            && (why.is_empty() || walker.sweep(self.goals.sweep_degrees.to_radians()));
        (arrived, PlannedView { goal: walker.goal, position: c.position, heading_deg: c.heading.to_degrees(), for_instances: why })
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
