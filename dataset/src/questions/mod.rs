//! The questions of a release, part of every build (issue 6): prompt-grounded questions
//! from each scene's prompt specification ([`prompt`]), and standard view-dependent
//! questions from what the rendered trajectory shows ([`standard`]) — the objects whose
//! ground-truth points the camera captured, their colours in the baseline frames, their
//! boxes. Both sets carry machine-readable forms, so the symbolic answerer and the rule
//! judge handle them without an LLM. The seen objects are kept, hidden, with the ground
//! truth: they are the scene graph an oracle would build.

pub mod prompt;
pub mod standard;

use std::collections::BTreeMap;

use osmab_evaluator::ground_truth::GroundTruth;
use osmab_evaluator::vqa::SceneQuestions;
use serde::{Deserialize, Serialize};

use crate::convert::habitat::ConversionReport;
use crate::spec::SceneSpec;

/// Classes questions never ask about: the room's shell.
pub const STRUCTURAL: [&str; 6] = ["other", "floor", "wall", "ceiling", "door", "window"];

/// Ground-truth points an object needs to count as seen by the trajectory.
pub const MIN_SEEN_POINTS: usize = 10;

/// An object of the scene (not its shell) and how much of it the trajectory saw.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SceneObject {
    pub id: String,
    pub label: String,
    /// Box of the object (from the scene), world frame, y up.
    pub bbox_center: [f64; 3],
    pub bbox_extent: [f64; 3],
    /// Its ground-truth points (0: the camera never saw it).
    pub points: usize,
    /// The colour name of its mean colour in the baseline frames, when clear.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub colour: Option<String>,
    /// A caption in the style of ConceptGraphs' (`a red chair`).
    pub caption: String,
}

impl SceneObject {
    /// Whether the trajectory saw it (at least [`MIN_SEEN_POINTS`] ground-truth points).
    pub fn seen(&self) -> bool {
        self.points >= MIN_SEEN_POINTS
    }
    pub fn min(&self, axis: usize) -> f64 {
        self.bbox_center[axis] - self.bbox_extent[axis] / 2.0
    }
    pub fn max(&self, axis: usize) -> f64 {
        self.bbox_center[axis] + self.bbox_extent[axis] / 2.0
    }
}

/// The name of an sRGB colour, or `None` when it sits between names.
pub fn colour_name(rgb: [f64; 3]) -> Option<&'static str> {
    let [r, g, b] = rgb.map(|c| c / 255.0);
    let max = r.max(g).max(b);
    let min = r.min(g).min(b);
    let (value, chroma) = (max, max - min);
    let saturation = if max > 0.0 { chroma / max } else { 0.0 };
    if value < 0.18 {
        return Some("black");
    }
    if saturation < 0.12 {
        return Some(if value > 0.82 {
            "white"
        } else if value > 0.3 {
            "grey"
        } else {
            "black"
        });
    }
    if saturation < 0.2 {
        return None;
    }
    let hue = if chroma == 0.0 {
        0.0
    } else if max == r {
        60.0 * ((g - b) / chroma).rem_euclid(6.0)
    } else if max == g {
        60.0 * ((b - r) / chroma + 2.0)
    } else {
        60.0 * ((r - g) / chroma + 4.0)
    };
    Some(match hue {
        h if !(12.0..345.0).contains(&h) => "red",
        h if h < 45.0 => {
            if value < 0.65 {
                "brown"
            } else {
                "orange"
            }
        }
        h if h < 70.0 => "yellow",
        h if h < 165.0 => "green",
        h if h < 255.0 => "blue",
        h if h < 290.0 => "purple",
        _ => "pink",
    })
}

