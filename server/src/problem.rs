//! Errors as RFC 9457 `application/problem+json` with a stable `code`. Internal causes
//! are logged with the request id and never sent to the client.

use axum::http::{HeaderValue, StatusCode, header};
use axum::response::{IntoResponse, Response};
use serde_json::{Map, Value, json};

use crate::store::StoreError;
pub use osmab_api::ProblemCode;

/// An error response.
#[derive(Debug)]
pub struct Problem {
    pub status: StatusCode,
    /// Stable machine-readable code (`quota_exceeded`).
    pub code: ProblemCode,
    pub title: String,
    pub detail: String,
    /// Extension members (`errors`, `retry_after`, ...).
    pub extra: Map<String, Value>,
    /// Seconds for a `Retry-After` header.
    pub retry_after: Option<u64>,
}

impl Problem {
    /// A problem with `status`, stable `code`, short `title` and a `detail` that says what to do.
    pub fn new(status: StatusCode, code: ProblemCode, title: impl Into<String>, detail: impl Into<String>) -> Self {
        Self { status, code, title: title.into(), detail: displayable(&detail.into()), extra: Map::new(), retry_after: None }
    }

    /// Add an extension member.
    pub fn with(mut self, key: &str, value: Value) -> Self {
        self.extra.insert(key.into(), value);
        self
    }

    /// Ask the client to retry after `seconds`.
    pub fn retry_after(mut self, seconds: u64) -> Self {
        self.retry_after = Some(seconds);
        self.extra.insert("retry_after".into(), json!(seconds));
        self
    }

    pub fn not_found(what: impl Into<String>) -> Self {
        Self::new(StatusCode::NOT_FOUND, ProblemCode::NotFound, "Not found", what)
    }

    pub fn bad_request(code: ProblemCode, detail: impl Into<String>) -> Self {
        Self::new(StatusCode::BAD_REQUEST, code, "Bad request", detail)
    }

    pub fn forbidden(detail: impl Into<String>) -> Self {
        Self::new(StatusCode::FORBIDDEN, ProblemCode::Forbidden, "Forbidden", detail)
    }

    /// A request whose body or fields do not hold what the route needs (422 `invalid_request`).
    pub fn invalid_request(detail: impl Into<String>) -> Self {
        Self::new(StatusCode::UNPROCESSABLE_ENTITY, ProblemCode::InvalidRequest, "Invalid request", detail)
    }

    pub fn conflict(detail: impl Into<String>) -> Self {
        Self::new(StatusCode::CONFLICT, ProblemCode::Conflict, "Conflict", detail)
    }

    /// An unexpected failure: logged in full, shown as a generic message.
    pub fn internal(cause: impl std::fmt::Display) -> Self {
        tracing::error!(error = %cause, "internal error");
        Self::new(
            StatusCode::INTERNAL_SERVER_ERROR,
            ProblemCode::Internal,
            "Internal error",
            "The server failed to handle the request; it has been logged. Retry later.",
        )
    }

    /// A failed blob operation: the object store being away is a 503 the client may retry
    /// (nothing was stored); anything else is [`Problem::internal`].
    pub fn storage(error: std::io::Error) -> Self {
        if crate::blobs::unavailable(&error) {
            tracing::warn!(error = %error, "object storage unavailable");
            return Self::storage_unavailable();
        }
        Self::internal(error)
    }

    /// The 503 of an unreachable object store.
    pub fn storage_unavailable() -> Self {
        Self::new(
            StatusCode::SERVICE_UNAVAILABLE,
            ProblemCode::StorageUnavailable,
            "Storage unavailable",
            "The server cannot reach its object storage right now; nothing was stored and no quota was used. Retry in a little while.",
        )
        .retry_after(30)
    }

    /// The JSON body.
    pub fn body(&self) -> Value {
        let mut body = Map::new();
        body.insert("type".into(), json!(format!("/api/docs#problem-{}", self.code)));
        body.insert("title".into(), json!(self.title));
        body.insert("status".into(), json!(self.status.as_u16()));
        body.insert("detail".into(), json!(self.detail));
        body.insert("code".into(), json!(self.code.as_str()));
        body.extend(self.extra.clone());
        Value::Object(body)
    }
}

impl std::fmt::Display for Problem {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{} {}: {}", self.status.as_u16(), self.code, self.detail)
    }
}

impl IntoResponse for Problem {
    fn into_response(self) -> Response {
        let mut response = (self.status, serde_json::to_string(&self.body()).expect("json")).into_response();
        let headers = response.headers_mut();
        headers.insert(header::CONTENT_TYPE, HeaderValue::from_static("application/problem+json"));
        if let Some(seconds) = self.retry_after {
            headers.insert(header::RETRY_AFTER, HeaderValue::from(seconds));
        }
        if self.status == StatusCode::UNAUTHORIZED {
            headers.insert(header::WWW_AUTHENTICATE, HeaderValue::from_static("Bearer realm=\"osmab\""));
        }
        response
    }
}

impl From<StoreError> for Problem {
    fn from(e: StoreError) -> Self {
        match e {
            StoreError::NotFound => Problem::not_found("No such record."),
            StoreError::Conflict(what) => Problem::conflict(format!("A record with the same key exists ({what}).")),
            other => Problem::internal(other),
        }
    }
}

/// Result of a handler.
pub type ApiResult<T> = Result<T, Problem>;

/// A detail as it may be shown: what a client sent and a detail repeats (a path, an
/// entry name) cannot carry control, bidi or other invisible characters — they are
/// written as `\u{…}` escapes — nor run on for pages (cut at 2,000 characters).
fn displayable(detail: &str) -> String {
    const MAX_CHARS: usize = 2000;
    let mut out = String::with_capacity(detail.len().min(4 * MAX_CHARS));
    for (i, c) in detail.chars().enumerate() {
        if i == MAX_CHARS {
            out.push('…');
            break;
        }
        if osmab_evaluator::text::is_invisible(c) {
            out.extend(c.escape_unicode());
        } else {
            out.push(c);
        }
    }
    out
}

#[cfg(test)]
mod displayable_tests {
    #[test]
    fn details_never_carry_invisible_characters_or_run_on() {
        assert_eq!(super::displayable("entry maps/a\nb\u{1b}[31m and \u{202E}x"), "entry maps/a\\u{a}b\\u{1b}[31m and \\u{202e}x");
        assert_eq!(super::displayable(&"x".repeat(5000)).chars().count(), 2001);
        assert_eq!(super::displayable("Fine: 3 of 5 — ok"), "Fine: 3 of 5 — ok");
    }
}
