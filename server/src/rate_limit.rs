//! A token bucket per client key (the middleware in `routes` decides the key: the team
//! or admin a write's token resolves to, else its address; failed authentications per
//! address). Successful reads are cheap and cached, so they are not limited.

use std::collections::HashMap;
use std::net::IpAddr;
use std::sync::Mutex;
use std::time::Instant;

use axum::http::HeaderMap;

use crate::proxies::TrustedProxies;

/// The bucket that failed authentications from `client` ([`client_of`]) share: wrong
/// tokens and console cookies that are no session alike.
pub fn failed_authentication(client: &str) -> String {
    format!("failed authentication from {client}")
}

/// The client a request counts against: the peer's address, or, when the peer is a trusted
/// proxy, the right-most address of `X-Forwarded-For` that is not one (each proxy appends
/// the address it saw; anything left of that was written by the client). Every loopback
/// address is one client, and an IPv6 client is its /64 (one host holds a whole /64).
pub fn client_of(headers: &HeaderMap, peer: Option<IpAddr>, trusted: &TrustedProxies) -> String {
    let Some(peer) = peer else {
        return "unknown".into();
    };
    if !trusted.contains(peer) {
        return address_key(peer);
    }
    let forwarded: Vec<&str> = headers.get_all("x-forwarded-for").iter().filter_map(|v| v.to_str().ok()).flat_map(|v| v.split(',')).collect();
    let mut client = peer;
    for hop in forwarded.iter().rev().map(|hop| hop.trim()) {
        match hop_address(hop) {
            Some(address) if trusted.contains(address) => client = address,
            Some(address) => return address_key(address),
            // A trusted proxy wrote what it saw, but not as an address ("unknown", an
            // obfuscated name): that text is the client, never the proxy itself.
            None => return format!("forwarded {}", hop.chars().take(64).collect::<String>()),
        }
    }
    address_key(client)
}

/// The address of one `X-Forwarded-For` entry: `1.2.3.4`, `1.2.3.4:5678`, `2001:db8::1` or
/// `[2001:db8::1]:443`.
fn hop_address(hop: &str) -> Option<IpAddr> {
    hop.parse::<IpAddr>()
        .ok()
        .or_else(|| hop.parse::<std::net::SocketAddr>().ok().map(|s| s.ip()))
        .or_else(|| hop.strip_prefix('[').and_then(|rest| rest.split_once(']')).and_then(|(address, _)| address.parse().ok()))
}

/// The rate-limit key of one address (see [`client_of`]).
fn address_key(address: IpAddr) -> String {
    let address = match address {
        IpAddr::V6(v6) => v6.to_ipv4_mapped().map_or(address, IpAddr::V4),
        v4 => v4,
    };
    match address {
        _ if address.is_loopback() => "loopback".into(),
        IpAddr::V4(v4) => v4.to_string(),
        IpAddr::V6(v6) => {
            let s = v6.segments();
            format!("{:x}:{:x}:{:x}:{:x}::/64", s[0], s[1], s[2], s[3])
        }
    }
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

    #[test]
    fn the_client_is_the_right_most_untrusted_forwarded_address_and_loopback_is_one() {
        let trusted = TrustedProxies::parse("10.0.0.0/8").unwrap();
        let headers =
            |xff: &str| -> HeaderMap { [(axum::http::header::HeaderName::from_static("x-forwarded-for"), xff.parse().unwrap())].into_iter().collect() };
        let proxy: Option<IpAddr> = Some("10.0.0.2".parse().unwrap());
        let forged = headers("1.2.3.4, 198.51.100.7, 10.0.0.9");
        assert_eq!(client_of(&forged, proxy, &trusted), "198.51.100.7", "what the client wrote left of its address is ignored");
        assert_eq!(client_of(&headers("junk, 198.51.100.7"), proxy, &trusted), "198.51.100.7");
        assert_eq!(client_of(&headers("198.51.100.7:5678"), proxy, &trusted), "198.51.100.7", "a port is not part of the client");
        assert_eq!(client_of(&headers("[2001:db8:1:2::5]:443"), proxy, &trusted), "2001:db8:1:2::/64");
        assert_eq!(client_of(&headers("unknown"), proxy, &trusted), "forwarded unknown", "never the proxy, which every client shares");
        assert_eq!(client_of(&forged, Some("203.0.113.5".parse().unwrap()), &trusted), "203.0.113.5", "a stranger's header counts for nothing");
        assert_eq!(client_of(&HeaderMap::new(), proxy, &trusted), "10.0.0.2", "a proxy that forwards nothing is the client");
        for alias in ["127.0.0.1", "127.0.0.2", "127.9.9.9", "::1", "::ffff:127.0.0.5"] {
            assert_eq!(client_of(&HeaderMap::new(), Some(alias.parse().unwrap()), &trusted), "loopback", "{alias}");
        }
        assert_eq!(client_of(&HeaderMap::new(), Some("2001:db8:1:2:aaaa::1".parse().unwrap()), &trusted), "2001:db8:1:2::/64");
        assert_eq!(client_of(&HeaderMap::new(), Some("2001:db8:1:2:bbbb::9".parse().unwrap()), &trusted), "2001:db8:1:2::/64");
    }
}
