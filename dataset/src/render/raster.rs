//! A CPU rasteriser for RGB, planar depth and semantic images from one pinhole camera:
//! near-plane clipping, perspective-correct interpolation, a depth buffer, then a
//! deferred shading pass; rows are split into bands rendered on all cores, into
//! buffers allocated once per frame size.
//!
//! One file, over 400 lines, on purpose: the passes share the frame buffers and the band
//! split, and the hot loops stay together for the optimiser and the reader. Which pixels
//! a triangle covers is `edges.rs`; where the clipped triangles are kept, `screen.rs`.

use std::time::Instant;

use nalgebra::Matrix4;
use rayon::prelude::*;

use super::edges::{Edges, Row, column, distance_at};
use std::sync::Arc;

pub use super::light::{AMBIENT, Light};
use super::light_bake::{BakedLight, LightBake, LightPlane, SampleLight};
use super::mesh::{Cluster, Surface, Triangle, World};
use super::screen::{BAND, Part, Screen, ScreenTriangle};

/// A pinhole camera: intrinsics (pixel centres at integer coordinates, as HaDaGe's
/// `c = (size − 1)/2` implies) and a camera-to-world pose in OpenCV axes
/// (x right, y down, z forward) in the Habitat world.
#[derive(Debug, Clone, Default)]
pub struct Camera {
    pub width: u32,
    pub height: u32,
    pub fx: f64,
    pub fy: f64,
    pub cx: f64,
    pub cy: f64,
    pub pose: Matrix4<f64>,
}

/// No lights: albedo as it is (Habitat's flat shading); lights: Phong diffuse with
/// ambient 0.4.
#[derive(Debug, Clone, PartialEq)]
pub enum Shading {
    Flat,
    Lit(Vec<Light>),
}

const INV_255: f32 = 1.0 / 255.0;

/// The fractional part of `x` (in [0, 1]: a tiny negative `x` rounds up to 1), 0 for
/// values too large to have one and for NaN.
#[inline(always)]
fn fract(x: f32) -> f32 {
    // On x86-64-v3 (.cargo/config.toml) `floor` is one instruction (on baseline x86-64 it is
    // a call to libm). `x - x.floor()` is `x - trunc(x)` (exact), plus 1 for a negative `x`
    // rounded once: the value the old truncating version gave, bit for bit.
    if x.abs() < 8_388_608.0 { x - x.floor() } else { 0.0 }
}
/// Nothing nearer than this is drawn.
const NEAR: f32 = 0.01;

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
    /// Per pixel: the number of the visible (clipped) triangle (`Screen::index`) and its
    /// weights.
    pub(super) hit: Vec<u32>,
    pub(super) weights: Vec<[f32; 2]>,
    /// The clipped, projected triangles `hit` indexes.
    pub(super) screen: Screen,
    /// Time spent in each pass, summed over the frames rendered into this one.
    pub pass_times: PassTimes,
    /// The camera lights' shadow maps of the last frame shaded, kept for reuse.
    pub(super) shadows: Vec<Box<ShadowMap>>,
}

/// Depth seen from a light attached to the camera, and where that light is.
#[derive(Debug, Clone, Default)]
pub(super) struct ShadowMap {
    /// The light's camera: the frame's orientation, at the light.
    camera: Camera,
    /// The light's offset from the camera, OpenCV camera axes.
    offset: [f32; 3],
    depth: Frame,
}

impl ShadowMap {
    /// How much of the light reaches the camera-space point `p` (x right, y down, z
    /// forward), 0–1: bilinear over the four nearest samples of the map, each lit when
    /// nothing lies nearer the light there (with a bias growing with distance).
    #[inline(always)]
    fn visibility(&self, p: [f32; 3]) -> f32 {
        let q = [p[0] - self.offset[0], p[1] - self.offset[1], p[2] - self.offset[2]];
        if q[2] <= 0.0 {
            return 1.0;
        }
        let c = &self.camera;
        let u = c.fx as f32 * q[0] / q[2] + c.cx as f32;
        let v = c.fy as f32 * q[1] / q[2] + c.cy as f32;
        let (w, h) = (c.width as usize, c.height as usize);
        if !(u >= 0.0 && v >= 0.0 && u < (w - 1) as f32 && v < (h - 1) as f32) {
            return 1.0;
        }
        let (x, y) = (u as usize, v as usize);
        let (fx, fy) = (u - x as f32, v - y as f32);
        let bias = 0.015 + 0.012 * q[2];
        let lit = |xx: usize, yy: usize| {
            let d = self.depth.depth[yy * w + xx];
            if d == 0.0 || d >= q[2] - bias { 1.0 } else { 0.0 }
        };
        let top = lit(x, y) * (1.0 - fx) + lit(x + 1, y) * fx;
        let bottom = lit(x, y + 1) * (1.0 - fx) + lit(x + 1, y + 1) * fx;
        top * (1.0 - fy) + bottom * fy
    }
}

/// Wall-clock time of each pass of the renderer (each pass runs on all cores), summed over
/// frames: what `osmab bench render` reports.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct PassTimes {
    pub frames: u32,
    /// Culling, transforming, clipping, projecting and binning the triangles.
    pub transform: std::time::Duration,
    /// The nearest triangle of every pixel.
    pub visibility: std::time::Duration,
    /// Classes, depth and colour from what is visible.
    pub resolve: std::time::Duration,
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
        self.weights.resize(n, [0.0; 2]);
    }
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

/// Clusters a task of the transform takes (~8,000 triangles).
const CLUSTERS_PER_TASK: usize = 128;

/// Whether any triangle of `cluster` may draw a pixel: false when its box lies wholly
/// behind the near plane, or wholly in front of it and two pixels beyond one edge of the
/// image, in which case `clip_and_project` would drop each of its triangles (their
/// vertices are convex combinations of the box's corners, so the same linear tests hold
/// for them, with room to spare for their single-precision rounding). That argument
/// needs finite coordinates, which the scene loaders (`read_gltf`, `read_obj`) enforce.
fn may_be_seen(cluster: &Cluster, world_to_camera: &Matrix4<f64>, camera: &Camera, near: f32) -> bool {
    let corners: [[f64; 3]; 8] = std::array::from_fn(|k| {
        let pick = |axis: usize| if k >> axis & 1 == 0 { cluster.min[axis] } else { cluster.max[axis] } as f64;
        let v = world_to_camera * nalgebra::Vector4::new(pick(0), pick(1), pick(2), 1.0);
        [v.x, v.y, v.z]
    });
    let near = near as f64;
    if corners.iter().all(|p| p[2] < near - 1e-6) {
        return false;
    }
    if !corners.iter().all(|p| p[2] > near + 1e-6) {
        return true;
    }
    let (w, h) = (camera.width as f64, camera.height as f64);
    let (fx, fy, cx, cy) = (camera.fx, camera.fy, camera.cx, camera.cy);
    // As in `outside_the_image`, a pixel further out.
    let left = corners.iter().all(|p| fx * p[0] + (cx + 2.0) * p[2] < 0.0);
    let right = corners.iter().all(|p| fx * p[0] + (cx - w - 1.0) * p[2] > 0.0);
    let above = corners.iter().all(|p| fy * p[1] + (cy + 2.0) * p[2] < 0.0);
    let below = corners.iter().all(|p| fy * p[1] + (cy - h - 1.0) * p[2] > 0.0);
    !(left || right || above || below)
}

/// Clip a camera-space triangle against the near plane and project it.
fn clip_and_project(cam: &[[f32; 3]; 3], camera: &Camera, near: f32, source: u32, out: &mut Vec<ScreenTriangle>) {
    let inside = cam.map(|p| p[2] >= near);
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
            let t = (near - a.0[2]) / (b.0[2] - a.0[2]);
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
    find_visible(world, camera, frame);
    shade(world, camera, shading, frame);
}

/// The first half of [`render`]: the nearest triangle of every pixel of `frame`, which
/// [`shade`] or [`shade_lightings`] then colours.
pub fn find_visible(world: &World, camera: &Camera, frame: &mut Frame) {
    rasterize(world, camera, NEAR, frame);
}

