//! API tokens and who is calling. A token is a fixed prefix plus 32 random characters;
//! only its SHA-256 is stored, so a leaked database holds no usable token. Handlers take
//! [`Caller`], [`TeamCaller`] or [`AdminCaller`] and never see the token itself.

use crate::clock::{new_id, now_ms, random_alphanumeric};
use crate::problem::{Problem, ProblemCode};
use crate::state::AppState;
use crate::store::{StoreError, Team, TokenRecord, TokenScope};
use crate::token;
use axum::extract::FromRequestParts;
use axum::http::StatusCode;
use axum::http::request::Parts;

/// A new token (shown once) and its record.
pub fn issue_token(scope: TokenScope, team_id: Option<&str>, expires_at: Option<i64>) -> (String, TokenRecord) {
    let token = token::with_prefix(&random_alphanumeric(token::ISSUED_LENGTH));
    let record = TokenRecord {
        id: new_id("tok"),
        team_id: team_id.map(str::to_string),
        scope,
        sha256: token::hash(&token),
        hint: token::hint(&token),
        created_at: now_ms(),
        expires_at,
        revoked_at: None,
    };
    (token, record)
}

/// The id prefix of console sessions: admin-scoped tokens the console issues at sign-in,
/// which sign nobody in again (a session never renews itself past its sign-out).
const SESSION_PREFIX: &str = "ses";

/// A console session for an operator who signed in with the admin token, expiring at `expires_at`.
pub fn issue_session(expires_at: i64) -> (String, TokenRecord) {
    let (token, mut record) = issue_token(TokenScope::Admin, None, Some(expires_at));
    record.id = new_id(SESSION_PREFIX);
    (token, record)
}

/// Whether `record` is a console session ([`issue_session`]), not a token an administrator holds.
pub fn is_session(record: &TokenRecord) -> bool {
    record.id.strip_prefix(SESSION_PREFIX).is_some_and(|rest| rest.starts_with('_'))
}

/// Who made a request.
#[derive(Debug, Clone)]
pub enum Caller {
    /// No token.
    Anonymous,
    /// An admin token.
    Admin,
    /// A team token.
    Team(Team),
}

impl Caller {
    /// Whether the caller may see `team_id`'s private records.
    pub fn can_see_team(&self, team_id: &str) -> bool {
        match self {
            Caller::Admin => true,
            Caller::Team(team) => team.id == team_id,
            Caller::Anonymous => false,
        }
    }

    /// May the caller `action` (e.g. "edit a submission") a record of `team_id`: the team
    /// itself or an admin; anyone else is refused, 401 without a token, 403 with another.
    pub fn may_change(&self, team_id: &str, action: &str) -> Result<(), Problem> {
        match self {
            Caller::Anonymous => {
                Err(unauthenticated(ProblemCode::Unauthenticated, &format!("To {action}, send the team's token: 'Authorization: Bearer osmab_…'.")))
            }
            _ if self.can_see_team(team_id) => Ok(()),
            _ => Err(Problem::forbidden(format!("Only the submitting team (or an admin) can {action}."))),
        }
    }
}

fn unauthenticated(code: ProblemCode, detail: &str) -> Problem {
    Problem::new(StatusCode::UNAUTHORIZED, code, "Authentication required", detail)
}

async fn resolve(parts: &Parts, state: &AppState) -> Result<Caller, Problem> {
    let mut values = parts.headers.get_all(axum::http::header::AUTHORIZATION).iter();
    let Some(value) = values.next() else {
        return Ok(Caller::Anonymous);
    };
    if values.next().is_some() {
        return Err(unauthenticated(ProblemCode::TokenInvalid, "Send one Authorization header, not several."));
    }
    let text = value.to_str().unwrap_or("").trim();
    // The scheme is case-insensitive (RFC 9110 §11.1).
    let token = match text.split_once(' ') {
        Some((scheme, token)) if scheme.eq_ignore_ascii_case("bearer") => token.trim(),
        _ => return Err(unauthenticated(ProblemCode::TokenInvalid, "Send the token as 'Authorization: Bearer osmab_…'.")),
    };
    let (caller, record) = caller_with_token(state, token).await?;
    if is_session(&record) {
        // A session cookie is for the console's pages: taken from a browser, it opens no API.
        return Err(unauthenticated(
            ProblemCode::TokenInvalid,
            "This is a console session, which opens the pages under /admin only; the API takes the admin token.",
        ));
    }
    Ok(caller)
}

