//! `osmab`: the OSMa-Bench++ evaluation service and its command line (the library's
//! [`osmab::cli`]).

use std::process::ExitCode;

use clap::Parser;
use osmab::cli;

fn main() -> ExitCode {
    osmab_cpu::require_build_features();
    osmab_client::stop_quietly_when_stdout_closes();
    let args = cli::Cli::parse();
    match cli::run(args) {
        Ok(()) => ExitCode::SUCCESS,
        Err(err) => {
            eprintln!("error: {err:#}");
            ExitCode::FAILURE
        }
    }
}
