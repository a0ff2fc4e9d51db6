//! `osmab admin team create|list|tokens|token` and `osmab admin token revoke ID`: teams and their tokens through the
//! admin API, from the machine the service runs on. The server and the admin token come from the
//! service's own settings (`OSMAB_PUBLIC_URL` or the bind address; `OSMAB_ADMIN_TOKEN` or the
//! data directory's `admin-token` file), so no token is typed or pasted.

use std::path::PathBuf;

use anyhow::Context;
use clap::{Args, Subcommand};
use reqwest::blocking::{Client, RequestBuilder};
use serde::de::DeserializeOwned;

use crate::config::Settings;
use crate::routes::admin_teams::{CreatedTeam, IssuedToken, TeamList, TeamView, TokenList};

#[derive(Debug, Args)]
pub struct AdminArgs {
    #[command(subcommand)]
    command: AdminCommand,
}

#[derive(Debug, Subcommand)]
enum AdminCommand {
    /// Teams and their tokens.
    #[command(subcommand)]
    Team(TeamCommand),
    /// Tokens by id.
    #[command(subcommand)]
    Token(TokenCommand),
}

#[derive(Debug, Subcommand)]
enum TokenCommand {
    /// Revoke a token by its id (`osmab admin team tokens TEAM` lists a team's).
    Revoke {
        token_id: String,
        #[command(flatten)]
        target: Target,
    },
}

/// The service to talk to.
#[derive(Debug, Args)]
struct Target {
    /// The service's settings file (as for `osmab serve`); environment variables override it.
    #[arg(long, env = "OSMAB_CONFIG")]
    config: Option<PathBuf>,
    /// The server (default: `OSMAB_PUBLIC_URL`, else the settings' bind address).
    #[arg(long)]
    url: Option<String>,
}

#[derive(Debug, Subcommand)]
enum TeamCommand {
    /// Create a team and print its token (shown this once: hand it to the team).
    Create {
        name: String,
        /// Submissions to the test split per window for this team (default: the split's policy).
        #[arg(long)]
        daily_quota: Option<i64>,
        #[command(flatten)]
        target: Target,
    },
    /// List the teams.
    List {
        #[command(flatten)]
        target: Target,
    },
    /// List a team's tokens (hints and states, never the tokens).
    Tokens {
        /// The team's name or id.
        team: String,
        #[command(flatten)]
        target: Target,
    },
    /// Issue another token for a team and print it (a lost token is replaced this way).
    Token {
        /// The team's name or id.
        team: String,
        #[command(flatten)]
        target: Target,
    },
}

/// The admin API of one service.
struct AdminApi {
    url: String,
    token: String,
    client: Client,
}

impl AdminApi {
    fn open(target: &Target) -> anyhow::Result<Self> {
        let settings = Settings::load(target.config.as_deref())?;
        let url = match &target.url {
            Some(url) => url.trim_end_matches('/').to_string(),
            None => settings.public_url.clone().unwrap_or_else(|| format!("http://{}", settings.bind)),
        };
        let token = match &settings.admin_token {
            Some(token) => token.expose().to_string(),
            None => {
                let path = settings.data_dir.join("admin-token");
                std::fs::read_to_string(&path)
                    .with_context(|| {
                        format!("{}: cannot read the admin token (set OSMAB_ADMIN_TOKEN, or run this where the service's data directory is)", path.display())
                    })?
                    .trim()
                    .to_string()
            }
        };
        let client = Client::builder().timeout(std::time::Duration::from_secs(60)).build()?;
        Ok(Self { url, token, client })
    }

    fn send<T: DeserializeOwned>(&self, request: RequestBuilder) -> anyhow::Result<T> {
        let response =
            request.bearer_auth(&self.token).send().with_context(|| format!("{}: the service does not answer (is `osmab serve` running?)", self.url))?;
        let response = crate::cli::client::checked(response)?;
        response.json().context("the service's answer does not read")
    }

    /// The team named `team` (or with that id).
    fn team(&self, team: &str) -> anyhow::Result<TeamView> {
        let list: TeamList = self.send(self.client.get(format!("{}/api/v1/admin/teams", self.url)))?;
        list.teams.into_iter().find(|t| t.id == team || t.name == team).with_context(|| format!("no team named '{team}' (`osmab admin team list` shows them)"))
    }
}

pub fn run(args: AdminArgs) -> anyhow::Result<()> {
    let command = match args.command {
        AdminCommand::Team(command) => command,
        AdminCommand::Token(TokenCommand::Revoke { token_id, target }) => {
            let api = AdminApi::open(&target)?;
            let response = api.client.delete(format!("{}/api/v1/admin/tokens/{token_id}", api.url)).bearer_auth(&api.token).send()?;
            crate::cli::client::checked(response)?;
            println!("token {token_id} revoked");
            return Ok(());
        }
    };
    match command {
        TeamCommand::Create { name, daily_quota, target } => {
            let api = AdminApi::open(&target)?;
            let body = serde_json::json!({"name": name, "daily_quota": daily_quota});
            let created: CreatedTeam = api.send(api.client.post(format!("{}/api/v1/admin/teams", api.url)).json(&body))?;
            println!("{}", created.token);
            eprintln!(
                "Team '{}' ({}) created. Its token is above, shown this once: the team runs `osmab client login --url {} --token …` with it.",
                created.name, created.id, api.url
            );
        }
        TeamCommand::List { target } => {
            let api = AdminApi::open(&target)?;
            let list: TeamList = api.send(api.client.get(format!("{}/api/v1/admin/teams", api.url)))?;
            let header: Vec<String> = ["id", "name", "daily quota", "created"].iter().map(|s| s.to_string()).collect();
            let rows: Vec<Vec<String>> = list
                .teams
                .iter()
                .map(|t| {
                    let quota = t.daily_quota.map_or_else(|| "policy".to_string(), |q| q.to_string());
                    vec![t.id.clone(), t.name.clone(), quota, t.created_at.clone().unwrap_or_default()]
                })
                .collect();
            println!("{}", crate::cli::client::table_text(&header, &rows));
        }
        TeamCommand::Tokens { team, target } => {
            let api = AdminApi::open(&target)?;
            let team = api.team(&team)?;
            let list: TokenList = api.send(api.client.get(format!("{}/api/v1/admin/teams/{}/tokens", api.url, team.id)))?;
            let header: Vec<String> = ["id", "starts with", "created", "expires", "revoked"].iter().map(|s| s.to_string()).collect();
            let rows: Vec<Vec<String>> = list
                .tokens
                .iter()
                .map(|t| {
                    vec![t.id.clone(), t.hint.clone(), t.created_at.clone(), t.expires_at.clone().unwrap_or_default(), t.revoked_at.clone().unwrap_or_default()]
                })
                .collect();
            println!("Tokens of team {}\n{}", team.name, crate::cli::client::table_text(&header, &rows));
        }
        TeamCommand::Token { team, target } => {
            let api = AdminApi::open(&target)?;
            let team = api.team(&team)?;
            let issued: IssuedToken = api.send(api.client.post(format!("{}/api/v1/admin/teams/{}/tokens", api.url, team.id)))?;
            println!("{}", issued.token);
            eprintln!("A new token ({}) for team '{}', shown this once; its earlier tokens stay valid until revoked.", issued.id, issued.team);
        }
    }
    Ok(())
}
