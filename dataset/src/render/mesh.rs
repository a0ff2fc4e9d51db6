//! The renderable world: triangles in Habitat world coordinates (y up) with a
//! material and a semantic class each, loaded from a converted Habitat-style scene.

use std::path::Path;

use nalgebra::{Matrix4, Point3, Quaternion, UnitQuaternion, Vector3};
use osmab_evaluator::{InputError, Result};
use serde_json::Value;

use std::sync::Arc;

use super::light_bake::LightBake;
pub use super::surface::{MipMaps, Surface, Triangle};
use crate::convert::gltf::{Texture, read_gltf};

/// Everything a camera can see: triangles, their surfaces, and runs of one object's
/// consecutive triangles with their bounding boxes, which the renderer tests against the
/// view before transforming any triangle of a run. The geometry is shared: a clone (the
/// same scene to be lit another way) costs no copy of it.
#[derive(Debug, Clone, Default)]
pub struct World {
    triangles: Arc<[Triangle]>,
    surfaces: Arc<[Surface]>,
    clusters: Arc<[Cluster]>,
    /// Each triangle's vertex positions again, packed: all that transforming a triangle
    /// reads, in a third of the memory `triangles` takes.
    positions: Arc<[[[f32; 3]; 3]]>,
    /// Ambient occlusion and the static lights' shadows, once baked ([`World::with_light_bake`]).
    light_bake: Option<Arc<LightBake>>,
}

/// Triangles of objects longer than this along any edge are split (metres) when a scene is
/// loaded, so the light baked into their vertices resolves a vase's shadow on a table top
/// (the room's floor, walls and ceiling get light maps instead: [`SHELL_SURFACES`]).
pub const MAX_EDGE: f32 = 0.25;
/// The classes of the room's large flat surfaces, which are lit from light maps.
pub const SHELL_SURFACES: [&str; 3] = ["floor", "wall", "ceiling"];

/// Triangles a cluster holds at most: a piece of an object small enough for its box to
/// leave the view when the object is half out of it.
const CLUSTER_TRIANGLES: usize = 64;

/// Consecutive triangles of one object instance, and the box that holds them.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Cluster {
    pub(crate) triangles: std::ops::Range<usize>,
    pub(crate) min: [f32; 3],
    pub(crate) max: [f32; 3],
}

/// Runs of at most `size` consecutive triangles of one instance, with their boxes.
fn clusters(triangles: &[Triangle], size: usize) -> Vec<Cluster> {
    let mut clusters = Vec::with_capacity(triangles.len() / size + 1);
    let mut start = 0;
    while start < triangles.len() {
        let instance = triangles[start].instance_id;
        let run = triangles[start..].iter().take(size).take_while(|t| t.instance_id == instance).count();
        let (mut min, mut max) = ([f32::INFINITY; 3], [f32::NEG_INFINITY; 3]);
        for p in triangles[start..start + run].iter().flat_map(|t| &t.positions) {
            for k in 0..3 {
                min[k] = min[k].min(p[k]);
                max[k] = max[k].max(p[k]);
            }
        }
        clusters.push(Cluster { triangles: start..start + run, min, max });
        start += run;
    }
    clusters
}

fn floats(v: &Value, n: usize) -> Option<Vec<f64>> {
    v.as_array().filter(|a| a.len() == n).and_then(|a| a.iter().map(Value::as_f64).collect())
}

impl World {
    pub fn new(triangles: Vec<Triangle>, surfaces: Vec<Surface>) -> World {
        World::with_cluster_size(triangles, surfaces, CLUSTER_TRIANGLES)
    }

    /// A world whose clusters hold at most `size` triangles (`new` chooses the size).
    pub(crate) fn with_cluster_size(triangles: Vec<Triangle>, surfaces: Vec<Surface>, size: usize) -> World {
        let clusters = clusters(&triangles, size.max(1));
        let positions = triangles.iter().map(|t| t.positions).collect();
        World { triangles: triangles.into(), surfaces: surfaces.into(), clusters: clusters.into(), positions, light_bake: None }
    }

