//! The OpenAPI 3.1 document (`/api/v1/openapi.json`) and its HTML page (`/api/docs`),
//! both generated from one table of operations; a test requests every operation in the
//! table so the document cannot list a route the router lacks.

use askama::Template;
use askama_web::WebTemplate;
use axum::http::header;
use axum::response::{IntoResponse, Response};
use serde_json::{Map, Value, json};

/// Who may call an operation.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Auth {
    Public,
    Team,
    Admin,
    /// Public, with more visible to the owning team or an admin.
    Optional,
}

/// One documented operation.
#[derive(Debug, Clone, Copy)]
pub struct Operation {
    pub method: &'static str,
    pub path: &'static str,
    pub auth: Auth,
    pub summary: &'static str,
    /// Media type of the request body, if any.
    pub body: Option<&'static str>,
    /// Success status.
    pub success: u16,
}

const fn op(method: &'static str, path: &'static str, auth: Auth, summary: &'static str, body: Option<&'static str>, success: u16) -> Operation {
    Operation { method, path, auth, summary, body, success }
}

const JSON: Option<&str> = Some("application/json");

/// Every operation of the API.
pub const OPERATIONS: &[Operation] = &[
    op("get", "/livez", Auth::Public, "Liveness: the process answers.", None, 200),
    op("get", "/readyz", Auth::Public, "Readiness: the database and the storage are reachable.", None, 200),
    op("get", "/metrics", Auth::Public, "Prometheus metrics (requests, latency, jobs and submissions by state).", None, 200),
    op("get", "/api/v1/openapi.json", Auth::Public, "This document.", None, 200),
    op("get", "/api/v1/releases", Auth::Optional, "Published releases (drafts too for admins).", None, 200),
    op("get", "/api/v1/releases/{version}", Auth::Optional, "One release; `current` names the current release.", None, 200),
    op(
        "get",
        "/api/v1/releases/{version}/manifest.json",
        Auth::Optional,
        "The manifest: every file with size and SHA-256, the digest, and one archive per sequence.",
        None,
        200,
    ),
    op(
        "get",
        "/api/v1/releases/{version}/files/{path}",
        Auth::Optional,
        "A public file or sequence archive, with Range, ETag (its SHA-256), If-None-Match and Repr-Digest.",
        None,
        200,
    ),
    op("get", "/api/v1/me", Auth::Team, "The calling team and its quota for today (UTC).", None, 200),
    op(
        "post",
        "/api/v1/submissions",
        Auth::Team,
        "Upload a submission archive (tar, tar.gz or zip; optional Content-Digest and Idempotency-Key). `?dry_run=true` validates only, free of quota; `?public=false` keeps it off the leaderboard. A repeat — the team's active submission of the same archive, or the same Idempotency-Key — answers 200 with that submission (`repeat: true`) and uses no quota.",
        Some("application/x-tar"),
        202,
    ),
    op("get", "/api/v1/submissions", Auth::Team, "The calling team's submissions.", None, 200),
    op("get", "/api/v1/submissions/{id}", Auth::Optional, "A submission: state, reason, history, jobs and its latest scores.", None, 200),
    op("patch", "/api/v1/submissions/{id}", Auth::Team, "Edit the method card (name, description, paper_url, code_url) or `public`.", JSON, 200),
    op("post", "/api/v1/submissions/{id}/cancel", Auth::Team, "Cancel a queued submission.", None, 200),
    op("get", "/api/v1/leaderboard", Auth::Public, "The leaderboard (`?release=V`); CSV with `Accept: text/csv`.", None, 200),
    op("get", "/api/v1/leaderboard.csv", Auth::Public, "The leaderboard as CSV.", None, 200),
    op(
        "get",
        "/api/v1/leaderboard/vqa",
        Auth::Public,
        "VQA accuracies in the paper's shapes: `table2` (subset × group × method × lighting, prompt-grounded) and `table3` (standard against prompt-grounded, over all lightings, with 95 % bootstrap intervals); `?table=2|3` for one.",
        None,
        200,
    ),
    op("get", "/api/v1/leaderboard/vqa.csv", Auth::Public, "One VQA table (`?table=2` or `?table=3`) as CSV.", None, 200),
    op("get", "/api/v1/jobs/{id}", Auth::Optional, "A job: state, attempts, lease and stage progress.", None, 200),
    op("post", "/api/v1/admin/teams", Auth::Admin, "Create a team: `{\"name\"}` → `{\"id\", \"name\", \"token\"}` (the token is shown once).", JSON, 201),
    op("get", "/api/v1/admin/teams", Auth::Admin, "Every team.", None, 200),
    op("patch", "/api/v1/admin/teams/{id}", Auth::Admin, "Set a team's daily quota (`{\"daily_quota\"}`; null for the default).", JSON, 200),
    op("post", "/api/v1/admin/teams/{id}/tokens", Auth::Admin, "Issue another token for a team (optional `expires_in_days`).", JSON, 201),
    op("get", "/api/v1/admin/teams/{id}/tokens", Auth::Admin, "A team's tokens (hints and states, never the tokens).", None, 200),
    op("delete", "/api/v1/admin/tokens/{id}", Auth::Admin, "Revoke a token.", None, 204),
    op(
        "post",
        "/api/v1/admin/releases",
        Auth::Admin,
        "Build a release from a config (`{\"config\"?: TOML, \"publish\"?, \"baselines\"?}`) as a job.",
        JSON,
        202,
    ),
    op(
        "post",
        "/api/v1/admin/releases/import",
        Auth::Admin,
        "Register a release built on the server's filesystem (`{\"path\", \"publish\"?}`), verifying its manifest.",
        JSON,
        201,
    ),
    op("post", "/api/v1/admin/releases/{version}/publish", Auth::Admin, "Freeze a draft into the current release.", None, 200),
    op("get", "/api/v1/admin/submissions", Auth::Admin, "Every submission.", None, 200),
    op("post", "/api/v1/admin/submissions/{id}/rescore", Auth::Admin, "Score a submission again; a new score is added, old ones stay.", None, 202),
    op("get", "/api/v1/admin/jobs", Auth::Admin, "Recent jobs.", None, 200),
];

