//! Procedural assets as glTF 2.0 ([`super::gltf_out`]), Y-up (Drake turns glTF Y-up into
//! its Z-up on load), one primitive per material, each textured with its colour and a fine
//! grain tiled in metres (so no instance is a flat colour).

use std::collections::BTreeMap;
use std::f64::consts::TAU;
use std::path::Path;

use osmab_evaluator::formats::image::{RgbImage, write_png_rgb};
use osmab_evaluator::synthetic::Rng;
use osmab_evaluator::{InputError, Result};

use super::gltf_out::{OutMaterial, OutPrimitive, write_gltf};
use super::library::{Asset, Shape};

/// Triangles of one material in the object's Drake frame.
/// The side of the square a material's texture covers, metres.
const TEXTURE_TILE_M: f64 = 0.3;
/// The side of a material's texture, texels.
const TEXTURE_SIDE: usize = 64;
/// How far a texel's brightness strays from the material's colour, either way.
const GRAIN: f64 = 0.12;

#[derive(Default)]
struct Geometry {
    positions: Vec<[f64; 3]>,
    normals: Vec<[f64; 3]>,
    uvs: Vec<[f32; 2]>,
    indices: Vec<u32>,
}

/// Texture coordinates of `p` on a face with normal `n`: the two other axes, in tiles.
fn planar_uv(p: [f64; 3], n: [f64; 3]) -> [f32; 2] {
    let axis = (0..3).max_by(|&a, &b| n[a].abs().total_cmp(&n[b].abs())).expect("three axes");
    let (u, v) = match axis {
        0 => (p[1], p[2]),
        1 => (p[0], p[2]),
        _ => (p[0], p[1]),
    };
    [(u / TEXTURE_TILE_M) as f32, (-v / TEXTURE_TILE_M) as f32]
}

impl Geometry {
    fn quad(&mut self, corners: [[f64; 3]; 4], normal: [f64; 3]) {
        let base = self.positions.len() as u32;
        self.positions.extend(corners);
        self.normals.extend([normal; 4]);
        self.uvs.extend(corners.map(|p| planar_uv(p, normal)));
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
                    self.uvs.extend([centre_top, p(c0, s0, height), p(c1, s1, height)].map(|q| planar_uv(q, [0.0, 0.0, 1.0])));
                    self.indices.extend([first, first + 1, first + 2]);
                    let first = self.positions.len() as u32;
                    self.positions.extend([[base[0], base[1], base[2]], p(c1, s1, 0.0), p(c0, s0, 0.0)]);
                    self.normals.extend([[0.0, 0.0, -1.0]; 3]);
                    self.uvs.extend([[base[0], base[1], base[2]], p(c1, s1, 0.0), p(c0, s0, 0.0)].map(|q| planar_uv(q, [0.0, 0.0, -1.0])));
                    self.indices.extend([first, first + 1, first + 2]);
                }
            }
        }
    }
}

/// Drake object frame → glTF (Y-up): (x, y, z) → (x, z, −y).
pub(super) fn to_gltf(p: [f64; 3]) -> [f32; 3] {
    [p[0] as f32, p[2] as f32, -p[1] as f32]
}

/// A material's texture: its colour with a fine, seamless grain (value noise on an 8 × 8
/// lattice, seeded by the material's name), averaging to the colour; RGB, row by row.
fn grain_texture(material: &super::library::Material) -> Vec<u8> {
    const LATTICE: usize = 8;
    let mut rng = Rng::new(material.name.bytes().fold(0xC0FF_EE00u64, |h, b| h.wrapping_mul(0x100_0000_01B3) ^ u64::from(b)));
    let lattice: Vec<f64> = (0..LATTICE * LATTICE).map(|_| rng.range(-1.0, 1.0)).collect();
    let at = |x: usize, y: usize| lattice[(y % LATTICE) * LATTICE + x % LATTICE];
    let smooth = |t: f64| t * t * (3.0 - 2.0 * t);
    let mut rgb = Vec::with_capacity(TEXTURE_SIDE * TEXTURE_SIDE * 3);
    for py in 0..TEXTURE_SIDE {
        for px in 0..TEXTURE_SIDE {
            let (fx, fy) = (px as f64 * LATTICE as f64 / TEXTURE_SIDE as f64, py as f64 * LATTICE as f64 / TEXTURE_SIDE as f64);
            let (x, y) = (fx as usize, fy as usize);
            let (tx, ty) = (smooth(fx - x as f64), smooth(fy - y as f64));
            let top = at(x, y) * (1.0 - tx) + at(x + 1, y) * tx;
            let bottom = at(x, y + 1) * (1.0 - tx) + at(x + 1, y + 1) * tx;
            let gain = 1.0 + GRAIN * (top * (1.0 - ty) + bottom * ty);
            rgb.extend((0..3).map(|c| (f64::from(material.color[c]) * gain * 255.0).round().clamp(0.0, 255.0) as u8));
        }
    }
    rgb
}

/// Write `asset` as `dir/stem.gltf` + `dir/stem.bin`, each material's grain texture beside
/// it (`stem_<material>.png`).
pub fn write_asset_gltf(asset: &Asset, dir: &Path, stem: &str) -> Result<()> {
    let mut by_material: BTreeMap<&str, (super::library::Material, Geometry)> = BTreeMap::new();
    for part in &asset.parts {
        by_material.entry(part.material.name).or_insert_with(|| (part.material, Geometry::default())).1.add(&part.shape);
    }
    std::fs::create_dir_all(dir).map_err(|e| InputError::io(dir, &e))?;
    let mut textures = Vec::new();
    for (material, _) in by_material.values() {
        let name = format!("{stem}_{}.png", material.name);
        let texture = RgbImage { width: TEXTURE_SIDE as u32, height: TEXTURE_SIDE as u32, pixels: grain_texture(material) };
        write_png_rgb(&dir.join(&name), &texture)?;
        textures.push(name);
    }
    let converted: Vec<(Vec<[f32; 3]>, Vec<[f32; 3]>)> = by_material
        .values()
        .map(|(_, geometry)| (geometry.positions.iter().map(|&p| to_gltf(p)).collect(), geometry.normals.iter().map(|&n| to_gltf(n)).collect()))
        .collect();
    let primitives: Vec<OutPrimitive> = by_material
        .values()
        .zip(&converted)
        .zip(&textures)
        .map(|(((material, geometry), (positions, normals)), texture)| OutPrimitive {
            positions,
            normals,
            uvs: Some(&geometry.uvs),
            indices: &geometry.indices,
            material: OutMaterial { name: material.name, color: [1.0; 4], texture: Some(texture), occlusion: None },
        })
        .collect();
    write_gltf(dir, stem, &asset.category, "osmab procedural assets", &primitives)
}
