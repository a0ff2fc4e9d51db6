//! glTF 2.0 meshes (`.gltf` with external or embedded buffers, and `.glb`), read into
//! flat triangle meshes in the asset's own (Y-up) frame with node transforms applied.
//! Normals are generated where the file has none (SceneSmith's assets carry only
//! positions and texture coordinates); base-colour textures are decoded, and a
//! missing or broken texture falls back to the base colour and is reported.
//!
//! One file, over 400 lines, on purpose: it is one format's reader, and the accessor, buffer
//! and node rules of the glTF spec read best side by side.

use std::path::{Path, PathBuf};

use base64::Engine;
use nalgebra::{Matrix3, Matrix4, Quaternion, UnitQuaternion, Vector3};
use osmab_evaluator::{InputError, Result};
use serde_json::Value;

/// Most vertices or indices accepted from one accessor.
const MAX_ELEMENTS: usize = 50_000_000;
/// Largest texture side decoded (an 8k texture is already generous for an object).
const MAX_TEXTURE_SIDE: u32 = 8192;

/// A decoded RGBA8 texture.
#[derive(Debug, Clone, PartialEq)]
pub struct Texture {
    pub width: u32,
    pub height: u32,
    pub rgba: Vec<u8>,
}

/// A material: base colour factor and, when it decodes, its base-colour texture.
#[derive(Debug, Clone, PartialEq)]
pub struct Material {
    pub name: String,
    pub base_color: [f32; 4],
    pub texture: Option<Texture>,
    /// Why a referenced texture could not be used (then the base colour is used).
    pub texture_problem: Option<String>,
    /// The ambient-occlusion texture (`occlusionTexture`, its red channel), when it decodes
    /// (one that does not is left out: it only darkens).
    pub occlusion: Option<Texture>,
}

/// One triangle list with a single material.
#[derive(Debug, Clone, PartialEq)]
pub struct TriangleMesh {
    pub positions: Vec<[f32; 3]>,
    pub normals: Vec<[f32; 3]>,
    pub uvs: Option<Vec<[f32; 2]>>,
    pub indices: Vec<u32>,
    pub material: Option<usize>,
}

/// Everything drawable in a glTF file.
#[derive(Debug, Clone, PartialEq)]
pub struct GltfAsset {
    pub meshes: Vec<TriangleMesh>,
    pub materials: Vec<Material>,
    /// Whether any normals had to be generated.
    pub generated_normals: bool,
}

impl GltfAsset {
    /// Axis-aligned bounds of all positions.
    pub fn bounds(&self) -> Option<([f32; 3], [f32; 3])> {
        let mut it = self.meshes.iter().flat_map(|m| m.positions.iter());
        let first = *it.next()?;
        Some(it.fold((first, first), |(lo, hi), p| (std::array::from_fn(|a| lo[a].min(p[a])), std::array::from_fn(|a| hi[a].max(p[a])))))
    }
}

struct Source {
    json: Value,
    buffers: Vec<Vec<u8>>,
}

