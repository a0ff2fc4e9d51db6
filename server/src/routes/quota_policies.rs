//! `GET /api/v1/admin/quotas` and `PUT /api/v1/admin/quotas/{split}`: the administrator's
//! limit per split (submissions per rolling window), shown to teams by `GET /api/v1/quota`.

use axum::extract::State;
use osmab_evaluator::scores::Split;
use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

use super::extract::{ApiJson, ApiPath};
use super::operation::{ApiRoutes, Auth, Operation, Verb};
use crate::auth::AdminCaller;
use crate::clock::now_ms;
use crate::intake::Policy;
use crate::problem::{ApiResult, Problem};
use crate::state::AppState;
use crate::store::QuotaPolicyRecord;

/// The longest window a policy may have.
const MAX_WINDOW_HOURS: i64 = 24 * 366;

/// One split's limit.
#[derive(Debug, Serialize, JsonSchema)]
pub struct PolicyView {
    /// Submissions a team may make to the split per window.
    pub limit: i64,
    /// Set by an administrator (false: the service's default).
    pub set: bool,
    pub split: Split,
    pub window_hours: i64,
}

/// Every split's limit.
#[derive(Debug, Serialize, JsonSchema)]
pub struct PolicyList {
    pub policies: Vec<PolicyView>,
}

/// A split's new limit.
#[derive(Debug, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct PolicyBody {
    /// Submissions per window, 0 or more (0 closes the split to teams).
    pub limit: i64,
    /// The window in hours, 1 to 8784.
    pub window_hours: i64,
}

/// The limit of `split` as it stands.
pub async fn view(state: &AppState, split: Split) -> ApiResult<PolicyView> {
    let set = state.store.quota_policies().await?.iter().any(|p| p.split == split);
    let policy = Policy::of(state, split).await?;
    Ok(PolicyView { limit: policy.limit, set, split, window_hours: policy.window_secs / 3600 })
}

/// The limit of every split, test first.
pub async fn views(state: &AppState) -> ApiResult<Vec<PolicyView>> {
    let mut policies = Vec::new();
    for split in Split::ALL {
        policies.push(view(state, split).await?);
    }
    Ok(policies)
}

/// `GET /api/v1/admin/quotas`.
pub async fn list(State(state): State<AppState>, _: AdminCaller) -> ApiResult<axum::Json<PolicyList>> {
    Ok(axum::Json(PolicyList { policies: views(&state).await? }))
}

/// Set the limit of the split named `split` (the API's and the console's action).
pub async fn apply(state: &AppState, split: &str, body: &PolicyBody) -> ApiResult<PolicyView> {
    let invalid = |detail: String| Problem::invalid_request(detail);
    let split: Split = split.parse().map_err(|e: String| Problem::not_found(format!("{e}; see GET /api/v1/admin/quotas")))?;
    if body.limit < 0 {
        return Err(invalid(format!("limit: expected 0 or more submissions per window, found {}", body.limit)));
    }
    if !(1..=MAX_WINDOW_HOURS).contains(&body.window_hours) {
        return Err(invalid(format!("window_hours: expected 1 to {MAX_WINDOW_HOURS} hours, found {}", body.window_hours)));
    }
    let record = QuotaPolicyRecord { split, max_submissions: body.limit, window_secs: body.window_hours * 3600, updated_at: now_ms() };
    state.store.set_quota_policy(&record).await?;
    tracing::info!(%split, limit = body.limit, window_hours = body.window_hours, "quota policy set by an admin");
    view(state, split).await
}

/// `PUT /api/v1/admin/quotas/{split}` `{"limit", "window_hours"}`.
pub async fn set(
    State(state): State<AppState>,
    _: AdminCaller,
    ApiPath(split): ApiPath<String>,
    ApiJson(body): ApiJson<PolicyBody>,
) -> ApiResult<axum::Json<PolicyView>> {
    Ok(axum::Json(apply(&state, &split, &body).await?))
}

/// The submission limits of the splits.
pub fn routes() -> ApiRoutes {
    ApiRoutes::new()
        .operation(
            Operation::new(Verb::Get, "/api/v1/admin/quotas", Auth::Admin, "The limit of every split (submissions per rolling window), set or default.", 200)
                .returns::<PolicyList>(),
            list,
        )
        .operation(
            Operation::new(Verb::Put, "/api/v1/admin/quotas/{split}", Auth::Admin, "Set a split's limit: `{\"limit\", \"window_hours\"}`.", 200)
                .takes::<PolicyBody>()
                .returns::<PolicyView>(),
            set,
        )
}
