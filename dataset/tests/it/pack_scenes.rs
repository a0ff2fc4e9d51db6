//! Scenes the built-in synthesizer draws from an asset pack: its textured meshes at their
//! catalogue's size, each instance recoloured in its own finish, the room dressed in the
//! pack's floor and wall textures, and everything converting as SceneSmith's scenes do.

use std::path::{Path, PathBuf};

use osmab_dataset::assets::AssetPack;
use osmab_dataset::classes::{Finish, table};
use osmab_dataset::convert::gltf::read_gltf;
use osmab_dataset::convert::habitat::{ConvertOptions, write_habitat_scene};
use osmab_dataset::convert::scene::load_scene;
use osmab_dataset::prompts::ScenePrompt;
use osmab_dataset::spec::{ObjectKind, ObjectSpec, Regime, Relation, RelationKind, SceneSpec};
use osmab_dataset::synthesis::source::AssetSource;
use osmab_dataset::synthesis::synthesize;
use serde_json::Value;

fn fixture() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/fixtures/pack")
}

/// A study with a desk against a wall and three books on it.
fn books_on_a_desk() -> ScenePrompt {
    let spec = SceneSpec {
        regime: Regime::Manipuland,
        room: "study".into(),
        objects: vec![
            ObjectSpec { category: "desk".into(), count: 1, kind: ObjectKind::Furniture },
            ObjectSpec { category: "book".into(), count: 3, kind: ObjectKind::Manipuland },
        ],
        relations: vec![
            Relation { subject: "desk".into(), kind: RelationKind::AgainstWall, targets: vec![] },
            Relation { subject: "book".into(), kind: RelationKind::On, targets: vec!["desk".into()] },
        ],
    };
    ScenePrompt { id: "test-0001".into(), source: "test".into(), text: "A study with a desk and three books on it.".into(), spec, layout_seed: None }
}

fn objects(scene: &Path) -> Vec<Value> {
    let state: Value = serde_json::from_slice(&std::fs::read(scene.join("combined_house/house_state.json")).unwrap()).unwrap();
    state["rooms"]["main"]["objects"].as_object().unwrap().values().cloned().collect()
}

/// What a glTF's triangles show of its textures: the texel (0–1) at each triangle's centre,
/// with the triangle's area.
fn shown_texels(file: &Path) -> Vec<([f64; 3], f64)> {
    let asset = read_gltf(file).unwrap();
    let mut out = Vec::new();
    for mesh in &asset.meshes {
        let texture = asset.materials[mesh.material.unwrap()].texture.as_ref().expect("every material textured");
        let uvs = mesh.uvs.as_ref().expect("texture coordinates");
        for t in mesh.indices.chunks_exact(3) {
            let [a, b, c] = [t[0], t[1], t[2]].map(|i| i as usize);
            let p = [a, b, c].map(|i| mesh.positions[i].map(f64::from));
            let e1: [f64; 3] = std::array::from_fn(|k| p[1][k] - p[0][k]);
            let e2: [f64; 3] = std::array::from_fn(|k| p[2][k] - p[0][k]);
            let n = [e1[1] * e2[2] - e1[2] * e2[1], e1[2] * e2[0] - e1[0] * e2[2], e1[0] * e2[1] - e1[1] * e2[0]];
            let uv = [(uvs[a][0] + uvs[b][0] + uvs[c][0]) / 3.0, (uvs[a][1] + uvs[b][1] + uvs[c][1]) / 3.0];
            let x = (((uv[0] - uv[0].floor()) * texture.width as f32) as usize).min(texture.width as usize - 1);
            let y = (((uv[1] - uv[1].floor()) * texture.height as f32) as usize).min(texture.height as usize - 1);
            let i = 4 * (y * texture.width as usize + x);
            out.push(([0, 1, 2].map(|k| f64::from(texture.rgba[i + k]) / 255.0), (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt()));
        }
    }
    out
}

/// The share of the shown area whose colour is nearer `finish` than any other finish of
/// `class`'s palette.
fn share_in_finish(file: &Path, class: &str, finish: &Finish) -> f64 {
    let distance = |a: [f64; 3], f: &Finish| (0..3).map(|k| (a[k] - f64::from(f.colour[k])).powi(2)).sum::<f64>();
    let texels = shown_texels(file);
    let total: f64 = texels.iter().map(|(_, a)| a).sum();
    let palette = table().class(class).unwrap().finishes();
    let nearest = |c: [f64; 3]| palette.iter().min_by(|a, b| distance(c, a).total_cmp(&distance(c, b))).unwrap().name.clone();
    texels.iter().filter(|(c, _)| nearest(*c) == finish.name).map(|(_, a)| a).sum::<f64>() / total
}

/// The finish an object's description names (`A desk in white lacquer (…)`), if any.
fn finish_named(description: &str) -> Option<&'static Finish> {
    let named = description.split(" in ").nth(1)?.split(" (").next()?.replace(' ', "_");
    table().finish(&named)
}

