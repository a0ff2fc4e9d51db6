//! Drake/SceneSmith scenes → Habitat-style scenes (scene-pipeline.md section 9.1).

pub mod directives;
pub mod gltf;
pub mod habitat;
pub mod lexicon;
pub mod light_settings;
pub mod lighting;
pub mod primitives;
pub mod scene;
pub mod sdf;
pub mod transform;
