//! `GET /releases/{version}`: a release's downloads, its scenes with their prompts and
//! preview frames, and the overview contact sheet.

use askama::Template;
use askama_web::WebTemplate;
use axum::extract::State;
use axum::response::{IntoResponse, Response};
use osmab_evaluator::scores::ReleaseLighting;

use super::format::human_size;
use crate::auth::Caller;
use crate::problem::ApiResult;
use crate::routes::extract::ApiPath;
use crate::state::AppState;

/// A lighting as `label` names it (the paper's label, or the short one for links in a
/// row); a name this server does not know, as written.

pub struct SceneView {
    pub id: String,
    pub subset: String,
    /// `val` or `test`.
    pub split: String,
    /// The prompt (none for a test scene, which publishes none).
    pub prompt: Option<String>,
    pub thumbnail: Option<String>,
    /// Every frame of each lighting's sequence in one sheet: (lighting, link).
    pub contact_sheets: Vec<(String, String)>,
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
    /// The day the release was built (imported into this server).
    pub built: String,
    /// The date its configuration gives.
    pub config_date: String,
    pub files: usize,
    pub total_size: String,
    pub manifest_link: String,
    pub lightings: Vec<String>,
    /// Every scene under every lighting in one picture, when the release has it.
    pub overview: Option<String>,
    pub test_scenes: usize,
    pub val_scenes: usize,
    pub scenes: Vec<SceneView>,
    pub archives: Vec<ArchiveView>,
    /// Every published release (newest first) with whether it is the current one: each has a
    /// page and a board.
    pub releases: Vec<(String, bool)>,
}

/// `GET /releases/{version}`: downloads, scenes with prompts and thumbnails.
pub async fn release(State(state): State<AppState>, caller: Caller, ApiPath(version): ApiPath<String>) -> ApiResult<Response> {
    let version = crate::routes::releases::resolve(&state, &version).await?;
    let record = crate::routes::releases::visible_release(&state, &caller, &version).await?;
    let manifest = crate::releases::served_manifest(&record);
    let file_link = |path: &str| format!("/api/v1/releases/{version}/files/{path}");
    let thumbnail_lighting = manifest.lightings.first().copied().unwrap_or(ReleaseLighting::BASELINE);
    let scenes = manifest
        .scenes
        .iter()
        .map(|s| {
            // The frame that shows the most of the scene (releases name it), else the first.
            let frame = s.preview.clone().unwrap_or_else(|| format!("sequences/{thumbnail_lighting}/{}/results/frame000000.jpg", s.id));
            let contact_sheets = manifest
                .lightings
                .iter()
                .filter_map(|l| {
                    let path = format!("quality/contact_sheets/{l}/{}.png", s.id);
                    manifest.has_file(&path).then(|| (l.lighting().short_label().to_string(), file_link(&path)))
                })
                .collect();
            SceneView {
                id: s.id.clone(),
                subset: s.subset.to_string(),
                split: s.split.to_string(),
                prompt: s.prompt.clone(),
                thumbnail: manifest.has_file(&frame).then(|| file_link(&frame)),
                contact_sheets,
            }
        })
        .collect();
    let archives = manifest
        .archives
        .iter()
        .map(|a| ArchiveView {
            lighting: a.lighting.label().to_string(),
            scene: a.scene.clone(),
            link: file_link(&a.path),
            size: human_size(a.size),
            sha256: a.sha256.clone(),
        })
        .collect();
    let (test_scenes, val_scenes) = manifest.split_sizes();
    Ok(ReleasePage {
        version: record.version.clone(),
        state: record.state.to_string(),
        digest: record.digest.clone(),
        built: crate::clock::rfc3339(record.created_at).chars().take(10).collect(),
        config_date: manifest.created.clone(),
        files: manifest.files.len(),
        total_size: human_size(manifest.files.iter().map(|f| f.size).sum()),
        manifest_link: format!("/api/v1/releases/{version}/manifest.json"),
        lightings: manifest.lightings.iter().map(|l| l.label().to_string()).collect(),
        overview: manifest.has_file(osmab_dataset::release::OVERVIEW).then(|| file_link(osmab_dataset::release::OVERVIEW)),
        test_scenes,
        val_scenes,
        scenes,
        archives,
        releases: state.store.published_versions().await?,
    }
    .into_response())
}
