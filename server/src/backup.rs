//! `osmab backup --out DIR` and `osmab restore DIR`: everything a lost disk would take — the
//! records (teams, tokens, submissions, scores, jobs), the stored blobs (archives, releases,
//! results), the receipt keys, the split secret and the admin token — as one folder described
//! by a manifest of every file's size and SHA-256, taken while the service runs, and put back
//! into an empty data directory.
//!
//! The manifest is sealed with an HMAC-SHA-256 under the operator's backup key
//! ([`BACKUP_KEY_VARIABLE`]), which is never in the backup: plain checksums would let anyone
//! who can write the backup store swap the database, the receipt key, the split secret and
//! the admin token, recompute the sums and have them restored. A restore verifies the seal
//! before it reads anything else.
//!
//! The database is copied first (SQLite: `VACUUM INTO`, a consistent snapshot a running server
//! does not notice; PostgreSQL: `pg_dump --format=custom`), the blobs after it: blobs are written
//! before the records that name them and never changed, so every blob the copied records name
//! is in the backup. Blobs in an object store are listed, not copied (key, size, ETag; the
//! bucket's versioning keeps the bytes, docs/deploy.md), and a restore first checks that the
//! bucket holds every listed object as it was.

use std::path::{Path, PathBuf};

use anyhow::{Context, bail, ensure};
use serde::{Deserialize, Serialize};
use sha2::Sha256;

use crate::blobs::{Blobs, StoredObject};
use crate::config::Settings;
use crate::store::Store;

/// The manifest's name and format.
pub const MANIFEST: &str = "backup.json";
pub const FORMAT: &str = "osmab-backup/2";
/// The format of backups taken before they were sealed: restored only when the operator
/// says the store they were kept in is trusted.
const UNSEALED_FORMAT: &str = "osmab-backup/1";
/// The environment variable holding the backup key.
pub const BACKUP_KEY_VARIABLE: &str = "OSMAB_BACKUP_KEY";
/// Characters a backup key needs at least.
const MIN_KEY_CHARS: usize = 32;
/// Where the database goes inside a backup.
const SQLITE_FILE: &str = "database/osmab.db";
const POSTGRES_FILE: &str = "database/osmab.pgdump";
/// The data directory's folders and files a backup holds besides the database.
const SECRETS: [&str; 3] = [crate::receipts::keys::RECEIPT_KEYS, crate::split_secret::SPLIT_SECRET_DIR, "admin-token"];
const BLOBS: &str = "blobs";
/// Scratch space inside the blob folder: uploads in flight, never part of a backup.
const SCRATCH: &str = ".incoming";
/// Key prefixes of transient objects: resumable-upload parts (expire within a day) and the
/// shared folders of release builds in progress.
const TRANSIENT: [&str; 2] = ["uploads/", "builds/"];

/// Which database a backup holds (`sqlite` or `postgres` in its manifest).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum DatabaseKind {
    /// `database/osmab.db`, a `VACUUM INTO` copy.
    Sqlite,
    /// `database/osmab.pgdump`, a `pg_dump` in its custom format.
    Postgres,
}

impl std::fmt::Display for DatabaseKind {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            DatabaseKind::Sqlite => "sqlite",
            DatabaseKind::Postgres => "postgres",
        })
    }
}

/// What a backup holds.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct BackupManifest {
    pub format: String,
    pub created_at: String,
    pub osmab_version: String,
    /// Which database file the backup holds.
    pub database: DatabaseKind,
    /// The objects of the bucket the blobs were in (empty for local blobs, copied under
    /// `blobs/`): what a restore checks the bucket for. Transient prefixes (resumable-upload
    /// parts, release builds in progress) are left out.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub objects: Vec<StoredObject>,
    /// Every file of the backup but this manifest, sorted by path.
    pub files: Vec<BackedUpFile>,
    /// The HMAC of everything above under the backup key (absent in backups before seals).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub seal: Option<Seal>,
}

