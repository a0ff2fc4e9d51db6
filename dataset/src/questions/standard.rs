//! Standard view-dependent questions in the OSMa-Bench categories, from what the
//! trajectory saw: the seen objects, their counts, colours and boxes. Only questions
//! with a clear answer are asked (a colour only for a class seen once and clearly
//! coloured; a nearest object only when the runner-up is 30 cm farther; a size
//! comparison only when one box is 1.5 times the other), so the ground truth is never
//! a coin toss.

use std::collections::BTreeMap;

use osmab_evaluator::synthetic::Rng;
use osmab_evaluator::vqa::answer::COLOURS;
use osmab_evaluator::vqa::{Question, QuestionForm};

use super::prompt::scene_seed;
use super::{STRUCTURAL, SceneObject, plural, with_article};

fn distance(a: &SceneObject, b: &SceneObject) -> f64 {
    (0..3).map(|k| (a.bbox_center[k] - b.bbox_center[k]).powi(2)).sum::<f64>().sqrt()
}

fn rests_on(top: &SceneObject, below: &SceneObject) -> bool {
    let overlap = [0, 2].iter().all(|&k| top.min(k) < below.max(k) && below.min(k) < top.max(k));
    overlap && (top.min(1) - below.max(1)).abs() <= 0.05
}

fn volume(o: &SceneObject) -> f64 {
    o.bbox_extent.iter().product()
}