/// The second half of [`render`]: colour, depth, classes and instances of what
/// [`find_visible`] found in `frame` for the same `camera`, lit as `world` is lit and
/// shaded by `shading`. `world` must hold the same triangles as the world visibility was
/// found in (the same scene, lit another way: its light bake is the only difference).
pub fn shade(world: &World, camera: &Camera, shading: &Shading, frame: &mut Frame) {
    let mut rgb = std::mem::take(&mut frame.rgb);
    shade_lightings(&[Lighting { world, shading }], camera, frame, std::slice::from_mut(&mut rgb));
    frame.rgb = rgb;
}

/// One way a frame is lit: the world lit that way (the same triangles as the world the
/// frame's visibility was found in; its light bake is the only difference) and its shading.
#[derive(Debug, Clone, Copy)]
pub struct Lighting<'a> {
    pub world: &'a World,
    pub shading: &'a Shading,
}

/// [`shade`] under several lightings at once: depth, classes and instances into `frame`,
/// and the colour image under `lightings[l]` into `rgbs[l]` (resized to the frame), each
/// the bytes [`shade`] gives under that lighting alone. What the lightings share — which
/// surface each pixel shows, its texture, its normal — is worked out once a pixel, and
/// only the light is worked out once a lighting.
pub fn shade_lightings(lightings: &[Lighting], camera: &Camera, frame: &mut Frame, rgbs: &mut [Vec<u8>]) {
    assert_eq!(lightings.len(), rgbs.len(), "one colour image a lighting");
    let mut spare = std::mem::take(&mut frame.shadows);
    let shadows: Vec<Option<Box<ShadowMap>>> = lightings.iter().map(|l| camera_light_shadow(l.world, camera, l.shading, &mut spare)).collect();
    let passes: Vec<LightingPass> = lightings.iter().zip(&shadows).map(|(l, s)| LightingPass { lighting: *l, shadow: s.as_deref() }).collect();
    if let Some(first) = lightings.first() {
        resolve(first.world, camera, &passes, frame, rgbs);
    }
    drop(passes);
    frame.shadows = shadows.into_iter().flatten().chain(spare).collect();
    frame.pass_times.frames += lightings.len() as u32;
}

/// The shadow map of the first light attached to the camera, when the world's light is
/// baked (a world rendered with shadows): depth seen from the light, looking where the
/// camera looks, at half the frame's size; what lies nearer the light than the camera
/// itself (a wall behind it) casts no shadow into the view. Reuses one of `spare`.
fn camera_light_shadow(world: &World, camera: &Camera, shading: &Shading, spare: &mut Vec<Box<ShadowMap>>) -> Option<Box<ShadowMap>> {
    let Shading::Lit(lights) = shading else { return None };
    let offset = lights.iter().find(|l| l.attached_to_camera)?.position;
    world.light_bake()?;
    let mut map = spare.pop().unwrap_or_default();
    // Habitat's camera frame (y up, z backward) in OpenCV's (y down, z forward).
    map.offset = [offset[0], -offset[1], -offset[2]];
    let (w, h) = ((camera.width / 2).max(1), (camera.height / 2).max(1));
    let scale = w as f64 / camera.width as f64;
    let translation = nalgebra::Vector4::new(map.offset[0] as f64, map.offset[1] as f64, map.offset[2] as f64, 0.0);
    let mut pose = camera.pose;
    let origin = camera.pose * translation;
    for k in 0..3 {
        pose[(k, 3)] += origin[k];
    }
    map.camera = Camera { width: w, height: h, fx: camera.fx * scale, fy: camera.fy * scale, cx: (w as f64 - 1.0) / 2.0, cy: (h as f64 - 1.0) / 2.0, pose };
    let near = (map.offset[0] * map.offset[0] + map.offset[1] * map.offset[1] + map.offset[2] * map.offset[2]).sqrt() + NEAR;
    rasterize(world, &map.camera, near, &mut map.depth);
    Some(map)
}

/// Depth, classes and instances of what `camera` sees, without colour: what a planner
/// needs to know before choosing a view (the colour image is left as it was).
pub fn render_visibility(world: &World, camera: &Camera, frame: &mut Frame) {
    rasterize(world, camera, NEAR, frame);
    resolve(world, camera, &[], frame, &mut []);
    frame.pass_times.frames += 1;
}

/// Visibility: the nearest triangle of every pixel (`frame.hit`, `frame.weights`,
/// `frame.depth`), and in `frame.screen` the clipped, projected triangles the hits index.
fn rasterize(world: &World, camera: &Camera, near: f32, frame: &mut Frame) {
    let start = Instant::now();
    frame.resize(camera.width, camera.height);
    project_triangles(world, camera, near, &mut frame.screen);
    let transformed = Instant::now();
    frame.pass_times.transform += transformed - start;
    let screen = &frame.screen;
    let w = camera.width as usize;
    // Visibility: a depth buffer per band of rows.
    frame
        .depth
        .par_chunks_mut(w * BAND)
        .zip(frame.hit.par_chunks_mut(w * BAND))
        .zip(frame.weights.par_chunks_mut(w * BAND))
        .enumerate()
        .for_each(|(band, ((depth, hit), weights))| nearest_in_band(screen, camera, band, Nearest { depth, hit, weights }));
    frame.pass_times.visibility += transformed.elapsed();
}

/// Into `screen`: the triangles of the clusters `camera` may see, in camera space,
/// clipped, projected and binned by band, part by part.
fn project_triangles(world: &World, camera: &Camera, near: f32, screen: &mut Screen) {
    let world_to_camera = camera.pose.try_inverse().expect("camera poses are rigid");
    screen.parts.resize_with(world.clusters().len().div_ceil(CLUSTERS_PER_TASK), Part::default);
    world.clusters().par_chunks(CLUSTERS_PER_TASK).zip(screen.parts.par_iter_mut()).for_each(|(clusters, part)| {
        part.triangles.clear();
        for cluster in clusters.iter().filter(|c| may_be_seen(c, &world_to_camera, camera, near)) {
            for (i, positions) in world.positions()[cluster.triangles.clone()].iter().enumerate() {
                let cam = positions.map(|p| to_camera(&world_to_camera, p));
                clip_and_project(&cam, camera, near, (cluster.triangles.start + i) as u32, &mut part.triangles);
            }
        }
        part.bin(camera.width, camera.height);
    });
    screen.index_parts();
}

/// The nearest triangle of every pixel of band `band` (`nearest` holds its rows).
fn nearest_in_band(screen: &Screen, camera: &Camera, band: usize, nearest: Nearest) {
    let Nearest { depth, hit, weights } = nearest;
    let (w, h) = (camera.width as usize, camera.height as usize);
    let wf = w as f64;
    depth.fill(f32::INFINITY);
    hit.fill(u32::MAX);
    let y0 = band * BAND;
    let y1 = (y0 + BAND).min(h);
    // Part by part, each in its order: the triangles in the world's order, so that
    // of two at the same depth the first drawn keeps the pixel.
    let triangles = screen
        .parts
        .iter()
        .enumerate()
        .flat_map(|(p, part)| part.in_band(band).iter().map(move |&place| (screen.index(p, place), &part.triangles[place as usize])));
    for (index, t) in triangles {
        let ([xmin, ymin], [xmax, ymax]) = t.bounds();
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
        // Barycentrics and 1/z are affine in (x, y), set up in f64 at the first pixel
        // (clipped vertices reach ~10⁶ pixels); the per-pixel steps are f32.
        let edges = Edges::new(t.xy, area, px0, py0, px1 as usize);
        let [za, zb, zc] = t.inv_z_plane;
        let (x0, y0f) = (px0 as f64, py0 as f64);
        let mut draw = RowDraw {
            index,
            first: px0,
            dy: 0.0,
            inv_z: [(za * x0 + zb * y0f + zc) as f32, za as f32, zb as f32],
            edges: [edges.distance[1], edges.distance[2]],
            gradient_lengths: edges.gradient_lengths,
            vertex_inv_z: [t.inv_z[1], t.inv_z[2]],
        };
        for py in py0..=py1 as usize {
            draw.dy = column(py - py0);
            let row = (py - y0) * w..(py - y0 + 1) * w;
            let nearest = Nearest { depth: &mut depth[row.clone()], hit: &mut hit[row.clone()], weights: &mut weights[row] };
            match edges.row(draw.dy) {
                Row::Run(run) => draw.run(run, nearest),
                Row::TestEachPixel => {
                    for px in px0..=px1 as usize {
                        if let Some([_, d1, d2]) = edges.covered(px, draw.dy) {
                            draw.pixel(column(px - px0), [d1, d2], &mut nearest.depth[px], &mut nearest.hit[px], &mut nearest.weights[px]);
                        }
                    }
                }
            }
        }
    }
}

