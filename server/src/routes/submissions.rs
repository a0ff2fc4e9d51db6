//! Submissions: upload (or dry-run validate), list, show with history and scores, edit
//! the method card, cancel.

use std::collections::BTreeSet;

use axum::body::Body;
use axum::extract::State;
use axum::http::{HeaderMap, StatusCode, header};
use axum::response::{IntoResponse, Response};
use futures_util::StreamExt;
use serde::Deserialize;
use serde_json::{Value, json};

use super::submission_view::{SubmissionItem, SubmissionList, SubmissionView};
use super::{ApiJson, ApiPath, ApiQuery};
use crate::auth::{Caller, TeamCaller};
use crate::clock::{next_utc_day, now_ms, rfc3339, utc_day_start};
use crate::intake::{Scratch, check, declared_sha256, hex, idempotency_key, receive, record, release_not_open, too_large};
use crate::problem::{ApiResult, Problem};
use crate::state::AppState;
use crate::store::{JobState, Recorded, ReleaseState, StoreError, SubmissionRecord, SubmissionState, Team};

#[derive(Debug, Deserialize)]
pub struct UploadQuery {
    /// Validate only: nothing is stored and no quota is used.
    #[serde(default)]
    dry_run: bool,
    /// Show the submission on the public leaderboard (default true).
    public: Option<bool>,
}

/// The quota of `team` today: (limit, used, resets at).
async fn quota(state: &AppState, team: &Team) -> ApiResult<(i64, i64, i64)> {
    let now = now_ms();
    let limit = team.daily_quota.unwrap_or(state.settings.daily_quota);
    let used = state.store.submissions_since(&team.id, utc_day_start(now)).await?;
    Ok((limit, used, next_utc_day(now)))
}

fn quota_json((limit, used, resets): (i64, i64, i64)) -> Value {
    json!({"limit": limit, "used": used, "remaining": (limit - used).max(0), "resets_at": rfc3339(resets)})
}

fn quota_exceeded((limit, used, resets): (i64, i64, i64)) -> Problem {
    let seconds = ((resets - now_ms()) / 1000).max(1) as u64;
    Problem::new(
        StatusCode::TOO_MANY_REQUESTS,
        "quota_exceeded",
        "Daily submission quota used",
        format!(
            "Your team has used {used} of its {limit} submissions for this UTC day; the next one is possible at {}. Dry runs (?dry_run=true) are free.",
            rfc3339(resets)
        ),
    )
    .with("quota", quota_json((limit, used, resets)))
    .retry_after(seconds)
}

/// `GET /api/v1/me`: the calling team and its quota.
pub async fn me(State(state): State<AppState>, TeamCaller(team): TeamCaller) -> ApiResult<axum::Json<Value>> {
    let q = quota(&state, &team).await?;
    Ok(axum::Json(json!({"team": {"id": team.id, "name": team.name}, "quota": quota_json(q)})))
}

/// The answer to an upload that repeats the team's earlier submission: that submission
/// (200, no quota used), or 422 when its idempotency key was used for another archive.
async fn answer_repeat(state: &AppState, team: &Team, earlier: Recorded) -> ApiResult<Response> {
    match earlier {
        Recorded::Repeat(id) => {
            let s = state.store.submission(&id).await?;
            tracing::info!(submission = %id, team = %team.name, "repeated upload answered with the earlier submission");
            let location = format!("/api/v1/submissions/{id}");
            let body =
                json!({"id": id, "state": s.state, "complete": s.complete, "repeat": true, "quota": quota_json(quota(state, team).await?), "url": location});
            Ok((StatusCode::OK, [(header::LOCATION, location)], axum::Json(body)).into_response())
        }
        Recorded::KeyReused(id) => Err(Problem::new(
            StatusCode::UNPROCESSABLE_ENTITY,
            "idempotency_key_reused",
            "Idempotency key reused",
            format!(
                "This Idempotency-Key was used for submission {id} of another archive. Send a new key for a new upload; nothing was stored and no quota was used."
            ),
        )),
        other => Err(Problem::internal(format!("not a repeat: {other:?}"))),
    }
}

/// `POST /api/v1/submissions[?dry_run=true]`: the body is the archive.
/// Bodies up to this size are read and dropped before an early refusal is sent.
const DRAIN_LIMIT: u64 = 64 << 20;

/// `problem`, after reading and dropping `body` when it is declared no larger than
/// [`DRAIN_LIMIT`] (for at most 30 s); a larger or undeclared one is left unread.
async fn drain_then(body: Body, declared_length: Option<u64>, problem: Problem) -> Problem {
    if declared_length.is_some_and(|n| n <= DRAIN_LIMIT) {
        let mut stream = body.into_data_stream();
        let mut read = 0u64;
        let drain = async {
            while let Some(Ok(chunk)) = stream.next().await {
                read += chunk.len() as u64;
                if read > DRAIN_LIMIT {
                    break;
                }
            }
        };
        let _ = tokio::time::timeout(std::time::Duration::from_secs(30), drain).await;
    }
    problem
}

