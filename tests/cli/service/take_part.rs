//! A way in without an organiser at hand: a stranger asks for access on the "Take part"
//! page, is shown a claim code once, the operator approves (or declines) from the command
//! line, and the stranger collects a working token with the code — once. Nothing exists
//! until the request is approved; one client holds few pending requests; the admin
//! commands find the service `serve` started, whatever `OSMAB_BIND` said.

use reqwest::blocking::Client;
use reqwest::redirect::Policy;
use serde_json::{Value, json};

use super::{Backend, Deployment, on_both_backends, problem};

fn said(output: &std::process::Output) -> String {
    format!("{}{}", String::from_utf8_lossy(&output.stdout), String::from_utf8_lossy(&output.stderr))
}

/// The text of the element with `id` in `page` (`<code id="…" …>text</code>`).
fn element_text(page: &str, id: &str) -> String {
    let start = page.find(&format!("id=\"{id}\"")).unwrap_or_else(|| panic!("no #{id} in {page}"));
    let text = &page[start..];
    text[text.find('>').unwrap() + 1..text.find('<').unwrap()].to_string()
}

fn a_stranger_asks_is_approved_and_collects_a_token_once(backend: Backend) {
    let deployment = Deployment::new(backend, &[]);
    let server = deployment.serve();
    let browser = Client::builder().redirect(Policy::none()).build().unwrap();
    let front = server.get("/").send().unwrap().text().unwrap();
    assert!(front.contains("href=\"/take-part\""), "every page leads to Take part");
    let page = server.get("/take-part").send().unwrap().text().unwrap();
    assert!(page.contains("id=\"ask-access\"") && page.contains("id=\"collect-access\""), "{page}");

    let ask = |team: &str| {
        browser
            .post(format!("{}/take-part", server.url))
            .form(&[
                ("team_name", team),
                ("contact", "lead@robot.example"),
                ("affiliation", "Robot Lab, Somewhere U"),
                ("method_url", "https://robot.example/paper"),
            ])
            .send()
            .unwrap()
    };
    let asked = ask("Robot Lab");
    assert_eq!(asked.status(), 201);
    assert_eq!(asked.headers()["cache-control"], "no-store");
    let code = element_text(&asked.text().unwrap(), "claim-code");
    assert!(code.starts_with("osmab_claim_"), "{code}");
    let collect = |code: &str| browser.post(format!("{}/take-part/collect", server.url)).form(&[("claim_code", code)]).send().unwrap();
    let waiting = collect(&code);
    assert_eq!(waiting.status(), 200);
    assert!(waiting.text().unwrap().contains("waits for the organisers"));
    assert_eq!(collect("osmab_claim_notacode000000000000000").status(), 404);
    let teams: Value = server.admin(server.get("/api/v1/admin/teams")).json().unwrap();
    assert!(!teams.to_string().contains("Robot Lab"), "nothing is created until approved: {teams}");

    // A name that reads as a pending request's, a malformed link, and a fourth pending request from one client.
    let twin = ask("Robot-Lab");
    assert_eq!(twin.status(), 409);
    assert!(twin.text().unwrap().contains("reads as"));
    let bad_link = browser
        .post(format!("{}/take-part", server.url))
        .form(&[("team_name", "Link Lab"), ("contact", "x@y.example"), ("affiliation", "Y"), ("method_url", "javascript:alert(1)")])
        .send()
        .unwrap();
    assert_eq!(bad_link.status(), 422);
    let api_ask =
        |team: &str| server.post("/api/v1/access-requests").json(&json!({"team_name": team, "contact": "c@d.example", "affiliation": "D"})).send().unwrap();
    let second: Value = api_ask("Declined Lab").json().unwrap();
    assert_eq!(second["state"], "pending");
    assert_eq!(api_ask("Third Lab").status(), 201);
    let body = problem(api_ask("Fourth Lab"), 429, "rate_limited");
    assert!(body["detail"].as_str().unwrap().contains("3 requests waiting"), "{body}");

    // The operator, from the command line, without --url: the admin commands find the server.
    let listed = deployment.run(&["admin", "team", "requests"]);
    let text = said(&listed);
    assert!(listed.status.success() && text.contains("Robot Lab") && text.contains("lead@robot.example") && text.contains("Declined Lab"), "{text}");
    let id = text.lines().find(|l| l.contains("Robot Lab")).unwrap().split_whitespace().next().unwrap().to_string();
    let approved = deployment.run(&["admin", "team", "approve", &id]);
    assert!(approved.status.success() && said(&approved).contains("Team 'Robot Lab' is created"), "{}", said(&approved));
    let again = deployment.run(&["admin", "team", "approve", &id]);
    assert!(!again.status.success() && said(&again).contains("only a pending one"), "{}", said(&again));
    let declined = deployment.run(&["admin", "team", "decline", second["id"].as_str().unwrap(), "--reason", "no method link yet"]);
    assert!(declined.status.success(), "{}", said(&declined));

    // The stranger collects the token once; it works.
    let collected = collect(&code).text().unwrap();
    let token = element_text(&collected, "team-token");
    let me: Value = server.get("/api/v1/me").bearer_auth(&token).send().unwrap().json().unwrap();
    assert_eq!(me["team"]["name"], "Robot Lab", "{me}");
    let twice = collect(&code).text().unwrap();
    assert!(!twice.contains("id=\"team-token\"") && twice.contains("collected already"), "the token is shown once");
    let reason: Value = server.post("/api/v1/access-requests/collect").json(&json!({"claim_code": second["claim_code"]})).send().unwrap().json().unwrap();
    assert_eq!(reason["state"], "declined");
    assert!(reason["message"].as_str().unwrap().contains("no method link yet") && reason.get("token").is_none(), "{reason}");
}

on_both_backends!(a_team_asks_for_access_and_collects_its_token_once_approved, super::a_stranger_asks_is_approved_and_collects_a_token_once);

#[test]
fn an_admin_command_that_finds_no_service_says_where_it_looked_and_how_to_point_it() {
    let deployment = Deployment::new(Backend::Sqlite, &[("OSMAB_BIND", "127.0.0.1:9")]);
    let refused = deployment.run(&["admin", "team", "list"]);
    let text = said(&refused);
    assert!(!refused.status.success() && text.contains("does not answer") && text.contains("OSMAB_BIND") && text.contains("--url"), "{text}");
}
