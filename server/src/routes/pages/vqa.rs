//! The question-answering parts of the pages: on the leaderboard, per entry and lighting
//! the prompt-grounded and standard accuracies in the paper's two groups with one bar
//! chart per (question set, group); on a submission's page, every group and category
//! with its interval, and who answered and judged.

use osmab_evaluator::scores::{Accuracy, Lighting, QuestionGroup, QuestionSet, Regime, Split, VqaScores};

use super::chart::{Axis, BarChart, Series, Size};
use super::format::{interval, percent};
use crate::leaderboard::Entry;
use crate::leaderboard::vqa::accuracy;

pub struct VqaRow {
    pub submission_id: String,
    pub method: String,
    pub baseline: bool,
    pub cells: Vec<String>,
}

pub struct VqaView {
    /// (lighting label, columns under it).
    pub lighting_groups: Vec<(&'static str, usize)>,
    /// Column labels under each lighting.
    pub columns: Vec<String>,
    pub rows: Vec<VqaRow>,
    /// Why some cells show "–", in words, where some do.
    pub blank_note: Option<String>,
    pub charts: Vec<String>,
    pub table_two_csv: String,
    pub table_three_csv: String,
    pub tables_json: String,
}

/// A (set, group) column's short label (`PromptGT Meas.`).
fn column_label(set: QuestionSet, group: QuestionGroup) -> String {
    let short = match group {
        QuestionGroup::Measurements => "Meas.",
        QuestionGroup::Relations => "Rel.",
    };
    format!("{} {short}", set.label())
}

/// The lightings a VQA table has columns for: each of the release's, or (a test board,
/// whose scores pool VQA over every lighting: `Scores::disclosed`) all of them at once.
#[derive(Clone, Copy)]
enum Columns {
    Lighting(Lighting),
    AllLightings,
}

impl Columns {
    fn label(self) -> &'static str {
        match self {
            Columns::Lighting(l) => l.label(),
            Columns::AllLightings => "All lightings",
        }
    }

    fn short_label(self) -> &'static str {
        match self {
            Columns::Lighting(l) => l.short_label(),
            Columns::AllLightings => "All",
        }
    }

    fn accuracy(self, e: &Entry, subset: Option<Regime>, set: QuestionSet, group: QuestionGroup) -> Option<f64> {
        match self {
            Columns::Lighting(l) => accuracy(e, l, subset, set, group),
            Columns::AllLightings => e.scores.vqa.as_ref()?.all_lightings.set_of(subset, set)?.group(group)?.accuracy,
        }
    }
}

/// The section for `entries` (in the page's order), over all scenes or one `subset`, per
/// lighting or (a test board's) over all lightings; `None` when no entry has VQA scores.
pub fn vqa_view(board_query: &str, lightings: &[Lighting], entries: &[&Entry], subset: Option<Regime>, split: Split) -> Option<VqaView> {
    let pooled = split == Split::Test;
    let with_vqa: Vec<&Entry> = entries.iter().copied().filter(|e| e.scores.vqa.is_some()).collect();
    if with_vqa.is_empty() {
        return None;
    }
    let groups: Vec<Columns> = if pooled { vec![Columns::AllLightings] } else { lightings.iter().map(|&l| Columns::Lighting(l)).collect() };
    let columns: Vec<(QuestionSet, QuestionGroup)> = QuestionSet::with_groups().collect();
    let rows: Vec<VqaRow> = with_vqa
        .iter()
        .map(|e| VqaRow {
            submission_id: e.submission_id.clone(),
            method: e.method.clone(),
            baseline: e.baseline,
            cells: groups.iter().flat_map(|&g| columns.iter().map(move |&(set, group)| percent(g.accuracy(e, subset, set, group)))).collect(),
        })
        .collect();
    let blank_note = rows.iter().any(|r| r.cells.iter().any(|c| c == "–")).then(|| crate::leaderboard::vqa::blank_note(split, pooled));
    let charts = columns
        .iter()
        .map(|&(set, group)| {
            BarChart {
                title: format!("{} {group}", set.label()),
                groups: groups.iter().map(|g| g.short_label().to_string()).collect(),
                group_titles: groups.iter().map(|g| g.label().to_string()).collect(),
                series: with_vqa
                    .iter()
                    .map(|e| Series { name: e.method.clone(), values: groups.iter().map(|&g| g.accuracy(e, subset, set, group)).collect() })
                    .collect(),
                axis: Axis::Fraction,
                size: Size::Small,
            }
            .to_svg()
        })
        .collect();
    Some(VqaView {
        lighting_groups: groups.iter().map(|g| (g.label(), columns.len())).collect(),
        columns: columns.iter().map(|&(set, group)| column_label(set, group)).collect(),
        rows,
        blank_note,
        charts,
        table_two_csv: format!("/api/v1/leaderboard/vqa.csv?table=2&{board_query}"),
        table_three_csv: format!("/api/v1/leaderboard/vqa.csv?table=3&{board_query}"),
        tables_json: format!("/api/v1/leaderboard/vqa?{board_query}"),
    })
}

