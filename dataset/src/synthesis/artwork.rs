//! A picture's print drawn anew ([`printed`]): the pack's wall art is Infinigen's noise in
//! blots a centimetre a texel, which at a metre reads as pixelated blobs. Real rooms hang
//! photographs and prints of landscapes, seascapes, botanical plates and colour-field
//! paintings, behind a mat. One of those subjects is drawn for the canvas of the picture's
//! mesh, on a texture finer than the pack's, and toned in the picture's print tone; the
//! frame keeps the pack's texels, toned as before. A pure function of the texture, the
//! meshes, the tone and a seed.

use osmab_evaluator::formats::image::RgbImage;
use osmab_evaluator::synthetic::Rng;

use super::recolour::{tone_texel, toned, value_noise as noise};
use crate::classes::PrintTone;
use crate::convert::gltf::{Texture, TriangleMesh};

/// The texel a canvas is drawn at (metres on the picture at the mesh's own scale), the most
/// a texture's side is multiplied by, and the longest side it grows to.
const CANVAS_TEXEL: f32 = 0.0015;
const MAX_UPSAMPLE: usize = 4;
const MAX_SIDE: usize = 2048;
/// A triangle facing along the picture's thin axis at least this share of the largest such
/// triangle's area is canvas; the frame's faces are strips far smaller.
const CANVAS_SHARE: f32 = 0.25;
/// The mat around the print, as a share of the canvas's shorter side.
const MAT: f32 = 0.08;

/// What a print shows.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Subject {
    /// Ridges one behind another, paler with distance, under a sky.
    Mountains,
    /// A sea under a sky, a low sun and its reflection.
    Seascape,
    /// A plant's stem and leaves on paper, as a botanical plate.
    Botanical,
    /// Two or three soft-edged fields of colour, as a colour-field painting.
    ColourFields,
}

const SUBJECTS: [Subject; 4] = [Subject::Mountains, Subject::Seascape, Subject::Botanical, Subject::ColourFields];

/// The canvas of a picture's mesh: its triangles' texture coordinates and where each vertex
/// lies on the canvas (0–1 across, 0–1 up).
struct Canvas {
    triangles: Vec<[([f32; 2], [f32; 2]); 3]>,
    /// Width over height, in metres.
    aspect: f32,
    /// Metres across one texel of the pack's texture.
    texel: f32,
}

/// `texture` of a picture whose meshes are `meshes`, its canvas drawn anew with a print
/// chosen by `seed` and everything toned in `tone`; without a canvas to find (no UVs, no
/// face along a thin axis), the pack's print toned as it is.
pub(super) fn printed(texture: &Texture, meshes: &[&TriangleMesh], tone: &PrintTone, seed: u64) -> RgbImage {
    let (width, height) = (texture.width as usize, texture.height as usize);
    let Some(canvas) = canvas_of(texture, meshes) else {
        return RgbImage { width: texture.width, height: texture.height, pixels: toned(texture, tone) };
    };
    let most = (MAX_SIDE / width.max(height).max(1)).clamp(1, MAX_UPSAMPLE);
    let factor = ((canvas.texel / CANVAS_TEXEL).ceil() as usize).clamp(1, most);
    let (out_width, out_height) = (width * factor, height * factor);
    let frame = toned(texture, tone);
    let mut pixels = vec![0u8; out_width * out_height * 3];
    for (o, px) in pixels.chunks_exact_mut(3).enumerate() {
        let (x, y) = (o % out_width / factor, o / out_width / factor);
        px.copy_from_slice(&frame[3 * (y * width + x)..3 * (y * width + x) + 3]);
    }
    let print = Print::drawn(seed, canvas.aspect);
    for triangle in &canvas.triangles {
        let uv = triangle.map(|(uv, _)| [uv[0] * out_width as f32, uv[1] * out_height as f32]);
        let area = cross(uv[0], uv[1], uv[2]);
        if area.abs() < 1e-9 {
            continue;
        }
        let lo = |k: usize| uv.iter().map(|p| p[k]).fold(f32::INFINITY, f32::min).floor().max(0.0) as usize;
        let hi = |k: usize, n: usize| (uv.iter().map(|p| p[k]).fold(f32::NEG_INFINITY, f32::max).ceil().max(0.0) as usize).min(n);
        for y in lo(1)..hi(1, out_height) {
            for x in lo(0)..hi(0, out_width) {
                let p = [x as f32 + 0.5, y as f32 + 0.5];
                let w = [cross(uv[1], uv[2], p) / area, cross(uv[2], uv[0], p) / area, cross(uv[0], uv[1], p) / area];
                if w.iter().any(|&v| v < -1e-4) {
                    continue;
                }
                let at = |k: usize| w[0] * triangle[0].1[k] + w[1] * triangle[1].1[k] + w[2] * triangle[2].1[k];
                let colour = print.at(at(0), at(1));
                pixels[3 * (y * out_width + x)..3 * (y * out_width + x) + 3].copy_from_slice(&tone_texel(colour, tone));
            }
        }
    }
    RgbImage { width: out_width as u32, height: out_height as u32, pixels }
}

