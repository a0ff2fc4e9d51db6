//! The leaderboard as CSV: one row per entry; its rank, rank group and robustness; per
//! lighting the pooled metrics with their 95 % intervals, the mean metrics and the pooled
//! metrics of each subset, then per lighting the VQA accuracies; empty cells where a
//! value is undefined; names made safe for spreadsheets.

use osmab_evaluator::csv_writer::{CsvWriter, LineEnd, spreadsheet_safe};
use osmab_evaluator::scores::{Aggregate, Metric, Regime};

use super::Leaderboard;

/// A number as CSV writes it, or nothing where undefined.
pub fn cell(value: Option<f64>) -> String {
    value.map(|x| x.to_string()).unwrap_or_default()
}

/// The CSV export of `board` (`GET /api/v1/leaderboard.csv`).
pub fn to_csv(board: &Leaderboard) -> String {
    let mut header: Vec<String> = [
        "rank",
        "rank_group",
        "submission_id",
        "team",
        "method",
        "baseline",
        "reference",
        "complete",
        "worst_lighting",
        "worst_lighting_miou",
        "largest_drop_lighting",
        "largest_drop",
    ]
    .into_iter()
    .map(String::from)
    .collect();
    for lighting in &board.lightings {
        for aggregate in Aggregate::ALL {
            for metric in Metric::COLUMNS {
                header.push(format!("{lighting}_{aggregate}_{metric}"));
            }
            if aggregate == Aggregate::Overall {
                for metric in Metric::COLUMNS {
                    header.push(format!("{lighting}_{aggregate}_{metric}_ci95_low"));
                    header.push(format!("{lighting}_{aggregate}_{metric}_ci95_high"));
                }
            }
        }
        for subset in Regime::ALL {
            for metric in Metric::COLUMNS {
                header.push(format!("{lighting}_{subset}_{metric}"));
            }
        }
    }
    header.extend(super::vqa::csv_columns(&board.lightings));
    let mut csv = CsvWriter::new(LineEnd::Lf);
    csv.row(&header);
    let name = |l: Option<osmab_evaluator::scores::Lighting>| l.map(|l| l.to_string()).unwrap_or_default();
    for e in &board.entries {
        let mut row = vec![
            e.rank.to_string(),
            e.rank_group.to_string(),
            e.submission_id.clone(),
            spreadsheet_safe(&e.team).into_owned(),
            spreadsheet_safe(&e.method).into_owned(),
            e.baseline.to_string(),
            e.reference.to_string(),
            e.complete.to_string(),
            name(e.robustness.worst_lighting),
            cell(e.robustness.worst_miou),
            name(e.robustness.largest_drop_lighting),
            cell(e.robustness.largest_drop),
        ];
        for &lighting in &board.lightings {
            for aggregate in Aggregate::ALL {
                for metric in Metric::COLUMNS {
                    row.push(cell(e.metric(lighting, None, aggregate, metric)));
                }
                if aggregate == Aggregate::Overall {
                    for metric in Metric::COLUMNS {
                        let interval = e.interval(lighting, None, metric);
                        row.push(cell(interval.map(|i| i[0])));
                        row.push(cell(interval.map(|i| i[1])));
                    }
                }
            }
            for subset in Regime::ALL {
                for metric in Metric::COLUMNS {
                    row.push(cell(e.metric(lighting, Some(subset), Aggregate::Overall, metric)));
                }
            }
        }
        row.extend(super::vqa::csv_cells(e, &board.lightings).into_iter().map(cell));
        csv.row(row);
    }
    csv.finish()
}
