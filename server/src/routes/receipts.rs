//! Score receipts: `GET /api/v1/keys` (the JWKS), `GET /api/v1/submissions/{id}/receipt`
//! (the signed receipt of the latest score; as `application/jose` when asked for) and
//! `GET /api/v1/submissions/{id}/results.json` (the full results document the receipt
//! names by SHA-256). Visible to whoever may see the submission: everyone for entries on
//! the public leaderboard, the baselines included.

use axum::extract::State;
use axum::http::{HeaderMap, StatusCode, header};
use axum::response::{IntoResponse, Response};
use schemars::JsonSchema;
use serde::Serialize;

use super::extract::ApiPath;
use super::operation::{ApiRoutes, Auth, Operation, Verb};
use crate::auth::Caller;
use crate::problem::{ApiResult, Problem};
use crate::receipts::{self, Facts, Receipt, results_document};
use crate::state::AppState;

/// `GET /api/v1/submissions/{id}/receipt`.
#[derive(Debug, Serialize, JsonSchema)]
pub struct SignedReceipt {
    /// The receipt as a compact JWS (EdDSA, Ed25519): what to keep and cite.
    pub jws: String,
    /// Where the keys that verify it are.
    pub keys_url: String,
    /// The signed payload, decoded for reading (verify `jws`, not this).
    pub receipt: Receipt,
}

/// `GET /api/v1/keys`: the public keys of receipts, the signing one first.
pub async fn keys(State(state): State<AppState>) -> Response {
    ([(header::CACHE_CONTROL, "public, max-age=300")], axum::Json(state.receipts.published().clone())).into_response()
}

/// The latest score document of a visible submission as it may be shown
/// (`Scores::disclosed`), with when it was scored.
async fn latest(state: &AppState, caller: &Caller, id: &str) -> ApiResult<(crate::store::SubmissionRecord, osmab_evaluator::scores::Scores, i64)> {
    let submission = super::submissions::visible_submission(state, caller, id).await?;
    let latest = state.store.scores(id).await?.pop();
    match latest {
        Some(record) => match record.scores {
            Some(scores) => Ok((submission, scores.disclosed(), record.created_at)),
            None => Err(Problem::internal(format!("the latest score of {id} does not read"))),
        },
        None => Err(Problem::conflict(format!("Submission {id} is {}; it has no score to issue a receipt for yet.", submission.state))),
    }
}

/// `GET /api/v1/submissions/{id}/receipt`.
pub async fn receipt(State(state): State<AppState>, caller: Caller, ApiPath(id): ApiPath<String>, headers: HeaderMap) -> ApiResult<Response> {
    let (submission, scores, scored_at_ms) = latest(&state, &caller, &id).await?;
    let team = state.store.team(&submission.team_id).await?;
    let release = state.store.release(&submission.release).await?;
    // An entry that stays anonymous gets an anonymous receipt (a new one once revealed).
    let team_name = if submission.card.anonymous { crate::leaderboard::ANONYMOUS } else { team.name.as_str() };
    let commitment = submission.card.anonymous.then(|| crate::receipts::team_commitment(&team.name, &state.receipts.claim_code(&submission.id)));
    let receipt = receipts::issue(&Facts {
        // `serve` sets it (to where it listens when not configured).
        issuer: state.settings.public_url.as_deref().unwrap_or("osmab"),
        submission_id: &submission.id,
        team: team_name,
        method: &submission.card.name,
        upload_sha256: &submission.archive_sha256,
        release_digest: &release.digest,
        scored_at_ms,
        scores: &scores,
        flagged: submission.flag.as_deref(),
        team_commitment: commitment.as_deref(),
    });
    let jws = receipts::sign(&receipt, &state.receipts);
    let wants_jose = headers.get(header::ACCEPT).and_then(|v| v.to_str().ok()).is_some_and(|a| a.contains("application/jose"));
    if wants_jose {
        return Ok(([(header::CONTENT_TYPE, "application/jose")], jws).into_response());
    }
    Ok(axum::Json(SignedReceipt { jws, keys_url: "/api/v1/keys".into(), receipt }).into_response())
}

/// `GET /api/v1/submissions/{id}/results.json`: the exact bytes a receipt's `results_sha256` names.
pub async fn results(State(state): State<AppState>, caller: Caller, ApiPath(id): ApiPath<String>) -> ApiResult<Response> {
    let (_, scores, _) = latest(&state, &caller, &id).await?;
    let document = results_document(&scores);
    let disposition = format!("inline; filename=\"{id}-results.json\"");
    Ok((StatusCode::OK, [(header::CONTENT_TYPE, "application/json".to_string()), (header::CONTENT_DISPOSITION, disposition)], document).into_response())
}

/// Receipts, results documents and the keys that verify them.
pub fn routes() -> ApiRoutes {
    ApiRoutes::new()
        .operation(
            Operation::new(
                Verb::Get,
                "/api/v1/submissions/{id}/receipt",
                Auth::Optional,
                "The signed receipt of the latest score: a compact JWS (EdDSA, Ed25519, `kid` in the header) of the upload's SHA-256, the release and its digest, the evaluator version, the SHA-256 of the full results document and the headline numbers; the JWS alone with `Accept: application/jose`. Verify with `osmab client verify` or any JOSE library against `/api/v1/keys`.",
                200,
            )
            .returns::<SignedReceipt>(),
            receipt,
        )
        .operation(
            Operation::new(
                Verb::Get,
                "/api/v1/submissions/{id}/results.json",
                Auth::Optional,
                "The full results document of the latest score (every lighting and scene), byte for byte what the receipt's `results_sha256` names.",
                200,
            )
            .returns_free_json(),
            results,
        )
        .operation(
            Operation::new(
                Verb::Get,
                "/api/v1/keys",
                Auth::Public,
                "The public keys of receipts as a JWKS (RFC 7517; `kty` OKP, `crv` Ed25519), the signing key first; retired keys stay listed.",
                200,
            )
            .returns::<crate::receipts::jws::Jwks>(),
            keys,
        )
}
