//! The deterministic symbolic answerer: a question's machine-readable form evaluated
//! against a scene graph. Nodes are matched to release classes by [`node_class`];
//! relations come from the boxes (y is up), with the distances the scene synthesizer
//! places by: `on` = the subject's centre over the object's footprint and its base on a
//! surface of the object (at least 5 cm above the object's base, so not on the floor
//! beside or under it, and at most 15 cm above its top: a seat or a shelf supports as
//! well as a top), `under` = below it within its footprint, `inside` = centre within
//! the box, `next to` = footprints within 50 cm, `near` = within 1.2 m; behind, in
//! front of, left and right need a facing or a viewer, which a graph does not have, so
//! they are checked as footprints within 1.5 m (release questions do not ask them).

use serde::{Deserialize, Serialize};

use super::graph::{FeatureVocabulary, GraphObject, SceneGraph, node_class};
use super::{QuestionForm, Relation};

/// Colour words the answerer looks for in node texts (and the generator names).
pub const COLOURS: [&str; 12] = ["black", "white", "grey", "gray", "red", "orange", "yellow", "green", "blue", "purple", "pink", "brown"];

/// What the answerer says when the graph cannot answer.
pub const NO_ANSWER: &str = "No answer";

/// Who produced an answer. Ordered by name, as the keys of a score document.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize, schemars::JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum AnsweredBy {
    /// The team, in `answers/`.
    Team,
    /// The symbolic answerer, from the scene graph.
    Symbolic,
    /// The LLM answerer, from the scene graph.
    Llm,
    /// Nobody (no graph, no form, no LLM): counted as wrong.
    None,
}

impl AnsweredBy {
    /// The name in score documents.
    pub fn name(self) -> &'static str {
        match self {
            AnsweredBy::Team => "team",
            AnsweredBy::Symbolic => "symbolic",
            AnsweredBy::Llm => "llm",
            AnsweredBy::None => "none",
        }
    }
}

impl Ord for AnsweredBy {
    fn cmp(&self, other: &Self) -> std::cmp::Ordering {
        self.name().cmp(other.name())
    }
}

impl PartialOrd for AnsweredBy {
    fn partial_cmp(&self, other: &Self) -> Option<std::cmp::Ordering> {
        Some(self.cmp(other))
    }
}

/// A scene graph with every node's class resolved once.
pub struct ClassifiedGraph<'g> {
    nodes: Vec<(&'g GraphObject, Option<String>)>,
}

const ON_GAP: f64 = 0.15;
/// A subject resting on an object's surface sits at least this far above its base.
const ON_LIFT: f64 = 0.05;
const NEXT_TO_GAP: f64 = 0.5;
const NEAR_GAP: f64 = 1.2;
const DIRECTIONAL_GAP: f64 = 1.5;

fn footprints_overlap(a: &GraphObject, b: &GraphObject) -> bool {
    [0, 2].iter().all(|&axis| a.min(axis) < b.max(axis) && b.min(axis) < a.max(axis))
}

fn footprint_gap(a: &GraphObject, b: &GraphObject) -> f64 {
    let gap = |axis: usize| (a.min(axis) - b.max(axis)).max(b.min(axis) - a.max(axis)).max(0.0);
    (gap(0).powi(2) + gap(2).powi(2)).sqrt()
}

/// Whether `subject` stands in `relation` to `object`, by their boxes.
pub fn related(subject: &GraphObject, relation: Relation, object: &GraphObject) -> bool {
    match relation {
        Relation::On => {
            let over = [0, 2].iter().all(|&a| subject.center[a] >= object.min(a) && subject.center[a] <= object.max(a));
            over && subject.min(1) >= object.min(1) + ON_LIFT && subject.min(1) <= object.max(1) + ON_GAP
        }
        Relation::Under => footprints_overlap(subject, object) && subject.center[1] < object.center[1] && subject.max(1) <= object.max(1),
        Relation::Inside => (0..3).all(|a| subject.center[a] >= object.min(a) && subject.center[a] <= object.max(a)),
        Relation::NextTo => footprint_gap(subject, object) <= NEXT_TO_GAP,
        Relation::Near => footprint_gap(subject, object) <= NEAR_GAP,
        Relation::Behind | Relation::InFrontOf | Relation::LeftOf | Relation::RightOf => footprint_gap(subject, object) <= DIRECTIONAL_GAP,
    }
}

impl<'g> ClassifiedGraph<'g> {
    pub fn new(graph: &'g SceneGraph, classes: &[String]) -> Self {
        Self::with_features(graph, classes, None)
    }

    /// As [`ClassifiedGraph::new`], naming nodes that carry only a feature by `vocabulary`.
    pub fn with_features(graph: &'g SceneGraph, classes: &[String], vocabulary: Option<&FeatureVocabulary>) -> Self {
        ClassifiedGraph { nodes: graph.objects.iter().map(|o| (o, node_class(o, classes, vocabulary))).collect() }
    }

