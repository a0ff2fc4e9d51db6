//! The rules of a resumable upload (tus 1.0.0) that a client must follow, beyond the
//! protocol: the service refuses a PATCH that breaks them (`chunk_too_small`).

/// The fewest bytes a PATCH that does not finish its upload may carry, and the most parts an
/// upload is split into (each part is a blob and a line of the upload's record).
const MIN_PART_BYTES: u64 = 64 << 10;
const MAX_PARTS: u64 = 1024;

/// The fewest bytes a PATCH of an upload of `length` bytes must carry unless it is the last:
/// 64 KiB, or more for uploads over 64 MiB, so no upload has more than [`MAX_PARTS`] parts.
pub fn min_part_bytes(length: u64) -> u64 {
    MIN_PART_BYTES.max(length.div_ceil(MAX_PARTS))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_part_is_at_least_64_kib_and_no_upload_has_more_than_1024_parts() {
        assert_eq!(min_part_bytes(0), 64 << 10);
        assert_eq!(min_part_bytes(64 << 20), 64 << 10);
        assert_eq!(min_part_bytes((64 << 20) + 1), (64 << 10) + 1);
        assert!(min_part_bytes(10 << 30) * 1024 >= 10 << 30);
    }
}
