//! Idle workers make their node ready to score the current release: one scene at a time,
//! between polls of the queue, each scene's ground truth is prepared and kept in the node's
//! cache and its box made known to validation ([`warm_scene`]). So the first submission
//! scored on a node after it starts, or after a release is published, is scored as fast as
//! every later one instead of paying for the whole release's preparation (on 2 cores, about
//! 20 s of a full release's first scoring). A job that arrives meanwhile waits at most for
//! the one scene being prepared: fetching the release (from an object store, gigabytes)
//! and reading its index run as a task of their own, not in the worker's loop.

use std::sync::Arc;
use std::time::{Duration, Instant};

use osmab_evaluator::submission::release::ReleaseIndex;
use osmab_evaluator::submission::warm::{Warmed, warm_scene};
use tokio::task::JoinHandle;

use super::scoring::ground_truth_cache;
use crate::state::AppState;
use crate::store::StoreError;

/// How often the current release is looked up while idle.
const LOOK_UP_EVERY: Duration = Duration::from_secs(2);
/// How long after a failure to fetch or read a release it is tried again.
const RETRY_AFTER: Duration = Duration::from_secs(60);

/// How far this node is in making the current release ready.
#[derive(Default)]
pub struct Warmup {
    /// When the current release was last looked up.
    looked_up: Option<Instant>,
    /// The release being made ready, or last made ready.
    version: Option<String>,
    /// Its index, while scenes remain.
    index: Option<Arc<ReleaseIndex>>,
    /// Scenes still to make ready, the next last.
    pending: Vec<String>,
    /// When it was taken up.
    started: Option<Instant>,
    /// How its scenes went so far.
    tally: Tally,
    /// A release being fetched and read, by a task of its own.
    fetching: Option<(String, JoinHandle<Result<ReleaseIndex, String>>)>,
    /// A release that could not be fetched or read, and when to try it again.
    failed: Option<(String, Instant)>,
}

/// Scenes of a release by how making them ready went.
#[derive(Default, Clone, Copy)]
struct Tally {
    prepared: usize,
    from_cache: usize,
    ready: usize,
    failed: usize,
}

/// Make one more scene of the current release ready if any is left; whether this did any
/// work (then the caller looks for a job again at once instead of sleeping). Only one
/// worker of a process does this at a time, and none when the cache is turned off.
pub async fn warm_next_scene(state: &AppState, warmup: &tokio::sync::Mutex<Warmup>) -> bool {
    let Some(cache) = ground_truth_cache(&state.settings) else { return false };
    let Ok(mut warmup) = warmup.try_lock() else { return false };
    follow_the_current_release(state, &mut warmup).await;
    let (Some(scene), Some(index)) = (warmup.pending.pop(), warmup.index.clone()) else { return false };
    let warmed = tokio::task::spawn_blocking({
        let scene = scene.clone();
        move || warm_scene(&index, &scene, &cache)
    })
    .await;
    let version = warmup.version.clone().unwrap_or_default();
    let tally = &mut warmup.tally;
    match warmed {
        Ok(Ok(Warmed::Prepared)) => tally.prepared += 1,
        Ok(Ok(Warmed::FromCache)) => tally.from_cache += 1,
        Ok(Ok(Warmed::AlreadyReady)) => tally.ready += 1,
        Ok(Ok(Warmed::NotKept(why))) => {
            tracing::warn!(release = %version, %scene, %why, "prepared the scene's ground truth but could not keep it");
            tally.failed += 1;
        }
        Ok(Err(e)) => {
            tracing::warn!(release = %version, %scene, error = %e, "could not prepare the scene's ground truth; its first scoring will");
            tally.failed += 1;
        }
        Err(e) => {
            tracing::warn!(release = %version, %scene, error = %e, "preparing the scene's ground truth stopped");
            tally.failed += 1;
        }
    }
    if warmup.pending.is_empty() {
        warmup.index = None;
        let Tally { prepared, from_cache, ready, failed } = warmup.tally;
        let seconds = warmup.started.map_or(0.0, |t| t.elapsed().as_secs_f64());
        if failed == 0 {
            tracing::info!(release = %version, prepared, from_cache, ready, seconds, "this node is ready to score the current release");
        } else {
            tracing::warn!(release = %version, prepared, from_cache, ready, failed, seconds, "this node made only part of the current release ready");
        }
    }
    true
}

