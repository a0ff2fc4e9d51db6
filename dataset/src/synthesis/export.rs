//! Procedural assets as glTF 2.0 the way SceneSmith ships its assets: a `.gltf` with
//! an external `.bin` buffer, Y-up (Drake turns glTF Y-up into its Z-up on load), one
//! primitive per material with positions, normals and indices.

use std::collections::BTreeMap;
use std::f64::consts::TAU;
use std::path::Path;

use osmab_evaluator::{InputError, Result};
use serde_json::json;

use super::library::{Asset, Shape};

/// Triangles of one material in the object's Drake frame.
#[derive(Default)]
struct Geometry {
    positions: Vec<[f64; 3]>,
    normals: Vec<[f64; 3]>,
    indices: Vec<u32>,
}

impl Geometry {
    fn quad(&mut self, corners: [[f64; 3]; 4], normal: [f64; 3]) {
        let base = self.positions.len() as u32;
        self.positions.extend(corners);
        self.normals.extend([normal; 4]);
        self.indices.extend([base, base + 1, base + 2, base, base + 2, base + 3]);
    }

    fn add(&mut self, shape: &Shape) {
        match *shape {
            Shape::Box { center: c, size: s } => {
                let h = s.map(|v| v / 2.0);
                let p = |x: f64, y: f64, z: f64| [c[0] + x * h[0], c[1] + y * h[1], c[2] + z * h[2]];
                self.quad([p(1.0, -1.0, -1.0), p(1.0, 1.0, -1.0), p(1.0, 1.0, 1.0), p(1.0, -1.0, 1.0)], [1.0, 0.0, 0.0]);
                self.quad([p(-1.0, 1.0, -1.0), p(-1.0, -1.0, -1.0), p(-1.0, -1.0, 1.0), p(-1.0, 1.0, 1.0)], [-1.0, 0.0, 0.0]);
                self.quad([p(1.0, 1.0, -1.0), p(-1.0, 1.0, -1.0), p(-1.0, 1.0, 1.0), p(1.0, 1.0, 1.0)], [0.0, 1.0, 0.0]);
                self.quad([p(-1.0, -1.0, -1.0), p(1.0, -1.0, -1.0), p(1.0, -1.0, 1.0), p(-1.0, -1.0, 1.0)], [0.0, -1.0, 0.0]);
                self.quad([p(-1.0, -1.0, 1.0), p(1.0, -1.0, 1.0), p(1.0, 1.0, 1.0), p(-1.0, 1.0, 1.0)], [0.0, 0.0, 1.0]);
                self.quad([p(-1.0, 1.0, -1.0), p(1.0, 1.0, -1.0), p(1.0, -1.0, -1.0), p(-1.0, -1.0, -1.0)], [0.0, 0.0, -1.0]);
            }
            Shape::Cylinder { base, radius, height } => {
                const SEGMENTS: usize = 24;
                let at = |i: usize| {
                    let a = TAU * i as f64 / SEGMENTS as f64;
                    (a.cos(), a.sin())
                };
                for i in 0..SEGMENTS {
                    let ((c0, s0), (c1, s1)) = (at(i), at(i + 1));
                    let side = [(c0 + c1) / 2.0, (s0 + s1) / 2.0, 0.0];
                    let len = (side[0] * side[0] + side[1] * side[1]).sqrt();
                    let n = [side[0] / len, side[1] / len, 0.0];
                    let p = |c: f64, s: f64, z: f64| [base[0] + radius * c, base[1] + radius * s, base[2] + z];
                    self.quad([p(c0, s0, 0.0), p(c1, s1, 0.0), p(c1, s1, height), p(c0, s0, height)], n);
                    let centre_top = [base[0], base[1], base[2] + height];
                    let first = self.positions.len() as u32;
                    self.positions.extend([centre_top, p(c0, s0, height), p(c1, s1, height)]);
                    self.normals.extend([[0.0, 0.0, 1.0]; 3]);
                    self.indices.extend([first, first + 1, first + 2]);
                    let first = self.positions.len() as u32;
                    self.positions.extend([[base[0], base[1], base[2]], p(c1, s1, 0.0), p(c0, s0, 0.0)]);
                    self.normals.extend([[0.0, 0.0, -1.0]; 3]);
                    self.indices.extend([first, first + 1, first + 2]);
                }
            }
        }
    }
}

