//! `osmab admin team create|list|tokens|token` and `osmab admin token revoke ID`: teams and their tokens through the
//! admin API, from the machine the service runs on. The server and the admin token come from the
//! service's own settings (`OSMAB_PUBLIC_URL` or the bind address; `OSMAB_ADMIN_TOKEN` or the
//! data directory's `admin-token` file), so no token is typed or pasted.

use std::path::PathBuf;

use anyhow::Context;
use clap::{Args, Subcommand};
use reqwest::blocking::{Client, RequestBuilder};
use serde::de::DeserializeOwned;

use crate::access_requests::AccessRequestView;
use crate::config::Settings;
use crate::routes::access_requests::RequestList;
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
    /// List the requests for access from the "Take part" page (pending ones unless --all).
    Requests {
        /// Every request, decided ones too.
        #[arg(long)]
        all: bool,
        #[command(flatten)]
        target: Target,
    },
    /// Approve a request for access: its team is created, and the requester collects the
    /// token with its claim code.
    Approve {
        /// The request's id (acc_…).
        request: String,
        #[command(flatten)]
        target: Target,
    },
    /// Decline a request for access, with a reason the requester reads.
    Decline {
        /// The request's id (acc_…).
        request: String,
        #[arg(long)]
        reason: String,
        #[command(flatten)]
        target: Target,
    },
}

/// The admin API of one service.
struct AdminApi {
    url: String,
    token: String,
    client: Client,
    /// Where the URL came from, for the message when nothing answers there.
    found: String,
}

impl AdminApi {
    fn open(target: &Target) -> anyhow::Result<Self> {
        let settings = Settings::load(target.config.as_deref())?;
        let listening = crate::serve::listening_url(&settings.data_dir);
        let (url, found) = match (&target.url, listening) {
            (Some(url), _) => (url.trim_end_matches('/').to_string(), "--url".to_string()),
            (None, Some(url)) => (url, format!("{} (written by `osmab serve` at start)", settings.data_dir.join(crate::serve::LISTENING_FILE).display())),
            (None, None) => match &settings.public_url {
                Some(url) => (url.clone(), "OSMAB_PUBLIC_URL".to_string()),
                None => (format!("http://{}", settings.bind), "the settings' bind address (OSMAB_BIND)".to_string()),
            },
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
        Ok(Self { url, token, client, found })
    }

    fn send<T: DeserializeOwned>(&self, request: RequestBuilder) -> anyhow::Result<T> {
        let response = request.bearer_auth(&self.token).send().with_context(|| {
            format!(
                "{}: the service does not answer (is `osmab serve` running?). The address came from {}; run this with the same OSMAB_DATA_DIR as \
                 `serve`, or give --url http://HOST:PORT",
                self.url, self.found
            )
        })?;
        let response = osmab_client::checked(response)?;
        response.json().context("the service's answer does not read")
    }

    /// Send `request`, expecting an answer without a body (null then).
    fn send_empty(&self, request: RequestBuilder) -> anyhow::Result<serde_json::Value> {
        let response = request
            .bearer_auth(&self.token)
            .send()
            .with_context(|| format!("{}: the service does not answer (it came from {}; give --url)", self.url, self.found))?;
        osmab_client::checked(response)?;
        Ok(serde_json::Value::Null)
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
            let _: serde_json::Value = api.send_empty(api.client.delete(format!("{}/api/v1/admin/tokens/{token_id}", api.url)))?;
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
                "Team '{}' ({}) created. Its token is above, shown this once: the team runs `osmab-client login --url {} --token …` with it.",
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
            println!("{}", osmab_client::table_text(&header, &rows));
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
            println!("Tokens of team {}\n{}", team.name, osmab_client::table_text(&header, &rows));
        }
        TeamCommand::Requests { all, target } => list_requests(all, &target)?,
        TeamCommand::Approve { request, target } => {
            let api = AdminApi::open(&target)?;
            let approved: AccessRequestView = api.send(api.client.post(format!("{}/api/v1/admin/access-requests/{request}/approve", api.url)))?;
            println!("Team '{}' is created; its requester collects the token with the claim code it was shown.", approved.team_name);
        }
        TeamCommand::Decline { request, reason, target } => {
            let api = AdminApi::open(&target)?;
            let body = serde_json::json!({"reason": reason});
            let declined: AccessRequestView = api.send(api.client.post(format!("{}/api/v1/admin/access-requests/{request}/decline", api.url)).json(&body))?;
            println!("The request for team '{}' is declined; its requester reads the reason when collecting.", declined.team_name);
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

/// `osmab admin team requests [--all]`: the requests for access from the "Take part" page.
fn list_requests(all: bool, target: &Target) -> anyhow::Result<()> {
    let api = AdminApi::open(target)?;
    let query = if all { "" } else { "?state=pending" };
    let list: RequestList = api.send(api.client.get(format!("{}/api/v1/admin/access-requests{query}", api.url)))?;
    let header: Vec<String> = ["id", "team", "contact", "affiliation", "method", "state", "asked"].iter().map(|s| s.to_string()).collect();
    let rows: Vec<Vec<String>> = list
        .requests
        .iter()
        .map(|r| {
            let method = r.method_url.clone().unwrap_or_default();
            vec![r.id.clone(), r.team_name.clone(), r.contact.clone(), r.affiliation.clone(), method, r.state.to_string(), r.created_at.clone()]
        })
        .collect();
    println!("{}", osmab_client::table_text(&header, &rows));
    if list.requests.is_empty() {
        eprintln!("No request{}.", if all { "" } else { " waits" });
    }
    Ok(())
}
