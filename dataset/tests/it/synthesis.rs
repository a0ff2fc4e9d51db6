//! Procedural synthesis in SceneSmith's format, and its round trip through the converter.

use std::collections::BTreeMap;
use std::path::Path;

use osmab_dataset::convert::gltf::read_gltf;
use osmab_dataset::convert::habitat::{ConvertOptions, write_habitat_scene};
use osmab_dataset::convert::lexicon::normalise_name;
use osmab_dataset::convert::scene::load_scene;
use osmab_dataset::prompts::grammar_pool;
use osmab_dataset::spec::{ObjectKind, Regime};
use osmab_dataset::synthesis::external::run_external;
use osmab_dataset::synthesis::library::make_asset;
use osmab_dataset::synthesis::placement::{MAX_REST_HEIGHT, place};
use osmab_dataset::synthesis::relations::unmet_relations;
use osmab_dataset::synthesis::source::AssetSource;
use osmab_dataset::synthesis::{export::write_asset_gltf, synthesize};
use osmab_evaluator::synthetic::Rng;

#[test]
fn synthesized_scenes_round_trip_through_the_converter_with_their_spec_intact() {
    for regime in Regime::ALL {
        for prompt in grammar_pool(regime, 6, 5).accepted {
            let dir = tempfile::tempdir().unwrap();
            synthesize(&prompt, 1, &dir.path().join("scene"), false, &AssetSource::procedural()).unwrap();
            let scene = load_scene(&dir.path().join("scene")).unwrap();
            let report = write_habitat_scene(&scene, &dir.path().join("habitat"), &ConvertOptions::default()).unwrap();
            assert!(report.unknown_names.is_empty(), "{:?}", report.unknown_names);
            let mut counted: BTreeMap<String, u32> = BTreeMap::new();
            for o in &report.objects {
                *counted.entry(o.class.clone()).or_default() += 1;
            }
            let mut expected: BTreeMap<String, u32> = BTreeMap::new();
            for o in &prompt.spec.objects {
                *expected.entry(normalise_name(&o.category).unwrap_or_else(|| panic!("{} has no class", o.category)).to_string()).or_default() += o.count;
            }
            for (class, n) in &expected {
                assert_eq!(counted.get(class), Some(n), "{class} in: {}", prompt.text);
            }
            assert_eq!(counted.get("wall"), Some(&8), "four walls and their skirting");
            assert_eq!((counted.get("door"), counted.get("floor")), (Some(&1), Some(&1)), "a door, a floor");
            assert!(counted.get("window").is_some_and(|n| *n >= 1), "at least one window in: {} {counted:?}", prompt.text);
            assert_eq!(scene.prompt.as_deref(), Some(prompt.text.as_str()));
        }
    }
}

#[test]
fn furniture_never_interpenetrates_and_small_objects_rest_on_their_hosts() {
    for (i, prompt) in grammar_pool(Regime::Manipuland, 10, 9).accepted.iter().chain(&grammar_pool(Regime::Furniture, 10, 9).accepted).enumerate() {
        let layout = place(&prompt.spec, i as u64, &AssetSource::procedural());
        let furniture: Vec<_> = layout.objects.iter().filter(|o| o.kind == ObjectKind::Furniture).collect();
        for (a, fa) in furniture.iter().enumerate() {
            let (lo, hi) = fa.footprint();
            assert!(
                lo[0] >= -layout.width / 2.0 && hi[0] <= layout.width / 2.0 && lo[1] >= -layout.depth / 2.0 && hi[1] <= layout.depth / 2.0,
                "{} leaves the room",
                fa.object_id
            );
            for fb in &furniture[a + 1..] {
                let (lo2, hi2) = fb.footprint();
                let overlap = lo[0] < hi2[0] - 1e-6 && lo2[0] < hi[0] - 1e-6 && lo[1] < hi2[1] - 1e-6 && lo2[1] < hi[1] - 1e-6;
                assert!(!overlap, "{} and {} overlap in: {}", fa.object_id, fb.object_id, prompt.text);
            }
        }
        for small in layout.objects.iter().filter(|o| o.kind == ObjectKind::Manipuland && o.host.is_some()) {
            let host = layout.objects.iter().find(|o| Some(&o.object_id) == small.host.as_ref()).unwrap();
            let (lo, hi) = small.footprint();
            let (hlo, hhi) = host.footprint();
            assert!(
                lo[0] >= hlo[0] - 1e-6 && hi[0] <= hhi[0] + 1e-6 && lo[1] >= hlo[1] - 1e-6 && hi[1] <= hhi[1] + 1e-6,
                "{} is not over {}",
                small.object_id,
                host.object_id
            );
            let z = small.position[2];
            assert!(z == 0.0 || host.asset.supports.iter().any(|s| (s.height - z).abs() < 1e-9), "{} floats at {z}", small.object_id);
            assert!(z <= MAX_REST_HEIGHT, "{} rests at {z} m, above what a robot's camera sees: {}", small.object_id, prompt.text);
            assert!(host.asset.supports.iter().any(|s| (s.height - z).abs() < 1e-9 && s.open) || z == 0.0, "{} is behind doors", small.object_id);
        }
    }
}

