//! Releases: the list, one release, its manifest and its public files. Drafts are
//! visible to admins only; ground truth is never a public file, so it cannot be served.

use axum::extract::State;
use axum::http::{HeaderMap, header};
use axum::response::{IntoResponse, Response};
use osmab_evaluator::scores::Lighting;
use serde::Serialize;

use super::extract::ApiPath;
use super::files::serve_blob;
use super::operation::{ApiRoutes, Auth, Operation, Verb};
use crate::auth::Caller;
use crate::problem::{ApiResult, Problem};
use crate::releases::release_prefix;
use crate::state::AppState;
use crate::store::{ReleaseRecord, ReleaseState, StoreError};

/// The summary of a release in lists (fields in the order of their keys).
#[derive(Debug, Serialize, schemars::JsonSchema)]
pub struct ReleaseSummary {
    /// When the release was built (from its manifest).
    pub created: Option<String>,
    /// Whether it is the current release.
    pub current: bool,
    pub digest: String,
    /// Its lightings in manifest order.
    pub lightings: Option<Vec<Lighting>>,
    pub manifest_url: String,
    pub published_at: Option<String>,
    pub registered_at: String,
    /// How many scenes it has.
    pub scenes: usize,
    pub state: ReleaseState,
    pub version: String,
}

impl From<&ReleaseRecord> for ReleaseSummary {
    fn from(r: &ReleaseRecord) -> Self {
        // What the manifest does not say (an old one without `created`) is null.
        let manifest = crate::releases::served_manifest(r);
        ReleaseSummary {
            created: Some(manifest.created.clone()).filter(|c| !c.is_empty()),
            current: r.is_current,
            digest: r.digest.clone(),
            lightings: Some(manifest.score_lightings()).filter(|l| !l.is_empty()),
            manifest_url: format!("/api/v1/releases/{}/manifest.json", r.version),
            published_at: r.published_at.map(crate::clock::rfc3339),
            registered_at: crate::clock::rfc3339(r.created_at),
            scenes: manifest.scenes.len(),
            state: r.state,
            version: r.version.clone(),
        }
    }
}

/// A release the caller may see.
pub async fn visible_release(state: &AppState, caller: &Caller, version: &str) -> ApiResult<ReleaseRecord> {
    match state.store.release(version).await {
        Ok(r) if r.state == ReleaseState::Published || matches!(caller, Caller::Admin) => Ok(r),
        Ok(_) | Err(StoreError::NotFound) => Err(Problem::not_found(format!("There is no published release '{version}'; see GET /api/v1/releases."))),
        Err(e) => Err(e.into()),
    }
}

/// `GET /api/v1/releases`.
pub async fn list(State(state): State<AppState>, caller: Caller) -> ApiResult<axum::Json<ReleaseList>> {
    let releases = state.store.releases().await?;
    let visible = releases.iter().filter(|r| r.state == ReleaseState::Published || matches!(caller, Caller::Admin)).map(ReleaseSummary::from).collect();
    Ok(axum::Json(ReleaseList { releases: visible }))
}

/// The releases the caller may see, newest first.
#[derive(Debug, Serialize, schemars::JsonSchema)]
pub struct ReleaseList {
    pub releases: Vec<ReleaseSummary>,
}

/// `GET /api/v1/releases/{version}` (`current` names the current release).
pub async fn show(State(state): State<AppState>, caller: Caller, ApiPath(version): ApiPath<String>) -> ApiResult<axum::Json<ReleaseSummary>> {
    let version = resolve(&state, &version).await?;
    Ok(axum::Json(ReleaseSummary::from(&visible_release(&state, &caller, &version).await?)))
}

pub async fn resolve(state: &AppState, version: &str) -> ApiResult<String> {
    if version == "current" {
        return match state.store.current_release().await {
            Ok(r) => Ok(r.version),
            Err(StoreError::NotFound) => Err(Problem::not_found("No release has been published yet.")),
            Err(e) => Err(e.into()),
        };
    }
    Ok(version.to_string())
}

/// `GET /api/v1/releases/{version}/manifest.json`.
pub async fn manifest(State(state): State<AppState>, caller: Caller, ApiPath(version): ApiPath<String>, headers: HeaderMap) -> ApiResult<Response> {
    let version = resolve(&state, &version).await?;
    let release = visible_release(&state, &caller, &version).await?;
    let etag = format!("\"{}\"", release.digest);
    if super::files::none_match(&headers, &etag) {
        return Ok((axum::http::StatusCode::NOT_MODIFIED, [(header::ETAG, etag)]).into_response());
    }
    Ok(([(header::CONTENT_TYPE, "application/json".to_string()), (header::ETAG, etag)], release.manifest).into_response())
}

/// `GET /api/v1/releases/{version}/files/{path}`: a manifest file or a sequence archive.
pub async fn file(
    State(state): State<AppState>,
    caller: Caller,
    ApiPath((version, path)): ApiPath<(String, String)>,
    headers: HeaderMap,
) -> ApiResult<Response> {
    let version = resolve(&state, &version).await?;
    let release = visible_release(&state, &caller, &version).await?;
    let entry = match state.store.release_file(&version, &path).await {
        Ok(entry) => entry,
        Err(StoreError::NotFound) => {
            return Err(Problem::not_found(format!("Release {version} has no public file '{path}'; the manifest lists every file.")));
        }
        Err(e) => return Err(e.into()),
    };
    let key = format!("{}/{}", release_prefix(&version), entry.path);
    serve_blob(&state.blobs, &key, &entry.path, entry.size as u64, &entry.sha256, &headers, release.state == ReleaseState::Published).await
}

/// The releases and their files.
pub fn routes() -> ApiRoutes {
    ApiRoutes::new()
        .operation(
            Operation::new(Verb::Get, "/api/v1/releases", Auth::Optional, "Published releases (drafts too for admins).", 200).returns::<ReleaseList>(),
            list,
        )
        .operation(
            Operation::new(Verb::Get, "/api/v1/releases/{version}", Auth::Optional, "One release; `current` names the current release.", 200)
                .returns::<ReleaseSummary>(),
            show,
        )
        .operation(
            Operation::new(
                Verb::Get,
                "/api/v1/releases/{version}/manifest.json",
                Auth::Optional,
                "The manifest: every file with size and SHA-256, the digest, and one archive per sequence.",
                200,
            )
            .returns_free_json(),
            manifest,
        )
        .operation(
            Operation::new(
                Verb::Get,
                "/api/v1/releases/{version}/files/{*path}",
                Auth::Optional,
                "A public file or sequence archive, with Range, ETag (its SHA-256), If-None-Match and Repr-Digest.",
                200,
            )
            .returns_other("application/octet-stream"),
            file,
        )
}
