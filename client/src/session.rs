//! Where the client keeps the server and the token: `client.toml` in the user's
//! configuration folder (`$OSMAB_CLIENT_CONFIG`, else `$XDG_CONFIG_HOME/osmab/`, else
//! `~/.config/osmab/`), written owner-only (0600) because it holds a secret.
//! `OSMAB_URL` and `OSMAB_TOKEN` override it for scripts and CI.

use std::collections::BTreeMap;
use std::path::PathBuf;

use anyhow::{Context, bail};
use serde::Deserialize;

/// A server and the token issued for it (tokens belong to the origin they were issued
/// for: another server never sees them).
#[derive(Clone)]
pub struct Session {
    pub url: String,
    pub token: Option<String>,
    /// Plain `http://` to a host that is not this machine is allowed (`--allow-http`).
    pub allow_http: bool,
}

impl std::fmt::Debug for Session {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Session").field("url", &self.url).field("token", &self.token.as_ref().map(|t| hint(t))).finish()
    }
}

/// `client.toml`: the default server and a token per origin (`token` alone is the
/// file of earlier versions: the token of `url`).
#[derive(Default, Deserialize)]
struct Stored {
    url: Option<String>,
    #[serde(default)]
    token: Option<String>,
    #[serde(default)]
    tokens: BTreeMap<String, String>,
}

/// The origin (`scheme://host[:port]`) of `url`, which a token belongs to.
pub fn origin(url: &str) -> anyhow::Result<String> {
    let parsed = reqwest::Url::parse(url).with_context(|| format!("'{url}' is not a URL (e.g. https://osmab.example.org)"))?;
    if !["http", "https"].contains(&parsed.scheme()) || parsed.host_str().is_none() {
        bail!("'{url}' is not an http(s) URL of a server");
    }
    Ok(parsed.origin().ascii_serialization())
}

/// Refuse plain `http://` to a host that is not this machine: the token would cross the
/// network readable by anyone on the way.
pub fn check_transport(url: &str, allow_http: bool) -> anyhow::Result<()> {
    let parsed = reqwest::Url::parse(url).with_context(|| format!("'{url}' is not a URL"))?;
    let host = parsed.host_str().unwrap_or_default().trim_start_matches('[').trim_end_matches(']');
    let loopback = host.eq_ignore_ascii_case("localhost") || host.parse::<std::net::IpAddr>().is_ok_and(|ip| ip.is_loopback());
    if parsed.scheme() == "http" && !loopback && !allow_http {
        bail!(
            "{url} is plain http to another machine: your token and uploads would travel unencrypted. Use https, or pass --allow-http if this network is yours"
        );
    }
    Ok(())
}

/// The first characters of a token, to tell tokens apart without showing them.
pub fn hint(token: &str) -> String {
    format!("{}…", token.chars().take(10).collect::<String>())
}

/// The file the session lives in.
pub fn config_path() -> anyhow::Result<PathBuf> {
    if let Some(path) = std::env::var_os("OSMAB_CLIENT_CONFIG") {
        return Ok(PathBuf::from(path));
    }
    let base = match std::env::var_os("XDG_CONFIG_HOME").filter(|v| !v.is_empty()) {
        Some(dir) => PathBuf::from(dir),
        None => PathBuf::from(std::env::var_os("HOME").context("neither XDG_CONFIG_HOME nor HOME is set; set OSMAB_CLIENT_CONFIG")?).join(".config"),
    };
    Ok(base.join("osmab").join("client.toml"))
}

fn read_stored() -> anyhow::Result<(PathBuf, Stored)> {
    let path = config_path()?;
    let stored = match std::fs::read_to_string(&path) {
        Ok(text) => toml::from_str(&text).with_context(|| format!("{}: not a client configuration (url, tokens)", path.display()))?,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => Stored::default(),
        Err(e) => return Err(e).with_context(|| format!("{}: cannot read", path.display())),
    };
    Ok((path, stored))
}

impl Stored {
    /// The token stored for `origin` (an earlier version's single token for its own url).
    fn token_for(&self, origin: &str) -> Option<String> {
        self.tokens.get(origin).cloned().or_else(|| {
            let legacy_origin = self.url.as_deref().and_then(|u| self::origin(u).ok());
            self.token.clone().filter(|_| legacy_origin.as_deref() == Some(origin))
        })
    }
}

