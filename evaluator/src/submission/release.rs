//! What a release offers a submission: its version, scenes with their subsets, lightings
//! and (where the release directory holds it) the ground truth to score against.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use crate::error::{InputError, Result};
use crate::formats::classes::ClassList;
pub use crate::formats::manifest::ManifestScene as ReleaseScene;
use crate::formats::manifest::ReleaseManifest;
use crate::scores::{Lighting, Split};

/// Folder of a release directory holding the private ground truth, one folder per scene.
pub const GROUND_TRUTH_DIR: &str = "ground_truth";

/// The facts of a release that validation and scoring need.
#[derive(Debug, Clone)]
pub struct ReleaseIndex {
    /// Where the release lives on disk.
    pub root: PathBuf,
    /// The release version.
    pub version: String,
    /// Its scenes in manifest order (those of [`ReleaseIndex::split`] only, when the
    /// index is restricted to one split).
    pub scenes: Vec<ReleaseScene>,
    /// The split this index is restricted to ([`ReleaseIndex::for_split`]), if any.
    pub split: Option<Split>,
    /// The release's scenes outside that split: a submission's files for them are
    /// ignored, not refused.
    pub outside_split: Vec<String>,
    /// Its lightings in manifest order.
    pub lightings: Vec<Lighting>,
    /// The release's classes (`classes.json`).
    pub classes: ClassList,
    /// Frames of each scene's sequence (in the first lighting), from the manifest.
    pub frames: BTreeMap<String, u64>,
}

impl ReleaseIndex {
    /// Read `root/manifest.json`.
    pub fn read(root: &Path) -> Result<Self> {
        let path = root.join("manifest.json");
        let manifest = ReleaseManifest::read(&path)?;
        let Some(&first) = manifest.lightings.first().filter(|_| !manifest.scenes.is_empty()) else {
            return Err(InputError::new(&path, "scenes", "a release needs at least one scene and one lighting"));
        };
        let classes = ClassList::read(&root.join("classes.json"))?;
        Ok(Self {
            root: root.to_path_buf(),
            frames: manifest.frames_under(first),
            version: manifest.version,
            scenes: manifest.scenes,
            split: None,
            outside_split: Vec::new(),
            lightings: manifest.lightings.into_iter().map(Lighting::from).collect(),
            classes,
        })
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

    /// This index restricted to the scenes of `split`: what a submission to that split
    /// is validated and scored against. Fails, naming the release's splits, when no
    /// scene belongs to it.
    pub fn for_split(&self, split: Split) -> Result<ReleaseIndex> {
        let (scenes, outside): (Vec<ReleaseScene>, Vec<ReleaseScene>) = self.scenes.iter().cloned().partition(|s| s.split == split);
        if scenes.is_empty() {
            let has: Vec<&str> = self.splits().into_iter().map(Split::name).collect();
            return Err(InputError::new(
                self.root.join("manifest.json"),
                "scenes[].split",
                format!("release {} has no scene in split '{split}' (it has {})", self.version, has.join(", ")),
            ));
        }
        let mut index = self.clone();
        index.frames.retain(|scene, _| scenes.iter().any(|s| &s.id == scene));
        index.scenes = scenes;
        index.split = Some(split);
        index.outside_split.extend(outside.into_iter().map(|s| s.id));
        Ok(index)
    }

    /// The most points a map of any scene may hold: one per pixel of every frame of the
    /// scene's sequence (what back-projecting every pixel once gives), when this copy of
    /// the release says how many frames of which size; unbounded otherwise.
    pub fn max_map_points(&self) -> u64 {
        let mut most = 0u64;
        for (scene, &count) in &self.frames {
            let camera = self.root.join("sequences").join(self.lightings[0].name()).join(scene).join("camera_params.yaml");
            let Ok(camera) = crate::formats::camera::CameraParams::read(&camera) else { return u64::MAX };
            most = most.max(count.saturating_mul(camera.image_width as u64 * camera.image_height as u64));
        }
        if most == 0 { u64::MAX } else { most }
    }

    /// The scene with id `id`.
    pub fn scene(&self, id: &str) -> Option<&ReleaseScene> {
        self.scenes.iter().find(|s| s.id == id)
    }

    /// The ground-truth folder of `scene` (`pointcloud.pcd`, `semantic.npy`, classes).
    pub fn ground_truth_dir(&self, scene: &str) -> PathBuf {
        self.root.join(GROUND_TRUTH_DIR).join(scene)
    }

    /// Whether this copy of the release carries its ground truth.
    pub fn has_ground_truth(&self) -> bool {
        self.scenes.iter().all(|s| self.ground_truth_dir(&s.id).join("semantic.npy").is_file())
    }

    /// The questions of `scene` with their answers (`ground_truth/questions/<scene>.json`),
    /// or `None` for a release built without questions or a copy without ground truth.
    pub fn answered_questions(&self, scene: &str) -> Result<Option<crate::vqa::SceneQuestions>> {
        let path = self.root.join(GROUND_TRUTH_DIR).join("questions").join(format!("{scene}.json"));
        if !path.is_file() {
            return Ok(None);
        }
        crate::vqa::SceneQuestions::read(&path).map(Some)
    }

    /// The public questions of `scene` (`questions/<scene>.json`), if the release has them.
    pub fn public_questions(&self, scene: &str) -> Result<Option<crate::vqa::SceneQuestions>> {
        let path = self.root.join("questions").join(format!("{scene}.json"));
        if !path.is_file() {
            return Ok(None);
        }
        crate::vqa::SceneQuestions::read(&path).map(Some)
    }

    /// The release's class names, in id order.
    pub fn class_names(&self) -> Vec<String> {
        self.classes.entries().into_iter().map(|c| c.name).collect()
    }

    /// The class list of `scene`'s ground truth.
    pub fn scene_classes(&self, scene: &str) -> Result<ClassList> {
        ClassList::read(&self.ground_truth_dir(scene).join("embed_semseg_classes.json"))
    }
}
