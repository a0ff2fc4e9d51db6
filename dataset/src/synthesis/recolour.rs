//! How a pack texture takes an instance's look: its main material recoloured in a finish
//! ([`recolour`]), its print toned ([`toned`]), or, for a room's shell, painted
//! ([`painted`]). Pure functions of the texture, the meshes that show it and the look.

use osmab_evaluator::formats::image::RgbImage;

use crate::classes::{Finish, MaterialKind, PrintTone};
use crate::convert::gltf::{Texture, TriangleMesh};

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

/// A wood whose texels are coarser than this (metres on the instance) gets its grain drawn
/// in metres on a finer texture ([`recolour`]): a 512-texel bake spread over a wardrobe
/// (10–18 mm a texel) showed its grain and its bake's speckle as blurred blotches.
const COARSE_GRAIN_TEXEL: f32 = 0.006;
/// The texel a finer texture aims at, the most it multiplies a side by, and the longest side
/// it grows to (a 512 bake becomes at most 2048 a side: 16 MB in the renderer; a larger bake
/// is already fine enough, and a hostile one must not grow past what the converter reads).
const FINE_TEXEL: f32 = 0.004;
const MAX_UPSAMPLE: usize = 4;
const MAX_DRAWN_SIDE: usize = 2048;
/// The texel assumed where the meshes give no texture area to measure it by.
const DEFAULT_TEXEL: f32 = 0.005;

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
/// flat gets a fine pattern of its finish's material, drawn in metres; so does a wood whose
/// texels are coarse, on a texture up to [`MAX_UPSAMPLE`] times finer a side, each texel
/// of the bake then a square of texels. It averages to the finish; texels of
/// other colours (a chair's black legs, a desk's white frame) keep theirs, unless they lie
/// scattered among the main material's ([`among_main`]): a weave's dark threads, a
/// granite's flecks, a bake's aliasing are the material's pattern, and kept in their own
/// colours they were the yellow and black "starfield" on a navy sofa. With `print`
/// [`Print::Dropped`] every texel is of the main material, with its finish's drawn pattern.
pub(super) fn recolour(texture: &Texture, meshes: &[&TriangleMesh], scale: f32, finish: &Finish, print: Print) -> RgbImage {
    let samples = shown_texels(texture, meshes);
    let main = main_colour(&samples);
    let main_luminance = luminance(main);
    let texel_size = texel_metres(texture, meshes, scale);
    let coarse_wood = finish.material == MaterialKind::Wood && texel_size > COARSE_GRAIN_TEXEL;
    let dropped = print == Print::Dropped;
    let drawn = dropped || coarse_wood || brightness_spread(&samples, main) < FLAT;
    let (width, height) = (texture.width as usize, texture.height as usize);
    let most = (MAX_DRAWN_SIDE / width.max(height).max(1)).clamp(1, MAX_UPSAMPLE);
    let factor = if coarse_wood { ((texel_size / FINE_TEXEL).ceil() as usize).clamp(1, most) } else { 1 };
    let out_texel = texel_size / factor as f32;
    let strength = finish.material.pattern();
    let texels: Vec<[f32; 3]> = texture.rgba.chunks_exact(4).map(|p| [p[0], p[1], p[2]].map(f32::from)).collect();
    let of_main: Vec<f32> = texels.iter().map(|&t| ((MAIN_FAR - distance(t, main)) / (MAIN_FAR - MAIN_NEAR)).clamp(0.0, 1.0)).collect();
    let among = among_main(&of_main, width, height);
    let (out_width, out_height) = (width * factor, height * factor);
    let pixels = (0..out_width * out_height)
        .flat_map(|o| {
            let (x, y) = (o % out_width, o / out_width);
            let i = (y / factor) * width + x / factor;
            let (texel, weight) = (texels[i], if dropped { 1.0 } else { of_main[i].max(among[i]) });
            let deviation = if drawn {
                material_pattern(finish.material, x as f32 * out_texel, y as f32 * out_texel)
            } else {
                ((luminance(texel) - main_luminance) / main_luminance.max(PATTERN_FLOOR)).clamp(-MAX_DEVIATION, MAX_DEVIATION)
            };
            let gain = 1.0 + strength * deviation;
            std::array::from_fn::<u8, 3, _>(|c| (weight * finish.colour[c] * gain * 255.0 + (1.0 - weight) * texel[c]).round().clamp(0.0, 255.0) as u8)
        })
        .collect();
    RgbImage { width: out_width as u32, height: out_height as u32, pixels }
}

