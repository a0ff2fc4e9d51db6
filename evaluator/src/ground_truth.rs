//! Ground-truth clouds: built from a rendered sequence exactly as OSMa-Bench's
//! `run_slam.py` builds them, written as `pointcloud.pcd` + `semantic.npy`, and read
//! back (or from a Replica-style semantic mesh) for scoring.

use std::collections::HashMap;
use std::path::{Path, PathBuf};

use rayon::prelude::*;
use serde::Deserialize;

use crate::error::{InputError, Result};
use crate::formats::classes::ClassList;
use crate::formats::image::{GrayImage16, read_jpeg_rgb, read_png_gray16};
use crate::formats::npy::{NpyArray, ReadLimits, read_npy_file, write_npy_file};
use crate::formats::pcd::{PointCloud, read_pcd, write_pcd};
use crate::formats::ply::{read_semantic_mesh, vertex_labels};
use crate::formats::sequence::Sequence;
use crate::label_set::unique_labels;

/// Every `FRAME_STRIDE`-th frame is used (`--stride 5`).
pub const FRAME_STRIDE: usize = 5;
/// Every `POINT_STRIDE`-th point of the concatenated cloud is kept (`--downsample_rate 10`).
pub const POINT_STRIDE: usize = 10;
/// Frames decoded at once; bounds memory (only their images and the kept points are
/// held) while keeping both cores busy.
const FRAMES_PER_BATCH: usize = 8;

/// Labelled ground-truth points of one scene.
#[derive(Debug, Clone, PartialEq)]
pub struct GroundTruth {
    /// Where it came from, for messages.
    pub source: PathBuf,
    /// Positions in the release's world frame.
    pub points: Vec<[f32; 3]>,
    /// Colours, when known (for viewing only; never scored).
    pub colors: Option<Vec<[u8; 3]>>,
    /// Class id of each point.
    pub labels: Vec<i64>,
}

impl GroundTruth {
    /// Read `dir/pointcloud.pcd` + `dir/semantic.npy` and check them against `classes`.
    pub fn read(dir: &Path, classes: &ClassList) -> Result<Self> {
        let pcd = dir.join("pointcloud.pcd");
        let npy = dir.join("semantic.npy");
        let (cloud, labels) = rayon::join(|| read_pcd(&pcd), || read_npy_file(&npy, ReadLimits::default()));
        let (cloud, labels) = (cloud?, labels?.into_i64_vec(&npy, "semantic")?);
        if labels.len() != cloud.points.len() {
            return Err(InputError::new(
                &npy,
                "semantic",
                format!("expected one label per point of {} ({} points), found {}", pcd.display(), cloud.points.len(), labels.len()),
            ));
        }
        if cloud.points.is_empty() {
            return Err(InputError::new(&pcd, "data", "the ground-truth cloud has no points"));
        }
        check_labels(&labels, classes, &npy)?;
        Ok(Self { source: dir.to_path_buf(), points: cloud.points, colors: cloud.colors, labels })
    }

    /// Read a semantic mesh (`mesh_semantic.ply`) with its `info_semantic.json`
    /// (`objects: [{id, class_id}]`): vertices labelled by majority vote of their faces.
    pub fn read_mesh(ply: &Path, info: &Path) -> Result<Self> {
        #[derive(Deserialize)]
        struct Object {
            id: i64,
            class_id: i64,
        }
        #[derive(Deserialize)]
        struct Info {
            objects: Vec<Object>,
        }
        let text = std::fs::read(info).map_err(|e| InputError::io(info, &e))?;
        let info_json: Info = serde_json::from_slice(&text)
            .map_err(|e| InputError::new(info, "objects", format!("expected {{\"objects\": [{{\"id\": int, \"class_id\": int}}, ...]}}: {e}")))?;
        let object_classes: HashMap<i64, i64> = info_json.objects.iter().map(|o| (o.id, o.class_id)).collect();
        let mesh = read_semantic_mesh(ply)?;
        if mesh.vertices.is_empty() {
            return Err(InputError::new(ply, "vertex", "the mesh has no vertices"));
        }
        let labels = vertex_labels(&mesh, &object_classes);
        Ok(Self { source: ply.to_path_buf(), points: mesh.vertices, colors: None, labels })
    }

