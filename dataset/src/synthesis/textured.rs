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
/// other colours (a chair's black legs, a desk's white frame) keep theirs, unless they lie
/// scattered among the main material's ([`among_main`]): a weave's dark threads, a
/// granite's flecks, a bake's aliasing are the material's pattern, and kept in their own
/// colours they were the yellow and black "starfield" on a navy sofa.
fn recolour(texture: &Texture, meshes: &[&TriangleMesh], finish: &Finish) -> Vec<u8> {
    let samples = shown_texels(texture, meshes);
    let main = main_colour(&samples);
    let main_luminance = luminance(main);
    let flat = brightness_spread(&samples, main) < FLAT;
    let strength = finish.material.pattern();
    let (width, height) = (texture.width as usize, texture.height as usize);
    let texels: Vec<[f32; 3]> = texture.rgba.chunks_exact(4).map(|p| [p[0], p[1], p[2]].map(f32::from)).collect();
    let of_main: Vec<f32> = texels.iter().map(|&t| ((MAIN_FAR - distance(t, main)) / (MAIN_FAR - MAIN_NEAR)).clamp(0.0, 1.0)).collect();
    let among = among_main(&of_main, width, height);
    texels
        .iter()
        .enumerate()
        .flat_map(|(i, &texel)| {
            let weight = of_main[i].max(among[i]);
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

/// Texels around a texel (either way, along each axis) that say whether it lies among the
/// main material: a weave's threads and a stone's flecks are a texel or two wide.
const AMONG_RADIUS: usize = 2;
/// Share of the texels around a texel that are of the main material (`of_main`, averaged)
/// below which it is wholly apart from it, and above which wholly among it.
const AMONG_APART: f32 = 0.3;
const AMONG_WITHIN: f32 = 0.55;

/// For each texel, how far it lies among texels of the main material (0 to 1): the mean of
/// `of_main` over the square of [`AMONG_RADIUS`] around it (cut at the texture's edges),
/// mapped from [`AMONG_APART`]..[`AMONG_WITHIN`] to 0..1. A part of another colour (legs,
/// a handle, a frame) is a patch of its own, so its texels, all but its rim, stay apart.
fn among_main(of_main: &[f32], width: usize, height: usize) -> Vec<f32> {
    // A box filter, rows then columns: each texel the mean of the texels within the radius.
    let mean_along = |values: &[f32], len: usize, count: usize, at: &dyn Fn(usize, usize) -> usize| -> Vec<f32> {
        let mut out = vec![0.0f32; values.len()];
        for line in 0..count {
            for k in 0..len {
                let (lo, hi) = (k.saturating_sub(AMONG_RADIUS), (k + AMONG_RADIUS).min(len - 1));
                let sum: f32 = (lo..=hi).map(|j| values[at(line, j)]).sum();
                out[at(line, k)] = sum / (hi - lo + 1) as f32;
            }
        }
        out
    };
    let rows = mean_along(of_main, width, height, &|y, x| y * width + x);
    let around = mean_along(&rows, height, width, &|x, y| y * width + x);
    around.into_iter().map(|share| ((share - AMONG_APART) / (AMONG_WITHIN - AMONG_APART)).clamp(0.0, 1.0)).collect()
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

/// The largest relative brightness a shell texture's marks (plaster, brush strokes) give a
/// painted texel, either way.
const PAINT_DEVIATION: f32 = 0.25;

/// `texture` in `paint`: every texel the paint's colour, as much brighter or darker as the
/// texel is against the texture's mean brightness (within [`PAINT_DEVIATION`]), so the
/// wall keeps its plaster and loses the texture's own hue (every room's walls were one
/// lilac before).
fn painted(texture: &Texture, paint: &Finish) -> Vec<u8> {
    let texels = || texture.rgba.chunks_exact(4).map(|p| luminance([p[0], p[1], p[2]].map(f32::from)));
    let mean = texels().sum::<f32>() / texels().len().max(1) as f32;
    texels()
        .flat_map(|l| {
            let gain = 1.0 + ((l - mean) / mean.max(PATTERN_FLOOR)).clamp(-PAINT_DEVIATION, PAINT_DEVIATION);
            paint.colour.map(|c| (c * gain * 255.0).round().clamp(0.0, 255.0) as u8)
        })
        .collect()
}

/// A box of `size` (Drake axes, centred at the origin) as `dir/stem.gltf`, its faces
/// textured with `shell` tiled in world metres: floors and walls; with a `paint`, the
/// texture in that paint ([`painted`]).
pub fn write_shell_box(shell: &ShellTexture, paint: Option<&Finish>, size: [f64; 3], dir: &Path, stem: &str) -> Result<()> {
    std::fs::create_dir_all(dir).map_err(|e| InputError::io(dir, &e))?;
    let image = match paint {
        Some(paint) => {
            let image = format!("{}_{}_texture.png", shell.name, paint.name);
            let bytes = std::fs::read(&shell.file).map_err(|e| InputError::io(&shell.file, &e))?;
            let texture = crate::convert::gltf::decode_image(&bytes).map_err(|why| InputError::new(&shell.file, "image", why))?;
            write_png_rgb(&dir.join(&image), &RgbImage { width: texture.width, height: texture.height, pixels: painted(&texture, paint) })?;
            image
        }
        None => {
            let extension = shell.file.extension().and_then(|e| e.to_str()).unwrap_or("jpg").to_ascii_lowercase();
            let image = format!("{}_texture.{extension}", shell.name);
            std::fs::copy(&shell.file, dir.join(&image)).map_err(|e| InputError::io(&shell.file, &e))?;
            image
        }
    };
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::classes::table;

    /// A `size`×`size` texture of `base`, with `paint` at the texels `at` says.
    fn texture(size: usize, base: [u8; 3], paint: [u8; 3], at: impl Fn(usize, usize) -> bool) -> Texture {
        let rgba = (0..size * size)
            .flat_map(|i| {
                let c = if at(i % size, i / size) { paint } else { base };
                [c[0], c[1], c[2], 255]
            })
            .collect();
        Texture { width: size as u32, height: size as u32, rgba }
    }

    /// A grid of 8 × 8 quads over the whole texture (its triangles' centres sample it).
    fn grid() -> TriangleMesh {
        let n = 8;
        let corner = |i: usize, j: usize| [i as f32 / n as f32, j as f32 / n as f32];
        let positions: Vec<[f32; 3]> = (0..=n).flat_map(|j| (0..=n).map(move |i| [i as f32, j as f32, 0.0])).collect();
        let uvs = (0..=n).flat_map(|j| (0..=n).map(move |i| corner(i, j))).collect();
        let at = |i: usize, j: usize| (j * (n + 1) + i) as u32;
        let indices =
            (0..n).flat_map(|j| (0..n).flat_map(move |i| [at(i, j), at(i + 1, j), at(i + 1, j + 1), at(i, j), at(i + 1, j + 1), at(i, j + 1)])).collect();
        TriangleMesh { normals: vec![[0.0, 0.0, 1.0]; positions.len()], positions, uvs: Some(uvs), indices, material: Some(0) }
    }

    fn texel(rgb: &[u8], size: usize, x: usize, y: usize) -> [u8; 3] {
        let i = 3 * (y * size + x);
        [rgb[i], rgb[i + 1], rgb[i + 2]]
    }

    #[test]
    fn a_painted_wall_takes_the_paints_colour_on_average_and_keeps_the_textures_marks() {
        let paint = table().finish("pale_blue_paint").expect("a finish of the table");
        // A lilac plaster: two brightnesses in stripes.
        let plaster = texture(8, [170, 160, 180], [150, 140, 160], |x, _| x % 2 == 0);
        let out = painted(&plaster, paint);
        let mean: [f32; 3] = std::array::from_fn(|c| out.chunks_exact(3).map(|t| t[c] as f32).sum::<f32>() / 64.0);
        for c in 0..3 {
            assert!((mean[c] - paint.colour[c] * 255.0).abs() < 1.5, "channel {c}: {mean:?} against {:?}", paint.colour);
        }
        // The darker stripes stay darker, by their share of the brightness.
        let (light, dark) = (texel(&out, 8, 1, 0), texel(&out, 8, 0, 0));
        assert!(dark.iter().zip(light).all(|(&d, l)| (d as f32) < l as f32 * 0.95), "{dark:?} {light:?}");
    }

    #[test]
    fn scattered_threads_of_another_colour_take_the_finish_as_its_pattern_and_a_part_of_its_own_keeps_its_colour() {
        let navy = table().finish("navy_fabric").expect("a finish of the table");
        let size = 64;
        // A yellow fabric of two shades woven with black threads every fourth texel, and a
        // black leg: the square in the corner, 16 texels a side.
        let leg = |x: usize, y: usize| x < 16 && y < 16;
        let mut fabric = texture(size, [190, 188, 110], [12, 12, 12], |x, y| leg(x, y) || (x % 4 == 0 && y % 4 == 0));
        for (i, t) in fabric.rgba.chunks_exact_mut(4).enumerate() {
            let (x, y) = (i % size, i / size);
            if t[0] == 190 && (x + 2 * y) % 3 == 0 {
                t[..3].copy_from_slice(&[172, 170, 100]);
            }
        }
        let out = recolour(&fabric, &[&grid()], navy);
        let navy_rgb = navy.colour.map(|c| c * 255.0);
        let near_navy = |t: [u8; 3], tolerance: f32| (0..3).all(|c| (t[c] as f32 - navy_rgb[c]).abs() <= tolerance * navy_rgb[c].max(1.0));
        // A thread among the weave is a darker navy, not black; the weave beside it is navy.
        let (thread, weave) = (texel(&out, size, 40, 40), texel(&out, size, 41, 42));
        assert!(near_navy(thread, 0.3) && thread.iter().zip(weave).all(|(&t, w)| t < w), "thread {thread:?}, weave {weave:?}");
        assert!(near_navy(weave, 0.05), "{weave:?}");
        // The leg keeps its black, away from its rim.
        assert_eq!(texel(&out, size, 5, 5), [12, 12, 12]);
    }
}
