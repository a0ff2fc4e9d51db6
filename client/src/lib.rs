//! The participant client: what a team runs on its own machine — log in once, download the
//! release (parallel, resumable, verified), validate offline with the evaluator's own code,
//! submit with a declared checksum, follow the evaluation, read results and the
//! leaderboard. Server errors are shown as the problem's title, detail and what to do.
//!
//! It is `osmab client …` in the service's binary and `osmab-client …` on its own (this
//! crate's binary, which `pip install osmab-client` installs): the same commands, built
//! without the service's database, storage and web stack. It reads the service's answers
//! into the service's own wire types ([`osmab_api`]).

mod api;
mod currency;
mod download;
mod fetch_file;
mod offline;
mod quiet_pipe;
mod resumable;
mod session;
mod submit;
mod verify;
mod view;

pub use api::checked;
pub use quiet_pipe::stop_quietly_when_stdout_closes;
pub use view::table_text;

use osmab_evaluator::scores::Split;
use std::path::PathBuf;
use std::sync::OnceLock;

use anyhow::{Context, bail};
use clap::Subcommand;

use api::Api;
use osmab_api::account::Me;
use osmab_api::states::SubmissionState;
use osmab_api::submissions::{Created, DryRun};
use session::Session;

/// How the client was started, as its messages suggest the next command: `osmab client`
/// unless the program said otherwise ([`invoked_as`]).
static INVOKED_AS: OnceLock<&'static str> = OnceLock::new();

/// Name the command that runs the client (`osmab-client`), for the commands its messages suggest.
pub fn invoked_as(command: &'static str) {
    INVOKED_AS.get_or_init(|| command);
}

/// The command that runs the client.
fn command() -> &'static str {
    INVOKED_AS.get().copied().unwrap_or("osmab client")
}

#[derive(Debug, clap::Args)]
pub struct ClientArgs {
    /// Allow plain http:// to a server that is not this machine (the token and uploads
    /// travel unencrypted); https, or http to this machine, needs no flag.
    #[arg(long, global = true)]
    allow_http: bool,
    #[command(subcommand)]
    command: ClientCommand,
}

