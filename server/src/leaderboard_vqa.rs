//! The VQA side of the leaderboard: per entry and lighting the pooled accuracy of the
//! prompt-grounded and the standard questions in the paper's two groups (Measurements,
//! Relations), and the paper's tables — Table II (subset × group × method × lighting,
//! prompt-grounded) and Table III (subset × group × method, standard against
//! prompt-grounded, over all lightings) — as JSON and CSV.

use osmab_evaluator::csv_writer::{CsvWriter, LineEnd, spreadsheet_safe};
use serde_json::{Value, json};

use crate::leaderboard::{Entry, Leaderboard, SUBSETS};

/// Question sets in column order, with their labels.
pub const SETS: [(&str, &str); 2] = [("prompt_grounded", "PromptGT"), ("standard", "Standard")];
/// The paper's groups of categories.
pub const GROUPS: [&str; 2] = ["Measurements", "Relations"];

/// The cell of one (set, group) under `lighting`, over all scenes or one subset.
pub fn accuracy(entry: &Entry, lighting: &str, subset: Option<&str>, set: &str, group: &str) -> Option<f64> {
    let at = &entry.scores["vqa"]["lightings"][lighting];
    let at = match subset {
        Some(s) => &at["subsets"][s],
        None => at,
    };
    at[set]["groups"][group]["accuracy"].as_f64()
}

/// The pooled accuracy of one (set, group) over every lighting, with its interval.
fn over_lightings(entry: &Entry, subset: &str, set: &str, group: &str) -> (Option<f64>, [Option<f64>; 2], Option<u64>) {
    let cell = &entry.scores["vqa"]["all_lightings"]["subsets"][subset][set]["groups"][group];
    (cell["accuracy"].as_f64(), [cell["ci95"][0].as_f64(), cell["ci95"][1].as_f64()], cell["total"].as_u64())
}

/// The CSV columns of every lighting: `{lighting}_vqa_{set}_{group}`.
pub fn csv_columns(lightings: &[String]) -> Vec<String> {
    lightings.iter().flat_map(|l| SETS.iter().flat_map(move |(set, _)| GROUPS.iter().map(move |g| format!("{l}_vqa_{set}_{}", g.to_lowercase())))).collect()
}

/// The CSV cells of `entry` in the order of [`csv_columns`].
pub fn csv_cells(entry: &Entry, lightings: &[String]) -> Vec<Option<f64>> {
    lightings.iter().flat_map(|l| SETS.iter().flat_map(move |(set, _)| GROUPS.iter().map(move |g| accuracy(entry, l, None, set, g)))).collect()
}

/// Table II: per subset, group, method and lighting, the prompt-grounded accuracy.
pub fn table_two(board: &Leaderboard) -> Vec<Value> {
    let mut rows = Vec::new();
    for subset in SUBSETS {
        for group in GROUPS {
            for entry in board.entries.iter().filter(|e| e.scores["vqa"].is_object()) {
                let mut row = json!({"subset": subset, "group": group, "method": entry.method, "submission_id": entry.submission_id});
                for lighting in &board.lightings {
                    row[lighting.as_str()] = json!(accuracy(entry, lighting, Some(subset), "prompt_grounded", group));
                }
                rows.push(row);
            }
        }
    }
    rows
}

/// Table III: per subset, group and method, standard against prompt-grounded accuracy
/// pooled over all lightings, with 95 % bootstrap intervals over scenes.
pub fn table_three(board: &Leaderboard) -> Vec<Value> {
    let mut rows = Vec::new();
    for subset in SUBSETS {
        for group in GROUPS {
            for entry in board.entries.iter().filter(|e| e.scores["vqa"].is_object()) {
                let (standard, standard_ci, standard_n) = over_lightings(entry, subset, "standard", group);
                let (prompt, prompt_ci, prompt_n) = over_lightings(entry, subset, "prompt_grounded", group);
                rows.push(json!({
                    "subset": subset, "group": group, "method": entry.method, "submission_id": entry.submission_id,
                    "standard": standard, "standard_ci95_low": standard_ci[0], "standard_ci95_high": standard_ci[1], "standard_questions": standard_n,
                    "prompt_grounded": prompt, "prompt_grounded_ci95_low": prompt_ci[0], "prompt_grounded_ci95_high": prompt_ci[1],
                    "prompt_grounded_questions": prompt_n,
                }));
            }
        }
    }
    rows
}

/// A table cell: text (team and method names, ids) made safe for spreadsheets, numbers
/// as JSON writes them, nothing for null.
fn csv_value(value: &Value) -> String {
    match value {
        Value::Null => String::new(),
        Value::String(s) => spreadsheet_safe(s).into_owned(),
        other => other.to_string(),
    }
}

/// Rows of one table as CSV with `columns`.
pub fn table_csv(rows: &[Value], columns: &[&str]) -> String {
    let mut csv = CsvWriter::new(LineEnd::Lf);
    csv.row(columns);
    for row in rows {
        csv.row(columns.iter().map(|c| csv_value(&row[*c])));
    }
    csv.finish()
}

/// The columns of Table II for `lightings`.
pub fn table_two_columns(lightings: &[String]) -> Vec<&str> {
    ["subset", "group", "method", "submission_id"].into_iter().chain(lightings.iter().map(String::as_str)).collect()
}

/// The columns of Table III.
pub const TABLE_THREE_COLUMNS: [&str; 12] = [
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
];

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn vqa_tables_defuse_formulas_in_names_and_keep_numbers() {
        let lightings = vec!["baseline".to_string()];
        let rows = vec![serde_json::json!({
            "subset": "all", "group": "Binary", "method": "=HYPERLINK(\"http://evil\",\"x\")", "submission_id": "sub_1", "baseline": -0.25
        })];
        let csv = table_csv(&rows, &table_two_columns(&lightings));
        assert_eq!(csv, "subset,group,method,submission_id,baseline\nall,Binary,\"'=HYPERLINK(\"\"http://evil\"\",\"\"x\"\")\",sub_1,-0.25\n");
    }
}
