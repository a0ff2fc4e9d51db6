//! Procedural synthesis of scenes in SceneSmith's own format, so one converter serves
//! both the built-in synthesizer and SceneSmith itself (or any external command that
//! writes the same format).

pub mod artwork;
pub mod dressing;
pub mod export;
pub mod external;
pub mod finishes;
pub mod gltf_out;
pub mod layout;
pub mod library;
pub mod placement;
pub mod recolour;
pub mod relations;
pub mod room;
pub mod source;
pub mod textured;
pub mod writer;

use std::path::Path;

use osmab_evaluator::Result;

use crate::prompts::ScenePrompt;
use source::AssetSource;

/// Synthesize `prompt` into the SceneSmith scene directory `dir` (with a ceiling when
/// `ceiling`), its objects and room shell from `assets`; returns the spec's relations the
/// scene does not satisfy.
pub fn synthesize(prompt: &ScenePrompt, seed: u64, dir: &Path, ceiling: bool, assets: &AssetSource) -> Result<Vec<String>> {
    let problems = prompt.spec.problems();
    if !problems.is_empty() {
        return Err(osmab_evaluator::InputError::new(&prompt.id, "spec", problems.join("; ")));
    }
    // A grammar prompt describes a layout it placed: reproduce it from the primary
    // relations and its seed. Other prompts are placed honouring every relation.
    let layout = match prompt.layout_seed {
        Some(layout_seed) => dressing::furnished(&prompt.spec.primary_only(), layout_seed, assets),
        None => dressing::furnished(&prompt.spec, seed, assets),
    };
    let unmet = relations::unmet_relations(&prompt.spec, &layout);
    let shell = assets.room_shell(seed);
    writer::write_scenesmith_scene(dir, &prompt.spec, &prompt.text, &layout, &unmet, ceiling, shell.as_ref())?;
    Ok(unmet)
}