/// A manifest's seal: which key made it, and the HMAC-SHA-256 of the unsealed manifest's JSON.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct Seal {
    /// A public name of the key (an HMAC of a fixed text under it), so a wrong key is named.
    pub key_id: String,
    pub hmac_sha256: String,
}

/// The operator's backup key, kept apart from the backups (it is never written into one).
pub struct BackupKey(Vec<u8>);

impl std::fmt::Debug for BackupKey {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "BackupKey({})", self.id())
    }
}

impl BackupKey {
    /// The key in [`BACKUP_KEY_VARIABLE`], or why there is none to use.
    pub fn from_env() -> anyhow::Result<Self> {
        Self::from_env_if_set()?.ok_or_else(|| {
            anyhow::anyhow!(
                "{BACKUP_KEY_VARIABLE} is not set: backups are sealed with a key kept apart from them, so that whoever can write the backup store cannot \
                 replace what it holds. Make one once (`openssl rand -hex 32`), keep it where the backups are not, and set it for `osmab backup` and `osmab restore`"
            )
        })
    }

    /// The key in [`BACKUP_KEY_VARIABLE`], if set.
    pub fn from_env_if_set() -> anyhow::Result<Option<Self>> {
        let text = std::env::var(BACKUP_KEY_VARIABLE).unwrap_or_default();
        if text.trim().is_empty() {
            return Ok(None);
        }
        Self::new(&text).map(Some)
    }

    fn new(text: &str) -> anyhow::Result<Self> {
        let text = text.trim();
        ensure!(
            text.chars().count() >= MIN_KEY_CHARS && !text.chars().any(char::is_control),
            "{BACKUP_KEY_VARIABLE}: a backup key is at least {MIN_KEY_CHARS} printable characters (e.g. `openssl rand -hex 32`)"
        );
        Ok(Self(text.as_bytes().to_vec()))
    }

    fn mac(&self) -> hmac::Hmac<Sha256> {
        use hmac::KeyInit;
        hmac::Hmac::<Sha256>::new_from_slice(&self.0).expect("HMAC takes a key of any length")
    }

    /// The key's public name.
    pub fn id(&self) -> String {
        use hmac::Mac;
        let mut mac = self.mac();
        mac.update(b"osmab backup key id");
        hex(&mac.finalize().into_bytes())[..16].to_string()
    }

    /// `manifest` sealed: its seal made over the manifest without one.
    fn seal(&self, mut manifest: BackupManifest) -> anyhow::Result<BackupManifest> {
        use hmac::Mac;
        manifest.seal = None;
        let mut mac = self.mac();
        mac.update(&serde_json::to_vec(&manifest)?);
        manifest.seal = Some(Seal { key_id: self.id(), hmac_sha256: hex(&mac.finalize().into_bytes()) });
        Ok(manifest)
    }

    /// Whether `manifest`'s seal was made with this key over exactly what it says; why not.
    fn verify(&self, manifest: &BackupManifest, path: &Path) -> anyhow::Result<()> {
        use hmac::Mac;
        let Some(seal) = &manifest.seal else {
            bail!(
                "{}: the manifest has no seal; a backup of this format is always sealed, so it was changed after it was taken. Nothing was written",
                path.display()
            );
        };
        ensure!(
            seal.key_id == self.id(),
            "{}: sealed with backup key {}, but {BACKUP_KEY_VARIABLE} is key {}: set the key this backup was taken with. Nothing was written",
            path.display(),
            seal.key_id,
            self.id()
        );
        let unsealed = BackupManifest { seal: None, ..manifest.clone() };
        let mut mac = self.mac();
        mac.update(&serde_json::to_vec(&unsealed)?);
        let expected = unhex(&seal.hmac_sha256).unwrap_or_default();
        ensure!(
            mac.verify_slice(&expected).is_ok(),
            "{}: the seal does not verify with the backup key: the manifest was changed (or re-sealed without the key) after the backup was taken. Nothing was written",
            path.display()
        );
        Ok(())
    }
}

fn hex(bytes: &[u8]) -> String {
    bytes.iter().map(|b| format!("{b:02x}")).collect()
}

