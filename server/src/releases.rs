//! Registering a built release: verify its manifest and checksums, copy its public files
//! and its private ground truth into blob storage, pack one archive per sequence, and
//! record it with the manifest participants download (the release's own, plus the
//! archives with their sizes and SHA-256).

use std::path::Path;

use osmab_dataset::release::{packed_sequence_archive, verify_release};
use osmab_evaluator::formats::manifest::{ArchiveEntry, FileEntry, ReleaseManifest};
use osmab_evaluator::scores::{ReleaseLighting, Split};
use osmab_evaluator::submission::release::GROUND_TRUTH_DIR;

use crate::blobs::Blobs;
use crate::clock::now_ms;
use crate::release_archives;
pub use crate::release_names::{check_version, release_prefix};
use crate::store::{ReleaseFile, ReleaseFileKind, ReleaseRecord, Store, StoreError};

/// The manifest a release record serves, typed. The service wrote it at import, so it
/// parses; one that does not (edited in the database by hand) reads as an empty manifest
/// and is logged, so the pages show what they can (the API serves the text itself).
pub fn served_manifest(record: &ReleaseRecord) -> ReleaseManifest {
    ReleaseManifest::parse(&record.manifest, Path::new(&format!("release {}: manifest", record.version))).unwrap_or_else(|e| {
        tracing::warn!(release = %record.version, error = %e, "a stored manifest does not parse");
        ReleaseManifest::default()
    })
}

/// A release copied into blob storage and ready to record.
#[derive(Debug)]
pub struct PreparedRelease {
    pub record: ReleaseRecord,
    pub files: Vec<ReleaseFile>,
}

fn copy_tree(source: &Path, target: &Path, provenance: Provenance) -> std::io::Result<()> {
    std::fs::create_dir_all(target)?;
    for entry in std::fs::read_dir(source)? {
        let entry = entry?;
        let kind = entry.file_type()?;
        let to = target.join(entry.file_name());
        if kind.is_dir() {
            copy_tree(&entry.path(), &to, provenance)?;
        } else if kind.is_file() {
            provenance.take(&entry.path(), &to)?;
        }
    }
    Ok(())
}

/// Where a release to import comes from, which decides how it is checked and taken.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Provenance {
    /// Assembled by this node's build job just before: the manifest's sizes and hashes were
    /// computed from these very files, in a build folder the service never rewrites in
    /// place, so every file is checked for its size (not hashed again) and hard-linked into
    /// the staging copy where the filesystem allows it, and the sequence archives the render
    /// jobs packed are taken with the hashes their stage markers recorded.
    JustBuilt,
    /// Anywhere else (`osmab import`, the admin import): every file is hashed against the
    /// manifest and copied, so later edits of the source folder cannot reach the stored release.
    External,
}

impl Provenance {
    /// Put a copy of `from` at `to`: a hard link for a just-built release (when `to` is on
    /// the same filesystem), else a copy. A file already at `to` is replaced, never written
    /// through: it may be a link to `from` itself (a ground-truth file the manifest lists
    /// is taken with the files and again with the ground-truth folder), and copying onto it
    /// would truncate the source.
    fn take(self, from: &Path, to: &Path) -> std::io::Result<()> {
        match std::fs::remove_file(to) {
            Ok(()) => {}
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => {}
            Err(e) => return Err(e),
        }
        if self == Provenance::JustBuilt && std::fs::hard_link(from, to).is_ok() {
            return Ok(());
        }
        std::fs::copy(from, to).map(|_| ())
    }

    /// Check the release in `dir` against its manifest as far as this provenance needs.
    fn check(self, dir: &Path) -> anyhow::Result<()> {
        match self {
            Provenance::External => verify_release(dir).map(|_| ()).map_err(|e| anyhow::anyhow!("the release does not match its manifest: {e}")),
            Provenance::JustBuilt => {
                let manifest = ReleaseManifest::read(&dir.join("manifest.json"))?;
                for entry in &manifest.files {
                    anyhow::ensure!(!entry.path.contains("..") && !entry.path.starts_with('/'), "'{}' is not a path inside the release", entry.path);
                    let path = dir.join(&entry.path);
                    let size = std::fs::metadata(&path).map_err(|e| anyhow::anyhow!("{}: {e}", path.display()))?.len();
                    anyhow::ensure!(size == entry.size, "{}: the manifest lists {} bytes, the build holds {size}", path.display(), entry.size);
                }
                Ok(())
            }
        }
    }
}