    /// Write `dir/pointcloud.pcd` and `dir/semantic.npy`.
    pub fn write(&self, dir: &Path) -> Result<()> {
        std::fs::create_dir_all(dir).map_err(|e| InputError::io(dir, &e))?;
        let cloud = PointCloud { points: self.points.clone(), colors: self.colors.clone() };
        write_pcd(&dir.join("pointcloud.pcd"), &cloud)?;
        write_npy_file(&dir.join("semantic.npy"), &NpyArray::from_i64(self.labels.clone()))
    }

    /// Build the ground truth of `sequence` as the reference does: frames 0, 5, 10, ...
    /// excluding the last frame; every pixel with depth > 0 back-projected (row-major)
    /// and moved to the world by its pose; all frames concatenated; every 10th point kept.
    pub fn build(sequence: &Sequence) -> Result<Self> {
        let classes = sequence.classes()?;
        let camera = &sequence.camera;
        if camera.crop_edge != 0 {
            return Err(InputError::new(
                sequence.dir.join("camera_params.yaml"),
                "camera_params.crop_edge",
                format!("expected 0 (HaDaGe never crops), found {}", camera.crop_edge),
            ));
        }
        let scale = camera.png_depth_scale as f32;
        if !scale.is_normal() {
            return Err(InputError::new(
                sequence.dir.join("camera_params.yaml"),
                "camera_params.png_depth_scale",
                "must be a normal float32 number (Open3D divides by it in float32)",
            ));
        }
        let frames = ground_truth_frames(sequence)?;
        let mut cloud = FrameCloud::default();
        let mut seen = 0usize; // points of the concatenated cloud before the current frame
        for batch in frames.chunks(FRAMES_PER_BATCH) {
            let depths: Vec<GrayImage16> = batch
                .par_iter()
                .map(|&f| read_png_gray16(&sequence.depth_frames[f], Some((camera.image_width, camera.image_height))))
                .collect::<Result<_>>()?;
            // Which of each frame's valid pixels survive the every-10th thinning.
            let mut firsts = Vec::with_capacity(batch.len());
            for depth in &depths {
                firsts.push((POINT_STRIDE - seen % POINT_STRIDE) % POINT_STRIDE);
                seen += depth.pixels.iter().filter(|&&d| d > 0).count();
            }
            let parts: Vec<FrameCloud> = batch
                .par_iter()
                .zip(depths.par_iter().zip(firsts.par_iter()))
                .map(|(&f, (depth, &first))| back_project(sequence, f, depth, first))
                .collect::<Result<_>>()?;
            for part in parts {
                cloud.points.extend(part.points);
                cloud.colors.extend(part.colors);
                cloud.labels.extend(part.labels);
            }
        }
        if cloud.points.is_empty() {
            return Err(InputError::new(&sequence.dir, "results/depth*.png", "no pixel has a depth above 0"));
        }
        check_labels(&cloud.labels, &classes, &sequence.dir.join("results"))?;
        Ok(Self { source: sequence.dir.clone(), points: cloud.points, colors: Some(cloud.colors), labels: cloud.labels })
    }
}

/// The frames the ground truth uses: 0, 5, 10, ... without the last frame.
fn ground_truth_frames(sequence: &Sequence) -> Result<Vec<usize>> {
    let frames: Vec<usize> = (0..sequence.len().saturating_sub(1)).step_by(FRAME_STRIDE).collect();
    if frames.is_empty() {
        return Err(InputError::new(&sequence.dir, "results", "a ground truth needs at least two frames (the last one is never used)"));
    }
    Ok(frames)
}

/// The valid (depth > 0) pixels of a frame that survive the every-10th thinning of the
/// concatenated cloud, given that the frame's first valid pixel is number `first` of
/// the thinning's phase: row-major pixel indices.
fn kept_in_frame(depth: &GrayImage16, first: usize) -> impl Iterator<Item = usize> + '_ {
    depth.pixels.iter().enumerate().filter(|(_, d)| **d > 0).map(|(pixel, _)| pixel).skip(first).step_by(POINT_STRIDE)
}

