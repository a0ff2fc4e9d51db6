//! The public view of a release: what a team downloads and nothing more. Semantic frames
//! are opened for val scenes only (the service's own copy holds the test split's too; the
//! mapper never reads them).

use std::path::{Path, PathBuf};

use osmab_evaluator::formats::camera::CameraParams;
use osmab_evaluator::formats::sequence::frame_path;
use osmab_evaluator::formats::trajectory::Trajectory;
use osmab_evaluator::scores::{Lighting, Split};
use osmab_evaluator::{InputError, Result};

/// A camera-to-world 4×4 pose (OpenCV camera axes), row-major.
pub type Pose = [[f64; 4]; 4];

/// One scene's sequence under one lighting: intrinsics, poses and where its frames are.
#[derive(Debug, Clone)]
pub struct PublicSequence {
    /// The sequence folder (`sequences/<lighting>/<scene>`).
    pub dir: PathBuf,
    /// Intrinsics and depth scale.
    pub camera: CameraParams,
    /// One pose per frame.
    pub poses: Vec<Pose>,
    /// Whether this sequence's semantic frames may be read (val scenes only).
    pub labelled: bool,
}

impl PublicSequence {
    /// Open the sequence of `scene` (of `split`) under `lighting` in `release`.
    pub fn open(release: &Path, lighting: Lighting, scene: &str, split: Split) -> Result<Self> {
        let dir = release.join("sequences").join(lighting.name()).join(scene);
        let camera = CameraParams::read(&dir.join("camera_params.yaml"))?;
        let trajectory = Trajectory::read(&dir.join("traj.txt"))?;
        let poses: Vec<Pose> = trajectory.poses.iter().map(|m| std::array::from_fn(|r| std::array::from_fn(|c| m[(r, c)]))).collect();
        if poses.is_empty() {
            return Err(InputError::new(dir.join("traj.txt"), "(lines)", "the sequence has no poses"));
        }
        let last = frame_path(&dir, "frame", poses.len() - 1);
        if !last.is_file() {
            return Err(InputError::new(&last, "(file)", format!("expected one colour frame per pose ({})", poses.len())));
        }
        Ok(Self { dir, camera, poses, labelled: split == Split::Val })
    }

    /// The frames the mapper uses: every [`crate::FRAME_STRIDE`]th.
    pub fn used_frames(&self) -> Vec<usize> {
        (0..self.poses.len()).step_by(crate::FRAME_STRIDE).collect()
    }
}
