//! Standard view-dependent questions in the OSMa-Bench categories. Every answer comes
//! from the scene itself — all of its objects, seen or not: counts of every instance of
//! a class, the nearest object of another class, what an object physically rests on,
//! its albedo's colour — and a question is asked only when the answer is clear (a
//! colour only for a class the scene has once; a nearest object only when the runner-up
//! is 30 cm farther; a size comparison only when one box is 1.5 times the other; a count
//! only when the camera saw every instance) and when the symbolic answerer, given the
//! oracle's scene graph (the seen objects' classes, captions and boxes), finds that same
//! answer: every question is one a perfect map answers.

use std::collections::BTreeMap;

use osmab_evaluator::synthetic::Rng;
use osmab_evaluator::vqa::answer::{COLOURS, ClassifiedGraph};
use osmab_evaluator::vqa::graph::SceneGraph;
use osmab_evaluator::vqa::judge::judge_without_llm;
use osmab_evaluator::vqa::{Question, QuestionForm};
use serde_json::Value;

use super::prompt::scene_seed;
use super::{STRUCTURAL, SceneObject, oracle_graph, plural, with_article};

fn distance(a: &SceneObject, b: &SceneObject) -> f64 {
    (0..3).map(|k| (a.bbox_center[k] - b.bbox_center[k]).powi(2)).sum::<f64>().sqrt()
}

fn volume(o: &SceneObject) -> f64 {
    o.bbox_extent.iter().product()
}

