//! Asset packs: folders of real-looking, textured meshes and room-shell textures with a
//! `catalogue.json` ([`catalogue`]) — the pack the forge makes from Infinigen
//! (`tools/forge/`), or an operator's own (scans, Objaverse-style downloads) in the same
//! format. Opening a pack checks every file against the catalogue (inside the pack, within
//! size, SHA-256 as listed); [`AssetPack::inspect`] also reads every mesh and checks what the
//! catalogue says of it (triangles, size, textures).

pub mod catalogue;

use std::io::Read;
use std::path::{Path, PathBuf};

use osmab_evaluator::{InputError, Result};
use sha2::{Digest, Sha256};

pub use catalogue::{Catalogue, ObjectEntry, ShellEntry, ShellKind};

use crate::convert::gltf::read_gltf;
use crate::release::manifest::hex;
use crate::render::obj::read_obj;

/// The largest catalogue read.
const MAX_CATALOGUE_BYTES: u64 = 16 << 20;
/// The largest mesh or texture file of a pack.
const MAX_FILE_BYTES: u64 = 64 << 20;
/// How far a mesh's bounds may differ from the catalogue's size: 1 cm, or 2 % of the side.
fn size_tolerance(side: f64) -> f64 {
    (0.02 * side).max(0.01)
}

/// An opened, checked asset pack.
#[derive(Debug, Clone)]
pub struct AssetPack {
    root: PathBuf,
    catalogue: Catalogue,
    digest: String,
}

/// What reading a mesh of the pack found.
#[derive(Debug, Clone, PartialEq)]
pub struct MeshFacts {
    pub class: String,
    pub variant: u32,
    pub triangles: u64,
    /// Width, depth, height of its bounds in the object frame (glTF's y is up).
    pub size: [f64; 3],
    /// Whether every triangle's material has a decoded texture.
    pub textured: bool,
}

impl AssetPack {
    /// Open the pack at `root`: its catalogue and every file it lists.
    pub fn open(root: &Path) -> Result<Self> {
        let file = root.join("catalogue.json");
        let bytes = read_capped(&file, MAX_CATALOGUE_BYTES)?;
        let text = std::str::from_utf8(&bytes).map_err(|_| InputError::new(&file, "(file)", "expected UTF-8 JSON"))?;
        let catalogue = Catalogue::parse(text, &file)?;
        let canonical_root = root.canonicalize().map_err(|e| InputError::io(root, &e))?;
        let listed = catalogue.objects.iter().map(|o| (&o.path, &o.sha256)).chain(catalogue.shells.iter().map(|s| (&s.path, &s.sha256)));
        for (path, sha256) in listed {
            let member = root.join(path);
            let canonical = member.canonicalize().map_err(|e| InputError::io(&member, &e))?;
            if !canonical.starts_with(&canonical_root) {
                return Err(InputError::new(&member, "(file)", format!("leaves the pack {} (a link outside it)", root.display())));
            }
            let found = hex_sha256(&read_capped(&member, MAX_FILE_BYTES)?);
            if &found != sha256 {
                return Err(InputError::new(&member, "(file)", format!("SHA-256 {found}, the catalogue lists {sha256}")));
            }
        }
        let digest = hex_sha256(&serde_json::to_vec(&catalogue).expect("a catalogue serialises"));
        Ok(Self { root: root.to_path_buf(), catalogue, digest })
    }

    pub fn catalogue(&self) -> &Catalogue {
        &self.catalogue
    }

    /// The SHA-256 of the catalogue's content (as parsed, so its layout does not count): with
    /// every file's SHA-256 in it and every file checked against it, it names the pack's
    /// whole content (a build input of every scene using it).
    pub fn digest(&self) -> &str {
        &self.digest
    }

    /// The file of a catalogue path.
    pub fn path(&self, relative: &str) -> PathBuf {
        self.root.join(relative)
    }

