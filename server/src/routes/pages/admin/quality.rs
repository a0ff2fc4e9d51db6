//! `GET /admin/releases/{version}/quality`: a release's quality report beside the current
//! release's — the bar's counts, the oracle's VQA accuracy per category, coverage and
//! lighting measures averaged over scenes — and the draft's scenes one by one, so an
//! operator sees what publishing would change before publishing.

use askama::Template;
use askama_web::WebTemplate;
use axum::extract::State;
use axum::http::StatusCode;
use axum::response::{IntoResponse, Response};

use osmab_dataset::release::quality_report::{LightingMeasures, QualityReport};
use osmab_evaluator::scores::{Aggregate, Metric, Split};

use super::super::format::percent;
use super::{AdminMessage, AdminSession};
use crate::auth::Caller;
use crate::problem::ApiResult;
use crate::routes::extract::ApiPath;
use crate::state::AppState;
use crate::store::{ReleaseRecord, ReleaseState, StoreError};

/// Where a release keeps its quality report.
const REPORT: &str = "quality/quality_report.json";

/// One measure of both releases.
pub struct Measure {
    pub name: String,
    pub this: String,
    pub current: String,
    /// The change reads as worse (more problems, less coverage).
    pub worse: bool,
}

pub struct SceneRow {
    pub scene: String,
    pub subset: String,
    pub prompt: String,
    pub frames: String,
    pub travelled: String,
    pub degenerate: String,
    pub mapped: String,
    pub problems: Vec<String>,
}

#[derive(Template, WebTemplate)]
#[template(path = "admin_quality.html")]
pub struct QualityPage {
    pub version: String,
    pub current: Option<String>,
    pub draft: bool,
    pub form_token: String,
    pub measures: Vec<Measure>,
    pub problems: Vec<String>,
    pub scenes: Vec<SceneRow>,
    /// Every scene under every lighting: this release's sheet and the current one's.
    pub overview: Option<String>,
    pub current_overview: Option<String>,
    /// This release's boards of the entries scored on it (a draft's baselines), before
    /// anyone else can see them.
    pub boards: Vec<DraftBoard>,
}

/// A board of this release as the operator sees it before publishing.
pub struct DraftBoard {
    pub split: Split,
    pub lightings: Vec<&'static str>,
    pub rows: Vec<DraftRow>,
}

pub struct DraftRow {
    pub method: String,
    pub submission_id: String,
    /// Pooled mIoU per lighting.
    pub cells: Vec<String>,
}

/// The overview sheet of `record`, as the console serves it (a draft's files are the
/// operator's only), when the release has one.
fn overview_of(record: &ReleaseRecord) -> Option<String> {
    let path = osmab_dataset::release::OVERVIEW;
    crate::releases::served_manifest(record).has_file(path).then(|| format!("/admin/releases/{}/files/{path}", record.version))
}

/// The boards of every split of `record` from the store's scored entries of it.
async fn boards_of(state: &AppState, record: &ReleaseRecord) -> Result<Vec<DraftBoard>, StoreError> {
    let rows = state.store.leaderboard_rows(&record.version).await?;
    let manifest = crate::releases::served_manifest(record);
    let (lightings, splits) = (manifest.score_lightings(), manifest.splits());
    Ok(splits
        .iter()
        .map(|&split| {
            let board = crate::leaderboard::rank(&record.version, lightings.clone(), split, splits.clone(), rows.clone());
            DraftBoard {
                split,
                lightings: lightings.iter().map(|l| l.label()).collect(),
                rows: board
                    .entries
                    .iter()
                    .map(|e| DraftRow {
                        method: e.method.clone(),
                        submission_id: e.submission_id.clone(),
                        cells: lightings.iter().map(|&l| percent(e.metric(l, None, Aggregate::Overall, Metric::Miou))).collect(),
                    })
                    .collect(),
            }
        })
        .filter(|b| !b.rows.is_empty())
        .collect())
}

/// How a measure of two releases is judged.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Judged {
    /// A quality: higher is better.
    Higher,
    /// A quality: lower is better.
    Lower,
    /// Set by the configuration (how many scenes, how long the paths): shown, never
    /// flagged, since a smaller draft is no regression.
    Configuration,
}

