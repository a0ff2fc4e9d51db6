//! Server-rendered pages (askama templates in `templates/`, styles in `static/`). They
//! work without JavaScript: sorting and the choice of aggregate and subset are links.
//! Numbers are formatted in [`format`], and every chart is a [`chart::BarChart`].

mod about;
pub mod admin;
mod chart;
mod format;
mod leaderboard;
mod manifest;
mod release;
mod submission;
mod vqa;

use askama::Template;
use askama_web::WebTemplate;
use axum::http::header;
use axum::response::{IntoResponse, Response};

pub use about::about;
pub use leaderboard::leaderboard;
pub use release::release;
pub use submission::submission;

use super::ApiPath;
use crate::problem::Problem;

/// A page that only says something (no leaderboard yet).
#[derive(Template, WebTemplate)]
#[template(path = "message.html")]
pub struct MessagePage {
    pub title: String,
    pub message: String,
}

const STYLE: &str = include_str!("../../../../static/style.css");

/// `GET /static/{file}`: the vendored assets.
pub async fn static_file(ApiPath(file): ApiPath<String>) -> Response {
    match file.as_str() {
        "style.css" => ([(header::CONTENT_TYPE, "text/css; charset=utf-8"), (header::CACHE_CONTROL, "public, max-age=3600")], STYLE).into_response(),
        _ => Problem::not_found(format!("There is no static file '{file}'.")).into_response(),
    }
}
