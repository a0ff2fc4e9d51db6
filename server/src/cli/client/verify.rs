//! `osmab client verify RECEIPT --keys JWKS [--results FILE]`: check a score receipt
//! offline — its signature against the service's published keys, and optionally that a
//! results document is the one the receipt names — and print what it certifies.

use std::path::Path;

use anyhow::{Context, bail};

use crate::receipts::jws::Jwks;
use crate::receipts::{Receipt, sha256_hex};

/// The compact JWS in `text`: the token itself, or the JSON of `GET …/receipt` (its `jws`).
fn token_of(text: &str) -> anyhow::Result<String> {
    let text = text.trim();
    if text.starts_with('{') {
        let value: serde_json::Value = serde_json::from_str(text).context("the receipt file is JSON but does not parse")?;
        return value["jws"].as_str().map(str::to_string).context("the receipt JSON has no \"jws\"");
    }
    Ok(text.to_string())
}

/// Verify the receipt in `receipt` against the key set in `keys`; with `results`, check
/// that file's SHA-256 too. Returns the receipt.
pub fn verify(receipt: &Path, keys: &Path, results: Option<&Path>) -> anyhow::Result<Receipt> {
    let text = std::fs::read_to_string(receipt).with_context(|| format!("{}: cannot read", receipt.display()))?;
    let keys: Jwks = serde_json::from_slice(&std::fs::read(keys).with_context(|| format!("{}: cannot read", keys.display()))?)
        .with_context(|| format!("{}: not a JWKS ({{\"keys\": [...]}})", keys.display()))?;
    let receipt = Receipt::verify(&token_of(&text)?, &keys).map_err(|why| anyhow::anyhow!("the receipt does not verify: {why}"))?;
    if let Some(path) = results {
        let bytes = std::fs::read(path).with_context(|| format!("{}: cannot read", path.display()))?;
        let found = sha256_hex(&bytes);
        if found != receipt.results_sha256 {
            bail!(
                "{}: its SHA-256 is {found}, the receipt names {}; it is not the results document this receipt certifies",
                path.display(),
                receipt.results_sha256
            );
        }
    }
    Ok(receipt)
}

/// The receipt in words.
pub fn describe(receipt: &Receipt, results_checked: bool) -> String {
    let mut out = format!(
        "Valid receipt issued by {} for submission {} ({}, team {}), scored {} with evaluator {} on release {} (digest {}).\nUpload SHA-256: {}\nResults SHA-256: {}{}\n",
        receipt.iss,
        receipt.submission_id,
        receipt.method,
        receipt.team,
        receipt.scored_at,
        receipt.evaluator_version,
        receipt.release,
        receipt.release_digest,
        receipt.upload_sha256,
        receipt.results_sha256,
        if results_checked { " (matches the results file)" } else { "" }
    );
    for (lighting, t) in &receipt.summary.semseg {
        out.push_str(&format!("  {lighting}: pooled mIoU {:.1}, f-mIoU {:.1}, mAcc {:.1}\n", t.miou * 100.0, t.fmiou * 100.0, t.macc * 100.0));
    }
    out
}
