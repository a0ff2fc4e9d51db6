//! What a release is called and where its files live in blob storage: the two facts the
//! blob store, the release importer and the archive packer share (a leaf: it imports nothing
//! of the crate).

/// Blob folder of release `version`.
pub fn release_prefix(version: &str) -> String {
    format!("releases/{version}")
}

/// A version string safe as a path component and URL segment.
pub fn check_version(version: &str) -> Result<(), String> {
    let ok = !version.is_empty() && version.len() <= 64 && version.chars().all(|c| c.is_ascii_alphanumeric() || "-_.".contains(c)) && !version.starts_with('.');
    if ok { Ok(()) } else { Err(format!("release version '{version}' must be 1-64 characters of letters, digits, '-', '_' and '.'")) }
}