/// Drake object frame → glTF (Y-up): (x, y, z) → (x, z, −y).
fn to_gltf(p: [f64; 3]) -> [f32; 3] {
    [p[0] as f32, p[2] as f32, -p[1] as f32]
}

/// Write `asset` as `dir/stem.gltf` + `dir/stem.bin`.
pub fn write_asset_gltf(asset: &Asset, dir: &Path, stem: &str) -> Result<()> {
    let mut by_material: BTreeMap<&str, (super::library::Material, Geometry)> = BTreeMap::new();
    for part in &asset.parts {
        by_material.entry(part.material.name).or_insert_with(|| (part.material, Geometry::default())).1.add(&part.shape);
    }
    let mut bin: Vec<u8> = Vec::new();
    let (mut views, mut accessors, mut primitives, mut materials) = (Vec::new(), Vec::new(), Vec::new(), Vec::new());
    for (material, geometry) in by_material.values() {
        let positions: Vec<[f32; 3]> = geometry.positions.iter().map(|&p| to_gltf(p)).collect();
        let normals: Vec<[f32; 3]> = geometry.normals.iter().map(|&n| to_gltf(n)).collect();
        let (lo, hi) = positions.iter().fold(([f32::INFINITY; 3], [f32::NEG_INFINITY; 3]), |(lo, hi), p| {
            (std::array::from_fn(|a| lo[a].min(p[a])), std::array::from_fn(|a| hi[a].max(p[a])))
        });
        let mut push_view = |bytes: Vec<u8>, target: u32| {
            while bin.len() % 4 != 0 {
                bin.push(0);
            }
            views.push(json!({"buffer": 0, "byteOffset": bin.len(), "byteLength": bytes.len(), "target": target}));
            bin.extend(bytes);
            views.len() - 1
        };
        let pv = push_view(positions.iter().flatten().flat_map(|v| v.to_le_bytes()).collect(), 34962);
        let nv = push_view(normals.iter().flatten().flat_map(|v| v.to_le_bytes()).collect(), 34962);
        let iv = push_view(geometry.indices.iter().flat_map(|v| v.to_le_bytes()).collect(), 34963);
        let base = accessors.len();
        accessors.push(json!({"bufferView": pv, "componentType": 5126, "count": positions.len(), "type": "VEC3", "min": lo, "max": hi}));
        accessors.push(json!({"bufferView": nv, "componentType": 5126, "count": normals.len(), "type": "VEC3"}));
        accessors.push(json!({"bufferView": iv, "componentType": 5125, "count": geometry.indices.len(), "type": "SCALAR"}));
        primitives.push(json!({"attributes": {"POSITION": base, "NORMAL": base + 1}, "indices": base + 2, "material": materials.len(), "mode": 4}));
        materials
            .push(json!({"name": material.name, "pbrMetallicRoughness": {"baseColorFactor": material.color, "metallicFactor": 0.0, "roughnessFactor": 0.8}}));
    }
    let doc = json!({
        "asset": {"version": "2.0", "generator": "osmab procedural assets"},
        "scene": 0,
        "scenes": [{"nodes": [0]}],
        "nodes": [{"name": asset.category, "mesh": 0}],
        "meshes": [{"name": asset.category, "primitives": primitives}],
        "materials": materials,
        "buffers": [{"uri": format!("{stem}.bin"), "byteLength": bin.len()}],
        "bufferViews": views,
        "accessors": accessors,
    });
    std::fs::create_dir_all(dir).map_err(|e| InputError::io(dir, &e))?;
    let gltf = dir.join(format!("{stem}.gltf"));
    std::fs::write(&gltf, serde_json::to_string_pretty(&doc).expect("serialisable")).map_err(|e| InputError::io(&gltf, &e))?;
    let bin_path = dir.join(format!("{stem}.bin"));
    std::fs::write(&bin_path, bin).map_err(|e| InputError::io(&bin_path, &e))
}
