//! `cargo xtask …`: developer tools kept out of the shipped `osmab` binary. Today the
//! service benchmarks — an HTTP/1.1 load generator over raw keep-alive connections, one
//! timed download and one streamed synthetic upload — that `bench/service.py` drives
//! against a running `osmab serve`.

mod loadgen;

use std::time::Duration;

use clap::{Parser, Subcommand};

#[derive(Debug, Parser)]
#[command(name = "xtask", about = "OSMa-Bench++ developer tools (service benchmarks)")]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Debug, Subcommand)]
enum Command {
    /// Load a running service with GET requests over keep-alive connections; prints requests/s and latency.
    Http {
        /// The URL to request (http://host:port/path).
        url: String,
        /// Concurrent connections.
        #[arg(long, default_value_t = 64)]
        concurrency: usize,
        /// Seconds to run.
        #[arg(long, default_value_t = 10.0)]
        seconds: f64,
        /// Extra request headers ("Accept: text/csv").
        #[arg(long = "header")]
        headers: Vec<String>,
    },
    /// Download a file of a running service once and print the throughput.
    Download {
        /// The file's URL.
        url: String,
    },
    /// Stream a synthetic upload of SIZE bytes to a running service (watch its memory meanwhile).
    Upload {
        /// The submissions URL (http://host:port/api/v1/submissions).
        url: String,
        /// A team token.
        #[arg(long, env = "OSMAB_TOKEN")]
        token: String,
        /// Upload size in bytes.
        #[arg(long, default_value_t = 2_000_000_000)]
        bytes: u64,
    },
}

fn main() -> anyhow::Result<()> {
    let runtime = tokio::runtime::Builder::new_multi_thread().enable_all().build()?;
    match Cli::parse().command {
        Command::Http { url, concurrency, seconds, headers } => {
            let report = runtime.block_on(loadgen::get_load(&url, &headers, concurrency, Duration::from_secs_f64(seconds)))?;
            println!(
                "{url}: {} requests in {:.1} s = {:.0} requests/s; latency p50 {:.2} ms, p99 {:.2} ms, max {:.2} ms; {} errors ({concurrency} connections)",
                report.requests,
                report.seconds,
                report.requests as f64 / report.seconds,
                report.p50_ms,
                report.p99_ms,
                report.max_ms,
                report.errors
            );
        }
        Command::Download { url } => {
            let (bytes, seconds) = runtime.block_on(loadgen::download(&url))?;
            println!("{url}: {bytes} bytes in {seconds:.2} s = {:.0} MB/s", bytes as f64 / seconds / 1e6);
        }
        Command::Upload { url, token, bytes } => {
            let (status, body, seconds) = runtime.block_on(loadgen::upload(&url, &token, bytes))?;
            println!(
                "{url}: {bytes} bytes in {seconds:.1} s = {:.0} MB/s; status {status}: {}",
                bytes as f64 / seconds / 1e6,
                body.chars().take(300).collect::<String>()
            );
        }
    }
    Ok(())
}
