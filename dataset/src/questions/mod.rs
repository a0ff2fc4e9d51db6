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

pub mod draw;
pub mod facts;
pub mod grounding;
pub mod objects;
pub mod priors;
pub mod prompt;
pub mod standard;
pub mod support;
pub mod wording;

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
    let graph = facts::oracle_scene_graph(objects);
    let facts = facts::SceneFacts::new(objects, &graph, lexicon);
    let mut asking = standard::Asking {
        facts: &facts,
        priors,
        room: &spec.room,
        regime: spec.regime,
        lexicon,
        rng: osmab_evaluator::synthetic::Rng::new(prompt::scene_seed(scene, seed)),
    };
    let mut drawn = prompt::prompt_questions(spec, &mut asking);
    drawn.extend(standard::standard_questions(&mut asking));
    // One question a text, whichever template drew it first.
    let mut texts = std::collections::BTreeSet::new();
    drawn.retain(|(_, c)| texts.insert(c.text.to_lowercase()));
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

/// An opaque id of a question, unique within its scene: `<scene>-q` and ten hex digits of
/// a hash of the scene, the seed and the text.
pub fn question_id(scene: &str, seed: u64, text: &str) -> String {
    use sha2::Digest;
    let digest = sha2::Sha256::digest(format!("osmab question\0{scene}\0{seed}\0{}", text.to_lowercase()).as_bytes());
    format!("{scene}-q{}", &crate::release::manifest::hex(&digest)[..10])
}