impl Session {
    /// The server (`--url`, else `OSMAB_URL`, else the stored one) and its token
    /// (`OSMAB_TOKEN`, else the one stored for that server's origin — never another's).
    pub fn load(url_flag: Option<&str>, allow_http: bool) -> anyhow::Result<Session> {
        let (_, stored) = read_stored()?;
        let url = url_flag
            .map(str::to_string)
            .or_else(|| std::env::var("OSMAB_URL").ok().filter(|u| !u.is_empty()))
            .or_else(|| stored.url.clone())
            .unwrap_or_else(|| "http://127.0.0.1:8080".to_string());
        let url = url.trim_end_matches('/').to_string();
        let origin = origin(&url)?;
        let token = std::env::var("OSMAB_TOKEN").ok().filter(|t| !t.is_empty()).or_else(|| stored.token_for(&origin));
        Ok(Session { url, token, allow_http })
    }

    /// The token, or an error that says how to get one.
    pub fn token(&self) -> anyhow::Result<&str> {
        match &self.token {
            Some(t) => Ok(t),
            None => bail!("no token: run `{} login --url {} --token osmab_…` with the token the organisers gave your team", crate::command(), self.url),
        }
    }

    /// Store the session — this server as the default and its token under its origin,
    /// the other servers' tokens kept — readable by its owner only.
    pub fn save(&self) -> anyhow::Result<PathBuf> {
        let (path, mut stored) = read_stored()?;
        let dir = path.parent().context("the configuration path has no folder")?;
        std::fs::create_dir_all(dir).with_context(|| format!("{}: cannot create", dir.display()))?;
        if let (Some(token), Some(url)) = (stored.token.take(), stored.url.clone()) {
            stored.tokens.entry(origin(&url)?).or_insert(token);
        }
        stored.url = Some(self.url.clone());
        if let Some(token) = &self.token {
            stored.tokens.insert(origin(&self.url)?, token.clone());
        }
        // TOML basic strings take JSON's escapes, so serde_json quotes them correctly.
        let quote = |s: &str| serde_json::to_string(s).expect("a string serialises");
        let mut text = format!("url = {}\n\n[tokens]\n", quote(&self.url));
        for (origin, token) in &stored.tokens {
            text.push_str(&format!("{} = {}\n", quote(origin), quote(token)));
        }
        let scratch = path.with_extension("toml.partial");
        {
            use std::io::Write;
            let mut options = std::fs::OpenOptions::new();
            options.write(true).create(true).truncate(true);
            #[cfg(unix)]
            std::os::unix::fs::OpenOptionsExt::mode(&mut options, 0o600);
            let mut file = options.open(&scratch).with_context(|| format!("{}: cannot write", scratch.display()))?;
            #[cfg(unix)]
            std::fs::set_permissions(&scratch, std::os::unix::fs::PermissionsExt::from_mode(0o600))?;
            file.write_all(text.as_bytes())?;
            file.sync_all()?;
        }
        std::fs::rename(&scratch, &path).with_context(|| format!("{}: cannot replace", path.display()))?;
        Ok(path)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_token_belongs_to_an_origin_and_plain_http_stays_on_this_machine() {
        assert_eq!(origin("https://Bench.Example.org:443/api/").unwrap(), "https://bench.example.org");
        assert_eq!(origin("http://127.0.0.1:8080").unwrap(), "http://127.0.0.1:8080");
        assert_ne!(origin("http://127.0.0.1:8080").unwrap(), origin("http://127.0.0.1:8081").unwrap());
        assert!(origin("ftp://x").is_err() && origin("not a url").is_err());
        for url in ["https://bench.example.org", "http://127.0.0.1:8080", "http://localhost:1", "http://[::1]:8080"] {
            assert!(check_transport(url, false).is_ok(), "{url}");
        }
        let refused = check_transport("http://bench.example.org", false).unwrap_err().to_string();
        assert!(refused.contains("--allow-http"), "{refused}");
        assert!(check_transport("http://10.0.0.5:8080", true).is_ok());
        let legacy = Stored { url: Some("http://127.0.0.1:8080".into()), token: Some("osmab_a".into()), tokens: BTreeMap::new() };
        assert_eq!(legacy.token_for("http://127.0.0.1:8080").as_deref(), Some("osmab_a"), "an earlier file's token stays its server's");
        assert_eq!(legacy.token_for("http://127.0.0.1:9090"), None);
    }
}
