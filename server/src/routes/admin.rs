//! Admin endpoints: teams, tokens and quotas; release builds, imports and publication;
//! re-scoring; lists of submissions and jobs. Every handler takes [`AdminCaller`].

use axum::extract::State;
use axum::http::{StatusCode, header};
use axum::response::{IntoResponse, Response};
use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

use super::jobs::JobView;
use super::{ApiJson, ApiPath};
use crate::auth::{AdminCaller, issue_token};
use crate::clock::{new_id, now_ms, rfc3339};
use crate::jobs::release_build::{BuildRelease, config_version};
use crate::jobs::scoring::ScoreSubmission;
use crate::problem::{ApiResult, Problem};
use crate::state::AppState;
use crate::store::{StoreError, SubmissionState, Team};

/// A team to create.
#[derive(Debug, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct NewTeam {
    pub name: String,
    pub daily_quota: Option<i64>,
}

fn unprocessable(detail: impl Into<String>) -> Problem {
    Problem::new(StatusCode::UNPROCESSABLE_ENTITY, "invalid_request", "Invalid request", detail)
}

/// `POST /api/v1/admin/teams` `{"name"}` → `201 {"id", "name", "token"}` (the token is shown once).
pub async fn create_team(State(state): State<AppState>, _: AdminCaller, ApiJson(body): ApiJson<NewTeam>) -> ApiResult<Response> {
    let created = new_team(&state, &body).await?;
    Ok((StatusCode::CREATED, [(header::LOCATION, format!("/api/v1/admin/teams/{}", created.id))], axum::Json(created)).into_response())
}

/// Create the team `body` names with its first token (the API and the console's form).
pub async fn new_team(state: &AppState, body: &NewTeam) -> ApiResult<CreatedTeam> {
    let name = body.name.trim().to_string();
    if let Some(problem) = osmab_evaluator::text::display_name_problem(&name, 80).or_else(|| crate::reserved_names::team_name_problem(&name)) {
        return Err(unprocessable(format!("name: {problem}")));
    }
    if body.daily_quota.is_some_and(|q| q < 0) {
        return Err(unprocessable("daily_quota: expected 0 or more"));
    }
    let team = Team { id: new_id("team"), name: name.clone(), daily_quota: body.daily_quota, created_at: now_ms() };
    match state.store.create_team(&team).await {
        Ok(()) => {}
        Err(StoreError::Conflict(_)) => return Err(Problem::conflict(format!("A team named '{name}' exists."))),
        Err(e) => return Err(e.into()),
    }
    let (token, record) = issue_token("team", Some(&team.id), None);
    state.store.insert_token(&record).await?;
    tracing::info!(team = %team.name, token = %record.hint, "team created");
    Ok(CreatedTeam { daily_quota: team.daily_quota, id: team.id, name: team.name, token, token_id: record.id })
}

/// A created team with its first token (shown once).
#[derive(Debug, Serialize, Deserialize, JsonSchema)]
pub struct CreatedTeam {
    pub daily_quota: Option<i64>,
    pub id: String,
    pub name: String,
    pub token: String,
    pub token_id: String,
}

/// A team in the admin's list.
#[derive(Debug, Serialize, Deserialize, JsonSchema)]
pub struct TeamView {
    #[serde(skip_serializing_if = "Option::is_none")]
    pub created_at: Option<String>,
    /// Submissions per UTC day; null for the service default.
    pub daily_quota: Option<i64>,
    pub id: String,
    pub name: String,
}

/// `GET /api/v1/admin/teams`.
#[derive(Debug, Serialize, Deserialize, JsonSchema)]
pub struct TeamList {
    pub teams: Vec<TeamView>,
}

/// `GET /api/v1/admin/teams`.
pub async fn list_teams(State(state): State<AppState>, _: AdminCaller) -> ApiResult<axum::Json<TeamList>> {
    let teams = state
        .store
        .teams()
        .await?
        .into_iter()
        .map(|t| TeamView { created_at: Some(rfc3339(t.created_at)), daily_quota: t.daily_quota, id: t.id, name: t.name })
        .collect();
    Ok(axum::Json(TeamList { teams }))
}

/// A team's new quota.
#[derive(Debug, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct TeamUpdate {
    daily_quota: Option<i64>,
}

