//! `GET /submissions/{id}`: a submission's state and history, its segmentation results per
//! lighting and scene, and its question answering — from the same view the API serves.

use askama::Template;
use askama_web::WebTemplate;
use axum::extract::State;
use axum::response::{IntoResponse, Response};
use osmab_evaluator::scores::{Aggregate, Lighting, Metric, Scores, Split};
use osmab_evaluator::semseg::report::MetricTriple;

use super::chart::{Axis, BarChart, Series, Size};
use super::format::{interval, percent};
use super::vqa::{VqaLighting, submission_vqa, vqa_sources};
use crate::auth::Caller;
use crate::problem::ApiResult;
use crate::routes::extract::ApiPath;
use crate::routes::submission_view::{self, SubmissionView};
use crate::state::AppState;

pub struct EventRow {
    pub state: String,
    pub reason: String,
    pub at: String,
}

pub struct SceneResult {
    pub scene: String,
    pub cells: Vec<String>,
}

pub struct LightingResult {
    pub label: &'static str,
    pub pooled: Vec<String>,
    /// The 95 % bootstrap interval of each pooled metric (empty for scores without them).
    pub pooled_ci: Vec<String>,
    pub mean: Vec<String>,
    pub scenes: Vec<SceneResult>,
    /// How many scenes the aggregates pool, where the rows are not shown (a test submission).
    pub pooled_scenes: Option<usize>,
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
    pub external_data: Option<String>,
    pub compute: Option<String>,
    pub anonymous: bool,
    pub flagged: Option<String>,
    pub release: String,
    pub state: String,
    pub reason: Option<String>,
    /// Where it stands in the queue, in words (queued or being scored).
    pub queue: Option<String>,
    /// Made by the service: the reference mapper, or (when not `reference`) a control.
    pub baseline: bool,
    pub reference: bool,
    pub complete: bool,
    pub history: Vec<EventRow>,
    pub results: Vec<LightingResult>,
    pub vqa: Vec<VqaLighting>,
    pub vqa_sources: String,
    /// What the scores of a test submission leave out, in words.
    pub withheld: Option<String>,
    pub evaluator_version: String,
    pub refresh: bool,
    /// The split it was made to, and the link to that board.
    pub split: Split,
    pub board_link: String,
    /// Where it stands on that board, once there.
    pub standing: Option<Standing>,
    /// A line to paste into a paper or a README.
    pub citation: String,
    /// Pooled metrics per lighting as a chart (empty before scoring).
    pub chart: String,
    /// The metrics' labels, in column order.
    pub metric_labels: Vec<&'static str>,
}

/// An entry's place on its board.
pub struct Standing {
    pub rank: usize,
    pub entries: usize,
    /// `None` where the board has too few scenes for significance groups.
    pub group: Option<usize>,
}

fn cells(triple: &MetricTriple) -> Vec<String> {
    Metric::COLUMNS.iter().map(|&m| percent(triple.defined(m))).collect()
}

/// Every lighting's results in the release's `order`: pooled (with intervals when
/// scored with them), mean over scenes, and scene by scene.
fn lighting_results(scores: &Scores, order: &[Lighting]) -> Vec<LightingResult> {
    order
        .iter()
        .filter_map(|l| Some((l, scores.semseg.get(l)?)))
        .map(|(l, table)| LightingResult {
            label: l.label(),
            pooled: cells(&table.overall),
            pooled_ci: match table.overall.ci95 {
                Some(_) => Metric::COLUMNS.iter().map(|&m| interval(table.overall.interval(m))).collect(),
                None => Vec::new(),
            },
            mean: cells(&table.overall_mean),
            scenes: table.scenes.iter().map(|(scene, t)| SceneResult { scene: scene.clone(), cells: cells(t) }).collect(),
            pooled_scenes: table.pooled,
        })
        .collect()
}

/// Where the submission stands on its board, when it is on it.
async fn standing(state: &AppState, view: &SubmissionView) -> Option<Standing> {
    let board = crate::routes::leaderboard::rendered(state, Some(&view.release), Some(view.split)).await.ok()?;
    let entries = &board.board.entries;
    entries.iter().find(|e| e.submission_id == view.id).map(|e| Standing {
        rank: e.rank,
        entries: entries.len(),
        group: board.board.significance.then_some(e.rank_group),
    })
}

/// The pooled metrics per lighting as a small chart.
fn metrics_chart(scores: &Scores, order: &[Lighting]) -> String {
    let lightings: Vec<Lighting> = order.iter().copied().filter(|l| scores.semseg.contains_key(l)).collect();
    BarChart {
        title: "Pooled segmentation metrics per lighting".into(),
        groups: lightings.iter().map(|l| l.short_label().to_string()).collect(),
        group_titles: lightings.iter().map(|l| l.label().to_string()).collect(),
        series: Metric::COLUMNS
            .iter()
            .map(|&m| Series { name: m.label().to_string(), values: lightings.iter().map(|&l| scores.semseg(l, None, Aggregate::Overall, m)).collect() })
            .collect(),
        axis: Axis::Fraction,
        size: Size::Small,
    }
    .to_svg()
}

/// `GET /submissions/{id}`.
pub async fn submission(State(state): State<AppState>, caller: Caller, ApiPath(id): ApiPath<String>) -> ApiResult<Response> {
    let record = crate::routes::submissions::visible_submission(&state, &caller, &id).await?;
    let view = submission_view::load(&state, &record, &caller).await?;
    // Lightings in the release's order.
    let release = state.store.release(&view.release).await?;
    let order = crate::releases::served_manifest(&release).score_lightings();
    let scores = view.scores.as_ref();
    let results = scores.map_or_else(Vec::new, |scores| lighting_results(scores, &order));
    let vqa = scores.and_then(|s| s.vqa.as_ref());
    let board_link = format!("/?release={}&split={}", view.release, view.split);
    let standing = standing(&state, &view).await;
    let origin = state.settings.public_url.clone().unwrap_or_default();
    let citation = format!(
        "{} ({}), OSMa-Bench++ release {}, {} split, submission {} — {origin}/submissions/{}",
        view.method.name, view.team, view.release, view.split, view.id, view.id
    );
    let chart = scores.map_or_else(String::new, |scores| metrics_chart(scores, &order));
    let reference = view.baseline && crate::reserved_names::is_reference_mapper(&view.method.name);
    Ok(SubmissionPage {
        metric_labels: Metric::COLUMNS.iter().map(|m| m.label()).collect(),
        split: view.split,
        board_link,
        standing,
        citation,
        chart,
        refresh: view.state.is_active(),
        state: view.state.to_string(),
        history: view.history.iter().map(|e| EventRow { state: e.state.to_string(), reason: e.reason.clone().unwrap_or_default(), at: e.at.clone() }).collect(),
        results,
        vqa: submission_vqa(vqa, &order, scores.is_some_and(|s| s.withheld.is_some())),
        vqa_sources: vqa_sources(vqa),
        withheld: scores.and_then(|s| s.withheld.as_ref()).map(|w| w.note.clone()),
        evaluator_version: scores.map(|s| s.evaluator_version.clone()).unwrap_or_default(),
        id: view.id,
        team: view.team,
        method: view.method.name,
        description: view.method.description,
        paper_url: view.method.paper_url,
        code_url: view.method.code_url,
        external_data: view.method.external_data,
        compute: view.method.compute,
        anonymous: view.method.anonymous,
        flagged: view.flagged,
        release: view.release,
        reason: view.reason,
        queue: view.queue.as_ref().map(|q| q.sentence()),
        reference,
        baseline: view.baseline,
        complete: view.complete,
    }
    .into_response())
}
