//! The release manifest (product.md section 9), one type for everything that writes or
//! reads it: the release build writes it, the service adds the sequence archives it packs
//! and serves it, the client downloads by it, validation and scoring read the scenes and
//! lightings from it, the pages show it.
//!
//! Fields are declared in the order of their JSON keys (alphabetical, as the manifests
//! written before this type have them), so a manifest read and written again is the same
//! bytes.

use std::collections::BTreeMap;
use std::path::Path;

use serde::{Deserialize, Serialize};
use sha2::{Digest, Sha256};

use crate::digest::hex;
use crate::error::{InputError, Result};
use crate::scores::{Lighting, Regime, ReleaseLighting, Split};

/// A release's manifest: what it is, how it was made, its scenes and lightings, and every
/// public file with its size and SHA-256.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct ReleaseManifest {
    /// One archive per sequence, added by the service when it imports the release (a
    /// built release's own manifest has none).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub archives: Vec<ArchiveEntry>,
    /// When the config says the release was made (free text, as the config writes it).
    #[serde(default)]
    pub created: String,
    /// The release digest: [`files_digest`] of [`ReleaseManifest::files`].
    #[serde(default)]
    pub digest: String,
    /// Every public file, sorted by path.
    #[serde(default)]
    pub files: Vec<FileEntry>,
    /// How the release was made.
    #[serde(default)]
    pub generator: Generator,
    /// The lightings every scene is rendered under, in render order (readers that need
    /// them, as validation does, refuse a manifest without any).
    #[serde(default)]
    pub lightings: Vec<ReleaseLighting>,
    /// The scenes, in scene order.
    #[serde(default)]
    pub scenes: Vec<ManifestScene>,
    /// The release version (`osmabpp-v1`).
    pub version: String,
}

/// One public file of a release.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct FileEntry {
    /// Path relative to the release root, with `/`.
    pub path: String,
    pub sha256: String,
    pub size: u64,
}

/// One sequence's archive (a scene under a lighting, as one tar) as the service serves it.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct ArchiveEntry {
    pub lighting: ReleaseLighting,
    /// Path of the archive in the release (`archives/sequences/<lighting>/<scene>.tar`).
    pub path: String,
    pub scene: String,
    pub sha256: String,
    pub size: u64,
}

/// A release's provenance: the config, its seed and content digest, the code version, and
/// with a test split the public id of the operator's secret.
#[derive(Debug, Clone, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct Generator {
    /// The digest of the asset pack the scenes were drawn from, when one was.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub assets_digest: Option<String>,
    #[serde(default)]
    pub code_version: String,
    /// The config file's text, as it was read.
    #[serde(default)]
    pub config: String,
    #[serde(default)]
    pub content_digest: String,
    #[serde(default)]
    pub seed: u64,
    /// A hash of the operator's split secret that tells nothing of it.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub split_secret_id: Option<String>,
}

/// One scene of a release.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct ManifestScene {
    /// Scene id (`scene_000`).
    pub id: String,
    /// The frame that shows the most of the scene (a path in the release).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub preview: Option<String>,
    /// The generating prompt; absent from a test scene, which publishes none.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub prompt: Option<String>,
    /// The public questions' file; absent from a test scene.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub questions: Option<String>,
    /// The split (`val` in releases built before splits existed).
    #[serde(default)]
    pub split: Split,
    /// The subset (prompt regime) it belongs to.
    pub subset: Regime,
}

/// The release digest of `files`: SHA-256 over their sorted `path size sha256` lines.
pub fn files_digest(files: &[FileEntry]) -> String {
    let mut lines: Vec<String> = files.iter().map(|f| format!("{} {} {}\n", f.path, f.size, f.sha256)).collect();
    lines.sort();
    hex(&Sha256::digest(lines.concat().as_bytes()))
}

impl ReleaseManifest {
    /// Parse a manifest's text; errors name `origin` (a file, or the URL it came from).
    pub fn parse(text: &str, origin: &Path) -> Result<Self> {
        serde_json::from_str(text).map_err(|e| InputError::new(origin, "(json)", e.to_string()))
    }

