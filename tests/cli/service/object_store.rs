//! A real S3-compatible server for the multi-node tests: moto's server mode, installed
//! from PyPI by `.ci/run` into `target/pyenv` (or named by `OSMAB_TEST_MOTO_SERVER`),
//! started once per test run and stopped when the test process ends. Nodes reach it
//! through a [`Relay`], a TCP forwarder the test can cut to make the store unreachable
//! (moto keeps its objects in memory, so the server itself must live on).

use std::io::{Read, Write};
use std::net::{Shutdown, TcpListener, TcpStream};
use std::path::PathBuf;
use std::process::{Child, Command, Stdio};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex, OnceLock};
use std::time::{Duration, Instant};

/// The moto server of this test run.
pub struct Moto {
    pub port: u16,
    _child: Mutex<Child>,
}

fn moto_binary() -> PathBuf {
    if let Some(path) = std::env::var_os("OSMAB_TEST_MOTO_SERVER") {
        return PathBuf::from(path);
    }
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../target/pyenv/bin/moto_server")
}

/// Install moto's server from PyPI into `target/pyenv` (what `.ci/run` does first), so
/// the README's test command works on a fresh machine with PostgreSQL and PyPI.
fn install_moto(binary: &std::path::Path) {
    let venv = binary.parent().and_then(|bin| bin.parent()).expect("target/pyenv/bin/moto_server").to_path_buf();
    let python = venv.join("bin/python");
    if !python.is_file() {
        let made = Command::new("python3").args(["-m", "venv"]).arg(&venv).status();
        assert!(made.is_ok_and(|s| s.success()), "python3 -m venv {} failed (Debian: apt-get install python3-venv)", venv.display());
    }
    let installed = Command::new(&python).args(["-m", "pip", "install", "-q", "moto[server]"]).status();
    assert!(installed.is_ok_and(|s| s.success()), "pip could not install moto[server] into {}", venv.display());
}

/// Start moto once; every test makes its own bucket in it.
pub fn moto() -> &'static Moto {
    static MOTO: OnceLock<Moto> = OnceLock::new();
    MOTO.get_or_init(|| {
        let binary = moto_binary();
        if !binary.is_file() && std::env::var_os("OSMAB_TEST_MOTO_SERVER").is_none() {
            install_moto(&binary);
        }
        assert!(binary.is_file(), "{} is missing: the multi-node tests need moto's S3 server (pip install 'moto[server]')", binary.display());
        let port = TcpListener::bind("127.0.0.1:0").unwrap().local_addr().unwrap().port();
        // The shell stops moto when this process ends (its stdin closes), however it ends.
        let script = format!("'{}' -H 127.0.0.1 -p {port} >/dev/null 2>&1 & pid=$!; read _; kill $pid", binary.display());
        let child = Command::new("sh").args(["-c", &script]).stdin(Stdio::piped()).stdout(Stdio::null()).spawn().expect("sh starts moto");
        let started = Instant::now();
        while TcpStream::connect(("127.0.0.1", port)).is_err() {
            assert!(started.elapsed() < Duration::from_secs(30), "moto did not listen on port {port} within 30 s");
            std::thread::sleep(Duration::from_millis(100));
        }
        Moto { port, _child: Mutex::new(child) }
    })
}

/// A new empty bucket.
pub fn bucket() -> String {
    let name = format!("osmab-e2e-{}", super::rand_suffix());
    let response = reqwest::blocking::Client::new().put(format!("http://127.0.0.1:{}/{name}", moto().port)).send().unwrap();
    assert!(response.status().is_success(), "moto made no bucket: {}", response.status());
    name
}

/// A TCP forwarder to moto that can be cut (new connections refused at once, open ones
/// closed) and restored.
pub struct Relay {
    pub port: u16,
    up: Arc<AtomicBool>,
}

fn pump(mut from: TcpStream, mut to: TcpStream, up: Arc<AtomicBool>) {
    from.set_read_timeout(Some(Duration::from_millis(50))).unwrap();
    let mut buffer = [0u8; 64 * 1024];
    loop {
        if !up.load(Ordering::SeqCst) {
            break;
        }
        match from.read(&mut buffer) {
            Ok(0) => break,
            Ok(n) => {
                if to.write_all(&buffer[..n]).is_err() {
                    break;
                }
            }
            Err(e) if matches!(e.kind(), std::io::ErrorKind::WouldBlock | std::io::ErrorKind::TimedOut) => {}
            Err(_) => break,
        }
    }
    let _ = from.shutdown(Shutdown::Both);
    let _ = to.shutdown(Shutdown::Both);
}

impl Relay {
    pub fn to_moto() -> Self {
        let target = moto().port;
        let listener = TcpListener::bind("127.0.0.1:0").unwrap();
        let port = listener.local_addr().unwrap().port();
        let up = Arc::new(AtomicBool::new(true));
        let flag = up.clone();
        std::thread::spawn(move || {
            for client in listener.incoming().flatten() {
                if !flag.load(Ordering::SeqCst) {
                    let _ = client.shutdown(Shutdown::Both);
                    continue;
                }
                let Ok(upstream) = TcpStream::connect(("127.0.0.1", target)) else { continue };
                let (client_read, upstream_read) = (client.try_clone().unwrap(), upstream.try_clone().unwrap());
                let (up_a, up_b) = (flag.clone(), flag.clone());
                std::thread::spawn(move || pump(client_read, upstream, up_a));
                std::thread::spawn(move || pump(upstream_read, client, up_b));
            }
        });
        Self { port, up }
    }

    /// Cut (`false`) or restore (`true`) the way to the store.
    pub fn set_up(&self, up: bool) {
        self.up.store(up, Ordering::SeqCst);
    }
}

/// The settings that put a node's blobs in `bucket` through `relay`.
pub fn storage_env(relay: &Relay, bucket: &str) -> Vec<(String, String)> {
    [
        ("OSMAB_STORAGE_URL", format!("s3://{bucket}/osmab")),
        ("AWS_ENDPOINT_URL", format!("http://127.0.0.1:{}", relay.port)),
        ("AWS_ACCESS_KEY_ID", "testing".into()),
        ("AWS_SECRET_ACCESS_KEY", "testing".into()),
        ("AWS_REGION", "us-east-1".into()),
    ]
    .into_iter()
    .map(|(k, v)| (k.to_string(), v))
    .collect()
}
