//! Learning what regions are, from the val split's frames under baseline lighting: each
//! region of every used frame, labelled with the class most of its blocks show, trains two
//! random forests (smartcore's CART trees, each grown on its own bootstrap sample with its
//! own seed, so the forests are the same on any number of threads) whose trees vote
//! together: one reads every feature of the set, the other the geometry alone.

use std::collections::BTreeMap;
use std::path::Path;

use osmab_evaluator::scores::{Lighting, Split};
use osmab_evaluator::submission::ReleaseIndex;
use osmab_evaluator::{InputError, Result};
use rayon::prelude::*;
use smartcore::ensemble::random_forest_classifier::{RandomForestClassifier, RandomForestClassifierParameters};
use smartcore::linalg::basic::matrix::DenseMatrix;
use smartcore::tree::decision_tree_classifier::SplitCriterion;

use crate::features::{FeatureSet, Levels, region_features};
use crate::frame::{Frame, block_side, read_frame};
use crate::public::PublicSequence;
use crate::regions::{NONE, Regions, segment};

/// Trees of each of the classifier's two forests.
pub const TREES: u64 = 32;
/// At most this many training regions of one class (frequent classes are thinned evenly,
/// so walls and floors do not drown the small objects the scores average over).
pub const PER_CLASS: usize = 1500;
const SEED: u64 = 20_261_128;

type Tree = RandomForestClassifier<f64, u32, DenseMatrix<f64>, Vec<u32>>;

/// The trained region classifier: two forests of [`TREES`] trees each, whose trees vote
/// together. The first reads every feature of the set; the second reads the geometry
/// alone (the last columns of a row), so a region whose colour no val region of its class
/// showed (a finish the val scenes never had) still gets the votes its height,
/// orientation and size earn, where trees that split on colour first would send it
/// anywhere. The geometry-only twin has two geometry forests of other seeds, so both
/// methods have as many trees.
pub struct RegionClassifier {
    whole: Vec<Tree>,
    geometry: Vec<Tree>,
    /// The features it reads.
    pub set: FeatureSet,
    /// Training regions it learned from, per class id.
    pub examples: BTreeMap<u32, usize>,
}

/// The votes of the trees for one region: how many trees name each class.
pub type Votes = BTreeMap<u32, u32>;

/// A sequence's frames read and segmented, with its levels.
pub struct SeenSequence {
    /// The frames, in order of use.
    pub frames: Vec<Frame>,
    /// Their regions.
    pub regions: Vec<Regions>,
    /// Floor and ceiling.
    pub levels: Levels,
    /// Metres a block spans at 1 m range.
    pub block_metres: f32,
}

/// Read, reduce and segment the used frames of `sequence` (with their classes, where
/// `with_classes` and the sequence is labelled).
pub fn see(sequence: &PublicSequence, with_classes: bool) -> Result<SeenSequence> {
    let frames: Vec<Frame> = sequence.used_frames().par_iter().map(|&f| read_frame(sequence, f, with_classes)).collect::<Result<_>>()?;
    let regions: Vec<Regions> = frames.par_iter().map(segment).collect();
    let levels = Levels::of(&frames);
    let block_metres = (block_side(sequence) as f64 / sequence.camera.fx) as f32;
    Ok(SeenSequence { frames, regions, levels, block_metres })
}

impl SeenSequence {
    /// Feature rows of every region of frame `k`.
    pub fn features(&self, k: usize, set: FeatureSet) -> Vec<Vec<f64>> {
        region_features(&self.frames[k], &self.regions[k], self.levels, set, self.block_metres)
    }
}

/// The class most blocks of each region of `frame` show.
fn region_classes(frame: &Frame, regions: &Regions) -> Vec<u32> {
    let Some(classes) = &frame.classes else { return vec![] };
    let mut votes: Vec<BTreeMap<u16, u32>> = vec![BTreeMap::new(); regions.count];
    for (&r, &c) in regions.of_block.iter().zip(classes) {
        if r != NONE {
            *votes[r as usize].entry(c).or_default() += 1;
        }
    }
    votes.iter().map(crate::majority).collect()
}

