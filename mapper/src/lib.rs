//! The reference mapper: a complete semantic mapping method that uses only what a team
//! downloads — colour and depth frames, camera poses and intrinsics, the class list and,
//! to learn from, the val split's semantic frames. It never reads a scene's ground truth,
//! prompt or questions, nor any test scene's semantics.
//!
//! - [`learn`]: two random forests classify image regions ([`regions`]), one by what their
//!   pixels show and the geometry their depth gives ([`features`]), one by the geometry
//!   alone, their trees voting together; trained on the val split's frames under baseline
//!   lighting.
//! - [`voxels`]: every used frame's regions get the trees' votes, their pixels are lifted
//!   with depth and pose into a voxel map that sums the votes per voxel, and objects are
//!   cut as connected voxels of one class.
//! - [`submission`]: the maps and scene graphs in the submission format, for every scene
//!   and lighting.

pub mod features;
pub mod frame;
pub mod learn;
pub mod public;
pub mod regions;
pub mod submission;
pub mod voxels;

pub use features::FeatureSet;
pub use submission::{Perceived, perceive};

/// The class with the most votes, ties to the lowest id; 0 ("other") when nobody voted.
/// (A region's class from its blocks, the forest's from its trees, a voxel's from its points.)
pub fn majority<K: Copy + Ord + Into<u32>>(votes: &std::collections::BTreeMap<K, u32>) -> u32 {
    votes.iter().max_by_key(|(c, n)| (**n, std::cmp::Reverse(**c))).map_or(0, |(c, _)| (*c).into())
}

/// Every how many frames of a sequence the mapper looks at (the ground truth uses every 5th).
pub const FRAME_STRIDE: usize = 10;
