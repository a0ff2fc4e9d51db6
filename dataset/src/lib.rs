//! The OSMa-Bench++ dataset pipeline (product.md section 8): scene prompts with
//! structured specifications, diverse selection, and (in later stages) synthesis,
//! conversion, rendering and releases. Knows nothing of the HTTP service.

pub mod assets;
pub mod baselines;
pub mod classes;
pub mod colour;
pub mod convert;
pub mod embedding;
pub mod external;
pub mod openai;
pub mod prompts;
pub mod questions;
pub mod release;
pub mod render;
pub mod selection;
pub mod spec;
pub mod synthesis;
