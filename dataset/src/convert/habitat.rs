//! Writing a loaded Drake scene as a Habitat-style scene: dataset, stage, object and
//! scene-instance configs with the frame change of scene-pipeline.md §4.2, copied
//! assets, generated primitive meshes, an instance-level semantic lexicon with class
//! names, a navigable-area map, lighting layouts for the four conditions, and a
//! report of everything that needed attention.
//!
//! One file, over 400 lines, on purpose: every config it writes applies the same frame change
//! and naming, kept in one place so they cannot drift apart.

use std::path::{Path, PathBuf};

use nalgebra::{Point3, UnitQuaternion, Vector3};
use osmab_evaluator::formats::json::write_pretty as write_json;
use osmab_evaluator::{InputError, Result};
use serde::{Deserialize, Serialize};
use serde_json::{Value, json};

use super::gltf::read_gltf;
use super::lexicon::{class_id, classes, normalise_name};
use super::lighting::{habitat_lighting, lighting};
use super::primitives::{box_mesh, cylinder_mesh, mtl, sphere_mesh};
use super::scene::{DrakeScene, PlacedModel};
use super::sdf::{Geometry, Visual};
use super::transform::{Pose, drake_to_habitat, point_to_habitat, wxyz};

/// Settings of the adaptation layer.
#[derive(Debug, Clone, Serialize)]
pub struct ConvertOptions {
    /// Agent radius for the navigable map (OSMa-Bench++: 0.15 m).
    pub agent_radius: f64,
    /// Agent height: obstacles lower than the floor plus this block the way.
    pub agent_height: f64,
    /// Cell size of the navigable map.
    pub cell_size: f64,
    /// Largest room side accepted, in metres (bounds the navigable map and the lights).
    pub max_room_side: f64,
}

impl Default for ConvertOptions {
    fn default() -> Self {
        Self { agent_radius: 0.15, agent_height: 1.5, cell_size: 0.05, max_room_side: 200.0 }
    }
}

/// One object instance of the converted scene.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct ConvertedObject {
    /// Instance semantic id (1, 2, ...), what semantic images hold.
    pub instance_id: i64,
    /// Canonical class and its id in the release lexicon.
    pub class: String,
    pub class_id: i64,
    /// Model instance name in the directives.
    pub model: String,
    /// The free-text name it was classified from.
    pub name: String,
    pub description: String,
    /// World-space bounds in Habitat axes (y up).
    pub bbox_min: [f64; 3],
    pub bbox_max: [f64; 3],
}

impl ConvertedObject {
    /// An object of `class` with instance id `id` spanning `lo`..`hi`, for tests.
    #[cfg(test)]
    pub(crate) fn spanning(id: i64, class: &str, lo: [f64; 3], hi: [f64; 3]) -> Self {
        Self {
            instance_id: id,
            class: class.into(),
            class_id: 0,
            model: String::new(),
            name: String::new(),
            description: String::new(),
            bbox_min: lo,
            bbox_max: hi,
        }
    }
}

/// What the conversion did and what needs attention.
#[derive(Debug, Clone, Default, Serialize, Deserialize)]
pub struct ConversionReport {
    pub scene: String,
    pub objects: Vec<ConvertedObject>,
    /// Names that matched no class (classified as "other"); never silently dropped.
    pub unknown_names: Vec<String>,
    /// Models with no `house_state.json` entry (classified from their instance name).
    pub models_without_metadata: Vec<String>,
    /// Models with nothing to draw (skipped).
    pub models_without_visuals: Vec<String>,
    /// Textures that could not be used; those visuals fall back to the base colour.
    pub texture_fallbacks: Vec<String>,
    /// glTF meshes without normals (generated when rendering).
    pub generated_normals: Vec<String>,
    /// Fraction of the floor the agent can stand on.
    pub navigable_fraction: f64,
}

struct Writer<'a> {
    out: &'a Path,
    options: &'a ConvertOptions,
    scene: &'a DrakeScene,
    report: ConversionReport,
    templates: Vec<(String, Value)>,
    instances: Vec<Value>,
    /// Footprints of obstacles in Habitat (x, z) with their height span.
    obstacles: Vec<([f64; 3], [f64; 3])>,
    floor: Option<([f64; 3], [f64; 3])>,
}

