//! `GET /`: the leaderboard page. Sorting and the choice of aggregate and subset are
//! links, so it works without JavaScript; each view is rendered once per built board.

use askama::Template;
use askama_web::WebTemplate;
use axum::extract::State;
use axum::http::{StatusCode, header};
use axum::response::{IntoResponse, Response};
use osmab_evaluator::scores::{Aggregate, Lighting, Metric, Regime, Split};
use serde::Deserialize;

use super::chart::{Axis, BarChart, Series, Size};
use super::format::{self, percent, signed_percent};
use super::{MessagePage, vqa};
use crate::leaderboard::{Entry, Leaderboard};
use crate::routes::extract::ApiQuery;
use crate::state::AppState;

#[derive(Debug, Deserialize, Default)]
pub struct BoardQuery {
    release: Option<String>,
    /// `test` or `val` (the release's test split by default).
    split: Option<String>,
    /// `overall` (pooled, default) or `overall_mean`.
    agg: Option<String>,
    /// `all` (default), `furniture` or `manipuland`.
    subset: Option<String>,
    /// `<lighting>.<metric>`.
    sort: Option<String>,
    /// `miou` (default: one metric a lighting) or `all` (mIoU, f-mIoU and mAcc).
    metrics: Option<String>,
}

/// What the page shows: an aggregate, all scenes or a subset, sorted by one column.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct View {
    pub aggregate: Aggregate,
    pub subset: Option<Regime>,
    pub sort: (Lighting, Metric),
    /// Every metric a lighting, not mIoU alone (also when sorted by another metric).
    pub all_metrics: bool,
}

impl View {
    /// The view a query asks for on `board`; anything unknown falls back to the default.
    fn of(query: &BoardQuery, board: &Leaderboard) -> Self {
        let first = board.lightings.first().copied().unwrap_or(Lighting::BASELINE);
        let sort = query
            .sort
            .as_deref()
            .and_then(|s| s.split_once('.'))
            .and_then(|(l, m)| Some((l.parse::<Lighting>().ok()?, m.parse::<Metric>().ok()?)))
            .filter(|(l, _)| board.lightings.contains(l));
        let sort = sort.unwrap_or((first, Metric::Miou));
        View {
            aggregate: query.agg.as_deref().and_then(|a| a.parse().ok()).unwrap_or(Aggregate::Overall),
            subset: query.subset.as_deref().and_then(|s| s.parse().ok()),
            sort,
            all_metrics: query.metrics.as_deref() == Some("all") || sort.1 != Metric::Miou,
        }
    }

    /// The metrics shown for each lighting.
    fn metrics(&self) -> &'static [Metric] {
        if self.all_metrics { &Metric::COLUMNS } else { &[Metric::Miou] }
    }

    fn subset_name(&self) -> &'static str {
        self.subset.map_or("all", Regime::name)
    }

    /// The key the rendered page is cached under.
    fn key(&self) -> String {
        format!("{}/{}/{}.{}/{}", self.aggregate, self.subset_name(), self.sort.0, self.sort.1, self.all_metrics)
    }

    fn link(&self, board: &Leaderboard) -> String {
        let metrics = if self.all_metrics { "all" } else { "miou" };
        format!("/?{}&agg={}&subset={}&sort={}.{}&metrics={metrics}", board_query(board), self.aggregate, self.subset_name(), self.sort.0, self.sort.1)
    }

    fn value(&self, e: &Entry, lighting: Lighting, metric: Metric) -> Option<f64> {
        e.metric(lighting, self.subset, self.aggregate, metric)
    }

    /// The cell of a metric, with its interval where the aggregate is pooled and the board
    /// has scenes enough for intervals.
    fn cell(&self, e: &Entry, lighting: Lighting, metric: Metric, significance: bool) -> Cell {
        let interval = match self.aggregate {
            Aggregate::Overall if significance => e.interval(lighting, self.subset, metric),
            _ => None,
        };
        Cell {
            value: percent(self.value(e, lighting, metric)),
            spread: interval.map(|[lo, hi]| (format!("±{:.1}", 50.0 * (hi - lo)), format!("95 % interval {}", format::interval(Some([lo, hi]))))),
        }
    }

    /// The change of mIoU against the baseline lighting, for the aggregate and scenes shown.
    fn change(&self, e: &Entry, lighting: Lighting) -> Option<f64> {
        e.scores.change_against_baseline(lighting, self.subset, self.aggregate, Metric::Miou)
    }
}

pub struct Column {
    pub label: &'static str,
    pub metric_label: &'static str,
    pub sort_link: String,
    pub sorted: bool,
    pub first_of_lighting: bool,
}

