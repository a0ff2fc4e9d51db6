//! The API token format, in one place that both the configuration check and the request
//! authentication use: a fixed prefix plus random letters and digits. Only a token's
//! SHA-256 is stored, with a short hint to tell tokens apart. Nothing here depends on
//! the rest of the service (issuing a token, with its randomness, is `auth::issue_token`).

use sha2::{Digest, Sha256};

/// Every token starts with this. Never change it: clients and secret scanners rely on it.
pub const PREFIX: &str = "osmab_";

/// Random characters in a token the server issues.
pub const ISSUED_LENGTH: usize = 32;

/// Random characters an operator-chosen token (`OSMAB_ADMIN_TOKEN`) needs at least.
const CONFIGURED_MIN_LENGTH: usize = 24;

/// A token of `random` letters and digits (at least [`ISSUED_LENGTH`] of them when issued).
pub fn with_prefix(random: &str) -> String {
    format!("{PREFIX}{random}")
}

/// Lowercase hex of the SHA-256 of `token`: what the store keeps.
pub fn hash(token: &str) -> String {
    Sha256::digest(token.as_bytes()).iter().map(|b| format!("{b:02x}")).collect()
}

/// The first characters of `token` (the prefix and four more), to tell tokens apart in lists.
pub fn hint(token: &str) -> String {
    token.chars().take(PREFIX.len() + 4).collect()
}

/// Whether `text` is in the token format at all (it may still be unknown or revoked).
pub fn has_prefix(text: &str) -> bool {
    text.starts_with(PREFIX)
}

/// Check an operator-chosen token: the prefix and at least 24 letters, digits or `_`.
pub fn check_configured(text: &str) -> Result<(), String> {
    let body = text.strip_prefix(PREFIX).unwrap_or("");
    if has_prefix(text) && body.len() >= CONFIGURED_MIN_LENGTH && body.bytes().all(|b| b.is_ascii_alphanumeric() || b == b'_') {
        Ok(())
    } else {
        Err(format!("must be '{PREFIX}' followed by at least {CONFIGURED_MIN_LENGTH} letters or digits (e.g. {PREFIX}$(openssl rand -hex 16))"))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn issued_tokens_have_the_prefix_and_pass_the_configured_check() {
        let token = with_prefix(&"a1".repeat(ISSUED_LENGTH / 2));
        assert!(has_prefix(&token));
        assert_eq!(token.len(), PREFIX.len() + ISSUED_LENGTH);
        assert_eq!(check_configured(&token), Ok(()));
        assert_eq!(hint(&token), token[..PREFIX.len() + 4]);
    }

    #[test]
    fn hash_is_sha256_hex() {
        assert_eq!(hash("abc"), "ba7816bf8f01cfea414140de5dae2223b00361a396177a9cb410ff61f20015ad");
    }

    #[test]
    fn configured_tokens_need_the_prefix_and_enough_safe_characters() {
        assert!(check_configured("osmab_short").is_err());
        assert!(check_configured("token_0123456789abcdef0123456789").is_err());
        assert!(check_configured("osmab_0123456789abcdef01234567;").is_err());
        assert!(check_configured("osmab_0123456789abcdef01234567").is_ok());
    }
}
