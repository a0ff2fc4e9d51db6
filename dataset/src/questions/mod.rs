//! The questions of a release, part of every build: prompt-grounded questions in the words
//! of each scene's prompt ([`prompt`]) and standard view-dependent questions ([`standard`]),
//! about the objects the rendered trajectory shows — counted per instance, exactly, their
//! colours (their albedo where the camera saw them), their boxes and what they physically
//! rest on ([`support`]). Every question carries a machine-readable form, so the symbolic
//! answerer and the rule judge handle it without an LLM; every one is settled clearly by
//! the scene and answered the same by a perfect map's graph ([`facts`]); and every one is
//! drawn so that its text tells nothing of its answer ([`draw`], against the odds of the
//! pool's simulated layouts, [`priors`]). Ids are opaque and questions come in id order,
//! so neither tells a category or an answer.

pub mod calibration;
pub mod draw;
pub mod facts;
pub mod grounding;
pub mod objects;
pub mod priors;
pub mod prompt;
pub mod standard;
pub mod support;
pub mod wording;

use std::cell::RefCell;

use calibration::{Calibration, Observed};
use osmab_evaluator::vqa::{Question, SceneQuestions};

use crate::spec::SceneSpec;
pub use objects::{InstancePoints, MIN_SEEN_POINTS, SceneObject, colour_name, object_id, oracle_graph, scene_objects};
pub use wording::{plural, with_article};
/// Every question of one scene, in id order: the prompt-grounded ones and the standard
/// ones, drawn against `priors` from a seed of `scene` and `seed`.
pub fn scene_questions(
    scene: &str,
    spec: &SceneSpec,
    objects: &[SceneObject],
    lexicon: &[String],
    priors: &priors::QuestionPriors,
    seed: u64,
) -> SceneQuestions {
    let drawn = drawn_questions(spec, objects, lexicon, priors, prompt::scene_seed(scene, seed), None);
    let mut questions: Vec<Question> = drawn
        .into_iter()
        .map(|(category, c)| Question {
            id: question_id(scene, seed, &c.text),
            category: category.into(),
            question: c.text,
            answer: Some(c.answer),
            form: Some(c.form),
        })
        .collect();
    questions.sort_by(|a, b| a.id.cmp(&b.id));
    SceneQuestions { scene: scene.to_string(), questions }
}

/// The questions every template draws of a scene, one a text, noting every candidate in
/// `observed` when given.
fn drawn_questions(
    spec: &SceneSpec,
    objects: &[SceneObject],
    lexicon: &[String],
    priors: &priors::QuestionPriors,
    seed: u64,
    observed: Option<&RefCell<Vec<Observed>>>,
) -> Vec<(&'static str, draw::Candidate)> {
    let graph = facts::oracle_scene_graph(objects);
    let facts = facts::SceneFacts::new(objects, &graph, lexicon);
    let mut asking =
        standard::Asking { facts: &facts, priors, room: &spec.room, regime: spec.regime, lexicon, rng: osmab_evaluator::synthetic::Rng::new(seed), observed };
    let mut drawn = prompt::prompt_questions(spec, &mut asking);
    drawn.extend(standard::standard_questions(&mut asking));
    // One question a text, whichever template drew it first.
    let mut texts = std::collections::BTreeSet::new();
    drawn.retain(|(_, c)| texts.insert(c.text.to_lowercase()));
    drawn
}

/// The question odds of `layouts`, calibrated on its held-out placements: every template's
/// candidates of each held-out placement are noted with their tally odds and answers
/// ([`calibration`]).
pub fn calibrated_priors<'a>(layouts: &'a priors::PoolLayouts, lexicon: &'a [String]) -> priors::QuestionPriors<'a> {
    use rayon::prelude::*;
    let priors = priors::QuestionPriors::new(layouts, lexicon);
    let observed: Vec<Observed> = layouts
        .held_out()
        .par_iter()
        .enumerate()
        .flat_map_iter(|(k, scene)| {
            let noted = RefCell::new(Vec::new());
            drawn_questions(&scene.spec, &scene.objects, lexicon, &priors, 0xca1b_0000 + k as u64, Some(&noted));
            noted.into_inner()
        })
        .collect();
    priors.calibrate(Calibration::fit(&observed));
    priors
}

