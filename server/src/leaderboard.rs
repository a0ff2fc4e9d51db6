//! The leaderboard of a release: every scored public submission (and the baselines) with
//! its latest score, ranked by pooled mIoU under the baseline lighting. Built from the
//! store at most once per second per release and served from memory as ready JSON and
//! CSV, so reads stay cheap under load.

use std::collections::HashMap;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Arc, RwLock};
use std::time::{Duration, Instant};

use serde::Serialize;
use serde_json::{Value, json};

use crate::store::{LeaderboardRow, Store, StoreResult};

/// Metrics in column order.
pub const METRICS: [&str; 3] = ["miou", "fmiou", "macc"];
/// Aggregates in column order: pooled, then mean over scenes.
pub const AGGREGATES: [&str; 2] = ["overall", "overall_mean"];
/// Subsets in column order.
pub const SUBSETS: [&str; 2] = ["furniture", "manipuland"];

/// One row of the leaderboard.
#[derive(Debug, Clone, Serialize)]
pub struct Entry {
    pub submission_id: String,
    pub team: String,
    pub method: String,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub paper_url: Option<String>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub code_url: Option<String>,
    pub baseline: bool,
    pub complete: bool,
    pub submitted_at: String,
    pub scores: Value,
}

impl Entry {
    /// A metric of the scores (`semseg.<lighting>.<aggregate>.<metric>`), if present.
    pub fn metric(&self, lighting: &str, aggregate: &str, metric: &str) -> Option<f64> {
        self.scores["semseg"][lighting][aggregate][metric].as_f64()
    }

    /// A pooled metric of one subset under one lighting.
    pub fn subset_metric(&self, lighting: &str, subset: &str, metric: &str) -> Option<f64> {
        self.scores["semseg"][lighting]["subsets"][subset]["overall"][metric].as_f64()
    }
}

/// The leaderboard of one release.
#[derive(Debug, Clone, Serialize)]
pub struct Leaderboard {
    pub release: String,
    pub lightings: Vec<String>,
    pub entries: Vec<Entry>,
}

impl Leaderboard {
    /// Rank `rows` of `release` (lightings in manifest order).
    pub fn new(release: &str, lightings: Vec<String>, rows: Vec<LeaderboardRow>) -> Self {
        let mut entries: Vec<Entry> = rows
            .into_iter()
            .map(|row| Entry {
                submission_id: row.submission_id,
                team: row.team,
                method: row.method_name,
                paper_url: row.paper_url,
                code_url: row.code_url,
                baseline: row.baseline,
                complete: row.complete,
                submitted_at: crate::clock::rfc3339(row.created_at),
                scores: serde_json::from_str(&row.body).unwrap_or(Value::Null),
            })
            .collect();
        let key_lighting = lightings.first().cloned().unwrap_or_default();
        entries.sort_by(|a, b| {
            let (x, y) = (a.metric(&key_lighting, "overall", "miou"), b.metric(&key_lighting, "overall", "miou"));
            y.unwrap_or(f64::NEG_INFINITY).total_cmp(&x.unwrap_or(f64::NEG_INFINITY)).then_with(|| a.submitted_at.cmp(&b.submitted_at))
        });
        Self { release: release.to_string(), lightings, entries }
    }

    /// The JSON document of `GET /api/v1/leaderboard`.
    pub fn to_json(&self) -> Value {
        json!({"release": self.release, "lightings": self.lightings, "entries": self.entries})
    }

    /// The CSV export: one row per entry, per lighting the pooled and mean metrics and
    /// the pooled metrics of each subset; empty cells where a value is undefined.
    pub fn to_csv(&self) -> String {
        let mut header = vec!["rank", "submission_id", "team", "method", "baseline", "complete"].into_iter().map(String::from).collect::<Vec<_>>();
        for lighting in &self.lightings {
            for aggregate in AGGREGATES {
                for metric in METRICS {
                    header.push(format!("{lighting}_{aggregate}_{metric}"));
                }
            }
            for subset in SUBSETS {
                for metric in METRICS {
                    header.push(format!("{lighting}_{subset}_{metric}"));
                }
            }
        }
        let mut out = header.join(",") + "\n";
        let cell = |v: Option<f64>| v.map(|x| x.to_string()).unwrap_or_default();
        for (rank, e) in self.entries.iter().enumerate() {
            let mut row =
                vec![(rank + 1).to_string(), e.submission_id.clone(), csv_text(&e.team), csv_text(&e.method), e.baseline.to_string(), e.complete.to_string()];
            for lighting in &self.lightings {
                for aggregate in AGGREGATES {
                    for metric in METRICS {
                        row.push(cell(e.metric(lighting, aggregate, metric)));
                    }
                }
                for subset in SUBSETS {
                    for metric in METRICS {
                        row.push(cell(e.subset_metric(lighting, subset, metric)));
                    }
                }
            }
            out.push_str(&(row.join(",") + "\n"));
        }
        out
    }
}

fn csv_text(text: &str) -> String {
    // Quote as RFC 4180, and defuse spreadsheet formulas in participant-chosen names.
    let text = if text.starts_with(['=', '+', '-', '@', '\t', '\r']) { format!("'{text}") } else { text.to_string() };
    if text.contains([',', '"', '\n', '\r']) { format!("\"{}\"", text.replace('"', "\"\"")) } else { text }
}

/// A leaderboard ready to serve.
#[derive(Debug)]
pub struct Rendered {
    pub board: Leaderboard,
    pub json: String,
    pub csv: String,
    /// Entity tags of the JSON and the CSV representation.
    pub etag_json: String,
    pub etag_csv: String,
}

/// Recently built leaderboards per release.
#[derive(Debug, Default)]
pub struct LeaderboardCache {
    generation: AtomicU64,
    boards: RwLock<HashMap<String, (Instant, u64, Arc<Rendered>)>>,
}

/// How long a built leaderboard is served before it is rebuilt (other replicas' writes
/// show up within this time; this process's own writes invalidate at once).
const FRESH_FOR: Duration = Duration::from_secs(1);

impl LeaderboardCache {
    /// Forget every built leaderboard (after a score or a publication).
    pub fn invalidate(&self) {
        self.generation.fetch_add(1, Ordering::SeqCst);
    }

    /// The leaderboard of `release`, rebuilt when stale.
    pub async fn get(&self, store: &Store, release: &str, lightings: &[String]) -> StoreResult<Arc<Rendered>> {
        let generation = self.generation.load(Ordering::SeqCst);
        if let Some((at, built_in, rendered)) = self.boards.read().expect("cache lock").get(release)
            && *built_in == generation
            && at.elapsed() < FRESH_FOR
        {
            return Ok(rendered.clone());
        }
        let rows = store.leaderboard_rows(release).await?;
        let board = Leaderboard::new(release, lightings.to_vec(), rows);
        let json = serde_json::to_string(&board.to_json()).expect("json");
        let csv = board.to_csv();
        use sha2::Digest;
        let tag = |text: &str| format!("\"{}\"", sha2::Sha256::digest(text.as_bytes()).iter().take(12).map(|b| format!("{b:02x}")).collect::<String>());
        let (etag_json, etag_csv) = (tag(&json), tag(&csv));
        let rendered = Arc::new(Rendered { board, json, csv, etag_json, etag_csv });
        self.boards.write().expect("cache lock").insert(release.to_string(), (Instant::now(), generation, rendered.clone()));
        Ok(rendered)
    }
}
