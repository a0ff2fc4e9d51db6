//! This process's scratch space: a directory of its own under `.incoming/`, owned while an
//! exclusive lock on its `.lock` file is held (released by the OS however the process
//! ends), so a later process can sweep what a dead one left. Every node has its own,
//! whatever the blob backend.

use std::io;
use std::path::{Path, PathBuf};
use std::sync::Arc;

/// Scratch directories are `.incoming/owner-<random>/`, each with `owner-<random>.lock`.
const OWNER_PREFIX: &str = "owner-";

/// The scratch directory of this process.
#[derive(Debug, Clone)]
pub struct ScratchSpace {
    incoming: PathBuf,
    dir: PathBuf,
    _owner_lock: Arc<std::fs::File>,
}

impl ScratchSpace {
    /// A scratch directory of this process's own under `incoming` (created when missing).
    pub fn open(incoming: &Path) -> io::Result<Self> {
        std::fs::create_dir_all(incoming)?;
        let owner = format!("{OWNER_PREFIX}{}", crate::clock::random_alphanumeric(12).to_ascii_lowercase());
        let lock = std::fs::OpenOptions::new().create_new(true).write(true).open(incoming.join(format!("{owner}.lock")))?;
        lock.lock()?;
        let dir = incoming.join(owner);
        std::fs::create_dir(&dir)?;
        Ok(Self { incoming: incoming.to_path_buf(), dir, _owner_lock: Arc::new(lock) })
    }

    /// A fresh path named after `name` in this process's scratch directory.
    pub fn path(&self, name: &str) -> PathBuf {
        self.dir.join(format!("{name}-{}", crate::clock::random_alphanumeric(12)))
    }

    /// Remove what no live process owns: the scratch directories of processes that ended
    /// (their lock can be taken — a process killed with -9 included), and loose entries
    /// older than `age` (left by versions before owned directories). Returns how many
    /// entries went.
    pub fn sweep(&self, age: std::time::Duration) -> usize {
        let Ok(entries) = std::fs::read_dir(&self.incoming) else { return 0 };
        let own_lock = format!("{}.lock", self.dir.file_name().unwrap_or_default().to_string_lossy());
        let mut removed = 0;
        for entry in entries.flatten() {
            let path = entry.path();
            let name = entry.file_name().to_string_lossy().into_owned();
            if path == self.dir || name == own_lock {
                continue;
            }
            if let Some(owner) = name.strip_prefix(OWNER_PREFIX).and_then(|n| n.strip_suffix(".lock")) {
                let Ok(lock) = std::fs::OpenOptions::new().write(true).open(&path) else { continue };
                // Held: its process lives. Taken: nobody owns the directory any more.
                if lock.try_lock().is_ok() {
                    let dir = self.incoming.join(format!("{OWNER_PREFIX}{owner}"));
                    removed += std::fs::read_dir(&dir).map(|d| d.count()).unwrap_or(0);
                    let _ = std::fs::remove_dir_all(&dir);
                    let _ = std::fs::remove_file(&path);
                }
                continue;
            }
            if name.starts_with(OWNER_PREFIX) {
                continue; // a directory: swept with its lock
            }
            let old = entry.metadata().and_then(|m| m.modified()).ok().and_then(|t| t.elapsed().ok()).is_some_and(|e| e > age);
            if old {
                let gone = if path.is_dir() { std::fs::remove_dir_all(&path) } else { std::fs::remove_file(&path) };
                removed += usize::from(gone.is_ok());
            }
        }
        removed
    }

    /// Whether scratch files can be written.
    pub fn check(&self) -> io::Result<()> {
        let probe = self.path("ready");
        std::fs::write(&probe, b"ok")?;
        std::fs::remove_file(probe)
    }
}

/// Removes a scratch file or folder when dropped, whatever happened; on the async
/// runtime the removal (maybe thousands of files) runs on a blocking thread.
pub struct Scratch(pub PathBuf);

fn remove_path(path: &Path) {
    if path.is_dir() {
        let _ = std::fs::remove_dir_all(path);
    } else {
        let _ = std::fs::remove_file(path);
    }
}

impl Drop for Scratch {
    fn drop(&mut self) {
        let path = std::mem::take(&mut self.0);
        match tokio::runtime::Handle::try_current() {
            Ok(handle) if handle.runtime_flavor() != tokio::runtime::RuntimeFlavor::CurrentThread => {
                handle.spawn_blocking(move || remove_path(&path));
            }
            _ => remove_path(&path),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn scratch_of_a_process_that_ended_is_swept_and_a_live_one_s_is_kept() {
        let dir = tempfile::tempdir().unwrap();
        let incoming = dir.path().join(".incoming");
        let live = ScratchSpace::open(&incoming).unwrap();
        std::fs::write(live.path("upload"), b"in progress").unwrap();
        let ended = ScratchSpace::open(&incoming).unwrap();
        std::fs::write(ended.path("upload"), b"left behind").unwrap();
        std::fs::write(ended.path("unpack"), b"left behind").unwrap();
        drop(ended); // its lock goes as a killed process's would
        let legacy = incoming.join("unpack-old");
        std::fs::write(&legacy, b"old layout").unwrap();
        let restarted = ScratchSpace::open(&incoming).unwrap();
        assert_eq!(restarted.sweep(std::time::Duration::from_secs(3600)), 2, "the ended process's two files");
        assert!(legacy.exists(), "a young loose entry stays until it is old");
        assert_eq!(std::fs::read_dir(&live.dir).unwrap().count(), 1, "the live process's upload is untouched");
        assert_eq!(restarted.sweep(std::time::Duration::ZERO), 1, "the loose entry, once old");
        let left: Vec<_> = std::fs::read_dir(&incoming).unwrap().map(|e| e.unwrap().file_name()).collect();
        assert_eq!(left.len(), 4, "two owners, each a directory and a lock: {left:?}");
    }
}
