//! OSMa-Bench's own VQA files and metrics: answered or judged files are lists of
//! `{question, answer, category, scene_graph_answer, similar?}`; `metrics.csv` has one row
//! per file with `File Name, Overall Accuracy, Accuracy (No Spatial)` and one column per
//! category (sorted; `0.00%` where a file lacks the category), percentages as Python's
//! `f"{x:.2%}"`, rows ended by `\r\n` as Python's csv writer does.

use crate::csv_writer::{CsvWriter, LineEnd};
use std::collections::{BTreeMap, BTreeSet};
use std::path::Path;

use serde_json::{Map, Value};

use super::judge::{JudgedBy, OpenJudge, Pending, Verdict, judge_without_llm};
use super::text::python_str;
use super::{QuestionForm, STANDARD_CATEGORIES};
use crate::InputError;

/// The category OSMa-Bench leaves out of `Accuracy (No Spatial)`.
pub const SPATIAL: &str = "Object Relations - Spatial";

/// One entry of an OSMa-Bench answers file, with every field kept.
#[derive(Debug, Clone, PartialEq)]
pub struct Entry {
    pub fields: Map<String, Value>,
}

impl Entry {
    pub fn category(&self) -> String {
        self.fields.get("category").map(python_str).unwrap_or_else(|| "Unknown".into())
    }
    pub fn answer(&self) -> &Value {
        &self.fields["answer"]
    }
    /// `scene_graph_answer`, `""` when missing (as the reference's `q.get(..., "")`).
    pub fn predicted(&self) -> Value {
        self.fields.get("scene_graph_answer").cloned().unwrap_or(Value::String(String::new()))
    }
    pub fn form(&self) -> Option<QuestionForm> {
        self.fields.get("form").and_then(|f| serde_json::from_value(f.clone()).ok())
    }
}

/// Read an OSMa-Bench answers file (answered, or judged with `similar`).
pub fn read_file(path: &Path) -> Result<Vec<Entry>, InputError> {
    let bytes = std::fs::read(path).map_err(|e| InputError::io(path, &e))?;
    let value: Value = serde_json::from_slice(&bytes).map_err(|e| InputError::new(path, "(json)", format!("not valid JSON: {e}")))?;
    let Value::Array(items) = value else {
        return Err(InputError::new(path, "(json)", "expected a list of {\"question\", \"answer\", \"category\", \"scene_graph_answer\"}"));
    };
    items
        .into_iter()
        .enumerate()
        .map(|(i, item)| match item {
            Value::Object(fields) if fields.contains_key("answer") => Ok(Entry { fields }),
            Value::Object(_) => Err(InputError::new(path, format!("[{i}].answer"), "missing: every entry needs the ground-truth answer")),
            _ => Err(InputError::new(path, format!("[{i}]"), "expected an object")),
        })
        .collect()
}

/// Which verdicts to trust.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct JudgeOptions {
    /// Keep `similar` verdicts already in the files for what cannot be judged locally.
    pub keep_recorded: bool,
}

/// Judge every entry: local rule, form rule, recorded verdict (if kept), then the open
/// judge (if any) in batches of 10 for the rest; undecided entries count as wrong.
pub fn judge_entries(entries: &[Entry], options: JudgeOptions, open: Option<&dyn OpenJudge>) -> Vec<Option<Verdict>> {
    let mut verdicts: Vec<Option<Verdict>> = entries
        .iter()
        .map(|e| {
            let recorded = if options.keep_recorded { e.fields.get("similar") } else { None };
            judge_without_llm(e.answer(), &e.predicted(), e.form().as_ref(), recorded)
        })
        .collect();
    if let Some(open) = open {
        let undecided: Vec<usize> = (0..entries.len()).filter(|&i| verdicts[i].is_none()).collect();
        for batch in undecided.chunks(10) {
            let pending: Vec<Pending> = batch
                .iter()
                .map(|&i| Pending {
                    question: entries[i].fields.get("question").map(python_str).unwrap_or_default(),
                    answer: python_str(entries[i].answer()),
                    scene_graph_answer: python_str(&entries[i].predicted()),
                })
                .collect();
            for (&i, verdict) in batch.iter().zip(open.judge(&pending)) {
                verdicts[i] = verdict.map(|correct| Verdict { correct, by: JudgedBy::Llm });
            }
        }
    }
    verdicts
}

/// The metrics of one file.
#[derive(Debug, Clone, PartialEq)]
pub struct FileMetrics {
    pub file_name: String,
    pub overall: f64,
    pub no_spatial: f64,
    /// Accuracy of every category present in the file.
    pub per_category: BTreeMap<String, f64>,
}