/// Verify the release in `dir` and stage it into blob storage (blocking work). Fails
/// with a message naming the file when the release is inconsistent.
pub fn stage_release(blobs: &Blobs, dir: &Path, provenance: Provenance) -> anyhow::Result<(PreparedRelease, std::path::PathBuf)> {
    provenance.check(dir)?;
    let manifest_path = dir.join("manifest.json");
    let manifest = ReleaseManifest::read(&manifest_path)?;
    let version = manifest.version.clone();
    check_version(&version).map_err(|m| anyhow::anyhow!("{}: version: {m}", manifest_path.display()))?;
    let entries = manifest.files.clone();
    let index = osmab_evaluator::submission::ReleaseIndex::read(dir)?;
    anyhow::ensure!(index.has_ground_truth(), "{}: the release has no ground truth for every scene; build it with `osmab release build`", dir.display());

    let staging = blobs.scratch("release");
    std::fs::create_dir_all(&staging)?;
    let stage = Staging { dir, staging: &staging, provenance, version: &version, entries: &entries };
    let result = stage.files(&manifest_path).and_then(|()| stage.archives(manifest)).and_then(|(manifest, archives)| stage.record(manifest, archives));
    match result {
        Ok(prepared) => Ok((prepared, staging)),
        Err(e) => {
            let _ = std::fs::remove_dir_all(&staging);
            Err(e)
        }
    }
}

/// A release being copied from `dir` into the blob store's `staging` folder.
struct Staging<'a> {
    dir: &'a Path,
    staging: &'a Path,
    provenance: Provenance,
    version: &'a str,
    /// The manifest's files.
    entries: &'a [FileEntry],
}

impl Staging<'_> {
    /// Copy the manifest's files, the original manifest and the ground truth, and check
    /// that what was staged is what the manifest lists, by size (a cheap guard against a
    /// copy gone wrong; the content was checked before, as the provenance asks).
    fn files(&self, manifest_path: &Path) -> anyhow::Result<()> {
        for entry in self.entries {
            let target = self.staging.join(&entry.path);
            std::fs::create_dir_all(target.parent().expect("files sit in folders"))?;
            self.provenance.take(&self.dir.join(&entry.path), &target)?;
        }
        std::fs::copy(manifest_path, self.staging.join("manifest.json.original"))?;
        copy_tree(&self.dir.join(GROUND_TRUTH_DIR), &self.staging.join(GROUND_TRUTH_DIR), self.provenance)?;
        for entry in self.entries {
            let staged = std::fs::metadata(self.staging.join(&entry.path))?.len();
            anyhow::ensure!(staged == entry.size, "{}: staged with {staged} bytes, the manifest lists {}", entry.path, entry.size);
        }
        Ok(())
    }

    /// One archive per sequence (lighting, scene), holding exactly the manifest's files
    /// of the sequence: the manifest listing them, and their records.
    fn archives(&self, mut manifest: ReleaseManifest) -> anyhow::Result<(ReleaseManifest, Vec<ReleaseFile>)> {
        let mut listed = Vec::new();
        let mut files = Vec::new();
        for (lighting, scene) in manifest.sequences() {
            let path = format!("archives/sequences/{lighting}/{scene}.tar");
            let target = self.staging.join(&path);
            std::fs::create_dir_all(target.parent().expect("nested"))?;
            let split = manifest.scene(&scene).map_or(Split::Test, |s| s.split);
            let (size, sha256) = self.archive(&manifest, lighting, &scene, split, &target)?;
            listed.push(ArchiveEntry { lighting, path: path.clone(), scene, sha256: sha256.clone(), size });
            files.push(ReleaseFile { version: self.version.to_string(), path, size: size as i64, sha256, kind: ReleaseFileKind::Archive });
        }
        manifest.archives = listed;
        Ok((manifest, files))
    }

    /// The archive of one sequence at `target`: its size and SHA-256. A just-built release
    /// brings the archives its render jobs packed of the scene's public files; one that is
    /// not the size those files pack to is packed again here.
    fn archive(&self, manifest: &ReleaseManifest, lighting: ReleaseLighting, scene: &str, split: Split, target: &Path) -> anyhow::Result<(u64, String)> {
        let members = manifest.sequence_files(lighting, scene);
        let packed = (self.provenance == Provenance::JustBuilt)
            .then(|| packed_sequence_archive(self.dir, lighting, scene, split))
            .flatten()
            .filter(|(_, size, _)| *size == release_archives::expected_size(&members));
        match packed {
            Some((archive, size, sha256)) => {
                self.provenance.take(&archive, target)?;
                Ok((size, sha256))
            }
            None => release_archives::pack_members(self.staging, &members, lighting, scene, target),
        }
    }

    /// The served manifest written, and the release's record with every file's.
    fn record(&self, manifest: ReleaseManifest, archives: Vec<ReleaseFile>) -> anyhow::Result<PreparedRelease> {
        let mut files: Vec<ReleaseFile> = self
            .entries
            .iter()
            .map(|e| ReleaseFile {
                version: self.version.to_string(),
                path: e.path.clone(),
                size: e.size as i64,
                sha256: e.sha256.clone(),
                kind: ReleaseFileKind::File,
            })
            .collect();
        files.extend(archives);
        let served = manifest.to_json();
        std::fs::write(self.staging.join("manifest.json"), &served)?;
        let record = ReleaseRecord {
            version: self.version.to_string(),
            state: crate::store::ReleaseState::Draft,
            is_current: false,
            digest: manifest.digest,
            manifest: served,
            created_at: now_ms(),
            published_at: None,
        };
        Ok(PreparedRelease { record, files })
    }
}

