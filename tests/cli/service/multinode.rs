//! Several nodes that share nothing but PostgreSQL and an S3-compatible bucket (moto's
//! server, through a relay the test can cut): each server and worker has a data
//! directory of its own.

use std::time::Duration;

use base64::Engine;
use serde_json::Value;
use sha2::{Digest, Sha256};

use super::object_store::{Relay, bucket, storage_env};
use super::workers::{job_of, killed_holding_the_job, signal};
use super::{Backend, Deployment, Server, baseline_dir, problem, tar_of};

fn hex(bytes: &[u8]) -> String {
    Sha256::digest(bytes).iter().map(|b| format!("{b:02x}")).collect()
}

fn deployment(relay: &Relay, extra: &[(&str, &str)]) -> Deployment {
    let storage = storage_env(relay, &bucket());
    let mut env: Vec<(&str, &str)> = storage.iter().map(|(k, v)| (k.as_str(), v.as_str())).collect();
    env.extend_from_slice(extra);
    Deployment::new(Backend::Postgres, &env)
}

/// Start a resumable upload of `size` bytes; its path.
fn create_upload(server: &Server<'_>, token: &str, size: usize) -> String {
    let response = server.post("/api/v1/uploads").bearer_auth(token).header("tus-resumable", "1.0.0").header("upload-length", size).send().unwrap();
    assert_eq!(response.status(), 201, "{}", response.text().unwrap());
    assert_eq!(response.headers()["tus-resumable"], "1.0.0");
    assert!(response.headers().contains_key("upload-expires"));
    response.headers()["location"].to_str().unwrap().to_string()
}

fn offset_at(server: &Server<'_>, token: &str, path: &str) -> u64 {
    let response = server.client.head(format!("{}{path}", server.url)).bearer_auth(token).header("tus-resumable", "1.0.0").send().unwrap();
    assert_eq!(response.status(), 200);
    response.headers()["upload-offset"].to_str().unwrap().parse().unwrap()
}

