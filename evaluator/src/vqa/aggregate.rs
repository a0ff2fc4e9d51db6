//! Pooled accuracies, as the paper reports them: correct / total over every question of
//! every scene, per (question set, group or category, subset, lighting), with a 95 %
//! bootstrap interval over scenes ([`crate::bootstrap`]), which the reference does not give.

use std::collections::BTreeMap;

use crate::bootstrap::{ROUNDS, SplitMix, percentile};
use crate::scores::{Accuracy, Lighting, QuestionGroup, QuestionSet, QuestionSetScores, Regime, SetsScores, VqaCell};

/// One judged question of a submission.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct JudgedQuestion {
    pub scene: String,
    pub subset: Regime,
    pub lighting: Lighting,
    pub category: String,
    pub correct: bool,
}

/// The pooled accuracy of `items` with its bootstrap interval over their scenes.
pub fn pooled<'a>(items: impl IntoIterator<Item = &'a JudgedQuestion>) -> Accuracy {
    let mut per_scene: BTreeMap<&str, (u64, u64)> = BTreeMap::new();
    for item in items {
        let slot = per_scene.entry(item.scene.as_str()).or_default();
        slot.0 += item.correct as u64;
        slot.1 += 1;
    }
    let (correct, total) = per_scene.values().fold((0, 0), |(c, t), (sc, st)| (c + sc, t + st));
    let counts: Vec<(u64, u64)> = per_scene.values().copied().collect();
    let ci95 = (counts.len() >= 2).then(|| {
        let mut rng = SplitMix::new(0x05AB_5EED ^ (counts.len() as u64) << 32 ^ total);
        let mut estimates: Vec<f64> = (0..ROUNDS)
            .filter_map(|_| {
                let (mut c, mut t) = (0u64, 0u64);
                for _ in 0..counts.len() {
                    let (sc, st) = counts[rng.below(counts.len())];
                    c += sc;
                    t += st;
                }
                (t > 0).then(|| c as f64 / t as f64)
            })
            .collect();
        estimates.sort_by(f64::total_cmp);
        [percentile(&estimates, 2.5), percentile(&estimates, 97.5)]
    });
    Accuracy { accuracy: (total > 0).then(|| correct as f64 / total as f64), ci95, correct, scenes: counts.len(), total }
}

/// One question set (prompt-grounded or standard): overall, per table group, per category.
fn question_set(items: &[&JudgedQuestion]) -> QuestionSetScores {
    let mut groups: BTreeMap<QuestionGroup, Vec<&JudgedQuestion>> = BTreeMap::new();
    let mut categories: BTreeMap<&str, Vec<&JudgedQuestion>> = BTreeMap::new();
    for item in items {
        if let Some(group) = QuestionGroup::of_category(&item.category) {
            groups.entry(group).or_default().push(item);
        }
        categories.entry(item.category.as_str()).or_default().push(item);
    }
    QuestionSetScores {
        categories: categories.iter().map(|(c, v)| (c.to_string(), pooled(v.iter().copied()))).collect(),
        groups: groups.iter().map(|(g, v)| (*g, pooled(v.iter().copied()))).collect(),
        overall: pooled(items.iter().copied()),
    }
}

/// Both question sets of `items`.
fn both_sets(items: &[&JudgedQuestion]) -> SetsScores {
    let (prompt, standard): (Vec<&JudgedQuestion>, Vec<&JudgedQuestion>) =
        items.iter().partition(|q| QuestionSet::of_category(&q.category) == QuestionSet::PromptGrounded);
    SetsScores { overall: pooled(items.iter().copied()), prompt_grounded: question_set(&prompt), standard: question_set(&standard) }
}

/// Both question sets over `chosen`, and per subset (every subset, with or without questions).
fn cell(chosen: &[&JudgedQuestion]) -> VqaCell {
    let SetsScores { overall, prompt_grounded, standard } = both_sets(chosen);
    let subsets = Regime::ALL
        .iter()
        .map(|s| {
            let members: Vec<&JudgedQuestion> = chosen.iter().copied().filter(|q| q.subset == *s).collect();
            (*s, both_sets(&members))
        })
        .collect();
    VqaCell { overall, prompt_grounded, standard, subsets }
}

/// The VQA summary of a submission: per lighting (and over all lightings) both question
/// sets, overall and per subset — the cells of the paper's Tables II and III.
pub fn summarize(items: &[JudgedQuestion]) -> (BTreeMap<Lighting, VqaCell>, VqaCell) {
    let mut lightings: BTreeMap<Lighting, Vec<&JudgedQuestion>> = BTreeMap::new();
    for item in items {
        lightings.entry(item.lighting).or_default().push(item);
    }
    let all: Vec<&JudgedQuestion> = items.iter().collect();
    (lightings.iter().map(|(l, v)| (*l, cell(v))).collect(), cell(&all))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn q(scene: &str, category: &str, correct: bool) -> JudgedQuestion {
        JudgedQuestion { scene: scene.into(), subset: Regime::Furniture, lighting: Lighting::Baseline, category: category.into(), correct }
    }

    #[test]
    fn accuracy_is_pooled_over_scenes_not_averaged() {
        let items = [q("a", "Measurement", true), q("a", "Measurement", true), q("a", "Measurement", true), q("b", "Measurement", false)];
        let acc = pooled(&items);
        assert_eq!((acc.correct, acc.total, acc.accuracy, acc.scenes), (3, 4, Some(0.75), 2));
        let [lo, hi] = acc.ci95.unwrap();
        assert!(0.0 <= lo && lo <= 0.75 && 0.75 <= hi && hi <= 1.0, "{lo} {hi}");
        assert_eq!(pooled(&items), acc, "the interval is reproducible");
        assert_eq!(pooled(&items[..1]).ci95, None, "one scene has no interval");
    }

    #[test]
    fn prompt_grounded_existence_counts_as_relations() {
        let items = [
            q("a", "PromptGT-Existence", true),
            q("a", "PromptGT-Relations", false),
            q("a", "PromptGT-Measurement", true),
            q("a", "Object Relations - Spatial", true),
        ];
        let (lightings, all) = summarize(&items);
        let prompt = &lightings[&Lighting::Baseline].prompt_grounded;
        assert_eq!(prompt.groups[&QuestionGroup::Relations].accuracy, Some(0.5));
        assert_eq!(prompt.groups[&QuestionGroup::Measurements].accuracy, Some(1.0));
        assert_eq!(lightings[&Lighting::Baseline].standard.groups[&QuestionGroup::Relations].total, 1);
        assert_eq!(all.subsets[&Regime::Manipuland].overall.total, 0);
    }
}
