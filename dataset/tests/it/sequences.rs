//! Trajectories and rendered sequences in HaDaGe's layout, read back by the evaluator.

use std::path::Path;

use osmab_dataset::convert::habitat::{ConvertOptions, write_habitat_scene};
use osmab_dataset::convert::scene::load_scene;
use osmab_dataset::prompts::grammar_pool;
use osmab_dataset::render::camera::{SensorSettings, camera_pose};
use osmab_dataset::render::coverage::{CoverageGoals, Plan, plan};
use osmab_dataset::render::mesh::World;
use osmab_dataset::render::navigation::NavGrid;
use osmab_dataset::render::trajectory::{Action, AgentState, MotionSettings};
use osmab_dataset::render::{plan_scene, render_scene};
use osmab_dataset::spec::Regime;
use osmab_dataset::synthesis::source::AssetSource;
use osmab_dataset::synthesis::synthesize;
use osmab_evaluator::formats::map::{MapSemantics, PredictedMap};
use osmab_evaluator::formats::sequence::Sequence;
use osmab_evaluator::ground_truth::GroundTruth;
use osmab_evaluator::scores::ReleaseLighting;
use osmab_evaluator::semseg::score_scene;

/// A synthesized and converted scene in `dir/habitat`; returns its name.
fn converted_scene(dir: &Path) -> String {
    let prompt = grammar_pool(Regime::Manipuland, 1, 17).accepted.remove(0);
    synthesize(&prompt, 0, &dir.join("scenesmith"), false, &AssetSource::procedural()).unwrap();
    let scene = load_scene(&dir.join("scenesmith")).unwrap();
    write_habitat_scene(&scene, &dir.join("habitat"), &ConvertOptions::default()).unwrap();
    scene.name
}

fn small() -> (SensorSettings, MotionSettings) {
    (
        SensorSettings { width: 96, height: 64, camera_pitch_deg: -20.0, ..Default::default() },
        MotionSettings { goals: 3, max_frames: 120, ..Default::default() },
    )
}

/// The trajectory of the converted scene `name` in `dir/habitat`.
fn planned(dir: &Path, name: &str, sensor: &SensorSettings, motion: &MotionSettings) -> Plan {
    plan_scene(&dir.join("habitat"), name, sensor, motion, &[], &CoverageGoals::default()).unwrap()
}

#[test]
fn trajectories_take_habitats_steps_through_free_space() {
    let dir = tempfile::tempdir().unwrap();
    let name = converted_scene(dir.path());
    let grid = NavGrid::read(&dir.path().join("habitat"), &name).unwrap();
    let (sensor, _) = small();
    let motion = MotionSettings { goals: 4, ..Default::default() };
    let states = planned(dir.path(), &name, &sensor, &motion).frames;
    assert!(states.len() > 20, "{} frames", states.len());
    for pair in states.windows(2) {
        let (a, b) = (pair[0], pair[1]);
        assert!(grid.navigable(b.x, b.z), "a frame outside free space at ({}, {})", b.x, b.z);
        let moved = ((b.x - a.x).powi(2) + (b.z - a.z).powi(2)).sqrt();
        let turned = (b.yaw - a.yaw).abs().to_degrees();
        match b.action {
            Action::MoveForward => assert!((moved - 0.03).abs() < 1e-9 && turned < 1e-9, "a forward sub-step is 3 cm"),
            _ => assert!(moved < 1e-9 && (turned - 2.0).abs() < 1e-9, "a turn sub-step is 2°"),
        }
    }
    assert_eq!(states, planned(dir.path(), &name, &sensor, &motion).frames, "deterministic");
}

