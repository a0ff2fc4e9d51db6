//! Tokens, scopes and quotas: every refusal is problem+json that says what to do.

use serde_json::{Value, json};

use super::{ADMIN, Backend, Deployment, baseline_dir, on_both_backends, problem, tar_of};

fn quotas_and_tokens(backend: Backend) {
    // The test release has val scenes only: its uploads count against the val quota.
    let deployment = Deployment::new(backend, &[("OSMAB_VAL_QUOTA", "1")]);
    let server = deployment.serve();
    server.import_test_release();
    let token = server.team("Team Quota");
    let archive = tar_of(baseline_dir("drop-small").path());

    // No token, a malformed one, an unknown one.
    problem(server.upload("", &archive, ""), 401, "token_invalid");
    let anonymous = server.post("/api/v1/submissions").body(archive.clone()).send().unwrap();
    assert_eq!(anonymous.headers()["www-authenticate"], "Bearer realm=\"osmab\"");
    problem(anonymous, 401, "unauthenticated");
    problem(server.upload("not-a-token", &archive, ""), 401, "token_invalid");
    problem(server.upload("osmab_0000000000000000000000000000000x", &archive, ""), 401, "token_invalid");
    // Scopes: admin tokens act for no team, team tokens cannot administer.
    problem(server.upload(ADMIN, &archive, ""), 403, "forbidden");
    let as_team = server.post("/api/v1/admin/teams").bearer_auth(&token).json(&json!({"name": "Sneaky"})).send().unwrap();
    problem(as_team, 403, "forbidden");
    problem(server.admin(server.post("/api/v1/admin/teams").json(&json!({"name": "Team Quota"}))), 409, "conflict");
    problem(server.admin(server.post("/api/v1/admin/teams").json(&json!({"nam": "typo"}))), 422, "invalid_request");

    // Dry runs are free; the one real submission of the day uses the quota.
    for _ in 0..3 {
        let dry = server.upload(&token, &archive, "?dry_run=true");
        assert_eq!(dry.status(), 200);
        let report: Value = dry.json().unwrap();
        assert_eq!((report["valid"].as_bool(), report["complete"].as_bool()), (Some(true), Some(true)));
    }
    let me: Value = server.get("/api/v1/me").bearer_auth(&token).send().unwrap().json().unwrap();
    assert_eq!((me["quota"]["limit"].as_i64(), me["quota"]["used"].as_i64()), (Some(1), Some(0)));
    // The same archive again is the same submission, with the quota used up or not, with
    // or without the idempotency key the first upload was made with (a client's retry);
    // that key with another archive is refused.
    let retry = |archive: &[u8], key: &str| {
        server
            .post("/api/v1/submissions")
            .bearer_auth(&token)
            .header("idempotency-key", key)
            .header("content-digest", super::content_digest(archive))
            .body(archive.to_vec())
            .send()
            .unwrap()
    };
    let first = retry(&archive, "retry-1");
    assert_eq!(first.status(), 202);
    let first_id = first.json::<Value>().unwrap()["id"].as_str().unwrap().to_string();
    for repeat in [server.upload(&token, &archive, ""), retry(&archive, "retry-1"), retry(&archive, "another-key")] {
        assert_eq!(repeat.status(), 200);
        let body: Value = repeat.json().unwrap();
        assert_eq!((body["id"].as_str(), body["repeat"].as_bool(), body["quota"]["used"].as_i64()), (Some(first_id.as_str()), Some(true), Some(1)), "{body}");
    }
    let other_archive = tar_of(baseline_dir("merge").path());
    let body = problem(retry(&other_archive, "retry-1"), 422, "idempotency_key_reused");
    assert!(body["detail"].as_str().unwrap().contains(&first_id), "{body}");
    problem(retry(&other_archive, "bad key with spaces"), 400, "invalid_idempotency_key");
    let submissions: Value = server.get("/api/v1/submissions").bearer_auth(&token).send().unwrap().json().unwrap();
    assert_eq!(submissions["submissions"].as_array().unwrap().len(), 1, "one submission: {submissions}");
    let refused = server.upload(&token, &other_archive, "");
    let retry_after: u64 = refused.headers()["retry-after"].to_str().unwrap().parse().unwrap();
    assert!((1..=86_400).contains(&retry_after));
    let body = problem(refused, 429, "quota_exceeded");
    assert_eq!(body["quota"]["used"], 1);
    assert!(body["detail"].as_str().unwrap().contains("UTC"), "{body}");
    assert_eq!(server.upload(&token, &archive, "?dry_run=true").status(), 200, "dry runs stay free when the quota is used");
    // An admin raises the quota.
    let team_id = server.admin(server.get("/api/v1/admin/teams")).json::<Value>().unwrap()["teams"][0]["id"].as_str().unwrap().to_string();
    let raised = server.admin(server.client.patch(format!("{}/api/v1/admin/teams/{team_id}", server.url)).json(&json!({"daily_quota": 3})));
    assert_eq!(raised.status(), 200);
    assert_eq!(server.upload(&token, &other_archive, "").status(), 202);

    // Revoked and expired tokens are explained.
    let issued: Value = server.admin(server.post(&format!("/api/v1/admin/teams/{team_id}/tokens"))).json().unwrap();
    let second = issued["token"].as_str().unwrap().to_string();
    assert_eq!(server.get("/api/v1/me").bearer_auth(&second).send().unwrap().status(), 200);
    let revoke = server.admin(server.client.delete(format!("{}/api/v1/admin/tokens/{}", server.url, issued["id"].as_str().unwrap())));
    assert_eq!(revoke.status(), 204);
    let body = problem(server.get("/api/v1/me").bearer_auth(&second).send().unwrap(), 401, "token_revoked");
    assert!(body["detail"].as_str().unwrap().contains("new one"));
    let tokens: Value = server.admin(server.get(&format!("/api/v1/admin/teams/{team_id}/tokens"))).json().unwrap();
    assert!(!tokens.to_string().contains(&second[10..]), "token lists never show tokens");
    assert_eq!(server.get("/api/v1/me").bearer_auth(&token).send().unwrap().status(), 200, "the other token still works");

    // Private submissions are invisible to other teams.
    let other = server.team("Team Other");
    let private = server.upload(&token, &tar_of(baseline_dir("label-noise").path()), "?public=false");
    let id = private.json::<Value>().unwrap()["id"].as_str().unwrap().to_string();
    problem(server.get(&format!("/api/v1/submissions/{id}")).bearer_auth(&other).send().unwrap(), 404, "not_found");
    assert_eq!(server.get(&format!("/api/v1/submissions/{id}")).bearer_auth(&token).send().unwrap().status(), 200);

    // Unknown routes and methods are problem+json too.
    problem(server.get("/api/v1/nothing").send().unwrap(), 404, "route_not_found");
    // A browser asking for a page that does not exist gets a page; the API stays problem+json.
    let page = server.get("/release").header("accept", "text/html,application/xhtml+xml").send().unwrap();
    assert_eq!((page.status().as_u16(), page.headers()["content-type"].to_str().unwrap()), (404, "text/html; charset=utf-8"));
    assert!(page.text().unwrap().contains("There is no page at <code>/release</code>"));
    problem(server.get("/api/v1/nothing").header("accept", "text/html").send().unwrap(), 404, "route_not_found");
    problem(server.get("/release").send().unwrap(), 404, "route_not_found");
    problem(server.client.delete(format!("{}/api/v1/leaderboard", server.url)).send().unwrap(), 405, "method_not_allowed");
}

