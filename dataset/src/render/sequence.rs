//! Rendering a trajectory into HaDaGe's sequence layout, byte-compatible with what
//! ConceptGraphs and BBQ read: `results/{frame,depth,semantic}%06d.{jpg,png,png}`,
//! `traj.txt`, `camera_params.yaml`, `embed_semseg_classes.json`, `log.txt` and copies
//! of the settings and light files.

use std::collections::BTreeMap;
use std::path::Path;

use nalgebra::Matrix4;
use osmab_evaluator::formats::camera::CameraParams;
use osmab_evaluator::formats::classes::ClassList;
use osmab_evaluator::formats::image::{GrayImage16, RgbImage, write_jpeg_rgb, write_png_gray16};
use osmab_evaluator::formats::sequence::frame_path;
use osmab_evaluator::formats::trajectory::Trajectory;
use osmab_evaluator::{InputError, Result};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use serde_json::Value;

use super::mesh::World;
use super::raster::{Camera, Frame, Light, Shading, render};
use super::trajectory::AgentState;

/// Camera and image settings (HaDaGe / OSMa-Bench++ defaults).
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct SensorSettings {
    pub width: u32,
    pub height: u32,
    pub hfov: f64,
    pub sensor_height: f64,
    pub depth_scale: f64,
    /// Pillow's default JPEG quality.
    pub jpeg_quality: u8,
}

impl Default for SensorSettings {
    fn default() -> Self {
        Self { width: 1200, height: 680, hfov: 90.0, sensor_height: 1.0, depth_scale: 6553.5, jpeg_quality: 75 }
    }
}

impl SensorSettings {
    /// The first setting a camera cannot have, as (field, expectation).
    pub fn problem(&self) -> Option<(&'static str, &'static str)> {
        if !(16..=8192).contains(&self.width) || !(16..=8192).contains(&self.height) {
            Some(("width", "image sides must be 16..=8192"))
        } else if !(self.hfov > 0.0 && self.hfov < 180.0) {
            Some(("hfov", "a horizontal field of view in degrees, in (0, 180)"))
        } else if !(self.sensor_height > 0.0 && self.sensor_height < 1.5) {
            Some(("sensor_height", "metres above the floor, in (0, 1.5) (below the agent's height)"))
        } else {
            None
        }
    }
}

/// The camera-to-world pose (OpenCV axes) of an agent state, as HaDaGe writes it:
/// Habitat's camera rotation with its y and z columns negated.
pub fn camera_pose(state: &AgentState, floor_height: f64, sensor_height: f64) -> Matrix4<f64> {
    let (s, c) = state.yaw.sin_cos();
    // Habitat camera: x right = (cos, 0, −sin), y up, looks along −z = (−sin, 0, −cos).
    Matrix4::new(c, 0.0, -s, state.x, 0.0, -1.0, 0.0, floor_height + sensor_height, -s, 0.0, -c, state.z, 0.0, 0.0, 0.0, 1.0)
}

/// A HaDaGe light-settings file as the renderer's lights for navigation segment `goal`
/// (a light is on when one of its `life_intervals` [start, end) holds the segment).
pub fn lights_for_goal(settings: &Value, goal: usize) -> Vec<Light> {
    let mut lights = Vec::new();
    for (_, l) in settings["lights"].as_object().into_iter().flatten() {
        let active = l["life_intervals"].as_array().is_none_or(|intervals| {
            intervals.iter().any(|iv| {
                let start = iv[0].as_u64().map_or(true, |s| s as usize <= goal);
                let end = iv[1].as_u64().map_or(true, |e| goal < e as usize);
                start && end
            })
        });
        if !active {
            continue;
        }
        let f = |k: &str, i: usize| l[k][i].as_f64().unwrap_or(0.0) as f32;
        let intensity = l["intensity"].as_f64().unwrap_or(0.0) as f32;
        let scale = intensity * if intensity < 0.0 { 0.1 } else { 2.5 };
        lights.push(Light {
            position: [f("position", 0), f("position", 1), f("position", 2)],
            color: [f("color", 0).clamp(0.0, 1.0) * scale, f("color", 1).clamp(0.0, 1.0) * scale, f("color", 2).clamp(0.0, 1.0) * scale],
            attached_to_camera: l["type"] == "camera",
        });
    }
    lights
}

/// What a rendered sequence holds.
#[derive(Debug, Clone, Default, Serialize, Deserialize)]
pub struct SequenceSummary {
    pub frames: usize,
    /// Pixels of each class over all frames.
    pub class_pixels: BTreeMap<u16, u64>,
}

