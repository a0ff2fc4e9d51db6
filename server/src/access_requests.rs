//! A way in for a team without an organiser at hand: it asks on the "Take part" page (or
//! `POST /api/v1/access-requests`) with its team name, a contact, its affiliation and a
//! link to its method, and is shown a claim code once. The operator approves or declines in
//! the console or with `osmab admin team requests`; approving creates the team. The
//! requester then collects the team's first token, once, with the claim code. Nothing but
//! the request exists until it is approved; a client holds at most [`PENDING_PER_CLIENT`]
//! pending requests and the service [`PENDING_IN_ALL`]; a claim code that is not known
//! counts as a failed authentication.

use osmab_evaluator::text::display_name_problem;
use serde::{Deserialize, Serialize};

use crate::clock::{new_id, now_ms, random_alphanumeric, rfc3339};
use crate::problem::{Problem, ProblemCode};
use crate::state::AppState;
use crate::store::{AccessRequestRecord, AccessRequestState, StoreError, TokenScope};

/// Pending requests one client may hold.
pub const PENDING_PER_CLIENT: i64 = 3;
/// Pending requests the service holds at most.
pub const PENDING_IN_ALL: i64 = 500;
/// The claim code's prefix (so a pasted code is recognised as one).
const CLAIM_PREFIX: &str = "osmab_claim_";

/// What a team sends to ask for access.
#[derive(Debug, Clone, Default, Deserialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct AccessRequestForm {
    /// The team's name as the board will show it.
    pub team_name: String,
    /// How the organisers reach the team (an e-mail address, a handle).
    pub contact: String,
    /// The lab, university or company.
    pub affiliation: String,
    /// A link to the method (paper, code or project page), if there is one.
    #[serde(default)]
    pub method_url: Option<String>,
}

/// A request as its requester and the operator see it.
#[derive(Debug, Clone, Serialize, Deserialize, schemars::JsonSchema)]
pub struct AccessRequestView {
    pub id: String,
    pub team_name: String,
    pub contact: String,
    pub affiliation: String,
    pub method_url: Option<String>,
    pub state: AccessRequestState,
    /// Why it was declined.
    pub reason: Option<String>,
    pub created_at: String,
    pub decided_at: Option<String>,
}

impl From<&AccessRequestRecord> for AccessRequestView {
    fn from(r: &AccessRequestRecord) -> Self {
        Self {
            id: r.id.clone(),
            team_name: r.team_name.clone(),
            contact: r.contact.clone(),
            affiliation: r.affiliation.clone(),
            method_url: r.method_url.clone(),
            state: r.state,
            reason: r.reason.clone(),
            created_at: rfc3339(r.created_at),
            decided_at: r.decided_at.map(rfc3339),
        }
    }
}

/// A request just made, with its claim code (shown this once).
#[derive(Debug, Clone, Serialize, Deserialize, schemars::JsonSchema)]
pub struct AskedAccess {
    pub id: String,
    pub claim_code: String,
    pub state: AccessRequestState,
}

/// What collecting with a claim code gives.
#[derive(Debug, Clone, Serialize, Deserialize, schemars::JsonSchema)]
pub struct Collected {
    pub state: AccessRequestState,
    pub team_name: String,
    /// The team's first token, present once: when the request was approved and this is the
    /// first collection.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub token: Option<String>,
    /// What the state means, in words.
    pub message: String,
}

