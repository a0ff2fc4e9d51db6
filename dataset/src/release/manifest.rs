//! The release manifest (product.md section 9): every public file with its size and
//! SHA-256, and the release digest = SHA-256 over the sorted `path size sha256` lines.

use std::io::Read;
use std::path::{Path, PathBuf};

use osmab_evaluator::{InputError, Result};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use sha2::{Digest, Sha256};

/// One file of a release.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct FileEntry {
    /// Path relative to the release root, with `/`.
    pub path: String,
    pub size: u64,
    pub sha256: String,
}

/// Lower-case hex of bytes.
pub fn hex(bytes: &[u8]) -> String {
    bytes.iter().map(|b| format!("{b:02x}")).collect()
}

/// SHA-256 and size of a file, streamed.
pub fn hash_file(path: &Path) -> Result<(u64, String)> {
    let mut file = std::fs::File::open(path).map_err(|e| InputError::io(path, &e))?;
    let mut hasher = Sha256::new();
    let mut buf = vec![0u8; 1 << 20];
    let mut size = 0u64;
    loop {
        let n = file.read(&mut buf).map_err(|e| InputError::io(path, &e))?;
        if n == 0 {
            break;
        }
        hasher.update(&buf[..n]);
        size += n as u64;
    }
    Ok((size, hex(&hasher.finalize())))
}

/// The release digest of `files`.
pub fn digest(files: &[FileEntry]) -> String {
    let mut lines: Vec<String> = files.iter().map(|f| format!("{} {} {}\n", f.path, f.size, f.sha256)).collect();
    lines.sort();
    hex(&Sha256::digest(lines.concat().as_bytes()))
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
