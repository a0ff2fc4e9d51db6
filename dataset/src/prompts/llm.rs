//! Prompts written by an LLM behind an OpenAI-compatible `/chat/completions`
//! endpoint. The model is asked for the paragraph *and* its structured spec in JSON;
//! both go through the same filters and agreement checks as the grammar's output.

use serde::Deserialize;
use serde_json::Value;

use super::{PromptJudge, PromptPool, RejectedPrompt, ScenePrompt, filters::Rejection};
use crate::openai::{ServiceClient, ServiceError};
use crate::spec::{Regime, SceneSpec};

/// Rooms suggested to the model, one per batch, as OSMa-Bench++ does.
const ROOM_HINTS: &[&str] = &[
    "kitchen",
    "bedroom",
    "living room",
    "office",
    "dining room",
    "storage room",
    "hallway",
    "laundry room",
    "home office",
    "workshop",
    "garage",
    "utility room",
    "entryway",
    "kids room",
    "guest room",
    "meeting room",
    "reception area",
    "study",
];

fn system_prompt(regime: Regime) -> String {
    let regime_rules = match regime {
        Regime::Furniture => {
            "Furniture only: floor-supported furniture such as tables, chairs, sofas, beds, cabinets, shelves, desks, counters. No small objects \
             (books, cups, bottles, boxes, lamps, electronics, decorations). Use at least 4 explicit counts and at least 5 objects in total."
        }
        Regime::Manipuland => {
            "Furniture defines the layout. Include exactly one main small target object (such as a box, book, laptop, mug, bottle, bowl, plate, \
             towel, pillow or bucket) on, under or inside a piece of furniture, and at most one small secondary group. Use at least 3 explicit \
             counts and 4 to 18 objects in total."
        }
    };
    format!(
        "You write compact, simulation-friendly indoor scene prompts for a 3D scene synthesizer.\n\
         Rules:\n- Output JSON only.\n- {regime_rules}\n- Give every object category an exact Arabic numeral count, exactly once in the text \
         (never repeat a number for the same objects).\n- No vague quantifiers (several, some, many, few, multiple, various).\n- No colours, \
         materials, styles, people, actions, viewpoints, occlusion or visibility wording.\n- Use explicit geometric relations: on, under, inside, \
         between, behind, in front of, next to, near, around, facing, opposite, parallel to, against the wall, along the wall, in the corner of \
         the room, in the center of the room.\n- 3 to 7 sentences, 30 to 150 words. No ids like chair#1, no brackets.\n\
         For each prompt also give its structured spec: {{\"room\": str, \"objects\": [{{\"category\": singular lower-case name as written, \
         \"count\": int, \"kind\": \"furniture\"|\"manipuland\"}}], \"relations\": [{{\"subject\": category, \"kind\": one of on, under, inside, \
         next_to, near, between, behind, in_front_of, around, facing, opposite, parallel_to, against_wall, along_wall, in_corner, \
         center_of_room, \"targets\": [categories: none for wall/corner/center relations, two for between, else one]}}]}}."
    )
}

fn user_prompt(batch: usize, room: &str) -> String {
    format!("Write {batch} different scene prompts. Soft room hint: {room}.\nReturn JSON: {{\"prompts\": [{{\"prompt\": \"...\", \"spec\": {{...}}}}]}}")
}

#[derive(Deserialize)]
struct SpecWithoutRegime {
    room: String,
    objects: Vec<crate::spec::ObjectSpec>,
    #[serde(default)]
    relations: Vec<crate::spec::Relation>,
}

/// Ask the model for `count` prompts of `regime` in batches of `batch`, judging them
/// as they come; `max_requests` bounds the calls. When the service fails, the error
/// comes with the pool gathered so far.
pub fn llm_pool(client: &ServiceClient, regime: Regime, count: usize, batch: usize, max_requests: usize) -> Result<PromptPool, (PromptPool, ServiceError)> {
    let mut pool = PromptPool { regime, accepted: Vec::new(), rejected: Vec::new() };
    let mut judge = PromptJudge::new(regime);
    let mut next = 0usize;
    for request in 0..max_requests {
        if pool.accepted.len() >= count {
            break;
        }
        let room = ROOM_HINTS[request % ROOM_HINTS.len()];
        let reply = match client.chat_json(&system_prompt(regime), &user_prompt(batch, room), 0.9) {
            Ok(reply) => reply,
            Err(err) => return Err((pool, err)),
        };
        let items = reply["prompts"].as_array().cloned().unwrap_or_default();
        if items.is_empty() {
            pool.rejected.push(RejectedPrompt {
                id: format!("{}-llm-request-{request}", regime.name()),
                text: String::new(),
                reasons: vec![Rejection::SpecMismatch],
                details: vec!["the reply has no 'prompts' list".into()],
            });
        }
        let mut candidates = Vec::new();
        for item in items {
            next += 1;
            let id = format!("{}-{next:04}", regime.name());
            let text = item["prompt"].as_str().unwrap_or_default().to_string();
            match parse_spec(&item["spec"], regime) {
                Ok(spec) => candidates.push(ScenePrompt { id, source: format!("llm:{}", client.model()), text, spec, layout_seed: None }),
                Err(problem) => pool.rejected.push(RejectedPrompt { id, text, reasons: vec![Rejection::SpecMismatch], details: vec![problem] }),
            }
        }
        for candidate in candidates {
            match judge.judge(candidate) {
                Ok(p) => pool.accepted.push(p),
                Err(r) => pool.rejected.push(r),
            }
        }
    }
    pool.accepted.truncate(count);
    Ok(pool)
}

fn parse_spec(value: &Value, regime: Regime) -> Result<SceneSpec, String> {
    let spec: SpecWithoutRegime = serde_json::from_value(value.clone()).map_err(|e| format!("spec is not valid: {e}"))?;
    Ok(SceneSpec { regime, room: spec.room, objects: spec.objects, relations: spec.relations })
}
