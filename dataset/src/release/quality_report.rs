//! A release's quality report read back: the counts, the oracle's accuracy, the problems
//! and every scene's measures, as `build_release` writes them to
//! `quality/quality_report.json` (public: a test scene's frame and path measures only) and
//! beside the ground truth (every measure). Reports of older releases may lack a measure:
//! every field but the scene's name is optional, and a missing one reads as unknown.

use std::collections::BTreeMap;

use serde::Deserialize;

/// A quality report.
#[derive(Debug, Clone, Default, PartialEq, Deserialize)]
pub struct QualityReport {
    /// How many scenes the release has.
    pub scenes: Option<f64>,
    /// How many pass the bar (of the val scenes, in a public report with a test split).
    pub passed: Option<f64>,
    /// How many match their prompt fully (same scenes as `passed`).
    pub full_match: Option<f64>,
    /// The bar's misses, `scene: what`.
    pub problems: Option<Vec<String>>,
    /// The oracle's VQA accuracy per question category.
    #[serde(default)]
    pub oracle_vqa: BTreeMap<String, f64>,
    #[serde(default)]
    pub per_scene: Vec<SceneReport>,
}

/// One scene of a report.
#[derive(Debug, Clone, Default, PartialEq, Deserialize)]
pub struct SceneReport {
    pub scene: String,
    /// `furniture` or `manipuland`.
    #[serde(default)]
    pub subset: String,
    /// The prompt it was generated from (not in a public report's test scenes).
    pub prompt_id: Option<String>,
    pub frames: Option<f64>,
    pub travelled_m: Option<f64>,
    /// The share of frames too close to a surface or too empty to map.
    pub degenerate_fraction: Option<f64>,
    /// Every object instance and whether its ground truth is mapped (not in a public
    /// report's test scenes).
    #[serde(default)]
    pub instances: Vec<InstanceMapped>,
    #[serde(default)]
    pub problems: Vec<String>,
    /// The image measures per lighting.
    #[serde(default)]
    pub lightings: BTreeMap<String, LightingMeasures>,
}

impl SceneReport {
    /// How many of its instances are mapped.
    pub fn mapped(&self) -> usize {
        self.instances.iter().filter(|i| i.mapped).count()
    }
}

/// Whether an object instance has ground-truth points.
#[derive(Debug, Clone, Default, PartialEq, Deserialize)]
pub struct InstanceMapped {
    #[serde(default)]
    pub mapped: bool,
}

/// The image measures of a scene under one lighting.
#[derive(Debug, Clone, Default, PartialEq, Deserialize)]
pub struct LightingMeasures {
    /// The median share of saturated pixels per frame.
    pub median_saturated: Option<f64>,
    /// The mean luma (0–255).
    pub mean_luma: Option<f64>,
}

impl QualityReport {
    /// Parse a report; `name` says which file in the message of a malformed one.
    pub fn parse(bytes: &[u8], name: &str) -> Result<QualityReport, String> {
        serde_json::from_slice(bytes).map_err(|e| format!("{name} is not a quality report: {e}"))
    }

    /// The share of object instances mapped over the scenes that list them.
    pub fn mapped_share(&self) -> Option<f64> {
        let (mapped, all) = self.per_scene.iter().fold((0, 0), |(m, n), s| (m + s.mapped(), n + s.instances.len()));
        (all > 0).then(|| mapped as f64 / all as f64)
    }

    /// The mean of a scene measure over the scenes that have it.
    pub fn mean_over_scenes(&self, measure: impl Fn(&SceneReport) -> Option<f64>) -> Option<f64> {
        let values: Vec<f64> = self.per_scene.iter().filter_map(measure).collect();
        (!values.is_empty()).then(|| values.iter().sum::<f64>() / values.len() as f64)
    }

    /// Every lighting any scene is measured under, by name.
    pub fn lightings(&self) -> Vec<String> {
        let mut names: Vec<String> = self.per_scene.iter().flat_map(|s| s.lightings.keys().cloned()).collect();
        names.sort();
        names.dedup();
        names
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_public_report_reads_with_its_test_scenes_measured_in_part() {
        let text = br#"{"scenes": 2, "passed": 1, "full_match": 1, "problems": ["scene_000: dark"], "bar": {"enforce": true},
            "oracle_vqa": {"counting": 0.75},
            "per_scene": [
              {"scene": "scene_000", "subset": "furniture", "split": "val", "prompt_id": "p1", "frames": 100, "travelled_m": 12.5,
               "degenerate_fraction": 0.01, "instances": [{"id": "obj_1", "mapped": true}, {"id": "obj_2", "mapped": false}],
               "problems": ["dark"], "lightings": {"baseline": {"median_saturated": 0.001, "mean_luma": 120.0, "geometry_differs": 0}}},
              {"scene": "scene_001", "subset": "manipuland", "split": "test", "frames": 80, "travelled_m": 7.5, "degenerate_fraction": 0.03,
               "lightings": {"no_lights": {"median_saturated": 0.0, "mean_luma": 20.0}}}
            ], "test_scenes": ["scene_001"]}"#;
        let report = QualityReport::parse(text, "quality_report.json").unwrap();
        assert_eq!((report.scenes, report.passed, report.oracle_vqa["counting"]), (Some(2.0), Some(1.0), 0.75));
        assert_eq!(report.per_scene[1].prompt_id, None, "a test scene's prompt is not public");
        assert_eq!(report.mapped_share(), Some(0.5), "over the scenes that list instances");
        assert_eq!(report.mean_over_scenes(|s| s.travelled_m), Some(10.0));
        assert_eq!(report.lightings(), ["baseline", "no_lights"]);
        let broken = QualityReport::parse(br#"{"per_scene": [{"frames": 3}]}"#, "quality/quality_report.json").unwrap_err();
        assert!(broken.starts_with("quality/quality_report.json is not a quality report: missing field `scene`"), "{broken}");
    }
}
