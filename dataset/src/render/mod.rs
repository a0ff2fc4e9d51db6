//! The built-in CPU renderer: RGB, planar depth and semantic images of a converted
//! Habitat-style scene, with Habitat's lighting model.

pub mod mesh;
pub mod raster;
