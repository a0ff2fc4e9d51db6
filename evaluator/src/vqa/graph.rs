//! Scene graphs as submissions carry them (product.md section 5): osmab's
//! `{"objects": [...], "edges"?: [...]}`, or ConceptGraphs' and BBQ's own node lists. A
//! node is matched to a release class by its label, or else by the class names its
//! texts (tag, caption, description, possible tags) mention.

use std::path::Path;

use serde_json::Value;

use crate::InputError;

/// One node of a scene graph.
#[derive(Debug, Clone, PartialEq)]
pub struct GraphObject {
    pub id: String,
    /// The node's texts, most specific first: label, object_tag, description, caption,
    /// then possible tags; lower case.
    pub texts: Vec<String>,
    /// Box centre and extent in the release's world frame (y up).
    pub center: [f64; 3],
    pub extent: [f64; 3],
    /// The node's feature vector, in the space of the submission's text_features.npz.
    pub features: Option<Vec<f32>>,
}

impl GraphObject {
    pub fn min(&self, axis: usize) -> f64 {
        self.center[axis] - self.extent[axis] / 2.0
    }
    pub fn max(&self, axis: usize) -> f64 {
        self.center[axis] + self.extent[axis] / 2.0
    }
    pub fn volume(&self) -> f64 {
        self.extent.iter().product()
    }
    pub fn distance(&self, other: &GraphObject) -> f64 {
        (0..3).map(|a| (self.center[a] - other.center[a]).powi(2)).sum::<f64>().sqrt()
    }
}

/// A relation edge, if the graph has any.
#[derive(Debug, Clone, PartialEq)]
pub struct Edge {
    pub source: String,
    pub target: String,
    pub relation: String,
}

/// A parsed scene graph.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct SceneGraph {
    pub objects: Vec<GraphObject>,
    pub edges: Vec<Edge>,
}

fn triple(value: Option<&Value>, name: &str, field: String) -> Result<Option<[f64; 3]>, InputError> {
    let Some(value) = value else { return Ok(None) };
    let numbers: Option<Vec<f64>> = value.as_array().map(|a| a.iter().filter_map(Value::as_f64).collect());
    match numbers {
        Some(n) if n.len() == 3 && value.as_array().is_some_and(|a| a.len() == 3) && n.iter().all(|x| x.is_finite()) => Ok(Some([n[0], n[1], n[2]])),
        _ => Err(InputError::new(name, field, "expected three finite numbers")),
    }
}

impl SceneGraph {
    /// Parse a scene graph JSON value; `name` is the file as the participant knows it.
    pub fn parse(value: &Value, name: &str) -> Result<SceneGraph, InputError> {
        let nodes = match value {
            Value::Array(list) => list,
            Value::Object(map) => match map.get("objects") {
                Some(Value::Array(list)) => list,
                _ => return Err(InputError::new(name, "objects", "expected {\"objects\": [...]} or a list of nodes")),
            },
            _ => return Err(InputError::new(name, "(json)", "expected {\"objects\": [...]} or a list of nodes")),
        };
        let objects = nodes.iter().enumerate().map(|(i, node)| parse_node(i, node, name)).collect::<Result<Vec<_>, _>>()?;
        let edges = parse_edges(value, name)?;
        Ok(SceneGraph { objects, edges })
    }

    /// Read a scene graph file.
    pub fn read(path: &Path, name: &str) -> Result<SceneGraph, InputError> {
        let bytes = std::fs::read(path).map_err(|e| InputError::io(name, &e))?;
        let value: Value = serde_json::from_slice(&bytes).map_err(|e| InputError::new(name, "(json)", format!("not valid JSON: {e}")))?;
        SceneGraph::parse(&value, name)
    }
}

