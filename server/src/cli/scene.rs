//! `osmab scene …`: the first stages of the dataset pipeline.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use anyhow::{Context, bail};
use clap::{Args, Subcommand};
use osmab_dataset::convert::habitat::{ConvertOptions, write_habitat_scene};
use osmab_dataset::convert::scene::load_scene;
use osmab_dataset::embedding::{Embedder, HashingEmbedder, ServiceEmbedder};
use osmab_dataset::openai::{ServiceClient, ServiceConfig};
use osmab_dataset::prompts::{PromptPool, ScenePrompt, grammar_pool, llm::llm_pool};
use osmab_dataset::selection::{NEAR_DUPLICATE_COSINE, SelectionReport, select};
use osmab_dataset::spec::Regime;
use osmab_evaluator::scores::ReleaseLighting;

#[derive(Debug, Subcommand)]
pub enum SceneCommand {
    /// Write a pool of scene prompts with their structured specs (filtered as OSMa-Bench++ does).
    Prompts(PromptsArgs),
    /// Remove near-duplicates and select a diverse subset per regime.
    Select(SelectArgs),
    /// Synthesize scenes in SceneSmith's format from selected prompts (built-in or an external command).
    Synthesize {
        /// final_prompts.json written by `osmab scene select`.
        #[arg(long)]
        prompts: PathBuf,
        /// Seed of the placement and asset sizes (prompts from the grammar carry their own layout).
        #[arg(long, default_value_t = 0)]
        seed: u64,
        /// Give the rooms a ceiling (SceneSmith's have none).
        #[arg(long)]
        ceiling: bool,
        /// An asset pack (a folder with catalogue.json; `assets` is the bundled one) to draw objects and room shells from; the procedural library alone without it.
        #[arg(long)]
        assets: Option<String>,
        /// An external synthesizer, as separate arguments after `--`: {prompt}, {prompt_file} and {out} are filled in.
        #[arg(last = true)]
        command: Vec<String>,
        /// Output directory: scene_000, scene_001, ...
        #[arg(long)]
        out: PathBuf,
    },
    /// Render RGB-D + semantic sequences of a converted scene under the four lightings (HaDaGe layout).
    Render {
        /// A directory written by `osmab scene convert`.
        habitat: PathBuf,
        /// Output root: <lighting>/<scene>/results/...
        #[arg(long)]
        out: PathBuf,
        /// Lightings to render, comma-separated.
        #[arg(long, default_value = "baseline,camera,dynamic_lights,no_lights")]
        lightings: String,
        #[arg(long, default_value_t = 1200)]
        width: u32,
        #[arg(long, default_value_t = 680)]
        height: u32,
        /// Horizontal field of view, degrees.
        #[arg(long, default_value_t = 90.0)]
        hfov: f64,
        /// Camera height above the floor, metres.
        #[arg(long, default_value_t = 1.0)]
        sensor_height: f64,
        /// Camera tilt, degrees (negative looks down).
        #[arg(long, default_value_t = 0.0, allow_negative_numbers = true)]
        pitch: f64,
        /// Navigation goals at least (the planner adds viewpoints until every object is observed).
        #[arg(long, default_value_t = 5)]
        goals: usize,
        /// Object categories the trajectory observes first (comma-separated; the prompt's).
        #[arg(long, default_value = "")]
        prompted: String,
        /// Seed of the start among the best ones.
        #[arg(long, default_value_t = 73)]
        seed: u64,
        /// Frames at most.
        #[arg(long, default_value_t = 20_000)]
        max_frames: usize,
    },
    /// Check an asset pack (the forge's, or an operator's own): its catalogue, every file's
    /// SHA-256 and every mesh against its entry; lists the classes it covers.
    Assets {
        /// The pack: catalogue.json and the files it lists.
        pack: PathBuf,
    },
    /// Convert a Drake/SceneSmith scene into a Habitat-style scene.
    Convert {
        /// The scene directory (package.xml, combined_house/house.dmd.yaml, ...).
        scene: PathBuf,
        /// Output directory.
        #[arg(long)]
        out: PathBuf,
    },
}

