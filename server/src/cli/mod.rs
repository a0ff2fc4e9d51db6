//! The subcommands of `osmab`.

mod admin;
mod baseline;
mod bench;
mod bench_dataset;
mod bench_questions;
mod bench_submission;
mod bench_vqa;
mod eval;
mod eval_vqa;
mod gt;
mod release;
mod scene;
mod service;

use clap::{Parser, Subcommand};

/// OSMa-Bench++: evaluation service, scorer and dataset tools.
#[derive(Debug, Parser)]
#[command(name = "osmab", version, about, propagate_version = true)]
pub struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Debug, Subcommand)]
enum Command {
    /// Run the service: HTTP API, pages and an in-process worker (SQLite under ./osmab-data by default).
    Serve(service::ServiceArgs),
    /// Run extra workers against the service's database and storage.
    Worker(service::WorkerArgs),
    /// Apply the database migrations.
    Migrate(service::ServiceArgs),
    /// Add a new receipt-signing key; it signs from the next start, the old ones stay published.
    RotateReceiptKey(service::ServiceArgs),
    /// Teams and their tokens, with this machine's service's admin token (no curl needed).
    Admin(admin::AdminArgs),
    /// Copy the records, stored blobs, receipt keys and split secret into a sealed folder, while the service runs.
    Backup(service::BackupArgs),
    /// Put a backup back into an empty data directory (and an empty database).
    Restore(service::RestoreArgs),
    /// The participant's tools: login, download, validate, submit, status, results, leaderboard.
    Client(osmab_client::ClientArgs),
    /// Score maps and confusion matrices.
    #[command(subcommand)]
    Eval(eval::EvalCommand),
    /// Build ground truth from rendered sequences.
    #[command(subcommand)]
    Gt(gt::GtCommand),
    /// Write a reference submission: perceive (the reference mapper, from the frames alone) or a control made from the ground truth.
    Baseline(baseline::BaselineArgs),
    /// Build and verify releases.
    #[command(subcommand)]
    Release(release::ReleaseCommand),
    /// Dataset pipeline: prompts, selection, synthesis, conversion, rendering.
    #[command(subcommand)]
    Scene(scene::SceneCommand),
    /// Generate benchmark data and time the scorer.
    #[command(subcommand)]
    Bench(bench::BenchCommand),
}

/// Run the parsed command line.
pub fn run(cli: Cli) -> anyhow::Result<()> {
    match cli.command {
        Command::Serve(args) => service::serve(args),
        Command::Worker(args) => service::worker(args),
        Command::Migrate(args) => service::migrate(args),
        Command::RotateReceiptKey(args) => service::rotate_receipt_key(args),
        Command::Admin(args) => admin::run(args),
        Command::Backup(args) => service::backup(args),
        Command::Restore(args) => service::restore(args),
        Command::Client(cmd) => osmab_client::run(cmd),
        Command::Eval(cmd) => eval::run(cmd),
        Command::Gt(cmd) => gt::run(cmd),
        Command::Scene(cmd) => scene::run(cmd),
        Command::Release(cmd) => release::run(cmd),
        Command::Baseline(args) => baseline::run(args),
        Command::Bench(cmd) => bench::run(cmd),
    }
}
