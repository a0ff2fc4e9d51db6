//! `GET /take-part`: ask for access (a plain form, no script) and collect the team's token
//! with the claim code shown when asking (`crate::access_requests` has the rules).

use askama::Template;
use askama_web::WebTemplate;
use axum::extract::State;
use axum::http::request::Parts;
use axum::http::{StatusCode, header};
use axum::response::{IntoResponse, Response};
use serde::Deserialize;

use super::admin::parse_form;
use crate::access_requests::AccessRequestForm;
use crate::state::AppState;

/// The form's fields as typed (kept to fill the form again after a refusal).
#[derive(Debug, Default, Deserialize)]
pub struct TypedForm {
    #[serde(default)]
    pub team_name: String,
    #[serde(default)]
    pub contact: String,
    #[serde(default)]
    pub affiliation: String,
    #[serde(default)]
    pub method_url: String,
}

#[derive(Template, WebTemplate)]
#[template(path = "take_part.html")]
pub struct TakePartPage {
    pub origin: String,
    pub error: Option<String>,
    pub form: TypedForm,
}

#[derive(Template, WebTemplate)]
#[template(path = "take_part_asked.html")]
pub struct AskedPage {
    pub origin: String,
    pub id: String,
    pub team_name: String,
    pub claim_code: String,
}

#[derive(Template, WebTemplate)]
#[template(path = "take_part_collected.html")]
pub struct CollectedPage {
    pub origin: String,
    pub team_name: String,
    pub state: String,
    pub message: String,
    pub token: Option<String>,
}

fn origin(state: &AppState) -> String {
    state.settings.public_url.clone().unwrap_or_default()
}

/// `GET /take-part`.
pub async fn take_part(State(state): State<AppState>) -> TakePartPage {
    TakePartPage { origin: origin(&state), error: None, form: TypedForm::default() }
}

/// `POST /take-part`: the request; the answer shows its claim code, once.
pub async fn ask(State(state): State<AppState>, parts: Parts, body: axum::body::Bytes) -> Response {
    let typed: TypedForm = match parse_form(&body) {
        Ok(form) => form,
        Err(response) => return response,
    };
    let form = AccessRequestForm {
        team_name: typed.team_name.clone(),
        contact: typed.contact.clone(),
        affiliation: typed.affiliation.clone(),
        method_url: Some(typed.method_url.clone()).filter(|u| !u.trim().is_empty()),
    };
    let client = crate::routes::access_requests::client_of(&state, &parts.headers, crate::http::peer_ip(&parts.extensions));
    match crate::access_requests::ask(&state, &form, &client).await {
        Ok(asked) => (
            StatusCode::CREATED,
            [(header::CACHE_CONTROL, "no-store")],
            AskedPage { origin: origin(&state), id: asked.id, team_name: form.team_name.trim().to_string(), claim_code: asked.claim_code },
        )
            .into_response(),
        Err(problem) => (problem.status, TakePartPage { origin: origin(&state), error: Some(problem.detail), form: typed }).into_response(),
    }
}

#[derive(Deserialize)]
struct ClaimForm {
    claim_code: String,
}

/// `POST /take-part/collect`: where the request stands, or the team's token once.
pub async fn collect(State(state): State<AppState>, parts: Parts, body: axum::body::Bytes) -> Response {
    let form: ClaimForm = match parse_form(&body) {
        Ok(form) => form,
        Err(response) => return response,
    };
    let refused = |problem: crate::problem::Problem| {
        (problem.status, TakePartPage { origin: origin(&state), error: Some(problem.detail), form: TypedForm::default() }).into_response()
    };
    match crate::access_requests::collect(&state, &form.claim_code).await {
        Ok(collected) => (
            [(header::CACHE_CONTROL, "no-store")],
            CollectedPage {
                origin: origin(&state),
                team_name: collected.team_name,
                state: collected.state.to_string(),
                message: collected.message,
                token: collected.token,
            },
        )
            .into_response(),
        Err(Some(problem)) => refused(problem),
        Err(None) => {
            let client = crate::routes::access_requests::client_of(&state, &parts.headers, crate::http::peer_ip(&parts.extensions));
            refused(crate::routes::access_requests::unknown_claim(&state, &client))
        }
    }
}
