//! The built-in CPU renderer: RGB, planar depth and semantic images of a converted
//! Habitat-style scene along a trajectory planned for coverage, with Habitat's
//! lighting model.

mod bvh;
pub mod camera;
pub mod coverage;
mod edges;
pub mod light;
pub mod light_bake;
pub mod loaders;
pub mod mesh;
pub mod navigation;
pub mod obj;
pub mod raster;
mod screen;
pub mod sequence;
pub mod surface;
pub mod trajectory;
pub mod view;

use std::path::Path;

use osmab_evaluator::formats::classes::{ClassEntry, ClassList};
use osmab_evaluator::scores::ReleaseLighting;
use osmab_evaluator::{InputError, Result};

use crate::convert::habitat::ConversionReport;
use crate::convert::lexicon::{is_shell_class, normalise_name};
use crate::convert::light_settings::LightSettings;
use camera::SensorSettings;
use coverage::{CoverageGoals, Plan, Target};
use navigation::NavGrid;
use sequence::{SequenceSummary, SequenceTarget, render_sequences};
use trajectory::{AgentState, MotionSettings};

/// The objects of a converted scene a trajectory must observe: everything but the
/// room's shell, those of `prompted` categories (names or classes) marked first.
pub fn scene_targets(report: &ConversionReport, prompted: &[String]) -> Vec<Target> {
    let prompted: Vec<&str> = prompted.iter().filter_map(|p| normalise_name(p)).collect();
    report
        .objects
        .iter()
        .filter(|o| !is_shell_class(&o.class))
        .map(|o| Target { instance_id: o.instance_id.clamp(0, u16::MAX as i64) as u16, class: o.class.clone(), prompted: prompted.contains(&o.class.as_str()) })
        .collect()
}

/// Plan the trajectory of the converted scene `scene` in `habitat_dir` (one for all
/// its lightings), observing its objects, those of the `prompted` categories first.
pub fn plan_scene(
    habitat_dir: &Path,
    scene: &str,
    sensor: &SensorSettings,
    motion: &MotionSettings,
    prompted: &[String],
    goals: &CoverageGoals,
) -> Result<Plan> {
    let world = mesh::World::load_habitat_scene(habitat_dir, scene)?;
    let grid = NavGrid::read(habitat_dir, scene)?;
    let report_path = habitat_dir.join("conversion_report.json");
    let report: ConversionReport = serde_json::from_slice(&std::fs::read(&report_path).map_err(|e| InputError::io(&report_path, &e))?)
        .map_err(|e| InputError::new(&report_path, "(json)", e.to_string()))?;
    let plan = coverage::plan(&world, &grid, sensor, motion, &scene_targets(&report, prompted), goals);
    if plan.frames.is_empty() {
        return Err(InputError::new(habitat_dir.join("navigation"), scene, "no trajectory: the navigable area is empty or the frame budget is too small"));
    }
    Ok(plan)
}

/// Render the converted scene `scene` in `habitat_dir` along `states` under each of
/// `lightings` into `out/<lighting>/<scene>/`, each lit by its own lights (and baked for
/// them), all of them drawn from one visibility pass a frame.
pub fn render_scene(
    habitat_dir: &Path,
    scene: &str,
    lightings: &[ReleaseLighting],
    sensor: &SensorSettings,
    states: &[AgentState],
    out: &Path,
) -> Result<Vec<(ReleaseLighting, SequenceSummary)>> {
    let mut settings_of = Vec::new();
    for lighting in lightings {
        settings_of.push(LightSettings::read(&habitat_dir.join("lighting_hadage").join(format!("light_settings_{scene}_{lighting}.json")))?);
    }
    let world = mesh::World::load_habitat_scene(habitat_dir, scene)?;
    let worlds = lit_worlds(&world, &settings_of);
    let grid = NavGrid::read(habitat_dir, scene)?;
    let classes_path = habitat_dir.join("semantics/classes.json");
    let classes = ClassList::read(&classes_path)?;
    let classes = ClassList::new(classes.entries().into_iter().map(|c| ClassEntry { name: c.name, id: c.id })).expect("unique");
    let settings = serde_json::json!({"scene_name": scene, "sensor": sensor});
    let targets: Vec<SequenceTarget> = lightings
        .iter()
        .zip(&settings_of)
        .zip(&worlds)
        .map(|((lighting, light_settings), world)| {
            let mut settings_copy = settings.clone();
            settings_copy["label"] = serde_json::json!(lighting);
            SequenceTarget { world, light_settings, settings_copy, dir: out.join(lighting.name()).join(scene) }
        })
        .collect();
    let summaries = render_sequences(&targets, states, grid.floor_height, sensor, &classes)?;
    Ok(lightings.iter().copied().zip(summaries).collect())
}

/// `world` lit for each of the HaDaGe light settings `lightings` on its own
/// ([`lit_world`]); lightings with the same static lights share one bake, and every
/// result shares `world`'s geometry.
pub fn lit_worlds(world: &mesh::World, lightings: &[LightSettings]) -> Vec<mesh::World> {
    let mut baked: Vec<(Vec<[f32; 3]>, bool, mesh::World)> = Vec::new();
    lightings
        .iter()
        .map(|settings| {
            let key = (static_light_positions(std::slice::from_ref(settings)), settings.is_unlit());
            if let Some((_, _, lit)) = baked.iter().find(|(positions, flat, _)| (positions, flat) == (&key.0, &key.1)) {
                return lit.clone();
            }
            let lit = lit_world(world.clone(), std::slice::from_ref(settings));
            baked.push((key.0, key.1, lit.clone()));
            lit
        })
        .collect()
}

/// `world` with its light baked for the static lights of the HaDaGe light settings
/// `lightings` (all their positions, whatever goals they shine in), when any of them is lit:
/// ambient occlusion and shadows. The ceiling's fixtures cast no shadow.
pub fn lit_world(world: mesh::World, lightings: &[LightSettings]) -> mesh::World {
    if lightings.iter().all(LightSettings::is_unlit) {
        return world;
    }
    let positions = static_light_positions(lightings);
    let fixtures = crate::convert::lexicon::class_id("ceiling").map(|id| id as u16);
    world.with_light_bake(&positions, fixtures, &mesh::shell_surface_ids())
}

/// The positions of the lights of `lightings` that are not attached to the camera, each
/// once, in the order the settings list them.
fn static_light_positions(lightings: &[LightSettings]) -> Vec<[f32; 3]> {
    let mut positions: Vec<[f32; 3]> = Vec::new();
    for settings in lightings {
        for light in settings.lights.values() {
            let position = light.position.map(|v| v as f32);
            if !light.attached_to_camera() && !positions.contains(&position) {
                positions.push(position);
            }
        }
    }
    positions
}
