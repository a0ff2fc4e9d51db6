//! `osmab bench`: synthetic data of the published sizes and timings of the scorer.
//! The comparison with the SciPy reference is driven by bench/semseg_vs_scipy.py.

use std::path::{Path, PathBuf};
use std::time::Instant;

use clap::Subcommand;
use osmab_evaluator::semseg::NearestIndex;
use osmab_evaluator::synthetic::{SceneSpec, generate};
use rayon::prelude::*;

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
        /// Write the ground-truth points (with their labels) in a random order, as a
        /// shuffled or voxel-downsampled ground truth arrives: no frame or row coherence.
        #[arg(long)]
        shuffle: bool,
        /// Output directory.
        #[arg(long)]
        out: PathBuf,
    },
    /// Time the scene pipeline: prompt pool, selection, synthesis and conversion per scene.
    Scenes {
        /// Furniture prompts in the pool.
        #[arg(long, default_value_t = 250)]
        furniture_pool: usize,
        /// Manipuland prompts in the pool.
        #[arg(long, default_value_t = 100)]
        manipuland_pool: usize,
        /// Scenes selected: furniture.
        #[arg(long, default_value_t = 24)]
        furniture: usize,
        /// Scenes selected: manipuland.
        #[arg(long, default_value_t = 16)]
        manipuland: usize,
        /// A SceneSmith scene to convert as well (e.g. ../shared/fixtures/scenesmith/scene_000).
        #[arg(long)]
        scenesmith: Option<PathBuf>,
    },
    /// Render frames (RGB + depth + semantic) of a converted scene at 1200×680 and report frames per second.
    Render {
        /// A SceneSmith scene (converted first) to render.
        #[arg(long)]
        scenesmith: PathBuf,
        /// Frames to render.
        #[arg(long, default_value_t = 60)]
        frames: usize,
        /// Light the scene (default: flat shading) with its lighting `--lighting`, shadows
        /// and ambient occlusion baked first (the bake is timed apart).
        #[arg(long)]
        lit: bool,
        /// The lighting `--lit` renders: baseline, camera or dynamic_lights (its first goal);
        /// or `all`, the release's four shaded from one visibility pass, as a release draws them.
        #[arg(long, default_value = "baseline")]
        lighting: String,
        /// Write the last frame's RGB here (PNG).
        #[arg(long)]
        save: Option<PathBuf>,
    },
    /// Estimate a release's build time from a measured sample of its scenes.
    ReleaseEstimate {
        /// The release configuration (e.g. configs/release-full.toml).
        #[arg(long)]
        config: PathBuf,
        /// Scenes to sample.
        #[arg(long, default_value_t = 3)]
        sample: usize,
        /// Frames rendered per sampled scene to time rendering and writing.
        #[arg(long, default_value_t = 40)]
        timed_frames: usize,
    },
    /// How much of a build's hidden test answers text-only predictors get right, per question
    /// template, against each template's majority answer (an operator's build folder: its
    /// ground truth and `.work/prompts`); several builds are summed.
    Questions {
        /// Build folders of `osmab release build`.
        #[arg(long = "release", required = true)]
        releases: Vec<PathBuf>,
        /// Draw the questions anew with this binary's generator, from the scenes' objects and
        /// prompts the builds kept (measures a change of the generator without rendering again).
        #[arg(long)]
        regenerate: bool,
        /// With --regenerate: independent draws of the test scenes' questions to measure over.
        #[arg(long, default_value_t = 1)]
        draws: u64,
        /// Write the tallies as JSON here.
        #[arg(long)]
        json: Option<PathBuf>,
    },
    /// Time the symbolic VQA answerer and the judge on a full-size synthetic submission.
    Vqa {
        #[arg(long, default_value_t = 40)]
        scenes: usize,
        #[arg(long, default_value_t = 4)]
        lightings: usize,
        /// Scene-graph nodes per scene (ConceptGraphs' example has 64).
        #[arg(long, default_value_t = 64)]
        objects: usize,
        /// Questions per scene (OSMa-Bench's ReplicaCAD set has about 184).
        #[arg(long, default_value_t = 200)]
        questions: usize,
        #[arg(long, default_value_t = 3)]
        repeat: usize,
    },
    /// Time the rank groups of a leaderboard: every pair of entries compared by a paired
    /// bootstrap of 1,000 replicates (what each board rebuild does).
    Ranking {
        #[arg(long, default_value_t = 200)]
        entries: usize,
        #[arg(long, default_value_t = 3)]
        repeat: usize,
    },
    /// Score a whole submission — every scene under every lighting, at a full release's
    /// sizes, with scene graphs and questions — from its archive as the worker does, and
    /// print the time of each stage. The data is generated under `--data` once.
    Submission {
        /// Where the release and the submission archive are generated (and reused).
        #[arg(long, default_value = "bench/data/submission")]
        data: PathBuf,
        /// Scenes (24 furniture + 16 manipuland in a full release).
        #[arg(long, default_value_t = 40)]
        scenes: usize,
        /// Ground-truth points a scene: a full release's ~390 frames a sequence at
        /// 1200×680, every 5th frame, every 10th point (OSMa-Bench's procedure).
        #[arg(long, default_value_t = 6_400_000)]
        gt_points: usize,
        /// Points a map (a ConceptGraphs-style map of such a room at 2.5 cm voxels).
        #[arg(long, default_value_t = 500_000)]
        map_points: usize,
        /// Objects in each room.
        #[arg(long, default_value_t = 40)]
        objects: usize,
        /// Maps cover the room's floor, walls and ceiling too.
        #[arg(long)]
        map_covers_room: bool,
        /// Put every scene's ground truth in Z-order on every run, as a node without its
        /// cache of prepared ground truth does (by default the first run fills the cache,
        /// emptied at the start, and later runs read it, as the worker does).
        #[arg(long)]
        no_ground_truth_cache: bool,
        /// Before the first run, make the node ready as an idle worker does (every scene's
        /// ground truth prepared into the emptied cache, its box learnt), timed on its own:
        /// run 0 is then the first submission on a node that was idle before it came.
        #[arg(long, conflicts_with = "no_ground_truth_cache")]
        warm_node: bool,
        /// Keep the cache of prepared ground truth an earlier bench left under `--data`
        /// (entries that no longer match the release are prepared again): every run is then
        /// warm, for comparing two binaries without the cold run's minute each time.
        #[arg(long, conflicts_with_all = ["no_ground_truth_cache", "warm_node"])]
        keep_cache: bool,
        #[arg(long, default_value_t = 1)]
        repeat: usize,
    },
    /// Time the nearest-neighbour index of a map: building it, and querying every
    /// ground-truth point frame by frame (or shuffled) and in Z-order.
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
        /// Query the ground-truth points in a random order (no frame or row coherence).
        #[arg(long)]
        shuffle: bool,
    },
}

