//! Tokens, scopes and quotas: every refusal is problem+json that says what to do.

use serde_json::{Value, json};

use super::{ADMIN, Backend, Deployment, baseline_dir, on_both_backends, problem, tar_of};

fn quotas_and_tokens(backend: Backend) {
    let deployment = Deployment::new(backend, &[("OSMAB_DAILY_QUOTA", "1")]);
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
    assert_eq!(server.upload(&token, &archive, "").status(), 202);
    let refused = server.upload(&token, &archive, "");
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
    assert_eq!(server.upload(&token, &archive, "").status(), 202);

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
    let private = server.upload(&token, &archive, "?public=false");
    let id = private.json::<Value>().unwrap()["id"].as_str().unwrap().to_string();
    problem(server.get(&format!("/api/v1/submissions/{id}")).bearer_auth(&other).send().unwrap(), 404, "not_found");
    assert_eq!(server.get(&format!("/api/v1/submissions/{id}")).bearer_auth(&token).send().unwrap().status(), 200);

    // Unknown routes and methods are problem+json too.
    problem(server.get("/api/v1/nothing").send().unwrap(), 404, "route_not_found");
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
    assert!(docs.contains("/api/v1/submissions") && docs.contains("problem-quota_exceeded"));
    let metrics = server.get("/metrics").send().unwrap().text().unwrap();
    assert!(metrics.contains("osmab_http_requests_total{method=\"GET\",route=\"/api/v1/openapi.json\",status=\"200\"}"), "{metrics}");
    assert!(metrics.contains("# TYPE osmab_jobs gauge"), "{metrics}");
}