/// The standard questions of a scene with `objects` (all of them, seen or not).
pub fn standard_questions(scene: &str, objects: &[SceneObject], lexicon: &[String], seed: u64) -> Vec<Question> {
    let mut rng = Rng::new(scene_seed(scene, seed) ^ 0x5747_414e_4441_5244);
    let mut all: BTreeMap<&str, Vec<&SceneObject>> = BTreeMap::new();
    for o in objects {
        all.entry(o.label.as_str()).or_default().push(o);
    }
    let seen_classes: Vec<&str> = all.iter().filter(|(_, v)| v.iter().any(|o| o.seen())).map(|(c, _)| *c).collect();
    // Classes whose every instance the camera saw: their counts are answerable.
    let counted: Vec<(&str, usize)> = all.iter().filter(|(_, v)| v.iter().all(|o| o.seen())).map(|(c, v)| (*c, v.len())).collect();
    // Classes the scene has once, and that one was seen: "the <class>" is unambiguous.
    let single: Vec<&SceneObject> = all.values().filter(|v| v.len() == 1 && v[0].seen()).map(|v| v[0]).collect();
    let absent: Vec<&str> = lexicon.iter().map(String::as_str).filter(|c| !STRUCTURAL.contains(c) && !all.contains_key(c)).collect();
    let by_id: BTreeMap<&str, &SceneObject> = objects.iter().map(|o| (o.id.as_str(), o)).collect();
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

    // Measurement: how many of a class the scene has.
    for (class, n) in counted.iter().take(3) {
        out.push((
            "Measurement",
            format!("How many {} are there in the scene?", plural(class)),
            n.to_string(),
            QuestionForm::Count { class: class.to_string() },
        ));
    }

    // Object Attributes: the colour of classes the scene has once.
    for o in single.iter().filter(|o| o.colour.is_some()).skip(2).take(3) {
        let colour = o.colour.clone().expect("filtered");
        out.push(("Object Attributes", format!("What colour is the {}?", o.label), colour, QuestionForm::Colour { class: o.label.clone() }));
    }

    // Object Relations - Spatial: the nearest object of another class (of all the
    // scene's objects), when clear.
    for o in single.iter().take(6) {
        let mut others: Vec<(f64, &str)> = objects.iter().filter(|x| x.label != o.label).map(|x| (distance(o, x), x.label.as_str())).collect();
        others.sort_by(|a, b| a.0.total_cmp(&b.0));
        let Some(&(nearest, class)) = others.first() else { continue };
        let runner_up = others.iter().find(|(_, c)| *c != class).map_or(f64::INFINITY, |x| x.0);
        if runner_up - nearest >= 0.3 {
            out.push((
                "Object Relations - Spatial",
                format!("What is the object closest to the {}?", o.label),
                class.into(),
                QuestionForm::Nearest { class: o.label.clone() },
            ));
        }
    }

    // Object Relations - Functional: what a singly present object physically rests on.
    for o in &single {
        let answer = match o.rests_on.as_deref() {
            Some("floor") => "floor".to_string(),
            Some(id) => match by_id.get(id) {
                Some(support) => support.label.clone(),
                None => continue,
            },
            None => continue,
        };
        out.push(("Object Relations - Functional", format!("What is the {} resting on?", o.label), answer, QuestionForm::Support { class: o.label.clone() }));
    }

    // Comparison: counts, and sizes when clearly different.
    for a in &counted {
        for b in &counted {
            if a.1 != b.1 && a.0 != b.0 {
                let more = QuestionForm::MoreThan { more: a.0.into(), fewer: b.0.into() };
                out.push(("Comparison", format!("Are there more {} than {} in the scene?", plural(a.0), plural(b.0)), yes_no(a.1 > b.1), more));
            }
        }
    }
    for a in &single {
        for b in &single {
            if volume(a) >= 1.5 * volume(b) {
                let larger = QuestionForm::Larger { a: b.label.clone(), b: a.label.clone() };
                out.push(("Comparison", format!("Which is larger, the {} or the {}?", b.label, a.label), a.label.clone(), larger));
            }
        }
    }

    // Asked only when a perfect map's graph gives the scene's answer, at most three of a
    // category (two functional, three of the rest), without duplicates.
    let oracle = SceneGraph::parse(&oracle_graph(objects), "oracle").expect("the oracle's graph is well formed");
    let answerer = ClassifiedGraph::new(&oracle, lexicon);
    let answerable = |answer: &str, form: &QuestionForm| {
        judge_without_llm(&Value::from(answer), &Value::from(answerer.answer(form)), Some(form), None).is_some_and(|v| v.correct)
    };
    let limit = |category: &str| match category {
        "Object Relations - Functional" | "Binary General" => 4,
        "Comparison" => 2,
        _ => 3,
    };
    let mut per_category: BTreeMap<&str, usize> = BTreeMap::new();
    let mut keys = std::collections::BTreeSet::new();
    out.retain(|(category, text, answer, form)| {
        let keep = per_category.get(category).copied().unwrap_or(0) < limit(category)
            && answerable(answer, form)
            && keys.insert((text.to_lowercase(), answer.to_lowercase(), category.to_string()));
        if keep {
            *per_category.entry(category).or_default() += 1;
        }
        keep
    });
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

    fn object(id: &str, label: &str, center: [f64; 3], extent: [f64; 3], colour: Option<&str>, rests_on: &str, points: usize) -> SceneObject {
        SceneObject {
            id: id.into(),
            label: label.into(),
            bbox_center: center,
            bbox_extent: extent,
            points,
            colour: colour.map(str::to_string),
            caption: match colour {
                Some(c) => format!("a {c} {label}"),
                None => format!("a {label}"),
            },
            rests_on: Some(rests_on.into()),
        }
    }

    fn scene() -> Vec<SceneObject> {
        vec![
            object("t", "table", [0.0, 0.375, 0.0], [1.2, 0.75, 0.8], Some("brown"), "floor", 900),
            object("m", "mug", [0.1, 0.8, 0.1], [0.1, 0.1, 0.1], Some("red"), "t", 40),
            object("c1", "chair", [1.0, 0.45, 0.0], [0.5, 0.9, 0.5], None, "floor", 300),
            object("c2", "chair", [-1.0, 0.45, 0.0], [0.5, 0.9, 0.5], None, "floor", 300),
            object("s", "sofa", [0.0, 0.45, -3.0], [2.0, 0.9, 0.9], Some("blue"), "floor", 800),
            object("b", "book", [0.3, 0.47, -2.9], [0.2, 0.04, 0.3], Some("green"), "s", 30),
            object("l", "lamp", [2.5, 0.8, -3.0], [0.4, 1.6, 0.4], Some("white"), "floor", 200),
            object("bed", "bed", [-3.0, 0.3, 3.0], [2.0, 0.6, 1.6], None, "floor", 0),
            object("k1", "bookshelf", [3.0, 1.0, 3.0], [0.8, 2.0, 0.4], None, "floor", 400),
            object("k2", "bookshelf", [3.0, 1.0, 2.0], [0.8, 2.0, 0.4], None, "floor", 2),
        ]
    }

    #[test]
    fn questions_cover_the_categories_with_answers_from_the_scene() {
        let lexicon: Vec<String> = crate::convert::lexicon::classes().into_iter().map(|c| c.name).collect();
        let questions = standard_questions("scene_000", &scene(), &lexicon, 1);
        let categories: std::collections::BTreeSet<&str> = questions.iter().map(|q| q.category.as_str()).collect();
        assert_eq!(categories.len(), 8, "{categories:?}");
        let answer = |text: &str| questions.iter().find(|q| q.question == text).and_then(|q| q.answer.clone());
        assert_eq!(answer("How many chairs are there in the scene?").as_deref(), Some("2"));
        assert_eq!(answer("How many bookshelves are there in the scene?"), None, "one bookshelf was never seen: its count is not asked");
        assert_eq!(answer("What is the mug resting on?").as_deref(), Some("table"));
        assert_eq!(answer("What is the book resting on?").as_deref(), Some("sofa"), "a seat supports, though far below the sofa's box top");
        assert!(questions.iter().all(|q| !q.question.contains(" bed ")), "the bed is in the scene (unseen): never asked absent, never asked about");
        let existence = questions.iter().find(|q| q.category == "Binary Existence-Based").unwrap();
        assert_eq!(existence.answer.as_deref(), Some("No"));
    }

    #[test]
    fn every_question_is_answered_right_from_the_oracles_graph() {
        let lexicon: Vec<String> = crate::convert::lexicon::classes().into_iter().map(|c| c.name).collect();
        let objects = scene();
        let graph = SceneGraph::parse(&oracle_graph(&objects), "oracle").unwrap();
        let answerer = ClassifiedGraph::new(&graph, &lexicon);
        for seed in 0..20 {
            for q in standard_questions("scene_000", &objects, &lexicon, seed) {
                let form = q.form.as_ref().unwrap();
                let verdict = judge_without_llm(&Value::from(q.answer.clone().unwrap()), &Value::from(answerer.answer(form)), Some(form), None);
                assert!(verdict.is_some_and(|v| v.correct), "{}: {:?} vs {}", q.question, q.answer, answerer.answer(form));
            }
        }
    }
}