fn copy_file(from: &Path, to: &Path) -> Result<()> {
    if let Some(dir) = to.parent() {
        std::fs::create_dir_all(dir).map_err(|e| InputError::io(dir, &e))?;
    }
    std::fs::copy(from, to).map(|_| ()).map_err(|e| InputError::new(from, "(copy)", format!("cannot copy to {}: {e}", to.display())))
}

/// Habitat bounds of Drake-frame points under `pose`.
fn habitat_bounds(points: impl Iterator<Item = Vector3<f64>>, pose: &Pose) -> ([f64; 3], [f64; 3]) {
    points.fold(([f64::INFINITY; 3], [f64::NEG_INFINITY; 3]), |(lo, hi), p| {
        let h = point_to_habitat(pose.transform_point(&Point3::from(p)).coords);
        (std::array::from_fn(|a| lo[a].min(h[a])), std::array::from_fn(|a| hi[a].max(h[a])))
    })
}

fn corners(lo: [f64; 3], hi: [f64; 3]) -> impl Iterator<Item = Vector3<f64>> {
    (0..8).map(move |i| Vector3::new(if i & 1 == 0 { lo[0] } else { hi[0] }, if i & 2 == 0 { lo[1] } else { hi[1] }, if i & 4 == 0 { lo[2] } else { hi[2] }))
}

