//! Publishing a release does not make the earlier one's board vanish: every board keeps a
//! release switcher, an earlier board says which release is current, the release page lists
//! every release with its board, and the client says when it works on an earlier release.

use std::path::PathBuf;
use std::process::{Command, Stdio};

use serde_json::{Value, json};

use super::client::client;
use super::{Backend, Deployment, TEST_RELEASE_CONFIG, baseline_dir, tar_of};

/// The test release's config under another version and seed, built once per test run.
fn second_release() -> PathBuf {
    let root = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("e2e-second-release");
    std::fs::create_dir_all(&root).unwrap();
    let config = root.join("config.toml");
    std::fs::write(&config, TEST_RELEASE_CONFIG.replace("version = \"e2e-1\"", "version = \"e2e-2\"").replace("seed = 7", "seed = 8")).unwrap();
    let out = root.join("release");
    let status = Command::new(env!("CARGO_BIN_EXE_osmab"))
        .args(["release", "build", "--config", crate::path(&config), "--out", crate::path(&out)])
        .stdout(Stdio::null())
        .status()
        .unwrap();
    assert!(status.success(), "the second release builds");
    out
}

#[test]
fn an_earlier_releases_board_stays_reachable_and_says_which_release_is_current() {
    let deployment = Deployment::new(Backend::Sqlite, &[]);
    let server = deployment.serve();
    let first = server.import_test_release();
    let token = server.team("Team Earlier");
    let oracle = baseline_dir("oracle");
    let id = server.upload(&token, &tar_of(oracle.path()), "").json::<Value>().unwrap()["id"].as_str().unwrap().to_string();
    assert_eq!(server.wait_done(&id, &token)["state"], "scored");
    let imported = server.admin(
        server.post("/api/v1/admin/releases/import").timeout(std::time::Duration::from_secs(600)).json(&json!({"path": second_release(), "publish": true})),
    );
    assert_eq!(imported.status(), 201, "{}", imported.text().unwrap());

    // The main board is the new release's; a switcher leads to the earlier one, which keeps its entry.
    let main = server.get("/").send().unwrap().text().unwrap();
    assert!(main.contains("release-choice") && main.contains(&format!("href=\"/?release={first}\"")), "{main}");
    assert!(!main.contains("id=\"older-release\""), "the current board needs no notice");
    let earlier = server.get(&format!("/?release={first}")).send().unwrap().text().unwrap();
    assert!(earlier.contains(&id) || earlier.contains("team-oracle"), "the earlier board keeps its entries");
    assert!(earlier.contains("id=\"older-release\"") && earlier.contains("the current release is") && earlier.contains("e2e-2"), "{earlier}");
    let release_page = server.get("/releases/e2e-2").send().unwrap().text().unwrap();
    assert!(release_page.contains("id=\"all-releases\"") && release_page.contains(&format!("href=\"/releases/{first}\"")), "{release_page}");

    // The client says so for a board, a validation and a submission of the earlier release.
    let home = tempfile::tempdir().unwrap();
    let config = home.path().join("client.toml");
    assert!(client(&config, &["login", "--url", &server.url, "--token", &token]).status.success());
    let board = client(&config, &["leaderboard", "--release", &first]);
    let note = "but e2e-2 is the current release";
    assert!(board.status.success() && String::from_utf8_lossy(&board.stderr).contains(&note), "{}", String::from_utf8_lossy(&board.stderr));
    let current = client(&config, &["leaderboard"]);
    assert!(!String::from_utf8_lossy(&current.stderr).contains("current release"), "no note on the current board");
    let dry = client(&config, &["submit", crate::path(oracle.path()), "--dry-run"]);
    assert!(
        String::from_utf8_lossy(&dry.stderr).contains(&format!("this submission is for release {first}, {note}")),
        "{}",
        String::from_utf8_lossy(&dry.stderr)
    );
}