#[test]
fn a_scene_drawn_from_a_pack_carries_its_meshes_at_their_size_each_in_its_own_finish() {
    let pack = AssetPack::open(&fixture()).unwrap();
    let assets = AssetSource::open(&fixture()).unwrap();
    let dir = tempfile::tempdir().unwrap();
    let unmet = synthesize(&books_on_a_desk(), 3, dir.path(), false, &assets).unwrap();
    assert_eq!(unmet, Vec::<String>::new());
    let all = objects(dir.path());
    // The dressing adds what the prompt does not name, and nothing it does.
    let dressing: Vec<&str> = all.iter().filter(|o| o["metadata"]["dressing"] == true).map(|o| o["metadata"]["category"].as_str().unwrap()).collect();
    assert!(dressing.len() >= 3 && dressing.iter().all(|c| !["desk", "book"].contains(c)), "{dressing:?}");
    let objects: Vec<Value> = all.iter().filter(|o| o["metadata"]["dressing"] == false).cloned().collect();
    assert_eq!(objects.len(), 4);
    let mut finishes = Vec::new();
    for o in &objects {
        let class = o["metadata"]["category"].as_str().unwrap();
        assert_eq!(o["metadata"]["asset_source"], "infinigen", "{class} is drawn from the pack");
        let entry = pack.catalogue().variants(class).next().unwrap();
        // Its size is the catalogue's, scaled uniformly by at most 6 %.
        let size: Vec<f64> = (0..3).map(|k| o["bbox_max"][k].as_f64().unwrap() - o["bbox_min"][k].as_f64().unwrap()).collect();
        let scale = size[0] / entry.size[0];
        assert!((0.94..=1.06).contains(&scale), "{class} scaled by {scale}");
        for k in 0..3 {
            assert!((size[k] - entry.size[k] * scale).abs() < 1e-4, "{class}: {size:?} is not {:?} × {scale}", entry.size);
        }
        // The mesh written is that size, and its texture shows the finish the description names.
        let mesh = dir.path().join(o["geometry_path"].as_str().unwrap());
        let (lo, hi) = read_gltf(&mesh).unwrap().bounds().unwrap();
        assert!(((hi[0] - lo[0]) as f64 - size[0]).abs() < 0.01 && ((hi[1] - lo[1]) as f64 - size[2]).abs() < 0.01, "{class}: the mesh is {lo:?}..{hi:?}");
        let description = o["description"].as_str().unwrap();
        let Some(finish) = finish_named(description) else {
            assert_eq!(class, "book", "only classes of their own colours have no finish: {description}");
            continue;
        };
        // Its main material shows the finish; other parts (legs, a frame) may keep their colour.
        let share = share_in_finish(&mesh, class, finish);
        eprintln!("{class}: {share:.2} of it in {}", finish.name);
        assert!(share >= 0.5, "{class}: only {share:.2} of what it shows is {}", finish.name);
        finishes.push(finish.name.clone());
    }
    // The books rest on the desk's top, as the catalogue measured it.
    let desk = objects.iter().find(|o| o["metadata"]["category"] == "desk").unwrap();
    let top = pack.catalogue().variants("desk").next().unwrap().supports[0].height;
    for book in objects.iter().filter(|o| o["metadata"]["category"] == "book") {
        assert_eq!(book["placement_info"]["parent_object"], desk["object_id"]);
        let z = book["transform"]["translation"][2].as_f64().unwrap();
        assert!((z / top - 1.0).abs() <= 0.061, "a book at {z} m on a desk top at {top} m (before scaling)");
    }
    assert_eq!(finishes.len(), 1, "the desk is drawn in a finish of its palette; the books keep their covers");
}