impl Writer<'_> {
    /// Class of a model (and of a room-geometry visual by its name).
    fn classify(&mut self, model: &PlacedModel, visual_name: &str) -> (String, String, String) {
        let (name, description) = match &model.info {
            Some(info) => (info.name.clone(), info.description.clone()),
            None if model.model.name == "room_geometry" || model.name.starts_with("room_geometry") => {
                (visual_name.trim_end_matches("_visual").to_string(), String::new())
            }
            None => {
                self.report.models_without_metadata.push(model.name.clone());
                // `<room>_<object>_<n>`: drop the room prefix.
                let stem = model.name.split_once('_').map_or(model.name.as_str(), |(_, rest)| rest);
                (stem.to_string(), String::new())
            }
        };
        // Room geometry visuals are named for what they are (floor_visual, north_wall_visual);
        // only there does "floor" or "wall" in a name decide the class ("Floor Lamp" is a lamp).
        let is_room = model.model.name == "room_geometry" || model.name.starts_with("room_geometry");
        let room_part = ["floor", "wall", "ceiling", "door", "window"].into_iter().find(|p| is_room && name.to_lowercase().contains(p));
        let class = room_part.or_else(|| normalise_name(&name));
        match class {
            Some(c) => (c.to_string(), name, description),
            None => {
                self.report.unknown_names.push(format!("{} ({})", name, model.name));
                ("other".to_string(), name, description)
            }
        }
    }

    /// Add `model` as instances of the scene: one per visual for room geometry (floor, each
    /// wall), else one for the whole model.
    fn add_model(&mut self, model: &PlacedModel) -> Result<()> {
        let room_geometry = model.model.name == "room_geometry";
        let groups: Vec<Vec<usize>> =
            if room_geometry { (0..model.visuals().count()).map(|i| vec![i]).collect() } else { vec![(0..model.visuals().count()).collect()] };
        let visuals: Vec<_> = model.visuals().collect();
        if visuals.is_empty() {
            self.report.models_without_visuals.push(model.name.clone());
            return Ok(());
        }
        for group in groups {
            let first = visuals[group[0]].0;
            let (class, name, description) = self.classify(model, &first.name);
            let instance_id = self.report.objects.len() as i64 + 1;
            let (mut lo, mut hi) = ([f64::INFINITY; 3], [f64::NEG_INFINITY; 3]);
            for &v in &group {
                let (visual, world) = visuals[v];
                let asset = match &visual.geometry {
                    Geometry::Mesh { path, scale } => self.mesh_asset(model, visual, &world, path, scale)?,
                    _ => self.primitive_asset(model, visual, &world, &class)?,
                };
                let (vlo, vhi) = habitat_bounds(corners(asset.local_bounds.0, asset.local_bounds.1), &world);
                for a in 0..3 {
                    lo[a] = lo[a].min(vlo[a]);
                    hi[a] = hi[a].max(vhi[a]);
                }
                self.add_footprint(model, visual, &class, (vlo, vhi))?;
                self.add_instance(model, visual, &world, &class, instance_id, asset);
            }
            self.report.objects.push(ConvertedObject {
                instance_id,
                class_id: class_id(&class).unwrap_or(0),
                class,
                model: model.name.clone(),
                name,
                description,
                bbox_min: lo,
                bbox_max: hi,
            });
        }
        Ok(())
    }

    /// A visual's mesh file (glTF or OBJ) copied into the scene's assets, with the texture
    /// fallbacks and generated normals it needed noted in the report.
    fn mesh_asset(&mut self, model: &PlacedModel, visual: &Visual, world: &Pose, path: &Path, scale: &[f64; 3]) -> Result<VisualAsset> {
        let q_c = UnitQuaternion::from_rotation_matrix(&drake_to_habitat());
        let ext = path.extension().and_then(|e| e.to_str()).unwrap_or("").to_lowercase();
        // One folder per visual: SceneSmith names every wall `wall.gltf`.
        let target = PathBuf::from("assets").join(&model.name).join(&visual.name).join(path.file_name().expect("a mesh file"));
        let relative = path.strip_prefix(&self.scene.root).unwrap_or(path).display().to_string();
        match ext.as_str() {
            "gltf" | "glb" => {
                let asset = read_gltf(path)?;
                let broken: Vec<usize> = asset.materials.iter().enumerate().filter(|(_, m)| m.texture_problem.is_some()).map(|(i, _)| i).collect();
                copy_mesh(path, &self.out.join(&target), &ext, &broken)?;
                if asset.generated_normals {
                    self.report.generated_normals.push(relative.clone());
                }
                for m in &asset.materials {
                    if let Some(problem) = &m.texture_problem {
                        let problem = problem.replace(&format!("{}/", self.scene.root.display()), "");
                        self.report.texture_fallbacks.push(format!("{relative}: material '{}': {problem}", m.name));
                    }
                }
                let textured = asset.materials.iter().any(|m| m.texture.is_some());
                // Drake turns glTF (Y-up) into Z-up by Rx(+90°): p_D = S·Rx90·p_gltf.
                let (glo, ghi) = asset.bounds().unwrap_or(([0.0; 3], [0.0; 3]));
                let lo_d = [glo[0] as f64 * scale[0], -(ghi[2] as f64) * scale[1], glo[1] as f64 * scale[2]];
                let hi_d = [ghi[0] as f64 * scale[0], -(glo[2] as f64) * scale[1], ghi[1] as f64 * scale[2]];
                Ok(VisualAsset {
                    render_asset: target,
                    rotation: q_c * world.rotation * q_c.inverse(),
                    scale: [scale[0], scale[2], scale[1]],
                    local_bounds: (lo_d, hi_d),
                    textured,
                })
            }
            "obj" => {
                let bounds = obj_bounds(path)?;
                copy_mesh(path, &self.out.join(&target), &ext, &[])?;
                let lo_d = std::array::from_fn(|a| bounds.0[a] * scale[a]);
                let hi_d = std::array::from_fn(|a| bounds.1[a] * scale[a]);
                Ok(VisualAsset { render_asset: target, rotation: q_c * world.rotation, scale: *scale, local_bounds: (lo_d, hi_d), textured: false })
            }
            other => Err(InputError::new(path, "(mesh)", format!("unsupported mesh format '.{other}' (expected .gltf, .glb or .obj)"))),
        }
    }

    /// A visual's primitive (box, cylinder, sphere) written as an OBJ mesh with its colour.
    fn primitive_asset(&self, model: &PlacedModel, visual: &Visual, world: &Pose, class: &str) -> Result<VisualAsset> {
        let q_c = UnitQuaternion::from_rotation_matrix(&drake_to_habitat());
        let mesh = match &visual.geometry {
            Geometry::Box { size } => box_mesh(*size),
            Geometry::Cylinder { radius, length } => cylinder_mesh(*radius, *length, 32),
            Geometry::Sphere { radius } => sphere_mesh(*radius, 16, 32),
            Geometry::Mesh { .. } => unreachable!("meshes are not primitives"),
        };
        let stem = format!("{}__{}", model.name, visual.name);
        let target = PathBuf::from("assets/primitives").join(format!("{stem}.obj"));
        let rgb = visual.diffuse.map(|d| [d[0], d[1], d[2]]).unwrap_or(default_colour(class));
        let dir = self.out.join("assets/primitives");
        std::fs::create_dir_all(&dir).map_err(|e| InputError::io(&dir, &e))?;
        std::fs::write(dir.join(format!("{stem}.mtl")), mtl(&stem, rgb)).map_err(|e| InputError::io(&dir, &e))?;
        std::fs::write(self.out.join(&target), mesh.to_obj(&format!("{stem}.mtl"), &stem)).map_err(|e| InputError::io(&dir, &e))?;
        Ok(VisualAsset { render_asset: target, rotation: q_c * world.rotation, scale: [1.0; 3], local_bounds: mesh.bounds(), textured: false })
    }

    /// Refuse a visual larger than a room; otherwise a floor visual widens the floor, and any
    /// other (but the ceiling) is an obstacle.
    fn add_footprint(&mut self, model: &PlacedModel, visual: &Visual, class: &str, (vlo, vhi): ([f64; 3], [f64; 3])) -> Result<()> {
        let is_floor = class == "floor";
        if (0..3).any(|a| vhi[a] - vlo[a] > self.options.max_room_side) {
            return Err(InputError::new(&model.file, &visual.name, format!("the visual spans more than {} m", self.options.max_room_side)));
        }
        if is_floor {
            self.floor = Some(match self.floor {
                Some((flo, fhi)) => (std::array::from_fn(|a| flo[a].min(vlo[a])), std::array::from_fn(|a| fhi[a].max(vhi[a]))),
                None => (vlo, vhi),
            });
        } else if class != "ceiling" && !lies_flat_on_the_floor((vlo, vhi)) {
            self.obstacles.push((vlo, vhi));
        }
        Ok(())
    }

    /// The visual's object template and its placed instance in the scene.
    fn add_instance(&mut self, model: &PlacedModel, visual: &Visual, world: &Pose, class: &str, instance_id: i64, asset: VisualAsset) {
        let handle = format!("{}__{}__{}", self.scene.name, model.name, visual.name);
        let template = json!({
            "render_asset": format!("../{}", asset.render_asset.display()),
            "up": [0.0, 1.0, 0.0],
            "front": [0.0, 0.0, -1.0],
            "semantic_id": instance_id,
            "shader_type": if asset.textured { "material" } else { "phong" },
            "is_collidable": true,
            "units_to_meters": 1.0,
            "user_defined": {"class": class, "class_id": class_id(class).unwrap_or(0), "model": model.name, "visual": visual.name},
        });
        self.templates.push((handle.clone(), template));
        let translation = point_to_habitat(world.translation.vector);
        let q = wxyz(&asset.rotation);
        self.instances.push(json!({
            "template_name": handle,
            "translation": translation,
            "rotation": q,
            "non_uniform_scale": asset.scale,
            "motion_type": "STATIC",
            "translation_origin": "asset_local",
        }));
    }
}

