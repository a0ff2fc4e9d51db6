//! The OpenAI-compatible client against a local server that speaks the protocol.

use osmab_dataset::embedding::{Embedder, ServiceEmbedder};
use osmab_dataset::openai::{ServiceClient, ServiceConfig, ServiceError};
use osmab_dataset::prompts::filters::Rejection;
use osmab_dataset::prompts::llm::llm_pool;
use osmab_dataset::spec::Regime;
use serde_json::json;

use crate::fake_service::{FakeService, Reply};

fn client(url: &str) -> ServiceClient {
    let mut config = ServiceConfig::new(url, "test-model");
    config.api_key = Some("sk-secret".into());
    config.initial_backoff_secs = 0.01;
    config.max_retries = 2;
    config.timeout_secs = 5.0;
    ServiceClient::new(config).unwrap()
}

const GOOD: &str = "A dining room with 1 dining table in the center of the room, 6 dining chairs around the dining table, 1 sideboard against the wall, and 1 bench next to the dining table. The sideboard is behind the dining table. The bench is opposite the sideboard.";

fn good_spec() -> serde_json::Value {
    json!({"room": "dining room", "objects": [
        {"category": "dining table", "count": 1, "kind": "furniture"},
        {"category": "dining chair", "count": 6, "kind": "furniture"},
        {"category": "sideboard", "count": 1, "kind": "furniture"},
        {"category": "bench", "count": 1, "kind": "furniture"}],
      "relations": [{"subject": "dining chair", "kind": "around", "targets": ["dining table"]},
                    {"subject": "sideboard", "kind": "behind", "targets": ["dining table"]}]})
}

#[test]
fn llm_prompts_are_judged_like_the_grammars() {
    let reply = json!({"prompts": [
        {"prompt": GOOD, "spec": good_spec()},
        // Counts in the text disagree with the spec.
        {"prompt": GOOD.replace("6 dining chairs", "5 dining chairs"), "spec": good_spec()},
        // Vague, too short, no spec.
        {"prompt": "A room with some chairs."},
    ]});
    let server = FakeService::start(vec![Reply::chat(&reply.to_string())]);
    let pool = llm_pool(&client(&server.base_url), Regime::Furniture, 1, 3, 1).map_err(|(_, e)| e).unwrap();
    let received = server.finish();
    assert_eq!(pool.accepted.len(), 1);
    assert_eq!(pool.accepted[0].text, GOOD);
    assert_eq!(pool.accepted[0].source, "llm:test-model");
    assert_eq!(pool.accepted[0].spec.object("dining chair").unwrap().count, 6);
    assert_eq!(pool.rejected.len(), 2);
    assert!(pool.rejected[0].reasons.contains(&Rejection::SpecMismatch));
    assert!(pool.rejected.iter().any(|r| r.details.iter().any(|d| d.contains("numerals"))), "{:?}", pool.rejected);

    let request = &received[0];
    assert_eq!(request.path, "/v1/chat/completions");
    assert_eq!(request.body["model"], "test-model");
    assert_eq!(request.body["response_format"]["type"], "json_object");
    assert!(request.headers.contains(&("authorization".into(), "Bearer sk-secret".into())));
}

#[test]
fn rate_limits_and_server_errors_are_retried() {
    let server = FakeService::start(vec![
        Reply { status: 429, body: "{}".into(), headers: vec![("Retry-After".into(), "0".into())] },
        Reply::json(503, json!({"error": "overloaded"})),
        Reply::chat("{\"ok\": true}"),
    ]);
    let value = client(&server.base_url).chat_json("s", "u", 0.0).unwrap();
    assert_eq!(value, json!({"ok": true}));
    assert_eq!(server.finish().len(), 3);
}

#[test]
fn client_errors_are_not_retried_and_are_explained() {
    let server = FakeService::start(vec![Reply::json(401, json!({"error": {"message": "invalid api key"}}))]);
    let err = client(&server.base_url).chat_json("s", "u", 0.0).unwrap_err();
    assert_eq!(server.finish().len(), 1, "a 401 is final");
    match &err {
        ServiceError::Status { status, body, attempts, .. } => {
            assert_eq!((*status, *attempts), (401, 1));
            assert!(body.contains("invalid api key"));
        }
        other => panic!("expected a status error, got {other}"),
    }
    assert!(err.to_string().contains("/v1/chat/completions"), "the endpoint is named: {err}");
}

#[test]
fn exhausted_retries_report_the_last_status() {
    let server = FakeService::start((0..3).map(|_| Reply::json(500, json!({"error": "boom"}))).collect());
    let err = client(&server.base_url).chat_json("s", "u", 0.0).unwrap_err();
    server.finish();
    assert!(matches!(err, ServiceError::Status { status: 500, attempts: 3, .. }), "{err}");
}

#[test]
fn an_unreachable_service_is_named() {
    // A port nothing listens on.
    let listener = std::net::TcpListener::bind("127.0.0.1:0").unwrap();
    let url = format!("http://{}/v1", listener.local_addr().unwrap());
    drop(listener);
    let err = client(&url).chat_json("s", "u", 0.0).unwrap_err();
    assert!(matches!(err, ServiceError::Unreachable { attempts: 3, .. }), "{err}");
    assert!(err.to_string().contains(&url));
}

#[test]
fn non_json_model_output_is_a_clear_error() {
    let server = FakeService::start(vec![Reply::chat("Sure! Here are your prompts: ...")]);
    let err = client(&server.base_url).chat_json("s", "u", 0.0).unwrap_err();
    server.finish();
    assert!(err.to_string().contains("not JSON"), "{err}");
}

#[test]
fn embeddings_come_back_in_input_order_and_normalised() {
    let server = FakeService::start(vec![Reply::json(
        200,
        json!({"object": "list", "data": [
            {"object": "embedding", "index": 1, "embedding": [0.0, 2.0]},
            {"object": "embedding", "index": 0, "embedding": [3.0, 4.0]},
        ]}),
    )]);
    let embedder = ServiceEmbedder { client: client(&server.base_url), batch: 8 };
    let vectors = embedder.embed(&["a".into(), "b".into()]).unwrap();
    let received = server.finish();
    assert_eq!(received[0].path, "/v1/embeddings");
    assert_eq!(received[0].body["input"], json!(["a", "b"]));
    assert_eq!(vectors, vec![vec![0.6, 0.8], vec![0.0, 1.0]]);
}

#[test]
fn malformed_embeddings_are_refused() {
    let server = FakeService::start(vec![Reply::json(200, json!({"data": [{"index": 0, "embedding": [1.0, "x"]}]}))]);
    let err = client(&server.base_url).embeddings(&["a".into()]).unwrap_err();
    server.finish();
    assert!(err.to_string().contains("not a finite embedding"), "{err}");
}

#[test]
fn secrets_never_print() {
    let mut config = ServiceConfig::new("http://x/v1", "m");
    config.api_key = Some("sk-secret".into());
    assert!(!format!("{config:?}").contains("sk-secret"));
}