/// Twice the signed area of the triangle (a, b, c).
fn cross(a: [f32; 2], b: [f32; 2], c: [f32; 2]) -> f32 {
    (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0])
}

/// The canvas of `meshes`: the large faces along the thinnest axis of their box, on the
/// side the largest of them lies (the front; the back against the wall is the frame's ring).
fn canvas_of(texture: &Texture, meshes: &[&TriangleMesh]) -> Option<Canvas> {
    let all = || meshes.iter().flat_map(|m| m.positions.iter());
    let (lo, hi) = all()
        .fold(([f32::INFINITY; 3], [f32::NEG_INFINITY; 3]), |(lo, hi), p| (std::array::from_fn(|k| lo[k].min(p[k])), std::array::from_fn(|k| hi[k].max(p[k]))));
    let extent: [f32; 3] = std::array::from_fn(|k| hi[k] - lo[k]);
    if extent.iter().any(|e| !e.is_finite()) {
        return None;
    }
    let thin = (0..3).min_by(|&a, &b| extent[a].total_cmp(&extent[b]))?;
    // Across and up: glTF's y is up, unless the picture lies flat.
    let up = if thin == 1 { 2 } else { 1 };
    let across = 3 - thin - up;
    let mut faces = Vec::new();
    for m in meshes {
        let Some(uvs) = &m.uvs else { continue };
        for t in m.indices.chunks_exact(3) {
            let [a, b, c] = [t[0], t[1], t[2]].map(|i| i as usize);
            // Indices are checked against the vertices when the glTF is read (as `texel_metres` relies on).
            let [pa, pb, pc] = [a, b, c].map(|i| m.positions[i]);
            let [ua, ub, uc] = [a, b, c].map(|i| uvs[i]);
            let (e1, e2) = ([0, 1, 2].map(|k| pb[k] - pa[k]), [0, 1, 2].map(|k| pc[k] - pa[k]));
            let normal = [e1[1] * e2[2] - e1[2] * e2[1], e1[2] * e2[0] - e1[0] * e2[2], e1[0] * e2[1] - e1[1] * e2[0]];
            let double_area = normal.iter().map(|v| v * v).sum::<f32>().sqrt();
            if double_area > 0.0 && normal[thin].abs() > 0.9 * double_area {
                faces.push((double_area / 2.0, (pa[thin] + pb[thin] + pc[thin]) / 3.0, [(ua, pa), (ub, pb), (uc, pc)]));
            }
        }
    }
    let &(largest, front, _) = faces.iter().max_by(|a, b| a.0.total_cmp(&b.0))?;
    let canvas: Vec<_> = faces.into_iter().filter(|(area, depth, _)| *area >= CANVAS_SHARE * largest && (depth - front).abs() <= 0.25 * extent[thin]).collect();
    let (mut min, mut max) = ([f32::INFINITY; 2], [f32::NEG_INFINITY; 2]);
    for (_, _, corners) in &canvas {
        for (_, p) in corners {
            min = [min[0].min(p[across]), min[1].min(p[up])];
            max = [max[0].max(p[across]), max[1].max(p[up])];
        }
    }
    let size = [max[0] - min[0], max[1] - min[1]];
    if !(size[0] > 0.0 && size[1] > 0.0) {
        return None;
    }
    let uv_area: f32 = canvas.iter().map(|(_, _, c)| 0.5 * cross(c[0].0, c[1].0, c[2].0).abs()).sum();
    let texels = uv_area * texture.width as f32 * texture.height as f32;
    let surface: f32 = canvas.iter().map(|(area, _, _)| area).sum();
    let texel = if texels > 0.0 { (surface / texels).sqrt() } else { return None };
    let place = |p: [f32; 3]| [(p[across] - min[0]) / size[0], (p[up] - min[1]) / size[1]];
    let triangles = canvas.iter().map(|(_, _, c)| c.map(|(uv, p)| (uv, place(p)))).collect();
    Some(Canvas { triangles, aspect: size[0] / size[1], texel })
}

