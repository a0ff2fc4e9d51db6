//! The release build configuration (`configs/release-*.toml`).

use std::path::Path;

use osmab_evaluator::scores::ReleaseLighting;
use osmab_evaluator::{InputError, Result};
use serde::{Deserialize, Serialize};

use super::split::SplitsConfig;
use crate::openai::ServiceConfig;
use crate::render::camera::SensorSettings;

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
    /// The asset pack the built-in synthesizer draws objects and room shells from (a folder
    /// with `catalogue.json`, relative to the working directory; `assets` is the one this
    /// repository ships); the procedural library alone when absent.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub assets: Option<String>,
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
    /// Camera tilt in degrees, negative looking down (HaDaGe's `camera_pitch_deg`).
    #[serde(default)]
    pub camera_pitch_deg: f64,
    /// Navigation goals at least per furniture and per manipuland scene (OSMa-Bench++:
    /// 5 and 10); the coverage planner adds viewpoints until every object is observed.
    pub goals_furniture: usize,
    pub goals_manipuland: usize,
    /// Frames per action (HaDaGe's move and turn frequency multipliers): 2 in
    /// OSMa-Bench (3 cm or 2° a frame), 1 in its `velocity` variant (6 cm or 4°).
    #[serde(default = "default_frames_per_action")]
    pub frames_per_action: u32,
    pub max_frames: usize,
    /// The lightings every scene is rendered under, in this order.
    pub lightings: Vec<ReleaseLighting>,
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
        SensorSettings {
            width: self.width,
            height: self.height,
            hfov: self.hfov,
            sensor_height: self.sensor_height,
            camera_pitch_deg: self.camera_pitch_deg,
            ..Default::default()
        }
    }
}

fn default_frames_per_action() -> u32 {
    2
}

impl RenderConfig {
    /// The motion of scene `index` of `regime` (HaDaGe's steps, this config's budget).
    pub fn motion(&self, regime: crate::spec::Regime, seed: u64) -> crate::render::trajectory::MotionSettings {
        let goals = if regime == crate::spec::Regime::Furniture { self.goals_furniture } else { self.goals_manipuland };
        crate::render::trajectory::MotionSettings { goals, seed, max_frames: self.max_frames, sub_steps: self.frames_per_action, ..Default::default() }
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

/// What every scene of a release must reach (product issue 12's bar); a scene that
/// misses it is replaced from the selection's spare prompts, and a build that cannot
/// replace it fails naming the scene and the measure.
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct QualityConfig {
    /// Fail the build on a miss (false: report the misses only, for quick test builds).
    #[serde(default = "yes")]
    pub enforce: bool,
    /// Frames dominated by one class (> 85 % of pixels) or short of depth (< 50 %).
    #[serde(default = "default_degenerate")]
    pub max_degenerate_fraction: f64,
    /// Median share of saturated pixels of a frame, in every lighting.
    #[serde(default = "default_saturated")]
    pub max_median_saturated: f64,
    /// Frames of `dynamic_lights` that must differ from `baseline`.
    #[serde(default = "default_dynamic")]
    pub min_dynamic_changed_fraction: f64,
    /// Metres the camera travels at least.
    #[serde(default = "default_travel")]
    pub min_travel: f64,
    /// The oracle's VQA accuracy at least, per question group.
    #[serde(default = "default_oracle_vqa")]
    pub min_oracle_vqa: f64,
    /// Spare prompts tried at most for a scene that misses the bar before the build fails
    /// (default: every spare of the scene's subset and split).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub replacements: Option<usize>,
    /// Placements tried for each prompt (each from a seed derived from the scene's, each
    /// honouring every relation of the prompt) before the prompt is replaced.
    #[serde(default = "default_placements")]
    pub placements: usize,
}

fn yes() -> bool {
    true
}
fn default_degenerate() -> f64 {
    0.10
}
fn default_saturated() -> f64 {
    0.05
}
fn default_dynamic() -> f64 {
    0.20
}
fn default_travel() -> f64 {
    2.0
}
fn default_oracle_vqa() -> f64 {
    0.98
}
fn default_placements() -> usize {
    4
}

impl Default for QualityConfig {
    fn default() -> Self {
        Self {
            enforce: true,
            max_degenerate_fraction: default_degenerate(),
            max_median_saturated: default_saturated(),
            min_dynamic_changed_fraction: default_dynamic(),
            min_travel: default_travel(),
            min_oracle_vqa: default_oracle_vqa(),
            replacements: None,
            placements: default_placements(),
        }
    }
}

/// The environment variable holding the LLM's API key for release builds.
pub const LLM_KEY_VARIABLE: &str = "OSMAB_LLM_API_KEY";
/// The environment variable holding the embeddings service's API key for release builds.
pub const EMBEDDINGS_KEY_VARIABLE: &str = "OSMAB_EMBEDDINGS_API_KEY";

/// Bounds of the sizes a release config sets ([`ReleaseConfig::size_beyond_bounds`]).
const MAX_PROMPT_POOL: u64 = 5_000;
const MAX_SCENES_PER_SUBSET: u64 = 200;
const MAX_FRAMES: u64 = 100_000;
const MAX_GOALS: u64 = 100;
const MAX_TIMEOUT_SECS: u64 = 86_400;
/// Scenes × lightings × max_frames × width × height at most: about ten times the full
/// release's (40 × 4 × 20,000 × 1200 × 680 ≈ 2.6·10¹²).
const MAX_RENDERED_PIXELS: u64 = 30_000_000_000_000;

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
    #[serde(default)]
    pub quality: QualityConfig,
    /// The hidden test split; every scene is val without it.
    #[serde(default, skip_serializing_if = "SplitsConfig::is_empty")]
    pub splits: SplitsConfig,
    /// The licence of the release's data (an SPDX id such as `CC-BY-4.0`), written into its
    /// LICENSE and CITATION.cff; without it, LICENSE says none was named.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub licence: Option<String>,
}

impl ReleaseConfig {
    /// Read and check a config file.
    pub fn read(path: &Path) -> Result<(Self, String)> {
        let text = std::fs::read_to_string(path).map_err(|e| InputError::io(path, &e))?;
        Self::parse(&text, path)
    }

