//! Server-rendered pages (askama templates in `templates/`, styles in `static/`). They
//! work without JavaScript: sorting and the choice of aggregate and subset are links.
//! Numbers are formatted in [`format`], and every chart is a [`chart::BarChart`].

mod about;
pub mod admin;
mod chart;
mod format;
mod leaderboard;
mod release;
mod submission;
mod take_part;
mod vqa;

use askama::Template;
use askama_web::WebTemplate;
use axum::Router;
use axum::http::header;
use axum::response::{IntoResponse, Response};
use axum::routing::{get, post};

pub use about::about;
pub use leaderboard::leaderboard;
pub use release::release;
pub use submission::submission;

use super::extract::ApiPath;
use crate::problem::Problem;
use crate::state::AppState;

/// A page that only says something (no leaderboard yet).
#[derive(Template, WebTemplate)]
#[template(path = "message.html")]
pub struct MessagePage {
    pub title: String,
    pub message: String,
}

/// The answer to a page that does not exist, for a browser.
#[derive(Template, WebTemplate)]
#[template(path = "not_found.html")]
pub struct NotFoundPage {
    pub path: String,
}

const STYLE: &str = include_str!("../../../../static/style.css");
const FAVICON: &str = include_str!("../../../../static/favicon.svg");

/// `GET /static/{file}`: the vendored assets.
pub async fn static_file(ApiPath(file): ApiPath<String>) -> Response {
    match file.as_str() {
        "style.css" => ([(header::CONTENT_TYPE, "text/css; charset=utf-8"), (header::CACHE_CONTROL, "public, max-age=3600")], STYLE).into_response(),
        "favicon.svg" => ([(header::CONTENT_TYPE, "image/svg+xml"), (header::CACHE_CONTROL, "public, max-age=86400")], FAVICON).into_response(),
        _ => Problem::not_found(format!("There is no static file '{file}'.")).into_response(),
    }
}

/// The public pages and the organisers' console (`/admin`, signed in with a cookie).
pub fn routes() -> Router<AppState> {
    Router::new()
        .route("/", get(leaderboard))
        .route("/releases/{version}", get(release))
        .route("/submissions/{id}", get(submission))
        .route("/about", get(about))
        .route("/take-part", get(take_part::take_part).post(take_part::ask))
        .route("/take-part/collect", post(take_part::collect))
        .route("/static/{file}", get(static_file))
        .route("/favicon.ico", get(|| async { axum::response::Redirect::permanent("/static/favicon.svg") }))
        .merge(admin::routes())
}
