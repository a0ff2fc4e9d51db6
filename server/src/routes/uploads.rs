//! `/api/v1/uploads`: the tus 1.0.0 protocol over [`crate::uploads`]. Every answer
//! carries `Tus-Resumable`; refusals are problem+json with the status tus prescribes
//! (412 for another protocol version, 409 for a wrong offset, 415 for another content
//! type, 460 for a checksum mismatch).

use axum::body::Body;
use axum::extract::{Request, State};
use axum::http::{HeaderMap, HeaderValue, StatusCode, header};
use axum::middleware::Next;
use axum::response::{IntoResponse, Response};
use base64::Engine;

use super::extract::ApiPath;
use super::operation::{ApiRoutes, Auth, Input, Operation, Verb};
use crate::auth::TeamCaller;
use crate::clock::http_date;
use crate::intake::Quota;
use crate::problem::{ApiResult, Problem, ProblemCode};
use crate::state::AppState;
use crate::store::UploadRecord;
use crate::uploads::{self, TUS_CHECKSUMS, TUS_EXTENSIONS, TUS_VERSION};

/// Adds `Tus-Resumable` to every answer, and refuses a request of another protocol
/// version (all but `OPTIONS`, which tells the versions).
pub async fn tus_headers(request: Request, next: Next) -> Response {
    let asks_version = request.method() != axum::http::Method::OPTIONS;
    let version = request.headers().get("tus-resumable").and_then(|v| v.to_str().ok()).map(str::to_string);
    let mut response = if asks_version && version.as_deref() != Some(TUS_VERSION) {
        let detail = match version {
            Some(v) => format!("Tus-Resumable: {v} is not served; this server speaks tus {TUS_VERSION}."),
            None => format!("Send Tus-Resumable: {TUS_VERSION} with every request of a resumable upload."),
        };
        let mut refused = Problem::new(StatusCode::PRECONDITION_FAILED, ProblemCode::TusVersion, "Unsupported tus version", detail).into_response();
        refused.headers_mut().insert("tus-version", HeaderValue::from_static(TUS_VERSION));
        refused
    } else {
        next.run(request).await
    };
    response.headers_mut().insert("tus-resumable", HeaderValue::from_static(TUS_VERSION));
    response
}

fn number(headers: &HeaderMap, name: &str) -> Result<Option<u64>, Problem> {
    match headers.get(name).map(|v| v.to_str().ok().and_then(|t| t.trim().parse::<u64>().ok())) {
        None => Ok(None),
        Some(Some(n)) => Ok(Some(n)),
        Some(None) => Err(Problem::bad_request(ProblemCode::InvalidHeader, format!("{name} must be a non-negative integer."))),
    }
}

fn upload_headers(upload: &UploadRecord) -> HeaderMap {
    let mut headers = HeaderMap::new();
    headers.insert("upload-offset", HeaderValue::from(upload.upload_offset));
    headers.insert("upload-length", HeaderValue::from(upload.length));
    headers.insert("upload-expires", HeaderValue::from_str(&http_date(upload.expires_at)).expect("ascii"));
    headers.insert(header::CACHE_CONTROL, HeaderValue::from_static("no-store"));
    if !upload.metadata.is_empty()
        && let Ok(value) = HeaderValue::from_str(&upload.metadata)
    {
        headers.insert("upload-metadata", value);
    }
    headers
}

/// `OPTIONS /api/v1/uploads`: what this server speaks.
pub async fn options(State(state): State<AppState>) -> Response {
    let mut headers = HeaderMap::new();
    headers.insert("tus-version", HeaderValue::from_static(TUS_VERSION));
    headers.insert("tus-extension", HeaderValue::from_static(TUS_EXTENSIONS));
    headers.insert("tus-checksum-algorithm", HeaderValue::from_static(TUS_CHECKSUMS));
    headers.insert("tus-max-size", HeaderValue::from(state.settings.max_upload_bytes));
    (StatusCode::NO_CONTENT, headers).into_response()
}

/// `POST /api/v1/uploads` with `Upload-Length` (and optionally `Upload-Metadata`).
pub async fn create(State(state): State<AppState>, TeamCaller(team): TeamCaller, headers: HeaderMap) -> ApiResult<Response> {
    if headers.contains_key("upload-defer-length") {
        return Err(Problem::bad_request(ProblemCode::InvalidHeader, "Upload-Defer-Length is not supported: send Upload-Length."));
    }
    let Some(length) = number(&headers, "upload-length")? else {
        return Err(Problem::bad_request(ProblemCode::InvalidHeader, "Send Upload-Length: the archive's size in bytes."));
    };
    // A team out of quota learns it before sending the archive, not after.
    // (The split is named when the upload is submitted: refused here only when every split is used up.)
    let default = crate::intake::default_split(&state).await?;
    if let Some(quota) = Quota::refusal_before_upload(&state, &team, None, default).await? {
        return Err(crate::intake::quota_exceeded(quota));
    }
    let metadata = headers.get("upload-metadata").and_then(|v| v.to_str().ok()).unwrap_or("");
    let upload = uploads::create(&state, &team, length, metadata).await?;
    let mut answer = upload_headers(&upload);
    answer.insert(header::LOCATION, HeaderValue::from_str(&format!("/api/v1/uploads/{}", upload.id)).expect("ascii id"));
    Ok((StatusCode::CREATED, answer).into_response())
}

