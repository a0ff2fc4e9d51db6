//! Light baked into a world once: how much ambient light reaches each surface past other
//! objects (ambient occlusion: the darkening where a sofa meets the floor, under a table,
//! in a room's corners) and how much of each ceiling light reaches it past everything in
//! between (shadows, softened by the light's size). The renderer interpolates these instead
//! of lighting each pixel, so shadows cost next to nothing per frame; lights that move with
//! the camera are lit per pixel ([`super::raster`]).
//!
//! Two kinds of samples hold the light:
//! - the room's floor, walls and ceiling — large flat triangles where most shadows fall — get
//!   a light map each plane: a grid of [`TEXEL`] samples in the plane, read bilinearly by
//!   world position, so a chair leg's shadow on a floor of two triangles is crisp;
//! - everything else gets its vertices baked, for both of their sides (the renderer draws
//!   both faces of every triangle), and interpolated across each triangle.

use std::collections::{BTreeMap, HashMap};
use std::sync::{Arc, Mutex};

use rayon::prelude::*;

use super::bvh::{Bvh, Ray};
use super::light::{AMBIENT, Light};
use super::surface::Triangle;

/// Ambient-occlusion rays per sample side (a vertex's back side — a closed object's inside,
/// a panel's rarely seen back — gets fewer), and how far they look (metres).
const AO_RAYS: [usize; 2] = [16, 4];
const AO_RADIUS: f32 = 0.5;
/// How dark full occlusion makes the ambient term.
const AO_STRENGTH: f32 = 0.85;
/// Shadow rays per light and sample side (front, back), to points of a disc of this radius
/// around the light: soft shadow edges, as a lamp's diffuser gives.
const SHADOW_RAYS: [usize; 2] = [4, 1];
const LIGHT_RADIUS: f32 = 0.12;
/// A light reaching a side with less than this share is not shadow-tested (its shadow
/// could not be seen).
const NEGLIGIBLE: f32 = 0.004;
/// How far off its surface a sample's rays start.
const OFFSET: f32 = 0.002;
/// The side of a light-map texel, metres, and the most texels a plane has along a side.
pub const TEXEL: f32 = 0.04;
const MAX_TEXELS: usize = 400;

/// What one sample receives from a light set: ambient front, ambient back, direct RGB
/// front, direct RGB back (a light-map texel's back is its front).
pub type SampleLight = [f32; 8];

/// What a light set gives every sample: the vertices' both sides, and the light-map texels'
/// front (ambient, direct RGB) packed apart, as the renderer reads them.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct BakedLight {
    pub samples: Vec<SampleLight>,
    pub texels: Vec<[f32; 4]>,
}

/// A light map: a grid of samples over one axis-aligned plane of the room.
#[derive(Debug, Clone, PartialEq)]
pub struct LightPlane {
    /// The axes the grid runs along (the plane's normal is the third).
    axes: [usize; 2],
    /// World coordinates of the first texel's centre along `axes`.
    origin: [f32; 2],
    size: [usize; 2],
    /// The index of its first texel among the bake's samples.
    first: u32,
}

impl LightPlane {
    /// What reaches world point `p` of the plane: bilinear over its four nearest texels
    /// (ambient, then direct RGB).
    #[inline(always)]
    pub fn sample(&self, texels: &[[f32; 4]], p: [f32; 3]) -> [f32; 4] {
        self.sample_in_plane(texels, [p[self.axes[0]], p[self.axes[1]]])
    }

    /// The two world axes the plane spans, in the order [`LightPlane::sample_in_plane`]
    /// takes a point's coordinates along them.
    #[inline(always)]
    pub fn axes(&self) -> [usize; 2] {
        self.axes
    }

    /// [`LightPlane::sample`] of a point given by its coordinates along the plane's
    /// [`LightPlane::axes`] alone (the third, across the plane, is not read).
    #[inline(always)]
    pub fn sample_in_plane(&self, texels: &[[f32; 4]], q: [f32; 2]) -> [f32; 4] {
        let u = ((q[0] - self.origin[0]) * (1.0 / TEXEL)).max(0.0);
        let v = ((q[1] - self.origin[1]) * (1.0 / TEXEL)).max(0.0);
        // Through u32, which converts in one instruction where usize takes several; the
        // values are the same (a map's side is at most MAX_TEXELS).
        let (x, y) = ((u as u32 as usize).min(self.size[0] - 2), (v as u32 as usize).min(self.size[1] - 2));
        let (fx, fy) = ((u - x as u32 as f32).min(1.0), (v - y as u32 as f32).min(1.0));
        let i = self.first as usize + y * self.size[0] + x;
        // The two texels of each row as one slice: one bounds check a row.
        let (near, far) = (&texels[i..i + 2], &texels[i + self.size[0]..i + self.size[0] + 2]);
        let (a, b, c, d) = (&near[0], &near[1], &far[0], &far[1]);
        let w = [(1.0 - fx) * (1.0 - fy), fx * (1.0 - fy), (1.0 - fx) * fy, fx * fy];
        std::array::from_fn(|k| w[0] * a[k] + w[1] * b[k] + w[2] * c[k] + w[3] * d[k])
    }
}

