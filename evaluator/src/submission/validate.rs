//! Checking an unpacked submission against a release before anything is scored: every
//! problem is reported at once, each naming the file (relative to the submission), the
//! field and what was expected.
//!
//! One file, over 400 lines, on purpose: one pass over the submission tree applies every
//! rule of the format in the order files are met, which is what reports every problem at once.

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use serde_json::Value;

use super::SUBMISSION_FORMAT;
use super::archive::list_tree;
use super::extents::{Extent, ground_truth_extent};
use super::release::ReleaseIndex;
use crate::error::InputError;
use crate::formats::map::{MapSemantics, PredictedMap, TextFeatures};
use crate::formats::npy::ReadLimits;

/// At most this many problems are reported (the rest are counted).
pub const MAX_REPORTED_PROBLEMS: usize = 50;

/// Size limits on what one submission may hold.
#[derive(Debug, Clone, Copy)]
pub struct SubmissionLimits {
    /// Limits on each `.npz`.
    pub arrays: ReadLimits,
    /// Largest scene graph or answers JSON file.
    pub max_json_bytes: u64,
}

impl Default for SubmissionLimits {
    fn default() -> Self {
        // 4 GiB of arrays a map holds ~100 M points with their ids and 10,000 objects of
        // 1024-dimensional features; the service validates two uploads at a time.
        Self { arrays: ReadLimits { max_array_bytes: 2 << 30, max_archive_bytes: 4 << 30, max_points: u64::MAX }, max_json_bytes: 64 << 20 }
    }
}

impl SubmissionLimits {
    /// The limits for a submission to `release` whose unpacked files may take
    /// `max_unpacked_bytes`: a map's arrays, once read, count against the same budget (a
    /// compressed `.npz` unpacks far beyond its size on disk), and a map holds at most
    /// one point per pixel of its scene's sequence. Validation then holds at most one
    /// map's arrays — under `max_unpacked_bytes` — at a time.
    pub fn for_release(release: &ReleaseIndex, max_unpacked_bytes: u64) -> Self {
        let default = Self::default();
        let budget = max_unpacked_bytes.min(default.arrays.max_archive_bytes);
        Self {
            arrays: ReadLimits { max_array_bytes: budget.min(default.arrays.max_array_bytes), max_archive_bytes: budget, max_points: release.max_map_points() },
            max_json_bytes: default.max_json_bytes.min(max_unpacked_bytes),
        }
    }
}

/// The method card of `submission.json`.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize, schemars::JsonSchema)]
pub struct MethodCard {
    /// Method name as shown on the leaderboard.
    pub name: String,
    /// What the method is and how it was run.
    #[serde(default)]
    pub description: String,
    /// Paper link.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub paper_url: Option<String>,
    /// Code link.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub code_url: Option<String>,
    /// Data used beyond the release (datasets, pretrained models), in words.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub external_data: Option<String>,
    /// Compute used (hardware, hours), in words.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub compute: Option<String>,
    /// Shown as "Anonymous" on the leaderboard (no team, no links) until the team reveals it.
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub anonymous: bool,
}

