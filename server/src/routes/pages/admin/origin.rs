//! Where the console's page was served from, as the browser saw it: the hosts a form may
//! come from and whether the connection was HTTPS. `X-Forwarded-Host` and
//! `X-Forwarded-Proto` count only from a proxy the operator trusts (`OSMAB_TRUSTED_PROXIES`);
//! from anyone else they are words a client wrote.

use std::net::IpAddr;

use axum::extract::FromRequestParts;
use axum::http::request::Parts;
use axum::http::{HeaderMap, header};

use crate::config::Settings;
use crate::state::AppState;

#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct PageOrigin {
    /// `host[:port]` values a form's `Origin` may name: the request's Host, a trusted proxy's
    /// forwarded host, the configured public URL's.
    pub hosts: Vec<String>,
    /// A trusted proxy says the browser's connection was HTTPS.
    pub https: bool,
}

impl PageOrigin {
    /// The origin of a request with `headers` from `peer`.
    pub fn of(headers: &HeaderMap, peer: Option<IpAddr>, settings: &Settings) -> Self {
        let text = |name: &str| headers.get(name).and_then(|v| v.to_str().ok()).map(|v| v.trim().to_string());
        // A forwarded header's value is the one the trusted proxy added: the last of its
        // lines, and the last of that line's comma-separated values (what comes before was
        // written by the client, or by a proxy the client chose).
        let forwarded = |name: &str| {
            headers.get_all(name).iter().filter_map(|v| v.to_str().ok()).next_back().and_then(|v| v.rsplit(',').next()).map(|v| v.trim().to_string())
        };
        let trusted = peer.is_some_and(|peer| settings.trusted_proxies.contains(peer));
        let mut hosts: Vec<String> = text(header::HOST.as_str()).into_iter().collect();
        if trusted {
            hosts.extend(forwarded("x-forwarded-host"));
        }
        if let Some(public) = &settings.public_url {
            hosts.extend(public.split_once("://").map(|(_, host)| host.to_string()));
        }
        hosts.retain(|h| !h.is_empty());
        let https = trusted && forwarded("x-forwarded-proto").is_some_and(|p| p.eq_ignore_ascii_case("https"));
        Self { hosts, https }
    }

    /// Whether a form whose `Origin` header is `origin` comes from this page's host.
    pub fn admits(&self, origin: &str) -> bool {
        origin.split_once("://").is_some_and(|(_, rest)| self.hosts.iter().any(|host| rest == host))
    }
}

impl FromRequestParts<AppState> for PageOrigin {
    type Rejection = std::convert::Infallible;

    async fn from_request_parts(parts: &mut Parts, state: &AppState) -> Result<Self, Self::Rejection> {
        Ok(Self::of(&parts.headers, crate::http::peer_ip(&parts.extensions), &state.settings))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn settings(trusted: &str, public_url: Option<&str>) -> Settings {
        let mut settings = Settings::load_from(None, &|_| None).unwrap();
        settings.trusted_proxies = crate::proxies::TrustedProxies::parse(trusted).unwrap();
        settings.public_url = public_url.map(str::to_string);
        settings
    }

    fn headers(pairs: &[(&'static str, &str)]) -> HeaderMap {
        pairs.iter().map(|(k, v)| (header::HeaderName::from_static(k), v.parse().unwrap())).collect()
    }

    #[test]
    fn forwarded_headers_count_only_from_trusted_proxies() {
        let forwarded = headers(&[("host", "10.0.0.5:8080"), ("x-forwarded-host", "evil.example"), ("x-forwarded-proto", "https")]);
        let stranger = PageOrigin::of(&forwarded, Some("203.0.113.9".parse().unwrap()), &settings("10.0.0.0/8", None));
        assert_eq!(stranger, PageOrigin { hosts: vec!["10.0.0.5:8080".into()], https: false }, "a client's own X-Forwarded-* is ignored");
        assert!(!stranger.admits("https://evil.example"));
        let proxy = PageOrigin::of(&forwarded, Some("10.1.2.3".parse().unwrap()), &settings("10.0.0.0/8", None));
        assert_eq!(proxy, PageOrigin { hosts: vec!["10.0.0.5:8080".into(), "evil.example".into()], https: true });
        let chained = headers(&[("host", "10.0.0.5:8080"), ("x-forwarded-host", "evil.example, osmab.example.org"), ("x-forwarded-proto", "http, https")]);
        let proxy_added = PageOrigin::of(&chained, Some("10.1.2.3".parse().unwrap()), &settings("10.0.0.0/8", None));
        assert_eq!(
            proxy_added,
            PageOrigin { hosts: vec!["10.0.0.5:8080".into(), "osmab.example.org".into()], https: true },
            "the value the proxy added: the last"
        );
        assert!(!proxy_added.admits("https://evil.example"));
        let public = PageOrigin::of(&headers(&[("host", "10.0.0.5:8080")]), None, &settings("", Some("https://bench.example")));
        assert!(public.admits("https://bench.example") && public.admits("http://10.0.0.5:8080") && !public.admits("https://other.example"));
    }
}
