//! `osmab bench`: synthetic data of the published sizes and timings of the scorer.
//! The comparison with the SciPy reference is driven by bench/semseg_vs_scipy.py.

use std::path::PathBuf;
use std::time::Instant;

use clap::Subcommand;
use osmab_evaluator::semseg::NearestIndex;
use osmab_evaluator::synthetic::{SceneSpec, generate};

#[derive(Debug, Subcommand)]
pub enum BenchCommand {
    /// Write a synthetic scene: gt/{pointcloud.pcd,semantic.npy,embed_semseg_classes.json}, map.npz, text_features.npz.
    Synth {
        /// Ground-truth points.
        #[arg(long, default_value_t = 5_000_000)]
        gt_points: usize,
        /// Predicted map points.
        #[arg(long, default_value_t = 1_000_000)]
        map_points: usize,
        /// Objects in the room.
        #[arg(long, default_value_t = 60)]
        objects: usize,
        /// Feature dimension (ConceptGraphs' ViT-H-14 gives 1024).
        #[arg(long, default_value_t = 1024)]
        feature_dim: usize,
        /// Random seed.
        #[arg(long, default_value_t = 7)]
        seed: u64,
        /// Let the map cover the floor, walls and ceiling too (no far-away queries).
        #[arg(long)]
        map_covers_room: bool,
        /// Output directory.
        #[arg(long)]
        out: PathBuf,
    },
    /// Time index build and queries of the nearest-neighbour association in-process.
    Nearest {
        #[arg(long, default_value_t = 5_000_000)]
        gt_points: usize,
        #[arg(long, default_value_t = 1_000_000)]
        map_points: usize,
        #[arg(long, default_value_t = 3)]
        repeat: usize,
        /// Let the map cover the floor, walls and ceiling too.
        #[arg(long)]
        map_covers_room: bool,
    },
}

pub fn run(cmd: BenchCommand) -> anyhow::Result<()> {
    match cmd {
        BenchCommand::Synth { gt_points, map_points, objects, feature_dim, seed, map_covers_room, out } => {
            let scene = generate(SceneSpec { gt_points, map_points, objects, feature_dim, seed, map_covers_room });
            let gt_dir = out.join("gt");
            scene.ground_truth.write(&gt_dir)?;
            scene.classes.write(&gt_dir.join("embed_semseg_classes.json"))?;
            scene.map.write(&out.join("map.npz"), false)?;
            scene.text.write(&out.join("text_features.npz"))?;
            println!("{}: {gt_points} ground-truth points, {map_points} map points", out.display());
            Ok(())
        }
        BenchCommand::Nearest { gt_points, map_points, repeat, map_covers_room } => {
            let scene = generate(SceneSpec { gt_points, map_points, objects: 60, feature_dim: 8, seed: 7, map_covers_room });
            println!("threads {}", rayon::current_num_threads());
            for run in 0..repeat {
                let clock = Instant::now();
                let index = NearestIndex::build(&scene.map.points);
                let built = clock.elapsed();
                let clock = Instant::now();
                let nearest = index.nearest_all(&scene.ground_truth.points);
                let queried = clock.elapsed();
                println!(
                    "run {run}: build {:.3} s, {} queries {:.3} s ({:.0} ns/query/thread), checksum {}",
                    built.as_secs_f64(),
                    nearest.len(),
                    queried.as_secs_f64(),
                    queried.as_secs_f64() * 1e9 * rayon::current_num_threads() as f64 / nearest.len() as f64,
                    nearest.iter().map(|&i| i as u64).sum::<u64>()
                );
            }
            Ok(())
        }
    }
}