/// One print: its subject and the shapes drawn for it.
struct Print {
    subject: Subject,
    aspect: f32,
    /// Per subject: ridge heights and roughness, the horizon, a stem's sway, fields' bounds.
    params: [f32; 8],
    seed: u32,
}

impl Print {
    fn drawn(seed: u64, aspect: f32) -> Print {
        let mut rng = Rng::new(seed ^ 0xA7_7E0F);
        let subject = SUBJECTS[rng.below(SUBJECTS.len())];
        let params = std::array::from_fn(|_| rng.range(0.0, 1.0) as f32);
        Print { subject, aspect, params, seed: rng.next_u64() as u32 }
    }

    /// The print's colour (sRGB, 0–1) at (s, t) on the canvas, 0–1 across and up: paper in
    /// the mat, the subject inside it.
    fn at(&self, s: f32, t: f32) -> [f32; 3] {
        let mat = MAT * self.aspect.min(1.0);
        let mat_across = MAT * (1.0 / self.aspect).min(1.0);
        let (s0, t0) = ((s - mat_across) / (1.0 - 2.0 * mat_across), (t - mat) / (1.0 - 2.0 * mat));
        if !(0.0..=1.0).contains(&s0) || !(0.0..=1.0).contains(&t0) {
            return [0.95, 0.94, 0.91];
        }
        let grain = 0.03 * noise(s0 * 300.0, t0 * 300.0 / self.aspect, self.seed ^ 7);
        let c = match self.subject {
            Subject::Mountains => self.mountains(s0, t0),
            Subject::Seascape => self.seascape(s0, t0),
            Subject::Botanical => self.botanical(s0, t0),
            Subject::ColourFields => self.colour_fields(s0, t0),
        };
        c.map(|v| (v + grain).clamp(0.0, 1.0))
    }

    fn sky(&self, t: f32, horizon: f32) -> [f32; 3] {
        let above = ((t - horizon) / (1.0 - horizon)).clamp(0.0, 1.0);
        mix([0.86, 0.84, 0.80], [0.46, 0.58, 0.72], above.powf(0.7))
    }

    fn mountains(&self, s: f32, t: f32) -> [f32; 3] {
        let p = &self.params;
        let layers = 3 + (p[0] * 2.0) as usize;
        let mut colour = self.sky(t, 0.35);
        for k in 0..layers {
            let depth = k as f32 / (layers - 1) as f32; // 0 far, 1 near
            let base = 0.62 - 0.45 * depth + 0.1 * p[1];
            let amp = 0.12 + 0.18 * p[2] * (1.0 - 0.5 * depth);
            let ridge = base + amp * fbm(s * (2.0 + 3.0 * depth) * self.aspect + 17.0 * k as f32, self.seed.wrapping_add(k as u32));
            let below = smooth(0.0, 0.004, ridge - t);
            if below > 0.0 {
                let (far, near) = ([0.62, 0.66, 0.70], [0.16, 0.19, 0.15]);
                let shade = 0.035 * noise(s * 60.0 * self.aspect, t * 60.0, self.seed ^ (k as u32 + 90));
                colour = mix(colour, mix(far, near, depth).map(|v| v + shade), below);
            }
        }
        colour
    }