impl MethodCard {
    /// Check lengths and links; `file` names the source in messages.
    pub fn check(&self, file: &str) -> Result<(), InputError> {
        if let Some(problem) = crate::text::display_name_problem(self.name.trim(), 80) {
            return Err(InputError::new(file, "method.name", problem));
        }
        if self.description.chars().count() > 4000 {
            return Err(InputError::new(file, "method.description", "expected at most 4000 characters"));
        }
        if let Some(c) = crate::text::first_hidden_format(&self.description) {
            return Err(InputError::new(
                file,
                "method.description",
                format!("expected visible text, found U+{:04X} (an invisible formatting character)", c as u32),
            ));
        }
        for (field, text) in [("method.external_data", &self.external_data), ("method.compute", &self.compute)] {
            if let Some(text) = text {
                if text.chars().count() > 1000 {
                    return Err(InputError::new(file, field, "expected at most 1000 characters"));
                }
                if let Some(c) = crate::text::first_hidden_format(text) {
                    return Err(InputError::new(file, field, format!("expected visible text, found U+{:04X} (an invisible formatting character)", c as u32)));
                }
            }
        }
        for (field, url) in [("method.paper_url", &self.paper_url), ("method.code_url", &self.code_url)] {
            if let Some(url) = url
                && (!(url.starts_with("https://") || url.starts_with("http://"))
                    || url.len() > 500
                    || url.chars().any(|c| c.is_whitespace() || crate::text::is_invisible(c)))
            {
                return Err(InputError::new(file, field, format!("expected an http(s) link of at most 500 characters, found '{url}'")));
            }
        }
        Ok(())
    }
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct SubmissionFile {
    format: String,
    release: String,
    method: MethodCard,
}

/// One (lighting, scene) a submission covers.
#[derive(Debug, Clone, PartialEq, Eq, Serialize)]
pub struct SceneEntry {
    /// Lighting label.
    pub lighting: crate::scores::Lighting,
    /// Scene id.
    pub scene: String,
    /// `maps/<lighting>/<scene>.npz`, when present.
    pub map: Option<PathBuf>,
    /// `graphs/<lighting>/<scene>.json`, when present.
    pub graph: Option<PathBuf>,
    /// `answers/<lighting>/<scene>.json`, when present.
    pub answers: Option<PathBuf>,
}

/// A submission that passed every check.
#[derive(Debug, Clone, Serialize)]
pub struct ValidSubmission {
    /// The unpacked submission.
    #[serde(skip)]
    pub root: PathBuf,
    /// The release it is for.
    pub release: String,
    /// Its method card.
    pub method: MethodCard,
    /// `text_features.npz`, when present.
    #[serde(skip)]
    pub text_features: Option<PathBuf>,
    /// What it covers, by lighting then scene.
    pub entries: Vec<SceneEntry>,
    /// Every (lighting, scene) of the release has a map.
    pub complete: bool,
    /// `lighting/scene` pairs without a map.
    pub missing_maps: Vec<String>,
    /// Files for scenes of the release's other split, ignored (a submission to one
    /// split may carry a whole release's maps).
    pub outside_split: Vec<String>,
    /// Points read over all maps.
    pub points: u64,
}

fn relative(root: &Path, mut error: InputError) -> InputError {
    let prefix = format!("{}/", root.display());
    if let Some(rest) = error.file.strip_prefix(&prefix) {
        error.file = rest.to_string();
    }
    error
}

/// Files that archivers add and that carry nothing (macOS resource forks, Finder data).
fn is_archiver_noise(path: &str) -> bool {
    path.starts_with("__MACOSX/") || path.rsplit('/').next().is_some_and(|name| name == ".DS_Store" || name.starts_with("._"))
}

/// Where an archive's content really starts: an archive of a folder holds `folder/…`.
fn submission_root(root: &Path) -> PathBuf {
    if root.join("submission.json").is_file() {
        return root.to_path_buf();
    }
    let entries: Vec<PathBuf> = std::fs::read_dir(root)
        .map(|d| d.filter_map(|e| e.ok()).map(|e| e.path()).filter(|p| !is_archiver_noise(&p.file_name().unwrap_or_default().to_string_lossy())).collect())
        .unwrap_or_default();
    match entries.as_slice() {
        [only] if only.is_dir() && only.join("submission.json").is_file() => only.clone(),
        _ => root.to_path_buf(),
    }
}

/// The JSON of a scene graph or answers file, size-checked.
fn read_json(path: &Path, name: &str, limits: SubmissionLimits) -> Result<Value, InputError> {
    let size = std::fs::metadata(path).map_err(|e| InputError::io(name, &e))?.len();
    if size > limits.max_json_bytes {
        return Err(InputError::new(name, "(file)", format!("{size} bytes is more than the {} allowed for a JSON file", limits.max_json_bytes)));
    }
    let bytes = std::fs::read(path).map_err(|e| InputError::io(name, &e))?;
    serde_json::from_slice(&bytes).map_err(|e| InputError::new(name, "(json)", format!("not valid JSON: {e}")))
}

/// A scene graph: `{"objects": [...], "edges"?: [...]}` or a bare node list (ConceptGraphs,
/// BBQ); node features need text_features.npz in the same space.
fn check_graph(value: &Value, name: &str, text: Option<&TextFeatures>) -> Result<(), InputError> {
    let graph = crate::vqa::graph::SceneGraph::parse(value, name)?;
    for (i, node) in graph.objects.iter().enumerate() {
        let Some(features) = &node.features else { continue };
        match text {
            None => {
                return Err(InputError::new(
                    name,
                    format!("objects[{i}].features"),
                    "nodes carry features, so the submission needs text_features.npz in the same space",
                ));
            }
            Some(t) if t.features.dim != features.len() => {
                return Err(InputError::new(
                    name,
                    format!("objects[{i}].features"),
                    format!("{} dimensions but text_features.npz has {}; they must share one space", features.len(), t.features.dim),
                ));
            }
            Some(_) => {}
        }
    }
    Ok(())
}

/// Answers: `[{"question_id", "answer"}]` with unique ids, each a question of the scene
/// when the release lists them (`known`).
fn check_answers(value: &Value, name: &str, scene: &str, known: Option<&BTreeSet<String>>) -> Result<(), InputError> {
    let Some(list) = value.as_array() else {
        return Err(InputError::new(name, "(json)", "expected a list of {\"question_id\": str, \"answer\": str}"));
    };
    let mut seen = BTreeSet::new();
    for (i, item) in list.iter().enumerate() {
        let id = item.get("question_id").and_then(Value::as_str);
        let answer = item.get("answer");
        match (id, answer) {
            (Some(id), Some(Value::String(_) | Value::Number(_) | Value::Bool(_))) => {
                if !seen.insert(id.to_string()) {
                    return Err(InputError::new(name, format!("[{i}].question_id"), format!("question '{id}' is answered twice")));
                }
                if known.is_some_and(|ids| !ids.contains(id)) {
                    return Err(InputError::new(
                        name,
                        format!("[{i}].question_id"),
                        format!("'{id}' is not a question of {scene}; the release lists them in questions/{scene}.json"),
                    ));
                }
            }
            _ => return Err(InputError::new(name, format!("[{i}]"), "expected {\"question_id\": str, \"answer\": str}")),
        }
    }
    Ok(())
}

/// A map in another frame than the release (say, relative to the first camera) overlaps
/// the scene's ground-truth box `(lo, hi)` only by accident: refuse it with that explanation.
fn check_frame(map: &PredictedMap, (lo, hi): Extent, name: &str) -> Result<(), InputError> {
    let margin = 0.5;
    let inside = map.points.iter().filter(|p| (0..3).all(|a| p[a] >= lo[a] - margin && p[a] <= hi[a] + margin)).count();
    if (inside as f64) < 0.5 * map.points.len() as f64 {
        return Err(InputError::new(
            name,
            "points",
            format!(
                "only {:.0}% of the points lie within 0.5 m of the scene's extent ({:.2?} to {:.2?}); the map looks like it is in another frame — points must be in the release's world frame (the frame of traj.txt)",
                100.0 * inside as f64 / map.points.len() as f64,
                lo,
                hi
            ),
        ));
    }
    Ok(())
}

/// Files checked at once. A map is read whole to be checked, so this bounds validation's
/// memory to that of two maps, whatever the cores (scoring holds one map and its index).
const FILES_AT_ONCE: usize = 2;

/// Check the unpacked submission in `unpacked` against `release`; on failure, every
/// problem found (at most [`MAX_REPORTED_PROBLEMS`], then a count of the rest).
pub fn validate(unpacked: &Path, release: &ReleaseIndex, limits: SubmissionLimits) -> Result<ValidSubmission, Vec<InputError>> {
    let root = submission_root(unpacked);
    let files = list_tree(&root).map_err(|e| vec![relative(&root, e)])?;
    let mut problems: Vec<InputError> = Vec::new();
    let card = read_card(&root, release, limits, &mut problems);
    let text = read_text_features(&root, release, limits, &mut problems);
    let mut found = Found::default();
    // Each file is placed and recorded in order, then checked [`FILES_AT_ONCE`] at a time,
    // its problems kept in the files' order.
    let mut to_check = Vec::new();
    for name in &files {
        if is_archiver_noise(name) || name == "submission.json" || name == "text_features.npz" {
            continue;
        }
        match place(name, release) {
            Placed::Ignored => {}
            Placed::OtherSplit => found.outside_split.push(name.clone()),
            Placed::Refused(problem) => to_check.push(Err(problem)),
            Placed::File { kind, lighting, scene } => {
                found.record(&root.join(name), kind, lighting, &scene, release);
                to_check.push(Ok((name, kind, lighting, scene)));
            }
        }
    }
    let map_scenes: BTreeSet<&str> = to_check.iter().filter_map(|file| file.as_ref().ok()).filter(|file| file.1 == FileKind::Map).map(|file| file.3).collect();
    let extents: BTreeMap<&str, Option<Extent>> = map_scenes.into_iter().map(|scene| (scene, ground_truth_extent(release, scene))).collect();
    let against = Against { root: &root, release, text: text.as_ref(), limits, extents: &extents };
    let check = |file: Result<(&String, FileKind, crate::scores::Lighting, &str), InputError>| match file {
        Err(problem) => (0, vec![problem]),
        Ok((name, kind, lighting, scene)) => check_file(&against, name, kind, lighting, scene),
    };
    let checked: Vec<(u64, Vec<InputError>)> = match rayon::ThreadPoolBuilder::new().num_threads(FILES_AT_ONCE).build() {
        Ok(pool) => pool.install(|| to_check.into_par_iter().map(|file| check(file)).collect()),
        Err(_) => to_check.into_iter().map(|file| check(file)).collect(),
    };
    for (points, file_problems) in checked {
        found.points += points;
        problems.extend(file_problems);
    }
    if found.entries.values().all(|e| e.map.is_none() && e.graph.is_none()) && problems.is_empty() {
        problems.push(nothing_to_score(release, &found.outside_split));
    }
    if !problems.is_empty() {
        return Err(capped(problems));
    }
    let card = card.expect("no problems means submission.json was read");
    let missing_maps = missing_maps(release, &found.entries);
    Ok(ValidSubmission {
        root: root.clone(),
        release: card.release,
        method: card.method,
        text_features: text.map(|t| t.source),
        complete: missing_maps.is_empty(),
        missing_maps,
        outside_split: found.outside_split,
        entries: found.entries.into_values().collect(),
        points: found.points,
    })
}

/// `submission.json`, checked against the release it is validated for; its problems go to
/// `problems`.
fn read_card(root: &Path, release: &ReleaseIndex, limits: SubmissionLimits, problems: &mut Vec<InputError>) -> Option<SubmissionFile> {
    let value = match read_json(&root.join("submission.json"), "submission.json", limits) {
        Ok(value) => value,
        Err(_) if !root.join("submission.json").is_file() => {
            problems.push(InputError::new(
                "submission.json",
                "(file)",
                format!("missing: every submission starts with submission.json ({{\"format\": \"{SUBMISSION_FORMAT}\", \"release\", \"method\"}})"),
            ));
            return None;
        }
        Err(e) => {
            problems.push(e);
            return None;
        }
    };
    let file = match serde_json::from_value::<SubmissionFile>(value) {
        Ok(file) => file,
        Err(e) => {
            problems.push(InputError::new(
                "submission.json",
                "(json)",
                format!("expected {{\"format\", \"release\", \"method\": {{\"name\", \"description\", \"paper_url\"?, \"code_url\"?}}}}: {e}"),
            ));
            return None;
        }
    };
    if file.format != SUBMISSION_FORMAT {
        problems.push(InputError::new("submission.json", "format", format!("expected \"{SUBMISSION_FORMAT}\", found \"{}\"", file.format)));
    }
    if file.release != release.version {
        problems.push(InputError::new(
            "submission.json",
            "release",
            format!("this submission is for release '{}', but it is being checked against release '{}'", file.release, release.version),
        ));
    }
    if let Err(e) = file.method.check("submission.json") {
        problems.push(e);
    }
    Some(file)
}

/// `text_features.npz`, when there is one, with class ids of the release.
fn read_text_features(root: &Path, release: &ReleaseIndex, limits: SubmissionLimits, problems: &mut Vec<InputError>) -> Option<TextFeatures> {
    let path = root.join("text_features.npz");
    if !path.is_file() {
        return None;
    }
    match TextFeatures::read(&path, limits.arrays) {
        Ok(t) => {
            if let Some(id) = t.class_ids.iter().find(|id| !release.classes.contains(**id)) {
                problems.push(InputError::new("text_features.npz", "class_ids", format!("class id {id} is not a class of the release (classes.json)")));
            }
            Some(t)
        }
        Err(e) => {
            problems.push(relative(root, e));
            None
        }
    }
}

/// The kinds of file a submission holds per (lighting, scene).
#[derive(Debug, Clone, Copy, PartialEq)]
enum FileKind {
    Map,
    Graph,
    Answers,
}

/// Where a file of the submission belongs.
enum Placed<'a> {
    /// A README or LICENSE at the top.
    Ignored,
    /// A file for a scene of the release's other split.
    OtherSplit,
    Refused(InputError),
    File {
        kind: FileKind,
        lighting: crate::scores::Lighting,
        scene: &'a str,
    },
}

