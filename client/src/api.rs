//! The service's HTTP API as the client uses it: the team's token on its own routes only
//! (public routes get none), JSON, and every error
//! shown as the problem+json title, detail and what to do — never as a raw body.

use std::time::Duration;

use anyhow::anyhow;
use reqwest::StatusCode;
use reqwest::blocking::{Client, RequestBuilder, Response};
use serde_json::Value;

use super::session::Session;
use osmab_api::ProblemCode;

/// A connection to one server.
pub struct Api {
    pub session: Session,
    pub client: Client,
}

/// What to do about an error code, beyond the server's own words.
fn advice(code: ProblemCode) -> Option<String> {
    use ProblemCode::*;
    let client = crate::command();
    Some(match code {
        TokenExpired | TokenRevoked | TokenInvalid | Unauthenticated => format!("ask the organisers for a new team token, then run `{client} login --token …`"),
        QuotaExceeded => format!("wait until the time in Retry-After, or validate offline meanwhile with `{client} validate` (free)"),
        InvalidSubmission => format!("fix the files listed and run `{client} validate` before submitting again"),
        DigestMismatch | UploadIncomplete => "the upload was damaged in transit; submit again".into(),
        PayloadTooLarge => "store features as float32 and leave out background points, or ask the organisers".into(),
        RateLimited => "wait a moment and try again".into(),
        _ => return None,
    })
}

/// An error answer of the service, in words.
pub fn problem_message(status: StatusCode, body: &str, retry_after: Option<&str>) -> String {
    let parsed: Option<Value> = serde_json::from_str(body).ok();
    let Some(problem) = parsed.filter(|p| p.get("title").is_some() || p.get("detail").is_some()) else {
        let text: String = body.chars().filter(|c| !c.is_control()).take(200).collect();
        return format!("the server answered {status}{}", if text.is_empty() { String::new() } else { format!(" ({text})") });
    };
    let title = problem["title"].as_str().unwrap_or("Error");
    let detail = problem["detail"].as_str().unwrap_or("");
    let code = problem["code"].as_str().unwrap_or("");
    let mut message = format!("{title}: {detail}");
    if let Some(errors) = problem["errors"].as_array() {
        // The detail quotes the first problem (or the only one): each is said once.
        let unsaid: Vec<String> = errors
            .iter()
            .map(|e| format!("{}: {}: {}", e["file"].as_str().unwrap_or("?"), e["field"].as_str().unwrap_or("?"), e["message"].as_str().unwrap_or("")))
            .filter(|line| !detail.contains(line.as_str()))
            .collect();
        for line in unsaid.iter().take(20) {
            message.push_str(&format!("\n  - {line}"));
        }
        if unsaid.len() > 20 {
            message.push_str(&format!("\n  … and {} more", unsaid.len() - 20));
        }
    }
    if let Some(at) = retry_after {
        message.push_str(&format!("\n  (retry after {at} s)"));
    }
    if let Some(todo) = ProblemCode::from_code(code).and_then(advice) {
        message.push_str(&format!("\n  What to do: {todo}."));
    }
    if !code.is_empty() {
        message.push_str(&format!(" [{code}, HTTP {}]", status.as_u16()));
    }
    message
}

impl Api {
    pub fn new(session: Session) -> anyhow::Result<Api> {
        super::session::check_transport(&session.url, session.allow_http)?;
        let client =
            Client::builder().connect_timeout(Duration::from_secs(15)).timeout(None).user_agent(concat!("osmab-client/", env!("CARGO_PKG_VERSION"))).build()?;
        Ok(Api { session, client })
    }

    pub fn url(&self, path: &str) -> String {
        format!("{}{path}", self.session.url)
    }

    /// GET a public route (releases, files, the leaderboard): no token is sent.
    pub fn get(&self, path: &str) -> RequestBuilder {
        self.client.get(self.url(path)).timeout(Duration::from_secs(60))
    }

    /// GET a route of the team's own (its submissions, `/me`) with its token.
    pub fn get_as_team(&self, path: &str) -> anyhow::Result<RequestBuilder> {
        Ok(self.get(path).bearer_auth(self.session.token()?))
    }

    /// Send `request`; an error status becomes the service's problem in words.
    pub fn send(&self, request: RequestBuilder) -> anyhow::Result<Response> {
        let response = request.send().map_err(|e| anyhow!("cannot reach {}: {}", self.session.url, describe(&e)))?;
        checked(response)
    }