    fn seascape(&self, s: f32, t: f32) -> [f32; 3] {
        let p = &self.params;
        let horizon = 0.3 + 0.25 * p[0];
        let (sun_s, sun_t, radius) = (0.2 + 0.6 * p[1], horizon + 0.1 + 0.25 * p[2], 0.04 + 0.04 * p[3]);
        let d = ((s - sun_s) * self.aspect).hypot(t - sun_t);
        if t >= horizon {
            let sun = ((radius - d) / 0.01).clamp(0.0, 1.0);
            let clouds = (fbm(s * 3.0 * self.aspect, self.seed ^ 3) * 0.5 + 0.5) * smooth(0.55, 0.9, t) * 0.25 * p[4];
            return mix(self.sky(t, horizon), [0.97, 0.95, 0.88], sun.max(clouds));
        }
        let below = (horizon - t) / horizon;
        let swell = 0.08 * noise(s * 6.0 * self.aspect, t * 90.0, self.seed ^ 5) + 0.04 * noise(s * 30.0 * self.aspect, t * 300.0, self.seed ^ 6);
        let glitter = (1.0 - ((s - sun_s) * self.aspect).abs() / (0.05 + 0.1 * below)).clamp(0.0, 1.0) * (0.5 + swell * 6.0).clamp(0.0, 1.0);
        let sea = mix([0.40, 0.50, 0.58], [0.14, 0.22, 0.28], below.powf(0.6)).map(|v| v + swell);
        mix(sea, [0.92, 0.90, 0.82], 0.6 * glitter)
    }

    fn botanical(&self, s: f32, t: f32) -> [f32; 3] {
        let p = &self.params;
        let paper = [0.93, 0.91, 0.85];
        let leaf_colour = [0.24, 0.36, 0.22];
        let (x, y) = ((s - 0.5) * self.aspect, t);
        let stem_at = |y: f32| 0.12 * (p[0] - 0.5) * (y * 3.0 + std::f32::consts::TAU * p[1]).sin() * self.aspect.min(1.0);
        // Edges drawn soft over a few texels, as a printed line is: hard ones stair-step
        // where the renderer magnifies the texture.
        let mut ink = (1.0 - smooth(0.004, 0.008, (x - stem_at(y)).abs())) * smooth(0.04, 0.06, y) * (1.0 - smooth(0.91, 0.93, y));
        let leaves = 5 + (p[2] * 5.0) as usize;
        for k in 0..leaves {
            let ly = 0.12 + 0.78 * (k as f32 + 0.5) / leaves as f32;
            let side = if k % 2 == 0 { 1.0 } else { -1.0 };
            let length = (0.16 + 0.08 * p[3]) * (1.0 - 0.5 * ly) * self.aspect.min(1.0);
            // The leaf points out from the stem and a little up.
            let rise: f32 = 0.3 + 0.4 * p[4];
            let direction = [side * rise.cos(), rise.sin()];
            let (dx, dy) = (x - stem_at(ly), y - ly);
            // Into the leaf's frame: along it from the stem, and across it.
            let along = (dx * direction[0] + dy * direction[1]) / length;
            let across = (dy * direction[0] - dx * direction[1]) / (0.32 * length);
            let r = (2.0 * along - 1.0).powi(2) + across * across;
            if r < 1.0 {
                let vein = 0.35 * (1.0 - smooth(0.03, 0.08, across.abs()));
                ink = ink.max(smooth(0.0, 0.12, 1.0 - r) * (0.85 - vein - 0.2 * r));
            }
        }
        mix(paper, leaf_colour, ink)
    }

