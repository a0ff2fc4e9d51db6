//! `osmab bench`: synthetic data of the published sizes and timings of the scorer.
//! The comparison with the SciPy reference is driven by bench/semseg_vs_scipy.py.

use std::path::PathBuf;
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
        /// Light the scene with the baseline layout (default: flat shading).
        #[arg(long)]
        lit: bool,
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
    /// Time the symbolic VQA answerer and the judge on a full-size synthetic submission.
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
        #[arg(long, default_value_t = 1)]
        repeat: usize,
    },
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
            let mut scene = generate(SceneSpec { gt_points, map_points, objects, feature_dim, seed, map_covers_room });
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
        BenchCommand::ReleaseEstimate { config, sample, timed_frames } => release_estimate(&config, sample, timed_frames),
        BenchCommand::Render { scenesmith, frames, lit, save } => render_frames(&scenesmith, frames, lit, save.as_deref()),
        BenchCommand::Scenes { furniture_pool, manipuland_pool, furniture, manipuland, scenesmith } => {
            scenes(furniture_pool, manipuland_pool, furniture, manipuland, scenesmith.as_deref())
        }
        BenchCommand::Questions { releases, regenerate, draws, json } => super::bench_questions::run(&releases, regenerate, draws, json.as_deref()),
        BenchCommand::Vqa { scenes, lightings, objects, questions, repeat } => {
            super::bench_vqa::run(super::bench_vqa::VqaBenchSize { scenes, lightings, objects, questions, repeat })
        }
        BenchCommand::Ranking { entries, repeat } => ranking(entries, repeat),
        BenchCommand::Submission { data, scenes, gt_points, map_points, objects, map_covers_room, no_ground_truth_cache, warm_node, repeat } => {
            let size = super::bench_submission::SubmissionBenchSize { scenes, gt_points, map_points, objects, map_covers_room };
            let node = match (no_ground_truth_cache, warm_node) {
                (true, _) => super::bench_submission::Node::WithoutCache,
                (false, false) => super::bench_submission::Node::Cold,
                (false, true) => super::bench_submission::Node::Warmed,
            };
            super::bench_submission::run(&size, &data, node, repeat)
        }
        BenchCommand::Nearest { gt_points, map_points, repeat, map_covers_room, shuffle: random_order } => {
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
    }
}

fn scenes(furniture_pool: usize, manipuland_pool: usize, furniture: usize, manipuland: usize, scenesmith: Option<&std::path::Path>) -> anyhow::Result<()> {
    use osmab_dataset::convert::habitat::{ConvertOptions, write_habitat_scene};
    use osmab_dataset::convert::scene::load_scene;
    use osmab_dataset::embedding::{Embedder, HashingEmbedder};
    use osmab_dataset::prompts::grammar_pool;
    use osmab_dataset::selection::{NEAR_DUPLICATE_COSINE, select};
    use osmab_dataset::spec::Regime;

    let clock = Instant::now();
    let pools = [
        (Regime::Furniture, grammar_pool(Regime::Furniture, furniture_pool, 42), furniture),
        (Regime::Manipuland, grammar_pool(Regime::Manipuland, manipuland_pool, 42), manipuland),
    ];
    let prompt_time = clock.elapsed().as_secs_f64();
    let written: usize = pools.iter().map(|(_, p, _)| p.accepted.len() + p.rejected.len()).sum();
    let accepted: usize = pools.iter().map(|(_, p, _)| p.accepted.len()).sum();

    let clock = Instant::now();
    let mut selected = Vec::new();
    for (_, pool, target) in &pools {
        let texts: Vec<String> = pool.accepted.iter().map(|p| p.text.clone()).collect();
        let ids: Vec<String> = pool.accepted.iter().map(|p| p.id.clone()).collect();
        let report = select(&ids, &HashingEmbedder::default().embed(&texts)?, *target, NEAR_DUPLICATE_COSINE);
        selected.extend(report.selected.iter().map(|s| pool.accepted.iter().find(|p| p.id == s.id).expect("from the pool").clone()));
    }
    let select_time = clock.elapsed().as_secs_f64();

    let work = std::env::temp_dir().join(format!("osmab-bench-scenes-{}", std::process::id()));
    let (mut synth_times, mut convert_times) = (Vec::new(), Vec::new());
    for (i, prompt) in selected.iter().enumerate() {
        let dir = work.join(format!("scene_{i:03}"));
        let clock = Instant::now();
        osmab_dataset::synthesis::synthesize(prompt, i as u64, &dir, false, &osmab_dataset::synthesis::source::AssetSource::procedural())?;
        synth_times.push(clock.elapsed().as_secs_f64());
        let clock = Instant::now();
        write_habitat_scene(&load_scene(&dir)?, &work.join(format!("habitat_{i:03}")), &ConvertOptions::default())?;
        convert_times.push(clock.elapsed().as_secs_f64());
    }
    let scenesmith_time = match scenesmith {
        Some(dir) => {
            let clock = Instant::now();
            write_habitat_scene(&load_scene(dir)?, &work.join("scenesmith"), &ConvertOptions::default())?;
            Some(clock.elapsed().as_secs_f64())
        }
        None => None,
    };
    let _ = std::fs::remove_dir_all(&work);
    let mean = |v: &[f64]| v.iter().sum::<f64>() / v.len().max(1) as f64;
    let max = |v: &[f64]| v.iter().copied().fold(0.0, f64::max);
    println!("| stage | measure | value |");
    println!("|---|---|---:|");
    println!("| prompts (grammar + filters) | {written} written, {accepted} kept, in {prompt_time:.3} s | {:.0} prompts/s |", written as f64 / prompt_time);
    println!("| selection (embed + dedup + farthest-first) | {} of {accepted} selected | {select_time:.3} s |", selected.len());
    println!("| synthesis | mean / max per scene over {} scenes | {:.1} / {:.1} ms |", synth_times.len(), 1e3 * mean(&synth_times), 1e3 * max(&synth_times));
    println!(
        "| conversion | mean / max per scene over {} scenes | {:.1} / {:.1} ms |",
        convert_times.len(),
        1e3 * mean(&convert_times),
        1e3 * max(&convert_times)
    );
    if let Some(t) = scenesmith_time {
        println!("| conversion of the SceneSmith scene | real assets (5 glTF, 7 MB) | {:.1} ms |", 1e3 * t);
    }
    Ok(())
}