#[test]
fn planned_trajectories_observe_every_object_from_two_viewpoints_and_travel() {
    let dir = tempfile::tempdir().unwrap();
    let name = converted_scene(dir.path());
    let sensor = SensorSettings { width: 320, height: 180, camera_pitch_deg: -20.0, ..Default::default() };
    let motion = MotionSettings { goals: 3, max_frames: 600, sub_steps: 1, ..Default::default() };
    let goals = CoverageGoals::default();
    let plan = planned(dir.path(), &name, &sensor, &motion);
    assert!(plan.coverage.len() >= 3, "{:?}", plan.coverage);
    for c in &plan.coverage {
        assert!(c.satisfied(&goals), "{} (instance {}) planned: {c:?}", c.class, c.instance_id);
    }
    assert!(plan.travelled >= goals.min_travel, "{} m in {} frames: {:?}", plan.travelled, plan.frames.len(), plan.viewpoints);
    assert!(plan.goals >= motion.goals, "{} goals", plan.goals);
    assert!(plan.frames.len() < motion.max_frames, "covered within the budget: {} frames", plan.frames.len());
    assert!(plan.degenerate_frames * 10 <= plan.frames.len(), "{} of {} frames degenerate", plan.degenerate_frames, plan.frames.len());
    // Goals are numbered in order from the look-around at the start (goal 0).
    assert_eq!(plan.frames[0].goal_index, 0);
    assert!(plan.frames.windows(2).all(|w| w[1].goal_index == w[0].goal_index || w[1].goal_index == w[0].goal_index + 1));

    // What the rendered sequence shows agrees: every object from two separate places.
    let rendered = render_scene(&dir.path().join("habitat"), &name, &[ReleaseLighting::NoLights], &sensor, &plan.frames, &dir.path().join("seq")).unwrap();
    let summary = &rendered[0].1;
    for c in &plan.coverage {
        let seen = summary.objects.get(&c.instance_id).unwrap_or_else(|| panic!("{} never drawn", c.class));
        assert!(seen.viewpoints.len() >= if c.prompted { 2 } else { 1 }, "{}: {seen:?}", c.class);
        assert!(seen.points >= 10.0, "{}: {seen:?}", c.class);
    }
    assert!((summary.travelled - plan.travelled).abs() < 1e-6);
}

#[test]
fn a_pitched_camera_looks_down_and_level_poses_print_no_negative_zeros() {
    let state = AgentState { x: 1.0, z: 2.0, yaw: 0.3, goal_index: 0, action: Action::TurnLeft };
    let level = camera_pose(&state, 0.0, &SensorSettings::default());
    let pitched = camera_pose(&state, 0.0, &SensorSettings { camera_pitch_deg: -20.0, ..Default::default() });
    // OpenCV axes: column 2 is the viewing direction, column 1 points down in the image.
    assert!(level[(1, 2)].abs() < 1e-15, "a level camera looks horizontally");
    assert!((pitched[(1, 2)] - (-20f64).to_radians().sin()).abs() < 1e-12, "20° down");
    assert_eq!((pitched[(0, 3)], pitched[(1, 3)], pitched[(2, 3)]), (1.0, 1.0, 2.0), "the camera sits at the sensor height");
    let r = pitched.fixed_view::<3, 3>(0, 0);
    assert!((r.transpose() * r - nalgebra::Matrix3::identity()).norm() < 1e-12, "a rotation");
    let straight = camera_pose(&AgentState { yaw: 0.0, ..state }, 0.0, &SensorSettings::default());
    assert!(straight.iter().all(|v| !(*v == 0.0 && v.is_sign_negative())), "{straight}");
}

