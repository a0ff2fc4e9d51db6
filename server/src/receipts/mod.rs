//! The service's side of signed score receipts ([`osmab_api::receipts`] says what one is):
//! it issues the receipt of a scored submission from what it recorded, and signs it with
//! its newest key ([`keys`]). A receipt is the same every time it is asked for (Ed25519
//! signatures are deterministic and `iat` is the time of scoring).

pub mod keys;

use osmab_evaluator::scores::Scores;

pub use keys::ReceiptKeys;
pub use osmab_api::jws;
pub use osmab_api::receipts::{Receipt, ReceiptSummary, results_document, sha256_hex, team_commitment};

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

/// The receipt of `facts`.
pub fn issue(facts: &Facts) -> Receipt {
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

/// `receipt` signed with `keys`, as a compact JWS.
pub fn sign(receipt: &Receipt, keys: &ReceiptKeys) -> String {
    let (key, kid) = keys.signing();
    jws::sign(&serde_json::to_vec(receipt).expect("a receipt serialises"), key, kid)
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
        let receipt = issue(&facts);
        assert_eq!((receipt.iat, receipt.iss.as_str()), (1_700_000_000, "https://osmab.example.org"));
        assert_eq!(receipt.results_sha256, sha256_hex(results_document(&scores).as_bytes()));
        let token = sign(&receipt, &keys);
        assert_eq!(token, sign(&issue(&facts), &keys), "deterministic");
        assert_eq!(Receipt::verify(&token, keys.published()).unwrap(), receipt);
        assert!(!serde_json::to_string(&receipt).unwrap().contains("flagged"), "receipts of unflagged entries read as before");
        let flagged = issue(&Facts { flagged: Some("maps copied from another team"), ..facts });
        assert_eq!(Receipt::verify(&sign(&flagged, &keys), keys.published()).unwrap().flagged.as_deref(), Some("maps copied from another team"));
    }
}
