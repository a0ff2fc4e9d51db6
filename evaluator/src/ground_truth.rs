//! Ground-truth clouds: built from a rendered sequence exactly as OSMa-Bench's
//! `run_slam.py` builds them, written as `pointcloud.pcd` + `semantic.npy`, and read
//! back (or from a Replica-style semantic mesh) for scoring.

use std::collections::HashMap;
use std::path::{Path, PathBuf};

use rayon::prelude::*;
use serde::Deserialize;

use crate::error::{InputError, Result};
use crate::formats::classes::ClassList;
use crate::formats::image::{read_jpeg_rgb, read_png_gray16};
use crate::formats::npy::{NpyArray, ReadLimits, read_npy_file, write_npy_file};
use crate::formats::pcd::{PointCloud, read_pcd, write_pcd};
use crate::formats::ply::{read_semantic_mesh, vertex_labels};
use crate::formats::sequence::Sequence;
use crate::label_set::unique_labels;

/// Every `FRAME_STRIDE`-th frame is used (`--stride 5`).
pub const FRAME_STRIDE: usize = 5;
/// Every `POINT_STRIDE`-th point of the concatenated cloud is kept (`--downsample_rate 10`).
pub const POINT_STRIDE: usize = 10;
/// Frames decoded at once; bounds memory while keeping both cores busy.
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
        let frames: Vec<usize> = (0..sequence.len().saturating_sub(1)).step_by(FRAME_STRIDE).collect();
        if frames.is_empty() {
            return Err(InputError::new(&sequence.dir, "results", "a ground truth needs at least two frames (the last one is never used)"));
        }
        let mut points = Vec::new();
        let mut colors = Vec::new();
        let mut labels = Vec::new();
        let mut seen = 0usize; // points of the concatenated cloud so far
        for batch in frames.chunks(FRAMES_PER_BATCH) {
            let clouds: Vec<FrameCloud> = batch.par_iter().map(|&f| back_project(sequence, f)).collect::<Result<_>>()?;
            for cloud in clouds {
                // Keep global indices 0, 10, 20, ... of the concatenation.
                let first = (POINT_STRIDE - seen % POINT_STRIDE) % POINT_STRIDE;
                for i in (first..cloud.points.len()).step_by(POINT_STRIDE) {
                    points.push(cloud.points[i]);
                    colors.push(cloud.colors[i]);
                    labels.push(cloud.labels[i]);
                }
                seen += cloud.points.len();
            }
        }
        if points.is_empty() {
            return Err(InputError::new(&sequence.dir, "results/depth*.png", "no pixel has a depth above 0"));
        }
        check_labels(&labels, &classes, &sequence.dir.join("results"))?;
        Ok(Self { source: sequence.dir.clone(), points, colors: Some(colors), labels })
    }
}

/// Every ground-truth label must be a class of the release.
fn check_labels(labels: &[i64], classes: &ClassList, file: &Path) -> Result<()> {
    let unknown: Vec<i64> = unique_labels(labels).into_iter().filter(|&l| l != -1 && !classes.contains(l)).collect();
    if unknown.is_empty() {
        Ok(())
    } else {
        let list: Vec<String> = unknown.iter().take(10).map(|l| l.to_string()).collect();
        Err(InputError::new(file, "labels", format!("class ids {} are not in the class list", list.join(", "))))
    }
}

/// The full-resolution cloud of one frame.
struct FrameCloud {
    points: Vec<[f32; 3]>,
    colors: Vec<[u8; 3]>,
    labels: Vec<i64>,
}

/// Back-project frame `index` with Open3D's arithmetic: depth as float32
/// `png / png_depth_scale`, `x = (u − cx)·z/fx` and `y = (v − cy)·z/fy` in float64,
/// then the camera-to-world pose applied in float64 and stored as float32.
fn back_project(sequence: &Sequence, index: usize) -> Result<FrameCloud> {
    let camera = &sequence.camera;
    let depth_path = &sequence.depth_frames[index];
    let semantic_path = &sequence.semantic_frames[index];
    let color_path = &sequence.color_frames[index];
    let depth = read_png_gray16(depth_path)?;
    let semantic = read_png_gray16(semantic_path)?;
    let color = read_jpeg_rgb(color_path)?;
    let (w, h) = (camera.image_width, camera.image_height);
    for (path, (iw, ih)) in [(depth_path, (depth.width, depth.height)), (semantic_path, (semantic.width, semantic.height)), (color_path, (color.width, color.height))] {
        if (iw, ih) != (w, h) {
            return Err(InputError::new(path, "size", format!("expected {w}x{h} pixels (camera_params.yaml), found {iw}x{ih}")));
        }
    }
    let pose = &sequence.trajectory.poses[index];
    let m: [[f64; 4]; 4] = std::array::from_fn(|r| std::array::from_fn(|c| pose[(r, c)]));
    let scale = camera.png_depth_scale as f32;
    let valid = depth.pixels.iter().filter(|&&d| d > 0).count();
    let mut cloud = FrameCloud { points: Vec::with_capacity(valid), colors: Vec::with_capacity(valid), labels: Vec::with_capacity(valid) };
    for v in 0..h as usize {
        for u in 0..w as usize {
            let pixel = v * w as usize + u;
            let z32 = depth.pixels[pixel] as f32 / scale;
            if z32 <= 0.0 {
                continue;
            }
            let z = z32 as f64;
            let x = (u as f64 - camera.cx) * z / camera.fx;
            let y = (v as f64 - camera.cy) * z / camera.fy;
            let world = |r: usize| m[r][0] * x + m[r][1] * y + m[r][2] * z + m[r][3];
            let wh = world(3);
            cloud.points.push([(world(0) / wh) as f32, (world(1) / wh) as f32, (world(2) / wh) as f32]);
            cloud.colors.push([color.pixels[3 * pixel], color.pixels[3 * pixel + 1], color.pixels[3 * pixel + 2]]);
            cloud.labels.push(semantic.pixels[pixel] as i64);
        }
    }
    Ok(cloud)
}