    /// The digest of everything in this config that shapes a release's content (not its
    /// name, date or service keys): two configs with one digest build the same release
    /// (for one operator's secret, where it has a test split).
    pub fn content_digest(&self) -> String {
        let mut content = self.clone();
        content.version.clear();
        content.created.clear();
        for service in [&mut content.prompts.llm, &mut content.selection.embeddings].into_iter().flatten() {
            service.api_key = None;
        }
        super::manifest::hex(&<sha2::Sha256 as sha2::Digest>::digest(serde_json::to_vec(&content).expect("serialisable")))
    }

    /// The first size this config sets beyond its bound, as (field, bound). The bounds are
    /// far above the full release's (250 and 100 prompts, 24 and 16 scenes, 20,000 frames at
    /// most, 5 and 10 goals) and stop a posted config from queueing work without end.
    fn size_beyond_bounds(&self) -> Option<(&'static str, u64)> {
        let sizes = [
            ("prompts.furniture_pool", self.prompts.furniture_pool as u64, MAX_PROMPT_POOL),
            ("prompts.manipuland_pool", self.prompts.manipuland_pool as u64, MAX_PROMPT_POOL),
            ("selection.furniture", self.selection.furniture as u64, MAX_SCENES_PER_SUBSET),
            ("selection.manipuland", self.selection.manipuland as u64, MAX_SCENES_PER_SUBSET),
            ("render.max_frames", self.render.max_frames as u64, MAX_FRAMES),
            ("render.goals_furniture", self.render.goals_furniture as u64, MAX_GOALS),
            ("render.goals_manipuland", self.render.goals_manipuland as u64, MAX_GOALS),
            ("render.timeout_secs", self.render.timeout_secs, MAX_TIMEOUT_SECS),
            ("synthesis.timeout_secs", self.synthesis.timeout_secs, MAX_TIMEOUT_SECS),
            ("quality.replacements", self.quality.replacements.unwrap_or(0) as u64, MAX_PROMPT_POOL),
        ];
        if let Some(found) = sizes.into_iter().find(|(_, size, bound)| size > bound) {
            return Some((found.0, found.2));
        }
        // Each within its bound, the sizes could still multiply into years of rendering.
        let pixels = [
            (self.selection.furniture + self.selection.manipuland) as u64,
            self.render.lightings.len() as u64,
            self.render.max_frames as u64,
            u64::from(self.render.width),
            u64::from(self.render.height),
        ]
        .into_iter()
        .try_fold(1u64, u64::checked_mul);
        pixels.is_none_or(|p| p > MAX_RENDERED_PIXELS).then_some(("render.max_frames", MAX_RENDERED_PIXELS))
    }