#[test]
fn two_servers_and_two_workers_share_only_postgres_and_the_bucket() {
    let relay = Relay::to_moto();
    let node_a = deployment(&relay, &[("OSMAB_WORKERS", "0"), ("OSMAB_JOB_LEASE_SECS", "2"), ("OSMAB_POLL_MS", "20")]);
    let node_b = node_a.another_node();
    let mut server_a = node_a.serve();
    let server_b = node_b.serve();
    server_a.import_test_release();
    let token = server_a.team("Team Nodes");

    // Uploaded through server A, scored by node B's worker, results read through B.
    let direct = server_a.upload(&token, &tar_of(baseline_dir("oracle").path()), "");
    assert_eq!(direct.status(), 202);
    let direct_id = direct.json::<Value>().unwrap()["id"].as_str().unwrap().to_string();
    let mut worker_b = node_b.spawn(&["worker"], "worker-b");
    assert_eq!(server_b.wait_done(&direct_id, &token)["state"], "scored");
    assert!(node_b.log("worker-b").contains("release cached from the object store"), "node B read the ground truth from the bucket");

    // A release file downloaded through B is the one A imported, byte for byte.
    let manifest: Value = server_b.get("/api/v1/releases/current/manifest.json").send().unwrap().json().unwrap();
    let archive = &manifest["archives"][0];
    let file = server_b.get(&format!("/api/v1/releases/current/files/{}", archive["path"].as_str().unwrap())).send().unwrap();
    assert_eq!(file.status(), 200);
    assert_eq!(file.headers()["etag"].to_str().unwrap(), format!("\"{}\"", archive["sha256"].as_str().unwrap()));
    let bytes = file.bytes().unwrap();
    assert_eq!(hex(&bytes), archive["sha256"].as_str().unwrap());
    let tail = server_b.get(&format!("/api/v1/releases/current/files/{}", archive["path"].as_str().unwrap())).header("range", "bytes=-100").send().unwrap();
    assert_eq!((tail.status().as_u16(), tail.bytes().unwrap().as_ref()), (206, &bytes[bytes.len() - 100..]));

    // A resumable upload begun on A, A killed -9 midway, finished and submitted through B.
    let upload = tar_of(baseline_dir("merge").path());
    let path = create_upload(&server_a, &token, upload.len());
    let half = upload.len() / 2;
    let first = server_a.tus_patch(&token, &path, 0, &upload[..half]);
    assert_eq!((first.status().as_u16(), first.headers()["upload-offset"].to_str().unwrap()), (204, half.to_string().as_str()));
    signal(&server_a.child, "KILL");
    let _ = server_a.child.wait();
    assert_eq!(offset_at(&server_b, &token, &path), half as u64, "B knows how far the upload came on A");
    let stale = server_b.tus_patch(&token, &path, 0, &upload[..half]);
    assert_eq!(problem(stale, 409, "offset_mismatch")["offset"], half);
    let mut damaged = upload[half..].to_vec();
    damaged[0] ^= 1;
    let checksum = format!("sha256 {}", base64::engine::general_purpose::STANDARD.encode(Sha256::digest(&upload[half..])));
    let corrupt = server_b
        .client
        .patch(format!("{}{path}", server_b.url))
        .bearer_auth(&token)
        .header("tus-resumable", "1.0.0")
        .header("content-type", "application/offset+octet-stream")
        .header("upload-offset", half)
        .header("upload-checksum", checksum)
        .body(damaged)
        .send()
        .unwrap();
    assert_eq!(corrupt.status().as_u16(), 460, "a chunk that does not match its checksum is refused");
    assert_eq!(offset_at(&server_b, &token, &path), half as u64, "and nothing of it is kept");
    assert_eq!(server_b.tus_patch(&token, &path, half, &upload[half..]).status(), 204);
    let upload_id = path.rsplit('/').next().unwrap();
    let submitted = server_b.post(&format!("/api/v1/submissions?upload={upload_id}")).bearer_auth(&token).send().unwrap();
    assert_eq!(submitted.status(), 202, "answered as a direct upload");
    let resumed_id = submitted.json::<Value>().unwrap()["id"].as_str().unwrap().to_string();
    let again = server_b.post(&format!("/api/v1/submissions?upload={upload_id}")).bearer_auth(&token).send().unwrap();
    assert_eq!(again.status(), 200);
    let again: Value = again.json().unwrap();
    assert_eq!((again["id"].as_str(), again["repeat"].as_bool()), (Some(resumed_id.as_str()), Some(true)), "submitting twice makes one submission");
    let done = server_b.wait_done(&resumed_id, &token);
    assert_eq!(done["state"], "scored", "{done}");
    assert_eq!(done["archive"]["sha256"].as_str().unwrap(), hex(&upload), "the parts joined into the archive sent");
    signal(&worker_b, "TERM");
    assert!(worker_b.wait().unwrap().success());

    // A worker of node C killed -9 holding a job; node D's worker finishes it, one score.
    let node_c = node_a.another_node();
    let node_d = node_a.another_node();
    let noisy = tar_of(baseline_dir("label-noise").path());
    let mut caught = None;
    for attempt in 0..5 {
        let answer = server_b.upload(&token, &noisy, "");
        let id = answer.json::<Value>().unwrap()["id"].as_str().unwrap().to_string();
        if killed_holding_the_job(&node_c, &server_b, &id, &format!("worker-c{attempt}")) {
            caught = Some(id);
            break;
        }
    }
    let id = caught.expect("worker C was killed holding a job within five tries");
    let _worker_d = node_d.spawn(&["worker"], "worker-d");
    let done = server_b.wait_done(&id, &token);
    assert_eq!(done["state"], "scored", "{done}");
    assert_eq!(done["score_history"].as_array().unwrap().len(), 1, "one score row, not two");
    assert_eq!(job_of(&server_b, &id)["state"], "succeeded");

    // A restarted server A signs receipts with the key every node publishes.
    let server_a = node_a.serve();
    let keys_a: Value = server_a.get("/api/v1/keys").send().unwrap().json().unwrap();
    let keys_b: Value = server_b.get("/api/v1/keys").send().unwrap().json().unwrap();
    assert_eq!(keys_a, keys_b, "one key set across nodes");
    let receipt: Value = server_a.get(&format!("/api/v1/submissions/{direct_id}/receipt")).bearer_auth(&token).send().unwrap().json().unwrap();
    let kid = receipt["jws"].as_str().unwrap().split('.').next().unwrap().to_string();
    let header: Value = serde_json::from_slice(&base64::engine::general_purpose::URL_SAFE_NO_PAD.decode(kid).unwrap()).unwrap();
    assert!(keys_b["keys"].as_array().unwrap().iter().any(|k| k["kid"] == header["kid"]), "B publishes the key A signed with");
    // Every server shows the new scores on its leaderboard.
    let board: Value = server_a.get("/api/v1/leaderboard").send().unwrap().json().unwrap();
    assert!(board["entries"].as_array().unwrap().len() >= 2, "{board}");
}

