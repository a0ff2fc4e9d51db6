//! Server-rendered pages (askama templates in `templates/`, styles in `static/`). They
//! work without JavaScript: sorting and the choice of aggregate and subset are links.

use askama::Template;
use askama_web::WebTemplate;
use axum::extract::State;
use axum::http::{StatusCode, header};
use axum::response::{IntoResponse, Response};
use serde::Deserialize;
use serde_json::Value;

use super::{ApiPath, ApiQuery};
use crate::auth::Caller;
use crate::leaderboard::{Entry, METRICS};
use crate::problem::{ApiResult, Problem};
use crate::state::AppState;

/// How the paper names each lighting.
pub fn lighting_label(lighting: &str) -> String {
    match lighting {
        "baseline" => "Baseline".into(),
        "camera" => "Camera Light".into(),
        "dynamic_lights" => "Dynamic Lights".into(),
        "no_lights" => "Nominal Lights".into(),
        other => other.replace('_', " "),
    }
}

fn metric_label(metric: &str) -> &'static str {
    match metric {
        "miou" => "mIoU",
        "fmiou" => "f-mIoU",
        _ => "mAcc",
    }
}

/// A metric in percent with one decimal, or an en dash where undefined.
pub(super) fn percent(v: Option<f64>) -> String {
    v.map(|x| format!("{:.1}", 100.0 * x)).unwrap_or_else(|| "–".into())
}

fn signed_percent(v: Option<f64>) -> String {
    v.map(|x| format!("{:+.1}%", 100.0 * x)).unwrap_or_else(|| "–".into())
}

pub(super) fn escape_xml(text: &str) -> String {
    text.replace('&', "&amp;").replace('<', "&lt;").replace('>', "&gt;").replace('"', "&quot;")
}

#[derive(Debug, Deserialize, Default)]
pub struct BoardQuery {
    release: Option<String>,
    /// `overall` (pooled, default) or `overall_mean`.
    agg: Option<String>,
    /// `all` (default), `furniture` or `manipuland`.
    subset: Option<String>,
    /// `<lighting>.<metric>`.
    sort: Option<String>,
}

pub struct Column {
    pub lighting: String,
    pub label: String,
    pub metric_label: &'static str,
    pub sort_link: String,
    pub sorted: bool,
    pub first_of_lighting: bool,
}

pub struct Row {
    pub rank: usize,
    pub submission_id: String,
    pub team: String,
    pub method: String,
    pub paper_url: Option<String>,
    pub baseline: bool,
    pub complete: bool,
    pub cells: Vec<String>,
    pub changes: Vec<String>,
}

pub struct Choice {
    pub label: &'static str,
    pub link: String,
    pub active: bool,
}

#[derive(Template, WebTemplate)]
#[template(path = "leaderboard.html")]
pub struct LeaderboardPage {
    pub release: String,
    pub lighting_groups: Vec<(String, usize)>,
    pub columns: Vec<Column>,
    pub change_headers: Vec<String>,
    pub rows: Vec<Row>,
    pub aggregates: Vec<Choice>,
    pub subsets: Vec<Choice>,
    pub chart: String,
    pub csv_link: String,
    pub json_link: String,
    pub vqa: Option<super::pages_vqa::VqaView>,
}

#[derive(Template, WebTemplate)]
#[template(path = "message.html")]
pub struct MessagePage {
    pub title: String,
    pub message: String,
}

fn link(release: &str, agg: &str, subset: &str, sort: &str) -> String {
    format!("/?release={release}&agg={agg}&subset={subset}&sort={sort}")
}

/// A short name of a lighting for narrow column headers.
pub(super) fn lighting_short(lighting: &str) -> String {
    match lighting {
        "camera" => "Camera".into(),
        "dynamic_lights" => "Dynamic".into(),
        "no_lights" => "Nominal".into(),
        other => lighting_label(other),
    }
}