/// Rows of a band's visibility buffers (all of the band's, or one).
struct Nearest<'a> {
    depth: &'a mut [f32],
    hit: &'a mut [u32],
    weights: &'a mut [[f32; 2]],
}

/// What one triangle writes at the covered pixels of a row of its box: 1/z and the
/// distances to the edges opposite vertices 1 and 2, each affine in (dx, dy) from the box's
/// first pixel, and from them depth and the perspective-correct weights of vertices 1
/// and 2. Where the triangle is nearer than what the pixel holds, it takes the pixel.
struct RowDraw {
    index: u32,
    /// The box's first column.
    first: usize,
    /// The row, counted from the box's first.
    dy: f32,
    /// 1/z at the box's first pixel, per pixel right and per pixel down.
    inv_z: [f32; 3],
    /// `Edges::distance` of edges 1 and 2.
    edges: [[f32; 3]; 2],
    gradient_lengths: [f32; 2],
    /// 1/z at vertices 1 and 2.
    vertex_inv_z: [f32; 2],
}

impl RowDraw {
    /// One pixel, `dx` columns right of the box's first, at distances `d` from edges 1 and 2.
    #[inline(always)]
    fn pixel(&self, dx: f32, d: [f32; 2], depth: &mut f32, hit: &mut u32, weights: &mut [f32; 2]) {
        let z = 1.0 / (self.inv_z[0] + self.inv_z[1] * dx + self.inv_z[2] * self.dy);
        if z < *depth {
            *depth = z;
            *hit = self.index;
            *weights = self.weights(d, z);
        }
    }

    /// Perspective-correct weights of vertices 1 and 2 at distances `d` and depth `z`.
    #[inline(always)]
    fn weights(&self, d: [f32; 2], z: f32) -> [f32; 2] {
        let [g1, g2] = self.gradient_lengths;
        let [w1, w2] = self.vertex_inv_z;
        [d[0] * g1 * w1 * z, d[1] * g2 * w2 * z]
    }

    /// The columns `run` of a row, all covered.
    #[inline(always)]
    fn run(&self, run: std::ops::Range<usize>, nearest: Nearest) {
        let Nearest { depth, hit, weights } = nearest;
        for px in run {
            let dx = column(px - self.first);
            let d = self.edges.map(|e| distance_at(e, dx, self.dy));
            self.pixel(dx, d, &mut depth[px], &mut hit[px], &mut weights[px]);
        }
    }
}

/// Pixels of a row resolved together.
const CHUNK: usize = 128;

/// One chunk of a row's surface attributes, for shading it all at once under each
/// lighting: what every lighting shares — albedo and the texture's occlusion, where in
/// its triangle each pixel lies and which run of pixels (one triangle) it belongs to, and,
/// when some lighting lights pixels one by one, world position and unit normal (facing the
/// camera) — and what one lighting gives: the light each pixel gets and how much of the
/// camera light reaches it. Structure-of-arrays, so the loop over lights runs across
/// pixels (independent, vectorisable) rather than as one long chain per pixel.
#[derive(Default)]
struct RowScratch {
    albedo: [Vec<f32>; 3],
    occlusion: Vec<f32>,
    /// Barycentrics in the source triangle.
    bary: [Vec<f32>; 3],
    /// The pixel's run (an index into `runs`); [`NO_RUN`] where nothing is hit.
    run: Vec<u32>,
    /// The source triangle each run of the chunk shows.
    runs: Vec<u32>,
    position: [Vec<f32>; 3],
    normal: [Vec<f32>; 3],
    light: [Vec<f32>; 3],
    /// How much of the camera light reaches the pixel.
    shadow: Vec<f32>,
}

/// A pixel that shows nothing, in [`RowScratch::run`].
const NO_RUN: u32 = u32::MAX;

impl RowScratch {
    fn resize(&mut self, w: usize) {
        let planes = self.albedo.iter_mut().chain(&mut self.bary).chain(&mut self.position).chain(&mut self.normal).chain(&mut self.light);
        for v in planes.chain([&mut self.occlusion]) {
            v.resize(w, 0.0);
        }
        self.run.resize(w, NO_RUN);
        self.shadow.resize(w, 1.0);
    }
}

/// One lighting to resolve a frame under, with its camera light's shadow map.
struct LightingPass<'a> {
    lighting: Lighting<'a>,
    shadow: Option<&'a ShadowMap>,
}

/// Per pixel, from what is visible: depth (0 for no hit), class, instance and, under each
/// of `lightings`, colour into its image of `rgbs`.
fn resolve(world: &World, camera: &Camera, lightings: &[LightingPass], frame: &mut Frame, rgbs: &mut [Vec<u8>]) {
    let start = Instant::now();
    let (w, h) = (camera.width as usize, camera.height as usize);
    let resolver = Resolver::new(world, &frame.screen, camera, lightings);
    // Each row's piece of every lighting's image.
    let mut rows: Vec<Vec<&mut [u8]>> = (0..h).map(|_| Vec::with_capacity(rgbs.len())).collect();
    for rgb in rgbs.iter_mut() {
        rgb.resize(w * h * 3, 0);
        for (row, piece) in rows.iter_mut().zip(rgb.chunks_mut(w * 3)) {
            row.push(piece);
        }
    }
    rows.par_iter_mut()
        .zip(frame.semantic.par_chunks_mut(w).zip(frame.instance.par_chunks_mut(w)))
        .zip(frame.depth.par_chunks_mut(w))
        .zip(frame.hit.par_chunks(w).zip(frame.weights.par_chunks(w)))
        .enumerate()
        .for_each_init(RowScratch::default, |row, (py, (((rgbs, (semantic, instance)), depth), (hit, weights)))| {
            resolver.row(py, row, RowOut { rgbs, semantic, instance, depth, hit, weights });
        });
    frame.pass_times.resolve += start.elapsed();
}

/// The lights of `shading` in world coordinates (a camera light's offset placed by the
/// camera `pose`); none without lights.
fn world_lights(lights: &[Light], pose: &Matrix4<f64>) -> Vec<Light> {
    lights
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
        .collect()
}

/// One row of a frame: its outputs (a piece of each lighting's colour image), and the
/// visibility they are resolved from.
struct RowOut<'a, 'b> {
    rgbs: &'b mut [&'a mut [u8]],
    semantic: &'a mut [u16],
    instance: &'a mut [u16],
    depth: &'a mut [f32],
    hit: &'a [u32],
    weights: &'a [[f32; 2]],
}

/// What resolving every row of a frame shares: the world, the visible triangles, the
/// camera and the lightings.
struct Resolver<'a> {
    world: &'a World,
    screen: &'a Screen,
    w: usize,
    lightings: Vec<LightingResolver<'a>>,
    /// Whether some lighting lights pixels one by one (which needs their positions and normals).
    per_pixel: bool,
    /// The level of detail of every triangle of `screen`, by its number (none when the frame
    /// is not coloured).
    lods: Vec<Lod>,
    /// The camera pose's rotation and translation, and its origin.
    r: [[f32; 4]; 3],
    camera_origin: [f32; 3],
    cx: f32,
    cy: f32,
    inv_fx: f32,
    inv_fy: f32,
}

