//! What the pages read of a release's manifest (written by `osmab_dataset::release`): its
//! scenes with their split and preview frame, its files and lightings, typed once here.

use osmab_dataset::release::manifest::FileEntry;
use osmab_evaluator::scores::Split;
use serde::Deserialize;

#[derive(Debug, Default, Deserialize)]
pub struct PublishedManifest {
    #[serde(default)]
    pub created: String,
    #[serde(default)]
    pub lightings: Vec<String>,
    #[serde(default)]
    pub files: Vec<FileEntry>,
    #[serde(default)]
    pub scenes: Vec<PublishedScene>,
    #[serde(default)]
    pub archives: Vec<Archive>,
}

#[derive(Debug, Deserialize)]
pub struct PublishedScene {
    pub id: String,
    #[serde(default)]
    pub subset: String,
    /// `val` where a release predates splits.
    #[serde(default = "open_split")]
    pub split: Split,
    /// Absent from a test scene, which publishes none.
    #[serde(default)]
    pub prompt: Option<String>,
    /// The frame that shows the most of the scene.
    #[serde(default)]
    pub preview: Option<String>,
}

/// One sequence archive (a scene under a lighting, as one tar).
#[derive(Debug, Deserialize)]
pub struct Archive {
    #[serde(default)]
    pub lighting: String,
    #[serde(default)]
    pub scene: String,
    pub path: String,
    #[serde(default)]
    pub size: u64,
    #[serde(default)]
    pub sha256: String,
}

fn open_split() -> Split {
    Split::Val
}

impl PublishedManifest {
    /// The manifest text of a release record; an unreadable one reads as empty (the pages
    /// show what they can, the API serves the text itself).
    pub fn parse(text: &str) -> Self {
        serde_json::from_str(text).unwrap_or_default()
    }

    pub fn has(&self, path: &str) -> bool {
        self.files.iter().any(|f| f.path == path)
    }

    /// How many scenes each split has: (test, val).
    pub fn split_sizes(&self) -> (usize, usize) {
        let test = self.scenes.iter().filter(|s| s.split == Split::Test).count();
        (test, self.scenes.len() - test)
    }
}
