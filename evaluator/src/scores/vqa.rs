//! The VQA part of the score document: pooled accuracies per lighting (and over all
//! lightings), per question set, group and category, overall and per subset, with what
//! answered and judged each question.

use std::collections::BTreeMap;

use serde::{Deserialize, Serialize};

use super::{Lighting, QuestionGroup, QuestionSet, Regime};
use crate::vqa::answer::AnsweredBy;
use crate::vqa::judge::JudgedBy;

/// A pooled accuracy: correct / total over every question of every scene.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize, schemars::JsonSchema)]
pub struct Accuracy {
    /// correct / total; absent without questions.
    pub accuracy: Option<f64>,
    /// 95 % bootstrap interval over scenes; absent with fewer than two scenes.
    pub ci95: Option<[f64; 2]>,
    pub correct: u64,
    /// How many scenes the questions come from.
    pub scenes: usize,
    pub total: u64,
}

/// One question set: overall, per table group, per category.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize, schemars::JsonSchema)]
pub struct QuestionSetScores {
    pub categories: BTreeMap<String, Accuracy>,
    pub groups: BTreeMap<QuestionGroup, Accuracy>,
    pub overall: Accuracy,
}

/// Both question sets and the two pooled.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize, schemars::JsonSchema)]
pub struct SetsScores {
    pub overall: Accuracy,
    pub prompt_grounded: QuestionSetScores,
    pub standard: QuestionSetScores,
}

/// Both question sets over some scenes, and the same per subset.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize, schemars::JsonSchema)]
pub struct VqaCell {
    pub overall: Accuracy,
    pub prompt_grounded: QuestionSetScores,
    pub standard: QuestionSetScores,
    pub subsets: BTreeMap<Regime, SetsScores>,
}

impl QuestionSetScores {
    fn for_each_accuracy(&mut self, f: &mut dyn FnMut(&mut Accuracy)) {
        f(&mut self.overall);
        self.groups.values_mut().chain(self.categories.values_mut()).for_each(|a| f(a));
    }
}

impl VqaCell {
    /// Apply `f` to every accuracy of the cell, its subsets' included.
    pub fn for_each_accuracy(&mut self, f: &mut dyn FnMut(&mut Accuracy)) {
        f(&mut self.overall);
        self.prompt_grounded.for_each_accuracy(f);
        self.standard.for_each_accuracy(f);
        for subset in self.subsets.values_mut() {
            f(&mut subset.overall);
            subset.prompt_grounded.for_each_accuracy(f);
            subset.standard.for_each_accuracy(f);
        }
    }
}

/// One question as answered and judged.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize, schemars::JsonSchema)]
pub struct AnswerRow {
    pub answer: String,
    pub answered_by: AnsweredBy,
    pub category: String,
    pub correct: bool,
    pub id: String,
    pub judged_by: JudgedBy,
}

/// The questions of one scene under one lighting.
#[derive(Debug, Clone, PartialEq, Eq, Default, Serialize, Deserialize, schemars::JsonSchema)]
pub struct SceneAnswers {
    pub answers: Vec<AnswerRow>,
    pub correct: u64,
    pub total: u64,
}

/// The VQA scores of a submission.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize, schemars::JsonSchema)]
pub struct VqaScores {
    /// Over every lighting.
    pub all_lightings: VqaCell,
    /// How many questions each answerer answered.
    pub answered_by: BTreeMap<AnsweredBy, u64>,
    /// How many verdicts each judge gave.
    pub judged_by: BTreeMap<JudgedBy, u64>,
    pub lightings: BTreeMap<Lighting, VqaCell>,
    /// Per lighting and scene, every question; left out of summaries.
    #[serde(default, skip_serializing_if = "BTreeMap::is_empty")]
    pub scenes: BTreeMap<Lighting, BTreeMap<String, SceneAnswers>>,
}

impl QuestionSetScores {
    /// The accuracy of `group`, if the set has questions of it.
    pub fn group(&self, group: QuestionGroup) -> Option<&Accuracy> {
        self.groups.get(&group)
    }
}

impl SetsScores {
    /// One of the two sets.
    pub fn set(&self, set: QuestionSet) -> &QuestionSetScores {
        match set {
            QuestionSet::PromptGrounded => &self.prompt_grounded,
            QuestionSet::Standard => &self.standard,
        }
    }
}

impl VqaCell {
    /// One of the two sets.
    pub fn set(&self, set: QuestionSet) -> &QuestionSetScores {
        match set {
            QuestionSet::PromptGrounded => &self.prompt_grounded,
            QuestionSet::Standard => &self.standard,
        }
    }

    /// The pooled accuracy of (`set`, `group`) over every scene of the cell.
    pub fn group_accuracy(&self, set: QuestionSet, group: QuestionGroup) -> Option<f64> {
        self.set(set).group(group)?.accuracy
    }

    /// One set over every scene (`subset` `None`) or one subset's.
    pub fn set_of(&self, subset: Option<Regime>, set: QuestionSet) -> Option<&QuestionSetScores> {
        match subset {
            None => Some(self.set(set)),
            Some(subset) => Some(self.subsets.get(&subset)?.set(set)),
        }
    }
}

impl VqaScores {
    /// The pooled accuracy of (`set`, `group`) under `lighting`, over every scene or one subset.
    pub fn accuracy(&self, lighting: Lighting, subset: Option<Regime>, set: QuestionSet, group: QuestionGroup) -> Option<f64> {
        self.lightings.get(&lighting)?.set_of(subset, set)?.group(group)?.accuracy
    }

    /// The pooled accuracy of (`set`, `group`) over every lighting in one subset.
    pub fn over_lightings(&self, subset: Regime, set: QuestionSet, group: QuestionGroup) -> Option<&Accuracy> {
        self.all_lightings.set_of(Some(subset), set)?.group(group)
    }
}
