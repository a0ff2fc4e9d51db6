//! Hostile and broken uploads get clear problem+json errors and leave every stored record
//! (submissions, leaderboard, blobs) as it was.

use std::io::Write;

use serde_json::Value;

use super::{Backend, Deployment, baseline_dir, on_both_backends, problem, tar_of};

fn tar_with(entries: &[(&str, &[u8])]) -> Vec<u8> {
    let mut builder = tar::Builder::new(Vec::new());
    for (name, data) in entries {
        let mut header = tar::Header::new_gnu();
        header.set_size(data.len() as u64);
        header.set_mode(0o644);
        header.set_entry_type(tar::EntryType::Regular);
        // Write the raw name so '..' reaches the server as a hostile client would send it.
        let bytes = name.as_bytes();
        header.as_old_mut().name[..bytes.len()].copy_from_slice(bytes);
        header.set_cksum();
        builder.append(&header, *data).unwrap();
    }
    builder.into_inner().unwrap()
}

fn zip_bomb() -> Vec<u8> {
    let mut zip = zip::ZipWriter::new(std::io::Cursor::new(Vec::new()));
    let options = zip::write::SimpleFileOptions::default().compression_method(zip::CompressionMethod::Deflated).large_file(true);
    zip.start_file("maps/baseline/scene_000.npz", options).unwrap();
    let zeros = vec![0u8; 1 << 20];
    for _ in 0..64 {
        zip.write_all(&zeros).unwrap();
    }
    zip.finish().unwrap().into_inner()
}

fn walk(dir: &std::path::Path) -> Vec<std::path::PathBuf> {
    let mut out = Vec::new();
    for entry in std::fs::read_dir(dir).into_iter().flatten().flatten() {
        let path = entry.path();
        if path.is_dir() {
            out.extend(walk(&path));
        }
        out.push(path);
    }
    out
}

fn stored_state(server: &super::Server<'_>, token: &str) -> (Value, Value, usize) {
    let submissions: Value = server.get("/api/v1/submissions").bearer_auth(token).send().unwrap().json().unwrap();
    let board: Value = server.get("/api/v1/leaderboard").send().unwrap().json().unwrap();
    (submissions, board, scratch_left(server))
}

/// Entries of the processes' own scratch directories under `.incoming`, once the server
/// has had a moment to remove them: a scratch folder goes on a blocking thread when its
/// request or job ends, which may be just after the answer (or the score) is out.
fn scratch_left(server: &super::Server<'_>) -> usize {
    let count = || {
        walk(&server.deployment.data.path().join("blobs/.incoming"))
            .iter()
            .filter(|p| p.parent().is_some_and(|d| d.is_dir() && d.file_name().is_some_and(|n| n.to_string_lossy().starts_with("owner-"))))
            .count()
    };
    let deadline = std::time::Instant::now() + std::time::Duration::from_secs(30);
    loop {
        let left = count();
        if left == 0 || std::time::Instant::now() > deadline {
            return left;
        }
        std::thread::sleep(std::time::Duration::from_millis(50));
    }
}

