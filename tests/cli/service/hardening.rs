//! The fourth hostile review's weak points, each played against a real `osmab serve`: the
//! data directory other local users could read, console sessions that renewed themselves,
//! strangers locking the operator out, resumable uploads that held scratch outside their
//! limit, look-alike team names, and regeneration configs of unbounded size.

use std::io::Write;
use std::time::Duration;

use reqwest::blocking::Client;
use reqwest::redirect::Policy;
use serde_json::json;

use super::{ADMIN, Backend, Deployment, problem};

fn browser_from(local: &str) -> Client {
    Client::builder().redirect(Policy::none()).local_address(local.parse::<std::net::IpAddr>().ok()).build().unwrap()
}

fn sign_in(browser: &Client, url: &str, token: &str) -> reqwest::blocking::Response {
    browser.post(format!("{url}/admin/login")).form(&[("token", token)]).send().unwrap()
}

#[test]
#[cfg(unix)]
fn the_data_directory_and_its_secret_folders_are_owner_only_and_repaired_at_start() {
    use std::os::unix::fs::PermissionsExt;
    let deployment = Deployment::new(Backend::Sqlite, &[]);
    std::fs::set_permissions(deployment.data.path(), std::fs::Permissions::from_mode(0o755)).unwrap();
    let server = deployment.serve();
    let mode = |rel: &str| std::fs::metadata(deployment.data.path().join(rel)).unwrap().permissions().mode() & 0o777;
    assert_eq!(mode(""), 0o700, "the data directory holds hidden ground truth, the database and uploads");
    assert_eq!((mode("receipt-keys"), mode("split-secret")), (0o700, 0o700), "the secret folders are what the log calls them");
    drop(server);
    assert!(deployment.log("serve").contains("made it owner-only"), "{}", deployment.log("serve"));
    // A secret folder loosened later is repaired at the next start.
    std::fs::set_permissions(deployment.data.path().join("split-secret"), std::fs::Permissions::from_mode(0o755)).unwrap();
    let _again = deployment.serve();
    assert_eq!(mode("split-secret"), 0o700);
}

#[test]
fn a_console_session_signs_nobody_in_again() {
    let deployment = Deployment::new(Backend::Sqlite, &[]);
    let server = deployment.serve();
    let browser = browser_from("127.0.0.1");
    let signed_in = sign_in(&browser, &server.url, ADMIN);
    assert_eq!(signed_in.status(), 303);
    let cookie = signed_in.headers()["set-cookie"].to_str().unwrap().split(';').next().unwrap().to_string();
    let session = cookie.split_once('=').unwrap().1.to_string();
    let renewed = sign_in(&browser, &server.url, &session);
    assert_eq!(renewed.status(), 401, "a session posted as the token makes no new session");
    assert!(renewed.headers().get("set-cookie").is_none() && renewed.text().unwrap().contains("console session"));
    let as_api_token = server.get("/api/v1/admin/teams").bearer_auth(&session).send().unwrap();
    assert!(problem(as_api_token, 401, "token_invalid")["detail"].as_str().unwrap().contains("console session"), "a session opens the pages only");
    assert_eq!(server.admin(server.get("/api/v1/admin/teams")).status(), 200, "the admin token does");
}

#[test]
fn strangers_at_the_operators_address_cannot_lock_the_admin_token_out_and_loopback_aliases_share_a_budget() {
    // One failure per 100 s after a burst of 4.
    let deployment = Deployment::new(Backend::Sqlite, &[("OSMAB_RATE_LIMIT", "0.01"), ("OSMAB_RATE_BURST", "4")]);
    let server = deployment.serve();
    let here = browser_from("127.0.0.1");
    for _ in 0..4 {
        assert_eq!(sign_in(&here, &server.url, "osmab_notthetoken000000000000000000").status(), 401);
    }
    assert_eq!(sign_in(&here, &server.url, "osmab_notthetoken000000000000000000").status(), 429, "guessing stops at the budget");
    assert_eq!(sign_in(&here, &server.url, ADMIN).status(), 303, "the admin token still signs in from the same address");
    let alias = browser_from("127.0.0.2");
    assert_eq!(sign_in(&alias, &server.url, "osmab_notthetoken000000000000000000").status(), 429, "another loopback address is the same client");
    let api = Client::builder().local_address("127.0.0.3".parse::<std::net::IpAddr>().ok()).build().unwrap();
    let refused = api.get(format!("{}/api/v1/me", server.url)).bearer_auth("osmab_0000000000000000000000000000000x").send().unwrap();
    problem(refused, 429, "rate_limited");
}

