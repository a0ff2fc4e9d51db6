//! `GET /api/v1/leaderboard[?release=V]` as JSON, or CSV with `Accept: text/csv` or `.csv`.

use std::sync::Arc;

use axum::extract::State;
use axum::http::{HeaderMap, StatusCode, header};
use axum::response::{IntoResponse, Response};
use serde::Deserialize;

use super::ApiQuery;
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
pub async fn json_or_csv(State(state): State<AppState>, ApiQuery(query): ApiQuery<LeaderboardQuery>, headers: HeaderMap) -> ApiResult<Response> {
    let board = rendered(&state, query.release.as_deref()).await?;
    let wants_csv = headers.get(header::ACCEPT).and_then(|v| v.to_str().ok()).is_some_and(|a| a.contains("text/csv"));
    Ok(respond(&board, &headers, wants_csv))
}

/// `GET /api/v1/leaderboard.csv`.
pub async fn csv(State(state): State<AppState>, ApiQuery(query): ApiQuery<LeaderboardQuery>, headers: HeaderMap) -> ApiResult<Response> {
    let board = rendered(&state, query.release.as_deref()).await?;
    Ok(respond(&board, &headers, true))
}

#[derive(Debug, Deserialize)]
pub struct VqaQuery {
    /// A release version; the current release by default.
    pub release: Option<String>,
    /// `2` or `3`: one table only (the CSV needs one).
    pub table: Option<u8>,
}

/// `GET /api/v1/leaderboard/vqa`: the paper's Table II and Table III shapes as JSON.
pub async fn vqa_tables(State(state): State<AppState>, ApiQuery(query): ApiQuery<VqaQuery>) -> ApiResult<Response> {
    let board = rendered(&state, query.release.as_deref()).await?;
    let board = &board.board;
    let body = match query.table {
        Some(2) => serde_json::json!({"release": board.release, "lightings": board.lightings, "table2": crate::leaderboard_vqa::table_two(board)}),
        Some(3) => serde_json::json!({"release": board.release, "table3": crate::leaderboard_vqa::table_three(board)}),
        None => serde_json::json!({
            "release": board.release,
            "lightings": board.lightings,
            "table2": crate::leaderboard_vqa::table_two(board),
            "table3": crate::leaderboard_vqa::table_three(board),
        }),
        Some(other) => return Err(Problem::bad_request("invalid_query", format!("table: expected 2 or 3, found {other}"))),
    };
    Ok(axum::Json(body).into_response())
}

/// `GET /api/v1/leaderboard/vqa.csv?table=2|3`: one of the tables as CSV.
pub async fn vqa_table_csv(State(state): State<AppState>, ApiQuery(query): ApiQuery<VqaQuery>) -> ApiResult<Response> {
    let board = rendered(&state, query.release.as_deref()).await?;
    let board = &board.board;
    let text = match query.table {
        Some(2) => crate::leaderboard_vqa::table_csv(&crate::leaderboard_vqa::table_two(board), &crate::leaderboard_vqa::table_two_columns(&board.lightings)),
        Some(3) => crate::leaderboard_vqa::table_csv(&crate::leaderboard_vqa::table_three(board), &crate::leaderboard_vqa::TABLE_THREE_COLUMNS),
        _ => {
            return Err(Problem::bad_request(
                "invalid_query",
                "table: expected ?table=2 (prompt-grounded per lighting) or ?table=3 (standard against prompt-grounded)",
            ));
        }
    };
    let disposition = format!("inline; filename=\"vqa-table{}-{}.csv\"", query.table.unwrap_or(0), board.release);
    Ok(([(header::CONTENT_TYPE, "text/csv; charset=utf-8".to_string()), (header::CONTENT_DISPOSITION, disposition)], text).into_response())
}
