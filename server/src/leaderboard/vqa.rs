//! The VQA side of the leaderboard: per entry and lighting the pooled accuracy of the
//! prompt-grounded and the standard questions in the paper's two groups (Measurements,
//! Relations), and the paper's tables — Table II (subset × group × method × lighting,
//! prompt-grounded) and Table III (subset × group × method, standard against
//! prompt-grounded, over all lightings) — as JSON and CSV.

use std::collections::BTreeMap;

use osmab_evaluator::csv_writer::{CsvWriter, LineEnd, spreadsheet_safe};
use osmab_evaluator::scores::{Lighting, QuestionGroup, QuestionSet, Regime};
use serde::Serialize;

use super::{Entry, Leaderboard};

/// A table cell as the JSON of the table writes the number (`1.0`, `1e-7`), or nothing.
fn cell(value: Option<f64>) -> String {
    value.filter(|v| v.is_finite()).map(|v| serde_json::to_string(&v).expect("a finite number")).unwrap_or_default()
}

/// The accuracy of one (set, group) under `lighting`, over all scenes or one subset.
pub fn accuracy(entry: &Entry, lighting: Lighting, subset: Option<Regime>, set: QuestionSet, group: QuestionGroup) -> Option<f64> {
    entry.scores.vqa.as_ref()?.accuracy(lighting, subset, set, group)
}

/// A row of Table II: the prompt-grounded accuracy of one method, subset and group per lighting.
#[derive(Debug, Clone, Serialize, schemars::JsonSchema)]
pub struct TableTwoRow {
    pub group: QuestionGroup,
    /// Per lighting of the release (null where the entry has no such questions).
    #[serde(flatten)]
    pub lightings: BTreeMap<Lighting, Option<f64>>,
    pub method: String,
    /// Why the row has blanks, in words (empty when it has none).
    #[serde(skip_serializing_if = "String::is_empty")]
    pub note: String,
    pub submission_id: String,
    pub subset: Regime,
}

/// A row of Table III: standard against prompt-grounded accuracy pooled over all
/// lightings, with 95 % bootstrap intervals over scenes.
#[derive(Debug, Clone, Serialize, schemars::JsonSchema)]
pub struct TableThreeRow {
    pub group: QuestionGroup,
    pub method: String,
    pub prompt_grounded: Option<f64>,
    pub prompt_grounded_ci95_high: Option<f64>,
    pub prompt_grounded_ci95_low: Option<f64>,
    pub prompt_grounded_questions: Option<u64>,
    pub standard: Option<f64>,
    pub standard_ci95_high: Option<f64>,
    pub standard_ci95_low: Option<f64>,
    pub standard_questions: Option<u64>,
    /// Why the row has blanks, in words (empty when it has none).
    #[serde(skip_serializing_if = "String::is_empty")]
    pub note: String,
    pub submission_id: String,
    pub subset: Regime,
}

/// Why a row of the tables of a `split` board with blanks has them: on a test board, what the disclosure
/// rule withholds (a blank is withheld, not zero); on a val board, that the scenes shown hold
/// no such question.
pub fn blank_note(split: osmab_evaluator::scores::Split, per_lighting: bool) -> String {
    let min = osmab_evaluator::scores::MIN_TEST_SCENES;
    match split {
        osmab_evaluator::scores::Split::Test if per_lighting => format!(
            "withheld, not zero: a test board shows question answering pooled over all lightings only, and a subset or question group only where \
             each of them pools at least {min} test scenes (a part beside its whole could be subtracted from it)"
        ),
        osmab_evaluator::scores::Split::Test => format!(
            "withheld, not zero: a test board shows a subset or question group only where each of them pools at least {min} test scenes \
             (a part beside its whole could be subtracted from it)"
        ),
        _ => "no question of this group in these scenes".to_string(),
    }
}