/// Read a `.gltf` or `.glb` file.
pub fn read_gltf(path: &Path) -> Result<GltfAsset> {
    let bytes = std::fs::read(path).map_err(|e| InputError::io(path, &e))?;
    let dir = path.parent().unwrap_or(Path::new("."));
    let (json, glb_bin) = if bytes.starts_with(b"glTF") { split_glb(&bytes, path)? } else { (parse_json(&bytes, path)?, None) };
    let version = json["asset"]["version"].as_str().unwrap_or("");
    if !version.starts_with("2.") {
        return Err(InputError::new(path, "asset.version", format!("expected glTF 2.x, found '{version}'")));
    }
    let mut buffers = Vec::new();
    for (i, buffer) in json["buffers"].as_array().cloned().unwrap_or_default().iter().enumerate() {
        let field = format!("buffers[{i}]");
        let data = match buffer["uri"].as_str() {
            None => glb_bin.clone().ok_or_else(|| InputError::new(path, &field, "buffer without uri outside a .glb"))?,
            Some(uri) => load_uri(uri, dir, path, &field)?,
        };
        let declared = buffer["byteLength"].as_u64().unwrap_or(0) as usize;
        if data.len() < declared {
            return Err(InputError::new(path, &field, format!("holds {} bytes, but byteLength says {declared}", data.len())));
        }
        buffers.push(data);
    }
    let source = Source { json, buffers };
    let materials = read_materials(&source, dir, path);
    let mut meshes = Vec::new();
    let mut generated_normals = false;
    let scene = source.json["scene"].as_u64().unwrap_or(0) as usize;
    let roots: Vec<usize> =
        source.json["scenes"][scene]["nodes"].as_array().map(|a| a.iter().filter_map(|n| n.as_u64().map(|n| n as usize)).collect()).unwrap_or_else(|| {
            // No scene: every node that is nobody's child.
            let nodes = source.json["nodes"].as_array().map_or(0, Vec::len);
            let children: std::collections::HashSet<u64> = source.json["nodes"]
                .as_array()
                .into_iter()
                .flatten()
                .flat_map(|n| n["children"].as_array().into_iter().flatten().filter_map(Value::as_u64))
                .collect();
            (0..nodes).filter(|i| !children.contains(&(*i as u64))).collect()
        });
    let mut stack: Vec<(usize, Matrix4<f64>, usize)> = roots.into_iter().map(|n| (n, Matrix4::identity(), 0)).collect();
    let node_count = source.json["nodes"].as_array().map_or(0, Vec::len);
    let mut visited = vec![false; node_count];
    while let Some((node_index, parent, depth)) = stack.pop() {
        if depth > 64 {
            return Err(InputError::new(path, "nodes", "the node hierarchy is deeper than 64 (or cyclic)"));
        }
        // glTF nodes form a forest: a node reached twice is a malformed (or hostile) file.
        match visited.get_mut(node_index) {
            Some(seen) if *seen => return Err(InputError::new(path, format!("nodes[{node_index}]"), "the node is reached twice; glTF nodes must form a tree")),
            Some(seen) => *seen = true,
            None => return Err(InputError::new(path, format!("nodes[{node_index}]"), "no such node")),
        }
        let node = &source.json["nodes"][node_index];
        if node.is_null() {
            return Err(InputError::new(path, format!("nodes[{node_index}]"), "no such node"));
        }
        let world = parent * local_matrix(node, path, node_index)?;
        if let Some(mesh) = node["mesh"].as_u64() {
            for (p, primitive) in source.json["meshes"][mesh as usize]["primitives"].as_array().cloned().unwrap_or_default().iter().enumerate() {
                let field = format!("meshes[{mesh}].primitives[{p}]");
                if let Some(m) = read_primitive(&source, primitive, &world, path, &field)? {
                    generated_normals |= primitive["attributes"]["NORMAL"].is_null();
                    meshes.push(m);
                }
            }
        }
        for child in node["children"].as_array().into_iter().flatten().filter_map(Value::as_u64) {
            stack.push((child as usize, world, depth + 1));
        }
    }
    Ok(GltfAsset { meshes, materials, generated_normals })
}

fn parse_json(bytes: &[u8], path: &Path) -> Result<Value> {
    serde_json::from_slice(bytes).map_err(|e| InputError::new(path, "(json)", format!("not valid glTF JSON: {e}")))
}

