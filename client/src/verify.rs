//! `osmab client verify RECEIPT --keys URL|JWKS [--issuer ORIGIN] [--results FILE]`: check a
//! score receipt — its signature against the service's published keys (refusing a key set
//! whose kids are not their keys' thumbprints), that it names as issuer the origin the keys
//! came from, that a receipt file's readable copy is what is signed, and optionally that a
//! results document is the one the receipt names — and print what it certifies.
//!
//! A key file binds nothing by itself: it may hold an attacker's key beside the service's.
//! With `--issuer`, the key that signed the receipt must also be one the issuer publishes
//! now (fetched from it); without, the output says that who issued it was not checked.
//! Where the issuer is reachable, the entry's current receipt is read too, so a receipt of
//! an entry rescored since (or flagged) says so.

use std::io::Read;
use std::path::{Path, PathBuf};

use anyhow::{Context, bail};

use osmab_api::jws::Jwks;
use osmab_api::receipts::{Receipt, sha256_hex};

/// Where the service's public keys come from, and which issuer a receipt must therefore name.
pub struct KeySource {
    place: KeyPlace,
    /// The origin the receipt must name (`https://host[:port]`); none when keys come from a
    /// file and no --issuer is given.
    issuer: Option<String>,
}

/// What verifying a receipt found besides its signature.
#[derive(Debug, Default)]
pub struct Currency {
    /// The issuer's current receipt of the entry certifies other results: it was rescored.
    pub superseded_by: Option<String>,
    /// The organisers' flag on the entry now, where it has one.
    pub flagged_now: Option<String>,
    /// Why the entry's current state could not be read, where it could not.
    pub unknown: Option<String>,
}

enum KeyPlace {
    Url(String),
    File(PathBuf),
}

/// The largest key set read from a URL.
const MAX_KEYS_BYTES: u64 = 1 << 20;

impl KeySource {
    /// `keys` as a URL (`http://` or `https://`: the issuer is its origin, and --issuer, if
    /// given, must agree) or a file path (the issuer is --issuer's, if given).
    pub fn parse(keys: &str, issuer: Option<&str>) -> anyhow::Result<Self> {
        let issuer = issuer.map(|i| osmab_api::receipts::origin(i).map_err(|why| anyhow::anyhow!("--issuer: {why}"))).transpose()?;
        if !(keys.starts_with("http://") || keys.starts_with("https://")) {
            return Ok(Self { place: KeyPlace::File(PathBuf::from(keys)), issuer });
        }
        let url = reqwest::Url::parse(keys).with_context(|| format!("--keys: cannot read '{keys}' as a URL"))?;
        let origin = url.origin().ascii_serialization();
        if let Some(given) = &issuer {
            anyhow::ensure!(*given == origin, "--issuer {given} and the keys' URL ({origin}) name different services");
        }
        Ok(Self { place: KeyPlace::Url(keys.to_string()), issuer: Some(origin) })
    }

    fn load(&self) -> anyhow::Result<Jwks> {
        let (bytes, from) = match &self.place {
            KeyPlace::File(path) => (std::fs::read(path).with_context(|| format!("{}: cannot read", path.display()))?, path.display().to_string()),
            KeyPlace::Url(url) => {
                let client = reqwest::blocking::Client::builder().timeout(std::time::Duration::from_secs(30)).build()?;
                let response = client.get(url).send().with_context(|| format!("{url}: cannot fetch the keys"))?;
                anyhow::ensure!(response.status().is_success(), "{url}: the keys answer {}", response.status());
                let mut bytes = Vec::new();
                response.take(MAX_KEYS_BYTES + 1).read_to_end(&mut bytes).with_context(|| format!("{url}: the keys could not be read"))?;
                anyhow::ensure!(bytes.len() as u64 <= MAX_KEYS_BYTES, "{url}: more than {MAX_KEYS_BYTES} bytes; not a key set");
                (bytes, url.clone())
            }
        };
        serde_json::from_slice(&bytes).with_context(|| format!("{from}: not a JWKS ({{\"keys\": [...]}})"))
    }
}

