//! SDFormat 1.7 models as SceneSmith writes them: links with poses (possibly
//! `relative_to` another link), and visuals with a pose and a mesh (`<uri>`,
//! `<scale>`) or a primitive (box, cylinder, sphere). Collisions, inertia and joints
//! are not needed to render a scene and are ignored (joints stay at zero).

use std::collections::HashMap;
use std::path::{Path, PathBuf};

use osmab_evaluator::{InputError, Result};

use super::transform::{Pose, pose, rpy};

/// What a visual looks like.
#[derive(Debug, Clone, PartialEq)]
pub enum Geometry {
    /// A mesh file (resolved to a path) with a scale.
    Mesh { path: PathBuf, scale: [f64; 3] },
    /// A box of the given size, centred on the visual frame.
    Box { size: [f64; 3] },
    /// A cylinder along the visual frame's z axis.
    Cylinder { radius: f64, length: f64 },
    /// A sphere.
    Sphere { radius: f64 },
}

/// One visual of a link.
#[derive(Debug, Clone, PartialEq)]
pub struct Visual {
    pub name: String,
    /// Pose in the link frame.
    pub pose: Pose,
    pub geometry: Geometry,
    /// `<material><diffuse>` colour, if given.
    pub diffuse: Option<[f64; 4]>,
}

/// One link with its pose in the model frame.
#[derive(Debug, Clone, PartialEq)]
pub struct Link {
    pub name: String,
    pub pose_in_model: Pose,
    pub visuals: Vec<Visual>,
}

/// A model: its links (the first is the base link unless named otherwise).
#[derive(Debug, Clone, PartialEq)]
pub struct Model {
    pub name: String,
    pub is_static: bool,
    pub links: Vec<Link>,
}

impl Model {
    /// The link named `name`.
    pub fn link(&self, name: &str) -> Option<&Link> {
        self.links.iter().find(|l| l.name == name)
    }
}

/// How `package://` and relative URIs resolve. Every file must stay inside `root`
/// (the scene directory), whatever `..` a URI holds.
pub struct UriResolver<'a> {
    /// The scene directory.
    pub root: &'a Path,
    /// Package name → directory (SceneSmith: `scene` → the scene root).
    pub packages: &'a HashMap<String, PathBuf>,
}

impl UriResolver<'_> {
    /// The file a URI names, relative URIs being relative to `base_dir`.
    pub fn resolve(&self, uri: &str, base_dir: &Path) -> std::result::Result<PathBuf, String> {
        let joined = if let Some(rest) = uri.strip_prefix("package://") {
            let (package, rel) = rest.split_once('/').ok_or_else(|| format!("'{uri}' has no path after the package name"))?;
            let root = self.packages.get(package).ok_or_else(|| format!("unknown package '{package}' in '{uri}'"))?;
            root.join(rel.trim_start_matches('/'))
        } else if let Some(abs) = uri.strip_prefix("file://") {
            PathBuf::from(abs)
        } else if uri.contains("://") {
            return Err(format!("unsupported URI scheme in '{uri}'"));
        } else if uri.starts_with('/') {
            PathBuf::from(uri)
        } else {
            base_dir.join(uri)
        };
        let resolved = normalize(&joined);
        // Lexically inside, and (when it exists) really inside: symlinks cannot lead out.
        let inside = resolved.starts_with(normalize(self.root))
            && match (std::fs::canonicalize(&resolved), std::fs::canonicalize(self.root)) {
                (Ok(real), Ok(root)) => real.starts_with(root),
                _ => true,
            };
        if inside { Ok(resolved) } else { Err(format!("'{uri}' points outside the scene directory")) }
    }
}

/// `path` with `.` and `..` folded away (lexically).
pub fn normalize(path: &Path) -> PathBuf {
    let mut out = PathBuf::new();
    for c in path.components() {
        match c {
            std::path::Component::ParentDir => {
                out.pop();
            }
            std::path::Component::CurDir => {}
            other => out.push(other),
        }
    }
    out
}

fn numbers(text: &str, n: usize, path: &Path, field: &str) -> Result<Vec<f64>> {
    let v: Option<Vec<f64>> = text.split_whitespace().map(|w| w.parse().ok()).collect();
    match v {
        Some(v) if v.len() == n && v.iter().all(|x: &f64| x.is_finite()) => Ok(v),
        _ => Err(InputError::new(path, field, format!("expected {n} finite numbers, found '{}'", text.trim()))),
    }
}