fn hostile_uploads(backend: Backend) {
    let deployment = Deployment::new(backend, &[("OSMAB_MAX_UPLOAD_BYTES", "20000000"), ("OSMAB_MAX_UNPACKED_BYTES", "30000000")]);
    let server = deployment.serve();
    let version = server.import_test_release();
    let token = server.team("Team Hostile");
    let oracle = baseline_dir("oracle");
    let good = tar_of(oracle.path());
    let accepted = server.upload(&token, &good, "");
    assert_eq!(accepted.status(), 202);
    let id = accepted.json::<Value>().unwrap()["id"].as_str().unwrap().to_string();
    server.wait_done(&id, &token);
    let before = stored_state(&server, &token);
    assert_eq!(before.2, 0, "the scoring's scratch files are removed");

    // The README's own archive command, literally: `tar -cf sub.tar -C my-submission .`
    // (its first entry is `./`).
    let scratch = tempfile::tempdir().unwrap();
    let made =
        std::process::Command::new("tar").args(["-cf", "sub.tar", "-C", oracle.path().to_str().unwrap(), "."]).current_dir(scratch.path()).output().unwrap();
    assert!(made.status.success(), "{}", String::from_utf8_lossy(&made.stderr));
    let readme_tar = std::fs::read(scratch.path().join("sub.tar")).unwrap();
    let response = server.upload(&token, &readme_tar, "?dry_run=true");
    assert_eq!(response.status(), 200, "{}", response.text().unwrap());

    // An entry that cannot be written (a file and a directory of one name) is named by its
    // path inside the upload, never by the server's scratch paths.
    let submission_json = std::fs::read(oracle.path().join("submission.json")).unwrap();
    let clash = tar_with(&[("submission.json", &submission_json), ("maps", b"x"), ("maps/baseline/scene_000.npz", b"y")]);
    let body = problem(server.upload(&token, &clash, ""), 422, "invalid_archive");
    let shown = body.to_string();
    assert!(!shown.contains(".incoming") && !shown.contains(deployment.data.path().to_str().unwrap()), "{shown}");
    assert_eq!((body["errors"][0]["file"].as_str(), body["errors"][0]["field"].as_str()), (Some("upload"), Some("maps/baseline/scene_000.npz")), "{body}");

    // Truncated archive.
    let truncated = &good[..good.len() / 2 + 100];
    let body = problem(server.upload(&token, truncated, ""), 422, "invalid_archive");
    assert!(body["detail"].as_str().unwrap().contains("truncated"), "{body}");

    // Path traversal.
    let evil = tar_with(&[("submission.json", &submission_json), ("../../evil.txt", b"owned")]);
    let body = problem(server.upload(&token, &evil, ""), 422, "invalid_archive");
    assert!(body["errors"][0]["message"].as_str().unwrap().contains(".."), "{body}");
    let escaped = walk(deployment.data.path())
        .into_iter()
        .chain(walk(deployment.data.path().parent().unwrap()).into_iter().filter(|p| p.parent() == deployment.data.path().parent()));
    assert!(escaped.into_iter().all(|p| p.file_name().unwrap() != "evil.txt"), "the entry was not written anywhere");

    // Archive bomb: 64 MiB of zeros in a small zip, over the expansion limit (200 times the
    // archive's size, OSMAB_MAX_EXPANSION_RATIO) long before the unpacked limit; a dry run too.
    let bomb = zip_bomb();
    assert!(bomb.len() < 1_000_000);
    for query in ["", "?dry_run=true"] {
        let body = problem(server.upload(&token, &bomb, query), 422, "invalid_archive");
        assert!(body["detail"].as_str().unwrap().contains(&format!("200 times its own {} bytes", bomb.len())), "{body}");
    }

    // Wrong checksum.
    let response = server
        .post("/api/v1/submissions")
        .bearer_auth(&token)
        .header("content-digest", super::content_digest(b"something else"))
        .body(good.clone())
        .send()
        .unwrap();
    problem(response, 422, "digest_mismatch");

    // Oversized body: declared (refused before reading) and streamed without a length
    // (refused once the limit is passed).
    // The declared case is sent raw (headers only): the answer must come before any byte of
    // the body, and a client still writing a body it was refused may see a broken pipe first.
    let answer = declared_upload_answer(&server.url, &token, 20_000_001);
    assert!(answer.starts_with("HTTP/1.1 413 "), "{answer}");
    assert!(answer.contains("\"code\":\"payload_too_large\""), "{answer}");
    let chunked = reqwest::blocking::Body::new(std::io::Cursor::new(vec![7u8; 25_000_000]));
    let response = server.post("/api/v1/submissions").bearer_auth(&token).body(chunked).send();
    match response {
        Ok(response) => {
            problem(response, 413, "payload_too_large");
        }
        // The server may close the connection before the client finished sending.
        Err(e) => assert!(e.is_request() || e.is_body() || e.is_connect(), "{e}"),
    }

    // NaN points and an unknown scene.
    let nan_dir = baseline_dir("oracle");
    let map_path = nan_dir.path().join("maps/baseline/scene_000.npz");
    let mut map = osmab_evaluator::formats::map::PredictedMap::read(&map_path, Default::default()).unwrap();
    map.points[3][1] = f32::NAN;
    map.write(&map_path, false).unwrap();
    std::fs::copy(nan_dir.path().join("graphs/baseline/scene_000.json"), nan_dir.path().join("graphs/baseline/scene_999.json")).unwrap();
    let body = problem(server.upload(&token, &tar_of(nan_dir.path()), ""), 422, "invalid_submission");
    let errors = body["errors"].as_array().unwrap();
    assert!(
        errors.iter().any(|e| e["file"] == "maps/baseline/scene_000.npz" && e["field"] == "points" && e["message"].as_str().unwrap().contains("NaN")),
        "{body}"
    );
    assert!(
        errors.iter().any(|e| e["file"] == "graphs/baseline/scene_999.json" && e["message"].as_str().unwrap().contains("unknown scene 'scene_999'")),
        "{body}"
    );

    // A submission for another release, and one without submission.json.
    let other = tar_with(&[("submission.json", br#"{"format": "osmab-submission/1", "release": "nope-9", "method": {"name": "x"}}"#)]);
    let body = problem(server.upload(&token, &other, ""), 422, "invalid_submission");
    assert!(body["detail"].as_str().unwrap().contains("nope-9"));
    let bare = tar_with(&[("maps/baseline/scene_000.npz", b"junk")]);
    problem(server.upload(&token, &bare, ""), 422, "invalid_submission");
    problem(server.upload(&token, b"", ""), 422, "invalid_archive");

    // A small upload whose map unpacks far beyond the unpacked-bytes limit (60 MB of
    // points and ids in a compressed .npz) is refused from the arrays' headers, naming the limit.
    let inflating = baseline_dir("oracle");
    let n = 3_000_000; // fewer points than the scene's pixels: the bytes are what is refused
    let zeros = osmab_evaluator::formats::npy::NpyArray::from_f32_matrix(n, 3, vec![0.0; n * 3]);
    let ids = osmab_evaluator::formats::npy::NpyArray::from_i64(vec![0; n]);
    let labels = osmab_evaluator::formats::npy::NpyArray::from_i64(vec![1]);
    osmab_evaluator::formats::npz::write_npz(
        &inflating.path().join("maps/baseline/scene_000.npz"),
        &[("points", &zeros), ("object_ids", &ids), ("labels", &labels)],
        true,
    )
    .unwrap();
    let archive = tar_of(inflating.path());
    assert!(archive.len() < 20_000_000);
    let body = problem(server.upload(&token, &archive, "?dry_run=true"), 422, "invalid_submission");
    assert!(
        body["errors"].as_array().unwrap().iter().any(|e| e["file"] == "maps/baseline/scene_000.npz" && e["message"].as_str().unwrap().contains("30000000")),
        "{body}"
    );

    // A map in another frame is reported as such.
    let shifted_dir = baseline_dir("oracle");
    let shifted_path = shifted_dir.path().join("maps/camera/scene_001.npz");
    let mut shifted = osmab_evaluator::formats::map::PredictedMap::read(&shifted_path, Default::default()).unwrap();
    for p in &mut shifted.points {
        p[0] += 40.0;
    }
    shifted.write(&shifted_path, false).unwrap();
    let body = problem(server.upload(&token, &tar_of(shifted_dir.path()), "?dry_run=true"), 422, "invalid_submission");
    assert!(body["errors"][0]["message"].as_str().unwrap().contains("another frame"), "{body}");

    // Nothing changed: the same submissions, the same leaderboard, no scratch files left.
    let (submissions, board, scratch) = stored_state(&server, &token);
    assert_eq!(submissions, before.0, "the team's submissions");
    assert_eq!(board, before.1, "the leaderboard");
    assert_eq!(scratch, 0, "scratch files left");
    let release_page = server.get(&format!("/releases/{version}")).send().unwrap();
    assert_eq!(release_page.status(), 200);
}

on_both_backends!(hostile_uploads_are_refused_and_change_nothing, super::hostile_uploads);

/// The raw answer to an upload that declares `length` bytes and sends none of them.
fn declared_upload_answer(url: &str, token: &str, length: u64) -> String {
    use std::io::{Read, Write};
    let address = url.trim_start_matches("http://");
    let mut stream = std::net::TcpStream::connect(address).unwrap();
    stream.set_read_timeout(Some(std::time::Duration::from_secs(30))).unwrap();
    write!(
        stream,
        "POST /api/v1/submissions HTTP/1.1\r\nHost: {address}\r\nAuthorization: Bearer {token}\r\nContent-Type: application/x-tar\r\nContent-Length: {length}\r\n\r\n"
    )
    .unwrap();
    let mut answer = Vec::new();
    let _ = stream.read_to_end(&mut answer);
    String::from_utf8_lossy(&answer).into_owned()
}

/// Whether the server closes `stream` (end of file or a reset) within `within`, reading
/// whatever it sends first (an answer) into `answer`.
fn closed_by_server(stream: &mut std::net::TcpStream, within: std::time::Duration, answer: &mut Vec<u8>) -> bool {
    use std::io::Read;
    stream.set_read_timeout(Some(within)).unwrap();
    let mut buffer = [0u8; 4096];
    loop {
        match stream.read(&mut buffer) {
            Ok(0) => return true,
            Ok(n) => answer.extend_from_slice(&buffer[..n]),
            Err(e) if matches!(e.kind(), std::io::ErrorKind::WouldBlock | std::io::ErrorKind::TimedOut) => return false,
            Err(_) => return true,
        }
    }
}

/// Slow clients hold nothing: a connection that trickles its headers, or sends none, is
/// closed at the header deadline; an upload whose body stalls is answered 408; the
/// service keeps answering others meanwhile.
fn slow_clients(backend: Backend) {
    use std::io::Write;
    use std::time::Duration;
    let deployment = Deployment::new(backend, &[("OSMAB_HEADER_TIMEOUT_SECS", "1"), ("OSMAB_BODY_IDLE_TIMEOUT_SECS", "1"), ("OSMAB_MAX_CONNECTIONS", "8")]);
    let server = deployment.serve();
    let token = server.team("Team Slow");
    let address = server.url.trim_start_matches("http://").to_string();

    // Headers one byte at a time, slower than the deadline allows in total.
    let mut trickle = std::net::TcpStream::connect(&address).unwrap();
    let mut closed = false;
    for byte in b"GET /api/v1/releases HTTP/1.1\r\nHost: x\r\n".iter() {
        if trickle.write_all(&[*byte]).is_err() {
            closed = true;
            break;
        }
        std::thread::sleep(Duration::from_millis(200));
    }
    let mut answer = Vec::new();
    assert!(closed || closed_by_server(&mut trickle, Duration::from_secs(10), &mut answer), "a trickling client is closed");
    // Silent connections (all the connection slots) are closed too, and the service answers again.
    let mut silent: Vec<_> = (0..8).map(|_| std::net::TcpStream::connect(&address).unwrap()).collect();
    for stream in &mut silent {
        assert!(closed_by_server(stream, Duration::from_secs(10), &mut Vec::new()), "a silent connection is closed");
    }
    assert_eq!(server.get("/api/v1/releases").send().unwrap().status(), 200);

    // An upload that stalls mid-body.
    let mut stalled = std::net::TcpStream::connect(&address).unwrap();
    write!(
        stalled,
        "POST /api/v1/submissions HTTP/1.1\r\nHost: {address}\r\nAuthorization: Bearer {token}\r\nContent-Type: application/x-tar\r\nContent-Length: 100000\r\n\r\n"
    )
    .unwrap();
    stalled.write_all(&[0u8; 1000]).unwrap();
    let mut answer = Vec::new();
    assert!(closed_by_server(&mut stalled, Duration::from_secs(10), &mut answer), "a stalled upload is ended");
    let answer = String::from_utf8_lossy(&answer);
    assert!(answer.starts_with("HTTP/1.1 408 "), "{answer}");
    assert!(answer.contains("\"code\":\"request_timeout\""), "{answer}");
}

on_both_backends!(slow_clients_are_closed_and_hold_nothing, super::slow_clients);