/// What a receipt file holds: the compact JWS itself, or the JSON of `GET …/receipt` (its
/// `jws` and, for reading, an unsigned copy of the payload under `receipt`).
struct ReceiptFile {
    token: String,
    readable_copy: Option<serde_json::Value>,
}

fn read_receipt_file(text: &str) -> anyhow::Result<ReceiptFile> {
    let text = text.trim();
    if text.starts_with('{') {
        let mut value: serde_json::Value = serde_json::from_str(text).context("the receipt file is JSON but does not parse")?;
        let token = value["jws"].as_str().map(str::to_string).context("the receipt JSON has no \"jws\"")?;
        return Ok(ReceiptFile { token, readable_copy: value.get_mut("receipt").map(serde_json::Value::take) });
    }
    Ok(ReceiptFile { token: text.to_string(), readable_copy: None })
}

/// Verify the receipt in `receipt` against the key set in `keys`; with `results`, check
/// that file's SHA-256 too. A receipt file whose unsigned, readable copy differs from what
/// is signed is refused, naming the fields (someone edited what people read). Returns the
/// receipt.
pub fn verify(receipt: &Path, keys: &KeySource, results: Option<&Path>) -> anyhow::Result<Receipt> {
    let text = std::fs::read_to_string(receipt).with_context(|| format!("{}: cannot read", receipt.display()))?;
    let file = read_receipt_file(&text)?;
    let signed = Receipt::verify(&file.token, &keys.load()?).map_err(|why| anyhow::anyhow!("the receipt does not verify: {why}"))?;
    if let Some(issuer) = &keys.issuer
        && signed.iss != *issuer
    {
        bail!("the receipt names {} as its issuer, but the keys are {issuer}'s: it was not issued by the service these keys belong to", signed.iss);
    }
    if let (KeyPlace::File(path), Some(issuer)) = (&keys.place, &keys.issuer) {
        // The file's word is not the issuer's: the signing key must be one the issuer publishes.
        let kid = signing_kid(&file.token)?;
        let published = KeySource { place: KeyPlace::Url(format!("{issuer}/api/v1/keys")), issuer: Some(issuer.clone()) }.load().with_context(|| {
            format!(
                "--issuer {issuer}: its keys could not be read to check that the receipt's key is its own (without --issuer, nothing binds {} to a service)",
                path.display()
            )
        })?;
        let in_file = keys.load()?.keys.into_iter().find(|k| k.kid == kid);
        if !published.keys.iter().any(|k| Some(k) == in_file.as_ref()) {
            bail!("the receipt is signed by key {kid} of {}, but {issuer} does not publish that key: it was not issued by {issuer}", path.display());
        }
    }
    if let Some(copy) = &file.readable_copy {
        let signed_value = serde_json::to_value(&signed).expect("a receipt serialises");
        let differing = differing_fields(&signed_value, copy);
        if !differing.is_empty() {
            bail!(
                "{}: the signature is good, but the readable copy under \"receipt\" differs from the signed payload in {}; the file was edited after it was issued (the signed values are the receipt)",
                receipt.display(),
                differing.join(", ")
            );
        }
    }
    if let Some(path) = results {
        let bytes = std::fs::read(path).with_context(|| format!("{}: cannot read", path.display()))?;
        let found = sha256_hex(&bytes);
        if found != signed.results_sha256 {
            bail!(
                "{}: its SHA-256 is {found}, the receipt names {}; it is not the results document this receipt certifies",
                path.display(),
                signed.results_sha256
            );
        }
    }
    Ok(signed)
}

