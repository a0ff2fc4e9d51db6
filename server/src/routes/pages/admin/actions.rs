//! The console's forms: each checks the session's form token, calls the admin API's own
//! function and answers with a redirect (303) to the page that shows the result, or a
//! page with the problem.

use axum::extract::{FromRequest, FromRequestParts, Request, State};
use axum::response::{IntoResponse, Redirect, Response};
use serde::Deserialize;

use super::{AdminMessage, AdminSession, parse_form};
use crate::problem::{Problem, ProblemCode};
use crate::routes::extract::ApiPath;
use crate::routes::{admin, admin_teams, quota_policies};
use crate::state::AppState;

/// A console form posted in a signed-in session, its form token checked (and where it came
/// from, see `origin.rs`): what every form handler takes, after its path.
pub struct Checked<T> {
    session: AdminSession,
    form: T,
}

impl<T: FormWithToken> FromRequest<AppState> for Checked<T> {
    type Rejection = Response;

    async fn from_request(request: Request, state: &AppState) -> Result<Self, Response> {
        let (mut parts, body) = request.into_parts();
        let session = AdminSession::from_request_parts(&mut parts, state).await?;
        let headers = parts.headers.clone();
        let body = axum::body::Bytes::from_request(Request::from_parts(parts, body), state).await.map_err(IntoResponse::into_response)?;
        let form: T = parse_form(&body)?;
        session.check_form(&headers, form.form_token())?;
        Ok(Checked { session, form })
    }
}

pub trait FormWithToken: serde::de::DeserializeOwned {
    fn form_token(&self) -> &str;
}

/// The forms, each with its `form_token` field.
macro_rules! form_with_token {
    ($($form:ty),+ $(,)?) => {
        $(impl FormWithToken for $form {
            fn form_token(&self) -> &str {
                &self.form_token
            }
        })+
    };
}

form_with_token!(TokenOnly, RegenerateForm, FlagForm, QuotaForm, TeamForm, DeclineForm);

/// The console with a notice on top (sealed for this session).
fn back(session: &AdminSession, notice: &str) -> Response {
    Redirect::to(&format!("/admin?notice={}&seal={}", urlencoding(notice), session.seal(notice))).into_response()
}

/// `text` percent-encoded for a query value.
fn urlencoding(text: &str) -> String {
    text.bytes()
        .map(|b| match b {
            b'A'..=b'Z' | b'a'..=b'z' | b'0'..=b'9' | b'-' | b'_' | b'.' | b'~' => (b as char).to_string(),
            _ => format!("%{b:02X}"),
        })
        .collect()
}

#[derive(Deserialize)]
pub struct TokenOnly {
    form_token: String,
}

#[derive(Deserialize)]
pub struct RegenerateForm {
    form_token: String,
    config: String,
    /// Checkboxes: present ("on") when ticked.
    publish: Option<String>,
    baselines: Option<String>,
    /// Build even what would be an existing release under another name.
    identical: Option<String>,
}

/// `POST /admin/regenerate` (`config`, `publish`, `baselines`): queue a release build and
/// follow it on its job's page.
pub async fn regenerate(State(state): State<AppState>, Checked { form, .. }: Checked<RegenerateForm>) -> Response {
    let config = Some(form.config.replace("\r\n", "\n")).filter(|c| !c.trim().is_empty());
    match admin::queue_release_build(&state, config, form.publish.is_some(), form.baselines.is_some(), form.identical.is_some()).await {
        Ok((job, _)) => Redirect::to(&format!("/admin/jobs/{job}")).into_response(),
        Err(problem) => AdminMessage::problem(problem),
    }
}

/// Go back to the console with the notice an action gave, or show its problem.
fn done(session: &AdminSession, outcome: Result<String, Problem>) -> Response {
    match outcome {
        Ok(notice) => back(session, &notice),
        Err(problem) => AdminMessage::problem(problem),
    }
}

/// `POST /admin/releases/{version}/publish`.
pub async fn publish(State(state): State<AppState>, ApiPath(version): ApiPath<String>, Checked { session, .. }: Checked<TokenOnly>) -> Response {
    done(&session, admin::publish(&state, &version).await.map(|()| format!("Release {version} is published and current.")))
}

#[derive(Deserialize)]
pub struct FlagForm {
    form_token: String,
    reason: String,
}