#[derive(Debug, Subcommand)]
pub enum ClientCommand {
    /// Store the server URL and your team token (owner-only file in your configuration folder).
    Login {
        /// The server (default: `OSMAB_URL`, else the one `login` stored).
        #[arg(long)]
        url: Option<String>,
        /// The team token (`osmab_…`); read from OSMAB_TOKEN when not given.
        #[arg(long)]
        token: Option<String>,
    },
    /// Download a release: manifest, then files and sequence archives, resumed and verified.
    Download {
        /// The release version (default: the current release).
        #[arg(long)]
        release: Option<String>,
        /// Only this lighting (repeatable).
        #[arg(long)]
        lighting: Vec<String>,
        /// Only this scene (repeatable).
        #[arg(long)]
        scene: Vec<String>,
        /// The folder to download into; what it already holds is verified and kept, interrupted files resume.
        #[arg(long)]
        out: PathBuf,
        /// Parallel connections.
        #[arg(long, default_value_t = 4)]
        jobs: usize,
        /// The server (default: `OSMAB_URL`, else the one `login` stored).
        #[arg(long)]
        url: Option<String>,
    },
    /// Validate a submission (folder or archive) offline, and score it when the release folder has ground truth.
    Validate {
        submission: PathBuf,
        /// A downloaded release; without it the release facts are fetched from the server.
        #[arg(long)]
        release_dir: Option<PathBuf>,
        /// The split to validate against (`test` or `val`); the release's test split when it
        /// has one. Every split whose ground truth the folder holds (val's is public) is scored.
        #[arg(long)]
        split: Option<Split>,
        /// The server (default: `OSMAB_URL`, else the one `login` stored).
        #[arg(long)]
        url: Option<String>,
        /// Also write each scored split's whole score document (every scene, lighting, question
        /// category) as `DIR/scores-<split>.json`.
        #[arg(long, value_name = "DIR")]
        scores_out: Option<PathBuf>,
    },
    /// Upload a submission (folder or archive) and print its id.
    Submit {
        submission: PathBuf,
        /// Validate on the server only; costs no quota.
        #[arg(long)]
        dry_run: bool,
        /// Keep it off the public leaderboard.
        #[arg(long)]
        private: bool,
        /// Follow the evaluation until it ends.
        #[arg(long)]
        watch: bool,
        /// The split to submit to: `test` (hidden scenes, the main board, few per window) or
        /// `val` (open scenes, their own board); the release's test split when it has one.
        #[arg(long)]
        split: Option<Split>,
        /// The server (default: `OSMAB_URL`, else the one `login` stored).
        #[arg(long)]
        url: Option<String>,
    },
    /// Show a submission's state and history; --watch follows it until scored or failed.
    Status {
        id: String,
        #[arg(long)]
        watch: bool,
        /// The server (default: `OSMAB_URL`, else the one `login` stored).
        #[arg(long)]
        url: Option<String>,
    },
    /// Print a scored submission's tables.
    Results {
        id: String,
        /// The server (default: `OSMAB_URL`, else the one `login` stored).
        #[arg(long)]
        url: Option<String>,
    },
    /// Check a score receipt offline: its signature against the service's keys (the JWKS of
    /// `GET /api/v1/keys`, saved to a file), and with --results that the results document is
    /// the one it certifies.
    Verify {
        /// The receipt: the compact JWS, or the JSON of `GET /api/v1/submissions/{id}/receipt`.
        receipt: PathBuf,
        /// The service's key set (JWKS): its URL (`https://HOST/api/v1/keys`), whose origin the
        /// receipt must name as its issuer, or a saved copy.
        #[arg(long)]
        keys: String,
        /// The origin the receipt must name as its issuer (`https://HOST`), when --keys is a file.
        #[arg(long)]
        issuer: Option<String>,
        /// A results document (`GET /api/v1/submissions/{id}/results.json`) to check against the receipt.
        #[arg(long)]
        results: Option<PathBuf>,
        /// Check that the entry is this team's: an anonymous entry's with --claim-code (shown to
        /// its team by `GET /api/v1/submissions/{id}`), any other by the team the receipt names.
        #[arg(long)]
        team: Option<String>,
        /// The entry's claim code, shown to its team only.
        #[arg(long, requires = "team")]
        claim_code: Option<String>,
    },
    /// Fetch a scored submission's signed receipt, the results document it certifies and the
    /// service's keys into --out; with --verify, check all three as `verify` does
    /// (the issuer must be this server's origin).
    Receipt {
        id: String,
        /// Where the three files go (`receipt-ID.json`, `results-ID.json`, `keys.json`).
        #[arg(long, default_value = ".")]
        out: PathBuf,
        /// Check the signature, the issuer and the results' SHA-256, and print what it certifies.
        #[arg(long)]
        verify: bool,
        /// The server (default: `OSMAB_URL`, else the one `login` stored).
        #[arg(long)]
        url: Option<String>,
    },
    /// Print the team's quota of every split: what it may still submit, and when more.
    Quota {
        /// The server (default: `OSMAB_URL`, else the one `login` stored).
        #[arg(long)]
        url: Option<String>,
    },
    /// Print the leaderboard.
    Leaderboard {
        #[arg(long)]
        release: Option<String>,
        /// `test` or `val`; the release's test split when it has one.
        #[arg(long)]
        split: Option<Split>,
        #[arg(long)]
        lighting: Option<String>,
        /// The server (default: `OSMAB_URL`, else the one `login` stored).
        #[arg(long)]
        url: Option<String>,
    },
}

