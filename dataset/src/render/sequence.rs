//! Rendering a trajectory into HaDaGe's sequence layout, byte-compatible with what
//! ConceptGraphs and BBQ read: `results/{frame,depth,semantic}%06d.{jpg,png,png}`,
//! `traj.txt`, `camera_params.yaml`, `embed_semseg_classes.json`, `log.txt` and copies
//! of the settings and light files.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use nalgebra::Matrix4;
use osmab_evaluator::formats::classes::ClassList;
use osmab_evaluator::formats::image::{GrayImage16, Packing, RgbImage, write_jpeg_rgb, write_png_gray16_to_all};
use osmab_evaluator::formats::sequence::Sequence;
use osmab_evaluator::formats::sequence::frame_path;
use osmab_evaluator::formats::trajectory::Trajectory;
use osmab_evaluator::{InputError, Result};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use serde_json::Value;

use super::camera::{SensorSettings, camera_pose};
use super::coverage::CoverageGoals;
use super::mesh::World;
use super::raster::{Frame, Light, Lighting, Shading, find_visible, shade_lightings};
use super::trajectory::AgentState;
use super::view::{Observed, View, ViewpointRule, digest64, exposure, visible_classes};
use crate::convert::light_settings::LightSettings;

/// A HaDaGe light-settings file as the renderer's lights for navigation segment `goal`
/// (a light is on when one of its `life_intervals` [start, end) holds the segment).
pub fn lights_for_goal(settings: &LightSettings, goal: usize) -> Vec<Light> {
    settings
        .lights
        .values()
        .filter(|l| l.shines_in(goal))
        .map(|l| {
            let intensity = l.intensity as f32;
            let scale = intensity * if intensity < 0.0 { 0.1 } else { 2.5 };
            Light {
                position: l.position.map(|v| v as f32),
                color: l.color.map(|c| (c as f32).clamp(0.0, 1.0) * scale),
                attached_to_camera: l.attached_to_camera(),
            }
        })
        .collect()
}

/// Measures of one frame, for the quality report.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize)]
pub struct FrameMeasures {
    /// Share of pixels with every channel at 250 or more.
    pub saturated: f32,
    /// Mean luma (Rec. 601, 0–255).
    pub luma: f32,
    /// Largest share of the image one class covers.
    pub dominant: f32,
    /// Share of pixels with depth.
    pub valid_depth: f32,
    /// Objects (instances, or classes when instances are unknown) covering at least
    /// 0.05 % of the image.
    #[serde(default)]
    pub objects: u16,
    /// Classes covering at least 0.05 % of the image with depth, counted from the
    /// images as written ([`super::view::visible_classes`]).
    #[serde(default)]
    pub classes: u16,
    /// The share of the image objects (classes not of the room's shell) cover.
    #[serde(default)]
    pub object_coverage: f32,
    /// Digests of the colour image and of the depth and semantic images, as written:
    /// two lightings of one trajectory must share the second and may differ in the first.
    pub colour_digest: u64,
    pub geometry_digest: u64,
}

impl FrameMeasures {
    /// Dominated by one class, or short of depth.
    pub fn degenerate(&self) -> bool {
        self.dominant as f64 > super::view::DOMINANT_CLASS_LIMIT || (self.valid_depth as f64) < super::view::MIN_VALID_DEPTH
    }
}

impl SequenceSummary {
    /// The frame that shows the most classes (the first of them), for a preview: counted
    /// from the written images, so an external renderer's identical sequence previews
    /// the same frame.
    pub fn preview_frame(&self) -> usize {
        self.per_frame.iter().enumerate().max_by_key(|(i, m)| (m.classes, std::cmp::Reverse(*i))).map_or(0, |(i, _)| i)
    }
}

/// What a rendered sequence holds.
#[derive(Debug, Clone, Default, Serialize, Deserialize)]
pub struct SequenceSummary {
    pub frames: usize,
    /// Pixels of each class over all frames.
    pub class_pixels: BTreeMap<u16, u64>,
    /// Every frame's measures, in order.
    #[serde(default)]
    pub per_frame: Vec<FrameMeasures>,
    /// How each object instance was observed (known when the built-in renderer drew
    /// the sequence; an external renderer's images carry classes, not instances).
    #[serde(default)]
    pub objects: BTreeMap<u16, Observed>,
    /// Metres the camera travelled.
    #[serde(default)]
    pub travelled: f64,
}

