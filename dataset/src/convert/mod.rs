//! Drake/SceneSmith scenes → Habitat-style scenes (scene-pipeline.md section 9.1).

pub mod directives;
pub mod gltf;
pub mod sdf;
pub mod transform;
pub mod lexicon;
pub mod scene;
pub mod primitives;
pub mod habitat;
