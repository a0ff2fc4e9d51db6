//! The `build_release` job: run the release pipeline of a config (the whole of product.md
//! section 8), import the result as a draft (or publish it), and optionally score the
//! reference baselines on it so the leaderboard has rows to compare against. Every stage
//! keeps its output in the build folder, so a retried job resumes where it stopped.
//!
//! The rendering, the bulk of the work, fans out: the build job prepares the scenes,
//! queues one `render_sequence` job per scene (its lightings are drawn together, one
//! visibility pass a frame) for any worker to take, waits off the queue (it does not hold a
//! worker) until they are all done, then assembles the release. Its progress shows how
//! many scenes are rendered and which failed.

use std::cell::RefCell;
use std::collections::BTreeMap;

use osmab_dataset::release::{Build, SequenceUnit, build_release, prepare_release, render_release_scene};
use serde::{Deserialize, Serialize};

use super::progress::{Progress, Stage};
use super::{Job, JobContext, JobError};
use crate::clock::now_ms;
use crate::releases::{Imported, Provenance, import_release};
use crate::state::AppState;
use crate::store::{JobKind, JobRecord, JobState, StoreError};

/// How long a build job waits between looks at its render jobs.
const WAIT_FOR_RENDERING: std::time::Duration = std::time::Duration::from_secs(2);

/// The configuration of the demo release built on an empty data directory.
pub const DEMO_CONFIG: &str = include_str!("../../../configs/release-demo.toml");

pub use crate::reserved_names::BASELINE_TEAM;

/// Build the release a config describes (its `version` is the job's subject).
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct BuildRelease {
    /// The release configuration (TOML, as configs/release-demo.toml).
    pub config: String,
    /// Publish the release when it is built (otherwise it stays a draft).
    #[serde(default)]
    pub publish: bool,
    /// Score the reference baselines on it.
    #[serde(default)]
    pub baselines: bool,
}

/// The version a release config declares.
pub fn config_version(config: &str) -> Result<String, String> {
    let value: toml::Table = toml::from_str(config).map_err(|e| format!("config: {e}"))?;
    let version = value.get("version").and_then(|v| v.as_str()).ok_or("config: missing 'version'")?.to_string();
    crate::releases::check_version(&version)?;
    Ok(version)
}

impl Job for BuildRelease {
    const KIND: JobKind = JobKind::BuildRelease;

    fn subject(&self) -> String {
        config_version(&self.config).unwrap_or_else(|_| "(invalid config)".into())
    }

    async fn run(self, ctx: JobContext) -> Result<(), JobError> {
        build(ctx, self).await
    }
}

/// Render the sequences of one scene of a prepared release build: its lightings not yet
/// rendered when the build fanned out.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct RenderSequence {
    version: String,
    /// Sequences of one scene. A job queued by an earlier version of the service named one
    /// sequence as `unit`; it is read as a scene with that one lighting.
    #[serde(alias = "unit", deserialize_with = "one_or_many")]
    units: Vec<SequenceUnit>,
}

/// A list, or a single item as a list of one.
fn one_or_many<'de, D: serde::Deserializer<'de>>(deserializer: D) -> Result<Vec<SequenceUnit>, D::Error> {
    #[derive(Deserialize)]
    #[serde(untagged)]
    enum OneOrMany {
        Many(Vec<SequenceUnit>),
        One(SequenceUnit),
    }
    Ok(match OneOrMany::deserialize(deserializer)? {
        OneOrMany::Many(units) => units,
        OneOrMany::One(unit) => vec![unit],
    })
}

impl Job for RenderSequence {
    const KIND: JobKind = JobKind::RenderSequence;
    const STARTS_ARE_NEWS: bool = false;

    /// `version/scene`; a job of one sequence queued by an earlier version of the service
    /// kept `version/scene/lighting`, which its build still waits for by that name.
    fn subject(&self) -> String {
        let scene = self.units.first().map_or("", |u| u.scene.as_str());
        format!("{}/{scene}", self.version)
    }

    async fn run(self, ctx: JobContext) -> Result<(), JobError> {
        render(ctx, self).await
    }
}

