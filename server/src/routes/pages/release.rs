//! `GET /releases/{version}`: a release's downloads, its scenes with their prompts and
//! preview frames, and the overview contact sheet.

use askama::Template;
use askama_web::WebTemplate;
use axum::extract::State;
use axum::response::{IntoResponse, Response};
use osmab_evaluator::scores::Lighting;
use serde_json::Value;

use super::format::human_size;
use crate::auth::Caller;
use crate::problem::{ApiResult, Problem};
use crate::routes::ApiPath;
use crate::state::AppState;

/// A lighting as the paper names it (a name this server does not know, as written).
fn lighting_label(name: &str) -> String {
    name.parse::<Lighting>().map(|l| l.label().to_string()).unwrap_or_else(|_| name.replace('_', " "))
}

pub struct SceneView {
    pub id: String,
    pub subset: String,
    /// `val` or `test`.
    pub split: String,
    /// The prompt (none for a test scene, which publishes none).
    pub prompt: Option<String>,
    pub thumbnail: Option<String>,
}

pub struct ArchiveView {
    pub lighting: String,
    pub scene: String,
    pub link: String,
    pub size: String,
    pub sha256: String,
}

#[derive(Template, WebTemplate)]
#[template(path = "release.html")]
pub struct ReleasePage {
    pub version: String,
    pub state: String,
    pub digest: String,
    pub created: String,
    pub files: usize,
    pub total_size: String,
    pub manifest_link: String,
    pub lightings: Vec<String>,
    /// Every scene under every lighting in one picture, when the release has it.
    pub overview: Option<String>,
    pub scenes: Vec<SceneView>,
    pub archives: Vec<ArchiveView>,
}

/// `GET /releases/{version}`: downloads, scenes with prompts and thumbnails.
pub async fn release(State(state): State<AppState>, caller: Caller, ApiPath(version): ApiPath<String>) -> ApiResult<Response> {
    let version = crate::routes::releases::resolve(&state, &version).await?;
    let record = crate::routes::releases::visible_release(&state, &caller, &version).await?;
    let manifest: Value = serde_json::from_str(&record.manifest).map_err(Problem::internal)?;
    let files = manifest["files"].as_array().cloned().unwrap_or_default();
    let has = |path: &str| files.iter().any(|f| f["path"] == path);
    let thumbnail_lighting = manifest["lightings"].as_array().and_then(|l| l.first()).and_then(Value::as_str).unwrap_or("baseline").to_string();
    let scenes = manifest["scenes"]
        .as_array()
        .into_iter()
        .flatten()
        .map(|s| {
            let id = s["id"].as_str().unwrap_or("").to_string();
            // The frame that shows the most of the scene (releases name it), else the first.
            let frame = s["preview"].as_str().map(str::to_string).unwrap_or_else(|| format!("sequences/{thumbnail_lighting}/{id}/results/frame000000.jpg"));
            SceneView {
                subset: s["subset"].as_str().unwrap_or("").to_string(),
                split: s["split"].as_str().unwrap_or("val").to_string(),
                prompt: s["prompt"].as_str().map(str::to_string),
                thumbnail: has(&frame).then(|| format!("/api/v1/releases/{version}/files/{frame}")),
                id,
            }
        })
        .collect();
    let archives = manifest["archives"]
        .as_array()
        .into_iter()
        .flatten()
        .map(|a| ArchiveView {
            lighting: lighting_label(a["lighting"].as_str().unwrap_or("")),
            scene: a["scene"].as_str().unwrap_or("").to_string(),
            link: format!("/api/v1/releases/{version}/files/{}", a["path"].as_str().unwrap_or("")),
            size: human_size(a["size"].as_u64().unwrap_or(0)),
            sha256: a["sha256"].as_str().unwrap_or("").to_string(),
        })
        .collect();
    Ok(ReleasePage {
        version: record.version.clone(),
        state: record.state.to_string(),
        digest: record.digest.clone(),
        created: manifest["created"].as_str().unwrap_or("").to_string(),
        files: files.len(),
        total_size: human_size(files.iter().filter_map(|f| f["size"].as_u64()).sum()),
        manifest_link: format!("/api/v1/releases/{version}/manifest.json"),
        lightings: manifest["lightings"].as_array().into_iter().flatten().filter_map(Value::as_str).map(lighting_label).collect(),
        overview: has(osmab_dataset::release::OVERVIEW).then(|| format!("/api/v1/releases/{version}/files/{}", osmab_dataset::release::OVERVIEW)),
        scenes,
        archives,
    }
    .into_response())
}