/// `osmab client receipt ID [--verify]`: save the receipt of submission `id`, its results
/// document and the service's keys under `out` (a team's token is sent where there is one:
/// a dry run's receipt is its team's); with `verify`, check them against each other, the
/// issuer being the origin they came from. Returns what to print.
pub fn fetch_receipt(api: &super::api::Api, id: &str, out: &Path, verify_them: bool) -> anyhow::Result<String> {
    anyhow::ensure!(!id.is_empty() && id.chars().all(|c| c.is_ascii_alphanumeric() || c == '_' || c == '-'), "'{id}' is not a submission id (sub_…)");
    std::fs::create_dir_all(out).with_context(|| format!("{}: cannot create the folder", out.display()))?;
    let fetch = |path: &str| -> anyhow::Result<Vec<u8>> {
        let request = api.get_as_team(path).unwrap_or_else(|_| api.get(path));
        let response = api.send(request)?;
        Ok(response.bytes().with_context(|| format!("GET {}: the answer could not be read", api.url(path)))?.to_vec())
    };
    let receipt = out.join(format!("receipt-{id}.json"));
    let results = out.join(format!("results-{id}.json"));
    let keys = out.join("keys.json");
    for (path, file) in
        [(format!("/api/v1/submissions/{id}/receipt"), &receipt), (format!("/api/v1/submissions/{id}/results.json"), &results), ("/api/v1/keys".into(), &keys)]
    {
        let bytes = fetch(&path)?;
        std::fs::write(file, bytes).with_context(|| format!("{}: cannot write", file.display()))?;
    }
    let saved = format!("Saved {}, {} and {}.\n", receipt.display(), results.display(), keys.display());
    if !verify_them {
        let client = crate::command();
        return Ok(saved
            + &format!(
                "Check them with: {client} receipt {id} --verify (or {client} verify {} --keys {} --results {})\n",
                receipt.display(),
                api.url("/api/v1/keys"),
                results.display()
            ));
    }
    let origin = reqwest::Url::parse(&api.url("/")).context("the server's URL")?.origin().ascii_serialization();
    let source = KeySource { place: KeyPlace::File(keys), issuer: Some(origin) };
    let checked = verify(&receipt, &source, Some(&results))?;
    Ok(saved + &describe(&checked, &source, true))
}

/// The `kid` in the header of the compact JWS `token`.
fn signing_kid(token: &str) -> anyhow::Result<String> {
    use base64::Engine;
    let header = token.trim().split('.').next().unwrap_or_default();
    let bytes = base64::engine::general_purpose::URL_SAFE_NO_PAD.decode(header).context("the receipt's header is not base64url")?;
    let value: serde_json::Value = serde_json::from_slice(&bytes).context("the receipt's header is not JSON")?;
    value["kid"].as_str().map(str::to_string).context("the receipt's header names no kid")
}

/// Whether `receipt` is still the entry's current one at its issuer (only where the keys
/// are the issuer's): the issuer's receipt now certifies the same results, or others (the
/// entry was rescored). `token` is sent where given (a private entry's team).
pub fn currency(receipt: &Receipt, keys: &KeySource, token: Option<&str>) -> Currency {
    let Some(issuer) = &keys.issuer else {
        return Currency { unknown: Some("the keys came from a file and no --issuer was given".into()), ..Currency::default() };
    };
    let url = format!("{issuer}/api/v1/submissions/{}/receipt", receipt.submission_id);
    let fetched = reqwest::blocking::Client::builder().timeout(std::time::Duration::from_secs(30)).build().and_then(|client| {
        let request = client.get(&url);
        let request = match token {
            Some(token) => request.bearer_auth(token),
            None => request,
        };
        request.send()
    });
    let current: Option<serde_json::Value> = match fetched {
        Ok(response) if response.status().is_success() => response.json().ok(),
        Ok(response) => return Currency { unknown: Some(format!("{url} answers {}", response.status())), ..Currency::default() },
        Err(e) => return Currency { unknown: Some(format!("{url}: {e}")), ..Currency::default() },
    };
    // The current receipt counts only as signed by the issuer's keys.
    let signed_now =
        current.as_ref().and_then(|c| c["jws"].as_str()).map(|jws| keys.load().and_then(|keys| Receipt::verify(jws, &keys).map_err(anyhow::Error::msg)));
    let now = match signed_now {
        Some(Ok(now)) => now,
        Some(Err(e)) => return Currency { unknown: Some(format!("{url}: the current receipt does not verify ({e})")), ..Currency::default() },
        None => return Currency { unknown: Some(format!("{url} did not answer a receipt")), ..Currency::default() },
    };
    // Scored again (another scoring time), or the same scoring shown otherwise (a rule of
    // what test scores show changed): either way this receipt's numbers are not today's.
    let rescored = now.iat != receipt.iat || now.results_sha256 != receipt.results_sha256;
    Currency { superseded_by: rescored.then(|| format!("{}, scored {}", now.results_sha256, now.scored_at)), flagged_now: now.flagged, unknown: None }
}