/// The pixels behind the ground-truth points of `sequence`, in the order of the cloud's
/// points: per used frame, its index and the row-major indices of its kept pixels.
/// (What [`GroundTruth::build`] back-projects; for labelling points with more than
/// their class.)
pub fn kept_pixels(sequence: &Sequence) -> Result<Vec<(usize, Vec<u32>)>> {
    let camera = &sequence.camera;
    let mut seen = 0usize;
    let mut out = Vec::new();
    for f in ground_truth_frames(sequence)? {
        let depth = read_png_gray16(&sequence.depth_frames[f], Some((camera.image_width, camera.image_height)))?;
        let first = (POINT_STRIDE - seen % POINT_STRIDE) % POINT_STRIDE;
        seen += depth.pixels.iter().filter(|&&d| d > 0).count();
        out.push((f, kept_in_frame(&depth, first).map(|p| p as u32).collect()));
    }
    Ok(out)
}

/// Every ground-truth label must be a class of the release.
pub(crate) fn check_labels(labels: &[i64], classes: &ClassList, file: &Path) -> Result<()> {
    let unknown: Vec<i64> = unique_labels(labels).into_iter().filter(|&l| l != -1 && !classes.contains(l)).collect();
    if unknown.is_empty() {
        Ok(())
    } else {
        let list: Vec<String> = unknown.iter().take(10).map(|l| l.to_string()).collect();
        Err(InputError::new(file, "labels", format!("class ids {} are not in the class list", list.join(", "))))
    }
}

/// The kept points of one frame.
#[derive(Default)]
struct FrameCloud {
    points: Vec<[f32; 3]>,
    colors: Vec<[u8; 3]>,
    labels: Vec<i64>,
}

/// Back-project the kept pixels of frame `index` (its valid pixels number `first`,
/// `first + 10`, ... in row-major order) with Open3D's arithmetic: depth as float32
/// `png / png_depth_scale`, `x = (u − cx)·z/fx` and `y = (v − cy)·z/fy` in float64,
/// then the camera-to-world pose applied in float64 and stored as float32.
fn back_project(sequence: &Sequence, index: usize, depth: &GrayImage16, first: usize) -> Result<FrameCloud> {
    let camera = &sequence.camera;
    let size = Some((camera.image_width, camera.image_height));
    let semantic = read_png_gray16(&sequence.semantic_frames[index], size)?;
    let color = read_jpeg_rgb(&sequence.color_frames[index], size)?;
    let pose = &sequence.trajectory.poses[index];
    let m: [[f64; 4]; 4] = std::array::from_fn(|r| std::array::from_fn(|c| pose[(r, c)]));
    let scale = camera.png_depth_scale as f32;
    let w = camera.image_width as usize;
    let mut cloud = FrameCloud::default();
    for pixel in kept_in_frame(depth, first) {
        let (u, v) = (pixel % w, pixel / w);
        let z = (depth.pixels[pixel] as f32 / scale) as f64;
        let x = (u as f64 - camera.cx) * z / camera.fx;
        let y = (v as f64 - camera.cy) * z / camera.fy;
        let world = |r: usize| m[r][0] * x + m[r][1] * y + m[r][2] * z + m[r][3];
        let wh = world(3);
        let point = [(world(0) / wh) as f32, (world(1) / wh) as f32, (world(2) / wh) as f32];
        if !point.iter().all(|c| c.is_finite()) {
            return Err(InputError::new(
                &sequence.depth_frames[index],
                format!("pixel ({u}, {v})"),
                "back-projects to a non-finite point; check fx, fy and the pose in traj.txt",
            ));
        }
        cloud.points.push(point);
        cloud.colors.push([color.pixels[3 * pixel], color.pixels[3 * pixel + 1], color.pixels[3 * pixel + 2]]);
        cloud.labels.push(semantic.pixels[pixel] as i64);
    }
    Ok(cloud)
}
