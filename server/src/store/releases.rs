//! Releases and their public files: drafts, publication, the current release.

use super::{ReleaseFile, ReleaseFileKind, ReleaseRecord, ReleaseState, Store, StoreError, StoreResult, on_pool};

/// Release files written by one INSERT: 5 parameters each, within SQLite's 32,766 and
/// PostgreSQL's 65,535 parameters a statement.
const FILES_PER_INSERT: usize = 1000;

impl Store {
    /// Register a release and its public files in one transaction.
    pub async fn insert_release(&self, release: &ReleaseRecord, files: &[ReleaseFile]) -> StoreResult<()> {
        on_pool!(self, |pool| {
            let mut tx = pool.begin().await?;
            sqlx::query("INSERT INTO releases (version, state, is_current, digest, manifest, created_at, published_at) VALUES ($1, $2, $3, $4, $5, $6, $7)")
                .bind(&release.version)
                .bind(&release.state)
                .bind(release.is_current)
                .bind(&release.digest)
                .bind(&release.manifest)
                .bind(release.created_at)
                .bind(release.published_at)
                .execute(&mut *tx)
                .await?;
            // Many rows a statement (a full release lists ~200,000 files): one round trip
            // each would take longer than everything else the import does.
            for chunk in files.chunks(FILES_PER_INSERT) {
                let mut insert = sqlx::QueryBuilder::new("INSERT INTO release_files (version, path, size, sha256, kind) ");
                insert.push_values(chunk, |mut row, file| {
                    row.push_bind(&file.version).push_bind(&file.path).push_bind(file.size).push_bind(&file.sha256).push_bind(file.kind);
                });
                insert.build().execute(&mut *tx).await?;
            }
            tx.commit().await
        })?;
        Ok(())
    }

    /// Every release, newest first.
    pub async fn releases(&self) -> StoreResult<Vec<ReleaseRecord>> {
        Ok(on_pool!(self, |pool| sqlx::query_as(
            "SELECT version, state, is_current, digest, manifest, created_at, published_at FROM releases ORDER BY created_at DESC, version"
        )
        .fetch_all(pool)
        .await)?)
    }

    /// The published releases' versions, newest first, each with whether it is the current one
    /// (no manifests: what a board's release switcher needs).
    pub async fn published_versions(&self) -> StoreResult<Vec<(String, bool)>> {
        Ok(on_pool!(self, |pool| sqlx::query_as("SELECT version, is_current FROM releases WHERE state = $1 ORDER BY published_at DESC, version DESC")
            .bind(ReleaseState::Published)
            .fetch_all(pool)
            .await)?)
    }

    /// Release `version`.
    pub async fn release(&self, version: &str) -> StoreResult<ReleaseRecord> {
        Ok(on_pool!(self, |pool| sqlx::query_as(
            "SELECT version, state, is_current, digest, manifest, created_at, published_at FROM releases WHERE version = $1"
        )
        .bind(version)
        .fetch_one(pool)
        .await)?)
    }

    /// The current (most recently published) release.
    pub async fn current_release(&self) -> StoreResult<ReleaseRecord> {
        Ok(on_pool!(self, |pool| sqlx::query_as(
            "SELECT version, state, is_current, digest, manifest, created_at, published_at FROM releases WHERE is_current = TRUE"
        )
        .fetch_one(pool)
        .await)?)
    }

    /// Freeze draft `version` and make it the current release.
    pub async fn publish_release(&self, version: &str, at: i64) -> StoreResult<()> {
        on_pool!(self, |pool| {
            let mut tx = pool.begin().await?;
            let done = sqlx::query("UPDATE releases SET state = $3, published_at = COALESCE(published_at, $2) WHERE version = $1")
                .bind(version)
                .bind(at)
                .bind(ReleaseState::Published)
                .execute(&mut *tx)
                .await?
                .rows_affected();
            if done == 0 {
                return Err(StoreError::NotFound);
            }
            sqlx::query("UPDATE releases SET is_current = FALSE WHERE is_current = TRUE AND version <> $1").bind(version).execute(&mut *tx).await?;
            sqlx::query("UPDATE releases SET is_current = TRUE WHERE version = $1").bind(version).execute(&mut *tx).await?;
            tx.commit().await.map_err(StoreError::from)
        })
    }

    /// Record a sequence archive of release `version` repacked to hold exactly its
    /// manifest's files: its new size and SHA-256, and the served manifest that lists them,
    /// in one transaction.
    pub async fn replace_release_archive(&self, version: &str, path: &str, size: i64, sha256: &str, manifest: &str) -> StoreResult<()> {
        on_pool!(self, |pool| {
            let mut tx = pool.begin().await?;
            let changed = sqlx::query("UPDATE release_files SET size = $3, sha256 = $4 WHERE version = $1 AND path = $2 AND kind = $5")
                .bind(version)
                .bind(path)
                .bind(size)
                .bind(sha256)
                .bind(ReleaseFileKind::Archive)
                .execute(&mut *tx)
                .await?
                .rows_affected();
            if changed == 0 {
                return Err(StoreError::NotFound);
            }
            sqlx::query("UPDATE releases SET manifest = $2 WHERE version = $1").bind(version).bind(manifest).execute(&mut *tx).await?;
            tx.commit().await.map_err(StoreError::from)
        })
    }

    /// A public file of a release.
    pub async fn release_file(&self, version: &str, path: &str) -> StoreResult<ReleaseFile> {
        Ok(on_pool!(self, |pool| sqlx::query_as("SELECT version, path, size, sha256, kind FROM release_files WHERE version = $1 AND path = $2")
            .bind(version)
            .bind(path)
            .fetch_one(pool)
            .await)?)
    }
}
