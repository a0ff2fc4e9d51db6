//! Memory a scorer keeps from one map to the next, and from one scene to the next.
//!
//! Scoring a submission builds an index and an answer array for every map (about 60 bytes
//! a map point and 4 bytes a ground-truth point) and reads a prepared cloud for every scene
//! (20 bytes a point). Made fresh each time, their pages are faulted in and zeroed by the
//! kernel and handed back after; on the 2-vCPU virtual machines this project is measured on,
//! that took about a tenth of a warm submission (docs/performance.md, "Memory kept from map
//! to map"). Reused, the same pages are only written.

use super::nearest::NearestIndex;

/// What [`super::score_prepared_reusing`] keeps for the next map: the last map's index,
/// rebuilt in place, and the answer array.
#[derive(Default)]
pub struct Scratch {
    pub(super) index: Option<NearestIndex>,
    pub(super) answers: Vec<u32>,
}
