//! A small client for OpenAI-compatible HTTP services (`/chat/completions`,
//! `/embeddings`): vLLM, Ollama, llama.cpp's server, or the hosted APIs. Timeouts,
//! retries with exponential backoff on rate limits, server errors and dropped
//! connections, and errors that say which endpoint failed and how.

use std::fmt;
use std::time::Duration;

use serde::{Deserialize, Serialize};
use serde_json::{Value, json};

/// Where and how to reach the service.
#[derive(Clone, Serialize, Deserialize)]
pub struct ServiceConfig {
    /// Base URL including the API version, e.g. `http://127.0.0.1:8000/v1`.
    pub base_url: String,
    /// Model name passed in every request.
    pub model: String,
    /// Bearer token, if the service needs one. Never printed.
    #[serde(default)]
    pub api_key: Option<String>,
    /// Per-request timeout in seconds.
    #[serde(default = "default_timeout")]
    pub timeout_secs: f64,
    /// Retries after the first attempt.
    #[serde(default = "default_retries")]
    pub max_retries: u32,
    /// First backoff in seconds; doubled each retry (capped at 30 s).
    #[serde(default = "default_backoff")]
    pub initial_backoff_secs: f64,
}

fn default_timeout() -> f64 {
    120.0
}
fn default_retries() -> u32 {
    4
}
fn default_backoff() -> f64 {
    1.0
}

impl ServiceConfig {
    /// A config with default timeout and retries.
    pub fn new(base_url: impl Into<String>, model: impl Into<String>) -> Self {
        Self {
            base_url: base_url.into(),
            model: model.into(),
            api_key: None,
            timeout_secs: default_timeout(),
            max_retries: default_retries(),
            initial_backoff_secs: default_backoff(),
        }
    }
}

impl fmt::Debug for ServiceConfig {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("ServiceConfig")
            .field("base_url", &self.base_url)
            .field("model", &self.model)
            .field("api_key", &self.api_key.as_ref().map(|_| "<redacted>"))
            .field("timeout_secs", &self.timeout_secs)
            .field("max_retries", &self.max_retries)
            .finish()
    }
}

/// What went wrong talking to the service.
#[derive(Debug, thiserror::Error)]
pub enum ServiceError {
    #[error("{url}: cannot reach the service after {attempts} attempt(s): {cause}")]
    Unreachable { url: String, attempts: u32, cause: String },
    #[error("{url}: the service answered {status} after {attempts} attempt(s): {body}")]
    Status { url: String, status: u16, attempts: u32, body: String },
    #[error("{url}: unexpected response: {what}")]
    BadResponse { url: String, what: String },
    #[error("invalid service configuration: {0}")]
    Config(String),
}

/// A blocking client for one OpenAI-compatible service.
pub struct ServiceClient {
    http: reqwest::blocking::Client,
    config: ServiceConfig,
}

impl ServiceClient {
    /// A client for `config`.
    pub fn new(config: ServiceConfig) -> Result<Self, ServiceError> {
        if !(config.base_url.starts_with("http://") || config.base_url.starts_with("https://")) {
            return Err(ServiceError::Config(format!("base_url '{}' must start with http:// or https://", config.base_url)));
        }
        if !(config.timeout_secs.is_finite() && config.timeout_secs > 0.0 && config.timeout_secs <= 86_400.0) {
            return Err(ServiceError::Config("timeout_secs must be in (0, 86400]".into()));
        }
        if !(config.initial_backoff_secs.is_finite() && (0.0..=60.0).contains(&config.initial_backoff_secs)) {
            return Err(ServiceError::Config("initial_backoff_secs must be in [0, 60]".into()));
        }
        let http = reqwest::blocking::Client::builder()
            .timeout(Duration::from_secs_f64(config.timeout_secs))
            .build()
            .map_err(|e| ServiceError::Config(format!("cannot build an HTTP client: {e}")))?;
        Ok(Self { http, config })
    }

    /// The model name.
    pub fn model(&self) -> &str {
        &self.config.model
    }

    fn url(&self, path: &str) -> String {
        format!("{}/{path}", self.config.base_url.trim_end_matches('/'))
    }