/// What becomes of a texture's print (what is not its main material) when it is recoloured.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) enum Print {
    /// Parts of other colours keep theirs (a chair's legs, a desk's frame, a can's label).
    Kept,
    /// It is not the class's look (the class table's `plain`): the finish covers it.
    Dropped,
}

/// The side of one texel of `texture` on `meshes` at `scale`, in metres: the square root of
/// their surface area over the texels their UVs cover ([`DEFAULT_TEXEL`] where they cover none).
fn texel_metres(texture: &Texture, meshes: &[&TriangleMesh], scale: f32) -> f32 {
    let (mut surface, mut texels) = (0.0f64, 0.0f64);
    let texture_area = texture.width as f64 * texture.height as f64;
    for m in meshes {
        let Some(uvs) = &m.uvs else { continue };
        for t in m.indices.chunks_exact(3) {
            let [a, b, c] = [t[0], t[1], t[2]].map(|i| i as usize);
            let (pa, pb, pc) = (m.positions[a].map(f64::from), m.positions[b].map(f64::from), m.positions[c].map(f64::from));
            let (e1, e2) = ([0, 1, 2].map(|k| pb[k] - pa[k]), [0, 1, 2].map(|k| pc[k] - pa[k]));
            let cross = [e1[1] * e2[2] - e1[2] * e2[1], e1[2] * e2[0] - e1[0] * e2[2], e1[0] * e2[1] - e1[1] * e2[0]];
            surface += 0.5 * (cross[0] * cross[0] + cross[1] * cross[1] + cross[2] * cross[2]).sqrt();
            let (ua, ub, uc) = (uvs[a].map(f64::from), uvs[b].map(f64::from), uvs[c].map(f64::from));
            texels += 0.5 * ((ub[0] - ua[0]) * (uc[1] - ua[1]) - (ub[1] - ua[1]) * (uc[0] - ua[0])).abs() * texture_area;
        }
    }
    let side = (surface / texels).sqrt() * f64::from(scale);
    if side.is_finite() && side > 0.0 { side as f32 } else { DEFAULT_TEXEL }
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

/// A seamless-enough pattern of `material` at (x, y) metres along the texture's rows and
/// columns, as a relative brightness in about ±0.5: wood thin streaks along the rows (a
/// grain line a few millimetres across and a dozen centimetres long, over a broad figure),
/// fabric a soft mottle, the rest a faint mottle. Deterministic (hashed lattice noise).
fn material_pattern(material: MaterialKind, x: f32, y: f32) -> f32 {
    match material {
        MaterialKind::Wood => {
            0.35 * value_noise(x / 0.12, y / 0.008, 11) + 0.25 * value_noise(x / 0.5, y / 0.04, 12) + 0.15 * value_noise(x / 0.03, y / 0.004, 13)
        }
        // Nothing finer than a few texels: a weave one texel fine is magnified into a mosaic
        // of squares on a sofa seen from a metre.
        MaterialKind::Fabric | MaterialKind::Leather => 0.2 * value_noise(x / 0.015, y / 0.015, 21) + 0.5 * value_noise(x / 0.07, y / 0.07, 22),
        _ => 0.4 * value_noise(x / 0.12, y / 0.12, 31),
    }
}

/// Smooth value noise in about [-1, 1] on an integer lattice hashed with `seed`.
pub(super) fn value_noise(x: f32, y: f32, seed: u32) -> f32 {
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

/// `texture` toned as a print in `tone`: each texel's brightness (0–1) placed between the
/// tone's ink and paper, plus the tone's share of the texel's own colour (its difference from
/// its grey). The print's shapes stay, its toy colours go; a dark frame takes the ink.
pub(super) fn toned(texture: &Texture, tone: &PrintTone) -> Vec<u8> {
    texture.rgba.chunks_exact(4).flat_map(|p| tone_texel([p[0], p[1], p[2]].map(|v| f32::from(v) / 255.0), tone)).collect()
}

/// One texel (sRGB, 0–1) toned in `tone`, as [`toned`] tones each.
pub(super) fn tone_texel(texel: [f32; 3], tone: &PrintTone) -> [u8; 3] {
    let grey = luminance(texel);
    std::array::from_fn(|c| {
        let value = tone.ink[c] + (tone.paper[c] - tone.ink[c]) * grey + tone.chroma * (texel[c] - grey);
        (value * 255.0).round().clamp(0.0, 255.0) as u8
    })
}

/// The largest relative brightness a shell texture's marks (plaster, brush strokes) give a
/// painted texel, either way.
const PAINT_DEVIATION: f32 = 0.25;

/// `texture` in `paint`: every texel the paint's colour, as much brighter or darker as the
/// texel is against the texture's mean brightness (within [`PAINT_DEVIATION`]), so the
/// wall keeps its plaster and loses the texture's own hue (every room's walls were one
/// lilac before).
pub(super) fn painted(texture: &Texture, paint: &Finish) -> Vec<u8> {
    let texels = || texture.rgba.chunks_exact(4).map(|p| luminance([p[0], p[1], p[2]].map(f32::from)));
    let mean = texels().sum::<f32>() / texels().len().max(1) as f32;
    texels()
        .flat_map(|l| {
            let gain = 1.0 + ((l - mean) / mean.max(PATTERN_FLOOR)).clamp(-PAINT_DEVIATION, PAINT_DEVIATION);
            paint.colour.map(|c| (c * gain * 255.0).round().clamp(0.0, 255.0) as u8)
        })
        .collect()
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
    fn a_print_in_toy_colours_toned_in_every_tone_is_muted_and_keeps_its_shapes() {
        // Infinigen's wall art: lemon yellow, royal blue and magenta blots on white, in a black frame.
        let colours: [[u8; 3]; 5] = [[230, 220, 30], [30, 60, 200], [220, 40, 200], [250, 250, 250], [8, 8, 8]];
        let print = Texture { width: 5, height: 1, rgba: colours.iter().flat_map(|c| [c[0], c[1], c[2], 255]).collect() };
        let saturation = |t: [u8; 3]| {
            let (max, min) = (t.iter().max().copied().unwrap_or(0), t.iter().min().copied().unwrap_or(0));
            if max == 0 { 0.0 } else { f32::from(max - min) / f32::from(max) }
        };
        let brightness = |t: [u8; 3]| luminance(t.map(f32::from));
        for tone in table().print_tones() {
            let out = toned(&print, tone);
            let texels: Vec<[u8; 3]> = (0..5).map(|x| texel(&out, 5, x, 0)).collect();
            for (before, after) in colours.iter().zip(&texels) {
                assert!(saturation(*after) <= 0.5, "{}: {before:?} toned {after:?} is saturated", tone.name);
            }
            // Lighter stays lighter: white > yellow > magenta > blue > black.
            for pair in [3, 0, 2, 1, 4].windows(2) {
                assert!(brightness(texels[pair[0]]) > brightness(texels[pair[1]]), "{}: {texels:?}", tone.name);
            }
            // The black frame takes the ink.
            let ink = tone.ink.map(|c| c * 255.0);
            assert!((0..3).all(|c| (f32::from(texels[4][c]) - ink[c]).abs() <= 8.0), "{}: frame {:?}, ink {ink:?}", tone.name, texels[4]);
        }
    }

    #[test]
    fn a_dropped_print_leaves_only_the_finish_in_its_own_faint_pattern() {
        let kraft = table().finish("kraft").expect("a finish of the table");
        let size = 64;
        // A food box's art: a grey ground with black letters and a green blot.
        let letters = |x: usize, y: usize| (8..24).contains(&y) && x % 6 < 3;
        let mut art = texture(size, [120, 110, 112], [10, 10, 10], letters);
        for t in art.rgba.chunks_exact_mut(4).skip(40 * size).take(10 * size) {
            t[..3].copy_from_slice(&[60, 110, 60]);
        }
        let kept = recolour(&art, &[&grid()], 0.05, kraft, Print::Kept).pixels;
        assert_eq!(texel(&kept, size, 1, 10), [10, 10, 10], "kept, the letters stay black");
        let plain = recolour(&art, &[&grid()], 0.05, kraft, Print::Dropped).pixels;
        let card = kraft.colour.map(|c| c * 255.0);
        // Letters, blot and ground alike: kraft within its pattern (strength 0.5 of ±0.4).
        for t in plain.chunks_exact(3) {
            assert!((0..3).all(|c| (f32::from(t[c]) - card[c]).abs() <= 0.21 * card[c] + 1.0), "{t:?} against {card:?}");
        }
        let mean: [f32; 3] = std::array::from_fn(|c| plain.chunks_exact(3).map(|t| f32::from(t[c])).sum::<f32>() / (size * size) as f32);
        assert!((0..3).all(|c| (mean[c] - card[c]).abs() < 0.05 * card[c]), "{mean:?} against {card:?}");
        // No trace of the print: a letter's texel is as bright as the ground three texels
        // either side (their mean, which the pattern's smooth slope does not move).
        let brightness = |x: usize, y: usize| luminance(texel(&plain, size, x, y).map(f32::from));
        for (x, y) in (8..24).flat_map(|y| (3..size - 3).map(move |x| (x, y))).filter(|&(x, y)| letters(x, y)) {
            let ground = (brightness(x - 3, y) + brightness(x + 3, y)) / 2.0;
            assert!((brightness(x, y) - ground).abs() < 3.0, "letter at ({x}, {y}): {} against {ground}", brightness(x, y));
        }
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
        let out = recolour(&fabric, &[&grid()], 1.0, navy, Print::Kept).pixels;
        let navy_rgb = navy.colour.map(|c| c * 255.0);
        let near_navy = |t: [u8; 3], tolerance: f32| (0..3).all(|c| (t[c] as f32 - navy_rgb[c]).abs() <= tolerance * navy_rgb[c].max(1.0));
        // A thread among the weave is a darker navy, not black; the weave beside it is navy.
        let (thread, weave) = (texel(&out, size, 40, 40), texel(&out, size, 41, 42));
        assert!(near_navy(thread, 0.3) && thread.iter().zip(weave).all(|(&t, w)| t < w), "thread {thread:?}, weave {weave:?}");
        assert!(near_navy(weave, 0.05), "{weave:?}");
        // The leg keeps its black, away from its rim.
        assert_eq!(texel(&out, size, 5, 5), [12, 12, 12]);
    }

    #[test]
    fn a_texel_measures_the_meshes_surface_over_the_texels_their_uvs_cover() {
        // The grid spans 8 × 8 metres over the whole 64 × 64 texture: 12.5 cm a texel.
        let plain = texture(64, [200, 200, 200], [0, 0, 0], |_, _| false);
        assert!((texel_metres(&plain, &[&grid()], 1.0) - 0.125).abs() < 1e-6);
        assert!((texel_metres(&plain, &[&grid()], 0.5) - 0.0625).abs() < 1e-6);
        let mut without_uvs = grid();
        without_uvs.uvs = None;
        assert_eq!(texel_metres(&plain, &[&without_uvs], 1.0), DEFAULT_TEXEL);
    }

    #[test]
    fn a_coarse_wood_is_drawn_finer_with_its_grain_along_the_rows_and_a_part_of_its_own_kept() {
        let oak = table().finish("oak").expect("a finish of the table");
        let size = 64;
        // A pale bake with texel noise (no grain of its own) and a black handle in the corner,
        // on a grid scaled to 12 mm a texel: three times finer a side, 4 mm a texel.
        let leg = |x: usize, y: usize| x < 16 && y < 16;
        let bake = texture(size, [205, 200, 190], [10, 10, 10], leg);
        let scale = 0.012 / 0.125;
        let out = recolour(&bake, &[&grid()], scale, oak, Print::Kept);
        assert_eq!((out.width, out.height), (3 * size as u32, 3 * size as u32));
        let side = 3 * size;
        let at = |x: usize, y: usize| texel(&out.pixels, side, x, y).map(f32::from);
        // Away from the handle it averages to oak.
        let wood: Vec<[f32; 3]> = (side / 2..side).flat_map(|y| (0..side).map(move |x| (x, y))).map(|(x, y)| at(x, y)).collect();
        for c in 0..3 {
            let mean = wood.iter().map(|t| t[c]).sum::<f32>() / wood.len() as f32;
            assert!((mean - oak.colour[c] * 255.0).abs() < 0.06 * oak.colour[c] * 255.0, "channel {c}: mean {mean}");
        }
        // Its grain runs along the rows: neighbours along a row differ less than across.
        let brightness = |t: [f32; 3]| luminance(t);
        let step = |dx: usize, dy: usize| {
            let pairs = (side / 2..side - 1).flat_map(|y| (0..side - 1).map(move |x| (x, y)));
            pairs.map(|(x, y)| (brightness(at(x, y)) - brightness(at(x + dx, y + dy))).abs()).sum::<f32>()
        };
        assert!(step(1, 0) * 2.0 < step(0, 1), "along {} across {}", step(1, 0), step(0, 1));
        // The handle keeps its black, away from its rim.
        assert_eq!(texel(&out.pixels, side, 15, 15), [10, 10, 10]);
        // A fabric on the same mesh keeps its bake's size.
        let fabric = table().finish("navy_fabric").expect("a finish of the table");
        assert_eq!(recolour(&bake, &[&grid()], scale, fabric, Print::Kept).width, size as u32);
        // A bake half the longest drawn side grows only twice, whatever its texel.
        let long = Texture { width: (MAX_DRAWN_SIDE / 2) as u32, height: 1, rgba: [205, 200, 190, 255].repeat(MAX_DRAWN_SIDE / 2) };
        let wide = recolour(&long, &[&grid()], 1.0, oak, Print::Kept);
        assert_eq!((wide.width, wide.height), (MAX_DRAWN_SIDE as u32, 2));
    }
}
