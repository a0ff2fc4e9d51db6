//! The four lighting conditions of OSMa-Bench++, laid out for each room as HaDaGe light
//! settings (and, without life intervals, as Habitat lighting configs):
//!
//! - `baseline`: ceiling point lights on a grid (at most 2.5 m apart, at least two),
//!   just under the ceiling fixtures the synthesizer hangs there ([`FIXTURE_DROP`] under
//!   the wall top), their intensity calibrated per room so that the floor
//!   and the walls up to 2 m are exposed like Habitat's flat albedo — the 90th
//!   percentile of the light factor `0.4 + Σ lights` on them is [`EXPOSURE_TARGET`] —
//!   so white walls are not blown out however large or small the room;
//! - `camera`: one light attached to the camera, above and behind it like a head lamp,
//!   so near surfaces are brighter than far ones without saturating at arm's length;
//! - `dynamic_lights`: the baseline lights in two zones (alternate lights of the grid),
//!   switched and dimmed by navigation goal in a cycle of three — one zone on and the
//!   other dimmed; all dimmed; the first off and the second on — so the room gets
//!   brighter and darker along the trajectory (from the first goal to the second, as
//!   far as the cycle goes) and the camera moves between differently lit areas;
//! - `no_lights`: none (Habitat's flat shading: the nominal, mesh-lit condition).
//!
//! Shading follows Habitat's Phong model (docs/rendering.md): light colour
//! `clip(colour) · intensity · 2.5`, Lambert over `1 + d²`, ambient 0.4.

use std::collections::BTreeMap;

use osmab_evaluator::scores::ReleaseLighting;
use serde_json::{Value, json};

use super::light_settings::{HadageLight, LightSettings};

/// Ceiling lights at most this far apart (metres).
const LIGHT_SPACING: f64 = 2.5;
/// How far under the wall top a ceiling light shines from: the underside of its fixture
/// ([`FIXTURE_HEIGHT`] tall) and a little more.
pub const FIXTURE_DROP: f64 = 0.12;
/// The height of a ceiling fixture (a flush dome), metres.
pub const FIXTURE_HEIGHT: f64 = 0.08;
/// The 90th percentile of the light factor on floor and walls under `baseline`.
pub const EXPOSURE_TARGET: f64 = 1.0;
/// Habitat's ambient term and its scale of positive intensities.
const AMBIENT: f64 = 0.4;
const POSITIVE_SCALE: f64 = 2.5;
/// The camera light: intensity and offset in Habitat's camera frame (x right, y up,
/// z backward), metres.
pub const CAMERA_LIGHT_INTENSITY: f64 = 0.8;
pub const CAMERA_LIGHT_OFFSET: [f64; 3] = [0.0, 0.25, 0.75];
/// A dimmed light's share of its full intensity.
const DIMMED: f64 = 0.3;
/// Goals the dynamic pattern is written for (the last state holds after them).
const PATTERN_GOALS: usize = 64;
/// The ceiling lights' colour: a warm white as a camera white-balanced for it records it,
/// barely tinted (a stronger tint pushed wood and leather into toy-like saturation).
const WARM_WHITE: [f64; 3] = [1.0, 0.98, 0.95];

/// A ceiling light of the grid: position and (column, row).
struct CeilingLight {
    position: [f64; 3],
    cell: (usize, usize),
}

fn ceiling_grid(floor: ([f64; 3], [f64; 3]), ceiling_height: f64) -> Vec<CeilingLight> {
    let (lo, hi) = floor;
    let (w, d) = (hi[0] - lo[0], hi[2] - lo[2]);
    let mut nx = (w / LIGHT_SPACING).ceil().clamp(1.0, 64.0) as usize;
    let mut nz = (d / LIGHT_SPACING).ceil().clamp(1.0, 64.0) as usize;
    if nx * nz < 2 {
        // Two zones at least, so some of the room can be lit while the rest is not.
        if w >= d { nx = 2 } else { nz = 2 }
    }
    let y = hi[1] + ceiling_height - FIXTURE_DROP;
    let mut lights = Vec::new();
    for i in 0..nx {
        for k in 0..nz {
            let x = lo[0] + w * (i as f64 + 0.5) / nx as f64;
            let z = lo[2] + d * (k as f64 + 0.5) / nz as f64;
            lights.push(CeilingLight { position: [x, y, z], cell: (i, k) });
        }
    }
    lights
}

/// Where the ceiling lights of a room with `floor` bounds (Habitat axes) and walls
/// `ceiling_height` high shine from: the synthesizer hangs their fixtures there.
pub fn ceiling_light_positions(floor: ([f64; 3], [f64; 3]), ceiling_height: f64) -> Vec<[f64; 3]> {
    ceiling_grid(floor, ceiling_height).into_iter().map(|l| l.position).collect()
}