impl RenderSequence {
    /// The release version a render job's subject names: the inverse of
    /// [`Job::subject`] (and of the `version/scene/lighting` of a job queued by an earlier
    /// version of the service), for whoever lists a build's render jobs.
    pub fn version_of_subject(subject: &str) -> &str {
        subject.split_once('/').map_or(subject, |(version, _)| version)
    }
}

/// The build folder of `version`: (its config, the release folder).
fn build_paths(state: &AppState, version: &str) -> (std::path::PathBuf, std::path::PathBuf) {
    let build_dir = build_dir(state, version);
    (build_dir.join("config.toml"), build_dir.join("release"))
}

fn build_dir(state: &AppState, version: &str) -> std::path::PathBuf {
    state.settings.data_dir.join("builds").join(version)
}

/// The blob prefix through which the nodes of an object-store deployment share a build
/// folder (prepared scenes, rendered sequences, stage markers).
fn build_prefix(version: &str) -> String {
    format!("builds/{version}")
}

/// Bring this node's copy of the build folder up to date with the shared one.
async fn pull_build(state: &AppState, version: &str) -> Result<(), JobError> {
    let pulled = state.blobs.pull_tree(&build_prefix(version), &build_dir(state, version)).await.map_err(JobError::retryable)?;
    if pulled > 0 {
        tracing::info!(files = pulled, "build folder brought up to date from the blob store");
    }
    Ok(())
}

/// Share what this node added to the build folder.
async fn push_build(state: &AppState, version: &str) -> Result<(), JobError> {
    let pushed = state.blobs.push_tree(&build_prefix(version), &build_dir(state, version)).await.map_err(JobError::retryable)?;
    if pushed > 0 {
        tracing::info!(files = pushed, "build folder shared through the blob store");
    }
    Ok(())
}

/// Run `stage` of the build off the runtime, its progress lines shown on the job.
async fn blocking_stage<T: Send + 'static>(
    ctx: &JobContext,
    stage: Stage,
    work: impl FnOnce(&dyn Fn(&str)) -> osmab_evaluator::Result<T> + Send + 'static,
) -> Result<T, JobError> {
    let blocking_ctx = ctx.clone();
    tokio::task::spawn_blocking(move || {
        let log = RefCell::new(Vec::<String>::new());
        let progress = |message: &str| {
            let mut log = log.borrow_mut();
            log.push(message.to_string());
            let tail: Vec<String> = log.iter().rev().take(20).rev().cloned().collect();
            blocking_ctx.progress_blocking(&Progress { log: Some(tail), ..Progress::at(stage, message) });
        };
        work(&progress).map_err(|e| JobError::Permanent(format!("release build: {e}")))
    })
    .await
    .map_err(|e| JobError::Retryable(format!("the {} stage ended: {e}", stage.name())))?
}

/// Where the rendering of a build stands.
enum Rendering {
    /// Every scene is rendered.
    Done,
    /// Some are still queued or running.
    Running { done: usize, total: usize },
}

/// The sequences a build job fanned out, as recorded in its progress.
fn fanned_out(progress: &str) -> Option<Vec<String>> {
    Progress::read(progress).fanned_out
}

/// Prepare the build (stages 1–4) and queue a render job for every scene with a sequence
/// not rendered yet; returns their subjects.
async fn fan_out(ctx: &JobContext, version: &str, config_path: &std::path::Path, out: &std::path::Path) -> Result<Vec<String>, JobError> {
    let (config, out_dir, secret) = (config_path.to_path_buf(), out.to_path_buf(), ctx.state.split_secret.clone());
    let assets_root = ctx.state.settings.assets_root.clone();
    pull_build(&ctx.state, version).await?;
    let units = blocking_stage(ctx, Stage::Prepare, move |progress| prepare_release(&config, &out_dir, Some(&secret), &assets_root, progress)).await?;
    push_build(&ctx.state, version).await?;
    let mut scenes: BTreeMap<usize, Vec<SequenceUnit>> = BTreeMap::new();
    for (unit, rendered) in units {
        if !rendered {
            scenes.entry(unit.scene_index).or_default().push(unit);
        }
    }
    let mut subjects = Vec::new();
    for units in scenes.into_values() {
        let job = RenderSequence { version: version.to_string(), units };
        let subject = job.subject();
        match super::enqueue(&ctx.state, &job).await {
            // A live job for it (left by an earlier build attempt) is followed instead.
            Ok(_) | Err(StoreError::Conflict(_)) => subjects.push(subject),
            Err(e) => return Err(e.into()),
        }
    }
    Ok(subjects)
}

