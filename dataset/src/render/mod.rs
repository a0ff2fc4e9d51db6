//! The built-in CPU renderer: RGB, planar depth and semantic images of a converted
//! Habitat-style scene, with Habitat's lighting model.

pub mod mesh;
pub mod obj;
pub mod raster;
pub mod sequence;
pub mod trajectory;

use std::path::Path;

use osmab_evaluator::formats::classes::{ClassEntry, ClassList};
use osmab_evaluator::{InputError, Result};

use sequence::{SensorSettings, SequenceSummary, render_sequence};
use trajectory::{MotionSettings, NavGrid, trajectory};

/// The four lighting conditions of OSMa-Bench++.
pub const LIGHTINGS: [&str; 4] = ["baseline", "camera", "dynamic_lights", "no_lights"];

/// Render the converted scene `scene` in `habitat_dir` under each of `lightings`, all
/// along the same trajectory, into `out/<lighting>/<scene>/`.
pub fn render_scene(
    habitat_dir: &Path,
    scene: &str,
    lightings: &[&str],
    sensor: &SensorSettings,
    motion: &MotionSettings,
    out: &Path,
) -> Result<Vec<(String, SequenceSummary)>> {
    let world = mesh::World::load_habitat_scene(habitat_dir, scene)?;
    let grid = NavGrid::read(habitat_dir, scene)?;
    let states = trajectory(&grid, motion);
    if states.is_empty() {
        return Err(InputError::new(habitat_dir.join("navigation"), scene, "no trajectory: the navigable area is empty or no goal is reachable"));
    }
    let classes_path = habitat_dir.join("semantics/classes.json");
    let classes = ClassList::read(&classes_path)?;
    let classes = ClassList::new(classes.entries().into_iter().map(|c| ClassEntry { name: c.name, id: c.id })).expect("unique");
    let settings = serde_json::json!({"scene_name": scene, "sensor": sensor, "motion": motion});
    let mut out_list = Vec::new();
    for lighting in lightings {
        let path = habitat_dir.join("lighting_hadage").join(format!("light_settings_{scene}_{lighting}.json"));
        let lights: serde_json::Value = serde_json::from_slice(&std::fs::read(&path).map_err(|e| InputError::io(&path, &e))?)
            .map_err(|e| InputError::new(&path, "(json)", e.to_string()))?;
        let mut settings = settings.clone();
        settings["label"] = serde_json::json!(lighting);
        let summary = render_sequence(&world, &states, grid.floor_height, sensor, &lights, &classes, &settings, &out.join(lighting).join(scene))?;
        out_list.push((lighting.to_string(), summary));
    }
    Ok(out_list)
}