/// A visual's render asset as placed in the scene: where it is, how it is turned and
/// scaled, its bounds in its own frame, whether it is textured.
struct VisualAsset {
    render_asset: PathBuf,
    rotation: UnitQuaternion<f64>,
    scale: [f64; 3],
    local_bounds: ([f64; 3], [f64; 3]),
    textured: bool,
}

/// Whether a visual's box (Habitat axes, y up) lies flat on the floor — a rug, a mat: walked
/// over, not around.
fn lies_flat_on_the_floor((lo, hi): ([f64; 3], [f64; 3])) -> bool {
    hi[1] - lo[1] < 0.05 && lo[1] < 0.02
}

fn default_colour(class: &str) -> [f64; 3] {
    match class {
        "floor" => [0.55, 0.45, 0.35],
        "wall" => [0.85, 0.84, 0.80],
        "ceiling" => [0.95, 0.95, 0.95],
        _ => [0.6, 0.6, 0.6],
    }
}

/// Copy a (parsed, valid) mesh and the files it references (glTF buffers and images,
/// OBJ materials). Materials listed in `broken_textures` lose their base-colour
/// texture in the copy, so every renderer falls back to the base colour.
fn copy_mesh(from: &Path, to: &Path, ext: &str, broken_textures: &[usize]) -> Result<()> {
    let dir = from.parent().unwrap_or(Path::new("."));
    let out_dir = to.parent().expect("a file has a folder");
    let mut referenced: Vec<String> = Vec::new();
    if ext == "gltf" {
        let mut json: Value =
            serde_json::from_slice(&std::fs::read(from).map_err(|e| InputError::io(from, &e))?).map_err(|e| InputError::new(from, "(json)", e.to_string()))?;
        for key in ["buffers", "images"] {
            referenced.extend(
                json[key].as_array().into_iter().flatten().filter_map(|b| b["uri"].as_str()).filter(|u| !u.starts_with("data:")).map(|u| u.replace("%20", " ")),
            );
        }
        for &m in broken_textures {
            if let Some(pbr) = json["materials"][m]["pbrMetallicRoughness"].as_object_mut() {
                pbr.remove("baseColorTexture");
            }
        }
        if let Some(dir) = to.parent() {
            std::fs::create_dir_all(dir).map_err(|e| InputError::io(dir, &e))?;
        }
        std::fs::write(to, serde_json::to_string(&json).expect("serialisable")).map_err(|e| InputError::io(to, &e))?;
    } else {
        copy_file(from, to)?;
    }
    if ext == "obj" {
        let text = std::fs::read_to_string(from).map_err(|e| InputError::io(from, &e))?;
        for line in text.lines() {
            if let Some(m) = line.strip_prefix("mtllib ") {
                let mtl = m.trim().to_string();
                if let Ok(mtl_text) = std::fs::read_to_string(dir.join(&mtl)) {
                    referenced.extend(
                        mtl_text
                            .lines()
                            .filter_map(|l| l.trim().strip_prefix("map_Kd ").or_else(|| l.trim().strip_prefix("map_Ka ")))
                            .map(|t| t.trim().to_string()),
                    );
                }
                referenced.push(mtl);
            }
        }
    }
    for rel in referenced {
        let source = super::sdf::normalize(&dir.join(&rel));
        if !source.starts_with(super::sdf::normalize(dir)) {
            return Err(InputError::new(from, "(uri)", format!("'{rel}' points outside the asset's folder")));
        }
        if !source.is_file() {
            // A broken texture was reported (and dropped) already; anything else is needed.
            if ext == "gltf" && !broken_textures.is_empty() && !rel.ends_with(".bin") {
                continue;
            }
            return Err(InputError::new(from, "(uri)", format!("references '{rel}', which does not exist")));
        }
        copy_file(&source, &out_dir.join(&rel))?;
    }
    Ok(())
}