pub fn run(args: ClientArgs) -> anyhow::Result<()> {
    let allow_http = args.allow_http;
    let api = |url: Option<&str>| Api::new(Session::load(url, allow_http)?);
    match args.command {
        ClientCommand::Login { url, token } => login(url.as_deref(), token, allow_http),
        ClientCommand::Download { release, lighting, scene, out, jobs, url } => {
            let api = api(url.as_deref())?;
            let selection = download::Selection { release, lightings: lighting, scenes: scene, jobs };
            let (fetched, skipped) = download::download(&api, &selection, &out)?;
            println!("{fetched} downloads done, {skipped} files already present and verified; the release is in {}", out.display());
            Ok(())
        }
        ClientCommand::Validate { submission, release_dir, split, url, scores_out } => {
            let api = if release_dir.is_none() { Some(api(url.as_deref())?) } else { None };
            if let (Some(api), Some(release)) = (&api, currency::card_release(&submission))
                && let Some(note) = currency::newer_release_note(api, &release, "this submission is for")
            {
                eprintln!("{note}");
            }
            let valid = offline::validate_offline(&submission, release_dir.as_deref(), split, api.as_ref(), scores_out.as_deref())?;
            if valid { Ok(()) } else { std::process::exit(1) }
        }
        ClientCommand::Quota { url } => view::quota(&api(url.as_deref())?),
        ClientCommand::Submit { submission, dry_run, private, watch, split, url } => {
            let api = api(url.as_deref())?;
            let packed = submit::pack(&submission)?;
            eprintln!("{}: {} bytes, SHA-256 {}", submission.display(), packed.size, packed.sha256_hex());
            if let Some(note) = currency::card_release(&submission).and_then(|release| currency::newer_release_note(&api, &release, "this submission is for")) {
                eprintln!("{note}");
            }
            if dry_run {
                // A dry run sends the archive once and stores nothing.
                let answer = submit::upload(&api, &packed, true, !private, split)?;
                return report_dry_run(&serde_json::from_value(answer).context("the server's dry-run answer")?);
            }
            // A submission goes resumably.
            let id = report_submitted(resumable::submit(&api, &packed, !private, split)?, watch);
            exit_unless_scored(watch, || view::status(&api, &id, true))
        }
        ClientCommand::Status { id, watch, url } => {
            let state = view::status(&api(url.as_deref())?, &id, watch)?;
            exit_unless_scored(watch, || Ok(state))
        }
        ClientCommand::Results { id, url } => view::results(&api(url.as_deref())?, &id),
        ClientCommand::Verify { receipt, keys, issuer, results, team, claim_code } => {
            let keys = verify::KeySource::parse(&keys, issuer.as_deref())?;
            let checked = verify::verify(&receipt, &keys, results.as_deref())?;
            print!("{}", verify::describe(&checked, &keys, results.is_some()));
            if let Some(team) = team {
                println!("{}", verify::claim(&checked, &team, claim_code.as_deref())?);
            }
            print!("{}", verify::describe_currency(&verify::currency(&checked, &keys, None)));
            Ok(())
        }
        ClientCommand::Receipt { id, out, verify, url } => {
            print!("{}", verify::fetch_receipt(&api(url.as_deref())?, &id, &out, verify)?);
            Ok(())
        }
        ClientCommand::Leaderboard { release, split, lighting, url } => {
            view::leaderboard(&api(url.as_deref())?, release.as_deref(), split, lighting.as_deref())
        }
    }
}

/// `osmab client login`: check the token against the server (the token given, else
/// `OSMAB_TOKEN`, else the one stored for this very server) and store it.
fn login(url: Option<&str>, token: Option<String>, allow_http: bool) -> anyhow::Result<()> {
    let mut session = Session::load(url, allow_http)?;
    if let Some(token) = token {
        session.token = Some(token);
    }
    let Some(token) = session.token.clone() else { bail!("give --token osmab_… (or set OSMAB_TOKEN)") };
    if !token.starts_with("osmab_") {
        bail!("that is not an osmab token: team tokens start with 'osmab_'; copy the whole token you were given");
    }
    let api = Api::new(session.clone())?;
    let me: Me = serde_json::from_value(api.get_team_json("/api/v1/me")?).context("the server's /api/v1/me answer")?;
    let path = session.save()?;
    let quota = &me.quota;
    println!(
        "Logged in to {} as team {} (token {}); {} of {} {} submissions left in this {}-hour window. Saved to {} (owner-only).",
        session.url,
        me.team.name,
        session::hint(&token),
        quota.remaining,
        quota.limit,
        quota.split,
        quota.window_hours,
        path.display()
    );
    Ok(())
}

/// What a dry run found valid.
fn report_dry_run(report: &DryRun) -> anyhow::Result<()> {
    println!(
        "Valid on the server for the {} split (dry run, no quota used): {} scene-lighting pairs, {}, {} points",
        report.split,
        report.entries.len(),
        if report.complete { "complete" } else { "incomplete" },
        report.points
    );
    Ok(())
}

/// Say what became of an upload (and, with `watch`, that it is followed); its submission's id.
fn report_submitted(created: Created, watch: bool) -> String {
    let id = created.id;
    // The id alone on stdout for scripts (`ID=$(osmab client submit …)`); in a terminal
    // the sentence below says it once.
    if !std::io::IsTerminal::is_terminal(&std::io::stdout()) {
        println!("{id}");
    }
    if created.repeat {
        eprintln!("The server already had this archive as {id} ({}); no quota was used.", created.state);
    } else {
        let next = if watch { "following it until it is scored:".to_string() } else { format!("follow it with `{} status {id} --watch`.", command()) };
        eprintln!(
            "Submitted to the {} split as {id} ({}); {} of {} left in the window; {next}",
            created.split, created.state, created.quota.remaining, created.quota.limit
        );
    }
    id
}

/// With `--watch`, exit 1 unless the submission ends scored (`finally` waits for it).
fn exit_unless_scored(watch: bool, finally: impl FnOnce() -> anyhow::Result<SubmissionState>) -> anyhow::Result<()> {
    if watch && finally()? != SubmissionState::Scored {
        std::process::exit(1);
    }
    Ok(())
}
