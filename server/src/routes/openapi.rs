//! The OpenAPI 3.1 document (`/api/v1/openapi.json`), generated from one table of
//! operations; `api_docs.rs` renders the same document as a page (`/api/docs`). Every request body, query and JSON
//! response is described by the schema of the Rust type the handler takes or returns
//! (derived with schemars, JSON Schema 2020-12 — OpenAPI 3.1's dialect), so the document
//! follows the code. A test requests every operation in the table, so the document
//! cannot list a route the router lacks, and checks that every JSON response has a schema.

use axum::http::header;
use axum::response::{IntoResponse, Response};
use schemars::generate::{SchemaGenerator, SchemaSettings};
use schemars::{JsonSchema, Schema};
use serde_json::{Map, Value, json};

use super::admin::{
    AdminSubmissionList, BuildBody, CreatedTeam, ImportBody, IssuedToken, JobList, NewTeam, NewToken, QueuedJob, TeamList, TeamUpdate, TokenList,
};
use super::health::{Live, Ready};
use super::jobs::JobView;
use super::leaderboard::{LeaderboardQuery, VqaQuery, VqaTables};
use super::releases::{ReleaseList, ReleaseSummary};
use super::submission_view::{SubmissionList, SubmissionView};
use super::submissions::{Created, DryRun, Me, MethodCardUpdate, UploadQuery};
use crate::leaderboard::Leaderboard;

/// Who may call an operation.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Auth {
    Public,
    Team,
    Admin,
    /// Public, with more visible to the owning team or an admin.
    Optional,
}