/// The summary numbers of a report, by name; `None` where the report has no such measure.
/// Counts that grow with the number of scenes are compared as shares of them, so a draft
/// of fewer scenes is compared like with like.
fn summary(report: &QualityReport) -> Vec<(String, Option<f64>, Judged)> {
    let share = |count: Option<f64>| Some(count? / report.scenes.filter(|n| *n > 0.0)?);
    let mut rows = vec![
        ("scenes".to_string(), report.scenes, Judged::Configuration),
        ("scenes passing the bar (share)".to_string(), share(report.passed), Judged::Higher),
        ("scenes matching their prompt fully (share)".to_string(), share(report.full_match), Judged::Higher),
        ("problems per scene".to_string(), share(report.problems.as_ref().map(|p| p.len() as f64)), Judged::Lower),
        ("object instances mapped (share)".to_string(), report.mapped_share(), Judged::Higher),
        ("frames per scene (mean)".to_string(), report.mean_over_scenes(|s| s.frames), Judged::Configuration),
        ("camera travel per scene, m (mean)".to_string(), report.mean_over_scenes(|s| s.travelled_m), Judged::Configuration),
        ("degenerate frames (mean share)".to_string(), report.mean_over_scenes(|s| s.degenerate_fraction), Judged::Lower),
    ];
    for lighting in report.lightings() {
        let measure = |of: fn(&LightingMeasures) -> Option<f64>| report.mean_over_scenes(|s| s.lightings.get(&lighting).and_then(of));
        rows.push((format!("{lighting}: saturated pixels (median share, mean)"), measure(|l| l.median_saturated), Judged::Lower));
        // Brightness is the lighting's character, not a quality: shown, not judged.
        rows.push((format!("{lighting}: mean luma"), measure(|l| l.mean_luma), Judged::Configuration));
    }
    for (category, accuracy) in &report.oracle_vqa {
        rows.push((format!("oracle VQA accuracy, {category}"), Some(*accuracy), Judged::Higher));
    }
    rows
}

/// A measure as the page prints it.
fn shown(value: Option<f64>) -> String {
    match value {
        None => "–".into(),
        Some(v) if v.fract() == 0.0 && v.abs() < 1e9 => format!("{v:.0}"),
        Some(v) if v.abs() < 1.0 => format!("{v:.3}"),
        Some(v) => format!("{v:.1}"),
    }
}

/// `this` beside `current`, measure by measure (the union of both reports' measures); a
/// quality that got worse is marked, a difference of configuration is not.
fn compare(this: &QualityReport, current: Option<&QualityReport>) -> Vec<Measure> {
    let ours = summary(this);
    let theirs = current.map(summary).unwrap_or_default();
    let mut names: Vec<(String, Judged)> = ours.iter().map(|(n, _, j)| (n.clone(), *j)).collect();
    names.extend(theirs.iter().filter(|(n, _, _)| !ours.iter().any(|(m, _, _)| m == n)).map(|(n, _, j)| (n.clone(), *j)));
    names
        .into_iter()
        .map(|(name, judged)| {
            let of = |rows: &[(String, Option<f64>, Judged)]| rows.iter().find(|(n, _, _)| *n == name).and_then(|(_, v, _)| *v);
            let (a, b) = (of(&ours), of(&theirs));
            let worse = match (a, b, judged) {
                (Some(a), Some(b), Judged::Higher) => a < b - 1e-9,
                (Some(a), Some(b), Judged::Lower) => a > b + 1e-9,
                _ => false,
            };
            Measure { this: shown(a), current: shown(b), worse, name }
        })
        .collect()
}

fn scene_rows(report: &QualityReport) -> Vec<SceneRow> {
    report
        .per_scene
        .iter()
        .map(|s| SceneRow {
            scene: s.scene.clone(),
            subset: s.subset.clone(),
            prompt: s.prompt_id.clone().unwrap_or_default(),
            frames: shown(s.frames),
            travelled: shown(s.travelled_m),
            degenerate: shown(s.degenerate_fraction),
            mapped: format!("{}/{}", s.mapped(), s.instances.len()),
            problems: s.problems.clone(),
        })
        .collect()
}

/// The full quality report, kept with the ground truth (every measure of the test scenes
/// too); releases built before splits have the public one only.
const FULL_REPORT: &str = "ground_truth/quality_report.json";

/// The quality report of `version`, read from the blob store: the full one when the
/// release keeps it, else the public one.
async fn report_of(state: &AppState, version: &str) -> Result<QualityReport, String> {
    let prefix = crate::releases::release_prefix(version);
    let fetched = match state.blobs.fetch(&format!("{prefix}/{FULL_REPORT}")).await {
        Ok(full) => full,
        Err(_) => state.blobs.fetch(&format!("{prefix}/{REPORT}")).await.map_err(|e| format!("release {version} has no readable quality report: {e}"))?,
    };
    let bytes = tokio::fs::read(fetched.path()).await.map_err(|e| format!("{REPORT} of {version}: {e}"))?;
    QualityReport::parse(&bytes, &format!("{REPORT} of {version}"))
}

