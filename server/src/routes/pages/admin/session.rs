//! Signing in to the operator's pages: the admin token is typed once into a form; the
//! server answers with a session token of its own (an admin-scope token in the store,
//! valid for [`SESSION_HOURS`], revoked at sign-out) in an `HttpOnly`, `SameSite=Strict`
//! cookie scoped to `/admin`, so the admin token itself never sits in a browser and every
//! server of a deployment knows the session. Forms carry a token derived from the
//! session ([`AdminSession::form_token`]); a POST without it, or from another origin, is
//! refused.

use axum::extract::{FromRequestParts, State};
use axum::http::request::Parts;
use axum::http::{HeaderMap, StatusCode, header};
use axum::response::{IntoResponse, Redirect, Response};
use serde::Deserialize;
use sha2::{Digest, Sha256};

use super::origin::PageOrigin;
use super::{AdminMessage, LoginPage, parse_form};
use crate::auth::{Caller, caller_with_token};
use crate::clock::now_ms;
use crate::state::AppState;

/// Where the sign-in form is, and posts to.
pub const LOGIN_PATH: &str = "/admin/login";
/// The session cookie.
pub const COOKIE: &str = "osmab_admin_session";
/// How long a session lasts.
pub const SESSION_HOURS: i64 = 12;

/// A signed-in operator.
#[derive(Debug, Clone)]
pub struct AdminSession {
    token: String,
    token_id: String,
    /// Where the page was served from (forms must come from there).
    origin: PageOrigin,
}

impl AdminSession {
    /// The value every form of this session carries (a hash of the session token: other
    /// sites cannot know it).
    pub fn form_token(&self) -> String {
        Sha256::digest(format!("osmab admin form\n{}", self.token)).iter().take(16).map(|b| format!("{b:02x}")).collect()
    }

    /// A seal over a notice the console shows after an action, so a crafted link cannot
    /// put words of its own on the console.
    pub fn seal(&self, notice: &str) -> String {
        Sha256::digest(format!("osmab admin notice\n{}\n{notice}", self.token)).iter().take(8).map(|b| format!("{b:02x}")).collect()
    }

    /// Refuse a form that lacks this session's form token or comes from another origin.
    pub fn check_form(&self, headers: &HeaderMap, form_token: &str) -> Result<(), Response> {
        // The page's host as the browser saw it: the Host header, a trusted proxy's
        // forwarded one (some proxies rewrite Host) or the configured public URL's.
        let same_origin = match headers.get(header::ORIGIN) {
            Some(origin) => self.origin.admits(origin.to_str().unwrap_or("")),
            // Without an Origin header (older browsers, curl) the form token decides.
            None => true,
        };
        let expected = self.form_token();
        let matches = expected.len() == form_token.len() && expected.bytes().zip(form_token.bytes()).fold(0u8, |acc, (a, b)| acc | (a ^ b)) == 0;
        if same_origin && matches {
            Ok(())
        } else {
            Err(AdminMessage::page(
                StatusCode::FORBIDDEN,
                "Form refused",
                "This form did not come from this console's own page (or the page is from an earlier session). Reload the page and try again.",
            ))
        }
    }
}

/// The value of cookie `name` in the request.
fn cookie<'a>(headers: &'a HeaderMap, name: &str) -> Option<&'a str> {
    headers
        .get_all(header::COOKIE)
        .iter()
        .filter_map(|v| v.to_str().ok())
        .flat_map(|v| v.split(';'))
        .filter_map(|pair| pair.trim().split_once('='))
        .find(|(k, _)| *k == name)
        .map(|(_, v)| v.trim())
}

impl FromRequestParts<AppState> for AdminSession {
    type Rejection = Response;

    async fn from_request_parts(parts: &mut Parts, state: &AppState) -> Result<Self, Self::Rejection> {
        let to_login = || Redirect::to(LOGIN_PATH).into_response();
        let Some(token) = cookie(&parts.headers, COOKIE) else {
            return Err(to_login());
        };
        let peer = crate::http::peer_ip(&parts.extensions);
        match caller_with_token(state, token).await {
            Ok((Caller::Admin, record)) => {
                Ok(AdminSession { token: token.to_string(), token_id: record.id, origin: PageOrigin::of(&parts.headers, peer, &state.settings) })
            }
            // A cookie that is no session counts as a failed authentication, as a wrong
            // token does: guessing sessions is limited per client like guessing tokens.
            Ok(_) | Err(_) => match count_failure(state, &parts.headers, peer) {
                None => Err(to_login()),
                Some(too_many) => Err(too_many),
            },
        }
    }
}

/// Count a failed authentication against the client of a request; the "too many" page
/// once its budget is spent.
fn count_failure(state: &AppState, headers: &HeaderMap, peer: Option<std::net::IpAddr>) -> Option<Response> {
    let client = crate::rate_limit::client_of(headers, peer, &state.settings.trusted_proxies);
    let seconds = state.limiter.admit(crate::rate_limit::failed_authentication(&client), std::time::Instant::now()).err()?;
    let mut page =
        AdminMessage::page(StatusCode::TOO_MANY_REQUESTS, "Too many attempts", &format!("Too many failed sign-ins from this address: retry in {seconds} s."));
    page.headers_mut().insert(header::RETRY_AFTER, seconds.into());
    Some(page)
}

/// `GET /admin/login`.
pub async fn login_form() -> Response {
    LoginPage { error: None }.into_response()
}