    /// Read the manifest file at `path`.
    pub fn read(path: &Path) -> Result<Self> {
        let text = std::fs::read_to_string(path).map_err(|e| InputError::io(path, &e))?;
        Self::parse(&text, path)
    }

    /// The manifest as written to `manifest.json` and served: pretty JSON and a newline.
    pub fn to_json(&self) -> String {
        serde_json::to_string_pretty(self).expect("a manifest serialises") + "\n"
    }

    /// Write the manifest to `path`.
    pub fn write(&self, path: &Path) -> Result<()> {
        std::fs::write(path, self.to_json()).map_err(|e| InputError::io(path, &e))
    }

    /// Whether [`ReleaseManifest::digest`] is the digest of the listed files (a truncated
    /// or edited manifest is not).
    pub fn digest_matches(&self) -> bool {
        self.digest == files_digest(&self.files)
    }

    /// The lightings on the score document's axis, in render order.
    pub fn score_lightings(&self) -> Vec<Lighting> {
        self.lightings.iter().map(|l| l.lighting()).collect()
    }

    /// Whether the release lists the file `path`.
    pub fn has_file(&self, path: &str) -> bool {
        self.files.iter().any(|f| f.path == path)
    }

    /// The scene with id `id`.
    pub fn scene(&self, id: &str) -> Option<&ManifestScene> {
        self.scenes.iter().find(|s| s.id == id)
    }

    /// The split of every scene, by id.
    pub fn scene_splits(&self) -> BTreeMap<&str, Split> {
        self.scenes.iter().map(|s| (s.id.as_str(), s.split)).collect()
    }

    /// The splits the release's scenes belong to, test first.
    pub fn splits(&self) -> Vec<Split> {
        Split::ALL.into_iter().filter(|split| self.scenes.iter().any(|s| s.split == *split)).collect()
    }

    /// The split a leaderboard ranks and a submission goes to unless it says otherwise:
    /// the hidden test split when the release has one, else the open val split.
    pub fn primary_split(&self) -> Split {
        if self.scenes.iter().any(|s| s.split == Split::Test) { Split::Test } else { Split::Val }
    }

    /// How many scenes each split has: (test, val).
    pub fn split_sizes(&self) -> (usize, usize) {
        let test = self.scenes.iter().filter(|s| s.split == Split::Test).count();
        (test, self.scenes.len() - test)
    }

    /// The colour frames of each scene's sequence under `lighting`, counted from the files.
    pub fn frames_under(&self, lighting: ReleaseLighting) -> BTreeMap<String, u64> {
        let mut frames: BTreeMap<String, u64> = BTreeMap::new();
        for file in &self.files {
            let mut parts = file.path.split('/');
            if let (Some("sequences"), Some(l), Some(scene), Some("results"), Some(name)) =
                (parts.next(), parts.next(), parts.next(), parts.next(), parts.next())
                && l == lighting.name()
                && name.starts_with("frame")
            {
                *frames.entry(scene.to_string()).or_default() += 1;
            }
        }
        frames
    }

    /// The files of the sequence `lighting`/`scene`: what its archive holds, in the
    /// manifest's (sorted) order.
    pub fn sequence_files(&self, lighting: ReleaseLighting, scene: &str) -> Vec<&FileEntry> {
        let prefix = sequence_prefix(lighting, scene);
        self.files.iter().filter(|f| f.path.starts_with(&prefix)).collect()
    }

    /// The sequences (lighting, scene) the files hold, sorted.
    pub fn sequences(&self) -> Vec<(ReleaseLighting, String)> {
        let mut found: Vec<(ReleaseLighting, String)> = Vec::new();
        for file in &self.files {
            if let ["sequences", lighting, scene, _, ..] = file.path.split('/').collect::<Vec<&str>>().as_slice()
                && let Ok(lighting) = lighting.parse::<ReleaseLighting>()
                && !found.iter().any(|(l, s)| *l == lighting && s == scene)
            {
                found.push((lighting, scene.to_string()));
            }
        }
        found.sort();
        found
    }
}

