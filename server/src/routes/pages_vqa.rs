//! The question-answering section of the leaderboard page: per entry and lighting the
//! prompt-grounded and standard accuracies in the paper's two groups, and one bar chart
//! per (question set, group) across lightings.

use super::pages::{escape_xml, lighting_label, lighting_short, percent};
use crate::leaderboard::Entry;
use crate::leaderboard_vqa::{GROUPS, SETS, accuracy};

pub struct VqaRow {
    pub submission_id: String,
    pub method: String,
    pub baseline: bool,
    pub cells: Vec<String>,
}

pub struct VqaView {
    /// (lighting label, columns under it).
    pub lighting_groups: Vec<(String, usize)>,
    /// Column labels under each lighting.
    pub columns: Vec<String>,
    pub rows: Vec<VqaRow>,
    pub charts: Vec<String>,
    pub table_two_csv: String,
    pub table_three_csv: String,
    pub tables_json: String,
}

/// The section for `entries` (in the page's order), over all scenes or one `subset`;
/// `None` when no entry has VQA scores.
pub fn vqa_view(release: &str, lightings: &[String], entries: &[&Entry], subset: Option<&str>) -> Option<VqaView> {
    let with_vqa: Vec<&Entry> = entries.iter().copied().filter(|e| e.scores["vqa"].is_object()).collect();
    if with_vqa.is_empty() {
        return None;
    }
    let pairs: Vec<(&str, &str, &str)> = SETS.iter().flat_map(|(set, label)| GROUPS.iter().map(move |g| (*set, *label, *g))).collect();
    let columns = pairs.iter().map(|(_, label, group)| format!("{label} {}", if *group == "Measurements" { "Meas." } else { "Rel." })).collect();
    let rows = with_vqa
        .iter()
        .map(|e| VqaRow {
            submission_id: e.submission_id.clone(),
            method: e.method.clone(),
            baseline: e.baseline,
            cells: lightings.iter().flat_map(|l| pairs.iter().map(move |(set, _, group)| percent(accuracy(e, l, subset, set, group)))).collect(),
        })
        .collect();
    let charts = pairs
        .iter()
        .map(|(set, label, group)| bar_chart(&format!("{label} {group}"), lightings, &with_vqa, |e, l| accuracy(e, l, subset, set, group)))
        .collect();
    Some(VqaView {
        lighting_groups: lightings.iter().map(|l| (lighting_label(l), pairs.len())).collect(),
        columns,
        rows,
        charts,
        table_two_csv: format!("/api/v1/leaderboard/vqa.csv?table=2&release={release}"),
        table_three_csv: format!("/api/v1/leaderboard/vqa.csv?table=3&release={release}"),
        tables_json: format!("/api/v1/leaderboard/vqa?release={release}"),
    })
}

