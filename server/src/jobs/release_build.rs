//! The `build_release` job: run the release pipeline of a config (the whole of product.md
//! section 8), import the result as a draft (or publish it), and optionally score the
//! reference baselines on it so the leaderboard has rows to compare against. Every stage
//! keeps its output in the build folder, so a retried job resumes where it stopped.

use std::cell::RefCell;

use osmab_dataset::baselines::{BASELINES, write_baseline};
use osmab_dataset::release::build_release;
use osmab_evaluator::submission::pack_directory;
use serde::{Deserialize, Serialize};
use serde_json::json;
use sha2::{Digest, Sha256};

use super::{JobContext, JobError};
use crate::clock::{new_id, now_ms};
use crate::intake::{Scratch, Upload};
use crate::releases::{Imported, import_release};
use crate::state::AppState;
use crate::store::{StoreError, Team};

/// Kind of the job that builds a release.
pub const BUILD_JOB: &str = "build_release";

/// The configuration of the demo release built on an empty data directory.
pub const DEMO_CONFIG: &str = include_str!("../../../configs/release-demo.toml");

/// Name of the team that owns the reference baselines.
pub const BASELINE_TEAM: &str = "OSMa-Bench baselines";

/// Parameters of a build job.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct BuildRequest {
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

pub async fn run(ctx: JobContext) -> Result<(), JobError> {
    let request: BuildRequest = serde_json::from_str(&ctx.job.payload).map_err(|e| JobError::Permanent(format!("payload: {e}")))?;
    let state = &ctx.state;
    let version = config_version(&request.config).map_err(JobError::Permanent)?;
    let build_dir = state.settings.data_dir.join("builds").join(&version);
    std::fs::create_dir_all(&build_dir)?;
    let config_path = build_dir.join("config.toml");
    std::fs::write(&config_path, &request.config)?;
    let out = build_dir.join("release");

    let already = matches!(state.store.release(&version).await, Ok(_));
    if !already {
        let blocking_ctx = ctx.clone();
        let (config_for_build, out_for_build) = (config_path.clone(), out.clone());
        tokio::task::spawn_blocking(move || {
            let log = RefCell::new(Vec::<String>::new());
            let progress = |message: &str| {
                let mut log = log.borrow_mut();
                log.push(message.to_string());
                let tail: Vec<&String> = log.iter().rev().take(20).rev().collect();
                blocking_ctx.progress_blocking(&json!({"stage": "build", "message": message, "log": tail}));
            };
            build_release(&config_for_build, &out_for_build, &progress).map_err(|e| JobError::Permanent(format!("release build: {e}")))
        })
        .await??;
        ctx.progress(&json!({"stage": "import", "message": format!("importing release {version}")})).await;
        let now = now_ms();
        if !state.store.heartbeat(&ctx.job.id, &ctx.owner, now + (state.settings.job_lease_secs * 1000) as i64, now).await? {
            return Err(JobError::Retryable("the lease was lost during the build; another worker took the job over".into()));
        }
        match import_release(&state.store, &state.blobs, &out, request.publish).await.map_err(|e| JobError::Retryable(format!("import: {e:#}")))? {
            Imported::New(v) | Imported::Unchanged(v) => tracing::info!(release = %v, publish = request.publish, "release imported"),
        }
    } else if request.publish {
        state.store.publish_release(&version, now_ms()).await?;
    }
    state.leaderboard.invalidate();
    if request.baselines {
        let release = crate::releases::release_dir(&state.blobs, &version)?;
        let queued = queue_baselines(state, &version, &release).await?;
        ctx.progress(&json!({"stage": "baselines", "message": format!("{queued} baseline submissions queued for scoring")})).await;
    }
    ctx.progress(&json!({"stage": "done", "message": format!("release {version} ready")})).await;
    Ok(())
}

/// The team that owns the baselines (created on first use).
pub async fn baseline_team(state: &AppState) -> Result<Team, StoreError> {
    match state.store.team_by_name(BASELINE_TEAM).await {
        Ok(team) => Ok(team),
        Err(StoreError::NotFound) => {
            let team = Team { id: new_id("team"), name: BASELINE_TEAM.into(), daily_quota: Some(0), created_at: now_ms() };
            match state.store.create_team(&team).await {
                Ok(()) => Ok(team),
                Err(StoreError::Conflict(_)) => state.store.team_by_name(BASELINE_TEAM).await,
                Err(e) => Err(e),
            }
        }
        Err(e) => Err(e),
    }
}

/// Submit every reference baseline of `version` (built in `release`) that is not there yet.
pub async fn queue_baselines(state: &AppState, version: &str, release: &std::path::Path) -> Result<usize, JobError> {
    let team = baseline_team(state).await?;
    let existing = state.store.submissions(Some(&team.id), 1000).await?;
    let mut queued = 0;
    for name in BASELINES {
        let method = format!("baseline-{name}");
        if existing.iter().any(|s| s.release == version && s.method_name == method && s.state != "failed") {
            continue;
        }
        let (dir, archive) = (Scratch(state.blobs.scratch("baseline")), Scratch(state.blobs.scratch("baseline-tar")));
        let (release, dir_path, archive_path) = (release.to_path_buf(), dir.0.clone(), archive.0.clone());
        let (size, sha256) = tokio::task::spawn_blocking(move || -> Result<(u64, [u8; 32]), JobError> {
            write_baseline(name, &release, &dir_path).map_err(|e| JobError::Permanent(e.to_string()))?;
            pack_directory(&dir_path, &archive_path).map_err(|e| JobError::Permanent(e.to_string()))?;
            let bytes = std::fs::read(&archive_path)?;
            Ok((bytes.len() as u64, Sha256::digest(&bytes).into()))
        })
        .await??;
        let upload = Upload { path: archive.0.clone(), size, sha256, received_at: now_ms() };
        let unpack_to = Scratch(state.blobs.scratch("baseline-check"));
        let (state_for_check, upload_path, unpack_path, current) = (state.clone(), upload.path.clone(), unpack_to.0.clone(), version.to_string());
        let validating_at = now_ms();
        let (valid, _) = tokio::task::spawn_blocking(move || crate::intake::check(&state_for_check, &upload_path, &unpack_path, Some(&current)))
            .await?
            .map_err(|p| JobError::Permanent(format!("baseline {name}: {}", p.detail)))?;
        crate::intake::record(state, &team, &upload, &valid, true, true, validating_at, None).await.map_err(|p| JobError::Retryable(p.detail))?;
        queued += 1;
    }
    Ok(queued)
}