/// `HEAD /api/v1/uploads/{id}`: its offset.
pub async fn head(State(state): State<AppState>, TeamCaller(team): TeamCaller, ApiPath(id): ApiPath<String>) -> ApiResult<Response> {
    let upload = uploads::status(&state, &team, &id).await?;
    Ok((StatusCode::OK, upload_headers(&upload)).into_response())
}

/// `Upload-Checksum: sha256 BASE64` as the digest.
fn declared_checksum(headers: &HeaderMap) -> Result<Option<[u8; 32]>, Problem> {
    let Some(value) = headers.get("upload-checksum") else { return Ok(None) };
    let text = value.to_str().unwrap_or("");
    let (algorithm, digest) = text.trim().split_once(' ').unwrap_or((text, ""));
    if algorithm != "sha256" {
        return Err(Problem::bad_request(ProblemCode::ChecksumAlgorithm, format!("Upload-Checksum names '{algorithm}'; this server checks {TUS_CHECKSUMS}.")));
    }
    let bytes = base64::engine::general_purpose::STANDARD.decode(digest.trim()).ok().filter(|b| b.len() == 32);
    match bytes {
        Some(bytes) => Ok(Some(bytes.try_into().expect("32 bytes"))),
        None => Err(Problem::bad_request(ProblemCode::InvalidHeader, "Upload-Checksum: the sha256 value must be 32 bytes in base64.")),
    }
}

/// `PATCH /api/v1/uploads/{id}`: bytes at `Upload-Offset`.
pub async fn patch(
    State(state): State<AppState>,
    TeamCaller(team): TeamCaller,
    ApiPath(id): ApiPath<String>,
    headers: HeaderMap,
    body: Body,
) -> ApiResult<Response> {
    let content_type = headers.get(header::CONTENT_TYPE).and_then(|v| v.to_str().ok()).unwrap_or("");
    if content_type != "application/offset+octet-stream" {
        return Err(Problem::new(
            StatusCode::UNSUPPORTED_MEDIA_TYPE,
            ProblemCode::UnsupportedMediaType,
            "Unsupported media type",
            "A PATCH of a resumable upload has Content-Type: application/offset+octet-stream.",
        ));
    }
    let Some(offset) = number(&headers, "upload-offset")? else {
        return Err(Problem::bad_request(ProblemCode::InvalidHeader, "Send Upload-Offset: where these bytes start (HEAD tells)."));
    };
    let checksum = declared_checksum(&headers)?;
    let upload = uploads::append(&state, &team, &id, offset, body, checksum).await?;
    let mut answer = HeaderMap::new();
    answer.insert("upload-offset", HeaderValue::from(upload.upload_offset));
    answer.insert("upload-expires", HeaderValue::from_str(&http_date(upload.expires_at)).expect("ascii"));
    Ok((StatusCode::NO_CONTENT, answer).into_response())
}

/// `DELETE /api/v1/uploads/{id}`: abandon it.
pub async fn delete(State(state): State<AppState>, TeamCaller(team): TeamCaller, ApiPath(id): ApiPath<String>) -> ApiResult<Response> {
    uploads::terminate(&state, &team, &id).await?;
    Ok(StatusCode::NO_CONTENT.into_response())
}

/// Resumable uploads (tus 1.0.0), with the protocol's headers on every answer.
pub fn routes() -> ApiRoutes {
    ApiRoutes::new()
        .operation(
            Operation::new(
                Verb::Options,
                "/api/v1/uploads",
                Auth::Public,
                "Resumable uploads (tus 1.0.0): `Tus-Version`, `Tus-Extension` (creation, checksum, termination, expiration), `Tus-Max-Size`, `Tus-Checksum-Algorithm` (sha256).",
                204,
            ),
            options,
        )
        .operation(
            Operation::new(
                Verb::Post,
                "/api/v1/uploads",
                Auth::Team,
                "Start a resumable upload: `Tus-Resumable: 1.0.0`, `Upload-Length` (bytes), optional `Upload-Metadata`. Answers 201 with `Location` and `Upload-Expires`; refused early (429) when the team's quota is used.",
                201,
            ),
            create,
        )
        .operation(
            Operation::new(
                Verb::Head,
                "/api/v1/uploads/{id}",
                Auth::Team,
                "Where a resumable upload stands: `Upload-Offset`, `Upload-Length`, `Upload-Expires`. Any server answers; resume from this offset after a dropped connection.",
                200,
            ),
            head,
        )
        .operation(
            Operation::new(
                Verb::Patch,
                "/api/v1/uploads/{id}",
                Auth::Team,
                "Send bytes at `Upload-Offset` (`Content-Type: application/offset+octet-stream`, optional `Upload-Checksum: sha256 BASE64`). Answers 204 with the new `Upload-Offset`; 409 on a wrong offset, 460 on a checksum mismatch. When `Upload-Offset` reaches `Upload-Length`, submit with `POST /api/v1/submissions?upload=ID`.",
                204,
            )
            .takes_body(Input::Chunk),
            patch,
        )
        .operation(Operation::new(Verb::Delete, "/api/v1/uploads/{id}", Auth::Team, "Abandon a resumable upload and its parts.", 204), delete)
        .wrap(|router| router.layer(axum::middleware::from_fn(tus_headers)))
}
