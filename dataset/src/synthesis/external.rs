//! An external synthesizer (SceneSmith itself): a configured command, run once per
//! prompt, whose output directory must then hold a SceneSmith scene for the converter.
//!
//! `{prompt}` is replaced by the prompt text, `{prompt_file}` by a file holding it, and
//! `{out}` by the scene directory, `{seed}` by the scene's seed (derived from the operator's
//! secret for a test scene: a synthesizer that honours it keeps test scenes unrebuildable
//! from the published config); the output goes to `out/synthesizer.log`.

use std::path::Path;
use std::time::Duration;

use osmab_evaluator::{InputError, Result};

use crate::convert::scene::DIRECTIVE_FILES;
use crate::external::run_command;

/// Run `command` for `prompt` into `out` (at most `timeout`), and check that a scene
/// came out.
pub fn run_external(command: &[String], prompt: &str, seed: u64, out: &Path, timeout: Duration) -> Result<()> {
    std::fs::create_dir_all(out).map_err(|e| InputError::io(out, &e))?;
    let prompt_file = out.join("prompt.txt");
    std::fs::write(&prompt_file, prompt).map_err(|e| InputError::io(&prompt_file, &e))?;
    let substitutions =
        [("prompt_file", prompt_file.display().to_string()), ("out", out.display().to_string()), ("prompt", prompt.to_string()), ("seed", seed.to_string())];
    run_command(command, &substitutions, &out.join("synthesizer.log"), timeout).map_err(|e| InputError::new(out, "synthesizer", e.message))?;
    if !DIRECTIVE_FILES.iter().any(|f| out.join(f).exists()) {
        return Err(InputError::new(out, "combined_house/house.dmd.yaml", format!("'{}' finished but wrote no SceneSmith scene", command[0])));
    }
    Ok(())
}