/// `GET /admin/releases/{version}/quality`.
pub async fn quality(State(state): State<AppState>, session: AdminSession, ApiPath(version): ApiPath<String>) -> Response {
    let release = match state.store.release(&version).await {
        Ok(r) => r,
        Err(StoreError::NotFound) => return AdminMessage::page(StatusCode::NOT_FOUND, "No such release", &format!("There is no release '{version}'.")),
        Err(e) => return AdminMessage::problem(e.into()),
    };
    let this = match report_of(&state, &version).await {
        Ok(report) => report,
        Err(message) => return AdminMessage::page(StatusCode::NOT_FOUND, "No quality report", &message),
    };
    let current_record = match state.store.current_release().await {
        Ok(current) if current.version != version => Some(current),
        _ => None,
    };
    let current = current_record.as_ref().map(|r| r.version.clone());
    let boards = match boards_of(&state, &release).await {
        Ok(boards) => boards,
        Err(e) => return AdminMessage::problem(e.into()),
    };
    let current_report = match &current {
        Some(v) => report_of(&state, v).await.ok(),
        None => None,
    };
    QualityPage {
        overview: overview_of(&release),
        current_overview: current_record.as_ref().and_then(overview_of),
        boards,
        measures: compare(&this, current_report.as_ref()),
        problems: this.problems.clone().unwrap_or_default(),
        scenes: scene_rows(&this),
        draft: release.state == ReleaseState::Draft,
        form_token: session.form_token(),
        current,
        version,
    }
    .into_response()
}

/// `GET /admin/releases/{version}/files/{path}`: a release's public file for the signed-in
/// operator — a draft's too, which the public route does not show (the console's session
/// cookie is scoped to `/admin`).
pub async fn file(
    State(state): State<AppState>,
    _: AdminSession,
    ApiPath((version, path)): ApiPath<(String, String)>,
    headers: axum::http::HeaderMap,
) -> ApiResult<Response> {
    crate::routes::releases::file(State(state), Caller::Admin, ApiPath((version, path)), headers).await
}

#[cfg(test)]
mod tests {
    use super::*;
    use serde_json::json;

    fn report(passed: u32, mapped: [bool; 2], problems: &[&str]) -> QualityReport {
        let report = json!({
            "scenes": 2, "passed": passed, "full_match": passed, "problems": problems, "oracle_vqa": {"counting": 0.9},
            "per_scene": [
                {"scene": "scene_000", "subset": "furniture", "prompt_id": "p1", "frames": 100, "travelled_m": 12.5, "degenerate_fraction": 0.01,
                 "instances": [{"mapped": mapped[0]}, {"mapped": mapped[1]}], "problems": problems,
                 "lightings": {"baseline": {"median_saturated": 0.001, "mean_luma": 120.0}}},
                {"scene": "scene_001", "subset": "manipuland", "prompt_id": "p2", "frames": 80, "travelled_m": 7.5, "degenerate_fraction": 0.03,
                 "instances": [], "problems": [], "lightings": {"baseline": {"median_saturated": 0.003, "mean_luma": 100.0}}}
            ]
        });
        QualityReport::parse(report.to_string().as_bytes(), "report").unwrap()
    }

    #[test]
    fn a_draft_is_compared_measure_by_measure_and_regressions_are_marked() {
        let draft = report(1, [true, false], &["scene_000: a prompted lamp is not mapped"]);
        let current = report(2, [true, true], &[]);
        let measures = compare(&draft, Some(&current));
        let get = |name: &str| measures.iter().find(|m| m.name == name).unwrap();
        let passing = get("scenes passing the bar (share)");
        assert_eq!((passing.this.as_str(), passing.current.as_str(), passing.worse), ("0.500", "1", true));
        let mapped = get("object instances mapped (share)");
        assert_eq!((mapped.this.as_str(), mapped.current.as_str(), mapped.worse), ("0.500", "1", true));
        assert!(get("problems per scene").worse, "more problems read as worse");
        let travel = get("camera travel per scene, m (mean)");
        assert_eq!((travel.this.as_str(), travel.worse), ("10", false));
        assert_eq!(get("baseline: mean luma").this, "110");
        assert_eq!(get("oracle VQA accuracy, counting").this, "0.900");
        let alone = compare(&draft, None);
        assert!(alone.iter().all(|m| m.current == "–" && !m.worse), "nothing to compare with");
        let rows = scene_rows(&draft);
        assert_eq!((rows[0].mapped.as_str(), rows[0].problems.len(), rows[1].mapped.as_str()), ("1/2", 1, "0/0"));
    }

    #[test]
    fn a_smaller_draft_is_compared_like_with_like() {
        // Half the scenes, all passing; fewer frames and a shorter path by configuration.
        let small = json!({
            "scenes": 1, "passed": 1, "full_match": 1, "problems": [],
            "per_scene": [{"scene": "scene_000", "subset": "furniture", "frames": 40, "travelled_m": 3.0, "degenerate_fraction": 0.01,
                           "instances": [{"mapped": true}], "problems": [], "lightings": {"baseline": {"median_saturated": 0.001, "mean_luma": 90.0}}}]
        });
        let small = QualityReport::parse(small.to_string().as_bytes(), "report").unwrap();
        let current = report(2, [true, true], &[]);
        let measures = compare(&small, Some(&current));
        let flagged: Vec<&str> = measures.iter().filter(|m| m.worse).map(|m| m.name.as_str()).collect();
        assert!(flagged.is_empty(), "differences of configuration are no regressions: {flagged:?}");
        assert_eq!(measures.iter().find(|m| m.name == "scenes").map(|m| (m.this.as_str(), m.current.as_str())), Some(("1", "2")));
    }
}
