//! `osmab client submit`: pack a folder deterministically (or take an archive as it is),
//! declare its SHA-256 (`Content-Digest`), upload it with a progress bar, and retry
//! what the network broke with the same `Idempotency-Key` (the server answers a repeat
//! with the submission it already made), after asking whether the server recorded the
//! upload already (to spare sending it again).

use osmab_evaluator::scores::Split;
use std::io::Read;
use std::path::{Path, PathBuf};
use std::time::Duration;

use anyhow::{Context, anyhow, bail};
use base64::Engine;
use indicatif::{ProgressBar, ProgressStyle};
use osmab_evaluator::submission::archive::pack_directory;
use serde_json::Value;

use super::api::{Api, checked, describe};

/// An archive ready to upload.
pub struct Packed {
    pub path: PathBuf,
    pub size: u64,
    pub sha256: [u8; 32],
    /// The temporary folder holding a packed directory (removed when dropped).
    _scratch: Option<tempfile::TempDir>,
}

impl Packed {
    pub fn sha256_hex(&self) -> String {
        self.sha256.iter().map(|b| format!("{b:02x}")).collect()
    }
}

/// The archive of `submission`: a folder packed as a deterministic tar, or the file itself.
pub fn pack(submission: &Path) -> anyhow::Result<Packed> {
    let (path, scratch) = if submission.is_dir() {
        let scratch = tempfile::tempdir().context("cannot create a temporary folder")?;
        let tar = scratch.path().join("submission.tar");
        pack_directory(submission, &tar).map_err(|e| anyhow!("{e}"))?;
        (tar, Some(scratch))
    } else if submission.is_file() {
        (submission.to_path_buf(), None)
    } else {
        bail!("{}: no such file or folder", submission.display());
    };
    let (size, sha256) = osmab_api::digest::sha256_file(&path).with_context(|| format!("{}: cannot read", path.display()))?;
    Ok(Packed { path, size, sha256, _scratch: scratch })
}

fn content_type(path: &Path) -> anyhow::Result<&'static str> {
    let mut head = [0u8; 4];
    let n = std::fs::File::open(path)?.read(&mut head)?;
    Ok(match &head[..n] {
        [0x1f, 0x8b, ..] => "application/gzip",
        [b'P', b'K', 3, 4] => "application/zip",
        _ => "application/x-tar",
    })
}

/// A reader that advances a progress bar.
struct Counted<R> {
    inner: R,
    bar: ProgressBar,
}

impl<R: Read> Read for Counted<R> {
    fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
        let n = self.inner.read(buf)?;
        self.bar.inc(n as u64);
        Ok(n)
    }
}

/// A recent submission of this team with the same archive, if the server has one (to
/// skip sending the archive again; when this check fails the retry is still safe: it
/// carries the same idempotency key).
fn already_recorded(api: &Api, sha256: &str) -> Option<Value> {
    let list = api.get_team_json("/api/v1/submissions").ok()?;
    for item in list["submissions"].as_array()?.iter().take(5) {
        let id = item["id"].as_str()?;
        let view = api.get_team_json(&format!("/api/v1/submissions/{id}")).ok()?;
        if view["archive"]["sha256"].as_str() == Some(sha256) {
            return Some(view);
        }
    }
    None
}

/// Upload `packed`; returns the server's answer (202 body, or the dry run's report).
pub fn upload(api: &Api, packed: &Packed, dry_run: bool, public: bool, split: Option<Split>) -> anyhow::Result<Value> {
    let token = api.session.token()?.to_string();
    let digest = format!("sha-256=:{}:", base64::engine::general_purpose::STANDARD.encode(packed.sha256));
    let mut query = Vec::new();
    if dry_run {
        query.push("dry_run=true");
    }
    if !public {
        query.push("public=false");
    }
    let split_query = split.map(|split| format!("split={split}"));
    query.extend(split_query.as_deref());
    let url = format!("{}{}", api.url("/api/v1/submissions"), if query.is_empty() { String::new() } else { format!("?{}", query.join("&")) });
    let kind = content_type(&packed.path)?;
    // One key for every attempt: the server answers a repeat with the submission the
    // first attempt made, so a retry never costs a second submission or quota unit.
    let idempotency_key = format!("osmab-client-{}-{}", &packed.sha256_hex()[..16], random_hex());
    let mut last = None;
    for attempt in 0..4 {
        if attempt > 0 {
            let wait = Duration::from_secs(2 << attempt);
            eprintln!("retrying in {} s ({})", wait.as_secs(), last.as_ref().map(|e: &anyhow::Error| e.to_string()).unwrap_or_default());
            std::thread::sleep(wait);
            if !dry_run && let Some(existing) = already_recorded(api, &packed.sha256_hex()) {
                eprintln!("the server had recorded the upload before the connection broke");
                return Ok(existing);
            }
        }
        let bar = ProgressBar::new(packed.size);
        bar.set_style(ProgressStyle::with_template("upload {bar:40} {bytes}/{total_bytes} {binary_bytes_per_sec} eta {eta}").expect("template"));
        let file = std::fs::File::open(&packed.path)?;
        let body = reqwest::blocking::Body::sized(Counted { inner: file, bar: bar.clone() }, packed.size);
        let sent = api
            .client
            .post(&url)
            .bearer_auth(&token)
            .header("content-type", kind)
            .header("content-digest", &digest)
            .header("idempotency-key", &idempotency_key)
            .timeout(Duration::from_secs(6 * 3600))
            .body(body)
            .send();
        bar.finish_and_clear();
        match sent {
            Ok(response) if response.status().is_server_error() || response.status().as_u16() == 429 && !is_quota(&response) => {
                last = Some(checked(response).err().unwrap_or_else(|| anyhow!("server error")));
            }
            Ok(response) => {
                let response = checked(response)?;
                return response.json().map_err(|e| anyhow!("the server's answer is not JSON: {e}"));
            }
            Err(e) => last = Some(anyhow!("the upload broke off: {}", describe(&e))),
        }
    }
    Err(last.unwrap_or_else(|| anyhow!("the upload failed")))
}

fn is_quota(response: &reqwest::blocking::Response) -> bool {
    // A daily quota is not worth retrying within minutes; a rate limit is.
    response.headers().get("retry-after").and_then(|v| v.to_str().ok()).and_then(|v| v.parse::<u64>().ok()).is_some_and(|s| s > 60)
}

/// 32 random hex digits from the operating system's generator: what keeps two uploads of
/// the same archive apart as idempotency keys.
fn random_hex() -> String {
    let mut bytes = [0u8; 16];
    getrandom::fill(&mut bytes).expect("the operating system's random generator works");
    bytes.iter().map(|b| format!("{b:02x}")).collect()
}