/// The scene's objects (not the shell), each with the ground-truth points of its class
/// inside its box and their mean colour.
pub fn scene_objects(report: &ConversionReport, gt: &GroundTruth) -> Vec<SceneObject> {
    const MARGIN: f64 = 0.05;
    let candidates: Vec<_> = report.objects.iter().filter(|o| !STRUCTURAL.contains(&o.class.as_str())).collect();
    let mut tallies = vec![(0usize, [0f64; 3]); candidates.len()];
    for (i, (p, &label)) in gt.points.iter().zip(&gt.labels).enumerate() {
        let p = p.map(f64::from);
        for (k, o) in candidates.iter().enumerate() {
            if o.class_id == label && (0..3).all(|a| p[a] >= o.bbox_min[a] - MARGIN && p[a] <= o.bbox_max[a] + MARGIN) {
                tallies[k].0 += 1;
                if let Some(colours) = &gt.colors {
                    for (a, c) in colours[i].iter().enumerate() {
                        tallies[k].1[a] += f64::from(*c);
                    }
                }
                break;
            }
        }
    }
    candidates
        .iter()
        .zip(tallies)
        .map(|(o, (n, sum))| {
            let colour = gt.colors.as_ref().filter(|_| n >= MIN_SEEN_POINTS).and_then(|_| colour_name(sum.map(|s| s / n as f64))).map(str::to_string);
            let center = std::array::from_fn(|a| (o.bbox_min[a] + o.bbox_max[a]) / 2.0);
            let extent = std::array::from_fn(|a| o.bbox_max[a] - o.bbox_min[a]);
            let caption = match &colour {
                Some(c) => format!("a {c} {}", o.class),
                None => format!("a {}", o.class),
            };
            SceneObject { id: format!("obj_{}", o.instance_id), label: o.class.clone(), bbox_center: center, bbox_extent: extent, points: n, colour, caption }
        })
        .collect()
}

/// Every question of one scene: the prompt-grounded ones, then the standard ones about
/// the objects the trajectory saw.
pub fn scene_questions(scene: &str, spec: &SceneSpec, objects: &[SceneObject], lexicon: &[String], seed: u64) -> SceneQuestions {
    let mut questions = prompt::prompt_questions(scene, spec, lexicon, seed);
    let seen: Vec<SceneObject> = objects.iter().filter(|o| o.seen()).cloned().collect();
    let present: Vec<String> = objects.iter().map(|o| o.label.clone()).collect();
    questions.extend(standard::standard_questions(scene, &seen, &present, lexicon, seed));
    SceneQuestions { scene: scene.to_string(), questions }
}

/// How many questions each category has, for reports.
pub fn category_counts(questions: &SceneQuestions) -> BTreeMap<String, usize> {
    let mut counts = BTreeMap::new();
    for q in &questions.questions {
        *counts.entry(q.category.clone()).or_default() += 1;
    }
    counts
}

/// `a chair`, `an armchair`.
pub fn with_article(name: &str) -> String {
    let article = if name.starts_with(['a', 'e', 'i', 'o', 'u']) { "an" } else { "a" };
    format!("{article} {name}")
}

/// `chair` → `chairs`, `shelf` → `shelves`, `box` → `boxes`, `dining chair` → `dining chairs`.
pub fn plural(name: &str) -> String {
    if let Some(stem) = name.strip_suffix("shelf") {
        return format!("{stem}shelves");
    }
    if name.ends_with('s') || name.ends_with('x') || name.ends_with("ch") || name.ends_with("sh") {
        return format!("{name}es");
    }
    if let Some(stem) = name.strip_suffix('y')
        && !stem.ends_with(['a', 'e', 'i', 'o', 'u'])
    {
        return format!("{stem}ies");
    }
    format!("{name}s")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn colours_are_named_only_when_clear() {
        assert_eq!(colour_name([200.0, 30.0, 30.0]), Some("red"));
        assert_eq!(colour_name([120.0, 80.0, 40.0]), Some("brown"));
        assert_eq!(colour_name([240.0, 240.0, 238.0]), Some("white"));
        assert_eq!(colour_name([20.0, 20.0, 25.0]), Some("black"));
        assert_eq!(colour_name([40.0, 90.0, 200.0]), Some("blue"));
        assert_eq!(colour_name([150.0, 140.0, 125.0]), None, "greyish beige is neither grey nor a hue");
    }

    #[test]
    fn plurals_follow_english_endings() {
        for (one, many) in [("chair", "chairs"), ("bookshelf", "bookshelves"), ("box", "boxes"), ("dining chair", "dining chairs"), ("bench", "benches")] {
            assert_eq!(plural(one), many);
        }
    }
}
