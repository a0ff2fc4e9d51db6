//! `osmab client` against a real `osmab serve` on a real socket: login, an interrupted
//! download resumed and verified, a corrupted file fetched again, offline validation,
//! submit and watch to `scored`, results, the leaderboard, and a revoked token explained.

use std::path::Path;
use std::process::{Command, Output};

use serde_json::Value;

use super::{Backend, Deployment, baseline_dir};

/// Run `osmab client …` with its own configuration file.
pub fn client(config: &Path, args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_osmab"))
        .arg("client")
        .args(args)
        .env_clear()
        .env("PATH", std::env::var("PATH").unwrap_or_default())
        .env("OSMAB_CLIENT_CONFIG", config)
        .output()
        .expect("osmab runs")
}

fn ok(out: &Output) -> String {
    assert!(out.status.success(), "osmab client failed:\n{}\n{}", String::from_utf8_lossy(&out.stdout), String::from_utf8_lossy(&out.stderr));
    String::from_utf8_lossy(&out.stdout).into_owned()
}

fn sha256(path: &Path) -> String {
    use sha2::Digest;
    sha2::Sha256::digest(std::fs::read(path).unwrap()).iter().map(|b| format!("{b:02x}")).collect()
}

#[test]
fn a_team_downloads_validates_submits_and_follows_with_the_client() {
    let deployment = Deployment::new(Backend::Sqlite, &[]);
    let server = deployment.serve();
    let version = server.import_test_release();
    let token = server.team("Team Client");
    let home = tempfile::tempdir().unwrap();
    let config = home.path().join("osmab/client.toml");

    // Login stores the server and token owner-only.
    let said = ok(&client(&config, &["login", "--url", &server.url, "--token", &token]));
    assert!(said.contains("as team Team Client") && !said.contains(&token), "{said}");
    #[cfg(unix)]
    {
        use std::os::unix::fs::PermissionsExt;
        assert_eq!(std::fs::metadata(&config).unwrap().permissions().mode() & 0o777, 0o600);
    }
    let bad = client(&config, &["login", "--token", "not-a-token"]);
    assert!(!bad.status.success() && String::from_utf8_lossy(&bad.stderr).contains("start with 'osmab_'"));

    // A download interrupted halfway (a .part file with the first half) resumes with Range.
    let out = tempfile::tempdir().unwrap();
    let manifest: Value = server.get(&format!("/api/v1/releases/{version}/manifest.json")).send().unwrap().json().unwrap();
    let classes = manifest["files"].as_array().unwrap().iter().find(|f| f["path"] == "classes.json").unwrap().clone();
    let full = server.get(&format!("/api/v1/releases/{version}/files/classes.json")).send().unwrap().bytes().unwrap();
    std::fs::write(out.path().join("classes.json.part"), &full[..full.len() / 2]).unwrap();
    let dl = client(&config, &["download", "--out", out.path().to_str().unwrap(), "--scene", "scene_000", "--lighting", "camera"]);
    ok(&dl);
    assert!(
        String::from_utf8_lossy(&dl.stderr).contains(&format!("classes.json: resuming at byte {}", full.len() / 2)),
        "{}",
        String::from_utf8_lossy(&dl.stderr)
    );
    assert_eq!(sha256(&out.path().join("classes.json")), classes["sha256"].as_str().unwrap());
    assert!(!out.path().join("classes.json.part").exists());
    let metrics = server.admin(server.get("/metrics")).text().unwrap();
    assert!(metrics.contains("status=\"206\""), "the resumed request was a range request");
    // Only the chosen sequence, every file verified against the manifest.
    let sequence_files: Vec<&Value> =
        manifest["files"].as_array().unwrap().iter().filter(|f| f["path"].as_str().unwrap().starts_with("sequences/camera/scene_000/")).collect();
    assert!(!sequence_files.is_empty());
    for f in &sequence_files {
        assert_eq!(sha256(&out.path().join(f["path"].as_str().unwrap())), f["sha256"].as_str().unwrap());
    }
    assert!(!out.path().join("sequences/baseline").exists() && !out.path().join("sequences/camera/scene_001").exists());
    assert!(!out.path().join(".osmab-downloads").exists(), "archives are removed once unpacked");

    // A corrupted file is noticed and fetched again; correct files are skipped.
    let victim = out.path().join(sequence_files[0]["path"].as_str().unwrap());
    std::fs::write(&victim, b"corrupted").unwrap();
    let again = client(&config, &["download", "--out", out.path().to_str().unwrap(), "--scene", "scene_000", "--lighting", "camera"]);
    let said = ok(&again);
    assert_eq!(sha256(&victim), sequence_files[0]["sha256"].as_str().unwrap());
    assert!(said.contains("1 downloads done"), "only the damaged sequence is fetched again: {said}");
    let third = ok(&client(&config, &["download", "--out", out.path().to_str().unwrap(), "--scene", "scene_000", "--lighting", "camera"]));
    assert!(third.starts_with("0 downloads done"), "{third}");

    // Offline validation with the downloaded release; a broken submission is explained.
    let submission = baseline_dir("label-noise");
    let valid = ok(&client(&config, &["validate", submission.path().to_str().unwrap(), "--release-dir", out.path().to_str().unwrap()]));
    assert!(valid.contains("Valid for the val split of release"), "{valid}");
    let broken = baseline_dir("label-noise");
    std::fs::write(broken.path().join("maps/baseline/scene_000.npz"), b"not an npz").unwrap();
    let refused = client(&config, &["validate", broken.path().to_str().unwrap()]);
    assert_eq!(refused.status.code(), Some(1));
    assert!(String::from_utf8_lossy(&refused.stdout).contains("maps/baseline/scene_000.npz"), "{}", String::from_utf8_lossy(&refused.stdout));

    // Submit, follow to scored, read the results and the leaderboard.
    let submitted = client(&config, &["submit", submission.path().to_str().unwrap(), "--watch"]);
    let said = ok(&submitted);
    let id = said.lines().next().unwrap().trim().to_string();
    assert!(id.starts_with("sub_"), "{said}");
    assert!(said.contains("scored"), "{said}");
    let view: Value = server.get(&format!("/api/v1/submissions/{id}")).bearer_auth(&token).send().unwrap().json().unwrap();
    assert_eq!(view["state"], "scored");
    let results = ok(&client(&config, &["results", &id]));
    let pooled = view["scores"]["semseg"]["baseline"]["overall"]["miou"].as_f64().unwrap();
    assert!(results.contains(&format!("{:.1}", pooled * 100.0)) && results.contains("Question answering"), "{results}");
    // Every VQA category is listed with its count, and the counts add up to "all".
    let by_category = results.split("Question answering by category").nth(1).unwrap_or_else(|| panic!("{results}"));
    let all = &view["scores"]["vqa"]["all_lightings"];
    let mut listed = 0;
    for set in ["prompt_grounded", "standard"] {
        for (category, accuracy) in all[set]["categories"].as_object().unwrap() {
            let total = accuracy["total"].as_u64().unwrap();
            assert!(by_category.lines().any(|l| l.contains(category.as_str()) && l.trim_end().ends_with(&format!(" {total}"))), "{category}: {by_category}");
            listed += total;
        }
    }
    assert_eq!(listed, all["overall"]["total"].as_u64().unwrap(), "{by_category}");
    let board = ok(&client(&config, &["leaderboard"]));
    assert!(board.contains("team-label-noise") && board.contains("Team Client"), "{board}");
    // One rule for the client, the API and the pages: this board pools too few scenes for
    // intervals and groups, and none of them shows any.
    let json: Value = server.get("/api/v1/leaderboard").send().unwrap().json().unwrap();
    assert_eq!(json["significance"], false, "{json}");
    let entries = json["entries"].to_string();
    assert!(!entries.contains("\"ci95\":[") && !entries.contains("\"ci95\":{"), "the JSON carries no interval: {json}");
    let page = server.get("/").send().unwrap().text().unwrap();
    assert!(board.contains("too few for intervals and significance groups") && page.contains("too few for intervals and significance"), "{board}");
    let ranks: Vec<&str> = board.lines().filter(|l| l.contains("team-") || l.contains("baseline-")).map(|l| l.split_whitespace().nth(1).unwrap()).collect();
    assert!(!ranks.is_empty() && ranks.iter().all(|g| *g == "–"), "no group in the client's table, as on the page: {board}");
    let quota = ok(&client(&config, &["quota"]));
    let header = quota.lines().find(|l| l.contains("split") && l.contains("remaining")).unwrap_or_else(|| panic!("{quota}"));
    assert!(header.trim_end().ends_with("default split"), "every column is labelled: {quota}");

    // A revoked token is explained with what to do, not shown as a raw body.
    let tokens: Value = server.admin(server.get("/api/v1/admin/teams")).json().unwrap();
    let team_id = tokens["teams"].as_array().unwrap().iter().find(|t| t["name"] == "Team Client").unwrap()["id"].as_str().unwrap().to_string();
    let listed: Value = server.admin(server.get(&format!("/api/v1/admin/teams/{team_id}/tokens"))).json().unwrap();
    for t in listed["tokens"].as_array().unwrap() {
        let response = server.admin(server.client.delete(format!("{}/api/v1/admin/tokens/{}", server.url, t["id"].as_str().unwrap())));
        assert!(response.status().is_success(), "{}", response.text().unwrap());
    }
    let denied = client(&config, &["status", &id]);
    assert!(!denied.status.success());
    let said = String::from_utf8_lossy(&denied.stderr);
    assert!(
        said.contains("This token was revoked at")
            && said.contains("What to do: ask the organisers for a new team token")
            && said.contains("[token_revoked, HTTP 401]"),
        "{said}"
    );
    assert!(!said.contains("{\""), "no raw JSON: {said}");
}

