//! `osmab gt build`.

use std::path::PathBuf;

use clap::Subcommand;
use osmab_evaluator::formats::sequence::Sequence;
use osmab_evaluator::ground_truth::GroundTruth;

#[derive(Debug, Subcommand)]
pub enum GtCommand {
    /// Build pointcloud.pcd + semantic.npy from a HaDaGe sequence, as OSMa-Bench does.
    Build {
        /// Sequence directory (results/, traj.txt, camera_params.yaml, embed_semseg_classes.json).
        sequence: PathBuf,
        /// Output directory.
        #[arg(long)]
        out: PathBuf,
    },
}

pub fn run(cmd: GtCommand) -> anyhow::Result<()> {
    match cmd {
        GtCommand::Build { sequence, out } => {
            let sequence = Sequence::open(&sequence)?;
            let ground_truth = GroundTruth::build(&sequence)?;
            ground_truth.write(&out)?;
            // The class list travels with the ground truth so `eval semseg` finds it.
            sequence.classes()?.write(&out.join("embed_semseg_classes.json"))?;
            println!("{}: {} points from {} frames", out.display(), ground_truth.points.len(), sequence.len());
            Ok(())
        }
    }
}
