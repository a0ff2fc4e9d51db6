//! Making a node ready to score a release at full speed before any submission asks: each
//! scene's ground truth read, checked, put in Z-order and kept in the node's cache, and
//! its box known to validation. Without this the first submission scored on a node pays
//! for all of it (a full release: reading 40 clouds twice, ordering 256 M points and
//! writing 4 GB); workers do it while they have nothing else to do.

use super::extents;
use super::release::ReleaseIndex;
use crate::error::{InputError, Result};
use crate::ground_truth::GroundTruth;
use crate::semseg::PreparedGroundTruth;
use crate::semseg::prepared_cache::{CacheKey, CacheMiss, PreparedCache};

/// What making a scene ready took.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Warmed {
    /// Nothing: the cache held the scene's entry (whole in length; a damaged payload is
    /// found by the CRC when a scoring loads it, and prepared again then) and its box was
    /// known.
    AlreadyReady,
    /// The cache held the entry; it was read back for the box.
    FromCache,
    /// The ground truth was read and prepared, and kept in the cache.
    Prepared,
    /// Prepared, but not kept (the cache's reason): the first scoring prepares it again.
    NotKept(String),
}

/// Make `scene` of `release` ready to be scored on this node with `cache`.
pub fn warm_scene(release: &ReleaseIndex, scene: &str, cache: &PreparedCache) -> Result<Warmed> {
    let dir = release.ground_truth_dir(scene);
    let classes = release.scene_classes(scene)?;
    let Some(key) = CacheKey::of(&dir) else {
        // The read says which file is missing or unreadable.
        GroundTruth::read(&dir, &classes)?;
        return Err(InputError::new(&dir, "ground_truth", "the ground-truth files could not be looked at"));
    };
    if cache.holds(&key) {
        if extents::is_known(release, scene) {
            return Ok(Warmed::AlreadyReady);
        }
        if let Ok(prepared) = cache.load(&key, &dir, &classes) {
            extents::remember(release, scene, prepared.points());
            return Ok(Warmed::FromCache);
        }
    }
    let prepared = PreparedGroundTruth::new(GroundTruth::read(&dir, &classes)?, &classes)?;
    extents::remember(release, scene, prepared.points());
    Ok(match cache.store(&key, &prepared) {
        Ok(()) => Warmed::Prepared,
        Err(CacheMiss(why)) => Warmed::NotKept(why),
    })
}

/// Make every scene of `release` ready, in the manifest's order, telling `each` how each
/// went; stops at the first scene that cannot be read.
pub fn warm_release(release: &ReleaseIndex, cache: &PreparedCache, mut each: impl FnMut(&str, &Warmed)) -> Result<()> {
    for scene in &release.scenes {
        let warmed = warm_scene(release, &scene.id, cache)?;
        each(&scene.id, &warmed);
    }
    Ok(())
}
