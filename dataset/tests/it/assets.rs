//! Asset packs: a catalogue and the meshes it lists, checked file by file and mesh by mesh;
//! anything the catalogue gets wrong is an error naming the entry and field.
//! The fixture is real forge output (tools/forge/): an Infinigen book and desk, baked.

use std::path::{Path, PathBuf};

use osmab_dataset::assets::AssetPack;
use serde_json::{Value, json};

fn fixture() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/fixtures/pack")
}

/// A copy of the fixture pack whose catalogue `edit` changes.
fn edited(edit: impl FnOnce(&mut Value)) -> tempfile::TempDir {
    let dir = tempfile::tempdir().unwrap();
    std::fs::create_dir_all(dir.path().join("meshes")).unwrap();
    std::fs::create_dir_all(dir.path().join("shell")).unwrap();
    for file in ["meshes/book-0.glb", "meshes/desk-0.glb", "shell/floor-carpet.jpg", "shell/wall-plaster.jpg"] {
        std::fs::copy(fixture().join(file), dir.path().join(file)).unwrap();
    }
    let mut catalogue: Value = serde_json::from_slice(&std::fs::read(fixture().join("catalogue.json")).unwrap()).unwrap();
    edit(&mut catalogue);
    std::fs::write(dir.path().join("catalogue.json"), serde_json::to_vec_pretty(&catalogue).unwrap()).unwrap();
    dir
}

/// The error opening and inspecting the pack at `root` gives.
fn refusal(root: &Path) -> String {
    match AssetPack::open(root).and_then(|pack| pack.inspect()) {
        Ok(_) => panic!("the pack at {} was accepted", root.display()),
        Err(e) => e.to_string(),
    }
}

#[test]
fn the_forges_pack_opens_and_every_mesh_is_what_its_entry_says() {
    let pack = AssetPack::open(&fixture()).unwrap();
    let meshes = pack.inspect().unwrap();
    assert_eq!(
        meshes.iter().map(|m| (m.class.as_str(), m.variant, m.triangles, m.textured)).collect::<Vec<_>>(),
        [("book", 0, 18, true), ("desk", 0, 2044, true)]
    );
    let desk = pack.catalogue().variants("desk").next().unwrap();
    assert_eq!(desk.supports.len(), 1, "the desk's top");
    assert!((desk.supports[0].height - desk.size[2]).abs() < 1e-3 && desk.under.as_ref().unwrap().clearance > 0.7);
    for (mesh, entry) in meshes.iter().zip(&pack.catalogue().objects) {
        for axis in 0..3 {
            assert!((mesh.size[axis] - entry.size[axis]).abs() < 0.01, "{mesh:?} against {entry:?}");
        }
    }
    // The digest names the catalogue's content (not its layout), and with it every file's SHA-256.
    let same = edited(|_| {});
    let again = AssetPack::open(same.path()).unwrap();
    assert_eq!(again.digest(), pack.digest());
    let reseeded = edited(|c| c["objects"][0]["seed"] = json!(7));
    let other = AssetPack::open(reseeded.path()).unwrap();
    assert_ne!(other.digest(), pack.digest());
}