/// What resolving a frame under one lighting needs beyond what the lightings share.
struct LightingResolver<'a> {
    /// Lights lit per pixel: those that move with the camera, and static ones the world's
    /// bake does not hold.
    lights: Vec<Light>,
    /// Whether each of `lights` is the shadowed camera light.
    shadowed: Vec<bool>,
    /// Light baked for this frame's static lights, per sample of the bake.
    baked: Option<(Arc<BakedLight>, &'a LightBake)>,
    shadow: Option<&'a ShadowMap>,
    lit: bool,
}

impl<'a> LightingResolver<'a> {
    fn new(pass: &LightingPass<'a>, pose: &Matrix4<f64>) -> Self {
        let Lighting { world, shading } = pass.lighting;
        let lit_lights: &[Light] = match shading {
            Shading::Lit(lights) => lights,
            Shading::Flat => &[],
        };
        let lit = matches!(shading, Shading::Lit(_));
        let bake = world.light_bake().filter(|_| lit);
        let (static_baked, per_pixel): (Vec<Light>, Vec<Light>) =
            lit_lights.iter().partition(|l| !l.attached_to_camera && bake.is_some_and(|b| b.has_light(l.position)));
        let first_camera_light = per_pixel.iter().position(|l| l.attached_to_camera);
        let shadowed = (0..per_pixel.len()).map(|i| pass.shadow.is_some() && Some(i) == first_camera_light).collect();
        LightingResolver { lights: world_lights(&per_pixel, pose), shadowed, baked: bake.map(|b| (b.sample_light(&static_baked), b)), shadow: pass.shadow, lit }
    }
}

impl<'a> Resolver<'a> {
    /// The resolver of `camera`'s frame of `world`, whose visible triangles are `screen`,
    /// under `lightings` (none: depth, classes and instances only).
    fn new(world: &'a World, screen: &'a Screen, camera: &Camera, lightings: &[LightingPass<'a>]) -> Self {
        let pose = camera.pose;
        let lightings: Vec<LightingResolver> = lightings.iter().map(|pass| LightingResolver::new(pass, &pose)).collect();
        Resolver {
            lods: if lightings.is_empty() { Vec::new() } else { levels_of_detail(world, screen) },
            world,
            screen,
            w: camera.width as usize,
            per_pixel: lightings.iter().any(|l| !l.lights.is_empty()),
            lightings,
            r: std::array::from_fn(|i| std::array::from_fn(|j| pose[(i, j)] as f32)),
            camera_origin: [pose[(0, 3)] as f32, pose[(1, 3)] as f32, pose[(2, 3)] as f32],
            cx: camera.cx as f32,
            cy: camera.cy as f32,
            inv_fx: 1.0 / camera.fx as f32,
            inv_fy: 1.0 / camera.fy as f32,
        }
    }

    /// Whether the frame is coloured at all.
    fn coloured(&self) -> bool {
        !self.lightings.is_empty()
    }

    /// Resolve row `py` into `out`, with `row` as scratch, [`CHUNK`] pixels at a time (so
    /// the scratch a chunk's passes share stays in the nearest cache).
    fn row(&self, py: usize, row: &mut RowScratch, out: RowOut) {
        row.resize(CHUNK);
        for x0 in (0..self.w).step_by(CHUNK) {
            let n = CHUNK.min(self.w - x0);
            let span = x0..x0 + n;
            let (semantic, instance, depth) = (&mut out.semantic[span.clone()], &mut out.instance[span.clone()], &mut out.depth[span.clone()]);
            self.gather_surfaces(row, n, semantic, instance, depth, &out.hit[span.clone()], &out.weights[span.clone()]);
            if !self.coloured() {
                continue;
            }
            if self.per_pixel {
                self.positions_and_normals(py, x0, n, row, depth);
            }
            for (lighting, rgb) in self.lightings.iter().zip(out.rgbs.iter_mut()) {
                self.start_light(lighting, row, n);
                if !lighting.lights.is_empty() {
                    self.shadows(lighting, py, x0, n, row, depth);
                    light(lighting, row, n);
                }
                colour(row, &mut rgb[3 * x0..3 * (x0 + n)], n);
            }
        }
    }

    /// 1. What each pixel shows, the same under every lighting: class, instance, depth and
    ///    (when coloured) its albedo, the texture's occlusion, where in its triangle it lies
    ///    and, when some lighting lights pixels one by one, its interpolated normal.
    #[allow(clippy::too_many_arguments)]
    fn gather_surfaces(
        &self,
        row: &mut RowScratch,
        w: usize,
        semantic: &mut [u16],
        instance: &mut [u16],
        depth: &mut [f32],
        hit: &[u32],
        weights: &[[f32; 2]],
    ) {
        let mut finder = self.screen.finder();
        // Neighbouring pixels mostly show the same triangle: it is looked up once a run.
        let mut showing: Option<Showing> = None;
        let coloured = self.coloured();
        let RowScratch { albedo, occlusion, bary, run, runs, normal, .. } = row;
        runs.clear();
        let [ar, ag, ab] = albedo.each_mut().map(|v| &mut v[..w]);
        let [b0, b1, b2] = bary.each_mut().map(|v| &mut v[..w]);
        let [nx, ny, nz] = normal.each_mut().map(|v| &mut v[..w]);
        let (occlusion, run) = (&mut occlusion[..w], &mut run[..w]);
        let (semantic, instance, depth, hit, weights) = (&mut semantic[..w], &mut instance[..w], &mut depth[..w], &hit[..w], &weights[..w]);
        for px in 0..w {
            if hit[px] == u32::MAX {
                semantic[px] = 0;
                instance[px] = 0;
                depth[px] = 0.0;
                (ar[px], ag[px], ab[px]) = (0.0, 0.0, 0.0);
                (nx[px], ny[px], nz[px]) = (0.0, 0.0, 0.0);
                run[px] = NO_RUN;
                continue;
            }
            let current = match showing {
                Some(current) if current.hit == hit[px] => current,
                _ => {
                    let current = self.showing(hit[px], finder.triangle(hit[px]), coloured);
                    runs.push(current.screen.source);
                    showing = Some(current);
                    current
                }
            };
            let (st, tri) = (current.screen, current.triangle);
            let [w1, w2] = weights[px];
            let w0 = 1.0 - w1 - w2;
            // Barycentrics in the source triangle.
            let b: [f32; 3] = std::array::from_fn(|k| w0 * st.bary[0][k] + w1 * st.bary[1][k] + w2 * st.bary[2][k]);
            semantic[px] = tri.class_id;
            instance[px] = tri.instance_id;
            if !coloured {
                continue;
            }
            let [red, green, blue, occluded] = albedo_at(current.surface, tri, b, current.lod.sampling(depth[px]));
            (ar[px], ag[px], ab[px], occlusion[px]) = (red, green, blue, occluded);
            (b0[px], b1[px], b2[px]) = (b[0], b[1], b[2]);
            run[px] = (runs.len() - 1) as u32;
            if self.per_pixel {
                let n: [f32; 3] = std::array::from_fn(|k| b[0] * tri.normals[0][k] + b[1] * tri.normals[1][k] + b[2] * tri.normals[2][k]);
                (nx[px], ny[px], nz[px]) = (n[0], n[1], n[2]);
            }
        }
    }

    /// What a run of pixels showing the (clipped) triangle numbered `hit` shares.
    #[inline(always)]
    fn showing<'s>(&'s self, hit: u32, screen: &'s ScreenTriangle, coloured: bool) -> Showing<'s> {
        let triangle = &self.world.triangles()[screen.source as usize];
        let surface = &self.world.surfaces()[triangle.surface as usize];
        let lod = if coloured { self.lods[hit as usize] } else { Lod::default() };
        Showing { hit, screen, triangle, surface, lod }
    }

    /// 2. The light each pixel starts from under `lighting`: flat, the albedo as it is;
    ///    lit, the ambient term (darkened by the texture's occlusion) and the static
    ///    lights' light baked for the side it shows, read from its plane's light map or
    ///    interpolated from its triangle's vertices. A pixel that shows nothing gets none.
    fn start_light(&self, lighting: &LightingResolver, row: &mut RowScratch, w: usize) {
        let RowScratch { occlusion, bary, run, runs, light, .. } = row;
        let [lr, lg, lb] = light.each_mut().map(|v| &mut v[..w]);
        let (occlusion, run, [b0, b1, b2]) = (&occlusion[..w], &run[..w], bary.each_ref().map(|v| &v[..w]));
        if !lighting.lit {
            for px in 0..w {
                let on = if run[px] == NO_RUN { 0.0 } else { 1.0 };
                (lr[px], lg[px], lb[px]) = (on, on, on);
            }
            return;
        }
        // Where the run's light is read, looked up once a run.
        let mut current: Option<(u32, Baked)> = None;
        for px in 0..w {
            if run[px] == NO_RUN {
                (lr[px], lg[px], lb[px]) = (0.0, 0.0, 0.0);
                continue;
            }
            let baked = match current {
                Some((at, baked)) if at == run[px] => baked,
                _ => {
                    let t = runs[run[px] as usize] as usize;
                    let baked = self.baked(lighting, t, &self.world.triangles()[t]);
                    current = Some((run[px], baked));
                    baked
                }
            };
            let b = [b0[px], b1[px], b2[px]];
            let [ambient, r, g, bl] = match baked {
                Baked::Plane(plane, texels, corners) => plane.sample_in_plane(texels, corners.map(|c| b[0] * c[0] + b[1] * c[1] + b[2] * c[2])),
                Baked::Vertices(v, side) => {
                    let channel = |c: usize| b[0] * v[0][c] + b[1] * v[1][c] + b[2] * v[2][c];
                    [channel(side), channel(2 + 3 * side), channel(3 + 3 * side), channel(4 + 3 * side)]
                }
                Baked::None => [AMBIENT, 0.0, 0.0, 0.0],
            };
            let ambient = ambient * occlusion[px];
            (lr[px], lg[px], lb[px]) = (ambient + r, ambient + g, ambient + bl);
        }
    }

    /// Where `lighting`'s baked light of triangle `t` (`tri`) is read.
    #[inline(always)]
    fn baked<'s>(&self, lighting: &'s LightingResolver, t: usize, tri: &Triangle) -> Baked<'s> {
        match &lighting.baked {
            Some((light, bake)) => match bake.plane_of(t) {
                Some(plane) => Baked::Plane(plane, &light.texels, plane.axes().map(|a| tri.positions.map(|p| p[a]))),
                None => Baked::Vertices(bake.corners()[t].map(|k| &light.samples[k as usize]), self.side_seen(tri)),
            },
            None => Baked::None,
        }
    }

    /// The side of `tri` the camera sees: 0, the side its vertex normals point to; 1, the other.
    #[inline(always)]
    fn side_seen(&self, tri: &Triangle) -> usize {
        let [a, b, c] = tri.positions;
        let (e1, e2) = ([b[0] - a[0], b[1] - a[1], b[2] - a[2]], [c[0] - a[0], c[1] - a[1], c[2] - a[2]]);
        let face = [e1[1] * e2[2] - e1[2] * e2[1], e1[2] * e2[0] - e1[0] * e2[2], e1[0] * e2[1] - e1[1] * e2[0]];
        let to_camera = [self.camera_origin[0] - a[0], self.camera_origin[1] - a[1], self.camera_origin[2] - a[2]];
        let normals: [f32; 3] = std::array::from_fn(|k| tri.normals[0][k] + tri.normals[1][k] + tri.normals[2][k]);
        let dot = |u: [f32; 3], v: [f32; 3]| u[0] * v[0] + u[1] * v[1] + u[2] * v[2];
        usize::from((dot(face, to_camera) >= 0.0) != (dot(face, normals) >= 0.0))
    }

    /// 1b. For lights lit per pixel, under any lighting: world positions from depth, and
    ///     the normals turned to the camera's side (two-sided) and made unit length —
    ///     across the chunk, branch-free, so it vectorises. A pixel without a hit has a
    ///     zero normal: it gets no light.
    fn positions_and_normals(&self, py: usize, x0: usize, w: usize, row: &mut RowScratch, depth: &[f32]) {
        let (r, camera_origin) = (&self.r, self.camera_origin);
        let RowScratch { position, normal, .. } = row;
        let [px_, py_, pz_] = position.each_mut().map(|v| &mut v[..w]);
        let [nx, ny, nz] = normal.each_mut().map(|v| &mut v[..w]);
        let depth = &depth[..w];
        let y = (py as f32 - self.cy) * self.inv_fy;
        for px in 0..w {
            let z = depth[px];
            let cam = [(column(x0 + px) - self.cx) * self.inv_fx * z, y * z, z];
            let p: [f32; 3] = std::array::from_fn(|i| r[i][0] * cam[0] + r[i][1] * cam[1] + r[i][2] * cam[2] + r[i][3]);
            let n = [nx[px], ny[px], nz[px]];
            let to_camera = [camera_origin[0] - p[0], camera_origin[1] - p[1], camera_origin[2] - p[2]];
            let side = if n[0] * to_camera[0] + n[1] * to_camera[1] + n[2] * to_camera[2] < 0.0 { -1.0 } else { 1.0 };
            let unit = side / (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt().max(1e-12);
            (px_[px], py_[px], pz_[px]) = (p[0], p[1], p[2]);
            (nx[px], ny[px], nz[px]) = (n[0] * unit, n[1] * unit, n[2] * unit);
        }
    }

    /// 2b. With `lighting`'s shadow map, how much of its camera light reaches each pixel.
    fn shadows(&self, lighting: &LightingResolver, py: usize, x0: usize, w: usize, row: &mut RowScratch, depth: &[f32]) {
        let Some(map) = lighting.shadow else { return };
        let y = (py as f32 - self.cy) * self.inv_fy;
        let shadow = &mut row.shadow[..w];
        for px in 0..w {
            let z = depth[px];
            shadow[px] = if z > 0.0 { map.visibility([(column(x0 + px) - self.cx) * self.inv_fx * z, y * z, z]) } else { 1.0 };
        }
    }
}

