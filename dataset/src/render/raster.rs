//! A CPU rasteriser for RGB, planar depth and semantic images from one pinhole camera:
//! near-plane clipping, perspective-correct interpolation, a depth buffer, then a
//! deferred shading pass; rows are split into bands rendered on all cores, into
//! buffers allocated once per frame size.
//!
//! One file, over 600 lines, on purpose: the passes share the frame buffers and the band
//! split, and the hot loops stay together for the optimiser and the reader.

use nalgebra::Matrix4;
use rayon::prelude::*;

use super::mesh::{Triangle, World};

/// A pinhole camera: intrinsics (pixel centres at integer coordinates, as HaDaGe's
/// `c = (size − 1)/2` implies) and a camera-to-world pose in OpenCV axes
/// (x right, y down, z forward) in the Habitat world.
#[derive(Debug, Clone)]
pub struct Camera {
    pub width: u32,
    pub height: u32,
    pub fx: f64,
    pub fy: f64,
    pub cx: f64,
    pub cy: f64,
    pub pose: Matrix4<f64>,
}

/// A light as Habitat applies it: colour already scaled by intensity (×2.5, or ×0.1
/// for negative, darkening lights); attenuated by 1/(1 + d²) as Magnum's PhongGL does
/// for an unbounded range.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Light {
    /// World position, or offset from the camera for camera lights.
    pub position: [f32; 3],
    pub color: [f32; 3],
    pub attached_to_camera: bool,
}

/// No lights: albedo as it is (Habitat's flat shading); lights: Phong diffuse with
/// ambient 0.4.
#[derive(Debug, Clone, PartialEq)]
pub enum Shading {
    Flat,
    Lit(Vec<Light>),
}

/// Habitat's hard-coded ambient term of its Phong shading.
pub const AMBIENT: f32 = 0.4;
const INV_255: f32 = 1.0 / 255.0;

/// The fractional part of `x` (in [0, 1)), without libm's `floorf` (a call on baseline
/// x86-64, once per textured pixel).
fn fract(x: f32) -> f32 {
    if x.abs() < 8_388_608.0 {
        let f = x - (x as i32) as f32;
        if f < 0.0 { f + 1.0 } else { f }
    } else {
        0.0
    }
}
/// Nothing nearer than this is drawn.
const NEAR: f32 = 0.01;
/// Rows per parallel band.
const BAND: usize = 16;

/// The images of one frame, reused from frame to frame.
#[derive(Debug, Clone, Default)]
pub struct Frame {
    pub width: u32,
    pub height: u32,
    /// RGB, 3 bytes a pixel.
    pub rgb: Vec<u8>,
    /// Planar depth in metres (camera z); 0 where nothing is hit.
    pub depth: Vec<f32>,
    /// Class ids; 0 where nothing is hit.
    pub semantic: Vec<u16>,
    /// Object instance ids (the scene's semantic ids); 0 where nothing is hit.
    pub instance: Vec<u16>,
    /// Per pixel: index of the visible (clipped) triangle and the weights of its
    /// vertices 1 and 2 (planar, so the visibility pass writes them eight at a time).
    pub(super) hit: Vec<u32>,
    pub(super) weight1: Vec<f32>,
    pub(super) weight2: Vec<f32>,
}

impl Frame {
    fn resize(&mut self, width: u32, height: u32) {
        let n = (width * height) as usize;
        self.width = width;
        self.height = height;
        self.rgb.resize(n * 3, 0);
        self.depth.resize(n, 0.0);
        self.semantic.resize(n, 0);
        self.instance.resize(n, 0);
        self.hit.resize(n, u32::MAX);
        self.weight1.resize(n, 0.0);
        self.weight2.resize(n, 0.0);
    }
}

/// A triangle after clipping and projection: screen x, y and 1/z per vertex, plus the
/// source triangle and each vertex's barycentric coordinates in it.
#[derive(Debug, Clone, Copy)]
struct ScreenTriangle {
    /// Screen positions in f64: clipped floor and wall triangles reach ~10⁵ pixels.
    xy: [[f64; 2]; 3],
    inv_z: [f32; 3],
    /// 1/z over the screen, from the source triangle's plane: a·x + b·y + c.
    inv_z_plane: [f64; 3],
    /// Barycentric coordinates (in the source triangle) of each vertex.
    bary: [[f32; 3]; 3],
    source: u32,
}

