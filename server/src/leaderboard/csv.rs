//! The leaderboard as CSV: one row per entry; its rank, rank group and robustness; per
//! lighting the pooled metrics with their 95 % intervals, the mean metrics and the pooled
//! metrics of each subset, then per lighting the VQA accuracies; empty cells where a
//! value is undefined; names made safe for spreadsheets.

use osmab_api::leaderboard::Entry;
use osmab_evaluator::csv_writer::{CsvWriter, LineEnd, spreadsheet_safe};
use osmab_evaluator::scores::{Aggregate, Lighting, Metric, QuestionSet, Regime};

use super::Leaderboard;

/// A number as CSV writes it, or nothing where undefined.
pub fn cell(value: Option<f64>) -> String {
    value.map(|x| x.to_string()).unwrap_or_default()
}

/// One column of the export: its header, and what an entry writes under it.
struct Column<'a> {
    header: String,
    cell: Box<dyn Fn(&Entry) -> String + 'a>,
}

fn column<'a>(header: impl Into<String>, cell: impl Fn(&Entry) -> String + 'a) -> Column<'a> {
    Column { header: header.into(), cell: Box::new(cell) }
}

/// The columns of `board`'s export, in order: each named once, beside its value.
fn columns(board: &Leaderboard) -> Vec<Column<'static>> {
    let name = |l: Option<Lighting>| l.map(|l| l.to_string()).unwrap_or_default();
    let mut columns = vec![
        column("rank", |e| e.rank.to_string()),
        column("rank_group", |e| e.rank_group.to_string()),
        column("submission_id", |e| e.submission_id.clone()),
        column("team", |e| spreadsheet_safe(&e.team).into_owned()),
        column("method", |e| spreadsheet_safe(&e.method).into_owned()),
        column("baseline", |e| e.baseline.to_string()),
        column("reference", |e| e.reference.to_string()),
        column("complete", |e| e.complete.to_string()),
        column("worst_lighting", move |e| name(e.robustness.worst_lighting)),
        column("worst_lighting_miou", |e| cell(e.robustness.worst_miou)),
        column("largest_drop_lighting", move |e| name(e.robustness.largest_drop_lighting)),
        column("largest_drop", |e| cell(e.robustness.largest_drop)),
    ];
    for &lighting in &board.lightings {
        for aggregate in Aggregate::ALL {
            for metric in Metric::COLUMNS {
                columns.push(column(format!("{lighting}_{aggregate}_{metric}"), move |e| cell(e.metric(lighting, None, aggregate, metric))));
            }
            if aggregate == Aggregate::Overall {
                for metric in Metric::COLUMNS {
                    let bound = move |e: &Entry, k: usize| cell(e.interval(lighting, None, metric).map(|i| i[k]));
                    columns.push(column(format!("{lighting}_{aggregate}_{metric}_ci95_low"), move |e| bound(e, 0)));
                    columns.push(column(format!("{lighting}_{aggregate}_{metric}_ci95_high"), move |e| bound(e, 1)));
                }
            }
        }
        for subset in Regime::ALL {
            for metric in Metric::COLUMNS {
                columns.push(column(format!("{lighting}_{subset}_{metric}"), move |e| cell(e.metric(lighting, Some(subset), Aggregate::Overall, metric))));
            }
        }
    }
    for &lighting in &board.lightings {
        for (set, group) in QuestionSet::with_groups() {
            let header = format!("{lighting}_vqa_{set}_{}", group.name().to_lowercase());
            columns.push(column(header, move |e| cell(super::vqa::accuracy(e, lighting, None, set, group))));
        }
    }
    columns
}

/// The CSV export of `board` (`GET /api/v1/leaderboard.csv`).
pub fn to_csv(board: &Leaderboard) -> String {
    let columns = columns(board);
    let mut csv = CsvWriter::new(LineEnd::Lf);
    csv.row(columns.iter().map(|c| c.header.clone()).collect::<Vec<_>>());
    for entry in &board.entries {
        csv.row(columns.iter().map(|c| (c.cell)(entry)).collect::<Vec<_>>());
    }
    csv.finish()
}
