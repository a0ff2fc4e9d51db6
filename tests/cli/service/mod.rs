//! End-to-end tests of the service: the real `osmab serve` binary on a real socket, over
//! SQLite and over PostgreSQL (a fresh database per server; the tests fail, they do not
//! skip, when PostgreSQL is unreachable — `.ci/run` starts it).

mod access;
mod admin_cli;
mod backup;
mod cards;
mod client;
mod console;
mod earlier_releases;
mod hardening;
mod headers;
mod hostile;
mod journey;
mod multinode;
mod object_store;
mod receipts;
mod reference_mapper;
mod regeneration;
mod schema;
mod splits;
mod take_part;
mod workers;

use std::io::{BufRead, BufReader};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::sync::OnceLock;
use std::time::{Duration, Instant};

use reqwest::blocking::{Client, RequestBuilder, Response};
use serde_json::{Value, json};

/// The admin token every test server is configured with.
pub const ADMIN: &str = "osmab_e2eadmintoken0000000000000000";

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Backend {
    Sqlite,
    Postgres,
}

/// Run a test body once per backend, as two tests.
macro_rules! on_both_backends {
    ($name:ident, $body:path) => {
        mod $name {
            #[test]
            fn sqlite() {
                $body(super::Backend::Sqlite)
            }
            #[test]
            fn postgres() {
                $body(super::Backend::Postgres)
            }
        }
    };
}
pub(crate) use on_both_backends;

#[path = "../../support/postgres.rs"]
mod test_database;
use test_database::{PgDatabase, rand_suffix};

fn block_on<F: std::future::Future>(f: F) -> F::Output {
    tokio::runtime::Builder::new_current_thread().enable_all().build().unwrap().block_on(f)
}

/// What every server of a test shares: its data directory and database.
pub struct Deployment {
    pub data: tempfile::TempDir,
    _pg: Option<PgDatabase>,
    pub env: Vec<(String, String)>,
}

impl Deployment {
    pub fn new(backend: Backend, env: &[(&str, &str)]) -> Self {
        let data = tempfile::tempdir().unwrap();
        let (database_url, pg) = match backend {
            Backend::Sqlite => (format!("sqlite://{}", data.path().join("osmab.db").display()), None),
            Backend::Postgres => {
                let db = PgDatabase::create();
                (db.url.clone(), Some(db))
            }
        };
        let mut all: Vec<(String, String)> = [
            ("OSMAB_DATA_DIR", data.path().to_str().unwrap()),
            ("DATABASE_URL", database_url.as_str()),
            ("OSMAB_ADMIN_TOKEN", ADMIN),
            ("OSMAB_DEMO", "false"),
            ("OSMAB_POLL_MS", "50"),
            ("OSMAB_RATE_LIMIT", "0"),
            ("OSMAB_BIND", "127.0.0.1:0"),
            ("OSMAB_SHUTDOWN_GRACE_SECS", "5"),
            ("RUST_LOG", "info"),
        ]
        .iter()
        .map(|(k, v)| (k.to_string(), v.to_string()))
        .collect();
        for (k, v) in env {
            all.retain(|(key, _)| key != k);
            all.push((k.to_string(), v.to_string()));
        }
        Self { data, _pg: pg, env: all }
    }

    /// Another node of this deployment: the same database and settings (and so the same
    /// object store, when `env` names one) with a data directory of its own.
    pub fn another_node(&self) -> Self {
        let data = tempfile::tempdir().unwrap();
        let mut env = self.env.clone();
        env.retain(|(k, _)| k != "OSMAB_DATA_DIR");
        env.push(("OSMAB_DATA_DIR".into(), data.path().to_str().unwrap().into()));
        Self { data, _pg: None, env }
    }

    /// Start `osmab <args>` with this deployment's environment; its log goes to `name.log`.
    /// The process is killed when the handle is dropped (a failing test leaves none behind).
    pub fn spawn(&self, args: &[&str], name: &str) -> Process {
        let log = std::fs::File::create(self.data.path().join(format!("{name}.log"))).unwrap();
        let child = Command::new(env!("CARGO_BIN_EXE_osmab"))
            .args(args)
            .env_clear()
            .env("PATH", std::env::var("PATH").unwrap_or_default())
            .envs(self.env.iter().map(|(k, v)| (k.as_str(), v.as_str())))
            .stdout(Stdio::piped())
            .stderr(Stdio::from(log))
            .spawn()
            .expect("osmab starts");
        Process(child)
    }

