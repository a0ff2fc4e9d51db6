//! Readers and writers for every file the evaluator touches. Each reader checks
//! what it parses and reports problems as [`crate::InputError`]s naming the file,
//! the field and the expectation.

pub mod camera;
pub mod classes;
pub mod confusion;
pub mod image;
pub mod json;
pub mod manifest;
pub mod map;
pub mod npy;
pub mod npz;
pub mod pcd;
pub mod ply;
pub mod sequence;
pub mod trajectory;