pub fn run(cmd: BenchCommand) -> anyhow::Result<()> {
    match cmd {
        BenchCommand::Synth { gt_points, map_points, objects, feature_dim, seed, map_covers_room, shuffle: random_order, out } => {
            synth(SceneSpec { gt_points, map_points, objects, feature_dim, seed, map_covers_room }, random_order, &out)
        }
        BenchCommand::ReleaseEstimate { config, sample, timed_frames } => super::bench_dataset::release_estimate(&config, sample, timed_frames),
        BenchCommand::Render { scenesmith, frames, lit, lighting, save } => {
            super::bench_dataset::render_frames(&scenesmith, frames, lit.then_some(lighting.as_str()), save.as_deref())
        }
        BenchCommand::Scenes { furniture_pool, manipuland_pool, furniture, manipuland, scenesmith } => {
            super::bench_dataset::scenes(furniture_pool, manipuland_pool, furniture, manipuland, scenesmith.as_deref())
        }
        BenchCommand::Questions { releases, regenerate, draws, json } => super::bench_questions::run(&releases, regenerate, draws, json.as_deref()),
        BenchCommand::Vqa { scenes, lightings, objects, questions, repeat } => {
            super::bench_vqa::run(super::bench_vqa::VqaBenchSize { scenes, lightings, objects, questions, repeat })
        }
        BenchCommand::Ranking { entries, repeat } => ranking(entries, repeat),
        BenchCommand::Submission { data, scenes, gt_points, map_points, objects, map_covers_room, no_ground_truth_cache, warm_node, keep_cache, repeat } => {
            let size = super::bench_submission::SubmissionBenchSize { scenes, gt_points, map_points, objects, map_covers_room };
            let node = match (no_ground_truth_cache, warm_node, keep_cache) {
                (true, _, _) => super::bench_submission::Node::WithoutCache,
                (false, true, _) => super::bench_submission::Node::Warmed,
                (false, false, true) => super::bench_submission::Node::Kept,
                (false, false, false) => super::bench_submission::Node::Cold,
            };
            super::bench_submission::run(&size, &data, node, repeat)
        }
        BenchCommand::Nearest { gt_points, map_points, repeat, map_covers_room, shuffle: random_order } => {
            nearest(gt_points, map_points, repeat, map_covers_room, random_order)
        }
    }
}

