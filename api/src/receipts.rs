//! Signed score receipts: what a submission was (its upload's SHA-256), what it was scored
//! against (release and its digest, evaluator version), its full results document (by
//! SHA-256, downloadable) and its headline numbers — signed by the service as a compact JWS
//! (EdDSA, Ed25519, `kid` in the header) whose keys are published as a JWKS. Anyone can
//! check a receipt offline, with `osmab client verify` or any JOSE library, so a paper can
//! cite one. A receipt is the same every time it is asked for (Ed25519 signatures are
//! deterministic and `iat` is the time of scoring). The service issues and signs them
//! (`osmab::receipts`); anyone reads and verifies them with this module.

use std::collections::BTreeMap;

use osmab_evaluator::scores::{Lighting, Scores, Split};
use osmab_evaluator::semseg::report::MetricTriple;
use schemars::JsonSchema;
use serde::{Deserialize, Serialize};
use sha2::Digest;

use crate::jws;

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

/// `url` as an origin (`https://host[:port]`, the default port left out), as a receipt
/// names its issuer, or why it is not one: an http:// or https:// address with a host and
/// without a path, query or credentials.
pub fn origin(url: &str) -> Result<String, String> {
    let parsed = url::Url::parse(url).map_err(|e| format!("cannot read '{url}' as a URL: {e}"))?;
    if !["http", "https"].contains(&parsed.scheme()) || parsed.host().is_none() {
        return Err(format!("'{url}' is not an http:// or https:// address with a host"));
    }
    if parsed.path() != "/" || parsed.query().is_some() || parsed.fragment().is_some() || !parsed.username().is_empty() || parsed.password().is_some() {
        return Err(format!("'{url}' must be an origin such as https://osmab.example.org, without a path, query or credentials"));
    }
    Ok(parsed.origin().ascii_serialization())
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
    crate::digest::hex(&sha2::Sha256::digest(bytes))
}

impl Receipt {
    /// The receipt in `token` once it verifies against `keys`.
    pub fn verify(token: &str, keys: &jws::Jwks) -> Result<Receipt, String> {
        let payload = jws::verify(token, keys)?;
        serde_json::from_slice(&payload).map_err(|e| format!("the signature is good but the payload is not a receipt: {e}"))
    }
}