/// The training regions of `release`: every region of the used frames of its val scenes
/// under baseline lighting (or its first lighting), as feature rows and classes.
fn training_set(release: &Path, index: &ReleaseIndex, set: FeatureSet) -> Result<(Vec<Vec<f64>>, Vec<u32>)> {
    let lighting = index.lightings.iter().copied().find(|l| *l == Lighting::Baseline).unwrap_or(index.lightings[0]);
    let val: Vec<&str> = index.scenes.iter().filter(|s| s.split == Split::Val).map(|s| s.id.as_str()).collect();
    if val.is_empty() {
        return Err(InputError::new(release.join("manifest.json"), "scenes", "the release has no val scene to learn from"));
    }
    let (mut rows, mut classes) = (Vec::new(), Vec::new());
    for scene in val {
        let sequence = PublicSequence::open(release, lighting, scene, Split::Val)?;
        let seen = see(&sequence, true)?;
        for k in 0..seen.frames.len() {
            rows.extend(seen.features(k, set));
            classes.extend(region_classes(&seen.frames[k], &seen.regions[k]));
        }
    }
    Ok(balanced(rows, classes))
}

/// At most [`PER_CLASS`] regions of each class, taken evenly through its regions.
fn balanced(rows: Vec<Vec<f64>>, classes: Vec<u32>) -> (Vec<Vec<f64>>, Vec<u32>) {
    let mut totals: BTreeMap<u32, usize> = BTreeMap::new();
    for &c in &classes {
        *totals.entry(c).or_default() += 1;
    }
    let mut taken: BTreeMap<u32, usize> = BTreeMap::new();
    let (mut kept_rows, mut kept_classes) = (Vec::new(), Vec::new());
    for (row, c) in rows.into_iter().zip(classes) {
        let seen = taken.entry(c).or_default();
        let total = totals[&c];
        // Keep the k-th region of a class when it starts a new stride of total / PER_CLASS.
        if total <= PER_CLASS || (*seen * PER_CLASS) / total != ((*seen + 1) * PER_CLASS) / total {
            kept_rows.push(row);
            kept_classes.push(c);
        }
        *seen += 1;
    }
    (kept_rows, kept_classes)
}

fn matrix(rows: &[Vec<f64>], width: usize) -> DenseMatrix<f64> {
    let values: Vec<f64> = rows.iter().flat_map(|r| r.iter().copied()).collect();
    DenseMatrix::new(rows.len(), width, values, false).expect("rows of one width")
}

impl RegionClassifier {
    /// Learn from the val scenes of the release in `release`.
    pub fn train(release: &Path, index: &ReleaseIndex, set: FeatureSet) -> Result<Self> {
        let (rows, classes) = training_set(release, index, set)?;
        Self::fit(&rows, &classes, set).map_err(|e| InputError::new(release, "(training)", e))
    }

    /// Grow both forests on `rows` labelled `classes`.
    pub fn fit(rows: &[Vec<f64>], classes: &[u32], set: FeatureSet) -> std::result::Result<Self, String> {
        if rows.is_empty() {
            return Err("no region to learn from".into());
        }
        let (whole, geometry) = (matrix(rows, set.len()), matrix(&geometry_columns(rows, set), FeatureSet::GeometryOnly.len()));
        let y = classes.to_vec();
        let mut trees = (0..2 * TREES)
            .into_par_iter()
            .map(|t| {
                let parameters = RandomForestClassifierParameters {
                    criterion: SplitCriterion::Gini,
                    max_depth: Some(24),
                    min_samples_leaf: 1,
                    min_samples_split: 2,
                    n_trees: 1,
                    m: None,
                    keep_samples: false,
                    seed: SEED + 7919 * t,
                };
                Tree::fit(if t < TREES { &whole } else { &geometry }, &y, parameters).map_err(|e| e.to_string())
            })
            .collect::<std::result::Result<Vec<_>, _>>()?;
        let geometry = trees.split_off(TREES as usize);
        let mut examples = BTreeMap::new();
        for &c in classes {
            *examples.entry(c).or_default() += 1;
        }
        Ok(Self { whole: trees, geometry, set, examples })
    }

    /// The class of each row: the trees' majority (ties to the lowest class id).
    pub fn classify(&self, rows: &[Vec<f64>]) -> Vec<u32> {
        self.votes(rows).iter().map(crate::majority).collect()
    }