/// Node `i` of a scene graph (`name` is the file as the participant knows it): its id,
/// texts, box and optional feature vector.
fn parse_node(i: usize, node: &Value, name: &str) -> Result<GraphObject, InputError> {
    let Some(fields) = node.as_object() else {
        return Err(InputError::new(name, format!("objects[{i}]"), "expected an object"));
    };
    let id = match fields.get("id") {
        Some(Value::String(s)) => s.clone(),
        Some(Value::Number(n)) => n.to_string(),
        None => i.to_string(),
        Some(_) => return Err(InputError::new(name, format!("objects[{i}].id"), "expected a string or an integer")),
    };
    let mut texts = Vec::new();
    for key in ["label", "object_tag", "description", "caption"] {
        match fields.get(key) {
            Some(Value::String(s)) if !s.trim().is_empty() => texts.push(s.trim().to_lowercase()),
            Some(Value::String(_) | Value::Null) | None => {}
            Some(_) => return Err(InputError::new(name, format!("objects[{i}].{key}"), "expected a string")),
        }
    }
    if let Some(tags) = fields.get("possible_tags") {
        let Some(list) = tags.as_array() else {
            return Err(InputError::new(name, format!("objects[{i}].possible_tags"), "expected a list of strings"));
        };
        texts.extend(list.iter().filter_map(Value::as_str).map(|s| s.trim().to_lowercase()).filter(|s| !s.is_empty()));
    }
    let center = triple(fields.get("bbox_center"), name, format!("objects[{i}].bbox_center"))?;
    let extent = triple(fields.get("bbox_extent"), name, format!("objects[{i}].bbox_extent"))?;
    let (Some(center), Some(extent)) = (center, extent) else {
        return Err(InputError::new(name, format!("objects[{i}]"), "every node needs bbox_center and bbox_extent (three numbers each)"));
    };
    if extent.iter().any(|&e| e < 0.0) {
        return Err(InputError::new(name, format!("objects[{i}].bbox_extent"), "extents cannot be negative"));
    }
    let features = parse_features(fields.get("features"), i, name)?;
    Ok(GraphObject { id, texts, center, extent, features })
}

/// Node `i`'s feature vector, if it has one: 1 to [`crate::formats::map::MAX_FEATURE_DIM`]
/// finite numbers.
fn parse_features(value: Option<&Value>, i: usize, name: &str) -> Result<Option<Vec<f32>>, InputError> {
    let features = match value {
        None | Some(Value::Null) => None,
        Some(Value::Array(values)) => {
            let numbers: Vec<f32> = values.iter().filter_map(Value::as_f64).map(|v| v as f32).collect();
            if numbers.len() != values.len()
                || numbers.is_empty()
                || numbers.len() > crate::formats::map::MAX_FEATURE_DIM
                || !numbers.iter().all(|v| v.is_finite())
            {
                return Err(InputError::new(
                    name,
                    format!("objects[{i}].features"),
                    format!("expected 1 to {} finite numbers", crate::formats::map::MAX_FEATURE_DIM),
                ));
            }
            Some(numbers)
        }
        Some(_) => return Err(InputError::new(name, format!("objects[{i}].features"), "expected a list of numbers")),
    };
    Ok(features)
}

/// The relation edges of a scene graph `value`, if it has any.
fn parse_edges(value: &Value, name: &str) -> Result<Vec<Edge>, InputError> {
    let mut edges = Vec::new();
    if let Some(list) = value.get("edges") {
        let Some(list) = list.as_array() else {
            return Err(InputError::new(name, "edges", "expected a list of {\"source\", \"target\", \"relation\"}"));
        };
        for (i, edge) in list.iter().enumerate() {
            let text = |key: &str| match edge.get(key) {
                Some(Value::String(s)) => Some(s.clone()),
                Some(Value::Number(n)) => Some(n.to_string()),
                _ => None,
            };
            match (text("source"), text("target"), text("relation")) {
                (Some(source), Some(target), Some(relation)) => edges.push(Edge { source, target, relation: relation.to_lowercase() }),
                _ => return Err(InputError::new(name, format!("edges[{i}]"), "expected {\"source\", \"target\", \"relation\"}")),
            }
        }
    }
    Ok(edges)
}

/// Class text features as unit vectors, to name nodes that carry only a feature.
pub struct FeatureVocabulary {
    names: Vec<String>,
    rows: Vec<Vec<f64>>,
    pub dim: usize,
}

impl FeatureVocabulary {
    /// The classes of `text` that `classes` names (the shell and "other" too: a node can
    /// be a wall).
    pub fn new(text: &crate::formats::map::TextFeatures, classes: &crate::formats::classes::ClassList) -> Self {
        let mut names = Vec::new();
        let mut rows = Vec::new();
        for (i, id) in text.class_ids.iter().enumerate() {
            let Some(name) = classes.name(*id) else { continue };
            let row = text.features.row(i);
            let norm = row.iter().map(|&v| f64::from(v) * f64::from(v)).sum::<f64>().sqrt();
            if norm > 0.0 {
                names.push(name.to_string());
                rows.push(row.iter().map(|&v| f64::from(v) / norm).collect());
            }
        }
        FeatureVocabulary { names, rows, dim: text.features.dim }
    }