/// Where `name` belongs: `maps/<lighting>/<scene>.npz`, `graphs/…​.json` or `answers/…​.json`
/// of a lighting and scene of the release.
fn place<'a>(name: &'a str, release: &ReleaseIndex) -> Placed<'a> {
    let parts: Vec<&str> = name.split('/').collect();
    let (kind, folder, extension) = match parts.first().copied() {
        Some("maps") => (FileKind::Map, "maps", "npz"),
        Some("graphs") => (FileKind::Graph, "graphs", "json"),
        Some("answers") => (FileKind::Answers, "answers", "json"),
        _ if parts.len() == 1 && (name.to_ascii_lowercase().starts_with("readme") || name.to_ascii_lowercase().starts_with("license")) => {
            return Placed::Ignored;
        }
        _ => {
            return Placed::Refused(InputError::new(
                name,
                "(file)",
                "unexpected file; a submission holds submission.json, text_features.npz, maps/, graphs/ and answers/",
            ));
        }
    };
    let Some(scene) = (parts.len() == 3).then(|| parts[2].strip_suffix(&format!(".{extension}"))).flatten() else {
        return Placed::Refused(InputError::new(name, "(path)", format!("expected {folder}/<lighting>/<scene>.{extension}")));
    };
    let Some(lighting) = release.lightings.iter().copied().find(|l| l.name() == parts[1]) else {
        let known: Vec<&str> = release.lightings.iter().map(|l| l.name()).collect();
        return Placed::Refused(InputError::new(
            name,
            "(path)",
            format!("unknown lighting '{}'; release {} has {}", parts[1], release.version, known.join(", ")),
        ));
    };
    if release.outside_split.iter().any(|s| s == scene) {
        return Placed::OtherSplit;
    }
    if release.scene(scene).is_none() {
        let known: Vec<&str> = release.scenes.iter().map(|s| s.id.as_str()).collect();
        let of = release.split.map_or(String::new(), |split| format!(" (split {split})"));
        return Placed::Refused(InputError::new(name, "(path)", format!("unknown scene '{scene}'; release {}{of} has {}", release.version, known.join(", "))));
    }
    Placed::File { kind, lighting, scene }
}