/// How an import ended.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Imported {
    /// Newly registered.
    New(String),
    /// The same release (same digest) was already registered.
    Unchanged(String),
}

/// Import the built release in `dir` (from `provenance`); `publish` also makes it the current release.
pub async fn import_release(store: &Store, blobs: &Blobs, dir: &Path, provenance: Provenance, publish: bool) -> anyhow::Result<Imported> {
    // One import at a time in this process, so two imports of one version cannot
    // replace each other's blobs (builds of one version are one job, by the jobs' index).
    static IMPORTING: tokio::sync::Mutex<()> = tokio::sync::Mutex::const_new(());
    let _one_at_a_time = IMPORTING.lock().await;
    let (blobs_for_stage, dir_owned) = (blobs.clone(), dir.to_path_buf());
    let (prepared, staging) = tokio::task::spawn_blocking(move || stage_release(&blobs_for_stage, &dir_owned, provenance)).await??;
    // Whatever happens below, the staged copy goes (after a local store's rename there is nothing left).
    let _staged = crate::blobs::Scratch(staging.clone());
    let version = prepared.record.version.clone();
    let outcome = match store.release(&version).await {
        Ok(existing) if existing.digest == prepared.record.digest => Imported::Unchanged(version.clone()),
        Ok(existing) => {
            anyhow::bail!(
                "release {version} is already registered with digest {}; a published release never changes — build it under a new version",
                existing.digest
            )
        }
        Err(StoreError::NotFound) => {
            let prefix = release_prefix(&version);
            // Blobs left by an import that died before recording it are replaced.
            blobs.remove_prefix(&prefix).await?;
            blobs.put_dir(&prefix, &staging).await?;
            if let Err(e) = store.insert_release(&prepared.record, &prepared.files).await {
                let _ = blobs.remove_prefix(&prefix).await;
                return Err(e.into());
            }
            Imported::New(version.clone())
        }
        Err(e) => return Err(e.into()),
    };
    if publish {
        store.publish_release(&version, now_ms()).await?;
    }
    Ok(outcome)
}

#[cfg(test)]
mod tests {
    use std::os::unix::fs::MetadataExt;

    use osmab_dataset::release::manifest::hash_file;

    use super::*;

    fn release_with(files: &[(&str, &[u8])]) -> tempfile::TempDir {
        let dir = tempfile::tempdir().unwrap();
        let mut manifest = ReleaseManifest { version: "v-1".into(), lightings: vec![ReleaseLighting::Baseline], ..ReleaseManifest::default() };
        for (path, bytes) in files {
            let target = dir.path().join(path);
            std::fs::create_dir_all(target.parent().unwrap()).unwrap();
            std::fs::write(&target, bytes).unwrap();
            let (size, sha256) = hash_file(&target).unwrap();
            manifest.files.push(FileEntry { path: path.to_string(), size, sha256 });
        }
        manifest.digest = osmab_evaluator::formats::manifest::files_digest(&manifest.files);
        manifest.write(&dir.path().join("manifest.json")).unwrap();
        dir
    }

