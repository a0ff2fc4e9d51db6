//! The stable `code` of every error the API answers, with what it means and what to do:
//! one enum the handlers name, the problem bodies carry and the OpenAPI document and
//! `/api/docs` list.

/// Declares [`ProblemCode`] from `Variant = "code"` entries whose doc comment is the
/// meaning shown to clients.
macro_rules! problem_codes {
    ($($(#[doc = $meaning:literal])+ $variant:ident = $code:literal,)+) => {
        /// A stable, machine-readable error code (`quota_exceeded`).
        #[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
        pub enum ProblemCode {
            $($(#[doc = $meaning])+ $variant,)+
        }

        impl ProblemCode {
            /// Every code, in the order the documentation lists them.
            pub const ALL: &[ProblemCode] = &[$(ProblemCode::$variant,)+];

            /// The code as clients see it.
            pub const fn as_str(self) -> &'static str {
                match self {
                    $(ProblemCode::$variant => $code,)+
                }
            }

            /// The code a client read from a problem body, if it is one of these.
            pub fn from_code(code: &str) -> Option<ProblemCode> {
                match code {
                    $($code => Some(ProblemCode::$variant),)+
                    _ => None,
                }
            }

            /// What the code means and what to do.
            pub fn meaning(self) -> &'static str {
                match self {
                    $(ProblemCode::$variant => concat!($($meaning),+).trim_ascii_start(),)+
                }
            }
        }
    };
}

problem_codes! {
    /// The operation needs a token: send `Authorization: Bearer osmab_…`.
    Unauthenticated = "unauthenticated",
    /// The token is malformed or unknown; copy the whole token, or ask for a new one.
    TokenInvalid = "token_invalid",
    /// The token was revoked; ask the organisers for a new one.
    TokenRevoked = "token_revoked",
    /// The token expired; ask the organisers for a new one.
    TokenExpired = "token_expired",
    /// The token is valid but may not do this (team vs admin scope).
    Forbidden = "forbidden",
    /// No such record, or not one you can see.
    NotFound = "not_found",
    /// No such route.
    RouteNotFound = "route_not_found",
    /// The route exists but not with this method.
    MethodNotAllowed = "method_not_allowed",
    /// The request body or parameters are malformed; the detail names the field.
    InvalidRequest = "invalid_request",
    /// A query parameter does not parse (a number, a boolean); the detail names it.
    InvalidQuery = "invalid_query",
    /// A path parameter does not parse (e.g. not UTF-8).
    InvalidPath = "invalid_path",
    /// The Content-Digest header is malformed.
    InvalidDigest = "invalid_digest",
    /// The Idempotency-Key header is not 1 to 255 visible ASCII characters.
    InvalidIdempotencyKey = "invalid_idempotency_key",
    /// The Idempotency-Key made an earlier submission of another archive; send a new key for a new upload.
    IdempotencyKeyReused = "idempotency_key_reused",
    /// The upload's SHA-256 differs from its Content-Digest; upload again.
    DigestMismatch = "digest_mismatch",
    /// The upload ended before Content-Length bytes arrived (upload again), or a resumable upload was submitted before all its bytes arrived.
    UploadIncomplete = "upload_incomplete",
    /// The upload is over the size limit.
    PayloadTooLarge = "payload_too_large",
    /// The request body stalled (nothing arrived for the body idle timeout); send it again.
    RequestTimeout = "request_timeout",
    /// The upload is not a readable tar, tar.gz or zip, or holds a refused entry (links, `..`, too many or too large files).
    InvalidArchive = "invalid_archive",
    /// The submission breaks the format; `errors` lists every problem with file, field and message.
    InvalidSubmission = "invalid_submission",
    /// The release named by the submission takes no submissions (not published).
    ReleaseNotOpen = "release_not_open",
    /// The team's submissions for this UTC day are used; `Retry-After` says when the next is possible. Dry runs are free.
    QuotaExceeded = "quota_exceeded",
    /// Too many write requests; `Retry-After` says when to retry.
    RateLimited = "rate_limited",
    /// The requested byte range lies outside the file.
    RangeNotSatisfiable = "range_not_satisfiable",
    /// The record exists or is in a state that forbids this.
    Conflict = "conflict",
    /// The database or storage is unreachable.
    NotReady = "not_ready",
    /// The object storage cannot be reached right now; nothing was stored and no quota was used. Retry after `Retry-After`.
    StorageUnavailable = "storage_unavailable",
    /// A resumable-upload request without `Tus-Resumable: 1.0.0`.
    TusVersion = "tus_version",
    /// A header of a resumable upload is missing or malformed; the detail names it.
    InvalidHeader = "invalid_header",
    /// `Upload-Metadata` is not comma-separated `KEY BASE64` pairs, or over 4 KiB.
    InvalidMetadata = "invalid_metadata",
    /// A resumable-upload PATCH without `Content-Type: application/offset+octet-stream`.
    UnsupportedMediaType = "unsupported_media_type",
    /// `Upload-Offset` is not where the upload stands (another request appended first); `offset` says where, or ask with HEAD.
    OffsetMismatch = "offset_mismatch",
    /// More bytes than the upload's `Upload-Length`.
    UploadOverrun = "upload_overrun",
    /// `Upload-Checksum` names an algorithm other than sha256.
    ChecksumAlgorithm = "checksum_algorithm",
    /// The chunk's SHA-256 differs from its `Upload-Checksum` (status 460); nothing was kept, send it again.
    ChecksumMismatch = "checksum_mismatch",
    /// Another PATCH of this resumable upload is still arriving at this server (409); wait for it, then continue from the offset HEAD reports.
    UploadBusy = "upload_busy",
    /// A PATCH that does not finish the upload carries fewer bytes than `minimum` (a sliver of the length, at least 64 KiB); send larger chunks.
    ChunkTooSmall = "chunk_too_small",
    /// The resumable upload expired before it was complete; start a new one.
    UploadExpired = "upload_expired",
    /// The team holds `OSMAB_MAX_OPEN_UPLOADS` resumable uploads open (429); finish or DELETE one, or let it expire.
    TooManyUploads = "too_many_uploads",
    /// The team's open resumable uploads would declare more than `OSMAB_MAX_OPEN_UPLOAD_BYTES` (413); finish or DELETE one.
    OpenUploadsTooLarge = "open_uploads_too_large",
    /// An unexpected failure, logged with the request id.
    Internal = "internal",
}

impl std::fmt::Display for ProblemCode {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.as_str())
    }
}

#[cfg(test)]
mod tests {
    use super::ProblemCode;

    #[test]
    fn codes_are_unique_snake_case_and_explained() {
        let mut seen = std::collections::HashSet::new();
        for code in ProblemCode::ALL {
            assert!(seen.insert(code.as_str()), "{code} twice");
            assert!(code.as_str().bytes().all(|b| b.is_ascii_lowercase() || b == b'_'), "{code}");
            assert!(code.meaning().ends_with('.') && !code.meaning().starts_with(' '), "{code}: {:?}", code.meaning());
        }
        assert_eq!(ProblemCode::QuotaExceeded.as_str(), "quota_exceeded");
        assert!(ProblemCode::QuotaExceeded.meaning().starts_with("The team's submissions"));
    }

    #[test]
    fn a_code_read_back_is_the_code_sent_and_an_unknown_one_is_none() {
        for &code in ProblemCode::ALL {
            assert_eq!(ProblemCode::from_code(code.as_str()), Some(code));
        }
        assert_eq!(ProblemCode::from_code("quota_exceded"), None);
    }
}