/// What a successful response carries.
#[derive(Debug, Clone, Copy)]
pub enum Body {
    /// JSON described by a type's schema.
    Json(fn(&mut SchemaGenerator) -> Schema),
    /// JSON whose shape a release defines (its manifest).
    FreeJson,
    /// Another media type (`text/csv`, a file, Prometheus text).
    Other(&'static str),
    /// Nothing (204).
    Empty,
}

/// What a request carries besides its path.
#[derive(Debug, Clone, Copy)]
pub enum Input {
    /// Nothing.
    None,
    /// A JSON body of a type.
    Json(fn(&mut SchemaGenerator) -> Schema),
    /// A submission archive.
    Archive,
    /// A chunk of a resumable upload (`application/offset+octet-stream`).
    Chunk,
}

/// One documented operation.
#[derive(Debug, Clone, Copy)]
pub struct Operation {
    pub method: &'static str,
    pub path: &'static str,
    pub auth: Auth,
    pub summary: &'static str,
    pub input: Input,
    /// Query parameters: the properties of a type's schema.
    pub query: Option<fn() -> Schema>,
    /// Success status.
    pub success: u16,
    pub output: Body,
}

/// The schema of `T`, as a reference into the document's components.
fn schema_of<T: JsonSchema>(generator: &mut SchemaGenerator) -> Schema {
    generator.subschema_for::<T>()
}

/// The whole schema of `T` (for query parameters).
fn root_of<T: JsonSchema>() -> Schema {
    SchemaSettings::draft2020_12().for_deserialize().into_generator().into_root_schema_for::<T>()
}

const fn op(method: &'static str, path: &'static str, auth: Auth, summary: &'static str, success: u16) -> Operation {
    Operation { method, path, auth, summary, input: Input::None, query: None, success, output: Body::Empty }
}

impl Operation {
    /// Answers JSON of type `T`.
    const fn returns<T: JsonSchema>(self) -> Self {
        Operation { output: Body::Json(schema_of::<T>), ..self }
    }
    /// Answers another media type.
    const fn returns_other(self, media: &'static str) -> Self {
        Operation { output: Body::Other(media), ..self }
    }
    /// Takes a JSON body of type `T`.
    const fn takes<T: JsonSchema>(self) -> Self {
        Operation { input: Input::Json(schema_of::<T>), ..self }
    }
    /// Takes the query parameters of `T`.
    const fn query<T: JsonSchema>(self) -> Self {
        Operation { query: Some(root_of::<T>), ..self }
    }
}

/// The answer to an upload: a submission (new, or the earlier one repeated) or, for a
/// dry run, the validation report.
#[derive(schemars::JsonSchema)]
#[serde(untagged)]
#[allow(dead_code)]
enum UploadAnswer {
    Submission(Created),
    DryRun(DryRun),
}

/// Every operation of the API.
pub const OPERATIONS: &[Operation] = &[
    op("get", "/livez", Auth::Public, "Liveness: the process answers.", 200).returns::<Live>(),
    op("get", "/readyz", Auth::Public, "Readiness: the database and the storage are reachable.", 200).returns::<Ready>(),
    op("get", "/metrics", Auth::Admin, "Prometheus metrics (requests, latency, jobs and submissions by state); the admin token only.", 200).returns_other("text/plain"),
    Operation { output: Body::FreeJson, ..op("get", "/api/v1/openapi.json", Auth::Public, "This document.", 200) },
    op("get", "/api/v1/releases", Auth::Optional, "Published releases (drafts too for admins).", 200).returns::<ReleaseList>(),
    op("get", "/api/v1/releases/{version}", Auth::Optional, "One release; `current` names the current release.", 200).returns::<ReleaseSummary>(),
    Operation {
        output: Body::FreeJson,
        ..op(
            "get",
            "/api/v1/releases/{version}/manifest.json",
            Auth::Optional,
            "The manifest: every file with size and SHA-256, the digest, and one archive per sequence.",
            200,
        )
    },
    op(
        "get",
        "/api/v1/releases/{version}/files/{path}",
        Auth::Optional,
        "A public file or sequence archive, with Range, ETag (its SHA-256), If-None-Match and Repr-Digest.",
        200,
    )
    .returns_other("application/octet-stream"),
    op("get", "/api/v1/me", Auth::Team, "The calling team and its quota for the split uploads go to by default.", 200).returns::<Me>(),
    op(
        "get",
        "/api/v1/quota",
        Auth::Team,
        "Before uploading: the team's quota of every split (limit, used, remaining, window, when the next submission is possible) and the split an upload goes to by default.",
        200,
    )
    .returns::<super::submissions::Quotas>(),
    Operation {
        input: Input::Archive,
        ..op(
            "post",
            "/api/v1/submissions",
            Auth::Team,
            "Upload a submission archive (tar, tar.gz or zip; optional Content-Digest and Idempotency-Key). `?dry_run=true` validates only, free of quota; `?public=false` keeps it off the leaderboard; `?upload=ID` submits a completed resumable upload instead of a body, answered exactly as a direct upload. A repeat — the team's active submission of the same archive, or the same Idempotency-Key — answers 200 with that submission (`repeat: true`) and uses no quota.",
            202,
        )
        .query::<UploadQuery>()
        .returns::<UploadAnswer>()
    },
    op(
        "options",
        "/api/v1/uploads",
        Auth::Public,
        "Resumable uploads (tus 1.0.0): `Tus-Version`, `Tus-Extension` (creation, checksum, termination, expiration), `Tus-Max-Size`, `Tus-Checksum-Algorithm` (sha256).",
        204,
    ),
    op(
        "post",
        "/api/v1/uploads",
        Auth::Team,
        "Start a resumable upload: `Tus-Resumable: 1.0.0`, `Upload-Length` (bytes), optional `Upload-Metadata`. Answers 201 with `Location` and `Upload-Expires`; refused early (429) when the team's quota is used.",
        201,
    ),
    op(
        "head",
        "/api/v1/uploads/{id}",
        Auth::Team,
        "Where a resumable upload stands: `Upload-Offset`, `Upload-Length`, `Upload-Expires`. Any server answers; resume from this offset after a dropped connection.",
        200,
    ),
    Operation {
        input: Input::Chunk,
        ..op(
            "patch",
            "/api/v1/uploads/{id}",
            Auth::Team,
            "Send bytes at `Upload-Offset` (`Content-Type: application/offset+octet-stream`, optional `Upload-Checksum: sha256 BASE64`). Answers 204 with the new `Upload-Offset`; 409 on a wrong offset, 460 on a checksum mismatch. When `Upload-Offset` reaches `Upload-Length`, submit with `POST /api/v1/submissions?upload=ID`.",
            204,
        )
    },
    op("delete", "/api/v1/uploads/{id}", Auth::Team, "Abandon a resumable upload and its parts.", 204),
    op("get", "/api/v1/submissions", Auth::Team, "The calling team's submissions.", 200).returns::<SubmissionList>(),
    op("get", "/api/v1/submissions/{id}", Auth::Optional, "A submission: state, reason, history, jobs and its latest scores.", 200).returns::<SubmissionView>(),
    op("patch", "/api/v1/submissions/{id}", Auth::Team, "Edit the method card (name, description, paper_url, code_url) or `public`.", 200)
        .takes::<MethodCardUpdate>()
        .returns::<SubmissionView>(),
    op("post", "/api/v1/submissions/{id}/cancel", Auth::Team, "Cancel a queued submission.", 200).returns::<SubmissionView>(),
    op(
        "get",
        "/api/v1/submissions/{id}/receipt",
        Auth::Optional,
        "The signed receipt of the latest score: a compact JWS (EdDSA, Ed25519, `kid` in the header) of the upload's SHA-256, the release and its digest, the evaluator version, the SHA-256 of the full results document and the headline numbers; the JWS alone with `Accept: application/jose`. Verify with `osmab client verify` or any JOSE library against `/api/v1/keys`.",
        200,
    )
    .returns::<super::receipts::SignedReceipt>(),
    Operation {
        output: Body::FreeJson,
        ..op(
            "get",
            "/api/v1/submissions/{id}/results.json",
            Auth::Optional,
            "The full results document of the latest score (every lighting and scene), byte for byte what the receipt's `results_sha256` names.",
            200,
        )
    },
    op("get", "/api/v1/keys", Auth::Public, "The public keys of receipts as a JWKS (RFC 7517; `kty` OKP, `crv` Ed25519), the signing key first; retired keys stay listed.", 200)
        .returns::<crate::receipts::jws::Jwks>(),
    op("get", "/api/v1/leaderboard", Auth::Public, "The leaderboard (`?release=V`); CSV with `Accept: text/csv`.", 200)
        .query::<LeaderboardQuery>()
        .returns::<Leaderboard>(),
    op("get", "/api/v1/leaderboard.csv", Auth::Public, "The leaderboard as CSV.", 200).query::<LeaderboardQuery>().returns_other("text/csv"),
    op(
        "get",
        "/api/v1/leaderboard/vqa",
        Auth::Public,
        "VQA accuracies in the paper's shapes: `table2` (subset × group × method × lighting, prompt-grounded) and `table3` (standard against prompt-grounded, over all lightings, with 95 % bootstrap intervals); `?table=2|3` for one.",
        200,
    )
    .query::<VqaQuery>()
    .returns::<VqaTables>(),
    op("get", "/api/v1/leaderboard/vqa.csv", Auth::Public, "One VQA table (`?table=2` or `?table=3`) as CSV.", 200).query::<VqaQuery>().returns_other("text/csv"),
    op("get", "/api/v1/jobs/{id}", Auth::Optional, "A job: state, attempts, lease and stage progress.", 200).returns::<JobView>(),
    op("post", "/api/v1/admin/teams", Auth::Admin, "Create a team: `{\"name\"}` → `{\"id\", \"name\", \"token\"}` (the token is shown once).", 201)
        .takes::<NewTeam>()
        .returns::<CreatedTeam>(),
    op("get", "/api/v1/admin/teams", Auth::Admin, "Every team.", 200).returns::<TeamList>(),
    op("patch", "/api/v1/admin/teams/{id}", Auth::Admin, "Set a team's daily quota (`{\"daily_quota\"}`; null for the default).", 200)
        .takes::<TeamUpdate>()
        .returns::<super::admin::TeamView>(),
    op("post", "/api/v1/admin/teams/{id}/tokens", Auth::Admin, "Issue another token for a team (optional `expires_in_days`).", 201)
        .takes::<NewToken>()
        .returns::<IssuedToken>(),
    op("get", "/api/v1/admin/teams/{id}/tokens", Auth::Admin, "A team's tokens (hints and states, never the tokens).", 200).returns::<TokenList>(),
    op("delete", "/api/v1/admin/tokens/{id}", Auth::Admin, "Revoke a token.", 204),
    op("post", "/api/v1/admin/releases", Auth::Admin, "Build a release from a config (`{\"config\"?: TOML, \"publish\"?, \"baselines\"?}`) as a job.", 202)
        .takes::<BuildBody>()
        .returns::<QueuedJob>(),
    op(
        "post",
        "/api/v1/admin/releases/import",
        Auth::Admin,
        "Register a release built on the server's filesystem (`{\"path\", \"publish\"?}`), verifying its manifest.",
        201,
    )
    .takes::<ImportBody>()
    .returns::<ReleaseSummary>(),
    op("post", "/api/v1/admin/releases/{version}/publish", Auth::Admin, "Freeze a draft into the current release.", 200).returns::<ReleaseSummary>(),
    op("get", "/api/v1/admin/submissions", Auth::Admin, "Every submission.", 200).returns::<AdminSubmissionList>(),
    op("post", "/api/v1/admin/submissions/{id}/rescore", Auth::Admin, "Score a submission again; a new score is added, old ones stay.", 202)
        .returns::<QueuedJob>(),
    op("get", "/api/v1/admin/jobs", Auth::Admin, "Recent jobs.", 200).returns::<JobList>(),
    op("put", "/api/v1/admin/submissions/{id}/flag", Auth::Admin, "Flag an entry (`{\"reason\"}`): the reason shows on the leaderboard and the submission's page.", 200)
        .takes::<super::admin::FlagBody>()
        .returns::<SubmissionView>(),
    op("delete", "/api/v1/admin/submissions/{id}/flag", Auth::Admin, "Clear an entry's flag.", 204),
    op(
        "post",
        "/api/v1/admin/submissions/{id}/refund",
        Auth::Admin,
        "Give back the quota unit a submission used (failures that were not the team's are refunded automatically).",
        200,
    )
    .returns::<super::admin::Refunded>(),
    op("get", "/api/v1/admin/quotas", Auth::Admin, "The limit of every split (submissions per rolling window), set or default.", 200)
        .returns::<super::quota_policies::PolicyList>(),
    op("put", "/api/v1/admin/quotas/{split}", Auth::Admin, "Set a split's limit: `{\"limit\", \"window_hours\"}`.", 200)
        .takes::<super::quota_policies::PolicyBody>()
        .returns::<super::quota_policies::PolicyView>(),
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
    (
        "upload_incomplete",
        "The upload ended before Content-Length bytes arrived (upload again), or a resumable upload was submitted before all its bytes arrived.",
    ),
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
    ("storage_unavailable", "The object storage cannot be reached right now; nothing was stored and no quota was used. Retry after `Retry-After`."),
    ("tus_version", "A resumable-upload request without `Tus-Resumable: 1.0.0`."),
    ("invalid_header", "A header of a resumable upload is missing or malformed; the detail names it."),
    ("invalid_metadata", "`Upload-Metadata` is not comma-separated `KEY BASE64` pairs, or over 4 KiB."),
    ("unsupported_media_type", "A resumable-upload PATCH without `Content-Type: application/offset+octet-stream`."),
    ("offset_mismatch", "`Upload-Offset` is not where the upload stands (another request appended first); `offset` says where, or ask with HEAD."),
    ("upload_overrun", "More bytes than the upload's `Upload-Length`."),
    ("checksum_algorithm", "`Upload-Checksum` names an algorithm other than sha256."),
    ("checksum_mismatch", "The chunk's SHA-256 differs from its `Upload-Checksum` (status 460); nothing was kept, send it again."),
    ("upload_expired", "The resumable upload expired before it was complete; start a new one."),
    ("too_many_uploads", "The team holds `OSMAB_MAX_OPEN_UPLOADS` resumable uploads open (429); finish or DELETE one, or let it expire."),
    ("open_uploads_too_large", "The team's open resumable uploads would declare more than `OSMAB_MAX_OPEN_UPLOAD_BYTES` (413); finish or DELETE one."),
    ("internal", "An unexpected failure, logged with the request id."),
];

fn path_parameters(path: &str) -> Vec<Value> {
    path.split('/')
        .filter_map(|part| part.strip_prefix('{').and_then(|p| p.strip_suffix('}')))
        .map(|name| json!({"name": name, "in": "path", "required": true, "schema": {"type": "string"}}))
        .collect()
}

/// The query parameters of a type's schema: one per property, required where the type requires it.
fn query_parameters(schema: &Schema) -> Vec<Value> {
    let object = schema.as_object().cloned().unwrap_or_default();
    let required: Vec<Value> = object.get("required").and_then(Value::as_array).cloned().unwrap_or_default();
    let properties = object.get("properties").and_then(Value::as_object).cloned().unwrap_or_default();
    properties
        .into_iter()
        .map(|(name, mut property)| {
            let description = property.as_object_mut().and_then(|p| p.remove("description"));
            let mut parameter = json!({"name": name, "in": "query", "required": required.contains(&json!(name)), "schema": property});
            if let Some(description) = description {
                parameter["description"] = description;
            }
            parameter
        })
        .collect()
}

/// The OpenAPI 3.1 document.
pub fn document_value() -> Value {
    // Answers are described as the server writes them, request bodies as it reads them.
    let settings = SchemaSettings::draft2020_12().with(|s| s.definitions_path = "/components/schemas".into());
    let mut generator = settings.clone().for_serialize().into_generator();
    let mut request_generator = settings.for_deserialize().into_generator();
    let mut paths = Map::new();
    for o in OPERATIONS {
        let success = match o.output {
            Body::Json(schema) => json!({"description": "Success", "content": {"application/json": {"schema": schema(&mut generator)}}}),
            Body::FreeJson => json!({"description": "Success", "content": {"application/json": {"schema": {"type": "object"}}}}),
            Body::Other(media) => json!({"description": "Success", "content": {media: {"schema": {"type": "string"}}}}),
            Body::Empty => json!({"description": "Success, no content"}),
        };
        let mut operation = json!({
            "summary": o.summary,
            "operationId": format!("{}_{}", o.method, o.path.trim_start_matches('/').replace(['/', '{', '}', '.'], "_")),
            "responses": {
                o.success.to_string(): success,
                "default": {"description": "An error", "content": {"application/problem+json": {"schema": {"$ref": "#/components/schemas/Problem"}}}}
            }
        });
        let mut parameters = path_parameters(o.path);
        if let Some(query) = o.query {
            parameters.extend(query_parameters(&query()));
        }
        if !parameters.is_empty() {
            operation["parameters"] = Value::Array(parameters);
        }
        match o.auth {
            Auth::Team | Auth::Admin => operation["security"] = json!([{"bearer": []}]),
            Auth::Optional => operation["security"] = json!([{}, {"bearer": []}]),
            Auth::Public => {}
        }
        match o.input {
            Input::None => {}
            Input::Json(schema) => {
                operation["requestBody"] = json!({"required": true, "content": {"application/json": {"schema": schema(&mut request_generator)}}})
            }
            Input::Chunk => {
                let binary = json!({"type": "string", "format": "binary"});
                operation["requestBody"] = json!({"required": true, "content": {"application/offset+octet-stream": {"schema": binary}}});
            }
            Input::Archive => {
                let binary = json!({"type": "string", "format": "binary"});
                operation["requestBody"] = json!({"required": true, "content": {"application/x-tar": {"schema": binary}, "application/gzip": {"schema": binary}, "application/zip": {"schema": binary}}});
            }
        }
        let entry = paths.entry(o.path.to_string()).or_insert_with(|| json!({}));
        entry[o.method] = operation;
    }
    let mut schemas = generator.take_definitions(true);
    for (name, schema) in request_generator.take_definitions(true) {
        let clash = schemas.get(&name).is_some_and(|known| *known != schema);
        assert!(!clash, "{name} is both a request and an answer with different schemas");
        schemas.insert(name, schema);
    }
    schemas.insert(
        "Problem".into(),
        json!({
            "type": "object",
            "required": ["type", "title", "status", "detail", "code"],
            "properties": {
                "type": {"type": "string"}, "title": {"type": "string"}, "status": {"type": "integer"}, "detail": {"type": "string"},
                "code": {"type": "string", "enum": PROBLEMS.iter().map(|p| p.0).collect::<Vec<_>>()},
                "errors": {"type": "array", "items": {"type": "object", "properties": {"file": {"type": "string"}, "field": {"type": "string"}, "message": {"type": "string"}}}}
            }
        }),
    );
    json!({
        "openapi": "3.1.0",
        "jsonSchemaDialect": "https://json-schema.org/draft/2020-12/schema",
        "info": {
            "title": "osmab: the OSMa-Bench++ evaluation service",
            "version": env!("CARGO_PKG_VERSION"),
            "description": "Download the frozen release, upload maps and scene graphs, follow their evaluation, read the leaderboard."
        },
        "paths": paths,
        "components": {
            "securitySchemes": {"bearer": {"type": "http", "scheme": "bearer", "description": "An API token (`osmab_` + 32 characters)."}},
            "schemas": schemas
        }
    })
}

/// `GET /api/v1/openapi.json`.
pub async fn document() -> Response {
    ([(header::CONTENT_TYPE, "application/json")], serde_json::to_string_pretty(&document_value()).expect("json")).into_response()
}
