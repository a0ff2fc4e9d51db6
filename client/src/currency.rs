//! Whether what a command works on is the service's current release: a team that submits to,
//! validates against or reads the board of an earlier release is told which one is current
//! (the earlier board stays at `/?release=V`).

use std::path::Path;

use super::api::Api;

/// The release a submission folder's `submission.json` names (none for an archive, or a card
/// that does not read: validation says why).
pub fn card_release(submission: &Path) -> Option<String> {
    let text = std::fs::read_to_string(submission.join("submission.json")).ok()?;
    let card: serde_json::Value = serde_json::from_str(&text).ok()?;
    card["release"].as_str().map(str::to_string)
}

/// A note when `release` is not the service's current release (nothing when it is, or when
/// the service cannot be asked).
pub fn newer_release_note(api: &Api, release: &str, what: &str) -> Option<String> {
    let releases = api.get_json("/api/v1/releases").ok()?;
    let current = releases["releases"].as_array()?.iter().find(|r| r["current"] == true)?["version"].as_str()?.to_string();
    (current != release).then(|| {
        format!(
            "Note: {what} release {release}, but {current} is the current release (its board is the main one; {release}'s stays at {}). \
             `{} download --out DIR` fetches {current}.",
            api.url(&format!("/?release={release}")),
            crate::command()
        )
    })
}
