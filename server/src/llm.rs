//! The optional LLM side of VQA, through any OpenAI-compatible endpoint: a judge for
//! answers no rule decides, and an answerer for questions without a machine-readable
//! form. Prompts follow OSMa-Bench's, but every item carries an id and replies are
//! merged by id, not by position, so an item the model drops stays undecided instead of
//! shifting every verdict after it.

use osmab_dataset::openai::{ServiceClient, ServiceConfig};
use osmab_evaluator::vqa::judge::{OpenJudge, Pending};
use osmab_evaluator::vqa::score::OpenAnswerer;
use serde_json::{Value, json};

/// The endpoint from `--llm-url`/`--llm-model` and `OSMAB_LLM_API_KEY`.
pub fn client(url: &str, model: &str) -> anyhow::Result<ServiceClient> {
    let mut config = ServiceConfig::new(url, model);
    config.api_key = std::env::var("OSMAB_LLM_API_KEY").ok().filter(|k| !k.is_empty());
    Ok(ServiceClient::new(config)?)
}

/// The `{"id": …, <field>: …}` items of a JSON-mode reply (`{"items": [...]}` or a bare list).
fn replies(reply: &Value) -> Vec<&Value> {
    let list = reply.get("items").or_else(|| reply.get("entries")).unwrap_or(reply);
    list.as_array().map(|a| a.iter().collect()).unwrap_or_default()
}

/// The LLM judge.
pub struct LlmJudge {
    pub client: ServiceClient,
}

impl OpenJudge for LlmJudge {
    fn judge(&self, pending: &[Pending]) -> Vec<Option<bool>> {
        let items: Vec<Value> = pending
            .iter()
            .enumerate()
            .map(|(i, p)| json!({"id": i, "question": p.question, "answer": p.answer, "scene_graph_answer": p.scene_graph_answer}))
            .collect();
        let user = format!(
            "Compare ground truth answers ('answer') and scene-graph answers ('scene_graph_answer'). Add a 'similar':'Yes'/'No' field to each entry. \
             Reply with {{\"items\": [{{\"id\", \"similar\"}}]}}.\nQuestions: ```json\n{}\n```",
            serde_json::to_string_pretty(&items).expect("json")
        );
        let mut verdicts = vec![None; pending.len()];
        match self.client.chat_json("You judge answers to questions about a 3D scene.", &user, 0.0) {
            Ok(reply) => {
                for item in replies(&reply) {
                    let id = item.get("id").and_then(Value::as_u64).map(|i| i as usize);
                    let similar = item.get("similar").and_then(Value::as_str).map(|s| s.trim().eq_ignore_ascii_case("yes"));
                    if let (Some(id), Some(similar)) = (id, similar)
                        && id < verdicts.len()
                    {
                        verdicts[id] = Some(similar);
                    }
                }
            }
            Err(e) => tracing::warn!(error = %e, "the LLM judge failed; those answers stay undecided"),
        }
        verdicts
    }
}

/// The LLM answerer.
pub struct LlmAnswerer {
    pub client: ServiceClient,
}

impl OpenAnswerer for LlmAnswerer {
    fn answer(&self, graph: &Value, questions: &[(String, String)]) -> Vec<Option<String>> {
        answer_with_llm(&self.client, graph, questions)
    }
}

/// The LLM answerer and judge of the service's settings, if configured.
pub fn from_settings(settings: &crate::config::Settings) -> anyhow::Result<Option<(LlmAnswerer, LlmJudge)>> {
    match (&settings.llm_url, &settings.llm_model) {
        (Some(url), Some(model)) => Ok(Some((LlmAnswerer { client: client(url, model)? }, LlmJudge { client: client(url, model)? }))),
        _ => Ok(None),
    }
}

/// `questions` (id, text) about `scene_graph`, answered in batches of 10; answers by id.
pub fn answer_with_llm(client: &ServiceClient, scene_graph: &Value, questions: &[(String, String)]) -> Vec<Option<String>> {
    let mut answers = vec![None; questions.len()];
    for (chunk_index, chunk) in questions.chunks(10).enumerate() {
        let items: Vec<Value> = chunk.iter().map(|(id, q)| json!({"id": id, "question": q})).collect();
        let user = format!(
            "Answer the following questions based ONLY on the provided scene graph. Add an 'answer' field to each question. \
             If Yes/No expected, answer strictly 'Yes' or 'No'. If counting, answer strictly as a number. Reply with {{\"items\": [{{\"id\", \"answer\"}}]}}.\n\
             Scene graph: ```json\n{}\n```\nQuestions: ```json\n{}\n```",
            serde_json::to_string(scene_graph).expect("json"),
            serde_json::to_string_pretty(&items).expect("json")
        );
        match client.chat_json("You answer questions about a 3D scene from its scene graph.", &user, 0.0) {
            Ok(reply) => {
                for item in replies(&reply) {
                    let (Some(id), Some(answer)) = (item.get("id").and_then(Value::as_str), item.get("answer")) else { continue };
                    if let Some(k) = chunk.iter().position(|(qid, _)| qid == id) {
                        answers[chunk_index * 10 + k] = Some(osmab_evaluator::vqa::text::python_str(answer));
                    }
                }
            }
            Err(e) => tracing::warn!(error = %e, "the LLM answerer failed; those questions stay unanswered"),
        }
    }
    answers
}
