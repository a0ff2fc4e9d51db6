//! What a scene says to a question: the answer of a question form when the scene settles it
//! clearly and the scene graph of a perfect map gives that same answer — the one test every
//! question passes before it is asked. The same test runs over the layouts the priors
//! simulate ([`super::priors`]), so a question's odds are measured exactly as it is asked.

use std::collections::BTreeMap;

use osmab_evaluator::vqa::QuestionForm;
use osmab_evaluator::vqa::answer::ClassifiedGraph;
use osmab_evaluator::vqa::graph::{GraphObject, SceneGraph};
use osmab_evaluator::vqa::judge::judge_text_without_llm;

use super::objects::{SceneObject, to_millimetre};

/// Two boxes differ clearly in size when one is this many times the other's volume.
pub const CLEARLY_LARGER: f64 = 1.5;
/// The nearest object is clear when the next class is this much farther (metres).
pub const CLEARLY_NEAREST: f64 = 0.3;

/// The answer of "yes or no" questions.
pub fn yes_no(b: bool) -> String {
    if b { "Yes".into() } else { "No".into() }
}

/// A scene's objects (all of them, seen or not) with the oracle's graph of the seen ones.
pub struct SceneFacts<'a> {
    objects: &'a [SceneObject],
    by_class: BTreeMap<&'a str, Vec<&'a SceneObject>>,
    by_id: BTreeMap<&'a str, &'a SceneObject>,
    answerer: ClassifiedGraph<'a>,
}

/// The scene graph a perfect map builds of `objects` ([`super::oracle_graph`]) as its parse
/// reads it: every seen object with its label and caption (trimmed, lower case, the empty
/// left out) and its box to the millimetre; no features, no edges.
pub fn oracle_scene_graph(objects: &[SceneObject]) -> SceneGraph {
    let objects = objects
        .iter()
        .filter(|o| o.seen())
        .map(|o| GraphObject {
            id: o.id.clone(),
            texts: [&o.label, &o.caption].into_iter().map(|t| t.trim()).filter(|t| !t.is_empty()).map(str::to_lowercase).collect(),
            center: to_millimetre(o.bbox_center),
            extent: to_millimetre(o.bbox_extent),
            features: None,
        })
        .collect();
    SceneGraph { objects, edges: Vec::new() }
}

impl<'a> SceneFacts<'a> {
    /// The facts of `objects`, whose oracle graph is `graph` ([`oracle_scene_graph`]).
    pub fn new(objects: &'a [SceneObject], graph: &'a SceneGraph, lexicon: &'a [String]) -> Self {
        let mut by_class: BTreeMap<&str, Vec<&SceneObject>> = BTreeMap::new();
        for o in objects {
            by_class.entry(o.label.as_str()).or_default().push(o);
        }
        let by_id = objects.iter().map(|o| (o.id.as_str(), o)).collect();
        SceneFacts { objects, by_class, by_id, answerer: ClassifiedGraph::new(graph, lexicon) }
    }

    /// The classes the scene has (seen or not).
    pub fn classes(&self) -> impl Iterator<Item = &'a str> + '_ {
        self.by_class.keys().copied()
    }

    /// Whether the scene has `class` and the camera saw at least one of them.
    pub fn seen(&self, class: &str) -> bool {
        self.by_class.get(class).is_some_and(|v| v.iter().any(|o| o.seen()))
    }

    /// How many `class` objects the scene has, when the camera saw every one (0 for an
    /// absent class).
    pub fn counted(&self, class: &str) -> Option<usize> {
        match self.by_class.get(class) {
            None => Some(0),
            Some(v) if v.iter().all(|o| o.seen()) => Some(v.len()),
            Some(_) => None,
        }
    }

