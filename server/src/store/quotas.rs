//! The administrator's quota policies: per split, how many submissions a team may make
//! in a rolling window. A split without a policy uses the service's defaults.

use osmab_evaluator::scores::Split;

use super::{Store, StoreResult, on_pool};

/// An administrator's limit for one split.
#[derive(Debug, Clone, PartialEq, Eq, sqlx::FromRow)]
pub struct QuotaPolicyRecord {
    #[sqlx(try_from = "String")]
    pub split: Split,
    pub max_submissions: i64,
    pub window_secs: i64,
    pub updated_at: i64,
}

impl Store {
    /// Every policy an administrator set, by split.
    pub async fn quota_policies(&self) -> StoreResult<Vec<QuotaPolicyRecord>> {
        Ok(on_pool!(self, |pool| sqlx::query_as("SELECT split, max_submissions, window_secs, updated_at FROM quota_policies ORDER BY split")
            .fetch_all(pool)
            .await)?)
    }

    /// Set the policy of a split (replacing the one before).
    pub async fn set_quota_policy(&self, policy: &QuotaPolicyRecord) -> StoreResult<()> {
        on_pool!(self, |pool| sqlx::query(
            "INSERT INTO quota_policies (split, max_submissions, window_secs, updated_at) VALUES ($1, $2, $3, $4) \
             ON CONFLICT (split) DO UPDATE SET max_submissions = $2, window_secs = $3, updated_at = $4"
        )
        .bind(policy.split.name())
        .bind(policy.max_submissions)
        .bind(policy.window_secs)
        .bind(policy.updated_at)
        .execute(pool)
        .await
        .map(|_| ()))?;
        Ok(())
    }
}
