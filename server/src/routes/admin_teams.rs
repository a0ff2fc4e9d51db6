//! Admin endpoints for teams and their tokens: create a team (with its first token, shown
//! once), list and update teams, issue, list and revoke tokens. Every handler takes
//! [`AdminCaller`].

use axum::extract::State;
use axum::http::{StatusCode, header};
use axum::response::{IntoResponse, Response};
use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

use super::extract::{ApiJson, ApiPath};
use super::operation::{ApiRoutes, Auth, Operation, Verb};
use crate::auth::{AdminCaller, issue_token};
use crate::clock::{new_id, now_ms, rfc3339};
use crate::problem::{ApiResult, Problem, ProblemCode};
use crate::state::AppState;
use crate::store::{StoreError, Team, TokenScope};

/// A team to create.
#[derive(Debug, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct NewTeam {
    pub name: String,
    pub daily_quota: Option<i64>,
}

/// `POST /api/v1/admin/teams` `{"name"}` → `201 {"id", "name", "token"}` (the token is shown once).
pub async fn create_team(State(state): State<AppState>, _: AdminCaller, ApiJson(body): ApiJson<NewTeam>) -> ApiResult<Response> {
    let created = new_team(&state, &body).await?;
    Ok((StatusCode::CREATED, [(header::LOCATION, format!("/api/v1/admin/teams/{}", created.id))], axum::Json(created)).into_response())
}

/// Create the team `body` names with its first token (the API and the console's form).
pub async fn new_team(state: &AppState, body: &NewTeam) -> ApiResult<CreatedTeam> {
    let team = create_team_record(state, &body.name, body.daily_quota).await?;
    let (token, record) = issue_token(TokenScope::Team, Some(&team.id), None);
    state.store.insert_token(&record).await?;
    tracing::info!(team = %team.name, token = %record.hint, "team created");
    Ok(CreatedTeam { daily_quota: team.daily_quota, id: team.id, name: team.name, token, token_id: record.id })
}

/// Create the team `name` (with its own `daily_quota`, if any) and no token: its name is
/// checked as visitors read it, against the reserved names and every other team's.
pub async fn create_team_record(state: &AppState, name: &str, daily_quota: Option<i64>) -> ApiResult<Team> {
    let name = name.trim().to_string();
    if let Some(problem) = osmab_evaluator::text::display_name_problem(&name, 80).or_else(|| crate::reserved_names::team_name_problem(&name)) {
        return Err(Problem::invalid_request(format!("name: {problem}")));
    }
    if daily_quota.is_some_and(|q| q < 0) {
        return Err(Problem::invalid_request("daily_quota: expected 0 or more"));
    }
    // Between teams too, names are compared as visitors read them (UTS #39 skeletons):
    // "TeamА" with a Cyrillic А, or "Team\u{a0}A", beside "TeamA" would pass for it.
    if let Some(twin) = state.store.teams().await?.into_iter().find(|t| osmab_evaluator::text::impersonates(&name, &t.name, false)) {
        return Err(Problem::conflict(if twin.name == name {
            format!("A team named '{name}' exists.")
        } else {
            format!("name: '{name}' reads as '{}', an existing team's name, and visitors could not tell them apart; choose another", twin.name)
        }));
    }
    let team = Team { id: new_id("team"), name: name.clone(), daily_quota, created_at: now_ms() };
    match state.store.create_team(&team).await {
        Ok(()) => Ok(team),
        Err(StoreError::Conflict(_)) => Err(Problem::conflict(format!("A team named '{name}' exists."))),
        Err(e) => Err(e.into()),
    }
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
        return Err(Problem::invalid_request("daily_quota: expected 0 or more"));
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
        serde_json::from_slice(&body).map_err(|e| Problem::bad_request(ProblemCode::InvalidRequest, format!("expected {{\"expires_in_days\"?: int}}: {e}")))?
    };
    if request.expires_in_days.is_some_and(|d| !(1..=3650).contains(&d)) {
        return Err(Problem::invalid_request("expires_in_days: expected 1 to 3650"));
    }
    let expires = request.expires_in_days.map(|d| now_ms() + d * 86_400_000);
    let (token, record) = issue_token(TokenScope::Team, Some(&team.id), expires);
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

/// Teams and their tokens.
pub fn routes() -> ApiRoutes {
    ApiRoutes::new()
        .operation(
            Operation::new(
                Verb::Post,
                "/api/v1/admin/teams",
                Auth::Admin,
                "Create a team: `{\"name\"}` → `{\"id\", \"name\", \"token\"}` (the token is shown once).",
                201,
            )
            .takes::<NewTeam>()
            .returns::<CreatedTeam>(),
            create_team,
        )
        .operation(Operation::new(Verb::Get, "/api/v1/admin/teams", Auth::Admin, "Every team.", 200).returns::<TeamList>(), list_teams)
        .operation(
            Operation::new(Verb::Patch, "/api/v1/admin/teams/{id}", Auth::Admin, "Set a team's daily quota (`{\"daily_quota\"}`; null for the default).", 200)
                .takes::<TeamUpdate>()
                .returns::<TeamView>(),
            update_team,
        )
        .operation(
            Operation::new(Verb::Post, "/api/v1/admin/teams/{id}/tokens", Auth::Admin, "Issue another token for a team (optional `expires_in_days`).", 201)
                .takes::<NewToken>()
                .returns::<IssuedToken>(),
            issue_team_token,
        )
        .operation(
            Operation::new(Verb::Get, "/api/v1/admin/teams/{id}/tokens", Auth::Admin, "A team's tokens (hints and states, never the tokens).", 200)
                .returns::<TokenList>(),
            list_team_tokens,
        )
        .operation(Operation::new(Verb::Delete, "/api/v1/admin/tokens/{id}", Auth::Admin, "Revoke a token.", 204), revoke_token)
}
