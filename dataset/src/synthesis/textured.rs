//! Textured geometry of a synthesized scene: pack meshes at their instance's scale with
//! their texture recoloured in its finish, and the room's floor and walls as tiled,
//! textured boxes. Written as glTF ([`super::gltf_out`]) with PNG or JPEG images beside.

use std::path::Path;

use osmab_evaluator::formats::image::{RgbImage, write_png_rgb};
use osmab_evaluator::{InputError, Result};

use super::export::to_gltf;
use super::gltf_out::{OutMaterial, OutPrimitive, write_gltf};
use super::library::PackMesh;
use super::source::ShellTexture;
use crate::classes::{Finish, MaterialKind};
use crate::convert::gltf::{Texture, TriangleMesh, read_gltf};

/// The largest relative brightness a texture's pattern may give a recoloured texel, either
/// way: a dark texture's faint highlights would otherwise become a light finish's bright
/// specks (the "starfield" of black pack textures recoloured light).
const MAX_DEVIATION: f32 = 0.45;
/// Brightness (0–255) below which a texture's pattern is measured against this instead:
/// the pattern's contrast, not its ratio to near-black.
const PATTERN_FLOOR: f32 = 70.0;
/// A main material whose brightness varies less than this (standard deviation, 0–255) has
/// lost its pattern in the bake: it gets one of its finish's material instead.
const FLAT: f32 = 4.0;

/// Write the pack mesh `mesh` of an instance of `category` as `dir/stem.gltf` (+ `.bin`
/// and one PNG per textured material).
pub fn write_pack_gltf(mesh: &PackMesh, category: &str, dir: &Path, stem: &str) -> Result<()> {
    let asset = read_gltf(&mesh.file)?;
    std::fs::create_dir_all(dir).map_err(|e| InputError::io(dir, &e))?;
    let scale = mesh.scale as f32;
    let positions: Vec<Vec<[f32; 3]>> = asset.meshes.iter().map(|m| m.positions.iter().map(|p| p.map(|v| v * scale)).collect()).collect();
    let mut names = Vec::new();
    for (k, material) in asset.materials.iter().enumerate() {
        let Some(texture) = &material.texture else {
            names.push(None);
            continue;
        };
        let users: Vec<&TriangleMesh> = asset.meshes.iter().filter(|m| m.material == Some(k)).collect();
        let rgb = match mesh.finish {
            Some(finish) => recolour(texture, &users, finish),
            None => texture.rgba.chunks_exact(4).flat_map(|p| [p[0], p[1], p[2]]).collect(),
        };
        let name = format!("{stem}_{k}.png");
        write_png_rgb(&dir.join(&name), &RgbImage { width: texture.width, height: texture.height, pixels: rgb })?;
        // The forge's ambient occlusion, as it is (a finish recolours, it does not relight).
        let occlusion = match &material.occlusion {
            Some(ao) => {
                let ao_name = format!("{stem}_{k}_ao.png");
                let grey: Vec<u8> = ao.rgba.chunks_exact(4).flat_map(|p| [p[0]; 3]).collect();
                write_png_rgb(&dir.join(&ao_name), &RgbImage { width: ao.width, height: ao.height, pixels: grey })?;
                Some(ao_name)
            }
            None => None,
        };
        names.push(Some((name, occlusion)));
    }
    let primitives: Vec<OutPrimitive> = asset
        .meshes
        .iter()
        .zip(&positions)
        .map(|(m, positions)| {
            let material = m.material.and_then(|k| asset.materials.get(k).map(|mat| (k, mat)));
            let texture = material.and_then(|(k, _)| names[k].as_ref()).map(|(t, _)| t.as_str());
            let occlusion = material.and_then(|(k, _)| names[k].as_ref()).and_then(|(_, o)| o.as_deref());
            OutPrimitive {
                positions,
                normals: &m.normals,
                uvs: m.uvs.as_deref().filter(|_| texture.is_some()),
                indices: &m.indices,
                material: OutMaterial {
                    name: material.map_or("default", |(_, mat)| mat.name.as_str()),
                    color: if texture.is_some() { [1.0; 4] } else { material.map_or([0.8, 0.8, 0.8, 1.0], |(_, mat)| mat.base_color) },
                    texture,
                    occlusion,
                },
            }
        })
        .collect();
    write_gltf(dir, stem, category, &format!("osmab from {} ({})", mesh.source, mesh.generator), &primitives)
}

