//! Admin regeneration: a release built through the API, its rendering fanned out as one
//! job per scene and lighting over the workers, ends bit-identical to the same config
//! built in one go by `osmab release build` (but for the front matter naming its version),
//! and is published.

use std::time::{Duration, Instant};

use serde_json::{Value, json};

use super::{Backend, Deployment, TEST_RELEASE_CONFIG, on_both_backends, test_release};

fn a_release_built_through_the_api_fans_out_its_rendering(backend: Backend) {
    let deployment = Deployment::new(backend, &[("OSMAB_WORKERS", "0"), ("OSMAB_POLL_MS", "20")]);
    let server = deployment.serve();
    let mut workers: Vec<_> = (0..2).map(|i| deployment.spawn(&["worker"], &format!("worker-{i}"))).collect();
    let config = TEST_RELEASE_CONFIG.replace("version = \"e2e-1\"", "version = \"regen-1\"");
    let response = server.admin(server.post("/api/v1/admin/releases").json(&json!({"config": config, "publish": true})));
    assert_eq!(response.status(), 202, "{}", response.text().unwrap());
    let url = response.json::<Value>().unwrap()["url"].as_str().unwrap().to_string();

    // The build job shows its rendering stage while the sequences are rendered.
    let started = Instant::now();
    let mut saw_rendering = None;
    let job = loop {
        let job: Value = server.admin(server.get(&url)).json().unwrap();
        if job["progress"]["stage"] == "rendering" && job["progress"]["fanned_out"].is_array() {
            saw_rendering.get_or_insert(job["progress"].clone());
        }
        if ["succeeded", "failed"].contains(&job["state"].as_str().unwrap()) {
            break job;
        }
        assert!(started.elapsed() < Duration::from_secs(300), "the build is stuck: {job}\n{}", deployment.log("worker-0"));
        std::thread::sleep(Duration::from_millis(20));
    };
    assert_eq!(job["state"], "succeeded", "{job}\n{}\n{}", deployment.log("worker-0"), deployment.log("worker-1"));
    assert_eq!(job["attempts"], 1, "waiting for the render jobs costs no attempt: {job}");
    let rendering = saw_rendering.expect("the rendering stage was visible");
    let mut fanned_out: Vec<&str> = rendering["fanned_out"].as_array().unwrap().iter().map(|s| s.as_str().unwrap()).collect();
    fanned_out.sort();
    assert_eq!(fanned_out, ["regen-1/scene_000", "regen-1/scene_001"], "one render job per scene, for all its lightings");

    // Every render job ran once and succeeded.
    let jobs: Value = server.admin(server.get("/api/v1/admin/jobs")).json().unwrap();
    let renders: Vec<&Value> = jobs["jobs"].as_array().unwrap().iter().filter(|j| j["kind"] == "render_sequence").collect();
    assert_eq!(renders.len(), 2, "{jobs}");
    assert!(renders.iter().all(|j| j["state"] == "succeeded" && j["attempts"] == 1), "{renders:?}");

    // The result is the release `osmab release build` makes of the same config, published.
    let built: Value = serde_json::from_slice(&std::fs::read(test_release().join("manifest.json")).unwrap()).unwrap();
    let release: Value = server.get("/api/v1/releases/regen-1").send().unwrap().json().unwrap();
    // Every file is the same but the front matter (README.md, LICENSE, CITATION.cff), which
    // names each release's own version.
    let served: Value = server.get("/api/v1/releases/regen-1/manifest.json").send().unwrap().json().unwrap();
    let front_matter = osmab_dataset::release::front_matter::FILES;
    let files = |manifest: &Value| -> Vec<Value> {
        manifest["files"].as_array().unwrap().iter().filter(|f| !front_matter.contains(&f["path"].as_str().unwrap())).cloned().collect()
    };
    assert_eq!(files(&served), files(&built), "the same files, byte for byte");
    assert_ne!(release["digest"], built["digest"], "another version, another front matter: {release}");
    for name in front_matter {
        let text = server.get(&format!("/api/v1/releases/regen-1/files/{name}")).send().unwrap().text().unwrap();
        assert!(text.contains("regen-1") && !text.contains("e2e-1"), "{name} names its own release: {text}");
    }
    assert_eq!(release["state"], "published", "{release}");
    assert_eq!(release["current"], true, "{release}");

    // Its sequence archives, packed by the render jobs, are the ones packing the release's
    // sequences at import makes, byte for byte, and match the manifest.
    let manifest: Value = server.get("/api/v1/releases/regen-1/manifest.json").send().unwrap().json().unwrap();
    let archives = manifest["archives"].as_array().unwrap();
    assert_eq!(archives.len(), 8, "{manifest}");
    let packed = tempfile::tempdir().unwrap();
    for archive in archives {
        let (lighting, scene) = (archive["lighting"].as_str().unwrap(), archive["scene"].as_str().unwrap());
        let served = server.get(&format!("/api/v1/releases/regen-1/files/{}", archive["path"].as_str().unwrap())).send().unwrap().bytes().unwrap();
        let expected = packed.path().join(format!("{lighting}-{scene}.tar"));
        let sequence = test_release().join("sequences").join(lighting).join(scene);
        osmab_evaluator::submission::pack_directory_as(&sequence, &format!("sequences/{lighting}/{scene}/"), &expected).unwrap();
        assert!(served[..] == std::fs::read(&expected).unwrap()[..], "{lighting}/{scene}: the served archive differs from packing the sequence");
        assert_eq!((served.len() as u64, super::sha256_hex(&served)), (archive["size"].as_u64().unwrap(), archive["sha256"].as_str().unwrap().to_string()));
        // The stored archive is the very file the render job packed (linked, not packed again).
        use std::os::unix::fs::MetadataExt;
        let data = deployment.data.path();
        let by_render_job = data.join(format!("builds/regen-1/release/.work/archives/{lighting}/{scene}.tar"));
        let stored = data.join("blobs/releases/regen-1").join(archive["path"].as_str().unwrap());
        assert_eq!(std::fs::metadata(&stored).unwrap().ino(), std::fs::metadata(&by_render_job).unwrap().ino(), "{}", stored.display());
    }

    // The ground truth is stored whole, and the build folder it was linked from kept whole
    // (the manifest lists some of its files, which are taken once with the files and again
    // with the ground-truth folder).
    let data = deployment.data.path();
    let reference = test_release().join("ground_truth");
    let mut compared = 0;
    let mut folders = vec![std::path::PathBuf::new()];
    while let Some(folder) = folders.pop() {
        for entry in std::fs::read_dir(reference.join(&folder)).unwrap() {
            let relative = folder.join(entry.unwrap().file_name());
            if reference.join(&relative).is_dir() {
                folders.push(relative);
                continue;
            }
            // The ground truth's own manifest names the release's version; its files and digest are the same.
            let comparable = |bytes: Vec<u8>| -> Vec<u8> {
                if relative.as_os_str() != "manifest.json" {
                    return bytes;
                }
                let manifest: Value = serde_json::from_slice(&bytes).unwrap();
                serde_json::to_vec(&(&manifest["files"], &manifest["digest"])).unwrap()
            };
            let expected = comparable(std::fs::read(reference.join(&relative)).unwrap());
            for copy in [data.join("blobs/releases/regen-1/ground_truth"), data.join("builds/regen-1/release/ground_truth")] {
                let path = copy.join(&relative);
                assert!(comparable(std::fs::read(&path).unwrap()) == expected, "{} differs from the one `osmab release build` makes", path.display());
            }
            compared += 1;
        }
    }
    assert!(compared >= 10, "{compared} ground-truth files");

    for worker in &mut workers {
        let _ = worker.kill();
        let _ = worker.wait();
    }
}

on_both_backends!(a_release_built_through_the_api_fans_out_its_rendering, super::a_release_built_through_the_api_fans_out_its_rendering);
