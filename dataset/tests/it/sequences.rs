//! Trajectories and rendered sequences in HaDaGe's layout, read back by the evaluator.

use std::path::Path;

use osmab_dataset::convert::habitat::{ConvertOptions, write_habitat_scene};
use osmab_dataset::convert::scene::load_scene;
use osmab_dataset::prompts::grammar_pool;
use osmab_dataset::render::sequence::SensorSettings;
use osmab_dataset::render::trajectory::{Action, MotionSettings, NavGrid, trajectory};
use osmab_dataset::render::{LIGHTINGS, render_scene};
use osmab_dataset::spec::Regime;
use osmab_dataset::synthesis::synthesize;
use osmab_evaluator::formats::map::{MapSemantics, PredictedMap};
use osmab_evaluator::formats::sequence::Sequence;
use osmab_evaluator::ground_truth::GroundTruth;
use osmab_evaluator::semseg::score_scene;

/// A synthesized and converted scene in `dir/habitat`; returns its name.
fn converted_scene(dir: &Path) -> String {
    let prompt = grammar_pool(Regime::Manipuland, 1, 17).accepted.remove(0);
    synthesize(&prompt, 0, &dir.join("scenesmith"), false).unwrap();
    let scene = load_scene(&dir.join("scenesmith")).unwrap();
    write_habitat_scene(&scene, &dir.join("habitat"), &ConvertOptions::default()).unwrap();
    scene.name
}

fn small() -> (SensorSettings, MotionSettings) {
    (SensorSettings { width: 96, height: 64, ..Default::default() }, MotionSettings { goals: 3, max_frames: 120, ..Default::default() })
}

#[test]
fn trajectories_take_habitats_steps_through_free_space() {
    let dir = tempfile::tempdir().unwrap();
    let name = converted_scene(dir.path());
    let grid = NavGrid::read(&dir.path().join("habitat"), &name).unwrap();
    let motion = MotionSettings { goals: 4, ..Default::default() };
    let states = trajectory(&grid, &motion);
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
    assert_eq!(states, trajectory(&grid, &motion), "seeded");
}

#[test]
fn rendered_sequences_are_hadage_sequences_the_evaluator_reads() {
    let dir = tempfile::tempdir().unwrap();
    let name = converted_scene(dir.path());
    let (sensor, motion) = small();
    let out = dir.path().join("sequences");
    let summaries = render_scene(&dir.path().join("habitat"), &name, &LIGHTINGS, &sensor, &motion, &out).unwrap();
    assert_eq!(summaries.len(), 4);
    let trajectories: Vec<String> = LIGHTINGS.iter().map(|l| std::fs::read_to_string(out.join(l).join(&name).join("traj.txt")).unwrap()).collect();
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
    assert_eq!((score.metrics.miou, score.metrics.fmiou, score.metrics.macc), (1.0, 1.0, 1.0));
}

#[test]
fn rendering_twice_gives_identical_files() {
    let dir = tempfile::tempdir().unwrap();
    let name = converted_scene(dir.path());
    let (sensor, motion) = small();
    let motion = MotionSettings { max_frames: 24, ..motion };
    for run in ["a", "b"] {
        render_scene(&dir.path().join("habitat"), &name, &["dynamic_lights"], &sensor, &motion, &dir.path().join(run)).unwrap();
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
fn lights_switch_with_their_life_intervals_and_switched_off_lights_leave_the_ambient_term() {
    use osmab_dataset::render::sequence::{has_no_lights, lights_for_goal};
    let settings = serde_json::json!({"lights": {
        "0": {"type": "point", "position": [0.0, 2.0, 0.0], "intensity": 1.0, "color": [1.0, 1.0, 1.0], "life_intervals": [[null, 1]]},
        "1": {"type": "point", "position": [1.0, 2.0, 0.0], "intensity": 1.0, "color": [1.0, 1.0, 1.0], "life_intervals": [[2, 4]]},
        "2": {"type": "camera", "position": [0.0, 0.0, 0.0], "intensity": 1.0, "color": [1.0, 1.0, 1.0], "life_intervals": [[null, null]]}
    }});
    let on = |goal| lights_for_goal(&settings, goal).iter().map(|l| l.position[0]).collect::<Vec<_>>();
    assert_eq!(on(0), vec![0.0, 0.0]);
    assert_eq!(on(1), vec![0.0]);
    assert_eq!(on(2), vec![1.0, 0.0]);
    assert_eq!(on(4), vec![0.0]);
    assert!(!has_no_lights(&settings));
    assert!(has_no_lights(&serde_json::json!({"lights": {}})));
}

#[test]
fn trajectories_start_and_stay_in_the_largest_free_region() {
    // A 4×4 m room (x < 4 m) and, behind a wall, a 0.3 m pocket: every seed must start in the room.
    let (width, height, cell) = (50usize, 40usize, 0.1);
    let cells = (0..width * height)
        .map(|i| if (1..39).contains(&(i / width)) && ((1..40).contains(&(i % width)) || (45..48).contains(&(i % width))) { 255 } else { 0 })
        .collect();
    let grid = NavGrid { origin_xz: [0.0, 0.0], cell_size: cell, width, height, floor_height: 0.0, cells };
    for seed in 0..40 {
        let states = trajectory(&grid, &MotionSettings { goals: 2, seed, ..Default::default() });
        assert!(!states.is_empty(), "seed {seed}: no frames");
        assert!(states.iter().all(|s| s.x < 4.0), "seed {seed}: the pocket behind the wall was used");
    }
}