/// A world's baked light.
#[derive(Debug)]
pub struct LightBake {
    /// Per triangle, the sample of each corner (unused for triangles of a light map).
    corners: Vec<[u32; 3]>,
    /// Per triangle, its light map, or [`NO_PLANE`].
    plane_of: Vec<u32>,
    planes: Vec<LightPlane>,
    /// Per sample, the ambient occlusion factor of each side (1: open).
    ao: Vec<[f32; 2]>,
    /// The static lights baked (world positions).
    lights: Vec<[f32; 3]>,
    /// Per light, per sample: the share of it each side receives (visibility × cosine over
    /// Habitat's attenuation 1 + d²).
    transfer: Vec<Vec<[f32; 2]>>,
    /// Texels (the first samples) of all light maps.
    texels: usize,
    /// Sample light of each light set rendered so far.
    combined: Mutex<Vec<(Vec<Light>, Arc<BakedLight>)>>,
}

/// A triangle that lies in no light map.
pub const NO_PLANE: u32 = u32::MAX;

/// A point to bake: position, unit normal, the object it belongs to, and whether its back
/// side is baked too.
#[derive(Debug, Clone, Copy)]
struct Sample {
    position: [f32; 3],
    normal: [f32; 3],
    instance: u16,
    two_sided: bool,
}

impl LightBake {
    /// Bake `world` for the static lights at `lights` (world positions). Triangles of
    /// `fixture_class` (the ceiling and its fixtures) cast no shadow from the lights; those
    /// of `planar_classes` that lie in an axis-aligned plane get light maps.
    pub fn bake(triangles: &[Triangle], lights: &[[f32; 3]], fixture_class: Option<u16>, planar_classes: &[u16]) -> LightBake {
        let (plane_of, planes, mut samples) = light_planes(triangles, planar_classes);
        let texels = samples.len();
        let corners = vertex_samples(triangles, &plane_of, &mut samples);
        let bvh = Bvh::build(triangles);
        let per_sample: Vec<([f32; 2], Vec<[f32; 2]>)> = samples
            .par_iter()
            .enumerate()
            .map(|(k, v)| {
                let sides = if v.two_sided { 2 } else { 1 };
                let mut ao = [1.0f32; 2];
                let mut transfer = vec![[0.0f32; 2]; lights.len()];
                for s in 0..sides {
                    let side = if s == 0 { v.normal } else { v.normal.map(|c| -c) };
                    let origin: [f32; 3] = std::array::from_fn(|i| v.position[i] + side[i] * OFFSET);
                    let twist = hash_unit(k as u32, s as u32);
                    ao[s] = ambient_occlusion(&bvh, origin, &basis(side), twist, AO_RAYS[s], |t| triangles[t as usize].instance_id == v.instance);
                    for (l, light) in lights.iter().enumerate() {
                        transfer[l][s] =
                            light_transfer(&bvh, origin, side, *light, twist, SHADOW_RAYS[s], |t| Some(triangles[t as usize].class_id) == fixture_class);
                    }
                }
                if !v.two_sided {
                    ao[1] = ao[0];
                    transfer.iter_mut().for_each(|t| t[1] = t[0]);
                }
                (ao, transfer)
            })
            .collect();
        let ao = per_sample.iter().map(|(ao, _)| *ao).collect();
        let transfer = (0..lights.len()).map(|l| per_sample.iter().map(|(_, t)| t[l]).collect()).collect();
        LightBake { corners, plane_of, planes, ao, lights: lights.to_vec(), transfer, texels, combined: Mutex::new(Vec::new()) }
    }

    /// Per triangle, the sample of each corner.
    pub fn corners(&self) -> &[[u32; 3]] {
        &self.corners
    }

    /// The light map of triangle `t`, if it lies in one.
    #[inline(always)]
    pub fn plane_of(&self, t: usize) -> Option<&LightPlane> {
        self.planes.get(self.plane_of[t] as usize)
    }

