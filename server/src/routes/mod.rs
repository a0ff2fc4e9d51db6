//! The HTTP surface: one `router(state)` the server, the tests and the benchmarks share.
//! Each module owns the routes, handlers and response shapes of one area.

pub mod admin;
mod admin_teams;
mod api_docs;
mod files;
mod headers;
mod health;
mod jobs;
mod leaderboard;
mod openapi;
mod pages;
pub mod quota_policies;
mod receipts;
mod releases;
pub mod submission_view;
pub mod submissions;
mod uploads;

use std::time::{Duration, Instant};

use axum::Router;
use axum::extract::{DefaultBodyLimit, FromRequest, FromRequestParts, MatchedPath, Request, State};
use axum::http::request::Parts;
use axum::http::{HeaderName, Method, StatusCode};
use axum::middleware::{Next, from_fn_with_state};
use axum::response::{IntoResponse, Response};
use axum::routing::{get, post, put};
use serde::de::DeserializeOwned;
use tower_http::request_id::{MakeRequestId, PropagateRequestIdLayer, RequestId, SetRequestIdLayer};
use tower_http::trace::TraceLayer;

use crate::problem::Problem;
use crate::state::AppState;

/// Largest JSON request body (everything but uploads, which stream).
const JSON_BODY_LIMIT: usize = 1 << 20;

static REQUEST_ID: HeaderName = HeaderName::from_static("x-request-id");

#[derive(Clone, Default)]
struct RandomRequestId;

impl MakeRequestId for RandomRequestId {
    fn make_request_id<B>(&mut self, _: &axum::http::Request<B>) -> Option<RequestId> {
        axum::http::HeaderValue::from_str(&crate::clock::random_alphanumeric(16)).ok().map(RequestId::new)
    }
}

/// A JSON body whose rejections are problem+json like every other error.
pub struct ApiJson<T>(pub T);

impl<T: DeserializeOwned, S: Send + Sync> FromRequest<S> for ApiJson<T> {
    type Rejection = Problem;

    async fn from_request(req: Request, state: &S) -> Result<Self, Self::Rejection> {
        match axum::Json::<T>::from_request(req, state).await {
            Ok(axum::Json(value)) => Ok(ApiJson(value)),
            Err(rejection) => Err(Problem::new(rejection.status(), "invalid_request", "Invalid request body", rejection.body_text())),
        }
    }
}

/// Query parameters whose rejections are problem+json (`invalid_query`).
pub struct ApiQuery<T>(pub T);

impl<T: DeserializeOwned, S: Send + Sync> FromRequestParts<S> for ApiQuery<T> {
    type Rejection = Problem;

    async fn from_request_parts(parts: &mut Parts, state: &S) -> Result<Self, Self::Rejection> {
        match axum::extract::Query::<T>::from_request_parts(parts, state).await {
            Ok(axum::extract::Query(value)) => Ok(ApiQuery(value)),
            Err(rejection) => Err(Problem::new(
                StatusCode::BAD_REQUEST,
                "invalid_query",
                "Invalid query parameters",
                format!("{}; see /api/docs for this route's parameters.", rejection.body_text()),
            )),
        }
    }
}

/// Path parameters whose rejections are problem+json (`invalid_path`).
pub struct ApiPath<T>(pub T);

impl<T: DeserializeOwned + Send, S: Send + Sync> FromRequestParts<S> for ApiPath<T> {
    type Rejection = Problem;

