//! Pooled accuracies, as the paper reports them: correct / total over every question of
//! every scene, per (question set, group or category, subset, lighting), with a 95 %
//! bootstrap interval over scenes (scenes resampled with replacement, 1,000 rounds,
//! a fixed seed, NumPy's linear percentiles), which the reference does not give.

use std::collections::BTreeMap;

use serde::Serialize;
use serde_json::{Value, json};

use super::{is_prompt_grounded, table_group};

/// One judged question of a submission.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct JudgedQuestion {
    pub scene: String,
    pub subset: String,
    pub lighting: String,
    pub category: String,
    pub correct: bool,
}

/// A pooled accuracy.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Accuracy {
    pub correct: u64,
    pub total: u64,
    /// correct / total; absent without questions.
    pub accuracy: Option<f64>,
    /// 95 % bootstrap interval over scenes; absent with fewer than two scenes.
    pub ci95: Option<[f64; 2]>,
    pub scenes: usize,
}

const ROUNDS: usize = 1000;

/// SplitMix64: a small, fixed generator so intervals are reproducible everywhere.
struct SplitMix(u64);

impl SplitMix {
    fn next(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }
    fn below(&mut self, n: usize) -> usize {
        ((self.next() >> 11) as f64 / (1u64 << 53) as f64 * n as f64) as usize
    }
}

/// NumPy's default (linear) percentile of sorted values.
fn percentile(sorted: &[f64], q: f64) -> f64 {
    let position = q / 100.0 * (sorted.len() - 1) as f64;
    let (lo, hi) = (position.floor() as usize, position.ceil() as usize);
    sorted[lo] + (sorted[hi] - sorted[lo]) * (position - lo as f64)
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
        let mut rng = SplitMix(0x05AB_5EED ^ (counts.len() as u64) << 32 ^ total);
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
    Accuracy { correct, total, accuracy: (total > 0).then(|| correct as f64 / total as f64), ci95, scenes: counts.len() }
}

/// One question set (prompt-grounded or standard): overall, per table group, per category.
fn question_set(items: &[&JudgedQuestion]) -> Value {
    let mut groups: BTreeMap<&str, Vec<&JudgedQuestion>> = BTreeMap::new();
    let mut categories: BTreeMap<&str, Vec<&JudgedQuestion>> = BTreeMap::new();
    for item in items {
        if let Some(group) = table_group(&item.category) {
            groups.entry(group).or_default().push(item);
        }
        categories.entry(item.category.as_str()).or_default().push(item);
    }
    json!({
        "overall": pooled(items.iter().copied()),
        "groups": groups.iter().map(|(g, v)| (g.to_string(), json!(pooled(v.iter().copied())))).collect::<serde_json::Map<_, _>>(),
        "categories": categories.iter().map(|(c, v)| (c.to_string(), json!(pooled(v.iter().copied())))).collect::<serde_json::Map<_, _>>(),
    })
}

/// Both question sets of `items`.
fn both_sets(items: &[&JudgedQuestion]) -> Value {
    let (prompt, standard): (Vec<&JudgedQuestion>, Vec<&JudgedQuestion>) = items.iter().partition(|q| is_prompt_grounded(&q.category));
    json!({"overall": pooled(items.iter().copied()), "prompt_grounded": question_set(&prompt), "standard": question_set(&standard)})
}

/// The VQA summary of a submission: per lighting (and over all lightings) both question
/// sets, overall and per subset — the cells of the paper's Tables II and III.
pub fn summarize(items: &[JudgedQuestion], subsets: &[&str]) -> Value {
    let mut lightings: BTreeMap<&str, Vec<&JudgedQuestion>> = BTreeMap::new();
    for item in items {
        lightings.entry(item.lighting.as_str()).or_default().push(item);
    }
    let with_subsets = |chosen: &[&JudgedQuestion]| {
        let mut value = both_sets(chosen);
        value["subsets"] = subsets
            .iter()
            .map(|s| {
                let members: Vec<&JudgedQuestion> = chosen.iter().copied().filter(|q| q.subset == *s).collect();
                (s.to_string(), both_sets(&members))
            })
            .collect::<serde_json::Map<_, _>>()
            .into();
        value
    };
    let all: Vec<&JudgedQuestion> = items.iter().collect();
    json!({
        "lightings": lightings.iter().map(|(l, v)| (l.to_string(), with_subsets(v))).collect::<serde_json::Map<_, _>>(),
        "all_lightings": with_subsets(&all),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn q(scene: &str, category: &str, correct: bool) -> JudgedQuestion {
        JudgedQuestion { scene: scene.into(), subset: "furniture".into(), lighting: "baseline".into(), category: category.into(), correct }
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
        let summary = summarize(&items, &["furniture", "manipuland"]);
        let prompt = &summary["lightings"]["baseline"]["prompt_grounded"];
        assert_eq!(prompt["groups"]["Relations"]["accuracy"], 0.5);
        assert_eq!(prompt["groups"]["Measurements"]["accuracy"], 1.0);
        assert_eq!(summary["lightings"]["baseline"]["standard"]["groups"]["Relations"]["total"], 1);
        assert_eq!(summary["all_lightings"]["subsets"]["manipuland"]["overall"]["total"], 0);
    }
}
