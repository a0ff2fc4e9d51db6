//! Submissions: upload (or dry-run validate), list, show with history and scores, edit
//! the method card, cancel.

use axum::body::Body;
use axum::extract::State;
use axum::http::{HeaderMap, StatusCode, header};
use axum::response::{IntoResponse, Response};
use futures_util::StreamExt;
use osmab_evaluator::scores::Split;
use serde::Deserialize;

use super::extract::{ApiJson, ApiPath, ApiQuery};
use super::operation::{ApiRoutes, Auth, Input, Operation, Verb};
use super::submission_view::{self, CoveredEntry, Created, DryRun, SubmissionItem, SubmissionList, SubmissionView, UploadAnswer};
use crate::auth::{Caller, SignedInCaller, TeamCaller};
use crate::clock::now_ms;
use crate::intake::{self, Accepted, Quota, declared_sha256, hex, idempotency_key, quota_exceeded, receive, too_large};
use crate::problem::{ApiResult, Problem, ProblemCode};
use crate::state::AppState;
use crate::store::{JobState, StoreError, SubmissionRecord, SubmissionState};
use crate::uploads::{self, Assembled};

#[derive(Debug, Deserialize, schemars::JsonSchema)]
pub struct UploadQuery {
    /// Validate only: nothing is stored and no quota is used.
    #[serde(default)]
    dry_run: bool,
    /// Show the submission on the public leaderboard (default true).
    public: Option<bool>,
    /// The split to submit to: `test` (the hidden scenes, the main board; few per window)
    /// or `val` (the open scenes, their own board). Default: the release's test split when
    /// it has one, else val.
    split: Option<Split>,
    /// Submit the completed resumable upload with this id (`/api/v1/uploads`) instead of
    /// a request body.
    upload: Option<String>,
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
    let declared_length = headers.get(header::CONTENT_LENGTH).and_then(|v| v.to_str().ok()).and_then(|v| v.parse::<u64>().ok());
    // Refusals before the upload is read still read (and drop) a modest body first:
    // a client answered while it is still sending sees a broken pipe, not the answer.
    let (team, query, declared) = match read_request(caller, query, &headers) {
        Ok(read) => read,
        Err(problem) => return Err(drain_then(body, declared_length, problem).await),
    };
    // A completed resumable upload instead of a body: joined from its parts, then taken
    // exactly as a direct upload.
    let assembled = match query.upload.as_deref() {
        Some(upload_id) => match uploads::assemble(&state, &team, upload_id).await {
            Ok(Assembled::Finished(id)) => return Ok(located(repeat_answer(&state, &team, id).await?)),
            Ok(Assembled::Ready(upload, scratch)) => Some((upload, scratch)),
            Err(problem) => return Err(drain_then(body, declared_length, problem).await),
        },
        None => None,
    };
    if !query.dry_run
        && let Some(problem) = quota_refusal(&state, &team, &query, &declared).await?
    {
        return Err(drain_then(body, declared_length, problem).await);
    }
    let (upload, _upload_scratch) = match assembled {
        Some(assembled) => assembled,
        None => read_body(&state, body, declared_length).await?,
    };
    declared.check(&upload)?;
    let accepted = accept(&state, &team, &upload, &query, declared.key).await?;
    let answer = match accepted {
        Accepted::Valid { submission, split } => return Ok(axum::Json(dry_run_report(submission, split, &upload)).into_response()),
        Accepted::Repeat { id } => repeat_answer(&state, &team, id).await?,
        Accepted::New { id, submission, split, quota } => {
            tracing::info!(submission = %id, team = %team.name, size = upload.size, "submission accepted");
            let body = Created {
                complete: submission.complete,
                missing_maps: Some(submission.missing_maps),
                quota: quota.expect("the quota is enforced").view(),
                repeat: false,
                split,
                state: SubmissionState::Queued,
                url: format!("/api/v1/submissions/{id}"),
                id: id.clone(),
            };
            (StatusCode::ACCEPTED, id, body)
        }
    };
    if let Some(upload_id) = query.upload.as_deref() {
        uploads::finish(&state, upload_id, &answer.1).await;
    }
    Ok(located(answer))
}

/// What an upload's headers declare of it: the idempotency key, the SHA-256.
struct Declared {
    key: Option<String>,
    sha256: Option<[u8; 32]>,
}

impl Declared {
    /// A refusal when the upload's SHA-256 is not the one declared.
    fn check(&self, upload: &intake::Upload) -> ApiResult<()> {
        match self.sha256 {
            Some(expected) if expected != upload.sha256 => Err(Problem::new(
                StatusCode::UNPROCESSABLE_ENTITY,
                ProblemCode::DigestMismatch,
                "Checksum mismatch",
                format!(
                    "The upload's SHA-256 is {} but Content-Digest declared another; the file changed or was corrupted on the way. Nothing was stored; upload again.",
                    upload.sha256_hex()
                ),
            )),
            _ => Ok(()),
        }
    }
}