/// The rows of both tables for every (subset, group, entry with VQA scores).
fn cells<'a>(board: &'a Leaderboard) -> impl Iterator<Item = (Regime, QuestionGroup, &'a Entry)> + 'a {
    Regime::ALL.iter().flat_map(move |&subset| QuestionGroup::ALL.iter().flat_map(move |&group| board.with_vqa().map(move |e| (subset, group, e))))
}

/// Table II.
pub fn table_two(board: &Leaderboard) -> Vec<TableTwoRow> {
    cells(board)
        .map(|(subset, group, entry)| {
            let lightings: BTreeMap<Lighting, Option<f64>> =
                board.lightings.iter().map(|&l| (l, accuracy(entry, l, Some(subset), QuestionSet::PromptGrounded, group))).collect();
            let note = if lightings.values().any(Option::is_none) { blank_note(board.split, true) } else { String::new() };
            TableTwoRow { group, lightings, method: entry.method.clone(), note, submission_id: entry.submission_id.clone(), subset }
        })
        .collect()
}

/// Table III.
pub fn table_three(board: &Leaderboard) -> Vec<TableThreeRow> {
    cells(board)
        .map(|(subset, group, entry)| {
            let over = |set| entry.scores.vqa.as_ref().and_then(|v| v.over_lightings(subset, set, group));
            let (standard, prompt) = (over(QuestionSet::Standard), over(QuestionSet::PromptGrounded));
            let ci = |a: Option<&osmab_evaluator::scores::Accuracy>, k: usize| a.and_then(|a| a.ci95).map(|c| c[k]);
            let blank = standard.and_then(|a| a.accuracy).is_none() || prompt.and_then(|a| a.accuracy).is_none();
            TableThreeRow {
                group,
                method: entry.method.clone(),
                prompt_grounded: prompt.and_then(|a| a.accuracy),
                prompt_grounded_ci95_high: ci(prompt, 1),
                prompt_grounded_ci95_low: ci(prompt, 0),
                prompt_grounded_questions: prompt.map(|a| a.total),
                standard: standard.and_then(|a| a.accuracy),
                standard_ci95_high: ci(standard, 1),
                standard_ci95_low: ci(standard, 0),
                standard_questions: standard.map(|a| a.total),
                note: if blank { blank_note(board.split, false) } else { String::new() },
                submission_id: entry.submission_id.clone(),
                subset,
            }
        })
        .collect()
}

/// Table II as CSV: subset, group, method, submission_id, then one column per lighting.
pub fn table_two_csv(rows: &[TableTwoRow], lightings: &[Lighting]) -> String {
    let mut csv = CsvWriter::new(LineEnd::Lf);
    csv.row(
        ["subset", "group", "method", "submission_id"]
            .into_iter()
            .map(String::from)
            .chain(lightings.iter().map(ToString::to_string))
            .chain(["note".to_string()]),
    );
    for row in rows {
        let names =
            [row.subset.to_string(), row.group.to_string(), spreadsheet_safe(&row.method).into_owned(), spreadsheet_safe(&row.submission_id).into_owned()];
        csv.row(names.into_iter().chain(lightings.iter().map(|l| cell(row.lightings.get(l).copied().flatten()))).chain([row.note.clone()]));
    }
    csv.finish()
}

/// The columns of Table III's CSV.
pub const TABLE_THREE_COLUMNS: [&str; 13] = [
    "subset",
    "group",
    "method",
    "submission_id",
    "standard",
    "standard_ci95_low",
    "standard_ci95_high",
    "standard_questions",
    "prompt_grounded",
    "prompt_grounded_ci95_low",
    "prompt_grounded_ci95_high",
    "prompt_grounded_questions",
    "note",
];

/// Table III as CSV with [`TABLE_THREE_COLUMNS`].
pub fn table_three_csv(rows: &[TableThreeRow]) -> String {
    let mut csv = CsvWriter::new(LineEnd::Lf);
    csv.row(TABLE_THREE_COLUMNS);
    let count = |n: Option<u64>| n.map(|n| n.to_string()).unwrap_or_default();
    for r in rows {
        csv.row([
            r.subset.to_string(),
            r.group.to_string(),
            spreadsheet_safe(&r.method).into_owned(),
            spreadsheet_safe(&r.submission_id).into_owned(),
            cell(r.standard),
            cell(r.standard_ci95_low),
            cell(r.standard_ci95_high),
            count(r.standard_questions),
            cell(r.prompt_grounded),
            cell(r.prompt_grounded_ci95_low),
            cell(r.prompt_grounded_ci95_high),
            count(r.prompt_grounded_questions),
            r.note.clone(),
        ]);
    }
    csv.finish()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn vqa_tables_defuse_formulas_in_names_and_keep_numbers() {
        let row = TableTwoRow {
            group: QuestionGroup::Relations,
            lightings: [(Lighting::Baseline, Some(-0.25))].into(),
            method: "=HYPERLINK(\"http://evil\",\"x\")".into(),
            note: String::new(),
            submission_id: "sub_1".into(),
            subset: Regime::Furniture,
        };
        let csv = table_two_csv(&[row], &[Lighting::Baseline]);
        assert_eq!(csv, "subset,group,method,submission_id,baseline,note\nfurniture,Relations,\"'=HYPERLINK(\"\"http://evil\"\",\"\"x\"\")\",sub_1,-0.25,\n");
    }
}