    /// The index of triangle `t`'s light map, or [`NO_PLANE`].
    #[inline(always)]
    pub fn plane_index(&self, t: usize) -> u32 {
        self.plane_of[t]
    }

    /// Light map `i`.
    #[inline(always)]
    pub fn plane(&self, i: u32) -> &LightPlane {
        &self.planes[i as usize]
    }

    /// Samples baked, of which light-map texels.
    pub fn samples(&self) -> (usize, usize) {
        (self.ao.len(), self.planes.iter().map(|p| p.size[0] * p.size[1]).sum())
    }

    /// Whether a light at `position` was baked.
    pub fn has_light(&self, position: [f32; 3]) -> bool {
        self.lights.contains(&position)
    }

    /// What every sample receives from `lights` (the baked ones among them) and the
    /// ambient term; computed once per light set.
    pub fn sample_light(&self, lights: &[Light]) -> Arc<BakedLight> {
        let mut cache = self.combined.lock().expect("the bake's cache is never poisoned");
        if let Some((_, v)) = cache.iter().find(|(l, _)| l.as_slice() == lights) {
            return v.clone();
        }
        let baked: Vec<(usize, [f32; 3])> = lights.iter().filter_map(|l| self.lights.iter().position(|p| *p == l.position).map(|i| (i, l.color))).collect();
        let combined: Vec<SampleLight> = (0..self.ao.len())
            .map(|v| {
                let mut out = [0.0f32; 8];
                out[0] = AMBIENT * self.ao[v][0];
                out[1] = AMBIENT * self.ao[v][1];
                for &(l, colour) in &baked {
                    let t = self.transfer[l][v];
                    for c in 0..3 {
                        out[2 + c] += colour[c] * t[0];
                        out[5 + c] += colour[c] * t[1];
                    }
                }
                out
            })
            .collect();
        let texels = combined[..self.texels].iter().map(|s| [s[0], s[2], s[3], s[4]]).collect();
        let combined = Arc::new(BakedLight { samples: combined, texels });
        if cache.len() >= 8 {
            cache.remove(0);
        }
        cache.push((lights.to_vec(), combined.clone()));
        combined
    }
}

/// The axis a unit normal lies along (and its sign), when it does within 0.1°.
fn axis_of(n: [f32; 3]) -> Option<(usize, bool)> {
    (0..3).find(|&a| n[a].abs() > 0.999_998).map(|a| (a, n[a] > 0.0))
}

/// The light maps of `world`: triangles of `classes` whose three normals lie along one
/// axis, grouped by plane (axis, side and position to the millimetre); each plane's grid
/// covers its triangles' extent. Returns each triangle's plane, the planes and their
/// texel samples (in plane order, row by row).
fn light_planes(triangles: &[Triangle], classes: &[u16]) -> (Vec<u32>, Vec<LightPlane>, Vec<Sample>) {
    let mut groups: BTreeMap<(usize, bool, i64), Vec<usize>> = BTreeMap::new();
    for (i, t) in triangles.iter().enumerate() {
        if !classes.contains(&t.class_id) {
            continue;
        }
        let axes: Vec<Option<(usize, bool)>> = t.normals.iter().map(|n| axis_of(normalise(*n))).collect();
        let Some((axis, positive)) = axes[0] else { continue };
        if axes.iter().any(|a| *a != Some((axis, positive))) {
            continue;
        }
        let coordinate = t.positions[0][axis];
        if t.positions.iter().any(|p| (p[axis] - coordinate).abs() > 1e-4) {
            continue;
        }
        groups.entry((axis, positive, (coordinate * 1000.0).round() as i64)).or_default().push(i);
    }
    let mut plane_of = vec![NO_PLANE; triangles.len()];
    let (mut planes, mut samples) = (Vec::new(), Vec::new());
    for ((axis, positive, _), members) in groups {
        let axes = [(axis + 1) % 3, (axis + 2) % 3];
        let (mut lo, mut hi) = ([f32::INFINITY; 2], [f32::NEG_INFINITY; 2]);
        for &i in &members {
            for p in &triangles[i].positions {
                for k in 0..2 {
                    lo[k] = lo[k].min(p[axes[k]]);
                    hi[k] = hi[k].max(p[axes[k]]);
                }
            }
        }
        let size = [0, 1].map(|k| (((hi[k] - lo[k]) / TEXEL).ceil() as usize + 1).max(2));
        if size.iter().any(|n| *n > MAX_TEXELS) {
            continue; // too large a plane for a grid: its triangles keep vertex samples
        }
        let origin = lo;
        let (coordinate, instance) = (triangles[members[0]].positions[0][axis], triangles[members[0]].instance_id);
        let mut normal = [0.0; 3];
        normal[axis] = if positive { 1.0 } else { -1.0 };
        let first = samples.len() as u32;
        for j in 0..size[1] {
            for i in 0..size[0] {
                let mut position = [0.0; 3];
                position[axis] = coordinate;
                position[axes[0]] = origin[0] + i as f32 * TEXEL;
                position[axes[1]] = origin[1] + j as f32 * TEXEL;
                samples.push(Sample { position, normal, instance, two_sided: false });
            }
        }
        for &i in &members {
            plane_of[i] = planes.len() as u32;
        }
        planes.push(LightPlane { axes, origin, size, first });
    }
    (plane_of, planes, samples)
}