/// 3. `lighting`'s lights lit per pixel, added light by light across the chunk to what
///    each pixel starts from (2): Lambert (n·d / |d|) times Magnum PhongGL's attenuation
///    1/(1 + |d|²) for an unbounded range, the camera light times its shadow; a light
///    behind the surface adds nothing.
fn light(lighting: &LightingResolver, row: &mut RowScratch, w: usize) {
    let RowScratch { position, normal, light, shadow, .. } = row;
    for (l, &shadowed) in lighting.lights.iter().zip(&lighting.shadowed) {
        // Slices of exactly `w` (no bounds checks in the loop, so it vectorises).
        let ([px_, py_, pz_], [nx, ny, nz]) = (position.each_ref().map(|v| &v[..w]), normal.each_ref().map(|v| &v[..w]));
        let [lr, lg, lb] = light.each_mut().map(|v| &mut v[..w]);
        let shadow = &shadow[..w];
        for i in 0..w {
            let d = [l.position[0] - px_[i], l.position[1] - py_[i], l.position[2] - pz_[i]];
            let facing = (nx[i] * d[0] + ny[i] * d[1] + nz[i] * d[2]).max(0.0);
            let d2 = d[0] * d[0] + d[1] * d[1] + d[2] * d[2];
            let reach = if shadowed { shadow[i] } else { 1.0 };
            let factor = reach * facing / (d2.sqrt().max(1e-6) * (1.0 + d2));
            lr[i] += factor * l.color[0];
            lg[i] += factor * l.color[1];
            lb[i] += factor * l.color[2];
        }
    }
}

/// What the pixels of a run showing one (clipped) triangle share: the triangle, its
/// surface and its level of detail.
#[derive(Clone, Copy)]
struct Showing<'a> {
    hit: u32,
    screen: &'a ScreenTriangle,
    triangle: &'a Triangle,
    surface: &'a Surface,
    lod: Lod,
}

