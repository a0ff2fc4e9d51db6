//! A small HTTP/1.1 load generator for the service benchmarks (`cargo xtask http`,
//! `cargo xtask upload`, `cargo xtask download`): keep-alive connections over raw TCP, so
//! the client's own overhead stays far below the server's and nothing is downloaded.

use std::sync::Arc;
use std::time::{Duration, Instant};

use anyhow::{Context, bail};
use tokio::io::{AsyncBufReadExt, AsyncReadExt, AsyncWriteExt, BufReader};
use tokio::net::TcpStream;

/// `host:port` and path of an `http://` URL.
fn split_url(url: &str) -> anyhow::Result<(String, String)> {
    let rest = url.strip_prefix("http://").context("only http:// URLs are supported")?;
    let (host, path) = match rest.find('/') {
        Some(i) => (&rest[..i], &rest[i..]),
        None => (rest, "/"),
    };
    Ok((host.to_string(), path.to_string()))
}

/// Read one response (status line, headers, Content-Length body); returns (status, body bytes).
async fn read_response(reader: &mut BufReader<TcpStream>) -> anyhow::Result<(u16, u64)> {
    let mut line = String::new();
    reader.read_line(&mut line).await?;
    let status: u16 = line.split_whitespace().nth(1).context("no status line")?.parse()?;
    let mut length = 0u64;
    loop {
        line.clear();
        if reader.read_line(&mut line).await? == 0 {
            bail!("connection closed in the headers");
        }
        let header = line.trim_end();
        if header.is_empty() {
            break;
        }
        if let Some((name, value)) = header.split_once(':')
            && name.eq_ignore_ascii_case("content-length")
        {
            length = value.trim().parse()?;
        }
    }
    let mut remaining = length;
    let mut sink = vec![0u8; 256 * 1024];
    while remaining > 0 {
        let want = remaining.min(sink.len() as u64) as usize;
        let n = reader.read(&mut sink[..want]).await?;
        if n == 0 {
            bail!("connection closed in the body");
        }
        remaining -= n as u64;
    }
    Ok((status, length))
}

/// Latency percentiles and throughput of a run.
pub struct LoadReport {
    pub requests: u64,
    pub errors: u64,
    pub seconds: f64,
    pub p50_ms: f64,
    pub p99_ms: f64,
    pub max_ms: f64,
}

/// `concurrency` keep-alive connections sending `GET url` (with `headers`) for `duration`.
pub async fn get_load(url: &str, headers: &[String], concurrency: usize, duration: Duration) -> anyhow::Result<LoadReport> {
    let (host, path) = split_url(url)?;
    let mut extra = String::new();
    for h in headers {
        extra.push_str(h);
        extra.push_str("\r\n");
    }
    let request: Arc<Vec<u8>> = Arc::new(format!("GET {path} HTTP/1.1\r\nHost: {host}\r\n{extra}\r\n").into_bytes());
    let deadline = Instant::now() + duration;
    let started = Instant::now();
    let mut tasks = Vec::new();
    for _ in 0..concurrency {
        let (host, request) = (host.clone(), request.clone());
        tasks.push(tokio::spawn(async move {
            let mut latencies: Vec<u32> = Vec::with_capacity(1 << 16);
            let mut errors = 0u64;
            while Instant::now() < deadline {
                let Ok(stream) = TcpStream::connect(&host).await else {
                    errors += 1;
                    continue;
                };
                stream.set_nodelay(true).ok();
                let mut reader = BufReader::new(stream);
                while Instant::now() < deadline {
                    let sent = Instant::now();
                    if reader.get_mut().write_all(&request).await.is_err() {
                        errors += 1;
                        break;
                    }
                    match read_response(&mut reader).await {
                        Ok((status, _)) if status < 400 || status == 304 => latencies.push(sent.elapsed().as_micros() as u32),
                        Ok(_) => errors += 1,
                        Err(_) => {
                            errors += 1;
                            break;
                        }
                    }
                }
            }
            (latencies, errors)
        }));
    }
    let mut all = Vec::new();
    let mut errors = 0;
    for task in tasks {
        let (latencies, e) = task.await?;
        all.extend(latencies);
        errors += e;
    }
    let seconds = started.elapsed().as_secs_f64();
    all.sort_unstable();
    let pick = |q: f64| all.get(((all.len() as f64 - 1.0) * q).round() as usize).map(|&us| us as f64 / 1000.0).unwrap_or(f64::NAN);
    Ok(LoadReport { requests: all.len() as u64, errors, seconds, p50_ms: pick(0.5), p99_ms: pick(0.99), max_ms: pick(1.0) })
}

/// Download `url` once; returns (bytes, seconds).
pub async fn download(url: &str) -> anyhow::Result<(u64, f64)> {
    let (host, path) = split_url(url)?;
    let stream = TcpStream::connect(&host).await?;
    let mut reader = BufReader::with_capacity(1 << 20, stream);
    let started = Instant::now();
    reader.get_mut().write_all(format!("GET {path} HTTP/1.1\r\nHost: {host}\r\nConnection: close\r\n\r\n").as_bytes()).await?;
    let (status, bytes) = read_response(&mut reader).await?;
    if status != 200 {
        bail!("GET {url}: status {status}");
    }
    Ok((bytes, started.elapsed().as_secs_f64()))
}

/// Upload a synthetic tar of about `bytes` bytes (one large member) with `token`;
/// returns (status, response body, seconds).
pub async fn upload(url: &str, token: &str, bytes: u64) -> anyhow::Result<(u16, String, f64)> {
    let (host, path) = split_url(url)?;
    let member = bytes.saturating_sub(2048).max(1) / 512 * 512;
    let mut header = tar::Header::new_gnu();
    header.set_path("maps/baseline/scene_000.npz")?;
    header.set_size(member);
    header.set_mode(0o644);
    header.set_entry_type(tar::EntryType::Regular);
    header.set_cksum();
    let total = 512 + member + 1024;
    let mut stream = TcpStream::connect(&host).await?;
    let started = Instant::now();
    let head = format!(
        "POST {path} HTTP/1.1\r\nHost: {host}\r\nAuthorization: Bearer {token}\r\nContent-Type: application/x-tar\r\nContent-Length: {total}\r\nConnection: close\r\n\r\n"
    );
    stream.write_all(head.as_bytes()).await?;
    stream.write_all(header.as_bytes()).await?;
    let block = vec![0u8; 1 << 20];
    let mut left = member;
    while left > 0 {
        let n = left.min(block.len() as u64) as usize;
        stream.write_all(&block[..n]).await?;
        left -= n as u64;
    }
    stream.write_all(&[0u8; 1024]).await?;
    let mut response = Vec::new();
    stream.read_to_end(&mut response).await?;
    let text = String::from_utf8_lossy(&response).to_string();
    let status: u16 = text.split_whitespace().nth(1).unwrap_or("0").parse().unwrap_or(0);
    let body = text.split_once("\r\n\r\n").map(|(_, b)| b.to_string()).unwrap_or_default();
    Ok((status, body, started.elapsed().as_secs_f64()))
}
