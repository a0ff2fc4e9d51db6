//! Blob storage: release files, sequence archives, ground truth and uploaded
//! submissions, addressed by '/'-separated keys. This is the local-directory store of
//! the embedded default and of deployments with a shared volume; every caller goes
//! through these methods, so an object-store backend only has to provide them.

use std::io;
use std::path::{Path, PathBuf};
use std::sync::Arc;

/// Blobs under one local directory.
#[derive(Debug, Clone)]
pub struct Blobs {
    root: PathBuf,
    /// This process's scratch directory under `.incoming/`, owned while `_owner_lock` (an
    /// exclusive lock on its `.lock` file, released by the OS however the process ends)
    /// is held: another process that can take the lock knows the owner is gone.
    scratch_dir: PathBuf,
    _owner_lock: Arc<std::fs::File>,
}

/// Scratch directories are `.incoming/owner-<random>/`, each with `owner-<random>.lock`.
const OWNER_PREFIX: &str = "owner-";

fn check_key(key: &str) -> io::Result<()> {
    let bad = key.is_empty() || key.starts_with('/') || key.split('/').any(|part| part.is_empty() || part == "." || part == "..") || key.contains('\\');
    if bad { Err(io::Error::new(io::ErrorKind::InvalidInput, format!("'{key}' is not a blob key"))) } else { Ok(()) }
}

impl Blobs {
    /// A store under `root` (created when missing), with a scratch directory of this
    /// process's own.
    pub fn open(root: &Path) -> io::Result<Self> {
        let incoming = root.join(".incoming");
        std::fs::create_dir_all(&incoming)?;
        let owner = format!("{OWNER_PREFIX}{}", crate::clock::random_alphanumeric(12).to_ascii_lowercase());
        let lock = std::fs::OpenOptions::new().create_new(true).write(true).open(incoming.join(format!("{owner}.lock")))?;
        lock.lock()?;
        let scratch_dir = incoming.join(owner);
        std::fs::create_dir(&scratch_dir)?;
        Ok(Self { root: root.to_path_buf(), scratch_dir, _owner_lock: Arc::new(lock) })
    }

    /// Where `key` lives on disk.
    pub fn path(&self, key: &str) -> io::Result<PathBuf> {
        check_key(key)?;
        Ok(self.root.join(key))
    }

    /// A fresh scratch path on the same filesystem (so `put_file` can rename), in this
    /// process's scratch directory.
    pub fn scratch(&self, name: &str) -> PathBuf {
        self.scratch_dir.join(format!("{name}-{}", crate::clock::random_alphanumeric(12)))
    }

    /// Move `source` (a scratch file) into `key`, atomically replacing nothing: a key is
    /// written once.
    pub fn put_file(&self, key: &str, source: &Path) -> io::Result<()> {
        let target = self.path(key)?;
        if target.exists() {
            return Err(io::Error::new(io::ErrorKind::AlreadyExists, format!("blob '{key}' exists")));
        }
        if let Some(parent) = target.parent() {
            std::fs::create_dir_all(parent)?;
        }
        match std::fs::rename(source, &target) {
            Ok(()) => Ok(()),
            Err(_) => {
                // Another filesystem: copy to a sibling, then rename into place.
                let partial = target.with_extension("partial");
                std::fs::copy(source, &partial)?;
                std::fs::rename(&partial, &target)?;
                std::fs::remove_file(source)
            }
        }
    }

    /// Move the directory `source` (a scratch directory) into `prefix`, which must not exist.
    pub fn put_dir(&self, prefix: &str, source: &Path) -> io::Result<()> {
        let target = self.path(prefix)?;
        if target.exists() {
            return Err(io::Error::new(io::ErrorKind::AlreadyExists, format!("blob folder '{prefix}' exists")));
        }
        if let Some(parent) = target.parent() {
            std::fs::create_dir_all(parent)?;
        }
        std::fs::rename(source, &target)
    }