pub async fn create(
    State(state): State<AppState>,
    caller: Result<TeamCaller, Problem>,
    query: Result<ApiQuery<UploadQuery>, Problem>,
    headers: HeaderMap,
    body: Body,
) -> ApiResult<Response> {
    let max = state.settings.max_upload_bytes;
    let declared_length = headers.get(header::CONTENT_LENGTH).and_then(|v| v.to_str().ok()).and_then(|v| v.parse::<u64>().ok());
    // Refusals before the upload is read still read (and drop) a modest body first:
    // a client answered while it is still sending sees a broken pipe, not the answer.
    let TeamCaller(team) = match caller {
        Ok(caller) => caller,
        Err(problem) => return Err(drain_then(body, declared_length, problem).await),
    };
    let ApiQuery(query) = match query {
        Ok(query) => query,
        Err(problem) => return Err(drain_then(body, declared_length, problem).await),
    };
    let key = match idempotency_key(&headers) {
        Ok(key) => key,
        Err(problem) => return Err(drain_then(body, declared_length, problem).await),
    };
    let declared_digest = match headers.get("content-digest").and_then(|v| v.to_str().ok()).map(declared_sha256) {
        Some(Ok(digest)) => digest,
        Some(Err(problem)) => return Err(drain_then(body, declared_length, problem).await),
        None => None,
    };
    if !query.dry_run {
        let q = quota(&state, &team).await?;
        // A repeat costs no quota: with the quota used up, an upload that names an earlier
        // submission (its key, or its declared digest) is still read and answered.
        let may_repeat = match (&key, declared_digest) {
            (None, None) => false,
            _ => {
                let digest = declared_digest.map(|d| hex(&d)).unwrap_or_default();
                state.store.repeated_submission(&team.id, &digest, key.as_deref()).await?.is_some()
            }
        };
        if q.1 >= q.0 && !may_repeat {
            return Err(drain_then(body, declared_length, quota_exceeded(q)).await);
        }
    }
    if declared_length.is_some_and(|n| n > max) {
        return Err(too_large(max));
    }
    let (upload, _upload_scratch) = receive(&state, body, max).await?;
    if let Some(length) = declared_length
        && length != upload.size
    {
        return Err(Problem::bad_request("upload_incomplete", format!("Content-Length said {length} bytes but {} arrived. Upload again.", upload.size)));
    }
    if let Some(expected) = declared_digest
        && expected != upload.sha256
    {
        return Err(Problem::new(
            StatusCode::UNPROCESSABLE_ENTITY,
            "digest_mismatch",
            "Checksum mismatch",
            format!(
                "The upload's SHA-256 is {} but Content-Digest declared another; the file changed or was corrupted on the way. Nothing was stored; upload again.",
                upload.sha256_hex()
            ),
        ));
    }
    if !query.dry_run
        && let Some(earlier) = state.store.repeated_submission(&team.id, &upload.sha256_hex(), key.as_deref()).await?
    {
        return answer_repeat(&state, &team, earlier).await;
    }
    let validating_at = now_ms();
    let current = state.store.current_release().await.ok().map(|r| r.version);
    let open: BTreeSet<String> = state.store.releases().await?.into_iter().filter(|r| r.state == ReleaseState::Published).map(|r| r.version).collect();
    let unpack_to = Scratch(state.blobs.scratch("unpack"));
    let (state_for_check, upload_path, unpack_path) = (state.clone(), upload.path.clone(), unpack_to.0.clone());
    // Unpacking and validation are heavy (disk and memory): a few at a time, the rest wait.
    let _permit = state.validation.acquire().await.map_err(Problem::internal)?;
    let (valid, _) = tokio::task::spawn_blocking(move || check(&state_for_check, &upload_path, &unpack_path, current.as_deref(), Some(&open)))
        .await
        .map_err(Problem::internal)??;
    // Published while this upload was checked is fine; withdrawn meanwhile is not.
    match state.store.release(&valid.release).await {
        Ok(r) if r.state == ReleaseState::Published => {}
        Ok(_) | Err(StoreError::NotFound) => return Err(release_not_open(&valid.release)),
        Err(e) => return Err(e.into()),
    }
    if query.dry_run {
        return Ok(axum::Json(json!({
            "valid": true,
            "release": valid.release,
            "method": valid.method,
            "complete": valid.complete,
            "missing_maps": valid.missing_maps,
            "entries": valid.entries.iter().map(|e| json!({"lighting": e.lighting, "scene": e.scene, "map": e.map.is_some(), "graph": e.graph.is_some(), "answers": e.answers.is_some()})).collect::<Vec<_>>(),
            "points": valid.points,
            "size": upload.size,
            "sha256": upload.sha256_hex(),
        }))
        .into_response());
    }
    // The quota again: another upload of the same team may have finished meanwhile.
    let q = quota(&state, &team).await?;
    if q.1 >= q.0 {
        return Err(quota_exceeded(q));
    }
    let recorded =
        record(&state, &team, &upload, &valid, query.public.unwrap_or(true), false, validating_at, Some((q.0, utc_day_start(now_ms()))), key.as_deref())
            .await?;
    let id = match recorded {
        Recorded::New(id) => id,
        Recorded::QuotaExceeded => return Err(quota_exceeded(quota(&state, &team).await?)),
        earlier => return answer_repeat(&state, &team, earlier).await,
    };
    tracing::info!(submission = %id, team = %team.name, size = upload.size, "submission accepted");
    let location = format!("/api/v1/submissions/{id}");
    let body = json!({"id": id, "state": "queued", "complete": valid.complete, "missing_maps": valid.missing_maps, "quota": quota_json((q.0, q.1 + 1, q.2)), "url": location});
    Ok((StatusCode::ACCEPTED, [(header::LOCATION, location)], axum::Json(body)).into_response())
}