fn pose_of(node: roxmltree::Node, path: &Path, field: &str) -> Result<(Pose, Option<String>)> {
    match node.children().find(|c| c.has_tag_name("pose")) {
        None => Ok((Pose::identity(), None)),
        Some(p) => {
            let v = numbers(p.text().unwrap_or(""), 6, path, &format!("{field}.pose"))?;
            if p.attribute("degrees") == Some("true") || p.attribute("rotation_format").is_some_and(|f| f != "euler_rpy") {
                return Err(InputError::new(path, format!("{field}.pose"), "only radian roll-pitch-yaw poses are supported"));
            }
            Ok((pose([v[0], v[1], v[2]], rpy(v[3], v[4], v[5])), p.attribute("relative_to").map(str::to_string)))
        }
    }
}

fn child_text<'a>(node: roxmltree::Node<'a, 'a>, tag: &str) -> Option<&'a str> {
    node.children().find(|c| c.has_tag_name(tag)).and_then(|c| c.text())
}

/// Read an SDF file's single model.
pub fn read_sdf(path: &Path, resolver: &UriResolver) -> Result<Model> {
    let text = std::fs::read_to_string(path).map_err(|e| InputError::io(path, &e))?;
    let doc = roxmltree::Document::parse(&text).map_err(|e| InputError::new(path, "(xml)", format!("not well-formed XML: {e}")))?;
    let root = doc.root_element();
    if !root.has_tag_name("sdf") {
        return Err(InputError::new(path, "sdf", "the root element is not <sdf>"));
    }
    let models: Vec<_> = root.children().filter(|c| c.has_tag_name("model")).collect();
    let [model] = models.as_slice() else {
        return Err(InputError::new(path, "sdf.model", format!("expected exactly one <model>, found {}", models.len())));
    };
    if model.children().any(|c| c.has_tag_name("include") || c.has_tag_name("model")) {
        return Err(InputError::new(path, "model", "nested models and <include> are not supported"));
    }
    let name = model.attribute("name").unwrap_or_default().to_string();
    let is_static = child_text(*model, "static").is_some_and(|t| matches!(t.trim(), "true" | "1"));
    let dir = path.parent().unwrap_or(Path::new("."));
    let raw_links = model.children().filter(|c| c.has_tag_name("link")).map(|link| read_link(link, path, dir, resolver)).collect::<Result<Vec<_>>>()?;
    if raw_links.is_empty() {
        return Err(InputError::new(path, "model.link", "the model has no links"));
    }
    Ok(Model { name, is_static, links: links_in_model(&raw_links, path)? })
}

/// A `<link>` as written: its name, its pose and the frame that pose is relative to, its visuals.
#[derive(Clone)]
struct RawLink {
    name: String,
    pose: Pose,
    relative_to: Option<String>,
    visuals: Vec<Visual>,
}

/// One `<link>` of the model at `path` (mesh URIs resolved from `dir`).
fn read_link(link: roxmltree::Node, path: &Path, dir: &Path, resolver: &UriResolver) -> Result<RawLink> {
    let link_name = link.attribute("name").unwrap_or_default().to_string();
    let field = format!("link[{link_name}]");
    let (link_pose, relative_to) = pose_of(link, path, &field)?;
    let mut visuals = Vec::new();
    for visual in link.children().filter(|c| c.has_tag_name("visual")) {
        let visual_name = visual.attribute("name").unwrap_or_default().to_string();
        let vfield = format!("{field}.visual[{visual_name}]");
        let (visual_pose, visual_relative) = pose_of(visual, path, &vfield)?;
        if visual_relative.is_some_and(|r| r != link_name) {
            return Err(InputError::new(path, format!("{vfield}.pose"), "visual poses relative to other frames are not supported"));
        }
        let geometry = visual.children().find(|c| c.has_tag_name("geometry")).ok_or_else(|| InputError::new(path, &vfield, "missing <geometry>"))?;
        let shape = geometry.children().find(|c| c.is_element()).ok_or_else(|| InputError::new(path, format!("{vfield}.geometry"), "empty <geometry>"))?;
        let geometry = read_geometry(shape, &vfield, path, dir, resolver)?;
        let diffuse = read_diffuse(visual, &vfield, path)?;
        visuals.push(Visual { name: visual_name, pose: visual_pose, geometry, diffuse });
    }
    Ok(RawLink { name: link_name, pose: link_pose, relative_to, visuals })
}

