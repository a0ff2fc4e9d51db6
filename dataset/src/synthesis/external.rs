//! An external synthesizer (SceneSmith itself): a configured command, run once per
//! prompt, whose output directory must then hold a SceneSmith scene for the converter.
//!
//! The command is a list of arguments (no shell); `{prompt}` is replaced by the prompt
//! text, `{prompt_file}` by a file holding it, and `{out}` by the scene directory.

use std::path::Path;
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use osmab_evaluator::{InputError, Result};

use crate::convert::scene::DIRECTIVE_FILES;

/// Run `command` for `prompt` into `out` (at most `timeout`), and check that a scene
/// came out. The command's output goes to `out/synthesizer.log`, not to memory.
pub fn run_external(command: &[String], prompt: &str, out: &Path, timeout: Duration) -> Result<()> {
    let Some((program, args)) = command.split_first() else {
        return Err(InputError::new("(config)", "synthesizer.command", "the command is empty"));
    };
    std::fs::create_dir_all(out).map_err(|e| InputError::io(out, &e))?;
    let prompt_file = out.join("prompt.txt");
    std::fs::write(&prompt_file, prompt).map_err(|e| InputError::io(&prompt_file, &e))?;
    let log_path = out.join("synthesizer.log");
    let log = std::fs::File::create(&log_path).map_err(|e| InputError::io(&log_path, &e))?;
    let fill = |a: &String| a.replace("{prompt_file}", &prompt_file.display().to_string()).replace("{out}", &out.display().to_string()).replace("{prompt}", prompt);
    let mut child = Command::new(fill(program))
        .args(args.iter().map(fill))
        .stdin(Stdio::null())
        .stdout(log.try_clone().map_err(|e| InputError::io(&log_path, &e))?)
        .stderr(log)
        .spawn()
        .map_err(|e| InputError::new("(config)", "synthesizer.command", format!("cannot run '{program}': {e}")))?;
    let started = Instant::now();
    let status = loop {
        if let Some(status) = child.try_wait().map_err(|e| InputError::io(out, &e))? {
            break status;
        }
        if started.elapsed() > timeout {
            let _ = child.kill();
            let _ = child.wait();
            return Err(InputError::new(out, "synthesizer", format!("'{program}' ran longer than {} s and was stopped", timeout.as_secs())));
        }
        std::thread::sleep(Duration::from_millis(50));
    };
    if !status.success() {
        let text = std::fs::read_to_string(&log_path).unwrap_or_default();
        let tail: Vec<&str> = text.lines().rev().take(5).collect::<Vec<_>>().into_iter().rev().collect();
        return Err(InputError::new(out, "synthesizer", format!("'{program}' failed with {status}: {}", tail.join("\n"))));
    }
    if !DIRECTIVE_FILES.iter().any(|f| out.join(f).exists()) {
        return Err(InputError::new(out, "combined_house/house.dmd.yaml", format!("'{program}' finished but wrote no SceneSmith scene")));
    }
    Ok(())
}
