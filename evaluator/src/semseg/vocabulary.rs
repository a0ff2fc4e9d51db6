//! The classes a scene is scored on.

use crate::formats::classes::ClassList;

/// The classes a scene is scored on: those present in its ground truth, except 0.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Vocabulary {
    ids: Vec<i64>,
}

impl Vocabulary {
    /// Sorted unique ground-truth labels that are classes of the release, without 0
    /// ("other") and -1 ("none"): the reference's `(classes & present) - excluded`.
    pub fn from_ground_truth(labels: &[i64], classes: &ClassList) -> Self {
        let ids =
            crate::label_set::unique_labels(labels).into_iter().filter(|l| !super::metrics::EXCLUDED_LABELS.contains(l) && classes.contains(*l)).collect();
        Self { ids }
    }

    /// Class ids, ascending.
    pub fn ids(&self) -> &[i64] {
        &self.ids
    }

    /// Whether `id` is scored in this scene.
    pub fn contains(&self, id: i64) -> bool {
        self.ids.binary_search(&id).is_ok()
    }

    /// Number of classes.
    pub fn len(&self) -> usize {
        self.ids.len()
    }

    /// Whether no class is scored.
    pub fn is_empty(&self) -> bool {
        self.ids.is_empty()
    }
}