/// The light factor (beyond ambient) of unit-intensity `lights` at point `p` with
/// normal `n`: Habitat's Lambert term over `1 + d²`.
fn irradiance(lights: &[CeilingLight], p: [f64; 3], n: [f64; 3]) -> f64 {
    lights
        .iter()
        .map(|l| {
            let d = [l.position[0] - p[0], l.position[1] - p[1], l.position[2] - p[2]];
            let d2 = d[0] * d[0] + d[1] * d[1] + d[2] * d[2];
            let facing = (n[0] * d[0] + n[1] * d[1] + n[2] * d[2]).max(0.0) / d2.sqrt().max(1e-9);
            POSITIVE_SCALE * facing / (1.0 + d2)
        })
        .sum()
}

/// The intensity that puts the 90th percentile of the light factor on the floor and on
/// the walls up to 2 m at [`EXPOSURE_TARGET`].
fn calibrated_intensity(lights: &[CeilingLight], floor: ([f64; 3], [f64; 3]), ceiling_height: f64) -> f64 {
    let (lo, hi) = floor;
    let y0 = hi[1];
    let step = 0.25;
    let (nx, nz) = ((((hi[0] - lo[0]) / step).ceil() as usize).max(1), (((hi[2] - lo[2]) / step).ceil() as usize).max(1));
    let at = |a: f64, b: f64, t: usize, n: usize| a + (b - a) * (t as f64 + 0.5) / n as f64;
    let mut samples = Vec::new();
    for i in 0..nx {
        for k in 0..nz {
            samples.push(irradiance(lights, [at(lo[0], hi[0], i, nx), y0, at(lo[2], hi[2], k, nz)], [0.0, 1.0, 0.0]));
        }
    }
    let top = 2.0f64.min(ceiling_height);
    let levels = ((top / 0.2) as usize).max(1);
    for h in 0..levels {
        let y = y0 + at(0.0, top, h, levels);
        for i in 0..nx {
            let x = at(lo[0], hi[0], i, nx);
            samples.push(irradiance(lights, [x, y, lo[2]], [0.0, 0.0, 1.0]));
            samples.push(irradiance(lights, [x, y, hi[2]], [0.0, 0.0, -1.0]));
        }
        for k in 0..nz {
            let z = at(lo[2], hi[2], k, nz);
            samples.push(irradiance(lights, [lo[0], y, z], [1.0, 0.0, 0.0]));
            samples.push(irradiance(lights, [hi[0], y, z], [-1.0, 0.0, 0.0]));
        }
    }
    samples.sort_by(f64::total_cmp);
    let p90 = samples[(samples.len() * 9 / 10).min(samples.len() - 1)];
    // Three decimals, so the published files read cleanly.
    (((EXPOSURE_TARGET - AMBIENT) / p90.max(1e-9)) * 1000.0).round() / 1000.0
}

/// A light's state in goal `goal` of the dynamic pattern: 0 on, 1 dimmed, 2 off. Lights
/// form two zones by the parity of their grid cell; goals cycle through (zone 0 on,
/// zone 1 dimmed), (both dimmed), (zone 0 off, zone 1 on). The brightest and the
/// darkest states come first, so even a sequence of two goals sees the room's
/// brightness change by the most the pattern has.
fn dynamic_state(cell: (usize, usize), goal: usize) -> usize {
    let zone = (cell.0 + cell.1) % 2;
    match (goal % 3, zone) {
        (0, 0) => 0,
        (0, _) => 1,
        (1, _) => 1,
        (2, 0) => 2,
        _ => 0,
    }
}

/// The `[start, end)` runs of goals (below [`PATTERN_GOALS`]; the last run open-ended
/// when it reaches the end) in which `state` holds for a light in `cell`.
fn runs(cell: (usize, usize), state: usize) -> Vec<[Option<u64>; 2]> {
    let mut intervals = Vec::new();
    let mut goal = 0;
    while goal < PATTERN_GOALS {
        if dynamic_state(cell, goal) != state {
            goal += 1;
            continue;
        }
        let start = goal;
        while goal < PATTERN_GOALS && dynamic_state(cell, goal) == state {
            goal += 1;
        }
        let end = (goal < PATTERN_GOALS).then_some(goal as u64);
        intervals.push([Some(start as u64), end]);
    }
    intervals
}

