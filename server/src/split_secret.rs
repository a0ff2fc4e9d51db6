//! The operator's split secret, which shapes the test scenes of every release the
//! service builds (see `osmab_dataset::release::split`): `OSMAB_SPLIT_SECRET` when set,
//! else the oldest secret in `OSMAB_DATA_DIR/split-secret/` — generated on first start,
//! kept owner-only like the admin token and the receipt keys, and shared through the
//! object store so every node of a deployment builds the same test scenes. Files are
//! named `<created ms>.<id>.secret`: two nodes starting at once may each write one, and
//! both then use the oldest.

use std::path::{Path, PathBuf};

use anyhow::Context;
use osmab_dataset::release::split::{SPLIT_SECRET_VARIABLE, SplitSecret};

use crate::blobs::Blobs;

/// The folder (in the data directory) and blob prefix of the split secret.
pub const SPLIT_SECRET_DIR: &str = "split-secret";

fn secrets_in(dir: &Path) -> anyhow::Result<Vec<PathBuf>> {
    let mut files: Vec<PathBuf> = match std::fs::read_dir(dir) {
        Ok(entries) => entries.flatten().map(|e| e.path()).filter(|p| p.extension().is_some_and(|x| x == "secret")).collect(),
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => Vec::new(),
        Err(e) => return Err(e).with_context(|| format!("{}: cannot list", dir.display())),
    };
    files.sort_by_key(|p| {
        let name = p.file_name().and_then(|n| n.to_str()).unwrap_or_default().to_string();
        (name.split('.').next().and_then(|ms| ms.parse::<u64>().ok()).unwrap_or(u64::MAX), name)
    });
    Ok(files)
}

/// Write a new random secret into `dir`.
fn generate(dir: &Path) -> anyhow::Result<PathBuf> {
    crate::secret_files::owner_only_dir(dir).with_context(|| format!("{}: cannot create", dir.display()))?;
    let mut bytes = [0u8; 32];
    getrandom::fill(&mut bytes).map_err(|e| anyhow::anyhow!("the operating system's random generator failed: {e}"))?;
    let text: String = bytes.iter().map(|b| format!("{b:02x}")).collect();
    let secret = SplitSecret::new(&text, "generated").map_err(|e| anyhow::anyhow!("{e}"))?;
    let path = dir.join(format!("{}.{}.secret", crate::clock::now_ms(), secret.id()));
    crate::secret_files::write_new_owner_only(&path, text.as_bytes()).with_context(|| format!("{}: cannot write", path.display()))?;
    Ok(path)
}

/// The secret of this service (see the module's notes); `dir` is
/// `OSMAB_DATA_DIR/split-secret`.
pub fn open(dir: &Path) -> anyhow::Result<SplitSecret> {
    if let Some(secret) = SplitSecret::from_env().map_err(|e| anyhow::anyhow!("{e}"))? {
        return Ok(secret);
    }
    let mut files = secrets_in(dir)?;
    if files.is_empty() {
        let path = generate(dir)?;
        tracing::warn!(file = %path.display(), "generated the split secret that shapes test scenes; keep this owner-only folder like the admin token");
        files = secrets_in(dir)?;
    }
    let path = &files[0];
    let text = std::fs::read_to_string(path).with_context(|| format!("{}: cannot read", path.display()))?;
    SplitSecret::new(&text, &path.display().to_string()).map_err(|e| anyhow::anyhow!("{e}"))
}

/// Bring the shared secret of an object-store deployment here, sharing this node's (a
/// new one on the first start of the first node) when the store has none.
pub async fn share(blobs: &Blobs, dir: &Path) -> anyhow::Result<()> {
    if std::env::var(SPLIT_SECRET_VARIABLE).is_ok_and(|v| !v.trim().is_empty()) {
        return Ok(());
    }
    crate::secret_files::share_folder(blobs, SPLIT_SECRET_DIR, dir, "split secret", |dir| Ok(!secrets_in(dir)?.is_empty()), generate).await
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_first_start_generates_a_secret_and_later_starts_keep_the_oldest() {
        let dir = tempfile::tempdir().unwrap();
        let folder = dir.path().join(SPLIT_SECRET_DIR);
        let first = open(&folder).unwrap();
        assert_eq!(open(&folder).unwrap().id(), first.id(), "the same secret on the next start");
        std::thread::sleep(std::time::Duration::from_millis(2));
        generate(&folder).unwrap();
        assert_eq!(open(&folder).unwrap().id(), first.id(), "a second one (a node racing) does not replace the oldest");
        #[cfg(unix)]
        for file in secrets_in(&folder).unwrap() {
            use std::os::unix::fs::PermissionsExt;
            assert_eq!(std::fs::metadata(&file).unwrap().permissions().mode() & 0o777, 0o600);
        }
    }
}
