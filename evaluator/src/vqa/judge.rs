//! Judging an answer against the ground truth as OSMa-Bench does: both answers through
//! `str(x).strip().lower()`; two yes/no answers, or two numbers, are equal or not (string
//! equality: "2" is not "2.0"). Everything else goes, in order, to a rule for the
//! question's machine-readable form, to an optional LLM judge, or keeps a verdict
//! recorded earlier; what none of them decides stays undecided and counts as wrong.

use serde::{Deserialize, Serialize};
use serde_json::Value;

use super::QuestionForm;
use super::graph::{mentions_class, names_class};
use super::text::{is_number, is_yes_no, normalise};

/// Who decided a verdict. Ordered by name, as the keys of a score document.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize, schemars::JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum JudgedBy {
    /// Yes/no or number, by exact normalised equality.
    Local,
    /// A verdict already in the input (`similar`), kept.
    Recorded,
    /// The rule for the question's machine-readable form.
    Rule,
    /// The LLM judge.
    Llm,
    /// Nobody: counted as wrong.
    None,
}

impl JudgedBy {
    /// Every judge, in the order they are tried.
    pub const ALL: [JudgedBy; 5] = [JudgedBy::Local, JudgedBy::Recorded, JudgedBy::Rule, JudgedBy::Llm, JudgedBy::None];

    pub fn name(self) -> &'static str {
        match self {
            JudgedBy::Local => "local",
            JudgedBy::Recorded => "recorded",
            JudgedBy::Rule => "rule",
            JudgedBy::Llm => "llm",
            JudgedBy::None => "none",
        }
    }
}

impl Ord for JudgedBy {
    fn cmp(&self, other: &Self) -> std::cmp::Ordering {
        self.name().cmp(other.name())
    }
}

impl PartialOrd for JudgedBy {
    fn partial_cmp(&self, other: &Self) -> Option<std::cmp::Ordering> {
        Some(self.cmp(other))
    }
}

/// A verdict: whether the answer is right, and who said so.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub struct Verdict {
    pub correct: bool,
    pub by: JudgedBy,
}

/// OSMa-Bench's local rule: `Some(equal)` when both answers are yes/no or both are
/// numbers, `None` when the judge would send the pair to the LLM.
pub fn judge_locally(answer: &Value, predicted: &Value) -> Option<bool> {
    let (gt, pred) = (normalise(answer), normalise(predicted));
    ((is_yes_no(&gt) && is_yes_no(&pred)) || (is_number(&gt) && is_number(&pred))).then(|| gt == pred)
}

/// The rule for a form whose answer is words (a class, a colour): the prediction must
/// name the same class or colour and no other candidate of the question. `None` when the
/// form's answers are yes/no or numbers (those are judged locally or not at all).
pub fn judge_by_form(form: &QuestionForm, answer: &str, predicted: &str) -> Option<bool> {
    let predicted = predicted.trim().to_lowercase();
    let answer = answer.trim().to_lowercase();
    match form {
        QuestionForm::Larger { a, b } => {
            let other = if answer == *a { b } else { a };
            let both = [a.as_str(), b.as_str()];
            Some(names_class(&predicted, &answer, &both) && !names_class(&predicted, other, &both))
        }
        QuestionForm::Nearest { .. } | QuestionForm::Support { .. } => Some(mentions_class(&predicted, &answer)),
        QuestionForm::Colour { .. } => Some(predicted.split(|c: char| !c.is_alphanumeric()).any(|w| w == answer)),
        _ => None,
    }
}

/// A recorded `similar` verdict: "Yes" (any case) is right; "No", "N/A" or anything
/// else is wrong, as the reference's metrics count them.
pub fn recorded(similar: &Value) -> Option<bool> {
    match similar {
        Value::Null => None,
        Value::String(s) => Some(s.trim().eq_ignore_ascii_case("yes")),
        other => Some(normalise(other) == "yes"),
    }
}

/// One answer to judge beyond the local rule.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Pending {
    pub question: String,
    pub answer: String,
    pub scene_graph_answer: String,
}

/// A judge for what the rules cannot decide (an LLM through an OpenAI-compatible API).
pub trait OpenJudge {
    /// Verdicts for `pending`, in order; `None` where it gave none.
    fn judge(&self, pending: &[Pending]) -> Vec<Option<bool>>;
}