/// The relative change of mIoU against the baseline lighting, one group of bars per
/// lighting and one bar per entry (the paper's robustness figure). `entries` come in the
/// leaderboard's own order, so a method keeps its colour whatever the table's sorting;
/// `changes[i][g]` is entry i's change under the g-th non-baseline lighting.
fn change_chart(entries: &[&Entry], others: &[String], changes: &[Vec<Option<f64>>]) -> String {
    if entries.is_empty() || others.is_empty() {
        return String::new();
    }
    let shown: Vec<&Entry> = entries.iter().take(8).copied().collect();
    let values = changes;
    // The axis reaches the largest change, rounded up to a multiple of 5 %.
    let extent = (values.iter().flatten().flatten().fold(0.05f64, |m, v| m.max(v.abs())).min(1.0) * 20.0).ceil() / 20.0;
    let (width, height, top, bottom, left) = (720.0, 260.0, 20.0, 60.0, 50.0);
    let plot_h = height - top - bottom;
    let zero = top + plot_h / 2.0;
    let group_w = (width - left - 10.0) / others.len() as f64;
    let bar_w = (group_w * 0.8 / shown.len() as f64).min(28.0);
    let palette = ["#1f77b4", "#ff7f0e", "#2ca02c", "#d62728", "#9467bd", "#8c564b", "#e377c2", "#7f7f7f"];
    let mut svg = format!(
        "<svg xmlns=\"http://www.w3.org/2000/svg\" viewBox=\"0 0 {width} {height}\" role=\"img\" aria-labelledby=\"chart-title\" class=\"chart\"><title id=\"chart-title\">Relative change of pooled mIoU against the baseline lighting</title>"
    );
    for frac in [-1.0, -0.5, 0.0, 0.5, 1.0] {
        let y = zero - frac * plot_h / 2.0;
        svg.push_str(&format!(
            "<line x1=\"{left}\" x2=\"{}\" y1=\"{y:.1}\" y2=\"{y:.1}\" class=\"grid\"/><text x=\"{}\" y=\"{:.1}\" class=\"axis\" text-anchor=\"end\">{:+.1}%</text>",
            width - 10.0,
            left - 6.0,
            y + 4.0,
            frac * extent * 100.0
        ));
    }
    for (g, lighting) in others.iter().enumerate() {
        let x0 = left + g as f64 * group_w + group_w * 0.1;
        for (i, entry) in shown.iter().enumerate() {
            if let Some(v) = values[i][g] {
                let h = (v / extent).clamp(-1.0, 1.0) * plot_h / 2.0;
                let (y, hh) = if h >= 0.0 { (zero - h, h) } else { (zero, -h) };
                svg.push_str(&format!(
                    "<rect x=\"{:.1}\" y=\"{y:.1}\" width=\"{bar_w:.1}\" height=\"{:.1}\" fill=\"{}\"><title>{} — {}: {:+.1}%</title></rect>",
                    x0 + i as f64 * bar_w,
                    hh.max(0.5),
                    palette[i % palette.len()],
                    escape_xml(&entry.method),
                    escape_xml(&lighting_label(lighting)),
                    v * 100.0
                ));
            }
        }
        svg.push_str(&format!(
            "<text x=\"{:.1}\" y=\"{:.1}\" class=\"axis\" text-anchor=\"middle\">{}</text>",
            left + g as f64 * group_w + group_w / 2.0,
            height - bottom + 18.0,
            escape_xml(&lighting_label(lighting))
        ));
    }
    for (i, entry) in shown.iter().enumerate() {
        let x = left + (i % 4) as f64 * 165.0;
        let y = height - 22.0 + (i / 4) as f64 * 14.0;
        svg.push_str(&format!(
            "<rect x=\"{x:.1}\" y=\"{:.1}\" width=\"10\" height=\"10\" fill=\"{}\"/><text x=\"{:.1}\" y=\"{y:.1}\" class=\"legend\">{}</text>",
            y - 9.0,
            palette[i % palette.len()],
            x + 14.0,
            escape_xml(&entry.method.chars().take(22).collect::<String>())
        ));
    }
    svg.push_str("</svg>");
    svg
}

/// `GET /`: the leaderboard of the current (or chosen) release.
pub async fn leaderboard(State(state): State<AppState>, ApiQuery(query): ApiQuery<BoardQuery>) -> Response {
    let rendered = match super::leaderboard::rendered(&state, query.release.as_deref()).await {
        Ok(r) => r,
        Err(problem) => {
            let status = problem.status;
            let page = MessagePage { title: "No leaderboard yet".into(), message: problem.detail };
            return (if status == StatusCode::NOT_FOUND { StatusCode::OK } else { status }, [(header::REFRESH, "10")], page).into_response();
        }
    };
    let board = &rendered.board;
    let agg = match query.agg.as_deref() {
        Some("overall_mean") => "overall_mean",
        _ => "overall",
    };
    let subset = match query.subset.as_deref() {
        Some("furniture") => "furniture",
        Some("manipuland") => "manipuland",
        _ => "all",
    };
    let default_sort = format!("{}.miou", board.lightings.first().map(String::as_str).unwrap_or("baseline"));
    let sort = query.sort.clone().filter(|s| s.split_once('.').is_some_and(|(l, m)| board.lightings.iter().any(|x| x == l) && METRICS.contains(&m)));
    let sort = sort.unwrap_or(default_sort);
    let view = format!("{agg}/{subset}/{sort}");
    let page = rendered.page(&view, || board_page(board, agg, subset, &sort).render().unwrap_or_else(|e| format!("template error: {e}")));
    ([(header::CONTENT_TYPE, "text/html; charset=utf-8")], page).into_response()
}

