//! Resumable uploads (tus): one row per upload; its parts are listed in the row and
//! appended in the statement that moves its offset.

use super::{Store, StoreError, StoreResult, on_pool};

/// A resumable upload as stored.
#[derive(Debug, Clone, PartialEq, Eq, sqlx::FromRow)]
pub struct UploadRecord {
    pub id: String,
    pub team_id: String,
    /// The declared length in bytes.
    pub length: i64,
    /// Bytes received so far.
    pub upload_offset: i64,
    /// The client's `Upload-Metadata`, as sent.
    pub metadata: String,
    /// One line `OFFSET LENGTH BLOB-KEY` per part, in order.
    pub parts: String,
    pub created_at: i64,
    pub expires_at: i64,
    /// The submission the upload became.
    pub submission_id: Option<String>,
}

/// One received part of an upload.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct UploadPart {
    pub offset: i64,
    pub length: i64,
    pub key: String,
}

impl UploadRecord {
    /// Its parts in order (a line that does not read is a defect, reported as such).
    pub fn parts(&self) -> Result<Vec<UploadPart>, String> {
        self.parts
            .lines()
            .filter(|l| !l.is_empty())
            .map(|line| {
                let mut fields = line.splitn(3, ' ');
                let (Some(offset), Some(length), Some(key)) = (fields.next(), fields.next(), fields.next()) else {
                    return Err(format!("upload {}: part line '{line}' is not OFFSET LENGTH KEY", self.id));
                };
                let number = |text: &str| text.parse::<i64>().map_err(|_| format!("upload {}: '{text}' in part line '{line}' is not a number", self.id));
                Ok(UploadPart { offset: number(offset)?, length: number(length)?, key: key.to_string() })
            })
            .collect()
    }
}

/// What a team may hold open at once: resumable uploads not yet a submission and not expired.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct OpenUploadLimits {
    /// Open uploads at most.
    pub uploads: i64,
    /// Their declared lengths summed at most.
    pub bytes: i64,
}

/// A team's open uploads, counted when a new one was refused (the new one not included).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct OpenUploads {
    pub uploads: i64,
    pub bytes: i64,
}

const COLUMNS: &str = "id, team_id, length, upload_offset, metadata, parts, created_at, expires_at, submission_id";

impl Store {
    /// Record a new upload unless its team would then hold more open uploads, or more bytes
    /// of them, than `limits` allow (counted inside the transaction after a lock on the team,
    /// so parallel requests on any node cannot overrun it); `Err` carries what the team holds.
    pub async fn insert_upload_within(&self, upload: &UploadRecord, limits: OpenUploadLimits, now: i64) -> StoreResult<Result<(), OpenUploads>> {
        let postgres = matches!(self, Store::Postgres(_));
        on_pool!(self, |pool| {
            let mut tx = pool.begin().await?;
            if postgres {
                // Serialise a team's concurrent uploads (SQLite serialises every writer already).
                sqlx::query("SELECT id FROM teams WHERE id = $1 FOR UPDATE").bind(&upload.team_id).execute(&mut *tx).await?;
            }
            // The insert first: on SQLite a transaction that reads before it writes cannot
            // wait for another writer.
            sqlx::query(
                "INSERT INTO uploads (id, team_id, length, upload_offset, metadata, parts, created_at, expires_at, submission_id) VALUES ($1, $2, $3, $4, $5, $6, $7, $8, $9)",
            )
            .bind(&upload.id)
            .bind(&upload.team_id)
            .bind(upload.length)
            .bind(upload.upload_offset)
            .bind(&upload.metadata)
            .bind(&upload.parts)
            .bind(upload.created_at)
            .bind(upload.expires_at)
            .bind(&upload.submission_id)
            .execute(&mut *tx)
            .await?;
            let (uploads, bytes): (i64, i64) = sqlx::query_as(
                "SELECT COUNT(*), CAST(COALESCE(SUM(length), 0) AS BIGINT) FROM uploads WHERE team_id = $1 AND submission_id IS NULL AND expires_at >= $2",
            )
            .bind(&upload.team_id)
            .bind(now)
            .fetch_one(&mut *tx)
            .await?;
            if uploads > limits.uploads || bytes > limits.bytes {
                tx.rollback().await?;
                return Ok(Err(OpenUploads { uploads: uploads - 1, bytes: bytes - upload.length }));
            }
            tx.commit().await?;
            Ok(Ok(()))
        })
    }

    /// Upload `id`.
    pub async fn upload(&self, id: &str) -> StoreResult<UploadRecord> {
        let sql = format!("SELECT {COLUMNS} FROM uploads WHERE id = $1");
        Ok(on_pool!(self, |pool| sqlx::query_as(sqlx::AssertSqlSafe(sql.as_str())).bind(id).fetch_one(pool).await)?)
    }

    /// Append `part` (received at the upload's offset `part.offset`) and move the offset
    /// past it, keeping the upload until `expires_at`; `false` when the offset moved
    /// meanwhile (another request appended first) or the upload is gone.
    pub async fn append_upload_part(&self, id: &str, part: &UploadPart, expires_at: i64) -> StoreResult<bool> {
        let line = format!("{} {} {}\n", part.offset, part.length, part.key);
        let done = on_pool!(self, |pool| sqlx::query(
            "UPDATE uploads SET upload_offset = upload_offset + $3, parts = parts || $4, expires_at = $5 \
             WHERE id = $1 AND upload_offset = $2 AND upload_offset + $3 <= length AND submission_id IS NULL"
        )
        .bind(id)
        .bind(part.offset)
        .bind(part.length)
        .bind(&line)
        .bind(expires_at)
        .execute(pool)
        .await
        .map(|r| r.rows_affected()))?;
        Ok(done == 1)
    }

    /// Record that upload `id` became `submission_id` (kept so a repeated request answers
    /// with it).
    pub async fn finish_upload(&self, id: &str, submission_id: &str) -> StoreResult<()> {
        let done = on_pool!(self, |pool| sqlx::query("UPDATE uploads SET submission_id = $2, parts = '' WHERE id = $1")
            .bind(id)
            .bind(submission_id)
            .execute(pool)
            .await
            .map(|r| r.rows_affected()))?;
        if done == 0 { Err(StoreError::NotFound) } else { Ok(()) }
    }

    /// Forget upload `id`.
    pub async fn delete_upload(&self, id: &str) -> StoreResult<()> {
        on_pool!(self, |pool| sqlx::query("DELETE FROM uploads WHERE id = $1").bind(id).execute(pool).await.map(|_| ()))?;
        Ok(())
    }

    /// Uploads whose time ran out before `now`, at most `limit`.
    pub async fn expired_uploads(&self, now: i64, limit: i64) -> StoreResult<Vec<String>> {
        let rows: Vec<(String,)> = on_pool!(self, |pool| sqlx::query_as("SELECT id FROM uploads WHERE expires_at < $1 ORDER BY expires_at LIMIT $2")
            .bind(now)
            .bind(limit)
            .fetch_all(pool)
            .await)?;
        Ok(rows.into_iter().map(|(id,)| id).collect())
    }
}
