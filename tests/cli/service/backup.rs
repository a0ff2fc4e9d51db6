//! The restore drill: a backup taken while the service runs, restored into a fresh data
//! directory and database, serves the same leaderboard byte for byte, every submission with
//! its history, receipts that verify with the restored keys, and scores new submissions. A
//! damaged backup, one re-sealed without the operator's backup key, or a data directory in
//! use is refused.

use serde_json::Value;

use super::{Backend, Deployment, baseline_dir, on_both_backends, tar_of};

/// The operator's backup key: set for `osmab backup` and `osmab restore`, never in a backup.
const BACKUP_KEY: (&str, &str) = ("OSMAB_BACKUP_KEY", "e2e-backup-key-0123456789abcdef0123456789");

fn said(output: &std::process::Output) -> String {
    format!("{}{}", String::from_utf8_lossy(&output.stdout), String::from_utf8_lossy(&output.stderr))
}

/// The test release on `server`, a team `team` and its oracle submission scored: the team's
/// token, the submission's id and the val board showing it.
fn a_scored_entry(server: &super::Server<'_>, team: &str) -> (String, String, String) {
    server.import_test_release();
    let token = server.team(team);
    let accepted: Value = server.upload(&token, &tar_of(baseline_dir("oracle").path()), "").json().unwrap();
    let id = accepted["id"].as_str().unwrap().to_string();
    assert_eq!(server.wait_done(&id, &token)["state"], "scored");
    let board = server.get("/api/v1/leaderboard?split=val").send().unwrap().text().unwrap();
    assert!(board.contains(&id) && board.contains(team), "the entry is on the board: {board}");
    (token, id, board)
}