fn unhex(text: &str) -> Option<Vec<u8>> {
    (0..text.len()).step_by(2).map(|i| text.get(i..i + 2).and_then(|h| u8::from_str_radix(h, 16).ok())).collect()
}

#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct BackedUpFile {
    pub path: String,
    pub size: u64,
    pub sha256: String,
}

/// Take a backup of the service `settings` describe into `out` (absent or empty), sealed with `key`.
pub async fn backup(settings: &Settings, out: &Path, key: &BackupKey) -> anyhow::Result<BackupManifest> {
    ensure_empty(out, "--out")?;
    create_private_dir(out)?;
    let url = settings.database_url.expose();
    let database = if url.starts_with("sqlite:") {
        let target = out.join(SQLITE_FILE);
        create_private_dir(target.parent().expect("a folder"))?;
        let store = Store::connect(url).await.context("opening the database")?;
        let copied = store.snapshot_into(&target).await;
        store.close().await;
        copied.context("copying the database (VACUUM INTO)")?;
        DatabaseKind::Sqlite
    } else {
        let target = out.join(POSTGRES_FILE);
        create_private_dir(target.parent().expect("a folder"))?;
        run("pg_dump", &["--format=custom", "--no-owner", "--file", path_text(&target)?, url])?;
        DatabaseKind::Postgres
    };
    let data = &settings.data_dir;
    let mut objects = Vec::new();
    if let Some(config) = &settings.storage {
        // The bucket holds the blobs, the receipt keys and the split secret.
        let scratch = ScratchDir::new()?;
        let blobs = Blobs::object(&scratch.0, config.clone())?;
        objects = blobs.inventory().await.context("listing the bucket")?.unwrap_or_default();
        objects.retain(|o| !TRANSIENT.iter().any(|prefix| o.key.starts_with(prefix)));
        for name in [crate::receipts::keys::RECEIPT_KEYS, crate::split_secret::SPLIT_SECRET_DIR] {
            blobs.pull_tree(name, &out.join(name)).await.with_context(|| format!("copying {name}/ from the bucket"))?;
        }
    }
    let (data_owned, out_owned, local_blobs) = (data.clone(), out.to_path_buf(), settings.storage.is_none());
    tokio::task::spawn_blocking(move || -> anyhow::Result<()> {
        if local_blobs {
            copy_tree(&data_owned.join(BLOBS), &out_owned.join(BLOBS), &|rel| !rel.starts_with(SCRATCH))?;
        }
        // Those taken from the bucket already are not copied again.
        copy_entries(&data_owned, &out_owned, SECRETS.into_iter().filter(|name| !out_owned.join(name).exists()))
    })
    .await??;
    let out_owned = out.to_path_buf();
    let files = tokio::task::spawn_blocking(move || describe_files(&out_owned)).await??;
    let manifest = BackupManifest {
        format: FORMAT.into(),
        created_at: crate::clock::rfc3339(crate::clock::now_ms()),
        osmab_version: env!("CARGO_PKG_VERSION").into(),
        database,
        objects,
        files,
        seal: None,
    };
    let manifest = key.seal(manifest)?;
    // Written last: a folder without it is an unfinished backup.
    std::fs::write(out.join(MANIFEST), serde_json::to_vec_pretty(&manifest)?).with_context(|| format!("{}: cannot write", out.join(MANIFEST).display()))?;
    Ok(manifest)
}

/// What vouches for a backup: the key that sealed it (where the operator has set one) and,
/// for a backup taken before seals, the operator's word that the store it was kept in is trusted.
pub struct Trust {
    pub key: Option<BackupKey>,
    pub unsealed_store: bool,
}