#[test]
fn a_resumable_upload_takes_one_patch_at_a_time_and_no_slivers() {
    let deployment = Deployment::new(Backend::Sqlite, &[]);
    let server = deployment.serve();
    let token = server.team("Team Patches");
    let created = server.post("/api/v1/uploads").bearer_auth(&token).header("tus-resumable", "1.0.0").header("upload-length", 300_000).send().unwrap();
    assert_eq!(created.status(), 201);
    let path = created.headers()["location"].to_str().unwrap().to_string();
    let body = problem(server.tus_patch(&token, &path, 0, b"x"), 400, "chunk_too_small");
    assert_eq!(body["minimum"], 65536, "{body}");

    // A PATCH still arriving holds the upload: a second one at the same offset is refused
    // instead of filling a scratch file of its own.
    let address = server.url.strip_prefix("http://").unwrap();
    let open_slow_patch = || {
        let mut slow = std::net::TcpStream::connect(address).unwrap();
        write!(
            slow,
            "PATCH {path} HTTP/1.1\r\nHost: {address}\r\nAuthorization: Bearer {token}\r\nTus-Resumable: 1.0.0\r\nContent-Type: application/offset+octet-stream\r\nUpload-Offset: 0\r\nContent-Length: 200000\r\n\r\n"
        )
        .unwrap();
        slow.write_all(&[b'y'; 1000]).unwrap();
        slow.flush().unwrap();
        slow.set_read_timeout(Some(Duration::from_millis(50))).unwrap();
        slow
    };
    let answered = |slow: &std::net::TcpStream| {
        let mut first = [0u8; 1];
        slow.peek(&mut first).is_ok_and(|read| read > 0)
    };
    let mut slow = open_slow_patch();
    // The probe is a sliver, which stores nothing when it gets through (400) before the slow
    // PATCH holds the upload. A probe that held the upload at the moment the slow PATCH arrived
    // made that one busy instead (it has an answer): open it again. Once the slow PATCH holds
    // the upload, the probe is refused as busy.
    let deadline = std::time::Instant::now() + Duration::from_secs(20);
    loop {
        let second = server.tus_patch(&token, &path, 0, b"z");
        if second.status() == 409 {
            assert_eq!(problem(second, 409, "upload_busy")["code"], "upload_busy");
            break;
        }
        assert_eq!(second.status(), 400, "a sliver that got through is refused and stores nothing");
        assert!(std::time::Instant::now() < deadline, "the slow PATCH never held the upload");
        if answered(&slow) {
            slow = open_slow_patch();
        }
        std::thread::sleep(Duration::from_millis(50));
    }
    drop(slow);
    // Once it is gone the upload takes PATCHes again; the last may be short.
    let deadline = std::time::Instant::now() + Duration::from_secs(10);
    while server.tus_patch(&token, &path, 0, &[b'z'; 299_990]).status() != 204 {
        assert!(std::time::Instant::now() < deadline, "the upload stayed busy");
        std::thread::sleep(Duration::from_millis(50));
    }
    assert_eq!(server.tus_patch(&token, &path, 299_990, &[b'z'; 10]).status(), 204, "the last chunk may be as short as what is left");
}

#[test]
fn team_names_that_read_as_an_existing_teams_are_refused() {
    let deployment = Deployment::new(Backend::Sqlite, &[]);
    let server = deployment.serve();
    server.team("TeamA");
    for twin in ["Team\u{0410}", "Team\u{00a0}A", "teama", "Team-A"] {
        let body = problem(server.admin(server.post("/api/v1/admin/teams").json(&json!({"name": twin}))), 409, "conflict");
        assert!(body["detail"].as_str().unwrap().contains("reads as 'TeamA'"), "{twin}: {body}");
    }
    assert_eq!(server.admin(server.post("/api/v1/admin/teams").json(&json!({"name": "Team B"}))).status(), 201);
}

#[test]
fn a_posted_regeneration_config_is_bounded_in_every_size() {
    let deployment = Deployment::new(Backend::Sqlite, &[]);
    let server = deployment.serve();
    for (from, to, field) in [
        ("furniture_pool = 12", "furniture_pool = 1000000000", "prompts.furniture_pool"),
        ("furniture = 1\n", "furniture = 100000\n", "selection.furniture"),
        ("max_frames = 300", "max_frames = 1000000000", "render.max_frames"),
        ("width = ", "width = 8192\nold_width = ", "render.width"),
    ] {
        let config = super::TEST_RELEASE_CONFIG.replace("version = \"e2e-1\"", "version = \"huge-1\"").replacen(from, to, 1);
        let config = if field == "render.width" { config.replace("\nold_width = ", "\n#") } else { config };
        let body = problem(server.admin(server.post("/api/v1/admin/releases").json(&json!({"config": config}))), 422, "invalid_request");
        let detail = body["detail"].as_str().unwrap();
        assert!(detail.contains(field) && (detail.contains("at most") || detail.contains("16..=4096")), "{field}: {body}");
    }
    let jobs = server.admin(server.get("/api/v1/admin/jobs")).json::<serde_json::Value>().unwrap();
    assert_eq!(jobs["jobs"].as_array().unwrap().len(), 0, "nothing queued: {jobs}");
}
