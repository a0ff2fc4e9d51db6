//! The closed sets the store records: a submission's, a job's and a release's state;
//! a job's kind, a token's scope and a release file's kind. Each is a TEXT column (with a
//! CHECK constraint) in both databases (with the `sqlx` feature, which the service's store
//! turns on), snake_case in JSON, and its name in problem details and logs.

use serde::{Deserialize, Serialize};

/// Declares a state enum mapped to a TEXT column, with `name()` and `Display`.
macro_rules! state {
    ($(#[$doc:meta])* $ty:ident { $($(#[$vdoc:meta])* $variant:ident = $name:literal,)+ }) => {
        $(#[$doc])*
        #[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize, schemars::JsonSchema)]
        #[cfg_attr(feature = "sqlx", derive(sqlx::Type), sqlx(type_name = "text", rename_all = "snake_case"))]
        #[serde(rename_all = "snake_case")]
        pub enum $ty {
            $($(#[$vdoc])* $variant,)+
        }

        impl $ty {
            /// Every value, in declaration order (what the column's CHECK constraint lists).
            pub const ALL: [$ty; [$($name),+].len()] = [$($ty::$variant,)+];

            /// The name as stored and served.
            pub const fn name(self) -> &'static str {
                match self { $($ty::$variant => $name,)+ }
            }
        }

        impl std::fmt::Display for $ty {
            fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
                f.write_str(self.name())
            }
        }
    };
}

state!(
    /// Where a submission is: received → validating → queued ⇄ scoring → scored, or
    /// failed / cancelled.
    SubmissionState {
        /// The upload is arriving.
        Received = "received",
        /// The upload is being unpacked and validated.
        Validating = "validating",
        /// Waiting for a worker.
        Queued = "queued",
        /// A worker scores it.
        Scoring = "scoring",
        /// Scored; the scores are recorded.
        Scored = "scored",
        /// Scoring failed for good; the reason says why.
        Failed = "failed",
        /// Cancelled by its team or an admin.
        Cancelled = "cancelled",
    }
);

impl SubmissionState {
    /// Whether the submission can still change by itself (not scored, failed or cancelled).
    pub fn is_active(self) -> bool {
        !matches!(self, SubmissionState::Scored | SubmissionState::Failed | SubmissionState::Cancelled)
    }
}

state!(
    /// Where a job is: queued → running → succeeded, failed or cancelled; a retry or a
    /// released job goes back to queued.
    JobState {
        Queued = "queued",
        Running = "running",
        Succeeded = "succeeded",
        Failed = "failed",
        Cancelled = "cancelled",
    }
);

state!(
    /// Whether a release takes submissions.
    ReleaseState {
        /// Being built or awaiting publication: no submissions, not public.
        Draft = "draft",
        /// Public; the current release is the newest published one.
        Published = "published",
    }
);

state!(
    /// What a token may do.
    TokenScope {
        /// Everything, the organisers' console included.
        Admin = "admin",
        /// What its team may do.
        Team = "team",
    }
);

state!(
    /// What a background job does (see `jobs::Job`).
    JobKind {
        /// Score a submission.
        ScoreSubmission = "score_submission",
        /// Build a release: fan out its sequences, then assemble and register it.
        BuildRelease = "build_release",
        /// Render the sequences of one scene of a release being built (its lightings not yet rendered).
        RenderSequence = "render_sequence",
    }
);

state!(
    /// What a public file of a release is.
    ReleaseFileKind {
        /// A file of the manifest.
        File = "file",
        /// A sequence archive (the sequence's files in one download).
        Archive = "archive",
    }
);

state!(
    /// Where a request for access is: pending → approved (the team exists) → collected (its
    /// first token was taken), or declined.
    AccessRequestState {
        /// Waiting for the operator.
        Pending = "pending",
        /// The team exists; its token waits for the claim code.
        Approved = "approved",
        /// Refused, with a reason.
        Declined = "declined",
        /// The requester took the team's first token.
        Collected = "collected",
    }
);
