//! A team's submission quota per split: how many submissions it may make to the split in
//! a rolling window, how many it made in the window, and when the next one becomes
//! possible. The limit is the administrator's policy for the split (or the service's
//! default: `OSMAB_DAILY_QUOTA` for test, `OSMAB_VAL_QUOTA` for val, per 24 hours); a team
//! with a limit of its own uses it for every split. Baselines, dry runs and refunded
//! submissions never count.

pub use osmab_api::account::QuotaView;
use osmab_evaluator::scores::Split;

use crate::clock::{now_ms, rfc3339};
use crate::state::AppState;
use crate::store::{QuotaPolicyRecord, StoreResult, Team};

/// The window of the service's default policies.
pub const DEFAULT_WINDOW_SECS: i64 = 24 * 3600;

/// How many submissions to a split a team may make per window.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Policy {
    pub limit: i64,
    pub window_secs: i64,
}

impl Policy {
    /// The policy of `split`: the administrator's, else the service's default.
    pub async fn of(state: &AppState, split: Split) -> StoreResult<Policy> {
        let set = state.store.quota_policies().await?.into_iter().find(|p| p.split == split);
        Ok(match set {
            Some(QuotaPolicyRecord { max_submissions, window_secs, .. }) => Policy { limit: max_submissions, window_secs },
            None => Policy { limit: Self::default_limit(state, split), window_secs: DEFAULT_WINDOW_SECS },
        })
    }

    fn default_limit(state: &AppState, split: Split) -> i64 {
        match split {
            Split::Test => state.settings.daily_quota,
            Split::Val => state.settings.val_quota,
        }
    }
}

/// The quota of a team for one split at one moment.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Quota {
    pub split: Split,
    /// Submissions per window.
    pub limit: i64,
    pub window_secs: i64,
    /// When the counted submissions were made (within the window), oldest first.
    pub counted: Vec<i64>,
    /// The moment this quota was read (ms since the epoch).
    pub at: i64,
}

impl Quota {
    /// The quota of `team` for `split` now.
    pub async fn of(state: &AppState, team: &Team, split: Split) -> StoreResult<Quota> {
        let at = now_ms();
        let policy = Policy::of(state, split).await?;
        let limit = team.daily_quota.unwrap_or(policy.limit);
        let counted = state.store.submissions_since(&team.id, split, at - policy.window_secs * 1000).await?;
        Ok(Quota { split, limit, window_secs: policy.window_secs, counted, at })
    }

    /// The quota to refuse an upload with before its body is read, if any: the named
    /// split's when used up; with no split named (it is known only once the archive names
    /// its release), the default split's when every split is used up.
    pub async fn refusal_before_upload(state: &AppState, team: &Team, split: Option<Split>, default: Split) -> StoreResult<Option<Quota>> {
        if let Some(split) = split {
            let quota = Quota::of(state, team, split).await?;
            return Ok(quota.exhausted().then_some(quota));
        }
        for split in Split::ALL {
            if !Quota::of(state, team, split).await?.exhausted() {
                return Ok(None);
            }
        }
        Ok(Some(Quota::of(state, team, default).await?))
    }

    /// Submissions counted in the window.
    pub fn used(&self) -> i64 {
        self.counted.len() as i64
    }

    /// Whether it is used up.
    pub fn exhausted(&self) -> bool {
        self.used() >= self.limit
    }

    /// The start of the window it counts (what the store counts from).
    pub fn window_start(&self) -> i64 {
        self.at - self.window_secs * 1000
    }

    /// When the next submission is possible, while the quota is used up: the first
    /// millisecond at which enough counted submissions have left the window (which counts
    /// its first millisecond; `None` with a limit of 0: never).
    pub fn next_at(&self) -> Option<i64> {
        if !self.exhausted() || self.limit <= 0 {
            return None;
        }
        let freeing = (self.used() - self.limit) as usize;
        self.counted.get(freeing).map(|made| made + self.window_secs * 1000 + 1)
    }

    /// The same quota with one more submission used (now).
    pub fn after_one(mut self) -> Quota {
        self.counted.push(self.at);
        self
    }

    pub fn view(&self) -> QuotaView {
        QuotaView {
            limit: self.limit,
            next_at: self.next_at().map(rfc3339),
            remaining: (self.limit - self.used()).max(0),
            resets_at: self.counted.first().map(|made| rfc3339(made + self.window_secs * 1000 + 1)),
            split: self.split,
            used: self.used(),
            window_hours: self.window_secs as f64 / 3600.0,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn quota(limit: i64, counted: &[i64]) -> Quota {
        Quota { split: Split::Test, limit, window_secs: 3600, counted: counted.to_vec(), at: 10_000_000 }
    }

    #[test]
    fn the_next_submission_waits_for_enough_counted_ones_to_leave_the_window() {
        let open = quota(3, &[9_000_000, 9_500_000]);
        assert!(!open.exhausted() && open.next_at().is_none());
        assert_eq!(open.view().remaining, 1);
        let full = open.clone().after_one();
        assert!(full.exhausted());
        assert_eq!(full.next_at(), Some(9_000_000 + 3_600_000 + 1), "the millisecond after the oldest's last in the window");
        // A limit lowered below the count: the next one waits for two to leave.
        let lowered = quota(1, &[9_000_000, 9_500_000]);
        assert_eq!(lowered.next_at(), Some(9_500_000 + 3_600_000 + 1));
        assert_eq!(quota(0, &[]).next_at(), None, "a limit of 0 never opens");
        let view = full.view();
        assert_eq!((view.used, view.remaining, view.window_hours, view.split), (3, 0, 1.0, Split::Test));
        assert!(view.next_at.is_some() && view.resets_at.is_some());
    }
}
