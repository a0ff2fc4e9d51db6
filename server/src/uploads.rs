//! Resumable uploads (tus 1.0.0: core, creation, checksum, termination, expiration).
//! State lives in the database and bytes in the blob store, so any server can take any
//! request of an upload: each `PATCH` stores its bytes as a part blob, then moves the
//! upload's offset in one conditional statement (two servers appending at the same
//! offset cannot both win; the loser's part is removed). A request cut short stores
//! nothing, and the client resumes from the offset `HEAD` reports. A complete upload is
//! [`assemble`]d into one file that intake takes exactly as a direct upload; unfinished
//! uploads expire and [`sweep_expired`] removes them.

use axum::body::Body;
use axum::http::StatusCode;
use osmab_api::uploads::min_part_bytes;
use sha2::{Digest, Sha256};
use tokio::io::AsyncWriteExt;

use crate::blobs::Scratch;
use crate::clock::{new_id, now_ms, rfc3339};
use crate::intake::{Upload, receive};
use crate::problem::{Problem, ProblemCode};
use crate::state::AppState;
use crate::store::{OpenUploadLimits, OpenUploads, StoreError, Team, UploadPart, UploadRecord};

/// The protocol version served.
pub const TUS_VERSION: &str = "1.0.0";
/// The extensions served.
pub const TUS_EXTENSIONS: &str = "creation,checksum,termination,expiration";
/// The checksum algorithms `Upload-Checksum` may name.
pub const TUS_CHECKSUMS: &str = "sha256";
/// Longest `Upload-Metadata` kept.
const MAX_METADATA: usize = 4096;

/// This server receiving a PATCH of one upload; dropped when it ends. A second PATCH of the
/// same upload meanwhile is refused, so concurrent PATCHes at one offset cannot each fill a
/// scratch file with the upload's remaining bytes: at most one remainder per upload is in
/// a server's scratch, and that is within the open-upload bytes the team declared (per
/// server: N servers of a deployment hold at most N remainders).
struct InFlight<'a>(&'a std::sync::Mutex<std::collections::HashSet<String>>, String);

impl<'a> InFlight<'a> {
    fn claim(set: &'a std::sync::Mutex<std::collections::HashSet<String>>, id: &str) -> Option<Self> {
        set.lock().unwrap_or_else(std::sync::PoisonError::into_inner).insert(id.to_string()).then(|| Self(set, id.to_string()))
    }
}

impl Drop for InFlight<'_> {
    fn drop(&mut self) {
        self.0.lock().unwrap_or_else(std::sync::PoisonError::into_inner).remove(&self.1);
    }
}

fn blob_prefix(id: &str) -> String {
    format!("uploads/{id}")
}

fn not_found(id: &str) -> Problem {
    Problem::not_found(format!("There is no upload '{id}' of your team; it may have expired. Create a new one with POST /api/v1/uploads."))
}

/// Upload `id` of `team`, unexpired.
async fn owned(state: &AppState, team: &Team, id: &str) -> Result<UploadRecord, Problem> {
    match state.store.upload(id).await {
        Ok(upload) if upload.team_id != team.id => Err(not_found(id)),
        Ok(upload) if upload.expires_at < now_ms() && upload.submission_id.is_none() => Err(Problem::new(
            StatusCode::GONE,
            ProblemCode::UploadExpired,
            "Upload expired",
            format!("Upload '{id}' expired at {} before it was complete; start a new one.", rfc3339(upload.expires_at)),
        )),
        Ok(upload) => Ok(upload),
        Err(StoreError::NotFound) => Err(not_found(id)),
        Err(e) => Err(e.into()),
    }
}

/// Start an upload of `length` bytes for `team`.
pub async fn create(state: &AppState, team: &Team, length: u64, metadata: &str) -> Result<UploadRecord, Problem> {
    let max = state.settings.max_upload_bytes;
    if length > max {
        return Err(crate::intake::too_large(max));
    }
    if metadata.len() > MAX_METADATA {
        return Err(Problem::bad_request(
            ProblemCode::InvalidMetadata,
            format!("Upload-Metadata has {} bytes; at most {MAX_METADATA} are kept.", metadata.len()),
        ));
    }
    for pair in metadata.split(',').map(str::trim).filter(|p| !p.is_empty()) {
        let mut fields = pair.split(' ');
        let (key, value) = (fields.next().unwrap_or(""), fields.next());
        let value_ok = value.is_none_or(|v| base64::Engine::decode(&base64::engine::general_purpose::STANDARD, v).is_ok());
        if key.is_empty() || fields.next().is_some() || !value_ok {
            return Err(Problem::bad_request(
                ProblemCode::InvalidMetadata,
                format!("Upload-Metadata: '{pair}' is not 'KEY BASE64-VALUE' (tus 1.0.0 creation)."),
            ));
        }
    }
    let now = now_ms();
    let upload = UploadRecord {
        id: new_id("upl"),
        team_id: team.id.clone(),
        length: length as i64,
        upload_offset: 0,
        metadata: metadata.to_string(),
        parts: String::new(),
        created_at: now,
        expires_at: now + state.settings.upload_expiry_secs as i64 * 1000,
        submission_id: None,
    };
    let limits = OpenUploadLimits { uploads: state.settings.max_open_uploads, bytes: state.settings.max_open_upload_bytes as i64 };
    if let Err(open) = state.store.insert_upload_within(&upload, limits, now).await? {
        return Err(open_uploads_refused(open, limits, length));
    }
    tracing::info!(upload = %upload.id, team = %team.name, length, "resumable upload started");
    Ok(upload)
}

