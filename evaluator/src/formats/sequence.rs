//! A HaDaGe RGB-D + semantic sequence directory:
//! `results/{frame,depth,semantic}%06d.{jpg,png,png}`, `traj.txt`,
//! `camera_params.yaml` and `embed_semseg_classes.json`.

use std::path::{Path, PathBuf};

use super::camera::CameraParams;
use super::classes::ClassList;
use super::trajectory::Trajectory;
use crate::error::{InputError, Result};

/// The files of one sequence, checked for consistency.
#[derive(Debug, Clone)]
pub struct Sequence {
    /// The sequence directory.
    pub dir: PathBuf,
    /// Intrinsics.
    pub camera: CameraParams,
    /// One camera-to-world pose per frame.
    pub trajectory: Trajectory,
    /// Colour frames in sorted file-name order.
    pub color_frames: Vec<PathBuf>,
    /// Depth frames, aligned with `color_frames`.
    pub depth_frames: Vec<PathBuf>,
    /// Semantic frames, aligned with `color_frames`.
    pub semantic_frames: Vec<PathBuf>,
}

impl Sequence {
    /// Open a sequence directory and check that frames, poses and intrinsics agree.
    pub fn open(dir: &Path) -> Result<Self> {
        let camera = CameraParams::read(&dir.join("camera_params.yaml"))?;
        let trajectory = Trajectory::read(&dir.join("traj.txt"))?;
        let results = dir.join("results");
        let color_frames = sorted_frames(&results, "frame", ".jpg")?;
        let depth_frames = sorted_frames(&results, "depth", ".png")?;
        let semantic_frames = sorted_frames(&results, "semantic", ".png")?;
        if color_frames.is_empty() {
            return Err(InputError::new(&results, "frame*.jpg", "the sequence has no frames"));
        }
        if semantic_frames.is_empty() {
            return Err(InputError::new(
                &results,
                "semantic*.png",
                "the sequence has no semantic frames (the scenes of a release's hidden test split publish none), so no ground truth can be built from it",
            ));
        }
        for (kind, frames) in [("depth*.png", &depth_frames), ("semantic*.png", &semantic_frames)] {
            if frames.len() != color_frames.len() {
                return Err(InputError::new(&results, kind, format!("expected one per colour frame ({}), found {}", color_frames.len(), frames.len())));
            }
        }
        if trajectory.poses.len() != color_frames.len() {
            return Err(InputError::new(
                dir.join("traj.txt"),
                "(lines)",
                format!("expected one pose per frame ({}), found {}", color_frames.len(), trajectory.poses.len()),
            ));
        }
        Ok(Self { dir: dir.to_path_buf(), camera, trajectory, color_frames, depth_frames, semantic_frames })
    }

    /// The sequence's class list (`embed_semseg_classes.json`).
    pub fn classes(&self) -> Result<ClassList> {
        ClassList::read(&self.dir.join("embed_semseg_classes.json"))
    }

    /// Number of frames.
    pub fn len(&self) -> usize {
        self.color_frames.len()
    }

    /// Whether the sequence has no frames (never true for an opened sequence).
    pub fn is_empty(&self) -> bool {
        self.color_frames.is_empty()
    }
}

/// `dir/prefix*suffix`, sorted by file name (Python's `sorted(glob(...))`).
fn sorted_frames(dir: &Path, prefix: &str, suffix: &str) -> Result<Vec<PathBuf>> {
    let entries = std::fs::read_dir(dir).map_err(|e| InputError::io(dir, &e))?;
    let mut frames = Vec::new();
    for entry in entries {
        let entry = entry.map_err(|e| InputError::io(dir, &e))?;
        let name = entry.file_name();
        let Some(name) = name.to_str() else { continue };
        if name.starts_with(prefix) && name.ends_with(suffix) {
            frames.push(entry.path());
        }
    }
    frames.sort();
    Ok(frames)
}

/// Path of frame `index` of kind `prefix` (`frame`, `depth`, `semantic`) in HaDaGe's naming.
pub fn frame_path(dir: &Path, prefix: &str, index: usize) -> PathBuf {
    let ext = if prefix == "frame" { "jpg" } else { "png" };
    dir.join("results").join(format!("{prefix}{index:06}.{ext}"))
}
