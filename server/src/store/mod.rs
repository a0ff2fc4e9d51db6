//! The service's records behind one interface with two backends: embedded SQLite (the
//! default) and PostgreSQL. The SQL is written once with `$N` placeholders, which both
//! drivers accept; where the dialects differ (claiming a job) each backend has its own
//! statement. Every query is runtime-checked, so building never needs a database.

mod access_requests;
mod error;
mod jobs;
mod models;
mod postgres;
mod queue;
mod quotas;
mod releases;
mod scores;
mod sqlite;
mod submissions;
mod teams;
#[cfg(test)]
pub mod tests;
mod tokens;
mod uploads;

pub use access_requests::AccessRequestRecord;
pub use error::{StoreError, StoreResult};
pub use jobs::{ClaimedJob, NewJob};
pub use models::*;
pub use osmab_api::states::{AccessRequestState, JobKind, JobState, ReleaseFileKind, ReleaseState, SubmissionState, TokenScope};
pub use queue::Standing;
pub use quotas::QuotaPolicyRecord;
pub use uploads::{OpenUploadLimits, OpenUploads, UploadPart, UploadRecord};

use sqlx::{PgPool, SqlitePool};

/// Run `$body` with `$pool` bound to whichever pool the store holds; the body is the
/// same text for both backends.
macro_rules! on_pool {
    ($store:expr, |$pool:ident| $body:expr) => {
        match $store {
            $crate::store::Store::Sqlite($pool) => $body,
            $crate::store::Store::Postgres($pool) => $body,
        }
    };
}
pub(crate) use on_pool;

/// The record store: one of the two backends.
#[derive(Clone)]
pub enum Store {
    /// Embedded SQLite (one file in the data directory).
    Sqlite(SqlitePool),
    /// PostgreSQL (any number of servers and workers share it).
    Postgres(PgPool),
}

impl std::fmt::Debug for Store {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.backend())
    }
}

impl Store {
    /// Connect to `url` (`sqlite://…` or `postgres://…`).
    pub async fn connect(url: &str) -> StoreResult<Self> {
        if url.starts_with("postgres://") || url.starts_with("postgresql://") {
            postgres::connect(url).await.map(Store::Postgres)
        } else if url.starts_with("sqlite:") {
            sqlite::connect(url).await.map(Store::Sqlite)
        } else {
            Err(StoreError::Database(sqlx::Error::Configuration("DATABASE_URL must start with sqlite: or postgres://".into())))
        }
    }

    /// `sqlite` or `postgres`.
    pub fn backend(&self) -> &'static str {
        match self {
            Store::Sqlite(_) => "sqlite",
            Store::Postgres(_) => "postgres",
        }
    }

    /// Apply the migrations of this backend (idempotent).
    pub async fn migrate(&self) -> StoreResult<()> {
        match self {
            Store::Sqlite(pool) => sqlx::migrate!("../migrations/sqlite").run(pool).await?,
            Store::Postgres(pool) => sqlx::migrate!("../migrations/postgres").run(pool).await?,
        }
        Ok(())
    }

    /// Whether the database answers.
    pub async fn ping(&self) -> StoreResult<()> {
        on_pool!(self, |pool| sqlx::query("SELECT 1").execute(pool).await.map(|_| ())).map_err(StoreError::from)
    }

    /// Close the pool (waits for connections to return).
    pub async fn close(&self) {
        on_pool!(self, |pool| pool.close().await)
    }

    /// A consistent copy of a SQLite database at `target` (`VACUUM INTO`: taken while
    /// others read and write); PostgreSQL is copied with `pg_dump` instead.
    pub async fn snapshot_into(&self, target: &std::path::Path) -> StoreResult<()> {
        let Store::Sqlite(pool) = self else {
            return Err(StoreError::Database(sqlx::Error::Configuration("VACUUM INTO is SQLite's; copy PostgreSQL with pg_dump".into())));
        };
        let target = target.to_str().ok_or_else(|| StoreError::Database(sqlx::Error::Configuration("the backup path is not UTF-8".into())))?;
        sqlx::query("VACUUM INTO $1").bind(target).execute(pool).await?;
        Ok(())
    }

    /// Tables in the database's own schema (`public` on PostgreSQL): 0 for a new database.
    pub async fn table_count(&self) -> StoreResult<i64> {
        Ok(match self {
            Store::Sqlite(pool) => sqlx::query_scalar("SELECT COUNT(*) FROM sqlite_master WHERE type = 'table'").fetch_one(pool).await?,
            Store::Postgres(pool) => sqlx::query_scalar("SELECT COUNT(*) FROM information_schema.tables WHERE table_schema = 'public'").fetch_one(pool).await?,
        })
    }
}
