//! Teams: created by admins, each with an optional daily quota.

use super::{Store, StoreError, StoreResult, Team, on_pool};

impl Store {
    /// Create a team.
    pub async fn create_team(&self, team: &Team) -> StoreResult<()> {
        on_pool!(self, |pool| sqlx::query("INSERT INTO teams (id, name, daily_quota, created_at) VALUES ($1, $2, $3, $4)")
            .bind(&team.id)
            .bind(&team.name)
            .bind(team.daily_quota)
            .bind(team.created_at)
            .execute(pool)
            .await
            .map(|r| r.rows_affected()))?;
        Ok(())
    }

    /// Every team, by name.
    pub async fn teams(&self) -> StoreResult<Vec<Team>> {
        Ok(on_pool!(self, |pool| sqlx::query_as("SELECT id, name, daily_quota, created_at FROM teams ORDER BY name").fetch_all(pool).await)?)
    }

    /// The team `id`.
    pub async fn team(&self, id: &str) -> StoreResult<Team> {
        Ok(on_pool!(self, |pool| sqlx::query_as("SELECT id, name, daily_quota, created_at FROM teams WHERE id = $1").bind(id).fetch_one(pool).await)?)
    }

    /// The team named `name`.
    pub async fn team_by_name(&self, name: &str) -> StoreResult<Team> {
        Ok(on_pool!(self, |pool| sqlx::query_as("SELECT id, name, daily_quota, created_at FROM teams WHERE name = $1").bind(name).fetch_one(pool).await)?)
    }

    /// Change a team's daily quota.
    pub async fn set_team_quota(&self, id: &str, quota: Option<i64>) -> StoreResult<()> {
        let done = on_pool!(self, |pool| sqlx::query("UPDATE teams SET daily_quota = $2 WHERE id = $1")
            .bind(id)
            .bind(quota)
            .execute(pool)
            .await
            .map(|r| r.rows_affected()))?;
        if done == 0 { Err(StoreError::NotFound) } else { Ok(()) }
    }
}