/// The shape of a visual's `<geometry>`: a mesh (its file resolved and checked), a box, a
/// cylinder or a sphere.
fn read_geometry(shape: roxmltree::Node, vfield: &str, path: &Path, dir: &Path, resolver: &UriResolver) -> Result<Geometry> {
    let gfield = format!("{vfield}.geometry.{}", shape.tag_name().name());
    let geometry = match shape.tag_name().name() {
        "mesh" => {
            let uri = child_text(shape, "uri").ok_or_else(|| InputError::new(path, &gfield, "missing <uri>"))?.trim();
            let file = resolver.resolve(uri, dir).map_err(|m| InputError::new(path, format!("{gfield}.uri"), m))?;
            if !file.is_file() {
                return Err(InputError::new(path, format!("{gfield}.uri"), format!("'{uri}' resolves to {}, which does not exist", file.display())));
            }
            let scale = match child_text(shape, "scale") {
                Some(t) => numbers(t, 3, path, &format!("{gfield}.scale"))?,
                None => vec![1.0; 3],
            };
            if scale.iter().any(|s| *s <= 0.0) {
                return Err(InputError::new(path, format!("{gfield}.scale"), "scales must be positive"));
            }
            Geometry::Mesh { path: file, scale: [scale[0], scale[1], scale[2]] }
        }
        "box" => {
            let s = numbers(child_text(shape, "size").unwrap_or(""), 3, path, &format!("{gfield}.size"))?;
            Geometry::Box { size: [s[0], s[1], s[2]] }
        }
        "cylinder" => Geometry::Cylinder {
            radius: numbers(child_text(shape, "radius").unwrap_or(""), 1, path, &format!("{gfield}.radius"))?[0],
            length: numbers(child_text(shape, "length").unwrap_or(""), 1, path, &format!("{gfield}.length"))?[0],
        },
        "sphere" => Geometry::Sphere { radius: numbers(child_text(shape, "radius").unwrap_or(""), 1, path, &format!("{gfield}.radius"))?[0] },
        other => return Err(InputError::new(path, gfield, format!("unsupported geometry <{other}> (expected mesh, box, cylinder or sphere)"))),
    };
    Ok(geometry)
}

/// A visual's `<material><diffuse>` colour as RGBA (an RGB one opaque), if it has one.
fn read_diffuse(visual: roxmltree::Node, vfield: &str, path: &Path) -> Result<Option<[f64; 4]>> {
    Ok(visual
        .children()
        .find(|c| c.has_tag_name("material"))
        .and_then(|m| child_text(m, "diffuse"))
        .map(|t| {
            numbers(t, 4, path, &format!("{vfield}.material.diffuse")).or_else(|_| {
                numbers(t, 3, path, &format!("{vfield}.material.diffuse")).map(|mut v| {
                    v.push(1.0);
                    v
                })
            })
        })
        .transpose()?
        .map(|v| [v[0], v[1], v[2], v[3]]))
}

/// The links with their poses in the model frame, `relative_to` chains between links
/// resolved (cycles are errors).
fn links_in_model(raw_links: &[RawLink], path: &Path) -> Result<Vec<Link>> {
    let index: HashMap<String, usize> = raw_links.iter().enumerate().map(|(i, l)| (l.name.clone(), i)).collect();
    let mut resolved: Vec<Option<Pose>> = vec![None; raw_links.len()];
    let mut links = Vec::new();
    for i in 0..raw_links.len() {
        let pose_in_model = link_pose_in_model(i, raw_links, &index, &mut resolved, &mut Vec::new(), path)?;
        let RawLink { name, visuals, .. } = raw_links[i].clone();
        links.push(Link { name, pose_in_model, visuals });
    }
    Ok(links)
}

/// The pose of link `i` in the model frame, following its `relative_to` chain (memoised
/// in `resolved`; `visiting` is the chain so far, to tell a cycle).
fn link_pose_in_model(
    i: usize,
    raw: &[RawLink],
    index: &HashMap<String, usize>,
    resolved: &mut [Option<Pose>],
    visiting: &mut Vec<usize>,
    path: &Path,
) -> Result<Pose> {
    if let Some(p) = resolved[i] {
        return Ok(p);
    }
    if visiting.contains(&i) {
        let chain: Vec<&str> = visiting.iter().map(|&j| raw[j].name.as_str()).collect();
        return Err(InputError::new(path, format!("link[{}].pose", raw[i].name), format!("relative_to forms a cycle: {}", chain.join(" -> "))));
    }
    visiting.push(i);
    let pose = match &raw[i].relative_to {
        None => raw[i].pose,
        Some(frame) if frame == "__model__" => raw[i].pose,
        Some(frame) => {
            let j = *index
                .get(frame)
                .ok_or_else(|| InputError::new(path, format!("link[{}].pose", raw[i].name), format!("relative_to '{frame}' is not a link of the model")))?;
            link_pose_in_model(j, raw, index, resolved, visiting, path)? * raw[i].pose
        }
    };
    visiting.pop();
    resolved[i] = Some(pose);
    Ok(pose)
}