    /// Remove every blob under `prefix/`.
    pub fn remove_prefix(&self, prefix: &str) -> io::Result<()> {
        let path = self.path(prefix)?;
        match std::fs::remove_dir_all(&path) {
            Err(e) if e.kind() == io::ErrorKind::NotFound => Ok(()),
            other => other,
        }
    }

    /// Remove what no live process owns: the scratch directories of processes that ended
    /// (their lock can be taken — a process killed with -9 included), and loose entries
    /// older than `age` (left by versions before owned directories). Returns how many
    /// entries went.
    pub fn sweep_scratch(&self, age: std::time::Duration) -> usize {
        let incoming = self.root.join(".incoming");
        let Ok(entries) = std::fs::read_dir(&incoming) else { return 0 };
        let mut removed = 0;
        for entry in entries.flatten() {
            let path = entry.path();
            let name = entry.file_name().to_string_lossy().into_owned();
            if path == self.scratch_dir || name == format!("{}.lock", self.scratch_dir.file_name().unwrap_or_default().to_string_lossy()) {
                continue;
            }
            if let Some(owner) = name.strip_prefix(OWNER_PREFIX).and_then(|n| n.strip_suffix(".lock")) {
                let Ok(lock) = std::fs::OpenOptions::new().write(true).open(&path) else { continue };
                // Held: its process lives. Taken: nobody owns the directory any more.
                if lock.try_lock().is_ok() {
                    let dir = incoming.join(format!("{OWNER_PREFIX}{owner}"));
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

    /// Whether the store can be written (readiness).
    pub fn check(&self) -> io::Result<()> {
        let probe = self.scratch("ready");
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
    fn keys_cannot_leave_the_store() {
        let dir = tempfile::tempdir().unwrap();
        let blobs = Blobs::open(dir.path()).unwrap();
        for key in ["../x", "a/../../x", "/etc/passwd", "a//b", "", "a\\b"] {
            assert!(blobs.path(key).is_err(), "{key}");
        }
        assert!(blobs.path("releases/v1/manifest.json").is_ok());
    }

    #[test]
    fn a_blob_is_written_once() {
        let dir = tempfile::tempdir().unwrap();
        let blobs = Blobs::open(dir.path()).unwrap();
        let scratch = blobs.scratch("t");
        std::fs::write(&scratch, b"one").unwrap();
        blobs.put_file("a/b", &scratch).unwrap();
        let again = blobs.scratch("t");
        std::fs::write(&again, b"two").unwrap();
        assert_eq!(blobs.put_file("a/b", &again).unwrap_err().kind(), io::ErrorKind::AlreadyExists);
        assert_eq!(std::fs::read(blobs.path("a/b").unwrap()).unwrap(), b"one");
    }

    #[test]
    fn scratch_of_a_process_that_ended_is_swept_and_a_live_one_s_is_kept() {
        let dir = tempfile::tempdir().unwrap();
        let live = Blobs::open(dir.path()).unwrap();
        std::fs::write(live.scratch("upload"), b"in progress").unwrap();
        let ended = Blobs::open(dir.path()).unwrap();
        std::fs::write(ended.scratch("upload"), b"left behind").unwrap();
        std::fs::write(ended.scratch("unpack"), b"left behind").unwrap();
        drop(ended); // its lock goes as a killed process's would
        let legacy = dir.path().join(".incoming/unpack-old");
        std::fs::write(&legacy, b"old layout").unwrap();
        let restarted = Blobs::open(dir.path()).unwrap();
        assert_eq!(restarted.sweep_scratch(std::time::Duration::from_secs(3600)), 2, "the ended process's two files");
        assert!(legacy.exists(), "a young loose entry stays until it is old");
        assert_eq!(std::fs::read_dir(&live.scratch_dir).unwrap().count(), 1, "the live process's upload is untouched");
        assert_eq!(restarted.sweep_scratch(std::time::Duration::ZERO), 1, "the loose entry, once old");
        let left: Vec<_> = std::fs::read_dir(dir.path().join(".incoming")).unwrap().map(|e| e.unwrap().file_name()).collect();
        assert_eq!(left.len(), 4, "two owners, each a directory and a lock: {left:?}");
    }
}
