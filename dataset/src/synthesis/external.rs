//! An external synthesizer (SceneSmith itself): a configured command, run once per
//! prompt, whose output directory must then hold a SceneSmith scene for the converter.
//!
//! The command is a list of arguments (no shell); `{prompt}` is replaced by the prompt
//! text, `{prompt_file}` by a file holding it, and `{out}` by the scene directory.

use std::path::Path;
use std::process::Command;

use osmab_evaluator::{InputError, Result};

use crate::convert::scene::DIRECTIVE_FILES;

/// Run `command` for `prompt` into `out`, and check that a scene came out.
pub fn run_external(command: &[String], prompt: &str, out: &Path) -> Result<()> {
    let Some((program, args)) = command.split_first() else {
        return Err(InputError::new("(config)", "synthesizer.command", "the command is empty"));
    };
    std::fs::create_dir_all(out).map_err(|e| InputError::io(out, &e))?;
    let prompt_file = out.join("prompt.txt");
    std::fs::write(&prompt_file, prompt).map_err(|e| InputError::io(&prompt_file, &e))?;
    let fill = |a: &String| a.replace("{prompt_file}", &prompt_file.display().to_string()).replace("{out}", &out.display().to_string()).replace("{prompt}", prompt);
    let output = Command::new(fill(program))
        .args(args.iter().map(fill))
        .output()
        .map_err(|e| InputError::new("(config)", "synthesizer.command", format!("cannot run '{program}': {e}")))?;
    if !output.status.success() {
        let stderr = String::from_utf8_lossy(&output.stderr);
        let tail: String = stderr.lines().rev().take(5).collect::<Vec<_>>().into_iter().rev().collect::<Vec<_>>().join("\n");
        return Err(InputError::new(out, "synthesizer", format!("'{program}' failed with {}: {tail}", output.status)));
    }
    if !DIRECTIVE_FILES.iter().any(|f| out.join(f).exists()) {
        return Err(InputError::new(out, "combined_house/house.dmd.yaml", format!("'{program}' finished but wrote no SceneSmith scene")));
    }
    Ok(())
}
