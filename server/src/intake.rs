//! Accepting a submission: the upload is streamed to a scratch file while its size and
//! SHA-256 are counted, unpacked with the archive limits, validated against its release
//! exactly as `osmab client validate` does, and only then recorded together with its
//! scoring job in one transaction. Nothing is recorded for a rejected upload.

use std::collections::BTreeSet;
use std::path::{Path, PathBuf};

use axum::body::Body;
use axum::http::StatusCode;
use futures_util::StreamExt;
use osmab_evaluator::InputError;
use osmab_evaluator::submission::{ArchiveLimits, ReleaseIndex, SubmissionLimits, ValidSubmission, unpack, validate};
use serde_json::{Value, json};
use sha2::{Digest, Sha256};
use tokio::io::AsyncWriteExt;

use crate::clock::{new_id, now_ms};
use crate::problem::Problem;
use crate::releases::release_dir;
use crate::state::AppState;
use crate::store::{NewJob, NewSubmission, Recorded, StoreError, Team};

/// Kind of the job that scores a submission.
pub const SCORE_JOB: &str = "score_submission";

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

/// Removes a scratch file or folder when dropped, whatever happened; on the async
/// runtime the removal (maybe thousands of files) runs on a blocking thread.
pub struct Scratch(pub PathBuf);

fn remove_path(path: &Path) {
    if path.is_dir() {
        let _ = std::fs::remove_dir_all(path);
    } else {
        let _ = std::fs::remove_file(path);
    }
}

impl Drop for Scratch {
    fn drop(&mut self) {
        let path = std::mem::take(&mut self.0);
        match tokio::runtime::Handle::try_current() {
            Ok(handle) if handle.runtime_flavor() != tokio::runtime::RuntimeFlavor::CurrentThread => {
                handle.spawn_blocking(move || remove_path(&path));
            }
            _ => remove_path(&path),
        }
    }
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
                    "request_timeout",
                    "Request timeout",
                    format!("The upload stalled after {size} bytes: nothing arrived for too long. Check the connection and upload again."),
                )
            } else {
                Problem::bad_request("upload_incomplete", format!("The upload ended early after {size} bytes ({e}). Check the connection and upload again."))
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
        "payload_too_large",
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
            let bytes = base64::engine::general_purpose::STANDARD
                .decode(encoded)
                .map_err(|_| Problem::bad_request("invalid_digest", "Content-Digest: the sha-256 value must be base64 between colons (sha-256=:…:)."))?;
            let digest: [u8; 32] = bytes.try_into().map_err(|_| Problem::bad_request("invalid_digest", "Content-Digest: a sha-256 digest has 32 bytes."))?;
            return Ok(Some(digest));
        }
    }
    Ok(None)
}

/// The problems of an invalid submission as a 422.
pub fn invalid(problems: &[InputError]) -> Problem {
    let first = problems.first().map(|p| p.to_string()).unwrap_or_default();
    let detail = if problems.len() == 1 {
        format!("The submission was not accepted: {first}. Fix it and upload again; nothing was stored and no quota was used.")
    } else {
        format!(
            "The submission was not accepted: {} problems, the first: {first}. Fix them and upload again; nothing was stored and no quota was used.",
            problems.len()
        )
    };
    let errors: Vec<Value> = problems.iter().map(|p| json!({"file": p.file, "field": p.field, "message": p.message})).collect();
    Problem::new(StatusCode::UNPROCESSABLE_ENTITY, "invalid_submission", "Invalid submission", detail).with("errors", Value::Array(errors))
}

/// The release named in `submission.json` (or the current one when it names none).
fn release_named(unpacked: &Path) -> Option<String> {
    let candidates = [unpacked.join("submission.json")];
    let direct = candidates.iter().find(|p| p.is_file()).cloned().or_else(|| {
        let mut dirs = std::fs::read_dir(unpacked).ok()?.filter_map(|e| e.ok()).filter(|e| e.path().is_dir());
        let only = dirs.next()?;
        dirs.next().is_none().then(|| only.path().join("submission.json")).filter(|p| p.is_file())
    })?;
    // Read only a plausible submission.json; a huge one is reported by the validator.
    if std::fs::metadata(&direct).ok()?.len() > 1 << 20 {
        return None;
    }
    let value: Value = serde_json::from_slice(&std::fs::read(direct).ok()?).ok()?;
    value.get("release")?.as_str().map(str::to_string)
}

/// The answer to a submission for a release that takes none (a draft, or withdrawn).
pub fn release_not_open(version: &str) -> Problem {
    Problem::new(
        StatusCode::CONFLICT,
        "release_not_open",
        "Release not open",
        format!("Release '{version}' is not published, so it takes no submissions; see GET /api/v1/releases."),
    )
}