/// Restore the backup in `from` into the empty data directory (and database) of `settings`.
/// The backup is first copied into a private staging folder in the data directory, and the
/// seal and every file are checked there: what is restored is exactly what was checked,
/// whatever happens to `from` meanwhile. A refused backup leaves nothing behind.
pub async fn restore(settings: &Settings, from: &Path, trust: &Trust) -> anyhow::Result<BackupManifest> {
    let data = &settings.data_dir;
    ensure_empty(data, "the data directory (OSMAB_DATA_DIR)")?;
    create_private_dir(data)?;
    let staged = Staging(data.join(".restore-staging"));
    let (from_owned, staged_owned) = (from.to_path_buf(), staged.0.clone());
    tokio::task::spawn_blocking(move || copy_tree(&from_owned, &staged_owned, &|_| true)).await??;
    let manifest = check_backup(&staged.0, from, trust)?;
    let in_bucket = !manifest.objects.is_empty();
    match (&settings.storage, in_bucket) {
        (None, false) | (Some(_), true) => {}
        (Some(_), false) => {
            bail!("OSMAB_STORAGE_URL is set, but this backup holds local blobs: restore it into a deployment with local storage (unset OSMAB_STORAGE_URL)")
        }
        (None, true) => bail!("this backup lists the objects of a bucket: restore it with OSMAB_STORAGE_URL set to that bucket"),
    }
    if let Some(config) = &settings.storage {
        let scratch = ScratchDir::new()?;
        check_bucket(&Blobs::object(&scratch.0, config.clone())?, &manifest.objects).await?;
    }
    restore_database(settings, &staged.0, &manifest).await?;
    for name in [BLOBS].into_iter().chain(SECRETS) {
        let source = staged.0.join(name);
        if source.exists() {
            std::fs::rename(&source, data.join(name)).with_context(|| format!("moving {} into {}", name, data.display()))?;
        }
    }
    Ok(manifest)
}

/// Put the checked database of the backup staged in `staged` into `settings`' (empty) one.
async fn restore_database(settings: &Settings, staged: &Path, manifest: &BackupManifest) -> anyhow::Result<()> {
    let url = settings.database_url.expose();
    match manifest.database {
        DatabaseKind::Sqlite => {
            let Some(target) = url.strip_prefix("sqlite://").or_else(|| url.strip_prefix("sqlite:")) else {
                bail!("the backup holds a SQLite database, but DATABASE_URL is not a sqlite: URL");
            };
            let target = PathBuf::from(target.split('?').next().unwrap_or(target));
            ensure!(!target.exists(), "{}: a database exists there; restore into a fresh one", target.display());
            copy_file(&staged.join(SQLITE_FILE), &target)?;
        }
        DatabaseKind::Postgres => {
            ensure!(!url.starts_with("sqlite:"), "the backup holds a PostgreSQL dump, but DATABASE_URL is a SQLite one");
            let store = Store::connect(url).await.context("connecting to the database to restore into")?;
            let tables = store.table_count().await;
            store.close().await;
            let tables = tables?;
            ensure!(tables == 0, "the database of DATABASE_URL holds {tables} tables; restore into an empty database");
            run("pg_restore", &["--no-owner", "--exit-on-error", "--dbname", url, path_text(&staged.join(POSTGRES_FILE))?])?;
        }
    }
    Ok(())
}

/// The staging folder of a restore, removed when dropped (after a restore, what is left of it;
/// after a refusal, all of it).
struct Staging(PathBuf);

impl Drop for Staging {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.0);
    }
}

/// A folder of its own under the system's temporary directory, removed when dropped: where
/// opening the object store puts its scratch space, away from any data directory.
struct ScratchDir(PathBuf);

impl ScratchDir {
    fn new() -> anyhow::Result<Self> {
        let dir = std::env::temp_dir().join(format!("osmab-backup-{}", crate::clock::random_alphanumeric(12)));
        create_private_dir(&dir)?;
        Ok(Self(dir))
    }
}

impl Drop for ScratchDir {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.0);
    }
}