/// `PATCH /api/v1/admin/teams/{id}` `{"daily_quota"}` (null: the service default).
pub async fn update_team(
    State(state): State<AppState>,
    _: AdminCaller,
    ApiPath(id): ApiPath<String>,
    ApiJson(body): ApiJson<TeamUpdate>,
) -> ApiResult<axum::Json<TeamView>> {
    if body.daily_quota.is_some_and(|q| q < 0) {
        return Err(unprocessable("daily_quota: expected 0 or more"));
    }
    state.store.set_team_quota(&id, body.daily_quota).await?;
    let t = state.store.team(&id).await?;
    Ok(axum::Json(TeamView { created_at: None, daily_quota: t.daily_quota, id: t.id, name: t.name }))
}

/// Another token for a team.
#[derive(Debug, Default, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct NewToken {
    /// Days until the token expires (none: never).
    expires_in_days: Option<i64>,
}

/// `POST /api/v1/admin/teams/{id}/tokens`: another token for a team (shown once).
pub async fn issue_team_token(State(state): State<AppState>, _: AdminCaller, ApiPath(id): ApiPath<String>, body: axum::body::Bytes) -> ApiResult<Response> {
    let team = state.store.team(&id).await?;
    let request: NewToken = if body.iter().all(u8::is_ascii_whitespace) {
        NewToken::default()
    } else {
        serde_json::from_slice(&body).map_err(|e| Problem::bad_request("invalid_request", format!("expected {{\"expires_in_days\"?: int}}: {e}")))?
    };
    if request.expires_in_days.is_some_and(|d| !(1..=3650).contains(&d)) {
        return Err(unprocessable("expires_in_days: expected 1 to 3650"));
    }
    let expires = request.expires_in_days.map(|d| now_ms() + d * 86_400_000);
    let (token, record) = issue_token("team", Some(&team.id), expires);
    state.store.insert_token(&record).await?;
    let body = IssuedToken { expires_at: expires.map(rfc3339), id: record.id, team: team.name, token };
    Ok((StatusCode::CREATED, axum::Json(body)).into_response())
}

/// A token issued for a team (shown once).
#[derive(Debug, Serialize, Deserialize, JsonSchema)]
pub struct IssuedToken {
    pub expires_at: Option<String>,
    pub id: String,
    /// The team's name.
    pub team: String,
    pub token: String,
}

/// A token in a list: its hint and state, never the token.
#[derive(Debug, Serialize, Deserialize, JsonSchema)]
pub struct TokenView {
    pub created_at: String,
    pub expires_at: Option<String>,
    /// The first characters of the token.
    pub hint: String,
    pub id: String,
    pub revoked_at: Option<String>,
}

/// `GET /api/v1/admin/teams/{id}/tokens`.
#[derive(Debug, Serialize, Deserialize, JsonSchema)]
pub struct TokenList {
    pub tokens: Vec<TokenView>,
}

/// `GET /api/v1/admin/teams/{id}/tokens`: hints and states, never the tokens.
pub async fn list_team_tokens(State(state): State<AppState>, _: AdminCaller, ApiPath(id): ApiPath<String>) -> ApiResult<axum::Json<TokenList>> {
    state.store.team(&id).await?;
    let tokens = state
        .store
        .tokens(Some(&id))
        .await?
        .iter()
        .map(|t| TokenView {
            created_at: rfc3339(t.created_at),
            expires_at: t.expires_at.map(rfc3339),
            hint: t.hint.clone(),
            id: t.id.clone(),
            revoked_at: t.revoked_at.map(rfc3339),
        })
        .collect();
    Ok(axum::Json(TokenList { tokens }))
}

/// `DELETE /api/v1/admin/tokens/{id}`: revoke a token.
pub async fn revoke_token(State(state): State<AppState>, _: AdminCaller, ApiPath(id): ApiPath<String>) -> ApiResult<StatusCode> {
    state.store.revoke_token(&id, now_ms()).await?;
    tracing::info!(token = %id, "token revoked");
    Ok(StatusCode::NO_CONTENT)
}

/// A release to build.
#[derive(Debug, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct BuildBody {
    /// A release configuration (TOML); the demo configuration when absent.
    config: Option<String>,
    #[serde(default)]
    publish: bool,
    #[serde(default)]
    baselines: bool,
    /// Build it even when an existing release was built from the same config content and
    /// secret (it would be the same release under another version).
    #[serde(default)]
    identical: bool,
}

