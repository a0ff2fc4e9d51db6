//! `osmab eval vqa`: judge OSMa-Bench answer files and print their metrics.csv rows.

use std::path::{Path, PathBuf};

use anyhow::{Context, bail};
use clap::Args;
use osmab_evaluator::vqa::judge::{JudgedBy, OpenJudge};
use osmab_evaluator::vqa::osma::{JudgeOptions, category_columns, file_metrics, judge_entries, judged_json, metrics_csv, read_file};

#[derive(Debug, Args)]
pub struct VqaArgs {
    /// Answered or judged files in OSMa-Bench's format ([{question, answer, category,
    /// scene_graph_answer, similar?}]), or directories searched for *.json.
    #[arg(required = true)]
    inputs: Vec<PathBuf>,
    /// Write each file here (at its path relative to its input) with `similar` and
    /// `judged_by` on every entry.
    #[arg(long)]
    judged_out: Option<PathBuf>,
    /// Judge afresh: ignore the `similar` verdicts already in the files.
    #[arg(long)]
    ignore_recorded: bool,
    /// OpenAI-compatible endpoint of an LLM judge for what no rule decides (key in OSMAB_LLM_API_KEY).
    #[arg(long, requires = "llm_model")]
    llm_url: Option<String>,
    /// The judge's model.
    #[arg(long)]
    llm_model: Option<String>,
}

/// Every file under `path` with its path relative to the input (its name for a file).
fn collect(path: &Path, relative: &Path, out: &mut Vec<(PathBuf, PathBuf)>) -> anyhow::Result<()> {
    if path.is_dir() {
        let mut children: Vec<PathBuf> = std::fs::read_dir(path)
            .with_context(|| format!("{}: cannot read directory", path.display()))?
            .map(|e| e.map(|e| e.path()))
            .collect::<Result<_, _>>()
            .with_context(|| format!("{}: cannot list directory", path.display()))?;
        children.sort();
        for child in children {
            if child.is_dir() || child.extension().is_some_and(|e| e == "json") {
                let name = child.file_name().expect("a listed entry has a name").to_owned();
                collect(&child, &relative.join(name), out)?;
            }
        }
    } else if path.is_file() {
        let relative = if relative.as_os_str().is_empty() { PathBuf::from(path.file_name().unwrap_or_default()) } else { relative.to_path_buf() };
        out.push((path.to_path_buf(), relative));
    } else {
        bail!("{}: no such file or directory", path.display());
    }
    Ok(())
}

pub fn run(args: &VqaArgs) -> anyhow::Result<()> {
    let mut files = Vec::new();
    for input in &args.inputs {
        collect(input, Path::new(""), &mut files)?;
    }
    if files.is_empty() {
        bail!("no *.json files in {}", args.inputs.iter().map(|p| p.display().to_string()).collect::<Vec<_>>().join(", "));
    }
    let judge = match (&args.llm_url, &args.llm_model) {
        (Some(url), Some(model)) => Some(crate::llm::LlmJudge { client: crate::llm::client(url, model)? }),
        _ => None,
    };
    let options = JudgeOptions { keep_recorded: !args.ignore_recorded };
    let mut parsed = Vec::new();
    for (path, relative) in &files {
        parsed.push((path, relative, read_file(path)?));
    }
    let columns =
        category_columns(parsed.iter().flat_map(|(_, _, entries)| entries.iter().map(|e| e.category())).collect::<Vec<_>>().iter().map(String::as_str));
    let mut rows = Vec::new();
    let mut by = std::collections::BTreeMap::<JudgedBy, usize>::new();
    for (path, relative, entries) in &parsed {
        let verdicts = judge_entries(entries, options, judge.as_ref().map(|j| j as &dyn OpenJudge));
        for v in &verdicts {
            *by.entry(v.map_or(JudgedBy::None, |v| v.by)).or_default() += 1;
        }
        let name = path.file_name().and_then(|n| n.to_str()).unwrap_or_default();
        rows.push(file_metrics(name, entries, &verdicts));
        if let Some(dir) = &args.judged_out {
            // The inputs' layout is kept, so files of the same name in two folders both survive.
            let target = dir.join(relative);
            let folder = target.parent().expect("a file in a folder");
            std::fs::create_dir_all(folder).with_context(|| format!("{}: cannot create", folder.display()))?;
            std::fs::write(&target, judged_json(entries, &verdicts)).with_context(|| format!("{}: cannot write", target.display()))?;
        }
    }
    print!("{}", metrics_csv(&rows, &columns));
    // In the order judges are tried (local, recorded, rule, llm, none), not by name.
    let summary: Vec<String> = JudgedBy::ALL.iter().filter_map(|k| by.get(k).map(|n| format!("{} {n}", k.name()))).collect();
    eprintln!("{} files, {} answers judged: {}", files.len(), by.values().sum::<usize>(), summary.join(", "));
    Ok(())
}