/// Whether `blobs` holds every object of `objects` with its size (and ETag, where both have
/// one); otherwise which do not, and how to bring them back.
async fn check_bucket(blobs: &Blobs, objects: &[StoredObject]) -> anyhow::Result<()> {
    let mut differing = Vec::new();
    for object in objects {
        let stored = blobs.stored(&object.key).await.with_context(|| format!("reading {} in the bucket", object.key))?;
        let same = stored.as_ref().is_some_and(|s| s.size == object.size && (s.e_tag.is_none() || object.e_tag.is_none() || s.e_tag == object.e_tag));
        if !same {
            differing.push(match stored {
                None => format!("{} (missing)", object.key),
                Some(s) => format!("{} ({} bytes, {} in the backup)", object.key, s.size, object.size),
            });
        }
    }
    ensure!(
        differing.is_empty(),
        "{} of the {} objects this backup lists are not in the bucket as they were, e.g. {}: restore them from the bucket's versions first (docs/deploy.md, \"Backup and restore\"); nothing was written",
        differing.len(),
        objects.len(),
        differing.iter().take(3).cloned().collect::<Vec<_>>().join(", ")
    );
    Ok(())
}

/// The manifest of the copy in `dir` of the backup at `shown` (which messages name), once
/// its seal verifies (see [`Trust`]) and every file it lists is there with its size and
/// SHA-256 and nothing else is.
fn check_backup(dir: &Path, shown: &Path, trust: &Trust) -> anyhow::Result<BackupManifest> {
    let path = shown.join(MANIFEST);
    let read_path = dir.join(MANIFEST);
    let manifest: BackupManifest =
        serde_json::from_slice(&std::fs::read(&read_path).with_context(|| format!("{}: cannot read (is this a backup?)", path.display()))?)
            .with_context(|| format!("{}: not a backup manifest", path.display()))?;
    match (manifest.format.as_str(), trust) {
        (FORMAT, Trust { key: Some(key), .. }) => key.verify(&manifest, &path)?,
        (FORMAT, Trust { key: None, .. }) => {
            bail!("{}: this backup is sealed; set {BACKUP_KEY_VARIABLE} to the key it was taken with. Nothing was written", path.display())
        }
        (UNSEALED_FORMAT, Trust { unsealed_store: true, .. }) => {}
        (UNSEALED_FORMAT, _) => bail!(
            "{}: format '{UNSEALED_FORMAT}', taken before backups were sealed: anyone who could write where it was kept could have replaced its keys, secrets \
             and database. Restore it only if you trust that store, with --trust-unsealed-backup. Nothing was written",
            path.display()
        ),
        (other, _) => bail!("{}: format '{other}', expected '{FORMAT}'", path.display()),
    }
    let found = describe_files(dir)?;
    let listed: std::collections::BTreeMap<&str, &BackedUpFile> = manifest.files.iter().map(|f| (f.path.as_str(), f)).collect();
    for file in &found {
        match listed.get(file.path.as_str()) {
            None => bail!("{}: not listed in {MANIFEST}; the backup was changed after it was taken", shown.join(&file.path).display()),
            Some(expected) if *expected != file => bail!(
                "{}: {} bytes with SHA-256 {}, the manifest says {} bytes with {}; the backup is damaged",
                shown.join(&file.path).display(),
                file.size,
                file.sha256,
                expected.size,
                expected.sha256
            ),
            Some(_) => {}
        }
    }
    if let Some(missing) = manifest.files.iter().find(|f| !found.iter().any(|g| g.path == f.path)) {
        bail!("{}: listed in {MANIFEST} but missing; the backup is incomplete", shown.join(&missing.path).display());
    }
    Ok(manifest)
}

/// Every file under `dir` but the manifest, with its size and SHA-256, sorted by path.
fn describe_files(dir: &Path) -> anyhow::Result<Vec<BackedUpFile>> {
    let mut files = Vec::new();
    for rel in osmab_evaluator::submission::archive::list_tree(dir).map_err(|e| anyhow::anyhow!("{e}"))? {
        if rel == MANIFEST {
            continue;
        }
        let path = dir.join(&rel);
        let (size, sum) = osmab_api::digest::sha256_file(&path).with_context(|| format!("{}: cannot read", path.display()))?;
        files.push(BackedUpFile { path: rel, size, sha256: osmab_api::digest::hex(&sum) });
    }
    Ok(files)
}

