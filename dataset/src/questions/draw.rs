//! Drawing questions so that their text tells nothing of their answer. A template's
//! candidates are first put in an order that knows nothing of their answers, and a prefix
//! of that order is taken that would ask, on average, as many questions as the template
//! wants (its length follows from the candidates' odds alone). Each candidate of the
//! prefix is then kept on its own, with the odds against its answer ([`super::priors`]):
//! a positive answer (yes; a count above zero) is kept with chance `1 − p`, a negative one
//! with chance `p`, where `p` is the calibrated odds of the positive answer before the
//! scene is seen. A question is so asked with either answer equally often over scenes
//! (`p · (1 − p)` both ways), and neither its template, nor its classes, nor its odds tell
//! its answer.
//!
//! Which candidates are considered never depends on an answer: picking, say, one kept
//! "yes" and one kept "no" per scene would make a candidate's chance of being asked depend
//! on how many others share its answer, and candidates whose answers are tied (the X is
//! larger than the Y, or the Y than the X; the X rests on the floor, or on the table) would
//! then lean against their odds (measured: the odds read backwards answered 81 % of the
//! size comparisons). So a scene asks a varying number of each template, balanced over the
//! release rather than within each scene.

use osmab_evaluator::synthetic::Rng;
use osmab_evaluator::vqa::QuestionForm;

use super::priors::AskedAs;

/// A question a template may ask of a scene.
#[derive(Debug, Clone, PartialEq)]
pub struct Candidate {
    pub form: QuestionForm,
    pub text: String,
    /// The scene's answer.
    pub answer: String,
    /// Which templates ask it, and so which layouts its odds come from.
    pub asked: AskedAs,
    /// The odds of the positive answer (yes; a count above zero) before the scene is seen.
    pub odds: f64,
}

impl Candidate {
    /// Whether the answer is positive: yes, or a count above zero.
    pub fn is_positive(&self) -> bool {
        !matches!(self.answer.as_str(), "No" | "0")
    }

    /// How many times this candidate is asked on average when it is considered: `p · (1 − p)`
    /// each way.
    fn expected_asked(&self) -> f64 {
        2.0 * self.odds * (1.0 - self.odds)
    }
}

/// The candidates a draw considers: a prefix of an order that knows nothing of the answers,
/// long enough that keeping each against its odds asks `per_template` on average.
pub fn considered(mut candidates: Vec<Candidate>, per_template: usize, rng: &mut Rng) -> Vec<Candidate> {
    for k in (1..candidates.len()).rev() {
        candidates.swap(k, rng.below(k + 1));
    }
    let mut expected = 0.0;
    let length = candidates
        .iter()
        .take_while(|c| {
            let more = expected < per_template as f64;
            expected += c.expected_asked();
            more
        })
        .count();
    candidates.truncate(length);
    candidates
}

/// Each of `considered` kept against its odds: a positive answer with chance `1 − p`, a
/// negative one with chance `p`.
pub fn kept(considered: Vec<Candidate>, rng: &mut Rng) -> Vec<Candidate> {
    considered
        .into_iter()
        .filter(|c| {
            let keep = if c.is_positive() { 1.0 - c.odds } else { c.odds };
            rng.unit() < keep
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A whole draw, as a template makes it: the considered candidates, each kept or not.
    fn draw(candidates: Vec<Candidate>, per_template: usize, rng: &mut Rng) -> Vec<Candidate> {
        let considered = considered(candidates, per_template, rng);
        kept(considered, rng)
    }

    fn candidate(class: &str, answer: &str, odds: f64) -> Candidate {
        Candidate {
            form: QuestionForm::Exists { class: class.into() },
            text: format!("Is there a {class}?"),
            answer: answer.into(),
            asked: AskedAs::Standard,
            odds,
        }
    }

    #[test]
    fn a_certain_answer_is_never_asked() {
        let candidates = vec![candidate("table", "Yes", 1.0), candidate("bed", "No", 0.0), candidate("chair", "Yes", 0.6), candidate("sofa", "No", 0.4)];
        for seed in 0..200 {
            let drawn = draw(candidates.clone(), 2, &mut Rng::new(seed));
            assert!(!drawn.iter().any(|c| c.text.contains("table") || c.text.contains("bed")), "{drawn:?}");
        }
    }

    #[test]
    fn a_template_asks_about_as_many_as_it_wants() {
        let mut rng = Rng::new(3);
        let mut asked = 0;
        for _ in 0..2_000 {
            let candidates: Vec<Candidate> = (0..30)
                .map(|k| {
                    let odds = 0.1 + 0.8 * rng.unit();
                    candidate(&format!("thing{k}"), if rng.unit() < odds { "Yes" } else { "No" }, odds)
                })
                .collect();
            asked += draw(candidates, 3, &mut rng).len();
        }
        let mean = asked as f64 / 2_000.0;
        assert!((2.8..3.6).contains(&mean), "{mean} a scene");
    }

    /// Tied candidates, as size comparisons are: exactly one of "the X is larger than the Y"
    /// and "the Y is larger than the X" is yes, and the odds say which is likely.
    #[test]
    fn tied_candidates_are_asked_with_either_answer_alike() {
        let mut rng = Rng::new(7);
        let (mut yes_where_likely, mut asked) = (0usize, 0usize);
        for _ in 0..40_000 {
            let mut candidates = Vec::new();
            for (k, odds) in [0.9, 0.8, 0.7, 0.95].into_iter().enumerate() {
                let larger = rng.unit() < odds;
                candidates.push(candidate(&format!("x{k} over y{k}"), if larger { "Yes" } else { "No" }, odds));
                candidates.push(candidate(&format!("y{k} over x{k}"), if larger { "No" } else { "Yes" }, 1.0 - odds));
            }
            for c in draw(candidates, 1, &mut rng) {
                asked += 1;
                yes_where_likely += usize::from(c.is_positive() == (c.odds > 0.5));
            }
        }
        let share = yes_where_likely as f64 / asked as f64;
        assert!((0.48..0.52).contains(&share), "the odds answer {share} of {asked}");
    }
}