#[test]
fn an_unreachable_object_store_answers_503_and_loses_nothing() {
    let relay = Relay::to_moto();
    let node = deployment(&relay, &[("OSMAB_WORKERS", "1")]);
    let server = node.serve();
    server.import_test_release();
    let token = server.team("Team Outage");
    let archive = tar_of(baseline_dir("oracle").path());
    let before = server.upload(&token, &archive, "");
    assert_eq!(before.status(), 202);
    let before_id = before.json::<Value>().unwrap()["id"].as_str().unwrap().to_string();
    assert_eq!(server.wait_done(&before_id, &token)["state"], "scored");

    relay.set_up(false);
    let ready = server.get("/readyz").send().unwrap();
    assert_eq!(ready.status(), 503, "not ready while the store is away");
    let other = tar_of(baseline_dir("drop-small").path());
    let refused = server.upload(&token, &other, "");
    assert!(refused.headers().contains_key("retry-after"));
    let body = problem(refused, 503, "storage_unavailable");
    assert!(body["detail"].as_str().unwrap().contains("nothing was stored"), "{body}");
    let manifest: Value = server.get("/api/v1/releases/current/manifest.json").send().unwrap().json().unwrap();
    let file = server.get(&format!("/api/v1/releases/current/files/{}", manifest["archives"][0]["path"].as_str().unwrap())).send().unwrap();
    problem(file, 503, "storage_unavailable");
    let me: Value = server.get("/api/v1/me").bearer_auth(&token).send().unwrap().json().unwrap();
    assert_eq!(me["quota"]["used"], 1, "the refused upload used no quota");

    // The client retries through the outage and lands the submission when the store returns.
    let config = tempfile::tempdir().unwrap();
    let client_env = [("OSMAB_CLIENT_CONFIG", config.path().join("client.toml")), ("OSMAB_UPLOAD_CHUNK_BYTES", "65536".into())];
    let login = std::process::Command::new(env!("CARGO_BIN_EXE_osmab"))
        .args(["client", "login", "--url", &server.url, "--token", &token])
        .envs(client_env.iter().map(|(k, v)| (k, v)))
        .output()
        .unwrap();
    assert!(login.status.success(), "{}", String::from_utf8_lossy(&login.stderr));
    let folder = baseline_dir("drop-small");
    let submit = std::process::Command::new(env!("CARGO_BIN_EXE_osmab"))
        .args(["client", "submit", folder.path().to_str().unwrap()])
        .envs(client_env.iter().map(|(k, v)| (k, v)))
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    std::thread::sleep(Duration::from_secs(3));
    relay.set_up(true);
    let out = submit.wait_with_output().unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{stderr}");
    assert!(stderr.contains("retrying"), "the client met the outage and retried: {stderr}");
    let id = String::from_utf8_lossy(&out.stdout).trim().to_string();
    assert_eq!(server.wait_done(&id, &token)["state"], "scored");
    assert_eq!(server.wait_done(&before_id, &token)["state"], "scored", "what was stored before the outage is intact");
    assert_eq!(server.get("/readyz").send().unwrap().status(), 200);
}
