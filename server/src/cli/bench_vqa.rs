//! `osmab bench vqa`: the symbolic answerer and the judge on a full-size submission —
//! every scene under every lighting, each with a ConceptGraphs-sized scene graph (JSON
//! text parsed as in scoring) and OSMa-Bench-sized question sets of every form.

use std::time::Instant;

use osmab_evaluator::synthetic::Rng;
use osmab_evaluator::vqa::answer::{COLOURS, ClassifiedGraph};
use osmab_evaluator::vqa::graph::SceneGraph;
use osmab_evaluator::vqa::judge::judge_without_llm;
use osmab_evaluator::vqa::{QuestionForm, Relation};
use serde_json::{Value, json};

/// Sizes of the synthetic submission.
pub struct VqaBenchSize {
    pub scenes: usize,
    pub lightings: usize,
    pub objects: usize,
    pub questions: usize,
    pub repeat: usize,
}

fn graph_json(rng: &mut Rng, classes: &[String], objects: usize) -> Value {
    let nodes: Vec<Value> = (0..objects)
        .map(|i| {
            let class = &classes[rng.below(classes.len())];
            let colour = COLOURS[rng.below(COLOURS.len())];
            json!({
                "id": i,
                "object_tag": class,
                "caption": format!("a {colour} {class} in the room"),
                "possible_tags": [class, "object"],
                "bbox_center": [rng.range(-4.0, 4.0), rng.range(0.0, 2.0), rng.range(-4.0, 4.0)],
                "bbox_extent": [rng.range(0.1, 2.0), rng.range(0.1, 2.0), rng.range(0.1, 2.0)],
            })
        })
        .collect();
    Value::Array(nodes)
}

fn random_form(rng: &mut Rng, classes: &[String]) -> QuestionForm {
    let mut class = || classes[rng.below(classes.len())].clone();
    let (a, b) = (class(), class());
    match rng.below(11) {
        0 => QuestionForm::Exists { class: a },
        1 => QuestionForm::ExistsAll { classes: vec![a, b] },
        2 => QuestionForm::ExistsAny { classes: vec![a, b] },
        3 => QuestionForm::Count { class: a },
        4 => QuestionForm::Related { subject: a, relation: Relation::On, object: b },
        5 => QuestionForm::Related { subject: a, relation: Relation::NextTo, object: b },
        6 => QuestionForm::MoreThan { more: a, fewer: b },
        7 => QuestionForm::LargerThan { a, b },
        8 => QuestionForm::Colour { class: a },
        9 => QuestionForm::NearestIs { class: a, nearest: b },
        _ => QuestionForm::RestsOn { class: a, support: b },
    }
}

/// Run the benchmark and print one line per run.
pub fn run(size: VqaBenchSize) -> anyhow::Result<()> {
    let classes: Vec<String> = osmab_dataset::convert::lexicon::classes().into_iter().map(|c| c.name).filter(|c| c != "other").collect();
    let mut rng = Rng::new(17);
    // Per scene: the truth (a full graph answers the questions) and per lighting the
    // submitted graph as JSON text, as it arrives in a submission.
    let mut scenes = Vec::new();
    for _ in 0..size.scenes {
        let truth_json = graph_json(&mut rng, &classes, size.objects);
        let truth = SceneGraph::parse(&truth_json, "truth.json")?;
        let answerer = ClassifiedGraph::new(&truth, &classes);
        let questions: Vec<(QuestionForm, String)> = (0..size.questions)
            .map(|_| {
                let form = random_form(&mut rng, &classes);
                let answer = answerer.answer(&form);
                (form, answer)
            })
            .collect();
        let submitted: Vec<String> = (0..size.lightings)
            .map(|_| {
                let mut nodes = truth_json.as_array().cloned().unwrap_or_default();
                nodes.retain(|_| rng.unit() > 0.2);
                serde_json::to_string(&Value::Array(nodes)).expect("json")
            })
            .collect();
        scenes.push((questions, submitted));
    }
    let total = size.scenes * size.lightings * size.questions;
    println!(
        "{} scenes × {} lightings × {} questions = {total} answers; graphs of {} nodes (80 % kept per lighting)",
        size.scenes, size.lightings, size.questions, size.objects
    );
    for run in 0..size.repeat {
        let started = Instant::now();
        let (mut correct, mut judged) = (0usize, 0usize);
        for (questions, graphs) in &scenes {
            for text in graphs {
                let value: Value = serde_json::from_str(text)?;
                let graph = SceneGraph::parse(&value, "graphs/baseline/scene.json")?;
                let answerer = ClassifiedGraph::new(&graph, &classes);
                for (form, truth) in questions {
                    let predicted = answerer.answer(form);
                    if let Some(verdict) = judge_without_llm(&Value::from(truth.as_str()), &Value::from(predicted), Some(form), None) {
                        judged += 1;
                        correct += verdict.correct as usize;
                    }
                }
            }
        }
        let seconds = started.elapsed().as_secs_f64();
        println!(
            "run {run}: {total} questions answered and {judged} judged in {seconds:.3} s = {:.0} questions/s ({:.1} % correct)",
            total as f64 / seconds,
            100.0 * correct as f64 / judged.max(1) as f64
        );
    }
    Ok(())
}