/// Bounds of an OBJ's vertices.
fn obj_bounds(path: &Path) -> Result<([f64; 3], [f64; 3])> {
    let text = std::fs::read_to_string(path).map_err(|e| InputError::io(path, &e))?;
    let mut b = ([f64::INFINITY; 3], [f64::NEG_INFINITY; 3]);
    for (i, line) in text.lines().enumerate() {
        if let Some(rest) = line.strip_prefix("v ") {
            let v: Vec<f64> = rest.split_whitespace().take(3).filter_map(|w| w.parse().ok()).collect();
            if v.len() != 3 || v.iter().any(|x| !x.is_finite()) {
                return Err(InputError::new(path, format!("line {}", i + 1), "a vertex needs 3 finite numbers"));
            }
            for a in 0..3 {
                b.0[a] = b.0[a].min(v[a]);
                b.1[a] = b.1[a].max(v[a]);
            }
        }
    }
    if b.0[0].is_infinite() {
        return Err(InputError::new(path, "v", "the OBJ has no vertices"));
    }
    Ok(b)
}

/// The navigable-area map: floor cells not covered by an obstacle dilated by the agent radius.
fn navigable_map(floor: ([f64; 3], [f64; 3]), obstacles: &[([f64; 3], [f64; 3])], options: &ConvertOptions) -> (usize, usize, Vec<u8>) {
    let (lo, hi) = floor;
    let width = (((hi[0] - lo[0]) / options.cell_size).ceil() as usize).max(1);
    let height = (((hi[2] - lo[2]) / options.cell_size).ceil() as usize).max(1);
    let floor_top = hi[1];
    let mut cells = vec![255u8; width * height];
    for (olo, ohi) in obstacles {
        // Only what the agent's body meets: above the floor, below its height.
        if ohi[1] <= floor_top + 0.02 || olo[1] >= floor_top + options.agent_height {
            continue;
        }
        let r = options.agent_radius;
        let (x0, x1) = (((olo[0] - r - lo[0]) / options.cell_size).floor(), ((ohi[0] + r - lo[0]) / options.cell_size).ceil());
        let (z0, z1) = (((olo[2] - r - lo[2]) / options.cell_size).floor(), ((ohi[2] + r - lo[2]) / options.cell_size).ceil());
        for z in (z0.max(0.0) as usize)..(z1.max(0.0) as usize).min(height) {
            for x in (x0.max(0.0) as usize)..(x1.max(0.0) as usize).min(width) {
                cells[z * width + x] = 0;
            }
        }
    }
    (width, height, cells)
}