    /// GET the public `path`, retrying what passes — a broken connection, a server error
    /// or a rate limit (after its `Retry-After`, at most a minute) — up to four times.
    pub fn get_retrying(&self, path: &str) -> anyhow::Result<Response> {
        let mut last = None;
        for attempt in 0..4u32 {
            match self.get(path).send() {
                Ok(response) if response.status().is_server_error() || response.status() == StatusCode::TOO_MANY_REQUESTS => {
                    let wait = response.headers().get("retry-after").and_then(|v| v.to_str().ok()).and_then(|v| v.parse::<u64>().ok()).unwrap_or(0).min(60);
                    last = Some(checked(response).err().unwrap_or_else(|| anyhow!("server error")).context(format!("GET {}", self.url(path))));
                    if attempt < 3 {
                        std::thread::sleep(Duration::from_secs(wait.max(1 << attempt)));
                    }
                }
                Ok(response) => return checked(response).map_err(|e| e.context(format!("GET {}", self.url(path)))),
                Err(e) => {
                    last = Some(anyhow!("cannot reach {}: {}", self.url(path), describe(&e)));
                    if attempt < 3 {
                        std::thread::sleep(Duration::from_secs(1 << attempt));
                    }
                }
            }
        }
        Err(last.unwrap_or_else(|| anyhow!("GET {} failed", self.url(path))))
    }

    /// GET the public `path` as JSON.
    pub fn get_json(&self, path: &str) -> anyhow::Result<Value> {
        let response = self.send(self.get(path))?;
        response.json().map_err(|e| anyhow!("{path}: the server's answer is not JSON: {e}"))
    }

    /// GET the team's `path` as JSON, with its token.
    pub fn get_team_json(&self, path: &str) -> anyhow::Result<Value> {
        self.get_team_as(path)
    }

    /// GET the team's `path`, with its token, as the server's own answer type `T`.
    pub fn get_team_as<T: serde::de::DeserializeOwned>(&self, path: &str) -> anyhow::Result<T> {
        let response = self.send(self.get_as_team(path)?)?;
        response.json().map_err(|e| anyhow!("{path}: the server's answer does not read as expected: {e}"))
    }
}

/// An error status as the service's problem in words.
pub fn checked(response: Response) -> anyhow::Result<Response> {
    if response.status().is_success() || response.status() == StatusCode::NOT_MODIFIED {
        return Ok(response);
    }
    let status = response.status();
    let retry_after = response.headers().get("retry-after").and_then(|v| v.to_str().ok()).map(str::to_string);
    let body = response.text().unwrap_or_default();
    Err(anyhow!(problem_message(status, &body, retry_after.as_deref())))
}

/// A transport error in words (the source chain, not reqwest's debug form).
pub fn describe(e: &reqwest::Error) -> String {
    let mut text = e.to_string();
    let mut source = std::error::Error::source(e);
    while let Some(s) = source {
        text.push_str(&format!(": {s}"));
        source = s.source();
    }
    text
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn problems_are_shown_as_title_detail_and_advice() {
        let body = r#"{"type":"https://osmab/problems/token_expired","title":"Authentication required","status":401,"detail":"This token expired at 2026-11-01T00:00:00Z.","code":"token_expired"}"#;
        let text = problem_message(StatusCode::UNAUTHORIZED, body, None);
        assert!(text.starts_with("Authentication required: This token expired at 2026-11-01T00:00:00Z."), "{text}");
        assert!(text.contains("What to do: ask the organisers for a new team token"), "{text}");
        assert!(text.ends_with("[token_expired, HTTP 401]"), "{text}");
        let listed = r#"{"title":"Invalid submission","detail":"2 problems","code":"invalid_submission","errors":[{"file":"maps/baseline/scene_000.npz","field":"points","message":"NaN at row 3"}]}"#;
        assert!(problem_message(StatusCode::UNPROCESSABLE_ENTITY, listed, None).contains("\n  - maps/baseline/scene_000.npz: points: NaN at row 3"));
    }

    #[test]
    fn a_refusal_says_each_problem_once() {
        // As the service words it: the detail quotes the first problem, `errors` lists them all.
        let one = r#"{"title":"Invalid submission","detail":"The submission was not accepted: maps/baseline/scene_000.npz: points: NaN at row 3. Fix it and upload again.","code":"invalid_submission","errors":[{"file":"maps/baseline/scene_000.npz","field":"points","message":"NaN at row 3"}]}"#;
        let text = problem_message(StatusCode::UNPROCESSABLE_ENTITY, one, None);
        assert_eq!(text.matches("NaN at row 3").count(), 1, "{text}");
        let two = r#"{"title":"Invalid submission","detail":"The submission was not accepted: 2 problems, the first: a.npz: points: NaN. Fix them.","code":"invalid_submission","errors":[{"file":"a.npz","field":"points","message":"NaN"},{"file":"b.npz","field":"object_ids","message":"negative"}]}"#;
        let text = problem_message(StatusCode::UNPROCESSABLE_ENTITY, two, None);
        assert_eq!(text.matches("a.npz: points: NaN").count(), 1, "{text}");
        assert!(text.contains("\n  - b.npz: object_ids: negative"), "{text}");
        let html = problem_message(StatusCode::BAD_GATEWAY, "<html>\n<body>bad gateway</body></html>", None);
        assert_eq!(html, "the server answered 502 Bad Gateway (<html><body>bad gateway</body></html>)");
    }
}