/// Copy each folder or file `names` of `from` that exists to the same name under `to`.
fn copy_entries<'a>(from: &Path, to: &Path, names: impl IntoIterator<Item = &'a str>) -> anyhow::Result<()> {
    for name in names {
        let source = from.join(name);
        if source.is_dir() {
            copy_tree(&source, &to.join(name), &|_| true)?;
        } else if source.is_file() {
            copy_file(&source, &to.join(name))?;
        }
    }
    Ok(())
}

/// Copy the files under `from` whose relative path `keep` accepts to `to`, keeping their
/// permission bits (the keys stay owner-only).
fn copy_tree(from: &Path, to: &Path, keep: &dyn Fn(&str) -> bool) -> anyhow::Result<()> {
    if !from.exists() {
        return Ok(());
    }
    for rel in osmab_evaluator::submission::archive::list_tree(from).map_err(|e| anyhow::anyhow!("{e}"))? {
        if keep(&rel) {
            copy_file(&from.join(&rel), &to.join(&rel))?;
        }
    }
    Ok(())
}

fn copy_file(from: &Path, to: &Path) -> anyhow::Result<()> {
    if let Some(parent) = to.parent() {
        create_private_dir(parent)?;
    }
    std::fs::copy(from, to).with_context(|| format!("copying {} to {}", from.display(), to.display()))?;
    Ok(())
}

fn create_private_dir(dir: &Path) -> anyhow::Result<()> {
    std::fs::create_dir_all(dir).with_context(|| format!("{}: cannot create", dir.display()))?;
    #[cfg(unix)]
    {
        use std::os::unix::fs::PermissionsExt;
        std::fs::set_permissions(dir, std::fs::Permissions::from_mode(0o700)).with_context(|| format!("{}: cannot make owner-only", dir.display()))?;
    }
    Ok(())
}

fn ensure_empty(dir: &Path, what: &str) -> anyhow::Result<()> {
    if let Ok(mut entries) = std::fs::read_dir(dir) {
        ensure!(entries.next().is_none(), "{what} {} is not empty; give a new or empty folder", dir.display());
    }
    Ok(())
}

fn path_text(path: &Path) -> anyhow::Result<&str> {
    path.to_str().with_context(|| format!("{}: not valid UTF-8", path.display()))
}

