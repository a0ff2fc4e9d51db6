//! Headers every answer carries, and the request headers checked before routing: pages may
//! run no script, be framed by no one, and admin pages are never cached; an HTTP/1.1 request
//! names its host once (RFC 9112 §3.2); a client's `x-request-id` is kept only when it is a
//! short token.

use axum::extract::Request;
use axum::http::{HeaderName, HeaderValue, header};
use axum::middleware::Next;
use axum::response::{IntoResponse, Response};

use crate::problem::{Problem, ProblemCode};

/// The header that carries a request's id (accepted from the client, else made up).
pub static REQUEST_ID: HeaderName = HeaderName::from_static("x-request-id");

/// The pages need no script, no inline style and nothing from another origin: their
/// stylesheet and images are the service's own, and forms post back to it.
pub const CONTENT_SECURITY_POLICY: &str = "default-src 'none'; style-src 'self'; img-src 'self'; form-action 'self'; frame-ancestors 'none'; base-uri 'none'";

/// Longest `x-request-id` a client may choose; longer ones are replaced by the server's own.
pub const MAX_REQUEST_ID_LEN: usize = 64;

/// Whether a client's request id may be echoed and logged as it is: 1 to 64 characters of
/// letters, digits, `-`, `_`, `.` and `:` (what tracing systems send: UUIDs, hex trace ids).
pub fn is_acceptable_request_id(value: &[u8]) -> bool {
    (1..=MAX_REQUEST_ID_LEN).contains(&value.len()) && value.iter().all(|b| b.is_ascii_alphanumeric() || b"-_.:".contains(b))
}

/// Drop a client's `x-request-id` that is not a short token (the server then makes one).
pub async fn accept_request_id(mut request: Request, next: Next) -> Response {
    let headers = request.headers_mut();
    let values: Vec<&HeaderValue> = headers.get_all(REQUEST_ID.clone()).iter().collect();
    if !(values.len() == 1 && is_acceptable_request_id(values[0].as_bytes())) {
        headers.remove(REQUEST_ID.clone());
    }
    next.run(request).await
}

/// Refuse an HTTP/1.1 request without exactly one `Host` header, as RFC 9112 §3.2 requires
/// (HTTP/1.0 may omit it).
pub async fn require_host(request: Request, next: Next) -> Response {
    let hosts = request.headers().get_all(header::HOST).iter().count();
    if request.version() == axum::http::Version::HTTP_11 && hosts != 1 {
        let detail = if hosts == 0 {
            "An HTTP/1.1 request must carry a Host header (RFC 9112 §3.2)."
        } else {
            "A request may carry one Host header, not several (RFC 9112 §3.2)."
        };
        return Problem::bad_request(ProblemCode::InvalidRequest, detail).into_response();
    }
    next.run(request).await
}

/// `nosniff` and a same-origin referrer policy on every answer; on HTML the content security
/// policy and `X-Frame-Options: DENY`; on the operator's pages and API, `Cache-Control: no-store`.
pub async fn security_headers(request: Request, next: Next) -> Response {
    let path = request.uri().path();
    let administrative = path == "/admin" || path.starts_with("/admin/") || path.starts_with("/api/v1/admin");
    let mut response = next.run(request).await;
    let is_html = response.headers().get(header::CONTENT_TYPE).and_then(|v| v.to_str().ok()).is_some_and(|t| t.starts_with("text/html"));
    let headers = response.headers_mut();
    headers.insert(header::X_CONTENT_TYPE_OPTIONS, HeaderValue::from_static("nosniff"));
    headers.insert(header::REFERRER_POLICY, HeaderValue::from_static("same-origin"));
    if is_html {
        headers.insert(header::CONTENT_SECURITY_POLICY, HeaderValue::from_static(CONTENT_SECURITY_POLICY));
        headers.insert(header::X_FRAME_OPTIONS, HeaderValue::from_static("DENY"));
    }
    if administrative {
        headers.insert(header::CACHE_CONTROL, HeaderValue::from_static("no-store"));
    }
    response
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn request_ids_are_short_tokens() {
        for good in ["a", "0f8e2c1d-8a4b-4c3e-9f00-123456789abc", "trace.span:42", &"x".repeat(64)] {
            assert!(is_acceptable_request_id(good.as_bytes()), "{good}");
        }
        for bad in ["", &"x".repeat(65), "two words", "line\nbreak", "<script>", "ünï", "a;b"] {
            assert!(!is_acceptable_request_id(bad.as_bytes()), "{bad:?}");
        }
    }
}