/// Where a triangle's baked light is read: its plane's light map (the texels' light, and
/// the triangle's corners along the plane's two axes), or its three vertices' light and the
/// side seen; none without a bake.
#[derive(Clone, Copy)]
enum Baked<'a> {
    Plane(&'a LightPlane, &'a [[f32; 4]], [[f32; 3]; 2]),
    Vertices([&'a SampleLight; 3], usize),
    None,
}

/// The level of detail of every (clipped) triangle of `screen`, by its number: computed once
/// a frame, not once for each run of pixels showing it (some three runs a triangle, one for
/// each row it crosses, in the rooms of a release).
fn levels_of_detail(world: &World, screen: &Screen) -> Vec<Lod> {
    let of_part = |part: &Part| -> Vec<Lod> {
        part.triangles
            .iter()
            .map(|st| {
                let triangle = &world.triangles()[st.source as usize];
                Lod::of(st, triangle, &world.surfaces()[triangle.surface as usize])
            })
            .collect()
    };
    screen.parts.par_iter().map(of_part).collect::<Vec<_>>().concat()
}

/// Which mipmap level a triangle's pixels read: log2 of how many texels a pixel covers,
/// measured over the triangle's (clipped) piece at its mean depth and scaled, pixel by
/// pixel, by the pixel's depth against that mean (a floor seen from 1 m reads finer texels
/// near the camera than far away).
#[derive(Debug, Clone, Copy, Default, PartialEq)]
struct Lod {
    /// The level at the mean depth.
    at_mean: f32,
    /// 1 / that depth.
    inv_mean_depth: f32,
}

impl Lod {
    /// The level of detail of `st` (a piece of `tri`) with `surface`'s texture.
    fn of(st: &ScreenTriangle, tri: &Triangle, surface: &Surface) -> Lod {
        let Some(tex) = &surface.texture else { return Lod::default() };
        let cross2 = |a: [f64; 2], b: [f64; 2], c: [f64; 2]| ((b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0])).abs();
        let screen = cross2(st.xy[0], st.xy[1], st.xy[2]);
        let uv = |k: usize| [tri.uvs[k][0] as f64, tri.uvs[k][1] as f64];
        let bary = |k: usize| [st.bary[k][1] as f64, st.bary[k][2] as f64];
        // The piece's share of the source triangle (its area in barycentric coordinates,
        // of which the whole triangle's is 1/2) times the source's texture area in texels.
        let level0 = &tex.levels[0];
        let texels = cross2(uv(0), uv(1), uv(2)) * cross2(bary(0), bary(1), bary(2)) * level0.width as f64 * level0.height as f64;
        if !(screen > 1e-9 && texels > 0.0) {
            return Lod::default();
        }
        let mean_inv_z = (st.inv_z[0] + st.inv_z[1] + st.inv_z[2]) / 3.0;
        Lod { at_mean: (0.5 * (texels / screen).log2()) as f32, inv_mean_depth: 1.0 / mean_inv_z.max(1e-6) }
    }

    /// How the texture is read at depth `z`: its level (rounded down), or, where a texel
    /// spans [`MAGNIFIED`]'s √2 pixels or more, the texture itself, blended between texels.
    #[inline(always)]
    fn sampling(self, z: f32) -> Sampling {
        // log2 by the float's bits: the exponent plus the mantissa as a fraction (within 0.09).
        let ratio = (z * self.inv_mean_depth).max(1e-6);
        let log2 = ratio.to_bits() as f32 * (1.0 / (1u32 << 23) as f32) - 127.0;
        let level = self.at_mean + log2;
        if level < MAGNIFIED { Sampling::Magnified } else { Sampling::Level(level.max(0.0) as u32 as usize) }
    }
}

/// The level of detail below which a texture is blended between texels: a texel spans
/// √2 pixels or more (closer, nearest texels of a pixel or so are not seen as squares, and
/// blending every pixel cost a tenth of a frame).
const MAGNIFIED: f32 = -0.5;

/// How a pixel reads its texture.
#[derive(Debug, Clone, Copy)]
enum Sampling {
    /// A texel spans √2 pixels or more: the texture (level 0), blended between the four
    /// texels around the point ([`bilinear`]); read nearest, close-up prints, weaves and
    /// grain showed their texels as squares.
    Magnified,
    /// Anything farther: the nearest texel of this mipmap level (the level's
    /// texels are already the means of the finer ones).
    Level(usize),
}

/// The albedo of `surface` at barycentrics `b` of `tri` — its colour, times its texture
/// there (read by `sampling`) when it has one — and the ambient occlusion the texture
/// carries (its alpha, when the surface keeps one there: [`Surface::occlusion_in_alpha`];
/// else 1).
#[inline(always)]
fn albedo_at(surface: &Surface, tri: &Triangle, b: [f32; 3], sampling: Sampling) -> [f32; 4] {
    let c = surface.color;
    let Some(mips) = &surface.texture else { return [c[0], c[1], c[2], 1.0] };
    let u = b[0] * tri.uvs[0][0] + b[1] * tri.uvs[1][0] + b[2] * tri.uvs[2][0];
    let v = b[0] * tri.uvs[0][1] + b[1] * tri.uvs[1][1] + b[2] * tri.uvs[2][1];
    let t = match sampling {
        Sampling::Magnified => bilinear(&mips.levels[0], u, v),
        Sampling::Level(level) => nearest(&mips.levels[level.min(mips.levels.len() - 1)], u, v),
    };
    let occlusion = if surface.occlusion_in_alpha { t[3] * INV_255 } else { 1.0 };
    [c[0] * t[0] * INV_255, c[1] * t[1] * INV_255, c[2] * t[2] * INV_255, occlusion]
}

/// The texel of `tex` holding `(u, v)`, repeated beyond 0..1, channels 0..255.
#[inline(always)]
fn nearest(tex: &crate::convert::gltf::Texture, u: f32, v: f32) -> [f32; 4] {
    // Through u32, which converts in one instruction where usize takes
    // several; the values are the same (the product is below the width).
    let (tw, th) = (tex.width as usize, tex.height as usize);
    let tx = ((fract(u) * tex.width as f32) as u32 as usize).min(tw - 1);
    let ty = ((fract(v) * tex.height as f32) as u32 as usize).min(th - 1);
    let at = 4 * (ty * tw + tx);
    let channels: [u8; 4] = tex.rgba[at..at + 4].try_into().expect("four channels a texel");
    channels.map(f32::from)
}

/// The texture at `(u, v)`, repeated beyond 0..1, blended from the four texels around the
/// point (their centres at half-texel offsets), channels 0..255. Read the nearest texel
/// instead, a texture seen close up shows its texels as squares (a picture's print, a
/// rug's weave, the grain of a table at arm's length).
#[inline(always)]
fn bilinear(tex: &crate::convert::gltf::Texture, u: f32, v: f32) -> [f32; 4] {
    let (tw, th) = (tex.width as usize, tex.height as usize);
    // The texel left of (above) the point and the weight of the one right of (below) it.
    // Shifted by a whole texture so the value is positive: the float-to-integer conversion
    // then floors, and the texel wraps with one comparison. Through u32, which converts in
    // one instruction where usize takes several; the values are below 2·width.
    let axis = |t: f32, n: usize| -> (usize, usize, f32) {
        let s = fract(t) * n as f32 + (n as f32 - 0.5);
        let floor = s as u32 as usize;
        let weight = s - floor as f32;
        let first = if floor >= n { floor - n } else { floor };
        let first = first.min(n - 1);
        let second = if first + 1 == n { 0 } else { first + 1 };
        (first, second, weight)
    };
    let (x0, x1, wx) = axis(u, tw);
    let (y0, y1, wy) = axis(v, th);
    let texel = |x: usize, y: usize| -> [f32; 4] {
        let at = 4 * (y * tw + x);
        let channels: [u8; 4] = tex.rgba[at..at + 4].try_into().expect("four channels a texel");
        channels.map(f32::from)
    };
    let (a, b, c, d) = (texel(x0, y0), texel(x1, y0), texel(x0, y1), texel(x1, y1));
    std::array::from_fn(|k| {
        let top = a[k] + wx * (b[k] - a[k]);
        let bottom = c[k] + wx * (d[k] - c[k]);
        top + wy * (bottom - top)
    })
}