/// OSMa-Bench's per-file metrics; an undecided entry is a wrong one.
pub fn file_metrics(file_name: &str, entries: &[Entry], verdicts: &[Option<Verdict>]) -> FileMetrics {
    let (mut right, mut total, mut right_ns, mut total_ns) = (0u64, 0u64, 0u64, 0u64);
    let mut per: BTreeMap<String, (u64, u64)> = BTreeMap::new();
    for (entry, verdict) in entries.iter().zip(verdicts) {
        let correct = verdict.is_some_and(|v| v.correct);
        let category = entry.category();
        total += 1;
        right += correct as u64;
        if category != SPATIAL {
            total_ns += 1;
            right_ns += correct as u64;
        }
        let slot = per.entry(category).or_default();
        slot.0 += correct as u64;
        slot.1 += 1;
    }
    let ratio = |r: u64, t: u64| if t > 0 { r as f64 / t as f64 } else { 0.0 };
    FileMetrics {
        file_name: file_name.to_string(),
        overall: ratio(right, total),
        no_spatial: ratio(right_ns, total_ns),
        per_category: per.into_iter().map(|(c, (r, t))| (c, ratio(r, t))).collect(),
    }
}

/// `f"{x:.2%}"`: the product with 100 rounded half-to-even on its exact binary value.
pub fn percent(x: f64) -> String {
    format!("{:.2}%", x * 100.0)
}

/// The category columns for `files`: every category they hold, sorted; when any
/// standard OSMa-Bench category is present, all eight are (so rows of files lacking
/// one line up with the published tables).
pub fn category_columns<'a>(categories: impl IntoIterator<Item = &'a str>) -> Vec<String> {
    let mut all: BTreeSet<String> = categories.into_iter().map(str::to_string).collect();
    if all.iter().any(|c| STANDARD_CATEGORIES.contains(&c.as_str())) {
        all.extend(STANDARD_CATEGORIES.iter().map(|c| c.to_string()));
    }
    all.into_iter().collect()
}

/// metrics.csv: the header, then one row per file (Python's `csv` module: `\r\n`).
pub fn metrics_csv(rows: &[FileMetrics], columns: &[String]) -> String {
    let mut csv = CsvWriter::new(LineEnd::CrLf);
    csv.row(["File Name", "Overall Accuracy", "Accuracy (No Spatial)"].iter().map(|s| s.to_string()).chain(columns.iter().cloned()));
    for row in rows {
        let mut cells = vec![row.file_name.clone(), percent(row.overall), percent(row.no_spatial)];
        cells.extend(columns.iter().map(|c| percent(row.per_category.get(c).copied().unwrap_or(0.0))));
        csv.row(cells);
    }
    csv.finish()
}

/// The judged file: every entry in its order with `similar` ("Yes", "No", the recorded
/// text, or "N/A" when undecided) and `judged_by`; the usual fields first, 4-space JSON.
pub fn judged_json(entries: &[Entry], verdicts: &[Option<Verdict>]) -> String {
    const FIRST: [&str; 4] = ["question", "answer", "category", "scene_graph_answer"];
    let mut items = Vec::with_capacity(entries.len());
    for (entry, verdict) in entries.iter().zip(verdicts) {
        let mut pairs: Vec<(String, Value)> = Vec::new();
        for key in FIRST {
            if let Some(v) = entry.fields.get(key) {
                pairs.push((key.to_string(), v.clone()));
            }
        }
        for (k, v) in &entry.fields {
            if !FIRST.contains(&k.as_str()) && k != "similar" && k != "judged_by" {
                pairs.push((k.clone(), v.clone()));
            }
        }
        let similar = match verdict {
            Some(Verdict { by: JudgedBy::Recorded, .. }) => entry.fields.get("similar").cloned().unwrap_or(Value::Null),
            Some(v) => Value::String(if v.correct { "Yes" } else { "No" }.into()),
            None => Value::String("N/A".into()),
        };
        pairs.push(("similar".into(), similar));
        pairs.push(("judged_by".into(), Value::String(verdict.map_or(JudgedBy::None, |v| v.by).name().into())));
        let body: Vec<String> = pairs
            .iter()
            .map(|(k, v)| {
                let value = serde_json::to_string_pretty(v).expect("json").replace('\n', "\n        ");
                format!("        {}: {value}", serde_json::to_string(k).expect("json"))
            })
            .collect();
        items.push(format!("    {{\n{}\n    }}", body.join(",\n")));
    }
    if items.is_empty() { "[]\n".into() } else { format!("[\n{}\n]\n", items.join(",\n")) }
}
