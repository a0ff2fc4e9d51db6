//! External tools that can replace a built-in stage (SceneSmith for synthesis, HaDaGe
//! for rendering): a configured argument list (no shell) with `{name}` placeholders,
//! run with a timeout, its output logged to a file rather than kept in memory.

use std::io::{Read, Seek, SeekFrom};
use std::os::unix::process::CommandExt;
use std::path::Path;
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use osmab_evaluator::{InputError, Result};

/// Run `command` with `{key}` replaced by each value of `substitutions`, logging to
/// `log`, for at most `timeout`.
pub fn run_command(command: &[String], substitutions: &[(&str, String)], log: &Path, timeout: Duration) -> Result<()> {
    let Some((program, args)) = command.split_first() else {
        return Err(InputError::new("(config)", "command", "the command is empty"));
    };
    let fill = |a: &String| substitutions.iter().fold(a.clone(), |s, (k, v)| s.replace(&format!("{{{k}}}"), v));
    if let Some(dir) = log.parent() {
        std::fs::create_dir_all(dir).map_err(|e| InputError::io(dir, &e))?;
    }
    let file = std::fs::File::create(log).map_err(|e| InputError::io(log, &e))?;
    let mut child = Command::new(fill(program))
        .args(args.iter().map(fill))
        .stdin(Stdio::null())
        .stdout(file.try_clone().map_err(|e| InputError::io(log, &e))?)
        .stderr(file)
        // Its own process group, so a timeout stops the tool's children too.
        .process_group(0)
        .spawn()
        .map_err(|e| InputError::new("(config)", "command", format!("cannot run '{program}': {e}")))?;
    let started = Instant::now();
    let status = loop {
        if let Some(status) = child.try_wait().map_err(|e| InputError::io(log, &e))? {
            break status;
        }
        if started.elapsed() > timeout {
            let _ = Command::new("kill").args(["-KILL", "--", &format!("-{}", child.id())]).stderr(Stdio::null()).status();
            let _ = child.kill();
            let _ = child.wait();
            return Err(InputError::new(log, "command", format!("'{program}' ran longer than {} s and was stopped", timeout.as_secs())));
        }
        std::thread::sleep(Duration::from_millis(50));
    };
    if !status.success() {
        let text = log_tail(log, 16 * 1024);
        let tail: Vec<&str> = text.lines().rev().take(5).collect::<Vec<_>>().into_iter().rev().collect();
        return Err(InputError::new(log, "command", format!("'{program}' failed with {status}: {}", tail.join("\n"))));
    }
    Ok(())
}

/// The last `bytes` of a log (a failing tool may have written gigabytes).
fn log_tail(log: &Path, bytes: u64) -> String {
    let Ok(mut file) = std::fs::File::open(log) else { return String::new() };
    let size = file.metadata().map(|m| m.len()).unwrap_or(0);
    let _ = file.seek(SeekFrom::Start(size.saturating_sub(bytes)));
    let mut tail = Vec::new();
    let _ = file.take(bytes).read_to_end(&mut tail);
    String::from_utf8_lossy(&tail).into_owned()
}