    fn of(&self, class: &str) -> impl Iterator<Item = &'g GraphObject> + '_ {
        let class = class.to_string();
        self.nodes.iter().filter(move |(_, c)| c.as_deref() == Some(class.as_str())).map(|(o, _)| *o)
    }

    fn class_of(&self, object: &GraphObject) -> Option<&str> {
        self.nodes.iter().find(|(o, _)| std::ptr::eq(*o, object)).and_then(|(_, c)| c.as_deref())
    }

    fn count(&self, class: &str) -> usize {
        self.of(class).count()
    }

    /// The largest box volume of a node of `class`, if the graph has one.
    fn largest(&self, class: &str) -> Option<f64> {
        self.of(class).map(GraphObject::volume).fold(None, |m: Option<f64>, v| Some(m.map_or(v, |m| m.max(v))))
    }

    /// The colour a node of `class` is described with, if any.
    fn colour(&self, class: &str) -> Option<&'static str> {
        self.of(class).find_map(|o| {
            o.texts.iter().find_map(|t| {
                let words: Vec<&str> = t.split(|c: char| !c.is_alphanumeric()).collect();
                COLOURS.iter().copied().find(|c| words.contains(c)).map(|c| if c == "gray" { "grey" } else { c })
            })
        })
    }

    /// The answer of `form` from this graph.
    pub fn answer(&self, form: &QuestionForm) -> String {
        let yes_no = |b: bool| if b { "Yes".to_string() } else { "No".to_string() };
        match form {
            QuestionForm::Exists { class } => yes_no(self.count(class) > 0),
            QuestionForm::ExistsAll { classes } => yes_no(classes.iter().all(|c| self.count(c) > 0)),
            QuestionForm::ExistsAny { classes } => yes_no(classes.iter().any(|c| self.count(c) > 0)),
            QuestionForm::Count { class } => self.count(class).to_string(),
            QuestionForm::Related { subject, relation, object } => {
                yes_no(self.of(subject).any(|s| self.of(object).any(|o| !std::ptr::eq(s, o) && related(s, *relation, o))))
            }
            QuestionForm::MoreThan { more, fewer } => yes_no(self.count(more) > self.count(fewer)),
            QuestionForm::RestsOn { class, support } => yes_no(self.answer(&QuestionForm::Support { class: class.clone() }) == *support),
            QuestionForm::NearestIs { class, nearest } => yes_no(self.answer(&QuestionForm::Nearest { class: class.clone() }) == *nearest),
            QuestionForm::LargerThan { a, b } => {
                let (va, vb) = (self.largest(a), self.largest(b));
                yes_no(matches!((va, vb), (Some(va), Some(vb)) if va > vb) || (va.is_some() && vb.is_none()))
            }
            QuestionForm::Larger { a, b } => match (self.largest(a), self.largest(b)) {
                (Some(va), Some(vb)) => {
                    if va >= vb {
                        a.clone()
                    } else {
                        b.clone()
                    }
                }
                (Some(_), None) => a.clone(),
                (None, Some(_)) => b.clone(),
                (None, None) => NO_ANSWER.into(),
            },
            QuestionForm::Colour { class } => self.colour(class).map_or(NO_ANSWER.into(), str::to_string),
            QuestionForm::HasColour { class, colour } => {
                yes_no(self.of(class).any(|o| o.texts.iter().any(|t| t.split(|c: char| !c.is_alphanumeric()).any(|w| w == colour))))
            }
            QuestionForm::Nearest { class } => {
                let Some(subject) = self.of(class).next() else { return NO_ANSWER.into() };
                self.nodes
                    .iter()
                    .filter(|(o, c)| !std::ptr::eq(*o, subject) && c.is_some() && c.as_deref() != Some(class.as_str()))
                    .min_by(|(a, _), (b, _)| subject.distance(a).total_cmp(&subject.distance(b)))
                    .and_then(|(_, c)| c.clone())
                    .unwrap_or_else(|| NO_ANSWER.into())
            }
            QuestionForm::Support { class } => {
                let Some(subject) = self.of(class).next() else { return NO_ANSWER.into() };
                // Of the objects it is on, the one whose base is highest (a mug on a tray on
                // a table rests on the tray).
                self.nodes
                    .iter()
                    .filter(|(o, c)| !std::ptr::eq(*o, subject) && c.is_some() && related(subject, Relation::On, o))
                    .max_by(|(a, _), (b, _)| a.min(1).total_cmp(&b.min(1)).then(a.max(1).total_cmp(&b.max(1))))
                    .map(|(o, _)| self.class_of(o).unwrap_or(NO_ANSWER).to_string())
                    .unwrap_or_else(|| "floor".into())
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use serde_json::json;

    fn graph() -> SceneGraph {
        SceneGraph::parse(
            &json!({"objects": [
                {"id": "t", "label": "table", "bbox_center": [0, 0.375, 0], "bbox_extent": [1.2, 0.75, 0.8]},
                {"id": "c1", "label": "chair", "caption": "a red chair", "bbox_center": [0.9, 0.45, 0], "bbox_extent": [0.5, 0.9, 0.5]},
                {"id": "c2", "label": "chairs", "bbox_center": [-0.9, 0.45, 0], "bbox_extent": [0.5, 0.9, 0.5]},
                {"id": "m", "label": "mug", "bbox_center": [0.1, 0.8, 0.1], "bbox_extent": [0.1, 0.1, 0.1]},
                {"id": "s", "label": "sofa", "bbox_center": [0, 0.45, -4], "bbox_extent": [2, 0.9, 0.9]},
                {"id": "b", "label": "book", "bbox_center": [0.3, 0.47, -3.9], "bbox_extent": [0.2, 0.04, 0.3]}
            ]}),
            "g.json",
        )
        .unwrap()
    }

    #[test]
    fn forms_are_answered_from_the_boxes_and_labels() {
        let classes: Vec<String> = ["table", "chair", "mug", "sofa", "bed", "book"].map(String::from).to_vec();
        let g = graph();
        let answerer = ClassifiedGraph::new(&g, &classes);
        let s = |x: &str| x.to_string();
        let cases = [
            (QuestionForm::Exists { class: s("sofa") }, "Yes"),
            (QuestionForm::Exists { class: s("bed") }, "No"),
            (QuestionForm::ExistsAll { classes: vec![s("sofa"), s("bed")] }, "No"),
            (QuestionForm::ExistsAny { classes: vec![s("sofa"), s("bed")] }, "Yes"),
            (QuestionForm::Count { class: s("chair") }, "2"),
            (QuestionForm::Related { subject: s("mug"), relation: Relation::On, object: s("table") }, "Yes"),
            (QuestionForm::Related { subject: s("mug"), relation: Relation::On, object: s("sofa") }, "No"),
            (QuestionForm::Related { subject: s("chair"), relation: Relation::NextTo, object: s("table") }, "Yes"),
            (QuestionForm::Related { subject: s("sofa"), relation: Relation::NextTo, object: s("table") }, "No"),
            (QuestionForm::MoreThan { more: s("chair"), fewer: s("table") }, "Yes"),
            (QuestionForm::Larger { a: s("mug"), b: s("sofa") }, "sofa"),
            (QuestionForm::Colour { class: s("chair") }, "red"),
            (QuestionForm::Colour { class: s("sofa") }, NO_ANSWER),
            (QuestionForm::HasColour { class: s("chair"), colour: s("blue") }, "No"),
            (QuestionForm::Nearest { class: s("sofa") }, "book"),
            (QuestionForm::Support { class: s("mug") }, "table"),
            (QuestionForm::Support { class: s("table") }, "floor"),
            (QuestionForm::RestsOn { class: s("mug"), support: s("table") }, "Yes"),
            (QuestionForm::RestsOn { class: s("mug"), support: s("floor") }, "No"),
            (QuestionForm::RestsOn { class: s("table"), support: s("floor") }, "Yes"),
            (QuestionForm::NearestIs { class: s("sofa"), nearest: s("book") }, "Yes"),
            (QuestionForm::NearestIs { class: s("sofa"), nearest: s("table") }, "No"),
            (QuestionForm::LargerThan { a: s("sofa"), b: s("mug") }, "Yes"),
            (QuestionForm::LargerThan { a: s("mug"), b: s("sofa") }, "No"),
            (QuestionForm::LargerThan { a: s("bed"), b: s("mug") }, "No"),
            (QuestionForm::Support { class: s("book") }, "sofa"),
            (QuestionForm::Related { subject: s("book"), relation: Relation::On, object: s("sofa") }, "Yes"),
            (QuestionForm::Related { subject: s("sofa"), relation: Relation::On, object: s("book") }, "No"),
            (QuestionForm::Related { subject: s("table"), relation: Relation::On, object: s("mug") }, "No"),
            (QuestionForm::Related { subject: s("chair"), relation: Relation::On, object: s("table") }, "No"),
        ];
        for (form, want) in cases {
            assert_eq!(answerer.answer(&form), want, "{form:?}");
        }
    }

    #[test]
    fn an_empty_graph_knows_nothing_exists() {
        let empty = SceneGraph::default();
        let classes = vec!["chair".to_string()];
        let answerer = ClassifiedGraph::new(&empty, &classes);
        assert_eq!(answerer.answer(&QuestionForm::Count { class: "chair".into() }), "0");
        assert_eq!(answerer.answer(&QuestionForm::Nearest { class: "chair".into() }), NO_ANSWER);
    }
}