on_both_backends!(tokens_scopes_and_quotas_are_enforced_and_explained, super::quotas_and_tokens);

/// Every operation in the OpenAPI document is routed (none falls through to 404/405).
#[test]
fn the_openapi_document_lists_only_real_routes() {
    let deployment = Deployment::new(Backend::Sqlite, &[]);
    let server = deployment.serve();
    let document: Value = server.get("/api/v1/openapi.json").send().unwrap().json().unwrap();
    assert_eq!(document["openapi"], "3.1.0");
    let paths = document["paths"].as_object().unwrap();
    assert!(paths.len() >= 20);
    for (path, methods) in paths {
        let concrete = path.replace("{version}", "v").replace("{id}", "x").replace("{path}", "a/b.txt");
        for method in methods.as_object().unwrap().keys() {
            let request = server.client.request(method.to_uppercase().parse().unwrap(), format!("{}{concrete}", server.url)).bearer_auth(ADMIN);
            let response = request.send().unwrap();
            let status = response.status().as_u16();
            let body: Value = response.json().unwrap_or(Value::Null);
            assert!(body["code"] != "route_not_found" && body["code"] != "method_not_allowed", "{method} {path}: {status} {body}");
        }
    }
    let docs = server.get("/api/docs").send().unwrap().text().unwrap();
    assert!(docs.replace("<wbr>", "").contains("<code>/api/v1/submissions</code>") && docs.contains("problem-quota_exceeded"));
    problem(server.get("/metrics").send().unwrap(), 401, "unauthenticated");
    let team = server.team("Team Metrics");
    problem(server.get("/metrics").bearer_auth(&team).send().unwrap(), 403, "forbidden");
    let metrics = server.admin(server.get("/metrics")).text().unwrap();
    assert!(metrics.contains("osmab_http_requests_total{method=\"GET\",route=\"/api/v1/openapi.json\",status=\"200\"}"), "{metrics}");
    assert!(metrics.contains("# TYPE osmab_jobs gauge"), "{metrics}");
}

