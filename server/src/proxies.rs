//! The reverse proxies the operator trusts with `X-Forwarded-*` headers
//! (`OSMAB_TRUSTED_PROXIES`): addresses or networks in CIDR notation. A forwarded header from
//! any other peer is something a client wrote and is ignored.

use std::net::IpAddr;

/// Addresses and networks (`10.0.0.0/8`, `127.0.0.1`, `fd00::/8`) whose forwarded headers count.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct TrustedProxies(Vec<(IpAddr, u8)>);

impl TrustedProxies {
    /// Comma-separated entries, or why one is not an address or network.
    pub fn parse(text: &str) -> anyhow::Result<Self> {
        Self::from_entries(text.split(',').map(str::trim).filter(|e| !e.is_empty()))
    }

    /// The list `entries`, each an address or network.
    pub fn from_entries<'a>(entries: impl IntoIterator<Item = &'a str>) -> anyhow::Result<Self> {
        let mut networks = Vec::new();
        for entry in entries {
            let (address, prefix) = entry.split_once('/').map_or((entry, None), |(a, p)| (a, Some(p)));
            let address: IpAddr =
                address.parse().map_err(|_| anyhow::anyhow!("OSMAB_TRUSTED_PROXIES: '{entry}' is not an IP address or a network such as 10.0.0.0/8"))?;
            let bits = if address.is_ipv4() { 32 } else { 128 };
            let prefix = match prefix {
                None => bits,
                Some(p) => p
                    .parse::<u8>()
                    .ok()
                    .filter(|p| *p <= bits)
                    .ok_or_else(|| anyhow::anyhow!("OSMAB_TRUSTED_PROXIES: '{entry}': the prefix length must be 0 to {bits}"))?,
            };
            networks.push((address, prefix));
        }
        Ok(Self(networks))
    }

    /// Whether `peer` is one of the trusted proxies.
    pub fn contains(&self, peer: IpAddr) -> bool {
        let peer = canonical(peer);
        self.0.iter().any(|&(network, prefix)| match (canonical(network), peer) {
            (IpAddr::V4(n), IpAddr::V4(p)) => prefix_matches(&n.octets(), &p.octets(), prefix),
            (IpAddr::V6(n), IpAddr::V6(p)) => prefix_matches(&n.octets(), &p.octets(), prefix),
            _ => false,
        })
    }
}

/// An IPv4 address mapped into IPv6 (`::ffff:10.0.0.1`, how a dual-stack socket reports an
/// IPv4 peer) as the IPv4 address.
fn canonical(address: IpAddr) -> IpAddr {
    match address {
        IpAddr::V6(v6) => v6.to_ipv4_mapped().map_or(address, IpAddr::V4),
        v4 => v4,
    }
}

fn prefix_matches(network: &[u8], peer: &[u8], prefix: u8) -> bool {
    let (whole, rest) = ((prefix / 8) as usize, prefix % 8);
    if network[..whole] != peer[..whole] {
        return false;
    }
    rest == 0 || {
        let mask = 0xFFu8 << (8 - rest);
        network[whole] & mask == peer[whole] & mask
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn addresses_and_networks_are_matched_by_prefix() {
        let trusted = TrustedProxies::parse("10.0.0.0/8, 192.168.1.7 ,fd00::/8, 172.16.0.0/12").unwrap();
        for inside in ["10.1.2.3", "192.168.1.7", "fd12::1", "172.31.255.255", "::ffff:10.9.9.9"] {
            assert!(trusted.contains(inside.parse().unwrap()), "{inside}");
        }
        for outside in ["11.0.0.1", "192.168.1.8", "fe80::1", "172.32.0.1", "127.0.0.1"] {
            assert!(!trusted.contains(outside.parse().unwrap()), "{outside}");
        }
        assert!(!TrustedProxies::default().contains("127.0.0.1".parse().unwrap()), "nobody is trusted unless configured");
        assert!(TrustedProxies::parse("0.0.0.0/0").unwrap().contains("8.8.8.8".parse().unwrap()));
        for bad in ["proxy.local", "10.0.0.0/33", "10.0.0.0/x"] {
            assert!(TrustedProxies::parse(bad).unwrap_err().to_string().contains(bad), "{bad}");
        }
    }
}
