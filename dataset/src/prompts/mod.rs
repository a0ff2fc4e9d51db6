//! Scene prompts: natural-language paragraphs with their structured specification,
//! written by the built-in grammar or an LLM, and kept only if they pass the
//! OSMa-Bench++ rule filters and agree with their spec.

pub mod filters;
pub mod grammar;
pub mod llm;

use std::collections::HashSet;

use serde::{Deserialize, Serialize};

use crate::spec::{Regime, SceneSpec};
use filters::{FilterRules, Rejection, dedup_key, explicit_numbers, rejections};

/// One scene prompt.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct ScenePrompt {
    /// Stable id (`furniture-0007`).
    pub id: String,
    /// Which backend wrote it (`grammar`, `llm:<model>`).
    pub source: String,
    /// The paragraph given to the scene synthesizer.
    pub text: String,
    /// What the paragraph says, machine-readable.
    pub spec: SceneSpec,
    /// For grammar prompts: the seed of the layout the prompt describes. Placing the
    /// spec's primary relations with it reproduces that layout, so every stated
    /// relation holds.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub layout_seed: Option<u64>,
}

/// A prompt that did not make it, and why.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct RejectedPrompt {
    pub id: String,
    pub text: String,
    pub reasons: Vec<Rejection>,
    /// Details of a spec mismatch, when that is a reason.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub details: Vec<String>,
}

/// The outcome of writing a pool of prompts for one regime.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct PromptPool {
    pub regime: Regime,
    pub accepted: Vec<ScenePrompt>,
    pub rejected: Vec<RejectedPrompt>,
}

/// Problems between a prompt's text and its spec: the spec must be valid, name every
/// category in the text, and its counts must be the text's numerals.
pub fn spec_mismatches(text: &str, spec: &SceneSpec) -> Vec<String> {
    let mut problems = spec.problems();
    let lower = text.to_lowercase();
    for o in &spec.objects {
        let plural = grammar::plural(&o.category);
        if !lower.contains(&o.category) && !lower.contains(&plural) {
            problems.push(format!("category '{}' does not appear in the text", o.category));
        }
    }
    let mut numerals = explicit_numbers(text);
    let mut counts: Vec<u64> = spec.objects.iter().map(|o| o.count as u64).collect();
    numerals.sort_unstable();
    counts.sort_unstable();
    if numerals != counts {
        problems.push(format!("the text's numerals {numerals:?} are not the spec's counts {counts:?}"));
    }
    problems
}

/// Judges prompts one at a time: rule filters, spec agreement, and exact duplicates
/// of any prompt it accepted before.
pub struct PromptJudge {
    regime: Regime,
    rules: FilterRules,
    seen: HashSet<String>,
}

impl PromptJudge {
    /// A judge for `regime` that has seen nothing yet.
    pub fn new(regime: Regime) -> Self {
        Self { regime, rules: FilterRules::for_regime(regime), seen: HashSet::new() }
    }

    /// Accept `prompt`, or say why not.
    pub fn judge(&mut self, prompt: ScenePrompt) -> Result<ScenePrompt, RejectedPrompt> {
        let mut reasons = rejections(&prompt.text, &self.rules);
        let details = if prompt.spec.regime == self.regime {
            spec_mismatches(&prompt.text, &prompt.spec)
        } else {
            vec![format!("spec regime is {}", prompt.spec.regime.name())]
        };
        if !details.is_empty() {
            reasons.push(Rejection::SpecMismatch);
        }
        if reasons.is_empty() && !self.seen.insert(dedup_key(&prompt.text)) {
            reasons.push(Rejection::ExactDuplicate);
        }
        if reasons.is_empty() { Ok(prompt) } else { Err(RejectedPrompt { id: prompt.id, text: prompt.text, reasons, details }) }
    }
}

/// Judge candidate prompts in order: rule filters, spec agreement, exact duplicates.
pub fn judge(regime: Regime, candidates: impl IntoIterator<Item = ScenePrompt>) -> PromptPool {
    let mut judge = PromptJudge::new(regime);
    let mut pool = PromptPool { regime, accepted: Vec::new(), rejected: Vec::new() };
    for prompt in candidates {
        match judge.judge(prompt) {
            Ok(p) => pool.accepted.push(p),
            Err(r) => pool.rejected.push(r),
        }
    }
    pool
}

/// Write `count` prompts of `regime` with the built-in grammar from `seed`, keeping
/// those that pass (at most `20 × count + 100` tries), each describing a layout of the
/// procedural library's assets.
pub fn grammar_pool(regime: Regime, count: usize, seed: u64) -> PromptPool {
    grammar_pool_with(regime, count, seed, &crate::synthesis::source::AssetSource::procedural())
}

/// [`grammar_pool`] with each prompt describing a layout of `assets`, the assets its scene
/// will be synthesized from.
pub fn grammar_pool_with(regime: Regime, count: usize, seed: u64, assets: &crate::synthesis::source::AssetSource) -> PromptPool {
    let mut rng = osmab_evaluator::synthetic::Rng::new(seed ^ (regime as u64 + 1).wrapping_mul(0x51_7C_C1_B7_27_22_0A_95));
    let mut judge = PromptJudge::new(regime);
    let mut pool = PromptPool { regime, accepted: Vec::new(), rejected: Vec::new() };
    let attempts = count * 20 + 100;
    for next in 1..=attempts {
        if pool.accepted.len() == count {
            break;
        }
        let (text, spec, layout_seed, unmet) = grammar::write_prompt(regime, &mut rng, assets);
        let id = format!("{}-{next:04}", regime.name());
        if !unmet.is_empty() {
            pool.rejected.push(RejectedPrompt { id, text, reasons: vec![Rejection::UnplaceableLayout], details: unmet });
            continue;
        }
        match judge.judge(ScenePrompt { id, source: "grammar".into(), text, spec, layout_seed: Some(layout_seed) }) {
            Ok(p) => pool.accepted.push(p),
            Err(r) => pool.rejected.push(r),
        }
    }
    pool
}