#[test]
fn pack_scenes_convert_textured_and_are_byte_identical_for_a_seed() {
    let assets = AssetSource::open(&fixture()).unwrap();
    let (a, b) = (tempfile::tempdir().unwrap(), tempfile::tempdir().unwrap());
    synthesize(&books_on_a_desk(), 5, &a.path().join("scene"), false, &assets).unwrap();
    synthesize(&books_on_a_desk(), 5, &b.path().join("scene"), false, &assets).unwrap();
    assert_eq!(super::synthesis::tree(a.path()), super::synthesis::tree(b.path()));
    let report = write_habitat_scene(&load_scene(&a.path().join("scene")).unwrap(), &a.path().join("habitat"), &ConvertOptions::default()).unwrap();
    assert!(report.texture_fallbacks.is_empty(), "{:?}", report.texture_fallbacks);
    let classes: Vec<&str> = report.objects.iter().map(|o| o.class.as_str()).filter(|c| !["floor", "wall"].contains(c)).collect();
    assert_eq!(classes.iter().filter(|c| **c == "book").count(), 3, "{classes:?}");
    assert_eq!(classes.iter().filter(|c| **c == "desk").count(), 1, "{classes:?}");
}

#[test]
fn classes_the_pack_lacks_come_from_the_procedural_library() {
    let assets = AssetSource::open(&fixture()).unwrap();
    let mut rng = osmab_evaluator::synthetic::Rng::new(1);
    let mug = assets.make("mug", &mut rng).unwrap();
    assert!(mug.mesh.is_none() && !mug.parts.is_empty());
    let desk = assets.make("desk", &mut rng).unwrap();
    assert!(desk.mesh.is_some() && desk.parts.is_empty());
    assert!(desk.under.is_some() && desk.clearance > 0.6, "the free floor under a desk comes from the catalogue: {:?}", desk.under);
}

#[test]
fn a_pack_dresses_the_room_in_its_floor_and_wall_textures_tiled_in_metres_paints_the_walls_and_dyes_the_carpet() {
    let pack = AssetPack::open(&fixture()).unwrap();
    let assets = AssetSource::open(&fixture()).unwrap();
    let dir = tempfile::tempdir().unwrap();
    synthesize(&books_on_a_desk(), 3, &dir.path().join("scene"), false, &assets).unwrap();
    let room = dir.path().join("scene/room_geometry");
    let sdf = std::fs::read_to_string(room.join("room_geometry_main.sdf")).unwrap();
    for part in ["floor", "left_wall", "right_wall", "back_wall", "front_wall"] {
        assert!(sdf.contains(&format!("<uri>{part}.gltf</uri>")), "{part} is a textured mesh: {sdf}");
        let gltf = read_gltf(&room.join(format!("{part}.gltf"))).unwrap();
        let texture = gltf.materials[0].texture.as_ref().expect("textured");
        let kind = if part == "floor" { osmab_dataset::assets::ShellKind::Floor } else { osmab_dataset::assets::ShellKind::Wall };
        let shell = pack.catalogue().shells_of(kind).next().unwrap();
        assert_eq!((texture.width, texture.height), (512, 512), "{part}: {}", shell.name);
        // The texture repeats once per `tile` metres: the floor's top spans width / tile of it.
        let (lo, hi) = gltf.bounds().unwrap();
        let uvs = gltf.meshes[0].uvs.as_ref().unwrap();
        let span = uvs.iter().map(|uv| uv[0]).fold(f32::NEG_INFINITY, f32::max) - uvs.iter().map(|uv| uv[0]).fold(f32::INFINITY, f32::min);
        let longest = (hi[0] - lo[0]).max(hi[2] - lo[2]);
        assert!((span * shell.tile as f32 - longest).abs() < 0.01, "{part}: {span} tiles over {longest} m");
        // The walls are in one paint of the wall class's palette, and the (carpeted) floor in
        // one dye of the floor class's, whatever the texture's own hue.
        let class = if part == "floor" { "floor" } else { "wall" };
        let texels = texture.rgba.len() as f32 / 4.0;
        let mean: [f32; 3] = std::array::from_fn(|c| texture.rgba.chunks_exact(4).map(|t| t[c] as f32).sum::<f32>() / texels);
        let finishes = table().class(class).unwrap().finishes();
        assert!(finishes.iter().any(|p| (0..3).all(|c| (mean[c] - p.colour[c] * 255.0).abs() < 2.0)), "{part}: mean {mean:?} is no {class} finish");
    }
    // Converted, the floor and walls keep their textures and their classes.
    let report = write_habitat_scene(&load_scene(&dir.path().join("scene")).unwrap(), &dir.path().join("habitat"), &ConvertOptions::default()).unwrap();
    assert!(report.texture_fallbacks.is_empty(), "{:?}", report.texture_fallbacks);
    assert_eq!(report.objects.iter().filter(|o| o.class == "wall").count(), 8, "four walls and their skirting");
    assert_eq!(report.objects.iter().filter(|o| o.class == "floor").count(), 1);
    assert!(report.navigable_fraction > 0.2, "the floor is walkable: {}", report.navigable_fraction);
}
