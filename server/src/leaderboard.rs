//! The leaderboard of a release: every scored public submission (and the baselines) with
//! its latest score, ranked by pooled mIoU under the baseline lighting. Built from the
//! store at most once per second per release and served from memory as ready JSON and
//! CSV, so reads stay cheap under load.

use osmab_evaluator::csv_writer::{CsvWriter, LineEnd, spreadsheet_safe};
use std::collections::HashMap;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Arc, Mutex, RwLock};
use std::time::{Duration, Instant};

use axum::body::Bytes;
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
                scores: summary(serde_json::from_str(&row.body).unwrap_or(Value::Null)),
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
    /// the pooled metrics of each subset, then per lighting the VQA accuracies; empty
    /// cells where a value is undefined.
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
        header.extend(crate::leaderboard_vqa::csv_columns(&self.lightings));
        let mut csv = CsvWriter::new(LineEnd::Lf);
        csv.row(&header);
        let cell = |v: Option<f64>| v.map(|x| x.to_string()).unwrap_or_default();
        for (rank, e) in self.entries.iter().enumerate() {
            let mut row = vec![
                (rank + 1).to_string(),
                e.submission_id.clone(),
                spreadsheet_safe(&e.team).into_owned(),
                spreadsheet_safe(&e.method).into_owned(),
                e.baseline.to_string(),
                e.complete.to_string(),
            ];
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
            row.extend(crate::leaderboard_vqa::csv_cells(e, &self.lightings).into_iter().map(cell));
            csv.row(row);
        }
        csv.finish()
    }
}

/// A score without its per-scene tables (`scenes` objects; scene counts stay): the
/// leaderboard carries the aggregates, a submission's own page and API the details.
fn summary(mut scores: Value) -> Value {
    fn strip(value: &mut Value) {
        if let Value::Object(map) = value {
            if map.get("scenes").is_some_and(Value::is_object) {
                map.remove("scenes");
            }
            map.values_mut().for_each(strip);
        }
    }
    strip(&mut scores);
    scores
}

/// A leaderboard ready to serve: its bytes are shared by every response.
#[derive(Debug)]
pub struct Rendered {
    pub board: Leaderboard,
    pub json: Bytes,
    pub csv: Bytes,
    /// Entity tags of the JSON and the CSV representation.
    pub etag_json: String,
    pub etag_csv: String,
    /// Leaderboard pages already rendered from this board, by their normalised view.
    pages: Mutex<HashMap<String, Bytes>>,
}

impl Rendered {
    /// The page of `view` (a normalised key of sort, aggregate and subset), rendered once.
    pub fn page(&self, view: &str, render: impl FnOnce() -> String) -> Bytes {
        if let Some(page) = self.pages.lock().expect("page cache lock").get(view) {
            return page.clone();
        }
        let page = Bytes::from(render());
        self.pages.lock().expect("page cache lock").insert(view.to_string(), page.clone());
        page
    }
}

/// Recently built leaderboards per release, and which one `current` was.
#[derive(Debug, Default)]
pub struct LeaderboardCache {
    generation: AtomicU64,
    boards: RwLock<HashMap<String, (Instant, u64, Arc<Rendered>)>>,
}

/// The cache key of the current release's board.
const CURRENT: &str = "";

/// How long a built leaderboard is served before it is rebuilt (other replicas' writes
/// show up within this time; this process's own writes invalidate at once).
const FRESH_FOR: Duration = Duration::from_secs(1);

impl LeaderboardCache {
    /// Forget every built leaderboard (after a score or a publication).
    pub fn invalidate(&self) {
        self.generation.fetch_add(1, Ordering::SeqCst);
    }

    /// The board last built for `release` (`None`: the current release) if still fresh:
    /// the hot path, which touches no database.
    pub fn fresh(&self, release: Option<&str>) -> Option<Arc<Rendered>> {
        let generation = self.generation.load(Ordering::SeqCst);
        let boards = self.boards.read().expect("cache lock");
        let (at, built_in, rendered) = boards.get(release.unwrap_or(CURRENT))?;
        (*built_in == generation && at.elapsed() < FRESH_FOR).then(|| rendered.clone())
    }

    /// Remember that the current release's board is `rendered`.
    pub fn remember_current(&self, rendered: &Arc<Rendered>, generation: u64) {
        self.boards.write().expect("cache lock").insert(CURRENT.to_string(), (Instant::now(), generation, rendered.clone()));
    }

    /// The cache generation now (read before a lookup that may be invalidated meanwhile).
    pub fn generation(&self) -> u64 {
        self.generation.load(Ordering::SeqCst)
    }

    /// The leaderboard of `release`, rebuilt when stale.
    pub async fn get(&self, store: &Store, release: &str, lightings: &[String]) -> StoreResult<Arc<Rendered>> {
        let generation = self.generation.load(Ordering::SeqCst);
        if let Some(rendered) = self.fresh(Some(release)) {
            return Ok(rendered);
        }
        let rows = store.leaderboard_rows(release).await?;
        let board = Leaderboard::new(release, lightings.to_vec(), rows);
        let json = Bytes::from(serde_json::to_string(&board.to_json()).expect("json"));
        let csv = Bytes::from(board.to_csv());
        use sha2::Digest;
        let tag = |text: &[u8]| format!("\"{}\"", sha2::Sha256::digest(text).iter().take(12).map(|b| format!("{b:02x}")).collect::<String>());
        let (etag_json, etag_csv) = (tag(&json), tag(&csv));
        let rendered = Arc::new(Rendered { board, json, csv, etag_json, etag_csv, pages: Mutex::default() });
        self.boards.write().expect("cache lock").insert(release.to_string(), (Instant::now(), generation, rendered.clone()));
        Ok(rendered)
    }
}