    /// Check the config `text` (named `path` in errors).
    pub fn parse(text: &str, path: &Path) -> Result<(Self, String)> {
        let text = text.to_string();
        let mut config: ReleaseConfig = toml::from_str(&text).map_err(|e| InputError::new(path, "(toml)", e.to_string()))?;
        let bad = |field: &str, m: &str| Err(InputError::new(path, field, m.to_string()));
        if config.version.is_empty() || !config.version.chars().all(|c| c.is_ascii_alphanumeric() || "._-".contains(c)) {
            return bad("version", "expected letters, digits, '.', '_' or '-'");
        }
        if let Some(licence) = &config.licence
            && (licence.is_empty() || licence.len() > 100 || !licence.chars().all(|c| c.is_ascii_alphanumeric() || " .-+()".contains(c)))
        {
            return bad("licence", "expected an SPDX licence expression such as CC-BY-4.0 (letters, digits, ' ', '.', '-', '+', '(', ')'; at most 100)");
        }
        let sensor = config.render.sensor();
        if let Some((field, expectation)) = sensor.problem() {
            return bad(&format!("render.{field}"), expectation);
        }
        let q = &config.quality;
        for (field, value) in [
            ("quality.max_degenerate_fraction", q.max_degenerate_fraction),
            ("quality.max_median_saturated", q.max_median_saturated),
            ("quality.min_dynamic_changed_fraction", q.min_dynamic_changed_fraction),
            ("quality.min_oracle_vqa", q.min_oracle_vqa),
        ] {
            if !(0.0..=1.0).contains(&value) {
                return bad(field, "a fraction in [0, 1]");
            }
        }
        if !(1..=64).contains(&q.placements) {
            return bad("quality.placements", "1 to 64 placements a prompt");
        }
        if !(q.min_travel >= 0.0 && q.min_travel < 1000.0) {
            return bad("quality.min_travel", "metres in [0, 1000)");
        }
        if let Some((field, bound)) = config.size_beyond_bounds() {
            let what = if bound == MAX_RENDERED_PIXELS { "scenes × lightings × max_frames × width × height " } else { "" };
            return bad(field, &format!("{what}at most {bound} (every size a release config sets is bounded, so a config cannot queue unbounded work)"));
        }
        if !(1..=8).contains(&config.render.frames_per_action) {
            return bad("render.frames_per_action", "1 to 8 frames per move or turn");
        }
        if config.render.lightings.is_empty() {
            return bad("render.lightings", "at least one lighting");
        }
        if let Some(twice) = config.render.lightings.iter().enumerate().find_map(|(i, l)| config.render.lightings[..i].contains(l).then_some(l)) {
            return bad("render.lightings", &format!("each lighting once ('{twice}' is listed twice)"));
        }
        for (field, test, scenes) in [
            ("splits.test_furniture", config.splits.test_furniture, config.selection.furniture),
            ("splits.test_manipuland", config.splits.test_manipuland, config.selection.manipuland),
        ] {
            if test > scenes {
                return bad(field, &format!("at most the subset's {scenes} selected scenes"));
            }
        }
        if !config.splits.is_empty() && !config.synthesis.command.is_empty() && !config.synthesis.command.iter().any(|a| a.contains("{seed}")) {
            return bad(
                "synthesis.command",
                "with a test split the external synthesizer must take {seed} (derived from the operator's secret for test scenes); without it the published config rebuilds them",
            );
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
