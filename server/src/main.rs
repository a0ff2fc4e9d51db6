//! `osmab`: the OSMa-Bench++ evaluation service and its command line.

mod auth;
mod backup;
mod blobs;
mod cli;
mod clock;
mod config;
mod http;
mod intake;
mod jobs;
mod leaderboard;
mod llm;
mod metrics;
mod problem;
mod proxies;
mod queue;
mod rate_limit;
mod receipts;
mod release_allow;
mod release_archives;
mod release_names;
mod releases;
mod reserved_names;
mod routes;
mod secret_files;
mod serve;
mod split_secret;
mod state;
mod store;
mod telemetry;
mod token;
mod uploads;

use std::process::ExitCode;

use clap::Parser;

fn main() -> ExitCode {
    osmab_cpu::require_build_features();
    let args = cli::Cli::parse();
    match cli::run(args) {
        Ok(()) => ExitCode::SUCCESS,
        Err(err) => {
            eprintln!("error: {err:#}");
            ExitCode::FAILURE
        }
    }
}
