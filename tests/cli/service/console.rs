//! The operator's console: sign in with the admin token for a session cookie, use the
//! forms (flag, refund, regenerate, publish), be refused without the session's form token
//! or from another origin, and sign out for good.

use reqwest::blocking::{Client, Response};
use reqwest::redirect::Policy;
use serde_json::Value;

use super::{ADMIN, Backend, Deployment, Server, baseline_dir, on_both_backends, tar_of};

/// A browser that does not follow redirects, so the tests see them.
fn browser() -> Client {
    Client::builder().redirect(Policy::none()).build().unwrap()
}

fn form(client: &Client, server: &Server<'_>, path: &str, cookie: &str, fields: &[(&str, &str)]) -> Response {
    client.post(format!("{}{path}", server.url)).header("cookie", cookie).form(fields).send().unwrap()
}

/// The hidden form token of a console page.
fn form_token(page: &str) -> String {
    let at = page.find("name=\"form_token\" value=\"").expect("a form token on the page") + "name=\"form_token\" value=\"".len();
    page[at..].split('"').next().unwrap().to_string()
}

fn location(response: &Response) -> &str {
    response.headers()["location"].to_str().unwrap()
}

fn console(backend: Backend) {
    let deployment = Deployment::new(backend, &[]);
    let server = deployment.serve();
    let version = server.import_test_release();
    let token = server.team("Team Console");
    let id = server.upload(&token, &tar_of(baseline_dir("merge").path()), "").json::<Value>().unwrap()["id"].as_str().unwrap().to_string();
    assert_eq!(server.wait_done(&id, &token)["state"], "scored");
    let browser = browser();

    // Without a session every console page sends the operator to sign in.
    for path in ["/admin", "/admin/jobs/job_x", &format!("/admin/releases/{version}/quality")] {
        let answer = browser.get(format!("{}{path}", server.url)).send().unwrap();
        assert_eq!((answer.status().as_u16(), location(&answer)), (303, "/admin/login"), "{path}");
    }
    let refused = browser.post(format!("{}/admin/submissions/{id}/flag", server.url)).form(&[("form_token", "x"), ("reason", "r")]).send().unwrap();
    assert_eq!((refused.status().as_u16(), location(&refused)), (303, "/admin/login"), "a form without a session changes nothing");

    // A wrong token or a team's is refused with a reason; the admin token opens a session.
    let sign_in = |t: &str| browser.post(format!("{}/admin/login", server.url)).form(&[("token", t)]).send().unwrap();
    let wrong = sign_in("osmab_notthetoken000000000000000000");
    assert_eq!(wrong.status(), 401);
    assert!(wrong.text().unwrap().contains("not known to this server"));
    let team = sign_in(&token);
    assert_eq!(team.status(), 401);
    assert!(team.text().unwrap().contains("team token"));
    let signed_in = sign_in(ADMIN);
    assert_eq!((signed_in.status().as_u16(), location(&signed_in)), (303, "/admin"));
    let set_cookie = signed_in.headers()["set-cookie"].to_str().unwrap().to_string();
    for attribute in ["HttpOnly", "SameSite=Strict", "Path=/admin", "Max-Age=43200"] {
        assert!(set_cookie.contains(attribute), "{set_cookie}");
    }
    let cookie = set_cookie.split(';').next().unwrap().to_string();
    assert!(!cookie.contains(ADMIN), "the session is a token of its own, not the admin token");

    // The console lists the release, the submission and the forms.
    let page = browser.get(format!("{}/admin", server.url)).header("cookie", &cookie).send().unwrap();
    assert_eq!(page.status(), 200);
    let page = page.text().unwrap();
    assert!(page.contains(&version) && page.contains(&id) && page.contains("Team Console") && page.contains("<textarea"), "{page}");
    let form_token = form_token(&page);

    // Forms without the session's form token, or from another origin, change nothing.
    let forged =
        form(&browser, &server, &format!("/admin/submissions/{id}/flag"), &cookie, &[("form_token", "0123456789abcdef0123456789abcdef"), ("reason", "forged")]);
    assert_eq!(forged.status(), 403);
    let cross = browser
        .post(format!("{}/admin/submissions/{id}/flag", server.url))
        .header("cookie", &cookie)
        .header("origin", "https://evil.example")
        .form(&[("form_token", form_token.as_str()), ("reason", "cross-site")])
        .send()
        .unwrap();
    assert_eq!(cross.status(), 403);
    // A client's own X-Forwarded-Host does not make another origin this page's: the test
    // server trusts no proxy (OSMAB_TRUSTED_PROXIES is unset).
    let spoofed = browser
        .post(format!("{}/admin/submissions/{id}/flag", server.url))
        .header("cookie", &cookie)
        .header("origin", "https://evil.example")
        .header("x-forwarded-host", "evil.example")
        .form(&[("form_token", form_token.as_str()), ("reason", "spoofed host")])
        .send()
        .unwrap();
    assert_eq!(spoofed.status(), 403);
    let missing = form(&browser, &server, &format!("/admin/submissions/{id}/flag"), &cookie, &[("reason", "no token")]);
    assert_eq!(missing.status(), 400);
    let entry = |server: &Server<'_>| {
        let board: Value = server.get("/api/v1/leaderboard").send().unwrap().json().unwrap();
        board["entries"].as_array().unwrap().iter().find(|e| e["submission_id"] == id.as_str()).cloned().unwrap()
    };
    assert!(entry(&server).get("flagged").is_none(), "no refused form flagged anything");

    // Flag, clear, refund through the forms.
    let flagged =
        form(&browser, &server, &format!("/admin/submissions/{id}/flag"), &cookie, &[("form_token", &form_token), ("reason", "trained on test scenes")]);
    assert_eq!(flagged.status(), 303);
    assert!(location(&flagged).starts_with("/admin?notice="));
    assert_eq!(entry(&server)["flagged"], "trained on test scenes");
    let after = browser.get(format!("{}{}", server.url, location(&flagged))).header("cookie", &cookie).send().unwrap().text().unwrap();
    assert!(after.contains(&format!("{id} is flagged.")), "the console says what was done");
    let crafted =
        browser.get(format!("{}/admin?notice=Send+your+token+to+evil.example&seal=0000000000000000", server.url)).header("cookie", &cookie).send().unwrap();
    assert!(!crafted.text().unwrap().contains("evil.example"), "a crafted link puts no words on the console");
    let blank = form(&browser, &server, &format!("/admin/submissions/{id}/flag"), &cookie, &[("form_token", &form_token), ("reason", "  ")]);
    assert_eq!(blank.status(), 422);
    assert!(blank.text().unwrap().contains("reason"));
    assert_eq!(form(&browser, &server, &format!("/admin/submissions/{id}/unflag"), &cookie, &[("form_token", &form_token)]).status(), 303);
    assert!(entry(&server).get("flagged").is_none());
    let used = |server: &Server<'_>| server.get("/api/v1/me").bearer_auth(&token).send().unwrap().json::<Value>().unwrap()["quota"]["used"].as_i64().unwrap();
    assert_eq!(used(&server), 1);
    assert_eq!(form(&browser, &server, &format!("/admin/submissions/{id}/refund"), &cookie, &[("form_token", &form_token)]).status(), 303);
    assert_eq!(used(&server), 0, "the quota unit is given back");
    let again = form(&browser, &server, &format!("/admin/submissions/{id}/refund"), &cookie, &[("form_token", &form_token)]);
    assert!(location(&again).contains("already"));
    let unknown = form(&browser, &server, "/admin/submissions/sub_none/refund", &cookie, &[("form_token", &form_token)]);
    assert_eq!(unknown.status(), 404);

    // The quotas: the console shows each split's limit and sets one; a bad number is refused.
    let page = browser.get(format!("{}/admin", server.url)).header("cookie", &cookie).send().unwrap().text().unwrap();
    assert!(page.contains("id=\"admin-quotas\"") && page.contains("data-split=\"test\"") && page.contains("the service's default"));
    let set = form(&browser, &server, "/admin/quotas", &cookie, &[("form_token", &form_token), ("split", "val"), ("limit", "7"), ("window_hours", "12")]);
    assert_eq!(set.status(), 303);
    assert!(location(&set).contains("7%20submissions%20per%20team%20per%2012%20hours"), "{}", location(&set));
    let policies: Value = server.admin(server.get("/api/v1/admin/quotas")).json().unwrap();
    let val = policies["policies"].as_array().unwrap().iter().find(|p| p["split"] == "val").unwrap().clone();
    assert_eq!((val["limit"].as_i64(), val["window_hours"].as_i64(), val["set"].as_bool()), (Some(7), Some(12), Some(true)));
    let quota: Value = server.get("/api/v1/quota").bearer_auth(&token).send().unwrap().json().unwrap();
    assert_eq!(quota["splits"][1]["limit"], 7, "teams see it before uploading: {quota}");
    for (limit, window) in [("many", "12"), ("3", "0")] {
        let bad =
            form(&browser, &server, "/admin/quotas", &cookie, &[("form_token", &form_token), ("split", "val"), ("limit", limit), ("window_hours", window)]);
        assert_eq!(bad.status(), 422, "{limit} per {window} h");
    }
    let forged = form(
        &browser,
        &server,
        "/admin/quotas",
        &cookie,
        &[("form_token", "0123456789abcdef0123456789abcdef"), ("split", "val"), ("limit", "0"), ("window_hours", "1")],
    );
    assert_eq!(forged.status(), 403);
    assert_eq!(server.get("/api/v1/quota").bearer_auth(&token).send().unwrap().json::<Value>().unwrap()["splits"][1]["limit"], 7, "nothing changed");

    // A broken configuration is refused with the field named, and nothing is queued.
    let jobs_before = server.admin(server.get("/api/v1/admin/jobs")).json::<Value>().unwrap()["jobs"].as_array().unwrap().len();
    let broken = form(&browser, &server, "/admin/regenerate", &cookie, &[("form_token", &form_token), ("config", "version = \"x-1\"\n[[nonsense")]);
    assert_eq!(broken.status(), 422);
    assert!(broken.text().unwrap().to_lowercase().contains("config"));
    assert_eq!(server.admin(server.get("/api/v1/admin/jobs")).json::<Value>().unwrap()["jobs"].as_array().unwrap().len(), jobs_before);

    // The quality page reads the release's report.
    let quality = browser.get(format!("{}/admin/releases/{version}/quality", server.url)).header("cookie", &cookie).send().unwrap();
    assert_eq!(quality.status(), 200);
    let quality = quality.text().unwrap();
    assert!(quality.contains("scenes passing the bar") && quality.contains("scene_000"), "{quality}");
    let none = browser.get(format!("{}/admin/releases/nope/quality", server.url)).header("cookie", &cookie).send().unwrap();
    assert_eq!(none.status(), 404);

    // A request for access waits in the console; approving it creates the team (no token shown here).
    let asked: Value = server
        .post("/api/v1/access-requests")
        .json(&serde_json::json!({"team_name": "Console Lab", "contact": "c@lab.example", "affiliation": "Lab"}))
        .send()
        .unwrap()
        .json()
        .unwrap();
    let id_of_request = asked["id"].as_str().unwrap();
    let page = browser.get(format!("{}/admin", server.url)).header("cookie", &cookie).send().unwrap().text().unwrap();
    assert!(
        page.contains("id=\"admin-access-requests\"")
            && page.contains("Console Lab")
            && page.contains(&format!("/admin/access-requests/{id_of_request}/approve")),
        "{page}"
    );
    let approved = form(&browser, &server, &format!("/admin/access-requests/{id_of_request}/approve"), &cookie, &[("form_token", &form_token)]);
    assert_eq!(approved.status(), 303);
    let teams: Value = server.admin(server.get("/api/v1/admin/teams")).json().unwrap();
    assert!(teams.to_string().contains("Console Lab"), "{teams}");
    let forged = form(&browser, &server, &format!("/admin/access-requests/{id_of_request}/decline"), &cookie, &[("form_token", "x"), ("reason", "r")]);
    assert_eq!(forged.status(), 403, "a decision needs the session's form token");

    // Signing out revokes the session: the same cookie no longer opens the console.
    let out = form(&browser, &server, "/admin/logout", &cookie, &[("form_token", &form_token)]);
    assert_eq!((out.status().as_u16(), location(&out)), (303, "/admin/login"));
    assert!(out.headers()["set-cookie"].to_str().unwrap().contains("Max-Age=0"));
    let after = browser.get(format!("{}/admin", server.url)).header("cookie", &cookie).send().unwrap();
    assert_eq!((after.status().as_u16(), location(&after)), (303, "/admin/login"));
}

on_both_backends!(an_operator_signs_in_and_uses_the_forms, super::console);
