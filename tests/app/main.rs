//! In-process tests of the HTTP service: the router [`osmab::app`] builds over a real
//! store (SQLite and PostgreSQL) and real blob directory, driven with tower's `oneshot` —
//! no socket, no process. The end-to-end tests in `tests/cli` run the binary on a socket.

use axum::body::Body;
use axum::http::{Method, Request, StatusCode, header};
use serde_json::{Value, json};
use tower::ServiceExt;

#[path = "../support/postgres.rs"]
mod test_database;
use test_database::PgDatabase;

const ADMIN: &str = "osmab_inprocessadmintoken0000000000";

/// Which database the service runs on.
#[derive(Clone, Copy, Debug)]
enum Backend {
    Sqlite,
    Postgres,
}

/// The service over a fresh data directory and database.
struct App {
    router: axum::Router,
    _dir: tempfile::TempDir,
    _database: Option<PgDatabase>,
}

impl App {
    async fn new(backend: Backend) -> App {
        let dir = tempfile::tempdir().unwrap();
        let database = matches!(backend, Backend::Postgres).then(PgDatabase::create);
        let url = match &database {
            Some(pg) => pg.url.clone(),
            None => format!("sqlite://{}/osmab.db", dir.path().display()),
        };
        let data_dir = dir.path().display().to_string();
        let env = move |key: &str| match key {
            "DATABASE_URL" => Some(url.clone()),
            "OSMAB_DATA_DIR" => Some(data_dir.clone()),
            "OSMAB_ADMIN_TOKEN" => Some(ADMIN.to_string()),
            "OSMAB_DEMO" => Some("false".to_string()),
            _ => None,
        };
        let settings = osmab::config::Settings::load_from(None, &env).unwrap();
        let state = osmab::serve::open(settings).await.unwrap();
        osmab::serve::ensure_admin_token(&state).await.unwrap();
        App { router: osmab::app(state), _dir: dir, _database: database }
    }

    /// A request for `method uri` with `token`.
    fn request(method: Method, uri: &str, token: Option<&str>) -> axum::http::request::Builder {
        let request = Request::builder().method(method).uri(uri).header(header::HOST, "localhost");
        match token {
            Some(token) => request.header(header::AUTHORIZATION, format!("Bearer {token}")),
            None => request,
        }
    }

    /// `method uri` with `token` and a JSON `body`: the status, the content type and the
    /// body (JSON when it is, else a string).
    async fn call(&self, method: Method, uri: &str, token: Option<&str>, body: Option<Value>) -> (StatusCode, String, Value) {
        let request = Self::request(method, uri, token);
        let request = match body {
            Some(body) => request.header(header::CONTENT_TYPE, "application/json").body(Body::from(body.to_string())),
            None => request.body(Body::empty()),
        };
        let response = self.router.clone().oneshot(request.unwrap()).await.unwrap();
        let status = response.status();
        let media = response.headers().get(header::CONTENT_TYPE).map(|v| v.to_str().unwrap().to_string()).unwrap_or_default();
        let bytes = axum::body::to_bytes(response.into_body(), 64 << 20).await.unwrap();
        let body = serde_json::from_slice(&bytes).unwrap_or_else(|_| Value::String(String::from_utf8_lossy(&bytes).into_owned()));
        (status, media, body)
    }

    /// The status of `method uri` with `token` and the extra `headers`, no body.
    async fn status_of(&self, method: Method, uri: &str, token: Option<&str>, headers: &[(&str, &str)]) -> StatusCode {
        let request = headers.iter().fold(Self::request(method, uri, token), |request, (name, value)| request.header(*name, *value));
        self.router.clone().oneshot(request.body(Body::empty()).unwrap()).await.unwrap().status()
    }

    async fn get(&self, uri: &str, token: Option<&str>) -> (StatusCode, String, Value) {
        self.call(Method::GET, uri, token, None).await
    }
}

/// Every documented operation is routed, and every refusal is problem+json with a code the
/// document lists; an unknown route or method is a problem too.
async fn every_documented_operation_is_served(backend: Backend) {
    let app = App::new(backend).await;
    let (status, _, document) = app.get("/api/v1/openapi.json", None).await;
    assert_eq!(status, StatusCode::OK);
    let codes: Vec<&str> =
        document["components"]["schemas"]["Problem"]["properties"]["code"]["enum"].as_array().unwrap().iter().map(|c| c.as_str().unwrap()).collect();
    assert!(codes.contains(&"quota_exceeded") && codes.contains(&"route_not_found"), "{codes:?}");
    let paths = document["paths"].as_object().unwrap();
    assert!(paths.len() >= 30, "{} paths", paths.len());
    for (path, methods) in paths {
        let concrete = path.replace("{version}", "v").replace("{id}", "x").replace("{path}", "a/b.txt").replace("{split}", "val");
        for method in methods.as_object().unwrap().keys() {
            let (status, media, body) = app.call(method.to_uppercase().parse().unwrap(), &concrete, Some(ADMIN), None).await;
            let code = body["code"].as_str().unwrap_or("");
            assert!(code != "route_not_found" && code != "method_not_allowed", "{method} {path}: {status} {body}");
            // A refusal is problem+json with a documented code (a HEAD answer has no body to show it).
            if (status.is_client_error() || status.is_server_error()) && method != "head" {
                assert_eq!(media, "application/problem+json", "{method} {path}: {status}");
                assert!(codes.contains(&code), "{method} {path}: code {code:?} is not documented");
            }
        }
    }
    let (status, media, body) = app.get("/api/v1/nowhere", None).await;
    assert_eq!((status, media.as_str(), body["code"].as_str()), (StatusCode::NOT_FOUND, "application/problem+json", Some("route_not_found")));
    let (status, _, body) = app.call(Method::DELETE, "/api/v1/leaderboard", Some(ADMIN), None).await;
    assert_eq!((status, body["code"].as_str()), (StatusCode::METHOD_NOT_ALLOWED, Some("method_not_allowed")));
    let (_, _, page) = app.get("/api/docs", None).await;
    let page = page.as_str().unwrap();
    for code in &codes {
        assert!(page.contains(&format!("problem-{code}")), "/api/docs explains {code}");
    }
}