    /// This world with its light baked for the static lights at `lights`: triangles of
    /// `fixture_class` cast no shadows (the ceiling's light fixtures), those of
    /// `planar_classes` (floor, walls, ceiling) get light maps.
    pub fn with_light_bake(mut self, lights: &[[f32; 3]], fixture_class: Option<u16>, planar_classes: &[u16]) -> World {
        self.light_bake = Some(Arc::new(LightBake::bake(&self.triangles, lights, fixture_class, planar_classes)));
        self
    }

    /// Its baked light, if baked.
    pub fn light_bake(&self) -> Option<&LightBake> {
        self.light_bake.as_deref()
    }

    pub fn triangles(&self) -> &[Triangle] {
        &self.triangles
    }

    pub fn surfaces(&self) -> &[Surface] {
        &self.surfaces
    }

    pub(crate) fn clusters(&self) -> &[Cluster] {
        &self.clusters
    }

    /// `triangles()[i].positions` at `i`.
    pub(crate) fn positions(&self) -> &[[[f32; 3]; 3]] {
        &self.positions
    }

    /// Load the converted scene in `dir` (written by `convert::habitat`), with the class
    /// of every object from its template's `user_defined.class_id`.
    pub fn load_habitat_scene(dir: &Path, scene: &str) -> Result<World> {
        let instance_path = dir.join("scenes").join(format!("{scene}.scene_instance.json"));
        let text = std::fs::read(&instance_path).map_err(|e| InputError::io(&instance_path, &e))?;
        let instance: Value = serde_json::from_slice(&text).map_err(|e| InputError::new(&instance_path, "(json)", e.to_string()))?;
        let mut builder = WorldBuilder::default();
        for (i, object) in instance["object_instances"].as_array().into_iter().flatten().enumerate() {
            let field = format!("object_instances[{i}]");
            let handle = object["template_name"].as_str().ok_or_else(|| InputError::new(&instance_path, &field, "missing template_name"))?;
            let template_path = dir.join("objects").join(format!("{handle}.object_config.json"));
            let template: Value = serde_json::from_slice(&std::fs::read(&template_path).map_err(|e| InputError::io(&template_path, &e))?)
                .map_err(|e| InputError::new(&template_path, "(json)", e.to_string()))?;
            let asset = dir.join("objects").join(template["render_asset"].as_str().ok_or_else(|| InputError::new(&template_path, "render_asset", "missing"))?);
            let ids = ObjectIds {
                class_id: template["user_defined"]["class_id"].as_u64().unwrap_or(0).min(u16::MAX as u64) as u16,
                instance_id: template["semantic_id"].as_u64().unwrap_or(0).min(u16::MAX as u64) as u16,
            };
            let placement = Placement::of(object);
            let ext = asset.extension().and_then(|e| e.to_str()).unwrap_or("").to_lowercase();
            if ext == "obj" {
                builder.add_obj(&asset, &placement, ids)?;
            } else {
                builder.add_gltf(&asset, &placement, ids)?;
            }
        }
        let surfaces = shell_surface_ids();
        let (planar, objects): (Vec<Triangle>, Vec<Triangle>) = builder.triangles.into_iter().partition(|t| surfaces.contains(&t.class_id));
        let mut triangles = planar;
        triangles.extend(subdivide(objects, MAX_EDGE));
        Ok(World::new(triangles, builder.surfaces))
    }
}

/// The class ids of [`SHELL_SURFACES`].
pub fn shell_surface_ids() -> Vec<u16> {
    SHELL_SURFACES.iter().filter_map(|c| crate::convert::lexicon::class_id(c)).map(|id| id as u16).collect()
}

