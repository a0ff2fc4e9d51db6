//! Where a queued or scoring submission stands, and when its scoring is expected to end
//! (the service estimates it: `osmab::queue`).

use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

/// Where a queued or scoring submission stands (fields in the order of their keys).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
pub struct QueueView {
    /// Jobs a worker takes before this one (0 while it is being scored).
    pub ahead: i64,
    /// How many recent scorings the estimate is based on.
    pub based_on: usize,
    /// When scoring is expected to end; absent without measured scorings.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub estimated_done_at: Option<String>,
    /// When scoring is expected to start (queued only).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub estimated_start_at: Option<String>,
    /// The median duration of recent scorings, in seconds.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub median_scoring_seconds: Option<f64>,
    /// 1 is next (0 while it is being scored).
    pub position: i64,
}

impl QueueView {
    /// The standing in words, for the page and the client.
    pub fn sentence(&self) -> String {
        let place = match self.position {
            0 => "Being scored".to_string(),
            1 => "Next in the queue".to_string(),
            n => format!("Position {n} in the queue ({} {} ahead)", self.ahead, if self.ahead == 1 { "job" } else { "jobs" }),
        };
        match (&self.estimated_done_at, self.median_scoring_seconds) {
            (Some(done), Some(seconds)) => format!(
                "{place}; expected to finish around {} UTC ({})",
                done.get(..16).unwrap_or(done).replace('T', " "),
                match self.based_on {
                    1 => format!("the one scoring measured here took {seconds:.0} s"),
                    n => format!("the median of the last {n} scorings here: {seconds:.0} s"),
                }
            ),
            _ => format!("{place}; no estimate yet (no scoring measured on this server)"),
        }
    }
}
