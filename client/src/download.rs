//! `osmab client download`: the manifest, then the release's files — each sequence as
//! its archive, everything else file by file — on several connections. A download
//! goes to `<file>.part` and resumes from there with `Range` (and `If-Range`, so a
//! changed file starts over); every file is checked against the manifest's SHA-256 and
//! one that does not match is fetched again from the start. What is already present
//! and correct is skipped, so running the command again finishes an interrupted run.

use std::collections::BTreeSet;
use std::path::{Path, PathBuf};
use std::sync::Mutex;

use anyhow::{Context, anyhow, bail};
use indicatif::{ProgressBar, ProgressStyle};
use osmab_evaluator::formats::manifest::{ArchiveEntry, FileEntry, ReleaseManifest, files_digest, sequence_prefix};
use osmab_evaluator::submission::archive::{ArchiveLimits, tar_file_names, unpack};

use super::api::Api;
use super::fetch_file::{RemoteFile, fetch, is_correct};

/// What to fetch.
pub struct Selection {
    pub release: Option<String>,
    pub lightings: Vec<String>,
    pub scenes: Vec<String>,
    pub jobs: usize,
}

/// One thing to download: a release file, or a sequence archive with the files it holds.
struct Task {
    file: RemoteFile,
    /// For an archive: the manifest files it unpacks to.
    unpacks_to: Option<Vec<FileEntry>>,
}

/// The release to fetch: the one named, else the current one.
fn pick_release(api: &Api, wanted: Option<&str>) -> anyhow::Result<String> {
    if let Some(v) = wanted {
        return Ok(v.to_string());
    }
    let list = api.get_json("/api/v1/releases")?;
    list["releases"]
        .as_array()
        .into_iter()
        .flatten()
        .find(|r| r["current"] == true)
        .and_then(|r| r["version"].as_str().map(str::to_string))
        .ok_or_else(|| anyhow!("the server has no current release yet; name one with --release"))
}

/// A path of the manifest, checked to stay inside the output folder.
fn local(out: &Path, path: &str) -> anyhow::Result<PathBuf> {
    let safe = !path.is_empty() && !path.starts_with('/') && path.split('/').all(|c| !c.is_empty() && c != "." && c != "..") && !path.contains('\\');
    if !safe {
        bail!("the manifest lists '{path}', which is not a plain relative path; refusing to write it");
    }
    Ok(out.join(path))
}

/// Whether a path belongs to the selection: a component naming a lighting or a scene of
/// the release must be a selected one.
fn selected(path: &str, lightings: &BTreeSet<String>, scenes: &BTreeSet<String>, selection: &Selection) -> bool {
    path.split('/').all(|component| {
        let stem = component.split('.').next().unwrap_or(component);
        let lighting_ok = !lightings.contains(stem) || selection.lightings.is_empty() || selection.lightings.iter().any(|l| l == stem);
        let scene_ok = !scenes.contains(stem) || selection.scenes.is_empty() || selection.scenes.iter().any(|s| s == stem);
        lighting_ok && scene_ok
    })
}

/// Where sequence archives and their partial downloads wait (inside the output folder).
const DOWNLOADS: &str = ".osmab-downloads";

/// Remove `dir` and the folders below it that hold no file (partial downloads stay).
fn remove_empty_folders(dir: &Path) {
    if let Ok(entries) = std::fs::read_dir(dir) {
        for entry in entries.flatten() {
            if entry.path().is_dir() {
                remove_empty_folders(&entry.path());
            }
        }
    }
    let _ = std::fs::remove_dir(dir);
}

/// Unpack a verified sequence archive, which must hold exactly the manifest's files of its
/// sequence, and check every file it holds.
fn unpack_sequence(archive: &Path, out: &Path, files: &[FileEntry]) -> anyhow::Result<()> {
    let held = tar_file_names(std::fs::File::open(archive)?, archive).map_err(|e| anyhow!("{e}"))?;
    let listed: BTreeSet<&str> = files.iter().map(|f| f.path.as_str()).collect();
    let extra: Vec<&str> = held.iter().map(String::as_str).filter(|name| !listed.contains(name)).collect();
    if !extra.is_empty() || held.len() != listed.len() {
        bail!(
            "{}: the archive holds {} files where the manifest lists {} for its sequence{}; the server's archive is out of date (tell the organisers: restarting the server repacks it)",
            archive.file_name().map(|n| n.to_string_lossy().to_string()).unwrap_or_default(),
            held.len(),
            listed.len(),
            if extra.is_empty() { String::new() } else { format!(" (not listed: {})", extra.iter().take(3).copied().collect::<Vec<_>>().join(", ")) }
        );
    }
    let staging_dir = tempfile::Builder::new().prefix(".osmab-unpack-").tempdir_in(out)?;
    let staging = staging_dir.path();
    let limits =
        ArchiveLimits { max_entries: files.len() + 64, max_total_bytes: files.iter().map(|f| f.size).sum::<u64>() + (1 << 20), max_expansion_ratio: None };
    unpack(archive, staging, limits).map_err(|e| anyhow!("{e}"))?;
    for f in files {
        let unpacked = staging.join(&f.path);
        if !is_correct(&unpacked, f.size, &f.sha256) {
            std::fs::remove_file(archive)?;
            bail!("{}: the archive's copy does not match the manifest (the archive is removed; run again to fetch it anew)", f.path);
        }
        let target = local(out, &f.path)?;
        std::fs::create_dir_all(target.parent().expect("nested"))?;
        std::fs::rename(&unpacked, &target)?;
    }
    std::fs::remove_file(archive)?;
    Ok(())
}