/// One row of a submission's VQA table: a category or a group.
pub struct VqaCategoryRow {
    pub name: String,
    pub counts: String,
    pub accuracy: String,
    pub interval: String,
    pub group: bool,
}

/// A submission's VQA results under one lighting.
pub struct VqaLighting {
    pub label: &'static str,
    pub rows: Vec<VqaCategoryRow>,
}

fn category_row(name: String, cell: &Accuracy, group: bool) -> VqaCategoryRow {
    VqaCategoryRow { name, counts: format!("{} / {}", cell.correct, cell.total), accuracy: percent(cell.accuracy), interval: interval(cell.ci95), group }
}

/// The row of a question group a shown test score withholds (it pools too few test scenes
/// beside the other groups), said as such rather than as "0 / 0".
fn withheld_row(name: String) -> VqaCategoryRow {
    VqaCategoryRow { name, counts: "withheld".into(), accuracy: "–".into(), interval: String::new(), group: true }
}

/// Per lighting (in `lightings` order), then over all lightings: each question set's
/// groups, then its categories (a test submission's are over all lightings only). A group
/// missing from a shown test score (`withheld`) is said to be withheld.
pub fn submission_vqa(vqa: Option<&VqaScores>, lightings: &[Lighting], withheld: bool) -> Vec<VqaLighting> {
    let Some(vqa) = vqa else { return Vec::new() };
    let none = Accuracy::default();
    lightings
        .iter()
        .filter_map(|l| Some((l.label(), vqa.lightings.get(l)?)))
        .chain(std::iter::once(("All lightings", &vqa.all_lightings)))
        .map(|(label, at)| {
            let mut rows = Vec::new();
            for set in QuestionSet::ALL {
                let scores = at.set(set);
                for group in QuestionGroup::ALL {
                    let name = format!("{} {group}", set.label());
                    rows.push(match scores.group(group) {
                        None if withheld => withheld_row(name),
                        cell => category_row(name, cell.unwrap_or(&none), true),
                    });
                }
                for (category, cell) in &scores.categories {
                    rows.push(category_row(category.clone(), cell, false));
                }
            }
            VqaLighting { label, rows }
        })
        .collect()
}

/// Who answered and who judged, in words.
pub fn vqa_sources(vqa: Option<&VqaScores>) -> String {
    let Some(vqa) = vqa else { return String::new() };
    let answered: Vec<String> = vqa.answered_by.iter().map(|(by, n)| format!("{} {n}", by.name())).collect();
    let judged: Vec<String> = vqa.judged_by.iter().map(|(by, n)| format!("{} {n}", by.name())).collect();
    format!("answered by {}; judged by {}", answered.join(", "), judged.join(", "))
}
