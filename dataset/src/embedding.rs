//! Text embeddings for near-duplicate removal and diverse selection: a built-in
//! deterministic embedding (hashed word unigrams and bigrams, signed, L2-normalised;
//! offline and identical on every machine) or an OpenAI-compatible `/embeddings`
//! endpoint.

use crate::openai::{ServiceClient, ServiceError};

/// Something that turns texts into unit vectors of one dimension.
pub trait Embedder {
    /// A name for reports (`builtin-hash-512`, `openai:<model>`).
    fn name(&self) -> String;
    /// One unit vector per text.
    fn embed(&self, texts: &[String]) -> Result<Vec<Vec<f32>>, ServiceError>;
}

/// The built-in embedding.
#[derive(Debug, Clone, Copy)]
pub struct HashingEmbedder {
    /// Output dimension.
    pub dim: usize,
}

impl Default for HashingEmbedder {
    fn default() -> Self {
        Self { dim: 512 }
    }
}

/// Words that carry no content for telling scenes apart.
const STOPWORDS: &[&str] = &[
    "a", "an", "the", "with", "and", "of", "in", "on", "to", "is", "are", "there", "it", "its", "this", "has", "have", "holds", "contains", "room", "one",
    "two", "each", "other", "at", "by", "for", "from",
];

/// FNV-1a, 64-bit: stable across platforms and releases (unlike `std`'s hasher).
pub(crate) fn fnv1a(text: &str) -> u64 {
    text.bytes().fold(0xcbf2_9ce4_8422_2325, |h, b| (h ^ b as u64).wrapping_mul(0x0100_0000_01b3))
}

impl Embedder for HashingEmbedder {
    fn name(&self) -> String {
        format!("builtin-hash-{}", self.dim)
    }

    fn embed(&self, texts: &[String]) -> Result<Vec<Vec<f32>>, ServiceError> {
        Ok(texts
            .iter()
            .map(|text| {
                // Content words only: articles, numerals and the like say nothing of the scene.
                let words: Vec<String> = text
                    .split(|c: char| !c.is_alphanumeric())
                    .map(str::to_lowercase)
                    .filter(|w| !w.is_empty() && !w.chars().all(|c| c.is_ascii_digit()) && !STOPWORDS.contains(&w.as_str()))
                    .collect();
                let mut v = vec![0f64; self.dim];
                let mut add = |feature: &str, weight: f64| {
                    let h = fnv1a(feature);
                    let sign = if h >> 63 == 0 { 1.0 } else { -1.0 };
                    v[(h % self.dim as u64) as usize] += sign * weight;
                };
                for w in &words {
                    add(w, 1.0);
                }
                for pair in words.windows(2) {
                    add(&format!("{} {}", pair[0], pair[1]), 0.7);
                }
                normalize(v)
            })
            .collect())
    }
}

fn normalize(v: Vec<f64>) -> Vec<f32> {
    let norm = v.iter().map(|x| x * x).sum::<f64>().sqrt();
    if norm == 0.0 { v.iter().map(|_| 0.0).collect() } else { v.iter().map(|x| (x / norm) as f32).collect() }
}

/// Embeddings from an OpenAI-compatible service, requested in batches.
pub struct ServiceEmbedder {
    pub client: ServiceClient,
    pub batch: usize,
}

impl Embedder for ServiceEmbedder {
    fn name(&self) -> String {
        format!("openai:{}", self.client.model())
    }

    fn embed(&self, texts: &[String]) -> Result<Vec<Vec<f32>>, ServiceError> {
        let mut out: Vec<Vec<f32>> = Vec::with_capacity(texts.len());
        for chunk in texts.chunks(self.batch.max(1)) {
            for v in self.client.embeddings(chunk)? {
                if out.first().is_some_and(|first| first.len() != v.len()) {
                    return Err(ServiceError::BadResponse {
                        url: "embeddings".into(),
                        what: format!("embeddings of {} and {} dimensions in one run", out[0].len(), v.len()),
                    });
                }
                out.push(normalize(v.iter().map(|&x| x as f64).collect()));
            }
        }
        Ok(out)
    }
}
