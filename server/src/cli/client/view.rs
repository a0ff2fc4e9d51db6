//! What the client prints: a submission's state and history (followed until it ends),
//! its score tables, and the leaderboard, as plain aligned text.

use std::time::Duration;

use anyhow::bail;
use serde_json::Value;

use super::api::Api;

const METRICS: [(&str, &str); 3] = [("miou", "mIoU"), ("fmiou", "f-mIoU"), ("macc", "mAcc")];

fn pct(v: &Value) -> String {
    v.as_f64().map(|x| format!("{:.1}", x * 100.0)).unwrap_or_else(|| "-".into())
}

/// Rows as aligned columns: numbers right-aligned, words left-aligned.
pub fn table(header: &[String], rows: &[Vec<String>]) -> String {
    let widths: Vec<usize> =
        (0..header.len()).map(|c| rows.iter().map(|r| r.get(c).map_or(0, |s| s.chars().count())).max().unwrap_or(0).max(header[c].chars().count())).collect();
    let numeric: Vec<bool> =
        (0..header.len()).map(|c| rows.iter().all(|r| r.get(c).is_none_or(|s| s == "-" || s.is_empty() || s.parse::<f64>().is_ok()))).collect();
    let line = |cells: &[String]| {
        cells
            .iter()
            .enumerate()
            .map(|(c, s)| if numeric[c] { format!("{s:>w$}", w = widths[c]) } else { format!("{s:<w$}", w = widths[c]) })
            .collect::<Vec<_>>()
            .join("  ")
            .trim_end()
            .to_string()
    };
    let mut out = line(header) + "\n";
    for row in rows {
        out.push_str(&line(row));
        out.push('\n');
    }
    out
}

/// `osmab client status ID [--watch]`: the state with its history; with `watch`, every
/// change as it happens until the submission is scored, failed or cancelled. Returns
/// the final state.
pub fn status(api: &Api, id: &str, watch: bool) -> anyhow::Result<String> {
    let mut shown = 0;
    loop {
        let view = api.get_team_json(&format!("/api/v1/submissions/{id}"))?;
        let history = view["history"].as_array().cloned().unwrap_or_default();
        if shown == 0 {
            println!(
                "{} — {} ({}), release {}",
                view["id"].as_str().unwrap_or(id),
                view["method"]["name"].as_str().unwrap_or("?"),
                view["team"].as_str().unwrap_or("?"),
                view["release"].as_str().unwrap_or("?")
            );
        }
        for event in history.iter().skip(shown) {
            let reason = event["reason"].as_str().filter(|r| !r.is_empty()).map(|r| format!(" — {r}")).unwrap_or_default();
            println!("{}  {}{reason}", event["at"].as_str().unwrap_or(""), event["state"].as_str().unwrap_or("?"));
        }
        shown = history.len();
        let state = view["state"].as_str().unwrap_or("").to_string();
        if !watch || ["scored", "failed", "cancelled"].contains(&state.as_str()) {
            if state == "failed" {
                println!("The submission failed: {}", view["reason"].as_str().unwrap_or("no reason recorded"));
            }
            return Ok(state);
        }
        std::thread::sleep(Duration::from_secs(2));
    }
}