    /// Read every mesh and check it against its entry: the triangles it lists, its size
    /// within 1 cm (or 2 %), standing on z = 0 and centred, with a texture on every material.
    pub fn inspect(&self) -> Result<Vec<MeshFacts>> {
        self.catalogue.objects.iter().map(|entry| self.inspect_entry(entry)).collect()
    }

    fn inspect_entry(&self, entry: &ObjectEntry) -> Result<MeshFacts> {
        let file = self.path(&entry.path);
        let (lo, hi, triangles, textured) = if entry.path.to_ascii_lowercase().ends_with(".obj") {
            let mesh = read_obj(&file)?;
            let textured = mesh.triangles.iter().all(|(_, m)| mesh.materials.get(*m).is_some_and(|m| m.texture.is_some()));
            let (lo, hi) = bounds(mesh.positions.iter()).ok_or_else(|| InputError::new(&file, "(geometry)", "no vertices"))?;
            (lo, hi, mesh.triangles.len() as u64, textured)
        } else {
            let asset = read_gltf(&file)?;
            let textured = asset.meshes.iter().all(|m| m.material.and_then(|k| asset.materials.get(k)).is_some_and(|m| m.texture.is_some()));
            let (lo, hi) = asset.bounds().ok_or_else(|| InputError::new(&file, "(geometry)", "no vertices"))?;
            (lo, hi, asset.meshes.iter().map(|m| m.indices.len() as u64 / 3).sum(), textured)
        };
        // glTF (and Blender's OBJ) are y-up: width x, depth z, height y.
        let size = [hi[0] - lo[0], hi[2] - lo[2], hi[1] - lo[1]].map(f64::from);
        let at = |field: &str| format!("catalogue entry {} {}: {field}", entry.class, entry.variant);
        if triangles != entry.triangles {
            return Err(InputError::new(&file, at("triangles"), format!("the mesh has {triangles} triangles, the catalogue lists {}", entry.triangles)));
        }
        for axis in 0..3 {
            if (size[axis] - entry.size[axis]).abs() > size_tolerance(entry.size[axis]) {
                return Err(InputError::new(&file, at("size"), format!("the mesh measures {size:.3?} m, the catalogue lists {:?}", entry.size)));
            }
        }
        let bottom = f64::from(lo[1]);
        let centre = [f64::from(lo[0] + hi[0]) / 2.0, f64::from(lo[2] + hi[2]) / 2.0];
        if bottom.abs() > 0.01 || centre.iter().any(|c| c.abs() > 0.01) {
            return Err(InputError::new(
                &file,
                at("path"),
                format!("expected the object standing on z = 0 centred in x and y (its bottom is at {bottom:.3} m, its centre at {centre:.3?})"),
            ));
        }
        Ok(MeshFacts { class: entry.class.clone(), variant: entry.variant, triangles, size, textured })
    }
}

fn bounds<'a>(mut points: impl Iterator<Item = &'a [f32; 3]>) -> Option<([f32; 3], [f32; 3])> {
    let first = *points.next()?;
    Some(points.fold((first, first), |(lo, hi), p| (std::array::from_fn(|a| lo[a].min(p[a])), std::array::from_fn(|a| hi[a].max(p[a])))))
}

/// The bytes of `file`, refused beyond `cap`.
fn read_capped(file: &Path, cap: u64) -> Result<Vec<u8>> {
    let handle = std::fs::File::open(file).map_err(|e| InputError::io(file, &e))?;
    let mut bytes = Vec::new();
    handle.take(cap + 1).read_to_end(&mut bytes).map_err(|e| InputError::io(file, &e))?;
    if bytes.len() as u64 > cap {
        return Err(InputError::new(file, "(file)", format!("larger than {} MiB, the most a pack's file may be", cap >> 20)));
    }
    Ok(bytes)
}

fn hex_sha256(bytes: &[u8]) -> String {
    hex(&Sha256::digest(bytes))
}