fn split_glb(bytes: &[u8], path: &Path) -> Result<(Value, Option<Vec<u8>>)> {
    let u32_at = |o: usize| bytes.get(o..o + 4).map(|b| u32::from_le_bytes(b.try_into().expect("4 bytes")) as usize);
    let bad = |m: &str| InputError::new(path, "(glb)", m.to_string());
    if u32_at(4) != Some(2) {
        return Err(bad("expected GLB version 2"));
    }
    let json_len = u32_at(12).ok_or_else(|| bad("truncated header"))?;
    if u32_at(16) != Some(0x4E4F_534A) {
        return Err(bad("the first chunk is not JSON"));
    }
    let json = bytes.get(20..20 + json_len).ok_or_else(|| bad("truncated JSON chunk"))?;
    let json = parse_json(json, path)?;
    let bin_start = 20 + json_len;
    let bin = match (u32_at(bin_start), u32_at(bin_start + 4)) {
        (Some(len), Some(0x004E_4942)) => Some(bytes.get(bin_start + 8..bin_start + 8 + len).ok_or_else(|| bad("truncated BIN chunk"))?.to_vec()),
        _ => None,
    };
    Ok((json, bin))
}

fn load_uri(uri: &str, dir: &Path, path: &Path, field: &str) -> Result<Vec<u8>> {
    if let Some(data) = uri.strip_prefix("data:") {
        let (_, payload) = data.split_once(";base64,").ok_or_else(|| InputError::new(path, field, "only base64 data URIs are supported"))?;
        return base64::engine::general_purpose::STANDARD.decode(payload).map_err(|e| InputError::new(path, field, format!("bad base64 data: {e}")));
    }
    let decoded = uri.replace("%20", " ");
    let file: PathBuf = super::sdf::normalize(&dir.join(&decoded));
    if decoded.contains("://") || !file.starts_with(super::sdf::normalize(dir)) {
        return Err(InputError::new(path, field, format!("'{uri}' must be a file beside the glTF")));
    }
    std::fs::read(&file).map_err(|e| InputError::new(path, field, format!("cannot read '{}': {e}", file.display())))
}

fn local_matrix(node: &Value, path: &Path, index: usize) -> Result<Matrix4<f64>> {
    let floats = |v: &Value, n: usize| -> Option<Vec<f64>> { v.as_array().filter(|a| a.len() == n).and_then(|a| a.iter().map(Value::as_f64).collect()) };
    if let Some(m) = floats(&node["matrix"], 16) {
        return Ok(Matrix4::from_column_slice(&m));
    }
    let t = floats(&node["translation"], 3).unwrap_or(vec![0.0; 3]);
    let r = floats(&node["rotation"], 4).unwrap_or(vec![0.0, 0.0, 0.0, 1.0]);
    let s = floats(&node["scale"], 3).unwrap_or(vec![1.0; 3]);
    if t.iter().chain(&r).chain(&s).any(|x| !x.is_finite()) {
        return Err(InputError::new(path, format!("nodes[{index}]"), "non-finite transform"));
    }
    let q = UnitQuaternion::from_quaternion(Quaternion::new(r[3], r[0], r[1], r[2]));
    Ok(Matrix4::new_translation(&Vector3::new(t[0], t[1], t[2])) * q.to_homogeneous() * Matrix4::new_nonuniform_scaling(&Vector3::new(s[0], s[1], s[2])))
}

