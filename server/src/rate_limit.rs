//! A token bucket per client key (the middleware in `routes` decides the key: the team
//! or admin a write's token resolves to, else its address; failed authentications per
//! address). Successful reads are cheap and cached, so they are not limited.

use std::collections::HashMap;
use std::sync::Mutex;
use std::time::Instant;

/// The bucket that failed authentications from `address` share: wrong tokens and console
/// cookies that are no session alike.
pub fn failed_authentication(address: Option<std::net::IpAddr>) -> String {
    format!("failed authentication from {}", address.map_or_else(|| "unknown".to_string(), |a| a.to_string()))
}

/// Token buckets keyed by client.
#[derive(Debug)]
pub struct RateLimiter {
    per_second: f64,
    burst: f64,
    buckets: Mutex<HashMap<String, (f64, Instant)>>,
}

impl RateLimiter {
    /// `per_second` sustained with bursts of `burst`; a rate of 0 admits everything.
    pub fn new(per_second: f64, burst: f64) -> Self {
        Self { per_second, burst, buckets: Mutex::new(HashMap::new()) }
    }

    /// Take one token for `client`; `Err(seconds)` says when the next one is due.
    pub fn admit(&self, client: String, now: Instant) -> Result<(), u64> {
        if self.per_second <= 0.0 {
            return Ok(());
        }
        let mut buckets = self.buckets.lock().expect("rate limiter lock");
        if buckets.len() > 100_000 && !buckets.contains_key(&client) {
            // Forget full buckets so many distinct clients cannot grow the map without bound.
            buckets.retain(|_, (tokens, at)| *tokens + now.duration_since(*at).as_secs_f64() * self.per_second < self.burst);
        }
        let (tokens, at) = buckets.entry(client).or_insert((self.burst, now));
        *tokens = (*tokens + now.duration_since(*at).as_secs_f64() * self.per_second).min(self.burst);
        *at = now;
        if *tokens >= 1.0 {
            *tokens -= 1.0;
            Ok(())
        } else {
            Err(((1.0 - *tokens) / self.per_second).ceil().max(1.0) as u64)
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::time::Duration;

    #[test]
    fn a_burst_is_admitted_then_refused_until_tokens_return() {
        let limiter = RateLimiter::new(2.0, 3.0);
        let client = || "127.0.0.1".to_string();
        let t0 = Instant::now();
        for _ in 0..3 {
            assert!(limiter.admit(client(), t0).is_ok());
        }
        assert_eq!(limiter.admit(client(), t0), Err(1));
        assert!(limiter.admit(client(), t0 + Duration::from_millis(600)).is_ok());
        assert!(limiter.admit("10.0.0.1".into(), t0).is_ok());
    }
}
