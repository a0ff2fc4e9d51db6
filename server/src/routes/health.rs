//! Liveness, readiness and Prometheus metrics.

use axum::extract::State;
use axum::http::{StatusCode, header};
use axum::response::{IntoResponse, Response};
use schemars::JsonSchema;
use serde::Serialize;

use super::operation::{ApiRoutes, Auth, Operation, Verb};
use crate::problem::{Problem, ProblemCode};
use crate::state::AppState;

/// `GET /livez`.
#[derive(Debug, Serialize, JsonSchema)]
pub struct Live {
    /// `ok`.
    pub status: &'static str,
}

/// `GET /readyz` when ready.
#[derive(Debug, Serialize, JsonSchema)]
pub struct Ready {
    /// `sqlite` or `postgres`.
    pub database: &'static str,
    /// `ready`.
    pub status: &'static str,
    /// `ok`.
    pub storage: &'static str,
}

/// `GET /livez`: the process answers.
pub async fn livez() -> axum::Json<Live> {
    axum::Json(Live { status: "ok" })
}

/// `GET /readyz`: the database and the blob storage are reachable.
pub async fn readyz(State(state): State<AppState>) -> Response {
    let (database, blobs) = tokio::join!(state.store.ping(), state.blobs.check());
    match (&database, &blobs) {
        (Ok(()), Ok(())) => axum::Json(Ready { database: state.store.backend(), status: "ready", storage: "ok" }).into_response(),
        _ => {
            let what = [database.err().map(|e| format!("database: {e}")), blobs.err().map(|e| format!("storage: {e}"))];
            let detail = what.into_iter().flatten().collect::<Vec<_>>().join("; ");
            tracing::warn!(%detail, "not ready");
            Problem::new(StatusCode::SERVICE_UNAVAILABLE, ProblemCode::NotReady, "Not ready", "The database or the storage is not reachable.").into_response()
        }
    }
}

/// `GET /metrics`: Prometheus text, for the admin token only (Prometheus sends it with
/// `authorization: {credentials_file: …}`): the counts say how many private submissions
/// there are and how often the console is logged into.
pub async fn metrics(_: crate::auth::AdminCaller, State(state): State<AppState>) -> Response {
    let jobs = state.store.job_state_counts().await.unwrap_or_default();
    let submissions = state.store.submission_state_counts().await.unwrap_or_default();
    let text = state.metrics.render(&[("osmab_jobs", "Jobs by state.", jobs), ("osmab_submissions", "Submissions by state.", submissions)]);
    ([(header::CONTENT_TYPE, "text/plain; version=0.0.4; charset=utf-8")], text).into_response()
}

/// Liveness, readiness and metrics.
pub fn routes() -> ApiRoutes {
    ApiRoutes::new()
        .operation(Operation::new(Verb::Get, "/livez", Auth::Public, "Liveness: the process answers.", 200).returns::<Live>(), livez)
        .operation(Operation::new(Verb::Get, "/readyz", Auth::Public, "Readiness: the database and the storage are reachable.", 200).returns::<Ready>(), readyz)
        .operation(
            Operation::new(
                Verb::Get,
                "/metrics",
                Auth::Admin,
                "Prometheus metrics (requests, latency, jobs and submissions by state); the admin token only.",
                200,
            )
            .returns_other("text/plain"),
            metrics,
        )
}