/// Every refusal is problem+json, extractors included; a draft release tells a dry run
/// nothing; names that display as something else are refused; editing needs a token.
fn refusals_at_the_edges(backend: Backend) {
    let deployment = Deployment::new(backend, &[]);
    let server = deployment.serve();
    let token = server.team("Team Edges");
    let archive = tar_of(baseline_dir("drop-small").path());

    // A draft release: a dry run naming it is refused before anything is validated, with the
    // answer a version that does not exist gets (nothing tells a draft exists).
    let draft = server.admin(server.post("/api/v1/admin/releases/import").json(&json!({"path": super::test_release(), "publish": false})));
    assert_eq!(draft.status(), 201);
    let version = draft.json::<Value>().unwrap()["version"].as_str().unwrap().to_string();
    let body = problem(server.upload(&token, &archive, "?dry_run=true"), 422, "invalid_submission");
    assert!(!body.to_string().contains("scene_0"), "nothing of the draft is shown: {body}");
    let elsewhere = baseline_dir("drop-small");
    let card = elsewhere.path().join("submission.json");
    let renamed = std::fs::read_to_string(&card).unwrap().replace(&format!("\"{version}\""), "\"nowhere-9\"");
    assert!(renamed.contains("nowhere-9"), "{renamed}");
    std::fs::write(&card, renamed).unwrap();
    let unknown = problem(server.upload(&token, &tar_of(elsewhere.path()), "?dry_run=true"), 422, "invalid_submission");
    assert_eq!(body["detail"].as_str().unwrap().replace(&version, "V"), unknown["detail"].as_str().unwrap().replace("nowhere-9", "V"));
    assert_eq!(body["errors"].to_string().replace(&version, "V"), unknown["errors"].to_string().replace("nowhere-9", "V"));
    assert_eq!(server.admin(server.post(&format!("/api/v1/admin/releases/{version}/publish"))).status(), 200);

    // A posted config runs no command, calls no service and reads no folder the operator did
    // not list (OSMAB_RELEASE_ALLOW), and nothing is queued.
    let marker = deployment.data.path().join("pwned");
    let shell = super::TEST_RELEASE_CONFIG
        .replace("version = \"e2e-1\"", "version = \"shell-1\"")
        .replace("[render]", &format!("[render]\ncommand = [\"sh\", \"-c\", \"touch {}\"]", marker.display()));
    let llm = super::TEST_RELEASE_CONFIG
        .replace("version = \"e2e-1\"", "version = \"llm-1\"")
        .replace("[selection]", "[prompts.llm]\nbase_url = \"https://collector.example/v1\"\nmodel = \"m\"\n\n[selection]");
    for (config, field) in [(shell, "render.command"), (llm, "prompts.llm.base_url")] {
        let body = problem(server.admin(server.post("/api/v1/admin/releases").json(&json!({"config": config}))), 422, "invalid_request");
        assert!(
            body["detail"].as_str().unwrap().contains(&format!("config: {field}")) && body["detail"].as_str().unwrap().contains("OSMAB_RELEASE_ALLOW"),
            "{body}"
        );
    }
    let jobs: Value = server.admin(server.get("/api/v1/admin/jobs")).json().unwrap();
    assert!(jobs["jobs"].as_array().unwrap().iter().all(|j| j["kind"] != "build_release"), "nothing queued: {jobs}");
    assert!(!marker.exists());

    // Query and path parameters that do not parse.
    problem(server.get("/api/v1/leaderboard/vqa.csv?table=two").send().unwrap(), 400, "invalid_query");
    problem(server.get("/api/v1/leaderboard/vqa.csv?table=4").send().unwrap(), 400, "invalid_query");
    problem(server.upload(&token, &archive, "?dry_run=maybe"), 400, "invalid_query");
    problem(server.get("/api/v1/submissions/%FF%FE").bearer_auth(&token).send().unwrap(), 400, "invalid_path");
    problem(server.get("/releases/%C0").send().unwrap(), 400, "invalid_path");

    // Names with bidirectional overrides or invisible characters.
    let body = problem(server.admin(server.post("/api/v1/admin/teams").json(&json!({"name": "Lab\u{202E}evil"}))), 422, "invalid_request");
    assert!(body["detail"].as_str().unwrap().contains("U+202E"), "{body}");
    let accepted: Value = server.upload(&token, &archive, "").json().unwrap();
    let id = accepted["id"].as_str().unwrap();
    let rename = |name: &str, token: Option<&str>| {
        let request = server.client.patch(format!("{}/api/v1/submissions/{id}", server.url)).json(&json!({"name": name}));
        match token {
            Some(token) => request.bearer_auth(token).send().unwrap(),
            None => request.send().unwrap(),
        }
    };
    let body = problem(rename("zero\u{200B}width", Some(&token)), 422, "invalid_request");
    assert!(body["detail"].as_str().unwrap().contains("U+200B"), "{body}");

    // Names that read as the service's own: the baselines, "Anonymous"; stacked combining marks.
    for team in ["\u{0410}nonymous", "OSMa-Bench Baselines"] {
        let body = problem(server.admin(server.post("/api/v1/admin/teams").json(&json!({"name": team}))), 422, "invalid_request");
        assert!(body["detail"].as_str().unwrap().contains("reserves"), "{team}: {body}");
    }
    let zalgo = format!("Z{}", "\u{0301}".repeat(79));
    let body = problem(server.admin(server.post("/api/v1/admin/teams").json(&json!({"name": zalgo}))), 422, "invalid_request");
    assert!(body["detail"].as_str().unwrap().contains("combining marks"), "{body}");
    for method in ["baseIine-oracle", "Baseline Oracle", "Аnonymous"] {
        let body = problem(rename(method, Some(&token)), 422, "invalid_request");
        assert!(body["detail"].as_str().unwrap().contains("reserves") || body["detail"].as_str().unwrap().contains("anonymous"), "{method}: {body}");
    }
    let impostor = baseline_dir("drop-small");
    let card = impostor.path().join("submission.json");
    std::fs::write(&card, std::fs::read_to_string(&card).unwrap().replace("\"team-drop-small\"", "\"baseline-oracle\"")).unwrap();
    let body = problem(server.upload(&token, &tar_of(impostor.path()), "?dry_run=true"), 422, "invalid_submission");
    assert!(body["errors"].to_string().contains("method.name") && body["errors"].to_string().contains("reference baselines"), "{body}");

    // Editing needs the team's token: 401 without one, 403 with another team's.
    problem(rename("mine now", None), 401, "unauthenticated");
    let other = server.team("Team Other Edges");
    problem(rename("mine now", Some(&other)), 403, "forbidden");
    assert_eq!(rename("A fine name", Some(&token)).status(), 200);
    // Before the body is looked at: no token is 401 even for a malformed body.
    let malformed = server.client.patch(format!("{}/api/v1/submissions/{id}", server.url)).header("content-type", "application/json").body("{").send().unwrap();
    problem(malformed, 401, "unauthenticated");

    // The scheme is case-insensitive; two Authorization headers are refused.
    let lower = server.get("/api/v1/me").header("authorization", format!("bearer {token}")).send().unwrap();
    assert_eq!(lower.status(), 200);
    let twice = server.get("/api/v1/me").header("authorization", format!("Bearer {token}")).header("authorization", format!("Bearer {other}")).send().unwrap();
    problem(twice, 401, "token_invalid");
    // Control and bidi characters the client sent are not echoed raw into details.
    let echoed = problem(server.get("/api/v1/submissions/a%E2%80%AEb%1B").bearer_auth(&token).send().unwrap(), 404, "not_found");
    let detail = echoed["detail"].as_str().unwrap();
    assert!(!detail.contains('\u{202E}') && !detail.contains('\u{1b}'), "{detail}");
}

