//! Queue transparency: where a submission stands and when its scoring is expected to end,
//! estimated from how long recent scorings took (their median), how many jobs a worker
//! takes before it, and how many workers are busy. An estimate, said as one: without
//! measured scorings there is none.

pub use osmab_api::queue::QueueView;

use crate::clock::rfc3339;
use crate::store::Standing;

/// Recent scorings the estimate is based on, at most.
pub const HISTORY: i64 = 50;

/// The median of `durations` (ms), if any.
fn median(durations: &[i64]) -> Option<i64> {
    let mut sorted = durations.to_vec();
    sorted.sort_unstable();
    let n = sorted.len();
    (n > 0).then(|| if n % 2 == 1 { sorted[n / 2] } else { (sorted[n / 2 - 1] + sorted[n / 2]) / 2 })
}

/// A queued submission's view: it starts once the jobs ahead and the running ones are
/// done, shared among the busy workers (at least one), the running ones half done on average.
pub fn queued(standing: Standing, durations: &[i64], now: i64) -> QueueView {
    let typical = median(durations);
    let workers = standing.busy_workers.max(1) as f64;
    let start = typical.map(|d| now + ((standing.ahead as f64 + standing.running as f64 * 0.5) / workers * d as f64).round() as i64);
    QueueView {
        ahead: standing.ahead,
        based_on: durations.len(),
        estimated_done_at: start.zip(typical).map(|(s, d)| rfc3339(s + d)),
        estimated_start_at: start.map(rfc3339),
        median_scoring_seconds: typical.map(|d| d as f64 / 1000.0),
        position: standing.ahead + 1,
    }
}

/// A submission being scored since `since`: expected to end a typical duration after it
/// started (or now, when it already takes longer than that).
pub fn scoring(since: i64, durations: &[i64], now: i64) -> QueueView {
    let typical = median(durations);
    QueueView {
        ahead: 0,
        based_on: durations.len(),
        estimated_done_at: typical.map(|d| rfc3339((since + d).max(now))),
        estimated_start_at: None,
        median_scoring_seconds: typical.map(|d| d as f64 / 1000.0),
        position: 0,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const NOW: i64 = 1_700_000_000_000;

    #[test]
    fn without_measured_scorings_there_is_a_position_but_no_estimate() {
        let view = queued(Standing { ahead: 2, running: 1, busy_workers: 1 }, &[], NOW);
        assert_eq!((view.position, view.ahead, view.based_on), (3, 2, 0));
        assert_eq!((view.estimated_start_at, view.estimated_done_at, view.median_scoring_seconds), (None, None, None));
    }

    #[test]
    fn the_estimate_waits_for_the_jobs_ahead_shared_among_busy_workers() {
        // Median of 10, 20, 30 s is 20 s; two ahead and one running (half done) on two workers.
        let view = queued(Standing { ahead: 2, running: 1, busy_workers: 2 }, &[30_000, 10_000, 20_000], NOW);
        assert_eq!(view.median_scoring_seconds, Some(20.0));
        assert_eq!(view.estimated_start_at.as_deref(), Some(rfc3339(NOW + 25_000).as_str()), "(2 + 0.5) / 2 × 20 s");
        assert_eq!(view.estimated_done_at.as_deref(), Some(rfc3339(NOW + 45_000).as_str()));
        let next = queued(Standing::default(), &[20_000, 40_000], NOW);
        assert_eq!((next.position, next.estimated_start_at.as_deref()), (1, Some(rfc3339(NOW).as_str())), "next with nothing running starts now");
        assert_eq!(next.median_scoring_seconds, Some(30.0), "an even count takes the middle two");
    }

    #[test]
    fn a_scoring_submission_ends_a_typical_duration_after_it_started_or_any_moment() {
        assert_eq!(scoring(NOW - 5_000, &[20_000], NOW).estimated_done_at.as_deref(), Some(rfc3339(NOW + 15_000).as_str()));
        assert_eq!(scoring(NOW - 60_000, &[20_000], NOW).estimated_done_at.as_deref(), Some(rfc3339(NOW).as_str()), "overdue: now");
        assert_eq!(scoring(NOW, &[], NOW).position, 0);
    }

    #[test]
    fn the_standing_reads_as_a_sentence() {
        let view = queued(Standing { ahead: 1, running: 0, busy_workers: 1 }, &[20_000], NOW);
        let done = rfc3339(NOW + 40_000);
        assert_eq!(
            view.sentence(),
            format!(
                "Position 2 in the queue (1 job ahead); expected to finish around {} UTC (the one scoring measured here took 20 s)",
                done[..16].replace('T', " ")
            )
        );
        assert_eq!(queued(Standing::default(), &[], NOW).sentence(), "Next in the queue; no estimate yet (no scoring measured on this server)");
        assert!(queued(Standing::default(), &[20_000, 40_000], NOW).sentence().ends_with("(the median of the last 2 scorings here: 30 s)"));
    }
}
