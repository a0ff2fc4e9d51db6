//! `osmab client submit` over resumable uploads (tus 1.0.0): the archive goes in chunks,
//! each with its SHA-256 (`Upload-Checksum`); the upload's address is kept in the
//! client's folder under the archive's SHA-256, so a submit killed midway (or cut off by
//! a server that died) continues from the offset the server reports — through any server
//! of the deployment — instead of starting again. The complete upload becomes a
//! submission with `POST /api/v1/submissions?upload=ID`, with the whole archive's
//! `Content-Digest` and an `Idempotency-Key` derived from the upload, so a retried or
//! resumed submit never makes two submissions.

use osmab_evaluator::scores::Split;
use std::io::{Read, Seek, SeekFrom};
use std::path::{Path, PathBuf};
use std::time::Duration;

use anyhow::{Context, anyhow, bail};
use base64::Engine;
use indicatif::{ProgressBar, ProgressStyle};
use reqwest::StatusCode;
use sha2::{Digest, Sha256};

use super::api::{Api, checked, describe};
use super::submit::Packed;
use osmab_api::submissions::Created;

const TUS: &str = "1.0.0";
/// Bytes per PATCH unless `OSMAB_UPLOAD_CHUNK_BYTES` says otherwise.
const CHUNK_BYTES: u64 = 8 << 20;
/// Attempts per request before the submit gives up (it resumes when run again).
const ATTEMPTS: u32 = 6;

fn chunk_bytes() -> anyhow::Result<u64> {
    match std::env::var("OSMAB_UPLOAD_CHUNK_BYTES") {
        Ok(text) => {
            text.trim().parse::<u64>().ok().filter(|n| *n >= 1).ok_or_else(|| anyhow!("OSMAB_UPLOAD_CHUNK_BYTES: '{text}' is not a positive number of bytes"))
        }
        Err(_) => Ok(CHUNK_BYTES),
    }
}

/// Where the address of the upload of the archive with `sha256` is kept.
fn state_file(sha256: &str) -> anyhow::Result<PathBuf> {
    let config = super::session::config_path()?;
    Ok(config.parent().context("the client's configuration file has no folder")?.join("uploads").join(format!("{sha256}.upload")))
}

/// Retry `request` while the network or the server fails passingly; the last error
/// after [`ATTEMPTS`].
fn with_retries(what: &str, mut request: impl FnMut() -> reqwest::Result<reqwest::blocking::Response>) -> anyhow::Result<reqwest::blocking::Response> {
    let mut last = None;
    for attempt in 0..ATTEMPTS {
        if attempt > 0 {
            let wait = Duration::from_millis(500 << attempt.min(5));
            eprintln!("{what}: retrying in {:.1} s ({})", wait.as_secs_f64(), last.as_ref().map(ToString::to_string).unwrap_or_default());
            std::thread::sleep(wait);
        }
        match request() {
            Ok(response) if response.status().is_server_error() => last = Some(checked(response).err().unwrap_or_else(|| anyhow!("server error"))),
            Ok(response) => return Ok(response),
            Err(e) => last = Some(anyhow!("{}", describe(&e))),
        }
    }
    Err(last.unwrap_or_else(|| anyhow!("{what} failed")).context(format!("{what} failed {ATTEMPTS} times; run the same command again to resume")))
}

fn offset_of(response: &reqwest::blocking::Response) -> anyhow::Result<u64> {
    response.headers().get("upload-offset").and_then(|v| v.to_str().ok()).and_then(|v| v.parse().ok()).context("the server's answer has no Upload-Offset")
}

/// The upload to continue (its path and offset), if the client kept one the server
/// still has.
fn kept_upload(api: &Api, token: &str, state: &PathBuf, size: u64) -> anyhow::Result<Option<(String, u64)>> {
    let Ok(path) = std::fs::read_to_string(state) else { return Ok(None) };
    let path = path.trim().to_string();
    if !path.starts_with("/api/v1/uploads/") {
        return Ok(None);
    }
    let response = with_retries("HEAD", || api.client.head(api.url(&path)).bearer_auth(token).header("tus-resumable", TUS).send())?;
    if !response.status().is_success() {
        return Ok(None); // expired or from another deployment: start anew
    }
    let length: Option<u64> = response.headers().get("upload-length").and_then(|v| v.to_str().ok()).and_then(|v| v.parse().ok());
    if length != Some(size) {
        return Ok(None);
    }
    Ok(Some((path, offset_of(&response)?)))
}

/// Send `packed` as a resumable upload and submit it; returns the server's answer.
pub fn submit(api: &Api, packed: &Packed, public: bool, split: Option<Split>) -> anyhow::Result<Created> {
    let token = api.session.token()?.to_string();
    // One kept upload per archive and split: a submit to another split starts its own.
    let state = state_file(&match split {
        Some(split) => format!("{}-{split}", packed.sha256_hex()),
        None => packed.sha256_hex(),
    })?;
    let (path, offset) = match kept_upload(api, &token, &state, packed.size)? {
        Some((path, offset)) => {
            eprintln!("resuming the upload at byte {offset} of {}", packed.size);
            (path, offset)
        }
        None => (create_upload(api, &token, packed, &state)?, 0),
    };
    send_rest(api, &token, packed, &path, offset, &state)?;
    let answer = submit_upload(api, &token, packed, &path, public, split)?;
    let _ = std::fs::remove_file(&state);
    Ok(answer)
}