/// Who holds `token`, and its record; a malformed, unknown, revoked or expired token is
/// refused with a problem that says which.
pub async fn caller_with_token(state: &AppState, token: &str) -> Result<(Caller, TokenRecord), Problem> {
    if !token::has_prefix(token) {
        return Err(unauthenticated(ProblemCode::TokenInvalid, "This is not an osmab token (they start with 'osmab_'). Copy the whole token you were given."));
    }
    let record = match state.store.token_by_hash(&token::hash(token)).await {
        Ok(record) => record,
        Err(StoreError::NotFound) => {
            return Err(unauthenticated(
                ProblemCode::TokenInvalid,
                "The token is not known to this server. Check that it was copied whole, or ask the organisers for a new one.",
            ));
        }
        Err(e) => return Err(e.into()),
    };
    if let Some(at) = record.revoked_at {
        return Err(unauthenticated(
            ProblemCode::TokenRevoked,
            &format!("This token was revoked at {}. Ask the organisers for a new one and run `osmab-client login` again.", crate::clock::rfc3339(at)),
        ));
    }
    if let Some(at) = record.expires_at
        && at <= now_ms()
    {
        return Err(unauthenticated(
            ProblemCode::TokenExpired,
            &format!("This token expired at {}. Ask the organisers for a new one and run `osmab-client login` again.", crate::clock::rfc3339(at)),
        ));
    }
    let caller = match (record.scope, &record.team_id) {
        (TokenScope::Admin, _) => Caller::Admin,
        (_, Some(team_id)) => Caller::Team(state.store.team(team_id).await?),
        _ => return Err(Problem::internal(format!("token {} has no team", record.id))),
    };
    Ok((caller, record))
}

/// The caller of a request resolved once (by the rate limiter, then reused by the
/// handler's extractor).
#[derive(Clone)]
struct Resolved(Caller);

/// Who sent the request: its token looked up once per request (a failure is not kept, so
/// it is looked up again, and answered, by the handler).
pub async fn caller_of(parts: &mut Parts, state: &AppState) -> Result<Caller, Problem> {
    if let Some(Resolved(caller)) = parts.extensions.get::<Resolved>() {
        return Ok(caller.clone());
    }
    let caller = resolve(parts, state).await?;
    parts.extensions.insert(Resolved(caller.clone()));
    Ok(caller)
}

impl FromRequestParts<AppState> for Caller {
    type Rejection = Problem;

    async fn from_request_parts(parts: &mut Parts, state: &AppState) -> Result<Self, Self::Rejection> {
        caller_of(parts, state).await
    }
}

/// A request made with a team token.
#[derive(Debug, Clone)]
pub struct TeamCaller(pub Team);

impl FromRequestParts<AppState> for TeamCaller {
    type Rejection = Problem;

    async fn from_request_parts(parts: &mut Parts, state: &AppState) -> Result<Self, Self::Rejection> {
        match caller_of(parts, state).await? {
            Caller::Team(team) => Ok(TeamCaller(team)),
            Caller::Admin => Err(Problem::forbidden("This needs a team token; admin tokens act for no team.")),
            Caller::Anonymous => Err(unauthenticated(ProblemCode::Unauthenticated, "This needs a team token: send 'Authorization: Bearer osmab_…'.")),
        }
    }
}

/// A request made with a token, a team's (acting on its own records) or an admin's (on any
/// team's): refused without one before anything else is looked at.
#[derive(Debug, Clone)]
pub struct SignedInCaller(pub Caller);

impl FromRequestParts<AppState> for SignedInCaller {
    type Rejection = Problem;

    async fn from_request_parts(parts: &mut Parts, state: &AppState) -> Result<Self, Self::Rejection> {
        match caller_of(parts, state).await? {
            Caller::Anonymous => {
                Err(unauthenticated(ProblemCode::Unauthenticated, "This needs a team token (or an admin token): send 'Authorization: Bearer osmab_…'."))
            }
            caller => Ok(SignedInCaller(caller)),
        }
    }
}

/// A request made with an admin token.
#[derive(Debug, Clone)]
pub struct AdminCaller;

impl FromRequestParts<AppState> for AdminCaller {
    type Rejection = Problem;

    async fn from_request_parts(parts: &mut Parts, state: &AppState) -> Result<Self, Self::Rejection> {
        match caller_of(parts, state).await? {
            Caller::Admin => Ok(AdminCaller),
            Caller::Team(_) => Err(Problem::forbidden("This needs an admin token; team tokens cannot manage the service.")),
            Caller::Anonymous => Err(unauthenticated(ProblemCode::Unauthenticated, "This needs an admin token: send 'Authorization: Bearer osmab_…'.")),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn only_the_hash_of_an_issued_token_is_kept() {
        let (token, record) = issue_token(TokenScope::Team, Some("team_x"), None);
        assert!(token.starts_with(token::PREFIX));
        assert_eq!(token.len(), token::PREFIX.len() + 32);
        assert_eq!(record.sha256, token::hash(&token));
        assert_eq!(record.sha256.len(), 64);
        assert!(!format!("{record:?}").contains(&token[token::PREFIX.len() + 4..]));
    }
}