    /// Run `osmab <args>` to its end with this deployment's environment.
    pub fn run(&self, args: &[&str]) -> std::process::Output {
        Command::new(env!("CARGO_BIN_EXE_osmab"))
            .args(args)
            .env_clear()
            .env("PATH", std::env::var("PATH").unwrap_or_default())
            .envs(self.env.iter().map(|(k, v)| (k.as_str(), v.as_str())))
            .output()
            .expect("osmab runs")
    }

    pub fn log(&self, name: &str) -> String {
        std::fs::read_to_string(self.data.path().join(format!("{name}.log"))).unwrap_or_default()
    }

    /// Start `osmab serve` and wait until it listens.
    pub fn serve(&self) -> Server<'_> {
        let mut child = self.spawn(&["serve"], "serve");
        let mut line = String::new();
        BufReader::new(child.stdout.take().unwrap()).read_line(&mut line).unwrap();
        let url = line.trim().strip_prefix("osmab listening on ").unwrap_or_else(|| panic!("serve did not start: {}", self.log("serve"))).to_string();
        Server { child, url, deployment: self, client: Client::builder().timeout(Duration::from_secs(60)).build().unwrap() }
    }
}

/// A started `osmab` process, killed when dropped.
pub struct Process(pub Child);

impl std::ops::Deref for Process {
    type Target = Child;
    fn deref(&self) -> &Child {
        &self.0
    }
}

impl std::ops::DerefMut for Process {
    fn deref_mut(&mut self) -> &mut Child {
        &mut self.0
    }
}

impl Drop for Process {
    fn drop(&mut self) {
        let _ = self.0.kill();
        let _ = self.0.wait();
    }
}

/// A running `osmab serve`.
pub struct Server<'a> {
    pub child: Process,
    pub url: String,
    pub deployment: &'a Deployment,
    pub client: Client,
}

impl Server<'_> {
    pub fn get(&self, path: &str) -> RequestBuilder {
        self.client.get(format!("{}{path}", self.url))
    }

    pub fn post(&self, path: &str) -> RequestBuilder {
        self.client.post(format!("{}{path}", self.url))
    }

    pub fn admin(&self, request: RequestBuilder) -> Response {
        request.bearer_auth(ADMIN).send().unwrap()
    }

    /// Import and publish the shared test release.
    pub fn import_test_release(&self) -> String {
        // Into an object store the release's ~5,000 files take a while (moto: ~110 PUTs a second).
        let request = self.post("/api/v1/admin/releases/import").timeout(Duration::from_secs(600));
        let response = self.admin(request.json(&json!({"path": test_release(), "publish": true})));
        assert_eq!(response.status(), 201, "{}", response.text().unwrap());
        response.json::<Value>().unwrap()["version"].as_str().unwrap().to_string()
    }

    /// Create a team; returns its token.
    pub fn team(&self, name: &str) -> String {
        let response = self.admin(self.post("/api/v1/admin/teams").json(&json!({"name": name})));
        assert_eq!(response.status(), 201);
        response.json::<Value>().unwrap()["token"].as_str().unwrap().to_string()
    }

    /// Upload `archive` with `token`, declaring its SHA-256.
    pub fn upload(&self, token: &str, archive: &[u8], query: &str) -> Response {
        self.post(&format!("/api/v1/submissions{query}"))
            .bearer_auth(token)
            .header("content-type", "application/x-tar")
            .header("content-digest", content_digest(archive))
            .body(archive.to_vec())
            .send()
            .unwrap()
    }

    /// Poll a submission until it is scored or failed.
    /// Append `bytes` at `offset` to the resumable upload at `path` (tus PATCH, with its
    /// SHA-256 in `Upload-Checksum`).
    pub fn tus_patch(&self, token: &str, path: &str, offset: usize, bytes: &[u8]) -> Response {
        use base64::Engine;
        use sha2::Digest;
        let checksum = format!("sha256 {}", base64::engine::general_purpose::STANDARD.encode(sha2::Sha256::digest(bytes)));
        self.client
            .patch(format!("{}{path}", self.url))
            .bearer_auth(token)
            .header("tus-resumable", "1.0.0")
            .header("content-type", "application/offset+octet-stream")
            .header("upload-offset", offset)
            .header("upload-checksum", checksum)
            .body(bytes.to_vec())
            .send()
            .unwrap()
    }

    pub fn wait_done(&self, id: &str, token: &str) -> Value {
        let started = Instant::now();
        loop {
            let body: Value = self.get(&format!("/api/v1/submissions/{id}")).bearer_auth(token).send().unwrap().json().unwrap();
            if ["scored", "failed", "cancelled"].contains(&body["state"].as_str().unwrap_or("")) {
                return body;
            }
            assert!(started.elapsed() < Duration::from_secs(120), "submission {id} stuck: {body}\n{}", self.deployment.log("serve"));
            std::thread::sleep(Duration::from_millis(100));
        }
    }
}

