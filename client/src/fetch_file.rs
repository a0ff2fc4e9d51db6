//! One release file fetched over HTTP into place: resumed from a partial download with
//! `Range`/`If-Range`, retried with backoff (or as the server asks), and verified against
//! the manifest's size and SHA-256 before it is renamed into place.

use std::io::{Read, Write};
use std::path::{Path, PathBuf};
use std::time::Duration;

use anyhow::{Context, anyhow};
use indicatif::ProgressBar;

use osmab_api::digest;

use super::api::{Api, checked, describe};

/// A file of a release as its manifest lists it.
pub struct RemoteFile {
    /// Its path in the release.
    pub path: String,
    pub size: u64,
    pub sha256: String,
}

/// Whether `path` holds exactly the manifest's bytes.
pub fn is_correct(path: &Path, size: u64, sha256: &str) -> bool {
    std::fs::metadata(path).is_ok_and(|m| m.len() == size) && digest::sha256_file(path).is_ok_and(|(_, sum)| digest::hex(&sum) == sha256)
}

/// Fetch `file.path` into `target` (through `target.part`, resumed), verified: up to
/// five attempts, waiting longer each time (or as long as the server asks).
pub fn fetch(api: &Api, version: &str, file: &RemoteFile, target: &Path, bar: &ProgressBar, log: &dyn Fn(String)) -> anyhow::Result<()> {
    if let Some(dir) = target.parent() {
        std::fs::create_dir_all(dir).with_context(|| format!("{}: cannot create", dir.display()))?;
    }
    let fetch = Fetch {
        api,
        url: format!("/api/v1/releases/{version}/files/{}", file.path),
        file,
        part: PathBuf::from(format!("{}.part", target.display())),
        target,
        bar,
        log,
    };
    let mut last_error = None;
    let mut wait = Duration::ZERO;
    for attempt in 0..5 {
        if attempt > 0 {
            std::thread::sleep(wait.max(Duration::from_secs(1 << attempt.min(4))));
        }
        match fetch.attempt()? {
            Attempt::Done => return Ok(()),
            Attempt::Again { error, after } => (last_error, wait) = (Some(error), after),
        }
    }
    Err(last_error.unwrap_or_else(|| anyhow!("{}: download failed", file.path)).context("the partial download is kept; run the command again to resume"))
}

/// One file being fetched.
struct Fetch<'a> {
    api: &'a Api,
    url: String,
    file: &'a RemoteFile,
    /// Where the bytes arrive until they are verified.
    part: PathBuf,
    target: &'a Path,
    bar: &'a ProgressBar,
    log: &'a dyn Fn(String),
}

/// How an attempt ended, when it did not fail for good.
enum Attempt {
    Done,
    /// Try again after `after` at least; `error` says why, should it be the last attempt.
    Again {
        error: anyhow::Error,
        after: Duration,
    },
}

impl Fetch<'_> {
    /// Bytes of the partial download so far.
    fn have(&self) -> u64 {
        std::fs::metadata(&self.part).map(|m| m.len()).unwrap_or(0)
    }

    /// Drop the partial download, and what the progress bar counted of it (it started from
    /// every .part's size).
    fn discard(&self) {
        self.bar.set_position(self.bar.position().saturating_sub(self.have()));
        let _ = std::fs::remove_file(&self.part);
    }

    /// The partial download renamed into place when it is the whole file, verified.
    fn finish_if_correct(&self) -> anyhow::Result<bool> {
        if self.have() == self.file.size && is_correct(&self.part, self.file.size, &self.file.sha256) {
            std::fs::rename(&self.part, self.target)?;
            return Ok(true);
        }
        Ok(false)
    }

    /// Ask for the rest of the file (all of it when nothing usable is here), and keep it.
    fn attempt(&self) -> anyhow::Result<Attempt> {
        let remote = &self.file.path;
        // A complete .part (the rename was interrupted) needs no byte from the server.
        if self.finish_if_correct()? {
            return Ok(Attempt::Done);
        }
        if self.have() >= self.file.size && self.have() > 0 {
            (self.log)(format!("{remote}: the partial download is not a prefix of the file; fetching it again from the start"));
            self.discard();
        }
        let have = self.have();
        let mut request = self.api.get(&self.url).timeout(Duration::from_secs(3600));
        if have > 0 {
            request = request.header("Range", format!("bytes={have}-")).header("If-Range", format!("\"{}\"", self.file.sha256));
        }
        let again = |error: anyhow::Error| Ok(Attempt::Again { error, after: Duration::ZERO });
        let response = match request.send() {
            Ok(r) => r,
            Err(e) => return again(anyhow!("{remote}: {}", describe(&e))),
        };
        let status = response.status();
        if status == reqwest::StatusCode::RANGE_NOT_SATISFIABLE {
            (self.log)(format!("{remote}: the server cannot resume at byte {have}; fetching it again from the start"));
            self.discard();
            return again(anyhow!("{remote}: range not satisfiable"));
        }
        if status.is_server_error() || status == reqwest::StatusCode::TOO_MANY_REQUESTS {
            // Passing trouble: wait as the server asks (at most a minute), then try again.
            let after = response
                .headers()
                .get("retry-after")
                .and_then(|v| v.to_str().ok())
                .and_then(|v| v.parse::<u64>().ok())
                .map_or(Duration::ZERO, |s| Duration::from_secs(s.min(60)));
            let error = checked(response).err().unwrap_or_else(|| anyhow!("server error")).context(format!("downloading {remote}"));
            return Ok(Attempt::Again { error, after });
        }
        let resumed = status == reqwest::StatusCode::PARTIAL_CONTENT;
        let response = checked(response).map_err(|e| e.context(format!("downloading {remote}")))?;
        if let Err(e) = self.keep(response, resumed, have)? {
            return again(anyhow!("{remote}: the connection broke: {e}"));
        }
        if self.finish_if_correct()? {
            return Ok(Attempt::Done);
        }
        (self.log)(format!("{remote}: the bytes do not match the manifest's SHA-256; fetching it again from the start"));
        self.discard();
        again(anyhow!("{remote}: SHA-256 mismatch"))
    }

    /// Write the answer's bytes to the partial download (after what it holds when
    /// `resumed`); the outer error is the disk's, the inner one the connection's.
    fn keep(&self, mut response: reqwest::blocking::Response, resumed: bool, have: u64) -> anyhow::Result<std::io::Result<()>> {
        let mut file = if resumed {
            (self.log)(format!("{}: resuming at byte {have} of {}", self.file.path, self.file.size));
            std::fs::OpenOptions::new().append(true).open(&self.part)?
        } else {
            // The whole file comes again: what the bar counted of the old part goes.
            self.discard();
            std::fs::File::create(&self.part)?
        };
        let mut buf = vec![0u8; 256 * 1024];
        let copied = loop {
            match response.read(&mut buf) {
                Ok(0) => break Ok(()),
                Ok(n) => {
                    file.write_all(&buf[..n])?;
                    self.bar.inc(n as u64);
                }
                Err(e) => break Err(e),
            }
        };
        file.sync_all()?;
        Ok(copied)
    }
}