#[test]
fn small_objects_rest_where_a_camera_sees_them_or_the_prompt_is_not_placeable() {
    use osmab_dataset::spec::{ObjectSpec, Relation, RelationKind, SceneSpec};
    let spec = |kind: RelationKind, host: &str| SceneSpec {
        regime: Regime::Manipuland,
        room: "study".into(),
        objects: vec![
            ObjectSpec { category: host.into(), count: 1, kind: ObjectKind::Furniture },
            ObjectSpec { category: "book".into(), count: 3, kind: ObjectKind::Manipuland },
        ],
        relations: vec![
            Relation { subject: host.into(), kind: RelationKind::AgainstWall, targets: vec![] },
            Relation { subject: "book".into(), kind, targets: vec![host.into()] },
        ],
    };
    for seed in 0..5 {
        // On a bookshelf (1.6–2 m tall): on its open shelves, not on its top.
        let on_shelf = spec(RelationKind::On, "bookshelf");
        let layout = place(&on_shelf, seed, &AssetSource::procedural());
        let unmet = unmet_relations(&on_shelf, &layout);
        assert!(unmet.is_empty(), "{unmet:?}");
        for book in layout.objects.iter().filter(|o| o.category == "book") {
            assert!(book.position[2] > 0.1 && book.position[2] <= MAX_REST_HEIGHT, "a book at {} m", book.position[2]);
        }
        // Inside a wardrobe (doors): nowhere a camera sees, so the relation is unmet.
        let in_wardrobe = spec(RelationKind::Inside, "wardrobe");
        let unmet = unmet_relations(&in_wardrobe, &place(&in_wardrobe, seed, &AssetSource::procedural()));
        assert!(unmet.iter().any(|u| u.contains("book inside wardrobe")), "{unmet:?}");
    }
}

pub fn tree(dir: &Path) -> Vec<(String, Vec<u8>)> {
    let mut out = Vec::new();
    let mut stack = vec![dir.to_path_buf()];
    while let Some(d) = stack.pop() {
        for entry in std::fs::read_dir(&d).unwrap() {
            let p = entry.unwrap().path();
            if p.is_dir() {
                stack.push(p);
            } else {
                out.push((p.strip_prefix(dir).unwrap().display().to_string(), std::fs::read(&p).unwrap()));
            }
        }
    }
    out.sort();
    out
}

#[test]
fn the_same_seed_synthesizes_byte_identical_scenes() {
    // A prompt from elsewhere (no layout of its own): the seed decides the layout.
    let mut prompt = grammar_pool(Regime::Furniture, 1, 3).accepted.remove(0);
    prompt.layout_seed = None;
    let (a, b, c) = (tempfile::tempdir().unwrap(), tempfile::tempdir().unwrap(), tempfile::tempdir().unwrap());
    synthesize(&prompt, 7, a.path(), false, &AssetSource::procedural()).unwrap();
    synthesize(&prompt, 7, b.path(), false, &AssetSource::procedural()).unwrap();
    synthesize(&prompt, 8, c.path(), false, &AssetSource::procedural()).unwrap();
    assert_eq!(tree(a.path()), tree(b.path()));
    assert_ne!(tree(a.path()), tree(c.path()));
}