    /// The one `class` object of the scene, when it has exactly one and the camera saw it.
    pub fn single(&self, class: &str) -> Option<&'a SceneObject> {
        match self.by_class.get(class).map(Vec::as_slice) {
            Some([only]) if only.seen() => Some(*only),
            _ => None,
        }
    }

    /// The classes the scene has exactly one (seen) object of.
    pub fn singles(&self) -> Vec<&'a SceneObject> {
        self.by_class.values().filter(|v| v.len() == 1 && v[0].seen()).map(|v| v[0]).collect()
    }

    /// What `o` rests on: `floor` or the class of its support.
    pub fn support_of(&self, o: &SceneObject) -> Option<String> {
        match o.rests_on.as_deref()? {
            "floor" => Some("floor".into()),
            id => self.by_id.get(id).map(|s| s.label.clone()),
        }
    }

    /// The class nearest to `o` (centre to centre, over every object of another class) and
    /// its distance, with the distance of the nearest object of each other class.
    fn distances_from(&self, o: &SceneObject) -> BTreeMap<&'a str, f64> {
        let mut nearest: BTreeMap<&str, f64> = BTreeMap::new();
        for x in self.objects.iter().filter(|x| x.label != o.label) {
            let d = (0..3).map(|k| (o.bbox_center[k] - x.bbox_center[k]).powi(2)).sum::<f64>().sqrt();
            let slot = nearest.entry(x.label.as_str()).or_insert(f64::INFINITY);
            *slot = slot.min(d);
        }
        nearest
    }

    /// The answer the scene gives `form`, when it settles it clearly (see the module's header).
    pub fn truth(&self, form: &QuestionForm) -> Option<String> {
        let answer = match form {
            QuestionForm::Exists { class } => yes_no(self.exists(class)?),
            QuestionForm::ExistsAll { classes } => {
                let each: Option<Vec<bool>> = classes.iter().map(|c| self.exists(c)).collect();
                yes_no(each?.into_iter().all(|b| b))
            }
            QuestionForm::ExistsAny { classes } => {
                let each: Option<Vec<bool>> = classes.iter().map(|c| self.exists(c)).collect();
                yes_no(each?.into_iter().any(|b| b))
            }
            QuestionForm::Count { class } => self.counted(class)?.to_string(),
            QuestionForm::MoreThan { more, fewer } => {
                let (m, f) = (self.counted(more)?, self.counted(fewer)?);
                if m == f || m == 0 || f == 0 {
                    return None;
                }
                yes_no(m > f)
            }
            QuestionForm::LargerThan { a, b } => {
                let ratio = self.single(a)?.bbox_extent.iter().product::<f64>() / self.single(b)?.bbox_extent.iter().product::<f64>();
                if ratio >= CLEARLY_LARGER {
                    yes_no(true)
                } else if ratio <= 1.0 / CLEARLY_LARGER {
                    yes_no(false)
                } else {
                    return None;
                }
            }
            QuestionForm::HasColour { class, colour } => yes_no(self.single(class)?.colour.as_deref()? == colour),
            QuestionForm::Colour { class } => self.single(class)?.colour.clone()?,
            QuestionForm::NearestIs { class, nearest } => {
                let o = self.single(class)?;
                if !self.seen(nearest) || nearest == class {
                    return None;
                }
                let distances = self.distances_from(o);
                let (best, d) = distances.iter().min_by(|a, b| a.1.total_cmp(b.1)).map(|(c, d)| (*c, *d))?;
                let runner_up = distances.iter().filter(|(c, _)| **c != best).map(|(_, d)| *d).fold(f64::INFINITY, f64::min);
                if best == nearest {
                    if runner_up - d < CLEARLY_NEAREST {
                        return None;
                    }
                    yes_no(true)
                } else {
                    if distances.get(nearest.as_str())? - d < CLEARLY_NEAREST {
                        return None;
                    }
                    yes_no(false)
                }
            }
            QuestionForm::RestsOn { class, support } => {
                let o = self.single(class)?;
                if support != "floor" && !self.seen(support) {
                    return None;
                }
                yes_no(self.support_of(o)? == *support)
            }
            QuestionForm::Related { subject, object, .. } => {
                if !self.seen(subject) || !self.seen(object) || subject == object {
                    return None;
                }
                self.answerer.answer(form)
            }
            // The open forms of earlier releases are no longer asked.
            QuestionForm::Larger { .. } | QuestionForm::Nearest { .. } | QuestionForm::Support { .. } => return None,
        };
        // Asked only when a perfect map's graph gives the scene's answer.
        let given = self.answerer.answer(form);
        judge_text_without_llm(&answer, &given, Some(form)).is_some_and(|v| v.correct).then_some(answer)
    }

    /// Whether the scene has `class`: `None` when it has one the camera never saw (a map
    /// could not know).
    fn exists(&self, class: &str) -> Option<bool> {
        match self.by_class.get(class) {
            None => Some(false),
            Some(_) if self.seen(class) => Some(true),
            Some(_) => None,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn object(id: &str, label: &str, center: [f64; 3], extent: [f64; 3], rests_on: &str, points: usize) -> SceneObject {
        SceneObject {
            id: id.into(),
            label: label.into(),
            bbox_center: center,
            bbox_extent: extent,
            points,
            colour: Some("red".into()),
            caption: format!("a red {label}"),
            rests_on: Some(rests_on.into()),
        }
    }

    #[test]
    fn the_typed_oracle_graph_is_the_parse_of_the_oracles_json_graph() {
        let mut odd = object("o", "Lamp ", [0.12345, -0.0004, 1e-9], [0.0006, 2.0, 1.23456789], "floor", 50);
        odd.caption = "  A Tall LAMP ".into();
        let mut blank = object("p", "plant", [-1.0005, 0.5, 3.0], [0.3, 0.3, 0.3], "floor", 50);
        blank.caption = "   ".into();
        let objects = vec![
            odd,
            blank,
            object("t", "table", [0.0, 0.375, 0.0], [1.2, 0.75, 0.8], "floor", 900),
            object("b", "bed", [-3.0, 0.3, 3.0], [2.0, 0.6, 1.6], "floor", 0),
        ];
        let parsed = SceneGraph::parse(&super::super::oracle_graph(&objects), "oracle").unwrap();
        assert_eq!(oracle_scene_graph(&objects), parsed);
        assert_eq!(parsed.objects.len(), 3, "the unseen bed is left out");
    }

    #[test]
    fn a_scene_settles_only_what_it_shows_clearly() {
        let lexicon: Vec<String> = crate::convert::lexicon::classes().into_iter().map(|c| c.name).collect();
        let objects = vec![
            object("t", "table", [0.0, 0.375, 0.0], [1.2, 0.75, 0.8], "floor", 900),
            object("m", "mug", [0.1, 0.8, 0.1], [0.1, 0.1, 0.1], "t", 40),
            object("c1", "chair", [1.0, 0.45, 0.0], [0.5, 0.9, 0.5], "floor", 300),
            object("c2", "chair", [-1.0, 0.45, 0.0], [0.5, 0.9, 0.5], "floor", 300),
            object("b", "bed", [-3.0, 0.3, 3.0], [2.0, 0.6, 1.6], "floor", 0),
        ];
        let graph = oracle_scene_graph(&objects);
        let facts = SceneFacts::new(&objects, &graph, &lexicon);
        let s = |x: &str| x.to_string();
        let truth = |form: QuestionForm| facts.truth(&form);
        assert_eq!(truth(QuestionForm::Exists { class: s("sofa") }).as_deref(), Some("No"));
        assert_eq!(truth(QuestionForm::Exists { class: s("bed") }), None, "a bed the camera never saw settles nothing");
        assert_eq!(truth(QuestionForm::Count { class: s("chair") }).as_deref(), Some("2"));
        assert_eq!(truth(QuestionForm::Count { class: s("sofa") }).as_deref(), Some("0"), "an absent class counts zero");
        assert_eq!(truth(QuestionForm::RestsOn { class: s("mug"), support: s("table") }).as_deref(), Some("Yes"));
        assert_eq!(truth(QuestionForm::RestsOn { class: s("mug"), support: s("floor") }).as_deref(), Some("No"));
        assert_eq!(truth(QuestionForm::RestsOn { class: s("chair"), support: s("floor") }), None, "two chairs: which one?");
        assert_eq!(truth(QuestionForm::LargerThan { a: s("table"), b: s("mug") }).as_deref(), Some("Yes"));
        assert_eq!(truth(QuestionForm::NearestIs { class: s("mug"), nearest: s("table") }).as_deref(), Some("Yes"));
        assert_eq!(truth(QuestionForm::NearestIs { class: s("mug"), nearest: s("chair") }).as_deref(), Some("No"));
        assert_eq!(truth(QuestionForm::MoreThan { more: s("chair"), fewer: s("table") }).as_deref(), Some("Yes"));
        assert_eq!(truth(QuestionForm::HasColour { class: s("mug"), colour: s("blue") }).as_deref(), Some("No"));
    }
}
