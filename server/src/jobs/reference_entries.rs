//! The entries the service scores itself on every release it builds, owned by the
//! baselines' team: the reference mapper (`baseline-perceive`, which maps from the frames
//! alone, as a team's method does) and the controls made from the ground truth (the
//! oracle and its degraded variants, which show the scale, not what lighting does to a
//! method). Each is written once and submitted to every split of the release that does
//! not have it yet.

use std::path::Path;

use osmab_dataset::baselines::{Control, write_baseline};
use osmab_evaluator::scores::Split;
use osmab_evaluator::submission::pack_directory;
use osmab_mapper::FeatureSet;
use sha2::{Digest, Sha256};

use super::JobError;
use crate::blobs::Scratch;
use crate::clock::{new_id, now_ms};
use crate::intake::Upload;
use crate::reserved_names::BASELINE_TEAM;
use crate::state::AppState;
use crate::store::{StoreError, SubmissionState, Team};

/// One entry the service makes itself.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ReferenceEntry {
    /// The reference mapper.
    Mapper,
    /// A control made from the ground truth.
    Control(Control),
}

impl ReferenceEntry {
    /// Every entry, the reference mapper first.
    pub fn all() -> impl Iterator<Item = ReferenceEntry> {
        std::iter::once(ReferenceEntry::Mapper).chain(Control::ALL.into_iter().map(ReferenceEntry::Control))
    }

    /// Its method name on the board.
    pub fn method(self) -> String {
        match self {
            ReferenceEntry::Mapper => osmab_mapper::submission::method_name(FeatureSet::Seeing).to_string(),
            ReferenceEntry::Control(control) => format!("baseline-{control}"),
        }
    }

    /// Write its submission for the release in `release` to the folder `out`.
    fn write(self, release: &Path, out: &Path) -> Result<(), String> {
        match self {
            ReferenceEntry::Mapper => osmab_mapper::perceive(release, out, FeatureSet::Seeing).map(|_| ()).map_err(|e| e.to_string()),
            ReferenceEntry::Control(control) => write_baseline(control, release, out).map(|_| ()).map_err(|e| e.to_string()),
        }
    }
}

/// The team that owns the reference entries (created on first use).
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

/// Submit every reference entry of `version` (built in `release`) to every split of the
/// release where it is not there yet: the oracle of a test split exists only here.
/// Returns how many submissions were queued.
pub async fn queue_reference_entries(state: &AppState, version: &str, release: &Path) -> Result<usize, JobError> {
    let team = baseline_team(state).await?;
    let existing = state.store.submissions(Some(&team.id), 1000).await?;
    let splits = osmab_evaluator::submission::ReleaseIndex::read(release).map_err(|e| JobError::Retryable(e.to_string()))?.splits();
    let mut queued = 0;
    for entry in ReferenceEntry::all() {
        let method = entry.method();
        let missing: Vec<Split> = splits
            .iter()
            .copied()
            .filter(|split| !existing.iter().any(|s| s.release == version && s.card.name == method && s.split == *split && s.state != SubmissionState::Failed))
            .collect();
        if missing.is_empty() {
            continue;
        }
        let dir = Scratch(state.blobs.scratch("baseline"));
        let (release_dir, dir_path) = (release.to_path_buf(), dir.0.clone());
        tokio::task::spawn_blocking(move || entry.write(&release_dir, &dir_path))
            .await
            .map_err(JobError::retryable)?
            .map_err(|e| JobError::Permanent(format!("{method}: {e}")))?;
        for split in missing {
            submit(state, &team, version, split, &method, &dir.0).await?;
            queued += 1;
        }
    }
    Ok(queued)
}

/// Pack the submission folder `dir` and hand it to intake for `split`.
async fn submit(state: &AppState, team: &Team, version: &str, split: Split, method: &str, dir: &Path) -> Result<(), JobError> {
    let archive = Scratch(state.blobs.scratch("baseline-tar"));
    let (dir_path, archive_path) = (dir.to_path_buf(), archive.0.clone());
    let (size, sha256) = tokio::task::spawn_blocking(move || -> Result<(u64, [u8; 32]), JobError> {
        pack_directory(&dir_path, &archive_path).map_err(|e| JobError::Permanent(e.to_string()))?;
        let bytes = std::fs::read(&archive_path).map_err(JobError::retryable)?;
        Ok((bytes.len() as u64, Sha256::digest(&bytes).into()))
    })
    .await
    .map_err(JobError::retryable)??;
    let upload = Upload { path: archive.0.clone(), size, sha256, received_at: now_ms() };
    let request = crate::intake::Request { public: true, baseline: true, release: Some(version.to_string()), split: Some(split), ..Default::default() };
    match crate::intake::accept(state, team, &upload, &request).await {
        Ok(_) => Ok(()),
        // The reference entries come from the release itself: one that does not validate is a defect of the build.
        Err(e @ (crate::intake::Error::Invalid(_) | crate::intake::Error::InvalidArchive(_))) => {
            Err(JobError::Permanent(format!("{method}: {}", crate::problem::Problem::from(e).detail)))
        }
        Err(e) => Err(JobError::Retryable(format!("{method}: {}", crate::problem::Problem::from(e).detail))),
    }
}