    /// The votes of every tree of both forests for each row.
    pub fn votes(&self, rows: &[Vec<f64>]) -> Vec<Votes> {
        if rows.is_empty() {
            return vec![];
        }
        let mut votes: Vec<Votes> = vec![BTreeMap::new(); rows.len()];
        let whole = matrix(rows, self.set.len());
        let geometry = matrix(&geometry_columns(rows, self.set), FeatureSet::GeometryOnly.len());
        let forests = self.whole.iter().map(|tree| (tree, &whole)).chain(self.geometry.iter().map(|tree| (tree, &geometry)));
        for (tree, x) in forests {
            let predicted = tree.predict(x).expect("a fitted tree predicts");
            for (v, c) in votes.iter_mut().zip(predicted) {
                *v.entry(c).or_default() += 1;
            }
        }
        votes
    }
}

/// The geometry features of each row of `set` (a row's last columns).
fn geometry_columns(rows: &[Vec<f64>], set: FeatureSet) -> Vec<Vec<f64>> {
    let skip = set.len() - FeatureSet::GeometryOnly.len();
    rows.iter().map(|row| row[skip..].to_vec()).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_forest_learns_separable_regions_and_is_the_same_every_time() {
        // Class 7 sits higher than class 3 in every feature, give or take a varied offset.
        let rows: Vec<Vec<f64>> = (0..200)
            .map(|i| {
                let high = if i % 2 == 1 { 1.0 } else { 0.0 };
                (0..FeatureSet::GeometryOnly.len()).map(|k| high + ((i * (k + 3)) % 11) as f64 * 0.05).collect()
            })
            .collect();
        let classes: Vec<u32> = (0..200).map(|i| if i % 2 == 1 { 7 } else { 3 }).collect();
        let forest = RegionClassifier::fit(&rows, &classes, FeatureSet::GeometryOnly).unwrap();
        assert_eq!(forest.classify(&rows), classes);
        let again = RegionClassifier::fit(&rows, &classes, FeatureSet::GeometryOnly).unwrap();
        let probe: Vec<Vec<f64>> = (0..50).map(|i| vec![i as f64 * 0.04; FeatureSet::GeometryOnly.len()]).collect();
        assert_eq!(forest.classify(&probe), again.classify(&probe));
        assert_eq!(forest.examples, BTreeMap::from([(3, 100), (7, 100)]));
    }

    #[test]
    fn a_region_of_a_colour_never_learned_keeps_the_votes_of_its_geometry() {
        // Class 3 is low and red, class 7 high and blue, in every training region: either
        // the colour or the height tells them apart.
        let set = FeatureSet::Seeing;
        let region = |red: f64, blue: f64, height: f64, i: usize| -> Vec<f64> {
            let wobble = (i % 7) as f64 * 0.01;
            let mut row = vec![0.3 + wobble; set.len()];
            (row[0], row[2]) = (red + wobble, blue + wobble);
            let geometry = set.len() - FeatureSet::GeometryOnly.len();
            row[geometry..].iter_mut().for_each(|g| *g = height + wobble);
            row
        };
        let rows: Vec<Vec<f64>> = (0..200).map(|i| if i % 2 == 0 { region(0.9, 0.1, 0.2, i) } else { region(0.1, 0.9, 1.5, i) }).collect();
        let classes: Vec<u32> = (0..200).map(|i| if i % 2 == 0 { 3 } else { 7 }).collect();
        let forest = RegionClassifier::fit(&rows, &classes, set).unwrap();
        // A low region painted blue: the trees that read colour may call it 7, but the 32
        // that read geometry alone all call it 3.
        let votes = &forest.votes(&[region(0.1, 0.9, 0.2, 0)])[0];
        assert_eq!(votes.values().sum::<u32>(), 2 * TREES as u32, "every tree of both forests votes");
        assert!(votes.get(&3).copied().unwrap_or(0) >= TREES as u32, "the geometry forest's votes: {votes:?}");
    }

    #[test]
    fn frequent_classes_are_thinned_evenly_and_rare_ones_kept() {
        let classes: Vec<u32> = (0..(PER_CLASS * 3 + 10)).map(|i| if i < 10 { 5 } else { 1 }).collect();
        let rows: Vec<Vec<f64>> = classes.iter().enumerate().map(|(i, _)| vec![i as f64]).collect();
        let (kept, kept_classes) = balanced(rows, classes);
        assert_eq!(kept_classes.iter().filter(|c| **c == 5).count(), 10);
        assert_eq!(kept_classes.iter().filter(|c| **c == 1).count(), PER_CLASS);
        assert!(kept.windows(2).all(|w| w[0][0] < w[1][0]), "order kept");
    }
}