/// Samples for the distinct vertices (position, normal, object) of every triangle not in a
/// light map, appended to `samples`; each triangle's corners as sample indices.
fn vertex_samples(triangles: &[Triangle], plane_of: &[u32], samples: &mut Vec<Sample>) -> Vec<[u32; 3]> {
    let mut index: HashMap<([u32; 3], [u32; 3], u16), u32> = HashMap::new();
    triangles
        .iter()
        .zip(plane_of)
        .map(|(t, &plane)| {
            if plane != NO_PLANE {
                return [0; 3];
            }
            std::array::from_fn(|c| {
                let normal = normalise(t.normals[c]);
                let key = (t.positions[c].map(f32::to_bits), normal.map(f32::to_bits), t.instance_id);
                *index.entry(key).or_insert_with(|| {
                    samples.push(Sample { position: t.positions[c], normal, instance: t.instance_id, two_sided: true });
                    (samples.len() - 1) as u32
                })
            })
        })
        .collect()
}

/// Two unit vectors that make an orthonormal frame with `n`.
fn basis(n: [f32; 3]) -> [[f32; 3]; 3] {
    let a = if n[0].abs() < 0.9 { [1.0, 0.0, 0.0] } else { [0.0, 1.0, 0.0] };
    let t = normalise(cross(a, n));
    let b = cross(n, t);
    [t, b, n]
}

fn cross(a: [f32; 3], b: [f32; 3]) -> [f32; 3] {
    [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]
}

fn normalise(v: [f32; 3]) -> [f32; 3] {
    let len = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
    if len > 1e-12 { v.map(|c| c / len) } else { [0.0, 1.0, 0.0] }
}

/// A number in [0, 1) from two integers: each sample side turns its ray pattern by its own
/// angle, so neighbouring samples do not band.
fn hash_unit(a: u32, b: u32) -> f32 {
    let mut h = a.wrapping_mul(0x9E37_79B1) ^ b.wrapping_mul(0x85EB_CA77);
    h ^= h >> 15;
    h = h.wrapping_mul(0x2C1B_3C6D);
    h ^= h >> 12;
    (h >> 8) as f32 / (1u32 << 24) as f32
}

/// The ambient light a side receives: 1 minus the (distance-weighted) share of `rays`
/// cosine-distributed rays that other objects stop within [`AO_RADIUS`].
fn ambient_occlusion(bvh: &Bvh, origin: [f32; 3], frame: &[[f32; 3]; 3], twist: f32, rays: usize, passes: impl Fn(u32) -> bool + Copy) -> f32 {
    let strata = (rays as f32).sqrt() as usize;
    let mut occlusion = 0.0;
    for i in 0..strata {
        for j in 0..strata {
            // Stratified cosine-weighted directions, the pattern turned by `twist`.
            let u = (i as f32 + 0.5) / strata as f32;
            let phi = std::f32::consts::TAU * ((j as f32 + 0.5) / strata as f32 + twist);
            let r = u.sqrt();
            let (x, y, z) = (r * phi.cos(), r * phi.sin(), (1.0 - u).sqrt());
            let dir: [f32; 3] = std::array::from_fn(|k| frame[0][k] * x + frame[1][k] * y + frame[2][k] * z);
            if let Some(t) = bvh.nearest(&Ray { origin, dir, far: AO_RADIUS }, passes) {
                let near = 1.0 - t / AO_RADIUS;
                occlusion += near * near;
            }
        }
    }
    1.0 - AO_STRENGTH * occlusion / (strata * strata) as f32
}