/// One lighting's sequence of a scene: the scene's world lit for that lighting (every
/// target of one render shares the same geometry), its light settings, the settings file
/// copied beside it, and its folder.
pub struct SequenceTarget<'a> {
    pub world: &'a World,
    pub light_settings: &'a LightSettings,
    pub settings_copy: Value,
    pub dir: PathBuf,
}

/// Render `states` of a scene under each of `targets` (its lightings) into their folders
/// (HaDaGe's layout); returns each target's summary, in order. The lightings share the
/// trajectory and the geometry, so each frame's visibility is found once and shaded once a
/// lighting, and its depth and semantic images — the same under every lighting — are
/// encoded once and written into every folder.
pub fn render_sequences(
    targets: &[SequenceTarget],
    states: &[AgentState],
    floor_height: f64,
    sensor: &SensorSettings,
    classes: &ClassList,
) -> Result<Vec<SequenceSummary>> {
    let Some(first) = targets.first() else { return Ok(Vec::new()) };
    debug_assert!(targets.iter().all(|t| t.world.triangles().len() == first.world.triangles().len()), "the targets of one render share their geometry");
    for t in targets {
        prepare_sequence_folder(&t.dir, sensor, t.light_settings, classes, &t.settings_copy)?;
    }
    let poses: Vec<Matrix4<f64>> = states.iter().map(|s| camera_pose(s, floor_height, sensor)).collect();
    for t in targets {
        write_trajectory(&t.dir, states, &poses)?;
    }
    let travelled = states.windows(2).map(|w| ((w[1].x - w[0].x).powi(2) + (w[1].z - w[0].z).powi(2)).sqrt()).sum();
    let mut summaries: Vec<SequenceSummary> = targets.iter().map(|_| SequenceSummary { frames: states.len(), travelled, ..Default::default() }).collect();
    let mut pixel_counts = vec![0u64; 1 << 16];
    let mut objects: BTreeMap<u16, Observed> = BTreeMap::new();
    let rule = CoverageGoals::default().viewpoint_rule(sensor.width, sensor.height);
    // A lighting without any light is flat; one whose lights are all off in a segment
    // is lit by the ambient term only (never brighter than with them on).
    let flat: Vec<bool> = targets.iter().map(|t| t.light_settings.is_unlit()).collect();
    let dirs: Vec<&Path> = targets.iter().map(|t| t.dir.as_path()).collect();
    const BATCH: usize = 8;
    let mut frames: Vec<Frame> = (0..BATCH).map(|_| Frame::default()).collect();
    // The colour image of each batch frame under each lighting: `colours[k * targets + l]`.
    let mut colours: Vec<Vec<u8>> = vec![Vec::new(); BATCH * targets.len()];
    for start in (0..states.len()).step_by(BATCH) {
        let end = (start + BATCH).min(states.len());
        for (k, i) in (start..end).enumerate() {
            let camera = sensor.camera(poses[i]);
            find_visible(first.world, &camera, &mut frames[k]);
            let shadings: Vec<Shading> = targets
                .iter()
                .zip(&flat)
                .map(|(t, &flat)| if flat { Shading::Flat } else { Shading::Lit(lights_for_goal(t.light_settings, states[i].goal_index)) })
                .collect();
            let lightings: Vec<Lighting> = targets.iter().zip(&shadings).map(|(t, shading)| Lighting { world: t.world, shading }).collect();
            shade_lightings(&lightings, &camera, &mut frames[k], &mut colours[k * targets.len()..(k + 1) * targets.len()]);
            for &c in &frames[k].semantic {
                pixel_counts[c as usize] += 1;
            }
        }
        // Encoding is the slow part of writing: every image of the batch at once.
        let n = end - start;
        let (geometry, colour) = rayon::join(
            || frames[..n].par_iter().enumerate().map(|(k, f)| encode_geometry(&dirs, sensor, &rule, start + k, f)).collect::<Result<Vec<_>>>(),
            || {
                colours[..n * targets.len()]
                    .par_iter()
                    .enumerate()
                    .map(|(j, rgb)| encode_colour(dirs[j % targets.len()], sensor, start + j / targets.len(), rgb))
                    .collect::<Result<Vec<_>>>()
            },
        );
        let (geometry, colour) = (geometry?, colour?);
        for (k, (shared, view)) in geometry.into_iter().enumerate() {
            let state = &states[start + k];
            for (l, summary) in summaries.iter_mut().enumerate() {
                summary.per_frame.push(colour[k * targets.len() + l].with(shared));
            }
            for v in &view.objects {
                objects.entry(v.instance_id).or_default().add(start + k, [state.x, state.z], v.pixels as f64, v.nearest as f64, &rule);
            }
        }
    }
    // What the frames show is the same under every lighting.
    let class_pixels: BTreeMap<u16, u64> = pixel_counts.iter().enumerate().filter(|(_, n)| **n > 0).map(|(c, n)| (c as u16, *n)).collect();
    for summary in &mut summaries {
        summary.class_pixels = class_pixels.clone();
        summary.objects = objects.clone();
    }
    Ok(summaries)
}

