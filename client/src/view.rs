//! What the client prints: a submission's state and history (followed until it ends),
//! its score tables, and the leaderboard, as plain aligned text.

use std::time::Duration;

use anyhow::bail;

use osmab_evaluator::scores::{Accuracy, Aggregate, Lighting, Metric, QuestionSet, Split};
use osmab_evaluator::semseg::report::MetricTriple;

use super::api::Api;
use osmab_api::account::Quotas;
use osmab_api::leaderboard::Leaderboard;
use osmab_api::states::SubmissionState;
use osmab_api::submissions::SubmissionView;

/// "pooled mIoU 81.2, f-mIoU 95.1, mAcc 85.0": a lighting's pooled metrics in one line,
/// labelled by the axes ([`Metric::label`]).
pub fn pooled_line(triple: &MetricTriple) -> String {
    let values: Vec<String> = Metric::COLUMNS.iter().map(|&m| format!("{} {:.1}", m.label(), triple.get(m) * 100.0)).collect();
    format!("pooled {}", values.join(", "))
}

fn pct(v: Option<f64>) -> String {
    v.map(|x| format!("{:.1}", x * 100.0)).unwrap_or_else(|| "-".into())
}

/// Rows as aligned columns: numbers right-aligned, words left-aligned.
pub fn table_text(header: &[String], rows: &[Vec<String>]) -> String {
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
pub fn status(api: &Api, id: &str, watch: bool) -> anyhow::Result<SubmissionState> {
    let mut shown = 0;
    let mut standing_shown = String::new();
    loop {
        let view: SubmissionView = api.get_team_as(&format!("/api/v1/submissions/{id}"))?;
        if shown == 0 {
            println!("{} — {} ({}), release {}", view.id, view.method.name, view.team, view.release);
        }
        for event in view.history.iter().skip(shown) {
            let reason = event.reason.as_deref().filter(|r| !r.is_empty()).map(|r| format!(" — {r}")).unwrap_or_default();
            println!("{}  {}{reason}", event.at, event.state);
        }
        shown = view.history.len();
        // Where it stands in the queue, when that changed (position or estimate).
        if let Some(queue) = &view.queue {
            let standing = queue.sentence();
            if standing != standing_shown {
                println!("  {standing}");
                standing_shown = standing;
            }
        }
        if !watch || !view.state.is_active() {
            if view.state == SubmissionState::Failed {
                println!("The submission failed: {}", view.reason.as_deref().unwrap_or("no reason recorded"));
            }
            return Ok(view.state);
        }
        std::thread::sleep(Duration::from_secs(2));
    }
}

/// `osmab client results ID`: segmentation per lighting (per scene, mean, pooled) and the
/// VQA groups per lighting.
pub fn results(api: &Api, id: &str) -> anyhow::Result<()> {
    let view: SubmissionView = api.get_team_as(&format!("/api/v1/submissions/{id}"))?;
    let Some(scores) = view.scores else {
        bail!("{id} has no score yet (state: {}); follow it with `{} status {id} --watch`", view.state, crate::command());
    };
    println!("{} — release {}, evaluator {}", view.method.name, scores.release, scores.evaluator_version);
    let header: Vec<String> = std::iter::once("scene".to_string()).chain(Metric::COLUMNS.iter().map(|m| m.label().to_string())).collect();
    let cells = |t: &MetricTriple| Metric::COLUMNS.iter().map(|&m| pct(t.defined(m))).collect::<Vec<_>>();
    for (lighting, table) in &scores.semseg {
        let mut rows: Vec<Vec<String>> = table.scenes.iter().map(|(scene, m)| std::iter::once(scene.clone()).chain(cells(m)).collect()).collect();
        for aggregate in [Aggregate::OverallMean, Aggregate::Overall] {
            let name = match (aggregate, table.pooled) {
                (Aggregate::Overall, _) => "pooled".to_string(),
                (_, Some(n)) => format!("mean over {n} scenes"),
                (_, None) => "mean over scenes".to_string(),
            };
            rows.push(std::iter::once(name).chain(cells(table.aggregate(aggregate))).collect());
        }
        println!("\nSegmentation, {lighting} (%)\n{}", table_text(&header, &rows));
    }
    if let Some(vqa) = &scores.vqa {
        let header: Vec<String> = std::iter::once("lighting".to_string())
            .chain(QuestionSet::with_groups().map(|(set, group)| format!("{} {}", set.label(), group.label())))
            .chain(std::iter::once("all".to_string()))
            .collect();
        let rows: Vec<Vec<String>> = vqa
            .lightings
            .iter()
            .map(|(l, v)| (l.to_string(), v))
            .chain(std::iter::once(("all lightings".to_string(), &vqa.all_lightings)))
            .map(|(l, v)| {
                std::iter::once(l)
                    .chain(QuestionSet::with_groups().map(|(set, group)| pct(v.group_accuracy(set, group))))
                    .chain(std::iter::once(pct(v.overall.accuracy)))
                    .collect()
            })
            .collect();
        println!("\nQuestion answering, pooled accuracy (%)\n{}", table_text(&header, &rows));
        // Every category, so the groups above (the paper's tables) and "all" add up.
        let all = &vqa.all_lightings;
        let header: Vec<String> = ["question set", "category", "accuracy (%)", "correct", "questions"].map(String::from).to_vec();
        let count = |a: &Accuracy| vec![pct(a.accuracy), a.correct.to_string(), a.total.to_string()];
        let mut rows: Vec<Vec<String>> = [(QuestionSet::PromptGrounded, &all.prompt_grounded), (QuestionSet::Standard, &all.standard)]
            .into_iter()
            .flat_map(|(set, scores)| scores.categories.iter().map(move |(category, a)| [vec![set.label().to_string(), category.clone()], count(a)].concat()))
            .collect();
        rows.push([vec!["all".to_string(), String::new()], count(&all.overall)].concat());
        println!("\nQuestion answering by category, all lightings\n{}", table_text(&header, &rows));
    }
    if let Some(withheld) = &scores.withheld {
        println!("\n{}", withheld.note);
    }
    Ok(())
}

/// `osmab client leaderboard [--release V] [--lighting L]`.
pub fn leaderboard(api: &Api, release: Option<&str>, split: Option<Split>, lighting: Option<&str>) -> anyhow::Result<()> {
    let query: Vec<String> = release.map(|v| format!("release={v}")).into_iter().chain(split.map(|s| format!("split={s}"))).collect();
    let path = if query.is_empty() { "/api/v1/leaderboard".to_string() } else { format!("/api/v1/leaderboard?{}", query.join("&")) };
    let board: Leaderboard = serde_json::from_value(api.get_json(&path)?).map_err(|e| anyhow::anyhow!("the server's leaderboard does not read: {e}"))?;
    let names: Vec<&str> = board.lightings.iter().map(|l| l.name()).collect();
    let lighting = match lighting {
        Some(l) => match l.parse::<Lighting>().ok().filter(|x| board.lightings.contains(x)) {
            Some(l) => l,
            None => bail!("the leaderboard has no lighting '{l}' (it has {})", names.join(", ")),
        },
        None => board.lightings.first().copied().unwrap_or(Lighting::BASELINE),
    };
    let header: Vec<String> =
        ["#", "group", "method", "team", Metric::Miou.label(), "±", Metric::Fmiou.label(), Metric::Macc.label(), "PromptGT", "Standard", ""]
            .iter()
            .map(|s| s.to_string())
            .collect();
    let rows: Vec<Vec<String>> = board
        .entries
        .iter()
        .enumerate()
        .map(|(i, e)| {
            let metric = |m| pct(e.metric(lighting, None, Aggregate::Overall, m));
            // A test board pools VQA over every lighting (Scores::disclosed).
            let vqa = e.scores.vqa.as_ref().and_then(|v| v.lightings.get(&lighting).or((board.split == Split::Test).then_some(&v.all_lightings)));
            let mut tags = Vec::new();
            if e.baseline {
                tags.push("baseline");
            }
            if !e.complete {
                tags.push("incomplete");
            }
            // One rule with the pages: too few scenes pooled, no intervals and no groups.
            let spread =
                e.interval(lighting, None, Metric::Miou).filter(|_| board.significance).map(|[lo, hi]| format!("{:.1}", 50.0 * (hi - lo))).unwrap_or_default();
            vec![
                (i + 1).to_string(),
                if e.rank_group > 0 && board.significance { e.rank_group.to_string() } else { "–".to_string() },
                e.method.clone(),
                e.team.clone(),
                metric(Metric::Miou),
                spread,
                metric(Metric::Fmiou),
                metric(Metric::Macc),
                pct(vqa.and_then(|v| v.prompt_grounded.overall.accuracy)),
                pct(vqa.and_then(|v| v.standard.overall.accuracy)),
                tags.join(" "),
            ]
        })
        .collect();
    let statistics = if board.significance {
        "± half the 95 % interval; entries within noise share a group".to_string()
    } else {
        format!("{} scenes pooled: too few for intervals and significance groups", board.scenes)
    };
    println!(
        "Leaderboard of {}, {} split{} — {lighting} lighting, pooled (%), {statistics}; VQA accuracy (%)\n{}",
        board.release,
        board.split,
        match board.splits.iter().find(|s| **s != board.split) {
            Some(other) => format!(" (also: --split {other})"),
            None => String::new(),
        },
        table_text(&header, &rows)
    );
    if let Some(note) = super::currency::newer_release_note(api, &board.release, "this is the board of") {
        eprintln!("{note}");
    }
    Ok(())
}

/// Print the team's quota of every split (`GET /api/v1/quota`).
pub fn quota(api: &Api) -> anyhow::Result<()> {
    let answer: Quotas = api.get_team_as("/api/v1/quota")?;
    let header: Vec<String> = ["split", "used", "limit", "remaining", "window (h)", "next possible", "default split"].iter().map(|s| s.to_string()).collect();
    let rows: Vec<Vec<String>> = answer
        .splits
        .iter()
        .map(|q| {
            vec![
                q.split.to_string(),
                q.used.to_string(),
                q.limit.to_string(),
                q.remaining.to_string(),
                q.window_hours.to_string(),
                q.next_at.clone().unwrap_or_else(|| "now".into()),
                if q.split == answer.default_split { "yes".into() } else { String::new() },
            ]
        })
        .collect();
    println!("Quota of team {}\n{}", answer.team.name, table_text(&header, &rows));
    Ok(())
}