/// Unpack and validate an upload (blocking). `current` is used when submission.json names
/// no release. With `open`, a release outside it is refused before anything is validated
/// against it (so a dry run tells nothing of a draft's scenes).
pub fn check(
    state: &AppState,
    upload: &Path,
    unpack_to: &Path,
    current: Option<&str>,
    open: Option<&BTreeSet<String>>,
) -> Result<(ValidSubmission, ReleaseIndex), Problem> {
    let limits = ArchiveLimits { max_entries: 20_000, max_total_bytes: state.settings.max_unpacked_bytes };
    unpack(upload, unpack_to, limits).map_err(|e| {
        let problem = invalid(&[as_uploaded(e, upload, unpack_to)]);
        Problem { code: "invalid_archive", title: "Invalid archive".into(), ..problem }
    })?;
    let version = release_named(unpack_to).or(current.map(str::to_string)).unwrap_or_default();
    if crate::releases::check_version(&version).is_err() {
        return Err(invalid(&[InputError::new("submission.json", "release", format!("'{version}' is not a release of this server"))]));
    }
    let dir = release_dir(&state.blobs, &version).map_err(Problem::internal)?;
    if open.is_some_and(|open| !open.contains(&version)) && dir.join("manifest.json").is_file() {
        return Err(release_not_open(&version));
    }
    if !dir.join("manifest.json").is_file() {
        return Err(invalid(&[InputError::new(
            "submission.json",
            "release",
            format!("'{version}' is not a release of this server; see GET /api/v1/releases"),
        )]));
    }
    let release = ReleaseIndex::read(&dir).map_err(Problem::internal)?;
    let submission = validate(unpack_to, &release, SubmissionLimits::for_release(&release, state.settings.max_unpacked_bytes))
        .map_err(|problems| invalid(&problems.into_iter().map(|e| as_uploaded(e, upload, unpack_to)).collect::<Vec<_>>()))?;
    Ok((submission, release))
}

/// An error as the participant must see it: files named by their path inside the upload
/// (`upload` for the archive itself), never by where the server keeps them.
fn as_uploaded(mut e: InputError, upload: &Path, unpacked: &Path) -> InputError {
    let hide = |text: &str| {
        text.replace(&format!("{}/", unpacked.display()), "")
            .replace(&unpacked.display().to_string(), "upload")
            .replace(&upload.display().to_string(), "upload")
    };
    let file = Path::new(&e.file);
    e.file = if file == upload {
        "upload".to_string()
    } else if let Ok(inside) = file.strip_prefix(unpacked) {
        inside.display().to_string()
    } else if file.is_absolute() {
        "upload".to_string()
    } else {
        e.file
    };
    e.field = hide(&e.field);
    e.message = hide(&e.message);
    e
}

/// Record a validated upload as a submission of `team` with its scoring job, storing the
/// archive first so the job always finds it — unless it repeats the team's earlier
/// submission (same archive, or the same `idempotency_key`). `quota = Some((limit,
/// since))` is checked in the same transaction. Nothing but a `Recorded::New` leaves a
/// stored archive behind.
#[allow(clippy::too_many_arguments)]
pub async fn record(
    state: &AppState,
    team: &Team,
    upload: &Upload,
    submission: &ValidSubmission,
    public: bool,
    baseline: bool,
    validating_at: i64,
    quota: Option<(i64, i64)>,
    idempotency_key: Option<&str>,
) -> Result<Recorded, Problem> {
    let id = new_id("sub");
    let key = format!("submissions/{id}/upload");
    state.blobs.put_file(&key, &upload.path).map_err(Problem::internal)?;
    let queued_at = now_ms();
    let new = NewSubmission {
        id: id.clone(),
        team_id: team.id.clone(),
        release: submission.release.clone(),
        method_name: submission.method.name.trim().to_string(),
        method_description: submission.method.description.clone(),
        paper_url: submission.method.paper_url.clone(),
        code_url: submission.method.code_url.clone(),
        public,
        baseline,
        complete: submission.complete,
        archive_size: upload.size as i64,
        archive_sha256: upload.sha256_hex(),
        idempotency_key: idempotency_key.map(str::to_string),
        received_at: upload.received_at,
        validating_at,
        queued_at,
    };
    let job = NewJob {
        id: new_id("job"),
        kind: SCORE_JOB.into(),
        subject: id.clone(),
        payload: json!({"submission_id": id}).to_string(),
        max_attempts: state.settings.job_max_attempts,
        created_at: queued_at,
    };
    let outcome = state.store.create_submission(&new, &job, quota).await;
    if !matches!(outcome, Ok(Recorded::New(_))) {
        let _ = state.blobs.remove_prefix(&format!("submissions/{id}"));
    }
    match outcome {
        Ok(recorded) => Ok(recorded),
        Err(StoreError::NotFound) => Err(Problem::not_found("The release is not registered.")),
        Err(other) => Err(other.into()),
    }
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
        None => Err(Problem::bad_request("invalid_idempotency_key", "Idempotency-Key: expected 1 to 255 visible ASCII characters (a UUID, say).")),
    }
}