/// Read accessor `index` as `width` floats (or integers, as floats) per element.
fn accessor(source: &Source, index: usize, width: usize, path: &Path, field: &str) -> Result<Vec<f64>> {
    let a = &source.json["accessors"][index];
    let bad = |m: String| InputError::new(path, format!("{field} (accessor {index})"), m);
    let count = a["count"].as_u64().ok_or_else(|| bad("missing count".into()))? as usize;
    if count > MAX_ELEMENTS {
        return Err(bad(format!("{count} elements is more than {MAX_ELEMENTS}")));
    }
    let components = match a["type"].as_str() {
        Some("SCALAR") => 1,
        Some("VEC2") => 2,
        Some("VEC3") => 3,
        Some("VEC4") => 4,
        other => return Err(bad(format!("unsupported type {other:?}"))),
    };
    if components != width {
        return Err(bad(format!("expected {width} components, found {components}")));
    }
    let (size, read): (usize, fn(&[u8]) -> f64) = match a["componentType"].as_u64() {
        Some(5126) => (4, |b| f32::from_le_bytes(b.try_into().expect("4")) as f64),
        Some(5125) => (4, |b| u32::from_le_bytes(b.try_into().expect("4")) as f64),
        Some(5123) => (2, |b| u16::from_le_bytes(b.try_into().expect("2")) as f64),
        Some(5121) => (1, |b| b[0] as f64),
        other => return Err(bad(format!("unsupported componentType {other:?}"))),
    };
    let view = &source.json["bufferViews"][a["bufferView"].as_u64().ok_or_else(|| bad("sparse or view-less accessors are not supported".into()))? as usize];
    let buffer = source.buffers.get(view["buffer"].as_u64().unwrap_or(u64::MAX) as usize).ok_or_else(|| bad("its buffer does not exist".into()))?;
    let element = size * components;
    let stride = match view["byteStride"].as_u64() {
        None => element,
        Some(s) if (4..=252).contains(&s) && s % 4 == 0 && s as usize >= element => s as usize,
        Some(s) => return Err(bad(format!("byteStride {s} is not a multiple of 4 in 4..=252 covering an element"))),
    };
    let (view_offset, view_length) = (view["byteOffset"].as_u64().unwrap_or(0), view["byteLength"].as_u64().unwrap_or(0));
    let start = view_offset.checked_add(a["byteOffset"].as_u64().unwrap_or(0));
    let end = start.and_then(|s| {
        if count == 0 {
            Some(s)
        } else {
            (stride as u64).checked_mul(count as u64 - 1).and_then(|x| x.checked_add(s)).and_then(|x| x.checked_add(element as u64))
        }
    });
    let view_end = view_offset.checked_add(view_length);
    let (Some(start), Some(end), Some(view_end)) = (start, end, view_end) else {
        return Err(bad("offsets overflow".into()));
    };
    let (start, end) = (start as usize, end as usize);
    if end > buffer.len() || end as u64 > view_end {
        return Err(bad(format!("reads bytes {start}..{end}, past the end of its buffer view")));
    }
    let mut out = Vec::with_capacity(count * components);
    for e in 0..count {
        let at = start + e * stride;
        for c in 0..components {
            out.push(read(&buffer[at + c * size..at + (c + 1) * size]));
        }
    }
    if out.iter().any(|v| !v.is_finite()) {
        return Err(bad("holds non-finite values".into()));
    }
    Ok(out)
}

fn read_primitive(source: &Source, primitive: &Value, world: &Matrix4<f64>, path: &Path, field: &str) -> Result<Option<TriangleMesh>> {
    if primitive["mode"].as_u64().unwrap_or(4) != 4 {
        return Ok(None); // points and lines draw nothing in a scene
    }
    let position = primitive["attributes"]["POSITION"].as_u64().ok_or_else(|| InputError::new(path, field, "no POSITION attribute"))? as usize;
    let raw = accessor(source, position, 3, path, &format!("{field}.POSITION"))?;
    let n = raw.len() / 3;
    let normal_matrix: Matrix3<f64> = world.fixed_view::<3, 3>(0, 0).try_inverse().map(|m| m.transpose()).unwrap_or_else(Matrix3::identity);
    let positions: Vec<[f32; 3]> = raw
        .chunks_exact(3)
        .map(|p| {
            let v = world.transform_point(&nalgebra::Point3::new(p[0], p[1], p[2]));
            [v.x as f32, v.y as f32, v.z as f32]
        })
        .collect();
    let indices: Vec<u32> = match primitive["indices"].as_u64() {
        Some(i) => accessor(source, i as usize, 1, path, &format!("{field}.indices"))?.into_iter().map(|v| v as u32).collect(),
        None => (0..n as u32).collect(),
    };
    if indices.len() % 3 != 0 {
        return Err(InputError::new(path, format!("{field}.indices"), "a triangle list needs a multiple of 3 indices"));
    }
    if let Some(bad) = indices.iter().find(|&&i| i as usize >= n) {
        return Err(InputError::new(path, format!("{field}.indices"), format!("index {bad} is past the {n} vertices")));
    }
    let normals = match primitive["attributes"]["NORMAL"].as_u64() {
        Some(i) => accessor(source, i as usize, 3, path, &format!("{field}.NORMAL"))?
            .chunks_exact(3)
            .map(|v| {
                let t = (normal_matrix * Vector3::new(v[0], v[1], v[2])).normalize();
                [t.x as f32, t.y as f32, t.z as f32]
            })
            .collect(),
        None => vertex_normals(&positions, &indices),
    };
    if normals.len() != n {
        return Err(InputError::new(path, format!("{field}.NORMAL"), "one normal per position expected"));
    }
    let uvs = match primitive["attributes"]["TEXCOORD_0"].as_u64() {
        Some(i) => {
            let uv: Vec<[f32; 2]> =
                accessor(source, i as usize, 2, path, &format!("{field}.TEXCOORD_0"))?.chunks_exact(2).map(|c| [c[0] as f32, c[1] as f32]).collect();
            (uv.len() == n).then_some(uv)
        }
        None => None,
    };
    Ok(Some(TriangleMesh { positions, normals, uvs, indices, material: primitive["material"].as_u64().map(|m| m as usize) }))
}