/// The caller, the query and what the headers declare, or the first refusal.
fn read_request(
    caller: Result<TeamCaller, Problem>,
    query: Result<ApiQuery<UploadQuery>, Problem>,
    headers: &HeaderMap,
) -> Result<(crate::store::Team, UploadQuery, Declared), Problem> {
    let TeamCaller(team) = caller?;
    let ApiQuery(query) = query?;
    let key = idempotency_key(headers)?;
    let sha256 = headers.get("content-digest").and_then(|v| v.to_str().ok()).map(declared_sha256).transpose()?.flatten();
    Ok((team, query, Declared { key, sha256 }))
}

/// The quota refusal of a new upload, if the team has none left. A repeat costs no quota:
/// with the quota used up, an upload that names an earlier submission (its key, or its
/// declared digest) is still read and answered.
async fn quota_refusal(state: &AppState, team: &crate::store::Team, query: &UploadQuery, declared: &Declared) -> ApiResult<Option<Problem>> {
    let default = intake::default_split(state).await?;
    let Some(quota) = Quota::refusal_before_upload(state, team, query.split, default).await? else { return Ok(None) };
    let may_repeat = match (&declared.key, declared.sha256) {
        (None, None) => false,
        _ => {
            let digest = declared.sha256.map(|d| hex(&d)).unwrap_or_default();
            state.store.repeated_submission(&team.id, &digest, quota.split, declared.key.as_deref()).await?.is_some()
        }
    };
    Ok((!may_repeat).then(|| quota_exceeded(quota)))
}

/// The request body as an upload in scratch space: no more than the service takes, and
/// exactly as long as declared.
async fn read_body(state: &AppState, body: Body, declared_length: Option<u64>) -> ApiResult<(intake::Upload, crate::blobs::Scratch)> {
    let max = state.settings.max_upload_bytes;
    if declared_length.is_some_and(|n| n > max) {
        return Err(too_large(max));
    }
    let (upload, scratch) = receive(state, body, max).await?;
    match declared_length {
        Some(length) if length != upload.size => {
            Err(Problem::bad_request(ProblemCode::UploadIncomplete, format!("Content-Length said {length} bytes but {} arrived. Upload again.", upload.size)))
        }
        _ => Ok((upload, scratch)),
    }
}

/// `intake::accept` of a team's upload. The bytes of a resumable upload that are not a
/// valid submission never will be: it is removed, so it does not hold the team's
/// open-upload room for a day.
async fn accept(state: &AppState, team: &crate::store::Team, upload: &intake::Upload, query: &UploadQuery, key: Option<String>) -> ApiResult<Accepted> {
    let request = intake::Request {
        dry_run: query.dry_run,
        public: query.public.unwrap_or(true),
        baseline: false,
        idempotency_key: key,
        enforce_quota: true,
        release: None,
        split: query.split,
    };
    let problem = match intake::accept(state, team, upload, &request).await {
        Ok(accepted) => return Ok(accepted),
        Err(e) => Problem::from(e),
    };
    if let Some(upload_id) = query.upload.as_deref()
        && [ProblemCode::InvalidArchive, ProblemCode::InvalidSubmission, ProblemCode::DigestMismatch].contains(&problem.code)
        && let Err(e) = uploads::terminate(state, team, upload_id).await
    {
        tracing::warn!(upload = %upload_id, error = %e.detail, "a refused upload could not be removed; it expires on its own");
    }
    Err(problem)
}

/// A dry run's answer: what the valid upload covers.
fn dry_run_report(valid: osmab_evaluator::submission::ValidSubmission, split: Split, upload: &intake::Upload) -> DryRun {
    let entries = valid
        .entries
        .iter()
        .map(|e| CoveredEntry { answers: e.answers.is_some(), graph: e.graph.is_some(), lighting: e.lighting, map: e.map.is_some(), scene: e.scene.clone() })
        .collect();
    DryRun {
        complete: valid.complete,
        entries,
        method: valid.method,
        missing_maps: valid.missing_maps,
        outside_split: valid.outside_split,
        points: valid.points,
        release: valid.release,
        sha256: upload.sha256_hex(),
        size: upload.size,
        split,
        valid: true,
    }
}

/// A submission's answer with its `Location`.
fn located((status, id, body): (StatusCode, String, Created)) -> Response {
    (status, [(header::LOCATION, format!("/api/v1/submissions/{id}"))], axum::Json(body)).into_response()
}

/// The 200 of an upload that repeats the team's earlier submission `id`.
async fn repeat_answer(state: &AppState, team: &crate::store::Team, id: String) -> ApiResult<(StatusCode, String, Created)> {
    let s = state.store.submission(&id).await?;
    tracing::info!(submission = %id, team = %team.name, "repeated upload answered with the earlier submission");
    let quota = Quota::of(state, team, s.split).await?.view();
    let body = Created {
        complete: s.complete,
        missing_maps: None,
        quota,
        repeat: true,
        split: s.split,
        state: s.state,
        url: format!("/api/v1/submissions/{id}"),
        id: id.clone(),
    };
    Ok((StatusCode::OK, id, body))
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
    Ok(axum::Json(submission_view::load(&state, &s, &caller).await?))
}