/// What a submission's files are checked against.
struct Against<'a> {
    root: &'a Path,
    release: &'a ReleaseIndex,
    text: Option<&'a TextFeatures>,
    limits: SubmissionLimits,
    /// Each mapped scene's ground-truth extent, read once.
    extents: &'a BTreeMap<&'a str, Option<Extent>>,
}

/// What the files of a submission hold so far.
#[derive(Default)]
struct Found {
    entries: BTreeMap<(crate::scores::Lighting, String), SceneEntry>,
    points: u64,
    outside_split: Vec<String>,
}

impl Found {
    /// Record the file at `path` of `kind` for (`lighting`, `scene`): answers for a test
    /// scene are refused when checked, and recorded as no file.
    fn record(&mut self, path: &Path, kind: FileKind, lighting: crate::scores::Lighting, scene: &str, release: &ReleaseIndex) {
        let entry = self.entries.entry((lighting, scene.to_string())).or_insert_with(|| SceneEntry {
            lighting,
            scene: scene.to_string(),
            map: None,
            graph: None,
            answers: None,
        });
        match kind {
            FileKind::Map => entry.map = Some(path.to_path_buf()),
            FileKind::Graph => entry.graph = Some(path.to_path_buf()),
            FileKind::Answers if is_test_scene(release, scene) => {}
            FileKind::Answers => entry.answers = Some(path.to_path_buf()),
        }
    }
}

