//! Visual question answering, the other half of scoring (product.md section 6):
//! questions with a machine-readable form ([`Question`], [`QuestionForm`]), scene graphs
//! ([`graph`]), the deterministic symbolic answerer ([`answer`]), OSMa-Bench's judging
//! ([`judge`]) and its files and metrics ([`osma`]), and pooled accuracies with bootstrap
//! intervals ([`aggregate`]).

pub mod aggregate;
pub mod answer;
pub mod graph;
pub mod judge;
pub mod osma;
pub mod score;
pub mod text;

use serde::{Deserialize, Serialize};

/// The OSMa-Bench (v1) view-dependent categories, as in the published files.
pub const STANDARD_CATEGORIES: [&str; 8] = [
    "Binary Existence-Based",
    "Binary General",
    "Binary Logical",
    "Comparison",
    "Measurement",
    "Object Attributes",
    "Object Relations - Functional",
    "Object Relations - Spatial",
];

/// The prompt-grounded categories of OSMa-Bench++.
pub const PROMPT_CATEGORIES: [&str; 3] = ["PromptGT-Existence", "PromptGT-Measurement", "PromptGT-Relations"];

/// Whether `category` is prompt-grounded.
pub fn is_prompt_grounded(category: &str) -> bool {
    crate::scores::QuestionSet::of_category(category) == crate::scores::QuestionSet::PromptGrounded
}

/// A spatial relation between two objects, as prompts state them.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Relation {
    On,
    Under,
    Inside,
    NextTo,
    Near,
    Behind,
    InFrontOf,
    LeftOf,
    RightOf,
}

impl Relation {
    /// The relation's words in a question ("on", "next to").
    pub fn words(self) -> &'static str {
        match self {
            Relation::On => "on",
            Relation::Under => "under",
            Relation::Inside => "inside",
            Relation::NextTo => "next to",
            Relation::Near => "near",
            Relation::Behind => "behind",
            Relation::InFrontOf => "in front of",
            Relation::LeftOf => "to the left of",
            Relation::RightOf => "to the right of",
        }
    }
}

/// What a question asks, in a form a program can answer from a scene graph and judge.
/// Class names are release classes (lower case, as in classes.json).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum QuestionForm {
    /// Is there a `class`? Yes/No.
    Exists { class: String },
    /// Are all of `classes` there (AND)? Yes/No.
    ExistsAll { classes: Vec<String> },
    /// Is any of `classes` there (OR)? Yes/No.
    ExistsAny { classes: Vec<String> },
    /// How many `class` objects? Digits.
    Count { class: String },
    /// Is a `subject` `relation` a `object`? Yes/No.
    Related { subject: String, relation: Relation, object: String },
    /// Are there more `more` objects than `fewer` objects? Yes/No.
    MoreThan { more: String, fewer: String },
    /// Which is larger (bounding-box volume), the `a` or the `b`? A class name.
    Larger { a: String, b: String },
    /// What colour is the `class`? A colour name.
    Colour { class: String },
    /// Is the `class` `colour`? Yes/No.
    HasColour { class: String, colour: String },
    /// What object is closest to the `class`? A class name.
    Nearest { class: String },
    /// What is the `class` resting on? A class name or "floor".
    Support { class: String },
    /// Is the `class` resting on the `support` (a class or "floor")? Yes/No.
    RestsOn { class: String, support: String },
    /// Is the `nearest` the object closest to the `class`? Yes/No.
    NearestIs { class: String, nearest: String },
    /// Is the `a` larger (bounding-box volume) than the `b`? Yes/No.
    LargerThan { a: String, b: String },
}

impl QuestionForm {
    /// The form's kind as its files name it (`exists`, `rests_on`): with the category, the
    /// template a question was made from.
    pub fn kind(&self) -> &'static str {
        match self {
            QuestionForm::Exists { .. } => "exists",
            QuestionForm::ExistsAll { .. } => "exists_all",
            QuestionForm::ExistsAny { .. } => "exists_any",
            QuestionForm::Count { .. } => "count",
            QuestionForm::Related { .. } => "related",
            QuestionForm::MoreThan { .. } => "more_than",
            QuestionForm::Larger { .. } => "larger",
            QuestionForm::Colour { .. } => "colour",
            QuestionForm::HasColour { .. } => "has_colour",
            QuestionForm::Nearest { .. } => "nearest",
            QuestionForm::Support { .. } => "support",
            QuestionForm::RestsOn { .. } => "rests_on",
            QuestionForm::NearestIs { .. } => "nearest_is",
            QuestionForm::LargerThan { .. } => "larger_than",
        }
    }
}

/// One question of a release, with its answer where the release keeps it.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Question {
    /// Unique within the scene (`<scene>-p03`, `<scene>-s12`).
    pub id: String,
    pub category: String,
    pub question: String,
    /// The ground-truth answer (digits, `Yes`/`No`, or words); absent in public files.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub answer: Option<String>,
    /// The machine-readable form, when the question has one.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub form: Option<QuestionForm>,
}

/// The questions of one scene (`questions/<scene>.json` without answers in a release;
/// `ground_truth/questions/<scene>.json` with them).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SceneQuestions {
    pub scene: String,
    pub questions: Vec<Question>,
}

impl SceneQuestions {
    /// The public copy: the same questions without their answers.
    pub fn without_answers(&self) -> SceneQuestions {
        SceneQuestions { scene: self.scene.clone(), questions: self.questions.iter().map(|q| Question { answer: None, ..q.clone() }).collect() }
    }

    /// Read and check a questions file (unique ids, known categories).
    pub fn read(path: &std::path::Path) -> crate::Result<SceneQuestions> {
        let bytes = std::fs::read(path).map_err(|e| crate::InputError::io(path, &e))?;
        let parsed: SceneQuestions =
            serde_json::from_slice(&bytes).map_err(|e| crate::InputError::new(path, "(json)", format!("expected {{\"scene\", \"questions\": [...]}}: {e}")))?;
        let mut seen = std::collections::BTreeSet::new();
        for (i, q) in parsed.questions.iter().enumerate() {
            if !seen.insert(q.id.as_str()) {
                return Err(crate::InputError::new(path, format!("questions[{i}].id"), format!("'{}' appears twice", q.id)));
            }
            if !STANDARD_CATEGORIES.contains(&q.category.as_str()) && !PROMPT_CATEGORIES.contains(&q.category.as_str()) {
                return Err(crate::InputError::new(path, format!("questions[{i}].category"), format!("unknown category '{}'", q.category)));
            }
        }
        Ok(parsed)
    }
}