/// `POST /admin/submissions/{id}/flag` (`reason`).
pub async fn flag(State(state): State<AppState>, ApiPath(id): ApiPath<String>, Checked { session, form }: Checked<FlagForm>) -> Response {
    done(&session, admin::set_flag(&state, &id, Some(&form.reason)).await.map(|()| format!("{id} is flagged.")))
}

/// `POST /admin/submissions/{id}/unflag`.
pub async fn unflag(State(state): State<AppState>, ApiPath(id): ApiPath<String>, Checked { session, .. }: Checked<TokenOnly>) -> Response {
    done(&session, admin::set_flag(&state, &id, None).await.map(|()| format!("{id} is no longer flagged.")))
}

/// `POST /admin/submissions/{id}/refund`.
pub async fn refund(State(state): State<AppState>, ApiPath(id): ApiPath<String>, Checked { session, .. }: Checked<TokenOnly>) -> Response {
    let refunded = admin::refund(&state, &id).await.map(|newly| match newly {
        true => format!("{id}: its quota unit is given back to the team."),
        false => format!("{id}: its quota unit had been given back already."),
    });
    done(&session, refunded)
}

#[derive(Deserialize)]
pub struct QuotaForm {
    form_token: String,
    split: String,
    limit: String,
    window_hours: String,
}

/// `POST /admin/quotas` (`split`, `limit`, `window_hours`): a split's limit per window.
pub async fn set_quota(State(state): State<AppState>, Checked { session, form }: Checked<QuotaForm>) -> Response {
    let number = |field: &str, text: &str| {
        text.trim().parse::<i64>().map_err(|_| {
            AdminMessage::problem(Problem::new(
                axum::http::StatusCode::UNPROCESSABLE_ENTITY,
                ProblemCode::InvalidRequest,
                "Invalid request",
                format!("{field}: expected a whole number, found '{text}'"),
            ))
        })
    };
    let body = match (number("limit", &form.limit), number("window_hours", &form.window_hours)) {
        (Ok(limit), Ok(window_hours)) => quota_policies::PolicyBody { limit, window_hours },
        (Err(refused), _) | (_, Err(refused)) => return refused,
    };
    let applied = quota_policies::apply(&state, &form.split, &body).await;
    done(&session, applied.map(|set| format!("The {} split: {} submissions per team per {} hours.", set.split, set.limit, set.window_hours)))
}

/// `POST /admin/access-requests/{id}/approve`: create the requested team; the requester
/// collects its token with the claim code.
pub async fn approve_access(State(state): State<AppState>, ApiPath(id): ApiPath<String>, Checked { session, .. }: Checked<TokenOnly>) -> Response {
    let approved = crate::access_requests::approve(&state, &id).await;
    done(&session, approved.map(|r| format!("Team {} is created; its requester collects the token with the claim code.", r.team_name)))
}

#[derive(Deserialize)]
pub struct DeclineForm {
    form_token: String,
    reason: String,
}

/// `POST /admin/access-requests/{id}/decline` (`reason`, which the requester reads).
pub async fn decline_access(State(state): State<AppState>, ApiPath(id): ApiPath<String>, Checked { session, form }: Checked<DeclineForm>) -> Response {
    let declined = crate::access_requests::decline(&state, &id, &form.reason).await;
    done(&session, declined.map(|r| format!("The request for team {} is declined.", r.team_name)))
}

#[derive(Deserialize)]
pub struct TeamForm {
    form_token: String,
    name: String,
}

/// `POST /admin/teams`: create a team; the answer shows its first token, once (it never
/// travels in a URL, so no redirect).
pub async fn create_team(State(state): State<AppState>, Checked { session, form }: Checked<TeamForm>) -> Response {
    match admin_teams::new_team(&state, &admin_teams::NewTeam { name: form.name, daily_quota: None }).await {
        Ok(team) => (
            axum::http::StatusCode::CREATED,
            [(axum::http::header::CACHE_CONTROL, "no-store")],
            super::TeamCreatedPage {
                name: team.name,
                id: team.id,
                token: team.token,
                origin: state.settings.public_url.clone().unwrap_or_default(),
                form_token: session.form_token(),
            },
        )
            .into_response(),
        Err(problem) => AdminMessage::problem(problem),
    }
}

#[cfg(test)]
mod tests {
    #[test]
    fn notices_travel_percent_encoded() {
        assert_eq!(super::urlencoding("sub_1 is flagged."), "sub_1%20is%20flagged.");
        assert_eq!(super::urlencoding("ä&="), "%C3%A4%26%3D");
    }
}
