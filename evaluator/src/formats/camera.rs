//! `camera_params.yaml` of a HaDaGe sequence (the pinhole intrinsics and depth scale).

use std::path::Path;

use serde::{Deserialize, Serialize};

use crate::error::{InputError, Result};
use crate::numeric::python_repr;

/// Pinhole intrinsics of one sequence, as HaDaGe writes and ConceptGraphs reads them.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct CameraParams {
    /// Image width in pixels.
    pub image_width: u32,
    /// Image height in pixels.
    pub image_height: u32,
    /// Focal length along x, pixels.
    pub fx: f64,
    /// Focal length along y, pixels.
    pub fy: f64,
    /// Principal point x, pixels.
    pub cx: f64,
    /// Principal point y, pixels.
    pub cy: f64,
    /// Depth PNG units per metre (6553.5 in HaDaGe: 65535 = 10 m).
    pub png_depth_scale: f64,
    /// Pixels cropped at the border by some loaders; HaDaGe writes 0.
    #[serde(default)]
    pub crop_edge: u32,
}

#[derive(Deserialize)]
struct CameraFile {
    camera_params: Option<CameraParams>,
}

/// Largest image side accepted.
const MAX_SIDE: u32 = 16_384;

impl CameraParams {
    /// HaDaGe's intrinsics for a `width` × `height` image with horizontal field of view `hfov_deg`:
    /// f = (w/2)/tan(hfov/2), c = (size − 1)/2.
    pub fn from_hfov(width: u32, height: u32, hfov_deg: f64, png_depth_scale: f64) -> Self {
        let f = (width as f64 / 2.0) / (hfov_deg.to_radians() / 2.0).tan();
        Self {
            image_width: width,
            image_height: height,
            fx: f,
            fy: f,
            cx: (width as f64 - 1.0) / 2.0,
            cy: (height as f64 - 1.0) / 2.0,
            png_depth_scale,
            crop_edge: 0,
        }
    }

    /// Read and check `camera_params.yaml`.
    pub fn read(path: &Path) -> Result<Self> {
        let text = std::fs::read_to_string(path).map_err(|e| InputError::io(path, &e))?;
        let file: CameraFile =
            serde_yaml_ng::from_str(&text).map_err(|e| InputError::new(path, "camera_params", format!("not valid camera parameters YAML: {e}")))?;
        let params = file.camera_params.ok_or_else(|| InputError::new(path, "camera_params", "missing the top-level 'camera_params' mapping"))?;
        params.validate(path)?;
        Ok(params)
    }

    fn validate(&self, path: &Path) -> Result<()> {
        let field = |name: &str| format!("camera_params.{name}");
        for (name, side) in [("image_width", self.image_width), ("image_height", self.image_height)] {
            if side == 0 || side > MAX_SIDE {
                return Err(InputError::new(path, field(name), format!("expected 1..={MAX_SIDE} pixels, found {side}")));
            }
        }
        for (name, value) in [("fx", self.fx), ("fy", self.fy), ("png_depth_scale", self.png_depth_scale)] {
            if !(value.is_finite() && value > 0.0) {
                return Err(InputError::new(path, field(name), format!("expected a positive finite number, found {value}")));
            }
        }
        for (name, value) in [("cx", self.cx), ("cy", self.cy)] {
            if !value.is_finite() {
                return Err(InputError::new(path, field(name), format!("expected a finite number, found {value}")));
            }
        }
        Ok(())
    }

    /// The YAML text HaDaGe writes (`yaml.dump`, keys sorted).
    pub fn to_yaml(&self) -> String {
        format!(
            "camera_params:\n  crop_edge: {}\n  cx: {}\n  cy: {}\n  fx: {}\n  fy: {}\n  image_height: {}\n  image_width: {}\n  png_depth_scale: {}\n",
            self.crop_edge,
            python_repr(self.cx),
            python_repr(self.cy),
            python_repr(self.fx),
            python_repr(self.fy),
            self.image_height,
            self.image_width,
            python_repr(self.png_depth_scale)
        )
    }

    /// Write `camera_params.yaml`.
    pub fn write(&self, path: &Path) -> Result<()> {
        std::fs::write(path, self.to_yaml()).map_err(|e| InputError::io(path, &e))
    }
}
