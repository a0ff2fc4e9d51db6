//! Score receipts: a scored public submission's receipt verifies offline with
//! `osmab client verify` against the published keys, names its results document by
//! SHA-256, and a changed receipt or results file is refused.

use base64::Engine;
use base64::engine::general_purpose::URL_SAFE_NO_PAD as B64;
use serde_json::Value;

use super::Server;

/// Check the receipt of scored submission `id` as a third party would.
pub fn a_receipt_verifies_offline_and_tampering_is_caught(server: &Server<'_>, id: &str) {
    let dir = tempfile::tempdir().unwrap();
    let keys = server.get("/api/v1/keys").send().unwrap().text().unwrap();
    let jwks: Value = serde_json::from_str(&keys).unwrap();
    assert_eq!(
        (jwks["keys"][0]["kty"].as_str(), jwks["keys"][0]["crv"].as_str(), jwks["keys"][0]["alg"].as_str()),
        (Some("OKP"), Some("Ed25519"), Some("EdDSA"))
    );
    let signed: Value = server.get(&format!("/api/v1/submissions/{id}/receipt")).send().unwrap().json().unwrap();
    let jws = signed["jws"].as_str().unwrap().to_string();
    let header: Value = serde_json::from_slice(&B64.decode(jws.split('.').next().unwrap()).unwrap()).unwrap();
    assert_eq!((header["alg"].as_str(), header["kid"].as_str()), (Some("EdDSA"), jwks["keys"][0]["kid"].as_str()), "{header}");
    let raw = server.get(&format!("/api/v1/submissions/{id}/receipt")).header("accept", "application/jose").send().unwrap().text().unwrap();
    assert_eq!(raw, jws, "the same receipt every time, and as application/jose");
    let results = server.get(&format!("/api/v1/submissions/{id}/results.json")).send().unwrap().bytes().unwrap();
    let receipt = &signed["receipt"];
    assert_eq!(receipt["submission_id"], id);
    assert_eq!(receipt["summary"]["semseg"]["baseline"]["miou"], 1.0, "the oracle's headline number");

    let write = |name: &str, bytes: &[u8]| {
        let path = dir.path().join(name);
        std::fs::write(&path, bytes).unwrap();
        path
    };
    let keys_file = write("keys.json", keys.as_bytes());
    let receipt_file = write("receipt.json", serde_json::to_string(&signed).unwrap().as_bytes());
    let results_file = write("results.json", &results);
    let verify = |receipt: &std::path::Path, results: &std::path::Path| {
        crate::osmab(&["client", "verify", crate::path(receipt), "--keys", crate::path(&keys_file), "--results", crate::path(results)])
    };
    let out = verify(&receipt_file, &results_file);
    let said = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success() && said.contains("Valid receipt") && said.contains(id) && said.contains("matches the results file"),
        "{said}{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(said.contains("issuer was not checked"), "keys from a file check no issuer unless told: {said}");
    assert_eq!(receipt["iss"].as_str(), Some(server.url.as_str()), "the receipt names the service's origin");

    // Keys fetched from the service: the receipt must name that service as its issuer.
    let keys_url = format!("{}/api/v1/keys", server.url);
    let out = crate::osmab(&["client", "verify", crate::path(&receipt_file), "--keys", &keys_url]);
    let said = String::from_utf8_lossy(&out.stdout);
    assert!(out.status.success() && said.contains("Valid receipt") && !said.contains("not checked"), "{said}{}", String::from_utf8_lossy(&out.stderr));
    let out = crate::osmab(&["client", "verify", crate::path(&receipt_file), "--keys", crate::path(&keys_file), "--issuer", "https://another.example.org"]);
    let told = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success() && told.contains("as its issuer, but the keys are https://another.example.org's"), "{told}");

    // A key set listing an attacker's key under the genuine kid is refused whole.
    let attacker = ed25519_dalek::SigningKey::from_bytes(&[9; 32]);
    let mut forged_keys = jwks.clone();
    forged_keys["keys"][0]["x"] = serde_json::json!(B64.encode(attacker.verifying_key().as_bytes()));
    let out =
        crate::osmab(&["client", "verify", crate::path(&receipt_file), "--keys", crate::path(&write("forged-keys.json", forged_keys.to_string().as_bytes()))]);
    let told = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success() && told.contains("not the RFC 7638 thumbprint"), "{told}");

    // A receipt file whose readable copy was edited (a better mIoU) is refused, naming the field.
    let mut edited = signed.clone();
    edited["receipt"]["summary"]["semseg"]["baseline"]["miou"] = serde_json::json!(0.5);
    let out = verify(&write("edited.json", edited.to_string().as_bytes()), &results_file);
    let told = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success() && told.contains("readable copy") && told.contains("\"summary\""), "{told}");

    // A receipt whose payload was changed (a better mIoU) no longer verifies.
    let parts: Vec<&str> = jws.split('.').collect();
    let mut payload: Value = serde_json::from_slice(&B64.decode(parts[1]).unwrap()).unwrap();
    payload["summary"]["semseg"]["camera"]["miou"] = serde_json::json!(0.999);
    let forged = format!("{}.{}.{}", parts[0], B64.encode(serde_json::to_vec(&payload).unwrap()), parts[2]);
    let out = verify(&write("forged.jws", forged.as_bytes()), &results_file);
    assert!(!out.status.success() && String::from_utf8_lossy(&out.stderr).contains("does not verify"), "{}", String::from_utf8_lossy(&out.stderr));

    // Results that are not the certified ones are refused by their SHA-256.
    let mut other = results.to_vec();
    other.push(b' ');
    let out = verify(&write("raw.jws", jws.as_bytes()), &write("other.json", &other));
    assert!(!out.status.success() && String::from_utf8_lossy(&out.stderr).contains("not the results document"), "{}", String::from_utf8_lossy(&out.stderr));

    // One command does the three downloads and every check, the issuer being the server asked.
    let fetched = dir.path().join("fetched");
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_osmab"))
        .args(["client", "receipt", id, "--verify", "--out", crate::path(&fetched), "--url", &server.url])
        .env("OSMAB_CLIENT_CONFIG", dir.path().join("no-login.toml"))
        .output()
        .unwrap();
    let said = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success() && said.contains("Valid receipt") && said.contains("matches the results file") && !said.contains("not checked"),
        "{said}{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert_eq!(std::fs::read(fetched.join(format!("results-{id}.json"))).unwrap(), results.to_vec(), "the results as served");
    assert_eq!(std::fs::read_to_string(fetched.join("keys.json")).unwrap(), keys);
    // What was saved is what a later offline check reads.
    std::fs::write(fetched.join(format!("results-{id}.json")), &other).unwrap();
    let out = crate::osmab(&[
        "client",
        "verify",
        crate::path(&fetched.join(format!("receipt-{id}.json"))),
        "--keys",
        crate::path(&fetched.join("keys.json")),
        "--results",
        crate::path(&fetched.join(format!("results-{id}.json"))),
    ]);
    assert!(!out.status.success() && String::from_utf8_lossy(&out.stderr).contains("not the results document"), "{}", String::from_utf8_lossy(&out.stderr));
    let out = crate::osmab(&["client", "receipt", "../etc", "--url", &server.url]);
    assert!(!out.status.success() && String::from_utf8_lossy(&out.stderr).contains("is not a submission id"), "{}", String::from_utf8_lossy(&out.stderr));

    // A key file holding the service's key and an attacker's: with --issuer, the key that
    // signed must be one the issuer publishes, so a receipt the attacker signed is refused.
    let thumbprint = |key: &ed25519_dalek::VerifyingKey| {
        use sha2::Digest;
        B64.encode(sha2::Sha256::digest(format!(r#"{{"crv":"Ed25519","kty":"OKP","x":"{}"}}"#, B64.encode(key.as_bytes())).as_bytes()))
    };
    let attacker_kid = thumbprint(&attacker.verifying_key());
    let mut both = jwks.clone();
    both["keys"].as_array_mut().unwrap().push(serde_json::json!({"alg": "EdDSA", "crv": "Ed25519", "kid": attacker_kid, "kty": "OKP", "use": "sig", "x": B64.encode(attacker.verifying_key().as_bytes())}));
    let both_file = write("both-keys.json", both.to_string().as_bytes());
    let mut better = payload.clone();
    better["summary"]["semseg"]["baseline"]["miou"] = serde_json::json!(1.0);
    let header = B64.encode(serde_json::to_vec(&serde_json::json!({"alg": "EdDSA", "kid": attacker_kid, "typ": "JWT"})).unwrap());
    let signing_input = format!("{header}.{}", B64.encode(serde_json::to_vec(&better).unwrap()));
    let signature = ed25519_dalek::Signer::sign(&attacker, signing_input.as_bytes());
    let forged_by_attacker = write("attacker.jws", format!("{signing_input}.{}", B64.encode(signature.to_bytes())).as_bytes());
    let out = crate::osmab(&["client", "verify", crate::path(&forged_by_attacker), "--keys", crate::path(&both_file)]);
    let said = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success() && said.contains("issuer was not checked") && said.contains("binds the receipt to no service"),
        "a file alone binds nothing, and says so: {said}"
    );
    let out = crate::osmab(&["client", "verify", crate::path(&forged_by_attacker), "--keys", crate::path(&both_file), "--issuer", &server.url]);
    let told = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success() && told.contains("does not publish that key") && told.contains(&attacker_kid), "{told}");
    let out = crate::osmab(&["client", "verify", crate::path(&receipt_file), "--keys", crate::path(&both_file), "--issuer", &server.url]);
    assert!(out.status.success(), "the genuine receipt is the issuer's: {}", String::from_utf8_lossy(&out.stderr));

    // Flagged: the receipt issued now says so, signed; one issued before says it is flagged now.
    let flag =
        server.admin(server.client.put(format!("{}/api/v1/admin/submissions/{id}/flag", server.url)).json(&serde_json::json!({"reason": "maps copied"})));
    assert!(flag.status().is_success(), "{}", flag.text().unwrap());
    let flagged: Value = server.get(&format!("/api/v1/submissions/{id}/receipt")).send().unwrap().json().unwrap();
    assert_eq!(flagged["receipt"]["flagged"], "maps copied");
    let flagged_file = write("flagged.json", flagged.to_string().as_bytes());
    let out = crate::osmab(&["client", "verify", crate::path(&flagged_file), "--keys", crate::path(&keys_file)]);
    assert!(
        String::from_utf8_lossy(&out.stdout).contains("FLAGGED by the organisers when this receipt was issued: maps copied"),
        "{}",
        String::from_utf8_lossy(&out.stdout)
    );
    let out = crate::osmab(&["client", "verify", crate::path(&receipt_file), "--keys", &keys_url]);
    let said = String::from_utf8_lossy(&out.stdout);
    assert!(out.status.success() && said.contains("FLAGGED now by the organisers: maps copied") && said.contains("Current:"), "{said}");
    let cleared = server.admin(server.client.delete(format!("{}/api/v1/admin/submissions/{id}/flag", server.url)));
    assert!(cleared.status().is_success());

    // Unflagged again, the receipt is the entry's current one.
    let out = crate::osmab(&["client", "verify", crate::path(&receipt_file), "--keys", &keys_url]);
    assert!(String::from_utf8_lossy(&out.stdout).contains("Current: the issuer's receipt of this entry certifies the same results today"));
}
