//! A team's whole journey: team and token, download with ranges, upload the oracle and a
//! degraded baseline, watch them reach `scored`, read the leaderboard and the pages.

use serde_json::Value;

use super::{Backend, Deployment, baseline_dir, on_both_backends, sha256_hex, tar_of, test_release};

fn journey(backend: Backend) {
    let deployment = Deployment::new(backend, &[]);
    let server = deployment.serve();
    assert_eq!(server.get("/livez").send().unwrap().status(), 200);
    let ready: Value = server.get("/readyz").send().unwrap().json().unwrap();
    assert_eq!(ready["database"], if backend == Backend::Sqlite { "sqlite" } else { "postgres" });
    let version = server.import_test_release();
    let token = server.team("Team Journey");

    // Before any submission, the idle worker makes this node ready to score the release:
    // each scene's ground truth prepared (in Z-order) and kept in the node's cache.
    let cache = deployment.data.path().join("cache/prepared-ground-truth");
    let entries = || match std::fs::read_dir(&cache) {
        Ok(dir) => dir.filter(|e| e.as_ref().unwrap().path().extension().is_some_and(|x| x == "zgt")).count(),
        Err(_) => 0,
    };
    let ready = ready_line(&deployment);
    assert!(ready.contains(&format!("release={version}")) && ready.contains("prepared=2"), "{ready}");
    assert_eq!(entries(), 2, "one prepared ground truth a scene");

    // The manifest lists every file and one archive per sequence with their checksums.
    let manifest: Value = server.get(&format!("/api/v1/releases/{version}/manifest.json")).send().unwrap().json().unwrap();
    let archives = manifest["archives"].as_array().unwrap();
    assert_eq!(archives.len(), 2 * 4, "one archive per scene and lighting");
    // Its scenes are val (a config without a test split): their ground truth is public, the
    // full quality report and the ground truth's own manifest are not.
    let ground_truth: Vec<&str> =
        manifest["files"].as_array().unwrap().iter().map(|f| f["path"].as_str().unwrap()).filter(|p| p.starts_with("ground_truth/")).collect();
    assert!(ground_truth.contains(&"ground_truth/scene_001/semantic.npy") && ground_truth.contains(&"ground_truth/questions/scene_000.json"));
    assert!(!ground_truth.iter().any(|p| *p == "ground_truth/manifest.json" || *p == "ground_truth/quality_report.json"), "{ground_truth:?}");
    assert!(manifest["scenes"].as_array().unwrap().iter().all(|s| s["split"] == "val"));

    // A file with a range, its ETag, and a conditional request.
    let traj = manifest["files"].as_array().unwrap().iter().find(|f| f["path"].as_str().unwrap().ends_with("traj.txt")).unwrap();
    let path = traj["path"].as_str().unwrap();
    let url = format!("/api/v1/releases/{version}/files/{path}");
    let whole = server.get(&url).send().unwrap();
    assert_eq!(whole.status(), 200);
    let etag = whole.headers()["etag"].to_str().unwrap().to_string();
    assert_eq!(etag, format!("\"{}\"", traj["sha256"].as_str().unwrap()));
    let bytes = whole.bytes().unwrap();
    assert_eq!(sha256_hex(&bytes), traj["sha256"].as_str().unwrap());
    let part = server.get(&url).header("range", "bytes=10-29").send().unwrap();
    assert_eq!(part.status(), 206);
    assert_eq!(part.headers()["content-range"].to_str().unwrap(), format!("bytes 10-29/{}", bytes.len()));
    assert_eq!(part.bytes().unwrap().as_ref(), &bytes[10..30]);
    let tail = server.get(&url).header("range", format!("bytes={}-", bytes.len() - 5)).send().unwrap();
    assert_eq!(tail.bytes().unwrap().as_ref(), &bytes[bytes.len() - 5..]);
    assert_eq!(server.get(&url).header("if-none-match", &etag).send().unwrap().status(), 304);
    super::problem(server.get(&url).header("range", format!("bytes={}-", bytes.len() + 10)).send().unwrap(), 416, "range_not_satisfiable");
    // What the manifest does not list is never served, whatever the path (the val scenes'
    // ground truth is listed; the full quality report and the ground truth's manifest are not).
    for hidden in ["ground_truth/manifest.json", "ground_truth/quality_report.json", "../ground_truth/scene_000/semantic.npy", "manifest.json.original"] {
        let status = server.get(&format!("/api/v1/releases/{version}/files/{hidden}")).send().unwrap().status();
        assert_eq!(status, 404, "{hidden}");
    }
    // A sequence archive matches its manifest checksum.
    let archive = &archives[0];
    let tar = server.get(&format!("/api/v1/releases/{version}/files/{}", archive["path"].as_str().unwrap())).send().unwrap().bytes().unwrap();
    assert_eq!(sha256_hex(&tar), archive["sha256"].as_str().unwrap());

    // Upload the oracle and a degraded baseline; both reach `scored`.
    let oracle = baseline_dir("oracle");
    let merged = baseline_dir("merge");
    let accepted = server.upload(&token, &tar_of(oracle.path()), "");
    assert_eq!(accepted.status(), 202);
    let location = accepted.headers()["location"].to_str().unwrap().to_string();
    let accepted: Value = accepted.json().unwrap();
    let oracle_id = accepted["id"].as_str().unwrap().to_string();
    assert_eq!(location, format!("/api/v1/submissions/{oracle_id}"));
    let merge_response = server.upload(&token, &tar_of(merged.path()), "?public=true");
    assert_eq!(merge_response.status(), 202);
    let merge_id = merge_response.json::<Value>().unwrap()["id"].as_str().unwrap().to_string();

    let oracle_view = server.wait_done(&oracle_id, &token);
    assert_eq!(oracle_view["state"], "scored", "{oracle_view}");
    let states: Vec<&str> = oracle_view["history"].as_array().unwrap().iter().map(|e| e["state"].as_str().unwrap()).collect();
    assert_eq!(states, ["received", "validating", "queued", "scoring", "scored"]);
    let scores = &oracle_view["scores"];
    assert_eq!(scores["release"], version.as_str());
    assert!(scores["evaluator_version"].is_string());
    for lighting in ["baseline", "camera", "dynamic_lights", "no_lights"] {
        for metric in ["miou", "fmiou", "macc"] {
            assert_eq!(scores["semseg"][lighting]["overall"][metric], 1.0, "the oracle is perfect under {lighting}");
        }
    }
    let merge_view = server.wait_done(&merge_id, &token);
    assert_eq!(merge_view["state"], "scored");
    // The same maps again under another method name: a twin within noise of the merge.
    let card_path = merged.path().join("submission.json");
    let mut card: Value = serde_json::from_slice(&std::fs::read(&card_path).unwrap()).unwrap();
    card["method"]["name"] = "Merged twin".into();
    std::fs::write(&card_path, serde_json::to_vec(&card).unwrap()).unwrap();
    let twin = server.upload(&token, &tar_of(merged.path()), "");
    assert_eq!(twin.status(), 202);
    let twin_id = twin.json::<Value>().unwrap()["id"].as_str().unwrap().to_string();
    let twin_view = server.wait_done(&twin_id, &token);
    assert_eq!(twin_view["state"], "scored");
    // Every scoring took the ground truth the worker had prepared; the cache still holds
    // one entry a scene, and the twin scores as the merge did.
    assert_eq!(entries(), 2, "one prepared ground truth a scene");
    assert!(!deployment.log("serve").contains("ground truth prepared again"), "{}", deployment.log("serve"));
    assert_eq!(twin_view["scores"]["semseg"], merge_view["scores"]["semseg"]);

    // Pooled values carry 95 % bootstrap intervals over scenes; the full document keeps
    // the replicates of pooled mIoU that rank comparisons pair up.
    for lighting in ["baseline", "camera", "dynamic_lights", "no_lights"] {
        assert_eq!(
            oracle_view["scores"]["semseg"][lighting]["overall"]["ci95"]["miou"],
            serde_json::json!([1.0, 1.0]),
            "every resample of the oracle is perfect"
        );
        let overall = &merge_view["scores"]["semseg"][lighting]["overall"];
        for metric in ["miou", "fmiou", "macc"] {
            let value = overall[metric].as_f64().unwrap();
            let [lo, hi] = [overall["ci95"][metric][0].as_f64().unwrap(), overall["ci95"][metric][1].as_f64().unwrap()];
            assert!(0.0 <= lo && lo <= value && value <= hi && hi <= 1.0, "{lighting} {metric}: {lo} ≤ {value} ≤ {hi}");
        }
        assert_eq!(merge_view["scores"]["semseg"][lighting]["bootstrap_miou"].as_array().unwrap().len(), 1000);
        let subset = &merge_view["scores"]["semseg"][lighting]["subsets"]["furniture"];
        assert_eq!((subset["scenes"].as_u64(), subset["overall"].get("ci95")), (Some(1), None), "one scene has no interval");
    }

    // The server's numbers are the evaluator's: score one scene locally and compare.
    let scene = "scene_000";
    let local = tempfile::tempdir().unwrap();
    let json_out = local.path().join("s.json");
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_osmab"))
        .args(["eval", "semseg", "--gt"])
        .arg(test_release().join("ground_truth").join(scene))
        .arg("--map")
        .arg(merged.path().join("maps/camera").join(format!("{scene}.npz")))
        .arg("--json")
        .arg(&json_out)
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let expected: Value = serde_json::from_slice(&std::fs::read(&json_out).unwrap()).unwrap();
    for metric in ["miou", "fmiou", "macc"] {
        assert_eq!(merge_view["scores"]["semseg"]["camera"]["scenes"][scene][metric], expected["metrics"][metric], "{metric}");
    }

    // The leaderboard ranks the oracle first, in JSON and CSV; the twins share a rank
    // group below it, and the oracle's is its own.
    let board: Value = server.get("/api/v1/leaderboard").send().unwrap().json().unwrap();
    assert_eq!(board["release"], version.as_str());
    let entries = board["entries"].as_array().unwrap();
    assert_eq!(entries.len(), 3);
    assert_eq!(entries[0]["submission_id"], oracle_id.as_str());
    assert_eq!(entries[0]["team"], "Team Journey");
    assert_eq!((entries[0]["baseline"].as_bool(), entries[0]["complete"].as_bool()), (Some(false), Some(true)));
    let standing: Vec<(u64, u64)> = entries.iter().map(|e| (e["rank"].as_u64().unwrap(), e["rank_group"].as_u64().unwrap())).collect();
    assert_eq!(standing, [(1, 1), (2, 2), (3, 2)]);
    assert_eq!(
        (entries[1]["submission_id"].as_str(), entries[2]["submission_id"].as_str()),
        (Some(merge_id.as_str()), Some(twin_id.as_str())),
        "equal scores: the earlier first"
    );
    let merge_miou = entries[1]["scores"]["semseg"]["baseline"]["overall"]["miou"].as_f64().unwrap();
    assert!(merge_miou < 1.0 && merge_miou > 0.0);
    assert_eq!(board["significance"], false, "two scenes pooled");
    assert!(entries[1]["scores"]["semseg"]["baseline"]["overall"].get("ci95").is_none(), "too few scenes for intervals: none, as the pages show none");
    assert!(entries[1]["scores"]["semseg"]["baseline"].get("bootstrap_miou").is_none(), "replicates stay in the full document");
    let worst = entries[1]["robustness"]["worst_miou"].as_f64().unwrap();
    let lighting = entries[1]["robustness"]["worst_lighting"].as_str().unwrap();
    assert_eq!(entries[1]["scores"]["semseg"][lighting]["overall"]["miou"].as_f64(), Some(worst));
    assert_eq!(
        entries[0]["robustness"],
        serde_json::json!({"largest_drop": 0.0, "largest_drop_lighting": "camera", "worst_lighting": "baseline", "worst_miou": 1.0})
    );
    let csv = server.get("/api/v1/leaderboard").header("accept", "text/csv").send().unwrap().text().unwrap();
    let mut lines = csv.lines();
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    assert!(header.join(",").starts_with("rank,rank_group,submission_id,team,method,baseline,reference,complete,worst_lighting,worst_lighting_miou,largest_drop_lighting,largest_drop,baseline_overall_miou,baseline_overall_fmiou,baseline_overall_macc,baseline_overall_miou_ci95_low"));
    // The oracle's row: first, every score 1 (f-mIoU sums the classes' shares as NumPy's
    // pairwise sum does, so it may print an ulp below 1).
    let oracle_row: Vec<&str> = lines.next().unwrap().split(',').collect();
    assert_eq!(oracle_row[..12].join(","), format!("1,1,{oracle_id},Team Journey,team-oracle,false,false,true,baseline,1,camera,0"));
    for (column, value) in oracle_row[12..21].iter().enumerate() {
        if header[12 + column].contains("ci95") {
            assert_eq!(*value, "", "no interval on a board of two scenes: {}", header[12 + column]);
            continue;
        }
        assert!((1.0 - value.parse::<f64>().unwrap()).abs() < 1e-12, "score column {} of the oracle's row: {value}", 12 + column);
    }
    assert_eq!(server.get("/api/v1/leaderboard.csv").send().unwrap().text().unwrap(), csv);

    // Pages render without JavaScript.
    let page = server.get("/").send().unwrap().text().unwrap();
    assert!(page.contains("team-oracle") && page.contains("team-merge") && page.contains("<svg"), "{page}");
    let release_page = server.get(&format!("/releases/{version}")).send().unwrap().text().unwrap();
    assert!(release_page.contains("scene_000") && release_page.contains(".tar"));
    let submission_page = server.get(&format!("/submissions/{oracle_id}")).send().unwrap().text().unwrap();
    assert!(submission_page.contains("scored") && submission_page.contains(scene));

    // Re-scoring adds a score and keeps the first.
    let rescore = server.admin(server.post(&format!("/api/v1/admin/submissions/{merge_id}/rescore")));
    assert_eq!(rescore.status(), 202);
    let rescore: Value = rescore.json().unwrap();
    let rescored = server.wait_done(&merge_id, &token);
    assert_eq!(rescored["state"], "scored");
    assert_eq!(rescored["score_history"].as_array().unwrap().len(), 2);
    assert_eq!(rescored["scores"]["semseg"], merge_view["scores"]["semseg"], "the same evaluator gives the same scores");

    // Every JSON answer is what the OpenAPI document's schema for it says.
    let document: Value = server.get("/api/v1/openapi.json").send().unwrap().json().unwrap();
    let job_id = rescored["jobs"][0]["id"].as_str().unwrap().to_string();
    let mut answers = vec![
        ("post", "/api/v1/submissions", accepted),
        ("post", "/api/v1/admin/submissions/{id}/rescore", rescore),
        ("get", "/api/v1/submissions/{id}", oracle_view.clone()),
        ("get", "/api/v1/submissions/{id}", rescored.clone()),
    ];
    let team_reads = [("/api/v1/me", "/api/v1/me".to_string()), ("/api/v1/submissions", "/api/v1/submissions".to_string())];
    let public_reads = [
        ("/livez", "/livez".to_string()),
        ("/readyz", "/readyz".to_string()),
        ("/api/v1/releases", "/api/v1/releases".to_string()),
        ("/api/v1/releases/{version}", format!("/api/v1/releases/{version}")),
        ("/api/v1/leaderboard", "/api/v1/leaderboard".to_string()),
        ("/api/v1/leaderboard/vqa", "/api/v1/leaderboard/vqa".to_string()),
    ];
    let admin_reads = [
        ("/api/v1/jobs/{id}", format!("/api/v1/jobs/{job_id}")),
        ("/api/v1/admin/teams", "/api/v1/admin/teams".to_string()),
        ("/api/v1/admin/submissions", "/api/v1/admin/submissions".to_string()),
        ("/api/v1/admin/jobs", "/api/v1/admin/jobs".to_string()),
    ];
    for (template, path) in team_reads {
        answers.push(("get", template, server.get(&path).bearer_auth(&token).send().unwrap().json().unwrap()));
    }
    for (template, path) in public_reads {
        answers.push(("get", template, server.get(&path).send().unwrap().json().unwrap()));
    }
    for (template, path) in admin_reads {
        answers.push(("get", template, server.admin(server.get(&path)).json().unwrap()));
    }
    assert!(oracle_view["scores"]["vqa"].is_object(), "the oracle's scene graphs give VQA scores to check");
    for (method, template, answer) in &answers {
        let broken = super::schema::violations(&document, super::schema::response_schema(&document, method, template), answer);
        assert!(broken.is_empty(), "{method} {template}: {broken:#?}");
    }

    // The oracle's score comes with a receipt anyone can check offline.
    super::receipts::a_receipt_verifies_offline_and_tampering_is_caught(&server, &oracle_id);
    answers.push(("get", "/api/v1/submissions/{id}/receipt", server.get(&format!("/api/v1/submissions/{oracle_id}/receipt")).send().unwrap().json().unwrap()));
    answers.push(("get", "/api/v1/keys", server.get("/api/v1/keys").send().unwrap().json().unwrap()));
    for (method, template, answer) in &answers[answers.len() - 2..] {
        let broken = super::schema::violations(&document, super::schema::response_schema(&document, method, template), answer);
        assert!(broken.is_empty(), "{method} {template}: {broken:#?}");
    }

    // The method card can be edited and the submission hidden from the leaderboard.
    let edited = server
        .client
        .patch(format!("{}/api/v1/submissions/{merge_id}", server.url))
        .bearer_auth(&token)
        .json(&serde_json::json!({"name": "Merged classes", "paper_url": "https://example.org/paper", "public": false}))
        .send()
        .unwrap();
    assert_eq!(edited.status(), 200);
    let board: Value = server.get("/api/v1/leaderboard").send().unwrap().json().unwrap();
    assert_eq!(board["entries"].as_array().unwrap().len(), 2, "the private submission left the leaderboard");
    assert_eq!(server.get(&format!("/api/v1/submissions/{merge_id}")).send().unwrap().status(), 404, "private to others");
    assert_eq!(server.get(&format!("/api/v1/submissions/{merge_id}/receipt")).send().unwrap().status(), 404, "and so is its receipt");

    // Restarted, the node finds every scene prepared in its cache: it reads each entry back
    // only for the box validation needs, and prepares nothing again.
    drop(server);
    let _restarted = deployment.serve();
    let ready = ready_line(&deployment);
    assert!(ready.contains("prepared=0") && ready.contains("from_cache=2"), "{ready}");
}

/// The line of the server's log saying the node is ready to score the current release
/// (waiting up to a minute for it).
fn ready_line(deployment: &Deployment) -> String {
    let waited = std::time::Instant::now();
    loop {
        let log = deployment.log("serve");
        if let Some(line) = log.lines().find(|l| l.contains("this node is ready to score the current release")) {
            return line.to_string();
        }
        assert!(waited.elapsed().as_secs() < 60, "the node never said it was ready:\n{log}");
        std::thread::sleep(std::time::Duration::from_millis(50));
    }
}

on_both_backends!(a_team_goes_from_download_to_leaderboard, super::journey);