    fn colour_fields(&self, s: f32, t: f32) -> [f32; 3] {
        let p = &self.params;
        let ground = mix([0.55, 0.32, 0.26], [0.22, 0.28, 0.36], p[0]);
        let fields = [
            (0.55 + 0.1 * p[1], 0.92, mix([0.78, 0.58, 0.36], [0.62, 0.66, 0.58], p[2])),
            (0.08, 0.45 + 0.08 * p[3], mix([0.30, 0.18, 0.16], [0.75, 0.70, 0.55], p[4])),
        ];
        let mut colour = ground.map(|v| v + 0.03 * noise(s * 8.0, t * 8.0, self.seed ^ 11));
        for (k, (bottom, top, fill)) in fields.into_iter().enumerate() {
            let edge = 0.015 * noise(s * 30.0, t * 30.0, self.seed ^ (20 + k as u32));
            let inside = smooth(-0.02, 0.02, (t - bottom + edge).min(top - t + edge)) * smooth(-0.02, 0.02, (s - 0.08 + edge).min(0.92 - s + edge));
            let brush = 0.04 * noise(s * 20.0, t * 60.0, self.seed ^ (30 + k as u32));
            colour = mix(colour, fill.map(|v| v + brush), inside);
        }
        colour
    }
}

fn mix(a: [f32; 3], b: [f32; 3], w: f32) -> [f32; 3] {
    std::array::from_fn(|k| a[k] + (b[k] - a[k]) * w)
}

/// 0 below `a`, 1 above `b`, smooth between.
fn smooth(a: f32, b: f32, x: f32) -> f32 {
    let t = ((x - a) / (b - a)).clamp(0.0, 1.0);
    t * t * (3.0 - 2.0 * t)
}