/// Start a resumable upload of `packed` and keep its address in `state`; its path.
fn create_upload(api: &Api, token: &str, packed: &Packed, state: &Path) -> anyhow::Result<String> {
    let encode = |text: &str| base64::engine::general_purpose::STANDARD.encode(text);
    let name = packed.path.file_name().unwrap_or_default().to_string_lossy();
    let metadata = format!("filename {},sha256 {}", encode(&name), encode(&packed.sha256_hex()));
    let response = with_retries("creating the upload", || {
        api.client
            .post(api.url("/api/v1/uploads"))
            .bearer_auth(token)
            .header("tus-resumable", TUS)
            .header("upload-length", packed.size)
            .header("upload-metadata", &metadata)
            .send()
    })?;
    let response = checked(response)?;
    let location = response.headers().get("location").and_then(|v| v.to_str().ok()).context("the server's answer has no Location")?.to_string();
    std::fs::create_dir_all(state.parent().expect("in the uploads folder"))?;
    std::fs::write(state, &location).with_context(|| format!("{}: cannot keep the upload's address", state.display()))?;
    Ok(location)
}

/// Send the bytes of `packed` from `offset` on, chunk by chunk, with a progress bar.
fn send_rest(api: &Api, token: &str, packed: &Packed, path: &str, mut offset: u64, state: &Path) -> anyhow::Result<()> {
    // The server refuses chunks below its minimum for the upload's length (but the last).
    let chunk = chunk_bytes()?.max(osmab_api::uploads::min_part_bytes(packed.size));
    let bar = ProgressBar::new(packed.size);
    bar.set_style(ProgressStyle::with_template("upload {bar:40} {bytes}/{total_bytes} {binary_bytes_per_sec} eta {eta}").expect("template"));
    bar.set_position(offset);
    let mut file = std::fs::File::open(&packed.path).with_context(|| format!("{}: cannot read", packed.path.display()))?;
    let mut buffer = Vec::new();
    while offset < packed.size {
        let length = chunk.min(packed.size - offset);
        file.seek(SeekFrom::Start(offset))?;
        buffer.resize(length as usize, 0);
        file.read_exact(&mut buffer).with_context(|| format!("{}: changed while uploading", packed.path.display()))?;
        match send_chunk(api, token, path, offset, &buffer, state) {
            Ok(next) => offset = next,
            Err(e) => {
                bar.abandon();
                return Err(e);
            }
        }
        bar.set_position(offset);
    }
    bar.finish_and_clear();
    Ok(())
}

/// Send `chunk` at `offset`; where the upload then stands.
fn send_chunk(api: &Api, token: &str, path: &str, offset: u64, chunk: &[u8], state: &Path) -> anyhow::Result<u64> {
    let checksum = format!("sha256 {}", base64::engine::general_purpose::STANDARD.encode(Sha256::digest(chunk)));
    let response = with_retries("sending", || {
        api.client
            .patch(api.url(path))
            .bearer_auth(token)
            .header("tus-resumable", TUS)
            .header("content-type", "application/offset+octet-stream")
            .header("upload-offset", offset)
            .header("upload-checksum", &checksum)
            .timeout(Duration::from_secs(600))
            .body(chunk.to_vec())
            .send()
    })?;
    match response.status() {
        status if status.is_success() => offset_of(&response),
        // Another attempt got there first, or this one's reply was lost: ask where it stands.
        StatusCode::CONFLICT => {
            let head = with_retries("HEAD", || api.client.head(api.url(path)).bearer_auth(token).header("tus-resumable", TUS).send())?;
            offset_of(&checked(head)?)
        }
        status if matches!(status.as_u16(), 404 | 410) => {
            let _ = std::fs::remove_file(state);
            bail!("the server no longer has this upload ({status}); run the same command again to start anew")
        }
        _ => Err(checked(response).err().unwrap_or_else(|| anyhow!("unexpected answer"))),
    }
}

/// Submit the completed upload at `path` (answered exactly as a direct upload).
fn submit_upload(api: &Api, token: &str, packed: &Packed, path: &str, public: bool, split: Option<Split>) -> anyhow::Result<Created> {
    let id = path.rsplit('/').next().unwrap_or_default().to_string();
    let digest = format!("sha-256=:{}:", base64::engine::general_purpose::STANDARD.encode(packed.sha256));
    let mut url = format!("{}?upload={id}", api.url("/api/v1/submissions"));
    if !public {
        url.push_str("&public=false");
    }
    if let Some(split) = split {
        url.push_str(&format!("&split={split}"));
    }
    let response = with_retries("submitting the upload", || {
        api.client
            .post(&url)
            .bearer_auth(token)
            .header("content-digest", &digest)
            .header("idempotency-key", format!("osmab-upload-{id}"))
            .timeout(Duration::from_secs(3600))
            .send()
    })?;
    checked(response)?.json().map_err(|e| anyhow!("the server's answer to the upload does not read as a submission: {e}"))
}
