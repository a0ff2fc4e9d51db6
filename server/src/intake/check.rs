//! Unpacking and validating an upload against its release, exactly as `osmab client
//! validate` does; errors name files by their path inside the upload.

use std::collections::BTreeSet;
use std::path::Path;

use osmab_evaluator::InputError;
use osmab_evaluator::scores::Split;
use osmab_evaluator::submission::{ArchiveLimits, ReleaseIndex, SubmissionLimits, ValidSubmission, unpack, validate};
use serde_json::Value;

use super::Error;
use crate::state::AppState;

/// The release named in `submission.json` (or the current one when it names none).
fn release_named(unpacked: &Path) -> Option<String> {
    let candidates = [unpacked.join("submission.json")];
    let direct = candidates.iter().find(|p| p.is_file()).cloned().or_else(|| {
        let mut dirs = std::fs::read_dir(unpacked).ok()?.filter_map(|e| e.ok()).filter(|e| e.path().is_dir());
        let only = dirs.next()?;
        dirs.next().is_none().then(|| only.path().join("submission.json")).filter(|p| p.is_file())
    })?;
    // Read only a plausible submission.json; a huge one is reported by the validator.
    if std::fs::metadata(&direct).ok()?.len() > 1 << 20 {
        return None;
    }
    let value: Value = serde_json::from_slice(&std::fs::read(direct).ok()?).ok()?;
    value.get("release")?.as_str().map(str::to_string)
}

/// Unpack and validate an upload (blocking) against the scenes of `split` (the release's
/// primary split when `None`); the index returned is restricted to them. `current` is
/// used when submission.json names no release. With `open`, a release outside it is refused before anything is validated
/// against it (so a dry run tells nothing of a draft's scenes).
pub fn check(
    state: &AppState,
    upload: &Path,
    unpack_to: &Path,
    current: Option<&str>,
    split: Option<Split>,
    open: Option<&BTreeSet<String>>,
) -> Result<(ValidSubmission, ReleaseIndex), Error> {
    let limits = ArchiveLimits {
        max_entries: 20_000,
        max_total_bytes: state.settings.max_unpacked_bytes,
        max_expansion_ratio: Some(state.settings.max_expansion_ratio),
    };
    unpack(upload, unpack_to, limits).map_err(|e| Error::InvalidArchive(as_uploaded(e, upload, unpack_to)))?;
    let version = release_named(unpack_to).or(current.map(str::to_string)).unwrap_or_default();
    // A draft and a version that does not exist get the same answer, decided before the
    // draft's files are looked at: a submission does not tell whether a draft exists.
    let not_open = || {
        Error::Invalid(vec![InputError::new(
            "submission.json",
            "release",
            format!("'{version}' is not a published release of this server; see GET /api/v1/releases"),
        )])
    };
    if crate::releases::check_version(&version).is_err() || open.is_some_and(|open| !open.contains(&version)) {
        return Err(not_open());
    }
    let Some(dir) = state.blobs.release_blocking(&version).map_err(Error::storage)? else {
        return Err(not_open());
    };
    let release = ReleaseIndex::read(&dir).map_err(Error::internal)?;
    let split = split.unwrap_or_else(|| release.primary_split());
    let release = release.for_split(split).map_err(|e| Error::Invalid(vec![InputError::new("(request)", "split", e.message)]))?;
    let submission = validate(unpack_to, &release, SubmissionLimits::for_release(&release, state.settings.max_unpacked_bytes))
        .map_err(|problems| Error::Invalid(problems.into_iter().map(|e| as_uploaded(e, upload, unpack_to)).collect()))?;
    Ok((submission, release))
}

/// An error as the participant must see it: files named by their path inside the upload
/// (`upload` for the archive itself), never by where the server keeps them.
fn as_uploaded(mut e: InputError, upload: &Path, unpacked: &Path) -> InputError {
    let hide = |text: &str| {
        text.replace(&format!("{}/", unpacked.display()), "")
            .replace(&unpacked.display().to_string(), "upload")
            .replace(&upload.display().to_string(), "upload")
    };
    let file = Path::new(&e.file);
    e.file = if file == upload {
        "upload".to_string()
    } else if let Ok(inside) = file.strip_prefix(unpacked) {
        inside.display().to_string()
    } else if file.is_absolute() {
        "upload".to_string()
    } else {
        e.file
    };
    e.field = hide(&e.field);
    e.message = hide(&e.message);
    e
}