    #[test]
    fn a_just_built_release_is_linked_and_an_external_one_copied() {
        let release = release_with(&[("classes.json", b"{}")]);
        let source = release.path().join("classes.json");
        for (provenance, shares_the_file) in [(Provenance::JustBuilt, true), (Provenance::External, false)] {
            let target = release.path().join(format!("{provenance:?}.json"));
            provenance.take(&source, &target).unwrap();
            assert_eq!(std::fs::read(&target).unwrap(), b"{}");
            let same = std::fs::metadata(&source).unwrap().ino() == std::fs::metadata(&target).unwrap().ino();
            assert_eq!(same, shares_the_file, "{provenance:?}");
        }
    }

    #[test]
    fn taking_a_file_twice_leaves_it_and_its_source_whole() {
        let release = release_with(&[("ground_truth/scene_000/embed_semseg_classes.json", b"{\"classes\": []}")]);
        let source = release.path().join("ground_truth/scene_000/embed_semseg_classes.json");
        for provenance in [Provenance::JustBuilt, Provenance::External] {
            let target = release.path().join(format!("{provenance:?}.json"));
            provenance.take(&source, &target).unwrap();
            // Again, onto the link or copy the first time made (the manifest's files, then
            // the ground-truth folder, both name it).
            provenance.take(&source, &target).unwrap();
            assert_eq!(std::fs::read(&target).unwrap(), b"{\"classes\": []}", "{provenance:?}: the staged copy");
            assert_eq!(std::fs::read(&source).unwrap(), b"{\"classes\": []}", "{provenance:?}: the build's own file");
        }
    }

    #[test]
    fn a_just_built_release_is_checked_by_size_and_an_external_one_by_hash() {
        let release = release_with(&[("questions/scene_000.json", b"[1, 2, 3]")]);
        assert!(Provenance::JustBuilt.check(release.path()).is_ok());
        // Same size, other bytes: only hashing sees it.
        std::fs::write(release.path().join("questions/scene_000.json"), b"[1, 2, 4]").unwrap();
        assert!(Provenance::JustBuilt.check(release.path()).is_ok());
        let err = Provenance::External.check(release.path()).unwrap_err().to_string();
        assert!(err.contains("questions/scene_000.json") && err.contains("SHA-256"), "{err}");
        // Another size: both see it, naming the file.
        std::fs::write(release.path().join("questions/scene_000.json"), b"[1]").unwrap();
        let err = Provenance::JustBuilt.check(release.path()).unwrap_err().to_string();
        assert!(err.contains("questions/scene_000.json") && err.contains("lists 9 bytes, the build holds 3"), "{err}");
    }

    #[test]
    fn a_just_built_manifest_may_not_point_outside_the_release() {
        let release = release_with(&[]);
        let mut manifest = ReleaseManifest::read(&release.path().join("manifest.json")).unwrap();
        manifest.files.push(FileEntry { path: "../etc/passwd".into(), size: 1, sha256: "00".into() });
        manifest.write(&release.path().join("manifest.json")).unwrap();
        let err = Provenance::JustBuilt.check(release.path()).unwrap_err().to_string();
        assert!(err.contains("'../etc/passwd' is not a path inside the release"), "{err}");
    }

    #[test]
    fn a_sequence_archive_is_hashed_as_it_is_written_and_holds_exactly_its_members() {
        let release = release_with(&[
            ("sequences/baseline/scene_000/results/frame000000.jpg", b"jpeg"),
            ("sequences/baseline/scene_000/results/semantic000000.png", b"hidden"),
            ("sequences/baseline/scene_000/traj.txt", b"1 0 0"),
        ]);
        let mut manifest = ReleaseManifest::read(&release.path().join("manifest.json")).unwrap();
        // The manifest of a test scene leaves its semantic frame out: so does the archive.
        manifest.files.retain(|f| !f.path.contains("semantic"));
        let members = manifest.sequence_files(ReleaseLighting::Baseline, "scene_000");
        let hashed = release.path().join("hashed.tar");
        let (size, sha256) = release_archives::pack_members(release.path(), &members, ReleaseLighting::Baseline, "scene_000", &hashed).unwrap();
        assert_eq!((size, sha256), hash_file(&hashed).unwrap());
        assert_eq!(size, release_archives::expected_size(&members));
        let names = osmab_evaluator::submission::tar_file_names(std::fs::File::open(&hashed).unwrap(), &hashed).unwrap();
        assert_eq!(names, ["sequences/baseline/scene_000/results/frame000000.jpg", "sequences/baseline/scene_000/traj.txt"]);
    }
}