fn write_png8(path: &Path, width: usize, height: usize, data: &[u8]) -> Result<()> {
    let file = std::fs::File::create(path).map_err(|e| InputError::io(path, &e))?;
    let mut encoder = png::Encoder::new(std::io::BufWriter::new(file), width as u32, height as u32);
    encoder.set_color(png::ColorType::Grayscale);
    encoder.set_depth(png::BitDepth::Eight);
    let err = |e: png::EncodingError| InputError::new(path, "(png)", e.to_string());
    let mut w = encoder.write_header().map_err(err)?;
    w.write_image_data(data).map_err(err)?;
    w.finish().map_err(err)
}

/// Convert `scene` into `out`.
pub fn write_habitat_scene(scene: &DrakeScene, out: &Path, options: &ConvertOptions) -> Result<ConversionReport> {
    clear_generated_folders(out)?;
    let mut w = Writer {
        out,
        options,
        scene,
        report: ConversionReport { scene: scene.name.clone(), ..Default::default() },
        templates: Vec::new(),
        instances: Vec::new(),
        obstacles: Vec::new(),
        floor: None,
    };
    for model in &scene.models {
        w.add_model(model)?;
    }
    let name = &scene.name;
    for (handle, template) in &w.templates {
        write_json(&out.join("objects").join(format!("{handle}.object_config.json")), template)?;
    }
    let floor =
        w.floor.or_else(|| footprint_of_objects(&w.report.objects)).ok_or_else(|| InputError::new(&scene.root, "models", "the scene has no visuals"))?;
    write_scene_configs(out, name, &w.instances)?;
    write_semantics(out, name, &w.report.objects)?;
    let ceiling_height = scene.wall_height.unwrap_or_else(|| w.obstacles.iter().map(|(_, hi)| hi[1]).fold(2.5f64, f64::max));
    if (0..3).step_by(2).any(|a| floor.1[a] - floor.0[a] > options.max_room_side) {
        return Err(InputError::new(&scene.root, "floor", format!("the floor spans more than {} m", options.max_room_side)));
    }
    for (condition, lights) in lighting(floor, ceiling_height) {
        write_json(&out.join("lighting").join(format!("{name}.{condition}.lighting_config.json")), &habitat_lighting(&lights))?;
        write_json(&out.join("lighting_hadage").join(format!("light_settings_{name}_{condition}.json")), &lights)?;
    }
    w.report.navigable_fraction = write_navigation(out, name, floor, &w.obstacles, options)?;
    if let Some(prompt) = &scene.prompt {
        write_json(&out.join("prompt.json"), &json!({"prompt": prompt}))?;
    }
    w.report.unknown_names.sort();
    w.report.unknown_names.dedup();
    write_json(&out.join("conversion_report.json"), &w.report)?;
    Ok(w.report)
}

/// Remove what an earlier conversion into `out` generated: a second conversion into the
/// same folder must not leave the first one's files behind (Habitat globs objects/ and
/// scenes/); only our own folders are cleared.
fn clear_generated_folders(out: &Path) -> Result<()> {
    std::fs::create_dir_all(out).map_err(|e| InputError::io(out, &e))?;
    for generated in ["assets", "objects", "scenes", "semantics", "lighting", "lighting_hadage", "navigation", "stages"] {
        let dir = out.join(generated);
        if dir.is_dir() {
            std::fs::remove_dir_all(&dir).map_err(|e| InputError::io(&dir, &e))?;
        }
    }
    Ok(())
}