/// Every lighting of a release as HaDaGe light settings, laid out for a room with `floor`
/// bounds (Habitat axes) and walls `ceiling_height` high.
pub fn lighting(floor: ([f64; 3], [f64; 3]), ceiling_height: f64) -> BTreeMap<ReleaseLighting, LightSettings> {
    let grid = ceiling_grid(floor, ceiling_height);
    let intensity = calibrated_intensity(&grid, floor, ceiling_height);
    let point = |position: [f64; 3], intensity: f64, runs: Vec<[Option<u64>; 2]>| HadageLight {
        life_intervals: Some(runs),
        ..HadageLight::always("point", position, intensity, WARM_WHITE)
    };
    let mut baseline = LightSettings::default();
    let mut dynamic = LightSettings::default();
    for (k, light) in grid.iter().enumerate() {
        baseline.lights.insert(k.to_string(), HadageLight::always("point", light.position, intensity, WARM_WHITE));
        dynamic.lights.insert(format!("{k}_on"), point(light.position, intensity, runs(light.cell, 0)));
        dynamic.lights.insert(format!("{k}_dimmed"), point(light.position, (intensity * DIMMED * 1000.0).round() / 1000.0, runs(light.cell, 1)));
    }
    let lights = |lighting: ReleaseLighting| match lighting {
        ReleaseLighting::Baseline => baseline.clone(),
        ReleaseLighting::Camera => LightSettings {
            lights: BTreeMap::from([("0".to_string(), HadageLight::always("camera", CAMERA_LIGHT_OFFSET, CAMERA_LIGHT_INTENSITY, [1.0, 1.0, 1.0]))]),
        },
        ReleaseLighting::DynamicLights => dynamic.clone(),
        ReleaseLighting::NoLights => LightSettings::default(),
    };
    ReleaseLighting::ALL.into_iter().map(|lighting| (lighting, lights(lighting))).collect()
}

/// A HaDaGe light-settings file as a Habitat lighting config (`camera` lights become
/// point lights attached to the camera; life intervals do not exist there).
pub fn habitat_lighting(hadage: &LightSettings) -> Value {
    let mut lights = serde_json::Map::new();
    for (id, light) in &hadage.lights {
        let model = if light.attached_to_camera() { "camera" } else { "global" };
        lights.insert(
            id.clone(),
            json!({"type": "point", "position": light.position, "intensity": light.intensity, "color": light.color, "position_model": model}),
        );
    }
    json!({"lights": lights})
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::render::sequence::lights_for_goal;

    const ROOM: ([f64; 3], [f64; 3]) = ([-2.5, -0.1, -2.0], [2.5, 0.0, 2.0]);

    #[test]
    fn baseline_lights_expose_floor_and_walls_like_flat_albedo() {
        for (floor, height) in [(ROOM, 2.5), (([-1.0, -0.1, -1.0], [1.0, 0.0, 1.0]), 2.5), (([-4.0, -0.1, -3.5], [4.0, 0.0, 3.5]), 3.0)] {
            let grid = ceiling_grid(floor, height);
            assert!(grid.len() >= 2, "two zones at least");
            let intensity = calibrated_intensity(&grid, floor, height);
            // Under a light, the floor is lit near the target; nowhere on the floor or the
            // lower walls much beyond it.
            let under = AMBIENT + intensity * irradiance(&grid, [grid[0].position[0], floor.1[1], grid[0].position[2]], [0.0, 1.0, 0.0]);
            assert!((0.7..=1.1).contains(&under), "{under}");
            let corner = AMBIENT + intensity * irradiance(&grid, [floor.0[0] + 0.01, floor.1[1] + 1.0, floor.0[2] + 0.5], [1.0, 0.0, 0.0]);
            assert!(corner < 1.2, "{corner}");
        }
    }

    #[test]
    fn dynamic_lights_change_at_every_goal_and_differ_from_baseline_from_the_first() {
        let settings = lighting(ROOM, 2.5);
        let baseline = lights_for_goal(&settings[&ReleaseLighting::Baseline], 0);
        let mut previous = None;
        for goal in 0..80 {
            let lights = lights_for_goal(&settings[&ReleaseLighting::DynamicLights], goal);
            assert!(lights.len() <= baseline.len(), "a light is on or dimmed, never both");
            assert_ne!(lights, baseline, "goal {goal}: some light is dimmed or off");
            if goal < PATTERN_GOALS {
                assert_ne!(Some(&lights), previous.as_ref(), "goal {goal}: the lights changed");
            }
            previous = Some(lights);
        }
        assert!(lights_for_goal(&settings[&ReleaseLighting::NoLights], 0).is_empty());
        let camera = lights_for_goal(&settings[&ReleaseLighting::Camera], 3);
        assert_eq!(camera.len(), 1);
        assert!(camera[0].attached_to_camera);
    }
}
