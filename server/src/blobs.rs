//! Blob storage: release files, sequence archives, ground truth and uploaded
//! submissions, addressed by '/'-separated keys. This is the local-directory store of
//! the embedded default and of deployments with a shared volume; every caller goes
//! through these methods, so an object-store backend only has to provide them.

use std::io;
use std::path::{Path, PathBuf};

/// Blobs under one local directory.
#[derive(Debug, Clone)]
pub struct Blobs {
    root: PathBuf,
}

fn check_key(key: &str) -> io::Result<()> {
    let bad = key.is_empty() || key.starts_with('/') || key.split('/').any(|part| part.is_empty() || part == "." || part == "..") || key.contains('\\');
    if bad { Err(io::Error::new(io::ErrorKind::InvalidInput, format!("'{key}' is not a blob key"))) } else { Ok(()) }
}

impl Blobs {
    /// A store under `root` (created when missing).
    pub fn open(root: &Path) -> io::Result<Self> {
        std::fs::create_dir_all(root)?;
        std::fs::create_dir_all(root.join(".incoming"))?;
        Ok(Self { root: root.to_path_buf() })
    }

    /// Where `key` lives on disk.
    pub fn path(&self, key: &str) -> io::Result<PathBuf> {
        check_key(key)?;
        Ok(self.root.join(key))
    }

    /// A fresh scratch path on the same filesystem (so `put_file` can rename).
    pub fn scratch(&self, name: &str) -> PathBuf {
        self.root.join(".incoming").join(format!("{name}-{}", crate::clock::random_alphanumeric(12)))
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

    /// Remove scratch entries older than `age` (left by processes that died mid-upload);
    /// returns how many went.
    pub fn sweep_scratch(&self, age: std::time::Duration) -> usize {
        let Ok(entries) = std::fs::read_dir(self.root.join(".incoming")) else { return 0 };
        let mut removed = 0;
        for entry in entries.flatten() {
            let old = entry.metadata().and_then(|m| m.modified()).ok().and_then(|t| t.elapsed().ok()).is_some_and(|e| e > age);
            if old {
                let path = entry.path();
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
}