/// Accuracy (0–100 %) per lighting, one bar per entry (the first eight).
fn bar_chart(title: &str, lightings: &[String], entries: &[&Entry], value: impl Fn(&Entry, &str) -> Option<f64>) -> String {
    let shown: Vec<&Entry> = entries.iter().take(8).copied().collect();
    let (width, height, top, bottom, left) = (360.0, 250.0, 24.0, 84.0, 40.0);
    let plot_h = height - top - bottom;
    let group_w = (width - left - 10.0) / lightings.len().max(1) as f64;
    let bar_w = (group_w * 0.8 / shown.len().max(1) as f64).min(18.0);
    let palette = ["#1f77b4", "#ff7f0e", "#2ca02c", "#d62728", "#9467bd", "#8c564b", "#e377c2", "#7f7f7f"];
    let mut svg = format!(
        "<svg xmlns=\"http://www.w3.org/2000/svg\" viewBox=\"0 0 {width} {height}\" role=\"img\" class=\"chart small\"><title>{} accuracy per lighting</title><text x=\"{left}\" y=\"14\" class=\"legend\">{} (%)</text>",
        escape_xml(title),
        escape_xml(title)
    );
    for frac in [0.0, 0.5, 1.0] {
        let y = top + plot_h * (1.0 - frac);
        svg.push_str(&format!(
            "<line x1=\"{left}\" x2=\"{}\" y1=\"{y:.1}\" y2=\"{y:.1}\" class=\"grid\"/><text x=\"{}\" y=\"{:.1}\" class=\"axis\" text-anchor=\"end\">{:.0}</text>",
            width - 10.0,
            left - 4.0,
            y + 4.0,
            frac * 100.0
        ));
    }
    for (g, lighting) in lightings.iter().enumerate() {
        let x0 = left + g as f64 * group_w + group_w * 0.1;
        for (i, entry) in shown.iter().enumerate() {
            if let Some(v) = value(entry, lighting) {
                let h = v.clamp(0.0, 1.0) * plot_h;
                svg.push_str(&format!(
                    "<rect x=\"{:.1}\" y=\"{:.1}\" width=\"{bar_w:.1}\" height=\"{:.1}\" fill=\"{}\"><title>{} — {}: {:.1}%</title></rect>",
                    x0 + i as f64 * bar_w,
                    top + plot_h - h,
                    h.max(0.5),
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
            height - bottom + 16.0,
            escape_xml(&lighting_short(lighting))
        ));
    }
    for (i, entry) in shown.iter().enumerate() {
        let x = left + (i % 2) as f64 * 160.0;
        let y = height - bottom + 34.0 + (i / 2) as f64 * 12.0;
        svg.push_str(&format!(
            "<rect x=\"{x:.1}\" y=\"{:.1}\" width=\"8\" height=\"8\" fill=\"{}\"/><text x=\"{:.1}\" y=\"{y:.1}\" class=\"legend\">{}</text>",
            y - 8.0,
            palette[i % palette.len()],
            x + 12.0,
            escape_xml(&entry.method.chars().take(22).collect::<String>())
        ));
    }
    svg.push_str("</svg>");
    svg
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
    pub label: String,
    pub rows: Vec<VqaCategoryRow>,
}

fn category_row(name: &str, cell: &serde_json::Value, group: bool) -> VqaCategoryRow {
    let interval = match (cell["ci95"][0].as_f64(), cell["ci95"][1].as_f64()) {
        (Some(lo), Some(hi)) => format!("{:.1}–{:.1}", lo * 100.0, hi * 100.0),
        _ => "–".into(),
    };
    VqaCategoryRow {
        name: name.to_string(),
        counts: format!("{} / {}", cell["correct"].as_u64().unwrap_or(0), cell["total"].as_u64().unwrap_or(0)),
        accuracy: percent(cell["accuracy"].as_f64()),
        interval,
        group,
    }
}

/// Per lighting: each question set's groups, then its categories.
pub fn submission_vqa(vqa: &serde_json::Value, lightings: &[String]) -> Vec<VqaLighting> {
    lightings
        .iter()
        .filter(|l| vqa["lightings"][l.as_str()].is_object())
        .map(|l| {
            let at = &vqa["lightings"][l.as_str()];
            let mut rows = Vec::new();
            for (set, label) in SETS {
                for group in GROUPS {
                    rows.push(category_row(&format!("{label} {group}"), &at[set]["groups"][group], true));
                }
                for (category, cell) in at[set]["categories"].as_object().into_iter().flatten() {
                    rows.push(category_row(category, cell, false));
                }
            }
            VqaLighting { label: lighting_label(l), rows }
        })
        .collect()
}

/// Who answered and who judged, in words.
pub fn vqa_sources(vqa: &serde_json::Value) -> String {
    let list = |v: &serde_json::Value| v.as_object().into_iter().flatten().map(|(k, n)| format!("{k} {n}")).collect::<Vec<_>>().join(", ");
    if !vqa.is_object() {
        return String::new();
    }
    format!("answered by {}; judged by {}", list(&vqa["answered_by"]), list(&vqa["judged_by"]))
}
