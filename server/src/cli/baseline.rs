//! `osmab baseline NAME --release DIR --out SUBMISSION_DIR`.

use std::path::PathBuf;

use clap::Args;
use osmab_dataset::baselines::{BASELINES, write_baseline};

#[derive(Debug, Args)]
pub struct BaselineArgs {
    /// oracle, drop-small, merge, label-noise or pose-drift.
    name: String,
    /// A built release (with its ground_truth/).
    #[arg(long)]
    release: PathBuf,
    /// The submission directory to write.
    #[arg(long)]
    out: PathBuf,
}

pub fn run(args: BaselineArgs) -> anyhow::Result<()> {
    if !BASELINES.contains(&args.name.as_str()) {
        anyhow::bail!("unknown baseline '{}' (expected one of {})", args.name, BASELINES.join(", "));
    }
    let maps = write_baseline(&args.name, &args.release, &args.out)?;
    println!("{}: baseline {} with {maps} maps", args.out.display(), args.name);
    Ok(())
}
