//! The rule filters of OSMa-Bench++ (`validate_prompt`): word and sentence counts,
//! explicit numerals, spatial cues, object totals, vague quantifiers, risky and
//! forbidden phrases, a "strong" relation, a known object.
//!
//! Phrases match on word boundaries, where the reference matched raw substrings (so
//! its "some" also hit "handsome" and "few" hit "curfew"); every other threshold is
//! the reference's.

use serde::{Deserialize, Serialize};

use crate::classes::{Role, table};
use crate::spec::Regime;

/// Thresholds and phrase lists of one regime.
#[derive(Debug, Clone)]
pub struct FilterRules {
    pub min_words: usize,
    pub max_words: usize,
    pub min_explicit_counts: usize,
    pub min_spatial_cues: usize,
    pub min_total_objects: u64,
    pub max_total_objects: Option<u64>,
    pub min_sentences: usize,
    pub max_sentences: usize,
    pub spatial_cues: &'static [&'static str],
    pub vague: &'static [&'static str],
    /// The reference's known objects, and every name of the class table's classes of the
    /// regime's role (so a class added to the table is known without an edit here).
    pub object_hints: Vec<&'static str>,
    pub forbidden_objects: &'static [&'static str],
    pub risky: &'static [&'static str],
    pub strong: &'static [&'static str],
}

