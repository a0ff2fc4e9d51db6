//! A small OBJ reader for the converter's primitives and simple OBJ assets: `v`, `vt`,
//! `f` (triangles or fans, negative indices), `mtllib`/`usemtl` and each material's
//! `Kd` and `map_Kd` base-colour texture (a texture that cannot be read leaves the
//! base colour, as for glTF).

use std::path::{Component, Path};

use osmab_evaluator::{InputError, Result};

use crate::convert::gltf::{Texture, decode_image};

/// Texture files larger than this are ignored (base colour used instead).
const MAX_TEXTURE_BYTES: u64 = 64 << 20;

/// One OBJ material.
#[derive(Debug, Clone, PartialEq)]
pub struct ObjMaterial {
    pub name: String,
    pub color: [f32; 3],
    pub texture: Option<Texture>,
}

/// An OBJ mesh: triangles as (vertex, UV) corners with their material.
#[derive(Debug, Clone, Default)]
pub struct ObjMesh {
    pub positions: Vec<[f32; 3]>,
    /// Texture coordinates with v pointing down (glTF's convention).
    pub uvs: Vec<[f32; 2]>,
    /// Index 0 is the default material (grey) used before any `usemtl`.
    pub materials: Vec<ObjMaterial>,
    pub triangles: Vec<([(u32, Option<u32>); 3], usize)>,
}

fn default_material() -> ObjMaterial {
    ObjMaterial { name: String::new(), color: [0.7, 0.7, 0.7], texture: None }
}

/// A file named inside an OBJ/MTL, resolved beside it; absolute paths and `..` are refused.
fn beside(path: &Path, name: &str) -> Option<std::path::PathBuf> {
    let relative = Path::new(name);
    relative.components().all(|c| matches!(c, Component::Normal(_) | Component::CurDir)).then(|| path.with_file_name("").join(relative))
}

fn read_texture(path: &Path) -> Option<Texture> {
    let size = std::fs::metadata(path).ok()?.len();
    if size > MAX_TEXTURE_BYTES {
        return None;
    }
    decode_image(&std::fs::read(path).ok()?).ok()
}

fn read_mtl(path: &Path, materials: &mut Vec<ObjMaterial>) {
    let Ok(text) = std::fs::read_to_string(path) else { return };
    for line in text.lines() {
        let mut words = line.split_whitespace();
        let keyword = words.next();
        if keyword == Some("newmtl") {
            materials.push(ObjMaterial { name: words.collect::<Vec<_>>().join(" "), ..default_material() });
            continue;
        }
        // Statements before the first `newmtl` belong to no material.
        let Some(m) = materials.last_mut().filter(|m| !m.name.is_empty()) else { continue };
        match keyword {
            Some("Kd") => {
                let c: Vec<f32> = words.filter_map(|w| w.parse().ok()).collect();
                if c.len() == 3 && c.iter().all(|x| x.is_finite()) {
                    m.color = [c[0], c[1], c[2]];
                }
            }
            // Options (-s, -o, …) come before the file name, which is last.
            Some("map_Kd") => m.texture = words.last().and_then(|name| beside(path, name)).and_then(|p| read_texture(&p)),
            _ => {}
        }
    }
}

/// Read the OBJ at `path` (and its material libraries beside it).
pub fn read_obj(path: &Path) -> Result<ObjMesh> {
    let text = std::fs::read_to_string(path).map_err(|e| InputError::io(path, &e))?;
    let mut mesh = ObjMesh { materials: vec![default_material()], ..Default::default() };
    let (mut current, mut chose_material) = (0, false);
    for (i, line) in text.lines().enumerate() {
        let at = || format!("line {}", i + 1);
        let mut words = line.split_whitespace();
        match words.next() {
            Some("v") => {
                let v: Vec<f32> = words.take(3).filter_map(|w| w.parse().ok()).collect();
                if v.len() != 3 || v.iter().any(|x| !x.is_finite()) {
                    return Err(InputError::new(path, at(), "a vertex needs 3 finite numbers"));
                }
                mesh.positions.push([v[0], v[1], v[2]]);
            }
            Some("vt") => {
                let t: Vec<f32> = words.take(2).filter_map(|w| w.parse().ok()).collect();
                if t.is_empty() || t.iter().any(|x| !x.is_finite()) {
                    return Err(InputError::new(path, at(), "a texture coordinate needs finite numbers"));
                }
                mesh.uvs.push([t[0], 1.0 - t.get(1).copied().unwrap_or(0.0)]);
            }
            Some("f") => {
                let resolve = |k: &str, count: usize| -> Option<Option<u32>> {
                    if k.is_empty() {
                        return Some(None);
                    }
                    let k: i64 = k.parse().ok()?;
                    let k = if k < 0 { count as i64 + k } else { k - 1 };
                    (k >= 0 && (k as usize) < count).then_some(Some(k as u32))
                };
                let corners: Vec<(u32, Option<u32>)> = words
                    .map(|w| {
                        let mut parts = w.split('/');
                        let v = resolve(parts.next().unwrap_or(""), mesh.positions.len())??;
                        let t = resolve(parts.next().unwrap_or(""), mesh.uvs.len())?;
                        Some((v, t))
                    })
                    .collect::<Option<_>>()
                    .ok_or_else(|| InputError::new(path, at(), "a face names a vertex or texture coordinate that does not exist"))?;
                for k in 1..corners.len().saturating_sub(1) {
                    mesh.triangles.push(([corners[0], corners[k], corners[k + 1]], current));
                }
            }
            Some("mtllib") => {
                for name in words {
                    if let Some(mtl) = beside(path, name) {
                        read_mtl(&mtl, &mut mesh.materials);
                    }
                }
            }
            Some("usemtl") => {
                let name = words.collect::<Vec<_>>().join(" ");
                chose_material = true;
                current = mesh.materials.iter().position(|m| m.name == name && !name.is_empty()).unwrap_or(0);
            }
            _ => {}
        }
    }
    // Without any `usemtl`, the first library material applies (the converter's primitives).
    if !chose_material && mesh.materials.len() > 1 {
        for t in &mut mesh.triangles {
            t.1 = 1;
        }
    }
    Ok(mesh)
}
