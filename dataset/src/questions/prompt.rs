//! Prompt-grounded (PromptGT) questions, as OSMa-Bench++ asks them: counts, relations and
//! existence taken from the scene's prompt specification, answered by the prompt itself
//! (digits; Yes/No) — which the release's quality control verified the scene to satisfy
//! (every prompted instance present and mapped, every relation met). At least 3
//! Measurement questions (when the prompt counts three classes), at least 3 Relations,
//! 1–3 Existence, no duplicates; most answers are Yes, so a method that maps nothing
//! scores little. Relations a scene graph's boxes cannot decide (behind, in front of:
//! they need an object's facing) are not asked; classes answered "No" are absent from
//! the scene, not only from the prompt.

use std::collections::BTreeMap;

use osmab_evaluator::synthetic::Rng;
use osmab_evaluator::vqa::{Question, QuestionForm, Relation};

use super::{STRUCTURAL, plural, with_article};
use crate::convert::lexicon::normalise_name;
use crate::spec::{RelationKind, SceneSpec};

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

/// The release class of a prompt category (none for the room's shell or unknown names).
pub fn class_of(category: &str) -> Option<&'static str> {
    normalise_name(category).filter(|c| !STRUCTURAL.contains(c))
}

/// A stable seed per scene.
pub fn scene_seed(scene: &str, seed: u64) -> u64 {
    scene.bytes().fold(seed ^ 0xcbf2_9ce4_8422_2325, |h, b| (h ^ u64::from(b)).wrapping_mul(0x0100_0000_01b3))
}

