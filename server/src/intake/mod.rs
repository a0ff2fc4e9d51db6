//! Accepting a submission, as one service the HTTP edge and the baseline job both call.
//! The upload is streamed to a scratch file while its size and SHA-256 are counted
//! ([`upload`]); [`accept`] then answers a repeat with the earlier submission, unpacks and
//! validates the archive against its release exactly as `osmab client validate` does
//! ([`check`]), checks that the release takes submissions and the team's [`Quota`], and
//! only then stores the archive and records the submission with its scoring job in one
//! transaction. Nothing is recorded for a refused upload ([`Error`]).

mod check;
mod error;
mod quota;
mod upload;

use std::collections::BTreeSet;

use osmab_evaluator::scores::Split;
use osmab_evaluator::submission::ValidSubmission;

pub use check::check;
pub use error::{Error, quota_exceeded};
pub use quota::{Policy, Quota};
pub use upload::{Upload, declared_sha256, hex, idempotency_key, receive, too_large};

use crate::blobs::Scratch;
use crate::clock::{new_id, now_ms};
use crate::jobs::scoring::ScoreSubmission;
use crate::state::AppState;
use crate::store::{NewSubmission, Recorded, ReleaseState, StoreError, StoredCard, Team};

/// What the uploader asks for.
#[derive(Debug, Clone, Default)]
pub struct Request {
    /// Validate only: nothing is stored and no quota is used.
    pub dry_run: bool,
    /// Show the submission on the public leaderboard.
    pub public: bool,
    /// A reference baseline (the organisers' own; never counts against a quota).
    pub baseline: bool,
    /// The client's `Idempotency-Key`.
    pub idempotency_key: Option<String>,
    /// Hold the team to its daily quota.
    pub enforce_quota: bool,
    /// The release to validate against when `submission.json` names none (the current one
    /// when `None`).
    pub release: Option<String>,
    /// The split the submission is made to (the release's primary split when `None`:
    /// test when it has one).
    pub split: Option<Split>,
}

/// What accepting an upload did.
#[derive(Debug)]
pub enum Accepted {
    /// A new submission to `split`, queued for scoring; the quota after it.
    New { id: String, submission: ValidSubmission, split: Split, quota: Option<Quota> },
    /// Nothing new: the team's earlier submission (its id) of the same archive, or made
    /// with the same idempotency key.
    Repeat { id: String },
    /// A dry run: the upload is valid for `split`.
    Valid { submission: ValidSubmission, split: Split },
}

/// The split of an upload that names none, as known before it is unpacked: the current
/// release's primary split (test when it has one).
pub async fn default_split(state: &AppState) -> Result<Split, StoreError> {
    match state.store.current_release().await {
        Ok(release) => Ok(crate::releases::served_manifest(&release).primary_split()),
        Err(StoreError::NotFound) => Ok(Split::Val),
        Err(e) => Err(e),
    }
}