/// An OpenAI-compatible service; the API key comes from OSMAB_OPENAI_API_KEY.
#[derive(Debug, Args)]
pub struct ServiceArgs {
    /// Base URL including the version, e.g. http://127.0.0.1:8000/v1 (unset: built-in backend).
    #[arg(long)]
    url: Option<String>,
    /// Model name.
    #[arg(long, default_value = "gpt-4.1-mini")]
    model: String,
    /// Request timeout in seconds.
    #[arg(long, default_value_t = 120.0)]
    timeout: f64,
    /// Retries after a failed request.
    #[arg(long, default_value_t = 4)]
    retries: u32,
}

impl ServiceArgs {
    fn client(&self) -> anyhow::Result<Option<ServiceClient>> {
        let Some(url) = &self.url else { return Ok(None) };
        let mut config = ServiceConfig::new(url.clone(), self.model.clone());
        config.api_key = std::env::var("OSMAB_OPENAI_API_KEY").ok().filter(|k| !k.is_empty());
        config.timeout_secs = self.timeout;
        config.max_retries = self.retries;
        Ok(Some(ServiceClient::new(config)?))
    }
}

#[derive(Debug, Args)]
pub struct PromptsArgs {
    /// furniture or manipuland.
    #[arg(long)]
    regime: Regime,
    /// Prompts to keep.
    #[arg(long, default_value_t = 300)]
    count: usize,
    /// Seed of the built-in grammar.
    #[arg(long, default_value_t = 42)]
    seed: u64,
    /// Prompts asked of the LLM per request.
    #[arg(long, default_value_t = 12)]
    batch: usize,
    /// LLM requests at most.
    #[arg(long, default_value_t = 80)]
    max_requests: usize,
    #[command(flatten)]
    llm: ServiceArgs,
    /// Output JSON (accepted and rejected prompts with reasons).
    #[arg(long)]
    out: PathBuf,
}

#[derive(Debug, Args)]
pub struct SelectArgs {
    /// Prompt pools written by `osmab scene prompts`.
    #[arg(required = true)]
    pools: Vec<PathBuf>,
    /// Furniture scenes to select.
    #[arg(long, default_value_t = 24)]
    furniture: usize,
    /// Manipuland scenes to select.
    #[arg(long, default_value_t = 16)]
    manipuland: usize,
    /// Cosine similarity at or above which a later prompt is a near-duplicate.
    #[arg(long, default_value_t = NEAR_DUPLICATE_COSINE)]
    threshold: f32,
    #[command(flatten)]
    embeddings: ServiceArgs,
    /// Output directory: selection.json, final_prompts.json, final_prompts.csv.
    #[arg(long)]
    out: PathBuf,
}