fn a_backup_restores_the_service_as_it_was(backend: Backend) {
    let original = Deployment::new(backend, &[BACKUP_KEY]);
    let server = original.serve();
    let (token, id, board) = a_scored_entry(&server, "Team Backup");
    let submission = server.get(&format!("/api/v1/submissions/{id}")).bearer_auth(&token).send().unwrap().text().unwrap();
    let receipt = server.get(&format!("/api/v1/submissions/{id}/receipt")).send().unwrap().text().unwrap();
    let results = server.get(&format!("/api/v1/submissions/{id}/results.json")).send().unwrap().bytes().unwrap();

    // Without the backup key: refused, naming it.
    let backups = tempfile::tempdir().unwrap();
    let keyless = Deployment { env: original.env.iter().filter(|(k, _)| k != BACKUP_KEY.0).cloned().collect(), ..original.another_node() };
    let refused = keyless.run(&["backup", "--out", backups.path().join("unsealed").to_str().unwrap()]);
    assert!(!refused.status.success() && said(&refused).contains("OSMAB_BACKUP_KEY is not set"), "{}", said(&refused));

    // Taken while the server runs.
    let backup = backups.path().join("b1");
    let taken = original.run(&["backup", "--out", backup.to_str().unwrap()]);
    assert!(taken.status.success(), "{}", said(&taken));
    let manifest: Value = serde_json::from_slice(&std::fs::read(backup.join("backup.json")).unwrap()).unwrap();
    let paths: Vec<&str> = manifest["files"].as_array().unwrap().iter().map(|f| f["path"].as_str().unwrap()).collect();
    assert!(paths.iter().any(|p| p.starts_with("receipt-keys/")) && paths.iter().any(|p| p.starts_with("split-secret/")), "{paths:?}");
    assert!(paths.iter().any(|p| p.starts_with("blobs/")) && paths.iter().any(|p| p.starts_with("database/")), "{paths:?}");
    let again = original.run(&["backup", "--out", backup.to_str().unwrap()]);
    assert!(!again.status.success() && said(&again).contains("is not empty"), "{}", said(&again));
    drop(server);

    // Into a data directory in use: refused, nothing changed.
    let refused = original.run(&["restore", backup.to_str().unwrap()]);
    assert!(!refused.status.success() && said(&refused).contains("is not empty"), "{}", said(&refused));

    // A damaged copy of the backup is refused naming the file, before anything is written.
    let fresh = Deployment::new(backend, &[BACKUP_KEY]);
    let damaged = backups.path().join("damaged");
    copy_dir(&backup, &damaged);
    let key = std::fs::read_dir(damaged.join("receipt-keys")).unwrap().next().unwrap().unwrap().path();
    let mut bytes = std::fs::read(&key).unwrap();
    bytes[0] ^= 1;
    std::fs::write(&key, bytes).unwrap();
    let refused = fresh.run(&["restore", damaged.to_str().unwrap()]);
    assert!(!refused.status.success() && said(&refused).contains("receipt-keys/") && said(&refused).contains("damaged"), "{}", said(&refused));
    assert_eq!(std::fs::read_dir(fresh.data.path()).unwrap().count(), 0, "nothing written");

    // Re-sealed: the receipt-signing key swapped for an attacker's and every sum recomputed,
    // as someone who can write the backup store (but has not the operator's key) would.
    // Refused, nothing written.
    let resealed = backups.path().join("resealed");
    copy_dir(&backup, &resealed);
    let signing_key = std::fs::read_dir(resealed.join("receipt-keys")).unwrap().next().unwrap().unwrap().path();
    std::fs::write(&signing_key, "09".repeat(32)).unwrap();
    let mut manifest: Value = serde_json::from_slice(&std::fs::read(resealed.join("backup.json")).unwrap()).unwrap();
    for file in manifest["files"].as_array_mut().unwrap() {
        let bytes = std::fs::read(resealed.join(file["path"].as_str().unwrap())).unwrap();
        file["size"] = bytes.len().into();
        file["sha256"] = super::sha256_hex(&bytes).into();
    }
    std::fs::write(resealed.join("backup.json"), serde_json::to_vec_pretty(&manifest).unwrap()).unwrap();
    let refused = fresh.run(&["restore", resealed.to_str().unwrap()]);
    assert!(!refused.status.success() && said(&refused).contains("the seal does not verify"), "{}", said(&refused));
    let keyless_restore = Deployment { env: fresh.env.iter().filter(|(k, _)| k != BACKUP_KEY.0).cloned().collect(), ..Deployment::new(backend, &[]) };
    let refused = keyless_restore.run(&["restore", backup.to_str().unwrap()]);
    assert!(!refused.status.success() && said(&refused).contains("set OSMAB_BACKUP_KEY"), "{}", said(&refused));
    assert_eq!(std::fs::read_dir(fresh.data.path()).unwrap().count(), 0, "nothing written");

    // The restore: the same board, submission and receipt; new submissions score.
    let restored = fresh.run(&["restore", backup.to_str().unwrap()]);
    assert!(restored.status.success(), "{}", said(&restored));
    let server = fresh.serve();
    assert_eq!(server.get("/api/v1/leaderboard?split=val").send().unwrap().text().unwrap(), board, "the board byte for byte");
    assert_eq!(server.get(&format!("/api/v1/submissions/{id}")).bearer_auth(&token).send().unwrap().text().unwrap(), submission, "the team's token works");
    assert_eq!(server.get(&format!("/api/v1/submissions/{id}/results.json")).send().unwrap().bytes().unwrap(), results);
    let restored_receipt: Value = server.get(&format!("/api/v1/submissions/{id}/receipt")).send().unwrap().json().unwrap();
    let old_receipt: Value = serde_json::from_str(&receipt).unwrap();
    let signed_by_same_key = |r: &Value| r["jws"].as_str().unwrap().split('.').next().unwrap().to_string();
    assert_eq!(signed_by_same_key(&restored_receipt), signed_by_same_key(&old_receipt), "the same signing key");
    // The old receipt verifies against the restored service's keys.
    let files = tempfile::tempdir().unwrap();
    let (receipt_file, keys_file) = (files.path().join("receipt.json"), files.path().join("keys.json"));
    std::fs::write(&receipt_file, &receipt).unwrap();
    std::fs::write(&keys_file, server.get("/api/v1/keys").send().unwrap().bytes().unwrap()).unwrap();
    let verified = fresh.run(&["client", "verify", receipt_file.to_str().unwrap(), "--keys", keys_file.to_str().unwrap()]);
    assert!(verified.status.success() && said(&verified).contains("Valid receipt"), "{}", said(&verified));
    let accepted: Value = server.upload(&token, &tar_of(baseline_dir("drop-small").path()), "").json().unwrap();
    let new_id = accepted["id"].as_str().unwrap();
    assert_eq!(server.wait_done(new_id, &token)["state"], "scored", "a new submission scores after the restore");
}