/// The floor of a scene without a floor visual: the footprint of everything, at height 0
/// (none without objects).
fn footprint_of_objects(objects: &[ConvertedObject]) -> Option<([f64; 3], [f64; 3])> {
    let lo = objects.iter().fold([f64::INFINITY; 3], |m, o| std::array::from_fn(|a| m[a].min(o.bbox_min[a])));
    let hi = objects.iter().fold([f64::NEG_INFINITY; 3], |m, o| std::array::from_fn(|a| m[a].max(o.bbox_max[a])));
    lo[0].is_finite().then_some(([lo[0], 0.0, lo[2]], [hi[0], 0.0, hi[2]]))
}

/// The scene instance (its placed objects) and the scene dataset config that points Habitat
/// at objects, lighting, scenes and semantics.
fn write_scene_configs(out: &Path, name: &str, instances: &[Value]) -> Result<()> {
    // No stage: the floor, walls and furniture are all collidable static objects with
    // their own poses and semantic ids (navmeshes include static objects), so nothing
    // needs the reference adapter's duplicate floor.
    let scene_instance = json!({
        "stage_instance": {"template_name": "NONE"},
        "default_lighting": format!("{name}.baseline"),
        "translation_origin": "asset_local",
        "semantic_scene_instance": name,
        "object_instances": instances,
    });
    write_json(&out.join("scenes").join(format!("{name}.scene_instance.json")), &scene_instance)?;
    write_json(
        &out.join(format!("{name}.scene_dataset_config.json")),
        &json!({
            "objects": {"paths": {".object_config.json": ["objects/"]}},
            "light_setups": {"default_attributes": {"positive_intensity_scale": 2.5, "negative_intensity_scale": 0.1}, "paths": {".lighting_config.json": ["lighting/"]}},
            "scene_instances": {"paths": {".scene_instance.json": ["scenes/"]}},
            "semantic_scene_descriptor_instances": {name.to_string(): format!("semantics/{name}.lexicon.json")},
        }),
    )
}

/// The scene's lexicon (instance ids with their class names: HaDaGe's remap_classes
/// collapses them to classes) and the class list.
fn write_semantics(out: &Path, name: &str, objects: &[ConvertedObject]) -> Result<()> {
    let mut lexicon = vec![json!({"name": "other", "id": 0})];
    lexicon.extend(objects.iter().map(|o| json!({"name": o.class, "id": o.instance_id})));
    write_json(&out.join("semantics").join(format!("{name}.lexicon.json")), &json!({"classes": lexicon}))?;
    write_json(&out.join("semantics/classes.json"), &json!({"classes": classes()}))
}

/// The navigable map of `floor` around `obstacles` as a PNG and its description; returns
/// the navigable fraction of the floor.
fn write_navigation(out: &Path, name: &str, floor: ([f64; 3], [f64; 3]), obstacles: &[([f64; 3], [f64; 3])], options: &ConvertOptions) -> Result<f64> {
    let (width, height, cells) = navigable_map(floor, obstacles, options);
    let nav_dir = out.join("navigation");
    std::fs::create_dir_all(&nav_dir).map_err(|e| InputError::io(&nav_dir, &e))?;
    write_png8(&nav_dir.join(format!("{name}.navigable.png")), width, height, &cells)?;
    let navigable = cells.iter().filter(|&&c| c == 255).count() as f64 / cells.len() as f64;
    write_json(
        &nav_dir.join(format!("{name}.navigable.json")),
        &json!({"origin_xz": [floor.0[0], floor.0[2]], "floor_height": floor.1[1], "cell_size": options.cell_size, "width": width, "height": height,
                "agent_radius": options.agent_radius, "agent_height": options.agent_height, "navigable_fraction": navigable,
                "png": format!("{name}.navigable.png"), "rows": "z increasing", "columns": "x increasing", "values": "255 navigable, 0 blocked"}),
    )?;
    Ok(navigable)
}