/// Colour distance (0–255 RGB, Euclidean) within which a texel is wholly of the main
/// material, and beyond which it is wholly something else (legs, handles, a base).
const MAIN_NEAR: f32 = 45.0;
const MAIN_FAR: f32 = 85.0;

/// `texture` with its main material recoloured in `finish`, as the procedural library gives
/// an asset's main material its finish. The main material is the colour covering most of
/// what `meshes` show of the texture (area-weighted, the texel at each triangle's centre; an
/// atlas's unused corners do not count). Its texels keep their brightness relative to it as
/// far as the finish's material shows a pattern (wood its grain, fabric its weave, lacquer
/// little), bounded either way so no texel turns into a speck; a main material the bake left
/// flat gets a fine pattern of its finish's material. It averages to the finish; texels of
/// other colours (a chair's black legs, a desk's white frame) keep theirs.
fn recolour(texture: &Texture, meshes: &[&TriangleMesh], finish: &Finish) -> Vec<u8> {
    let samples = shown_texels(texture, meshes);
    let main = main_colour(&samples);
    let main_luminance = luminance(main);
    let flat = brightness_spread(&samples, main) < FLAT;
    let strength = finish.material.pattern();
    let width = texture.width as usize;
    texture
        .rgba
        .chunks_exact(4)
        .enumerate()
        .flat_map(|(i, p)| {
            let texel = [p[0], p[1], p[2]].map(f32::from);
            let weight = ((MAIN_FAR - distance(texel, main)) / (MAIN_FAR - MAIN_NEAR)).clamp(0.0, 1.0);
            let deviation = if flat {
                material_pattern(finish.material, i % width, i / width)
            } else {
                ((luminance(texel) - main_luminance) / main_luminance.max(PATTERN_FLOOR)).clamp(-MAX_DEVIATION, MAX_DEVIATION)
            };
            let gain = 1.0 + strength * deviation;
            std::array::from_fn::<u8, 3, _>(|c| (weight * finish.colour[c] * gain * 255.0 + (1.0 - weight) * texel[c]).round().clamp(0.0, 255.0) as u8)
        })
        .collect()
}

fn luminance(p: [f32; 3]) -> f32 {
    0.2126 * p[0] + 0.7152 * p[1] + 0.0722 * p[2]
}

/// The standard deviation of the brightness of the samples of the main colour `main`.
fn brightness_spread(samples: &[([f32; 3], f32)], main: [f32; 3]) -> f32 {
    let near: Vec<(f32, f32)> = samples.iter().filter(|(c, _)| distance(*c, main) < MAIN_NEAR).map(|(c, a)| (luminance(*c), *a)).collect();
    let total: f32 = near.iter().map(|(_, a)| a).sum();
    if total <= 0.0 {
        return 0.0;
    }
    let mean = near.iter().map(|(l, a)| l * a).sum::<f32>() / total;
    (near.iter().map(|(l, a)| (l - mean).powi(2) * a).sum::<f32>() / total).sqrt()
}

