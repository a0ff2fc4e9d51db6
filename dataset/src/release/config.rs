//! The release build configuration (`configs/release-*.toml`).

use std::path::Path;

use osmab_evaluator::{InputError, Result};
use serde::{Deserialize, Serialize};

use crate::openai::ServiceConfig;
use crate::render::sequence::SensorSettings;

#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PromptsConfig {
    pub furniture_pool: usize,
    pub manipuland_pool: usize,
    /// An OpenAI-compatible LLM; the built-in grammar when absent.
    #[serde(default)]
    pub llm: Option<ServiceConfig>,
}

#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SelectionConfig {
    pub furniture: usize,
    pub manipuland: usize,
    #[serde(default = "default_threshold")]
    pub threshold: f32,
    /// An OpenAI-compatible embeddings service; the built-in embedding when absent.
    #[serde(default)]
    pub embeddings: Option<ServiceConfig>,
}

fn default_threshold() -> f32 {
    crate::selection::NEAR_DUPLICATE_COSINE
}

#[derive(Debug, Clone, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SynthesisConfig {
    #[serde(default)]
    pub ceiling: bool,
    /// An external synthesizer (SceneSmith); the built-in one when empty.
    #[serde(default)]
    pub command: Vec<String>,
    #[serde(default = "default_synthesis_timeout")]
    pub timeout_secs: u64,
}

fn default_synthesis_timeout() -> u64 {
    24 * 3600
}

#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RenderConfig {
    pub width: u32,
    pub height: u32,
    #[serde(default = "default_hfov")]
    pub hfov: f64,
    #[serde(default = "default_sensor_height")]
    pub sensor_height: f64,
    /// Navigation goals per furniture and per manipuland scene (OSMa-Bench++: 5 and 10).
    pub goals_furniture: usize,
    pub goals_manipuland: usize,
    pub max_frames: usize,
    pub lightings: Vec<String>,
    /// An external renderer (HaDaGe) run per scene and lighting; the built-in one when
    /// empty. Placeholders: {scene_dir} (the converted scene), {scene}, {lighting},
    /// {out} (the sequence directory to write), {width}, {height}, {goals}, {seed}.
    #[serde(default)]
    pub command: Vec<String>,
    #[serde(default = "default_render_timeout")]
    pub timeout_secs: u64,
}

impl RenderConfig {
    /// The camera these settings describe.
    pub fn sensor(&self) -> SensorSettings {
        SensorSettings { width: self.width, height: self.height, hfov: self.hfov, sensor_height: self.sensor_height, ..Default::default() }
    }
}

fn default_render_timeout() -> u64 {
    24 * 3600
}

fn default_hfov() -> f64 {
    90.0
}
fn default_sensor_height() -> f64 {
    1.0
}

/// The environment variable holding the LLM's API key for release builds.
pub const LLM_KEY_VARIABLE: &str = "OSMAB_LLM_API_KEY";
/// The environment variable holding the embeddings service's API key for release builds.
pub const EMBEDDINGS_KEY_VARIABLE: &str = "OSMAB_EMBEDDINGS_API_KEY";

/// Everything a release build needs; the same config gives the same release.
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ReleaseConfig {
    pub version: String,
    /// The release date written in the manifest (fixed, so rebuilds are identical).
    pub created: String,
    pub seed: u64,
    pub prompts: PromptsConfig,
    pub selection: SelectionConfig,
    #[serde(default)]
    pub synthesis: SynthesisConfig,
    pub render: RenderConfig,
}

impl ReleaseConfig {
    /// Read and check a config file.
    pub fn read(path: &Path) -> Result<(Self, String)> {
        let text = std::fs::read_to_string(path).map_err(|e| InputError::io(path, &e))?;
        let mut config: ReleaseConfig = toml::from_str(&text).map_err(|e| InputError::new(path, "(toml)", e.to_string()))?;
        let bad = |field: &str, m: &str| Err(InputError::new(path, field, m.to_string()));
        if config.version.is_empty() || !config.version.chars().all(|c| c.is_ascii_alphanumeric() || "._-".contains(c)) {
            return bad("version", "expected letters, digits, '.', '_' or '-'");
        }
        let sensor = config.render.sensor();
        if let Some((field, expectation)) = sensor.problem() {
            return bad(&format!("render.{field}"), expectation);
        }
        if config.render.lightings.is_empty() {
            return bad("render.lightings", "at least one lighting");
        }
        if let Some(l) = config.render.lightings.iter().find(|l| !crate::render::LIGHTINGS.contains(&l.as_str())) {
            return bad("render.lightings", &format!("unknown lighting '{l}' (expected some of {})", crate::render::LIGHTINGS.join(", ")));
        }
        // The config text is published in the manifest: secrets come from the environment.
        for (field, service, variable) in [
            ("prompts.llm.api_key", &mut config.prompts.llm, LLM_KEY_VARIABLE),
            ("selection.embeddings.api_key", &mut config.selection.embeddings, EMBEDDINGS_KEY_VARIABLE),
        ] {
            if let Some(service) = service {
                if service.api_key.is_some() {
                    return bad(field, &format!("no secrets in a release config (its text is published in the manifest); set {variable} instead"));
                }
                service.api_key = std::env::var(variable).ok().filter(|k| !k.is_empty());
            }
        }
        Ok((config, text))
    }
}