#[test]
fn grammar_prompts_get_the_layout_they_describe() {
    for regime in Regime::ALL {
        for prompt in grammar_pool(regime, 12, 21).accepted {
            let dir = tempfile::tempdir().unwrap();
            let unmet = synthesize(&prompt, 99, dir.path(), false, &AssetSource::procedural()).unwrap();
            assert_eq!(unmet, Vec::<String>::new(), "{}", prompt.text);
        }
    }
}

#[test]
fn relations_a_layout_fails_are_reported() {
    // Ask the first object to stand both in a corner and in the centre of the room: no
    // layout honours both.
    let mut prompt = grammar_pool(Regime::Furniture, 1, 4).accepted.remove(0);
    prompt.layout_seed = None;
    let anchor = prompt.spec.objects[0].category.clone();
    for kind in [osmab_dataset::spec::RelationKind::InCorner, osmab_dataset::spec::RelationKind::CenterOfRoom] {
        prompt.spec.relations.push(osmab_dataset::spec::Relation { subject: anchor.clone(), kind, targets: vec![] });
    }
    let dir = tempfile::tempdir().unwrap();
    let unmet = synthesize(&prompt, 1, dir.path(), false, &AssetSource::procedural()).unwrap();
    let state: serde_json::Value = serde_json::from_slice(&std::fs::read(dir.path().join("combined_house/house_state.json")).unwrap()).unwrap();
    assert_eq!(state["placement"]["unmet"], serde_json::json!(unmet));
    assert!(unmet.iter().any(|u| u.contains(&anchor)), "{unmet:?}");
}

#[test]
fn procedural_assets_export_as_readable_gltf_of_their_size() {
    let mut rng = Rng::new(1);
    for category in ["dining table", "office chair", "bookshelf", "bed", "sofa", "mug", "laptop", "bucket"] {
        let asset = make_asset(category, &mut rng).unwrap();
        let dir = tempfile::tempdir().unwrap();
        write_asset_gltf(&asset, dir.path(), "asset").unwrap();
        let gltf = read_gltf(&dir.path().join("asset.gltf")).unwrap();
        assert!(!gltf.generated_normals, "{category}: normals are written");
        assert!(gltf.materials.len() >= 1);
        assert!(gltf.materials.iter().all(|m| m.texture.is_some()), "{category}: every material is textured, none a flat colour");
        let (lo, hi) = gltf.bounds().unwrap();
        // glTF is Y-up: height along y, width along x, depth along z.
        assert!((hi[1] - lo[1] - asset.size[2] as f32).abs() < 0.02, "{category}: height {} vs {}", hi[1] - lo[1], asset.size[2]);
        assert!(lo[1].abs() < 1e-4, "{category}: the bottom is at 0");
        assert!((hi[0] - lo[0]) <= asset.size[0] as f32 + 0.05 && (hi[2] - lo[2]) <= asset.size[1] as f32 + 0.05, "{category}");
    }
}

#[test]
fn an_external_synthesizer_is_run_and_checked() {
    let fixture = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../shared/fixtures/scenesmith/scene_000");
    let out = tempfile::tempdir().unwrap();
    let copy = vec!["cp".to_string(), "-r".into(), format!("{}/.", fixture.display()), "{out}".into()];
    run_external(&copy, "A bedroom with 1 bed.", 7, out.path(), std::time::Duration::from_secs(60)).unwrap();
    assert_eq!(std::fs::read_to_string(out.path().join("prompt.txt")).unwrap(), "A bedroom with 1 bed.");
    assert!(load_scene(out.path()).is_ok());

    let failing = vec!["sh".to_string(), "-c".into(), "echo 'CUDA out of memory' >&2; exit 3".into()];
    let err = run_external(&failing, "p", 7, tempfile::tempdir().unwrap().path(), std::time::Duration::from_secs(60)).unwrap_err();
    assert!(err.message.contains("CUDA out of memory"), "{err}");
    let slow = vec!["sleep".to_string(), "5".into()];
    let err = run_external(&slow, "p", 7, tempfile::tempdir().unwrap().path(), std::time::Duration::from_millis(300)).unwrap_err();
    assert!(err.message.contains("ran longer than"), "{err}");
    let silent = vec!["true".to_string()];
    let err = run_external(&silent, "p", 7, tempfile::tempdir().unwrap().path(), std::time::Duration::from_secs(60)).unwrap_err();
    assert!(err.message.contains("wrote no SceneSmith scene"), "{err}");
}
