//! What may be shown of a score: everything of a val submission; of a test submission, no
//! number that depends on fewer than [`MIN_TEST_SCENES`] test scenes. Per-scene rows and
//! bootstrap replicates (from which per-scene values could be solved) are left out; a
//! segmentation aggregate (per lighting, per subset) is shown where it pools at least that
//! many of the submission's scenes; VQA is shown pooled over every lighting — a cell per
//! lighting would let one submission try a different answer set under each lighting and
//! learn which is right — and per subset, question set, group and category where it pools
//! at least that many scenes. Applied where scores leave the service (its API, pages,
//! exports, receipts), so it also covers every score stored before the rule existed.

use serde::{Deserialize, Serialize};

use super::{Accuracy, QuestionSetScores, Scores, Split, VqaCell};

/// The fewest test scenes a shown number of a test submission may depend on.
pub const MIN_TEST_SCENES: usize = 5;

/// What a shown score leaves out, and why.
#[derive(Debug, Clone, PartialEq, Eq, Default, Serialize, Deserialize, schemars::JsonSchema)]
pub struct Withheld {
    /// Numbers that would depend on fewer test scenes than this are not shown.
    pub min_scenes: usize,
    /// What was left out, in words.
    pub note: String,
}

fn keep_accuracy(accuracy: &mut Accuracy, min: usize) {
    if accuracy.scenes < min {
        *accuracy = Accuracy::default();
    }
}

fn keep_set(set: &mut QuestionSetScores, min: usize) {
    set.categories.retain(|_, a| a.scenes >= min);
    set.groups.retain(|_, a| a.scenes >= min);
    keep_accuracy(&mut set.overall, min);
}

fn keep_cell(cell: &mut VqaCell, min: usize) {
    keep_accuracy(&mut cell.overall, min);
    keep_set(&mut cell.prompt_grounded, min);
    keep_set(&mut cell.standard, min);
    cell.subsets.retain(|_, s| s.overall.scenes >= min);
    for subset in cell.subsets.values_mut() {
        keep_accuracy(&mut subset.overall, min);
        keep_set(&mut subset.prompt_grounded, min);
        keep_set(&mut subset.standard, min);
    }
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
            lighting.subsets.retain(|_, subset| subset.scenes >= min);
        }
        let kept: Vec<_> = shown.semseg.keys().copied().collect();
        shown.relative_change.retain(|lighting, _| kept.contains(lighting) && kept.contains(&super::Lighting::BASELINE));
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
                "A test submission's scores show no number that depends on fewer than {min} test scenes: no per-scene rows, segmentation per lighting and \
                 subset only where {min} or more scenes are pooled, VQA pooled over all lightings (per subset, group and category where {min} or more scenes are pooled). \
                 Val submissions show everything."
            ),
        });
        shown
    }
}