on_both_backends!(refusals_at_the_edges_are_problem_json, super::refusals_at_the_edges);

/// Writes are limited per team however its token header is spelled, and failed
/// authentications per address, reads included; anonymous reads are not limited.
fn rate_limits_by_caller(backend: Backend) {
    // One request per 100 s after a burst of 6: the admin's own setup stays within it.
    let deployment = Deployment::new(backend, &[("OSMAB_RATE_LIMIT", "0.01"), ("OSMAB_RATE_BURST", "6")]);
    let server = deployment.serve();
    let token = server.team("Team Limited");
    let cancel = |authorization: String| server.post("/api/v1/submissions/sub_none/cancel").header("authorization", authorization).send().unwrap();
    for spaces in 1..=6 {
        let response = cancel(format!("Bearer{}{token}", " ".repeat(spaces)));
        assert_eq!(response.status(), 404, "write {spaces} is admitted (and finds nothing)");
    }
    let body = problem(cancel(format!("Bearer       {token}")), 429, "rate_limited");
    assert!(body["detail"].as_str().unwrap().contains("retry"), "{body}");
    // Another team is not affected.
    let other = server.team("Team Unlimited");
    assert_eq!(cancel(format!("Bearer {other}")).status(), 404);

    // Failed authentications, session cookies of the console included, share one budget per address.
    let guess_session = || server.get("/admin").header("cookie", "osmab_admin_session=osmab_2222222222222222222222222222222x").send().unwrap();
    for _ in 0..3 {
        problem(server.get("/api/v1/me").bearer_auth("osmab_0000000000000000000000000000000x").send().unwrap(), 401, "token_invalid");
        let login = guess_session();
        assert_eq!((login.status().as_u16(), login.url().path()), (200, "/admin/login"), "a cookie that is no session goes to the sign-in page");
    }
    let refused = server.get("/api/v1/me").bearer_auth("osmab_1111111111111111111111111111111x").send().unwrap();
    assert!(refused.headers().contains_key("retry-after"));
    problem(refused, 429, "rate_limited");
    let refused = guess_session();
    assert_eq!(refused.status(), 429, "session guesses are refused once the budget is spent");
    assert!(refused.headers().contains_key("retry-after"));
    for _ in 0..10 {
        assert_eq!(server.get("/api/v1/releases").send().unwrap().status(), 200, "anonymous reads are not limited");
    }
}