/// The refusal of an upload that would pass the team's open-upload limits: 429 for their
/// number, 413 for their bytes, each naming the limit and what frees room.
fn open_uploads_refused(open: OpenUploads, limits: OpenUploadLimits, length: u64) -> Problem {
    let frees = "Finish or DELETE an open upload (they also expire OSMAB_UPLOAD_EXPIRY_SECS after their last chunk), then start this one again.";
    if open.uploads >= limits.uploads {
        return Problem::new(
            StatusCode::TOO_MANY_REQUESTS,
            ProblemCode::TooManyUploads,
            "Too many open uploads",
            format!("Your team has {} resumable uploads open, the most it may (OSMAB_MAX_OPEN_UPLOADS = {}). {frees}", open.uploads, limits.uploads),
        )
        .with("limit", limits.uploads.into());
    }
    Problem::new(
        StatusCode::PAYLOAD_TOO_LARGE,
        ProblemCode::OpenUploadsTooLarge,
        "Open uploads too large",
        format!(
            "Your team's open resumable uploads declare {} bytes; {length} more would pass {} (OSMAB_MAX_OPEN_UPLOAD_BYTES). {frees}",
            open.bytes, limits.bytes
        ),
    )
    .with("limit", limits.bytes.into())
}

/// Where an upload stands (`HEAD`).
pub async fn status(state: &AppState, team: &Team, id: &str) -> Result<UploadRecord, Problem> {
    owned(state, team, id).await
}

/// Append `body`, sent for `offset`, to upload `id`; `checksum` is the SHA-256 the client
/// declared for it. Returns the upload after the append.
pub async fn append(state: &AppState, team: &Team, id: &str, offset: u64, body: Body, checksum: Option<[u8; 32]>) -> Result<UploadRecord, Problem> {
    let upload = owned(state, team, id).await?;
    if upload.submission_id.is_some() {
        return Err(Problem::conflict(format!("Upload '{id}' is complete and already became a submission.")));
    }
    if offset != upload.upload_offset as u64 {
        return Err(offset_conflict(&upload, offset));
    }
    let Some(_in_flight) = InFlight::claim(&state.uploads_in_flight, id) else {
        return Err(Problem::new(
            StatusCode::CONFLICT,
            ProblemCode::UploadBusy,
            "Upload busy",
            format!("Another PATCH of upload '{id}' is still arriving; wait for it, then continue from the offset HEAD reports."),
        ));
    };
    let room = (upload.length - upload.upload_offset) as u64;
    let (part, _scratch) = receive(state, body, room).await.map_err(|problem| {
        if problem.status == StatusCode::PAYLOAD_TOO_LARGE {
            Problem::new(
                StatusCode::PAYLOAD_TOO_LARGE,
                ProblemCode::UploadOverrun,
                "More than the upload's length",
                format!("The upload is {} bytes long and {} have arrived: at most {room} more fit.", upload.length, upload.upload_offset),
            )
        } else {
            problem
        }
    })?;
    if let Some(expected) = checksum
        && expected != part.sha256
    {
        return Err(Problem::new(
            StatusCode::from_u16(460).expect("460 is a status code"),
            ProblemCode::ChecksumMismatch,
            "Checksum mismatch",
            format!("The {} bytes sent for offset {offset} do not have the SHA-256 Upload-Checksum declared; nothing was kept. Send them again.", part.size),
        ));
    }
    if part.size == 0 {
        return Ok(upload);
    }
    let minimum = min_part_bytes(upload.length as u64);
    if part.size < minimum && part.size < room {
        return Err(Problem::new(
            StatusCode::BAD_REQUEST,
            ProblemCode::ChunkTooSmall,
            "Chunk too small",
            format!(
                "{} bytes sent for offset {offset}: a PATCH that does not finish the upload carries at least {minimum} bytes; nothing was kept.",
                part.size
            ),
        )
        .with("minimum", serde_json::json!(minimum)));
    }
    let key = format!("{}/{offset:020}-{}", blob_prefix(id), crate::clock::random_alphanumeric(8).to_ascii_lowercase());
    state.blobs.put_file(&key, &part.path).await.map_err(Problem::storage)?;
    let expires_at = now_ms() + state.settings.upload_expiry_secs as i64 * 1000;
    let appended = UploadPart { offset: offset as i64, length: part.size as i64, key: key.clone() };
    if !state.store.append_upload_part(id, &appended, expires_at).await? {
        let _ = state.blobs.remove_prefix(&key).await;
        let now = owned(state, team, id).await?;
        return Err(offset_conflict(&now, offset));
    }
    owned(state, team, id).await
}

