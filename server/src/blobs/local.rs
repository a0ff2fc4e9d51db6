//! The local-directory backend: blobs as files under one directory (the embedded default,
//! and deployments whose nodes share a volume). Writes are renames from scratch space on
//! the same filesystem, so a blob appears whole or not at all.

use std::io;
use std::path::{Path, PathBuf};

/// Blobs under `root`.
#[derive(Debug, Clone)]
pub struct LocalBlobs {
    pub root: PathBuf,
}

impl LocalBlobs {
    pub fn path(&self, key: &str) -> PathBuf {
        self.root.join(key)
    }

    /// Move `source` into `key` (blocking); a key is written once.
    pub fn put_file(&self, key: &str, source: &Path) -> io::Result<()> {
        let target = self.path(key);
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

    /// Move `source` into `key` in place of what it holds, atomically (blocking): readers see
    /// the old blob or the new one, never a part.
    pub fn replace_file(&self, key: &str, source: &Path) -> io::Result<()> {
        let target = self.path(key);
        if let Some(parent) = target.parent() {
            std::fs::create_dir_all(parent)?;
        }
        if std::fs::rename(source, &target).is_err() {
            let partial = target.with_extension("partial");
            std::fs::copy(source, &partial)?;
            std::fs::rename(&partial, &target)?;
            std::fs::remove_file(source)?;
        }
        Ok(())
    }

    /// Move the directory `source` into `prefix`, which must not exist (blocking).
    pub fn put_dir(&self, prefix: &str, source: &Path) -> io::Result<()> {
        let target = self.path(prefix);
        if target.exists() {
            return Err(io::Error::new(io::ErrorKind::AlreadyExists, format!("blob folder '{prefix}' exists")));
        }
        if let Some(parent) = target.parent() {
            std::fs::create_dir_all(parent)?;
        }
        std::fs::rename(source, &target)
    }

    /// Remove every blob under `prefix/` (blocking).
    pub fn remove_prefix(&self, prefix: &str) -> io::Result<()> {
        let path = self.path(prefix);
        let removed = if path.is_file() { std::fs::remove_file(&path) } else { std::fs::remove_dir_all(&path) };
        match removed {
            Err(e) if e.kind() == io::ErrorKind::NotFound => Ok(()),
            other => other,
        }
    }
}
