//! The release's two splits: which scenes are `val` (open) and which are `test` (hidden),
//! and the operator's secret that shapes every test scene, so that a published config —
//! it travels in the manifest — rebuilds the val scenes but not the test ones.
//!
//! The secret enters the seed of a test scene's synthesis: the layout, and with it the
//! trajectory, the frames and the ground truth, follow from it. Without the secret a
//! rebuild from the config yields other rooms, whose semantics say nothing of the
//! published test frames.

use osmab_evaluator::scores::Split;
use osmab_evaluator::{InputError, Result};
use serde::{Deserialize, Serialize};
use sha2::{Digest, Sha256};

use super::manifest::hex;

/// The environment variable holding the operator's split secret for release builds.
pub const SPLIT_SECRET_VARIABLE: &str = "OSMAB_SPLIT_SECRET";

/// Characters a split secret needs at least.
const MIN_SECRET_CHARS: usize = 16;

/// How many scenes of each subset the hidden test split takes (`[splits]` of a release
/// config); the rest are val. Test scenes are spread evenly through each subset's
/// scenes, which come in the selection's farthest-first order.
#[derive(Debug, Clone, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SplitsConfig {
    #[serde(default)]
    pub test_furniture: usize,
    #[serde(default)]
    pub test_manipuland: usize,
}

impl SplitsConfig {
    /// No test split: every scene is val (and the config hashes as before splits existed).
    pub fn is_empty(&self) -> bool {
        self.test_furniture == 0 && self.test_manipuland == 0
    }

    /// The split of scene `index` of a selection of `furniture` then `manipuland` scenes.
    pub fn split_of(&self, index: usize, furniture: usize, manipuland: usize) -> Split {
        let (position, scenes, test) =
            if index < furniture { (index, furniture, self.test_furniture) } else { (index - furniture, manipuland, self.test_manipuland) };
        let is_test = (0..test.min(scenes)).any(|k| (2 * k + 1) * scenes / (2 * test) == position);
        if is_test { Split::Test } else { Split::Val }
    }
}

/// PBKDF2 rounds of the secret's public id: a guess of an operator-chosen passphrase costs
/// this many HMAC-SHA-256 evaluations (≈0.1 s here) instead of one hash.
const ID_ROUNDS: u32 = 100_000;

/// The operator's secret (from [`SPLIT_SECRET_VARIABLE`] or the server's data folder), and
/// its public id once derived.
#[derive(Clone)]
pub struct SplitSecret(String, std::sync::OnceLock<String>);

impl std::fmt::Debug for SplitSecret {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "SplitSecret({})", self.id())
    }
}

impl SplitSecret {
    /// A secret from its text; `source` names where it came from for the error.
    pub fn new(text: &str, source: &str) -> Result<Self> {
        let text = text.trim();
        if text.chars().count() < MIN_SECRET_CHARS || text.chars().any(char::is_control) {
            return Err(InputError::new(
                source,
                "(secret)",
                format!("a split secret is at least {MIN_SECRET_CHARS} printable characters (e.g. `openssl rand -hex 32`)"),
            ));
        }
        Ok(Self(text.to_string(), std::sync::OnceLock::new()))
    }

    /// The secret in [`SPLIT_SECRET_VARIABLE`], if set.
    pub fn from_env() -> Result<Option<Self>> {
        match std::env::var(SPLIT_SECRET_VARIABLE) {
            Ok(text) if !text.trim().is_empty() => Self::new(&text, SPLIT_SECRET_VARIABLE).map(Some),
            _ => Ok(None),
        }
    }

    /// A public name of the secret: build stages and manifests record it, so a build resumed
    /// under another secret redoes its test scenes and a release tells which secret built it.
    /// Derived slowly (PBKDF2-HMAC-SHA-256, [`ID_ROUNDS`] rounds): the id is published, and a
    /// fast hash of it would let anyone test guesses of a passphrase at millions a second.
    pub fn id(&self) -> String {
        self.1.get_or_init(|| hex(&pbkdf2_sha256(self.0.as_bytes(), b"osmab split secret id", ID_ROUNDS))[..16].to_string()).clone()
    }

    /// The synthesis seed of test scene `index` of a release seeded with `seed`.
    pub fn scene_seed(&self, seed: u64, index: usize) -> u64 {
        let mut hasher = Sha256::new();
        hasher.update(b"osmab test scene seed\0");
        hasher.update(self.0.as_bytes());
        hasher.update(seed.to_le_bytes());
        hasher.update((index as u64).to_le_bytes());
        u64::from_le_bytes(hasher.finalize()[..8].try_into().expect("8 bytes"))
    }

    /// The seed of placement `attempt` of test scene `index` (attempt 0 is
    /// [`SplitSecret::scene_seed`]): a scene whose placement misses its prompt's relations
    /// or the planned quality check is placed again from the next.
    pub fn attempt_seed(&self, seed: u64, index: usize, attempt: usize) -> u64 {
        if attempt == 0 {
            return self.scene_seed(seed, index);
        }
        let mut hasher = Sha256::new();
        hasher.update(b"osmab test scene placement\0");
        hasher.update(self.0.as_bytes());
        hasher.update(seed.to_le_bytes());
        hasher.update((index as u64).to_le_bytes());
        hasher.update((attempt as u64).to_le_bytes());
        u64::from_le_bytes(hasher.finalize()[..8].try_into().expect("8 bytes"))
    }