/// A seamless-enough pattern of `material` at texel (x, y), as a relative brightness in
/// about ±0.5: wood streaks along the texture's rows, fabric a soft mottle, the rest a faint
/// mottle. Deterministic (hashed lattice noise).
fn material_pattern(material: MaterialKind, x: usize, y: usize) -> f32 {
    let (x, y) = (x as f32, y as f32);
    match material {
        MaterialKind::Wood => 0.7 * value_noise(x / 48.0, y / 3.0, 11) + 0.3 * value_noise(x / 6.0, y / 1.5, 12),
        // No texel-sized component: textures are sampled nearest, and a weave one texel fine
        // is magnified into a mosaic of squares on a sofa seen from a metre.
        MaterialKind::Fabric | MaterialKind::Leather => 0.2 * value_noise(x / 3.0, y / 3.0, 21) + 0.5 * value_noise(x / 14.0, y / 14.0, 22),
        _ => 0.4 * value_noise(x / 24.0, y / 24.0, 31),
    }
}

/// Smooth value noise in about [-1, 1] on an integer lattice hashed with `seed`.
fn value_noise(x: f32, y: f32, seed: u32) -> f32 {
    let hash = |i: i32, j: i32| {
        let mut h = (i as u32).wrapping_mul(0x8DA6_B343) ^ (j as u32).wrapping_mul(0xD816_3841) ^ seed.wrapping_mul(0xCB1A_B31F);
        h ^= h >> 13;
        h = h.wrapping_mul(0x5BD1_E995);
        h ^= h >> 15;
        (h & 0xFFFF) as f32 / 32767.5 - 1.0
    };
    let (i, j) = (x.floor() as i32, y.floor() as i32);
    let (tx, ty) = (x - x.floor(), y - y.floor());
    let (sx, sy) = (tx * tx * (3.0 - 2.0 * tx), ty * ty * (3.0 - 2.0 * ty));
    let top = hash(i, j) * (1.0 - sx) + hash(i + 1, j) * sx;
    let bottom = hash(i, j + 1) * (1.0 - sx) + hash(i + 1, j + 1) * sx;
    top * (1.0 - sy) + bottom * sy
}

fn distance(a: [f32; 3], b: [f32; 3]) -> f32 {
    ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2) + (a[2] - b[2]).powi(2)).sqrt()
}

/// What `meshes` show of `texture`: the texel at each triangle's centre, with its area.
fn shown_texels(texture: &Texture, meshes: &[&TriangleMesh]) -> Vec<([f32; 3], f32)> {
    let texel = |uv: [f32; 2]| {
        let (w, h) = (texture.width as usize, texture.height as usize);
        let x = ((uv[0] - uv[0].floor()) * w as f32) as usize;
        let y = ((uv[1] - uv[1].floor()) * h as f32) as usize;
        let i = 4 * (y.min(h - 1) * w + x.min(w - 1));
        [texture.rgba[i], texture.rgba[i + 1], texture.rgba[i + 2]].map(f32::from)
    };
    let mut samples = Vec::new();
    for m in meshes {
        let Some(uvs) = &m.uvs else { continue };
        for t in m.indices.chunks_exact(3) {
            let [a, b, c] = [t[0], t[1], t[2]].map(|i| i as usize);
            let (pa, pb, pc) = (m.positions[a], m.positions[b], m.positions[c]);
            let e1 = [pb[0] - pa[0], pb[1] - pa[1], pb[2] - pa[2]];
            let e2 = [pc[0] - pa[0], pc[1] - pa[1], pc[2] - pa[2]];
            let cross = [e1[1] * e2[2] - e1[2] * e2[1], e1[2] * e2[0] - e1[0] * e2[2], e1[0] * e2[1] - e1[1] * e2[0]];
            let area = (cross[0] * cross[0] + cross[1] * cross[1] + cross[2] * cross[2]).sqrt();
            let centre = [(uvs[a][0] + uvs[b][0] + uvs[c][0]) / 3.0, (uvs[a][1] + uvs[b][1] + uvs[c][1]) / 3.0];
            samples.push((texel(centre), area));
        }
    }
    samples
}