/// `triangles` with each one longer than `max_edge` split, its longest edge halved again and
/// again until no edge is longer (positions, normals and texture coordinates interpolated):
/// the same surfaces, in pieces small enough for light baked into vertices, without a
/// thin strip (a wall box's top) becoming thousands of slivers. Two triangles sharing an edge
/// halve it at the same point; where a T-junction remains, the rasteriser's coverage
/// tolerance closes the seam.
pub fn subdivide(triangles: Vec<Triangle>, max_edge: f32) -> Vec<Triangle> {
    let length2 = |a: [f32; 3], b: [f32; 3]| (a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2) + (a[2] - b[2]).powi(2);
    let limit = max_edge * max_edge;
    let mut out = Vec::with_capacity(triangles.len());
    let mut stack = Vec::new();
    for t in triangles {
        stack.push(t);
        while let Some(t) = stack.pop() {
            let p = t.positions;
            let edges = [length2(p[0], p[1]), length2(p[1], p[2]), length2(p[2], p[0])];
            let longest = (0..3).max_by(|&a, &b| edges[a].total_cmp(&edges[b]).then(b.cmp(&a))).expect("three edges");
            if !(edges[longest] > limit) || !edges[longest].is_finite() {
                out.push(t);
                continue;
            }
            // Halve edge (i, j) at m: (i, m, k) and (m, j, k), k the third, keep the winding.
            let (i, j) = (longest, (longest + 1) % 3);
            let mid3 = |v: [[f32; 3]; 3]| std::array::from_fn::<f32, 3, _>(|c| (v[i][c] + v[j][c]) / 2.0);
            let mid2 = |v: [[f32; 2]; 3]| std::array::from_fn::<f32, 2, _>(|c| (v[i][c] + v[j][c]) / 2.0);
            let (mp, mn, mu) = (mid3(t.positions), mid3(t.normals), mid2(t.uvs));
            let mut first = t;
            first.positions[j] = mp;
            first.normals[j] = mn;
            first.uvs[j] = mu;
            let mut second = t;
            second.positions[i] = mp;
            second.normals[i] = mn;
            second.uvs[i] = mu;
            // The second is drawn after the first.
            stack.push(second);
            stack.push(first);
        }
    }
    out
}

/// The class and instance of an object's triangles.
#[derive(Clone, Copy)]
struct ObjectIds {
    class_id: u16,
    instance_id: u16,
}

/// Where an object instance is: its transform from its asset's frame into the world, and
/// the matrix that turns its normals.
struct Placement {
    transform: Matrix4<f64>,
    normal_matrix: nalgebra::Matrix3<f64>,
}

impl Placement {
    /// The placement of an `object_instances` entry: translation, rotation (w, x, y, z) and
    /// non-uniform scale, each the identity when missing.
    fn of(object: &Value) -> Placement {
        let (t, q, s) = (
            floats(&object["translation"], 3).unwrap_or(vec![0.0; 3]),
            floats(&object["rotation"], 4).unwrap_or(vec![1.0, 0.0, 0.0, 0.0]),
            floats(&object["non_uniform_scale"], 3).unwrap_or(vec![1.0; 3]),
        );
        let rotation = UnitQuaternion::from_quaternion(Quaternion::new(q[0], q[1], q[2], q[3]));
        let transform = Matrix4::new_translation(&Vector3::new(t[0], t[1], t[2]))
            * rotation.to_homogeneous()
            * Matrix4::new_nonuniform_scaling(&Vector3::new(s[0], s[1], s[2]));
        let normal_matrix = transform.fixed_view::<3, 3>(0, 0).try_inverse().map(|m| m.transpose()).unwrap_or_else(nalgebra::Matrix3::identity);
        Placement { transform, normal_matrix }
    }

    /// A point of the asset, in the world.
    fn place(&self, p: [f32; 3]) -> [f32; 3] {
        let w = self.transform.transform_point(&Point3::new(p[0] as f64, p[1] as f64, p[2] as f64));
        [w.x as f32, w.y as f32, w.z as f32]
    }

    /// A normal of the asset, in the world (unit length).
    fn turn(&self, n: [f32; 3]) -> [f32; 3] {
        let w = (self.normal_matrix * Vector3::new(n[0] as f64, n[1] as f64, n[2] as f64)).normalize();
        [w.x as f32, w.y as f32, w.z as f32]
    }
}

/// `texture` with `occlusion`'s red channel (at the nearest of its texels, which may be
/// fewer) in its alpha: one fetch gives a pixel both.
fn occlusion_in_alpha(texture: &Texture, occlusion: &Texture) -> Texture {
    let (w, h) = (texture.width as usize, texture.height as usize);
    let (ow, oh) = (occlusion.width as usize, occlusion.height as usize);
    let mut rgba = texture.rgba.clone();
    for y in 0..h {
        let oy = (y * oh / h).min(oh - 1);
        for x in 0..w {
            let ox = (x * ow / w).min(ow - 1);
            rgba[4 * (y * w + x) + 3] = occlusion.rgba[4 * (oy * ow + ox)];
        }
    }
    Texture { width: texture.width, height: texture.height, rgba }
}

