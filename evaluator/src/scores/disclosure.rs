//! What may be shown of a score: everything of a val submission; of a test submission, no
//! number that depends on fewer than [`MIN_TEST_SCENES`] test scenes, and no number finer
//! than the board shows it ([`SHOWN_RESOLUTION`]).
//!
//! - Per-scene rows and bootstrap replicates (from which per-scene values could be solved)
//!   are left out.
//! - A segmentation aggregate (per lighting, per subset) is shown where it pools at least
//!   [`MIN_TEST_SCENES`] of the submission's scenes; VQA is shown pooled over every lighting
//!   only — a cell per lighting would let one submission try a different answer set under
//!   each lighting and learn which is right.
//! - **Partitions are shown whole or not at all.** The subsets of a lighting, the groups
//!   of a question set and its categories each split a shown whole into parts; showing the
//!   parts that qualify beside the whole would let a reader subtract them and read the
//!   withheld part (PromptGT overall minus Relations gave Measurements). So the parts of a
//!   partition are shown only when every part qualifies — for the groups, which leave some
//!   categories out, the left-out remainder included.
//! - **Every fraction is rounded to the board's 0.1 %.** All four lightings share one
//!   ground truth per scene, so a submission whose maps differ between two lightings in one
//!   scene only makes the difference of the two lightings' numbers that scene's alone. At
//!   full precision that difference told a scene's class fractions to 15 digits; rounded,
//!   any difference of shown numbers is known to ±[`SHOWN_RESOLUTION`], and a scene's own
//!   quantity, which enters a pooled number scaled down by the pool, is known no finer. The
//!   relative change is recomputed from the rounded values, so it says nothing more.
//!
//! Applied where scores leave the service (its API, pages, exports, receipts), so it also
//! covers every score stored before the rule existed; ranks are made from the shown values.

use serde::{Deserialize, Serialize};

use std::collections::{BTreeMap, BTreeSet};

use super::{Accuracy, QuestionSet, QuestionSetScores, Scores, SetsScores, Split, VqaCell};
use crate::semseg::report::{MetricIntervals, MetricTriple};

/// The fewest test scenes a shown number of a test submission may depend on.
pub const MIN_TEST_SCENES: usize = 5;

/// The resolution of a shown fraction of a test submission: 0.001, the board's 0.1 %.
pub const SHOWN_RESOLUTION: f64 = 1.0 / STEPS_PER_UNIT;
/// Shown fractions are whole multiples of 1/1000 (divided, not multiplied, so 0.412 is
/// the double nearest 0.412 and serialises as such).
const STEPS_PER_UNIT: f64 = 1000.0;

/// What a shown score leaves out, and why.
#[derive(Debug, Clone, PartialEq, Eq, Default, Serialize, Deserialize, schemars::JsonSchema)]
pub struct Withheld {
    /// Numbers that would depend on fewer test scenes than this are not shown.
    pub min_scenes: usize,
    /// What was left out, in words.
    pub note: String,
}

/// `value` to the nearest multiple of [`SHOWN_RESOLUTION`] (undefined stays undefined), the
/// step chosen as the pages write the value (`{:.1}` of its percent, which rounds the exact
/// double): `value * 1000` could itself round a value just short of a half step onto it, and
/// the API would then say −28.8 % where the board writes −28.7 %.
pub fn rounded(value: f64) -> f64 {
    if !value.is_finite() {
        return value;
    }
    let percent: f64 = format!("{:.1}", 100.0 * value).parse().expect("a formatted finite float parses");
    // `+ 0.0` turns a rounded -0.0 into 0.0.
    (percent * 10.0).round() / STEPS_PER_UNIT + 0.0
}

fn rounded_pair(pair: [f64; 2]) -> [f64; 2] {
    pair.map(rounded)
}

fn round_triple(triple: &mut MetricTriple) {
    for value in [&mut triple.miou, &mut triple.fmiou, &mut triple.macc] {
        *value = rounded(*value);
    }
    if let Some(MetricIntervals { fmiou, macc, miou }) = &mut triple.ci95 {
        for interval in [fmiou, macc, miou].into_iter().flatten() {
            *interval = rounded_pair(*interval);
        }
    }
}

fn round_accuracy(accuracy: &mut Accuracy) {
    accuracy.accuracy = accuracy.accuracy.map(rounded);
    accuracy.ci95 = accuracy.ci95.map(rounded_pair);
}

/// An accuracy of fewer than `min` scenes is shown as none; a shown one is rounded.
fn keep_accuracy(accuracy: &mut Accuracy, min: usize) {
    if accuracy.scenes < min {
        *accuracy = Accuracy::default();
    }
    round_accuracy(accuracy);
}

/// The parts of a partition, all of them when every part pools `min` scenes, else none.
fn keep_partition<K: Ord, V>(parts: &mut BTreeMap<K, V>, scenes: impl Fn(&V) -> usize, min: usize) {
    if parts.values().any(|part| scenes(part) < min) {
        parts.clear();
    }
}

fn keep_set(set: &mut QuestionSetScores, min: usize) {
    // The groups leave some categories out: the set's overall minus its groups is those
    // categories' accuracy, shown only where one of them alone pools `min` scenes (their
    // union then pools at least as many).
    let ungrouped = set.categories.iter().filter(|(category, _)| super::QuestionGroup::of_category(category).is_none()).map(|(_, a)| a.scenes).max();
    if ungrouped.is_some_and(|scenes| scenes < min) {
        set.groups.clear();
    }
    keep_partition(&mut set.categories, |a| a.scenes, min);
    keep_partition(&mut set.groups, |a| a.scenes, min);
    set.categories.values_mut().chain(set.groups.values_mut()).for_each(round_accuracy);
    keep_accuracy(&mut set.overall, min);
}