/// The share of a light at `light` a side with normal `n` at `origin` receives: the cosine
/// over Habitat's attenuation, times the share of `rays` rays to points around the light
/// that nothing (but what `passes`) stops.
fn light_transfer(bvh: &Bvh, origin: [f32; 3], n: [f32; 3], light: [f32; 3], twist: f32, rays: usize, passes: impl Fn(u32) -> bool + Copy) -> f32 {
    let d: [f32; 3] = std::array::from_fn(|k| light[k] - origin[k]);
    let d2 = d[0] * d[0] + d[1] * d[1] + d[2] * d[2];
    let dist = d2.sqrt().max(1e-6);
    let cos = (n[0] * d[0] + n[1] * d[1] + n[2] * d[2]) / dist;
    if cos <= 0.0 {
        return 0.0;
    }
    let unshadowed = cos / (1.0 + d2);
    if unshadowed < NEGLIGIBLE {
        return unshadowed;
    }
    let frame = basis(d.map(|c| c / dist));
    let mut open = 0;
    for k in 0..rays {
        let a = std::f32::consts::TAU * ((k as f32 + 0.5) / rays as f32 + twist);
        let r = LIGHT_RADIUS * if k % 2 == 0 { 0.5 } else { 0.9 };
        let target: [f32; 3] = std::array::from_fn(|i| light[i] + frame[0][i] * r * a.cos() + frame[1][i] * r * a.sin());
        let to: [f32; 3] = std::array::from_fn(|i| target[i] - origin[i]);
        let len = (to[0] * to[0] + to[1] * to[1] + to[2] * to[2]).sqrt();
        if !bvh.occluded(&Ray { origin, dir: to.map(|c| c / len), far: len - 0.01 }, passes) {
            open += 1;
        }
    }
    unshadowed * open as f32 / rays as f32
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::render::surface::Triangle;

    fn square(id: u16, y: f32, lo: [f32; 2], hi: [f32; 2]) -> Vec<Triangle> {
        let t = |p: [[f32; 3]; 3]| Triangle { positions: p, normals: [[0.0, 1.0, 0.0]; 3], uvs: [[0.0; 2]; 3], surface: 0, class_id: id, instance_id: id };
        vec![t([[lo[0], y, lo[1]], [hi[0], y, lo[1]], [hi[0], y, hi[1]]]), t([[lo[0], y, lo[1]], [hi[0], y, hi[1]], [lo[0], y, hi[1]]])]
    }

    /// A 4 × 4 m floor of two triangles, a 1 m coffee-table top at 0.25 m over its middle,
    /// baked for a light 2.4 m above the centre.
    fn room(planar: &[u16]) -> (Vec<Triangle>, LightBake, Arc<BakedLight>) {
        let mut triangles = square(1, 0.0, [-2.0, -2.0], [2.0, 2.0]);
        triangles.extend(square(2, 0.25, [-0.5, -0.5], [0.5, 0.5]));
        let light = [0.0, 2.4, 0.0];
        let bake = LightBake::bake(&triangles, &[light], None, planar);
        let lit = bake.sample_light(&[Light { position: light, color: [1.0; 3], attached_to_camera: false }]);
        (triangles, bake, lit)
    }

    #[test]
    fn a_low_table_shades_the_floor_under_it_and_darkens_its_ambient_in_the_floors_light_map() {
        let (_, bake, lit) = room(&[1]);
        let floor = bake.plane_of(0).expect("the floor has a light map");
        assert!(bake.plane_of(2).is_none(), "the table top is baked at its vertices");
        let under = floor.sample(&lit.texels, [0.0, 0.0, 0.0]);
        let open = floor.sample(&lit.texels, [-1.8, 0.0, -1.8]);
        let edge = floor.sample(&lit.texels, [0.6, 0.0, 0.0]);
        assert_eq!(under[1..], [0.0; 3], "the table top hides the light from the floor under it");
        assert!(open[1] > 0.05, "the open floor is lit: {open:?}");
        assert!(edge[1] > 0.0, "beside the table, light again: {edge:?}");
        assert!(under[0] < 0.95 * AMBIENT, "under the table the ambient light is occluded: {under:?}");
        assert!((open[0] - AMBIENT).abs() < 1e-6, "nothing near the open floor: {open:?}");
        let (samples, texels) = bake.samples();
        assert_eq!(texels, 101 * 101, "4 cm texels over 4 m");
        assert_eq!(samples, texels + 4, "and the table top's four vertices");
    }

    #[test]
    fn without_a_light_map_the_floors_vertices_hold_its_light() {
        let (_, bake, lit) = room(&[]);
        assert!(bake.plane_of(0).is_none());
        let corner = lit.samples[bake.corners()[0][0] as usize];
        assert!(corner[2] > 0.0 && corner[5] == 0.0, "a floor corner is lit from above, not below: {corner:?}");
    }
}
