//! What every answer carries and what is checked before routing: pages that run no script
//! and are framed by no one, admin answers never cached, one `Host` per HTTP/1.1 request,
//! and a client's `x-request-id` echoed only when it is a short token.

use std::io::{Read, Write};

use super::{Backend, Deployment};

const CSP: &str = "default-src 'none'; style-src 'self'; img-src 'self'; form-action 'self'; frame-ancestors 'none'; base-uri 'none'";

/// The raw answer to `request` sent as it is on a fresh connection.
fn raw(address: &str, request: &str) -> String {
    let mut stream = std::net::TcpStream::connect(address).unwrap();
    stream.set_read_timeout(Some(std::time::Duration::from_secs(10))).unwrap();
    stream.write_all(request.as_bytes()).unwrap();
    let mut answer = Vec::new();
    let _ = stream.read_to_end(&mut answer);
    String::from_utf8_lossy(&answer).into_owned()
}

#[test]
fn pages_api_and_requests_carry_and_get_the_headers_a_hostile_review_asks_for() {
    let deployment = Deployment::new(Backend::Sqlite, &[]);
    let server = deployment.serve();

    let page = server.get("/").send().unwrap();
    let header = |response: &reqwest::blocking::Response, name: &str| response.headers().get(name).map(|v| v.to_str().unwrap().to_string());
    assert_eq!(header(&page, "content-security-policy").as_deref(), Some(CSP));
    assert_eq!(header(&page, "x-frame-options").as_deref(), Some("DENY"));
    assert_eq!(header(&page, "x-content-type-options").as_deref(), Some("nosniff"));
    assert_eq!(header(&page, "referrer-policy").as_deref(), Some("same-origin"));
    let login = server.get("/admin/login").send().unwrap();
    assert_eq!(header(&login, "cache-control").as_deref(), Some("no-store"), "the operator's pages are never cached");
    let admin_api = server.get("/api/v1/admin/jobs").send().unwrap();
    assert_eq!((admin_api.status().as_u16(), header(&admin_api, "cache-control").as_deref()), (401, Some("no-store")));
    let api = server.get("/api/v1/releases").send().unwrap();
    assert_eq!((header(&api, "x-content-type-options").as_deref(), header(&api, "content-security-policy")), (Some("nosniff"), None));

    // Request ids: a short token is echoed; anything else is replaced by the server's own.
    let echoed = |id: &str| header(&server.get("/livez").header("x-request-id", id).send().unwrap(), "x-request-id").unwrap();
    assert_eq!(echoed("0f8e2c1d-8a4b-4c3e-9f00-123456789abc"), "0f8e2c1d-8a4b-4c3e-9f00-123456789abc");
    for hostile in ["x".repeat(8000), "two words".to_string(), "<script>alert(1)</script>".to_string()] {
        let id = echoed(&hostile);
        assert!(id != hostile && (1..=64).contains(&id.len()) && id.bytes().all(|b| b.is_ascii_alphanumeric()), "{hostile:.40} answered {id}");
    }

    // Host: required once in HTTP/1.1, optional in HTTP/1.0.
    let address = server.url.trim_start_matches("http://");
    let missing = raw(address, "GET /livez HTTP/1.1\r\nConnection: close\r\n\r\n");
    assert!(missing.starts_with("HTTP/1.1 400") && missing.contains("application/problem+json") && missing.contains("Host header"), "{missing}");
    let twice = raw(address, "GET /livez HTTP/1.1\r\nHost: a\r\nHost: b\r\nConnection: close\r\n\r\n");
    assert!(twice.starts_with("HTTP/1.1 400") && twice.contains("one Host header"), "{twice}");
    let old = raw(address, "GET /livez HTTP/1.0\r\n\r\n");
    assert!(old.starts_with("HTTP/1.0 200") || old.starts_with("HTTP/1.1 200"), "{old}");
    let fine = raw(address, "GET /livez HTTP/1.1\r\nHost: example\r\nConnection: close\r\n\r\n");
    assert!(fine.starts_with("HTTP/1.1 200"), "{fine}");
}
