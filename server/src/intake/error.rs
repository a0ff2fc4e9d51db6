//! Why intake refused an upload, and how each reason is answered over HTTP.

use axum::http::StatusCode;
use osmab_evaluator::InputError;
use serde_json::{Value, json};

use super::Quota;
use crate::clock::{now_ms, rfc3339};
use crate::problem::{Problem, ProblemCode};
use crate::store::StoreError;

/// A refused upload. Nothing is stored and no quota is used for any of them.
#[derive(Debug)]
pub enum Error {
    /// The archive does not unpack (the problem names the entry).
    InvalidArchive(InputError),
    /// The submission does not validate against its release (every problem found).
    Invalid(Vec<InputError>),
    /// The release named is not published (a draft, or withdrawn meanwhile).
    ReleaseNotOpen(String),
    /// The team's quota is used up.
    QuotaExceeded(Quota),
    /// The idempotency key names the team's earlier submission (its id) of another archive.
    KeyReused(String),
    /// The store failed.
    Store(StoreError),
    /// The object store could not be reached.
    StorageUnavailable(String),
    /// Something of the server's failed (the disk, a thread).
    Internal(String),
}

impl Error {
    pub fn internal(e: impl std::fmt::Display) -> Self {
        Error::Internal(e.to_string())
    }

    /// A failed blob operation: the object store away, or the server's own failure.
    pub fn storage(e: std::io::Error) -> Self {
        if crate::blobs::unavailable(&e) { Error::StorageUnavailable(e.to_string()) } else { Error::Internal(e.to_string()) }
    }
}

impl From<StoreError> for Error {
    fn from(e: StoreError) -> Self {
        Error::Store(e)
    }
}

/// The problems of an invalid submission as a 422.
fn invalid(problems: &[InputError]) -> Problem {
    let first = problems.first().map(|p| p.to_string()).unwrap_or_default();
    let detail = if problems.len() == 1 {
        format!("The submission was not accepted: {first}. Fix it and upload again; nothing was stored and no quota was used.")
    } else {
        format!(
            "The submission was not accepted: {} problems, the first: {first}. Fix them and upload again; nothing was stored and no quota was used.",
            problems.len()
        )
    };
    let errors: Vec<Value> = problems.iter().map(|p| json!({"file": p.file, "field": p.field, "message": p.message})).collect();
    Problem::new(StatusCode::UNPROCESSABLE_ENTITY, ProblemCode::InvalidSubmission, "Invalid submission", detail).with("errors", Value::Array(errors))
}

/// The 429 of a used-up quota, with `Retry-After` when the next submission is possible.
pub fn quota_exceeded(quota: Quota) -> Problem {
    let view = quota.view();
    let hours = view.window_hours;
    let (when, seconds) = match quota.next_at() {
        // Whole seconds, rounded up: waiting that long always suffices, and never more
        // than the window (a submission is at least a millisecond old when counted).
        Some(at) => (format!("the next one is possible at {} (UTC)", rfc3339(at)), ((at - now_ms()).max(1) as u64).div_ceil(1000)),
        None => ("the organisers allow none at the moment (UTC clock)".to_string(), (quota.window_secs.max(1)) as u64),
    };
    Problem::new(
        StatusCode::TOO_MANY_REQUESTS,
        ProblemCode::QuotaExceeded,
        "Submission quota used",
        format!(
            "Your team has used {} of its {} submissions to the {} split in the last {hours} hours; {when}. Dry runs (?dry_run=true) are free, and `osmab-client validate` scores the val split offline.",
            view.used, view.limit, view.split
        ),
    )
    .with("quota", serde_json::to_value(view).expect("a quota serialises"))
    .retry_after(seconds)
}

impl From<Error> for Problem {
    fn from(e: Error) -> Problem {
        match e {
            Error::InvalidArchive(problem) => Problem { code: ProblemCode::InvalidArchive, title: "Invalid archive".into(), ..invalid(&[problem]) },
            Error::Invalid(problems) => invalid(&problems),
            Error::ReleaseNotOpen(version) => Problem::new(
                StatusCode::CONFLICT,
                ProblemCode::ReleaseNotOpen,
                "Release not open",
                format!("Release '{version}' is not published, so it takes no submissions; see GET /api/v1/releases."),
            ),
            Error::QuotaExceeded(quota) => quota_exceeded(quota),
            Error::KeyReused(id) => Problem::new(
                StatusCode::UNPROCESSABLE_ENTITY,
                ProblemCode::IdempotencyKeyReused,
                "Idempotency key reused",
                format!(
                    "This Idempotency-Key was used for submission {id} of another archive. Send a new key for a new upload; nothing was stored and no quota was used."
                ),
            ),
            Error::Store(StoreError::NotFound) => Problem::not_found("The release is not registered."),
            Error::Store(e) => e.into(),
            Error::StorageUnavailable(message) => {
                tracing::warn!(error = %message, "object storage unavailable");
                Problem::storage_unavailable()
            }
            Error::Internal(message) => Problem::internal(message),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_refusal_has_its_status_and_stable_code() {
        let file = || InputError::new("maps/baseline/scene_000.npz", "points", "NaN in row 3");
        let now = now_ms();
        let quota = Quota { split: osmab_evaluator::scores::Split::Test, limit: 5, window_secs: 86_400, counted: vec![now - 3_600_000; 5], at: now };
        let cases: Vec<(Error, u16, ProblemCode)> = vec![
            (Error::InvalidArchive(file()), 422, ProblemCode::InvalidArchive),
            (Error::Invalid(vec![file(), file()]), 422, ProblemCode::InvalidSubmission),
            (Error::ReleaseNotOpen("2026.2".into()), 409, ProblemCode::ReleaseNotOpen),
            (Error::QuotaExceeded(quota.clone()), 429, ProblemCode::QuotaExceeded),
            (Error::KeyReused("sub_1".into()), 422, ProblemCode::IdempotencyKeyReused),
            (Error::Store(StoreError::NotFound), 404, ProblemCode::NotFound),
            (Error::StorageUnavailable("connection refused".into()), 503, ProblemCode::StorageUnavailable),
            (Error::Internal("disk full".into()), 500, ProblemCode::Internal),
        ];
        for (error, status, code) in cases {
            let problem = Problem::from(error);
            assert_eq!((problem.status.as_u16(), problem.code), (status, code), "{}", problem.detail);
        }
        let invalid = Problem::from(Error::Invalid(vec![file(), file()]));
        assert!(invalid.detail.starts_with("The submission was not accepted: 2 problems, the first: maps/baseline/scene_000.npz"), "{}", invalid.detail);
        assert!(!Problem::from(Error::Internal("disk full at /srv/osmab".into())).detail.contains("/srv"), "internal causes are logged, not sent");
        let limited = Problem::from(Error::QuotaExceeded(quota));
        assert!(limited.detail.contains("used 5 of its 5 submissions to the test split in the last 24 hours"), "{}", limited.detail);
        let retry: u64 = limited.retry_after.expect("Retry-After");
        assert!((82_700..=82_802).contains(&retry), "23 hours until the oldest leaves the window (rounded up): {retry}");
    }
}
