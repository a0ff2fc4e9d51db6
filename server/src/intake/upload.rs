//! An upload arriving: streamed to a scratch file while its size and SHA-256 are counted,
//! with the request headers that describe it (`Content-Digest`, `Idempotency-Key`).

use std::path::PathBuf;

use axum::body::Body;
use axum::http::StatusCode;
use futures_util::StreamExt;
use serde_json::json;
use sha2::{Digest, Sha256};
use tokio::io::AsyncWriteExt;

use crate::blobs::Scratch;
use crate::clock::now_ms;
use crate::problem::{Problem, ProblemCode};
use crate::state::AppState;

/// An upload on disk with what was counted while it arrived.
#[derive(Debug)]
pub struct Upload {
    pub path: PathBuf,
    pub size: u64,
    pub sha256: [u8; 32],
    pub received_at: i64,
}

impl Upload {
    /// Lowercase hex of the SHA-256.
    pub fn sha256_hex(&self) -> String {
        hex(&self.sha256)
    }
}

/// Lowercase hex of a SHA-256 digest (as records and manifests store it).
pub fn hex(digest: &[u8; 32]) -> String {
    digest.iter().map(|b| format!("{b:02x}")).collect()
}

/// Stream `body` into a scratch file, at most `max_bytes`, counting size and SHA-256;
/// memory stays at one chunk whatever the upload's size.
pub async fn receive(state: &AppState, body: Body, max_bytes: u64) -> Result<(Upload, Scratch), Problem> {
    let received_at = now_ms();
    let path = state.blobs.scratch("upload");
    let scratch = Scratch(path.clone());
    let mut file = tokio::fs::File::create(&path).await.map_err(Problem::internal)?;
    let mut hasher = Sha256::new();
    let mut size = 0u64;
    let mut stream = body.into_data_stream();
    while let Some(chunk) = stream.next().await {
        let chunk = chunk.map_err(|e| {
            if crate::http::is_body_timeout(&e) {
                Problem::new(
                    StatusCode::REQUEST_TIMEOUT,
                    ProblemCode::RequestTimeout,
                    "Request timeout",
                    format!("The upload stalled after {size} bytes: nothing arrived for too long. Check the connection and upload again."),
                )
            } else {
                Problem::bad_request(
                    ProblemCode::UploadIncomplete,
                    format!("The upload ended early after {size} bytes ({e}). Check the connection and upload again."),
                )
            }
        })?;
        size += chunk.len() as u64;
        if size > max_bytes {
            return Err(too_large(max_bytes));
        }
        hasher.update(&chunk);
        file.write_all(&chunk).await.map_err(Problem::internal)?;
    }
    file.flush().await.map_err(Problem::internal)?;
    file.sync_all().await.map_err(Problem::internal)?;
    Ok((Upload { path, size, sha256: hasher.finalize().into(), received_at }, scratch))
}

/// The 413 for an upload over the limit.
pub fn too_large(max_bytes: u64) -> Problem {
    Problem::new(
        StatusCode::PAYLOAD_TOO_LARGE,
        ProblemCode::PayloadTooLarge,
        "Upload too large",
        format!("Uploads are limited to {max_bytes} bytes. Store features as float32, drop background points, or ask the organisers about larger submissions."),
    )
    .with("limit_bytes", json!(max_bytes))
}

/// The SHA-256 of an RFC 9530 `Content-Digest` header (`sha-256=:BASE64:`), if it names one.
pub fn declared_sha256(header: &str) -> Result<Option<[u8; 32]>, Problem> {
    use base64::Engine;
    for item in header.split(',') {
        let item = item.trim();
        if let Some(value) = item.strip_prefix("sha-256=") {
            let encoded = value.trim().trim_start_matches(':').trim_end_matches(':');
            let bytes = base64::engine::general_purpose::STANDARD.decode(encoded).map_err(|_| {
                Problem::bad_request(ProblemCode::InvalidDigest, "Content-Digest: the sha-256 value must be base64 between colons (sha-256=:…:).")
            })?;
            let digest: [u8; 32] =
                bytes.try_into().map_err(|_| Problem::bad_request(ProblemCode::InvalidDigest, "Content-Digest: a sha-256 digest has 32 bytes."))?;
            return Ok(Some(digest));
        }
    }
    Ok(None)
}

/// The `Idempotency-Key` request header (draft-ietf-httpapi-idempotency-key-header), if
/// sent: 1 to 255 visible ASCII characters.
pub fn idempotency_key(headers: &axum::http::HeaderMap) -> Result<Option<String>, Problem> {
    let Some(value) = headers.get("idempotency-key") else {
        return Ok(None);
    };
    let key = value.to_str().ok().map(|k| k.trim().trim_matches('"')).filter(|k| (1..=255).contains(&k.len()) && k.bytes().all(|b| b.is_ascii_graphic()));
    match key {
        Some(key) => Ok(Some(key.to_string())),
        None => Err(Problem::bad_request(ProblemCode::InvalidIdempotencyKey, "Idempotency-Key: expected 1 to 255 visible ASCII characters (a UUID, say).")),
    }
}