/// The folder a sequence's files start with in a release: `sequences/<lighting>/<scene>/`.
pub fn sequence_prefix(lighting: ReleaseLighting, scene: &str) -> String {
    format!("sequences/{lighting}/{scene}/")
}

#[cfg(test)]
mod tests {
    use super::*;

    fn file(path: &str) -> FileEntry {
        FileEntry { path: path.into(), size: 3, sha256: "ab".into() }
    }

    fn manifest() -> ReleaseManifest {
        let files = vec![
            file("classes.json"),
            file("sequences/baseline/scene_000/results/frame000000.jpg"),
            file("sequences/baseline/scene_000/results/frame000001.jpg"),
            file("sequences/baseline/scene_000/traj.txt"),
            file("sequences/no_lights/scene_000/results/frame000000.jpg"),
            file("sequences/no_lights/scene_001/results/frame000000.jpg"),
        ];
        ReleaseManifest {
            archives: Vec::new(),
            created: "2026-11-28".into(),
            digest: files_digest(&files),
            files,
            generator: Generator { seed: 7, code_version: "0.1.0".into(), ..Generator::default() },
            lightings: vec![ReleaseLighting::Baseline, ReleaseLighting::NoLights],
            scenes: vec![
                ManifestScene {
                    id: "scene_000".into(),
                    preview: None,
                    prompt: Some("a study".into()),
                    questions: None,
                    split: Split::Val,
                    subset: Regime::Furniture,
                },
                ManifestScene { id: "scene_001".into(), preview: None, prompt: None, questions: None, split: Split::Test, subset: Regime::Manipuland },
            ],
            version: "v-1".into(),
        }
    }

    #[test]
    fn a_manifest_serialises_with_sorted_keys_as_an_untyped_value_does_and_reads_back_to_itself() {
        let typed = manifest();
        let text = typed.to_json();
        let untyped: serde_json::Value = serde_json::from_str(&text).unwrap();
        assert_eq!(serde_json::to_string_pretty(&untyped).unwrap() + "\n", text, "keys in the order a serde_json::Value writes them");
        assert_eq!(ReleaseManifest::parse(&text, Path::new("m.json")).unwrap(), typed);
        assert!(!text.contains("archives") && !text.contains("split_secret_id") && !text.contains("questions"), "absent parts are left out: {text}");
    }

    #[test]
    fn the_digest_ties_the_file_list_and_an_edited_list_breaks_it() {
        let mut m = manifest();
        assert!(m.digest_matches());
        m.files[1].size += 1;
        assert!(!m.digest_matches());
    }

    #[test]
    fn scenes_splits_frames_and_sequences_are_read_from_the_lists() {
        let m = manifest();
        assert_eq!(m.splits(), [Split::Test, Split::Val]);
        assert_eq!(m.primary_split(), Split::Test);
        assert_eq!(m.split_sizes(), (1, 1));
        assert_eq!(m.frames_under(ReleaseLighting::Baseline), BTreeMap::from([("scene_000".to_string(), 2)]));
        assert_eq!(m.sequence_files(ReleaseLighting::Baseline, "scene_000").len(), 3);
        assert_eq!(
            m.sequences(),
            [
                (ReleaseLighting::Baseline, "scene_000".to_string()),
                (ReleaseLighting::NoLights, "scene_000".to_string()),
                (ReleaseLighting::NoLights, "scene_001".to_string())
            ]
        );
    }

    #[test]
    fn a_manifest_naming_a_lighting_no_release_has_is_refused_naming_the_file() {
        let text = manifest().to_json().replace("\"no_lights\"", "\"velocity\"");
        let err = ReleaseManifest::parse(&text, Path::new("release/manifest.json")).unwrap_err().to_string();
        assert!(err.contains("release/manifest.json") && err.contains("velocity"), "{err}");
    }
}
