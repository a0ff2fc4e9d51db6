//! `catalogue.json` of an asset pack: what every mesh and room-shell texture of the pack is,
//! where it came from and what it holds, as the forge (`tools/forge/`) writes it and as an
//! operator writes it for assets of their own. Read strictly: an unknown field, a class
//! outside the lexicon, a path that leaves the pack, a size that is not a size or a
//! support outside its object is an error naming the entry and field.

use std::collections::BTreeSet;
use std::path::{Component, Path};

use osmab_evaluator::{InputError, Result};
use serde::{Deserialize, Serialize};

use crate::convert::lexicon::normalise_name;

/// The format the catalogue declares.
pub const FORMAT: &str = "osmab-assets/1";

/// The largest object a pack may hold, metres along any axis.
const MAX_SIDE_M: f64 = 10.0;
/// How far a support may reach past its object's bounds (the forge measures on a 1 cm grid).
const SUPPORT_SLACK_M: f64 = 0.02;

/// The whole catalogue.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Catalogue {
    pub format: String,
    /// Every object mesh, sorted by class and variant.
    pub objects: Vec<ObjectEntry>,
    /// Floor and wall textures.
    #[serde(default)]
    pub shells: Vec<ShellEntry>,
}

/// One variant of a class: a mesh in the SceneSmith object frame (glTF's Y-up as SceneSmith
/// ships them: up +Z, front +Y and bottom at z = 0 once Drake turns it; centred in x and y).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ObjectEntry {
    /// A class of the lexicon.
    pub class: String,
    pub variant: u32,
    /// "infinigen", "procedural", "scan", …: where the geometry comes from.
    pub source: String,
    /// What made it: generator versions and factory.
    pub generator: String,
    pub seed: u64,
    /// Width (x), depth (y), height (z), metres.
    pub size: [f64; 3],
    /// The uniform scale the forge applied to bring it into its class's size range.
    #[serde(default = "unit_scale")]
    pub scale: f64,
    pub triangles: u64,
    /// Surfaces other objects can rest on, in the object frame.
    #[serde(default)]
    pub supports: Vec<SupportEntry>,
    /// The floor under it that is free up to a clearance (a table's, a desk's).
    #[serde(default)]
    pub under: Option<UnderEntry>,
    /// The mesh, relative to the pack: `.glb`, `.gltf` or `.obj`.
    pub path: String,
    pub sha256: String,
    pub license: String,
}

fn unit_scale() -> f64 {
    1.0
}

/// A surface of an object: height and x/y extent in the object frame.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SupportEntry {
    pub height: f64,
    pub min: [f64; 2],
    pub max: [f64; 2],
    /// Whether part of the object is above it (a shelf of a cabinet).
    pub inside: bool,
    /// Whether it is seen and reached from the front.
    pub open: bool,
    /// Free height above it; `null` on top of the object.
    pub clear_height: Option<f64>,
}

/// The free floor under an object.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct UnderEntry {
    pub clearance: f64,
    pub min: [f64; 2],
    pub max: [f64; 2],
}

/// Which surface of a room a shell texture dresses.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum ShellKind {
    Floor,
    Wall,
}

/// A tileable texture for floors or walls.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ShellEntry {
    pub name: String,
    pub kind: ShellKind,
    pub source: String,
    pub generator: String,
    pub seed: u64,
    /// The side of the square the texture covers, metres.
    pub tile: f64,
    /// The texture, relative to the pack: `.jpg` or `.png`.
    pub path: String,
    pub sha256: String,
    pub license: String,
}

impl Catalogue {
    /// Parse `text` (the catalogue at `file`) and check every entry on its own; the files it
    /// names are checked by [`super::AssetPack::open`].
    pub fn parse(text: &str, file: &Path) -> Result<Self> {
        let catalogue: Catalogue = serde_json::from_str(text).map_err(|e| InputError::new(file, "(json)", format!("not a catalogue ({e})")))?;
        if catalogue.format != FORMAT {
            return Err(InputError::new(file, "format", format!("expected \"{FORMAT}\", found {:?}", catalogue.format)));
        }
        let mut seen = BTreeSet::new();
        for (i, entry) in catalogue.objects.iter().enumerate() {
            let at = |field: &str| format!("objects[{i}] ({} {}).{field}", entry.class, entry.variant);
            entry.check(file, &at)?;
            if !seen.insert((entry.class.as_str(), entry.variant)) {
                return Err(InputError::new(file, at("variant"), "the class lists this variant twice"));
            }
        }
        let mut names = BTreeSet::new();
        for (i, shell) in catalogue.shells.iter().enumerate() {
            let at = |field: &str| format!("shells[{i}] ({}).{field}", shell.name);
            if !(shell.tile.is_finite() && shell.tile > 0.0 && shell.tile <= MAX_SIDE_M) {
                return Err(InputError::new(file, at("tile"), format!("expected a tile side in (0, {MAX_SIDE_M}] m, found {}", shell.tile)));
            }
            check_path(file, &at("path"), &shell.path, &["jpg", "jpeg", "png"])?;
            check_sha256(file, &at("sha256"), &shell.sha256)?;
            check_text(file, &at("license"), &shell.license)?;
            if !names.insert(shell.name.as_str()) {
                return Err(InputError::new(file, at("name"), "two shell textures have this name"));
            }
        }
        Ok(catalogue)
    }

