//! `GET /api/v1/leaderboard[?release=V]` as JSON, or CSV with `Accept: text/csv` or `.csv`.

use std::sync::Arc;

use axum::extract::{Query, State};
use axum::http::{HeaderMap, StatusCode, header};
use axum::response::{IntoResponse, Response};
use serde::Deserialize;

use crate::leaderboard::Rendered;
use crate::problem::{ApiResult, Problem};
use crate::state::AppState;
use crate::store::StoreError;

#[derive(Debug, Deserialize)]
pub struct LeaderboardQuery {
    /// A release version; the current release by default.
    pub release: Option<String>,
}

/// The rendered leaderboard of `release` (the current one when `None`).
pub async fn rendered(state: &AppState, release: Option<&str>) -> ApiResult<Arc<Rendered>> {
    if let Some(board) = state.leaderboard.fresh(release) {
        return Ok(board);
    }
    let generation = state.leaderboard.generation();
    let record = match release {
        Some(version) => state.store.release(version).await,
        None => state.store.current_release().await,
    };
    let record = match record {
        Ok(r) if r.state == "published" => r,
        Ok(_) | Err(StoreError::NotFound) => {
            return Err(match release {
                Some(v) => Problem::not_found(format!("There is no published release '{v}'; see GET /api/v1/releases.")),
                None => Problem::not_found("No release has been published yet; the demo release is built on first start and appears within a minute."),
            });
        }
        Err(e) => return Err(e.into()),
    };
    let manifest: serde_json::Value = serde_json::from_str(&record.manifest).unwrap_or_default();
    let lightings: Vec<String> = manifest["lightings"].as_array().into_iter().flatten().filter_map(|l| l.as_str().map(str::to_string)).collect();
    let board = state.leaderboard.get(&state.store, &record.version, &lightings).await?;
    if release.is_none() {
        state.leaderboard.remember_current(&board, generation);
    }
    Ok(board)
}

fn respond(board: &Rendered, headers: &HeaderMap, csv: bool) -> Response {
    let tag = if csv { &board.etag_csv } else { &board.etag_json };
    if super::files::none_match(headers, tag) {
        return (StatusCode::NOT_MODIFIED, [(header::ETAG, tag.clone())]).into_response();
    }
    let cache = (header::CACHE_CONTROL, "public, max-age=1".to_string());
    let etag = (header::ETAG, tag.clone());
    let vary = (header::VARY, "Accept".to_string());
    if csv {
        let disposition = (header::CONTENT_DISPOSITION, format!("inline; filename=\"leaderboard-{}.csv\"", board.board.release));
        ([(header::CONTENT_TYPE, "text/csv; charset=utf-8".to_string()), cache, etag, vary, disposition], board.csv.clone()).into_response()
    } else {
        ([(header::CONTENT_TYPE, "application/json".to_string()), cache, etag, vary], board.json.clone()).into_response()
    }
}

/// `GET /api/v1/leaderboard`.
pub async fn json_or_csv(State(state): State<AppState>, Query(query): Query<LeaderboardQuery>, headers: HeaderMap) -> ApiResult<Response> {
    let board = rendered(&state, query.release.as_deref()).await?;
    let wants_csv = headers.get(header::ACCEPT).and_then(|v| v.to_str().ok()).is_some_and(|a| a.contains("text/csv"));
    Ok(respond(&board, &headers, wants_csv))
}

/// `GET /api/v1/leaderboard.csv`.
pub async fn csv(State(state): State<AppState>, Query(query): Query<LeaderboardQuery>, headers: HeaderMap) -> ApiResult<Response> {
    let board = rendered(&state, query.release.as_deref()).await?;
    Ok(respond(&board, &headers, true))
}
