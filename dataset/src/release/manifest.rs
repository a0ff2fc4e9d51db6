//! The files a release manifest lists (its type is [`osmab_evaluator::formats::manifest`]):
//! every public file with its size and SHA-256, and the release digest = SHA-256 over the
//! sorted `path size sha256` lines.

use std::path::{Path, PathBuf};

pub use osmab_evaluator::digest::hex;
pub use osmab_evaluator::formats::manifest::{FileEntry, files_digest as digest};
use osmab_evaluator::{InputError, Result};
use rayon::prelude::*;

/// SHA-256 and size of a file, streamed.
pub fn hash_file(path: &Path) -> Result<(u64, String)> {
    let (size, sum) = osmab_evaluator::digest::sha256_file(path).map_err(|e| InputError::io(path, &e))?;
    Ok((size, hex(&sum)))
}

/// Every regular file under `root` except `excluded` top-level entries, sorted; the files
/// are hashed on all cores (a full release holds some 40 GB).
pub fn list_files(root: &Path, excluded: &[&str]) -> Result<Vec<FileEntry>> {
    let mut found: Vec<(String, PathBuf)> = Vec::new();
    let mut stack: Vec<PathBuf> = vec![root.to_path_buf()];
    while let Some(dir) = stack.pop() {
        for entry in std::fs::read_dir(&dir).map_err(|e| InputError::io(&dir, &e))? {
            let entry = entry.map_err(|e| InputError::io(&dir, &e))?;
            let path = entry.path();
            let rel = path.strip_prefix(root).expect("below root").to_string_lossy().replace('\\', "/");
            if dir == root && excluded.contains(&rel.as_str()) {
                continue;
            }
            let kind = entry.file_type().map_err(|e| InputError::io(&path, &e))?;
            if kind.is_dir() {
                stack.push(path);
            } else if kind.is_file() {
                found.push((rel, path));
            }
        }
    }
    found.sort_by(|a, b| a.0.cmp(&b.0));
    found
        .into_par_iter()
        .map(|(rel, path)| {
            let (size, sha256) = hash_file(&path)?;
            Ok(FileEntry { path: rel, size, sha256 })
        })
        .collect()
}