/// Make `dir` afresh for a sequence: its results folder, camera parameters, classes,
/// loader configs and the settings it was rendered with.
fn prepare_sequence_folder(dir: &Path, sensor: &SensorSettings, light_settings: &LightSettings, classes: &ClassList, settings_copy: &Value) -> Result<()> {
    let results = dir.join("results");
    if dir.exists() {
        std::fs::remove_dir_all(dir).map_err(|e| InputError::io(dir, &e))?;
    }
    std::fs::create_dir_all(&results).map_err(|e| InputError::io(&results, &e))?;
    let params = sensor.intrinsics();
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
    super::loaders::write_loader_configs(dir, &params)?;
    let configs = dir.join("configs");
    for (sub, text) in
        [("sim_settings/settings.json", serde_json::to_string_pretty(settings_copy).expect("json")), ("lighting/light_settings.json", light_settings.to_json())]
    {
        let path = configs.join(sub);
        std::fs::create_dir_all(path.parent().expect("nested")).map_err(|e| InputError::io(&path, &e))?;
        std::fs::write(&path, text).map_err(|e| InputError::io(&path, &e))?;
    }
    Ok(())
}

/// The camera path (`traj.txt`, one pose a frame) and the action log.
fn write_trajectory(dir: &Path, states: &[AgentState], poses: &[Matrix4<f64>]) -> Result<()> {
    Trajectory { poses: poses.to_vec() }.write(&dir.join("traj.txt"))?;
    let log: String = states.iter().enumerate().map(|(i, s)| format!("[{i:06}] Action: {}\n", s.action.name())).collect();
    std::fs::write(dir.join("log.txt"), log).map_err(|e| InputError::io(dir, &e))
}

/// What a frame's colour image measures: its lighting's own.
struct ColourMeasures {
    saturated: f32,
    luma: f32,
    digest: u64,
}

/// What a frame's depth and semantic images measure: the same under every lighting.
#[derive(Clone, Copy)]
struct GeometryMeasures {
    dominant: f32,
    valid_depth: f32,
    objects: u16,
    classes: u16,
    object_coverage: f32,
    digest: u64,
}

impl ColourMeasures {
    fn with(&self, g: GeometryMeasures) -> FrameMeasures {
        FrameMeasures {
            saturated: self.saturated,
            luma: self.luma,
            dominant: g.dominant,
            valid_depth: g.valid_depth,
            objects: g.objects,
            classes: g.classes,
            object_coverage: g.object_coverage,
            colour_digest: self.digest,
            geometry_digest: g.digest,
        }
    }
}

/// Frame `i`'s colour image `rgb` encoded into `dir`, and its measures.
fn encode_colour(dir: &Path, sensor: &SensorSettings, i: usize, rgb: &[u8]) -> Result<ColourMeasures> {
    write_jpeg_rgb(&frame_path(dir, "frame", i), &RgbImage { width: sensor.width, height: sensor.height, pixels: rgb.to_vec() }, sensor.jpeg_quality)?;
    let (saturated, luma) = exposure(rgb);
    Ok(ColourMeasures { saturated: saturated as f32, luma: luma as f32, digest: digest64(rgb) })
}