fn copy_dir(from: &std::path::Path, to: &std::path::Path) {
    for entry in std::fs::read_dir(from).unwrap() {
        let entry = entry.unwrap();
        let target = to.join(entry.file_name());
        if entry.file_type().unwrap().is_dir() {
            std::fs::create_dir_all(&target).unwrap();
            copy_dir(&entry.path(), &target);
        } else {
            std::fs::create_dir_all(to).unwrap();
            std::fs::copy(entry.path(), &target).unwrap();
        }
    }
}

on_both_backends!(a_backup_taken_while_serving_restores_the_same_service, super::a_backup_restores_the_service_as_it_was);

/// With PostgreSQL and a bucket: the backup lists the bucket's objects (the bytes stay in the
/// bucket, versioned) beside the database dump, the keys and the secret; a restore checks the
/// bucket first and refuses one that lacks them, then serves the same board.
#[test]
fn a_backup_of_a_bucket_deployment_lists_its_objects_and_restores_against_the_bucket() {
    use super::object_store::{Relay, bucket, storage_env};
    let relay = Relay::to_moto();
    let (kept, empty) = (bucket(), bucket());
    let in_bucket = |name: &str| storage_env(&relay, name);
    let kept_env = in_bucket(&kept);
    let env: Vec<(&str, &str)> = kept_env.iter().map(|(k, v)| (k.as_str(), v.as_str())).collect();
    let env: Vec<(&str, &str)> = env.into_iter().chain([BACKUP_KEY]).collect();
    let original = Deployment::new(Backend::Postgres, &env);
    let server = original.serve();
    let (token, id, board) = a_scored_entry(&server, "Team Bucket");

    let backups = tempfile::tempdir().unwrap();
    let backup = backups.path().join("b");
    let taken = original.run(&["backup", "--out", backup.to_str().unwrap()]);
    assert!(taken.status.success(), "{}", said(&taken));
    drop(server);
    let manifest: Value = serde_json::from_slice(&std::fs::read(backup.join("backup.json")).unwrap()).unwrap();
    let objects: Vec<&str> = manifest["objects"].as_array().unwrap().iter().map(|o| o["key"].as_str().unwrap()).collect();
    assert!(objects.contains(&format!("submissions/{id}/upload").as_str()), "{objects:?}");
    assert!(objects.iter().any(|k| k.starts_with("releases/")) && objects.iter().any(|k| k.starts_with("receipt-keys/")), "{objects:?}");
    let files: Vec<&str> = manifest["files"].as_array().unwrap().iter().map(|f| f["path"].as_str().unwrap()).collect();
    assert!(files.contains(&"database/osmab.pgdump") && files.iter().any(|f| f.starts_with("receipt-keys/")), "{files:?}");
    assert!(!files.iter().any(|f| f.starts_with("blobs/")), "the bucket's bytes are not copied: {files:?}");

    // A bucket without the objects: refused, naming one, nothing written.
    let empty_env = in_bucket(&empty);
    let env: Vec<(&str, &str)> = empty_env.iter().map(|(k, v)| (k.as_str(), v.as_str())).collect();
    let env: Vec<(&str, &str)> = env.into_iter().chain([BACKUP_KEY]).collect();
    let wrong = Deployment::new(Backend::Postgres, &env);
    let refused = wrong.run(&["restore", backup.to_str().unwrap()]);
    assert!(!refused.status.success() && said(&refused).contains("(missing)") && said(&refused).contains("nothing was written"), "{}", said(&refused));
    assert_eq!(std::fs::read_dir(wrong.data.path()).unwrap().count(), 0);

    // The bucket it was taken from: restored, the same board; new submissions score.
    let env: Vec<(&str, &str)> = kept_env.iter().map(|(k, v)| (k.as_str(), v.as_str())).collect();
    let env: Vec<(&str, &str)> = env.into_iter().chain([BACKUP_KEY]).collect();
    let fresh = Deployment::new(Backend::Postgres, &env);
    let restored = fresh.run(&["restore", backup.to_str().unwrap()]);
    assert!(restored.status.success(), "{}", said(&restored));
    let server = fresh.serve();
    assert_eq!(server.get("/api/v1/leaderboard?split=val").send().unwrap().text().unwrap(), board);
    let accepted: Value = server.upload(&token, &tar_of(baseline_dir("drop-small").path()), "").json().unwrap();
    assert_eq!(server.wait_done(accepted["id"].as_str().unwrap(), &token)["state"], "scored");
}
