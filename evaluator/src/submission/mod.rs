//! A whole submission (product.md section 5) checked against a release, then scored.
//!
//! [`release::ReleaseIndex`] says what a release holds; [`validate::validate`] reads
//! every file of an unpacked submission once and reports every problem with the file
//! (relative to the submission), field and expectation; [`score::score_submission`]
//! turns a valid submission into the scores object of product.md section 9. The
//! server and `osmab client validate` run this very code.

pub mod archive;
pub mod extents;
pub mod release;
pub mod score;
pub mod validate;
pub mod warm;
pub mod zip_directory;

pub use archive::{ArchiveLimits, pack_directory, pack_directory_as, pack_directory_into, pack_files_as, pack_files_into, tar_file_names, unpack};
pub use release::ReleaseIndex;
pub use score::{ScoringTimings, score_submission, score_submission_timed};
pub use validate::{MethodCard, SubmissionLimits, ValidSubmission, validate};

/// The `format` value of `submission.json`.
pub const SUBMISSION_FORMAT: &str = "osmab-submission/1";