/// Download the selection into `out`; returns (fetched, skipped) counts.
pub fn download(api: &Api, selection: &Selection, out: &Path) -> anyhow::Result<(usize, usize)> {
    let version = pick_release(api, selection.release.as_deref())?;
    let manifest_text = api.get_retrying(&format!("/api/v1/releases/{version}/manifest.json"))?.text()?;
    let manifest = Listing::verified(&manifest_text, &version)?;
    std::fs::create_dir_all(out).with_context(|| format!("{}: cannot create", out.display()))?;
    std::fs::write(out.join("manifest.json"), &manifest_text)?;
    manifest.check(selection, &version)?;
    let (tasks, skipped) = manifest.tasks(selection, out)?;
    let fetched = tasks.len();
    fetch_all(api, &version, tasks, selection.jobs, out)?;
    Ok((fetched, skipped))
}

/// What a manifest lists, as the download reads it.
struct Listing {
    files: Vec<FileEntry>,
    archives: Vec<ArchiveEntry>,
    lightings: BTreeSet<String>,
    scenes: BTreeSet<String>,
}

impl Listing {
    /// The manifest of `version`, checked: one file per path, and the file list matching
    /// the digest that ties it to the release (a truncated or edited manifest fails here).
    fn verified(text: &str, version: &str) -> anyhow::Result<Listing> {
        let manifest = ReleaseManifest::parse(text, Path::new(&format!("the manifest of {version}"))).map_err(|e| anyhow!("{e}"))?;
        let digest = manifest.digest.clone();
        let listing = Listing {
            lightings: manifest.lightings.iter().map(|l| l.name().to_string()).collect(),
            scenes: manifest.scenes.iter().map(|s| s.id.clone()).collect(),
            files: manifest.files,
            archives: manifest.archives,
        };
        let mut listed = BTreeSet::new();
        let paths = listing.files.iter().map(|f| f.path.as_str()).chain(listing.archives.iter().map(|a| a.path.as_str()));
        if let Some(twice) = paths.into_iter().find(|p| !listed.insert(*p)) {
            bail!("the manifest of {version} lists '{twice}' twice; refusing to download from it (ask the organisers)");
        }
        if files_digest(&listing.files) != digest {
            bail!("the manifest of {version} does not match its digest; the download was damaged or the server is misconfigured");
        }
        Ok(listing)
    }

    /// Every lighting and scene asked for is in the release.
    fn check(&self, selection: &Selection, version: &str) -> anyhow::Result<()> {
        for wanted in &selection.lightings {
            anyhow::ensure!(
                self.lightings.contains(wanted),
                "release {version} has no lighting '{wanted}' (it has {})",
                self.lightings.iter().cloned().collect::<Vec<_>>().join(", ")
            );
        }
        for wanted in &selection.scenes {
            anyhow::ensure!(self.scenes.contains(wanted), "release {version} has no scene '{wanted}'");
        }
        Ok(())
    }

