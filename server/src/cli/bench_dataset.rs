//! `osmab bench scenes|render|release-estimate`: the dataset pipeline's timings — prompts to
//! converted scenes, lit and unlit rendering of a scene, and the estimate of a whole
//! release's build time from a sample of its scenes.

use std::time::Instant;

use anyhow::Context;
use osmab_evaluator::scores::ReleaseLighting;

pub fn scenes(furniture_pool: usize, manipuland_pool: usize, furniture: usize, manipuland: usize, scenesmith: Option<&std::path::Path>) -> anyhow::Result<()> {
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

pub fn render_frames(scenesmith: &std::path::Path, frames: usize, lighting: Option<&str>, save: Option<&std::path::Path>) -> anyhow::Result<()> {
    use osmab_dataset::convert::habitat::{ConvertOptions, write_habitat_scene};
    use osmab_dataset::convert::light_settings::LightSettings;
    use osmab_dataset::convert::scene::load_scene;
    use osmab_dataset::render::lit_worlds;
    use osmab_dataset::render::mesh::World;
    use osmab_dataset::render::raster::{Camera, Frame, Lighting, Shading, find_visible, shade_lightings};
    use osmab_dataset::render::sequence::lights_for_goal;

    let work = std::env::temp_dir().join(format!("osmab-bench-render-{}", std::process::id()));
    let scene = load_scene(scenesmith)?;
    write_habitat_scene(&scene, &work, &ConvertOptions::default())?;
    let clock = Instant::now();
    let world = World::load_habitat_scene(&work, &scene.name)?;
    let load = clock.elapsed().as_secs_f64();
    // `all`: the four lightings of a release, shaded from one visibility pass as a release
    // build draws them.
    let names: Vec<&str> = match lighting {
        Some("all") => vec!["baseline", "camera", "dynamic_lights", "no_lights"],
        Some(lighting) => vec![lighting],
        None => Vec::new(),
    };
    let settings = names
        .iter()
        .map(|lighting| {
            let path = work.join(format!("lighting_hadage/light_settings_{}_{lighting}.json", scene.name));
            LightSettings::read(&path).with_context(|| format!("{}: no such lighting", path.display()))
        })
        .collect::<anyhow::Result<Vec<_>>>()?;
    let (worlds, shadings) = if settings.is_empty() {
        (vec![world], vec![Shading::Flat])
    } else {
        let clock = Instant::now();
        let worlds = lit_worlds(&world, &settings);
        println!("light bake (ambient occlusion, shadows of the static lights): {:.2} s", clock.elapsed().as_secs_f64());
        let shadings = settings.iter().map(|s| if s.is_unlit() { Shading::Flat } else { Shading::Lit(lights_for_goal(s, 0)) }).collect();
        (worlds, shadings)
    };
    let lightings: Vec<Lighting> = worlds.iter().zip(&shadings).map(|(world, shading)| Lighting { world, shading }).collect();
    let mut frame = Frame::default();
    let mut rgbs = vec![Vec::new(); lightings.len()];
    let clock = Instant::now();
    for i in 0..frames {
        // Turn on the spot at the room centre, 1 m up (OpenCV axes in the Habitat world).
        let a = std::f64::consts::TAU * i as f64 / frames as f64;
        let (c, s) = (a.cos(), a.sin());
        let pose = nalgebra::Matrix4::new(c, 0.0, -s, 0.0, 0.0, -1.0, 0.0, 1.0, -s, 0.0, -c, 0.0, 0.0, 0.0, 0.0, 1.0);
        let camera = Camera { width: 1200, height: 680, fx: 600.0, fy: 600.0, cx: 599.5, cy: 339.5, pose };
        find_visible(&worlds[0], &camera, &mut frame);
        shade_lightings(&lightings, &camera, &mut frame, &mut rgbs);
    }
    let seconds = clock.elapsed().as_secs_f64();
    println!(
        "{} triangles (loaded in {load:.2} s); {frames} frames of 1200x680 in {seconds:.2} s: {:.1} frames/s ({})",
        worlds[0].triangles().len(),
        frames as f64 / seconds,
        if names.is_empty() { "flat".to_string() } else { names.join(" + ") }
    );
    let passes = frame.pass_times;
    let per_frame = |d: std::time::Duration| 1e3 * d.as_secs_f64() / frames.max(1) as f64;
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
        encoder.write_header()?.write_image_data(&rgbs[0])?;
    }
    let _ = std::fs::remove_dir_all(&work);
    Ok(())
}

pub fn release_estimate(config_path: &std::path::Path, sample: usize, timed_frames: usize) -> anyhow::Result<()> {
    use osmab_dataset::convert::habitat::{ConvertOptions, write_habitat_scene};
    use osmab_dataset::convert::scene::load_scene;
    use osmab_dataset::embedding::{Embedder, HashingEmbedder};
    use osmab_dataset::release::config::ReleaseConfig;
    use osmab_dataset::render::coverage::CoverageGoals;
    use osmab_dataset::selection::select;
    use osmab_dataset::spec::Regime;

    let (config, _) = ReleaseConfig::read(config_path)?;
    let assets =
        osmab_dataset::synthesis::source::AssetSource::for_config(config.synthesis.assets.as_deref(), &osmab_dataset::synthesis::source::assets_root())?;
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
        let rendered =
            osmab_dataset::render::render_scene(&work.join("hab").join(&name), &name, &[ReleaseLighting::Baseline], &sensor, timed, &work.join("seq"))?;
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
