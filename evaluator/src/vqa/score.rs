//! The VQA part of a submission's score: for every (lighting, scene) with a scene graph
//! or answers, every question of the scene answered (the team's own answer, else the
//! symbolic answerer on the graph — nodes named by their label or texts, or by their
//! feature against text_features.npz — else the optional LLM answerer) and judged, then
//! pooled as the paper does. Which answerer and which judge decided is recorded.

use std::collections::BTreeMap;

use serde_json::Value;

use super::SceneQuestions;
use super::aggregate::{JudgedQuestion, summarize};
use super::answer::{AnsweredBy, ClassifiedGraph, NO_ANSWER};
use super::graph::SceneGraph;
use super::judge::{JudgedBy, OpenJudge, Pending, Verdict, judge_without_llm};
use crate::error::{InputError, Result, ScoreError};
use crate::scores::{AnswerRow, Lighting, Regime, SceneAnswers, VqaScores};
use crate::submission::release::ReleaseIndex;
use crate::submission::validate::{SceneEntry, ValidSubmission};

/// An answerer for questions without a machine-readable form (an LLM).
pub trait OpenAnswerer {
    /// Answers to `questions` (id, text) from `graph` (the file's JSON), by position.
    fn answer(&self, graph: &Value, questions: &[(String, String)]) -> Vec<Option<String>>;
}

/// The optional open answerer and judge.
#[derive(Default, Clone, Copy)]
pub struct OpenBackends<'a> {
    pub answerer: Option<&'a dyn OpenAnswerer>,
    pub judge: Option<&'a dyn OpenJudge>,
}

struct Answered {
    id: String,
    answer: String,
    by: AnsweredBy,
    verdict: Option<Verdict>,
}

fn team_answers(path: &std::path::Path, name: &str) -> Result<BTreeMap<String, Value>> {
    let bytes = std::fs::read(path).map_err(|e| InputError::io(name, &e))?;
    let list: Vec<Value> = serde_json::from_slice(&bytes).map_err(|e| InputError::new(name, "(json)", e.to_string()))?;
    Ok(list.into_iter().filter_map(|item| Some((item.get("question_id")?.as_str()?.to_string(), item.get("answer")?.clone()))).collect())
}

/// Score the VQA of `submission`; `None` when the release has no questions or the
/// submission no graphs or answers.
pub fn score_vqa(submission: &ValidSubmission, release: &ReleaseIndex, open: OpenBackends) -> std::result::Result<Option<VqaScores>, ScoreError> {
    let classes = release.class_names();
    let text = submission
        .text_features
        .as_deref()
        .map(|p| crate::formats::map::TextFeatures::read(p, crate::formats::npy::ReadLimits::default()))
        .transpose()
        .map_err(ScoreError::Submission)?;
    let vocabulary = text.as_ref().map(|t| super::graph::FeatureVocabulary::new(t, &release.classes));
    let mut tally = Tally::default();
    let mut questions_cache = BTreeMap::new();
    for entry in submission.entries.iter().filter(|e| e.graph.is_some() || e.answers.is_some()) {
        if !questions_cache.contains_key(&entry.scene) {
            questions_cache.insert(entry.scene.clone(), release.answered_questions(&entry.scene).map_err(ScoreError::Service)?);
        }
        let Some(questions) = &questions_cache[&entry.scene] else { continue };
        let Some(subset) = release.scene(&entry.scene).map(|s| s.subset) else { continue };
        let team = match &entry.answers {
            Some(path) => team_answers(path, &format!("answers/{}/{}.json", entry.lighting, entry.scene)).map_err(ScoreError::Submission)?,
            None => BTreeMap::new(),
        };
        let graph_name = format!("graphs/{}/{}.json", entry.lighting, entry.scene);
        let graph_json = read_graph(entry, &graph_name).map_err(ScoreError::Submission)?;
        let graph = graph_json.as_ref().map(|g| SceneGraph::parse(g, &graph_name)).transpose().map_err(ScoreError::Submission)?;
        let classified = graph.as_ref().map(|g| ClassifiedGraph::with_features(g, &classes, vocabulary.as_ref()));
        let mut answers = answer_questions(questions, &team, classified.as_ref(), graph_json.as_ref(), open.answerer);
        judge_answers(questions, &mut answers, open.judge);
        tally.add_scene(entry, subset, questions, &answers);
    }
    if tally.judged.is_empty() {
        return Ok(None);
    }
    let (lightings, all_lightings) = summarize(&tally.judged);
    Ok(Some(VqaScores { all_lightings, answered_by: tally.answered_by, judged_by: tally.judged_by, lightings, scenes: tally.per_scene }))
}

