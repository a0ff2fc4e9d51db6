//! Drake model directives (`house.dmd.yaml`): frames, models with free-body poses, and
//! welds, with the `!Identity`, `!Rpy` and `!AngleAxis` rotation tags.

use std::path::Path;

use nalgebra::{Unit, UnitQuaternion, Vector3};
use osmab_evaluator::{InputError, Result};
use serde_yaml_ng::Value;

use super::transform::{Pose, pose, rpy};

/// A pose relative to a named frame.
#[derive(Debug, Clone, PartialEq)]
pub struct RelativePose {
    /// The frame it is relative to (`world`, `room_main_frame`, `model::link`).
    pub base_frame: Option<String>,
    /// The pose in that frame.
    pub pose: Pose,
}

/// One directive.
#[derive(Debug, Clone, PartialEq)]
pub enum Directive {
    /// `add_frame`: a named frame at a pose in its base frame.
    AddFrame { name: String, pose: RelativePose },
    /// `add_model`: a model instance from an SDF file, optionally with a free-body pose.
    AddModel { name: String, file: String, free_body: Option<(String, RelativePose)> },
    /// `add_weld`: `child` fixed to `parent` at `pose`.
    AddWeld { parent: String, child: String, pose: Pose },
}

/// Parse a directives file.
pub fn read_directives(path: &Path) -> Result<Vec<Directive>> {
    let text = std::fs::read_to_string(path).map_err(|e| InputError::io(path, &e))?;
    let root: Value = serde_yaml_ng::from_str(&text).map_err(|e| InputError::new(path, "(yaml)", format!("not valid YAML: {e}")))?;
    let list =
        root.get("directives").and_then(Value::as_sequence).ok_or_else(|| InputError::new(path, "directives", "expected a top-level 'directives' list"))?;
    list.iter().enumerate().map(|(i, item)| parse_directive(item, path, &format!("directives[{i}]"))).collect()
}

fn parse_directive(item: &Value, path: &Path, field: &str) -> Result<Directive> {
    let map = item.as_mapping().filter(|m| m.len() == 1).ok_or_else(|| InputError::new(path, field, "each directive is a mapping with exactly one key"))?;
    let (key, body) = map.iter().next().expect("one entry");
    let key = key.as_str().unwrap_or_default();
    let field = format!("{field}.{key}");
    let string = |name: &str| -> Result<String> {
        body.get(name).and_then(Value::as_str).map(str::to_string).ok_or_else(|| InputError::new(path, format!("{field}.{name}"), "expected a string"))
    };
    match key {
        "add_frame" => {
            let x_pf = body.get("X_PF").ok_or_else(|| InputError::new(path, format!("{field}.X_PF"), "missing"))?;
            let pose = parse_transform(x_pf, path, &format!("{field}.X_PF"))?;
            if pose.base_frame.is_none() {
                return Err(InputError::new(path, format!("{field}.X_PF.base_frame"), "add_frame needs a base_frame"));
            }
            Ok(Directive::AddFrame { name: string("name")?, pose })
        }
        "add_model" => {
            let free_body = match body.get("default_free_body_pose") {
                None => None,
                Some(v) => {
                    let m = v
                        .as_mapping()
                        .filter(|m| m.len() == 1)
                        .ok_or_else(|| InputError::new(path, format!("{field}.default_free_body_pose"), "expected one body name mapped to its pose"))?;
                    let (body_name, transform) = m.iter().next().expect("one entry");
                    let body_name = body_name.as_str().unwrap_or_default().to_string();
                    Some((body_name.clone(), parse_transform(transform, path, &format!("{field}.default_free_body_pose.{body_name}"))?))
                }
            };
            Ok(Directive::AddModel { name: string("name")?, file: string("file")?, free_body })
        }
        "add_weld" => {
            let pose = match body.get("X_PC") {
                Some(v) => {
                    let t = parse_transform(v, path, &format!("{field}.X_PC"))?;
                    if t.base_frame.is_some() {
                        return Err(InputError::new(
                            path,
                            format!("{field}.X_PC.base_frame"),
                            "a weld's X_PC has no base_frame (it is relative to the parent)",
                        ));
                    }
                    t.pose
                }
                None => Pose::identity(),
            };
            Ok(Directive::AddWeld { parent: string("parent")?, child: string("child")?, pose })
        }
        "add_model_instance" | "add_collision_filter_group" => Err(InputError::new(path, field, format!("'{key}' is not supported by the converter"))),
        "add_directives" => Err(InputError::new(path, field, "nested directive files (add_directives) are not supported; flatten them first")),
        other => Err(InputError::new(path, field, format!("unknown directive '{other}' (expected add_frame, add_model or add_weld)"))),
    }
}

