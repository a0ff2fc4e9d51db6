//! A Drake/SceneSmith scene loaded and resolved: every visual of every model with its
//! pose in the Drake world, and what object (and class) it belongs to.

use std::collections::HashMap;
use std::path::{Path, PathBuf};

use osmab_evaluator::{InputError, Result};
use serde_json::Value;

use super::directives::{Directive, RelativePose, read_directives};
use super::sdf::{Model, UriResolver, Visual, normalize, read_sdf};
use super::transform::Pose;

/// The directive files SceneSmith writes, best first (stage-limited runs stop early).
pub const DIRECTIVE_FILES: &[&str] = &[
    "combined_house/house.dmd.yaml",
    "combined_house_after_ceiling/house.dmd.yaml",
    "combined_house_after_wall_objects/house.dmd.yaml",
    "combined_house_after_furniture/house.dmd.yaml",
];

/// What `house_state.json` says of one object.
#[derive(Debug, Clone, PartialEq)]
pub struct ObjectInfo {
    pub room: String,
    pub object_id: String,
    pub name: String,
    pub description: String,
    pub object_type: String,
}

/// One model instance of the scene.
#[derive(Debug, Clone)]
pub struct PlacedModel {
    /// Instance name in the directives.
    pub name: String,
    /// The SDF file.
    pub file: PathBuf,
    pub model: Model,
    /// Pose of the model frame in the Drake world.
    pub world: Pose,
    /// The `house_state.json` entry, when one matches.
    pub info: Option<ObjectInfo>,
}

impl PlacedModel {
    /// Drake-world pose of every visual.
    pub fn visuals(&self) -> impl Iterator<Item = (&Visual, Pose)> {
        self.model.links.iter().flat_map(move |link| link.visuals.iter().map(move |v| (v, self.world * link.pose_in_model * v.pose)))
    }
}

/// A loaded scene.
#[derive(Debug, Clone)]
pub struct DrakeScene {
    pub root: PathBuf,
    pub name: String,
    pub prompt: Option<String>,
    pub models: Vec<PlacedModel>,
    /// Wall height from the layout, when given.
    pub wall_height: Option<f64>,
}

/// `package.xml`'s package name (SceneSmith: `scene`).
fn package_name(root: &Path) -> Result<String> {
    let path = root.join("package.xml");
    let Ok(text) = std::fs::read_to_string(&path) else { return Ok("scene".into()) };
    let doc = roxmltree::Document::parse(&text).map_err(|e| InputError::new(&path, "(xml)", format!("not well-formed XML: {e}")))?;
    doc.descendants()
        .find(|n| n.has_tag_name("name"))
        .and_then(|n| n.text())
        .map(|t| t.trim().to_string())
        .ok_or_else(|| InputError::new(&path, "package.name", "missing <name>"))
}