/// Look up the current release (at most every [`LOOK_UP_EVERY`]); when it is not the one
/// being made ready, drop what is left of that one and start fetching the new one, and
/// take up a fetched one.
async fn follow_the_current_release(state: &AppState, warmup: &mut Warmup) {
    if let Some((version, fetch)) = warmup.fetching.take_if(|(_, fetch)| fetch.is_finished()) {
        match fetch.await {
            Ok(Ok(index)) => take_up(warmup, version, index),
            Ok(Err(why)) => fail(warmup, version, &why),
            Err(e) => fail(warmup, version, &format!("fetching it stopped: {e}")),
        }
    }
    if warmup.looked_up.is_some_and(|at| at.elapsed() < LOOK_UP_EVERY) {
        return;
    }
    warmup.looked_up = Some(Instant::now());
    let current = match state.store.current_release().await {
        Ok(current) => current.version,
        Err(StoreError::NotFound) => return,
        Err(e) => {
            tracing::debug!(error = %e, "could not look up the current release");
            return;
        }
    };
    let known = [warmup.version.as_ref(), warmup.fetching.as_ref().map(|(v, _)| v)];
    let retry_later = warmup.failed.as_ref().is_some_and(|(v, at)| *v == current && at.elapsed() < RETRY_AFTER);
    if known.contains(&Some(&current)) || retry_later {
        return;
    }
    if let Some((version, fetch)) = warmup.fetching.take() {
        fetch.abort();
        tracing::info!(release = %version, "no longer fetching the release to prepare its ground truth: another one is current");
    }
    let (blobs, version) = (state.blobs.clone(), current.clone());
    let fetch = tokio::spawn(async move {
        let dir = match blobs.release(&version).await {
            Ok(Some(dir)) => dir,
            Ok(None) => return Err("it is not in the blob store".to_string()),
            Err(e) => return Err(format!("fetching it: {e}")),
        };
        match tokio::task::spawn_blocking(move || ReleaseIndex::read(&dir)).await {
            Ok(Ok(index)) => Ok(index),
            Ok(Err(e)) => Err(format!("reading it: {e}")),
            Err(e) => Err(format!("reading it stopped: {e}")),
        }
    });
    warmup.fetching = Some((current, fetch));
}

/// Make `index`'s scenes the ones left to make ready, in the manifest's order, dropping
/// what was left of the release before.
fn take_up(warmup: &mut Warmup, version: String, index: ReleaseIndex) {
    if !warmup.pending.is_empty() {
        tracing::info!(release = ?warmup.version, left = warmup.pending.len(), "stopped preparing the ground truth of a release that is no longer current");
    }
    warmup.failed = None;
    if !index.has_ground_truth() {
        tracing::info!(release = %version, "the current release has no ground truth on this node: nothing to prepare");
        (warmup.version, warmup.index, warmup.pending) = (Some(version), None, Vec::new());
        return;
    }
    tracing::info!(release = %version, scenes = index.scenes.len(), "preparing the current release's ground truth while idle");
    warmup.pending = index.scenes.iter().rev().map(|s| s.id.clone()).collect();
    warmup.index = Some(Arc::new(index));
    warmup.version = Some(version);
    warmup.started = Some(Instant::now());
    warmup.tally = Tally::default();
}

fn fail(warmup: &mut Warmup, version: String, why: &str) {
    tracing::warn!(release = %version, %why, retry_secs = RETRY_AFTER.as_secs(), "could not fetch the current release to prepare its ground truth");
    warmup.failed = Some((version, Instant::now()));
}