/// Whether `accuracy` has questions but pools fewer than `min` scenes.
fn withheld(accuracy: &Accuracy, min: usize) -> bool {
    accuracy.total > 0 && accuracy.scenes < min
}

/// The two question sets split their overall: both shown, or neither (the overall minus one
/// would be the other).
fn keep_sets(overall: &mut Accuracy, prompt_grounded: &mut QuestionSetScores, standard: &mut QuestionSetScores, min: usize) {
    keep_accuracy(overall, min);
    if [&*prompt_grounded, &*standard].iter().any(|set| withheld(&set.overall, min)) {
        *prompt_grounded = QuestionSetScores::default();
        *standard = QuestionSetScores::default();
    }
    keep_set(prompt_grounded, min);
    keep_set(standard, min);
}

fn keep_cell(cell: &mut VqaCell, min: usize) {
    keep_sets(&mut cell.overall, &mut cell.prompt_grounded, &mut cell.standard, min);
    keep_partition(&mut cell.subsets, |s| s.overall.scenes, min);
    for subset in cell.subsets.values_mut() {
        keep_sets(&mut subset.overall, &mut subset.prompt_grounded, &mut subset.standard, min);
    }
    // The subsets split the whole too: a number shown for one subset but withheld for
    // another would be the whole's minus the shown one. Each subset shows only what all do.
    for set in [QuestionSet::PromptGrounded, QuestionSet::Standard] {
        let everywhere = cell.subsets.values().all(|s| !withheld(&set_of(s, set).overall, min));
        let groups = common_keys(cell.subsets.values().map(|s| &set_of(s, set).groups));
        let categories = common_keys(cell.subsets.values().map(|s| &set_of(s, set).categories));
        for subset in cell.subsets.values_mut() {
            let shown = match set {
                QuestionSet::PromptGrounded => &mut subset.prompt_grounded,
                QuestionSet::Standard => &mut subset.standard,
            };
            if !everywhere {
                *shown = QuestionSetScores::default();
            }
            shown.groups.retain(|group, _| groups.contains(group));
            shown.categories.retain(|category, _| categories.contains(category));
        }
    }
}

/// The question set `set` of `scores`.
fn set_of(scores: &SetsScores, set: QuestionSet) -> &QuestionSetScores {
    match set {
        QuestionSet::PromptGrounded => &scores.prompt_grounded,
        QuestionSet::Standard => &scores.standard,
    }
}

/// The keys every one of `maps` has.
fn common_keys<'a, K: Ord + Clone + 'a, V: 'a>(mut maps: impl Iterator<Item = &'a BTreeMap<K, V>>) -> BTreeSet<K> {
    let first: BTreeSet<K> = maps.next().map(|m| m.keys().cloned().collect()).unwrap_or_default();
    maps.fold(first, |common, map| common.into_iter().filter(|k| map.contains_key(k)).collect())
}

impl Scores {
    /// This document as it may be shown (see the module's header): unchanged for val.
    pub fn disclosed(&self) -> Scores {
        if self.split != Some(Split::Test) {
            return self.clone();
        }
        let min = MIN_TEST_SCENES;
        let mut shown = self.clone();
        shown.semseg.retain(|_, lighting| lighting.scenes.len() >= min);
        for lighting in shown.semseg.values_mut() {
            lighting.pooled = Some(lighting.scenes.len());
            lighting.scenes.clear();
            lighting.bootstrap_miou.clear();
            keep_partition(&mut lighting.subsets, |subset| subset.scenes, min);
            round_triple(&mut lighting.overall);
            round_triple(&mut lighting.overall_mean);
            for subset in lighting.subsets.values_mut() {
                round_triple(&mut subset.overall);
                round_triple(&mut subset.overall_mean);
            }
        }
        shown.relative_change = shown_relative_change(&shown);
        if let Some(vqa) = &mut shown.vqa {
            vqa.scenes.clear();
            vqa.lightings.clear();
            keep_cell(&mut vqa.all_lightings, min);
        }
        if shown.vqa.as_ref().is_some_and(|v| v.all_lightings.overall.scenes < min) {
            shown.vqa = None;
        }
        shown.withheld = Some(Withheld {
            min_scenes: min,
            note: format!(
                "A test submission's scores show no number that depends on fewer than {min} test scenes, and every fraction to 0.1 %: no per-scene rows, \
                 segmentation per lighting where {min} or more scenes are pooled, VQA pooled over all lightings, and subsets, question groups and \
                 categories only where every one of them pools {min} or more scenes (a part beside its whole could be subtracted from it). \
                 Val submissions show everything."
            ),
        });
        shown
    }
}

/// The relative change of each shown lighting against the shown baseline, made from the
/// rounded values (so it tells nothing they do not) and rounded.
fn shown_relative_change(shown: &Scores) -> BTreeMap<super::Lighting, super::RelativeChange> {
    let Some(baseline) = shown.semseg.get(&super::Lighting::BASELINE) else {
        return Default::default();
    };
    shown
        .semseg
        .iter()
        .filter(|(lighting, _)| shown.relative_change.contains_key(lighting))
        .map(|(lighting, scores)| {
            let mut change = super::RelativeChange {
                overall: scores.overall.relative_change(&baseline.overall),
                overall_mean: scores.overall_mean.relative_change(&baseline.overall_mean),
            };
            round_triple(&mut change.overall);
            round_triple(&mut change.overall_mean);
            (*lighting, change)
        })
        .collect()
}
