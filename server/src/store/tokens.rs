//! API tokens: only their SHA-256 and a short hint are stored.

use super::{Store, StoreError, StoreResult, TokenRecord, on_pool};

/// The insert statement of token record `$token`, for either backend.
macro_rules! insert_token_query {
    ($token:expr) => {
        sqlx::query("INSERT INTO tokens (id, team_id, scope, sha256, hint, created_at, expires_at, revoked_at) VALUES ($1, $2, $3, $4, $5, $6, $7, $8)")
            .bind(&$token.id)
            .bind(&$token.team_id)
            .bind($token.scope)
            .bind(&$token.sha256)
            .bind(&$token.hint)
            .bind($token.created_at)
            .bind($token.expires_at)
            .bind($token.revoked_at)
    };
}

impl Store {
    /// Store a token record.
    pub async fn insert_token(&self, token: &TokenRecord) -> StoreResult<()> {
        on_pool!(self, |pool| insert_token_query!(token).execute(pool).await.map(|r| r.rows_affected()))?;
        Ok(())
    }

    /// The token whose SHA-256 is `sha256`.
    pub async fn token_by_hash(&self, sha256: &str) -> StoreResult<TokenRecord> {
        Ok(on_pool!(self, |pool| sqlx::query_as("SELECT id, team_id, scope, sha256, hint, created_at, expires_at, revoked_at FROM tokens WHERE sha256 = $1")
            .bind(sha256)
            .fetch_one(pool)
            .await)?)
    }

    /// Tokens of a team (or the admin tokens for `None`).
    pub async fn tokens(&self, team_id: Option<&str>) -> StoreResult<Vec<TokenRecord>> {
        Ok(match team_id {
            Some(team) => on_pool!(self, |pool| sqlx::query_as(
                "SELECT id, team_id, scope, sha256, hint, created_at, expires_at, revoked_at FROM tokens WHERE team_id = $1 ORDER BY created_at"
            )
            .bind(team)
            .fetch_all(pool)
            .await)?,
            None => on_pool!(self, |pool| sqlx::query_as(
                "SELECT id, team_id, scope, sha256, hint, created_at, expires_at, revoked_at FROM tokens WHERE scope = 'admin' ORDER BY created_at"
            )
            .fetch_all(pool)
            .await)?,
        })
    }

    /// Revoke token `id`; revoking twice keeps the first time.
    pub async fn revoke_token(&self, id: &str, at: i64) -> StoreResult<()> {
        let done = on_pool!(self, |pool| sqlx::query("UPDATE tokens SET revoked_at = COALESCE(revoked_at, $2) WHERE id = $1")
            .bind(id)
            .bind(at)
            .execute(pool)
            .await
            .map(|r| r.rows_affected()))?;
        if done == 0 { Err(StoreError::NotFound) } else { Ok(()) }
    }

    /// Put the configured admin token in place under the fixed id `id`, replacing the
    /// token an earlier configuration set (so changing the setting revokes the old one).
    pub async fn replace_token(&self, token: &TokenRecord) -> StoreResult<()> {
        on_pool!(self, |pool| {
            let mut tx = pool.begin().await?;
            sqlx::query("DELETE FROM tokens WHERE id = $1").bind(&token.id).execute(&mut *tx).await?;
            insert_token_query!(token).execute(&mut *tx).await?;
            tx.commit().await
        })?;
        Ok(())
    }
}