fn to_camera(m: &Matrix4<f64>, p: [f32; 3]) -> [f32; 3] {
    let v = m * nalgebra::Vector4::new(p[0] as f64, p[1] as f64, p[2] as f64, 1.0);
    [v.x as f32, v.y as f32, v.z as f32]
}

/// Whether a camera-space triangle in front of the near plane lies wholly beyond one
/// edge of the image, by more than a pixel: its projection could cover no pixel centre,
/// so it is dropped before projecting (most of a room's triangles, for any one view).
/// The margin keeps this single-precision test on the safe side of the exact one.
fn outside_the_image(cam: &[[f32; 3]; 3], camera: &Camera) -> bool {
    let (fx, fy, cx, cy) = (camera.fx as f32, camera.fy as f32, camera.cx as f32, camera.cy as f32);
    let (w, h) = (camera.width as f32, camera.height as f32);
    // Screen x = fx·x/z + cx with z > 0: x < -1 ⟺ fx·x + (cx + 1)·z < 0, and so on.
    let left = cam.iter().all(|p| fx * p[0] + (cx + 1.0) * p[2] < 0.0);
    let right = cam.iter().all(|p| fx * p[0] + (cx - w) * p[2] > 0.0);
    let above = cam.iter().all(|p| fy * p[1] + (cy + 1.0) * p[2] < 0.0);
    let below = cam.iter().all(|p| fy * p[1] + (cy - h) * p[2] > 0.0);
    left || right || above || below
}