/// `reference` and every name of the table's classes of `role`, each once.
fn object_hints(reference: &[&'static str], role: Role) -> Vec<&'static str> {
    let mut hints = reference.to_vec();
    for word in table().prompt_words(role) {
        if !hints.contains(&word) {
            hints.push(word);
        }
    }
    hints
}

const VAGUE: &[&str] = &["several", "some", "many", "few", "multiple", "various", "a couple of", "a few", "lots of", "a set of", "a group of"];

impl FilterRules {
    /// The rules of `regime`.
    pub fn for_regime(regime: Regime) -> Self {
        match regime {
            Regime::Furniture => Self {
                min_words: 28,
                max_words: 170,
                min_explicit_counts: 4,
                min_spatial_cues: 2,
                min_total_objects: 5,
                max_total_objects: None,
                min_sentences: 3,
                max_sentences: 7,
                spatial_cues: FURNITURE_SPATIAL_CUES,
                vague: VAGUE,
                object_hints: object_hints(FURNITURE_OBJECT_HINTS, Role::Furniture),
                forbidden_objects: FURNITURE_FORBIDDEN_OBJECTS,
                risky: FURNITURE_RISKY,
                strong: FURNITURE_STRONG,
            },
            Regime::Manipuland => Self {
                min_words: 26,
                max_words: 170,
                min_explicit_counts: 3,
                min_spatial_cues: 2,
                min_total_objects: 4,
                max_total_objects: Some(18),
                min_sentences: 3,
                max_sentences: 7,
                spatial_cues: &["on", "under", "inside", "between", "behind", "next to", "near", "in front of", "against the wall", "along the wall"],
                vague: &VAGUE[..9],
                object_hints: object_hints(MANIPULAND_OBJECT_HINTS, Role::Object),
                forbidden_objects: &[],
                risky: MANIPULAND_RISKY,
                strong: &["under", "inside", "behind", "in front of", "between"],
            },
        }
    }
}

/// Phrases that place furniture relative to furniture or the room.
const FURNITURE_SPATIAL_CUES: &[&str] = &[
    "under",
    "between",
    "behind",
    "next to",
    "near",
    "around",
    "left of",
    "right of",
    "in front of",
    "against the wall",
    "along the wall",
    "facing",
    "surrounding",
    "center of the room",
    "parallel to",
    "opposite",
];

/// Furniture a furniture prompt is expected to name (the reference's list).
const FURNITURE_OBJECT_HINTS: &[&str] = &[
    "table",
    "desk",
    "chair",
    "armchair",
    "sofa",
    "bench",
    "cabinet",
    "bookshelf",
    "shelf",
    "wardrobe",
    "dresser",
    "nightstand",
    "bed",
    "sideboard",
    "counter",
    "island",
    "workbench",
    "storage rack",
    "tv stand",
    "credenza",
];

/// Small objects a furniture prompt must not name.
const FURNITURE_FORBIDDEN_OBJECTS: &[&str] = &[
    "book",
    "books",
    "cup",
    "cups",
    "mug",
    "mugs",
    "bottle",
    "bottles",
    "phone",
    "phones",
    "tool",
    "tools",
    "toy",
    "toys",
    "plate",
    "plates",
    "lamp",
    "lamps",
    "container",
    "containers",
    "box",
    "boxes",
    "sign",
    "signs",
    "remote",
    "monitor",
    "monitors",
    "keyboard",
    "keyboards",
    "laptop",
    "laptops",
    "apple",
    "apples",
    "bag",
    "bags",
    "basket",
    "baskets",
];

/// Phrases a furniture scene cannot honour (odd furniture, views, occlusion).
const FURNITURE_RISKY: &[&str] = &[
    "umbrella stand",
    "ironing board",
    "mirror",
    "pegboard",
    "drying rack",
    "luggage rack",
    "crib",
    "changing table",
    "shoe rack",
    "coat rack",
    "foldable rack",
    "wall shelf",
    "wall shelves",
    "from the entrance",
    "from the doorway",
    "viewed from",
    "visible from",
    "partially occluded",
    "partially blocked",
    "occluded",
    "blocked from view",
    "partially visible",
    "layered depth",
    "foreground",
    "background",
];

/// Relations that make a furniture prompt's layout specific.
const FURNITURE_STRONG: &[&str] = &[
    "between",
    "behind",
    "around",
    "facing",
    "surrounding",
    "parallel to",
    "opposite",
    "along the wall",
    "against the wall",
    "center of the room",
    "narrow passage",
    "constrained space",
    "corridor-like space",
    "u shape",
    "u-shaped",
];

/// Objects a manipuland prompt is expected to name (the reference's list).
const MANIPULAND_OBJECT_HINTS: &[&str] = &[
    "box",
    "container",
    "backpack",
    "suitcase",
    "helmet",
    "clock",
    "pillow",
    "blanket",
    "bucket",
    "can",
    "book",
    "books",
    "laptop",
    "microwave",
    "towel",
    "towels",
    "plate",
    "plates",
    "mug",
    "mugs",
    "bottle",
    "bottles",
    "bowl",
    "bowls",
    "boxes",
    "cans",
];

/// Phrases a manipuland scene cannot honour (clutter, views, occlusion).
const MANIPULAND_RISKY: &[&str] = &[
    "a pile of",
    "scattered",
    "messy",
    "cluttered with many",
    "randomly placed",
    "loosely placed",
    "stacked irregularly",
    "partially visible from",
    "from the doorway",
    "from the entrance",
    "from the side",
    "from the front",
    "direct access",
    "occluded",
    "partially occluded",
    "layered depth",
    "foreground",
    "background",
];

/// Why a prompt was rejected (stable names, as in the reference's analysis files).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Rejection {
    TooShort,
    TooLong,
    VagueWords,
    TooFewExplicitCounts,
    TooFewSpatialCues,
    TooFewTotalObjects,
    TooManyTotalObjects,
    TooFewSentences,
    TooManySentences,
    ContainsIds,
    ContainsStructuralMarkup,
    ContainsForbiddenObjects,
    ContainsRiskyLanguage,
    TooSimple,
    NoRequiredObjectHits,
    /// The structured spec is unusable or disagrees with the text.
    SpecMismatch,
    /// Same text (case and spacing aside) as an earlier prompt.
    ExactDuplicate,
    /// The built-in layout could not place the scene the prompt describes.
    UnplaceableLayout,
}

/// Words of a text, lower case (letters, digits, apostrophes and hyphens).
fn words(text: &str) -> Vec<String> {
    text.split(|c: char| !(c.is_alphanumeric() || c == '\'' || c == '-')).filter(|w| !w.is_empty()).map(|w| w.to_lowercase()).collect()
}

/// Whether `word` is `part` or, for the last word of a phrase, its plural.
fn word_matches(word: &str, part: &str, last: bool) -> bool {
    word == part || (last && (word == crate::prompts::grammar::plural(part) || word.strip_suffix('s') == Some(part)))
}

/// Whether `phrase` occurs in `words` as whole words (its last word also as a plural).
fn has_phrase(words: &[String], phrase: &str) -> bool {
    let parts: Vec<&str> = phrase.split(' ').collect();
    words.windows(parts.len()).any(|w| w.iter().zip(&parts).enumerate().all(|(i, (a, b))| word_matches(a, b, i + 1 == parts.len())))
}

/// The phrases of `list` that occur in `words`.
pub fn phrase_hits(words_of_text: &[String], list: &[&'static str]) -> Vec<&'static str> {
    list.iter().copied().filter(|p| has_phrase(words_of_text, p)).collect()
}

/// The explicit Arabic numerals of a text, in order.
pub fn explicit_numbers(text: &str) -> Vec<u64> {
    words(text).iter().filter(|w| w.chars().all(|c| c.is_ascii_digit())).map(|w| w.parse().unwrap_or(u64::MAX)).collect()
}

/// Sentences: pieces between `.`, `!` and `?` that hold text.
pub fn sentence_count(text: &str) -> usize {
    text.split(['.', '!', '?']).filter(|s| !s.trim().is_empty()).count()
}

/// Measurements of a prompt the filter looks at.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct PromptAnalysis {
    pub word_count: usize,
    pub sentence_count: usize,
    pub explicit_numbers: Vec<u64>,
    pub spatial_hits: Vec<String>,
    pub object_hits: Vec<String>,
}

/// Measure `text`.
pub fn analyze(text: &str, rules: &FilterRules) -> PromptAnalysis {
    let w = words(text);
    PromptAnalysis {
        word_count: w.len(),
        sentence_count: sentence_count(text),
        explicit_numbers: explicit_numbers(text),
        spatial_hits: phrase_hits(&w, rules.spatial_cues).into_iter().map(String::from).collect(),
        object_hits: phrase_hits(&w, &rules.object_hints).into_iter().map(String::from).collect(),
    }
}

/// Every rule `text` breaks (empty: it passes).
pub fn rejections(text: &str, rules: &FilterRules) -> Vec<Rejection> {
    let w = words(text);
    let a = analyze(text, rules);
    let total: u64 = a.explicit_numbers.iter().fold(0u64, |t, &n| t.saturating_add(n));
    let mut out = Vec::new();
    let mut check = |broken: bool, r: Rejection| {
        if broken {
            out.push(r)
        }
    };
    check(a.word_count < rules.min_words, Rejection::TooShort);
    check(a.word_count > rules.max_words, Rejection::TooLong);
    check(!phrase_hits(&w, rules.vague).is_empty(), Rejection::VagueWords);
    check(a.explicit_numbers.len() < rules.min_explicit_counts, Rejection::TooFewExplicitCounts);
    check(a.spatial_hits.len() < rules.min_spatial_cues, Rejection::TooFewSpatialCues);
    check(total < rules.min_total_objects, Rejection::TooFewTotalObjects);
    check(rules.max_total_objects.is_some_and(|m| total > m), Rejection::TooManyTotalObjects);
    check(a.sentence_count < rules.min_sentences, Rejection::TooFewSentences);
    check(a.sentence_count > rules.max_sentences, Rejection::TooManySentences);
    check(text.contains('#'), Rejection::ContainsIds);
    check(text.contains(['{', '}', '[', ']']), Rejection::ContainsStructuralMarkup);
    check(!phrase_hits(&w, rules.forbidden_objects).is_empty(), Rejection::ContainsForbiddenObjects);
    check(!phrase_hits(&w, rules.risky).is_empty(), Rejection::ContainsRiskyLanguage);
    check(phrase_hits(&w, rules.strong).is_empty(), Rejection::TooSimple);
    check(a.object_hits.is_empty(), Rejection::NoRequiredObjectHits);
    out
}

/// The text as the exact-duplicate check sees it: lower case, spaces folded.
pub fn dedup_key(text: &str) -> String {
    text.to_lowercase().split_whitespace().collect::<Vec<_>>().join(" ")
}
