//! The store's behaviour, run against both backends: a temporary SQLite file and a fresh
//! PostgreSQL database (`OSMAB_TEST_DATABASE_URL`, default the local server; the test
//! fails, it does not skip, when PostgreSQL is unreachable).

use super::*;
use crate::clock::now_ms;
use osmab_evaluator::scores::{Scores, Split};

mod jobs;
mod records;
mod submissions;
mod uploads;

/// A store of each backend; PostgreSQL databases are dropped when the guard goes.
pub struct TestStores {
    pub stores: Vec<Store>,
    _dir: tempfile::TempDir,
    pg_admin: String,
    pg_database: String,
}

pub fn postgres_base_url() -> String {
    std::env::var("OSMAB_TEST_DATABASE_URL").unwrap_or_else(|_| "postgres://postgres@127.0.0.1:5432/test".into())
}

impl TestStores {
    pub async fn new() -> Self {
        let dir = tempfile::tempdir().unwrap();
        let sqlite = Store::connect(&format!("sqlite://{}", dir.path().join("t.db").display())).await.unwrap();
        sqlite.migrate().await.unwrap();
        let base = postgres_base_url();
        let admin =
            sqlx::PgPool::connect(&base).await.unwrap_or_else(|e| panic!("PostgreSQL at {base} is needed for the store tests (.ci/run starts it): {e}"));
        let name = format!("osmab_test_{}", crate::clock::random_alphanumeric(12).to_ascii_lowercase());
        sqlx::query(sqlx::AssertSqlSafe(format!("CREATE DATABASE {name}"))).execute(&admin).await.unwrap();
        admin.close().await;
        let url = match base.rfind('/') {
            Some(i) => format!("{}/{name}", &base[..i]),
            None => panic!("{base} names no database"),
        };
        let postgres = Store::connect(&url).await.unwrap();
        postgres.migrate().await.unwrap();
        Self { stores: vec![sqlite, postgres], _dir: dir, pg_admin: base, pg_database: name }
    }

    pub async fn drop_all(self) {
        for store in &self.stores {
            store.close().await;
        }
        if let Ok(admin) = sqlx::PgPool::connect(&self.pg_admin).await {
            let _ = sqlx::query(sqlx::AssertSqlSafe(format!("DROP DATABASE IF EXISTS {} WITH (FORCE)", self.pg_database))).execute(&admin).await;
            admin.close().await;
        }
    }
}

/// A public, complete submission of `team_id` to release r1, every step at `t`.
pub(super) fn submission(id: &str, team_id: &str, t: i64) -> NewSubmission {
    NewSubmission {
        id: id.into(),
        team_id: team_id.into(),
        release: "r1".into(),
        card: StoredCard {
            name: "M".into(),
            description: String::new(),
            paper_url: None,
            code_url: None,
            external_data: None,
            compute: None,
            anonymous: false,
        },
        public: true,
        baseline: false,
        complete: true,
        archive_size: 1,
        archive_sha256: "00".into(),
        idempotency_key: None,
        split: Split::Test,
        received_at: t,
        validating_at: t,
        queued_at: t,
    }
}

pub(super) fn job(id: &str, at: i64) -> NewJob {
    NewJob { id: id.into(), kind: JobKind::ScoreSubmission, subject: format!("sub_{id}"), payload: "{}".into(), max_attempts: 3, created_at: at }
}

/// A score document told apart by `mark`.
pub(super) fn score(mark: u32) -> Scores {
    Scores { release: "r1".into(), evaluator_version: "0.1.0".into(), missing_maps: vec![format!("mark-{mark}")], ..Scores::default() }
}

pub(super) fn release(version: &str) -> ReleaseRecord {
    ReleaseRecord {
        version: version.into(),
        state: ReleaseState::Draft,
        is_current: false,
        digest: format!("digest-{version}"),
        manifest: "{}".into(),
        created_at: now_ms(),
        published_at: None,
    }
}