/// A ridge's profile along `x`: four octaves of value noise, about ±1.
fn fbm(x: f32, seed: u32) -> f32 {
    (0..4).map(|o| noise(x * (1 << o) as f32, 0.5, seed.wrapping_add(o)) / (1 << o) as f32).sum::<f32>() / 1.875
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::classes::table;

    /// A picture as the pack's are: a frame's ring and a canvas quad facing +z, 1.2 × 0.8 m,
    /// 2 cm thick, on a 64-texel atlas whose frame is dark brown and whose canvas (u ≥ 0.5)
    /// is toy-coloured blots.
    fn picture() -> (Texture, TriangleMesh) {
        let size = 64;
        let rgba = (0..size * size)
            .flat_map(|i| {
                let (x, y) = (i % size, i / size);
                let c = if x < size / 2 {
                    [60, 40, 25]
                } else if (x / 4 + y / 4) % 2 == 0 {
                    [230, 220, 30]
                } else {
                    [220, 40, 200]
                };
                [c[0], c[1], c[2], 255]
            })
            .collect();
        let texture = Texture { width: size as u32, height: size as u32, rgba };
        let (w, h, d) = (0.6, 0.8, 0.01);
        // The canvas, then a frame strip on each side (front) and the back.
        let mut positions = vec![[-w, 0.0, d], [w, 0.0, d], [w, h, d], [-w, h, d]];
        let mut uvs = vec![[0.5, 1.0], [1.0, 1.0], [1.0, 0.0], [0.5, 0.0]];
        let mut indices = vec![0, 1, 2, 0, 2, 3];
        for (k, (lo, hi)) in [([-w, 0.0], [w, 0.02]), ([-w, h - 0.02], [w, h]), ([-w, 0.0], [-w + 0.02, h]), ([w - 0.02, 0.0], [w, h])].into_iter().enumerate()
        {
            let first = positions.len() as u32;
            let z = if k == 0 { -d } else { d };
            positions.extend([[lo[0], lo[1], z], [hi[0], lo[1], z], [hi[0], hi[1], z], [lo[0], hi[1], z]]);
            uvs.extend([[0.0, 1.0], [0.4, 1.0], [0.4, 0.0], [0.0, 0.0]]);
            indices.extend([first, first + 1, first + 2, first, first + 2, first + 3]);
        }
        let mesh = TriangleMesh { normals: vec![[0.0, 0.0, 1.0]; positions.len()], positions, uvs: Some(uvs), indices, material: Some(0) };
        (texture, mesh)
    }

    fn texel(image: &RgbImage, x: usize, y: usize) -> [u8; 3] {
        let i = 3 * (y * image.width as usize + x);
        [image.pixels[i], image.pixels[i + 1], image.pixels[i + 2]]
    }

    #[test]
    fn a_canvas_is_found_on_the_front_with_its_texel_and_shape() {
        let (texture, mesh) = picture();
        let canvas = canvas_of(&texture, &[&mesh]).expect("a canvas");
        assert_eq!(canvas.triangles.len(), 2, "the frame's strips are not canvas");
        assert!((canvas.aspect - 1.5).abs() < 1e-5, "{}", canvas.aspect);
        // 1.2 m over 32 texels across, 0.8 m over 64 up: a texel of sqrt(0.96 / 2048) m.
        assert!((canvas.texel - (0.96f32 / 2048.0).sqrt()).abs() < 1e-5, "{}", canvas.texel);
        // Its corners: the vertex at u = 0.5, v = 1 is the canvas's bottom left.
        assert!(canvas.triangles[0].iter().any(|&(uv, at)| uv == [0.5, 1.0] && at == [0.0, 0.0]));
        let mut flat = mesh.clone();
        flat.uvs = None;
        assert!(canvas_of(&texture, &[&flat]).is_none(), "without UVs there is nothing to draw on");
    }

    #[test]
    fn a_picture_gets_a_finer_print_behind_a_mat_in_its_tone_and_its_frame_toned() {
        let (texture, mesh) = picture();
        for tone in table().print_tones() {
            for seed in 0..8 {
                let out = printed(&texture, &[&mesh], tone, seed);
                // 21.7 mm a texel becomes 5.4 mm: four times finer, the most it grows.
                assert_eq!((out.width, out.height), (256, 256));
                // The frame takes the ink, as `toned` gives it.
                assert_eq!(texel(&out, 10, 100), tone_texel([60.0, 40.0, 25.0].map(|v| v / 255.0), tone));
                // The mat, just inside the canvas's edge, is paper.
                let paper = tone_texel([0.95, 0.94, 0.91], tone);
                assert_eq!(texel(&out, 130, 128), paper, "{} seed {seed}", tone.name);
                // The print inside has shapes: brightness varies, and none of the blots' hue.
                let inside: Vec<f32> =
                    (150..240).flat_map(|x| (40..220).map(move |y| (x, y))).map(|(x, y)| texel(&out, x, y).iter().map(|&v| f32::from(v)).sum()).collect();
                let mean = inside.iter().sum::<f32>() / inside.len() as f32;
                let spread = (inside.iter().map(|v| (v - mean).powi(2)).sum::<f32>() / inside.len() as f32).sqrt();
                assert!(spread > 6.0, "{} seed {seed}: a flat print ({spread})", tone.name);
                let [r, g, b] = texel(&out, 200, 128).map(f32::from);
                assert!((r.max(g).max(b) - r.min(g).min(b)) / r.max(g).max(b).max(1.0) <= 0.5, "{} seed {seed}: saturated", tone.name);
            }
        }
    }

    #[test]
    fn every_subject_is_drawn_and_a_seed_draws_the_same_print_again() {
        let subjects: std::collections::BTreeSet<String> = (0..64).map(|seed| format!("{:?}", Print::drawn(seed, 1.4).subject)).collect();
        assert_eq!(subjects.len(), SUBJECTS.len(), "{subjects:?}");
        let (texture, mesh) = picture();
        let tone = &table().print_tones()[0];
        assert_eq!(printed(&texture, &[&mesh], tone, 3).pixels, printed(&texture, &[&mesh], tone, 3).pixels);
        assert_ne!(printed(&texture, &[&mesh], tone, 3).pixels, printed(&texture, &[&mesh], tone, 4).pixels);
    }
}
