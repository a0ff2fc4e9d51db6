//! HaDaGe's light-settings file (`lighting_hadage/light_settings_<scene>_<lighting>.json`,
//! copied into every sequence as `configs/lighting/light_settings.json`): the lights of one
//! lighting, each with the navigation segments it shines in. The converter writes it
//! ([`super::lighting`]), the renderer reads it. Fields are declared in the order of their
//! JSON keys, so a file is the bytes an untyped writer made of the same lights.

use std::collections::BTreeMap;
use std::path::Path;

use osmab_evaluator::Result;
use serde::{Deserialize, Serialize};

/// The lights of one lighting, by id (ids in order).
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct LightSettings {
    pub lights: BTreeMap<String, HadageLight>,
}

/// One light.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct HadageLight {
    /// Linear RGB, each 0–1 where the light is white.
    pub color: [f64; 3],
    /// Habitat's intensity (negative lights darken).
    pub intensity: f64,
    /// The `[start, end)` runs of navigation goals it shines in, `null` an open end;
    /// absent, it always shines.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub life_intervals: Option<Vec<[Option<u64>; 2]>>,
    /// Where it is: in the scene (Habitat axes), or, for a camera light, in the camera's
    /// frame (x right, y up, z backward).
    pub position: [f64; 3],
    /// `point`, or `camera` for a light riding with the camera.
    #[serde(rename = "type")]
    pub kind: String,
}

impl HadageLight {
    /// A light that shines all along.
    pub fn always(kind: &str, position: [f64; 3], intensity: f64, color: [f64; 3]) -> Self {
        HadageLight { color, intensity, life_intervals: Some(vec![[None, None]]), position, kind: kind.to_string() }
    }

    /// Whether it rides with the camera.
    pub fn attached_to_camera(&self) -> bool {
        self.kind == "camera"
    }

    /// Whether it shines during navigation segment `goal`.
    pub fn shines_in(&self, goal: usize) -> bool {
        let goal = goal as u64;
        self.life_intervals.as_ref().is_none_or(|runs| runs.iter().any(|[start, end]| start.is_none_or(|s| s <= goal) && end.is_none_or(|e| goal < e)))
    }
}

impl LightSettings {
    /// Read the file at `path`.
    pub fn read(path: &Path) -> Result<Self> {
        osmab_evaluator::formats::json::read(path)
    }

    /// Whether it holds no light at all (the `no_lights` condition: flat, unlit).
    pub fn is_unlit(&self) -> bool {
        self.lights.is_empty()
    }

    /// The file's text as every copy of it is written: pretty JSON.
    pub fn to_json(&self) -> String {
        serde_json::to_string_pretty(self).expect("light settings serialise")
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_light_shines_in_the_goals_of_its_runs_and_always_without_any() {
        let mut light = HadageLight::always("point", [0.0; 3], 1.0, [1.0; 3]);
        assert!((0..100).all(|g| light.shines_in(g)));
        light.life_intervals = Some(vec![[None, Some(1)], [Some(3), Some(5)], [Some(9), None]]);
        assert_eq!((0..12).filter(|g| light.shines_in(*g)).collect::<Vec<_>>(), [0, 3, 4, 9, 10, 11]);
        light.life_intervals = None;
        assert!(light.shines_in(7), "absent runs: always on");
    }

    #[test]
    fn a_file_reads_back_to_the_same_bytes_with_keys_as_an_untyped_writer_puts_them() {
        let text = r#"{"lights": {"0_on": {"type": "point", "position": [1.25, 2.38, -0.5], "intensity": 0.731, "color": [1.0, 0.98, 0.95], "life_intervals": [[0, 1], [3, null]]},
                        "1": {"type": "camera", "position": [0.0, 0.25, 0.75], "intensity": 0.8, "color": [1.0, 1.0, 1.0]}}}"#;
        let typed: LightSettings = serde_json::from_str(text).unwrap();
        let untyped: serde_json::Value = serde_json::from_str(text).unwrap();
        assert_eq!(typed.to_json(), serde_json::to_string_pretty(&untyped).unwrap());
        assert!(typed.lights["1"].attached_to_camera() && !typed.lights["0_on"].attached_to_camera());
        assert!(LightSettings::default().is_unlit());
    }
}