fn render_frames(scenesmith: &std::path::Path, frames: usize, lit: bool, save: Option<&std::path::Path>) -> anyhow::Result<()> {
    use osmab_dataset::convert::habitat::{ConvertOptions, write_habitat_scene};
    use osmab_dataset::convert::scene::load_scene;
    use osmab_dataset::render::mesh::World;
    use osmab_dataset::render::raster::{Camera, Frame, Light, Shading, render};

    let work = std::env::temp_dir().join(format!("osmab-bench-render-{}", std::process::id()));
    let scene = load_scene(scenesmith)?;
    write_habitat_scene(&scene, &work, &ConvertOptions::default())?;
    let clock = Instant::now();
    let world = World::load_habitat_scene(&work, &scene.name)?;
    let load = clock.elapsed().as_secs_f64();
    let shading = if lit {
        let text = std::fs::read(work.join(format!("lighting_hadage/light_settings_{}_baseline.json", scene.name)))?;
        let json: serde_json::Value = serde_json::from_slice(&text)?;
        Shading::Lit(
            json["lights"]
                .as_object()
                .into_iter()
                .flatten()
                .map(|(_, l)| {
                    let v = |k: &str, i: usize| l[k][i].as_f64().unwrap_or(0.0) as f32;
                    let intensity = l["intensity"].as_f64().unwrap_or(0.0) as f32;
                    let scale = intensity * if intensity < 0.0 { 0.1 } else { 2.5 };
                    Light {
                        position: [v("position", 0), v("position", 1), v("position", 2)],
                        color: [v("color", 0) * scale, v("color", 1) * scale, v("color", 2) * scale],
                        attached_to_camera: false,
                    }
                })
                .collect(),
        )
    } else {
        Shading::Flat
    };
    let mut frame = Frame::default();
    let clock = Instant::now();
    for i in 0..frames {
        // Turn on the spot at the room centre, 1 m up (OpenCV axes in the Habitat world).
        let a = std::f64::consts::TAU * i as f64 / frames as f64;
        let (c, s) = (a.cos(), a.sin());
        let pose = nalgebra::Matrix4::new(c, 0.0, -s, 0.0, 0.0, -1.0, 0.0, 1.0, -s, 0.0, -c, 0.0, 0.0, 0.0, 0.0, 1.0);
        let camera = Camera { width: 1200, height: 680, fx: 600.0, fy: 600.0, cx: 599.5, cy: 339.5, pose };
        render(&world, &camera, &shading, &mut frame);
    }
    let seconds = clock.elapsed().as_secs_f64();
    println!(
        "{} triangles (loaded in {load:.2} s); {frames} frames of 1200x680 in {seconds:.2} s: {:.1} frames/s ({})",
        world.triangles().len(),
        frames as f64 / seconds,
        if lit { "lit" } else { "flat" }
    );
    let passes = frame.pass_times;
    let per_frame = |d: std::time::Duration| 1e3 * d.as_secs_f64() / passes.frames.max(1) as f64;
    println!(
        "per frame: transform {:.2} ms, visibility {:.2} ms, resolve {:.2} ms (each pass on all cores)",
        per_frame(passes.transform),
        per_frame(passes.visibility),
        per_frame(passes.resolve)
    );
    if let Some(path) = save {
        let file = std::fs::File::create(path)?;
        let mut encoder = png::Encoder::new(std::io::BufWriter::new(file), 1200, 680);
        encoder.set_color(png::ColorType::Rgb);
        encoder.set_depth(png::BitDepth::Eight);
        encoder.write_header()?.write_image_data(&frame.rgb)?;
    }
    let _ = std::fs::remove_dir_all(&work);
    Ok(())
}

