//! `GET /about`: what the benchmark measures, how to take part, what the boards show, how to
//! cite a result and under which licences — linked from every page.

use askama::Template;
use askama_web::WebTemplate;
use axum::extract::State;
use serde::Deserialize;

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

/// What the page reads of a manifest: each scene's split (`val` where a release predates splits).
#[derive(Deserialize)]
struct ManifestScenes {
    scenes: Vec<ManifestScene>,
}

#[derive(Deserialize)]
struct ManifestScene {
    #[serde(default)]
    split: Option<String>,
}

/// `GET /about`.
pub async fn about(State(state): State<AppState>) -> AboutPage {
    let release = state.store.current_release().await.ok().map(|r| {
        let scenes = serde_json::from_str::<ManifestScenes>(&r.manifest).map(|m| m.scenes).unwrap_or_default();
        let test_scenes = scenes.iter().filter(|s| s.split.as_deref() == Some("test")).count();
        CurrentRelease { version: r.version, digest: r.digest, scenes: scenes.len(), test_scenes, val_scenes: scenes.len() - test_scenes }
    });
    AboutPage { origin: state.settings.public_url.clone().unwrap_or_default(), release }
}