/// A submission the caller may see: public ones to everyone, private ones to their team and admins.
pub async fn visible_submission(state: &AppState, caller: &Caller, id: &str) -> ApiResult<SubmissionRecord> {
    match state.store.submission(id).await {
        Ok(s) if s.public || s.baseline || caller.can_see_team(&s.team_id) => Ok(s),
        Ok(_) | Err(StoreError::NotFound) => Err(Problem::not_found(format!("There is no submission '{id}' you can see."))),
        Err(e) => Err(e.into()),
    }
}

/// `GET /api/v1/submissions/{id}`.
pub async fn show(State(state): State<AppState>, caller: Caller, ApiPath(id): ApiPath<String>) -> ApiResult<axum::Json<SubmissionView>> {
    let s = visible_submission(&state, &caller, &id).await?;
    Ok(axum::Json(SubmissionView::load(&state, &s).await?))
}

/// `GET /api/v1/submissions`: the calling team's submissions.
pub async fn list(State(state): State<AppState>, TeamCaller(team): TeamCaller) -> ApiResult<axum::Json<SubmissionList>> {
    let submissions = state.store.submissions(Some(&team.id), 500).await?.iter().map(SubmissionItem::from).collect();
    Ok(axum::Json(SubmissionList { submissions }))
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MethodCardUpdate {
    name: Option<String>,
    description: Option<String>,
    paper_url: Option<Option<String>>,
    code_url: Option<Option<String>>,
    public: Option<bool>,
}

/// `PATCH /api/v1/submissions/{id}`: edit the method card or visibility (own team or admin).
pub async fn update(
    State(state): State<AppState>,
    caller: Caller,
    ApiPath(id): ApiPath<String>,
    change: Result<ApiJson<MethodCardUpdate>, Problem>,
) -> ApiResult<axum::Json<SubmissionView>> {
    let mut s = visible_submission(&state, &caller, &id).await?;
    caller.may_change(&s.team_id, "edit a submission")?;
    // The body is looked at only once the caller may edit.
    let ApiJson(change) = change?;
    if let Some(name) = change.name {
        s.method_name = name.trim().to_string();
    }
    if let Some(description) = change.description {
        s.method_description = description;
    }
    if let Some(url) = change.paper_url {
        s.paper_url = url;
    }
    if let Some(url) = change.code_url {
        s.code_url = url;
    }
    if let Some(public) = change.public {
        s.public = public;
    }
    let card = osmab_evaluator::submission::MethodCard {
        name: s.method_name.clone(),
        description: s.method_description.clone(),
        paper_url: s.paper_url.clone(),
        code_url: s.code_url.clone(),
    };
    card.check("request body")
        .map_err(|e| Problem::new(StatusCode::UNPROCESSABLE_ENTITY, "invalid_request", "Invalid method card", format!("{}: {}", e.field, e.message)))?;
    state.store.update_method_card(&id, &s, now_ms()).await?;
    state.leaderboard.invalidate();
    Ok(axum::Json(SubmissionView::load(&state, &state.store.submission(&id).await?).await?))
}

/// `POST /api/v1/submissions/{id}/cancel`: stop a submission that is not scored yet.
pub async fn cancel(State(state): State<AppState>, caller: Caller, ApiPath(id): ApiPath<String>) -> ApiResult<axum::Json<SubmissionView>> {
    let s = visible_submission(&state, &caller, &id).await?;
    caller.may_change(&s.team_id, "cancel a submission")?;
    let reason = if matches!(caller, Caller::Admin) { "cancelled by an admin" } else { "cancelled by the team" };
    if !state.store.set_submission_state(&id, &[SubmissionState::Queued], SubmissionState::Cancelled, Some(reason), now_ms()).await? {
        return Err(Problem::conflict(format!("The submission is {}; only queued submissions can be cancelled.", s.state)));
    }
    for job in state.store.jobs_for(&id).await? {
        if job.state == JobState::Queued {
            let _ = state.store.cancel_job(&job.id, now_ms()).await;
        }
    }
    Ok(axum::Json(SubmissionView::load(&state, &state.store.submission(&id).await?).await?))
}