/// A world's triangles and surfaces as its objects are added, with the textures loaded so far.
#[derive(Default)]
struct WorldBuilder {
    triangles: Vec<Triangle>,
    surfaces: Vec<Surface>,
    texture_cache: Vec<(String, Option<std::sync::Arc<MipMaps>>)>,
}

impl WorldBuilder {
    /// `texture` shared under `key`: loaded once per asset and material.
    fn cached(&mut self, key: String, texture: &Option<Texture>) -> Option<Arc<MipMaps>> {
        if let Some((_, t)) = self.texture_cache.iter().find(|(k, _)| *k == key) {
            return t.clone();
        }
        let t = texture.clone().map(|t| Arc::new(MipMaps::of(t)));
        self.texture_cache.push((key, t.clone()));
        t
    }

    /// An OBJ asset's materials and triangles, with flat faces: the face normal, so boxes
    /// keep sharp edges.
    fn add_obj(&mut self, asset: &Path, placement: &Placement, ids: ObjectIds) -> Result<()> {
        let obj = super::obj::read_obj(asset)?;
        let base = self.surfaces.len() as u32;
        for m in &obj.materials {
            self.surfaces.push(Surface { color: m.color, texture: m.texture.clone().map(|t| Arc::new(MipMaps::of(t))), occlusion_in_alpha: false });
        }
        for (corners, material) in &obj.triangles {
            let p = corners.map(|(k, _)| placement.place(obj.positions[k as usize]));
            let e1 = Vector3::new(p[1][0] - p[0][0], p[1][1] - p[0][1], p[1][2] - p[0][2]);
            let e2 = Vector3::new(p[2][0] - p[0][0], p[2][1] - p[0][1], p[2][2] - p[0][2]);
            let n = e1.cross(&e2);
            let n = if n.norm() > 0.0 { n.normalize() } else { Vector3::y() };
            let uvs = corners.map(|(_, t)| t.map_or([0.0; 2], |t| obj.uvs[t as usize]));
            let (class_id, instance_id) = (ids.class_id, ids.instance_id);
            self.triangles.push(Triangle { positions: p, normals: [[n.x, n.y, n.z]; 3], uvs, surface: base + *material as u32, class_id, instance_id });
        }
        Ok(())
    }

    /// A glTF asset's materials (each texture loaded once per asset and material), a grey
    /// fallback surface, and its triangles with their interpolated normals.
    fn add_gltf(&mut self, asset: &Path, placement: &Placement, ids: ObjectIds) -> Result<()> {
        let gltf = read_gltf(asset)?;
        let base = self.surfaces.len() as u32;
        for (m, material) in gltf.materials.iter().enumerate() {
            let with_occlusion = material.texture.as_ref().zip(material.occlusion.as_ref()).map(|(t, ao)| occlusion_in_alpha(t, ao));
            let occlusion_in_alpha = with_occlusion.is_some();
            let texture = self.cached(format!("{}#{m}", asset.display()), &with_occlusion.or_else(|| material.texture.clone()));
            let c = material.base_color;
            self.surfaces.push(Surface { color: [c[0], c[1], c[2]], texture, occlusion_in_alpha });
        }
        let fallback = self.surfaces.len() as u32;
        self.surfaces.push(Surface { color: [0.7, 0.7, 0.7], texture: None, occlusion_in_alpha: false });
        for mesh in &gltf.meshes {
            let surface = mesh.material.filter(|&m| m < gltf.materials.len()).map_or(fallback, |m| base + m as u32);
            for tri in mesh.indices.chunks_exact(3) {
                let k = [tri[0] as usize, tri[1] as usize, tri[2] as usize];
                self.triangles.push(Triangle {
                    positions: k.map(|k| placement.place(mesh.positions[k])),
                    normals: k.map(|k| placement.turn(mesh.normals[k])),
                    uvs: k.map(|k| mesh.uvs.as_ref().map_or([0.0; 2], |uv| uv[k])),
                    surface,
                    class_id: ids.class_id,
                    instance_id: ids.instance_id,
                });
            }
        }
        Ok(())
    }
}
