//! The operator's console at `/admin`: pages and plain HTML forms (no JavaScript) for what
//! maintainers otherwise do with `curl` — start a regeneration from a config, watch its
//! stages and render jobs, compare a draft's quality report with the current release's,
//! publish, flag entries, refund quota. Every action goes through the same functions as
//! the admin API (`routes::admin`); [`session`] says how an operator signs in.

mod actions;
mod console;
mod origin;
mod quality;
mod session;

use askama::Template;
use askama_web::WebTemplate;
use axum::http::StatusCode;
use axum::response::{IntoResponse, Response};
use serde::de::DeserializeOwned;

pub use actions::{approve_access, create_team, decline_access, flag, publish, refund, regenerate, set_quota, unflag};
pub use console::{console, job};
pub use quality::{file as release_file, quality};
pub use session::{AdminSession, LOGIN_PATH, login, login_form, logout};

/// The console's pages and forms, each signed in through [`AdminSession`] (the sign-in
/// page and form excepted).
pub fn routes() -> axum::Router<crate::state::AppState> {
    use axum::routing::{get, post};
    axum::Router::new()
        .route("/admin", get(console))
        .route(LOGIN_PATH, get(login_form).post(login))
        .route("/admin/logout", post(logout))
        .route("/admin/regenerate", post(regenerate))
        .route("/admin/jobs/{id}", get(job))
        .route("/admin/releases/{version}/quality", get(quality))
        .route("/admin/releases/{version}/files/{*path}", get(release_file))
        .route("/admin/releases/{version}/publish", post(publish))
        .route("/admin/submissions/{id}/flag", post(flag))
        .route("/admin/submissions/{id}/unflag", post(unflag))
        .route("/admin/submissions/{id}/refund", post(refund))
        .route("/admin/quotas", post(set_quota))
        .route("/admin/teams", post(create_team))
        .route("/admin/access-requests/{id}/approve", post(approve_access))
        .route("/admin/access-requests/{id}/decline", post(decline_access))
}

/// The sign-in page.
#[derive(Template, WebTemplate)]
#[template(path = "admin_login.html")]
pub struct LoginPage {
    pub error: Option<String>,
}

/// A team just created, with its first token (shown this once).
#[derive(Template, WebTemplate)]
#[template(path = "admin_team_created.html")]
pub struct TeamCreatedPage {
    pub name: String,
    pub id: String,
    pub token: String,
    /// The service's public origin, for the login command.
    pub origin: String,
    pub form_token: String,
}

/// A console page that only says something (a refused form, a missing record).
#[derive(Template, WebTemplate)]
#[template(path = "admin_message.html")]
pub struct AdminMessage {
    pub title: String,
    pub message: String,
}

impl AdminMessage {
    pub fn page(status: StatusCode, title: &str, message: &str) -> Response {
        (status, AdminMessage { title: title.into(), message: message.into() }).into_response()
    }

    /// The page of a refused action: the problem's status and words.
    pub fn problem(problem: crate::problem::Problem) -> Response {
        AdminMessage::page(problem.status, &problem.title, &problem.detail)
    }
}

/// Bytes of an `application/x-www-form-urlencoded` body as `T`, or a page saying what is wrong.
pub fn parse_form<T: DeserializeOwned>(body: &[u8]) -> Result<T, Response> {
    serde_urlencoded::from_bytes(body)
        .map_err(|e| AdminMessage::page(StatusCode::BAD_REQUEST, "Form not understood", &format!("The form's fields do not read: {e}.")))
}