#[test]
fn rendered_sequences_are_hadage_sequences_the_evaluator_reads() {
    let dir = tempfile::tempdir().unwrap();
    let name = converted_scene(dir.path());
    let (sensor, motion) = small();
    let out = dir.path().join("sequences");
    let states = planned(dir.path(), &name, &sensor, &motion).frames;
    let summaries = render_scene(&dir.path().join("habitat"), &name, &ReleaseLighting::ALL, &sensor, &states, &out).unwrap();
    assert_eq!(summaries.len(), 4);
    let trajectories: Vec<String> =
        ReleaseLighting::ALL.iter().map(|l| std::fs::read_to_string(out.join(l.name()).join(&name).join("traj.txt")).unwrap()).collect();
    assert!(trajectories.windows(2).all(|t| t[0] == t[1]), "the same trajectory under every lighting");

    let baseline = out.join("baseline").join(&name);
    let sequence = Sequence::open(&baseline).unwrap();
    assert_eq!(sequence.len(), summaries[0].1.frames);
    assert_eq!((sequence.camera.fx, sequence.camera.cx, sequence.camera.cy), (48.00000000000001, 47.5, 31.5));
    let log = std::fs::read_to_string(baseline.join("log.txt")).unwrap();
    assert!(log.starts_with("[000000] Action: "));
    // Different lightings, different pixels; same geometry and semantics.
    let frame = |l: &str, kind: &str, ext: &str| std::fs::read(out.join(l).join(&name).join(format!("results/{kind}000010.{ext}"))).unwrap();
    assert_ne!(frame("baseline", "frame", "jpg"), frame("no_lights", "frame", "jpg"));
    assert_eq!(frame("baseline", "depth", "png"), frame("camera", "depth", "png"));
    assert_eq!(frame("baseline", "semantic", "png"), frame("no_lights", "semantic", "png"));
    // Every frame's depth and semantics are the same under every lighting; the colours of
    // dynamic_lights differ from baseline's from the first goal on.
    for (_, s) in &summaries[1..] {
        assert!(s.per_frame.iter().zip(&summaries[0].1.per_frame).all(|(a, b)| a.geometry_digest == b.geometry_digest));
    }
    let dynamic = &summaries.iter().find(|(l, _)| *l == ReleaseLighting::DynamicLights).unwrap().1;
    let differing = dynamic.per_frame.iter().zip(&summaries[0].1.per_frame).filter(|(a, b)| a.colour_digest != b.colour_digest).count();
    assert!(differing * 10 >= 8 * dynamic.frames, "{differing} of {} frames differ", dynamic.frames);
    // ConceptGraphs' dataconfig sits beside camera_params.yaml.
    assert!(baseline.join(osmab_dataset::render::loaders::CONCEPTGRAPHS_CONFIG).is_file());

    // Ground truth from the rendered sequence, and the oracle map made from it, score 1.
    let classes = sequence.classes().unwrap();
    let gt = GroundTruth::build(&sequence).unwrap();
    let ids: Vec<i64> = classes.entries().iter().map(|c| c.id).collect();
    let oracle = PredictedMap {
        source: "oracle".into(),
        points: gt.points.clone(),
        semantics: MapSemantics::ObjectLabels { object_ids: gt.labels.iter().map(|l| ids.iter().position(|c| c == l).unwrap() as u32).collect(), labels: ids },
    };
    let score = score_scene(&gt, &oracle, &classes, None).unwrap();
    assert!(score.metrics.classes.len() >= 3, "floor, walls and furniture are seen: {:?}", score.confusion.labels());
    // f-mIoU sums the classes' shares of the points as the reference does (NumPy's pairwise
    // sum): with every IoU 1 that sum may land an ulp below 1.
    assert_eq!((score.metrics.miou, score.metrics.macc), (1.0, 1.0));
    assert!(1.0 - score.metrics.fmiou < 1e-12, "{}", score.metrics.fmiou);
}

#[test]
fn rendering_twice_gives_identical_files() {
    let dir = tempfile::tempdir().unwrap();
    let name = converted_scene(dir.path());
    let (sensor, motion) = small();
    let motion = MotionSettings { max_frames: 24, ..motion };
    for run in ["a", "b"] {
        let states = planned(dir.path(), &name, &sensor, &motion).frames;
        render_scene(&dir.path().join("habitat"), &name, &[ReleaseLighting::DynamicLights], &sensor, &states, &dir.path().join(run)).unwrap();
    }
    let read = |run: &str| {
        let root = dir.path().join(run).join("dynamic_lights").join(&name).join("results");
        let mut files: Vec<(String, Vec<u8>)> = std::fs::read_dir(&root)
            .unwrap()
            .map(|e| e.unwrap().path())
            .map(|p| (p.file_name().unwrap().to_string_lossy().to_string(), std::fs::read(&p).unwrap()))
            .collect();
        files.sort();
        files
    };
    assert_eq!(read("a"), read("b"));
}

