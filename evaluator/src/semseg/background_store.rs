//! Keeping prepared ground truth in a [`PreparedCache`] on a thread of its own, so the
//! scorer goes on to the scene's maps while the entry is written. Writing a full release's
//! entries is mostly waiting for the disk (4 GB); done in line, the first scoring on a node
//! waited for all of it.

use std::sync::Arc;
use std::sync::mpsc::{SyncSender, sync_channel};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

use super::PreparedGroundTruth;
use super::prepared_cache::{CacheKey, CacheMiss, PreparedCache};

/// What the writing thread did.
#[derive(Debug, Default, Clone, PartialEq)]
pub struct StoreReport {
    /// Entries written.
    pub stored: usize,
    /// Time spent writing them (beside the scoring, not added to it).
    pub writing: Duration,
    /// Why an entry was not kept, one line an entry, naming its ground truth.
    pub misses: Vec<String>,
}

/// A thread storing entries in a cache, one at a time. [`BackgroundStore::keep`] hands it
/// an entry and waits only while it is still writing the one before, so at most one entry
/// beyond the scorer's own is held; [`BackgroundStore::finish`] waits for the last.
pub struct BackgroundStore {
    /// The cache the entries go to.
    cache: PreparedCache,
    sender: Option<SyncSender<(CacheKey, Arc<PreparedGroundTruth>)>>,
    writer: Result<Option<JoinHandle<StoreReport>>, String>,
}

impl BackgroundStore {
    /// Start the thread storing into `cache`.
    pub fn start(cache: PreparedCache) -> Self {
        // A rendezvous: the hand-over waits until the thread is free to take the entry.
        let (sender, entries) = sync_channel::<(CacheKey, Arc<PreparedGroundTruth>)>(0);
        let writer = std::thread::Builder::new()
            .name("osmab-cache-store".into())
            .spawn({
                let cache = cache.clone();
                move || {
                    let mut report = StoreReport::default();
                    for (key, prepared) in entries {
                        let clock = Instant::now();
                        match cache.store(&key, &prepared) {
                            Ok(()) => report.stored += 1,
                            Err(CacheMiss(why)) => report.misses.push(format!("{}: not kept: {why}", prepared.source().display())),
                        }
                        report.writing += clock.elapsed();
                    }
                    report
                }
            })
            .map(Some)
            .map_err(|e| format!("could not start the thread keeping prepared ground truth: {e}"));
        Self { cache, sender: writer.is_ok().then_some(sender), writer }
    }

    /// The cache the entries go to (to load from it, too).
    pub fn cache(&self) -> &PreparedCache {
        &self.cache
    }

    /// Store `prepared` under `key` once the entry before it is written. A store that
    /// could not start its thread keeps nothing (a cache only ever saves time) and says so
    /// in its report.
    pub fn keep(&self, key: CacheKey, prepared: Arc<PreparedGroundTruth>) {
        if let Some(sender) = &self.sender {
            let _ = sender.send((key, prepared));
        }
    }

    /// Wait for every entry handed over to be written.
    pub fn finish(mut self) -> StoreReport {
        self.wait()
    }

    fn wait(&mut self) -> StoreReport {
        drop(self.sender.take());
        let failed = |why: String| StoreReport { misses: vec![why], ..StoreReport::default() };
        match self.writer.as_mut().map(Option::take) {
            Ok(Some(writer)) => writer.join().unwrap_or_else(|panic| {
                let what = panic.downcast_ref::<&str>().map(|s| s.to_string()).or_else(|| panic.downcast_ref::<String>().cloned()).unwrap_or_default();
                failed(format!("the thread keeping prepared ground truth stopped: {what}"))
            }),
            Ok(None) => StoreReport::default(),
            Err(why) => failed(std::mem::take(why)),
        }
    }
}

impl Drop for BackgroundStore {
    /// A scoring that stops early still leaves no thread writing behind it.
    fn drop(&mut self) {
        self.wait();
    }
}