on_both_backends!(rate_limits_follow_the_caller_not_the_header, super::rate_limits_by_caller);

/// A team holds at most `OSMAB_MAX_OPEN_UPLOADS` resumable uploads open, declaring at most
/// `OSMAB_MAX_OPEN_UPLOAD_BYTES`; each refusal names its limit, and finishing or deleting an
/// upload frees room.
fn open_uploads(backend: Backend) {
    let deployment = Deployment::new(backend, &[("OSMAB_MAX_OPEN_UPLOADS", "2"), ("OSMAB_MAX_UPLOAD_BYTES", "1000"), ("OSMAB_MAX_OPEN_UPLOAD_BYTES", "1200")]);
    let server = deployment.serve();
    let token = server.team("Team Open");
    let start = |token: &str, length: u64| {
        server.post("/api/v1/uploads").bearer_auth(token).header("tus-resumable", "1.0.0").header("upload-length", length).send().unwrap()
    };
    let first = start(&token, 700);
    assert_eq!(first.status(), 201);
    let first = first.headers()["location"].to_str().unwrap().to_string();
    assert_eq!(start(&token, 400).status(), 201);
    let body = problem(start(&token, 1), 429, "too_many_uploads");
    assert!(body["detail"].as_str().unwrap().contains("OSMAB_MAX_OPEN_UPLOADS = 2") && body["limit"] == 2, "{body}");
    let other = server.team("Team Elsewhere");
    assert_eq!(start(&other, 1000).status(), 201, "another team's uploads are its own");

    let deleted = server.client.delete(format!("{}{first}", server.url)).bearer_auth(&token).header("tus-resumable", "1.0.0").send().unwrap();
    assert_eq!(deleted.status(), 204);
    let body = problem(start(&token, 1001), 413, "payload_too_large");
    assert!(body["detail"].as_str().unwrap().contains("1000"), "one upload's own limit first: {body}");
    let body = problem(start(&token, 900), 413, "open_uploads_too_large");
    assert!(body["detail"].as_str().unwrap().contains("OSMAB_MAX_OPEN_UPLOAD_BYTES") && body["limit"] == 1200, "400 open + 900 passes 1200: {body}");
    let last = start(&token, 800);
    assert_eq!(last.status(), 201, "400 + 800 fits under 1200");
    let last = last.headers()["location"].to_str().unwrap().to_string();

    // A complete upload that is no submission is removed when refused: it frees its room.
    assert_eq!(server.tus_patch(&token, &last, 0, &[b'x'; 800]).status(), 204);
    let upload_id = last.rsplit('/').next().unwrap();
    problem(server.post(&format!("/api/v1/submissions?upload={upload_id}")).bearer_auth(&token).send().unwrap(), 422, "invalid_archive");
    let gone = server.client.head(format!("{}{last}", server.url)).bearer_auth(&token).header("tus-resumable", "1.0.0").send().unwrap();
    assert_eq!(gone.status(), 404, "the refused upload is removed");
    assert_eq!(start(&token, 800).status(), 201, "its room is free again");
}

on_both_backends!(open_uploads_are_limited_per_team, super::open_uploads);
