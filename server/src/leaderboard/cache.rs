//! Built leaderboards in memory. A read of the current release's board touches no
//! database while the board is fresh (at most one second old and built since the last
//! invalidation); otherwise the board is rebuilt from the store, by one request at a
//! time: the others wait for that board instead of all querying the database at once
//! (with PostgreSQL's small pool a herd of rebuilds cost 5× the throughput). This
//! process's own writes invalidate at once; other replicas' writes show within a second.

use std::collections::HashMap;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Arc, Mutex, RwLock};
use std::time::{Duration, Instant};

use axum::body::Bytes;
use osmab_evaluator::scores::Split;
use sha2::Digest;

use super::Leaderboard;
use crate::store::{ReleaseState, Store, StoreError};

/// A leaderboard ready to serve: its bytes are shared by every response.
#[derive(Debug)]
pub struct Rendered {
    pub board: Leaderboard,
    pub json: Bytes,
    pub csv: Bytes,
    /// Entity tags of the JSON and the CSV representation.
    pub etag_json: String,
    pub etag_csv: String,
    /// Every published release's version, newest first, and whether it is the current one:
    /// the board page's release switcher (read with the board, so it is as fresh).
    pub published: Vec<(String, bool)>,
    /// Leaderboard pages already rendered from this board, by their normalised view.
    pages: Mutex<HashMap<String, Bytes>>,
}

impl Rendered {
    fn new(board: Leaderboard, published: Vec<(String, bool)>) -> Self {
        let json = Bytes::from(serde_json::to_string(&board).expect("a leaderboard serialises"));
        let csv = Bytes::from(super::csv::to_csv(&board));
        let tag = |text: &[u8]| format!("\"{}\"", sha2::Sha256::digest(text).iter().take(12).map(|b| format!("{b:02x}")).collect::<String>());
        let (etag_json, etag_csv) = (tag(&json), tag(&csv));
        Self { board, json, csv, etag_json, etag_csv, published, pages: Mutex::default() }
    }

    /// The page of `view` (a normalised key of sort, aggregate and subset), rendered once.
    /// The page of `view`, when it was rendered already.
    pub fn cached_page(&self, view: &str) -> Option<Bytes> {
        self.pages.lock().expect("page cache lock").get(view).cloned()
    }

    pub fn page(&self, view: &str, render: impl FnOnce() -> String) -> Bytes {
        if let Some(page) = self.pages.lock().expect("page cache lock").get(view) {
            return page.clone();
        }
        let page = Bytes::from(render());
        self.pages.lock().expect("page cache lock").insert(view.to_string(), page.clone());
        page
    }
}

/// Why there is no board to show.
#[derive(Debug, thiserror::Error)]
pub enum BoardError {
    /// The release named does not exist or is not published (`None`: no current release).
    #[error("no published release")]
    NotPublished(Option<String>),
    /// The release (its version) has no scene in the split asked for (it has these).
    #[error("no such split")]
    NoSplit(String, Split, Vec<Split>),
    #[error(transparent)]
    Store(#[from] StoreError),
}

/// Recently built leaderboards per release, and which one the current release's was.
#[derive(Debug, Default)]
pub struct LeaderboardCache {
    generation: AtomicU64,
    boards: RwLock<HashMap<String, (Instant, u64, Arc<Rendered>)>>,
    /// Held while a board is rebuilt.
    rebuilding: tokio::sync::Mutex<()>,
}

/// The cache key of the current release's board.
const CURRENT: &str = "";

/// How long a built leaderboard is served before it is rebuilt.
const FRESH_FOR: Duration = Duration::from_secs(1);

impl LeaderboardCache {
    /// Forget every built leaderboard (after a score or a publication).
    pub fn invalidate(&self) {
        self.generation.fetch_add(1, Ordering::SeqCst);
    }

    /// The board last built under `key` if still fresh.
    fn fresh(&self, key: &str) -> Option<Arc<Rendered>> {
        let generation = self.generation.load(Ordering::SeqCst);
        let boards = self.boards.read().expect("cache lock");
        let (at, built_in, rendered) = boards.get(key)?;
        (*built_in == generation && at.elapsed() < FRESH_FOR).then(|| rendered.clone())
    }

    fn remember(&self, key: &str, rendered: &Arc<Rendered>, generation: u64) {
        self.boards.write().expect("cache lock").insert(key.to_string(), (Instant::now(), generation, rendered.clone()));
    }

    /// The leaderboard of `split` (`None`: the release's primary split) of the published
    /// `release` (`None`: the current release), from memory while fresh, else rebuilt
    /// from `store`.
    pub async fn board(&self, store: &Store, release: Option<&str>, split: Option<Split>) -> Result<Arc<Rendered>, BoardError> {
        let key = format!("{}#{}", release.unwrap_or(CURRENT), split.map_or("", Split::name));
        let key = key.as_str();
        if let Some(rendered) = self.fresh(key) {
            return Ok(rendered);
        }
        let _rebuilding = self.rebuilding.lock().await;
        if let Some(rendered) = self.fresh(key) {
            return Ok(rendered);
        }
        // Read before the store, so a write meanwhile leaves this board stale.
        let generation = self.generation.load(Ordering::SeqCst);
        let record = match release {
            Some(version) => store.release(version).await,
            None => store.current_release().await,
        };
        let record = match record {
            Ok(r) if r.state == ReleaseState::Published => r,
            Ok(_) | Err(StoreError::NotFound) => return Err(BoardError::NotPublished(release.map(str::to_string))),
            Err(e) => return Err(e.into()),
        };
        let manifest = crate::releases::served_manifest(&record);
        let splits = manifest.splits();
        let split = split.unwrap_or_else(|| manifest.primary_split());
        if !splits.contains(&split) {
            return Err(BoardError::NoSplit(record.version, split, splits));
        }
        let resolved = format!("{}#{split}", record.version);
        if let Some(rendered) = self.fresh(&resolved) {
            self.remember(key, &rendered, generation);
            return Ok(rendered);
        }
        let rows = store.leaderboard_rows(&record.version).await?;
        let published = store.published_versions().await?;
        let board = super::rank(&record.version, manifest.score_lightings(), split, splits, rows);
        let rendered = Arc::new(Rendered::new(board, published));
        self.remember(&resolved, &rendered, generation);
        self.remember(key, &rendered, generation);
        Ok(rendered)
    }
}
