//! `osmab-client`: the participant client on its own, as `pip install osmab-client` installs
//! it. The same commands as `osmab client …` (the [`osmab_client`] library).

use std::process::ExitCode;

use clap::Parser;

/// The OSMa-Bench++ participant client: download a release, validate a submission offline
/// with the evaluator's own checks, submit it, follow it, and read results, receipts and
/// the leaderboard.
#[derive(Parser)]
#[command(name = "osmab-client", version)]
struct Cli {
    #[command(flatten)]
    client: osmab_client::ClientArgs,
}

fn main() -> ExitCode {
    osmab_cpu::require_build_features();
    osmab_client::stop_quietly_when_stdout_closes();
    osmab_client::invoked_as("osmab-client");
    match osmab_client::run(Cli::parse().client) {
        Ok(()) => ExitCode::SUCCESS,
        Err(err) => {
            eprintln!("error: {err:#}");
            ExitCode::FAILURE
        }
    }
}
