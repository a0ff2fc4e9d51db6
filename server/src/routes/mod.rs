//! The HTTP surface: one `router(state)` the server, the tests and the benchmarks share.
//! Each module owns the routes, handlers and response shapes of one area.

pub mod access_requests;
pub mod admin;
pub mod admin_teams;
mod api_docs;
mod extract;
mod files;
mod headers;
mod health;
mod jobs;
mod leaderboard;
pub mod me;
mod openapi;
pub mod operation;
mod pages;
pub mod quota_policies;
mod receipts;
mod releases;
pub mod submission_view;
pub mod submissions;
mod uploads;

use std::sync::Arc;
use std::time::{Duration, Instant};

use axum::extract::{DefaultBodyLimit, MatchedPath, Request, State};
use axum::http::{Method, StatusCode};
use axum::middleware::{Next, from_fn_with_state};
use axum::response::{IntoResponse, Response};
use axum::routing::get;
use axum::{Extension, Router};
use tower_http::request_id::{MakeRequestId, PropagateRequestIdLayer, RequestId, SetRequestIdLayer};
use tower_http::trace::TraceLayer;

use crate::problem::{Problem, ProblemCode};
use crate::state::AppState;
use headers::REQUEST_ID;
use openapi::Served;
use operation::ApiRoutes;

/// Largest JSON request body (everything but uploads, which stream).
const JSON_BODY_LIMIT: usize = 1 << 20;

#[derive(Clone, Default)]
struct RandomRequestId;

impl MakeRequestId for RandomRequestId {
    fn make_request_id<B>(&mut self, _: &axum::http::Request<B>) -> Option<RequestId> {
        axum::http::HeaderValue::from_str(&crate::clock::random_alphanumeric(16)).ok().map(RequestId::new)
    }
}

async fn count_request(State(state): State<AppState>, request: Request, next: Next) -> Response {
    let started = Instant::now();
    let method = request.method().to_string();
    let route = request.extensions().get::<MatchedPath>().map(|p| p.as_str().to_string()).unwrap_or_else(|| "(unmatched)".into());
    let response = next.run(request).await;
    state.metrics.observe(&method, &route, response.status().as_u16(), started.elapsed());
    response
}

/// Requests that change things are limited per caller — the team or admin its token
/// resolves to (however the header is spelled), else its address — and failed
/// authentications, reads included, per address.
async fn limit_requests(State(state): State<AppState>, request: Request, next: Next) -> Response {
    let write = ![Method::GET, Method::HEAD, Method::OPTIONS].contains(request.method());
    if !write && !request.headers().contains_key(axum::http::header::AUTHORIZATION) {
        return next.run(request).await;
    }
    if request.method() == Method::POST && request.uri().path() == crate::routes::pages::admin::LOGIN_PATH {
        // The sign-in limits its own failures: the right admin token is never refused for
        // what strangers did at the same address.
        return next.run(request).await;
    }
    let address = crate::rate_limit::client_of(request.headers(), crate::http::peer_ip(request.extensions()), &state.settings.trusted_proxies);
    let (mut parts, body) = request.into_parts();
    let client = match crate::auth::caller_of(&mut parts, &state).await {
        Ok(crate::auth::Caller::Team(team)) => write.then(|| format!("team {}", team.id)),
        Ok(crate::auth::Caller::Admin) => write.then(|| "admin".to_string()),
        Ok(crate::auth::Caller::Anonymous) => write.then(|| format!("address {address}")),
        Err(problem) if problem.status == StatusCode::UNAUTHORIZED => Some(crate::rate_limit::failed_authentication(&address)),
        // The store is unavailable: the handler answers with its own error.
        Err(_) => None,
    };
    if let Some(client) = client
        && let Err(seconds) = state.limiter.admit(client, Instant::now())
    {
        return Problem::new(StatusCode::TOO_MANY_REQUESTS, ProblemCode::RateLimited, "Too many requests", format!("Slow down: retry in {seconds} s."))
            .retry_after(seconds)
            .into_response();
    }
    next.run(Request::from_parts(parts, body)).await
}

