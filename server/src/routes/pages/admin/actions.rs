//! The console's forms: each checks the session's form token, calls the admin API's own
//! function and answers with a redirect (303) to the page that shows the result, or a
//! page with the problem.

use axum::extract::State;
use axum::http::HeaderMap;
use axum::response::{IntoResponse, Redirect, Response};
use serde::Deserialize;

use super::{AdminMessage, AdminSession, parse_form};
use crate::problem::{Problem, ProblemCode};
use crate::routes::extract::ApiPath;
use crate::routes::{admin, admin_teams, quota_policies};
use crate::state::AppState;

/// A form body after its form token was checked.
fn checked<T: FormWithToken>(session: &AdminSession, headers: &HeaderMap, body: &[u8]) -> Result<T, Response> {
    let form: T = parse_form(body)?;
    session.check_form(headers, form.form_token())?;
    Ok(form)
}

trait FormWithToken: serde::de::DeserializeOwned {
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
struct TokenOnly {
    form_token: String,
}

#[derive(Deserialize)]
struct RegenerateForm {
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
pub async fn regenerate(State(state): State<AppState>, session: AdminSession, headers: HeaderMap, body: axum::body::Bytes) -> Response {
    let form: RegenerateForm = match checked(&session, &headers, &body) {
        Ok(form) => form,
        Err(refused) => return refused,
    };
    let config = Some(form.config.replace("\r\n", "\n")).filter(|c| !c.trim().is_empty());
    match admin::queue_release_build(&state, config, form.publish.is_some(), form.baselines.is_some(), form.identical.is_some()).await {
        Ok((job, _)) => Redirect::to(&format!("/admin/jobs/{job}")).into_response(),
        Err(problem) => AdminMessage::problem(problem),
    }
}

/// A form with no field but its token: check it, do `action`, and go back to the console
/// with the notice `action` gives (or show its problem).
async fn token_form(session: &AdminSession, headers: &HeaderMap, body: &[u8], action: impl Future<Output = Result<String, Problem>>) -> Response {
    match checked::<TokenOnly>(session, headers, body) {
        Ok(_) => match action.await {
            Ok(notice) => back(session, &notice),
            Err(problem) => AdminMessage::problem(problem),
        },
        Err(refused) => refused,
    }
}

/// `POST /admin/releases/{version}/publish`.
pub async fn publish(
    State(state): State<AppState>,
    session: AdminSession,
    headers: HeaderMap,
    ApiPath(version): ApiPath<String>,
    body: axum::body::Bytes,
) -> Response {
    token_form(&session, &headers, &body, async { admin::publish(&state, &version).await.map(|()| format!("Release {version} is published and current.")) })
        .await
}

#[derive(Deserialize)]
struct FlagForm {
    form_token: String,
    reason: String,
}

/// `POST /admin/submissions/{id}/flag` (`reason`).
pub async fn flag(State(state): State<AppState>, session: AdminSession, headers: HeaderMap, ApiPath(id): ApiPath<String>, body: axum::body::Bytes) -> Response {
    let form: FlagForm = match checked(&session, &headers, &body) {
        Ok(form) => form,
        Err(refused) => return refused,
    };
    match admin::set_flag(&state, &id, Some(&form.reason)).await {
        Ok(()) => back(&session, &format!("{id} is flagged.")),
        Err(problem) => AdminMessage::problem(problem),
    }
}

/// `POST /admin/submissions/{id}/unflag`.
pub async fn unflag(
    State(state): State<AppState>,
    session: AdminSession,
    headers: HeaderMap,
    ApiPath(id): ApiPath<String>,
    body: axum::body::Bytes,
) -> Response {
    token_form(&session, &headers, &body, async { admin::set_flag(&state, &id, None).await.map(|()| format!("{id} is no longer flagged.")) }).await
}

/// `POST /admin/submissions/{id}/refund`.
pub async fn refund(
    State(state): State<AppState>,
    session: AdminSession,
    headers: HeaderMap,
    ApiPath(id): ApiPath<String>,
    body: axum::body::Bytes,
) -> Response {
    token_form(&session, &headers, &body, async {
        Ok(match admin::refund(&state, &id).await? {
            true => format!("{id}: its quota unit is given back to the team."),
            false => format!("{id}: its quota unit had been given back already."),
        })
    })
    .await
}

#[derive(Deserialize)]
struct QuotaForm {
    form_token: String,
    split: String,
    limit: String,
    window_hours: String,
}

/// `POST /admin/quotas` (`split`, `limit`, `window_hours`): a split's limit per window.
pub async fn set_quota(State(state): State<AppState>, session: AdminSession, headers: HeaderMap, body: axum::body::Bytes) -> Response {
    let form: QuotaForm = match checked(&session, &headers, &body) {
        Ok(form) => form,
        Err(refused) => return refused,
    };
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
    match quota_policies::apply(&state, &form.split, &body).await {
        Ok(set) => back(&session, &format!("The {} split: {} submissions per team per {} hours.", set.split, set.limit, set.window_hours)),
        Err(problem) => AdminMessage::problem(problem),
    }
}

/// `POST /admin/access-requests/{id}/approve`: create the requested team; the requester
/// collects its token with the claim code.
pub async fn approve_access(
    State(state): State<AppState>,
    session: AdminSession,
    headers: HeaderMap,
    ApiPath(id): ApiPath<String>,
    body: axum::body::Bytes,
) -> Response {
    token_form(&session, &headers, &body, async {
        crate::access_requests::approve(&state, &id)
            .await
            .map(|r| format!("Team {} is created; its requester collects the token with the claim code.", r.team_name))
    })
    .await
}

#[derive(Deserialize)]
struct DeclineForm {
    form_token: String,
    reason: String,
}

/// `POST /admin/access-requests/{id}/decline` (`reason`, which the requester reads).
pub async fn decline_access(
    State(state): State<AppState>,
    session: AdminSession,
    headers: HeaderMap,
    ApiPath(id): ApiPath<String>,
    body: axum::body::Bytes,
) -> Response {
    let form: DeclineForm = match checked(&session, &headers, &body) {
        Ok(form) => form,
        Err(refused) => return refused,
    };
    match crate::access_requests::decline(&state, &id, &form.reason).await {
        Ok(r) => back(&session, &format!("The request for team {} is declined.", r.team_name)),
        Err(problem) => AdminMessage::problem(problem),
    }
}

#[derive(Deserialize)]
struct TeamForm {
    form_token: String,
    name: String,
}

/// `POST /admin/teams`: create a team; the answer shows its first token, once (it never
/// travels in a URL, so no redirect).
pub async fn create_team(State(state): State<AppState>, session: AdminSession, headers: HeaderMap, body: axum::body::Bytes) -> Response {
    let form: TeamForm = match checked(&session, &headers, &body) {
        Ok(form) => form,
        Err(refused) => return refused,
    };
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