/// Where the render jobs of `subjects` stand; a failed one fails the build.
async fn rendering(ctx: &JobContext, version: &str, subjects: &[String]) -> Result<Rendering, JobError> {
    let parts = ctx.state.store.jobs_of(RenderSequence::KIND, &format!("{version}/"), 0).await?;
    let mut latest: BTreeMap<&str, &JobRecord> = BTreeMap::new();
    for part in &parts {
        latest.insert(part.subject.as_str(), part); // ordered by creation within a subject
    }
    let (mut done, mut running) = (0, Vec::new());
    for subject in subjects {
        match latest.get(subject.as_str()) {
            Some(job) if job.state == JobState::Succeeded => done += 1,
            Some(job) if matches!(job.state, JobState::Queued | JobState::Running) => running.push(subject.as_str()),
            Some(job) => {
                let why = job.error.as_deref().unwrap_or("cancelled");
                return Err(JobError::Permanent(format!("rendering {subject} failed: {why}")));
            }
            None => return Err(JobError::Retryable(format!("the render job of {subject} is missing"))),
        }
    }
    if running.is_empty() {
        return Ok(Rendering::Done);
    }
    let total = subjects.len();
    ctx.progress(&Progress {
        fanned_out: Some(subjects.to_vec()),
        rendered: Some(done),
        waiting_for: Some(running.iter().map(|s| s.to_string()).collect()),
        ..Progress::at(Stage::Rendering, format!("{done} of {total} scenes rendered"))
    })
    .await;
    Ok(Rendering::Running { done, total })
}

async fn build(ctx: JobContext, request: BuildRelease) -> Result<(), JobError> {
    let state = &ctx.state;
    let version = config_version(&request.config).map_err(JobError::Permanent)?;
    let (config_path, out) = build_paths(state, &version);
    std::fs::create_dir_all(config_path.parent().expect("in the build folder")).map_err(JobError::retryable)?;
    std::fs::write(&config_path, &request.config).map_err(JobError::retryable)?;

    let already = matches!(state.store.release(&version).await, Ok(_));
    if !already {
        let subjects = match fanned_out(&ctx.job.progress) {
            Some(subjects) => subjects,
            None => {
                let subjects = fan_out(&ctx, &version, &config_path, &out).await?;
                let message = format!("{} scenes queued for rendering", subjects.len());
                ctx.progress(&Progress { fanned_out: Some(subjects.clone()), rendered: Some(0), ..Progress::at(Stage::Rendering, message) }).await;
                subjects
            }
        };
        if let Rendering::Running { done, total } = rendering(&ctx, &version, &subjects).await? {
            tracing::debug!(done, total, "waiting for the render jobs");
            return Err(JobError::Waiting(WAIT_FOR_RENDERING));
        }
        pull_build(state, &version).await?;
        let (config_for_build, out_for_build, secret) = (config_path.clone(), out.clone(), state.split_secret.clone());
        let assets_root = state.settings.assets_root.clone();
        blocking_stage(&ctx, Stage::Assemble, move |progress| build_release(&config_for_build, &out_for_build, Some(&secret), &assets_root, progress)).await?;
        ctx.progress(&Progress::at(Stage::Import, format!("importing release {version}"))).await;
        let now = now_ms();
        if !state.store.heartbeat(&ctx.job.id, &ctx.owner, now + (state.settings.job_lease_secs * 1000) as i64, now).await? {
            return Err(JobError::Retryable("the lease was lost during the build; another worker took the job over".into()));
        }
        match import_release(&state.store, &state.blobs, &out, Provenance::JustBuilt, request.publish)
            .await
            .map_err(|e| JobError::Retryable(format!("import: {e:#}")))?
        {
            Imported::New(v) | Imported::Unchanged(v) => tracing::info!(release = %v, publish = request.publish, "release imported"),
        }
    } else if request.publish {
        state.store.publish_release(&version, now_ms()).await?;
    }
    state.leaderboard.invalidate();
    if request.baselines {
        let Some(release) = state.blobs.release(&version).await.map_err(JobError::retryable)? else {
            return Err(JobError::Retryable(format!("release {version} is missing from the blob store")));
        };
        let queued = super::reference_entries::queue_reference_entries(state, &version, &release).await?;
        ctx.progress(&Progress::at(Stage::Baselines, format!("{queued} baseline submissions queued for scoring"))).await;
    }
    ctx.progress(&Progress::at(Stage::Done, format!("release {version} ready"))).await;
    if request.publish {
        let board = format!("{}/", state.settings.public_url.as_deref().unwrap_or(""));
        tracing::info!(release = %version, "release {version} is published: the leaderboard is ready at {board}");
    }
    Ok(())
}