/// Why `form` cannot be asked, naming the field.
fn form_problem(form: &AccessRequestForm) -> Option<String> {
    let team_name = form.team_name.trim();
    if let Some(problem) = display_name_problem(team_name, 80).or_else(|| crate::reserved_names::team_name_problem(team_name)) {
        return Some(format!("team_name: {problem}"));
    }
    for (field, text, max) in [("contact", form.contact.trim(), 200), ("affiliation", form.affiliation.trim(), 200)] {
        if let Some(problem) = display_name_problem(text, max) {
            return Some(format!("{field}: {problem}"));
        }
    }
    form.method_url.as_deref().map(str::trim).filter(|u| !u.is_empty()).and_then(|url| {
        let link = (url.starts_with("https://") || url.starts_with("http://")) && url.len() <= 500 && !url.chars().any(char::is_whitespace);
        (!link).then(|| format!("method_url: expected an http(s) link of at most 500 characters, found '{}'", url.chars().take(80).collect::<String>()))
    })
}

/// The name of a team or pending request `name` reads as, if any (UTS #39 skeletons).
async fn look_alike(state: &AppState, name: &str) -> Result<Option<String>, Problem> {
    let teams = state.store.teams().await?.into_iter().map(|t| t.name);
    let pending = state.store.access_requests(Some(AccessRequestState::Pending)).await?.into_iter().map(|r| r.team_name);
    Ok(teams.chain(pending).find(|other| osmab_evaluator::text::impersonates(name, other, false)))
}

/// Record the request `form` from `client` (the rate limiter's key); its claim code is in
/// the answer, and nowhere else.
pub async fn ask(state: &AppState, form: &AccessRequestForm, client: &str) -> Result<AskedAccess, Problem> {
    if let Some(problem) = form_problem(form) {
        return Err(Problem::invalid_request(problem));
    }
    let team_name = form.team_name.trim().to_string();
    if let Some(taken) = look_alike(state, &team_name).await? {
        return Err(Problem::conflict(format!("team_name: '{team_name}' reads as '{taken}', a team or a request already made; choose another name")));
    }
    let claim_code = format!("{CLAIM_PREFIX}{}", random_alphanumeric(24));
    let record = AccessRequestRecord {
        id: new_id("acc"),
        team_name,
        contact: form.contact.trim().to_string(),
        affiliation: form.affiliation.trim().to_string(),
        method_url: form.method_url.as_deref().map(str::trim).filter(|u| !u.is_empty()).map(str::to_string),
        claim_sha256: crate::token::hash(&claim_code),
        client: client.to_string(),
        state: AccessRequestState::Pending,
        reason: None,
        team_id: None,
        created_at: now_ms(),
        decided_at: None,
        collected_at: None,
    };
    if !state.store.insert_access_request(&record, PENDING_PER_CLIENT, PENDING_IN_ALL).await? {
        return Err(Problem::new(
            axum::http::StatusCode::TOO_MANY_REQUESTS,
            ProblemCode::RateLimited,
            "Too many requests for access",
            format!(
                "This address has {PENDING_PER_CLIENT} requests waiting for the organisers (or the service holds {PENDING_IN_ALL}): wait for a decision, then ask again."
            ),
        ));
    }
    tracing::info!(request = %record.id, team = %record.team_name, "access requested");
    Ok(AskedAccess { id: record.id, claim_code, state: AccessRequestState::Pending })
}

/// Approve request `id`: its team is created (and nothing else until it is collected).
pub async fn approve(state: &AppState, id: &str) -> Result<AccessRequestView, Problem> {
    let request = state.store.access_request(id).await.map_err(|e| not_found(e, id))?;
    if request.state != AccessRequestState::Pending {
        return Err(Problem::conflict(format!("Access request {id} is {}; only a pending one can be approved.", request.state)));
    }
    let team = crate::routes::admin_teams::create_team_record(state, &request.team_name, None).await?;
    state.store.advance_access_request(id, AccessRequestState::Pending, AccessRequestState::Approved, None, Some(&team.id), now_ms()).await?;
    tracing::info!(request = %id, team = %team.name, "access approved");
    Ok((&state.store.access_request(id).await?).into())
}