/// 3. Colour: albedo times light, clipped, rounded half up (without libm's roundf, which
///    is not inlined on baseline x86-64), into the `w` pixels of `rgb`.
fn colour(row: &RowScratch, rgb: &mut [u8], w: usize) {
    let ([ar, ag, ab], [lr, lg, lb]) = (row.albedo.each_ref().map(|v| &v[..w]), row.light.each_ref().map(|v| &v[..w]));
    let channel = |albedo: f32, light: f32| ((albedo * light.max(0.0)).clamp(0.0, 1.0) * 255.0 + 0.5) as u8;
    for (px, out) in rgb[..3 * w].chunks_exact_mut(3).enumerate() {
        out[0] = channel(ar[px], lr[px]);
        out[1] = channel(ag[px], lg[px]);
        out[2] = channel(ab[px], lb[px]);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn of_two_triangles_at_the_same_depth_the_first_in_the_worlds_order_keeps_the_pixel() {
        use crate::render::mesh::Surface;
        let triangle = |class_id: u16, positions: [[f32; 3]; 3]| Triangle {
            positions,
            normals: [[0.0, 0.0, -1.0]; 3],
            uvs: [[0.0; 2]; 3],
            surface: 0,
            class_id,
            instance_id: class_id,
        };
        // Facing the camera 2 m ahead (OpenCV axes: z forward), over the image's centre.
        let ahead = [[-1.0, -1.0, 2.0], [1.0, -1.0, 2.0], [0.0, 1.0, 2.0]];
        let behind_the_camera = [[0.0, 0.0, -5.0], [1.0, 0.0, -5.0], [0.0, 1.0, -5.0]];
        let camera = Camera { width: 64, height: 48, fx: 40.0, fy: 40.0, cx: 31.5, cy: 23.5, pose: Matrix4::identity() };
        let surfaces = vec![Surface { color: [1.0; 3], texture: None, occlusion_in_alpha: false }];
        // The same triangle twice, next to each other or 300 one-triangle clusters apart
        // (in another task of the transform), in either order of their classes.
        for (between, first, second) in [(0, 1, 2), (0, 2, 1), (300, 1, 2), (300, 2, 1)] {
            let mut triangles = vec![triangle(first, ahead)];
            triangles.extend((0..between).map(|i| triangle(10 + (i % 2) as u16, behind_the_camera)));
            triangles.push(triangle(second, ahead));
            let world = World::with_cluster_size(triangles, surfaces.clone(), 1);
            let mut frame = Frame::default();
            render(&world, &camera, &Shading::Flat, &mut frame);
            let count = |class: u16| frame.semantic.iter().filter(|&&c| c == class).count();
            assert!(count(first) > 500, "{between} apart: the first covers {} pixels", count(first));
            assert_eq!(count(second), 0, "{between} apart: the second drawn took pixels at the same depth");
        }
    }

    #[test]
    fn each_pass_time_is_summed_over_the_frames_rendered_into_a_frame() {
        let positions = [[-1.0, -1.0, 2.0], [1.0, -1.0, 2.0], [0.0, 1.0, 2.0]];
        let triangle = Triangle { positions, normals: [[0.0, 0.0, -1.0]; 3], uvs: [[0.0; 2]; 3], surface: 0, class_id: 1, instance_id: 1 };
        let world = World::new(vec![triangle], vec![crate::render::mesh::Surface { color: [1.0; 3], texture: None, occlusion_in_alpha: false }]);
        let camera = Camera { width: 64, height: 48, fx: 40.0, fy: 40.0, cx: 31.5, cy: 23.5, pose: Matrix4::identity() };
        let mut frame = Frame::default();
        let clock = Instant::now();
        render(&world, &camera, &Shading::Flat, &mut frame);
        render_visibility(&world, &camera, &mut frame);
        let elapsed = clock.elapsed();
        let times = frame.pass_times;
        assert_eq!(times.frames, 2);
        // The passes run one after another, inside the two calls.
        assert!(times.transform + times.visibility + times.resolve <= elapsed, "{times:?} within {elapsed:?}");
    }

    #[test]
    fn culling_clusters_by_their_boxes_changes_no_pixel_and_drops_most_of_a_room_out_of_view() {
        use crate::render::mesh::Surface;
        // Small triangles of 400 objects all around the camera (some behind it, some
        // through its near plane, some just beyond the image's edges), 30 each.
        let mut state = 0x2545_F491_4F6C_DD1Du64;
        let mut uniform = move || {
            state = state.wrapping_mul(6_364_136_223_846_793_005).wrapping_add(1_442_695_040_888_963_407);
            ((state >> 11) as f64 / (1u64 << 53) as f64) as f32
        };
        let mut triangles = Vec::new();
        for object in 0..400u16 {
            let spread = if object % 8 == 0 { 0.8 } else { 8.0 }; // an eighth within 0.4 m
            let centre = [0.1 + (uniform() - 0.5) * spread, 0.2 + (uniform() - 0.5) * spread, (uniform() - 0.5) * spread];
            let size = if object % 10 == 0 { 0.02 } else { 0.3 };
            for _ in 0..30 {
                let p: [[f32; 3]; 3] = std::array::from_fn(|_| std::array::from_fn(|k| centre[k] + (uniform() - 0.5) * size));
                triangles.push(Triangle {
                    positions: p,
                    normals: [[0.0, 0.0, -1.0]; 3],
                    uvs: [[0.0; 2]; 3],
                    surface: 0,
                    class_id: object + 1,
                    instance_id: object + 1,
                });
            }
        }
        let surfaces = vec![Surface { color: [0.5, 0.25, 1.0], texture: None, occlusion_in_alpha: false }];
        let clustered = World::with_cluster_size(triangles.clone(), surfaces.clone(), 8);
        assert_eq!(clustered.clusters().len(), 400 * 4, "a cluster never holds two objects");
        // The reference: one instance, one cluster, whose box holds the camera (never culled).
        let one = triangles.iter().map(|t| Triangle { instance_id: 1, ..*t }).collect::<Vec<_>>();
        let whole = World::with_cluster_size(one, surfaces, triangles.len());
        assert_eq!(whole.clusters().len(), 1);
        let (mut culled, mut drawn) = (0, 0);
        for view in 0..24 {
            let a = std::f64::consts::TAU * view as f64 / 24.0;
            let (c, s) = (a.cos(), a.sin());
            let pose = Matrix4::new(c, 0.0, -s, 0.1, 0.0, -1.0, 0.0, 0.2, -s, 0.0, -c, 0.0, 0.0, 0.0, 0.0, 1.0);
            let camera = Camera { width: 160, height: 120, fx: 80.0, fy: 80.0, cx: 79.5, cy: 59.5, pose };
            let world_to_camera = pose.try_inverse().unwrap();
            culled += clustered.clusters().iter().filter(|c| !may_be_seen(c, &world_to_camera, &camera, NEAR)).count();
            let (mut a, mut b) = (Frame::default(), Frame::default());
            render(&clustered, &camera, &Shading::Flat, &mut a);
            render(&whole, &camera, &Shading::Flat, &mut b);
            drawn += b.semantic.iter().filter(|&&s| s != 0).count();
            assert!(whole.clusters().iter().all(|c| may_be_seen(c, &world_to_camera, &camera, NEAR)));
            assert_eq!((a.depth, a.semantic, a.rgb), (b.depth, b.semantic, b.rgb), "view {view}");
        }
        let clusters = 24 * clustered.clusters().len();
        assert!(drawn > 24 * 160 * 120 / 10, "the objects are in view: {drawn} pixels");
        assert!(culled > clusters / 2, "{culled} of {clusters} clusters culled");
    }

    #[test]
    fn each_visible_triangle_s_level_of_detail_is_found_under_the_number_its_pixels_hold() {
        use crate::convert::gltf::Texture;
        use crate::render::mesh::{MipMaps, Surface};
        // Objects in a ring around the camera, textured at eight densities from 1 to 128
        // repeats, in clusters of one object: the frame's triangles come in several parts.
        let texture = Arc::new(MipMaps::of(Texture { width: 64, height: 64, rgba: vec![128; 64 * 64 * 4] }));
        let surfaces = vec![Surface { color: [1.0; 3], texture: Some(texture), occlusion_in_alpha: false }];
        let mut triangles = Vec::new();
        for object in 0..200u16 {
            let a = std::f32::consts::TAU * object as f32 / 200.0;
            let centre = [3.0 * a.cos(), 0.0, 3.0 * a.sin()];
            let uv_scale = (1u32 << (object % 8)) as f32;
            for k in 0..8 {
                let offset = k as f32 * 0.05;
                triangles.push(Triangle {
                    positions: [
                        [centre[0], centre[1] + offset, centre[2]],
                        [centre[0] + 0.2, centre[1] + offset, centre[2]],
                        [centre[0], centre[1] + offset + 0.2, centre[2] + 0.1],
                    ],
                    normals: [[0.0, 0.0, -1.0]; 3],
                    uvs: [[0.0, 0.0], [uv_scale, 0.0], [0.0, uv_scale]],
                    surface: 0,
                    class_id: 1,
                    instance_id: object + 1,
                });
            }
        }
        let world = World::with_cluster_size(triangles, surfaces, 8);
        let pose = Matrix4::new(1.0, 0.0, 0.0, 0.0, 0.0, -1.0, 0.0, 0.0, 0.0, 0.0, -1.0, 0.0, 0.0, 0.0, 0.0, 1.0);
        let camera = Camera { width: 320, height: 240, fx: 160.0, fy: 160.0, cx: 159.5, cy: 119.5, pose };
        let mut frame = Frame::default();
        find_visible(&world, &camera, &mut frame);
        let screen = &frame.screen;
        let lods = levels_of_detail(&world, screen);
        let filled: Vec<usize> = screen.parts.iter().enumerate().filter(|(_, part)| !part.triangles.is_empty()).map(|(p, _)| p).collect();
        assert!(filled.len() >= 2, "the triangles seen come in several parts: {filled:?}");
        let mut levels = Vec::new();
        for p in filled {
            for (place, st) in screen.parts[p].triangles.iter().enumerate() {
                let triangle = &world.triangles()[st.source as usize];
                let own = Lod::of(st, triangle, &world.surfaces()[0]);
                assert_eq!(lods[screen.index(p, place as u32) as usize], own, "part {p}, place {place}");
                levels.push(own.at_mean);
            }
        }
        assert_eq!(lods.len(), levels.len(), "one level of detail for each triangle of the frame");
        levels.sort_by(f32::total_cmp);
        assert!(levels[levels.len() - 1] - levels[0] > 3.0, "the objects' levels differ: {levels:?}");
    }

    #[test]
    fn the_fractional_part_through_floor_is_the_truncating_one_to_the_bit() {
        // The version before floor was one instruction (only the sign of a zero differs).
        let truncating = |x: f32| {
            if x.abs() < 8_388_608.0 {
                let f = x - (x as i32) as f32;
                if f < 0.0 { f + 1.0 } else { f }
            } else {
                0.0
            }
        };
        let mut bits = 0x2545_F491_u32;
        let random = (0..200_000).map(|_| {
            bits ^= bits << 13;
            bits ^= bits >> 17;
            bits ^= bits << 5;
            f32::from_bits(bits)
        });
        let stepped = (-50_000..50_000).map(|i| i as f32 * 0.013_7);
        let edges = [-1e-9, -0.5, -1.0, -2.75, 0.999_999_94, 8_388_607.5, -8_388_607.5, 8_388_608.0, 1e30, f32::INFINITY, f32::NEG_INFINITY, f32::NAN];
        for x in random.chain(stepped).chain(edges) {
            let (now, before) = (fract(x), truncating(x));
            assert!(now == before, "fract({x:e}) = {now:e}, truncating gave {before:e}");
            assert!((0.0..=1.0).contains(&now), "fract({x:e}) = {now:e}");
        }
        // A tiny negative value rounds up to 1, as it did.
        assert_eq!(fract(-1e-9), 1.0);
    }

    #[test]
    fn a_texture_is_blended_between_texel_centres_and_wraps_at_its_edges() {
        use crate::convert::gltf::Texture;
        // Two texels side by side, one row: black then white (alpha 0 then 200).
        let tex = Texture { width: 2, height: 1, rgba: vec![0, 0, 0, 0, 255, 255, 255, 200] };
        let red = |u: f32| bilinear(&tex, u, 0.5)[0];
        // At a texel's centre, that texel alone.
        assert_eq!(red(0.25), 0.0);
        assert_eq!(red(0.75), 255.0);
        // Halfway between the centres, the mean; a quarter of the way, a quarter of the step.
        assert_eq!(red(0.5), 127.5);
        assert_eq!(red(0.375), 63.75);
        // At the texture's edge, halfway between its last texel and (repeated) its first.
        assert_eq!(red(0.0), 127.5);
        assert_eq!(red(1.0), 127.5);
        assert_eq!(red(-0.25), 255.0);
        // Every channel is blended alike, alpha too.
        assert_eq!(bilinear(&tex, 0.5, 0.9), [127.5, 127.5, 127.5, 100.0]);
    }

    #[test]
    fn a_floor_with_a_light_map_is_lit_at_each_pixel_as_its_map_reads_at_the_point_the_pixel_shows() {
        use crate::render::mesh::Surface;
        // A 4 × 4 m mid-grey floor with a light map, a light 1.2 m over it (off the
        // camera's axis), seen from 1.5 m up, looking down.
        let floor = |p: [[f32; 3]; 3]| Triangle { positions: p, normals: [[0.0, 1.0, 0.0]; 3], uvs: [[0.0; 2]; 3], surface: 0, class_id: 1, instance_id: 1 };
        let triangles = vec![floor([[-2.0, 0.0, -2.0], [2.0, 0.0, -2.0], [2.0, 0.0, 2.0]]), floor([[-2.0, 0.0, -2.0], [2.0, 0.0, 2.0], [-2.0, 0.0, 2.0]])];
        let light = Light { position: [0.6, 1.2, -0.3], color: [1.0; 3], attached_to_camera: false };
        let surfaces = vec![Surface { color: [0.5; 3], texture: None, occlusion_in_alpha: false }];
        let world = World::with_cluster_size(triangles, surfaces, 64).with_light_bake(&[light.position], None, &[1]);
        // OpenCV axes: x right along the world's x, y down along its z, z forward down.
        #[rustfmt::skip]
        let pose = Matrix4::new(1.0, 0.0, 0.0, 0.0, 0.0, 0.0, -1.0, 1.5, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0);
        let camera = Camera { width: 96, height: 64, fx: 60.0, fy: 60.0, cx: 47.5, cy: 31.5, pose };
        let mut frame = Frame::default();
        render(&world, &camera, &Shading::Lit(vec![light]), &mut frame);
        let bake = world.light_bake().expect("baked");
        let map = bake.plane_of(0).expect("the floor has a light map");
        let lit = bake.sample_light(&[light]);
        let (mut brightest, mut darkest) = (0u8, 255u8);
        for (i, &z) in frame.depth.iter().enumerate() {
            assert!((z - 1.5).abs() < 1e-3, "pixel {i} sees the floor 1.5 m below: {z}");
            let (x, y) = ((i % 96) as f32, (i / 96) as f32);
            // The point the pixel shows, in the world: x along x, z along the image's y.
            let point = [(x - 47.5) / 60.0 * z, 0.0, (y - 31.5) / 60.0 * z];
            let [ambient, red, ..] = map.sample(&lit.texels, point);
            let expected = 0.5 * (ambient + red) * 255.0;
            let got = frame.rgb[3 * i];
            assert!((got as f32 - expected).abs() <= 1.0, "pixel ({x}, {y}): {got}, its light map gives {expected:.2}");
            (brightest, darkest) = (brightest.max(got), darkest.min(got));
        }
        // The map is read where the pixel lies: bright under the light, dim in the far corners.
        assert!(brightest > darkest + 20, "the light falls off across the floor: {darkest}..{brightest}");
    }
}