/// Load the scene in `root`.
pub fn load_scene(root: &Path) -> Result<DrakeScene> {
    let root = normalize(&std::path::absolute(root).map_err(|e| InputError::io(root, &e))?);
    let dmd = DIRECTIVE_FILES
        .iter()
        .map(|f| root.join(f))
        .find(|p| p.exists())
        .ok_or_else(|| InputError::new(&root, "combined_house/house.dmd.yaml", "no model directives found (looked for combined_house*/house.dmd.yaml)"))?;
    let directives = read_directives(&dmd)?;
    let packages = HashMap::from([(package_name(&root)?, root.clone())]);
    let resolver = UriResolver { root: &root, packages: &packages };
    let dmd_dir = dmd.parent().expect("a file has a folder").to_path_buf();

    let mut frames: HashMap<String, RelativePose> = HashMap::new();
    let mut attachments: HashMap<String, (String, Pose, String)> = HashMap::new(); // model → (base link, pose, parent frame)
    let mut models = Vec::new();
    for (i, d) in directives.iter().enumerate() {
        match d {
            Directive::AddFrame { name, pose } => {
                if frames.insert(name.clone(), pose.clone()).is_some() {
                    return Err(InputError::new(&dmd, format!("directives[{i}].add_frame.name"), format!("frame '{name}' is defined twice")));
                }
            }
            Directive::AddModel { name, file, free_body } => {
                let sdf = resolver.resolve(file, &dmd_dir).map_err(|m| InputError::new(&dmd, format!("directives[{i}].add_model.file"), m))?;
                if !sdf.exists() {
                    return Err(InputError::new(
                        &dmd,
                        format!("directives[{i}].add_model.file"),
                        format!("'{file}' resolves to {}, which does not exist", sdf.display()),
                    ));
                }
                if models.iter().any(|(n, _, _)| n == name) {
                    return Err(InputError::new(&dmd, format!("directives[{i}].add_model.name"), format!("model '{name}' is added twice")));
                }
                let model = read_sdf(&sdf, &resolver)?;
                if let Some((body, pose)) = free_body {
                    if model.link(body).is_none() {
                        return Err(InputError::new(
                            &dmd,
                            format!("directives[{i}].add_model.default_free_body_pose"),
                            format!("model '{name}' has no link '{body}'"),
                        ));
                    }
                    attachments.insert(name.clone(), (body.clone(), pose.pose, pose.base_frame.clone().unwrap_or_else(|| "world".into())));
                }
                models.push((name.clone(), sdf, model));
            }
            Directive::AddWeld { parent, child, pose } => {
                let (model, link) = child
                    .split_once("::")
                    .ok_or_else(|| InputError::new(&dmd, format!("directives[{i}].add_weld.child"), format!("'{child}' is not a model::link frame")))?;
                if attachments.insert(model.to_string(), (link.to_string(), *pose, parent.clone())).is_some() {
                    return Err(InputError::new(&dmd, format!("directives[{i}].add_weld"), format!("model '{model}' is attached twice")));
                }
            }
        }
    }
    let by_name: HashMap<&str, &Model> = models.iter().map(|(n, _, m)| (n.as_str(), m)).collect();
    if let Some(unknown) = attachments.keys().find(|m| !by_name.contains_key(m.as_str())) {
        return Err(InputError::new(&dmd, "directives", format!("a weld attaches model '{unknown}', which no add_model adds")));
    }
    let resolver = FrameResolver { dmd: &dmd, frames: &frames, attachments: &attachments, models: &by_name };
    let (objects, prompt, wall_height) = read_house_state(&dmd_dir.join("house_state.json"))?;
    let mut placed = Vec::new();
    for (name, file, model) in &models {
        let world = resolver.model_pose(name, &mut Vec::new())?;
        let info = objects.iter().find(|o| model_name_matches(name, o)).cloned();
        placed.push(PlacedModel { name: name.clone(), file: file.clone(), model: model.clone(), world, info });
    }
    let name = root.file_name().and_then(|n| n.to_str()).unwrap_or("scene").to_string();
    Ok(DrakeScene { root, name, prompt, models: placed, wall_height })
}

/// SceneSmith names model instances `<room>_<object_id>` (or with the name-based
/// formula `<room>_<name_lower>_<suffix>`); members of stacks, filled containers and
/// piles add `_s<4>_<i>`, `_f<4>_<i>` or `_p<4>_<i>` and belong to that object.
fn model_name_matches(model: &str, info: &ObjectInfo) -> bool {
    let suffix: String = info.object_id.rsplit('_').next().unwrap_or("").chars().take(8).collect();
    let by_name = format!("{}_{}_{suffix}", info.room, info.name.to_lowercase().replace(' ', "_"));
    let by_id = format!("{}_{}", info.room, info.object_id);
    let member_of = |base: &str| {
        model.strip_prefix(base).and_then(|rest| rest.strip_prefix('_')).is_some_and(|rest| {
            let mut parts = rest.splitn(2, '_');
            let (tag, index) = (parts.next().unwrap_or(""), parts.next().unwrap_or(""));
            tag.len() == 5 && matches!(tag.as_bytes()[0], b's' | b'f' | b'p') && !index.is_empty() && index.chars().all(|c| c.is_ascii_digit())
        })
    };
    model == by_id || model == by_name || member_of(&by_id) || member_of(&by_name)
}