/// Decline request `id` with `reason`, which its requester reads when collecting.
pub async fn decline(state: &AppState, id: &str, reason: &str) -> Result<AccessRequestView, Problem> {
    let reason = reason.trim();
    if let Some(problem) = display_name_problem(reason, 300) {
        return Err(Problem::invalid_request(format!("reason: {problem}")));
    }
    let request = state.store.access_request(id).await.map_err(|e| not_found(e, id))?;
    if request.state != AccessRequestState::Pending {
        return Err(Problem::conflict(format!("Access request {id} is {}; only a pending one can be declined.", request.state)));
    }
    state.store.advance_access_request(id, AccessRequestState::Pending, AccessRequestState::Declined, Some(reason), None, now_ms()).await?;
    tracing::info!(request = %id, "access declined");
    Ok((&state.store.access_request(id).await?).into())
}

/// What the claim code `code` gives now: the team's first token once approved (and only
/// the first time), else where the request stands. `Err(None)` for a code no request has.
pub async fn collect(state: &AppState, code: &str) -> Result<Collected, Option<Problem>> {
    let code = code.trim();
    let request = match state.store.access_request_by_claim(&crate::token::hash(code)).await {
        Ok(request) => request,
        Err(StoreError::NotFound) => return Err(None),
        Err(e) => return Err(Some(e.into())),
    };
    let (token, message) = match (request.state, &request.team_id) {
        (AccessRequestState::Pending, _) => (None, "Your request waits for the organisers. Come back with the same code later.".to_string()),
        (AccessRequestState::Declined, _) => (None, format!("The organisers declined the request: {}", request.reason.as_deref().unwrap_or("no reason given"))),
        (AccessRequestState::Collected, _) => {
            (None, "The team's token was collected already; it is shown only once. Ask the organisers for a new one if it is lost.".to_string())
        }
        (AccessRequestState::Approved, Some(team_id)) => {
            // Taking the request first: of two collections at once, one wins the token.
            state
                .store
                .advance_access_request(&request.id, AccessRequestState::Approved, AccessRequestState::Collected, None, None, now_ms())
                .await
                .map_err(|e| Some(Problem::from(e)))?;
            let (token, record) = crate::auth::issue_token(TokenScope::Team, Some(team_id), None);
            state.store.insert_token(&record).await.map_err(|e| Some(Problem::from(e)))?;
            tracing::info!(request = %request.id, token = %record.hint, "access collected");
            (Some(token), "Approved: here is your team's token, shown this once. Keep it like a password.".to_string())
        }
        (AccessRequestState::Approved, None) => return Err(Some(Problem::internal(format!("access request {} is approved without a team", request.id)))),
    };
    let state_now = if token.is_some() { AccessRequestState::Collected } else { request.state };
    Ok(Collected { state: state_now, team_name: request.team_name, token, message })
}

fn not_found(e: StoreError, id: &str) -> Problem {
    match e {
        StoreError::NotFound => Problem::not_found(format!("There is no access request '{id}'.")),
        e => e.into(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn form(team_name: &str, method_url: Option<&str>) -> AccessRequestForm {
        AccessRequestForm {
            team_name: team_name.into(),
            contact: "a@lab.example".into(),
            affiliation: "A Lab".into(),
            method_url: method_url.map(str::to_string),
        }
    }

    #[test]
    fn a_request_names_the_field_it_fails_on() {
        assert_eq!(form_problem(&form("Robot Lab", Some("https://lab.example/paper"))), None);
        assert_eq!(form_problem(&form("Robot Lab", Some(""))), None, "the link is optional");
        assert!(form_problem(&form("", None)).unwrap().starts_with("team_name:"));
        assert!(form_problem(&form("OSMa-Bench baselines", None)).unwrap().contains("reserves"));
        assert!(form_problem(&form("Robot Lab", Some("javascript:alert(1)"))).unwrap().starts_with("method_url:"));
        let mut no_contact = form("Robot Lab", None);
        no_contact.contact = " ".into();
        assert!(form_problem(&no_contact).unwrap().starts_with("contact:"));
    }
}