pub fn run(cmd: SceneCommand) -> anyhow::Result<()> {
    match cmd {
        SceneCommand::Prompts(args) => prompts(&args),
        SceneCommand::Select(args) => selection(&args),
        SceneCommand::Convert { scene, out } => convert(&scene, &out),
        SceneCommand::Assets { pack } => check_assets(&pack),
        SceneCommand::Render { habitat, out, lightings, width, height, hfov, sensor_height, pitch, goals, prompted, seed, max_frames } => {
            let sensor = osmab_dataset::render::camera::SensorSettings { width, height, hfov, sensor_height, camera_pitch_deg: pitch, ..Default::default() };
            if let Some((field, expectation)) = sensor.problem() {
                bail!("--{}: {expectation}", field.replace('_', "-"));
            }
            let motion = osmab_dataset::render::trajectory::MotionSettings { goals, seed, max_frames, ..Default::default() };
            let lightings: Vec<ReleaseLighting> = lightings
                .split(',')
                .map(str::trim)
                .filter(|l| !l.is_empty())
                .map(str::parse)
                .collect::<Result<_, String>>()
                .map_err(|e| anyhow::anyhow!("--lightings: {e}"))?;
            let scene = scene_name(&habitat)?;
            let prompted: Vec<String> = prompted.split(',').map(str::trim).filter(|p| !p.is_empty()).map(str::to_string).collect();
            let coverage = osmab_dataset::render::coverage::CoverageGoals::default();
            let plan = osmab_dataset::render::plan_scene(&habitat, &scene, &sensor, &motion, &prompted, &coverage)?;
            let unobserved: Vec<String> =
                plan.coverage.iter().filter(|c| !c.satisfied(&coverage)).map(|c| format!("{} (instance {})", c.class, c.instance_id)).collect();
            println!(
                "trajectory: {} frames, {} goals, {:.1} m; {} of {} objects observed as planned{}",
                plan.frames.len(),
                plan.goals,
                plan.travelled,
                plan.coverage.len() - unobserved.len(),
                plan.coverage.len(),
                if unobserved.is_empty() { String::new() } else { format!(" (short: {})", unobserved.join(", ")) }
            );
            let plan_path = out.join("trajectories").join(format!("{scene}.json"));
            std::fs::create_dir_all(out.join("trajectories")).with_context(|| format!("{}: cannot create", out.display()))?;
            write_json(&plan_path, &plan)?;
            println!("{}: the planned trajectory, its viewpoints and predicted coverage", plan_path.display());
            for (lighting, summary) in osmab_dataset::render::render_scene(&habitat, &scene, &lightings, &sensor, &plan.frames, &out)? {
                println!("{}: {} frames", out.join(lighting.name()).join(&scene).display(), summary.frames);
            }
            Ok(())
        }
        SceneCommand::Synthesize { prompts, seed, ceiling, assets, command, out } => {
            let assets = osmab_dataset::synthesis::source::AssetSource::for_config(assets.as_deref(), &osmab_dataset::synthesis::source::assets_root())?;
            synthesize_all(&prompts, seed, ceiling, &assets, &command, &out)
        }
    }
}

fn prompts(args: &PromptsArgs) -> anyhow::Result<()> {
    let pool = match args.llm.client()? {
        Some(client) => llm_pool(&client, args.regime, args.count, args.batch, args.max_requests).map_err(|(partial, err)| {
            // Keep what was accepted before the service failed.
            let _ = write_json(&args.out, &partial);
            anyhow::anyhow!("{err} ({} prompts accepted before the failure are in {})", partial.accepted.len(), args.out.display())
        })?,
        None => grammar_pool(args.regime, args.count, args.seed),
    };
    write_json(&args.out, &pool)?;
    let mut reasons: BTreeMap<String, usize> = BTreeMap::new();
    for r in pool.rejected.iter().flat_map(|r| &r.reasons) {
        *reasons.entry(serde_json::to_value(r)?.as_str().unwrap_or("?").to_string()).or_default() += 1;
    }
    println!("{}: {} {} prompts accepted, {} rejected {:?}", args.out.display(), pool.accepted.len(), args.regime.name(), pool.rejected.len(), reasons);
    if pool.accepted.len() < args.count {
        eprintln!("warning: {} of the {} prompts asked for were written", pool.accepted.len(), args.count);
    }
    Ok(())
}