/// Run a PostgreSQL client tool, or say what is missing.
fn run(program: &str, args: &[&str]) -> anyhow::Result<()> {
    let output = std::process::Command::new(program)
        .args(args)
        .output()
        .with_context(|| format!("{program} could not be run (PostgreSQL's client tools, e.g. Debian's postgresql-client, of the server's major version)"))?;
    ensure!(output.status.success(), "{program} failed ({}): {}", output.status, String::from_utf8_lossy(&output.stderr).trim());
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A backup folder of one file, its manifest sealed with `key` (or left unsealed as an
    /// `osmab-backup/1` one).
    fn a_backup(key: Option<&BackupKey>) -> tempfile::TempDir {
        let dir = tempfile::tempdir().unwrap();
        std::fs::write(dir.path().join("admin-token"), "osmab_real").unwrap();
        let manifest = BackupManifest {
            format: if key.is_some() { FORMAT } else { UNSEALED_FORMAT }.into(),
            created_at: "2026-11-27T00:00:00Z".into(),
            osmab_version: "0".into(),
            database: DatabaseKind::Sqlite,
            objects: Vec::new(),
            files: describe_files(dir.path()).unwrap(),
            seal: None,
        };
        let manifest = match key {
            Some(key) => key.seal(manifest).unwrap(),
            None => manifest,
        };
        std::fs::write(dir.path().join(MANIFEST), serde_json::to_vec_pretty(&manifest).unwrap()).unwrap();
        dir
    }

    fn key(text: &str) -> BackupKey {
        BackupKey::new(text).unwrap()
    }

    fn with_key(text: &str) -> Trust {
        Trust { key: Some(key(text)), unsealed_store: false }
    }

    const OPERATOR: &str = "operator-key-0123456789abcdef0123456789";

    #[test]
    fn a_sealed_backup_verifies_with_its_key_only() {
        let backup = a_backup(Some(&key(OPERATOR)));
        assert!(check_backup(backup.path(), backup.path(), &with_key(OPERATOR)).is_ok());
        let wrong = check_backup(backup.path(), backup.path(), &with_key("another-key-0123456789abcdef0123456789")).unwrap_err().to_string();
        assert!(wrong.contains(&format!("sealed with backup key {}", key(OPERATOR).id())) && wrong.contains("Nothing was written"), "{wrong}");
        let none = check_backup(backup.path(), backup.path(), &Trust { key: None, unsealed_store: true }).unwrap_err().to_string();
        assert!(none.contains(BACKUP_KEY_VARIABLE), "{none}");
    }

    #[test]
    fn a_backup_re_sealed_without_the_key_is_refused() {
        // Someone who can write the backup store swaps the admin token and recomputes every
        // sum, keeping the old seal or making one with a key of their own under the same id.
        let backup = a_backup(Some(&key(OPERATOR)));
        std::fs::write(backup.path().join("admin-token"), "osmab_attacker").unwrap();
        let path = backup.path().join(MANIFEST);
        let mut manifest: BackupManifest = serde_json::from_slice(&std::fs::read(&path).unwrap()).unwrap();
        manifest.files = describe_files(backup.path()).unwrap();
        std::fs::write(&path, serde_json::to_vec_pretty(&manifest).unwrap()).unwrap();
        let refused = check_backup(backup.path(), backup.path(), &with_key(OPERATOR)).unwrap_err().to_string();
        assert!(refused.contains("the seal does not verify"), "{refused}");

        let mut forged = key("attacker-key-0123456789abcdef0123456789").seal(manifest.clone()).unwrap();
        forged.seal.as_mut().unwrap().key_id = key(OPERATOR).id();
        std::fs::write(&path, serde_json::to_vec_pretty(&forged).unwrap()).unwrap();
        assert!(check_backup(backup.path(), backup.path(), &with_key(OPERATOR)).unwrap_err().to_string().contains("the seal does not verify"));

        manifest.seal = None;
        std::fs::write(&path, serde_json::to_vec_pretty(&manifest).unwrap()).unwrap();
        assert!(check_backup(backup.path(), backup.path(), &with_key(OPERATOR)).unwrap_err().to_string().contains("has no seal"));
        manifest.format = UNSEALED_FORMAT.into();
        std::fs::write(&path, serde_json::to_vec_pretty(&manifest).unwrap()).unwrap();
        let downgraded = check_backup(backup.path(), backup.path(), &with_key(OPERATOR)).unwrap_err().to_string();
        assert!(downgraded.contains("--trust-unsealed-backup"), "a seal stripped to an old format is refused unless the operator vouches: {downgraded}");
    }

    #[test]
    fn an_unsealed_backup_of_before_restores_only_on_the_operators_word() {
        let old = a_backup(None);
        assert!(check_backup(old.path(), old.path(), &with_key(OPERATOR)).unwrap_err().to_string().contains("taken before backups were sealed"));
        assert!(check_backup(old.path(), old.path(), &Trust { key: None, unsealed_store: true }).is_ok());
    }

    #[test]
    fn a_manifest_naming_another_database_is_refused_naming_the_file_and_the_choices() {
        let backup = a_backup(Some(&key(OPERATOR)));
        let path = backup.path().join(MANIFEST);
        let text = std::fs::read_to_string(&path).unwrap();
        assert!(text.contains("\"database\": \"sqlite\""), "written as before: {text}");
        std::fs::write(&path, text.replace("\"database\": \"sqlite\"", "\"database\": \"mysql\"")).unwrap();
        let refused = format!("{:#}", check_backup(backup.path(), backup.path(), &with_key(OPERATOR)).unwrap_err());
        assert!(refused.contains(MANIFEST) && refused.contains("not a backup manifest") && refused.contains("expected `sqlite` or `postgres`"), "{refused}");
    }

    #[test]
    fn a_short_key_is_refused() {
        assert!(BackupKey::new("short").unwrap_err().to_string().contains("at least 32"));
    }
}