/// Accept `upload` from `team` as `request` asks.
pub async fn accept(state: &AppState, team: &Team, upload: &Upload, request: &Request) -> Result<Accepted, Error> {
    // A repeat is known before unpacking when the split is (else once the release says it).
    if let (false, Some(split)) = (request.dry_run, request.split) {
        match state.store.repeated_submission(&team.id, &upload.sha256_hex(), split, request.idempotency_key.as_deref()).await? {
            Some(Recorded::Repeat(id)) => return Ok(Accepted::Repeat { id }),
            Some(Recorded::KeyReused(id)) => return Err(Error::KeyReused(id)),
            _ => {}
        }
    }
    let validating_at = now_ms();
    let current = match &request.release {
        Some(release) => Some(release.clone()),
        None => state.store.current_release().await.ok().map(|r| r.version),
    };
    let open: BTreeSet<String> = state.store.releases().await?.into_iter().filter(|r| r.state == ReleaseState::Published).map(|r| r.version).collect();
    let unpack_to = Scratch(state.blobs.scratch("unpack"));
    let (state_for_check, upload_path, unpack_path, split) = (state.clone(), upload.path.clone(), unpack_to.0.clone(), request.split);
    // Unpacking and validation are heavy (disk and memory): a few at a time, the rest wait.
    let _permit = state.validation.acquire().await.map_err(Error::internal)?;
    let open_only = (!request.baseline).then_some(open);
    let (submission, release) =
        tokio::task::spawn_blocking(move || check(&state_for_check, &upload_path, &unpack_path, current.as_deref(), split, open_only.as_ref()))
            .await
            .map_err(Error::internal)??;
    let split = release.split.expect("checked against one split");
    if !request.baseline
        && let Some(problem) = crate::reserved_names::method_name_problem(submission.method.name.trim())
    {
        return Err(Error::Invalid(vec![osmab_evaluator::InputError::new("submission.json", "method.name", problem)]));
    }
    if let (false, None) = (request.dry_run, request.split) {
        match state.store.repeated_submission(&team.id, &upload.sha256_hex(), split, request.idempotency_key.as_deref()).await? {
            Some(Recorded::Repeat(id)) => return Ok(Accepted::Repeat { id }),
            Some(Recorded::KeyReused(id)) => return Err(Error::KeyReused(id)),
            _ => {}
        }
    }
    if !request.baseline {
        // Published while this upload was checked is fine; withdrawn meanwhile is not.
        match state.store.release(&submission.release).await {
            Ok(r) if r.state == ReleaseState::Published => {}
            Ok(_) | Err(StoreError::NotFound) => return Err(Error::ReleaseNotOpen(submission.release.clone())),
            Err(e) => return Err(e.into()),
        }
    }
    if request.dry_run {
        return Ok(Accepted::Valid { submission, split });
    }
    // The quota again: another upload of the same team may have finished meanwhile.
    let quota = match request.enforce_quota {
        true => Some(Quota::of(state, team, split).await?),
        false => None,
    };
    if let Some(quota) = quota.as_ref().filter(|q| q.exhausted()) {
        return Err(Error::QuotaExceeded(quota.clone()));
    }
    match record(state, team, upload, &submission, split, request, validating_at, quota.as_ref()).await? {
        Recorded::New(id) => Ok(Accepted::New { id, submission, split, quota: quota.map(Quota::after_one) }),
        Recorded::Repeat(id) => Ok(Accepted::Repeat { id }),
        Recorded::KeyReused(id) => Err(Error::KeyReused(id)),
        Recorded::QuotaExceeded => Err(Error::QuotaExceeded(Quota::of(state, team, split).await?)),
    }
}

/// Record a validated upload as a submission of `team` with its scoring job, storing the
/// archive first so the job always finds it — unless it repeats the team's earlier
/// submission. `quota` is checked again in the same transaction. Nothing but a
/// `Recorded::New` leaves a stored archive behind.
async fn record(
    state: &AppState,
    team: &Team,
    upload: &Upload,
    submission: &ValidSubmission,
    split: Split,
    request: &Request,
    validating_at: i64,
    quota: Option<&Quota>,
) -> Result<Recorded, Error> {
    let id = new_id("sub");
    let key = format!("submissions/{id}/upload");
    state.blobs.put_file(&key, &upload.path).await.map_err(Error::storage)?;
    let queued_at = now_ms();
    let new = NewSubmission {
        id: id.clone(),
        team_id: team.id.clone(),
        release: submission.release.clone(),
        card: StoredCard::from(&submission.method),
        public: request.public,
        baseline: request.baseline,
        complete: submission.complete,
        archive_size: upload.size as i64,
        archive_sha256: upload.sha256_hex(),
        idempotency_key: request.idempotency_key.clone(),
        split,
        received_at: upload.received_at,
        validating_at,
        queued_at,
    };
    let job = crate::jobs::new_job(&ScoreSubmission { submission_id: id.clone(), rescore: false }, state);
    let outcome = state.store.create_submission(&new, &job, quota.map(|q| (q.limit, q.window_start()))).await;
    if !matches!(outcome, Ok(Recorded::New(_))) {
        let _ = state.blobs.remove_prefix(&format!("submissions/{id}")).await;
    }
    Ok(outcome?)
}