/// Frame `i`'s depth and semantic images encoded once and written into each of `dirs`,
/// their measures and the view (what the frame shows, by `rule`).
fn encode_geometry(dirs: &[&Path], sensor: &SensorSettings, rule: &ViewpointRule, i: usize, f: &Frame) -> Result<(GeometryMeasures, View)> {
    let (w, h) = (sensor.width, sensor.height);
    let scale = sensor.depth_scale as f32;
    // HaDaGe: float metres × scale, truncated (Pillow's f2i), clipped to 16 bits.
    let depth: Vec<u16> = f.depth.iter().map(|&z| (z * scale).clamp(0.0, 65535.0) as u16).collect();
    let view = View::of(f);
    let mut geometry: Vec<u8> = depth.iter().flat_map(|d| d.to_le_bytes()).collect();
    geometry.extend(f.semantic.iter().flat_map(|c| c.to_le_bytes()));
    let measures = GeometryMeasures {
        dominant: view.dominant_fraction as f32,
        valid_depth: view.valid_fraction as f32,
        objects: view.objects.iter().filter(|v| v.pixels as f64 >= rule.min_pixels).count().min(u16::MAX as usize) as u16,
        classes: visible_classes(&f.semantic, &depth, rule.min_pixels),
        object_coverage: view.object_fraction as f32,
        digest: digest64(&geometry),
    };
    let paths = |kind: &str| -> Vec<PathBuf> { dirs.iter().map(|dir| frame_path(dir, kind, i)).collect() };
    write_png_gray16_to_all(&paths("depth"), &GrayImage16 { width: w, height: h, pixels: depth }, Packing::Gradients)?;
    write_png_gray16_to_all(&paths("semantic"), &GrayImage16 { width: w, height: h, pixels: f.semantic.clone() }, Packing::FewValues)?;
    Ok((measures, view))
}

/// The summary of a sequence on disk (one rendered by an external tool): frames, class
/// pixels and every frame's measures, read from its images (instances are unknown).
pub fn summarize_sequence(dir: &Path) -> Result<SequenceSummary> {
    let sequence = Sequence::open(dir)?;
    let mut summary = SequenceSummary { frames: sequence.len(), ..Default::default() };
    let size = Some((sequence.camera.image_width, sequence.camera.image_height));
    for i in 0..sequence.len() {
        let semantic = osmab_evaluator::formats::image::read_png_gray16(&sequence.semantic_frames[i], size)?;
        let depth = osmab_evaluator::formats::image::read_png_gray16(&sequence.depth_frames[i], size)?;
        let colour = osmab_evaluator::formats::image::read_jpeg_rgb(&sequence.color_frames[i], size)?;
        let n = semantic.pixels.len().max(1);
        let mut per_class: BTreeMap<u16, u64> = BTreeMap::new();
        let mut valid = 0usize;
        let min_pixels = CoverageGoals::default().viewpoint_rule(semantic.width, semantic.height).min_pixels;
        for (&c, &d) in semantic.pixels.iter().zip(&depth.pixels) {
            *summary.class_pixels.entry(c).or_default() += 1;
            if d > 0 {
                valid += 1;
                *per_class.entry(c).or_default() += 1;
            }
        }
        let (saturated, luma) = exposure(&colour.pixels);
        let classes = visible_classes(&semantic.pixels, &depth.pixels, min_pixels);
        let mut geometry: Vec<u8> = depth.pixels.iter().flat_map(|d| d.to_le_bytes()).collect();
        geometry.extend(semantic.pixels.iter().flat_map(|c| c.to_le_bytes()));
        summary.per_frame.push(FrameMeasures {
            saturated: saturated as f32,
            luma: luma as f32,
            dominant: (per_class.values().copied().max().unwrap_or(0) as f64 / n as f64) as f32,
            valid_depth: (valid as f64 / n as f64) as f32,
            objects: classes,
            classes,
            object_coverage: (per_class.iter().filter(|(c, _)| !super::view::is_shell_id(**c as usize)).map(|(_, n)| n).sum::<u64>() as f64 / n as f64) as f32,
            colour_digest: digest64(&colour.pixels),
            geometry_digest: digest64(&geometry),
        });
    }
    let poses = &sequence.trajectory.poses;
    summary.travelled = poses.windows(2).map(|w| ((w[1][(0, 3)] - w[0][(0, 3)]).powi(2) + (w[1][(2, 3)] - w[0][(2, 3)]).powi(2)).sqrt()).sum();
    Ok(summary)
}