/// `osmab client results ID`: segmentation per lighting (per scene, mean, pooled) and the
/// VQA groups per lighting.
pub fn results(api: &Api, id: &str) -> anyhow::Result<()> {
    let view = api.get_team_json(&format!("/api/v1/submissions/{id}"))?;
    let scores = &view["scores"];
    if !scores.is_object() {
        bail!("{id} has no score yet (state: {}); follow it with `osmab client status {id} --watch`", view["state"].as_str().unwrap_or("?"));
    }
    println!(
        "{} — release {}, evaluator {}",
        view["method"]["name"].as_str().unwrap_or("?"),
        scores["release"].as_str().unwrap_or("?"),
        scores["evaluator_version"].as_str().unwrap_or("?")
    );
    let header: Vec<String> = std::iter::once("scene".to_string()).chain(METRICS.iter().map(|(_, l)| l.to_string())).collect();
    for (lighting, table_json) in scores["semseg"].as_object().into_iter().flatten() {
        let mut rows: Vec<Vec<String>> = table_json["scenes"]
            .as_object()
            .into_iter()
            .flatten()
            .map(|(scene, m)| std::iter::once(scene.clone()).chain(METRICS.iter().map(|(k, _)| pct(&m[*k]))).collect())
            .collect();
        for (name, key) in [("mean over scenes", "overall_mean"), ("pooled", "overall")] {
            rows.push(std::iter::once(name.to_string()).chain(METRICS.iter().map(|(k, _)| pct(&table_json[key][*k]))).collect());
        }
        println!("\nSegmentation, {lighting} (%)\n{}", table(&header, &rows));
    }
    if let Some(lightings) = scores["vqa"]["lightings"].as_object() {
        let header: Vec<String> = ["lighting", "PromptGT Meas.", "PromptGT Rel.", "Standard Meas.", "Standard Rel.", "all"].map(String::from).to_vec();
        let rows: Vec<Vec<String>> = lightings
            .iter()
            .map(|(l, v)| {
                let g = |set: &str, group: &str| pct(&v[set]["groups"][group]["accuracy"]);
                vec![
                    l.clone(),
                    g("prompt_grounded", "Measurements"),
                    g("prompt_grounded", "Relations"),
                    g("standard", "Measurements"),
                    g("standard", "Relations"),
                    pct(&v["overall"]["accuracy"]),
                ]
            })
            .collect();
        println!("\nQuestion answering, pooled accuracy (%)\n{}", table(&header, &rows));
    }
    Ok(())
}

/// `osmab client leaderboard [--release V] [--lighting L]`.
pub fn leaderboard(api: &Api, release: Option<&str>, lighting: Option<&str>) -> anyhow::Result<()> {
    let path = match release {
        Some(v) => format!("/api/v1/leaderboard?release={v}"),
        None => "/api/v1/leaderboard".to_string(),
    };
    let board = api.get_json(&path)?;
    let lightings: Vec<String> = board["lightings"].as_array().into_iter().flatten().filter_map(|l| l.as_str().map(str::to_string)).collect();
    let lighting = match lighting {
        Some(l) if lightings.iter().any(|x| x == l) => l.to_string(),
        Some(l) => bail!("the leaderboard has no lighting '{l}' (it has {})", lightings.join(", ")),
        None => lightings.first().cloned().unwrap_or_else(|| "baseline".into()),
    };
    let header: Vec<String> = ["#", "method", "team", "mIoU", "f-mIoU", "mAcc", "PromptGT", "Standard", ""].iter().map(|s| s.to_string()).collect();
    let rows: Vec<Vec<String>> = board["entries"]
        .as_array()
        .into_iter()
        .flatten()
        .enumerate()
        .map(|(i, e)| {
            let at = &e["scores"]["semseg"][lighting.as_str()]["overall"];
            let vqa = &e["scores"]["vqa"]["lightings"][lighting.as_str()];
            let mut tags = Vec::new();
            if e["baseline"] == true {
                tags.push("baseline");
            }
            if e["complete"] == false {
                tags.push("incomplete");
            }
            vec![
                (i + 1).to_string(),
                e["method"].as_str().unwrap_or("?").to_string(),
                e["team"].as_str().unwrap_or("?").to_string(),
                pct(&at["miou"]),
                pct(&at["fmiou"]),
                pct(&at["macc"]),
                pct(&vqa["prompt_grounded"]["overall"]["accuracy"]),
                pct(&vqa["standard"]["overall"]["accuracy"]),
                tags.join(" "),
            ]
        })
        .collect();
    println!("Leaderboard of {} — {lighting} lighting, pooled (%); VQA accuracy (%)\n{}", board["release"].as_str().unwrap_or("?"), table(&header, &rows));
    Ok(())
}
