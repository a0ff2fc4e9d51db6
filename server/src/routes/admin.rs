//! Admin endpoints: release builds, imports and publication; re-scoring, flags and
//! refunds; lists of submissions and jobs (teams and tokens: [`super::admin_teams`]).
//! Every handler takes [`AdminCaller`].

use axum::extract::State;
use axum::http::{StatusCode, header};
use axum::response::{IntoResponse, Response};
use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

use super::extract::{ApiJson, ApiPath};
use super::jobs::JobView;
use super::operation::{ApiRoutes, Auth, Operation, Verb};
use crate::auth::AdminCaller;
use crate::clock::{now_ms, rfc3339};
use crate::jobs::release_build::{BuildRelease, config_version};
use crate::jobs::scoring::ScoreSubmission;
use crate::problem::{ApiResult, Problem};
use crate::state::AppState;
use crate::store::{StoreError, SubmissionState};

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
        let generator = crate::releases::served_manifest(&release).generator;
        // A release built before the manifest recorded the digest: from its config's text.
        let built_digest = Some(generator.content_digest).filter(|d| !d.is_empty()).or_else(|| {
            osmab_dataset::release::config::ReleaseConfig::parse(&generator.config, std::path::Path::new("manifest.json")).ok().map(|(c, _)| c.content_digest())
        });
        if built_digest.as_deref() == Some(digest.as_str()) && generator.split_secret_id == secret_id {
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
    let version = config_version(&config).map_err(Problem::invalid_request)?;
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
    let (checked, _) = checked.map_err(|e| Problem::invalid_request(format!("config: {}: {}", e.field, e.message)))?;
    state.settings.release_allow.check(&checked).map_err(|why| Problem::invalid_request(format!("config: {why}")))?;
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
        return Err(Problem::invalid_request(format!("path: '{}' holds no manifest.json", body.path)));
    }
    let outcome = crate::releases::import_release(&state.store, &state.blobs, &dir, crate::releases::Provenance::External, body.publish)
        .await
        .map_err(|e| Problem::invalid_request(format!("{e:#}")))?;
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
        return Err(Problem::invalid_request("reason: expected 1 to 300 characters of visible text"));
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
    Ok(axum::Json(super::submission_view::load(&state, &state.store.submission(&id).await?, &crate::auth::Caller::Admin).await?))
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
            method: s.card.name,
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

/// Releases, submissions and jobs as the organisers manage them.
pub fn routes() -> ApiRoutes {
    ApiRoutes::new()
        .operation(
            Operation::new(
                Verb::Post,
                "/api/v1/admin/releases",
                Auth::Admin,
                "Build a release from a config (`{\"config\"?: TOML, \"publish\"?, \"baselines\"?}`) as a job.",
                202,
            )
            .takes::<BuildBody>()
            .returns::<QueuedJob>(),
            build_release,
        )
        .operation(
            Operation::new(
                Verb::Post,
                "/api/v1/admin/releases/import",
                Auth::Admin,
                "Register a release built on the server's filesystem (`{\"path\", \"publish\"?}`), verifying its manifest.",
                201,
            )
            .takes::<ImportBody>()
            .returns::<super::releases::ReleaseSummary>(),
            import_release,
        )
        .operation(
            Operation::new(Verb::Post, "/api/v1/admin/releases/{version}/publish", Auth::Admin, "Freeze a draft into the current release.", 200)
                .returns::<super::releases::ReleaseSummary>(),
            publish_release,
        )
        .operation(
            Operation::new(Verb::Get, "/api/v1/admin/submissions", Auth::Admin, "Every submission.", 200).returns::<AdminSubmissionList>(),
            list_submissions,
        )
        .operation(
            Operation::new(
                Verb::Post,
                "/api/v1/admin/submissions/{id}/rescore",
                Auth::Admin,
                "Score a submission again; a new score is added, old ones stay.",
                202,
            )
            .returns::<QueuedJob>(),
            rescore,
        )
        .operation(Operation::new(Verb::Get, "/api/v1/admin/jobs", Auth::Admin, "Recent jobs.", 200).returns::<JobList>(), list_jobs)
        .operation(
            Operation::new(
                Verb::Put,
                "/api/v1/admin/submissions/{id}/flag",
                Auth::Admin,
                "Flag an entry (`{\"reason\"}`): the reason shows on the leaderboard and the submission's page.",
                200,
            )
            .takes::<FlagBody>()
            .returns::<super::submission_view::SubmissionView>(),
            flag,
        )
        .operation(Operation::new(Verb::Delete, "/api/v1/admin/submissions/{id}/flag", Auth::Admin, "Clear an entry's flag.", 204), unflag)
        .operation(
            Operation::new(
                Verb::Post,
                "/api/v1/admin/submissions/{id}/refund",
                Auth::Admin,
                "Give back the quota unit a submission used (failures that were not the team's are refunded automatically).",
                200,
            )
            .returns::<Refunded>(),
            refund_quota,
        )
}