    /// What to download into `out` (sequences as archives, the rest file by file), with
    /// where each goes; and how many selected files are there already, verified.
    fn tasks(&self, selection: &Selection, out: &Path) -> anyhow::Result<(Vec<(Task, PathBuf)>, usize)> {
        let mut tasks: Vec<(Task, PathBuf)> = Vec::new();
        let mut skipped = 0;
        let mut in_archives = BTreeSet::new();
        for a in &self.archives {
            if !selected(&format!("sequences/{}/{}", a.lighting, a.scene), &self.lightings, &self.scenes, selection) {
                continue;
            }
            let prefix = sequence_prefix(a.lighting, &a.scene);
            let members: Vec<FileEntry> = self.files.iter().filter(|f| f.path.starts_with(&prefix)).cloned().collect();
            in_archives.extend(members.iter().map(|f| f.path.clone()));
            let missing = members.iter().any(|f| local(out, &f.path).map_or(true, |p| !is_correct(&p, f.size, &f.sha256)));
            if !missing {
                skipped += members.len();
                continue;
            }
            // Archives land in a hidden folder and are removed once unpacked and verified.
            let target = local(&out.join(DOWNLOADS), &a.path)?;
            tasks.push((Task { file: RemoteFile { path: a.path.clone(), size: a.size, sha256: a.sha256.clone() }, unpacks_to: Some(members) }, target));
        }
        for f in self.files.iter().filter(|f| !in_archives.contains(&f.path) && selected(&f.path, &self.lightings, &self.scenes, selection)) {
            let target = local(out, &f.path)?;
            if is_correct(&target, f.size, &f.sha256) {
                skipped += 1;
                continue;
            }
            if target.exists() {
                eprintln!("{}: present but not the manifest's bytes; fetching it again", f.path);
                std::fs::remove_file(&target)?;
            }
            tasks.push((Task { file: RemoteFile { path: f.path.clone(), size: f.size, sha256: f.sha256.clone() }, unpacks_to: None }, target));
        }
        Ok((tasks, skipped))
    }
}

/// Download `tasks` with `jobs` threads behind one progress bar (archives unpacked as they
/// arrive); every failure is reported together at the end.
fn fetch_all(api: &Api, version: &str, tasks: Vec<(Task, PathBuf)>, jobs: usize, out: &Path) -> anyhow::Result<()> {
    let total: u64 = tasks.iter().map(|(t, _)| t.file.size).sum();
    let already: u64 = tasks.iter().map(|(_, p)| std::fs::metadata(PathBuf::from(format!("{}.part", p.display()))).map(|m| m.len()).unwrap_or(0)).sum();
    let bar = ProgressBar::new(total);
    bar.set_style(ProgressStyle::with_template("{bar:40} {bytes}/{total_bytes} {binary_bytes_per_sec} eta {eta} {msg}").expect("template"));
    bar.set_position(already.min(total));
    let count = tasks.len();
    let queue = Mutex::new(tasks);
    let errors = Mutex::new(Vec::new());
    let log = |line: String| bar.suspend(|| eprintln!("{line}"));
    std::thread::scope(|scope| {
        for _ in 0..jobs.max(1) {
            scope.spawn(|| {
                loop {
                    let Some((task, target)) = queue.lock().expect("queue").pop() else { break };
                    let result = fetch(api, version, &task.file, &target, &bar, &log)
                        .and_then(|()| match &task.unpacks_to {
                            Some(members) => unpack_sequence(&target, out, members),
                            None => Ok(()),
                        })
                        .with_context(|| format!("{} (into {})", task.file.path, target.display()));
                    if let Err(e) = result {
                        errors.lock().expect("errors").push(format!("{e:#}"));
                    }
                }
            });
        }
    });
    bar.finish_and_clear();
    remove_empty_folders(&out.join(DOWNLOADS));
    let errors = errors.into_inner().expect("errors");
    if !errors.is_empty() {
        bail!("{} of {count} downloads failed:\n  {}", errors.len(), errors.join("\n  "));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn manifest_paths_stay_inside_the_output() {
        let out = Path::new("/tmp/x");
        assert!(local(out, "sequences/baseline/scene_000/results/frame000000.jpg").is_ok());
        for bad in ["../etc/passwd", "/etc/passwd", "a//b", "a/./b", "a\\b", ""] {
            assert!(local(out, bad).is_err(), "{bad}");
        }
    }

    #[test]
    fn filters_keep_what_names_no_other_lighting_or_scene() {
        let lightings: BTreeSet<String> = ["baseline", "camera"].map(String::from).into();
        let scenes: BTreeSet<String> = ["scene_000", "scene_001"].map(String::from).into();
        let selection = Selection { release: None, lightings: vec!["camera".into()], scenes: vec!["scene_001".into()], jobs: 1 };
        let keep = |p: &str| selected(p, &lightings, &scenes, &selection);
        assert!(keep("classes.json"));
        assert!(keep("questions/scene_001.json"));
        assert!(!keep("questions/scene_000.json"));
        assert!(keep("sequences/camera/scene_001/traj.txt"));
        assert!(!keep("sequences/baseline/scene_001/traj.txt"));
        assert!(!keep("quality/contact_sheets/baseline/scene_001.png"));
    }
}
