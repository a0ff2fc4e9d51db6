//! Serving an immutable blob with `ETag` (its SHA-256), `If-None-Match`, `If-Range` and
//! single byte ranges, streamed in chunks from the blob store (a file, or ranged GETs of
//! an object: the server streams rather than redirecting, so every download keeps this
//! one contract — see docs/deploy.md).

use crate::blobs::Blobs;
use crate::problem::{Problem, ProblemCode};
use axum::body::Body;
use axum::http::{HeaderMap, HeaderValue, StatusCode, header};
use axum::response::{IntoResponse, Response};
use base64::Engine;

/// Parse a single `bytes=` range against `size`: `Ok(None)` for no (or an ignorable)
/// range, `Err(())` for an unsatisfiable one.
pub fn parse_range(value: &str, size: u64) -> Result<Option<(u64, u64)>, ()> {
    let Some(spec) = value.trim().strip_prefix("bytes=") else { return Ok(None) };
    if spec.contains(',') {
        // Several ranges: answered with the whole file, which RFC 9110 allows.
        return Ok(None);
    }
    let (start, end) = spec.split_once('-').ok_or(())?;
    let (start, end) = (start.trim(), end.trim());
    let range = if start.is_empty() {
        let suffix: u64 = end.parse().map_err(|_| ())?;
        if suffix == 0 || size == 0 {
            return Err(());
        }
        (size.saturating_sub(suffix), size - 1)
    } else {
        let start: u64 = start.parse().map_err(|_| ())?;
        let end: u64 = if end.is_empty() { size.saturating_sub(1) } else { end.parse::<u64>().map_err(|_| ())?.min(size.saturating_sub(1)) };
        if start >= size || end < start {
            return Err(());
        }
        (start, end)
    };
    Ok(Some(range))
}

fn content_type(path: &str) -> &'static str {
    match path.rsplit('.').next().unwrap_or("") {
        "json" => "application/json",
        "png" => "image/png",
        "jpg" | "jpeg" => "image/jpeg",
        "txt" => "text/plain; charset=utf-8",
        "yaml" | "yml" => "application/yaml",
        "tar" => "application/x-tar",
        "csv" => "text/csv; charset=utf-8",
        _ => "application/octet-stream",
    }
}

/// Whether `If-None-Match` in `request` matches `etag` (weak comparison, `*` matches).
pub fn none_match(request: &HeaderMap, etag: &str) -> bool {
    request
        .get(header::IF_NONE_MATCH)
        .and_then(|v| v.to_str().ok())
        .is_some_and(|tags| tags.trim() == "*" || tags.split(',').any(|t| t.trim().trim_start_matches("W/") == etag))
}

/// The response for the blob `key` (`size` bytes, hex `sha256`) as `name`.
pub async fn serve_blob(blobs: &Blobs, key: &str, name: &str, size: u64, sha256: &str, request: &HeaderMap, immutable: bool) -> Result<Response, Problem> {
    let etag = format!("\"{sha256}\"");
    let mut headers = HeaderMap::new();
    headers.insert(header::ETAG, HeaderValue::from_str(&etag).expect("hex"));
    headers.insert(header::ACCEPT_RANGES, HeaderValue::from_static("bytes"));
    headers.insert(header::CONTENT_TYPE, HeaderValue::from_static(content_type(name)));
    let cache = if immutable { "public, max-age=31536000, immutable" } else { "no-cache" };
    headers.insert(header::CACHE_CONTROL, HeaderValue::from_static(cache));
    if let Ok(bytes) = (0..32).map(|i| u8::from_str_radix(&sha256[2 * i..2 * i + 2], 16)).collect::<Result<Vec<u8>, _>>() {
        let digest = format!("sha-256=:{}:", base64::engine::general_purpose::STANDARD.encode(bytes));
        headers.insert(HeaderName::from_static("repr-digest"), HeaderValue::from_str(&digest).expect("base64"));
    }
    if none_match(request, &etag) {
        return Ok((StatusCode::NOT_MODIFIED, headers).into_response());
    }
    let range_applies = match request.get(header::IF_RANGE).and_then(|v| v.to_str().ok()) {
        Some(tag) => tag.trim() == etag,
        None => true,
    };
    let range = match request.get(header::RANGE).and_then(|v| v.to_str().ok()) {
        Some(value) if range_applies => match parse_range(value, size) {
            Ok(range) => range,
            Err(()) => {
                // Not cacheable: only the size, so the client can ask again.
                let problem = Problem::new(
                    StatusCode::RANGE_NOT_SATISFIABLE,
                    ProblemCode::RangeNotSatisfiable,
                    "Range not satisfiable",
                    format!("The file has {size} bytes; ask for a range inside it (bytes=START-END)."),
                );
                let mut response = problem.into_response();
                response.headers_mut().insert(header::CONTENT_RANGE, HeaderValue::from_str(&format!("bytes */{size}")).expect("ascii"));
                return Ok(response);
            }
        },
        _ => None,
    };
    let (status, start, length) = match range {
        Some((start, end)) => {
            headers.insert(header::CONTENT_RANGE, HeaderValue::from_str(&format!("bytes {start}-{end}/{size}")).expect("ascii"));
            (StatusCode::PARTIAL_CONTENT, start, end - start + 1)
        }
        None => (StatusCode::OK, 0, size),
    };
    let stream = blobs.read(key, start, length).await.map_err(Problem::storage)?;
    headers.insert(header::CONTENT_LENGTH, HeaderValue::from(length));
    let body = Body::from_stream(stream);
    Ok((status, headers, body).into_response())
}

use axum::http::HeaderName;

#[cfg(test)]
mod tests {
    use super::parse_range;

    #[test]
    fn ranges_follow_rfc_9110() {
        assert_eq!(parse_range("bytes=0-9", 100), Ok(Some((0, 9))));
        assert_eq!(parse_range("bytes=90-", 100), Ok(Some((90, 99))));
        assert_eq!(parse_range("bytes=-10", 100), Ok(Some((90, 99))));
        assert_eq!(parse_range("bytes=95-200", 100), Ok(Some((95, 99))));
        assert_eq!(parse_range("bytes=100-", 100), Err(()));
        assert_eq!(parse_range("bytes=5-2", 100), Err(()));
        assert_eq!(parse_range("bytes=0-1,5-6", 100), Ok(None));
        assert_eq!(parse_range("items=0-1", 100), Ok(None));
        assert_eq!(parse_range("bytes=x-1", 100), Err(()));
    }
}