/// The top-level fields where `copy` differs from `signed` (missing, extra or changed).
fn differing_fields(signed: &serde_json::Value, copy: &serde_json::Value) -> Vec<String> {
    let (Some(signed), Some(copy)) = (signed.as_object(), copy.as_object()) else {
        return vec!["the whole copy (not a JSON object)".into()];
    };
    let names: std::collections::BTreeSet<&String> = signed.keys().chain(copy.keys()).collect();
    names.into_iter().filter(|name| signed.get(*name) != copy.get(*name)).map(|name| format!("\"{name}\"")).collect()
}

/// The receipt in words.
pub fn describe(receipt: &Receipt, keys: &KeySource, results_checked: bool) -> String {
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
    if keys.issuer.is_none() {
        out.push_str("The issuer was not checked: the keys came from a file, which binds the receipt to no service (give --issuer ORIGIN, or --keys as the service's URL).\n");
    }
    if receipt.team_commitment.is_some() {
        out.push_str("The entry is anonymous: its team can prove it theirs with the claim code it is shown (--team NAME --claim-code CODE).\n");
    }
    if let Some(reason) = &receipt.flagged {
        out.push_str(&format!("FLAGGED by the organisers when this receipt was issued: {reason}\n"));
    }
    for (lighting, t) in &receipt.summary.semseg {
        out.push_str(&format!("  {lighting}: {}\n", super::view::pooled_line(t)));
    }
    out
}

/// Whether `receipt` is team `team`'s entry, as its claim `code` proves against the
/// receipt's team commitment (an anonymous entry) or as the receipt names it.
pub fn claim(receipt: &Receipt, team: &str, code: Option<&str>) -> anyhow::Result<String> {
    match &receipt.team_commitment {
        Some(_) if code.is_none() => bail!("the receipt is of an anonymous entry: give --claim-code, the code its team is shown"),
        Some(commitment) if *commitment == osmab_api::receipts::team_commitment(team, code.unwrap_or_default().trim()) => {
            Ok(format!("Claimed: this anonymous entry is team {team}'s (the claim code matches the receipt's signed team commitment)."))
        }
        Some(_) => bail!("the team name and claim code do not match this receipt's team commitment: it is not shown to be {team}'s"),
        None if receipt.team == team => Ok(format!("The receipt names team {team} (no claim code is needed).")),
        None => bail!("the receipt names team {}, not {team}, and carries no team commitment", receipt.team),
    }
}

/// Whether the receipt is still current, in words.
pub fn describe_currency(currency: &Currency) -> String {
    let flag = currency.flagged_now.as_ref().map(|reason| format!("FLAGGED now by the organisers: {reason}\n")).unwrap_or_default();
    flag + &match (&currency.superseded_by, &currency.unknown) {
        (Some(now), _) => format!(
            "SUPERSEDED: the issuer's current receipt of this entry certifies other results (SHA-256 {now}): it was rescored, or is shown otherwise, since; this receipt's numbers are not its current ones.\n"
        ),
        (None, Some(why)) => format!("Whether the entry was rescored or flagged since was not checked ({why}).\n"),
        (None, None) => "Current: the issuer's receipt of this entry certifies the same results today.\n".into(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_receipt_of_other_results_than_the_current_ones_reads_as_superseded() {
        let superseded = Currency { superseded_by: Some("ab12".into()), flagged_now: None, unknown: None };
        assert!(describe_currency(&superseded).starts_with("SUPERSEDED") && describe_currency(&superseded).contains("ab12"));
        let flagged = Currency { flagged_now: Some("copied".into()), ..Currency::default() };
        assert_eq!(
            describe_currency(&flagged),
            "FLAGGED now by the organisers: copied\nCurrent: the issuer's receipt of this entry certifies the same results today.\n"
        );
        let unknown = Currency { unknown: Some("offline".into()), ..Currency::default() };
        assert!(describe_currency(&unknown).contains("was not checked (offline)"));
    }
}