#[test]
fn a_catalogue_that_misstates_its_meshes_is_refused_naming_entry_and_field() {
    let cases: Vec<(&str, Box<dyn FnOnce(&mut Value)>, &[&str])> = vec![
        ("a format of its own", Box::new(|c| c["format"] = json!("assets/9")), &["format", "osmab-assets/1"]),
        ("an unknown field", Box::new(|c| c["objects"][0]["colour"] = json!("red")), &["colour"]),
        ("a class outside the lexicon", Box::new(|c| c["objects"][0]["class"] = json!("spaceship")), &["objects[0]", "class", "spaceship", "lexicon"]),
        ("a path leaving the pack", Box::new(|c| c["objects"][0]["path"] = json!("../book-0.glb")), &["objects[0]", "path", "inside the pack"]),
        ("an absolute path", Box::new(|c| c["objects"][0]["path"] = json!("/etc/passwd.glb")), &["path", "inside the pack"]),
        ("a mesh of another format", Box::new(|c| c["objects"][0]["path"] = json!("meshes/book-0.blend")), &["path", ".glb or .gltf or .obj"]),
        ("a file that is not there", Box::new(|c| c["objects"][0]["path"] = json!("meshes/book-9.glb")), &["book-9.glb", "not found"]),
        (
            "another file's SHA-256",
            Box::new(|c| c["objects"][0]["sha256"] = c["objects"][1]["sha256"].clone()),
            &["book-0.glb", "SHA-256", "the catalogue lists"],
        ),
        ("a SHA-256 that is not one", Box::new(|c| c["objects"][0]["sha256"] = json!("F48105")), &["sha256", "64 lower-case hex"]),
        ("a size of no object", Box::new(|c| c["objects"][1]["size"] = json!([1.1, -0.7, 0.77])), &["objects[1] (desk 0).size", "three sides"]),
        (
            "a size the mesh does not have",
            Box::new(|c| c["objects"][1]["size"] = json!([1.3, 0.7448, 0.7717])),
            &["desk 0: size", "measures", "catalogue lists"],
        ),
        ("triangles the mesh does not have", Box::new(|c| c["objects"][1]["triangles"] = json!(10000)), &["desk 0: triangles", "2044", "10000"]),
        ("a support outside its object", Box::new(|c| c["objects"][1]["supports"][0]["max"] = json!([2.0, 0.3])), &["supports[0]", "footprint"]),
        ("a support above its object", Box::new(|c| c["objects"][1]["supports"][0]["height"] = json!(1.5)), &["supports[0]", "height"]),
        ("a clearance taller than its object", Box::new(|c| c["objects"][1]["under"]["clearance"] = json!(3.0)), &["under", "clearance"]),
        ("a variant listed twice", Box::new(|c| c["objects"][1] = c["objects"][0].clone()), &["objects[1]", "variant", "twice"]),
        ("no licence", Box::new(|c| c["objects"][0]["license"] = json!(" ")), &["license", "non-empty"]),
        (
            "a shell of no kind",
            Box::new(
                |c| c["shells"] = json!([{"name": "x", "kind": "roof", "source": "s", "generator": "g", "seed": 1, "tile": 2.0, "path": "shell/x.jpg", "sha256": "0".repeat(64), "license": "l"}]),
            ),
            &["roof"],
        ),
    ];
    for (what, edit, expected) in cases {
        let pack = edited(edit);
        let message = refusal(pack.path());
        for word in expected {
            assert!(message.contains(word), "{what}: {message:?} does not say {word:?}");
        }
    }
}

#[test]
fn hostile_packs_are_refused() {
    // Not JSON at all, and NaN where a number belongs (JSON has none: a parse error).
    let pack = edited(|_| {});
    std::fs::write(pack.path().join("catalogue.json"), "{\"format\": \"osmab-assets/1\", \"objects\": [{\"size\": [NaN, 1, 1]}]}").unwrap();
    assert!(refusal(pack.path()).contains("not a catalogue"));
    // A catalogue beyond 16 MiB is not read.
    std::fs::write(pack.path().join("catalogue.json"), vec![b' '; (16 << 20) + 1]).unwrap();
    assert!(refusal(pack.path()).contains("larger than 16 MiB"));
    // A mesh that is a link to a file outside the pack.
    let outside = tempfile::tempdir().unwrap();
    let pack = edited(|_| {});
    let mesh = pack.path().join("meshes/book-0.glb");
    std::fs::rename(&mesh, outside.path().join("book-0.glb")).unwrap();
    std::os::unix::fs::symlink(outside.path().join("book-0.glb"), &mesh).unwrap();
    assert!(refusal(pack.path()).contains("leaves the pack"));
    // A mesh whose bytes are not a glTF (its SHA-256 listed to match).
    let pack = edited(|c| {
        c["objects"][0]["sha256"] = json!("2c26b46b68ffc68ff99b453c1d30413413422d706483bfa0f98a5e886266e7ae");
    });
    std::fs::write(pack.path().join("meshes/book-0.glb"), "foo").unwrap();
    let message = refusal(pack.path());
    assert!(message.contains("book-0.glb"), "{message}");
}

/// Every class a scene can hold — what prompts may name (furniture and objects) and what
/// the dressing adds (doors, windows, rugs, pictures, curtains) — has a model in the
/// bundled pack or is deliberately drawn by the procedural library: no class silently
/// becomes a stand-in box.
#[test]
fn every_class_a_scene_can_hold_has_a_pack_model_or_is_deliberately_procedural() {
    use osmab_dataset::classes::{Role, table};
    let bundled = Path::new(env!("CARGO_MANIFEST_DIR")).join("../assets");
    let pack = AssetPack::open(&bundled).unwrap();
    let mut missing = Vec::new();
    for class in table().classes() {
        let dressing = matches!(class.name.as_str(), "door" | "window");
        if class.role == Role::Shell && !dressing {
            continue;
        }
        let in_pack = pack.catalogue().variants(&class.name).next().is_some();
        if !in_pack && !class.procedural {
            missing.push(class.name.clone());
        }
        // What the synthesizer draws for it is never a stand-in.
        let asset = osmab_dataset::synthesis::library::make_asset(&class.name, &mut osmab_evaluator::synthetic::Rng::new(1));
        assert!(asset.is_some(), "{}: the procedural library cannot draw it", class.name);
    }
    assert!(missing.is_empty(), "classes with neither a pack model nor `procedural = true` in dataset/classes.toml: {missing:?}");
}