    /// POST `body` as JSON, retrying what is worth retrying.
    fn post(&self, path: &str, body: &Value) -> Result<Value, ServiceError> {
        let url = self.url(path);
        let mut backoff = Duration::from_secs_f64(self.config.initial_backoff_secs.max(0.0));
        let attempts = self.config.max_retries + 1;
        for attempt in 1..=attempts {
            let mut request = self.http.post(&url).json(body);
            if let Some(key) = &self.config.api_key {
                request = request.bearer_auth(key);
            }
            let last = attempt == attempts;
            match request.send() {
                Err(e) => {
                    if last {
                        return Err(ServiceError::Unreachable { url, attempts, cause: e.to_string() });
                    }
                }
                Ok(response) => {
                    let status = response.status();
                    if status.is_success() {
                        return response.json::<Value>().map_err(|e| ServiceError::BadResponse { url: url.clone(), what: format!("body is not JSON: {e}") });
                    }
                    let retryable = status.as_u16() == 429 || status.is_server_error();
                    let retry_after = response
                        .headers()
                        .get(reqwest::header::RETRY_AFTER)
                        .and_then(|v| v.to_str().ok())
                        .and_then(|v| v.trim().parse::<f64>().ok())
                        .filter(|s| s.is_finite())
                        .map(|s| Duration::from_secs_f64(s.clamp(0.0, 60.0)));
                    let text = response.text().unwrap_or_default();
                    if !retryable || last {
                        let body: String = text.chars().take(300).collect();
                        return Err(ServiceError::Status { url, status: status.as_u16(), attempts: attempt, body });
                    }
                    if let Some(wait) = retry_after {
                        backoff = backoff.max(wait);
                    }
                }
            }
            std::thread::sleep(backoff);
            backoff = (backoff * 2).min(Duration::from_secs(30));
        }
        unreachable!("the last attempt returns")
    }

    /// One chat completion in JSON mode; returns the parsed JSON the model wrote.
    pub fn chat_json(&self, system: &str, user: &str, temperature: f64) -> Result<Value, ServiceError> {
        let body = json!({
            "model": self.config.model,
            "messages": [{"role": "system", "content": system}, {"role": "user", "content": user}],
            "temperature": temperature,
            "response_format": {"type": "json_object"},
        });
        let url = self.url("chat/completions");
        let response = self.post("chat/completions", &body)?;
        let content = response["choices"][0]["message"]["content"]
            .as_str()
            .ok_or_else(|| ServiceError::BadResponse { url: url.clone(), what: "no choices[0].message.content string".into() })?;
        // Models sometimes wrap JSON in a code fence; accept that, nothing looser.
        let trimmed = content.trim().trim_start_matches("```json").trim_start_matches("```").trim_end_matches("```").trim();
        serde_json::from_str(trimmed).map_err(|e| ServiceError::BadResponse { url, what: format!("the model's message is not JSON: {e}") })
    }

    /// Embeddings of `inputs`, in order.
    pub fn embeddings(&self, inputs: &[String]) -> Result<Vec<Vec<f32>>, ServiceError> {
        let url = self.url("embeddings");
        let response = self.post("embeddings", &json!({"model": self.config.model, "input": inputs}))?;
        let data = response["data"].as_array().ok_or_else(|| ServiceError::BadResponse { url: url.clone(), what: "no 'data' array".into() })?;
        if data.len() != inputs.len() {
            return Err(ServiceError::BadResponse { url, what: format!("{} embeddings for {} inputs", data.len(), inputs.len()) });
        }
        let mut out = vec![Vec::new(); inputs.len()];
        for (i, item) in data.iter().enumerate() {
            let index = item["index"].as_u64().map_or(i, |x| x as usize);
            let vector: Option<Vec<f32>> = item["embedding"].as_array().and_then(|v| v.iter().map(|x| x.as_f64().map(|f| f as f32)).collect());
            match (vector, out.get_mut(index)) {
                (Some(v), Some(slot)) if !v.is_empty() && v.iter().all(|x| x.is_finite()) => *slot = v,
                _ => return Err(ServiceError::BadResponse { url, what: format!("data[{i}] is not a finite embedding for a known index") }),
            }
        }
        let dim = out[0].len();
        if out.iter().any(|v| v.len() != dim) {
            return Err(ServiceError::BadResponse { url, what: "embeddings of different lengths".into() });
        }
        Ok(out)
    }
}
