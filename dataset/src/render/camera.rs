//! The camera of a sequence: its image and sensor settings (HaDaGe / OSMa-Bench++) and the
//! pose an agent state puts it in. Shared by trajectory planning ([`super::coverage`]) and
//! rendering ([`super::sequence`]), so neither needs the other for it.

use nalgebra::Matrix4;
use osmab_evaluator::formats::camera::CameraParams;
use serde::{Deserialize, Serialize};

use super::raster::Camera;
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
    /// Camera tilt about its x axis, degrees; negative looks down (the OSMa-Bench++
    /// HaDaGe patch's `camera_pitch_deg`, 0 by default).
    #[serde(default)]
    pub camera_pitch_deg: f64,
}

impl Default for SensorSettings {
    fn default() -> Self {
        Self { width: 1200, height: 680, hfov: 90.0, sensor_height: 1.0, depth_scale: 6553.5, jpeg_quality: 75, camera_pitch_deg: 0.0 }
    }
}

impl SensorSettings {
    /// The first setting a camera cannot have, as (field, expectation).
    pub fn problem(&self) -> Option<(&'static str, &'static str)> {
        if !(16..=4096).contains(&self.width) || !(16..=4096).contains(&self.height) {
            Some(("width", "image sides must be 16..=4096"))
        } else if !(self.hfov > 0.0 && self.hfov < 180.0) {
            Some(("hfov", "a horizontal field of view in degrees, in (0, 180)"))
        } else if !(self.sensor_height > 0.0 && self.sensor_height < 1.5) {
            Some(("sensor_height", "metres above the floor, in (0, 1.5) (below the agent's height)"))
        } else if !(self.camera_pitch_deg >= -60.0 && self.camera_pitch_deg <= 60.0) {
            Some(("camera_pitch_deg", "degrees in [-60, 60] (negative looks down)"))
        } else {
            None
        }
    }

    /// The intrinsics HaDaGe derives from the field of view.
    pub fn intrinsics(&self) -> CameraParams {
        CameraParams::from_hfov(self.width, self.height, self.hfov, self.depth_scale)
    }

    /// The camera at `pose` (camera-to-world, OpenCV axes).
    pub fn camera(&self, pose: Matrix4<f64>) -> Camera {
        let p = self.intrinsics();
        Camera { width: self.width, height: self.height, fx: p.fx, fy: p.fy, cx: p.cx, cy: p.cy, pose }
    }

    /// The same camera with a smaller image `width` pixels wide (same field of view).
    pub fn scaled_to(&self, width: u32) -> SensorSettings {
        let width = width.min(self.width).max(8);
        let height = ((self.height as f64 * width as f64 / self.width as f64).round() as u32).max(4);
        SensorSettings { width, height, ..self.clone() }
    }
}

/// The camera-to-world pose (OpenCV axes) of an agent state, as HaDaGe writes it:
/// Habitat's camera rotation (yaw about +y, then the sensor's pitch about its x axis)
/// with its y and z columns negated.
pub fn camera_pose(state: &AgentState, floor_height: f64, sensor: &SensorSettings) -> Matrix4<f64> {
    let (s, c) = state.yaw.sin_cos();
    let (sp, cp) = sensor.camera_pitch_deg.to_radians().sin_cos();
    // Habitat camera, level: x right = (cos, 0, −sin), y up, looks along −z = (−sin, 0, −cos).
    // Pitched by p about x: y = (s·sin p, cos p, c·sin p), z = (s·cos p, −sin p, c·cos p).
    let (x, y, z) = ([c, 0.0, -s], [s * sp, cp, c * sp], [s * cp, -sp, c * cp]);
    let t = [state.x, floor_height + sensor.sensor_height, state.z];
    // `+ 0.0` turns the −0.0 of negated zeros into 0.0, so traj.txt never prints "-0".
    let m = Matrix4::new(x[0], -y[0], -z[0], t[0], x[1], -y[1], -z[1], t[1], x[2], -y[2], -z[2], t[2], 0.0, 0.0, 0.0, 1.0);
    m.map(|v| v + 0.0)
}