#[test]
fn the_lightings_of_a_scene_drawn_together_are_the_files_of_each_drawn_alone() {
    // One visibility pass a frame shaded under four lightings (each baked for its own
    // lights), depth and semantics encoded once: byte for byte what one lighting at a time gives.
    let dir = tempfile::tempdir().unwrap();
    let name = converted_scene(dir.path());
    let (sensor, motion) = small();
    let states = planned(dir.path(), &name, &sensor, &MotionSettings { max_frames: 30, ..motion }).frames;
    let habitat = dir.path().join("habitat");
    let together = render_scene(&habitat, &name, &ReleaseLighting::ALL, &sensor, &states, &dir.path().join("together")).unwrap();
    for (lighting, summary) in &together {
        let alone = render_scene(&habitat, &name, &[*lighting], &sensor, &states, &dir.path().join("alone")).unwrap();
        assert_eq!(serde_json::to_value(summary).unwrap(), serde_json::to_value(&alone[0].1).unwrap(), "{lighting}: the summary");
        let files = |root: &str| -> Vec<(String, Vec<u8>)> {
            let folder = dir.path().join(root).join(lighting.name()).join(&name);
            let mut files: Vec<(String, Vec<u8>)> =
                walk(&folder).into_iter().map(|p| (p.strip_prefix(&folder).unwrap().display().to_string(), std::fs::read(&p).unwrap())).collect();
            files.sort();
            files
        };
        let (drawn_together, drawn_alone) = (files("together"), files("alone"));
        assert_eq!(drawn_together.len(), drawn_alone.len(), "{lighting}: the same files");
        assert!(drawn_together.len() > 3 * states.len(), "{lighting}: colour, depth and semantics of every frame");
        for ((path, bytes), (path_alone, bytes_alone)) in drawn_together.iter().zip(&drawn_alone) {
            assert_eq!(path, path_alone);
            assert!(bytes == bytes_alone, "{lighting}: {path} differs");
        }
    }
}

/// Every file under `dir`, at any depth.
fn walk(dir: &Path) -> Vec<std::path::PathBuf> {
    let mut files = Vec::new();
    for entry in std::fs::read_dir(dir).unwrap() {
        let path = entry.unwrap().path();
        if path.is_dir() { files.extend(walk(&path)) } else { files.push(path) }
    }
    files
}

#[test]
fn lights_switch_with_their_life_intervals_and_switched_off_lights_leave_the_ambient_term() {
    use osmab_dataset::convert::light_settings::LightSettings;
    use osmab_dataset::render::sequence::lights_for_goal;
    let settings: LightSettings = serde_json::from_value(serde_json::json!({"lights": {
        "0": {"type": "point", "position": [0.0, 2.0, 0.0], "intensity": 1.0, "color": [1.0, 1.0, 1.0], "life_intervals": [[null, 1]]},
        "1": {"type": "point", "position": [1.0, 2.0, 0.0], "intensity": 1.0, "color": [1.0, 1.0, 1.0], "life_intervals": [[2, 4]]},
        "2": {"type": "camera", "position": [0.0, 0.0, 0.0], "intensity": 1.0, "color": [1.0, 1.0, 1.0], "life_intervals": [[null, null]]}
    }}))
    .unwrap();
    let on = |goal| lights_for_goal(&settings, goal).iter().map(|l| l.position[0]).collect::<Vec<_>>();
    assert_eq!(on(0), vec![0.0, 0.0]);
    assert_eq!(on(1), vec![0.0]);
    assert_eq!(on(2), vec![1.0, 0.0]);
    assert_eq!(on(4), vec![0.0]);
    assert!(!settings.is_unlit());
    assert!(serde_json::from_str::<LightSettings>(r#"{"lights": {}}"#).unwrap().is_unlit());
}

#[test]
fn trajectories_start_and_stay_in_the_largest_free_region() {
    // A 4×4 m room (x < 4 m) and, behind a wall, a 0.3 m pocket: every seed must start in the room.
    let (width, height, cell) = (50usize, 40usize, 0.1);
    let cells = (0..width * height)
        .map(|i| if (1..39).contains(&(i / width)) && ((1..40).contains(&(i % width)) || (45..48).contains(&(i % width))) { 255 } else { 0 })
        .collect();
    let grid = NavGrid::new([0.0, 0.0], cell, width, height, 0.0, cells);
    let sensor = SensorSettings { width: 32, height: 18, ..Default::default() };
    for seed in 0..20 {
        let motion = MotionSettings { goals: 2, seed, max_frames: 400, ..Default::default() };
        let states = plan(&World::default(), &grid, &sensor, &motion, &[], &CoverageGoals::default()).frames;
        assert!(!states.is_empty(), "seed {seed}: no frames");
        assert!(states.iter().all(|s| s.x < 4.0), "seed {seed}: the pocket behind the wall was used");
        assert!(states.iter().all(|s| grid.navigable(s.x, s.z)));
    }
}