/// Every problem `code` with what it means and what to do.
pub const PROBLEMS: &[(&str, &str)] = &[
    ("unauthenticated", "The operation needs a token: send `Authorization: Bearer osmab_…`."),
    ("token_invalid", "The token is malformed or unknown; copy the whole token, or ask for a new one."),
    ("token_revoked", "The token was revoked; ask the organisers for a new one."),
    ("token_expired", "The token expired; ask the organisers for a new one."),
    ("forbidden", "The token is valid but may not do this (team vs admin scope)."),
    ("not_found", "No such record, or not one you can see."),
    ("route_not_found", "No such route."),
    ("method_not_allowed", "The route exists but not with this method."),
    ("invalid_request", "The request body or parameters are malformed; the detail names the field."),
    ("invalid_query", "A query parameter does not parse (a number, a boolean); the detail names it."),
    ("invalid_path", "A path parameter does not parse (e.g. not UTF-8)."),
    ("invalid_digest", "The Content-Digest header is malformed."),
    ("invalid_idempotency_key", "The Idempotency-Key header is not 1 to 255 visible ASCII characters."),
    ("idempotency_key_reused", "The Idempotency-Key made an earlier submission of another archive; send a new key for a new upload."),
    ("digest_mismatch", "The upload's SHA-256 differs from its Content-Digest; upload again."),
    ("upload_incomplete", "The upload ended before Content-Length bytes arrived; upload again."),
    ("payload_too_large", "The upload is over the size limit."),
    ("request_timeout", "The request body stalled (nothing arrived for the body idle timeout); send it again."),
    ("invalid_archive", "The upload is not a readable tar, tar.gz or zip, or holds a refused entry (links, `..`, too many or too large files)."),
    ("invalid_submission", "The submission breaks the format; `errors` lists every problem with file, field and message."),
    ("release_not_open", "The release named by the submission takes no submissions (not published)."),
    ("quota_exceeded", "The team's submissions for this UTC day are used; `Retry-After` says when the next is possible. Dry runs are free."),
    ("rate_limited", "Too many write requests; `Retry-After` says when to retry."),
    ("range_not_satisfiable", "The requested byte range lies outside the file."),
    ("conflict", "The record exists or is in a state that forbids this."),
    ("not_ready", "The database or storage is unreachable."),
    ("internal", "An unexpected failure, logged with the request id."),
];

fn path_parameters(path: &str) -> Vec<Value> {
    path.split('/')
        .filter_map(|part| part.strip_prefix('{').and_then(|p| p.strip_suffix('}')))
        .map(|name| json!({"name": name, "in": "path", "required": true, "schema": {"type": "string"}}))
        .collect()
}