    /// The class whose text feature is most similar (cosine, the first maximum wins).
    pub fn classify(&self, features: &[f32]) -> Option<&str> {
        if features.len() != self.dim {
            return None;
        }
        let mut best: Option<(f64, usize)> = None;
        for (j, row) in self.rows.iter().enumerate() {
            let dot: f64 = row.iter().zip(features).map(|(a, &b)| a * f64::from(b)).sum();
            if best.is_none_or(|(b, _)| dot > b) {
                best = Some((dot, j));
            }
        }
        best.map(|(_, j)| self.names[j].as_str())
    }
}

/// Lower-case words of `text`.
fn words(text: &str) -> Vec<String> {
    text.to_lowercase().split(|c: char| !c.is_alphanumeric()).filter(|w| !w.is_empty()).map(str::to_string).collect()
}

/// A word and its plural forms agree ("chair"/"chairs", "box"/"boxes", "shelf"/"shelves").
fn same_word(word: &str, class_word: &str) -> bool {
    word == class_word
        || word.strip_suffix('s') == Some(class_word)
        || word.strip_suffix("es") == Some(class_word)
        || (class_word.ends_with('y') && word.strip_suffix("ies") == Some(&class_word[..class_word.len() - 1]))
        || (class_word.ends_with('f') && word.strip_suffix("ves") == Some(&class_word[..class_word.len() - 1]))
}

/// Whether `text` names `class` (its words in order, the last one possibly plural;
/// underscores in class names count as spaces).
pub fn mentions_class(text: &str, class: &str) -> bool {
    let class_words = words(&class.replace('_', " "));
    let text_words = words(text);
    if class_words.is_empty() || text_words.len() < class_words.len() {
        return false;
    }
    text_words.windows(class_words.len()).any(|window| {
        let n = class_words.len();
        window[..n - 1] == class_words[..n - 1] && same_word(&window[n - 1], &class_words[n - 1])
    })
}

/// `text` with every mention of `class` blanked out (for telling "chair" from "dining
/// chair": a mention of the shorter name inside the longer one is not a mention).
pub fn without_mentions(text: &str, class: &str) -> String {
    let class_words = words(&class.replace('_', " "));
    let text_words = words(text);
    let n = class_words.len();
    if n == 0 {
        return text_words.join(" ");
    }
    let mut kept = Vec::with_capacity(text_words.len());
    let mut i = 0;
    while i < text_words.len() {
        let window = &text_words[i..(i + n).min(text_words.len())];
        if window.len() == n && window[..n - 1] == class_words[..n - 1] && same_word(&window[n - 1], &class_words[n - 1]) {
            kept.push("|".to_string());
            i += n;
        } else {
            kept.push(text_words[i].clone());
            i += 1;
        }
    }
    kept.join(" ")
}

/// Whether `text` names `class` itself, not only as part of the longer name of one of
/// `candidates` ("the dining chair" names "dining chair", not "chair").
pub fn names_class(text: &str, class: &str, candidates: &[&str]) -> bool {
    let mut rest = text.to_string();
    for longer in candidates.iter().filter(|c| **c != class && mentions_class(c, class)) {
        rest = without_mentions(&rest, longer);
    }
    mentions_class(&rest, class)
}

/// The release class a node stands for: the first of its texts that names a class
/// decides, and within it the longest class name ("dining chair" over "chair"); a node
/// without a class name takes the class of its feature, when it has one.
pub fn node_class(object: &GraphObject, classes: &[String], vocabulary: Option<&FeatureVocabulary>) -> Option<String> {
    for text in &object.texts {
        let best = classes.iter().filter(|c| mentions_class(text, c)).max_by_key(|c| (words(&c.replace('_', " ")).len(), c.len()));
        if let Some(class) = best {
            return Some(class.clone());
        }
    }
    object.features.as_deref().zip(vocabulary).and_then(|(f, v)| v.classify(f)).map(str::to_string)
}

#[cfg(test)]
mod tests {
    use super::*;
    use serde_json::json;

