//! A local HTTP server that speaks just enough of the OpenAI protocol for the tests:
//! it answers each request with the next scripted response and records what it got.

use std::io::{BufRead, BufReader, Read, Write};
use std::net::TcpListener;
use std::sync::{Arc, Mutex};
use std::thread::JoinHandle;

/// One scripted answer.
pub struct Reply {
    pub status: u16,
    pub body: String,
    pub headers: Vec<(String, String)>,
}

impl Reply {
    pub fn json(status: u16, body: serde_json::Value) -> Self {
        Self { status, body: body.to_string(), headers: vec![] }
    }

    /// A chat completion whose message content is `content`.
    pub fn chat(content: &str) -> Self {
        Self::json(
            200,
            serde_json::json!({"id": "x", "object": "chat.completion", "choices": [{"index": 0, "message": {"role": "assistant", "content": content}, "finish_reason": "stop"}]}),
        )
    }
}

/// A request as received: path, headers (lower-case names) and JSON body.
#[derive(Debug, Clone)]
pub struct Received {
    pub path: String,
    pub headers: Vec<(String, String)>,
    pub body: serde_json::Value,
}

pub struct FakeService {
    pub base_url: String,
    pub received: Arc<Mutex<Vec<Received>>>,
    handle: Option<JoinHandle<()>>,
}

impl FakeService {
    /// Serve `replies` in order on 127.0.0.1, one connection each.
    pub fn start(replies: Vec<Reply>) -> Self {
        let listener = TcpListener::bind("127.0.0.1:0").unwrap();
        let base_url = format!("http://{}/v1", listener.local_addr().unwrap());
        let received = Arc::new(Mutex::new(Vec::new()));
        let log = received.clone();
        let handle = std::thread::spawn(move || {
            // Give up after 20 s without a client, so a test whose code stops calling
            // fails on its assertions instead of hanging here.
            listener.set_nonblocking(true).unwrap();
            for reply in replies {
                let deadline = std::time::Instant::now() + std::time::Duration::from_secs(20);
                let stream = loop {
                    match listener.accept() {
                        Ok((stream, _)) => break Some(stream),
                        Err(_) if std::time::Instant::now() < deadline => std::thread::sleep(std::time::Duration::from_millis(5)),
                        Err(_) => break None,
                    }
                };
                let Some(stream) = stream else { return };
                stream.set_nonblocking(false).unwrap();
                let mut reader = BufReader::new(stream.try_clone().unwrap());
                let mut request_line = String::new();
                reader.read_line(&mut request_line).unwrap();
                let path = request_line.split_whitespace().nth(1).unwrap_or_default().to_string();
                let mut headers = Vec::new();
                loop {
                    let mut line = String::new();
                    reader.read_line(&mut line).unwrap();
                    let line = line.trim_end();
                    if line.is_empty() {
                        break;
                    }
                    let (k, v) = line.split_once(':').unwrap();
                    headers.push((k.trim().to_lowercase(), v.trim().to_string()));
                }
                let length: usize = headers.iter().find(|(k, _)| k == "content-length").map_or(0, |(_, v)| v.parse().unwrap());
                let mut body = vec![0u8; length];
                reader.read_exact(&mut body).unwrap();
                log.lock().unwrap().push(Received { path, headers, body: serde_json::from_slice(&body).unwrap_or(serde_json::Value::Null) });
                let mut out = stream;
                let mut head =
                    format!("HTTP/1.1 {} X\r\nContent-Type: application/json\r\nContent-Length: {}\r\nConnection: close\r\n", reply.status, reply.body.len());
                for (k, v) in &reply.headers {
                    head.push_str(&format!("{k}: {v}\r\n"));
                }
                out.write_all(head.as_bytes()).unwrap();
                out.write_all(b"\r\n").unwrap();
                out.write_all(reply.body.as_bytes()).unwrap();
            }
        });
        Self { base_url, received, handle: Some(handle) }
    }

    /// Wait until every scripted reply was served and return what was received.
    pub fn finish(mut self) -> Vec<Received> {
        self.handle.take().unwrap().join().unwrap();
        self.received.lock().unwrap().clone()
    }
}
