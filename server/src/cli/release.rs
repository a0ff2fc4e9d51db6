//! `osmab release build` and `osmab release verify`.

use std::io::IsTerminal;
use std::path::PathBuf;
use std::time::Instant;

use clap::Subcommand;
use indicatif::{ProgressBar, ProgressStyle};
use osmab_dataset::release::{build_release, verify_release};

#[derive(Debug, Subcommand)]
pub enum ReleaseCommand {
    /// Run the whole pipeline (prompts → selection → synthesis → conversion → rendering → ground truth) into a release.
    Build {
        /// The release configuration (see configs/release-demo.toml).
        #[arg(long)]
        config: PathBuf,
        /// Output directory; a build interrupted earlier resumes where it stopped.
        #[arg(long)]
        out: PathBuf,
    },
    /// Check every file of a release against its manifest.
    Verify {
        /// The release directory.
        dir: PathBuf,
    },
    /// Register a built release with the service (same database and storage as `osmab serve`).
    Import {
        /// The release directory (built by `osmab release build`).
        dir: PathBuf,
        /// Make it the current release at once (otherwise it stays a draft until published).
        #[arg(long)]
        publish: bool,
        #[command(flatten)]
        service: super::service::ServiceArgs,
    },
}

pub fn run(cmd: ReleaseCommand) -> anyhow::Result<()> {
    match cmd {
        ReleaseCommand::Build { config, out } => {
            let started = Instant::now();
            // A live spinner on a terminal; plain timed lines in logs and CI.
            let spinner = std::io::stderr().is_terminal().then(|| {
                let bar = ProgressBar::new_spinner();
                bar.set_style(ProgressStyle::with_template("{spinner} [{elapsed_precise}] {msg}").expect("valid template"));
                bar.enable_steady_tick(std::time::Duration::from_millis(120));
                bar
            });
            let progress = |message: &str| match &spinner {
                Some(bar) => bar.set_message(message.to_string()),
                None => eprintln!("[{:>7.1}s] {message}", started.elapsed().as_secs_f64()),
            };
            let secret = osmab_dataset::release::split::SplitSecret::from_env()?;
            let result = build_release(&config, &out, secret.as_ref(), &osmab_dataset::synthesis::source::assets_root(), &progress);
            if let Some(bar) = &spinner {
                bar.finish_and_clear();
            }
            result?;
            println!("{}: release built in {:.1} s", out.display(), started.elapsed().as_secs_f64());
            Ok(())
        }
        ReleaseCommand::Import { dir, publish, service } => super::service::import(&dir, publish, service),
        ReleaseCommand::Verify { dir } => {
            let n = verify_release(&dir)?;
            println!("{}: {n} files match the manifest", dir.display());
            Ok(())
        }
    }
}
