//! Prompt-grounded (PromptGT) questions, as OSMa-Bench++ asks them: counts, relations and
//! existence in the words of the scene's prompt ("in the dining room"), answered by the
//! prompt — which the release's quality control verified the scene to satisfy — and by the
//! scene where the prompt is silent (a class it never names is absent: zero, no). A class the
//! prompt does not name but the room's dressing holds (a rug, a vase) is not asked here: the
//! prompt cannot answer it (the standard questions do; [`super::grounding`]). Drawn
//! like every question ([`super::draw`]): each against its odds among the layouts where
//! the prompt settles it, so the text tells nothing; relations
//! are asked between the classes the prompt states and the camera saw, and answered by the
//! scene's boxes.
//! Relations a scene graph's boxes cannot decide (behind, in front of: they need an
//! object's facing) are not asked.

use osmab_evaluator::vqa::{QuestionForm, Relation};

use super::draw::Candidate;
use super::grounding::{class_of, prompt_settles, stated_classes};
use super::priors::AskedAs;
use super::standard::Asking;
use super::wording::{plural, with_article};
use crate::spec::{RelationKind, SceneSpec};

/// The relations asked, each decided by boxes (see `osmab_evaluator::vqa::answer`).
const ASKED_RELATIONS: [Relation; 5] = [Relation::On, Relation::Under, Relation::Inside, Relation::NextTo, Relation::Near];

/// The question form of a prompt relation, when boxes decide it (`around` is `next
/// to`; `behind` and `in front of` need the target's facing, `facing`, `between`,
/// `opposite`, `parallel to` and the wall relations have no form).
fn relation_form(kind: RelationKind) -> Option<Relation> {
    Some(match kind {
        RelationKind::On => Relation::On,
        RelationKind::Under => Relation::Under,
        RelationKind::Inside => Relation::Inside,
        RelationKind::NextTo | RelationKind::Around => Relation::NextTo,
        RelationKind::Near => Relation::Near,
        _ => return None,
    })
}

/// A stable seed per scene.
pub fn scene_seed(scene: &str, seed: u64) -> u64 {
    scene.bytes().fold(seed ^ 0xcbf2_9ce4_8422_2325, |h, b| (h ^ u64::from(b)).wrapping_mul(0x0100_0000_01b3))
}

/// The text of a relation question.
fn relation_text(subject: &str, relation: Relation, object: &str, room: &str) -> String {
    format!("Is there {} {} the {object} in the {room}?", with_article(subject), relation.words())
}

/// The PromptGT questions of a scene whose prompt has `spec`: (category, question).
pub fn prompt_questions(spec: &SceneSpec, asking: &mut Asking) -> Vec<(&'static str, Candidate)> {
    let room = spec.room.clone();
    let mut out: Vec<(&'static str, Candidate)> = Vec::new();
    let stated = stated_classes(spec);
    let per_template = 2 * stated.len().clamp(1, 3);

    // Only what the prompt settles: a class it states, or one the scene lacks altogether;
    // relations between stated classes the camera saw.
    let settled = |c: &Candidate| prompt_settles(&c.form, &stated, asking.facts);
    // Measurement: the stated count of a class (categories of one class add up), or zero.
    let mut counts = asking.counts(AskedAs::PromptGrounded, |c| format!("How many {} are in the {room}?", plural(c)));
    counts.retain(settled);
    out.extend(asking.draw(counts, per_template).into_iter().map(|c| ("PromptGT-Measurement", c)));

    // Relations between the scene's classes, as its boxes decide them: what the prompt
    // states first (a stated relation the boxes confirm), then any other.
    let mut relations = Vec::new();
    for relation in &spec.relations {
        let (Some(form), [target]) = (relation_form(relation.kind), relation.targets.as_slice()) else { continue };
        let (Some(subject), Some(object)) = (class_of(&relation.subject), class_of(target)) else { continue };
        relations.extend(asking.candidate(
            AskedAs::PromptGrounded,
            QuestionForm::Related { subject: subject.into(), relation: form, object: object.into() },
            relation_text(subject, form, object, &room),
        ));
    }
    let present: Vec<&str> = asking.facts.classes().filter(|c| asking.facts.seen(c) && stated.contains(c)).collect();
    for subject in &present {
        for object in present.iter().filter(|o| *o != subject) {
            for relation in ASKED_RELATIONS {
                let form = QuestionForm::Related { subject: subject.to_string(), relation, object: object.to_string() };
                relations.extend(asking.candidate(AskedAs::PromptGrounded, form, relation_text(subject, relation, object, &room)));
            }
        }
    }
    let mut seen = std::collections::BTreeSet::new();
    relations.retain(|c| settled(c) && seen.insert(c.text.to_lowercase()));
    out.extend(asking.draw(relations, per_template).into_iter().map(|c| ("PromptGT-Relations", c)));

    // Existence: classes the prompt states (yes) and classes it does not (no).
    let mut existence = asking.existence(AskedAs::PromptGrounded, |c| format!("Is there {} in the {room}?", with_article(c)));
    existence.retain(settled);
    out.extend(asking.draw(existence, 4).into_iter().map(|c| ("PromptGT-Existence", c)));
    out
}