/// `GET /api/v1/submissions`: the calling team's submissions.
pub async fn list(State(state): State<AppState>, TeamCaller(team): TeamCaller) -> ApiResult<axum::Json<SubmissionList>> {
    let submissions = state.store.submissions(Some(&team.id), 500).await?.iter().map(SubmissionItem::from).collect();
    Ok(axum::Json(SubmissionList { submissions }))
}

#[derive(Debug, Deserialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct MethodCardUpdate {
    name: Option<String>,
    description: Option<String>,
    paper_url: Option<Option<String>>,
    code_url: Option<Option<String>>,
    external_data: Option<Option<String>>,
    compute: Option<Option<String>>,
    /// `false` reveals the team on the leaderboard.
    anonymous: Option<bool>,
    public: Option<bool>,
}

/// `PATCH /api/v1/submissions/{id}`: edit the method card or visibility (own team or admin).
pub async fn update(
    State(state): State<AppState>,
    SignedInCaller(caller): SignedInCaller,
    ApiPath(id): ApiPath<String>,
    change: Result<ApiJson<MethodCardUpdate>, Problem>,
) -> ApiResult<axum::Json<SubmissionView>> {
    let mut s = visible_submission(&state, &caller, &id).await?;
    caller.may_change(&s.team_id, "edit a submission")?;
    // The body is looked at only once the caller may edit.
    let ApiJson(change) = change?;
    let card = &mut s.card;
    if let Some(name) = change.name {
        card.name = name.trim().to_string();
    }
    if let Some(description) = change.description {
        card.description = description;
    }
    if let Some(url) = change.paper_url {
        card.paper_url = url;
    }
    if let Some(url) = change.code_url {
        card.code_url = url;
    }
    if let Some(text) = change.external_data {
        card.external_data = text;
    }
    if let Some(text) = change.compute {
        card.compute = text;
    }
    if let Some(anonymous) = change.anonymous {
        card.anonymous = anonymous;
    }
    if let Some(public) = change.public {
        s.public = public;
    }
    let card = osmab_evaluator::submission::MethodCard::from(&s.card);
    card.check("request body").map_err(|e| {
        Problem::new(StatusCode::UNPROCESSABLE_ENTITY, ProblemCode::InvalidRequest, "Invalid method card", format!("{}: {}", e.field, e.message))
    })?;
    let baselines = state.store.team(&s.team_id).await?.name == crate::jobs::release_build::BASELINE_TEAM;
    if !baselines && let Some(problem) = crate::reserved_names::method_name_problem(card.name.trim()) {
        return Err(Problem::new(StatusCode::UNPROCESSABLE_ENTITY, ProblemCode::InvalidRequest, "Invalid method card", format!("name: {problem}")));
    }
    state.store.update_method_card(&id, &s, now_ms()).await?;
    state.leaderboard.invalidate();
    Ok(axum::Json(submission_view::load(&state, &state.store.submission(&id).await?, &caller).await?))
}

/// `POST /api/v1/submissions/{id}/cancel`: stop a submission that is not scored yet.
pub async fn cancel(
    State(state): State<AppState>,
    SignedInCaller(caller): SignedInCaller,
    ApiPath(id): ApiPath<String>,
) -> ApiResult<axum::Json<SubmissionView>> {
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
    Ok(axum::Json(submission_view::load(&state, &state.store.submission(&id).await?, &caller).await?))
}

/// Uploading, listing, editing and cancelling submissions.
pub fn routes() -> ApiRoutes {
    ApiRoutes::new()
        .operation(
            Operation::new(
                Verb::Post,
                "/api/v1/submissions",
                Auth::Team,
                "Upload a submission archive (tar, tar.gz or zip; optional Content-Digest and Idempotency-Key). `?dry_run=true` validates only, free of quota; `?public=false` keeps it off the leaderboard; `?upload=ID` submits a completed resumable upload instead of a body, answered exactly as a direct upload. A repeat — the team's active submission of the same archive, or the same Idempotency-Key — answers 200 with that submission (`repeat: true`) and uses no quota.",
                202,
            )
            .takes_body(Input::Archive)
            .query::<UploadQuery>()
            .returns::<UploadAnswer>(),
            create,
        )
        .operation(Operation::new(Verb::Get, "/api/v1/submissions", Auth::Team, "The calling team's submissions.", 200).returns::<SubmissionList>(), list)
        .operation(
            Operation::new(Verb::Get, "/api/v1/submissions/{id}", Auth::Optional, "A submission: state, reason, history, jobs and its latest scores.", 200)
                .returns::<SubmissionView>(),
            show,
        )
        .operation(
            Operation::new(Verb::Patch, "/api/v1/submissions/{id}", Auth::TeamOrAdmin, "Edit the method card (name, description, paper_url, code_url) or `public`.", 200)
                .takes::<MethodCardUpdate>()
                .returns::<SubmissionView>(),
            update,
        )
        .operation(
            Operation::new(Verb::Post, "/api/v1/submissions/{id}/cancel", Auth::TeamOrAdmin, "Cancel a queued submission.", 200).returns::<SubmissionView>(),
            cancel,
        )
}