/// The PromptGT questions of a scene whose prompt has `spec` and whose objects are of
/// the classes `present`.
pub fn prompt_questions(scene: &str, spec: &SceneSpec, present: &[String], lexicon: &[String], seed: u64) -> Vec<Question> {
    let mut rng = Rng::new(scene_seed(scene, seed));
    let room = spec.room.as_str();
    let mut out: Vec<(String, String, String, QuestionForm)> = Vec::new();

    // Measurement: the stated count of every class (categories of one class add up).
    let mut counts: BTreeMap<&str, u32> = BTreeMap::new();
    for object in &spec.objects {
        if let Some(class) = class_of(&object.category) {
            *counts.entry(class).or_default() += object.count;
        }
    }
    for (class, count) in &counts {
        let text = format!("How many {} are in the {room}?", plural(class));
        out.push(("PromptGT-Measurement".into(), text, count.to_string(), QuestionForm::Count { class: class.to_string() }));
    }

    // Relations: every stated relation with a form (answered Yes by the prompt). With
    // fewer than three, reversed support relations (a mug on a table means the table is
    // not on the mug), then a stated class beside one the prompt never mentions, both
    // answered No, fill up to three.
    let mut fills = Vec::new();
    for relation in &spec.relations {
        let (Some(form), [target]) = (relation_form(relation.kind), relation.targets.as_slice()) else { continue };
        let (Some(subject), Some(target)) = (class_of(&relation.subject), class_of(target)) else { continue };
        if subject == target {
            continue;
        }
        let text = format!("Is there {} {} the {target} in the {room}?", with_article(subject), relation.kind.phrase());
        out.push(("PromptGT-Relations".into(), text, "Yes".into(), QuestionForm::Related { subject: subject.into(), relation: form, object: target.into() }));
        if matches!(form, Relation::On | Relation::Inside | Relation::Under) {
            let text = format!("Is there {} {} the {subject} in the {room}?", with_article(target), relation.kind.phrase());
            fills.push((
                "PromptGT-Relations".to_string(),
                text,
                "No".to_string(),
                QuestionForm::Related { subject: target.into(), relation: form, object: subject.into() },
            ));
        }
    }
    let stated_classes: Vec<&str> = counts.keys().copied().collect();
    let unmentioned: Vec<&String> =
        lexicon.iter().filter(|c| !STRUCTURAL.contains(&c.as_str()) && !counts.contains_key(c.as_str()) && !present.contains(c)).collect();
    for subject in stated_classes.iter().take(3) {
        if let Some(other) = (!unmentioned.is_empty()).then(|| unmentioned[(rng.next_u64() % unmentioned.len() as u64) as usize]) {
            let text = format!("Is there {} next to {} in the {room}?", with_article(subject), with_article(other));
            fills.push((
                "PromptGT-Relations".into(),
                text,
                "No".into(),
                QuestionForm::Related { subject: subject.to_string(), relation: Relation::NextTo, object: other.clone() },
            ));
        }
    }
    let stated_relations = out.iter().filter(|q| q.0 == "PromptGT-Relations").count();
    out.extend(fills.into_iter().take(3usize.saturating_sub(stated_relations)));

    // Existence: two different stated classes (Yes) and one the scene does not have (No).
    let mut pick = |from: usize| (from > 0).then(|| (rng.next_u64() % from as u64) as usize);
    let mut existence = Vec::new();
    let mut stated: Vec<&str> = stated_classes.clone();
    for _ in 0..2 {
        if let Some(i) = pick(stated.len()) {
            existence.push((stated.remove(i).to_string(), "Yes"));
        }
    }
    if let Some(i) = pick(unmentioned.len()) {
        existence.push((unmentioned[i].clone(), "No"));
    }
    for (class, answer) in existence {
        let text = format!("Is there {} in the {room}?", with_article(&class));
        out.push(("PromptGT-Existence".into(), text, answer.into(), QuestionForm::Exists { class }));
    }

    // De-duplicated on (question, answer, category), lower case, as OSMa-Bench++ does.
    let mut seen = std::collections::BTreeSet::new();
    out.retain(|(category, text, answer, _)| seen.insert((text.to_lowercase(), answer.to_lowercase(), category.clone())));
    out.into_iter()
        .enumerate()
        .map(|(i, (category, question, answer, form))| Question {
            id: format!("{scene}-p{:02}", i + 1),
            category,
            question,
            answer: Some(answer),
            form: Some(form),
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::spec::{ObjectKind, ObjectSpec, Regime};

    #[test]
    fn a_prompt_gives_counts_relations_and_existence() {
        let spec = SceneSpec {
            regime: Regime::Manipuland,
            room: "kitchen".into(),
            objects: vec![
                ObjectSpec { category: "dining table".into(), count: 1, kind: ObjectKind::Furniture },
                ObjectSpec { category: "dining chair".into(), count: 4, kind: ObjectKind::Furniture },
                ObjectSpec { category: "coffee mug".into(), count: 2, kind: ObjectKind::Manipuland },
                ObjectSpec { category: "cup".into(), count: 1, kind: ObjectKind::Manipuland },
            ],
            relations: vec![
                crate::spec::Relation { subject: "coffee mug".into(), kind: RelationKind::On, targets: vec!["dining table".into()] },
                crate::spec::Relation { subject: "dining chair".into(), kind: RelationKind::Around, targets: vec!["dining table".into()] },
            ],
        };
        let lexicon: Vec<String> = crate::convert::lexicon::classes().into_iter().map(|c| c.name).collect();
        let present: Vec<String> = ["dining table", "dining chair", "mug", "lamp"].map(String::from).to_vec();
        let questions = prompt_questions("scene_003", &spec, &present, &lexicon, 42);
        let of = |c: &str| questions.iter().filter(|q| q.category == c).collect::<Vec<_>>();
        let measurement = of("PromptGT-Measurement");
        assert_eq!(measurement.len(), 3);
        let mugs = measurement.iter().find(|q| q.question.contains("mugs")).unwrap();
        assert_eq!(mugs.answer.as_deref(), Some("3"), "coffee mugs and cups are one class");
        assert_eq!(of("PromptGT-Relations").len(), 3);
        let relations: Vec<(&str, &str)> = of("PromptGT-Relations").iter().map(|q| (q.question.as_str(), q.answer.as_deref().unwrap())).collect();
        assert_eq!(
            relations,
            [
                ("Is there a mug on the dining table in the kitchen?", "Yes"),
                ("Is there a dining chair around the dining table in the kitchen?", "Yes"),
                ("Is there a dining table on the mug in the kitchen?", "No")
            ]
        );
        let existence = of("PromptGT-Existence");
        assert!((1..=4).contains(&existence.len()));
        assert!(existence.iter().any(|q| q.answer.as_deref() == Some("No")));
        assert!(
            questions.iter().all(|q| matches!(q.answer.as_deref(), Some("Yes" | "No")) || q.answer.as_deref().unwrap().bytes().all(|b| b.is_ascii_digit()))
        );
        assert!(questions.iter().all(|q| !q.question.contains("lamp")), "a class the scene has is never answered No");
        assert_eq!(questions, prompt_questions("scene_003", &spec, &present, &lexicon, 42), "deterministic");
    }
}
