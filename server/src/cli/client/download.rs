//! `osmab client download`: the manifest, then the release's files — each sequence as
//! its archive, everything else file by file — on several connections. A download
//! goes to `<file>.part` and resumes from there with `Range` (and `If-Range`, so a
//! changed file starts over); every file is checked against the manifest's SHA-256 and
//! one that does not match is fetched again from the start. What is already present
//! and correct is skipped, so running the command again finishes an interrupted run.

use std::collections::BTreeSet;
use std::io::{Read, Write};
use std::path::{Path, PathBuf};
use std::sync::Mutex;
use std::time::Duration;

use anyhow::{Context, anyhow, bail};
use indicatif::{ProgressBar, ProgressStyle};
use osmab_evaluator::submission::archive::{ArchiveLimits, tar_file_names, unpack};
use serde::Deserialize;
use serde_json::Value;
use sha2::{Digest, Sha256};

use super::api::{Api, checked, describe};

#[derive(Debug, Clone, Deserialize)]
struct FileEntry {
    path: String,
    size: u64,
    sha256: String,
}

#[derive(Debug, Clone, Deserialize)]
struct ArchiveEntry {
    path: String,
    lighting: String,
    scene: String,
    size: u64,
    sha256: String,
}

/// What to fetch.
pub struct Selection {
    pub release: Option<String>,
    pub lightings: Vec<String>,
    pub scenes: Vec<String>,
    pub jobs: usize,
}

