//! The service's secrets on disk — receipt-signing keys, the split secret, a generated
//! admin token — as owner-only files, and, in a multi-node deployment, one folder of them
//! shared through the object store: the one way each is written and shared.

use std::io::Write;
use std::path::Path;

use anyhow::Context;

use crate::blobs::Blobs;

/// Write `bytes` to a new file at `path` that only its owner may read (mode 0600 on Unix),
/// synced; an existing file is an error, never overwritten.
pub fn write_new_owner_only(path: &Path, bytes: &[u8]) -> std::io::Result<()> {
    let mut options = std::fs::OpenOptions::new();
    options.write(true).create_new(true);
    #[cfg(unix)]
    std::os::unix::fs::OpenOptionsExt::mode(&mut options, 0o600);
    let mut file = options.open(path)?;
    file.write_all(bytes)?;
    file.sync_all()
}

/// Create `dir` (and its parents) if missing and make it owner-only (mode 0700 on Unix),
/// repairing a folder another user could read or enter; `Ok(true)` when its mode was
/// repaired, so the caller can say so.
pub fn owner_only_dir(dir: &Path) -> std::io::Result<bool> {
    let existed = dir.is_dir();
    std::fs::create_dir_all(dir)?;
    #[cfg(unix)]
    {
        use std::os::unix::fs::PermissionsExt;
        let mode = std::fs::metadata(dir)?.permissions().mode() & 0o777;
        if mode != 0o700 {
            match std::fs::set_permissions(dir, std::fs::Permissions::from_mode(0o700)) {
                Ok(()) => return Ok(existed && mode & 0o077 != 0),
                // Not ours to change (a volume another user owns): say so, and go on only
                // where no one else can read it anyway.
                Err(e) if e.kind() == std::io::ErrorKind::PermissionDenied && mode & 0o077 == 0 => {
                    tracing::warn!(dir = %dir.display(), mode = format!("{mode:o}"), "cannot make the folder 0700 (not its owner); others cannot read it");
                }
                Err(e) => {
                    return Err(std::io::Error::new(
                        e.kind(),
                        format!(
                            "{e}: it is readable by other users (mode {mode:o}) and could not be made owner-only; chown it to the service's user or chmod 700 it"
                        ),
                    ));
                }
            }
        }
    }
    Ok(false)
}

/// Bring the shared folder `prefix` of the object store into `dir`; when it holds no secret
/// yet (`has_one`), `generate` one here (the first start of the first node) and share it;
/// then read the folder back, so every node ends with the same files, each owner-only.
/// `what` names the secret in errors.
pub async fn share_folder(
    blobs: &Blobs,
    prefix: &str,
    dir: &Path,
    what: &str,
    has_one: impl Fn(&Path) -> anyhow::Result<bool>,
    generate: impl FnOnce(&Path) -> anyhow::Result<std::path::PathBuf>,
) -> anyhow::Result<()> {
    owner_only_dir(dir).with_context(|| format!("{}: cannot create", dir.display()))?;
    blobs.pull_tree(prefix, dir).await.with_context(|| format!("cannot read the {what} from the object storage"))?;
    if !has_one(dir)? {
        generate(dir)?;
    }
    blobs.push_tree(prefix, dir).await.with_context(|| format!("cannot share the {what} through the object storage"))?;
    blobs.pull_tree(prefix, dir).await.with_context(|| format!("cannot read the {what} from the object storage"))?;
    #[cfg(unix)]
    for entry in std::fs::read_dir(dir)?.flatten() {
        use std::os::unix::fs::PermissionsExt;
        if entry.path().is_file() {
            std::fs::set_permissions(entry.path(), std::fs::Permissions::from_mode(0o600))?;
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    #[test]
    fn a_secret_file_is_new_and_owner_only() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("a.secret");
        super::write_new_owner_only(&path, b"x").unwrap();
        assert_eq!(std::fs::read(&path).unwrap(), b"x");
        #[cfg(unix)]
        {
            use std::os::unix::fs::PermissionsExt;
            assert_eq!(std::fs::metadata(&path).unwrap().permissions().mode() & 0o777, 0o600);
        }
        let again = super::write_new_owner_only(&path, b"y").unwrap_err();
        assert_eq!(again.kind(), std::io::ErrorKind::AlreadyExists, "never overwritten");
        assert_eq!(std::fs::read(&path).unwrap(), b"x");
    }

    #[test]
    #[cfg(unix)]
    fn a_secret_folder_is_made_owner_only_and_a_readable_one_repaired() {
        use std::os::unix::fs::PermissionsExt;
        let root = tempfile::tempdir().unwrap();
        let dir = root.path().join("a/b");
        assert!(!super::owner_only_dir(&dir).unwrap(), "a new folder needed no repair");
        assert_eq!(std::fs::metadata(&dir).unwrap().permissions().mode() & 0o777, 0o700);
        std::fs::set_permissions(&dir, std::fs::Permissions::from_mode(0o755)).unwrap();
        assert!(super::owner_only_dir(&dir).unwrap(), "0755 is repaired");
        assert_eq!(std::fs::metadata(&dir).unwrap().permissions().mode() & 0o777, 0o700);
    }
}