type HouseState = (Vec<ObjectInfo>, Option<String>, Option<f64>);

fn read_house_state(path: &Path) -> Result<HouseState> {
    if !path.exists() {
        return Ok((Vec::new(), None, None));
    }
    let text = std::fs::read(path).map_err(|e| InputError::io(path, &e))?;
    let json: Value = serde_json::from_slice(&text).map_err(|e| InputError::new(path, "(json)", format!("not valid JSON: {e}")))?;
    let mut objects = Vec::new();
    for (room, entry) in json["rooms"].as_object().into_iter().flatten() {
        for (object_id, o) in entry["objects"].as_object().into_iter().flatten() {
            let text = |k: &str| o[k].as_str().unwrap_or_default().to_string();
            // A category given by the synthesizer (osmab's) names the class better than prose.
            let name = o["metadata"]["category"].as_str().map(str::to_string).unwrap_or_else(|| text("name"));
            objects.push(ObjectInfo {
                room: room.clone(),
                object_id: object_id.clone(),
                name,
                description: text("description"),
                object_type: text("object_type"),
            });
        }
    }
    let prompt = json["layout"]["house_prompt"].as_str().map(str::to_string);
    Ok((objects, prompt, json["layout"]["wall_height"].as_f64()))
}

struct FrameResolver<'a> {
    dmd: &'a Path,
    frames: &'a HashMap<String, RelativePose>,
    attachments: &'a HashMap<String, (String, Pose, String)>,
    models: &'a HashMap<&'a str, &'a Model>,
}

impl FrameResolver<'_> {
    fn cycle(&self, visiting: &[String], frame: &str) -> InputError {
        InputError::new(self.dmd, "directives", format!("frames form a cycle: {} -> {frame}", visiting.join(" -> ")))
    }

    /// World pose of a named frame.
    fn frame_pose(&self, frame: &str, visiting: &mut Vec<String>) -> Result<Pose> {
        if frame == "world" {
            return Ok(Pose::identity());
        }
        if visiting.iter().any(|f| f == frame) {
            return Err(self.cycle(visiting, frame));
        }
        visiting.push(frame.to_string());
        let pose = if let Some(def) = self.frames.get(frame) {
            self.frame_pose(def.base_frame.as_deref().unwrap_or("world"), visiting)? * def.pose
        } else if let Some((model, link)) = frame.split_once("::") {
            let m = self.models.get(model).ok_or_else(|| InputError::new(self.dmd, "directives", format!("frame '{frame}' names unknown model '{model}'")))?;
            let model_pose = self.model_pose(model, visiting)?;
            if link == "__model__" {
                model_pose
            } else {
                let l =
                    m.link(link).ok_or_else(|| InputError::new(self.dmd, "directives", format!("frame '{frame}': model '{model}' has no link '{link}'")))?;
                model_pose * l.pose_in_model
            }
        } else {
            return Err(InputError::new(self.dmd, "directives", format!("unknown frame '{frame}' (not world, an add_frame or a model::link)")));
        };
        visiting.pop();
        Ok(pose)
    }

    /// World pose of a model's frame: from its weld or free-body pose, else the world.
    fn model_pose(&self, model: &str, visiting: &mut Vec<String>) -> Result<Pose> {
        let Some((link, pose, parent)) = self.attachments.get(model) else { return Ok(Pose::identity()) };
        let key = format!("{model}::(attachment)");
        if visiting.contains(&key) {
            return Err(self.cycle(visiting, model));
        }
        visiting.push(key);
        let attached_world = self.frame_pose(parent, visiting)? * pose;
        visiting.pop();
        if link == "__model__" {
            return Ok(attached_world);
        }
        let m = self.models.get(model).ok_or_else(|| InputError::new(self.dmd, "directives", format!("a weld names unknown model '{model}'")))?;
        let l = m.link(link).ok_or_else(|| InputError::new(self.dmd, "directives", format!("model '{model}' has no link '{link}'")))?;
        Ok(attached_world * l.pose_in_model.inverse())
    }
}
