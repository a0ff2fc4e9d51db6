//! Requests for access from the "Take part" page (see `crate::access_requests`).

use super::{AccessRequestState, Store, StoreError, StoreResult, on_pool};

/// One request for access, as stored (the claim code only as its SHA-256).
#[derive(Debug, Clone, PartialEq, Eq, sqlx::FromRow)]
pub struct AccessRequestRecord {
    pub id: String,
    pub team_name: String,
    pub contact: String,
    pub affiliation: String,
    pub method_url: Option<String>,
    pub claim_sha256: String,
    pub client: String,
    pub state: AccessRequestState,
    pub reason: Option<String>,
    pub team_id: Option<String>,
    pub created_at: i64,
    pub decided_at: Option<i64>,
    pub collected_at: Option<i64>,
}

/// The columns, in [`AccessRequestRecord`]'s order (a macro, so statements stay literals).
macro_rules! columns {
    () => {
        "id, team_name, contact, affiliation, method_url, claim_sha256, client, state, reason, team_id, created_at, decided_at, collected_at"
    };
}

impl Store {
    /// Record a new pending request, unless `client` already holds `per_client` pending ones
    /// or the service `in_all` (checked in the same statement, so parallel requests cannot
    /// overrun either); `Ok(false)` when refused for that.
    pub async fn insert_access_request(&self, request: &AccessRequestRecord, per_client: i64, in_all: i64) -> StoreResult<bool> {
        const SQL: &str = concat!(
            "INSERT INTO access_requests (",
            columns!(),
            ") SELECT $1, $2, $3, $4, $5, $6, $7, $8, $9, $10, $11, $12, $13 ",
            "WHERE (SELECT COUNT(*) FROM access_requests WHERE state = $16 AND client = $7) < $14 ",
            "AND (SELECT COUNT(*) FROM access_requests WHERE state = $16) < $15"
        );
        let inserted = on_pool!(self, |pool| sqlx::query(SQL)
            .bind(&request.id)
            .bind(&request.team_name)
            .bind(&request.contact)
            .bind(&request.affiliation)
            .bind(&request.method_url)
            .bind(&request.claim_sha256)
            .bind(&request.client)
            .bind(request.state)
            .bind(&request.reason)
            .bind(&request.team_id)
            .bind(request.created_at)
            .bind(request.decided_at)
            .bind(request.collected_at)
            .bind(per_client)
            .bind(in_all)
            .bind(AccessRequestState::Pending)
            .execute(pool)
            .await
            .map(|r| r.rows_affected()))?;
        Ok(inserted == 1)
    }

    /// Requests in `state` (every state when `None`), oldest first.
    pub async fn access_requests(&self, state: Option<AccessRequestState>) -> StoreResult<Vec<AccessRequestRecord>> {
        const SQL: &str = concat!("SELECT ", columns!(), " FROM access_requests WHERE ($1 IS NULL OR state = $1) ORDER BY created_at, id");
        Ok(on_pool!(self, |pool| sqlx::query_as(SQL).bind(state.map(AccessRequestState::name)).fetch_all(pool).await)?)
    }

    /// The request `id`.
    pub async fn access_request(&self, id: &str) -> StoreResult<AccessRequestRecord> {
        const SQL: &str = concat!("SELECT ", columns!(), " FROM access_requests WHERE id = $1");
        Ok(on_pool!(self, |pool| sqlx::query_as(SQL).bind(id).fetch_one(pool).await)?)
    }

    /// The request whose claim code hashes to `claim_sha256`.
    pub async fn access_request_by_claim(&self, claim_sha256: &str) -> StoreResult<AccessRequestRecord> {
        const SQL: &str = concat!("SELECT ", columns!(), " FROM access_requests WHERE claim_sha256 = $1");
        Ok(on_pool!(self, |pool| sqlx::query_as(SQL).bind(claim_sha256).fetch_one(pool).await)?)
    }

    /// Move request `id` from `from` to `to` (with `reason`, `team_id` and the time it
    /// happened, as the step records them); `Err(Conflict)` when it is no longer in `from`
    /// (another operator or collection came first).
    pub async fn advance_access_request(
        &self,
        id: &str,
        from: AccessRequestState,
        to: AccessRequestState,
        reason: Option<&str>,
        team_id: Option<&str>,
        at: i64,
    ) -> StoreResult<()> {
        let sql = if to == AccessRequestState::Collected {
            "UPDATE access_requests SET state = $3, reason = COALESCE($4, reason), team_id = COALESCE($5, team_id), collected_at = $6 WHERE id = $1 AND state = $2"
        } else {
            "UPDATE access_requests SET state = $3, reason = COALESCE($4, reason), team_id = COALESCE($5, team_id), decided_at = $6 WHERE id = $1 AND state = $2"
        };
        let done = on_pool!(self, |pool| sqlx::query(sql)
            .bind(id)
            .bind(from)
            .bind(to)
            .bind(reason)
            .bind(team_id)
            .bind(at)
            .execute(pool)
            .await
            .map(|r| r.rows_affected()))?;
        if done == 1 {
            return Ok(());
        }
        match self.access_request(id).await {
            Ok(now) => Err(StoreError::Conflict(format!("access request {id} is {}, not {from}", now.state))),
            Err(e) => Err(e),
        }
    }
}