    /// Where the prompt `prompt_id` stands in the secret order in which test scenes draw
    /// their prompts from the pool: the pool is rebuilt by anyone from the published config,
    /// so which of its prompts the test scenes took is decided by the secret.
    pub fn test_prompt_rank(&self, prompt_id: &str) -> u64 {
        let mut hasher = Sha256::new();
        hasher.update(b"osmab test prompt\0");
        hasher.update(self.0.as_bytes());
        hasher.update(prompt_id.as_bytes());
        u64::from_le_bytes(hasher.finalize()[..8].try_into().expect("8 bytes"))
    }
}

/// PBKDF2 (RFC 8018) with HMAC-SHA-256, one 32-byte block.
fn pbkdf2_sha256(password: &[u8], salt: &[u8], rounds: u32) -> [u8; 32] {
    use hmac::{Hmac, KeyInit, Mac};
    let keyed = Hmac::<Sha256>::new_from_slice(password).expect("HMAC takes a key of any length");
    let mut mac = keyed.clone();
    mac.update(salt);
    mac.update(&1u32.to_be_bytes());
    let mut block: [u8; 32] = mac.finalize().into_bytes().into();
    let mut sum = block;
    for _ in 1..rounds {
        let mut mac = keyed.clone();
        mac.update(&block);
        block = mac.finalize().into_bytes().into();
        sum.iter_mut().zip(block).for_each(|(s, b)| *s ^= b);
    }
    sum
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pbkdf2_is_the_standards_function() {
        // RFC 7914 §11's PBKDF2-HMAC-SHA-256 vector ("passwd", "salt", 1 round), first 32 bytes.
        assert_eq!(hex(&pbkdf2_sha256(b"passwd", b"salt", 1)), "55ac046e56e3089fec1691c22544b605f94185216dde0465e68b9d57c20dacbc");
    }

    #[test]
    fn the_public_id_is_not_a_fast_hash_of_the_secret() {
        let secret = SplitSecret::new("correct horse battery staple", "test").unwrap();
        let fast = hex(&Sha256::digest("osmab split secret id\0correct horse battery staple".as_bytes()))[..16].to_string();
        assert_ne!(secret.id(), fast, "a guess is no longer one SHA-256 away");
        assert_eq!(secret.id(), hex(&pbkdf2_sha256(b"correct horse battery staple", b"osmab split secret id", ID_ROUNDS))[..16]);
        assert_eq!(secret.id().len(), 16);
    }

    #[test]
    fn test_scenes_are_spread_evenly_through_each_subset() {
        let splits = SplitsConfig { test_furniture: 12, test_manipuland: 1 };
        let of = |i| splits.split_of(i, 24, 16);
        let furniture: Vec<usize> = (0..24).filter(|&i| of(i) == Split::Test).collect();
        assert_eq!(furniture, (0..12).map(|k| 2 * k + 1).collect::<Vec<_>>(), "every other furniture scene, from the second");
        let manipuland: Vec<usize> = (24..40).filter(|&i| of(i) == Split::Test).collect();
        assert_eq!(manipuland, [32], "one in the middle of sixteen");
        let demo = SplitsConfig { test_furniture: 1, test_manipuland: 1 };
        assert_eq!((0..3).map(|i| demo.split_of(i, 2, 1)).collect::<Vec<_>>(), [Split::Val, Split::Test, Split::Test]);
        assert!((0..40).all(|i| SplitsConfig::default().split_of(i, 24, 16) == Split::Val), "no [splits]: all val");
        let all = SplitsConfig { test_furniture: 3, test_manipuland: 0 };
        assert!((0..3).all(|i| all.split_of(i, 3, 2) == Split::Test));
    }

    #[test]
    fn the_secret_changes_every_test_seed_and_its_id_reveals_nothing_of_it() {
        let a = SplitSecret::new("correct horse battery staple", "test").unwrap();
        let b = SplitSecret::new("correct horse battery stapler", "test").unwrap();
        assert_eq!(a.scene_seed(42, 1), SplitSecret::new(" correct horse battery staple\n", "test").unwrap().scene_seed(42, 1), "trimmed");
        assert_ne!(a.scene_seed(42, 1), b.scene_seed(42, 1));
        assert_ne!(a.scene_seed(42, 1), a.scene_seed(42, 2));
        assert_ne!(a.scene_seed(42, 1), a.scene_seed(43, 1));
        assert_ne!(a.id(), b.id());
        assert!(!format!("{a:?}").contains("horse"), "Debug shows the id, never the secret");
        let short = SplitSecret::new("hunter2", "OSMAB_SPLIT_SECRET").unwrap_err();
        assert!(short.to_string().contains("OSMAB_SPLIT_SECRET") && short.to_string().contains("16"), "{short}");
    }
}