#[derive(Deserialize)]
struct LoginForm {
    token: String,
}

/// The session cookie's header; `Secure` when the request came over HTTPS (a trusted TLS
/// proxy in front says so with `X-Forwarded-Proto`), so the browser never sends it in clear.
fn session_cookie(value: &str, max_age_secs: i64, origin: &PageOrigin) -> String {
    let https = origin.https;
    format!("{COOKIE}={value}; Path=/admin; HttpOnly; SameSite=Strict; Max-Age={max_age_secs}{}", if https { "; Secure" } else { "" })
}

/// `POST /admin/login` (`token`): start a session with an admin token. Failures are
/// limited per client (the request limiter leaves this form alone), so the admin token
/// signs in even while strangers at the same address are refused: tokens are too long to
/// guess, and a budget shared with strangers would let them lock the operator out.
pub async fn login(State(state): State<AppState>, origin: PageOrigin, parts: Parts, body: axum::body::Bytes) -> Response {
    let form: LoginForm = match parse_form(&body) {
        Ok(form) => form,
        Err(response) => return response,
    };
    let peer = crate::http::peer_ip(&parts.extensions);
    let refused = |message: String| {
        count_failure(&state, &parts.headers, peer).unwrap_or_else(|| (StatusCode::UNAUTHORIZED, LoginPage { error: Some(message) }).into_response())
    };
    match caller_with_token(&state, form.token.trim()).await {
        Ok((Caller::Admin, record)) if crate::auth::is_session(&record) => {
            return refused("That is a console session, not the admin token: sign in with the admin token.".into());
        }
        Ok((Caller::Admin, _)) => {}
        Ok(_) => return refused("That is a team token; the console needs the admin token.".into()),
        Err(problem) => return refused(problem.detail),
    }
    let expires = now_ms() + SESSION_HOURS * 3_600_000;
    let (session, record) = crate::auth::issue_session(expires);
    if let Err(e) = state.store.insert_token(&record).await {
        return crate::problem::Problem::from(e).into_response();
    }
    tracing::info!(session = %record.id, "operator signed in to the console");
    ([(header::SET_COOKIE, session_cookie(&session, SESSION_HOURS * 3600, &origin))], Redirect::to("/admin")).into_response()
}

#[derive(Deserialize)]
struct FormToken {
    form_token: String,
}

/// `POST /admin/logout`: end the session (its token is revoked).
pub async fn logout(State(state): State<AppState>, session: AdminSession, headers: HeaderMap, body: axum::body::Bytes) -> Response {
    let form: FormToken = match parse_form(&body) {
        Ok(form) => form,
        Err(response) => return response,
    };
    if let Err(refused) = session.check_form(&headers, &form.form_token) {
        return refused;
    }
    if let Err(e) = state.store.revoke_token(&session.token_id, now_ms()).await {
        return crate::problem::Problem::from(e).into_response();
    }
    ([(header::SET_COOKIE, session_cookie("", 0, &session.origin))], Redirect::to(LOGIN_PATH)).into_response()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_cookie_is_found_among_others_and_forms_need_the_session_token_from_this_origin() {
        let mut headers = HeaderMap::new();
        headers.insert(header::COOKIE, "a=1; osmab_admin_session=osmab_abc ; b=2".parse().unwrap());
        assert_eq!(cookie(&headers, COOKIE), Some("osmab_abc"));
        assert_eq!(cookie(&headers, "missing"), None);

        let origin = |hosts: &[&str]| PageOrigin { hosts: hosts.iter().map(|h| h.to_string()).collect(), https: false };
        let session = AdminSession { token: "osmab_abc".into(), token_id: "tok_1".into(), origin: origin(&["bench.example:8080"]) };
        let other = AdminSession { token: "osmab_xyz".into(), token_id: "tok_2".into(), origin: origin(&["bench.example:8080"]) };
        assert_ne!(session.form_token(), other.form_token());
        let mut same = HeaderMap::new();
        same.insert(header::HOST, "bench.example:8080".parse().unwrap());
        same.insert(header::ORIGIN, "https://bench.example:8080".parse().unwrap());
        assert!(session.check_form(&same, &session.form_token()).is_ok());
        assert!(session.check_form(&same, &other.form_token()).is_err(), "another session's form");
        assert!(session.check_form(&same, "").is_err());
        let mut cross = same.clone();
        cross.insert(header::ORIGIN, "https://evil.example".parse().unwrap());
        assert!(session.check_form(&cross, &session.form_token()).is_err(), "another origin");
        let behind_proxy = AdminSession { origin: origin(&["10.0.0.5:8080", "bench.example"]), ..session.clone() };
        let mut proxied = cross.clone();
        proxied.insert(header::ORIGIN, "https://bench.example".parse().unwrap());
        assert!(behind_proxy.check_form(&proxied, &session.form_token()).is_ok(), "a trusted proxy that rewrites Host forwards the public one");
    }

    #[test]
    fn the_cookie_is_secure_behind_a_tls_proxy() {
        let plain = session_cookie("v", 60, &PageOrigin::default());
        assert_eq!(plain, "osmab_admin_session=v; Path=/admin; HttpOnly; SameSite=Strict; Max-Age=60");
        assert!(session_cookie("v", 60, &PageOrigin { hosts: vec![], https: true }).ends_with("; Secure"));
    }
}
