//! What a running job reports of itself, typed once: every job writes a [`Progress`], the
//! job API serves it (as JSON on the job), and the console reads it back. Fields a job
//! does not report are left out of the JSON, as before it was typed.

use serde::{Deserialize, Serialize};

/// The stage a job is in. A release build goes prepare → rendering → assemble → import →
/// baselines → done; a render job is in `render`, a scoring job in `scoring`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, schemars::JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum Stage {
    Prepare,
    Rendering,
    Assemble,
    Import,
    Baselines,
    Done,
    Render,
    Scoring,
}

impl Stage {
    /// The stages of a release build, in order.
    pub const BUILD: [Stage; 6] = [Stage::Prepare, Stage::Rendering, Stage::Assemble, Stage::Import, Stage::Baselines, Stage::Done];

    pub fn name(self) -> &'static str {
        match self {
            Stage::Prepare => "prepare",
            Stage::Rendering => "rendering",
            Stage::Assemble => "assemble",
            Stage::Import => "import",
            Stage::Baselines => "baselines",
            Stage::Done => "done",
            Stage::Render => "render",
            Stage::Scoring => "scoring",
        }
    }
}

/// A job's progress. Fields in the order of their JSON keys (as the untyped progress was
/// written), so the stored text is what it was.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize, schemars::JsonSchema)]
pub struct Progress {
    /// A scoring job's maps scored so far, of `total`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub done: Option<usize>,
    /// A build's render jobs, by subject (`version/scene/lighting`), once queued.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub fanned_out: Option<Vec<String>>,
    /// The stage's latest lines (at most 20), oldest first (one text of lines, from older
    /// servers, reads as its lines).
    #[serde(default, skip_serializing_if = "Option::is_none", deserialize_with = "lines")]
    pub log: Option<Vec<String>>,
    /// The latest line, in words.
    #[serde(default, skip_serializing_if = "String::is_empty")]
    pub message: String,
    /// How many of the render jobs are rendered.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub rendered: Option<usize>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub stage: Option<Stage>,
    /// When the attempt that wrote it began (ms since the epoch).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub started_at: Option<i64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub total: Option<usize>,
    /// The render jobs still queued or running.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub waiting_for: Option<Vec<String>>,
    /// The worker that wrote it.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub worker: Option<String>,
}

/// A list of lines, or one text of them.
fn lines<'de, D: serde::Deserializer<'de>>(deserializer: D) -> Result<Option<Vec<String>>, D::Error> {
    #[derive(Deserialize)]
    #[serde(untagged)]
    enum Lines {
        Many(Vec<String>),
        One(String),
    }
    Ok(Option::<Lines>::deserialize(deserializer)?.map(|lines| match lines {
        Lines::Many(lines) => lines,
        Lines::One(text) => text.lines().map(str::to_string).collect(),
    }))
}

impl Progress {
    /// At `stage`, saying `message`.
    pub fn at(stage: Stage, message: impl Into<String>) -> Self {
        Progress { stage: Some(stage), message: message.into(), ..Progress::default() }
    }

    /// The progress a job recorded (its `progress` column); nothing for text that is not one.
    pub fn read(text: &str) -> Self {
        serde_json::from_str(text).unwrap_or_default()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn progress_writes_only_what_a_job_reported_with_keys_as_before() {
        let rendering = Progress { fanned_out: Some(vec!["v/scene_000".into()]), rendered: Some(0), ..Progress::at(Stage::Rendering, "1 scenes queued") };
        assert_eq!(
            serde_json::to_value(&rendering).unwrap(),
            serde_json::json!({"stage": "rendering", "message": "1 scenes queued", "fanned_out": ["v/scene_000"], "rendered": 0})
        );
        let text = serde_json::to_string(&rendering).unwrap();
        assert_eq!(text, r#"{"fanned_out":["v/scene_000"],"message":"1 scenes queued","rendered":0,"stage":"rendering"}"#, "the text the untyped progress was");
        assert_eq!(Progress::read(&text), rendering);
        assert_eq!(Progress::read("not json"), Progress::default());
        assert_eq!(
            Progress::read(r#"{"log": "a\nb", "stage": "prepare"}"#).log,
            Some(vec!["a".to_string(), "b".to_string()]),
            "an older text log reads as lines"
        );
        assert_eq!(Stage::BUILD.map(Stage::name), ["prepare", "rendering", "assemble", "import", "baselines", "done"]);
    }
}
