//! Signed score receipts: what a submission was (its upload's SHA-256), what it was scored
//! against (release and its digest, evaluator version), its full results document (by
//! SHA-256, downloadable) and its headline numbers — signed by the service as a compact JWS
//! (EdDSA, Ed25519, `kid` in the header) whose keys are published as a JWKS. Anyone can
//! check a receipt offline, with `osmab client verify` or any JOSE library, so a paper can
//! cite one. A receipt is the same every time it is asked for (Ed25519 signatures are
//! deterministic and `iat` is the time of scoring).

pub mod jws;
pub mod keys;

use std::collections::BTreeMap;

use osmab_evaluator::scores::{Lighting, Scores, Split};
use osmab_evaluator::semseg::report::MetricTriple;
use schemars::JsonSchema;
use serde::{Deserialize, Serialize};
use sha2::Digest;

pub use keys::ReceiptKeys;

/// The headline numbers of a receipt, per lighting.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
pub struct ReceiptSummary {
    /// Every (lighting, scene) of the release had a map.
    pub complete: bool,
    /// Pooled segmentation metrics per lighting.
    pub semseg: BTreeMap<Lighting, MetricTriple>,
    /// Pooled VQA accuracy per lighting, where the submission had scene graphs or answers
    /// (not for a test submission: see `Scores::disclosed`).
    #[serde(default, skip_serializing_if = "BTreeMap::is_empty")]
    pub vqa: BTreeMap<Lighting, Option<f64>>,
    /// Pooled VQA accuracy over every lighting.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub vqa_all_lightings: Option<f64>,
}

/// The signed payload (fields in the order of their keys).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
pub struct Receipt {
    pub evaluator_version: String,
    /// The organisers' flag on the entry when the receipt was issued (its reason): a receipt
    /// of a flagged entry says so, signed.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub flagged: Option<String>,
    /// Issued at: the time of scoring, in seconds since the epoch.
    pub iat: i64,
    /// `osmab`.
    pub iss: String,
    pub method: String,
    pub release: String,
    /// The release's digest (manifest.json).
    pub release_digest: String,
    /// SHA-256 of the full results document (every lighting and scene), as served at `results_url`.
    pub results_sha256: String,
    pub results_url: String,
    pub scored_at: String,
    /// The split whose scenes were scored (absent before releases had splits).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub split: Option<Split>,
    pub submission_id: String,
    pub summary: ReceiptSummary,
    pub team: String,
    /// Of an anonymous entry (`team` is "Anonymous"): SHA-256 of its team's name and the
    /// entry's claim code ([`team_commitment`]), which only the team is shown, so the team
    /// can prove the entry theirs and nobody else can claim it.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub team_commitment: Option<String>,
    /// SHA-256 of the uploaded archive.
    pub upload_sha256: String,
}

/// The full results document of `scores`: the bytes the receipt's `results_sha256` names.
pub fn results_document(scores: &Scores) -> String {
    serde_json::to_string(scores).expect("a score document serialises")
}

/// The commitment an anonymous entry's receipt carries to team `team` with claim code `code`.
pub fn team_commitment(team: &str, code: &str) -> String {
    sha256_hex(format!("osmab receipt team\0{team}\0{code}").as_bytes())
}

/// Lowercase hex SHA-256 of `bytes`.
pub fn sha256_hex(bytes: &[u8]) -> String {
    sha2::Sha256::digest(bytes).iter().map(|b| format!("{b:02x}")).collect()
}

/// What a receipt is made from.
pub struct Facts<'a> {
    /// The service's public origin (`Settings::public_url`): a receipt names who issued it, and
    /// `osmab client verify` checks it against where the keys came from.
    pub issuer: &'a str,
    pub submission_id: &'a str,
    pub team: &'a str,
    pub method: &'a str,
    pub upload_sha256: &'a str,
    pub release_digest: &'a str,
    pub scored_at_ms: i64,
    pub scores: &'a Scores,
    /// The organisers' flag on the entry, if any.
    pub flagged: Option<&'a str>,
    /// Of an anonymous entry, its team commitment.
    pub team_commitment: Option<&'a str>,
}

impl Receipt {
    /// The receipt of `facts`.
    pub fn of(facts: &Facts) -> Receipt {
        let scores = facts.scores;
        let summary = ReceiptSummary {
            complete: scores.complete,
            semseg: scores.semseg.iter().map(|(l, t)| (*l, t.overall)).collect(),
            vqa: scores.vqa.iter().flat_map(|v| v.lightings.iter().map(|(l, cell)| (*l, cell.overall.accuracy))).collect(),
            vqa_all_lightings: scores.vqa.as_ref().and_then(|v| v.all_lightings.overall.accuracy),
        };
        Receipt {
            evaluator_version: scores.evaluator_version.clone(),
            flagged: facts.flagged.map(str::to_string),
            iat: facts.scored_at_ms / 1000,
            iss: facts.issuer.into(),
            method: facts.method.into(),
            release: scores.release.clone(),
            release_digest: facts.release_digest.into(),
            results_sha256: sha256_hex(results_document(scores).as_bytes()),
            results_url: format!("/api/v1/submissions/{}/results.json", facts.submission_id),
            scored_at: crate::clock::rfc3339(facts.scored_at_ms),
            split: scores.split,
            submission_id: facts.submission_id.into(),
            summary,
            team: facts.team.into(),
            team_commitment: facts.team_commitment.map(str::to_string),
            upload_sha256: facts.upload_sha256.into(),
        }
    }

    /// The receipt signed with `keys`, as a compact JWS.
    pub fn sign(&self, keys: &ReceiptKeys) -> String {
        let (key, kid) = keys.signing();
        jws::sign(&serde_json::to_vec(self).expect("a receipt serialises"), key, kid)
    }

    /// The receipt in `token` once it verifies against `keys`.
    pub fn verify(token: &str, keys: &jws::Jwks) -> Result<Receipt, String> {
        let payload = jws::verify(token, keys)?;
        serde_json::from_slice(&payload).map_err(|e| format!("the signature is good but the payload is not a receipt: {e}"))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_receipt_is_the_same_every_time_and_names_its_results_by_hash() {
        let dir = tempfile::tempdir().unwrap();
        let keys = ReceiptKeys::open(dir.path()).unwrap();
        let scores = Scores { release: "r1".into(), evaluator_version: "0.1.0".into(), complete: true, ..Scores::default() };
        let facts = Facts {
            issuer: "https://osmab.example.org",
            submission_id: "sub_1",
            team: "T",
            method: "M",
            upload_sha256: "ab",
            release_digest: "cd",
            scored_at_ms: 1_700_000_000_123,
            scores: &scores,
            flagged: None,
            team_commitment: None,
        };
        let receipt = Receipt::of(&facts);
        assert_eq!((receipt.iat, receipt.iss.as_str()), (1_700_000_000, "https://osmab.example.org"));
        assert_eq!(receipt.results_sha256, sha256_hex(results_document(&scores).as_bytes()));
        let token = receipt.sign(&keys);
        assert_eq!(token, Receipt::of(&facts).sign(&keys), "deterministic");
        assert_eq!(Receipt::verify(&token, keys.published()).unwrap(), receipt);
        assert!(!serde_json::to_string(&receipt).unwrap().contains("flagged"), "receipts of unflagged entries read as before");
        let flagged = Receipt::of(&Facts { flagged: Some("maps copied from another team"), ..facts });
        assert_eq!(Receipt::verify(&flagged.sign(&keys), keys.published()).unwrap().flagged.as_deref(), Some("maps copied from another team"));
    }
}