fn offset_conflict(upload: &UploadRecord, offset: u64) -> Problem {
    Problem::new(
        StatusCode::CONFLICT,
        ProblemCode::OffsetMismatch,
        "Upload-Offset mismatch",
        format!("Upload-Offset is {offset} but the upload has {} bytes; ask with HEAD and continue from there.", upload.upload_offset),
    )
    .with("offset", serde_json::json!(upload.upload_offset))
}

/// Forget upload `id` and its parts (`DELETE`).
pub async fn terminate(state: &AppState, team: &Team, id: &str) -> Result<(), Problem> {
    owned(state, team, id).await?;
    state.blobs.remove_prefix(&blob_prefix(id)).await.map_err(Problem::storage)?;
    state.store.delete_upload(id).await?;
    tracing::info!(upload = %id, "resumable upload terminated");
    Ok(())
}

/// A complete upload, ready for intake.
pub enum Assembled {
    /// Its bytes in one scratch file (removed with the guard).
    Ready(Upload, Scratch),
    /// It already became this submission.
    Finished(String),
}

/// Join the parts of the complete upload `id` into one file, counting its SHA-256.
pub async fn assemble(state: &AppState, team: &Team, id: &str) -> Result<Assembled, Problem> {
    let upload = owned(state, team, id).await?;
    if let Some(submission) = upload.submission_id {
        return Ok(Assembled::Finished(submission));
    }
    if upload.upload_offset < upload.length {
        return Err(Problem::new(
            StatusCode::CONFLICT,
            ProblemCode::UploadIncomplete,
            "Upload incomplete",
            format!("Upload '{id}' has {} of its {} bytes; send the rest with PATCH first.", upload.upload_offset, upload.length),
        ));
    }
    let parts = upload.parts().map_err(Problem::internal)?;
    let path = state.blobs.scratch("assembled");
    let scratch = Scratch(path.clone());
    let mut file = tokio::fs::File::create(&path).await.map_err(Problem::internal)?;
    let (mut hasher, mut size) = (Sha256::new(), 0u64);
    for part in &parts {
        if part.offset as u64 != size {
            return Err(Problem::internal(format!("upload {id}: part at {} follows {size} bytes", part.offset)));
        }
        // Streamed, so a part as large as the whole upload costs one chunk of memory.
        let mut chunks = state.blobs.read(&part.key, 0, part.length as u64).await.map_err(Problem::storage)?;
        let mut copied = 0u64;
        while let Some(chunk) = futures_util::StreamExt::next(&mut chunks).await {
            let chunk = chunk.map_err(Problem::storage)?;
            hasher.update(&chunk);
            file.write_all(&chunk).await.map_err(Problem::internal)?;
            copied += chunk.len() as u64;
        }
        if copied != part.length as u64 {
            return Err(Problem::internal(format!("upload {id}: part {} has {copied} bytes, {} recorded", part.key, part.length)));
        }
        size += copied;
    }
    file.flush().await.map_err(Problem::internal)?;
    if size != upload.length as u64 {
        return Err(Problem::internal(format!("upload {id}: parts hold {size} of {} bytes", upload.length)));
    }
    let assembled = Upload { path, size, sha256: hasher.finalize().into(), received_at: upload.created_at };
    Ok(Assembled::Ready(assembled, scratch))
}

/// Record that upload `id` became `submission_id` and drop its parts.
pub async fn finish(state: &AppState, id: &str, submission_id: &str) {
    if let Err(e) = state.store.finish_upload(id, submission_id).await {
        tracing::warn!(upload = %id, error = %e, "could not record the upload's submission");
        return;
    }
    if let Err(e) = state.blobs.remove_prefix(&blob_prefix(id)).await {
        tracing::warn!(upload = %id, error = %e, "the upload's parts stay until it expires");
    }
}

/// Remove uploads whose time ran out (their parts, then their record); returns how many.
pub async fn sweep_expired(state: &AppState) -> usize {
    let Ok(expired) = state.store.expired_uploads(now_ms(), 100).await else { return 0 };
    let mut removed = 0;
    for id in expired {
        if state.blobs.remove_prefix(&blob_prefix(&id)).await.is_ok() && state.store.delete_upload(&id).await.is_ok() {
            removed += 1;
        }
    }
    if removed > 0 {
        tracing::info!(removed, "expired resumable uploads removed");
    }
    removed
}