/// Area-weighted vertex normals (a degenerate vertex gets +Y).
pub fn vertex_normals(positions: &[[f32; 3]], indices: &[u32]) -> Vec<[f32; 3]> {
    let mut sums = vec![Vector3::<f64>::zeros(); positions.len()];
    for t in indices.chunks_exact(3) {
        let p = |i: u32| {
            let v = positions[i as usize];
            Vector3::new(v[0] as f64, v[1] as f64, v[2] as f64)
        };
        let n = (p(t[1]) - p(t[0])).cross(&(p(t[2]) - p(t[0])));
        for &i in t {
            sums[i as usize] += n;
        }
    }
    sums.iter()
        .map(|s| {
            if s.norm() > 0.0 {
                let n = s.normalize();
                [n.x as f32, n.y as f32, n.z as f32]
            } else {
                [0.0, 1.0, 0.0]
            }
        })
        .collect()
}

fn read_materials(source: &Source, dir: &Path, path: &Path) -> Vec<Material> {
    let materials = source.json["materials"].as_array().cloned().unwrap_or_default();
    materials
        .iter()
        .enumerate()
        .map(|(i, m)| {
            let pbr = &m["pbrMetallicRoughness"];
            let factor: Vec<f32> =
                pbr["baseColorFactor"].as_array().map(|a| a.iter().filter_map(Value::as_f64).map(|v| v as f32).collect()).unwrap_or_default();
            let base_color = if factor.len() == 4 && factor.iter().all(|v| v.is_finite()) { [factor[0], factor[1], factor[2], factor[3]] } else { [1.0; 4] };
            let (texture, texture_problem) = match pbr["baseColorTexture"]["index"].as_u64() {
                None => (None, None),
                Some(t) => match load_texture(source, t as usize, dir, path, &format!("materials[{i}]")) {
                    Ok(tex) => (Some(tex), None),
                    Err(e) => (None, Some(e.to_string())),
                },
            };
            let occlusion = m["occlusionTexture"]["index"]
                .as_u64()
                .and_then(|t| load_texture(source, t as usize, dir, path, &format!("materials[{i}].occlusionTexture")).ok());
            Material { name: m["name"].as_str().unwrap_or("").to_string(), base_color, texture, texture_problem, occlusion }
        })
        .collect()
}

