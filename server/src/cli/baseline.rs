//! `osmab baseline NAME --release DIR --out SUBMISSION_DIR`: the controls made from the
//! ground truth, or `perceive`, the reference mapper that maps from the frames alone.

use std::path::PathBuf;

use clap::Args;
use osmab_dataset::baselines::{Control, write_baseline};
use osmab_mapper::FeatureSet;

/// The reference mapper's name on the command line.
pub const PERCEIVE: &str = "perceive";

#[derive(Debug, Args)]
pub struct BaselineArgs {
    /// perceive (the reference mapper, from the frames alone), or a control made from the
    /// ground truth: oracle, drop-small, merge, label-noise or pose-drift.
    name: String,
    /// A built release (a control needs its ground_truth/; perceive reads only its public files).
    #[arg(long)]
    release: PathBuf,
    /// The submission directory to write.
    #[arg(long)]
    out: PathBuf,
    /// perceive only: classify regions by their geometry alone (the twin that shows what seeing adds).
    #[arg(long)]
    geometry_only: bool,
}

pub fn run(args: BaselineArgs) -> anyhow::Result<()> {
    if args.name == PERCEIVE {
        let set = if args.geometry_only { FeatureSet::GeometryOnly } else { FeatureSet::Seeing };
        let started = std::time::Instant::now();
        let done = osmab_mapper::perceive(&args.release, &args.out, set)?;
        println!(
            "{}: {} with {} maps, learned from {} val regions of {} classes, in {:.1} s",
            args.out.display(),
            osmab_mapper::submission::method_name(set),
            done.maps,
            done.training_regions,
            done.training_classes,
            started.elapsed().as_secs_f64()
        );
        return Ok(());
    }
    if args.geometry_only {
        anyhow::bail!("--geometry-only is an option of the reference mapper (osmab baseline perceive), not of the control '{}'", args.name);
    }
    let control: Control = args
        .name
        .parse()
        .map_err(|_| anyhow::anyhow!("unknown baseline '{}' (expected {PERCEIVE} or one of {})", args.name, Control::ALL.map(Control::name).join(", ")))?;
    let maps = write_baseline(control, &args.release, &args.out)?;
    println!("{}: baseline {} with {maps} maps", args.out.display(), args.name);
    Ok(())
}