fn numbers(value: &Value, path: &Path, field: &str, n: usize) -> Result<Vec<f64>> {
    let list = value.as_sequence().ok_or_else(|| InputError::new(path, field, format!("expected a list of {n} numbers")))?;
    let values: Option<Vec<f64>> = list.iter().map(Value::as_f64).collect();
    match values {
        Some(v) if v.len() == n && v.iter().all(|x| x.is_finite()) => Ok(v),
        _ => Err(InputError::new(path, field, format!("expected a list of {n} finite numbers"))),
    }
}

/// Drake's `Transform` schema.
fn parse_transform(value: &Value, path: &Path, field: &str) -> Result<RelativePose> {
    let map = value.as_mapping().ok_or_else(|| InputError::new(path, field, "expected a transform mapping"))?;
    for key in map.keys() {
        let k = key.as_str().unwrap_or_default();
        if !matches!(k, "base_frame" | "translation" | "rotation") {
            return Err(InputError::new(path, format!("{field}.{k}"), "unknown key (expected base_frame, translation, rotation)"));
        }
    }
    let base_frame = match value.get("base_frame") {
        Some(v) => Some(v.as_str().ok_or_else(|| InputError::new(path, format!("{field}.base_frame"), "expected a frame name"))?.to_string()),
        None => None,
    };
    let translation = match value.get("translation") {
        Some(v) => numbers(v, path, &format!("{field}.translation"), 3)?,
        None => vec![0.0; 3],
    };
    let rotation = match value.get("rotation") {
        Some(v) => parse_rotation(v, path, &format!("{field}.rotation"))?,
        None => UnitQuaternion::identity(),
    };
    Ok(RelativePose { base_frame, pose: pose([translation[0], translation[1], translation[2]], rotation) })
}

fn parse_rotation(value: &Value, path: &Path, field: &str) -> Result<UnitQuaternion<f64>> {
    let (tag, body) = match value {
        Value::Tagged(tagged) => (Some(tagged.tag.to_string()), &tagged.value),
        other => (None, other),
    };
    let has = |k: &str| body.get(k).is_some();
    let kind = match tag.as_deref() {
        Some("!Identity") => "identity",
        Some("!Rpy") => "rpy",
        Some("!AngleAxis") => "angle_axis",
        Some(other) => return Err(InputError::new(path, field, format!("unknown rotation tag '{other}' (expected !Identity, !Rpy or !AngleAxis)"))),
        None if has("deg") => "rpy",
        None if has("angle_deg") => "angle_axis",
        None if body.as_mapping().is_some_and(|m| m.is_empty()) || body.is_null() => "identity",
        None => return Err(InputError::new(path, field, "expected !Identity {}, !Rpy {deg: [r, p, y]} or !AngleAxis {angle_deg, axis}")),
    };
    match kind {
        "identity" => Ok(UnitQuaternion::identity()),
        "rpy" => {
            let deg = numbers(body.get("deg").unwrap_or(&Value::Null), path, &format!("{field}.deg"), 3)?;
            Ok(rpy(deg[0].to_radians(), deg[1].to_radians(), deg[2].to_radians()))
        }
        _ => {
            let angle = body
                .get("angle_deg")
                .and_then(Value::as_f64)
                .filter(|a| a.is_finite())
                .ok_or_else(|| InputError::new(path, format!("{field}.angle_deg"), "expected a finite number"))?;
            let axis = numbers(body.get("axis").unwrap_or(&Value::Null), path, &format!("{field}.axis"), 3)?;
            let axis = Vector3::new(axis[0], axis[1], axis[2]);
            if axis.norm() < 1e-9 {
                return Err(InputError::new(path, format!("{field}.axis"), "the axis must not be zero"));
            }
            Ok(UnitQuaternion::from_axis_angle(&Unit::new_normalize(axis), angle.to_radians()))
        }
    }
}