/// One thing to download: a release file, or a sequence archive with the files it holds.
struct Task {
    remote: String,
    size: u64,
    sha256: String,
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

/// Whether `path` holds exactly the manifest's bytes.
fn is_correct(path: &Path, size: u64, sha256: &str) -> bool {
    std::fs::metadata(path).is_ok_and(|m| m.len() == size) && osmab_dataset::release::manifest::hash_file(path).is_ok_and(|(_, h)| h == sha256)
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

/// Fetch `task.remote` into `target` (through `target.part`, resumed), verified.
fn fetch(api: &Api, version: &str, task: &Task, target: &Path, bar: &ProgressBar, log: &dyn Fn(String)) -> anyhow::Result<()> {
    let part = PathBuf::from(format!("{}.part", target.display()));
    if let Some(dir) = target.parent() {
        std::fs::create_dir_all(dir).with_context(|| format!("{}: cannot create", dir.display()))?;
    }
    let url = format!("/api/v1/releases/{version}/files/{}", task.remote);
    // Bytes of `part` the progress bar counts already (it started from every .part's size).
    let discard = |part: &Path| {
        let have = std::fs::metadata(part).map(|m| m.len()).unwrap_or(0);
        bar.set_position(bar.position().saturating_sub(have));
        let _ = std::fs::remove_file(part);
    };
    let mut last_error = None;
    let mut wait = Duration::ZERO;
    for attempt in 0..5 {
        if attempt > 0 {
            std::thread::sleep(wait.max(Duration::from_secs(1 << attempt.min(4))));
            wait = Duration::ZERO;
        }
        let have = std::fs::metadata(&part).map(|m| m.len()).unwrap_or(0);
        // A complete .part (the rename was interrupted) needs no byte from the server.
        if have == task.size && is_correct(&part, task.size, &task.sha256) {
            std::fs::rename(&part, target)?;
            return Ok(());
        }
        if have >= task.size && have > 0 {
            log(format!("{}: the partial download is not a prefix of the file; fetching it again from the start", task.remote));
            discard(&part);
        }
        let have = std::fs::metadata(&part).map(|m| m.len()).unwrap_or(0);
        let mut request = api.get(&url).timeout(Duration::from_secs(3600));
        if have > 0 {
            request = request.header("Range", format!("bytes={have}-")).header("If-Range", format!("\"{}\"", task.sha256));
        }
        let response = match request.send() {
            Ok(r) => r,
            Err(e) => {
                last_error = Some(anyhow!("{}: {}", task.remote, describe(&e)));
                continue;
            }
        };
        let status = response.status();
        if status == reqwest::StatusCode::RANGE_NOT_SATISFIABLE {
            log(format!("{}: the server cannot resume at byte {have}; fetching it again from the start", task.remote));
            discard(&part);
            last_error = Some(anyhow!("{}: range not satisfiable", task.remote));
            continue;
        }
        if status.is_server_error() || status == reqwest::StatusCode::TOO_MANY_REQUESTS {
            // Passing trouble: wait as the server asks (at most a minute), then try again.
            wait = response
                .headers()
                .get("retry-after")
                .and_then(|v| v.to_str().ok())
                .and_then(|v| v.parse::<u64>().ok())
                .map_or(Duration::ZERO, |s| Duration::from_secs(s.min(60)));
            last_error = Some(checked(response).err().unwrap_or_else(|| anyhow!("server error")).context(format!("downloading {}", task.remote)));
            continue;
        }
        let resumed = status == reqwest::StatusCode::PARTIAL_CONTENT;
        let mut response = match checked(response) {
            Ok(r) => r,
            Err(e) => return Err(e.context(format!("downloading {}", task.remote))),
        };
        let mut file = if resumed {
            log(format!("{}: resuming at byte {have} of {}", task.remote, task.size));
            std::fs::OpenOptions::new().append(true).open(&part)?
        } else {
            // The whole file comes again: what the bar counted of the old part goes.
            discard(&part);
            std::fs::File::create(&part)?
        };
        let mut buf = vec![0u8; 256 * 1024];
        let copied = loop {
            match response.read(&mut buf) {
                Ok(0) => break Ok(()),
                Ok(n) => {
                    file.write_all(&buf[..n])?;
                    bar.inc(n as u64);
                }
                Err(e) => break Err(e),
            }
        };
        file.sync_all()?;
        if let Err(e) = copied {
            last_error = Some(anyhow!("{}: the connection broke: {e}", task.remote));
            continue;
        }
        if is_correct(&part, task.size, &task.sha256) {
            std::fs::rename(&part, target)?;
            return Ok(());
        }
        log(format!("{}: the bytes do not match the manifest's SHA-256; fetching it again from the start", task.remote));
        discard(&part);
        last_error = Some(anyhow!("{}: SHA-256 mismatch", task.remote));
    }
    Err(last_error.unwrap_or_else(|| anyhow!("{}: download failed", task.remote)).context("the partial download is kept; run the command again to resume"))
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
    let manifest: Value = serde_json::from_str(&manifest_text).context("the manifest is not JSON")?;
    let files: Vec<FileEntry> = serde_json::from_value(manifest["files"].clone()).context("manifest: files")?;
    let archives: Vec<ArchiveEntry> =
        serde_json::from_value(manifest.get("archives").cloned().unwrap_or(Value::Array(vec![]))).context("manifest: archives")?;
    // One path, one file: a manifest that lists a path twice (with two checksums) is refused.
    let mut listed = BTreeSet::new();
    if let Some(twice) = files.iter().map(|f| f.path.as_str()).chain(archives.iter().map(|a| a.path.as_str())).find(|p| !listed.insert(*p)) {
        bail!("the manifest of {version} lists '{twice}' twice; refusing to download from it (ask the organisers)");
    }
    // The digest ties the file list to the release: a truncated or edited manifest fails here.
    let mut lines: Vec<String> = files.iter().map(|f| format!("{} {} {}\n", f.path, f.size, f.sha256)).collect();
    lines.sort();
    let digest: String = Sha256::digest(lines.concat().as_bytes()).iter().map(|b| format!("{b:02x}")).collect();
    if manifest["digest"].as_str() != Some(digest.as_str()) {
        bail!("the manifest of {version} does not match its digest; the download was damaged or the server is misconfigured");
    }
    std::fs::create_dir_all(out).with_context(|| format!("{}: cannot create", out.display()))?;
    std::fs::write(out.join("manifest.json"), &manifest_text)?;

    let lightings: BTreeSet<String> = manifest["lightings"].as_array().into_iter().flatten().filter_map(|v| v.as_str().map(str::to_string)).collect();
    let scenes: BTreeSet<String> = manifest["scenes"].as_array().into_iter().flatten().filter_map(|v| v["id"].as_str().map(str::to_string)).collect();
    for wanted in &selection.lightings {
        anyhow::ensure!(
            lightings.contains(wanted),
            "release {version} has no lighting '{wanted}' (it has {})",
            lightings.iter().cloned().collect::<Vec<_>>().join(", ")
        );
    }
    for wanted in &selection.scenes {
        anyhow::ensure!(scenes.contains(wanted), "release {version} has no scene '{wanted}'");
    }

    let mut tasks: Vec<(Task, PathBuf)> = Vec::new();
    let mut skipped = 0;
    let mut in_archives = BTreeSet::new();
    for a in &archives {
        if !selected(&format!("sequences/{}/{}", a.lighting, a.scene), &lightings, &scenes, selection) {
            continue;
        }
        let prefix = format!("sequences/{}/{}/", a.lighting, a.scene);
        let members: Vec<FileEntry> = files.iter().filter(|f| f.path.starts_with(&prefix)).cloned().collect();
        in_archives.extend(members.iter().map(|f| f.path.clone()));
        let missing = members.iter().any(|f| local(out, &f.path).map_or(true, |p| !is_correct(&p, f.size, &f.sha256)));
        if !missing {
            skipped += members.len();
            continue;
        }
        // Archives land in a hidden folder and are removed once unpacked and verified.
        let target = local(&out.join(DOWNLOADS), &a.path)?;
        tasks.push((Task { remote: a.path.clone(), size: a.size, sha256: a.sha256.clone(), unpacks_to: Some(members) }, target));
    }
    for f in files.iter().filter(|f| !in_archives.contains(&f.path) && selected(&f.path, &lightings, &scenes, selection)) {
        let target = local(out, &f.path)?;
        if is_correct(&target, f.size, &f.sha256) {
            skipped += 1;
            continue;
        }
        if target.exists() {
            eprintln!("{}: present but not the manifest's bytes; fetching it again", f.path);
            std::fs::remove_file(&target)?;
        }
        tasks.push((Task { remote: f.path.clone(), size: f.size, sha256: f.sha256.clone(), unpacks_to: None }, target));
    }

    let total: u64 = tasks.iter().map(|(t, _)| t.size).sum();
    let already: u64 = tasks.iter().map(|(_, p)| std::fs::metadata(PathBuf::from(format!("{}.part", p.display()))).map(|m| m.len()).unwrap_or(0)).sum();
    let bar = ProgressBar::new(total);
    bar.set_style(ProgressStyle::with_template("{bar:40} {bytes}/{total_bytes} {binary_bytes_per_sec} eta {eta} {msg}").expect("template"));
    bar.set_position(already.min(total));
    let fetched = tasks.len();
    let queue = Mutex::new(tasks);
    let errors = Mutex::new(Vec::new());
    let log = |line: String| bar.suspend(|| eprintln!("{line}"));
    std::thread::scope(|scope| {
        for _ in 0..selection.jobs.max(1) {
            scope.spawn(|| {
                loop {
                    let Some((task, target)) = queue.lock().expect("queue").pop() else { break };
                    let result = fetch(api, &version, &task, &target, &bar, &log)
                        .and_then(|()| match &task.unpacks_to {
                            Some(members) => unpack_sequence(&target, out, members),
                            None => Ok(()),
                        })
                        .with_context(|| format!("{} (into {})", task.remote, target.display()));
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
        bail!("{} of {fetched} downloads failed:\n  {}", errors.len(), errors.join("\n  "));
    }
    Ok((fetched, skipped))
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
