//! JSON Web Signatures (RFC 7515) in compact serialisation with `alg` EdDSA over Ed25519
//! (RFC 8037), and the JSON Web Key Set (RFC 7517) that publishes the public keys. Only
//! what receipts need: sign a JSON payload under a `kid`, verify against a key set.

use base64::Engine;
use base64::engine::general_purpose::URL_SAFE_NO_PAD as B64;
use ed25519_dalek::{Signature, Signer, SigningKey, Verifier, VerifyingKey};
use schemars::JsonSchema;
use serde::{Deserialize, Serialize};
use sha2::Digest;

/// A public key as a JWK (`kty` OKP, `crv` Ed25519).
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize, JsonSchema)]
pub struct Jwk {
    /// `EdDSA`.
    pub alg: String,
    /// `Ed25519`.
    pub crv: String,
    /// The key id: its RFC 7638 thumbprint.
    pub kid: String,
    /// `OKP`.
    pub kty: String,
    /// `sig`.
    #[serde(rename = "use")]
    pub use_: String,
    /// The public key, base64url.
    pub x: String,
}

/// A JSON Web Key Set.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize, JsonSchema)]
pub struct Jwks {
    pub keys: Vec<Jwk>,
}

/// The RFC 7638 thumbprint of an Ed25519 public key: base64url SHA-256 of its required
/// members in lexicographic order.
pub fn thumbprint(key: &VerifyingKey) -> String {
    let canonical = format!(r#"{{"crv":"Ed25519","kty":"OKP","x":"{}"}}"#, B64.encode(key.as_bytes()));
    B64.encode(sha2::Sha256::digest(canonical.as_bytes()))
}

impl Jwk {
    /// The JWK of `key`.
    pub fn of(key: &VerifyingKey) -> Self {
        Jwk { alg: "EdDSA".into(), crv: "Ed25519".into(), kid: thumbprint(key), kty: "OKP".into(), use_: "sig".into(), x: B64.encode(key.as_bytes()) }
    }

    /// The verifying key it holds, if it is an Ed25519 key.
    pub fn key(&self) -> Result<VerifyingKey, String> {
        if self.kty != "OKP" || self.crv != "Ed25519" {
            return Err(format!("key {}: expected kty OKP and crv Ed25519, found {} {}", self.kid, self.kty, self.crv));
        }
        let bytes: [u8; 32] =
            B64.decode(&self.x).ok().and_then(|b| b.try_into().ok()).ok_or_else(|| format!("key {}: x is not 32 bytes of base64url", self.kid))?;
        VerifyingKey::from_bytes(&bytes).map_err(|e| format!("key {}: {e}", self.kid))
    }
}

#[derive(Debug, Serialize, Deserialize)]
struct Header {
    alg: String,
    kid: String,
    typ: String,
}

/// `payload` signed with `key` under `kid`, as a compact JWS.
pub fn sign(payload: &[u8], key: &SigningKey, kid: &str) -> String {
    let header = serde_json::to_vec(&Header { alg: "EdDSA".into(), kid: kid.into(), typ: "JWT".into() }).expect("a header serialises");
    let signing_input = format!("{}.{}", B64.encode(header), B64.encode(payload));
    let signature = key.sign(signing_input.as_bytes());
    format!("{signing_input}.{}", B64.encode(signature.to_bytes()))
}

impl Jwks {
    /// Whether every key is an Ed25519 key whose `kid` is its RFC 7638 thumbprint, each
    /// `kid` once: a set that lists an attacker's key under the service's genuine `kid`, or
    /// two keys under one, is refused whole rather than searched.
    pub fn check(&self) -> Result<(), String> {
        let mut seen = std::collections::HashSet::new();
        for jwk in &self.keys {
            let key = jwk.key()?;
            let computed = thumbprint(&key);
            if computed != jwk.kid {
                return Err(format!(
                    "key {}: its kid is not the RFC 7638 thumbprint of its public key ({computed}); the key set is forged or damaged",
                    jwk.kid
                ));
            }
            if !seen.insert(jwk.kid.as_str()) {
                return Err(format!("kid {} appears twice in the key set", jwk.kid));
            }
        }
        Ok(())
    }
}

/// The payload of compact JWS `token` once its signature verifies under the key of its
/// `kid` in `keys` (a key set that passes [`Jwks::check`]); otherwise what is wrong, in
/// words.
pub fn verify(token: &str, keys: &Jwks) -> Result<Vec<u8>, String> {
    keys.check()?;
    let parts: Vec<&str> = token.trim().split('.').collect();
    let [header, payload, signature] = parts[..] else {
        return Err(format!("a compact JWS has three parts separated by dots; this has {}", parts.len()));
    };
    let header: Header =
        B64.decode(header).ok().and_then(|h| serde_json::from_slice(&h).ok()).ok_or("the header is not base64url JSON with alg, kid and typ")?;
    if header.alg != "EdDSA" {
        return Err(format!("alg {} is not EdDSA", header.alg));
    }
    let jwk = keys.keys.iter().find(|k| k.kid == header.kid).ok_or_else(|| format!("no key with kid {} in the key set", header.kid))?;
    let key = jwk.key()?;
    let signature: [u8; 64] = B64.decode(signature).ok().and_then(|s| s.try_into().ok()).ok_or("the signature is not 64 bytes of base64url")?;
    let signing_input = &token.trim()[..token.trim().rfind('.').expect("three parts")];
    key.verify(signing_input.as_bytes(), &Signature::from_bytes(&signature))
        .map_err(|_| "the signature does not match: the receipt was changed or signed with another key".to_string())?;
    B64.decode(payload).map_err(|_| "the payload is not base64url".to_string())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// RFC 8037, appendix A.1–A.4: the Ed25519 key, its thumbprint and a JWS of
    /// "Example of Ed25519 signing".
    const D: &str = "nWGxne_9WmC6hEr0kuwsxERJxWl7MmkZcDusAxyuf2A";
    const X: &str = "11qYAYKxCrfVS_7TyWQHOg7hcvPapiMlrwIaaPcHURo";
    const THUMBPRINT: &str = "kPrK_qmxVWaYVA9wwBF6Iuo3vVzz7TxHCTwXBygrS4k";
    const SIGNATURE: &str = "hgyY0il_MGCjP0JzlnLWG1PPOt7-09PGcvMg3AIbQR6dWbhijcNR4ki4iylGjg5BhVsPt9g7sVvpAr_MuM0KAg";

    fn rfc_key() -> SigningKey {
        SigningKey::from_bytes(&B64.decode(D).unwrap().try_into().unwrap())
    }

    #[test]
    fn the_rfc_8037_key_has_its_public_key_thumbprint_and_signature() {
        let key = rfc_key();
        assert_eq!(B64.encode(key.verifying_key().as_bytes()), X);
        assert_eq!(thumbprint(&key.verifying_key()), THUMBPRINT);
        // The RFC's JWS has the header {"alg":"EdDSA"}; the signature over it is deterministic.
        let input = format!("{}.{}", B64.encode(br#"{"alg":"EdDSA"}"#), B64.encode(b"Example of Ed25519 signing"));
        assert_eq!(B64.encode(key.sign(input.as_bytes()).to_bytes()), SIGNATURE);
    }

    #[test]
    fn a_signed_payload_verifies_and_any_change_is_refused() {
        let key = rfc_key();
        let keys = Jwks { keys: vec![Jwk::of(&key.verifying_key())] };
        let token = sign(br#"{"score":0.5}"#, &key, &keys.keys[0].kid);
        assert_eq!(verify(&token, &keys).unwrap(), br#"{"score":0.5}"#);
        let parts: Vec<&str> = token.split('.').collect();
        let forged = format!("{}.{}.{}", parts[0], B64.encode(br#"{"score":0.9}"#), parts[2]);
        assert!(verify(&forged, &keys).unwrap_err().contains("does not match"));
        let other = SigningKey::from_bytes(&[7; 32]);
        let stranger = sign(br#"{"score":0.5}"#, &other, &keys.keys[0].kid);
        assert!(verify(&stranger, &keys).unwrap_err().contains("does not match"), "the kid of a key set does not make another key's signature valid");
        assert!(verify("a.b", &keys).unwrap_err().contains("three parts"));
        let unknown = sign(b"{}", &key, "nobody");
        assert!(verify(&unknown, &keys).unwrap_err().contains("no key with kid nobody"));
    }

    #[test]
    fn a_key_set_listing_another_key_under_a_genuine_kid_or_one_kid_twice_is_refused() {
        let genuine = rfc_key();
        let attacker = SigningKey::from_bytes(&[9; 32]);
        let kid = thumbprint(&genuine.verifying_key());
        let token = sign(br#"{"score":0.99}"#, &attacker, &kid);
        // The attacker's public key published under the genuine kid.
        let forged = Jwks { keys: vec![Jwk { kid: kid.clone(), ..Jwk::of(&attacker.verifying_key()) }] };
        assert!(verify(&token, &forged).unwrap_err().contains("not the RFC 7638 thumbprint"), "a mislabelled key is refused");
        // Two keys under one kid, the attacker's first.
        let both = Jwks { keys: vec![Jwk { kid: kid.clone(), ..Jwk::of(&attacker.verifying_key()) }, Jwk::of(&genuine.verifying_key())] };
        assert!(verify(&token, &both).is_err());
        let twice = Jwks { keys: vec![Jwk::of(&genuine.verifying_key()), Jwk::of(&genuine.verifying_key())] };
        let honest = sign(b"{}", &genuine, &kid);
        assert!(verify(&honest, &twice).unwrap_err().contains("appears twice"));
        assert!(verify(&honest, &Jwks { keys: vec![Jwk::of(&genuine.verifying_key())] }).is_ok());
    }
}
