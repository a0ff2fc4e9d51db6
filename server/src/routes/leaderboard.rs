//! `GET /api/v1/leaderboard[?release=V]` as JSON, or CSV with `Accept: text/csv` or `.csv`.

use std::sync::Arc;

use axum::extract::State;
use axum::http::{HeaderMap, StatusCode, header};
use axum::response::{IntoResponse, Response};
use osmab_evaluator::scores::{Lighting, Split};
use serde::{Deserialize, Serialize};

use super::extract::ApiQuery;
use super::operation::{ApiRoutes, Auth, Operation, Verb};
use crate::leaderboard::Rendered;
use crate::leaderboard::cache::BoardError;
use crate::leaderboard::vqa::{TableThreeRow, TableTwoRow, table_three, table_three_csv, table_two, table_two_csv};
use crate::problem::{ApiResult, Problem, ProblemCode};
use crate::state::AppState;

#[derive(Debug, Deserialize, schemars::JsonSchema)]
pub struct LeaderboardQuery {
    /// A release version; the current release by default.
    pub release: Option<String>,
    /// `test` or `val`; the release's test split by default when it has one.
    pub split: Option<Split>,
}

/// The rendered leaderboard of `split` of `release` (the current one, its primary split,
/// when `None`).
pub async fn rendered(state: &AppState, release: Option<&str>, split: Option<Split>) -> ApiResult<Arc<Rendered>> {
    state.leaderboard.board(&state.store, release, split).await.map_err(|e| match e {
        BoardError::NoSplit(version, split, has) => Problem::not_found(format!(
            "Release {version} has no {split} split; its boards: {}.",
            has.iter().map(|s| format!("?split={s}")).collect::<Vec<_>>().join(", ")
        )),
        BoardError::NotPublished(Some(v)) => Problem::not_found(format!("There is no published release '{v}'; see GET /api/v1/releases.")),
        BoardError::NotPublished(None) => {
            Problem::not_found("No release has been published yet; the demo release is built on first start and appears in about four minutes (on 2 cores).")
        }
        BoardError::Store(e) => e.into(),
    })
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
        let disposition = (header::CONTENT_DISPOSITION, format!("inline; filename=\"leaderboard-{}-{}.csv\"", board.board.release, board.board.split));
        ([(header::CONTENT_TYPE, "text/csv; charset=utf-8".to_string()), cache, etag, vary, disposition], board.csv.clone()).into_response()
    } else {
        ([(header::CONTENT_TYPE, "application/json".to_string()), cache, etag, vary], board.json.clone()).into_response()
    }
}

/// `GET /api/v1/leaderboard`.
pub async fn json_or_csv(State(state): State<AppState>, ApiQuery(query): ApiQuery<LeaderboardQuery>, headers: HeaderMap) -> ApiResult<Response> {
    let board = rendered(&state, query.release.as_deref(), query.split).await?;
    let wants_csv = headers.get(header::ACCEPT).and_then(|v| v.to_str().ok()).is_some_and(|a| a.contains("text/csv"));
    Ok(respond(&board, &headers, wants_csv))
}

/// `GET /api/v1/leaderboard.csv`.
pub async fn csv(State(state): State<AppState>, ApiQuery(query): ApiQuery<LeaderboardQuery>, headers: HeaderMap) -> ApiResult<Response> {
    let board = rendered(&state, query.release.as_deref(), query.split).await?;
    Ok(respond(&board, &headers, true))
}

#[derive(Debug, Deserialize, schemars::JsonSchema)]
pub struct VqaQuery {
    /// A release version; the current release by default.
    pub release: Option<String>,
    /// `test` or `val`; the release's test split by default when it has one.
    pub split: Option<Split>,
    /// `2` or `3`: one table only (the CSV needs one).
    pub table: Option<u8>,
}

/// The paper's VQA tables of a release (one or both).
#[derive(Debug, Serialize, schemars::JsonSchema)]
pub struct VqaTables {
    /// The release's lightings (Table II's columns); absent with Table III alone.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub lightings: Option<Vec<Lighting>>,
    pub release: String,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub table2: Option<Vec<TableTwoRow>>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub table3: Option<Vec<TableThreeRow>>,
}

/// `GET /api/v1/leaderboard/vqa`: the paper's Table II and Table III shapes as JSON.
pub async fn vqa_tables(State(state): State<AppState>, ApiQuery(query): ApiQuery<VqaQuery>) -> ApiResult<axum::Json<VqaTables>> {
    let board = rendered(&state, query.release.as_deref(), query.split).await?;
    let board = &board.board;
    let (two, three) = match query.table {
        None => (true, true),
        Some(2) => (true, false),
        Some(3) => (false, true),
        Some(other) => return Err(Problem::bad_request(ProblemCode::InvalidQuery, format!("table: expected 2 or 3, found {other}"))),
    };
    Ok(axum::Json(VqaTables {
        lightings: two.then(|| board.lightings.clone()),
        release: board.release.clone(),
        table2: two.then(|| table_two(board)),
        table3: three.then(|| table_three(board)),
    }))
}

/// `GET /api/v1/leaderboard/vqa.csv?table=2|3`: one of the tables as CSV.
pub async fn vqa_table_csv(State(state): State<AppState>, ApiQuery(query): ApiQuery<VqaQuery>) -> ApiResult<Response> {
    let board = rendered(&state, query.release.as_deref(), query.split).await?;
    let board = &board.board;
    let text = match query.table {
        Some(2) => table_two_csv(&table_two(board), &board.lightings),
        Some(3) => table_three_csv(&table_three(board)),
        _ => {
            return Err(Problem::bad_request(
                ProblemCode::InvalidQuery,
                "table: expected ?table=2 (prompt-grounded per lighting) or ?table=3 (standard against prompt-grounded)",
            ));
        }
    };
    let disposition = format!("inline; filename=\"vqa-table{}-{}.csv\"", query.table.unwrap_or(0), board.release);
    Ok(([(header::CONTENT_TYPE, "text/csv; charset=utf-8".to_string()), (header::CONTENT_DISPOSITION, disposition)], text).into_response())
}

/// The leaderboard and the VQA tables, as JSON and CSV.
pub fn routes() -> ApiRoutes {
    ApiRoutes::new()
        .operation(
            Operation::new(Verb::Get, "/api/v1/leaderboard", Auth::Public, "The leaderboard (`?release=V`); CSV with `Accept: text/csv`.", 200)
                .query::<LeaderboardQuery>()
                .returns::<crate::leaderboard::Leaderboard>(),
            json_or_csv,
        )
        .operation(
            Operation::new(Verb::Get, "/api/v1/leaderboard.csv", Auth::Public, "The leaderboard as CSV.", 200).query::<LeaderboardQuery>().returns_other("text/csv"),
            csv,
        )
        .operation(
            Operation::new(
                Verb::Get,
                "/api/v1/leaderboard/vqa",
                Auth::Public,
                "VQA accuracies in the paper's shapes: `table2` (subset × group × method × lighting, prompt-grounded) and `table3` (standard against prompt-grounded, over all lightings, with 95 % bootstrap intervals); `?table=2|3` for one.",
                200,
            )
            .query::<VqaQuery>()
            .returns::<VqaTables>(),
            vqa_tables,
        )
        .operation(
            Operation::new(Verb::Get, "/api/v1/leaderboard/vqa.csv", Auth::Public, "One VQA table (`?table=2` or `?table=3`) as CSV.", 200)
                .query::<VqaQuery>()
                .returns_other("text/csv"),
            vqa_table_csv,
        )
}