/// Judge one answer: local rule, form rule, recorded verdict, open judge (deferred:
/// returns `None` so the caller can batch those), in that order.
pub fn judge_without_llm(answer: &Value, predicted: &Value, form: Option<&QuestionForm>, similar: Option<&Value>) -> Option<Verdict> {
    if let Some(correct) = judge_locally(answer, predicted) {
        return Some(Verdict { correct, by: JudgedBy::Local });
    }
    if let Some(correct) = form.and_then(|f| judge_by_form(f, &super::text::python_str(answer), &super::text::python_str(predicted))) {
        return Some(Verdict { correct, by: JudgedBy::Rule });
    }
    similar.and_then(recorded).map(|correct| Verdict { correct, by: JudgedBy::Recorded })
}

/// [`judge_without_llm`] of a textual `answer` and `predicted` answer, without a recorded verdict.
pub fn judge_text_without_llm(answer: &str, predicted: &str, form: Option<&QuestionForm>) -> Option<Verdict> {
    judge_without_llm(&Value::from(answer), &Value::from(predicted), form, None)
}

#[cfg(test)]
mod tests {
    use super::*;
    use serde_json::json;

    #[test]
    fn yes_no_and_numbers_are_judged_locally_by_exact_text() {
        assert_eq!(judge_locally(&json!("Yes"), &json!(" yes ")), Some(true));
        assert_eq!(judge_locally(&json!("No"), &json!("Yes")), Some(false));
        assert_eq!(judge_locally(&json!("2"), &json!("2.0")), Some(false), "string equality, no tolerance");
        assert_eq!(judge_locally(&json!(3), &json!("3")), Some(true));
        assert_eq!(judge_locally(&json!("Yes"), &json!("2")), None, "mixed kinds go to the LLM");
        assert_eq!(judge_locally(&json!("red"), &json!("red")), None, "words go to the LLM even when equal");
        assert_eq!(judge_locally(&json!("Yes"), &json!("Yes.")), None);
    }

    #[test]
    fn word_answers_follow_their_form() {
        let larger = QuestionForm::Larger { a: "sofa".into(), b: "chair".into() };
        assert_eq!(judge_by_form(&larger, "sofa", "The sofa"), Some(true));
        assert_eq!(judge_by_form(&larger, "sofa", "sofa and chair"), Some(false), "naming both candidates is no answer");
        assert_eq!(judge_by_form(&larger, "sofa", "chairs"), Some(false));
        // One name inside the other: "dining chair" names the dining chair, not the chair.
        let nested = QuestionForm::Larger { a: "chair".into(), b: "dining chair".into() };
        assert_eq!(judge_by_form(&nested, "dining chair", "the dining chair"), Some(true));
        assert_eq!(judge_by_form(&nested, "dining chair", "the chair"), Some(false));
        assert_eq!(judge_by_form(&nested, "chair", "the chair"), Some(true));
        assert_eq!(judge_by_form(&nested, "chair", "the dining chair"), Some(false));
        assert_eq!(judge_by_form(&nested, "chair", "the chair, not the dining chair"), Some(false), "naming both is no answer");
        let colour = QuestionForm::Colour { class: "sofa".into() };
        assert_eq!(judge_by_form(&colour, "red", "It is red."), Some(true));
        assert_eq!(judge_by_form(&colour, "red", "reddish"), Some(false));
        assert_eq!(judge_by_form(&QuestionForm::Count { class: "chair".into() }, "2", "two"), None);
    }

    #[test]
    fn verdicts_come_from_local_rule_then_form_then_record() {
        let support = QuestionForm::Support { class: "cup".into() };
        assert_eq!(judge_without_llm(&json!("No"), &json!("no"), None, Some(&json!("No"))), Some(Verdict { correct: true, by: JudgedBy::Local }));
        assert_eq!(judge_without_llm(&json!("table"), &json!("a table"), Some(&support), None), Some(Verdict { correct: true, by: JudgedBy::Rule }));
        assert_eq!(judge_without_llm(&json!("wood"), &json!("wooden"), None, Some(&json!("Yes"))), Some(Verdict { correct: true, by: JudgedBy::Recorded }));
        assert_eq!(judge_without_llm(&json!("wood"), &json!("x"), None, Some(&json!("N/A"))), Some(Verdict { correct: false, by: JudgedBy::Recorded }));
        assert_eq!(judge_without_llm(&json!("wood"), &json!("wooden"), None, None), None);
    }
}
