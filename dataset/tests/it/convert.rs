//! Drake/SceneSmith → Habitat conversion, on real SceneSmith assets and on small
//! hand-made scenes.

use std::path::{Path, PathBuf};

use osmab_dataset::convert::gltf::read_gltf;
use osmab_dataset::convert::habitat::{ConvertOptions, write_habitat_scene};
use osmab_dataset::convert::scene::load_scene;
use serde_json::Value;

fn scene_000() -> PathBuf {
    let dir = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../shared/fixtures/scenesmith/scene_000");
    assert!(dir.is_dir(), "fixture missing: {}", dir.display());
    dir
}

fn json(path: &Path) -> Value {
    serde_json::from_slice(&std::fs::read(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()))).unwrap()
}

#[test]
fn scene_000_converts_with_every_object_classified_and_placed() {
    let out = tempfile::tempdir().unwrap();
    let scene = load_scene(&scene_000()).unwrap();
    let report = write_habitat_scene(&scene, out.path(), &ConvertOptions::default()).unwrap();
    let classes: Vec<&str> = report.objects.iter().map(|o| o.class.as_str()).collect();
    for expected in ["floor", "wall", "bed", "desk", "office chair", "printer", "mug"] {
        assert!(classes.contains(&expected), "{expected} missing from {classes:?}");
    }
    assert_eq!(classes.iter().filter(|c| **c == "wall").count(), 4);
    assert!(report.unknown_names.is_empty(), "{:?}", report.unknown_names);

    // Every object's Habitat box is its house_state box moved by the Drake pose and
    // C: (x, y, z) -> (x, z, -y), to the millimetre.
    let state = json(&scene_000().join("combined_house/house_state.json"));
    for (object_id, o) in state["rooms"]["main"]["objects"].as_object().unwrap() {
        let converted = report.objects.iter().find(|c| c.model == format!("main_{object_id}")).unwrap_or_else(|| panic!("{object_id} not converted"));
        let t: Vec<f64> = o["transform"]["translation"].as_array().unwrap().iter().map(|v| v.as_f64().unwrap()).collect();
        let q: Vec<f64> = o["transform"]["rotation_wxyz"].as_array().unwrap().iter().map(|v| v.as_f64().unwrap()).collect();
        let rotation = nalgebra::UnitQuaternion::from_quaternion(nalgebra::Quaternion::new(q[0], q[1], q[2], q[3]));
        let (lo, hi) = (&o["bbox_min"], &o["bbox_max"]);
        let (mut elo, mut ehi) = ([f64::INFINITY; 3], [f64::NEG_INFINITY; 3]);
        for i in 0..8 {
            let pick = |k: usize| if i >> k & 1 == 0 { lo[k].as_f64().unwrap() } else { hi[k].as_f64().unwrap() };
            let p = rotation * nalgebra::Vector3::new(pick(0), pick(1), pick(2)) + nalgebra::Vector3::new(t[0], t[1], t[2]);
            let h = [p.x, p.z, -p.y];
            for a in 0..3 {
                elo[a] = elo[a].min(h[a]);
                ehi[a] = ehi[a].max(h[a]);
            }
        }
        for a in 0..3 {
            assert!(
                (converted.bbox_min[a] - elo[a]).abs() < 1e-3 && (converted.bbox_max[a] - ehi[a]).abs() < 1e-3,
                "{object_id} axis {a}: {:?}..{:?} vs {elo:?}..{ehi:?}",
                converted.bbox_min,
                converted.bbox_max
            );
        }
    }

    // What Habitat does with the written instances: translation · rotation · scale on the
    // glTF asset as it is. Each furniture box must come out where house_state says.
    let instance = json(&out.path().join("scenes/scene_000.scene_instance.json"));
    for object in report.objects.iter().filter(|o| o.model.starts_with("main_")) {
        let placed = instance["object_instances"].as_array().unwrap().iter().find(|i| i["template_name"].as_str().unwrap().contains(&object.model)).unwrap();
        let template = json(&out.path().join("objects").join(format!("{}.object_config.json", placed["template_name"].as_str().unwrap())));
        let asset = read_gltf(&out.path().join("objects").join(template["render_asset"].as_str().unwrap())).unwrap();
        let (lo, hi) = asset.bounds().unwrap();
        let v = |k: &str| -> Vec<f64> { placed[k].as_array().unwrap().iter().map(|x| x.as_f64().unwrap()).collect() };
        let (t, q, s) = (v("translation"), v("rotation"), v("non_uniform_scale"));
        let rotation = nalgebra::UnitQuaternion::from_quaternion(nalgebra::Quaternion::new(q[0], q[1], q[2], q[3]));
        let (mut wlo, mut whi) = ([f64::INFINITY; 3], [f64::NEG_INFINITY; 3]);
        for i in 0..8 {
            let c = |k: usize| if i >> k & 1 == 0 { lo[k] as f64 } else { hi[k] as f64 };
            let p = rotation * nalgebra::Vector3::new(c(0) * s[0], c(1) * s[1], c(2) * s[2]) + nalgebra::Vector3::new(t[0], t[1], t[2]);
            for a in 0..3 {
                wlo[a] = wlo[a].min(p[a]);
                whi[a] = whi[a].max(p[a]);
            }
        }
        for a in 0..3 {
            assert!(
                (wlo[a] - object.bbox_min[a]).abs() < 1e-3 && (whi[a] - object.bbox_max[a]).abs() < 1e-3,
                "{}: Habitat puts it at {wlo:?}..{whi:?}, expected {:?}..{:?}",
                object.model,
                object.bbox_min,
                object.bbox_max
            );
        }
    }
    let bed = instance["object_instances"].as_array().unwrap().iter().find(|i| i["template_name"].as_str().unwrap().contains("king_bed")).unwrap();
    assert_eq!(bed["translation"], serde_json::json!([-0.8, 0.0, -1.2]));
    let lexicon = json(&out.path().join("semantics/scene_000.lexicon.json"));
    let template = json(&out.path().join("objects/scene_000__main_king_bed_0__visual.object_config.json"));
    let id = template["semantic_id"].as_i64().unwrap();
    assert!(lexicon["classes"].as_array().unwrap().iter().any(|c| c["id"] == id && c["name"] == "bed"));
    assert_eq!(template["up"], serde_json::json!([0.0, 1.0, 0.0]));
    // The copied asset loads, with normals generated (SceneSmith's glTF has none).
    let asset = read_gltf(&out.path().join("assets/main_king_bed_0/visual/king_bed.gltf")).unwrap();
    assert!(asset.generated_normals);
    let mesh = &asset.meshes[0];
    assert_eq!(mesh.normals.len(), mesh.positions.len());
    assert!(mesh.normals.iter().all(|n| ((n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt() - 1.0).abs() < 1e-4));
    assert!(asset.materials[0].texture.is_some(), "the texture in a buffer view decodes");
    assert_eq!(report.generated_normals.len(), 5);
    for condition in ["baseline", "camera", "dynamic_lights", "no_lights"] {
        let habitat = json(&out.path().join(format!("lighting/scene_000.{condition}.lighting_config.json")));
        let hadage = json(&out.path().join(format!("lighting_hadage/light_settings_scene_000_{condition}.json")));
        assert_eq!(habitat["lights"].as_object().unwrap().len(), hadage["lights"].as_object().unwrap().len(), "{condition}");
    }
    let baseline = json(&out.path().join("lighting_hadage/light_settings_scene_000_baseline.json"));
    for light in baseline["lights"].as_object().unwrap().values() {
        let p = &light["position"];
        // Inside the 5 x 5 m room, under its 2 m walls.
        assert!(p[0].as_f64().unwrap().abs() < 2.5 && p[2].as_f64().unwrap().abs() < 2.5 && p[1].as_f64().unwrap() < 2.0, "{light}");
    }
    assert_eq!(instance["stage_instance"]["template_name"], "NONE");
}

#[test]
fn the_navigable_map_blocks_furniture_and_keeps_open_floor() {
    let out = tempfile::tempdir().unwrap();
    let report = write_habitat_scene(&load_scene(&scene_000()).unwrap(), out.path(), &ConvertOptions::default()).unwrap();
    let meta = json(&out.path().join("navigation/scene_000.navigable.json"));
    let decoder = png::Decoder::new(std::io::BufReader::new(std::fs::File::open(out.path().join("navigation/scene_000.navigable.png")).unwrap()));
    let mut reader = decoder.read_info().unwrap();
    let mut cells = vec![0; reader.output_buffer_size().unwrap()];
    reader.next_frame(&mut cells).unwrap();
    let (ox, oz, cell, width) = (
        meta["origin_xz"][0].as_f64().unwrap(),
        meta["origin_xz"][1].as_f64().unwrap(),
        meta["cell_size"].as_f64().unwrap(),
        meta["width"].as_u64().unwrap() as usize,
    );
    let at = |x: f64, z: f64| cells[((z - oz) / cell) as usize * width + ((x - ox) / cell) as usize];
    assert_eq!(at(-0.8, -1.2), 0, "under the bed");
    assert_eq!(at(-0.5, 0.8), 255, "open floor between bed and desk");
    assert_eq!(at(-2.45, 0.0), 0, "next to a wall, within the agent radius");
    assert!(report.navigable_fraction > 0.2 && report.navigable_fraction < 0.9);
}

fn all_files(dir: &Path) -> Vec<(PathBuf, Vec<u8>)> {
    let mut out = Vec::new();
    for entry in std::fs::read_dir(dir).unwrap() {
        let path = entry.unwrap().path();
        if path.is_dir() {
            out.extend(all_files(&path).into_iter().map(|(p, b)| (Path::new(path.file_name().unwrap()).join(p), b)));
        } else {
            out.push((PathBuf::from(path.file_name().unwrap()), std::fs::read(&path).unwrap()));
        }
    }
    out.sort();
    out
}

#[test]
fn converting_twice_gives_identical_files() {
    let (a, b) = (tempfile::tempdir().unwrap(), tempfile::tempdir().unwrap());
    for out in [&a, &b] {
        write_habitat_scene(&load_scene(&scene_000()).unwrap(), out.path(), &ConvertOptions::default()).unwrap();
    }
    assert_eq!(all_files(a.path()), all_files(b.path()));
}

/// A one-model scene with a box visual and the given directives.
fn tiny_scene(directives: &str, sdf_uri: &str) -> tempfile::TempDir {
    let dir = tempfile::tempdir().unwrap();
    std::fs::create_dir_all(dir.path().join("combined_house")).unwrap();
    std::fs::create_dir_all(dir.path().join("assets")).unwrap();
    std::fs::write(dir.path().join("package.xml"), "<package><name>scene</name></package>").unwrap();
    std::fs::write(
        dir.path().join("assets/crate.sdf"),
        format!(r#"<sdf version="1.7"><model name="crate"><link name="base_link"><visual name="v"><geometry><mesh><uri>{sdf_uri}</uri></mesh></geometry></visual></link></model></sdf>"#),
    )
    .unwrap();
    std::fs::write(dir.path().join("combined_house/house.dmd.yaml"), directives).unwrap();
    dir
}

const MODEL: &str = "- add_model:\n    name: main_crate_0\n    file: package://scene/assets/crate.sdf\n";

fn load_error(directives: &str, uri: &str) -> String {
    let scene = tiny_scene(directives, uri);
    std::fs::write(scene.path().join("assets/crate.obj"), "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n").unwrap();
    load_scene(scene.path()).unwrap_err().to_string()
}

#[test]
fn malformed_scenes_get_clear_errors() {
    let cases = [
        (
            format!("directives:\n{MODEL}    default_free_body_pose:\n      base_link:\n        base_frame: world\n        rotation: !Quaternion {{w: 1}}\n"),
            "crate.obj",
            "unknown rotation tag '!Quaternion'",
        ),
        (format!("directives:\n{MODEL}"), "missing.obj", "does not exist"),
        (format!("directives:\n{MODEL}"), "../../../../../etc/passwd", "outside the scene directory"),
        (
            format!(
                "directives:\n- add_frame:\n    name: a\n    X_PF: {{base_frame: b}}\n- add_frame:\n    name: b\n    X_PF: {{base_frame: a}}\n{MODEL}- add_weld:\n    parent: a\n    child: main_crate_0::base_link\n"
            ),
            "crate.obj",
            "cycle",
        ),
        (
            format!("directives:\n{MODEL}- add_weld:\n    parent: nowhere_frame\n    child: main_crate_0::base_link\n"),
            "crate.obj",
            "unknown frame 'nowhere_frame'",
        ),
        ("directives:\n- add_robot: {name: r2d2}\n".to_string(), "crate.obj", "unknown directive 'add_robot'"),
        (
            format!("directives:\n{MODEL}    default_free_body_pose:\n      wheel_link:\n        translation: [0, 0, 0]\n"),
            "crate.obj",
            "has no link 'wheel_link'",
        ),
        (format!("directives:\n{MODEL}    default_free_body_pose:\n      base_link:\n        translation: [0, nan, 0]\n"), "crate.obj", "3 finite numbers"),
    ];
    for (directives, uri, needle) in cases {
        let scene = tiny_scene(&directives, uri);
        std::fs::write(scene.path().join("assets/crate.obj"), "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n").unwrap();
        let err = load_scene(scene.path()).map(|_| ()).unwrap_err().to_string();
        assert!(err.contains(needle), "'{needle}' not in: {err}");
    }
    assert!(load_error("not: [valid", "x.obj").contains("not valid YAML"));
}

#[test]
fn a_broken_texture_falls_back_to_the_base_colour_and_is_reported() {
    let dir = tempfile::tempdir().unwrap();
    let source = scene_000().join("room_main/generated_assets/furniture/sdf/work_desk_1761578426");
    for entry in std::fs::read_dir(&source).unwrap() {
        let path = entry.unwrap().path();
        std::fs::copy(&path, dir.path().join(path.file_name().unwrap())).unwrap();
    }
    let gltf = dir.path().join("work_desk.gltf");
    let mut doc = json(&gltf);
    doc["images"][0]["bufferView"] = serde_json::json!(1); // vertex data, not a PNG
    std::fs::write(&gltf, doc.to_string()).unwrap();
    let asset = read_gltf(&gltf).unwrap();
    assert!(asset.materials[0].texture.is_none());
    assert!(asset.materials[0].texture_problem.as_ref().unwrap().contains("neither PNG nor JPEG"));
    // A missing buffer, though, is an error naming it.
    std::fs::remove_file(dir.path().join("gltf_buffer_1.bin")).unwrap();
    let err = read_gltf(&gltf).unwrap_err();
    assert!(err.to_string().contains("gltf_buffer_1.bin"), "{err}");
}

#[test]
fn hostile_gltf_files_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("evil.gltf");
    let base = serde_json::json!({"asset": {"version": "2.0"}, "scenes": [{"nodes": [0]}], "meshes": [], "buffers": [], "bufferViews": [], "accessors": []});
    // Node 0 lists node 1 twice: a DAG that would be walked exponentially often.
    let mut shared = base.clone();
    shared["nodes"] = serde_json::json!([{"children": [1, 1]}, {"children": []}]);
    std::fs::write(&path, shared.to_string()).unwrap();
    assert!(read_gltf(&path).unwrap_err().message.contains("reached twice"));
    // An accessor whose stride would read far past its buffer.
    let mut strided = base.clone();
    strided["buffers"] = serde_json::json!([{"uri": "data:application/octet-stream;base64,AAAAAAAAAAAAAAAA", "byteLength": 12}]);
    strided["bufferViews"] = serde_json::json!([{"buffer": 0, "byteLength": 12, "byteStride": 4000}]);
    strided["accessors"] = serde_json::json!([{"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3"}]);
    strided["meshes"] = serde_json::json!([{"primitives": [{"attributes": {"POSITION": 0}}]}]);
    strided["nodes"] = serde_json::json!([{"mesh": 0}]);
    std::fs::write(&path, strided.to_string()).unwrap();
    assert!(read_gltf(&path).unwrap_err().message.contains("byteStride"));
    // A buffer that claims to live outside the asset's folder.
    let mut escape = base;
    escape["buffers"] = serde_json::json!([{"uri": "../../../../etc/passwd", "byteLength": 1}]);
    escape["nodes"] = serde_json::json!([]);
    std::fs::write(&path, escape.to_string()).unwrap();
    assert!(read_gltf(&path).unwrap_err().message.contains("beside the glTF"));
}

#[test]
fn scenes_with_unusual_models_are_handled_or_refused_clearly() {
    // A weld to a model that was never added.
    let weld = format!("directives:\n{MODEL}- add_weld:\n    parent: world\n    child: main_ghost_0::base_link\n");
    assert!(load_error(&weld, "crate.obj").contains("no add_model adds"));
    // The same model added twice.
    assert!(load_error(&format!("directives:\n{MODEL}{MODEL}"), "crate.obj").contains("added twice"));

    // A model without visuals is skipped and reported; a "Floor Lamp" is a lamp.
    let scene = tiny_scene(&format!("directives:\n{MODEL}"), "crate.obj");
    std::fs::write(scene.path().join("assets/crate.obj"), "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n").unwrap();
    std::fs::write(
        scene.path().join("combined_house/house_state.json"),
        r#"{"rooms": {"main": {"objects": {"crate_0": {"name": "Floor Lamp", "description": "A tall lamp.", "object_type": "furniture"}}}}}"#,
    )
    .unwrap();
    let loaded = load_scene(scene.path()).unwrap();
    let out = tempfile::tempdir().unwrap();
    let report = write_habitat_scene(&loaded, out.path(), &ConvertOptions::default()).unwrap();
    assert_eq!(report.objects[0].class, "lamp");

    std::fs::write(scene.path().join("assets/crate.sdf"), r#"<sdf version="1.7"><model name="crate"><link name="base_link"/></model></sdf>"#).unwrap();
    let report = write_habitat_scene(&load_scene(scene.path()).unwrap(), tempfile::tempdir().unwrap().path(), &ConvertOptions::default());
    let err = report.map(|r| r.models_without_visuals).map_err(|e| e.to_string());
    // Nothing left to draw: no floor either, so the conversion says so.
    assert!(err.as_ref().is_err_and(|e| e.contains("no visuals")) || err.as_ref().is_ok_and(|m| m == &vec!["main_crate_0".to_string()]), "{err:?}");

    // Links whose poses refer to each other in a circle.
    std::fs::write(
        scene.path().join("assets/crate.sdf"),
        r#"<sdf version="1.7"><model name="crate"><link name="a"><pose relative_to="b">0 0 0 0 0 0</pose></link><link name="b"><pose relative_to="a">0 0 0 0 0 0</pose></link></model></sdf>"#,
    )
    .unwrap();
    assert!(load_scene(scene.path()).unwrap_err().message.contains("cycle"));
}