    /// The variants of `class`, in variant order.
    pub fn variants<'a>(&'a self, class: &'a str) -> impl Iterator<Item = &'a ObjectEntry> + 'a {
        self.objects.iter().filter(move |e| e.class == class)
    }

    /// The shell textures of `kind`, in catalogue order.
    pub fn shells_of(&self, kind: ShellKind) -> impl Iterator<Item = &ShellEntry> + '_ {
        self.shells.iter().filter(move |s| s.kind == kind)
    }
}

impl ObjectEntry {
    fn check(&self, file: &Path, at: &dyn Fn(&str) -> String) -> Result<()> {
        if normalise_name(&self.class) != Some(self.class.as_str()) {
            return Err(InputError::new(file, at("class"), format!("{:?} is not a class of the lexicon (dataset/src/convert/lexicon.rs)", self.class)));
        }
        if !self.size.iter().all(|v| v.is_finite() && *v > 0.0 && *v <= MAX_SIDE_M) {
            return Err(InputError::new(file, at("size"), format!("expected three sides in (0, {MAX_SIDE_M}] m, found {:?}", self.size)));
        }
        if !(self.scale.is_finite() && self.scale > 0.0) {
            return Err(InputError::new(file, at("scale"), format!("expected a positive scale, found {}", self.scale)));
        }
        if self.triangles == 0 {
            return Err(InputError::new(file, at("triangles"), "expected at least one triangle"));
        }
        let [w, d, h] = self.size;
        let inside_x = |x: f64| x.is_finite() && x.abs() <= w / 2.0 + SUPPORT_SLACK_M;
        let inside_y = |y: f64| y.is_finite() && y.abs() <= d / 2.0 + SUPPORT_SLACK_M;
        for (k, s) in self.supports.iter().enumerate() {
            let field = at(&format!("supports[{k}]"));
            if !(s.height.is_finite() && s.height > 0.0 && s.height <= h + SUPPORT_SLACK_M) {
                return Err(InputError::new(file, field, format!("expected a height in (0, {h}] m (the object's height), found {}", s.height)));
            }
            if !(inside_x(s.min[0]) && inside_x(s.max[0]) && inside_y(s.min[1]) && inside_y(s.max[1]) && s.min[0] < s.max[0] && s.min[1] < s.max[1]) {
                return Err(InputError::new(
                    file,
                    field,
                    format!("expected min < max within the object's {w} × {d} m footprint, found {:?} to {:?}", s.min, s.max),
                ));
            }
            if let Some(clear) = s.clear_height
                && !(clear.is_finite() && clear > 0.0)
            {
                return Err(InputError::new(file, field, format!("expected a positive free height or null, found {clear}")));
            }
        }
        if let Some(under) = &self.under {
            let ok = under.clearance.is_finite() && under.clearance > 0.0 && under.clearance <= h;
            if !ok || !(inside_x(under.min[0]) && inside_x(under.max[0]) && inside_y(under.min[1]) && inside_y(under.max[1])) {
                return Err(InputError::new(file, at("under"), format!("expected a clearance in (0, {h}] m over the object's footprint, found {under:?}")));
            }
        }
        check_path(file, &at("path"), &self.path, &["glb", "gltf", "obj"])?;
        check_sha256(file, &at("sha256"), &self.sha256)?;
        check_text(file, &at("license"), &self.license)?;
        check_text(file, &at("source"), &self.source)
    }
}

/// A path inside the pack: relative, no `..`, one of `extensions`.
fn check_path(file: &Path, field: &str, path: &str, extensions: &[&str]) -> Result<()> {
    let p = Path::new(path);
    if path.is_empty() || !p.components().all(|c| matches!(c, Component::Normal(_))) {
        return Err(InputError::new(file, field, format!("expected a path inside the pack (relative, no ..), found {path:?}")));
    }
    let extension = p.extension().and_then(|e| e.to_str()).map(str::to_ascii_lowercase).unwrap_or_default();
    if !extensions.contains(&extension.as_str()) {
        return Err(InputError::new(file, field, format!("expected a .{} file, found {path:?}", extensions.join(" or ."))));
    }
    Ok(())
}

fn check_sha256(file: &Path, field: &str, sha256: &str) -> Result<()> {
    if sha256.len() != 64 || !sha256.bytes().all(|b| b.is_ascii_digit() || (b'a'..=b'f').contains(&b)) {
        return Err(InputError::new(file, field, format!("expected 64 lower-case hex digits, found {sha256:?}")));
    }
    Ok(())
}

fn check_text(file: &Path, field: &str, text: &str) -> Result<()> {
    if text.trim().is_empty() {
        return Err(InputError::new(file, field, "expected a non-empty text"));
    }
    Ok(())
}
