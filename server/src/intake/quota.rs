//! A team's submission quota: how many submissions it may make per UTC day, how many it
//! made today, and when the count starts over. Baselines and dry runs never count.

use serde::Serialize;

use crate::clock::{next_utc_day, now_ms, rfc3339, utc_day_start};
use crate::state::AppState;
use crate::store::{StoreResult, Team};

/// The quota of a team at one moment.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Quota {
    /// Submissions per UTC day.
    pub limit: i64,
    /// Submissions made since the day began.
    pub used: i64,
    /// When the day ends (ms since the epoch).
    pub resets_at: i64,
}

/// The quota as the API shows it (fields in the order of their keys).
#[derive(Debug, Clone, Serialize, schemars::JsonSchema)]
pub struct QuotaView {
    pub limit: i64,
    pub remaining: i64,
    pub resets_at: String,
    pub used: i64,
}

impl Quota {
    /// The quota of `team` now.
    pub async fn of(state: &AppState, team: &Team) -> StoreResult<Quota> {
        let now = now_ms();
        let limit = team.daily_quota.unwrap_or(state.settings.daily_quota);
        let used = state.store.submissions_since(&team.id, utc_day_start(now)).await?;
        Ok(Quota { limit, used, resets_at: next_utc_day(now) })
    }

    /// Whether it is used up.
    pub fn exhausted(&self) -> bool {
        self.used >= self.limit
    }

    /// The start of the day it counts (what the store counts from).
    pub fn day_start(&self) -> i64 {
        utc_day_start(self.resets_at - 1)
    }

    /// The same quota with one more submission used.
    pub fn after_one(self) -> Quota {
        Quota { used: self.used + 1, ..self }
    }

    pub fn view(&self) -> QuotaView {
        QuotaView { limit: self.limit, remaining: (self.limit - self.used).max(0), resets_at: rfc3339(self.resets_at), used: self.used }
    }
}