fn load_texture(source: &Source, texture: usize, dir: &Path, path: &Path, field: &str) -> Result<Texture> {
    let image_index =
        source.json["textures"][texture]["source"].as_u64().ok_or_else(|| InputError::new(path, field, format!("texture {texture} has no image")))? as usize;
    let image = &source.json["images"][image_index];
    let bytes = if let Some(view) = image["bufferView"].as_u64() {
        let v = &source.json["bufferViews"][view as usize];
        let buffer =
            source.buffers.get(v["buffer"].as_u64().unwrap_or(u64::MAX) as usize).ok_or_else(|| InputError::new(path, field, "image buffer missing"))?;
        let start = v["byteOffset"].as_u64().unwrap_or(0) as usize;
        let end = start.saturating_add(v["byteLength"].as_u64().unwrap_or(0) as usize);
        buffer.get(start..end).ok_or_else(|| InputError::new(path, field, "image bytes past the end of the buffer"))?.to_vec()
    } else if let Some(uri) = image["uri"].as_str() {
        load_uri(uri, dir, path, field)?
    } else {
        return Err(InputError::new(path, field, "image has neither bufferView nor uri"));
    };
    decode_image(&bytes).map_err(|m| InputError::new(path, format!("{field}.baseColorTexture"), m))
}

/// Decode PNG or JPEG bytes to RGBA8.
pub fn decode_image(bytes: &[u8]) -> std::result::Result<Texture, String> {
    if bytes.starts_with(b"\x89PNG") {
        let mut decoder = png::Decoder::new(std::io::Cursor::new(bytes));
        decoder.set_transformations(png::Transformations::EXPAND | png::Transformations::STRIP_16);
        let mut reader = decoder.read_info().map_err(|e| format!("unreadable PNG: {e}"))?;
        let (w, h) = (reader.info().width, reader.info().height);
        if w > MAX_TEXTURE_SIDE || h > MAX_TEXTURE_SIDE {
            return Err(format!("a {w}x{h} texture is too large"));
        }
        let mut buf = vec![0; reader.output_buffer_size().ok_or("texture too large")?];
        let frame = reader.next_frame(&mut buf).map_err(|e| format!("corrupt PNG: {e}"))?;
        let data = &buf[..frame.buffer_size()];
        let rgba = match frame.color_type {
            png::ColorType::Rgba => data.to_vec(),
            png::ColorType::Rgb => data.chunks_exact(3).flat_map(|c| [c[0], c[1], c[2], 255]).collect(),
            png::ColorType::GrayscaleAlpha => data.chunks_exact(2).flat_map(|c| [c[0], c[0], c[0], c[1]]).collect(),
            png::ColorType::Grayscale => data.iter().flat_map(|&g| [g, g, g, 255]).collect(),
            png::ColorType::Indexed => return Err("palette PNG was not expanded".into()),
        };
        Ok(Texture { width: w, height: h, rgba })
    } else if bytes.starts_with(&[0xFF, 0xD8]) {
        let mut decoder = jpeg_decoder::Decoder::new(std::io::Cursor::new(bytes));
        decoder.read_info().map_err(|e| format!("corrupt JPEG: {e}"))?;
        let info = decoder.info().ok_or("JPEG without header")?;
        if info.width as u32 > MAX_TEXTURE_SIDE || info.height as u32 > MAX_TEXTURE_SIDE {
            return Err(format!("a {}x{} texture is too large", info.width, info.height));
        }
        decoder.set_max_decoding_buffer_size(MAX_TEXTURE_SIDE as usize * MAX_TEXTURE_SIDE as usize * 4);
        let pixels = decoder.decode().map_err(|e| format!("corrupt JPEG: {e}"))?;
        let rgba = match info.pixel_format {
            jpeg_decoder::PixelFormat::RGB24 => pixels.chunks_exact(3).flat_map(|c| [c[0], c[1], c[2], 255]).collect(),
            jpeg_decoder::PixelFormat::L8 => pixels.iter().flat_map(|&g| [g, g, g, 255]).collect(),
            other => return Err(format!("unsupported JPEG pixel format {other:?}")),
        };
        Ok(Texture { width: info.width as u32, height: info.height as u32, rgba })
    } else {
        Err("the image is neither PNG nor JPEG".into())
    }
}
