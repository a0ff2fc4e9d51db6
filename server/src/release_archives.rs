//! The sequence archives of a release: each holds exactly the public files of its sequence
//! that the manifest lists, packed deterministically. Imports pack them (or take the ones
//! a render job packed, when they are what the manifest says), and at start every stored
//! release is checked, its archives compared by size with what its manifest lists; an
//! archive that holds more (one packed from a whole sequence folder, semantic frames of a
//! hidden test scene included) is repacked from the stored public files, so an existing
//! deployment heals without a rebuild.

use std::path::Path;

use osmab_evaluator::formats::manifest::{ArchiveEntry, FileEntry, ReleaseManifest, sequence_prefix};
use osmab_evaluator::scores::ReleaseLighting;
use osmab_evaluator::submission::archive::packed_size;
use osmab_evaluator::submission::pack_files_into;

use crate::blobs::{Blobs, Scratch};
use crate::release_names::release_prefix;
use crate::store::Store;

/// The size of the archive that holds exactly `members`.
pub fn expected_size(members: &[&FileEntry]) -> u64 {
    packed_size(members.iter().map(|f| (f.path.len(), f.size)))
}

/// A writer that hashes what passes through it.
struct Hashing<W> {
    inner: W,
    sha256: sha2::Sha256,
    size: u64,
}

impl<W: std::io::Write> std::io::Write for Hashing<W> {
    fn write(&mut self, bytes: &[u8]) -> std::io::Result<usize> {
        let written = self.inner.write(bytes)?;
        sha2::Digest::update(&mut self.sha256, &bytes[..written]);
        self.size += written as u64;
        Ok(written)
    }

    fn flush(&mut self) -> std::io::Result<()> {
        self.inner.flush()
    }
}

/// Pack `members` (manifest paths under `root`, all of one sequence) into the archive
/// `target`, names as in the manifest; its size and SHA-256 computed as it is written.
pub fn pack_members(root: &Path, members: &[&FileEntry], lighting: ReleaseLighting, scene: &str, target: &Path) -> anyhow::Result<(u64, String)> {
    let prefix = sequence_prefix(lighting, scene);
    let names: Vec<String> = members.iter().map(|f| f.path.strip_prefix(&prefix).expect("a member of the sequence").to_string()).collect();
    let sink = Hashing { inner: std::io::BufWriter::new(std::fs::File::create(target)?), sha256: sha2::Digest::new(), size: 0 };
    let Hashing { inner, sha256, size } = pack_files_into(&root.join(&prefix), &names, &prefix, sink, target)?;
    inner.into_inner().map_err(|e| e.into_error())?.sync_all()?;
    Ok((size, osmab_evaluator::digest::hex(&sha2::Digest::finalize(sha256))))
}

/// What checking the stored releases did.
#[derive(Debug, Default, Clone, PartialEq, Eq)]
pub struct Healed {
    /// Archives checked.
    pub checked: usize,
    /// Archives repacked to hold exactly their manifest's files: `version/path`.
    pub repacked: Vec<String>,
}

/// Check every archive of every stored release against its manifest, and repack those
/// that hold something else (see the module's header).
pub async fn heal_stored_archives(store: &Store, blobs: &Blobs) -> anyhow::Result<Healed> {
    let mut healed = Healed::default();
    for release in store.releases().await? {
        let mut manifest = ReleaseManifest::parse(&release.manifest, Path::new(&format!("release {}: manifest", release.version)))?;
        let mut changed = false;
        for k in 0..manifest.archives.len() {
            healed.checked += 1;
            let archive = manifest.archives[k].clone();
            let members = manifest.sequence_files(archive.lighting, &archive.scene);
            if archive.size == expected_size(&members) {
                continue;
            }
            let (size, sha256) = repack(blobs, &release.version, &archive, &members).await?;
            tracing::warn!(
                release = %release.version,
                archive = %archive.path,
                was = archive.size,
                now = size,
                "a sequence archive held files its manifest does not list; repacked from the manifest's files"
            );
            manifest.archives[k].size = size;
            manifest.archives[k].sha256 = sha256.clone();
            let served = manifest.to_json();
            store.replace_release_archive(&release.version, &archive.path, size as i64, &sha256, &served).await?;
            let key = format!("{}/manifest.json", release_prefix(&release.version));
            let copy = Scratch(blobs.scratch("manifest"));
            std::fs::write(&copy.0, &served)?;
            blobs.replace_file(&key, &copy.0).await?;
            healed.repacked.push(format!("{}/{}", release.version, archive.path));
            changed = true;
        }
        if changed {
            tracing::info!(release = %release.version, "the release's archives now hold exactly its manifest's files");
        }
    }
    Ok(healed)
}

/// Repack `archive` of release `version` from its stored `members` into the blob store.
async fn repack(blobs: &Blobs, version: &str, archive: &ArchiveEntry, members: &[&FileEntry]) -> anyhow::Result<(u64, String)> {
    let prefix = release_prefix(version);
    let staging = Scratch(blobs.scratch("repack"));
    for member in members {
        let fetched = blobs.fetch(&format!("{prefix}/{}", member.path)).await?;
        let target = staging.0.join(&member.path);
        std::fs::create_dir_all(target.parent().expect("nested"))?;
        std::fs::copy(fetched.path(), &target)?;
    }
    let packed = Scratch(blobs.scratch("repacked"));
    let (root, target, lighting, scene) = (staging.0.clone(), packed.0.clone(), archive.lighting, archive.scene.clone());
    let owned: Vec<FileEntry> = members.iter().map(|f| (*f).clone()).collect();
    let (size, sha256) = tokio::task::spawn_blocking(move || {
        let refs: Vec<&FileEntry> = owned.iter().collect();
        pack_members(&root, &refs, lighting, &scene, &target)
    })
    .await??;
    blobs.replace_file(&format!("{prefix}/{}", archive.path), &packed.0).await?;
    Ok((size, sha256))
}
