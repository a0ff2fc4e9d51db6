//! Writing glTF 2.0 the way SceneSmith ships its assets: a `.gltf` with an external `.bin`
//! buffer (and external images), Y-up, one primitive per material with positions, normals,
//! texture coordinates when textured, and indices.

use std::path::Path;

use osmab_evaluator::{InputError, Result};
use serde_json::{Value, json};

/// A material of a written mesh: a base colour, and a texture file beside the `.gltf`.
pub struct OutMaterial<'a> {
    pub name: &'a str,
    pub color: [f32; 4],
    /// The image's file name (PNG or JPEG), relative to the `.gltf`.
    pub texture: Option<&'a str>,
    /// An ambient-occlusion image's file name (its red channel), relative to the `.gltf`.
    pub occlusion: Option<&'a str>,
}

/// One material's triangles, already in glTF's Y-up frame.
pub struct OutPrimitive<'a> {
    pub positions: &'a [[f32; 3]],
    pub normals: &'a [[f32; 3]],
    pub uvs: Option<&'a [[f32; 2]]>,
    pub indices: &'a [u32],
    pub material: OutMaterial<'a>,
}

/// Write `primitives` as one mesh named `name`: `dir/stem.gltf` + `dir/stem.bin`.
pub fn write_gltf(dir: &Path, stem: &str, name: &str, generator: &str, primitives: &[OutPrimitive]) -> Result<()> {
    let mut bin: Vec<u8> = Vec::new();
    let (mut views, mut accessors, mut out_primitives, mut materials, mut images) = (Vec::new(), Vec::new(), Vec::new(), Vec::new(), Vec::<Value>::new());
    for primitive in primitives {
        let (lo, hi) = primitive.positions.iter().fold(([f32::INFINITY; 3], [f32::NEG_INFINITY; 3]), |(lo, hi), p| {
            (std::array::from_fn(|a| lo[a].min(p[a])), std::array::from_fn(|a| hi[a].max(p[a])))
        });
        let mut push_view = |bytes: Vec<u8>, target: u32| {
            while bin.len() % 4 != 0 {
                bin.push(0);
            }
            views.push(json!({"buffer": 0, "byteOffset": bin.len(), "byteLength": bytes.len(), "target": target}));
            bin.extend(bytes);
            views.len() - 1
        };
        let floats = |values: &mut dyn Iterator<Item = f32>| values.flat_map(f32::to_le_bytes).collect::<Vec<u8>>();
        let pv = push_view(floats(&mut primitive.positions.iter().flatten().copied()), 34962);
        let nv = push_view(floats(&mut primitive.normals.iter().flatten().copied()), 34962);
        let uv = primitive.uvs.map(|uvs| push_view(floats(&mut uvs.iter().flatten().copied()), 34962));
        let iv = push_view(primitive.indices.iter().flat_map(|v| v.to_le_bytes()).collect(), 34963);
        let base = accessors.len();
        accessors.push(json!({"bufferView": pv, "componentType": 5126, "count": primitive.positions.len(), "type": "VEC3", "min": lo, "max": hi}));
        accessors.push(json!({"bufferView": nv, "componentType": 5126, "count": primitive.normals.len(), "type": "VEC3"}));
        accessors.push(json!({"bufferView": iv, "componentType": 5125, "count": primitive.indices.len(), "type": "SCALAR"}));
        let mut attributes = json!({"POSITION": base, "NORMAL": base + 1});
        if let (Some(view), Some(uvs)) = (uv, primitive.uvs) {
            attributes["TEXCOORD_0"] = json!(accessors.len());
            accessors.push(json!({"bufferView": view, "componentType": 5126, "count": uvs.len(), "type": "VEC2"}));
        }
        out_primitives.push(json!({"attributes": attributes, "indices": base + 2, "material": materials.len(), "mode": 4}));
        let m = &primitive.material;
        let mut pbr = json!({"baseColorFactor": m.color, "metallicFactor": 0.0, "roughnessFactor": 0.8});
        let mime = |file: &str| if file.ends_with(".png") { "image/png" } else { "image/jpeg" };
        if let Some(texture) = m.texture {
            pbr["baseColorTexture"] = json!({"index": images.len()});
            images.push(json!({"uri": texture, "mimeType": mime(texture)}));
        }
        let mut material = json!({"name": m.name, "pbrMetallicRoughness": pbr});
        if let Some(occlusion) = m.occlusion {
            material["occlusionTexture"] = json!({"index": images.len()});
            images.push(json!({"uri": occlusion, "mimeType": mime(occlusion)}));
        }
        materials.push(material);
    }
    let mut doc = json!({
        "asset": {"version": "2.0", "generator": generator},
        "scene": 0,
        "scenes": [{"nodes": [0]}],
        "nodes": [{"name": name, "mesh": 0}],
        "meshes": [{"name": name, "primitives": out_primitives}],
        "materials": materials,
        "buffers": [{"uri": format!("{stem}.bin"), "byteLength": bin.len()}],
        "bufferViews": views,
        "accessors": accessors,
    });
    if !images.is_empty() {
        let textures: Vec<Value> = (0..images.len()).map(|k| json!({"source": k, "sampler": 0})).collect();
        doc["images"] = json!(images);
        doc["textures"] = json!(textures);
        doc["samplers"] = json!([{"wrapS": 10497, "wrapT": 10497}]);
    }
    std::fs::create_dir_all(dir).map_err(|e| InputError::io(dir, &e))?;
    let gltf = dir.join(format!("{stem}.gltf"));
    std::fs::write(&gltf, serde_json::to_string_pretty(&doc).expect("serialisable")).map_err(|e| InputError::io(&gltf, &e))?;
    let bin_path = dir.join(format!("{stem}.bin"));
    std::fs::write(&bin_path, bin).map_err(|e| InputError::io(&bin_path, &e))
}