/// The scene graph file of `entry` (named `graph_name` in errors) as JSON, if it has one.
fn read_graph(entry: &SceneEntry, graph_name: &str) -> Result<Option<Value>> {
    let graph_json: Option<Value> = match &entry.graph {
        Some(path) => Some(
            serde_json::from_slice(&std::fs::read(path).map_err(|e| InputError::io(graph_name, &e))?)
                .map_err(|e| InputError::new(graph_name, "(json)", e.to_string()))?,
        ),
        None => None,
    };
    Ok(graph_json)
}

/// Every question of a scene answered: the team's own answer, else the symbolic answerer
/// on the `classified` graph, else (with a graph) the open `answerer`, else no answer.
fn answer_questions(
    questions: &SceneQuestions,
    team: &BTreeMap<String, Value>,
    classified: Option<&ClassifiedGraph>,
    graph_json: Option<&Value>,
    answerer: Option<&dyn OpenAnswerer>,
) -> Vec<Answered> {
    let mut answers: Vec<Answered> = Vec::with_capacity(questions.questions.len());
    let mut open_questions = Vec::new();
    for q in &questions.questions {
        let (answer, by) = if let Some(a) = team.get(&q.id) {
            (super::text::python_str(a), AnsweredBy::Team)
        } else if let (Some(g), Some(form)) = (classified, &q.form) {
            (g.answer(form), AnsweredBy::Symbolic)
        } else {
            if graph_json.is_some() && answerer.is_some() {
                open_questions.push((answers.len(), q.id.clone(), q.question.clone()));
            }
            (NO_ANSWER.to_string(), AnsweredBy::None)
        };
        answers.push(Answered { id: q.id.clone(), answer, by, verdict: None });
    }
    if let (Some(answerer), Some(g)) = (answerer, graph_json)
        && !open_questions.is_empty()
    {
        let asked: Vec<(String, String)> = open_questions.iter().map(|(_, id, text)| (id.clone(), text.clone())).collect();
        for ((slot, _, _), reply) in open_questions.iter().zip(answerer.answer(g, &asked)) {
            if let Some(reply) = reply {
                answers[*slot].answer = reply;
                answers[*slot].by = AnsweredBy::Llm;
            }
        }
    }
    answers
}

/// Judge every answer: by rule where the rules settle it, else (for an answer given) by
/// the open `judge` in batches of ten, if there is one.
fn judge_answers(questions: &SceneQuestions, answers: &mut [Answered], judge: Option<&dyn OpenJudge>) {
    let mut pending = Vec::new();
    for (k, (q, a)) in questions.questions.iter().zip(answers.iter_mut()).enumerate() {
        let truth = Value::String(q.answer.clone().unwrap_or_default());
        a.verdict = judge_without_llm(&truth, &Value::String(a.answer.clone()), q.form.as_ref(), None);
        if a.verdict.is_none() && a.by != AnsweredBy::None {
            pending.push(k);
        }
    }
    if let Some(judge) = judge {
        for batch in pending.chunks(10) {
            let items: Vec<Pending> = batch
                .iter()
                .map(|&k| Pending {
                    question: questions.questions[k].question.clone(),
                    answer: questions.questions[k].answer.clone().unwrap_or_default(),
                    scene_graph_answer: answers[k].answer.clone(),
                })
                .collect();
            for (&k, verdict) in batch.iter().zip(judge.judge(&items)) {
                answers[k].verdict = verdict.map(|correct| Verdict { correct, by: JudgedBy::Llm });
            }
        }
    }
}

/// The judged questions of every scene so far, who answered and judged them, and each
/// scene's answer rows.
#[derive(Default)]
struct Tally {
    judged: Vec<JudgedQuestion>,
    answered_by: BTreeMap<AnsweredBy, u64>,
    judged_by: BTreeMap<JudgedBy, u64>,
    per_scene: BTreeMap<Lighting, BTreeMap<String, SceneAnswers>>,
}

impl Tally {
    /// Add the judged `answers` of `entry`'s scene (of `subset`).
    fn add_scene(&mut self, entry: &SceneEntry, subset: Regime, questions: &SceneQuestions, answers: &[Answered]) {
        let mut rows = Vec::with_capacity(answers.len());
        let (mut right, total) = (0u64, answers.len() as u64);
        for (q, a) in questions.questions.iter().zip(answers) {
            let correct = a.verdict.is_some_and(|v| v.correct);
            right += correct as u64;
            let by = a.verdict.map_or(JudgedBy::None, |v| v.by);
            *self.answered_by.entry(a.by).or_default() += 1;
            *self.judged_by.entry(by).or_default() += 1;
            self.judged.push(JudgedQuestion { scene: entry.scene.clone(), subset, lighting: entry.lighting, category: q.category.clone(), correct });
            rows.push(AnswerRow { answer: a.answer.clone(), answered_by: a.by, category: q.category.clone(), correct, id: a.id.clone(), judged_by: by });
        }
        self.per_scene.entry(entry.lighting).or_default().insert(entry.scene.clone(), SceneAnswers { answers: rows, correct: right, total });
    }
}