/// The sequences of one scene of a prepared build.
async fn render(ctx: JobContext, request: RenderSequence) -> Result<(), JobError> {
    let (config_path, out) = build_paths(&ctx.state, &request.version);
    pull_build(&ctx.state, &request.version).await?;
    let blocking_ctx = ctx.clone();
    let (units, secret, assets_root) = (request.units.clone(), ctx.state.split_secret.clone(), ctx.state.settings.assets_root.clone());
    tokio::task::spawn_blocking(move || {
        let progress = |message: &str| blocking_ctx.progress_blocking(&Progress::at(Stage::Render, message));
        // A renderer can fail for passing reasons (an external command's timeout): retried.
        // A config that cannot be used, or sequences not of one scene of it, fail the same
        // way every time; a renderer can fail for passing reasons (an external command's
        // timeout, the disk): retried.
        let build =
            Build::open(&config_path, &out, Some(&secret), &assets_root).map_err(|e| JobError::Permanent(format!("the build's config cannot be used: {e}")))?;
        build.check_scene_units(&units).map_err(|e| JobError::Permanent(e.to_string()))?;
        render_release_scene(&build, &units, &progress).map_err(|e| JobError::Retryable(e.to_string()))
    })
    .await
    .map_err(|e| JobError::Retryable(format!("the render thread ended: {e}")))??;
    push_build(&ctx.state, &request.version).await
}

#[cfg(test)]
mod tests {
    use super::*;

    fn unit(lighting: &str) -> SequenceUnit {
        SequenceUnit { scene_index: 3, scene: "scene_003".into(), lighting: lighting.parse().unwrap() }
    }

    #[test]
    fn a_render_job_names_its_scene_and_reads_back_every_lighting_it_carries() {
        let job = RenderSequence { version: "v-1".into(), units: vec![unit("baseline"), unit("no_lights")] };
        assert_eq!(job.subject(), "v-1/scene_003");
        assert_eq!(RenderSequence::version_of_subject(&job.subject()), "v-1", "the console finds the build by it");
        assert_eq!(RenderSequence::version_of_subject("demo-2/scene_001/camera"), "demo-2", "a job queued by an earlier version");
        let back: RenderSequence = serde_json::from_value(serde_json::to_value(&job).unwrap()).unwrap();
        assert_eq!(back.units, job.units);
    }

    #[test]
    fn a_render_job_queued_by_an_earlier_version_is_read_as_its_one_sequence() {
        let queued = serde_json::json!({"version": "v-1", "unit": {"scene_index": 3, "scene": "scene_003", "lighting": "camera"}});
        let job: RenderSequence = serde_json::from_value(queued).unwrap();
        assert_eq!(job.units, vec![unit("camera")]);
        let neither = serde_json::from_value::<RenderSequence>(serde_json::json!({"version": "v-1"}));
        assert!(neither.is_err(), "a job without its sequences is refused");
    }
}