/// `osmab bench synth`: write a synthetic scene (ground truth, map, text features) to `out`.
fn synth(spec: SceneSpec, random_order: bool, out: &Path) -> anyhow::Result<()> {
    let (gt_points, map_points, seed) = (spec.gt_points, spec.map_points, spec.seed);
    let mut scene = generate(spec);
    if random_order {
        // One permutation for the points, their labels and colours.
        let gt = &mut scene.ground_truth;
        let mut permutation: Vec<usize> = (0..gt.points.len()).collect();
        shuffle(&mut permutation, seed);
        gt.points = permutation.iter().map(|&i| gt.points[i]).collect();
        gt.labels = permutation.iter().map(|&i| gt.labels[i]).collect();
        gt.colors = gt.colors.take().map(|colors| permutation.iter().map(|&i| colors[i]).collect());
    }
    let gt_dir = out.join("gt");
    scene.ground_truth.write(&gt_dir)?;
    scene.classes.write(&gt_dir.join("embed_semseg_classes.json"))?;
    scene.map.write(&out.join("map.npz"), false)?;
    scene.text.write(&out.join("text_features.npz"))?;
    println!("{}: {gt_points} ground-truth points, {map_points} map points", out.display());
    Ok(())
}

/// `osmab bench nearest`: time building the nearest-neighbour index of a map and querying
/// every ground-truth point, frame by frame (or shuffled) and in Z-order.
fn nearest(gt_points: usize, map_points: usize, repeat: usize, map_covers_room: bool, random_order: bool) -> anyhow::Result<()> {
    let mut scene = generate(SceneSpec { gt_points, map_points, objects: 60, feature_dim: 8, seed: 7, map_covers_room });
    if random_order {
        shuffle(&mut scene.ground_truth.points, 7);
    }
    println!("threads {}, queries {}", rayon::current_num_threads(), if random_order { "in random order" } else { "frame by frame" });
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
        // As a whole submission's scoring does: the cloud put in Z-order once (for
        // all the maps of its scene), then answered in that order.
        let clock = Instant::now();
        let order = osmab_evaluator::semseg::z_order::z_order(&scene.ground_truth.points);
        let ordered: Vec<[f32; 3]> = order.par_iter().map(|&i| scene.ground_truth.points[i as usize]).collect();
        let ordering = clock.elapsed();
        let clock = Instant::now();
        let in_order = index.nearest_all_in_order(&ordered);
        let queried = clock.elapsed();
        println!(
            "       in Z-order once: ordering {:.3} s, queries {:.3} s, checksum {}",
            ordering.as_secs_f64(),
            queried.as_secs_f64(),
            in_order.iter().map(|&i| i as u64).sum::<u64>()
        );
    }
    Ok(())
}

/// `osmab bench ranking`: `entries` synthetic entries, evenly spread in mIoU, each with
/// 1,000 replicates of scene noise (shared between entries, as resamples are) plus noise
/// of its own; the time of `rank_groups` over all of them.
fn ranking(entries: usize, repeat: usize) -> anyhow::Result<()> {
    use crate::leaderboard::ranking::{Standing, rank_groups};
    let mut rng = osmab_evaluator::synthetic::Rng::new(11);
    let shared: Vec<f64> = (0..osmab_evaluator::bootstrap::ROUNDS).map(|_| rng.range(-0.05, 0.05)).collect();
    let standings: Vec<Standing> = (0..entries)
        .map(|i| {
            let value = 0.9 - 0.8 * i as f64 / entries.max(1) as f64;
            Standing { value: Some(value), replicates: shared.iter().map(|s| Some(value + s + rng.range(-0.01, 0.01))).collect() }
        })
        .collect();
    for run in 0..repeat {
        let clock = Instant::now();
        let groups = rank_groups(&standings);
        let distinct = groups.iter().collect::<std::collections::BTreeSet<_>>().len();
        println!(
            "run {run}: {entries} entries, {} pairs compared, {distinct} distinct groups in {:.3} s",
            entries * entries.saturating_sub(1) / 2,
            clock.elapsed().as_secs_f64()
        );
    }
    Ok(())
}

/// Shuffle `items` in place (Fisher–Yates with SplitMix64 from `seed`): queries with no
/// frame or row coherence.
pub fn shuffle<T>(items: &mut [T], seed: u64) {
    let mut state = seed;
    let mut next = || {
        state = state.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = state;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    };
    for i in (1..items.len()).rev() {
        let j = (next() % (i as u64 + 1)) as usize;
        items.swap(i, j);
    }
}