/// A request refused with its body unread (an upload without a valid token, over quota
/// or too large) leaves bytes on the connection: say `Connection: close` so the client
/// does not reuse it for its next request.
async fn close_after_refused_body(request: Request, next: Next) -> Response {
    let has_body = request.headers().get(axum::http::header::CONTENT_LENGTH).is_some_and(|v| v != "0")
        || request.headers().contains_key(axum::http::header::TRANSFER_ENCODING);
    let mut response = next.run(request).await;
    if has_body && (response.status().is_client_error() || response.status().is_server_error()) {
        response.headers_mut().insert(axum::http::header::CONNECTION, axum::http::HeaderValue::from_static("close"));
    }
    response
}

/// An unknown route: problem+json, but a page for a browser asking for a page (a GET that
/// accepts HTML, outside the API), so a mistyped link does not show raw JSON.
async fn route_not_found(request: Request) -> Response {
    let path = request.uri().path().to_string();
    let wants_page = request.method() == Method::GET
        && !path.starts_with("/api/")
        && request.headers().get(axum::http::header::ACCEPT).and_then(|v| v.to_str().ok()).is_some_and(|a| a.contains("text/html"));
    if wants_page {
        return (StatusCode::NOT_FOUND, pages::NotFoundPage { path }).into_response();
    }
    Problem::new(StatusCode::NOT_FOUND, ProblemCode::RouteNotFound, "Not found", format!("There is no {} {path}; see /api/docs.", request.method()))
        .into_response()
}

async fn method_not_allowed(request: Request) -> Problem {
    Problem::new(
        StatusCode::METHOD_NOT_ALLOWED,
        ProblemCode::MethodNotAllowed,
        "Method not allowed",
        format!("{} is not allowed on {}; see /api/docs.", request.method(), request.uri().path()),
    )
}

/// Every operation of the API, area by area: what the router serves and the OpenAPI
/// document and `/api/docs` describe.
fn api() -> ApiRoutes {
    ApiRoutes::new()
        .merge(health::routes())
        .merge(openapi::routes())
        .merge(releases::routes())
        .merge(me::routes())
        .merge(submissions::routes())
        .merge(uploads::routes())
        .merge(receipts::routes())
        .merge(leaderboard::routes())
        .merge(jobs::routes())
        .merge(admin_teams::routes())
        .merge(access_requests::routes())
        .merge(admin::routes())
        .merge(quota_policies::routes())
}

/// The whole service.
pub fn router(state: AppState) -> Router {
    let (api, operations) = api().into_parts();
    Router::new()
        .merge(api)
        .merge(pages::routes())
        .route("/api/docs", get(api_docs::docs_page))
        .layer(Extension(Served(Arc::new(operations))))
        .fallback(route_not_found)
        .method_not_allowed_fallback(method_not_allowed)
        .layer(DefaultBodyLimit::max(JSON_BODY_LIMIT))
        .layer(from_fn_with_state(state.clone(), limit_requests))
        .layer(axum::middleware::from_fn(close_after_refused_body))
        .layer(from_fn_with_state(state.clone(), count_request))
        .layer(
            TraceLayer::new_for_http()
                .make_span_with(|request: &Request| {
                    let id = request.headers().get(&REQUEST_ID).and_then(|v| v.to_str().ok()).unwrap_or("-");
                    let route = request.extensions().get::<MatchedPath>().map(MatchedPath::as_str).unwrap_or(request.uri().path());
                    tracing::info_span!("request", request_id = %id, method = %request.method(), route = %route)
                })
                .on_request(())
                .on_response(|response: &Response, latency: Duration, _span: &tracing::Span| {
                    tracing::info!(status = response.status().as_u16(), latency_ms = latency.as_secs_f64() * 1000.0, "response");
                }),
        )
        .layer(PropagateRequestIdLayer::new(REQUEST_ID.clone()))
        .layer(SetRequestIdLayer::new(REQUEST_ID.clone(), RandomRequestId))
        .layer(axum::middleware::from_fn(headers::accept_request_id))
        .layer(axum::middleware::from_fn(headers::require_host))
        .layer(axum::middleware::from_fn(headers::security_headers))
        .with_state(state)
}