/// The OpenAPI 3.1 document.
pub fn document_value() -> Value {
    let mut paths = Map::new();
    for o in OPERATIONS {
        let mut operation = json!({
            "summary": o.summary,
            "operationId": format!("{}_{}", o.method, o.path.trim_start_matches('/').replace(['/', '{', '}', '.'], "_")),
            "responses": {
                o.success.to_string(): {"description": "Success"},
                "default": {"description": "An error", "content": {"application/problem+json": {"schema": {"$ref": "#/components/schemas/Problem"}}}}
            }
        });
        let parameters = path_parameters(o.path);
        if !parameters.is_empty() {
            operation["parameters"] = Value::Array(parameters);
        }
        match o.auth {
            Auth::Team | Auth::Admin => operation["security"] = json!([{"bearer": []}]),
            Auth::Optional => operation["security"] = json!([{}, {"bearer": []}]),
            Auth::Public => {}
        }
        if let Some(media) = o.body {
            let content = if media == "application/json" {
                json!({"application/json": {"schema": {"type": "object"}}})
            } else {
                json!({"application/x-tar": {"schema": {"type": "string", "format": "binary"}}, "application/gzip": {"schema": {"type": "string", "format": "binary"}}, "application/zip": {"schema": {"type": "string", "format": "binary"}}})
            };
            operation["requestBody"] = json!({"required": true, "content": content});
        }
        let entry = paths.entry(o.path.to_string()).or_insert_with(|| json!({}));
        entry[o.method] = operation;
    }
    json!({
        "openapi": "3.1.0",
        "info": {
            "title": "osmab: the OSMa-Bench++ evaluation service",
            "version": env!("CARGO_PKG_VERSION"),
            "description": "Download the frozen release, upload maps and scene graphs, follow their evaluation, read the leaderboard."
        },
        "paths": paths,
        "components": {
            "securitySchemes": {"bearer": {"type": "http", "scheme": "bearer", "description": "An API token (`osmab_` + 32 characters)."}},
            "schemas": {
                "Problem": {
                    "type": "object",
                    "required": ["type", "title", "status", "detail", "code"],
                    "properties": {
                        "type": {"type": "string"}, "title": {"type": "string"}, "status": {"type": "integer"}, "detail": {"type": "string"},
                        "code": {"type": "string", "enum": PROBLEMS.iter().map(|p| p.0).collect::<Vec<_>>()},
                        "errors": {"type": "array", "items": {"type": "object", "properties": {"file": {"type": "string"}, "field": {"type": "string"}, "message": {"type": "string"}}}}
                    }
                }
            }
        }
    })
}

/// `GET /api/v1/openapi.json`.
pub async fn document() -> Response {
    ([(header::CONTENT_TYPE, "application/json")], serde_json::to_string_pretty(&document_value()).expect("json")).into_response()
}

pub struct OperationView {
    pub method: String,
    pub path: &'static str,
    pub auth: &'static str,
    /// The summary as HTML: escaped, with `code` spans.
    pub summary_html: String,
}

/// `text` escaped for HTML, with backtick spans as `<code>`.
fn inline_code(text: &str) -> String {
    let escaped = text.replace('&', "&amp;").replace('<', "&lt;").replace('>', "&gt;").replace('"', "&quot;");
    let mut out = String::new();
    for (i, part) in escaped.split('`').enumerate() {
        if i % 2 == 1 {
            out.push_str("<code>");
            out.push_str(part);
            out.push_str("</code>");
        } else {
            out.push_str(part);
        }
    }
    out
}

#[derive(Template, WebTemplate)]
#[template(path = "api_docs.html")]
pub struct DocsPage {
    pub title: &'static str,
    pub version: &'static str,
    pub description: &'static str,
    pub operations: Vec<OperationView>,
    pub problems: Vec<(&'static str, String)>,
}

/// `GET /api/docs`: the API reference, rendered on the server (no external assets).
pub async fn docs_page() -> DocsPage {
    DocsPage {
        title: "osmab API",
        version: env!("CARGO_PKG_VERSION"),
        description: "Download the frozen release, upload maps and scene graphs, follow their evaluation, read the leaderboard.",
        operations: OPERATIONS
            .iter()
            .map(|o| OperationView {
                method: o.method.to_uppercase(),
                path: o.path,
                auth: match o.auth {
                    Auth::Public => "none",
                    Auth::Team => "team token",
                    Auth::Admin => "admin token",
                    Auth::Optional => "optional",
                },
                summary_html: inline_code(o.summary),
            })
            .collect(),
        problems: PROBLEMS.iter().map(|(code, text)| (*code, inline_code(text))).collect(),
    }
}