/// The existing release a config (by its content digest) and the operator's secret
/// would rebuild byte for byte, if any: its version and digest.
async fn same_release(state: &AppState, config: &osmab_dataset::release::config::ReleaseConfig) -> Result<Option<(String, String)>, Problem> {
    let digest = config.content_digest();
    let secret_id = (!config.splits.is_empty()).then(|| state.split_secret.id());
    for release in state.store.releases().await? {
        let manifest: serde_json::Value = serde_json::from_str(&release.manifest).unwrap_or_default();
        let generator = &manifest["generator"];
        let built_digest = generator["content_digest"].as_str().map(str::to_string).or_else(|| {
            let text = generator["config"].as_str()?;
            osmab_dataset::release::config::ReleaseConfig::parse(text, std::path::Path::new("manifest.json")).ok().map(|(c, _)| c.content_digest())
        });
        if built_digest.as_deref() == Some(digest.as_str()) && generator["split_secret_id"].as_str().map(str::to_string) == secret_id {
            return Ok(Some((release.version, release.digest)));
        }
    }
    Ok(None)
}

/// Queue a build of the release `config` describes (the demo configuration when absent):
/// the job's id and the release version. A config that would rebuild an existing release
/// byte for byte is refused unless `identical` says to build it anyway.
pub async fn queue_release_build(
    state: &AppState,
    config: Option<String>,
    publish: bool,
    baselines: bool,
    identical: bool,
) -> Result<(String, String), Problem> {
    let config = config.unwrap_or_else(|| crate::jobs::release_build::DEMO_CONFIG.to_string());
    let version = config_version(&config).map_err(unprocessable)?;
    let scratch = state.blobs.scratch("config-check");
    let text = config.clone();
    let checked = tokio::task::spawn_blocking(move || {
        std::fs::write(&scratch, &text).map_err(|e| osmab_evaluator::InputError::io(&scratch, &e))?;
        let checked = osmab_dataset::release::config::ReleaseConfig::read(&scratch);
        let _ = std::fs::remove_file(&scratch);
        checked
    })
    .await
    .map_err(Problem::internal)?;
    let (checked, _) = checked.map_err(|e| unprocessable(format!("config: {}: {}", e.field, e.message)))?;
    state.settings.release_allow.check(&checked).map_err(|why| unprocessable(format!("config: {why}")))?;
    if state.store.release(&version).await.is_ok() {
        return Err(Problem::conflict(format!("Release {version} exists; releases are immutable, so build under a new version.")));
    }
    if !identical && let Some((existing, digest)) = same_release(state, &checked).await? {
        return Err(Problem::conflict(format!(
            "Release {existing} was built from this config's content{} (digest {digest}): {version} would be the same release under another name. \
             Change the config (its seed, say){}, or ask for it with \"identical\": true.",
            if checked.splits.is_empty() { "" } else { " and the same split secret" },
            if checked.splits.is_empty() { "" } else { " or rotate the secret" },
        )));
    }
    let job = crate::jobs::new_job(&BuildRelease { config, publish, baselines }, state);
    match state.store.enqueue(&job).await {
        Ok(()) => Ok((job.id, version)),
        Err(StoreError::Conflict(_)) => Err(Problem::conflict(format!("Release {version} is being built already."))),
        Err(e) => Err(e.into()),
    }
}

/// `POST /api/v1/admin/releases`: build a release from a config as a job → `202 {"job", "version"}`.
pub async fn build_release(State(state): State<AppState>, _: AdminCaller, ApiJson(body): ApiJson<BuildBody>) -> ApiResult<Response> {
    let (job, version) = queue_release_build(&state, body.config, body.publish, body.baselines, body.identical).await?;
    let url = format!("/api/v1/jobs/{job}");
    Ok((StatusCode::ACCEPTED, [(header::LOCATION, url.clone())], axum::Json(QueuedJob { job, submission: None, url, version: Some(version) })).into_response())
}

/// A release built on the server's filesystem to register.
#[derive(Debug, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct ImportBody {
    /// A release directory on the server's filesystem (built by `osmab release build`).
    path: String,
    #[serde(default)]
    publish: bool,
}