/// `sha-256=:BASE64:` of `bytes` (RFC 9530).
pub fn content_digest(bytes: &[u8]) -> String {
    use base64::Engine;
    use sha2::Digest;
    format!("sha-256=:{}:", base64::engine::general_purpose::STANDARD.encode(sha2::Sha256::digest(bytes)))
}

/// The small release of the service tests (two scenes, four lightings at 160×90), also the
/// browser check's build (`tests/fixtures/release-small.toml`, one file for both).
pub const TEST_RELEASE_CONFIG: &str = include_str!("../../fixtures/release-small.toml");

/// A small release (two scenes, four lightings) built once per test run; builds resume,
/// so later runs reuse it.
pub fn test_release() -> &'static Path {
    static RELEASE: OnceLock<PathBuf> = OnceLock::new();
    RELEASE.get_or_init(|| {
        let root = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("e2e-release");
        std::fs::create_dir_all(&root).unwrap();
        let config = root.join("config.toml");
        std::fs::write(&config, TEST_RELEASE_CONFIG).unwrap();
        let out = root.join("release");
        let status = Command::new(env!("CARGO_BIN_EXE_osmab"))
            .args(["release", "build", "--config", config.to_str().unwrap(), "--out", out.to_str().unwrap()])
            .stdout(Stdio::null())
            .status()
            .unwrap();
        assert!(status.success(), "the test release builds");
        out
    })
}

/// The baseline `name` of the test release as a submission folder.
pub fn baseline_dir(name: &str) -> tempfile::TempDir {
    baseline_dir_of(test_release(), name)
}

/// The baseline `name` of the release built in `release` as a team's submission folder: its
/// method is called `team-{name}` (names starting with "baseline" are the service's own).
pub fn baseline_dir_of(release: &Path, name: &str) -> tempfile::TempDir {
    let dir = tempfile::tempdir().unwrap();
    let out = Command::new(env!("CARGO_BIN_EXE_osmab"))
        .args(["baseline", name, "--release", release.to_str().unwrap(), "--out", dir.path().to_str().unwrap()])
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let card = dir.path().join("submission.json");
    let text = std::fs::read_to_string(&card).unwrap();
    let renamed = text.replace(&format!("\"baseline-{name}\""), &format!("\"team-{name}\""));
    assert_ne!(text, renamed, "the baseline's method name is in its card");
    std::fs::write(&card, renamed).unwrap();
    dir
}

/// A tar of the files under `dir` (as `osmab client submit` will pack it).
pub fn tar_of(dir: &Path) -> Vec<u8> {
    let out = tempfile::NamedTempFile::new().unwrap();
    osmab_evaluator::submission::pack_directory(dir, out.path()).unwrap();
    std::fs::read(out.path()).unwrap()
}

/// Assert `response` is problem+json with `status` and `code`; returns the body.
pub fn problem(response: Response, status: u16, code: &str) -> Value {
    assert_eq!(response.status().as_u16(), status, "expected {status} {code}");
    assert_eq!(response.headers()["content-type"], "application/problem+json");
    let body: Value = response.json().unwrap();
    assert_eq!(body["code"], code, "{body}");
    assert_eq!(body["status"], status);
    assert!(body["detail"].as_str().is_some_and(|d| !d.is_empty()) && body["title"].is_string() && body["type"].is_string(), "{body}");
    body
}

/// The SHA-256 of `bytes`, in lowercase hex (as manifests list it).
pub fn sha256_hex(bytes: &[u8]) -> String {
    use sha2::Digest;
    sha2::Sha256::digest(bytes).iter().map(|b| format!("{b:02x}")).collect()
}