/// The leaderboard page of `board` for one view (aggregate, subset, sort key `lighting.metric`).
fn board_page(board: &crate::leaderboard::Leaderboard, agg: &str, subset: &str, sort: &str) -> LeaderboardPage {
    let value = |e: &Entry, lighting: &str, metric: &str| -> Option<f64> {
        if subset == "all" { e.metric(lighting, agg, metric) } else { e.scores["semseg"][lighting]["subsets"][subset][agg][metric].as_f64() }
    };
    let (sort_lighting, sort_metric) = sort.split_once('.').expect("checked");
    let mut entries: Vec<&Entry> = board.entries.iter().collect();
    entries.sort_by(|a, b| {
        value(b, sort_lighting, sort_metric).unwrap_or(f64::NEG_INFINITY).total_cmp(&value(a, sort_lighting, sort_metric).unwrap_or(f64::NEG_INFINITY))
    });
    let release = &board.release;
    let mut columns = Vec::new();
    for lighting in &board.lightings {
        for (k, metric) in METRICS.iter().enumerate() {
            let key = format!("{lighting}.{metric}");
            columns.push(Column {
                lighting: lighting.clone(),
                label: lighting_label(lighting),
                metric_label: metric_label(metric),
                sort_link: link(release, agg, subset, &key),
                sorted: key == *sort,
                first_of_lighting: k == 0,
            });
        }
    }
    let others: Vec<String> = board.lightings.iter().filter(|l| l.as_str() != "baseline").cloned().collect();
    // The change of mIoU against the baseline lighting, for the aggregate and scenes shown.
    let change = |e: &Entry, lighting: &str| match (value(e, lighting, "miou"), value(e, "baseline", "miou")) {
        (Some(v), Some(b)) if b != 0.0 => Some((v - b) / b),
        _ => None,
    };
    let rows = entries
        .iter()
        .enumerate()
        .map(|(i, e)| Row {
            rank: i + 1,
            submission_id: e.submission_id.clone(),
            team: e.team.clone(),
            method: e.method.clone(),
            paper_url: e.paper_url.clone(),
            baseline: e.baseline,
            complete: e.complete,
            cells: columns.iter().map(|c| percent(value(e, &c.lighting, metric_key(c.metric_label)))).collect(),
            changes: others.iter().map(|l| signed_percent(change(e, l))).collect(),
        })
        .collect();
    let aggregates = [("Pooled", "overall"), ("Mean over scenes", "overall_mean")]
        .into_iter()
        .map(|(label, key)| Choice { label, link: link(release, key, subset, &sort), active: key == agg })
        .collect();
    let subsets = [("All scenes", "all"), ("Furniture", "furniture"), ("Manipuland", "manipuland")]
        .into_iter()
        .map(|(label, key)| Choice { label, link: link(release, agg, key, &sort), active: key == subset })
        .collect();
    let in_board_order: Vec<&Entry> = board.entries.iter().collect();
    let chart_changes: Vec<Vec<Option<f64>>> = in_board_order.iter().take(8).map(|e| others.iter().map(|l| change(e, l)).collect()).collect();
    let chart = change_chart(&in_board_order, &others, &chart_changes);
    LeaderboardPage {
        release: release.clone(),
        lighting_groups: board.lightings.iter().map(|l| (lighting_label(l), METRICS.len())).collect(),
        columns,
        change_headers: others.iter().map(|l| lighting_short(l)).collect(),
        rows,
        aggregates,
        subsets,
        chart,
        csv_link: format!("/api/v1/leaderboard.csv?release={release}"),
        json_link: format!("/api/v1/leaderboard?release={release}"),
        vqa: super::pages_vqa::vqa_view(release, &board.lightings, &entries, (subset != "all").then_some(subset)),
    }
}

fn metric_key(label: &str) -> &'static str {
    match label {
        "mIoU" => "miou",
        "f-mIoU" => "fmiou",
        _ => "macc",
    }
}

