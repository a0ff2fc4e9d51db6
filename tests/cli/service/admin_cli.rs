//! `osmab admin team …`: an operator makes teams and handles their tokens from the service's
//! machine, without curl; what it prints works as the team's token.

use serde_json::Value;

use super::{Backend, Deployment};

fn text(output: &std::process::Output) -> (String, String) {
    (String::from_utf8_lossy(&output.stdout).into_owned(), String::from_utf8_lossy(&output.stderr).into_owned())
}

#[test]
fn an_operator_creates_lists_reissues_and_revokes_team_tokens_from_the_command_line() {
    let deployment = Deployment::new(Backend::Sqlite, &[]);
    let server = deployment.serve();
    let admin = |args: &[&str]| {
        let mut all = vec!["admin", if args[0] == "revoke" { "token" } else { "team" }];
        all.extend_from_slice(args);
        all.extend_from_slice(&["--url", &server.url]);
        deployment.run(&all)
    };
    let created = admin(&["create", "Lab One", "--daily-quota", "3"]);
    let (token, said) = text(&created);
    assert!(created.status.success() && token.trim().starts_with("osmab_") && said.contains("shown this once"), "{token}{said}");
    let me: Value = server.get("/api/v1/me").bearer_auth(token.trim()).send().unwrap().json().unwrap();
    assert_eq!(me["team"]["name"], "Lab One", "{me}");

    let (list, _) = text(&admin(&["list"]));
    assert!(list.lines().any(|l| l.contains("Lab One") && l.contains(" 3")), "{list}");
    let reissued = admin(&["token", "Lab One"]);
    let (second, _) = text(&reissued);
    assert!(reissued.status.success() && second.trim().starts_with("osmab_") && second != token, "{second}");
    let (tokens, _) = text(&admin(&["tokens", "Lab One"]));
    let ids: Vec<&str> = tokens.lines().filter_map(|l| l.split_whitespace().next()).filter(|w| w.starts_with("tok_")).collect();
    assert_eq!(ids.len(), 2, "{tokens}");

    // Revoke one: it stops working, the other still works.
    assert!(admin(&["revoke", ids[0]]).status.success(), "osmab admin token revoke ID");
    let statuses: Vec<u16> = [token.trim(), second.trim()].iter().map(|t| server.get("/api/v1/me").bearer_auth(t).send().unwrap().status().as_u16()).collect();
    assert_eq!(statuses.iter().filter(|s| **s == 401).count(), 1, "exactly the revoked token is refused: {statuses:?}");

    // Refusals say what is wrong.
    let (_, said) = text(&admin(&["token", "No Such Lab"]));
    assert!(said.contains("no team named 'No Such Lab'"), "{said}");
    let (_, said) = text(&admin(&["create", "Lab One"]));
    assert!(said.contains("exists"), "{said}");
}
