//! Registering a built release: verify its manifest and checksums, copy its public files
//! and its private ground truth into blob storage, pack one archive per sequence, and
//! record it with the manifest participants download (the release's own, plus the
//! archives with their sizes and SHA-256).

use std::collections::BTreeMap;
use std::path::Path;

use osmab_dataset::release::manifest::{FileEntry, hash_file};
use osmab_dataset::release::verify_release;
use osmab_evaluator::scores::Split;
use osmab_evaluator::submission::pack_directory_as;
use osmab_evaluator::submission::release::GROUND_TRUTH_DIR;
use serde_json::{Value, json};

use crate::blobs::Blobs;
use crate::clock::now_ms;
use crate::store::{ReleaseFile, ReleaseRecord, Store, StoreError};

/// Blob folder of release `version`.
pub fn release_prefix(version: &str) -> String {
    format!("releases/{version}")
}

/// The splits of a served manifest's scenes, test first (a scene without one is val).
pub fn manifest_splits(manifest: &str) -> Vec<Split> {
    let value: Value = serde_json::from_str(manifest).unwrap_or_default();
    let of_scenes: Vec<Split> =
        value["scenes"].as_array().into_iter().flatten().map(|s| s["split"].as_str().and_then(|n| n.parse().ok()).unwrap_or_default()).collect();
    Split::ALL.into_iter().filter(|split| of_scenes.contains(split)).collect()
}

/// The split a release's main leaderboard ranks and uploads go to by default: test when
/// the release has a test split, else val.
pub fn primary_split(manifest: &str) -> Split {
    if manifest_splits(manifest).contains(&Split::Test) { Split::Test } else { Split::Val }
}

/// A version string safe as a path component and URL segment.
pub fn check_version(version: &str) -> Result<(), String> {
    let ok = !version.is_empty() && version.len() <= 64 && version.chars().all(|c| c.is_ascii_alphanumeric() || "-_.".contains(c)) && !version.starts_with('.');
    if ok { Ok(()) } else { Err(format!("release version '{version}' must be 1-64 characters of letters, digits, '-', '_' and '.'")) }
}

/// A release copied into blob storage and ready to record.
#[derive(Debug)]
pub struct PreparedRelease {
    pub record: ReleaseRecord,
    pub files: Vec<ReleaseFile>,
}

fn copy_tree(source: &Path, target: &Path) -> std::io::Result<()> {
    std::fs::create_dir_all(target)?;
    for entry in std::fs::read_dir(source)? {
        let entry = entry?;
        let kind = entry.file_type()?;
        let to = target.join(entry.file_name());
        if kind.is_dir() {
            copy_tree(&entry.path(), &to)?;
        } else if kind.is_file() {
            std::fs::copy(entry.path(), &to)?;
        }
    }
    Ok(())
}

/// Verify the release in `dir` and stage it into blob storage (blocking work). Fails
/// with a message naming the file when the release is inconsistent.
pub fn stage_release(blobs: &Blobs, dir: &Path) -> anyhow::Result<(PreparedRelease, std::path::PathBuf)> {
    verify_release(dir).map_err(|e| anyhow::anyhow!("the release does not match its manifest: {e}"))?;
    let manifest_path = dir.join("manifest.json");
    let mut manifest: Value = serde_json::from_slice(&std::fs::read(&manifest_path)?)?;
    let version = manifest["version"].as_str().unwrap_or_default().to_string();
    check_version(&version).map_err(|m| anyhow::anyhow!("{}: version: {m}", manifest_path.display()))?;
    let entries: Vec<FileEntry> = serde_json::from_value(manifest["files"].clone())?;
    let index = osmab_evaluator::submission::ReleaseIndex::read(dir)?;
    anyhow::ensure!(index.has_ground_truth(), "{}: the release has no ground truth for every scene; build it with `osmab release build`", dir.display());

    let staging = blobs.scratch("release");
    std::fs::create_dir_all(&staging)?;
    let result = (|| -> anyhow::Result<PreparedRelease> {
        for entry in &entries {
            let target = staging.join(&entry.path);
            std::fs::create_dir_all(target.parent().expect("files sit in folders"))?;
            std::fs::copy(dir.join(&entry.path), &target)?;
        }
        std::fs::copy(&manifest_path, staging.join("manifest.json.original"))?;
        copy_tree(&dir.join(GROUND_TRUTH_DIR), &staging.join(GROUND_TRUTH_DIR))?;

        let mut files: Vec<ReleaseFile> = entries
            .iter()
            .map(|e| ReleaseFile { version: version.clone(), path: e.path.clone(), size: e.size as i64, sha256: e.sha256.clone(), kind: "file".into() })
            .collect();
        let mut sequences: BTreeMap<(String, String), ()> = BTreeMap::new();
        for entry in &entries {
            let parts: Vec<&str> = entry.path.split('/').collect();
            if parts.len() > 3 && parts[0] == "sequences" {
                sequences.insert((parts[1].to_string(), parts[2].to_string()), ());
            }
        }
        let mut archives = Vec::new();
        for (lighting, scene) in sequences.keys() {
            let path = format!("archives/sequences/{lighting}/{scene}.tar");
            let target = staging.join(&path);
            std::fs::create_dir_all(target.parent().expect("nested"))?;
            pack_directory_as(&staging.join("sequences").join(lighting).join(scene), &format!("sequences/{lighting}/{scene}/"), &target)?;
            let (size, sha256) = hash_file(&target)?;
            archives.push(json!({"path": path, "lighting": lighting, "scene": scene, "size": size, "sha256": sha256}));
            files.push(ReleaseFile { version: version.clone(), path, size: size as i64, sha256, kind: "archive".into() });
        }
        manifest["archives"] = Value::Array(archives);
        let served = serde_json::to_string_pretty(&manifest)? + "\n";
        std::fs::write(staging.join("manifest.json"), &served)?;
        let digest = manifest["digest"].as_str().unwrap_or_default().to_string();
        let record = ReleaseRecord {
            version: version.clone(),
            state: crate::store::ReleaseState::Draft,
            is_current: false,
            digest,
            manifest: served,
            created_at: now_ms(),
            published_at: None,
        };
        Ok(PreparedRelease { record, files })
    })();
    match result {
        Ok(prepared) => Ok((prepared, staging)),
        Err(e) => {
            let _ = std::fs::remove_dir_all(&staging);
            Err(e)
        }
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

/// Import the built release in `dir`; `publish` also makes it the current release.
pub async fn import_release(store: &Store, blobs: &Blobs, dir: &Path, publish: bool) -> anyhow::Result<Imported> {
    // One import at a time in this process, so two imports of one version cannot
    // replace each other's blobs (builds of one version are one job, by the jobs' index).
    static IMPORTING: tokio::sync::Mutex<()> = tokio::sync::Mutex::const_new(());
    let _one_at_a_time = IMPORTING.lock().await;
    let (blobs_for_stage, dir_owned) = (blobs.clone(), dir.to_path_buf());
    let (prepared, staging) = tokio::task::spawn_blocking(move || stage_release(&blobs_for_stage, &dir_owned)).await??;
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
