//! The service's receipt-signing keys: Ed25519 seeds in owner-only files under
//! `OSMAB_DATA_DIR/receipt-keys/`, named `<created ms>.<kid>.seed`. The first start
//! generates one, as it does the admin token; `osmab keys rotate` adds a new one, which
//! signs from then on, while the old ones stay listed so receipts they signed still verify.
//! Several servers share the folder (or a copy of it) to sign with the same key.

use std::path::{Path, PathBuf};

use anyhow::{Context, bail};
use ed25519_dalek::SigningKey;

use super::jws::{Jwk, Jwks, thumbprint};

/// The folder (in the data directory) and blob prefix of the receipt-signing keys.
pub const RECEIPT_KEYS: &str = "receipt-keys";

/// The keys of this service: the newest signs, all verify.
pub struct ReceiptKeys {
    signing: SigningKey,
    kid: String,
    published: Jwks,
    /// Derived from the oldest key, which is never removed: the claim codes of anonymous
    /// entries stay the same across key rotations.
    claim_key: [u8; 32],
}

fn read_seed(path: &Path) -> anyhow::Result<SigningKey> {
    let text = std::fs::read_to_string(path).with_context(|| format!("{}: cannot read", path.display()))?;
    let bytes: Vec<u8> = (0..text.trim().len())
        .step_by(2)
        .map(|i| text.trim().get(i..i + 2).and_then(|h| u8::from_str_radix(h, 16).ok()))
        .collect::<Option<_>>()
        .with_context(|| format!("{}: expected 64 hexadecimal digits", path.display()))?;
    let seed: [u8; 32] = bytes.try_into().map_err(|_| anyhow::anyhow!("{}: expected 64 hexadecimal digits (a 32-byte seed)", path.display()))?;
    Ok(SigningKey::from_bytes(&seed))
}

/// Write a new random key into `dir`; returns its file.
pub fn generate(dir: &Path) -> anyhow::Result<PathBuf> {
    crate::secret_files::owner_only_dir(dir).with_context(|| format!("{}: cannot create", dir.display()))?;
    let mut seed = [0u8; 32];
    getrandom::fill(&mut seed).map_err(|e| anyhow::anyhow!("the operating system's random generator failed: {e}"))?;
    let key = SigningKey::from_bytes(&seed);
    let path = dir.join(format!("{}.{}.seed", crate::clock::now_ms(), thumbprint(&key.verifying_key())));
    let hex: String = seed.iter().map(|b| format!("{b:02x}")).collect();
    crate::secret_files::write_new_owner_only(&path, hex.as_bytes()).with_context(|| format!("{}: cannot write", path.display()))?;
    Ok(path)
}

impl ReceiptKeys {
    /// The keys in `dir`, generating the first when there is none.
    pub fn open(dir: &Path) -> anyhow::Result<Self> {
        let list = |dir: &Path| -> anyhow::Result<Vec<PathBuf>> {
            let mut files: Vec<PathBuf> = match std::fs::read_dir(dir) {
                Ok(entries) => entries.flatten().map(|e| e.path()).filter(|p| p.extension().is_some_and(|x| x == "seed")).collect(),
                Err(e) if e.kind() == std::io::ErrorKind::NotFound => Vec::new(),
                Err(e) => return Err(e).with_context(|| format!("{}: cannot list", dir.display())),
            };
            // `<created ms>.<kid>.seed`: the newest last.
            files.sort_by_key(|p| p.file_name().and_then(|n| n.to_str()).and_then(|n| n.split('.').next()?.parse::<u64>().ok()).unwrap_or(0));
            Ok(files)
        };
        let mut files = list(dir)?;
        if files.is_empty() {
            let path = generate(dir)?;
            tracing::warn!(file = %path.display(), "generated the receipt-signing key; keep this owner-only folder like the admin token");
            files = list(dir)?;
        }
        let mut keys = Vec::new();
        for path in &files {
            let key = read_seed(path)?;
            let kid = thumbprint(&key.verifying_key());
            if !path.file_name().and_then(|n| n.to_str()).is_some_and(|n| n.contains(&kid)) {
                bail!("{}: the file is named for another key than the one it holds", path.display());
            }
            keys.push(key);
        }
        let claim_key: [u8; 32] = {
            use sha2::Digest;
            let oldest = keys.first().expect("at least one key");
            sha2::Sha256::new().chain_update(b"osmab claim key\0").chain_update(oldest.to_bytes()).finalize().into()
        };
        let signing = keys.pop().expect("at least one key");
        let mut published: Vec<Jwk> = std::iter::once(&signing).chain(keys.iter().rev()).map(|k| Jwk::of(&k.verifying_key())).collect();
        published.dedup_by(|a, b| a.kid == b.kid);
        Ok(ReceiptKeys { kid: thumbprint(&signing.verifying_key()), signing, published: Jwks { keys: published }, claim_key })
    }

    /// The key that signs, and its id.
    pub fn signing(&self) -> (&SigningKey, &str) {
        (&self.signing, &self.kid)
    }

    /// The claim code of submission `id`: shown to its team only, it proves an anonymous
    /// entry theirs against the team commitment its receipt carries
    /// ([`super::team_commitment`]), and tells nothing of the team's other entries.
    pub fn claim_code(&self, id: &str) -> String {
        use hmac::{KeyInit, Mac};
        let mut mac = hmac::Hmac::<sha2::Sha256>::new_from_slice(&self.claim_key).expect("HMAC takes a key of any length");
        mac.update(b"osmab claim\0");
        mac.update(id.as_bytes());
        mac.finalize().into_bytes().iter().take(16).map(|b| format!("{b:02x}")).collect()
    }

    /// Every public key, the signing one first.
    pub fn published(&self) -> &Jwks {
        &self.published
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_first_open_generates_a_key_rotation_adds_one_and_old_keys_stay_listed() {
        let dir = tempfile::tempdir().unwrap();
        let first = ReceiptKeys::open(&dir.path().join("keys")).unwrap();
        assert_eq!(first.published().keys.len(), 1);
        let again = ReceiptKeys::open(&dir.path().join("keys")).unwrap();
        assert_eq!(again.signing().1, first.signing().1, "the same key on the next start");
        std::thread::sleep(std::time::Duration::from_millis(2));
        generate(&dir.path().join("keys")).unwrap();
        let rotated = ReceiptKeys::open(&dir.path().join("keys")).unwrap();
        assert_ne!(rotated.signing().1, first.signing().1, "the new key signs");
        let kids: Vec<&str> = rotated.published().keys.iter().map(|k| k.kid.as_str()).collect();
        assert_eq!(kids, [rotated.signing().1, first.signing().1], "the old key stays listed");
        #[cfg(unix)]
        for entry in std::fs::read_dir(dir.path().join("keys")).unwrap() {
            use std::os::unix::fs::PermissionsExt;
            assert_eq!(entry.unwrap().metadata().unwrap().permissions().mode() & 0o777, 0o600, "owner-only");
        }
    }

    #[test]
    fn a_damaged_key_file_is_refused_by_name() {
        let dir = tempfile::tempdir().unwrap();
        std::fs::write(dir.path().join("1.abc.seed"), "not hex").unwrap();
        let error = ReceiptKeys::open(dir.path()).err().unwrap().to_string();
        assert!(error.contains("1.abc.seed") && error.contains("64 hexadecimal digits"), "{error}");
    }
}