    async fn from_request_parts(parts: &mut Parts, state: &S) -> Result<Self, Self::Rejection> {
        match axum::extract::Path::<T>::from_request_parts(parts, state).await {
            Ok(axum::extract::Path(value)) => Ok(ApiPath(value)),
            Err(rejection) => Err(Problem::new(StatusCode::BAD_REQUEST, "invalid_path", "Invalid path", rejection.body_text())),
        }
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
    let peer = crate::http::peer_ip(request.extensions());
    let address = peer.map_or_else(|| "unknown".to_string(), |ip| ip.to_string());
    let (mut parts, body) = request.into_parts();
    let client = match crate::auth::caller_of(&mut parts, &state).await {
        Ok(crate::auth::Caller::Team(team)) => write.then(|| format!("team {}", team.id)),
        Ok(crate::auth::Caller::Admin) => write.then(|| "admin".to_string()),
        Ok(crate::auth::Caller::Anonymous) => write.then(|| format!("address {address}")),
        Err(problem) if problem.status == StatusCode::UNAUTHORIZED => Some(crate::rate_limit::failed_authentication(peer)),
        // The store is unavailable: the handler answers with its own error.
        Err(_) => None,
    };
    if let Some(client) = client
        && let Err(seconds) = state.limiter.admit(client, Instant::now())
    {
        return Problem::new(StatusCode::TOO_MANY_REQUESTS, "rate_limited", "Too many requests", format!("Slow down: retry in {seconds} s."))
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

async fn route_not_found(request: Request) -> Problem {
    Problem::new(StatusCode::NOT_FOUND, "route_not_found", "Not found", format!("There is no {} {}; see /api/docs.", request.method(), request.uri().path()))
}

async fn method_not_allowed(request: Request) -> Problem {
    Problem::new(
        StatusCode::METHOD_NOT_ALLOWED,
        "method_not_allowed",
        "Method not allowed",
        format!("{} is not allowed on {}; see /api/docs.", request.method(), request.uri().path()),
    )
}

/// The whole service.
pub fn router(state: AppState) -> Router {
    let api = Router::new()
        .route("/api/v1/openapi.json", get(openapi::document))
        .route("/api/v1/releases", get(releases::list))
        .route("/api/v1/releases/{version}", get(releases::show))
        .route("/api/v1/releases/{version}/manifest.json", get(releases::manifest))
        .route("/api/v1/releases/{version}/files/{*path}", get(releases::file))
        .route("/api/v1/me", get(submissions::me))
        .route("/api/v1/quota", get(submissions::quotas))
        .route("/api/v1/submissions", post(submissions::create).get(submissions::list))
        .route("/api/v1/submissions/{id}", get(submissions::show).patch(submissions::update))
        .route("/api/v1/submissions/{id}/receipt", get(receipts::receipt))
        .route("/api/v1/submissions/{id}/results.json", get(receipts::results))
        .route("/api/v1/keys", get(receipts::keys))
        .route("/api/v1/submissions/{id}/cancel", post(submissions::cancel))
        .route("/api/v1/leaderboard", get(leaderboard::json_or_csv))
        .route("/api/v1/leaderboard.csv", get(leaderboard::csv))
        .route("/api/v1/leaderboard/vqa", get(leaderboard::vqa_tables))
        .route("/api/v1/leaderboard/vqa.csv", get(leaderboard::vqa_table_csv))
        .route("/api/v1/jobs/{id}", get(jobs::show))
        .route("/api/v1/admin/teams", post(admin::create_team).get(admin::list_teams))
        .route("/api/v1/admin/teams/{id}", axum::routing::patch(admin::update_team))
        .route("/api/v1/admin/teams/{id}/tokens", post(admin::issue_team_token).get(admin::list_team_tokens))
        .route("/api/v1/admin/tokens/{id}", axum::routing::delete(admin::revoke_token))
        .route("/api/v1/admin/releases", post(admin::build_release))
        .route("/api/v1/admin/releases/import", post(admin::import_release))
        .route("/api/v1/admin/releases/{version}/publish", post(admin::publish_release))
        .route("/api/v1/admin/submissions", get(admin::list_submissions))
        .route("/api/v1/admin/submissions/{id}/rescore", post(admin::rescore))
        .route("/api/v1/admin/submissions/{id}/flag", put(admin::flag).delete(admin::unflag))
        .route("/api/v1/admin/submissions/{id}/refund", post(admin::refund_quota))
        .route("/api/v1/admin/jobs", get(admin::list_jobs))
        .route("/api/v1/admin/quotas", get(quota_policies::list))
        .route("/api/v1/admin/quotas/{split}", put(quota_policies::set));
    let resumable = Router::new()
        .route("/api/v1/uploads", post(uploads::create).options(uploads::options))
        .route("/api/v1/uploads/{id}", axum::routing::head(uploads::head).patch(uploads::patch).delete(uploads::delete))
        .layer(axum::middleware::from_fn(uploads::tus_headers));
    let pages = Router::new()
        .route("/", get(pages::leaderboard))
        .route("/releases/{version}", get(pages::release))
        .route("/submissions/{id}", get(pages::submission))
        .route("/admin", get(pages::admin::console))
        .route("/admin/login", get(pages::admin::login_form).post(pages::admin::login))
        .route("/admin/logout", post(pages::admin::logout))
        .route("/admin/regenerate", post(pages::admin::regenerate))
        .route("/admin/jobs/{id}", get(pages::admin::job))
        .route("/admin/releases/{version}/quality", get(pages::admin::quality))
        .route("/admin/releases/{version}/files/{*path}", get(pages::admin::release_file))
        .route("/admin/releases/{version}/publish", post(pages::admin::publish))
        .route("/admin/submissions/{id}/flag", post(pages::admin::flag))
        .route("/admin/submissions/{id}/unflag", post(pages::admin::unflag))
        .route("/admin/submissions/{id}/refund", post(pages::admin::refund))
        .route("/admin/quotas", post(pages::admin::set_quota))
        .route("/admin/teams", post(pages::admin::create_team))
        .route("/api/docs", get(api_docs::docs_page))
        .route("/about", get(pages::about))
        .route("/static/{file}", get(pages::static_file));
    let health = Router::new().route("/livez", get(health::livez)).route("/readyz", get(health::readyz)).route("/metrics", get(health::metrics));
    Router::new()
        .merge(api)
        .merge(resumable)
        .merge(pages)
        .merge(health)
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