/// A metric cell: the value and, on pooled aggregates, its 95 % interval as `±half-width`
/// with the interval itself in the title.
pub struct Cell {
    pub value: String,
    pub spread: Option<(String, String)>,
}

pub struct Row {
    pub rank: usize,
    /// 1 + entries significantly above (default ranking).
    pub rank_group: usize,
    pub submission_id: String,
    pub team: String,
    pub method: String,
    pub paper_url: Option<String>,
    /// A control made from the ground truth (shown muted, tagged "control").
    pub control: bool,
    /// The project's reference mapper (tagged "reference").
    pub reference: bool,
    pub complete: bool,
    /// Why the organisers flagged it.
    pub flagged: Option<String>,
    pub cells: Vec<Cell>,
    pub changes: Vec<String>,
    /// The worst lighting's label and mIoU, and the largest drop against baseline.
    pub worst: String,
    pub worst_miou: String,
    pub largest_drop: String,
}

pub struct Choice {
    pub label: std::borrow::Cow<'static, str>,
    pub link: String,
    pub active: bool,
}

#[derive(Template, WebTemplate)]
#[template(path = "leaderboard.html")]
pub struct LeaderboardPage {
    pub release: String,
    /// The split ranked, and what it means.
    pub split: Split,
    pub split_note: &'static str,
    /// The boards of the release's splits (empty with one split).
    pub boards: Vec<Choice>,
    /// The boards of every published release (empty with one).
    pub releases: Vec<Choice>,
    /// The current release, when this board is of another.
    pub current_release: Option<String>,
    pub lighting_groups: Vec<(&'static str, usize)>,
    pub columns: Vec<Column>,
    pub change_headers: Vec<&'static str>,
    /// Why some cells show "–", in words, where some do.
    pub blank_note: Option<String>,
    pub rows: Vec<Row>,
    pub aggregates: Vec<Choice>,
    pub subsets: Vec<Choice>,
    /// mIoU alone or every metric.
    pub metric_choices: Vec<Choice>,
    /// The same frame under each lighting, to say what the lightings are.
    pub lighting_frames: Vec<LightingFrame>,
    /// Whether rank groups and intervals are shown (scenes enough for them).
    pub significance: bool,
    /// How many scenes the board pools.
    pub scenes: usize,
    pub chart: String,
    /// The same chart for a phone's width.
    pub chart_narrow: String,
    pub csv_link: String,
    pub json_link: String,
    pub vqa: Option<vqa::VqaView>,
    /// The lighting whose pooled mIoU ranks entries and groups them.
    pub ranking_lighting: &'static str,
}

/// `GET /`: the leaderboard of the current (or chosen) release.
pub async fn leaderboard(State(state): State<AppState>, ApiQuery(query): ApiQuery<BoardQuery>) -> Response {
    let split = query.split.as_deref().and_then(|s| s.parse::<Split>().ok());
    let rendered = match crate::routes::leaderboard::rendered(&state, query.release.as_deref(), split).await {
        Ok(r) => r,
        Err(problem) => {
            let status = problem.status;
            let page = MessagePage { title: "No leaderboard yet".into(), message: problem.detail };
            return (if status == StatusCode::NOT_FOUND { StatusCode::OK } else { status }, [(header::REFRESH, "10")], page).into_response();
        }
    };
    let view = View::of(&query, &rendered.board);
    let page = match rendered.cached_page(&view.key()) {
        Some(page) => page,
        None => {
            let frames = lighting_frames(&state, &rendered.board).await;
            rendered.page(&view.key(), || {
                board_page(&rendered.board, &rendered.published, view, frames).render().unwrap_or_else(|e| format!("template error: {e}"))
            })
        }
    };
    ([(header::CONTENT_TYPE, "text/html; charset=utf-8")], page).into_response()
}

/// One frame of the release under one lighting, with what the lighting is.
pub struct LightingFrame {
    pub label: &'static str,
    /// The name the API, the files and the client use (`no_lights`).
    pub name: &'static str,
    pub src: String,
    pub explanation: &'static str,
}

/// The same frame of one scene under each of the board's lightings: the preview frame of
/// the release's first open (val) scene, else of its first scene; none when the release
/// lacks one of those frames.
async fn lighting_frames(state: &AppState, board: &Leaderboard) -> Vec<LightingFrame> {
    let Ok(record) = state.store.release(&board.release).await else { return Vec::new() };
    let manifest = crate::releases::served_manifest(&record);
    let scene = manifest.scenes.iter().find(|s| s.split == Split::Val).or(manifest.scenes.first());
    let Some(preview) = scene.and_then(|s| s.preview.as_deref()) else { return Vec::new() };
    let Some(rest) = preview.strip_prefix("sequences/").and_then(|p| p.split_once('/')).map(|(_, rest)| rest) else { return Vec::new() };
    let frames: Vec<LightingFrame> = board
        .lightings
        .iter()
        .map(|&lighting| LightingFrame {
            label: lighting.label(),
            name: lighting.name(),
            src: format!("sequences/{lighting}/{rest}"),
            explanation: lighting.explanation(),
        })
        .collect();
    if !frames.iter().all(|f| manifest.has_file(&f.src)) {
        return Vec::new();
    }
    frames.into_iter().map(|f| LightingFrame { src: format!("/api/v1/releases/{}/files/{}", board.release, f.src), ..f }).collect()
}

/// A link to each published release's board (newest first), `board`'s marked.
fn release_choices(board: &Leaderboard, published: &[(String, bool)]) -> Vec<Choice> {
    if published.len() < 2 {
        return Vec::new();
    }
    published
        .iter()
        .map(|(version, current)| Choice {
            label: if *current { format!("{version} (current)").into() } else { version.clone().into() },
            link: format!("/?release={version}"),
            active: *version == board.release,
        })
        .collect()
}

/// The query naming `board`: its release and split.
fn board_query(board: &Leaderboard) -> String {
    format!("release={}&split={}", board.release, board.split)
}

/// The leaderboard page of `board` for one view.
fn board_page(board: &Leaderboard, published: &[(String, bool)], view: View, lighting_frames: Vec<LightingFrame>) -> LeaderboardPage {
    let (sort_lighting, sort_metric) = view.sort;
    let mut entries: Vec<&Entry> = board.entries.iter().collect();
    let key = |e: &Entry| view.value(e, sort_lighting, sort_metric).unwrap_or(f64::NEG_INFINITY);
    entries.sort_by(|a, b| key(b).total_cmp(&key(a)));
    let (columns, cells_of) = columns(board, view);
    let others: Vec<Lighting> = board.lightings.iter().copied().filter(|&l| l != Lighting::BASELINE).collect();
    let rows: Vec<Row> = entries.iter().enumerate().map(|(i, e)| row(i + 1, e, board, view, &cells_of, &others)).collect();
    let (chart, chart_narrow) =
        (change_chart(board, view, &others, Size::Wide, Lighting::label), change_chart(board, view, &others, Size::Narrow, Lighting::short_label));
    let split_note = match board.split {
        Split::Test => "Test split: scenes whose semantics and answers are hidden; scored by the server only, a few submissions per team and window.",
        Split::Val => "Validation split: open scenes whose ground truth is public; osmab-client validate scores them offline.",
    };
    LeaderboardPage {
        release: board.release.clone(),
        split: board.split,
        split_note,
        boards: split_choices(board, view),
        // The release switcher: every published release's board stays reachable.
        releases: release_choices(board, published),
        current_release: published.iter().find(|(_, current)| *current).map(|(v, _)| v.clone()).filter(|v| *v != board.release),
        lighting_groups: board.lightings.iter().map(|l| (l.label(), view.metrics().len())).collect(),
        metric_choices: metric_choices(board, view),
        lighting_frames,
        significance: board.significance,
        scenes: board.scenes,
        columns,
        change_headers: others.iter().map(|l| l.short_label()).collect(),
        blank_note: blank_note(board, &rows),
        rows,
        aggregates: Aggregate::ALL
            .iter()
            .map(|&aggregate| Choice { label: aggregate.label().into(), link: View { aggregate, ..view }.link(board), active: aggregate == view.aggregate })
            .collect(),
        subsets: std::iter::once(None)
            .chain(Regime::ALL.iter().copied().map(Some))
            .map(|subset| Choice {
                label: subset.map_or("All scenes", Regime::label).into(),
                link: View { subset, ..view }.link(board),
                active: subset == view.subset,
            })
            .collect(),
        chart,
        chart_narrow,
        csv_link: format!("/api/v1/leaderboard.csv?{}", board_query(board)),
        json_link: format!("/api/v1/leaderboard?{}", board_query(board)),
        vqa: vqa::vqa_view(&board_query(board), &board.lightings, &entries, view.subset, board.split),
        ranking_lighting: board.lightings.first().copied().unwrap_or(Lighting::BASELINE).label(),
    }
}

/// Why some cells of the segmentation table show "–", in words, where some do: on a test
/// board, what the disclosure rule withholds (a lighting, subset or aggregate of too few
/// test scenes, or a part beside its whole); on a val board, a metric that is undefined.
fn blank_note(board: &Leaderboard, rows: &[Row]) -> Option<String> {
    if !rows.iter().any(|r| r.cells.iter().any(|c| c.value == "–")) {
        return None;
    }
    let min = osmab_evaluator::scores::MIN_TEST_SCENES;
    Some(match board.split {
        Split::Test => format!(
            "withheld, not zero: a test board shows a number only where it pools at least {min} test scenes, and a subset only when every subset \
             does (a part beside its whole could be subtracted from it); choose All scenes for the pooled numbers"
        ),
        _ => "undefined: the scenes shown hold no class this metric can be computed on".to_string(),
    })
}

/// The metric columns of the view (each lighting's metrics, each a link sorting by it),
/// and the (lighting, metric) each stands for.
fn columns(board: &Leaderboard, view: View) -> (Vec<Column>, Vec<(Lighting, Metric)>) {
    let mut columns = Vec::new();
    let mut cells_of = Vec::new();
    for &lighting in &board.lightings {
        for (k, &metric) in view.metrics().iter().enumerate() {
            columns.push(Column {
                label: lighting.label(),
                metric_label: metric.label(),
                sort_link: View { sort: (lighting, metric), ..view }.link(board),
                sorted: (lighting, metric) == view.sort,
                first_of_lighting: k == 0,
            });
            cells_of.push((lighting, metric));
        }
    }
    (columns, cells_of)
}

/// The row of `e` at `rank`: its cells, its change under the `others` lightings and its robustness.
fn row(rank: usize, e: &Entry, board: &Leaderboard, view: View, cells_of: &[(Lighting, Metric)], others: &[Lighting]) -> Row {
    Row {
        rank,
        submission_id: e.submission_id.clone(),
        team: e.team.clone(),
        method: e.method.clone(),
        paper_url: e.paper_url.clone(),
        control: e.baseline && !e.reference,
        reference: e.reference,
        complete: e.complete,
        flagged: e.flagged.clone(),
        rank_group: e.rank_group,
        cells: cells_of.iter().map(|&(l, m)| view.cell(e, l, m, board.significance)).collect(),
        changes: others.iter().map(|&l| signed_percent(view.change(e, l))).collect(),
        worst: e.robustness.worst_lighting.map_or("–", Lighting::short_label).to_string(),
        worst_miou: percent(e.robustness.worst_miou),
        largest_drop: percent(e.robustness.largest_drop),
    }
}

/// mIoU alone, or every metric.
fn metric_choices(board: &Leaderboard, view: View) -> Vec<Choice> {
    let every_metric = Metric::COLUMNS.map(Metric::label).join(", ");
    [(false, Metric::Miou.label().into()), (true, every_metric.into())]
        .into_iter()
        .map(|(all_metrics, label): (bool, std::borrow::Cow<'static, str>)| {
            // mIoU alone also sorts by mIoU (a sort by another metric shows every metric).
            let sort = if all_metrics { view.sort } else { (view.sort.0, Metric::Miou) };
            Choice { label, link: View { all_metrics, sort, ..view }.link(board), active: all_metrics == view.all_metrics }
        })
        .collect()
}

/// The boards of the release's splits, when it has more than one.
fn split_choices(board: &Leaderboard, view: View) -> Vec<Choice> {
    if board.splits.len() < 2 {
        return Vec::new();
    }
    board
        .splits
        .iter()
        .map(|&split| Choice {
            label: split.label().into(),
            link: format!("/?release={}&split={split}&agg={}&subset={}", board.release, view.aggregate, view.subset_name()),
            active: split == board.split,
        })
        .collect()
}

/// The chart of every entry's relative change under the `others` lightings, labelled with
/// `label`. It keeps the leaderboard's own order, so a method keeps its colour whatever the sorting.
fn change_chart(board: &Leaderboard, view: View, others: &[Lighting], size: Size, label: fn(Lighting) -> &'static str) -> String {
    BarChart {
        title: format!("Relative change of pooled {} against the baseline lighting", Metric::Miou.label()),
        groups: others.iter().map(|&l| label(l).to_string()).collect(),
        group_titles: others.iter().map(|l| l.label().to_string()).collect(),
        // Controls are left out: their change under a lighting is set by how they were made, not measured.
        series: board
            .entries
            .iter()
            .filter(|e| !e.baseline || e.reference)
            .map(|e| Series { name: e.method.clone(), values: others.iter().map(|&l| view.change(e, l)).collect() })
            .collect(),
        axis: Axis::Change,
        size,
    }
    .to_svg()
}
