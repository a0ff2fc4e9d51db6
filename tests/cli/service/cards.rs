//! Method cards and anonymity: a submission carries its external data and compute, can
//! stay anonymous on the leaderboard (no team, no links, an anonymous receipt) until its
//! team reveals it, and the organisers can flag an entry with a reason everyone sees.

use serde_json::{Value, json};

use super::{Backend, Deployment, baseline_dir, on_both_backends, tar_of};

fn cards_anonymity_and_flags(backend: Backend) {
    let deployment = Deployment::new(backend, &[]);
    let server = deployment.serve();
    server.import_test_release();
    let token = server.team("Team Card");
    let dir = baseline_dir("drop-small");
    let card_file = dir.path().join("submission.json");
    let mut card: Value = serde_json::from_slice(&std::fs::read(&card_file).unwrap()).unwrap();
    card["method"]["external_data"] = json!("CLIP ViT-H-14 weights (LAION-2B)");
    card["method"]["compute"] = json!("1 × A100, 3 h per scene");
    card["method"]["paper_url"] = json!("https://example.org/our-paper");
    card["method"]["anonymous"] = json!(true);

    // A card field over its limit is refused by name before anything is stored.
    let mut long = card.clone();
    long["method"]["compute"] = json!("x".repeat(1001));
    std::fs::write(&card_file, serde_json::to_vec(&long).unwrap()).unwrap();
    let refused = server.upload(&token, &tar_of(dir.path()), "?dry_run=true");
    assert_eq!(refused.status(), 422);
    assert!(refused.text().unwrap().contains("method.compute"));

    std::fs::write(&card_file, serde_json::to_vec(&card).unwrap()).unwrap();
    let id = server.upload(&token, &tar_of(dir.path()), "").json::<Value>().unwrap()["id"].as_str().unwrap().to_string();
    assert_eq!(server.wait_done(&id, &token)["state"], "scored");

    // Everyone else sees an anonymous entry; its team sees itself.
    let entry = |board: &Value| board["entries"].as_array().unwrap().iter().find(|e| e["submission_id"] == id.as_str()).cloned().unwrap();
    let board: Value = server.get("/api/v1/leaderboard").send().unwrap().json().unwrap();
    let anonymous = entry(&board);
    assert_eq!(
        (anonymous["team"].as_str(), anonymous["anonymous"].as_bool(), anonymous.get("paper_url")),
        (Some("Anonymous"), Some(true), None),
        "{anonymous}"
    );
    let public: Value = server.get(&format!("/api/v1/submissions/{id}")).send().unwrap().json().unwrap();
    assert_eq!(public["team"], "Anonymous");
    assert_eq!(public["method"]["paper_url"], Value::Null, "links would tell who it is");
    assert_eq!(
        (public["method"]["external_data"].as_str(), public["method"]["compute"].as_str()),
        (Some("CLIP ViT-H-14 weights (LAION-2B)"), Some("1 × A100, 3 h per scene"))
    );
    let own: Value = server.get(&format!("/api/v1/submissions/{id}")).bearer_auth(&token).send().unwrap().json().unwrap();
    assert_eq!((own["team"].as_str(), own["method"]["paper_url"].as_str()), (Some("Team Card"), Some("https://example.org/our-paper")));
    let receipt: Value = server.get(&format!("/api/v1/submissions/{id}/receipt")).send().unwrap().json().unwrap();
    assert_eq!(receipt["receipt"]["team"], "Anonymous", "an anonymous entry's receipt does not name its team");

    // But it binds one: the team proves the entry theirs with the claim code only it is shown;
    // another team cannot claim it, nor the team with a wrong code.
    assert!(public.get("claim_code").is_none(), "only the team sees the claim code: {public}");
    let code = own["claim_code"].as_str().unwrap();
    let files = tempfile::tempdir().unwrap();
    let receipt_file = files.path().join("receipt.json");
    std::fs::write(&receipt_file, receipt.to_string()).unwrap();
    let keys = format!("{}/api/v1/keys", server.url);
    let claim = |team: &str, code: &str| crate::osmab(&["client", "verify", crate::path(&receipt_file), "--keys", &keys, "--team", team, "--claim-code", code]);
    let claimed = claim("Team Card", code);
    let said = String::from_utf8_lossy(&claimed.stdout);
    assert!(
        claimed.status.success() && said.contains("Claimed: this anonymous entry is team Team Card's"),
        "{said}{}",
        String::from_utf8_lossy(&claimed.stderr)
    );
    for (team, code) in [("Team Impostor", code), ("Team Card", "0123456789abcdef0123456789abcdef")] {
        let refused = claim(team, code);
        assert!(!refused.status.success() && String::from_utf8_lossy(&refused.stderr).contains("do not match"), "{team}");
    }
    let page = server.get("/").send().unwrap().text().unwrap();
    assert!(!page.contains("Team Card"), "the leaderboard page does not name the team");

    // The organisers flag it; everyone sees why; clearing the flag removes it.
    let empty = server.admin(server.client.put(format!("{}/api/v1/admin/submissions/{id}/flag", server.url)).json(&json!({"reason": "  "})));
    assert_eq!(empty.status(), 422);
    let flagged =
        server.admin(server.client.put(format!("{}/api/v1/admin/submissions/{id}/flag", server.url)).json(&json!({"reason": "trained on test scenes"})));
    assert_eq!(flagged.status(), 200);
    let board: Value = server.get("/api/v1/leaderboard").send().unwrap().json().unwrap();
    assert_eq!(entry(&board)["flagged"], "trained on test scenes");
    let page = server.get("/").send().unwrap().text().unwrap();
    assert!(page.contains("title=\"trained on test scenes\">flagged</span>"), "{page}");
    let team_flag =
        server.client.put(format!("{}/api/v1/admin/submissions/{id}/flag", server.url)).bearer_auth(&token).json(&json!({"reason": "x"})).send().unwrap();
    assert_eq!(team_flag.status(), 403, "only organisers flag");
    let document: Value = server.get("/api/v1/openapi.json").send().unwrap().json().unwrap();
    for (template, answer) in [("/api/v1/leaderboard", &board), ("/api/v1/submissions/{id}", &public)] {
        let broken = super::schema::violations(&document, super::schema::response_schema(&document, "get", template), answer);
        assert!(broken.is_empty(), "{template}: {broken:?}");
    }
    assert_eq!(server.admin(server.client.delete(format!("{}/api/v1/admin/submissions/{id}/flag", server.url))).status(), 204);
    let board: Value = server.get("/api/v1/leaderboard").send().unwrap().json().unwrap();
    assert!(entry(&board).get("flagged").is_none());

    // The team reveals itself.
    let revealed =
        server.client.patch(format!("{}/api/v1/submissions/{id}", server.url)).bearer_auth(&token).json(&json!({"anonymous": false})).send().unwrap();
    assert_eq!(revealed.status(), 200);
    let board: Value = server.get("/api/v1/leaderboard").send().unwrap().json().unwrap();
    let shown = entry(&board);
    assert_eq!((shown["team"].as_str(), shown["paper_url"].as_str(), shown.get("anonymous")), (Some("Team Card"), Some("https://example.org/our-paper"), None));
}

on_both_backends!(a_method_card_can_stay_anonymous_until_revealed_and_entries_can_be_flagged, super::cards_anonymity_and_flags);
