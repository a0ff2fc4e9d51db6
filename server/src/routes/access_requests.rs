//! Requests for access over the API: a team asks and collects
//! (`/api/v1/access-requests…`, no token), the operator lists, approves and declines
//! (`/api/v1/admin/access-requests…`). The rules are `crate::access_requests`'.

use axum::extract::State;
use axum::http::request::Parts;
use axum::http::{HeaderMap, StatusCode, header};
use axum::response::{IntoResponse, Response};
use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

use super::extract::{ApiJson, ApiPath, ApiQuery};
use super::operation::{ApiRoutes, Auth, Operation, Verb};
use crate::access_requests::{AccessRequestForm, AccessRequestView, AskedAccess, Collected};
use crate::auth::AdminCaller;
use crate::problem::{ApiResult, Problem, ProblemCode};
use crate::state::AppState;
use crate::store::AccessRequestState;

/// The rate limiter's key for the client of a request.
pub fn client_of(state: &AppState, headers: &HeaderMap, parts_peer: Option<std::net::IpAddr>) -> String {
    crate::rate_limit::client_of(headers, parts_peer, &state.settings.trusted_proxies)
}

/// `POST /api/v1/access-requests`: ask for access; the claim code is in the answer, once.
pub async fn ask(State(state): State<AppState>, parts: Parts, ApiJson(form): ApiJson<AccessRequestForm>) -> ApiResult<Response> {
    let client = client_of(&state, &parts.headers, crate::http::peer_ip(&parts.extensions));
    let asked = crate::access_requests::ask(&state, &form, &client).await?;
    Ok((StatusCode::CREATED, [(header::CACHE_CONTROL, "no-store")], axum::Json(asked)).into_response())
}

/// `POST /api/v1/access-requests/collect` body.
#[derive(Debug, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct Claim {
    pub claim_code: String,
}

/// The answer to a claim code no request has (counted as a failed authentication).
pub fn unknown_claim(state: &AppState, client: &str) -> Problem {
    match state.limiter.admit(crate::rate_limit::failed_authentication(client), std::time::Instant::now()) {
        Err(seconds) => Problem::new(StatusCode::TOO_MANY_REQUESTS, ProblemCode::RateLimited, "Too many requests", format!("Slow down: retry in {seconds} s."))
            .retry_after(seconds),
        Ok(()) => Problem::not_found("No request for access has this claim code. Copy the whole code you were shown (it starts with osmab_claim_)."),
    }
}

/// `POST /api/v1/access-requests/collect`: where a request stands, and once approved the
/// team's first token (only the first time).
pub async fn collect(State(state): State<AppState>, parts: Parts, ApiJson(claim): ApiJson<Claim>) -> ApiResult<Response> {
    match crate::access_requests::collect(&state, &claim.claim_code).await {
        Ok(collected) => Ok(([(header::CACHE_CONTROL, "no-store")], axum::Json(collected)).into_response()),
        Err(Some(problem)) => Err(problem),
        Err(None) => Err(unknown_claim(&state, &client_of(&state, &parts.headers, crate::http::peer_ip(&parts.extensions)))),
    }
}

/// `GET /api/v1/admin/access-requests` query.
#[derive(Debug, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct RequestsQuery {
    /// Only requests in this state (default: every state).
    pub state: Option<AccessRequestState>,
}

/// `GET /api/v1/admin/access-requests`.
#[derive(Debug, Serialize, Deserialize, JsonSchema)]
pub struct RequestList {
    pub requests: Vec<AccessRequestView>,
}

/// `GET /api/v1/admin/access-requests`: oldest first.
pub async fn list(State(state): State<AppState>, _: AdminCaller, ApiQuery(query): ApiQuery<RequestsQuery>) -> ApiResult<axum::Json<RequestList>> {
    let requests = state.store.access_requests(query.state).await?;
    Ok(axum::Json(RequestList { requests: requests.iter().map(AccessRequestView::from).collect() }))
}

/// `POST /api/v1/admin/access-requests/{id}/approve`: create the team.
pub async fn approve(State(state): State<AppState>, _: AdminCaller, ApiPath(id): ApiPath<String>) -> ApiResult<axum::Json<AccessRequestView>> {
    Ok(axum::Json(crate::access_requests::approve(&state, &id).await?))
}

/// `POST /api/v1/admin/access-requests/{id}/decline` body.
#[derive(Debug, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct Decline {
    /// Shown to the requester.
    pub reason: String,
}

/// `POST /api/v1/admin/access-requests/{id}/decline`.
pub async fn decline(
    State(state): State<AppState>,
    _: AdminCaller,
    ApiPath(id): ApiPath<String>,
    ApiJson(body): ApiJson<Decline>,
) -> ApiResult<axum::Json<AccessRequestView>> {
    Ok(axum::Json(crate::access_requests::decline(&state, &id, &body.reason).await?))
}

/// Asking for access and deciding on it.
pub fn routes() -> ApiRoutes {
    ApiRoutes::new()
        .operation(
            Operation::new(
                Verb::Post,
                "/api/v1/access-requests",
                Auth::Public,
                "Ask for access: `{\"team_name\", \"contact\", \"affiliation\", \"method_url\"?}` → `{\"id\", \"claim_code\", \"state\"}`; keep the claim code (shown once) to collect the team's token when approved. At most 3 pending requests per client.",
                201,
            )
            .takes::<AccessRequestForm>()
            .returns::<AskedAccess>(),
            ask,
        )
        .operation(
            Operation::new(
                Verb::Post,
                "/api/v1/access-requests/collect",
                Auth::Public,
                "Where a request stands (`{\"claim_code\"}`); once approved, the team's first token, the first time only. An unknown code counts as a failed authentication.",
                200,
            )
            .takes::<Claim>()
            .returns::<Collected>(),
            collect,
        )
        .operation(
            Operation::new(Verb::Get, "/api/v1/admin/access-requests", Auth::Admin, "Requests for access, oldest first (`?state=pending`).", 200)
                .query::<RequestsQuery>()
                .returns::<RequestList>(),
            list,
        )
        .operation(
            Operation::new(Verb::Post, "/api/v1/admin/access-requests/{id}/approve", Auth::Admin, "Approve a pending request: its team is created; the requester collects the token.", 200)
                .returns::<AccessRequestView>(),
            approve,
        )
        .operation(
            Operation::new(Verb::Post, "/api/v1/admin/access-requests/{id}/decline", Auth::Admin, "Decline a pending request with a reason the requester reads.", 200)
                .takes::<Decline>()
                .returns::<AccessRequestView>(),
            decline,
        )
}
