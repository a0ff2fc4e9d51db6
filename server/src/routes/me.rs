//! The calling team: who it is, and what it may still submit to each split.

use axum::extract::State;
use osmab_evaluator::scores::Split;

pub use osmab_api::account::{Me, Quotas, TeamRef};

use super::operation::{ApiRoutes, Auth, Operation, Verb};
use crate::auth::TeamCaller;
use crate::intake::{self, Quota};
use crate::problem::ApiResult;
use crate::state::AppState;

/// `GET /api/v1/me`: the calling team and its quota.
pub async fn me(State(state): State<AppState>, TeamCaller(team): TeamCaller) -> ApiResult<axum::Json<Me>> {
    let quota = Quota::of(&state, &team, intake::default_split(&state).await?).await?;
    Ok(axum::Json(Me { quota: quota.view(), team: TeamRef { id: team.id, name: team.name } }))
}

/// `GET /api/v1/quota`: before uploading, what the calling team may still submit to each
/// split, and when more becomes possible.
pub async fn quotas(State(state): State<AppState>, TeamCaller(team): TeamCaller) -> ApiResult<axum::Json<Quotas>> {
    let mut splits = Vec::new();
    for split in Split::ALL {
        splits.push(Quota::of(&state, &team, split).await?.view());
    }
    let default_split = intake::default_split(&state).await?;
    Ok(axum::Json(Quotas { default_split, splits, team: TeamRef { id: team.id, name: team.name } }))
}

/// The calling team's own account.
pub fn routes() -> ApiRoutes {
    ApiRoutes::new()
        .operation(
            Operation::new(Verb::Get, "/api/v1/me", Auth::Team, "The calling team and its quota for the split uploads go to by default.", 200).returns::<Me>(),
            me,
        )
        .operation(
            Operation::new(
                Verb::Get,
                "/api/v1/quota",
                Auth::Team,
                "Before uploading: the team's quota of every split (limit, used, remaining, window, when the next submission is possible) and the split an upload goes to by default.",
                200,
            )
            .returns::<Quotas>(),
            quotas,
        )
}