/// `POST /api/v1/admin/releases/import`: register a built release (manifest and checksums verified).
pub async fn import_release(State(state): State<AppState>, _: AdminCaller, ApiJson(body): ApiJson<ImportBody>) -> ApiResult<Response> {
    let dir = std::path::PathBuf::from(&body.path);
    if !dir.join("manifest.json").is_file() {
        return Err(unprocessable(format!("path: '{}' holds no manifest.json", body.path)));
    }
    let outcome = crate::releases::import_release(&state.store, &state.blobs, &dir, crate::releases::Provenance::External, body.publish)
        .await
        .map_err(|e| unprocessable(format!("{e:#}")))?;
    state.leaderboard.invalidate();
    let (status, version) = match outcome {
        crate::releases::Imported::New(v) => (StatusCode::CREATED, v),
        crate::releases::Imported::Unchanged(v) => (StatusCode::OK, v),
    };
    let release = state.store.release(&version).await?;
    Ok((status, axum::Json(super::releases::ReleaseSummary::from(&release))).into_response())
}

/// Freeze the draft `version` into the current release.
pub async fn publish(state: &AppState, version: &str) -> Result<(), Problem> {
    match state.store.publish_release(version, now_ms()).await {
        Ok(()) => {}
        Err(StoreError::NotFound) => return Err(Problem::not_found(format!("There is no release '{version}'."))),
        Err(e) => return Err(e.into()),
    }
    state.leaderboard.invalidate();
    tracing::info!(release = %version, "release published");
    Ok(())
}

/// `POST /api/v1/admin/releases/{version}/publish`: freeze a draft into the current release.
pub async fn publish_release(
    State(state): State<AppState>,
    _: AdminCaller,
    ApiPath(version): ApiPath<String>,
) -> ApiResult<axum::Json<super::releases::ReleaseSummary>> {
    publish(&state, &version).await?;
    Ok(axum::Json(super::releases::ReleaseSummary::from(&state.store.release(&version).await?)))
}

/// `POST /api/v1/admin/submissions/{id}/rescore`: score again with this evaluator; a new
/// score is added, the old ones stay.
pub async fn rescore(State(state): State<AppState>, _: AdminCaller, ApiPath(id): ApiPath<String>) -> ApiResult<Response> {
    let s = state.store.submission(&id).await?;
    let now = now_ms();
    let job = crate::jobs::new_job(&ScoreSubmission { submission_id: id.clone(), rescore: true }, &state);
    // Scored and failed submissions, and ones stuck without a live job (the jobs' unique
    // index refuses a second live one).
    match state
        .store
        .requeue_submission(
            &id,
            &[SubmissionState::Scored, SubmissionState::Failed, SubmissionState::Queued, SubmissionState::Scoring],
            "re-scoring requested by an admin",
            &job,
            now,
        )
        .await
    {
        Ok(true) => {}
        Ok(false) => return Err(Problem::conflict(format!("The submission is {}; it cannot be re-scored.", s.state))),
        Err(StoreError::Conflict(_)) => return Err(Problem::conflict("The submission has a queued or running scoring job already.")),
        Err(e) => return Err(e.into()),
    }
    let url = format!("/api/v1/jobs/{}", job.id);
    Ok((
        StatusCode::ACCEPTED,
        [(header::LOCATION, url.clone())],
        axum::Json(QueuedJob { job: job.id.clone(), submission: Some(id), url: url.clone(), version: None }),
    )
        .into_response())
}

/// An organiser's flag on a leaderboard entry.
#[derive(Debug, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct FlagBody {
    /// Why, shown on the leaderboard and the submission's page (1 to 300 characters).
    reason: String,
}

/// A store error naming submission `id` when it does not exist.
fn no_submission(e: StoreError, id: &str) -> Problem {
    match e {
        StoreError::NotFound => Problem::not_found(format!("There is no submission '{id}'.")),
        other => other.into(),
    }
}

/// Flag submission `id` with `reason`, or clear its flag (`None`).
pub async fn set_flag(state: &AppState, id: &str, reason: Option<&str>) -> Result<(), Problem> {
    let reason = reason.map(str::trim);
    if let Some(reason) = reason
        && (reason.is_empty() || reason.chars().count() > 300 || osmab_evaluator::text::first_hidden_format(reason).is_some())
    {
        return Err(unprocessable("reason: expected 1 to 300 characters of visible text"));
    }
    state.store.set_flag(id, reason, now_ms()).await.map_err(|e| no_submission(e, id))?;
    state.leaderboard.invalidate();
    tracing::info!(submission = %id, reason = reason.unwrap_or("(cleared)"), "entry flag set");
    Ok(())
}