/// An opaque id of a question, unique within its scene: `<scene>-q` and ten hex digits of
/// a hash of the scene, the seed and the text.
pub fn question_id(scene: &str, seed: u64, text: &str) -> String {
    use sha2::Digest;
    let digest = sha2::Sha256::digest(format!("osmab question\0{scene}\0{seed}\0{}", text.to_lowercase()).as_bytes());
    format!("{scene}-q{}", &crate::release::manifest::hex(&digest)[..10])
}

#[cfg(test)]
mod tests {
    use std::collections::BTreeMap;

    use osmab_evaluator::vqa::QuestionForm;

    use super::priors::{AskedAs, PoolLayouts};
    use crate::prompts::grammar_pool;
    use crate::spec::Regime;
    use crate::synthesis::dressing::furnished;
    use crate::synthesis::source::AssetSource;

    /// Every prompt of two pools placed afresh (as a test scene is) `draws` times: per
    /// template (category and form), the questions asked and how many of them the pool's
    /// odds answer (the positive answer where they favour it).
    fn odds_hits(draws: u64) -> BTreeMap<String, (usize, usize)> {
        let lexicon: Vec<String> = crate::convert::lexicon::classes().into_iter().map(|c| c.name).collect();
        let pools = [grammar_pool(Regime::Furniture, 60, 5), grammar_pool(Regime::Manipuland, 40, 5)];
        let layouts = PoolLayouts::place(&pools, 3, &AssetSource::procedural());
        let priors = super::calibrated_priors(&layouts, &lexicon);
        let mut per_template: BTreeMap<String, (usize, usize)> = BTreeMap::new();
        for draw in 0..draws {
            for (k, prompt) in pools.iter().flat_map(|p| p.accepted.iter()).enumerate() {
                let layout = furnished(&prompt.spec, 0xbeef_0000 + draw * 1000 + k as u64, &AssetSource::procedural());
                let objects = super::priors::layout_objects(&layout);
                let questions = super::scene_questions(&format!("scene_{k:03}"), &prompt.spec, &objects, &lexicon, &priors, 91 + draw);
                for q in questions.questions {
                    let form = q.form.clone().expect("every question has a form");
                    if matches!(form, QuestionForm::Colour { .. } | QuestionForm::HasColour { .. }) {
                        continue;
                    }
                    let asked = if osmab_evaluator::vqa::is_prompt_grounded(&q.category) { AskedAs::PromptGrounded } else { AskedAs::Standard };
                    let favours_positive = priors.odds(asked, &prompt.spec.room, prompt.spec.regime, &form) > 0.5;
                    let positive = !matches!(q.answer.as_deref().expect("answered"), "0" | "No");
                    let tally = per_template.entry(format!("{} / {}", q.category, form.kind())).or_default();
                    tally.0 += usize::from(positive == favours_positive);
                    tally.1 += 1;
                }
            }
        }
        per_template
    }

    /// The question design's promise, measured as the bench measures a release (`osmab
    /// bench questions`): the generator's own odds answer no template's questions much better
    /// or worse than a coin. Drawn one kept yes and one kept no per scene, the odds answered
    /// 18 % of the size comparisons and 37 % of what rests on what (read backwards: 82 % and
    /// 63 %); drawn from a prefix that knows nothing of the answers but against uncalibrated
    /// odds, 43 % and 42 %, and 55 % of the prompt-grounded existence and counts.
    #[test]
    fn the_pool_s_odds_tell_no_template_s_answer() {
        for (template, (hits, asked)) in odds_hits(10) {
            let share = hits as f64 / asked as f64;
            println!("{template}: {hits} of {asked} ({:.1} %)", 100.0 * share);
            if asked >= 150 {
                assert!((0.42..0.58).contains(&share), "{template}: the pool's odds answer {hits} of {asked}");
            }
        }
    }
}
