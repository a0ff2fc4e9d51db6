//! `GET /api/v1/jobs/{id}`: a job's state, attempts, lease and stage progress.

use axum::extract::State;
use serde_json::{Value, json};

use super::ApiPath;
use crate::auth::Caller;
use crate::clock::rfc3339;
use crate::problem::{ApiResult, Problem};
use crate::state::AppState;
use crate::store::{JobRecord, StoreError};

/// The JSON view of a job; workers and raw errors are for admins only.
pub fn job_json(j: &JobRecord, admin: bool) -> Value {
    let mut view = json!({
        "id": j.id,
        "kind": j.kind,
        "subject": j.subject,
        "state": j.state,
        "attempts": j.attempts,
        "max_attempts": j.max_attempts,
        "progress": serde_json::from_str::<Value>(&j.progress).unwrap_or(Value::Null),
        "run_after": rfc3339(j.run_after),
        "created_at": rfc3339(j.created_at),
        "updated_at": rfc3339(j.updated_at),
    });
    if admin {
        view["error"] = json!(j.error);
        view["lease"] = json!(j.lease_owner.as_ref().map(|owner| json!({"worker": owner, "expires_at": j.lease_expires.map(rfc3339)})));
    }
    view
}

/// `GET /api/v1/jobs/{id}`: admins see every job; teams see the jobs of their submissions.
pub async fn show(State(state): State<AppState>, caller: Caller, ApiPath(id): ApiPath<String>) -> ApiResult<axum::Json<Value>> {
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
    Ok(axum::Json(job_json(&job, matches!(caller, Caller::Admin))))
}