    #[test]
    fn class_names_match_whole_words_and_plurals() {
        assert!(mentions_class("two wooden chairs", "chair"));
        assert!(mentions_class("bookshelves", "bookshelf"));
        assert!(mentions_class("a dining chair", "dining_chair"));
        assert!(!mentions_class("armchair", "chair"));
        assert!(!mentions_class("chair", "dining chair"));
        assert!(mentions_class("boxes on a shelf", "box"));
    }

    #[test]
    fn every_format_parses_and_finds_its_classes() {
        let classes: Vec<String> = ["chair", "dining chair", "table", "sofa"].map(String::from).to_vec();
        let osmab = json!({"objects": [{"id": "a", "label": "Dining Chair", "bbox_center": [0, 0.5, 0], "bbox_extent": [0.5, 1, 0.5]}]});
        let concept_graphs = json!([{"id": 3, "object_tag": "wooden table", "caption": "a table with a cup", "possible_tags": ["table"], "bbox_center": [1, 0.4, 0], "bbox_extent": [1.2, 0.8, 0.6]}]);
        let bbq = json!([{"id": 0, "description": "a grey sofa with cushions", "bbox_center": [0, 0, 0], "bbox_extent": [2, 1, 1]}]);
        for (graph, want) in [(osmab, "dining chair"), (concept_graphs, "table"), (bbq, "sofa")] {
            let parsed = SceneGraph::parse(&graph, "graphs/baseline/scene_000.json").unwrap();
            assert_eq!(node_class(&parsed.objects[0], &classes, None).as_deref(), Some(want));
        }
    }

    #[test]
    fn a_node_with_only_a_feature_takes_the_most_similar_class() {
        use crate::formats::classes::{ClassEntry, ClassList};
        use crate::formats::map::{FeatureMatrix, TextFeatures};
        let classes = ClassList::new([("other", 0), ("chair", 1), ("table", 2)].map(|(n, id)| ClassEntry { name: n.into(), id })).unwrap();
        let text = TextFeatures {
            source: "text_features.npz".into(),
            class_ids: vec![1, 2],
            features: FeatureMatrix { rows: 2, dim: 3, values: vec![1.0, 0.0, 0.0, 0.0, 2.0, 0.0] },
        };
        let vocabulary = FeatureVocabulary::new(&text, &classes);
        let graph = SceneGraph::parse(
            &json!([{"id": 1, "features": [0.1, 0.9, 0.2], "bbox_center": [0, 0, 0], "bbox_extent": [1, 1, 1]},
                    {"id": 2, "caption": "a chair", "features": [0.0, 1.0, 0.0], "bbox_center": [0, 0, 0], "bbox_extent": [1, 1, 1]},
                    {"id": 3, "features": [0.1, 0.9], "bbox_center": [0, 0, 0], "bbox_extent": [1, 1, 1]}]),
            "g.json",
        )
        .unwrap();
        let names: Vec<String> = ["chair", "table"].map(String::from).to_vec();
        let got: Vec<Option<String>> = graph.objects.iter().map(|o| node_class(o, &names, Some(&vocabulary))).collect();
        assert_eq!(got, [Some("table".into()), Some("chair".into()), None], "texts first; a feature of another dimension names nothing");
        let bad = SceneGraph::parse(&json!([{"id": 1, "features": [0.1, "x"], "bbox_center": [0, 0, 0], "bbox_extent": [1, 1, 1]}]), "g.json").unwrap_err();
        assert_eq!(bad.field, "objects[0].features");
    }

    #[test]
    fn malformed_graphs_are_refused_with_the_field() {
        let name = "graphs/camera/scene_001.json";
        for (graph, field) in [
            (json!({"nodes": []}), "objects"),
            (json!([{"id": 1, "bbox_center": [0, 0], "bbox_extent": [1, 1, 1]}]), "objects[0].bbox_center"),
            (json!([{"id": 1, "bbox_center": [0, 0, 0]}]), "objects[0]"),
            (json!([{"id": 1, "label": 5, "bbox_center": [0, 0, 0], "bbox_extent": [1, 1, 1]}]), "objects[0].label"),
            (json!([{"id": 1, "bbox_center": [0, 0, 0], "bbox_extent": [1, -1, 1]}]), "objects[0].bbox_extent"),
            (json!({"objects": [], "edges": [{"source": 1}]}), "edges[0]"),
        ] {
            let e = SceneGraph::parse(&graph, name).unwrap_err();
            assert_eq!((e.file.as_str(), e.field.as_str()), (name, field), "{e}");
        }
    }
}