pub fn standard_questions(scene: &str, seen: &[SceneObject], present: &[String], lexicon: &[String], seed: u64) -> Vec<Question> {
    let mut rng = Rng::new(scene_seed(scene, seed) ^ 0x5747_414e_4441_5244);
    let mut by_class: BTreeMap<&str, Vec<&SceneObject>> = BTreeMap::new();
    for o in seen {
        by_class.entry(o.label.as_str()).or_default().push(o);
    }
    let seen_classes: Vec<&str> = by_class.keys().copied().collect();
    let single: Vec<&SceneObject> = by_class.values().filter(|v| v.len() == 1).map(|v| v[0]).collect();
    let absent: Vec<&str> = lexicon.iter().map(String::as_str).filter(|c| !STRUCTURAL.contains(c) && !present.iter().any(|p| p == c)).collect();
    let mut choose = |n: usize| (rng.next_u64() % n.max(1) as u64) as usize;
    let mut out: Vec<(&str, String, String, QuestionForm)> = Vec::new();
    let yes_no = |b: bool| if b { "Yes".to_string() } else { "No".to_string() };

    // Binary General: presence of seen classes; colour yes/no.
    for class in seen_classes.iter().take(2) {
        out.push((
            "Binary General",
            format!("Is there {} in the scene?", with_article(class)),
            "Yes".into(),
            QuestionForm::Exists { class: class.to_string() },
        ));
    }
    for (k, o) in single.iter().filter(|o| o.colour.is_some()).take(2).enumerate() {
        let colour = o.colour.clone().expect("filtered");
        let asked = if k % 2 == 0 {
            colour.clone()
        } else {
            let others: Vec<&&str> = COLOURS.iter().filter(|c| **c != colour && **c != "gray").collect();
            others[choose(others.len())].to_string()
        };
        let form = QuestionForm::HasColour { class: o.label.clone(), colour: asked.clone() };
        out.push(("Binary General", format!("Is the {} {asked}?", o.label), yes_no(asked == colour), form));
    }

    // Binary Existence-Based: classes the scene does not have.
    for _ in 0..3.min(absent.len()) {
        let class = absent[choose(absent.len())];
        out.push((
            "Binary Existence-Based",
            format!("Is there {} in the scene?", with_article(class)),
            "No".into(),
            QuestionForm::Exists { class: class.to_string() },
        ));
    }

    // Binary Logical: AND and OR over seen and absent classes.
    if !seen_classes.is_empty() && !absent.is_empty() {
        let (a, b) = (seen_classes[choose(seen_classes.len())], absent[choose(absent.len())]);
        let and = QuestionForm::ExistsAll { classes: vec![a.into(), b.into()] };
        out.push(("Binary Logical", format!("Is there {} and {} in the scene?", with_article(a), with_article(b)), "No".into(), and));
        let or = QuestionForm::ExistsAny { classes: vec![b.into(), a.into()] };
        out.push(("Binary Logical", format!("Is there {} or {} in the scene?", with_article(b), with_article(a)), "Yes".into(), or));
    }
    if seen_classes.len() >= 2 {
        let (a, b) = (seen_classes[0], seen_classes[seen_classes.len() - 1]);
        out.push((
            "Binary Logical",
            format!("Is there {} and {} in the scene?", with_article(a), with_article(b)),
            "Yes".into(),
            QuestionForm::ExistsAll { classes: vec![a.into(), b.into()] },
        ));
    }

    // Measurement: counts of seen classes.
    for (class, objects) in by_class.iter().take(3) {
        out.push((
            "Measurement",
            format!("How many {} are there in the scene?", plural(class)),
            objects.len().to_string(),
            QuestionForm::Count { class: class.to_string() },
        ));
    }

    // Object Attributes: the colour of classes seen once.
    for o in single.iter().filter(|o| o.colour.is_some()).skip(2).take(3) {
        let colour = o.colour.clone().expect("filtered");
        out.push(("Object Attributes", format!("What colour is the {}?", o.label), colour, QuestionForm::Colour { class: o.label.clone() }));
    }

    // Object Relations - Spatial: the nearest object of another class, when clear.
    for o in single.iter().take(6) {
        let mut others: Vec<(f64, &str)> = seen.iter().filter(|x| x.label != o.label).map(|x| (distance(o, x), x.label.as_str())).collect();
        others.sort_by(|a, b| a.0.total_cmp(&b.0));
        let Some(&(nearest, class)) = others.first() else { continue };
        let runner_up = others.iter().find(|(_, c)| *c != class).map_or(f64::INFINITY, |x| x.0);
        if runner_up - nearest >= 0.3 && out.iter().filter(|q| q.0 == "Object Relations - Spatial").count() < 3 {
            out.push((
                "Object Relations - Spatial",
                format!("What is the object closest to the {}?", o.label),
                class.into(),
                QuestionForm::Nearest { class: o.label.clone() },
            ));
        }
    }

    // Object Relations - Functional: what a singly seen object rests on.
    for o in &single {
        if out.iter().filter(|q| q.0 == "Object Relations - Functional").count() >= 2 {
            break;
        }
        let supports: Vec<&SceneObject> = seen.iter().filter(|x| x.id != o.id && rests_on(o, x)).collect();
        let answer = match supports.as_slice() {
            [only] => only.label.clone(),
            [] if o.min(1).abs() <= 0.05 => "floor".into(),
            _ => continue,
        };
        out.push(("Object Relations - Functional", format!("What is the {} resting on?", o.label), answer, QuestionForm::Support { class: o.label.clone() }));
    }

    // Comparison: counts, and sizes when clearly different.
    let counted: Vec<(&str, usize)> = by_class.iter().map(|(c, v)| (*c, v.len())).collect();
    if let Some((a, b)) = counted.iter().flat_map(|a| counted.iter().map(move |b| (a, b))).find(|(a, b)| a.1 != b.1) {
        let more = QuestionForm::MoreThan { more: a.0.into(), fewer: b.0.into() };
        out.push(("Comparison", format!("Are there more {} than {} in the scene?", plural(a.0), plural(b.0)), yes_no(a.1 > b.1), more));
    }
    if let Some((a, b)) = single.iter().flat_map(|a| single.iter().map(move |b| (a, b))).find(|(a, b)| volume(a) >= 1.5 * volume(b)) {
        let larger = QuestionForm::Larger { a: b.label.clone(), b: a.label.clone() };
        out.push(("Comparison", format!("Which is larger, the {} or the {}?", b.label, a.label), a.label.clone(), larger));
    }

    let mut seen_keys = std::collections::BTreeSet::new();
    out.retain(|(category, text, answer, _)| seen_keys.insert((text.to_lowercase(), answer.to_lowercase(), category.to_string())));
    out.into_iter()
        .enumerate()
        .map(|(i, (category, question, answer, form))| Question {
            id: format!("{scene}-s{:02}", i + 1),
            category: category.into(),
            question,
            answer: Some(answer),
            form: Some(form),
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn object(id: &str, label: &str, center: [f64; 3], extent: [f64; 3], colour: Option<&str>) -> SceneObject {
        SceneObject {
            id: id.into(),
            label: label.into(),
            bbox_center: center,
            bbox_extent: extent,
            points: 100,
            colour: colour.map(str::to_string),
            caption: String::new(),
        }
    }

    #[test]
    fn questions_cover_the_categories_with_clear_answers() {
        let seen = [
            object("t", "table", [0.0, 0.375, 0.0], [1.2, 0.75, 0.8], Some("brown")),
            object("m", "mug", [0.1, 0.8, 0.1], [0.1, 0.1, 0.1], Some("red")),
            object("c1", "chair", [1.0, 0.45, 0.0], [0.5, 0.9, 0.5], None),
            object("c2", "chair", [-1.0, 0.45, 0.0], [0.5, 0.9, 0.5], None),
            object("s", "sofa", [0.0, 0.4, -3.0], [2.0, 0.8, 0.9], Some("blue")),
            object("l", "lamp", [2.5, 0.8, -3.0], [0.4, 1.6, 0.4], Some("white")),
        ];
        let present: Vec<String> = ["table", "mug", "chair", "sofa", "lamp", "bed"].map(String::from).to_vec();
        let lexicon: Vec<String> = crate::convert::lexicon::classes().into_iter().map(|c| c.name).collect();
        let questions = standard_questions("scene_000", &seen, &present, &lexicon, 1);
        let categories: std::collections::BTreeSet<&str> = questions.iter().map(|q| q.category.as_str()).collect();
        assert_eq!(categories.len(), 8, "{categories:?}");
        let answer = |text: &str| questions.iter().find(|q| q.question == text).and_then(|q| q.answer.clone());
        assert_eq!(answer("How many chairs are there in the scene?").as_deref(), Some("2"));
        assert_eq!(answer("What is the mug resting on?").as_deref(), Some("table"));
        assert!(questions.iter().filter(|q| q.category == "Binary Existence-Based").all(|q| !q.question.contains(" bed ")), "bed is present though unseen");
        let existence = questions.iter().find(|q| q.category == "Binary Existence-Based").unwrap();
        assert_eq!(existence.answer.as_deref(), Some("No"));
    }
}