/// The colour covering the most area: the heaviest cell of a coarse colour grid, refined to
/// the area-weighted mean of the samples near it (twice).
fn main_colour(samples: &[([f32; 3], f32)]) -> [f32; 3] {
    const CELLS: usize = 6;
    let cell = |c: [f32; 3]| c.map(|v| ((v / 256.0 * CELLS as f32) as usize).min(CELLS - 1));
    let mut weights = vec![0.0f32; CELLS * CELLS * CELLS];
    for (colour, area) in samples {
        let [r, g, b] = cell(*colour);
        weights[(r * CELLS + g) * CELLS + b] += area;
    }
    let heaviest = (0..weights.len()).max_by(|&a, &b| weights[a].total_cmp(&weights[b]).then(b.cmp(&a))).unwrap_or(0);
    let side = 256.0 / CELLS as f32;
    let mut main = [heaviest / (CELLS * CELLS), heaviest / CELLS % CELLS, heaviest % CELLS].map(|k| (k as f32 + 0.5) * side);
    for _ in 0..2 {
        let (mut sum, mut total) = ([0.0f32; 3], 0.0f32);
        for (colour, area) in samples.iter().filter(|(c, _)| distance(*c, main) < MAIN_FAR) {
            for k in 0..3 {
                sum[k] += colour[k] * area;
            }
            total += area;
        }
        if total > 0.0 {
            main = sum.map(|v| v / total);
        }
    }
    if samples.is_empty() { [128.0; 3] } else { main }
}

/// A box of `size` (Drake axes, centred at the origin) as `dir/stem.gltf`, its faces
/// textured with `shell` tiled in world metres: floors and walls.
pub fn write_shell_box(shell: &ShellTexture, size: [f64; 3], dir: &Path, stem: &str) -> Result<()> {
    std::fs::create_dir_all(dir).map_err(|e| InputError::io(dir, &e))?;
    let extension = shell.file.extension().and_then(|e| e.to_str()).unwrap_or("jpg").to_ascii_lowercase();
    let image = format!("{}_texture.{extension}", shell.name);
    let target = dir.join(&image);
    std::fs::copy(&shell.file, &target).map_err(|e| InputError::io(&shell.file, &e))?;
    let h = size.map(|v| v / 2.0);
    let (mut positions, mut normals, mut uvs, mut indices) = (Vec::new(), Vec::new(), Vec::new(), Vec::new());
    // Each face: its normal axis and sign; texture axes are the other two, in metres / tile.
    for (axis, sign) in [(0, 1.0), (0, -1.0), (1, 1.0), (1, -1.0), (2, 1.0), (2, -1.0)] {
        let (u_axis, v_axis) = match axis {
            0 => (1, 2),
            1 => (0, 2),
            _ => (0, 1),
        };
        let base = positions.len() as u32;
        let corners = [(-1.0, -1.0), (1.0, -1.0), (1.0, 1.0), (-1.0, 1.0)];
        for (cu, cv) in corners {
            let mut p = [0.0; 3];
            p[axis] = sign * h[axis];
            p[u_axis] = cu * h[u_axis];
            p[v_axis] = cv * h[v_axis];
            let mut n = [0.0; 3];
            n[axis] = sign;
            positions.push(to_gltf(p));
            normals.push(to_gltf(n));
            uvs.push([(p[u_axis] / shell.tile) as f32, (-p[v_axis] / shell.tile) as f32]);
        }
        // Counter-clockwise seen from outside: flip the winding on faces whose corner order
        // runs clockwise about their normal.
        let clockwise = (sign < 0.0) ^ (axis == 1);
        indices.extend(if clockwise { [base, base + 2, base + 1, base, base + 3, base + 2] } else { [base, base + 1, base + 2, base, base + 2, base + 3] });
    }
    let primitive = OutPrimitive {
        positions: &positions,
        normals: &normals,
        uvs: Some(&uvs),
        indices: &indices,
        material: OutMaterial { name: &shell.name, color: [1.0; 4], texture: Some(&image), occlusion: None },
    };
    write_gltf(dir, stem, stem, "osmab room shell", &[primitive])
}
