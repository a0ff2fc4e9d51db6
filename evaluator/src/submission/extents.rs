//! The boxes of the release's ground-truth clouds, which validation places each map
//! against. A release's clouds are hundreds of megabytes and the same scenes are checked
//! for every upload and again when scored, so only each box is kept, for the life of the
//! process, per file as it is now (its path, length and modification time).

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::sync::{Mutex, OnceLock};
use std::time::SystemTime;

use super::release::ReleaseIndex;
use crate::formats::pcd::read_pcd;

/// The lowest and highest coordinates of a cloud.
pub type Extent = ([f32; 3], [f32; 3]);

/// A file as it is now.
type Identity = (PathBuf, u64, Option<SystemTime>);

fn known() -> &'static Mutex<BTreeMap<Identity, Extent>> {
    static KNOWN: OnceLock<Mutex<BTreeMap<Identity, Extent>>> = OnceLock::new();
    KNOWN.get_or_init(Default::default)
}

fn identity(path: &Path) -> Option<Identity> {
    let meta = std::fs::metadata(path).ok()?;
    Some((path.to_path_buf(), meta.len(), meta.modified().ok()))
}

fn cloud_of(release: &ReleaseIndex, scene: &str) -> PathBuf {
    release.ground_truth_dir(scene).join("pointcloud.pcd")
}

/// The box of `scene`'s ground-truth points, from its `pointcloud.pcd` (labels are not
/// needed to place a map), read only when this process does not know it yet; `None` when
/// the cloud cannot be read or is empty.
pub fn ground_truth_extent(release: &ReleaseIndex, scene: &str) -> Option<Extent> {
    let path = cloud_of(release, scene);
    let identity = identity(&path)?;
    if let Some(extent) = known().lock().unwrap_or_else(|e| e.into_inner()).get(&identity) {
        return Some(*extent);
    }
    let cloud = read_pcd(&path).ok()?;
    if cloud.points.is_empty() {
        return None;
    }
    let extent = crate::bounds::bounding_box(&cloud.points);
    known().lock().unwrap_or_else(|e| e.into_inner()).insert(identity, extent);
    Some(extent)
}

/// Whether this process knows the box of `scene`'s cloud as the file is now.
pub fn is_known(release: &ReleaseIndex, scene: &str) -> bool {
    identity(&cloud_of(release, scene)).is_some_and(|identity| known().lock().unwrap_or_else(|e| e.into_inner()).contains_key(&identity))
}

/// Remember the box of `scene`'s cloud from `points`, the points of that cloud as the file
/// is now (in any order), so validation need not read it.
pub(crate) fn remember(release: &ReleaseIndex, scene: &str, points: &[[f32; 3]]) {
    if let (Some(identity), false) = (identity(&cloud_of(release, scene)), points.is_empty()) {
        known().lock().unwrap_or_else(|e| e.into_inner()).insert(identity, crate::bounds::bounding_box(points));
    }
}