/// A server on a loopback port that answers every request 200 with an empty listing and
/// keeps what it was sent (request line and headers), to see which token reaches another
/// origin.
fn recording_server() -> (String, std::sync::Arc<std::sync::Mutex<Vec<String>>>) {
    let (url, seen) =
        scripted_server(|_, _| (200, vec![("Content-Type", "application/json".into())], br#"{"rows": [], "entries": [], "releases": []}"#.to_vec()));
    // `localhost` rather than 127.0.0.1: another spelling of a loopback origin.
    (url.replace("127.0.0.1", "localhost"), seen)
}

#[test]
fn a_token_goes_only_to_the_server_it_was_issued_for() {
    let deployment = Deployment::new(Backend::Sqlite, &[]);
    let server = deployment.serve();
    server.import_test_release();
    let token = server.team("Team Origins");
    let home = tempfile::tempdir().unwrap();
    let config = home.path().join("osmab/client.toml");
    ok(&client(&config, &["login", "--url", &server.url, "--token", &token]));

    // Another server, by flag or by OSMAB_URL: public calls carry no token, team calls
    // have none to send.
    let (other, seen) = recording_server();
    let _ = client(&config, &["leaderboard", "--url", &other]);
    let status = client(&config, &["status", "sub_x", "--url", &other]);
    assert!(!status.status.success() && String::from_utf8_lossy(&status.stderr).contains("no token"), "{}", String::from_utf8_lossy(&status.stderr));
    Command::new(env!("CARGO_BIN_EXE_osmab"))
        .args(["client", "leaderboard"])
        .env_clear()
        .env("PATH", std::env::var("PATH").unwrap_or_default())
        .env("OSMAB_CLIENT_CONFIG", &config)
        .env("OSMAB_URL", &other)
        .output()
        .unwrap();
    let requests = seen.lock().unwrap().clone();
    assert!(requests.len() >= 2, "{requests:?}");
    assert!(requests.iter().all(|r| !r.to_ascii_lowercase().contains("authorization") && !r.contains(&token)), "{requests:?}");

    // Logging in to the other server without a token keeps the first one's and changes nothing.
    let before = std::fs::read_to_string(&config).unwrap();
    let login = client(&config, &["login", "--url", &other]);
    assert!(!login.status.success() && String::from_utf8_lossy(&login.stderr).contains("--token"), "{}", String::from_utf8_lossy(&login.stderr));
    assert_eq!(std::fs::read_to_string(&config).unwrap(), before);
    // The home server still has its token: logging in again needs none.
    let again = ok(&client(&config, &["login", "--url", &server.url]));
    assert!(again.contains("as team Team Origins"), "{again}");
}

#[test]
fn plain_http_to_another_machine_needs_an_explicit_flag() {
    let home = tempfile::tempdir().unwrap();
    let config = home.path().join("osmab/client.toml");
    let refused = client(&config, &["leaderboard", "--url", "http://192.0.2.1:8080"]);
    let said = String::from_utf8_lossy(&refused.stderr);
    assert!(!refused.status.success() && said.contains("--allow-http") && said.contains("unencrypted"), "{said}");
}

/// A server on a loopback port whose answers `script` decides from the request line and
/// the number of requests for that path so far; it keeps every request line it was sent.
fn scripted_server(
    script: impl Fn(&str, usize) -> (u16, Vec<(&'static str, String)>, Vec<u8>) + Send + 'static,
) -> (String, std::sync::Arc<std::sync::Mutex<Vec<String>>>) {
    use std::io::{BufRead, BufReader, Write};
    let listener = std::net::TcpListener::bind("127.0.0.1:0").unwrap();
    let url = format!("http://127.0.0.1:{}", listener.local_addr().unwrap().port());
    let seen = std::sync::Arc::new(std::sync::Mutex::new(Vec::new()));
    let kept = seen.clone();
    std::thread::spawn(move || {
        for stream in listener.incoming().flatten() {
            let mut reader = BufReader::new(stream.try_clone().unwrap());
            let mut head = String::new();
            loop {
                let mut line = String::new();
                if reader.read_line(&mut line).unwrap_or(0) == 0 || line == "\r\n" {
                    break;
                }
                head.push_str(&line);
            }
            let request_line = head.lines().next().unwrap_or_default().to_string();
            let path = request_line.split(' ').nth(1).unwrap_or_default().to_string();
            let count = kept.lock().unwrap().iter().filter(|h: &&String| h.lines().next().and_then(|l| l.split(' ').nth(1)) == Some(path.as_str())).count();
            kept.lock().unwrap().push(head.clone());
            let (status, headers, body) = script(&head, count);
            let mut answer = format!("HTTP/1.1 {status} X\r\nContent-Length: {}\r\nConnection: close\r\n", body.len());
            for (k, v) in headers {
                answer.push_str(&format!("{k}: {v}\r\n"));
            }
            answer.push_str("\r\n");
            let mut stream = stream;
            let _ = stream.write_all(answer.as_bytes());
            let _ = stream.write_all(&body);
        }
    });
    (url, seen)
}

#[test]
fn downloads_retry_passing_errors_restart_unusable_parts_and_refuse_a_doubled_manifest() {
    use sha2::Digest;
    let hex = |b: &[u8]| sha2::Sha256::digest(b).iter().map(|x| format!("{x:02x}")).collect::<String>();
    let files: [(&str, &[u8]); 3] = [("flaky.txt", b"served after a 503"), ("complete.txt", b"already all here"), ("stale.txt", b"the new content")];
    // The release digest: the SHA-256 of the sorted "path size sha256" lines.
    let mut lines: Vec<String> = files.iter().map(|(p, b)| format!("{p} {} {}\n", b.len(), hex(b))).collect();
    lines.sort();
    let manifest = serde_json::json!({
        "version": "v1",
        "digest": hex(lines.concat().as_bytes()),
        "files": files.iter().map(|(p, b)| serde_json::json!({"path": p, "size": b.len(), "sha256": hex(b)})).collect::<Vec<_>>(),
    })
    .to_string();
    let served = files.iter().map(|(p, b)| (format!("/api/v1/releases/v1/files/{p}"), b.to_vec())).collect::<Vec<_>>();
    let (url, seen) = scripted_server(move |head, count| {
        let path = head.lines().next().unwrap_or_default().split(' ').nth(1).unwrap_or_default().to_string();
        if path == "/api/v1/releases/v1/manifest.json" {
            return (200, vec![("Content-Type", "application/json".into())], manifest.clone().into_bytes());
        }
        let Some((_, body)) = served.iter().find(|(p, _)| *p == path) else { return (404, vec![], b"{}".to_vec()) };
        if path.ends_with("flaky.txt") && count == 0 {
            return (503, vec![("Retry-After", "1".into())], b"{}".to_vec());
        }
        if head.to_ascii_lowercase().contains("range: bytes=") {
            return (416, vec![], Vec::new()); // this server cannot resume
        }
        (200, vec![], body.clone())
    });
    let home = tempfile::tempdir().unwrap();
    let config = home.path().join("osmab/client.toml");
    let out = tempfile::tempdir().unwrap();
    std::fs::write(out.path().join("complete.txt.part"), b"already all here").unwrap();
    std::fs::write(out.path().join("stale.txt.part"), b"the old").unwrap();
    ok(&client(&config, &["download", "--release", "v1", "--out", out.path().to_str().unwrap(), "--url", &url, "--jobs", "1"]));
    for (path, body) in files {
        assert_eq!(std::fs::read(out.path().join(path)).unwrap(), body, "{path}");
    }
    let requests = seen.lock().unwrap().clone();
    assert!(!requests.iter().any(|r| r.contains("complete.txt")), "a complete .part is not fetched again: {requests:?}");
    assert_eq!(requests.iter().filter(|r| r.contains("flaky.txt")).count(), 2, "the 503 is retried once");

    // A manifest that lists one path twice is refused before anything is fetched.
    let doubled = serde_json::json!({"version": "v2", "files": [
        {"path": "a.txt", "size": 1, "sha256": hex(b"a")}, {"path": "a.txt", "size": 1, "sha256": hex(b"b")}
    ]})
    .to_string();
    let (url, _) = scripted_server(move |_, _| (200, vec![("Content-Type", "application/json".into())], doubled.clone().into_bytes()));
    let refused = client(&config, &["download", "--release", "v2", "--out", out.path().to_str().unwrap(), "--url", &url]);
    let said = String::from_utf8_lossy(&refused.stderr);
    assert!(!refused.status.success() && said.contains("lists 'a.txt' twice"), "{said}");
}