pub struct SceneView {
    pub id: String,
    pub subset: String,
    pub prompt: String,
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

fn human_size(bytes: u64) -> String {
    let units = ["B", "KiB", "MiB", "GiB", "TiB"];
    let mut value = bytes as f64;
    let mut unit = 0;
    while value >= 1024.0 && unit < units.len() - 1 {
        value /= 1024.0;
        unit += 1;
    }
    if unit == 0 { format!("{bytes} B") } else { format!("{value:.1} {}", units[unit]) }
}

/// `GET /releases/{version}`: downloads, scenes with prompts and thumbnails.
pub async fn release(State(state): State<AppState>, caller: Caller, ApiPath(version): ApiPath<String>) -> ApiResult<Response> {
    let version = super::releases::resolve(&state, &version).await?;
    let record = super::releases::visible_release(&state, &caller, &version).await?;
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
                prompt: s["prompt"].as_str().unwrap_or("").to_string(),
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
        state: record.state.clone(),
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

pub struct EventView {
    pub state: String,
    pub reason: String,
    pub at: String,
}

pub struct SceneResult {
    pub scene: String,
    pub cells: Vec<String>,
}

pub struct LightingResult {
    pub label: String,
    pub pooled: Vec<String>,
    pub mean: Vec<String>,
    pub scenes: Vec<SceneResult>,
}

#[derive(Template, WebTemplate)]
#[template(path = "submission.html")]
pub struct SubmissionPage {
    pub id: String,
    pub team: String,
    pub method: String,
    pub description: String,
    pub paper_url: Option<String>,
    pub code_url: Option<String>,
    pub release: String,
    pub state: String,
    pub reason: Option<String>,
    pub baseline: bool,
    pub complete: bool,
    pub history: Vec<EventView>,
    pub results: Vec<LightingResult>,
    pub vqa: Vec<super::pages_vqa::VqaLighting>,
    pub vqa_sources: String,
    pub evaluator_version: String,
    pub refresh: bool,
}

/// `GET /submissions/{id}`: state history and per-scene results.
pub async fn submission(State(state): State<AppState>, caller: Caller, ApiPath(id): ApiPath<String>) -> ApiResult<Response> {
    let s = super::submissions::visible_submission(&state, &caller, &id).await?;
    let view = super::submissions::submission_json(&state, &s).await?;
    let history = view["history"]
        .as_array()
        .into_iter()
        .flatten()
        .map(|e| EventView {
            state: e["state"].as_str().unwrap_or("").into(),
            reason: e["reason"].as_str().unwrap_or("").into(),
            at: e["at"].as_str().unwrap_or("").into(),
        })
        .collect();
    let scores = &view["scores"];
    let mut results = Vec::new();
    let release = state.store.release(&s.release).await?;
    let manifest: Value = serde_json::from_str(&release.manifest).unwrap_or_default();
    let order: Vec<String> = manifest["lightings"].as_array().into_iter().flatten().filter_map(|l| l.as_str().map(String::from)).collect();
    if let Some(semseg) = scores["semseg"].as_object() {
        for lighting in order.iter().filter(|l| semseg.contains_key(l.as_str())) {
            let table = &semseg[lighting.as_str()];
            let triple = |v: &Value| METRICS.iter().map(|m| percent(v[m].as_f64())).collect::<Vec<_>>();
            results.push(LightingResult {
                label: lighting_label(lighting),
                pooled: triple(&table["overall"]),
                mean: triple(&table["overall_mean"]),
                scenes: table["scenes"].as_object().into_iter().flatten().map(|(scene, v)| SceneResult { scene: scene.clone(), cells: triple(v) }).collect(),
            });
        }
    }
    Ok(SubmissionPage {
        id: s.id.clone(),
        team: view["team"].as_str().unwrap_or("").into(),
        method: s.method_name.clone(),
        description: s.method_description.clone(),
        paper_url: s.paper_url.clone(),
        code_url: s.code_url.clone(),
        release: s.release.clone(),
        refresh: ["received", "validating", "queued", "scoring"].contains(&s.state.as_str()),
        state: s.state.clone(),
        reason: s.reason.clone(),
        baseline: s.baseline,
        complete: s.complete,
        history,
        results,
        vqa: super::pages_vqa::submission_vqa(&scores["vqa"], &order),
        vqa_sources: super::pages_vqa::vqa_sources(&scores["vqa"]),
        evaluator_version: scores["evaluator_version"].as_str().unwrap_or("").into(),
    }
    .into_response())
}

const STYLE: &str = include_str!("../../../static/style.css");

/// `GET /static/{file}`: the vendored assets.
pub async fn static_file(ApiPath(file): ApiPath<String>) -> Response {
    match file.as_str() {
        "style.css" => ([(header::CONTENT_TYPE, "text/css; charset=utf-8"), (header::CACHE_CONTROL, "public, max-age=3600")], STYLE).into_response(),
        _ => Problem::not_found(format!("There is no static file '{file}'.")).into_response(),
    }
}