/// Render `states` of `world` lit by `light_settings` into `dir` (HaDaGe's layout).
#[allow(clippy::too_many_arguments)]
pub fn render_sequence(
    world: &World,
    states: &[AgentState],
    floor_height: f64,
    sensor: &SensorSettings,
    light_settings: &Value,
    classes: &ClassList,
    settings_copy: &Value,
    dir: &Path,
) -> Result<SequenceSummary> {
    let results = dir.join("results");
    if dir.exists() {
        std::fs::remove_dir_all(dir).map_err(|e| InputError::io(dir, &e))?;
    }
    std::fs::create_dir_all(&results).map_err(|e| InputError::io(&results, &e))?;
    let params = CameraParams::from_hfov(sensor.width, sensor.height, sensor.hfov, sensor.depth_scale);
    params.write(&dir.join("camera_params.yaml"))?;
    std::fs::write(
        dir.join("camera_params.txt"),
        format!(
            "camera_matrix = \n[[{} 0. {}]\n [0. {} {}]\n [0. 0. 1.]]\n\ndepth_scale = {}\n",
            params.fx, params.cx, params.fy, params.cy, sensor.depth_scale
        ),
    )
    .map_err(|e| InputError::io(dir, &e))?;
    classes.write(&dir.join("embed_semseg_classes.json"))?;
    let configs = dir.join("configs");
    for (sub, value) in [("sim_settings/settings.json", settings_copy), ("lighting/light_settings.json", light_settings)] {
        let path = configs.join(sub);
        std::fs::create_dir_all(path.parent().expect("nested")).map_err(|e| InputError::io(&path, &e))?;
        std::fs::write(&path, serde_json::to_string_pretty(value).expect("json")).map_err(|e| InputError::io(&path, &e))?;
    }
    let poses: Vec<Matrix4<f64>> = states.iter().map(|s| camera_pose(s, floor_height, sensor.sensor_height)).collect();
    Trajectory { poses: poses.clone() }.write(&dir.join("traj.txt"))?;
    let log: String = states.iter().enumerate().map(|(i, s)| format!("[{i:06}] Action: {}\n", s.action.name())).collect();
    std::fs::write(dir.join("log.txt"), log).map_err(|e| InputError::io(dir, &e))?;

    let mut summary = SequenceSummary { frames: states.len(), ..Default::default() };
    let mut pixel_counts = vec![0u64; 1 << 16];
    // A lighting without any light is flat; one whose lights are all off in a segment
    // is lit by the ambient term only (never brighter than with them on).
    let flat = has_no_lights(light_settings);
    const BATCH: usize = 8;
    let mut frames: Vec<Frame> = (0..BATCH).map(|_| Frame::default()).collect();
    for start in (0..states.len()).step_by(BATCH) {
        let end = (start + BATCH).min(states.len());
        for (k, i) in (start..end).enumerate() {
            let camera = Camera { width: sensor.width, height: sensor.height, fx: params.fx, fy: params.fy, cx: params.cx, cy: params.cy, pose: poses[i] };
            let lights = lights_for_goal(light_settings, states[i].goal_index);
            let shading = if flat { Shading::Flat } else { Shading::Lit(lights) };
            render(world, &camera, &shading, &mut frames[k]);
            for &c in &frames[k].semantic {
                pixel_counts[c as usize] += 1;
            }
        }
        // Encoding is the slow part of writing: all frames of the batch at once.
        frames[..end - start].par_iter().enumerate().try_for_each(|(k, f)| -> Result<()> {
            let i = start + k;
            let (w, h) = (sensor.width, sensor.height);
            write_jpeg_rgb(&frame_path(dir, "frame", i), &RgbImage { width: w, height: h, pixels: f.rgb.clone() }, sensor.jpeg_quality)?;
            let scale = sensor.depth_scale as f32;
            // HaDaGe: float metres × scale, truncated (Pillow's f2i), clipped to 16 bits.
            let depth = f.depth.iter().map(|&z| (z * scale).clamp(0.0, 65535.0) as u16).collect();
            write_png_gray16(&frame_path(dir, "depth", i), &GrayImage16 { width: w, height: h, pixels: depth })?;
            write_png_gray16(&frame_path(dir, "semantic", i), &GrayImage16 { width: w, height: h, pixels: f.semantic.clone() })
        })?;
    }
    summary.class_pixels = pixel_counts.iter().enumerate().filter(|(_, n)| **n > 0).map(|(c, n)| (c as u16, *n)).collect();
    Ok(summary)
}

/// Whether a light-settings file holds no light at all (the `no_lights` condition).
pub fn has_no_lights(settings: &Value) -> bool {
    settings["lights"].as_object().is_none_or(|lights| lights.is_empty())
}