/// A team the admin creates sees itself and its quota of every split; without a token, or
/// with a team's token on an admin route, it is refused.
async fn a_new_team_sees_itself_and_its_quota(backend: Backend) {
    let app = App::new(backend).await;
    let (status, _, created) = app.call(Method::POST, "/api/v1/admin/teams", Some(ADMIN), Some(json!({"name": "Team Oneshot"}))).await;
    assert_eq!(status, StatusCode::CREATED, "{created}");
    let token = created["token"].as_str().unwrap();
    let (status, _, me) = app.get("/api/v1/me", Some(token)).await;
    assert_eq!((status, me["team"]["name"].as_str()), (StatusCode::OK, Some("Team Oneshot")), "{me}");
    let (_, _, quota) = app.get("/api/v1/quota", Some(token)).await;
    let splits: Vec<&str> = quota["splits"].as_array().unwrap().iter().map(|s| s["split"].as_str().unwrap()).collect();
    assert_eq!(splits, ["test", "val"], "{quota}");
    assert_eq!(app.get("/api/v1/me", None).await.2["code"], "unauthenticated");
    assert_eq!(app.get("/api/v1/admin/teams", Some(token)).await.2["code"], "forbidden");
    let (_, _, teams) = app.get("/api/v1/admin/teams", Some(ADMIN)).await;
    assert!(teams.to_string().contains("Team Oneshot"), "{teams}");
}

/// Who may call an operation is what the document says (`x-osmab-caller`), because the
/// handler's extractor says so: no token is refused (401) exactly where a token is needed, a
/// team's token is refused (403) on admin-only operations, and an admin's on team-only ones.
/// Path parameters name nothing that exists, so a caller let in gets 404, 400 or 422, never
/// 401 or 403.
async fn who_may_call_each_operation_is_what_it_declares(backend: Backend) {
    let app = App::new(backend).await;
    let (_, _, created) = app.call(Method::POST, "/api/v1/admin/teams", Some(ADMIN), Some(json!({"name": "Team Caller"}))).await;
    let team = created["token"].as_str().unwrap().to_string();
    let (_, _, document) = app.get("/api/v1/openapi.json", None).await;
    let refused = |status: StatusCode| status == StatusCode::UNAUTHORIZED || status == StatusCode::FORBIDDEN;
    let mut wrong = Vec::new();
    for (path, methods) in document["paths"].as_object().unwrap() {
        let concrete = path.replace("{version}", "v").replace("{id}", "x").replace("{path}", "a/b.txt").replace("{split}", "val");
        for (method, operation) in methods.as_object().unwrap() {
            let caller = operation["x-osmab-caller"].as_str().unwrap_or("(none)");
            // (no token, a team's token, the admin's token): refused or let in.
            let expected = match caller {
                "public" | "optional" => [false, false, false],
                "team" => [true, false, true],
                "admin" => [true, true, false],
                "team_or_admin" => [true, false, false],
                other => panic!("{method} {path}: x-osmab-caller {other:?}"),
            };
            let mut seen = [false; 3];
            for (i, token) in [None, Some(team.as_str()), Some(ADMIN)].into_iter().enumerate() {
                // Tus-Resumable, which the upload routes check before anything else (tus 1.0.0).
                let status = app.status_of(method.to_uppercase().parse().unwrap(), &concrete, token, &[("tus-resumable", "1.0.0")]).await;
                seen[i] = refused(status);
            }
            if seen != expected {
                wrong.push(format!("{} {path} declares {caller}: refused (none, team, admin) = {seen:?}", method.to_uppercase()));
            }
        }
    }
    assert!(wrong.is_empty(), "operations whose handler lets in others than they declare:\n{}", wrong.join("\n"));
}

macro_rules! on_both_backends {
    ($($name:ident),+ $(,)?) => {
        mod sqlite {
            $(#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
            async fn $name() {
                super::$name(super::Backend::Sqlite).await
            })+
        }
        mod postgres {
            $(#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
            async fn $name() {
                super::$name(super::Backend::Postgres).await
            })+
        }
    };
}

on_both_backends!(every_documented_operation_is_served, a_new_team_sees_itself_and_its_quota, who_may_call_each_operation_is_what_it_declares);
