//! `GET /api/v1/jobs/{id}`: a job's state, attempts, lease and stage progress.

use axum::extract::State;
use schemars::JsonSchema;
use serde::Serialize;

use super::extract::ApiPath;
use super::operation::{ApiRoutes, Auth, Operation, Verb};
use crate::auth::Caller;
use crate::clock::rfc3339;
use crate::jobs::progress::Progress;
use crate::problem::{ApiResult, Problem};
use crate::state::AppState;
use crate::store::{JobKind, JobRecord, JobState, StoreError};

/// Who holds a running job, and until when.
#[derive(Debug, Clone, Serialize, JsonSchema)]
pub struct Lease {
    pub expires_at: Option<String>,
    pub worker: String,
}

/// A job as the API shows it (fields in the order of their keys); the error text and
/// the lease are for admins only (absent for everyone else).
#[derive(Debug, Clone, Serialize, JsonSchema)]
pub struct JobView {
    pub attempts: i64,
    pub created_at: String,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub error: Option<Option<String>>,
    pub id: String,
    /// `score_submission`, `build_release` or `render_sequence`.
    pub kind: JobKind,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub lease: Option<Option<Lease>>,
    pub max_attempts: i64,
    /// The job's last progress report (stage, message, counts), as the job wrote it.
    pub progress: Progress,
    pub run_after: String,
    pub state: JobState,
    /// What the job is about: a submission id, a release version, `version/scene/lighting`.
    pub subject: String,
    pub updated_at: String,
}

impl JobView {
    /// The view of `j`; with `admin`, its error text and lease too.
    pub fn of(j: &JobRecord, admin: bool) -> Self {
        let lease = j.lease_owner.as_ref().map(|owner| Lease { expires_at: j.lease_expires.map(rfc3339), worker: owner.clone() });
        JobView {
            attempts: j.attempts,
            created_at: rfc3339(j.created_at),
            error: admin.then(|| j.error.clone()),
            id: j.id.clone(),
            kind: j.kind,
            lease: admin.then_some(lease),
            max_attempts: j.max_attempts,
            progress: Progress::read(&j.progress),
            run_after: rfc3339(j.run_after),
            state: j.state,
            subject: j.subject.clone(),
            updated_at: rfc3339(j.updated_at),
        }
    }
}

/// `GET /api/v1/jobs/{id}`: admins see every job; teams see the jobs of their submissions.
pub async fn show(State(state): State<AppState>, caller: Caller, ApiPath(id): ApiPath<String>) -> ApiResult<axum::Json<JobView>> {
    let missing = || Problem::not_found(format!("There is no job '{id}' you can see."));
    let job = match state.store.job(&id).await {
        Ok(job) => job,
        Err(StoreError::NotFound) => return Err(missing()),
        Err(e) => return Err(e.into()),
    };
    let allowed = match &caller {
        Caller::Admin => true,
        Caller::Team(_) | Caller::Anonymous => match state.store.submission(&job.subject).await {
            Ok(s) => s.public || s.baseline || caller.can_see_team(&s.team_id),
            Err(_) => false,
        },
    };
    if !allowed {
        return Err(missing());
    }
    Ok(axum::Json(JobView::of(&job, matches!(caller, Caller::Admin))))
}

/// One job, for whoever may see what it works on.
pub fn routes() -> ApiRoutes {
    ApiRoutes::new().operation(
        Operation::new(Verb::Get, "/api/v1/jobs/{id}", Auth::Optional, "A job: state, attempts, lease and stage progress.", 200).returns::<JobView>(),
        show,
    )
}