fn selection(args: &SelectArgs) -> anyhow::Result<()> {
    let mut by_regime: BTreeMap<Regime, Vec<ScenePrompt>> = BTreeMap::new();
    for path in &args.pools {
        let text = std::fs::read(path).with_context(|| format!("{}: cannot read", path.display()))?;
        let pool: PromptPool =
            serde_json::from_slice(&text).with_context(|| format!("{}: not a prompt pool written by `osmab scene prompts`", path.display()))?;
        by_regime.entry(pool.regime).or_default().extend(pool.accepted);
    }
    let embedder: Box<dyn Embedder> = match args.embeddings.client()? {
        Some(client) => Box::new(ServiceEmbedder { client, batch: 64 }),
        None => Box::new(HashingEmbedder::default()),
    };
    let mut reports: BTreeMap<&str, SelectionReport> = BTreeMap::new();
    let mut final_prompts = Vec::new();
    for regime in Regime::ALL {
        let target = match regime {
            Regime::Furniture => args.furniture,
            Regime::Manipuland => args.manipuland,
        };
        let prompts = by_regime.remove(&regime).unwrap_or_default();
        if prompts.is_empty() {
            if target > 0 {
                bail!("no {} prompts among the pools, but {target} are to be selected", regime.name());
            }
            continue;
        }
        let texts: Vec<String> = prompts.iter().map(|p| p.text.clone()).collect();
        // Ids repeat across pools of one regime: select by position, report by a unique key.
        let keys: Vec<String> = prompts.iter().enumerate().map(|(i, p)| format!("{}#{i}", p.id)).collect();
        let report = select(&keys, &embedder.embed(&texts)?, target, args.threshold);
        for s in &report.selected {
            let index: usize = s.id.rsplit('#').next().and_then(|i| i.parse().ok()).expect("keys end in their position");
            final_prompts.push(prompts[index].clone());
        }
        println!(
            "{}: {} candidates, {} near-duplicates removed, {} selected{}",
            regime.name(),
            report.candidates,
            report.near_duplicates.len(),
            report.selected.len(),
            if report.shortfall > 0 { format!(" ({} short)", report.shortfall) } else { String::new() }
        );
        reports.insert(regime.name(), report);
    }
    std::fs::create_dir_all(&args.out).with_context(|| format!("{}: cannot create", args.out.display()))?;
    write_json(&args.out.join("selection.json"), &serde_json::json!({"embedder": embedder.name(), "regimes": reports}))?;
    write_json(&args.out.join("final_prompts.json"), &final_prompts)?;
    // SceneSmith's experiment.csv_path format: scene_index,prompt.
    let mut csv = osmab_evaluator::csv_writer::CsvWriter::new(osmab_evaluator::csv_writer::LineEnd::Lf);
    csv.row(["scene_index", "prompt"]);
    for (i, p) in final_prompts.iter().enumerate() {
        csv.row([i.to_string(), p.text.clone()]);
    }
    std::fs::write(args.out.join("final_prompts.csv"), csv.finish()).with_context(|| format!("{}: cannot write", args.out.display()))?;
    Ok(())
}

fn synthesize_all(
    prompts_file: &Path,
    seed: u64,
    ceiling: bool,
    assets: &osmab_dataset::synthesis::source::AssetSource,
    command: &[String],
    out: &Path,
) -> anyhow::Result<()> {
    let text = std::fs::read(prompts_file).with_context(|| format!("{}: cannot read", prompts_file.display()))?;
    let prompts: Vec<ScenePrompt> =
        serde_json::from_slice(&text).with_context(|| format!("{}: not a list of prompts written by `osmab scene select`", prompts_file.display()))?;
    let mut report = Vec::new();
    let mut failures = 0;
    for (i, prompt) in prompts.iter().enumerate() {
        let dir = out.join(format!("scene_{i:03}"));
        let result = if command.is_empty() {
            osmab_dataset::synthesis::synthesize(prompt, seed.wrapping_add(i as u64), &dir, ceiling, assets)
        } else {
            osmab_dataset::synthesis::external::run_external(
                command,
                &prompt.text,
                seed.wrapping_add(i as u64),
                &dir,
                std::time::Duration::from_secs(24 * 3600),
            )
            .map(|()| Vec::new())
        };
        // One failed scene does not lose the others; the report says which failed.
        match result {
            Ok(unmet) => {
                println!("{}: {} ({} unmet relations)", dir.display(), prompt.id, unmet.len());
                report.push(serde_json::json!({"scene": format!("scene_{i:03}"), "prompt_id": prompt.id, "regime": prompt.spec.regime, "unmet": unmet}));
            }
            Err(err) => {
                failures += 1;
                eprintln!("error: {}: {err}", dir.display());
                report.push(
                    serde_json::json!({"scene": format!("scene_{i:03}"), "prompt_id": prompt.id, "regime": prompt.spec.regime, "error": err.to_string()}),
                );
            }
        }
    }
    write_json(&out.join("synthesis_report.json"), &report)?;
    if failures > 0 {
        bail!("{failures} of {} scenes failed; see {}", prompts.len(), out.join("synthesis_report.json").display());
    }
    Ok(())
}

