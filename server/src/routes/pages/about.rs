//! `GET /about`: what the benchmark measures, how to take part, what the boards show, how to
//! cite a result and under which licences — linked from every page.

use askama::Template;
use askama_web::WebTemplate;
use axum::extract::State;
use osmab_evaluator::scores::Metric;

use crate::state::AppState;

#[derive(Template, WebTemplate)]
#[template(path = "about.html")]
pub struct AboutPage {
    /// The service's origin, for the commands shown.
    pub origin: String,
    pub release: Option<CurrentRelease>,
}

/// The current release, as the page names it.
pub struct CurrentRelease {
    pub version: String,
    pub digest: String,
    pub scenes: usize,
    pub test_scenes: usize,
    pub val_scenes: usize,
}

/// `GET /about`.
pub async fn about(State(state): State<AppState>) -> AboutPage {
    let release = state.store.current_release().await.ok().map(|r| {
        let (test_scenes, val_scenes) = crate::releases::served_manifest(&r).split_sizes();
        CurrentRelease { version: r.version, digest: r.digest, scenes: test_scenes + val_scenes, test_scenes, val_scenes }
    });
    AboutPage { origin: state.settings.public_url.clone().unwrap_or_default(), release }
}
