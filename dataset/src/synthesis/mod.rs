//! Procedural synthesis of scenes in SceneSmith's own format, so one converter serves
//! both the built-in synthesizer and SceneSmith itself (or any external command that
//! writes the same format).

pub mod export;
pub mod external;
pub mod library;
pub mod placement;
pub mod writer;

use std::path::Path;

use osmab_evaluator::Result;

use crate::prompts::ScenePrompt;

/// Synthesize `prompt` into the SceneSmith scene directory `dir`; returns the relations
/// the placement could not honour.
pub fn synthesize(prompt: &ScenePrompt, seed: u64, dir: &Path) -> Result<Vec<String>> {
    let layout = placement::place(&prompt.spec, seed);
    writer::write_scenesmith_scene(dir, &prompt.spec, &prompt.text, &layout)?;
    Ok(layout.unmet)
}
