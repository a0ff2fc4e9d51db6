//! The dataset pipeline's specification, as tests.

mod assets;
mod convert;
mod fake_service;
mod pack_scenes;
mod prompts;
mod release;
mod render;
mod selection;
mod sequences;
mod service;
mod synthesis;