fn is_test_scene(release: &ReleaseIndex, scene: &str) -> bool {
    release.scene(scene).is_some_and(|s| s.split == crate::scores::Split::Test)
}

/// Check the file `name` of `kind` for (`lighting`, `scene`): the points it holds (a map's)
/// and its problems.
fn check_file(against: &Against<'_>, name: &str, kind: FileKind, lighting: crate::scores::Lighting, scene: &str) -> (u64, Vec<InputError>) {
    let Against { root, release, text, limits, extents } = *against;
    let path = root.join(name);
    match kind {
        FileKind::Map => {
            let map = match PredictedMap::read(&path, limits.arrays) {
                Ok(map) => map,
                Err(e) => return (0, vec![relative(root, e)]),
            };
            let extent = extents.get(scene).copied().flatten();
            let semantics = check_semantics(&map, release, text, name).err();
            let frame = extent.and_then(|extent| check_frame(&map, extent, name).err());
            (map.points.len() as u64, semantics.into_iter().chain(frame).collect())
        }
        FileKind::Graph => (0, read_json(&path, name, limits).and_then(|v| check_graph(&v, name, text)).err().into_iter().collect()),
        FileKind::Answers if is_test_scene(release, scene) => (
            0,
            vec![InputError::new(
                name,
                "(file)",
                format!(
                    "{scene} is a test scene: its questions are hidden and the server answers them from your scene graph (graphs/{lighting}/{scene}.json); answers/ is for val scenes only"
                ),
            )],
        ),
        FileKind::Answers => {
            let known = release
                .public_questions(scene)
                .ok()
                .flatten()
                .or_else(|| release.answered_questions(scene).ok().flatten())
                .map(|questions| questions.questions.into_iter().map(|q| q.id).collect::<BTreeSet<String>>());
            (0, read_json(&path, name, limits).and_then(|v| check_answers(&v, name, scene, known.as_ref())).err().into_iter().collect())
        }
    }
}

