//! Drawing questions so that their text tells nothing of their answer. Each candidate is
//! first kept or dropped on its own, with the odds against its answer ([`super::priors`]):
//! a "yes" is kept with chance `1 − p`, a "no" with chance `p`, where `p` is the odds of
//! "yes" before the scene is seen; a question about a class (or pair, or relation) is then
//! kept with either answer equally often over scenes (`p · (1 − p)` both ways), so neither
//! its template nor its classes predict its answer. Of the kept ones, every scene asks as
//! many answered yes as answered no, picked evenly.

use osmab_evaluator::synthetic::Rng;
use osmab_evaluator::vqa::QuestionForm;

/// A question a template may ask of a scene.
#[derive(Debug, Clone, PartialEq)]
pub struct Candidate {
    pub form: QuestionForm,
    pub text: String,
    /// The scene's answer.
    pub answer: String,
    /// The odds of the positive answer (yes; a count above zero) before the scene is seen.
    pub odds: f64,
}

/// `count` of `items` picked evenly, without replacement.
fn pick<T>(mut items: Vec<T>, count: usize, rng: &mut Rng) -> Vec<T> {
    let mut out = Vec::with_capacity(count);
    while out.len() < count && !items.is_empty() {
        let k = rng.below(items.len());
        out.push(items.swap_remove(k));
    }
    out
}

/// Up to `per_side` candidates with a positive answer and as many with a negative one
/// (`positive` decides which is which), each kept against its odds first (see the module's
/// header); both sides get the same number, so every scene is balanced.
pub fn draw_balanced(candidates: Vec<Candidate>, positive: impl Fn(&Candidate) -> bool, per_side: usize, rng: &mut Rng) -> Vec<Candidate> {
    let mut kept_yes = Vec::new();
    let mut kept_no = Vec::new();
    for candidate in candidates {
        let is_positive = positive(&candidate);
        let keep = if is_positive { 1.0 - candidate.odds } else { candidate.odds };
        if rng.unit() < keep {
            if is_positive { kept_yes.push(candidate) } else { kept_no.push(candidate) }
        }
    }
    let n = per_side.min(kept_yes.len()).min(kept_no.len());
    let mut out = pick(kept_yes, n, rng);
    out.extend(pick(kept_no, n, rng));
    out
}

/// Whether a yes/no candidate's answer is yes.
pub fn is_yes(c: &Candidate) -> bool {
    c.answer == "Yes"
}

/// Whether a count candidate's answer is above zero.
pub fn is_nonzero(c: &Candidate) -> bool {
    c.answer != "0"
}

#[cfg(test)]
mod tests {
    use super::*;

    fn candidate(class: &str, answer: &str, odds: f64) -> Candidate {
        Candidate { form: QuestionForm::Exists { class: class.into() }, text: format!("Is there a {class}?"), answer: answer.into(), odds }
    }

    #[test]
    fn every_scene_asks_as_many_yes_as_no_and_never_a_certainty() {
        let candidates = vec![
            candidate("table", "Yes", 1.0),
            candidate("chair", "Yes", 0.6),
            candidate("lamp", "Yes", 0.3),
            candidate("bed", "No", 0.0),
            candidate("sofa", "No", 0.4),
        ];
        for seed in 0..50 {
            let drawn = draw_balanced(candidates.clone(), is_yes, 3, &mut Rng::new(seed));
            assert!(drawn.len() <= 2, "one no with odds above zero: at most one of each");
            assert!(!drawn.iter().any(|c| c.text.contains("table") || c.text.contains("bed")), "certain answers are never asked: {drawn:?}");
            assert_eq!(drawn.iter().filter(|c| is_yes(c)).count() * 2, drawn.len());
        }
    }

    #[test]
    fn over_many_scenes_a_class_is_asked_with_either_answer_alike() {
        // A class present in 80 % of scenes, among others with their own odds.
        let mut rng = Rng::new(7);
        let (mut yes, mut no) = (0, 0);
        for scene in 0..20_000 {
            let present = scene % 5 != 0;
            let mut candidates = vec![candidate("chair", if present { "Yes" } else { "No" }, 0.8)];
            for (k, odds) in [0.5, 0.3, 0.7, 0.9, 0.2].into_iter().enumerate() {
                let present = rng.unit() < odds;
                candidates.push(candidate(&format!("thing{k}"), if present { "Yes" } else { "No" }, odds));
            }
            for c in draw_balanced(candidates, is_yes, 1, &mut rng).into_iter().filter(|c| c.text.contains("chair")) {
                if is_yes(&c) { yes += 1 } else { no += 1 }
            }
        }
        let share = yes as f64 / (yes + no) as f64;
        assert!((0.45..0.55).contains(&share), "asked {yes} times yes and {no} times no");
    }
}
