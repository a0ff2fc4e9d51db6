//! Idle workers make their node ready to score the current release: one scene at a time,
//! between polls of the queue, each scene's ground truth is prepared and kept in the node's
//! cache and its box made known to validation ([`warm_scene`]). So the first submission
//! scored on a node after it starts, or after a release is published, is scored as fast as
//! every later one instead of paying for the whole release's preparation (on 2 cores, about
//! 30 s of a full release's first scoring). A job that arrives meanwhile waits at most for
//! the one scene being prepared.

use std::sync::Arc;
use std::time::Instant;

use osmab_evaluator::submission::release::ReleaseIndex;
use osmab_evaluator::submission::warm::{Warmed, warm_scene};

use super::scoring::ground_truth_cache;
use crate::state::AppState;
use crate::store::StoreError;

/// How far this node is in making the current release ready.
#[derive(Default)]
pub struct Warmup {
    /// The release being made ready, or last made ready (each is taken up once per process).
    version: Option<String>,
    /// Its index, while scenes remain.
    index: Option<Arc<ReleaseIndex>>,
    /// Scenes still to make ready, the next last.
    pending: Vec<String>,
    /// When it was taken up.
    started: Option<Instant>,
    /// How its scenes went so far.
    tally: Tally,
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
pub async fn warm_next_scene(state: &AppState) -> bool {
    let Some(cache) = ground_truth_cache(&state.settings) else { return false };
    let Ok(mut warmup) = state.warmup.try_lock() else { return false };
    if warmup.pending.is_empty() && !take_up_current_release(state, &mut warmup).await {
        return false;
    }
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
        tracing::info!(release = %version, prepared, from_cache, ready, failed, seconds, "this node is ready to score the current release");
    }
    true
}

/// Take up the current release if this process has not yet; whether it has scenes to make
/// ready.
async fn take_up_current_release(state: &AppState, warmup: &mut Warmup) -> bool {
    let current = match state.store.current_release().await {
        Ok(current) => current,
        Err(StoreError::NotFound) => return false,
        Err(e) => {
            tracing::debug!(error = %e, "could not look up the current release");
            return false;
        }
    };
    if warmup.version.as_deref() == Some(current.version.as_str()) {
        return false;
    }
    warmup.version = Some(current.version.clone());
    let dir = match state.blobs.release(&current.version).await {
        Ok(Some(dir)) => dir,
        Ok(None) => return false,
        Err(e) => {
            tracing::warn!(release = %current.version, error = %e, "could not fetch the current release to prepare its ground truth");
            return false;
        }
    };
    let index = match tokio::task::spawn_blocking(move || ReleaseIndex::read(&dir)).await {
        Ok(Ok(index)) if index.has_ground_truth() => index,
        Ok(Ok(_)) => return false,
        Ok(Err(e)) => {
            tracing::warn!(release = %current.version, error = %e, "could not read the current release to prepare its ground truth");
            return false;
        }
        Err(_) => return false,
    };
    tracing::info!(release = %current.version, scenes = index.scenes.len(), "preparing the current release's ground truth while idle");
    warmup.pending = index.scenes.iter().rev().map(|s| s.id.clone()).collect();
    warmup.index = Some(Arc::new(index));
    warmup.started = Some(Instant::now());
    warmup.tally = Tally::default();
    !warmup.pending.is_empty()
}