/// Clip a camera-space triangle against the near plane and project it.
fn clip_and_project(cam: &[[f32; 3]; 3], camera: &Camera, source: u32, out: &mut Vec<ScreenTriangle>) {
    let inside = cam.map(|p| p[2] >= NEAR);
    if !inside.iter().any(|&i| i) {
        return;
    }
    if inside.iter().all(|&i| i) && outside_the_image(cam, camera) {
        return;
    }
    let corners = [[1.0f32, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
    // Sutherland–Hodgman against z = NEAR, carrying barycentric coordinates: at most four
    // vertices, kept on the stack (this runs for every triangle of every frame).
    let mut poly = [([0.0f32; 3], [0.0f32; 3]); 4];
    let mut vertices = 0;
    for i in 0..3 {
        let (a, b) = ((cam[i], corners[i]), (cam[(i + 1) % 3], corners[(i + 1) % 3]));
        let (ia, ib) = (inside[i], inside[(i + 1) % 3]);
        if ia {
            poly[vertices] = a;
            vertices += 1;
        }
        if ia != ib {
            let t = (NEAR - a.0[2]) / (b.0[2] - a.0[2]);
            let lerp = |x: [f32; 3], y: [f32; 3]| [x[0] + t * (y[0] - x[0]), x[1] + t * (y[1] - x[1]), x[2] + t * (y[2] - x[2])];
            poly[vertices] = (lerp(a.0, b.0), lerp(a.1, b.1));
            vertices += 1;
        }
    }
    let poly = &poly[..vertices];
    let project = |p: [f32; 3]| [camera.fx * p[0] as f64 / p[2] as f64 + camera.cx, camera.fy * p[1] as f64 / p[2] as f64 + camera.cy];
    // The plane n·P = d of the source triangle: on the ray of pixel (x, y),
    // 1/z = n·((x − cx)/fx, (y − cy)/fy, 1) / d, affine in x and y.
    let p = cam.map(|q| nalgebra::Vector3::new(q[0] as f64, q[1] as f64, q[2] as f64));
    let n = (p[1] - p[0]).cross(&(p[2] - p[0]));
    let d = n.dot(&p[0]);
    if d.abs() <= 1e-12 * n.norm() {
        return; // Seen edge-on: covers no pixel.
    }
    let (a, b) = (n.x / (camera.fx * d), n.y / (camera.fy * d));
    let inv_z_plane = [a, b, n.z / d - a * camera.cx - b * camera.cy];
    for k in 1..poly.len().saturating_sub(1) {
        let v = [poly[0], poly[k], poly[k + 1]];
        out.push(ScreenTriangle { xy: v.map(|(p, _)| project(p)), inv_z: v.map(|(p, _)| 1.0 / p[2]), inv_z_plane, bary: v.map(|(_, b)| b), source });
    }
}

/// Render `world` seen by `camera` into `frame`: colour, depth, classes and instances.
pub fn render(world: &World, camera: &Camera, shading: &Shading, frame: &mut Frame) {
    let screen = rasterize(world, camera, frame);
    resolve(world, camera, &screen, Some(shading), frame);
}

/// Depth, classes and instances of what `camera` sees, without colour: what a planner
/// needs to know before choosing a view (the colour image is left as it was).
pub fn render_visibility(world: &World, camera: &Camera, frame: &mut Frame) {
    let screen = rasterize(world, camera, frame);
    resolve(world, camera, &screen, None, frame);
}

/// Visibility: the nearest triangle of every pixel (`frame.hit`, `frame.weight1`, `frame.weight2`,
/// `frame.depth`); returns the clipped, projected triangles the hits index.
fn rasterize(world: &World, camera: &Camera, frame: &mut Frame) -> Vec<ScreenTriangle> {
    frame.resize(camera.width, camera.height);
    let world_to_camera = camera.pose.try_inverse().expect("camera poses are rigid");
    let mut screen = Vec::with_capacity(world.triangles.len());
    let clipped: Vec<Vec<ScreenTriangle>> = world
        .triangles
        .par_chunks(8192)
        .enumerate()
        .map(|(c, chunk)| {
            let mut out = Vec::with_capacity(chunk.len());
            for (i, t) in chunk.iter().enumerate() {
                let cam = t.positions.map(|p| to_camera(&world_to_camera, p));
                clip_and_project(&cam, camera, (c * 8192 + i) as u32, &mut out);
            }
            out
        })
        .collect();
    for part in clipped {
        screen.extend(part);
    }
    let (w, h) = (camera.width as usize, camera.height as usize);
    let (wf, hf) = (w as f64, h as f64);
    // Bin triangles by the bands of rows they touch, so each band visits only its own.
    let bands = h.div_ceil(BAND);
    let mut binned: Vec<Vec<u32>> = vec![Vec::new(); bands];
    for (index, t) in screen.iter().enumerate() {
        let ys = [t.xy[0][1], t.xy[1][1], t.xy[2][1]];
        let xs = [t.xy[0][0], t.xy[1][0], t.xy[2][0]];
        let (ymin, ymax) = (ys[0].min(ys[1]).min(ys[2]), ys[0].max(ys[1]).max(ys[2]));
        let (xmin, xmax) = (xs[0].min(xs[1]).min(xs[2]), xs[0].max(xs[1]).max(xs[2]));
        if ymax < 0.0 || ymin > hf - 1.0 || xmax < 0.0 || xmin > wf - 1.0 || !(ymin.is_finite() && ymax.is_finite()) {
            continue;
        }
        let first = (ymin.ceil().max(0.0) as usize) / BAND;
        let last = ((ymax.floor().min(hf - 1.0)) as usize) / BAND;
        for band in binned.iter_mut().take(last + 1).skip(first) {
            band.push(index as u32);
        }
    }
    // Visibility: a depth buffer per band of rows.
    frame
        .depth
        .par_chunks_mut(w * BAND)
        .zip(frame.hit.par_chunks_mut(w * BAND))
        .zip(frame.weight1.par_chunks_mut(w * BAND).zip(frame.weight2.par_chunks_mut(w * BAND)))
        .zip(binned.par_iter())
        .enumerate()
        .for_each(|(band, (((depth, hit), (weight1, weight2)), triangles))| {
            depth.fill(f32::INFINITY);
            hit.fill(u32::MAX);
            let y0 = band * BAND;
            let y1 = (y0 + BAND).min(h);
            for &index in triangles {
                let t = &screen[index as usize];
                let ys = [t.xy[0][1], t.xy[1][1], t.xy[2][1]];
                let (ymin, ymax) = (ys[0].min(ys[1]).min(ys[2]), ys[0].max(ys[1]).max(ys[2]));
                let xs = [t.xy[0][0], t.xy[1][0], t.xy[2][0]];
                let (xmin, xmax) = (xs[0].min(xs[1]).min(xs[2]), xs[0].max(xs[1]).max(xs[2]));
                let [a, b, c] = t.xy;
                let area = (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0]);
                if area.abs() < 1e-9 {
                    continue;
                }
                let px0 = (xmin.ceil().max(0.0)) as usize;
                let px1 = (xmax.floor().min(wf - 1.0)).max(-1.0) as isize;
                let py0 = (ymin.ceil().max(y0 as f64)) as usize;
                let py1 = (ymax.floor().min(y1 as f64 - 1.0)) as isize;
                if px1 < px0 as isize || py1 < py0 as isize {
                    continue;
                }
                let cover = Cover::new(t, area, px0 as f64, py0 as f64, index);
                let columns = px1 as usize + 1 - px0;
                for py in py0..=py1 as usize {
                    let dy = (py - py0) as f32;
                    if let Some(span) = cover.row_span(dy, columns) {
                        cover.draw_row(dy, span, (py - y0) * w + px0, depth, hit, weight1, weight2);
                    }
                }
            }
        });
    screen
}

/// Pixels a row's visibility pass takes at once: one AVX register of f32.
const LANES: usize = 8;

/// A pixel centre within 10⁻³ pixel of an edge counts as inside: on an edge shared by two
/// triangles, at least one draws it.
const EDGE_TOLERANCE_PIXELS: f32 = -1e-3;

/// One triangle's coverage of the pixels of a band, set up at the band's first pixel
/// (`dx = dy = 0`): its edges as signed distances in pixels, two of them with their
/// gradients (barycentrics), and 1/z, all affine in the offsets.
struct Cover {
    e0: [f32; 3],
    e1: [f32; 3],
    e2: [f32; 3],
    g1: f32,
    g2: f32,
    inv_z: [f32; 3],
    /// 1/z at the triangle's vertices 1 and 2.
    inv_z1: f32,
    inv_z2: f32,
    index: u32,
}

impl Cover {
    /// The coverage of screen triangle `t` (of signed double area `area`, not near zero)
    /// from pixel (`x0`, `y0`). Barycentrics and 1/z are affine in (x, y), set up in f64
    /// at that pixel (clipped vertices reach ~10⁶ pixels); the per-pixel steps are f32.
    /// Coverage uses each barycentric as a signed distance in pixels to its edge, so its
    /// rounding is a fraction of a pixel however large the triangle.
    fn new(t: &ScreenTriangle, area: f64, x0: f64, y0: f64, index: u32) -> Cover {
        let [a, b, c] = t.xy;
        let inv_area = 1.0 / area;
        let l0 = [((b[0] - x0) * (c[1] - y0) - (b[1] - y0) * (c[0] - x0)) * inv_area, (b[1] - c[1]) * inv_area, (c[0] - b[0]) * inv_area];
        let l1 = [((c[0] - x0) * (a[1] - y0) - (c[1] - y0) * (a[0] - x0)) * inv_area, (c[1] - a[1]) * inv_area, (a[0] - c[0]) * inv_area];
        let l2 = [1.0 - l0[0] - l1[0], -l0[1] - l1[1], -l0[2] - l1[2]];
        let per_pixel = |l: [f64; 3]| {
            let g = (l[1] * l[1] + l[2] * l[2]).sqrt();
            (g as f32, [(l[0] / g) as f32, (l[1] / g) as f32, (l[2] / g) as f32])
        };
        let ((_, e0), (g1, e1), (g2, e2)) = (per_pixel(l0), per_pixel(l1), per_pixel(l2));
        let [za, zb, zc] = t.inv_z_plane;
        let inv_z = [(za * x0 + zb * y0 + zc) as f32, za as f32, zb as f32];
        Cover { e0, e1, e2, g1, g2, inv_z, inv_z1: t.inv_z[1], inv_z2: t.inv_z[2], index }
    }

    /// Depth-test the columns `span` of row `dy`, which starts at `row` in the band's
    /// buffers, eight at a time.
    #[allow(clippy::too_many_arguments)]
    fn draw_row(&self, dy: f32, span: std::ops::Range<usize>, row: usize, depth: &mut [f32], hit: &mut [u32], weight1: &mut [f32], weight2: &mut [f32]) {
        for dx in span.clone().step_by(LANES) {
            let valid = (span.end - dx).min(LANES);
            let at = row + dx;
            let lanes = (depth[at..].first_chunk_mut(), hit[at..].first_chunk_mut(), weight1[at..].first_chunk_mut(), weight2[at..].first_chunk_mut());
            match lanes {
                // Lanes past the span are the next pixels of the band: read, left as they are.
                (Some(d), Some(h), Some(v1), Some(v2)) => self.lanes(dx as i32 as f32, dy, valid, d, h, v1, v2),
                // The band's last pixels: through a copy.
                _ => {
                    let (mut d, mut h, mut v1, mut v2) = ([f32::INFINITY; LANES], [u32::MAX; LANES], [0.0; LANES], [0.0; LANES]);
                    d[..valid].copy_from_slice(&depth[at..at + valid]);
                    h[..valid].copy_from_slice(&hit[at..at + valid]);
                    v1[..valid].copy_from_slice(&weight1[at..at + valid]);
                    v2[..valid].copy_from_slice(&weight2[at..at + valid]);
                    self.lanes(dx as i32 as f32, dy, valid, &mut d, &mut h, &mut v1, &mut v2);
                    depth[at..at + valid].copy_from_slice(&d[..valid]);
                    hit[at..at + valid].copy_from_slice(&h[..valid]);
                    weight1[at..at + valid].copy_from_slice(&v1[..valid]);
                    weight2[at..at + valid].copy_from_slice(&v2[..valid]);
                }
            }
        }
    }

    /// The columns `0..columns` of row `dy` that the triangle may cover: a superset of
    /// those whose pixel test passes, found from each edge's line in exact arithmetic,
    /// widened by a bound on the single-precision test's rounding and a pixel on each
    /// side; `None` when no column can pass. (Most of a large triangle's bounding box
    /// lies outside it.)
    fn row_span(&self, dy: f32, columns: usize) -> Option<std::ops::Range<usize>> {
        let (mut first, mut last) = (0.0f64, columns as f64 - 1.0);
        for e in [self.e0, self.e1, self.e2] {
            let [e0, ex, ey] = e.map(f64::from);
            let dy = dy as f64;
            // The test evaluates e0 + ex·dx + ey·dy in f32: within 4 units of rounding
            // (2⁻²⁴ each) of the exact value; 10⁻⁶ is four times that.
            let slack = 1e-6 * (e0.abs() + ex.abs() * last.max(0.0) + ey.abs() * dy.abs());
            // Passing needs ex·dx ≥ need (exactly, within the slack).
            let need = EDGE_TOLERANCE_PIXELS as f64 - slack - e0 - ey * dy;
            if !(need.is_finite() && slack.is_finite()) {
                continue; // No bound from this edge: the pixel test decides.
            }
            if ex > 0.0 {
                first = first.max((need / ex - 1.0).floor());
            } else if ex < 0.0 {
                last = last.min((need / ex + 1.0).ceil());
            } else if need > 0.0 {
                return None;
            }
        }
        (first <= last).then(|| first as usize..last as usize + 1)
    }

    /// Depth-test the first `valid` of `LANES` pixels of a row, at offsets `dx0 + lane`,
    /// `dy`, against the nearest so far: where the triangle covers a pixel and is nearer,
    /// it becomes the pixel's hit. Lane by lane over fixed arrays with selects, so the
    /// compiler makes one instruction of each step for all lanes (over slices, it
    /// branched pixel by pixel); the arithmetic is the same as pixel by pixel.
    #[inline(always)]
    #[allow(clippy::too_many_arguments)]
    fn lanes(&self, dx0: f32, dy: f32, valid: usize, depth: &mut [f32; LANES], hit: &mut [u32; LANES], weight1: &mut [f32; LANES], weight2: &mut [f32; LANES]) {
        // First every lane's candidate, then the selects: with the division and the
        // selects in one loop, the compiler branched lane by lane to skip the division.
        let (mut nearer, mut z, mut w1, mut w2) = ([0u32; LANES], [0.0f32; LANES], [0.0f32; LANES], [0.0f32; LANES]);
        for l in 0..LANES {
            let dx = dx0 + l as f32;
            let at = |e: [f32; 3]| e[0] + e[1] * dx + e[2] * dy;
            // Either winding: both faces are drawn.
            let (d0, d1, d2) = (at(self.e0), at(self.e1), at(self.e2));
            let outside = (d0 < EDGE_TOLERANCE_PIXELS) | (d1 < EDGE_TOLERANCE_PIXELS) | (d2 < EDGE_TOLERANCE_PIXELS);
            z[l] = 1.0 / at(self.inv_z);
            nearer[l] = (((l < valid) & !outside & (z[l] < depth[l])) as u32).wrapping_neg();
            // Perspective-correct weights of vertices 1 and 2.
            w1[l] = d1 * self.g1 * self.inv_z1 * z[l];
            w2[l] = d2 * self.g2 * self.inv_z2 * z[l];
        }
        let blend = |m: u32, new: u32, old: u32| (new & m) | (old & !m);
        for l in 0..LANES {
            depth[l] = f32::from_bits(blend(nearer[l], z[l].to_bits(), depth[l].to_bits()));
            hit[l] = blend(nearer[l], self.index, hit[l]);
            weight1[l] = f32::from_bits(blend(nearer[l], w1[l].to_bits(), weight1[l].to_bits()));
            weight2[l] = f32::from_bits(blend(nearer[l], w2[l].to_bits(), weight2[l].to_bits()));
        }
    }
}

/// One row's surface attributes, for shading it all at once: albedo, world position and
/// unit normal (facing the camera) of each pixel, structure-of-arrays, so the loop over
/// lights runs across pixels (independent, vectorisable) rather than as one long chain
/// per pixel.
#[derive(Default)]
struct RowScratch {
    albedo: [Vec<f32>; 3],
    position: [Vec<f32>; 3],
    normal: [Vec<f32>; 3],
    light: [Vec<f32>; 3],
}

impl RowScratch {
    fn resize(&mut self, w: usize) {
        for v in self.albedo.iter_mut().chain(&mut self.position).chain(&mut self.normal).chain(&mut self.light) {
            v.resize(w, 0.0);
        }
    }
}

/// Per pixel, from what is visible: depth (0 for no hit), class, instance and, with a
/// shading, colour.
fn resolve(world: &World, camera: &Camera, screen: &[ScreenTriangle], shading: Option<&Shading>, frame: &mut Frame) {
    let w = camera.width as usize;
    let pose = camera.pose;
    let camera_origin = [pose[(0, 3)] as f32, pose[(1, 3)] as f32, pose[(2, 3)] as f32];
    let lights: Vec<Light> = match shading {
        None | Some(Shading::Flat) => Vec::new(),
        Some(Shading::Lit(lights)) => lights
            .iter()
            .map(|l| {
                if l.attached_to_camera {
                    // Offsets are in Habitat's camera frame (y up, z backward); the pose is OpenCV's.
                    let p = pose * nalgebra::Vector4::new(l.position[0] as f64, -l.position[1] as f64, -l.position[2] as f64, 1.0);
                    Light { position: [p.x as f32, p.y as f32, p.z as f32], ..*l }
                } else {
                    *l
                }
            })
            .collect(),
    };
    let lit = matches!(shading, Some(Shading::Lit(_)));
    let coloured = shading.is_some();
    let r: [[f32; 4]; 3] = std::array::from_fn(|i| std::array::from_fn(|j| pose[(i, j)] as f32));
    let (cx, cy, inv_fx, inv_fy) = (camera.cx as f32, camera.cy as f32, 1.0 / camera.fx as f32, 1.0 / camera.fy as f32);
    frame
        .rgb
        .par_chunks_mut(w * 3)
        .zip(frame.semantic.par_chunks_mut(w).zip(frame.instance.par_chunks_mut(w)))
        .zip(frame.depth.par_chunks_mut(w))
        .zip(frame.hit.par_chunks(w).zip(frame.weight1.par_chunks(w).zip(frame.weight2.par_chunks(w))))
        .enumerate()
        .for_each_init(RowScratch::default, |row, (py, (((rgb, (semantic, instance)), depth), (hit, (weight1, weight2))))| {
            row.resize(w);
            let RowScratch { albedo: row_albedo, position, normal, light } = row;
            // 1. What each pixel shows: class, instance, depth and (when coloured) its
            //    albedo and interpolated normal (gathered from its triangle).
            {
                let [ar, ag, ab] = row_albedo.each_mut().map(|v| &mut v[..w]);
                let [nx, ny, nz] = normal.each_mut().map(|v| &mut v[..w]);
                let (semantic, instance, depth, hit, weight1, weight2) =
                    (&mut semantic[..w], &mut instance[..w], &mut depth[..w], &hit[..w], &weight1[..w], &weight2[..w]);
                for px in 0..w {
                    if hit[px] == u32::MAX {
                        semantic[px] = 0;
                        instance[px] = 0;
                        depth[px] = 0.0;
                        (ar[px], ag[px], ab[px]) = (0.0, 0.0, 0.0);
                        (nx[px], ny[px], nz[px]) = (0.0, 0.0, 0.0);
                        continue;
                    }
                    let st = &screen[hit[px] as usize];
                    let tri: &Triangle = &world.triangles[st.source as usize];
                    let (w1, w2) = (weight1[px], weight2[px]);
                    let w0 = 1.0 - w1 - w2;
                    // Barycentrics in the source triangle.
                    let b: [f32; 3] = std::array::from_fn(|k| w0 * st.bary[0][k] + w1 * st.bary[1][k] + w2 * st.bary[2][k]);
                    semantic[px] = tri.class_id;
                    instance[px] = tri.instance_id;
                    if !coloured {
                        continue;
                    }
                    let surface = &world.surfaces[tri.surface as usize];
                    let mut albedo = surface.color;
                    if let Some(tex) = &surface.texture {
                        let u = b[0] * tri.uvs[0][0] + b[1] * tri.uvs[1][0] + b[2] * tri.uvs[2][0];
                        let v = b[0] * tri.uvs[0][1] + b[1] * tri.uvs[1][1] + b[2] * tri.uvs[2][1];
                        let (tw, th) = (tex.width as usize, tex.height as usize);
                        let tx = ((fract(u) * tw as f32) as usize).min(tw - 1);
                        let ty = ((fract(v) * th as f32) as usize).min(th - 1);
                        let t = &tex.rgba[4 * (ty * tw + tx)..4 * (ty * tw + tx) + 3];
                        albedo = [albedo[0] * t[0] as f32 * INV_255, albedo[1] * t[1] as f32 * INV_255, albedo[2] * t[2] as f32 * INV_255];
                    }
                    (ar[px], ag[px], ab[px]) = (albedo[0], albedo[1], albedo[2]);
                    if lit {
                        let n: [f32; 3] = std::array::from_fn(|k| b[0] * tri.normals[0][k] + b[1] * tri.normals[1][k] + b[2] * tri.normals[2][k]);
                        (nx[px], ny[px], nz[px]) = (n[0], n[1], n[2]);
                    }
                }
            }
            // 1b. Lit: world positions from depth, and the normals turned to the camera's
            //     side (two-sided) and made unit length — across the row, branch-free, so
            //     it vectorises. A pixel without a hit has a zero normal: it gets no light.
            if lit {
                let [px_, py_, pz_] = position.each_mut().map(|v| &mut v[..w]);
                let [nx, ny, nz] = normal.each_mut().map(|v| &mut v[..w]);
                let depth = &depth[..w];
                let y = (py as f32 - cy) * inv_fy;
                for px in 0..w {
                    let z = depth[px];
                    let cam = [(px as f32 - cx) * inv_fx * z, y * z, z];
                    let p: [f32; 3] = std::array::from_fn(|i| r[i][0] * cam[0] + r[i][1] * cam[1] + r[i][2] * cam[2] + r[i][3]);
                    let n = [nx[px], ny[px], nz[px]];
                    let to_camera = [camera_origin[0] - p[0], camera_origin[1] - p[1], camera_origin[2] - p[2]];
                    let side = if n[0] * to_camera[0] + n[1] * to_camera[1] + n[2] * to_camera[2] < 0.0 { -1.0 } else { 1.0 };
                    let unit = side / (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt().max(1e-12);
                    (px_[px], py_[px], pz_[px]) = (p[0], p[1], p[2]);
                    (nx[px], ny[px], nz[px]) = (n[0] * unit, n[1] * unit, n[2] * unit);
                }
            }
            if !coloured {
                return;
            }
            // 2. Light: ambient plus, light by light across the row, Lambert (n·d / |d|)
            //    times Magnum PhongGL's attenuation 1/(1 + |d|²) for an unbounded range;
            //    a light behind the surface adds nothing.
            for c in light.iter_mut() {
                c.fill(if lit { AMBIENT } else { 1.0 });
            }
            for l in &lights {
                // Slices of exactly `w` (no bounds checks in the loop, so it vectorises).
                let ([px_, py_, pz_], [nx, ny, nz]) = (position.each_ref().map(|v| &v[..w]), normal.each_ref().map(|v| &v[..w]));
                let [lr, lg, lb] = light.each_mut().map(|v| &mut v[..w]);
                for i in 0..w {
                    let d = [l.position[0] - px_[i], l.position[1] - py_[i], l.position[2] - pz_[i]];
                    let facing = (nx[i] * d[0] + ny[i] * d[1] + nz[i] * d[2]).max(0.0);
                    let d2 = d[0] * d[0] + d[1] * d[1] + d[2] * d[2];
                    let factor = facing / (d2.sqrt().max(1e-6) * (1.0 + d2));
                    lr[i] += factor * l.color[0];
                    lg[i] += factor * l.color[1];
                    lb[i] += factor * l.color[2];
                }
            }
            // 3. Colour: albedo times light, clipped, rounded half up (without libm's
            //    roundf, which is not inlined on baseline x86-64).
            let ([ar, ag, ab], [lr, lg, lb]) = (row_albedo.each_ref().map(|v| &v[..w]), light.each_ref().map(|v| &v[..w]));
            let channel = |albedo: f32, light: f32| ((albedo * light.max(0.0)).clamp(0.0, 1.0) * 255.0 + 0.5) as u8;
            for (px, out) in rgb[..3 * w].chunks_exact_mut(3).enumerate() {
                out[0] = channel(ar[px], lr[px]);
                out[1] = channel(ag[px], lg[px]);
                out[2] = channel(ab[px], lb[px]);
            }
        });
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Triangles of every size and slant over a 120 × 120 window, from a fixed generator.
    fn triangles() -> impl Iterator<Item = ScreenTriangle> {
        let mut state = 0x9E37_79B9_7F4A_7C15u64;
        let mut uniform = move || {
            state = state.wrapping_mul(6_364_136_223_846_793_005).wrapping_add(1_442_695_040_888_963_407);
            (state >> 11) as f64 / (1u64 << 53) as f64
        };
        (0..4000).map(move |case| {
            // From a few pixels to far beyond the window, as clipped floors reach.
            let size = [3.0, 40.0, 400.0, 1e5][case % 4];
            let centre = [uniform() * 120.0, uniform() * 120.0];
            let mut xy: [[f64; 2]; 3] = std::array::from_fn(|_| [centre[0] + (uniform() - 0.5) * size, centre[1] + (uniform() - 0.5) * size]);
            match case % 7 {
                0 => xy[1][1] = xy[0][1] + (uniform() - 0.5) * 1e-3, // a nearly level edge
                1 => xy[1][1] = xy[0][1],                            // a level edge
                2 => xy = xy.map(|p| p.map(f64::round)),             // edges through pixel centres
                _ => {}
            }
            ScreenTriangle { xy, inv_z: [1.0; 3], inv_z_plane: [0.0, 0.0, 1.0], bary: [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]], source: 0 }
        })
    }

    #[test]
    fn a_rows_span_holds_every_pixel_the_pixel_test_draws_and_skips_the_rest_of_the_box() {
        let (mut drawn, mut boxed, mut spanned) = (0usize, 0usize, 0usize);
        for t in triangles() {
            let [a, b, c] = t.xy;
            let area = (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0]);
            let (xs, ys) = (t.xy.map(|p| p[0]), t.xy.map(|p| p[1]));
            let px0 = xs.iter().copied().fold(f64::INFINITY, f64::min).ceil().max(0.0);
            let px1 = xs.iter().copied().fold(f64::NEG_INFINITY, f64::max).floor().min(119.0);
            let py0 = ys.iter().copied().fold(f64::INFINITY, f64::min).ceil().max(0.0);
            let py1 = ys.iter().copied().fold(f64::NEG_INFINITY, f64::max).floor().min(119.0);
            if area.abs() < 1e-9 || px1 < px0 || py1 < py0 {
                continue;
            }
            let cover = Cover::new(&t, area, px0, py0, 1);
            let columns = (px1 - px0) as usize + 1;
            for dy in 0..=(py1 - py0) as usize {
                let dy = dy as f32;
                // The pixel test on every column of the box, with room for the last lanes.
                let (mut depth, mut hit) = (vec![f32::INFINITY; columns + LANES], vec![0u32; columns + LANES]);
                let (mut weight1, mut weight2) = (vec![0.0; columns + LANES], vec![0.0; columns + LANES]);
                cover.draw_row(dy, 0..columns, 0, &mut depth, &mut hit, &mut weight1, &mut weight2);
                let span = cover.row_span(dy, columns).unwrap_or(0..0);
                for (dx, &h) in hit[..columns].iter().enumerate() {
                    assert!(h == 0 || span.contains(&dx), "{:?}: row {dy} column {dx} is drawn but outside {span:?}", t.xy);
                    drawn += (h == 1) as usize;
                }
                assert!(hit[columns..].iter().all(|&h| h == 0), "lanes past the span are left as they were");
                boxed += columns;
                spanned += span.len();
            }
        }
        assert!(drawn > 100_000, "the triangles cover pixels: {drawn}");
        // Each row's span is at most a few pixels wider than what is drawn in it.
        assert!(spanned < drawn + drawn / 5 + 20_000 && spanned < boxed / 2, "{spanned} columns spanned for {drawn} drawn, of {boxed} in the boxes");
    }
}