fn release_estimate(config_path: &std::path::Path, sample: usize, timed_frames: usize) -> anyhow::Result<()> {
    use osmab_dataset::convert::habitat::{ConvertOptions, write_habitat_scene};
    use osmab_dataset::convert::scene::load_scene;
    use osmab_dataset::embedding::{Embedder, HashingEmbedder};
    use osmab_dataset::release::config::ReleaseConfig;
    use osmab_dataset::render::coverage::CoverageGoals;
    use osmab_dataset::selection::select;
    use osmab_dataset::spec::Regime;

    let (config, _) = ReleaseConfig::read(config_path)?;
    let assets = osmab_dataset::synthesis::source::AssetSource::for_config(config.synthesis.assets.as_deref())?;
    let clock = Instant::now();
    let mut chosen = Vec::new();
    for (regime, pool_size, target) in [
        (Regime::Furniture, config.prompts.furniture_pool, config.selection.furniture),
        (Regime::Manipuland, config.prompts.manipuland_pool, config.selection.manipuland),
    ] {
        let pool = osmab_dataset::prompts::grammar_pool_with(regime, pool_size, config.seed, &assets);
        let texts: Vec<String> = pool.accepted.iter().map(|p| p.text.clone()).collect();
        let keys: Vec<String> = (0..texts.len()).map(|i| i.to_string()).collect();
        let report = select(&keys, &HashingEmbedder::default().embed(&texts)?, target, config.selection.threshold);
        chosen.extend(report.selected.iter().map(|s| pool.accepted[s.id.parse::<usize>().expect("index")].clone()));
    }
    let prompt_time = clock.elapsed().as_secs_f64();
    let total_scenes = chosen.len();
    // Sample scenes spread over both regimes.
    let picks: Vec<usize> = (0..sample.min(total_scenes)).map(|k| k * total_scenes / sample.min(total_scenes).max(1)).collect();
    let work = std::env::temp_dir().join(format!("osmab-release-estimate-{}", std::process::id()));
    let sensor = config.render.sensor();
    let (mut scene_seconds, mut frames_total, mut per_frame) = (0.0, 0usize, Vec::new());
    println!("| sampled scene | regime | synthesis + conversion + planning s | frames per lighting | s per frame (render + write) |");
    println!("|---|---|---:|---:|---:|");
    for &i in &picks {
        let prompt = &chosen[i];
        let name = format!("scene_{i:03}");
        let clock = Instant::now();
        osmab_dataset::synthesis::synthesize(prompt, config.seed.wrapping_add(i as u64), &work.join("ss").join(&name), config.synthesis.ceiling, &assets)?;
        let mut loaded = load_scene(&work.join("ss").join(&name))?;
        loaded.name = name.clone();
        write_habitat_scene(&loaded, &work.join("hab").join(&name), &ConvertOptions::default())?;
        let motion = config.render.motion(prompt.spec.regime, config.seed.wrapping_add(i as u64));
        let prompted: Vec<String> = prompt.spec.objects.iter().map(|o| o.category.clone()).collect();
        let coverage = CoverageGoals { min_travel: config.quality.min_travel, ..Default::default() };
        let plan = osmab_dataset::render::plan_scene(&work.join("hab").join(&name), &name, &sensor, &motion, &prompted, &coverage)?;
        let prepare = clock.elapsed().as_secs_f64();
        let frames = plan.frames.len();
        let timed = &plan.frames[..timed_frames.min(frames)];
        let clock = Instant::now();
        let rendered = osmab_dataset::render::render_scene(&work.join("hab").join(&name), &name, &["baseline"], &sensor, timed, &work.join("seq"))?;
        let seconds = clock.elapsed().as_secs_f64() / rendered[0].1.frames.max(1) as f64;
        println!("| {name} | {} | {prepare:.2} | {frames} | {seconds:.4} |", prompt.spec.regime.name());
        scene_seconds += prepare;
        frames_total += frames;
        per_frame.push(seconds);
    }
    let _ = std::fs::remove_dir_all(&work);
    let n = picks.len().max(1) as f64;
    let mean_frames = frames_total as f64 / n;
    let mean_per_frame = per_frame.iter().sum::<f64>() / n;
    let lightings = config.render.lightings.len() as f64;
    let estimate = prompt_time + total_scenes as f64 * (scene_seconds / n + mean_frames * lightings * mean_per_frame * 1.02);
    println!();
    println!(
        "{total_scenes} scenes × {} lightings × {mean_frames:.0} frames on average at {:.4} s a frame, plus prompts/selection ({prompt_time:.1} s) and synthesis/conversion: about {:.0} min ({:.1} h) on this machine (ground truth adds ~2 %).",
        lightings,
        mean_per_frame,
        estimate / 60.0,
        estimate / 3600.0
    );
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