/// Give back the quota unit submission `id` used; false when it was given back already
/// (or never counted: baselines).
pub async fn refund(state: &AppState, id: &str) -> Result<bool, Problem> {
    let refunded = state.store.refund_quota(id, now_ms()).await.map_err(|e| no_submission(e, id))?;
    tracing::info!(submission = %id, refunded, "quota refund requested by an admin");
    Ok(refunded)
}

/// `PUT /api/v1/admin/submissions/{id}/flag` `{"reason"}`: flag an entry on the leaderboard.
pub async fn flag(
    State(state): State<AppState>,
    _: AdminCaller,
    ApiPath(id): ApiPath<String>,
    ApiJson(body): ApiJson<FlagBody>,
) -> ApiResult<axum::Json<super::submission_view::SubmissionView>> {
    set_flag(&state, &id, Some(&body.reason)).await?;
    Ok(axum::Json(super::submission_view::SubmissionView::load(&state, &state.store.submission(&id).await?, &crate::auth::Caller::Admin).await?))
}

/// `DELETE /api/v1/admin/submissions/{id}/flag`: clear an entry's flag.
pub async fn unflag(State(state): State<AppState>, _: AdminCaller, ApiPath(id): ApiPath<String>) -> ApiResult<StatusCode> {
    set_flag(&state, &id, None).await?;
    Ok(StatusCode::NO_CONTENT)
}

/// Whether a refund changed anything.
#[derive(Debug, Serialize, JsonSchema)]
pub struct Refunded {
    /// False when the submission's quota unit had been given back already.
    pub refunded: bool,
    pub submission: String,
}

/// `POST /api/v1/admin/submissions/{id}/refund`: give back the quota unit a submission
/// used (failures through no fault of the team are refunded automatically).
pub async fn refund_quota(State(state): State<AppState>, _: AdminCaller, ApiPath(id): ApiPath<String>) -> ApiResult<axum::Json<Refunded>> {
    let refunded = refund(&state, &id).await?;
    Ok(axum::Json(Refunded { refunded, submission: id }))
}

/// A job queued by an admin request.
#[derive(Debug, Serialize, JsonSchema)]
pub struct QueuedJob {
    pub job: String,
    /// The submission re-scored.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub submission: Option<String>,
    pub url: String,
    /// The release built.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub version: Option<String>,
}

/// A submission in the admin's list.
#[derive(Debug, Serialize, JsonSchema)]
pub struct AdminSubmissionItem {
    pub baseline: bool,
    pub created_at: String,
    pub id: String,
    /// The method's name.
    pub method: String,
    pub reason: Option<String>,
    pub release: String,
    pub state: SubmissionState,
    pub team_id: String,
}

/// `GET /api/v1/admin/submissions`.
#[derive(Debug, Serialize, JsonSchema)]
pub struct AdminSubmissionList {
    pub submissions: Vec<AdminSubmissionItem>,
}

/// `GET /api/v1/admin/submissions`: every submission, newest first.
pub async fn list_submissions(State(state): State<AppState>, _: AdminCaller) -> ApiResult<axum::Json<AdminSubmissionList>> {
    let submissions = state
        .store
        .submissions(None, 1000)
        .await?
        .into_iter()
        .map(|s| AdminSubmissionItem {
            baseline: s.baseline,
            created_at: rfc3339(s.created_at),
            id: s.id,
            method: s.method_name,
            reason: s.reason,
            release: s.release,
            state: s.state,
            team_id: s.team_id,
        })
        .collect();
    Ok(axum::Json(AdminSubmissionList { submissions }))
}

/// `GET /api/v1/admin/jobs`.
#[derive(Debug, Serialize, JsonSchema)]
pub struct JobList {
    pub jobs: Vec<JobView>,
}

/// `GET /api/v1/admin/jobs`: recent jobs.
pub async fn list_jobs(State(state): State<AppState>, _: AdminCaller) -> ApiResult<axum::Json<JobList>> {
    Ok(axum::Json(JobList { jobs: state.store.jobs(200).await?.iter().map(|j| JobView::of(j, true)).collect() }))
}