/// The scene of a converted directory (its single `scenes/*.scene_instance.json`).
/// Open and inspect the pack at `root`, then print what it holds class by class.
fn check_assets(root: &Path) -> anyhow::Result<()> {
    let pack = osmab_dataset::assets::AssetPack::open(root)?;
    let meshes = pack.inspect()?;
    let mut classes: BTreeMap<&str, Vec<&osmab_dataset::assets::MeshFacts>> = BTreeMap::new();
    for mesh in &meshes {
        classes.entry(mesh.class.as_str()).or_default().push(mesh);
    }
    for (class, variants) in &classes {
        let triangles: Vec<u64> = variants.iter().map(|m| m.triangles).collect();
        let untextured = variants.iter().filter(|m| !m.textured).count();
        let sources: std::collections::BTreeSet<&str> = pack.catalogue().variants(class).map(|e| e.source.as_str()).collect();
        println!(
            "{class}: {} variants, {}-{} triangles, {}; {}",
            variants.len(),
            triangles.iter().min().unwrap_or(&0),
            triangles.iter().max().unwrap_or(&0),
            if untextured == 0 { "all textured".to_string() } else { format!("{untextured} without a texture") },
            sources.into_iter().collect::<Vec<_>>().join(", ")
        );
    }
    for kind in [osmab_dataset::assets::ShellKind::Floor, osmab_dataset::assets::ShellKind::Wall] {
        let names: Vec<&str> = pack.catalogue().shells_of(kind).map(|s| s.name.as_str()).collect();
        println!("{kind:?} textures: {}", if names.is_empty() { "none".to_string() } else { names.join(", ") });
    }
    let missing: Vec<String> = osmab_dataset::convert::lexicon::classes()
        .into_iter()
        .map(|c| c.name)
        .filter(|c| {
            !classes.contains_key(c.as_str()) && osmab_dataset::synthesis::library::make_asset(c, &mut osmab_evaluator::synthetic::Rng::new(0)).is_some()
        })
        .collect();
    println!(
        "{}: {} meshes of {} classes, digest {}; classes without a mesh keep the built-in procedural asset: {}",
        root.display(),
        meshes.len(),
        classes.len(),
        pack.digest(),
        if missing.is_empty() { "none".to_string() } else { missing.join(", ") }
    );
    Ok(())
}

fn scene_name(habitat: &Path) -> anyhow::Result<String> {
    let dir = habitat.join("scenes");
    let mut names: Vec<String> = std::fs::read_dir(&dir)
        .with_context(|| format!("{}: not a converted scene (no scenes/ folder)", habitat.display()))?
        .filter_map(|e| e.ok()?.file_name().to_str()?.strip_suffix(".scene_instance.json").map(str::to_string))
        .collect();
    names.sort();
    match names.as_slice() {
        [one] => Ok(one.clone()),
        _ => bail!("{}: expected exactly one scene instance, found {}", dir.display(), names.len()),
    }
}

fn convert(scene: &Path, out: &Path) -> anyhow::Result<()> {
    let loaded = load_scene(scene)?;
    let report = write_habitat_scene(&loaded, out, &ConvertOptions::default())?;
    println!("{}: {} objects, {:.0}% of the floor navigable", out.display(), report.objects.len(), 100.0 * report.navigable_fraction);
    for name in &report.unknown_names {
        eprintln!("warning: '{name}' matches no class of the lexicon; classified as 'other'");
    }
    for problem in &report.texture_fallbacks {
        eprintln!("warning: {problem}; the base colour is used instead");
    }
    Ok(())
}

fn write_json(path: &Path, value: &impl serde::Serialize) -> anyhow::Result<()> {
    Ok(osmab_evaluator::formats::json::write_pretty(path, value)?)
}
