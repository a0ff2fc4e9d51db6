//! Where the client keeps the server and the token: `client.toml` in the user's
//! configuration folder (`$OSMAB_CLIENT_CONFIG`, else `$XDG_CONFIG_HOME/osmab/`, else
//! `~/.config/osmab/`), written owner-only (0600) because it holds a secret.
//! `OSMAB_URL` and `OSMAB_TOKEN` override it for scripts and CI.

use std::path::PathBuf;

use anyhow::{Context, bail};
use serde::{Deserialize, Serialize};

/// A server and the token to use with it.
#[derive(Clone, Serialize, Deserialize)]
pub struct Session {
    pub url: String,
    pub token: Option<String>,
}

impl std::fmt::Debug for Session {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Session").field("url", &self.url).field("token", &self.token.as_ref().map(|t| hint(t))).finish()
    }
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

impl Session {
    /// The stored session with `OSMAB_URL`/`OSMAB_TOKEN` applied; `--url` wins over both.
    pub fn load(url_flag: Option<&str>) -> anyhow::Result<Session> {
        let path = config_path()?;
        let stored: Option<Session> = match std::fs::read_to_string(&path) {
            Ok(text) => Some(toml::from_str(&text).with_context(|| format!("{}: not a client configuration (url, token)", path.display()))?),
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => None,
            Err(e) => return Err(e).with_context(|| format!("{}: cannot read", path.display())),
        };
        let url = url_flag
            .map(str::to_string)
            .or_else(|| std::env::var("OSMAB_URL").ok().filter(|u| !u.is_empty()))
            .or_else(|| stored.as_ref().map(|s| s.url.clone()))
            .unwrap_or_else(|| "http://127.0.0.1:8080".to_string());
        let token = std::env::var("OSMAB_TOKEN").ok().filter(|t| !t.is_empty()).or_else(|| stored.and_then(|s| s.token));
        Ok(Session { url: url.trim_end_matches('/').to_string(), token })
    }

    /// The token, or an error that says how to get one.
    pub fn token(&self) -> anyhow::Result<&str> {
        match &self.token {
            Some(t) => Ok(t),
            None => bail!("no token: run `osmab client login --url {} --token osmab_…` with the token the organisers gave your team", self.url),
        }
    }

    /// Store the session, readable by its owner only.
    pub fn save(&self) -> anyhow::Result<PathBuf> {
        let path = config_path()?;
        let dir = path.parent().context("the configuration path has no folder")?;
        std::fs::create_dir_all(dir).with_context(|| format!("{}: cannot create", dir.display()))?;
        // TOML basic strings take JSON's escapes, so serde_json quotes them correctly.
        let quote = |s: &str| serde_json::to_string(s).expect("a string serialises");
        let mut text = format!("url = {}\n", quote(&self.url));
        if let Some(token) = &self.token {
            text.push_str(&format!("token = {}\n", quote(token)));
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