/// The problem of a submission with no map and no scene graph: when its files are all for
/// the other split's scenes, which split they are for and how to choose it.
fn nothing_to_score(release: &ReleaseIndex, outside_split: &[String]) -> InputError {
    let message = match (release.split, outside_split.first()) {
        (Some(split), Some(example)) => {
            let other = if split == crate::scores::Split::Test { crate::scores::Split::Val } else { crate::scores::Split::Test };
            format!(
                "the submission has no maps and no scene graphs for the {split} split: its {} files are for {other} scenes (e.g. {example}); \
                 submit or validate them for the {other} split (`--split {other}`, or `?split={other}` in the API)",
                outside_split.len()
            )
        }
        _ => "the submission has no maps and no scene graphs; expected maps/<lighting>/<scene>.npz".to_string(),
    };
    InputError::new("maps/", "(folder)", message)
}

/// At most [`MAX_REPORTED_PROBLEMS`] problems, and a last one saying how many more there were.
fn capped(mut problems: Vec<InputError>) -> Vec<InputError> {
    if problems.len() > MAX_REPORTED_PROBLEMS {
        let more = problems.len() - MAX_REPORTED_PROBLEMS;
        problems.truncate(MAX_REPORTED_PROBLEMS);
        problems.push(InputError::new("(submission)", "(problems)", format!("{more} more problems not listed")));
    }
    problems
}

/// `<lighting>/<scene>` of every sequence of the release the submission has no map for.
fn missing_maps(release: &ReleaseIndex, entries: &BTreeMap<(crate::scores::Lighting, String), SceneEntry>) -> Vec<String> {
    release
        .lightings
        .iter()
        .flat_map(|l| release.scenes.iter().map(move |s| (l, s)))
        .filter(|(l, s)| !entries.get(&(**l, s.id.clone())).is_some_and(|e| e.map.is_some()))
        .map(|(l, s)| format!("{l}/{}", s.id))
        .collect()
}

/// Labels must be release classes; features need text features of the same dimension.
fn check_semantics(map: &PredictedMap, release: &ReleaseIndex, text: Option<&TextFeatures>, name: &str) -> Result<(), InputError> {
    let needs_text = |dim: usize, field: &str| match text {
        None => {
            Err(InputError::new(name, field, "the map carries features, so the submission needs text_features.npz (class_ids, features) in the same space"))
        }
        Some(t) if t.features.dim != dim => {
            Err(InputError::new(name, field, format!("features have {dim} dimensions but text_features.npz has {}; they must share one space", t.features.dim)))
        }
        Some(_) => Ok(()),
    };
    match &map.semantics {
        MapSemantics::ObjectLabels { labels, .. } => match labels.iter().position(|l| !release.classes.contains(*l)) {
            Some(i) => {
                Err(InputError::new(name, "labels", format!("object {i} has label {}, which is not a class id of the release (classes.json)", labels[i])))
            }
            None => Ok(()),
        },
        MapSemantics::ObjectFeatures { features, .. } => needs_text(features.dim, "features"),
        MapSemantics::PointFeatures(features) => needs_text(features.dim, "point_features"),
    }
}
