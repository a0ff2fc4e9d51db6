//! Lights as the renderer applies them, Habitat's way.

/// A light as Habitat applies it: colour already scaled by intensity (×2.5, or ×0.1
/// for negative, darkening lights); attenuated by 1/(1 + d²) as Magnum's PhongGL does
/// for an unbounded range.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Light {
    /// World position, or offset from the camera for camera lights.
    pub position: [f32; 3],
    pub color: [f32; 3],
    pub attached_to_camera: bool,
}

/// Habitat's hard-coded ambient term of its Phong shading.
pub const AMBIENT: f32 = 0.4;
