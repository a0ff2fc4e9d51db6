//! Semantic meshes in PLY (Replica's `mesh_semantic.ply`: vertices with x, y, z and
//! faces with `vertex_indices` and `object_id`), the reference's second ground-truth
//! source. ASCII and binary (either byte order) are read.

use std::collections::HashMap;
use std::fs::File;
use std::io::{BufRead, BufReader, Read};
use std::path::Path;

use crate::error::{InputError, Result};

/// Vertices and labelled faces of a semantic mesh.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct SemanticMesh {
    /// Vertex positions.
    pub vertices: Vec<[f32; 3]>,
    /// Concatenated vertex indices of all faces.
    pub face_vertices: Vec<u32>,
    /// Start of each face in `face_vertices` (one more entry than faces).
    pub face_offsets: Vec<usize>,
    /// Object id of each face.
    pub face_objects: Vec<i64>,
}

#[derive(Debug, Clone, Copy, PartialEq)]
enum Scalar {
    I8,
    U8,
    I16,
    U16,
    I32,
    U32,
    F32,
    F64,
}

impl Scalar {
    fn parse(name: &str) -> Option<Self> {
        Some(match name {
            "char" | "int8" => Scalar::I8,
            "uchar" | "uint8" => Scalar::U8,
            "short" | "int16" => Scalar::I16,
            "ushort" | "uint16" => Scalar::U16,
            "int" | "int32" => Scalar::I32,
            "uint" | "uint32" => Scalar::U32,
            "float" | "float32" => Scalar::F32,
            "double" | "float64" => Scalar::F64,
            _ => return None,
        })
    }

    fn size(self) -> usize {
        match self {
            Scalar::I8 | Scalar::U8 => 1,
            Scalar::I16 | Scalar::U16 => 2,
            Scalar::I32 | Scalar::U32 | Scalar::F32 => 4,
            Scalar::F64 => 8,
        }
    }
}

#[derive(Debug, Clone)]
struct Property {
    name: String,
    /// `Some(count type)` for list properties.
    list: Option<Scalar>,
    value: Scalar,
}

#[derive(Debug, Clone)]
struct Element {
    name: String,
    count: usize,
    properties: Vec<Property>,
}

#[derive(Debug, Clone, Copy, PartialEq)]
enum Format {
    Ascii,
    Little,
    Big,
}

/// Largest list length accepted for one face.
const MAX_FACE_VERTICES: usize = 64;

/// Read a semantic mesh.
pub fn read_semantic_mesh(path: &Path) -> Result<SemanticMesh> {
    let file = File::open(path).map_err(|e| InputError::io(path, &e))?;
    let mut reader = BufReader::with_capacity(1 << 20, file);
    let (format, elements) = read_header(&mut reader, path)?;
    let mut mesh = SemanticMesh { face_offsets: vec![0], ..Default::default() };
    let mut source = ValueSource { reader: &mut reader, format, path, line: Vec::new(), pos: 0 };
    for element in &elements {
        match element.name.as_str() {
            "vertex" => read_vertices(&mut source, element, &mut mesh, path)?,
            "face" => read_faces(&mut source, element, &mut mesh, path)?,
            _ => skip_element(&mut source, element)?,
        }
    }
    Ok(mesh)
}

/// The position of `element`'s property `name`, if it has one.
fn property(element: &Element, name: &str) -> Option<usize> {
    element.properties.iter().position(|p| p.name == name)
}

/// The vertices of `element` into `mesh`: their x, y and z (finite), other properties skipped.
fn read_vertices<R: BufRead>(source: &mut ValueSource<R>, element: &Element, mesh: &mut SemanticMesh, path: &Path) -> Result<()> {
    let axes = [property(element, "x"), property(element, "y"), property(element, "z")];
    if axes.iter().any(Option::is_none) {
        return Err(InputError::new(path, "header.vertex", "vertices need properties x, y and z"));
    }
    mesh.vertices.reserve(element.count.min(1 << 24));
    let mut values = vec![0.0f64; element.properties.len()];
    for i in 0..element.count {
        source.start_record()?;
        for (k, p) in element.properties.iter().enumerate() {
            if p.list.is_some() {
                source.skip_list(p)?;
            } else {
                values[k] = source.scalar(p.value)?;
            }
        }
        let v = axes.map(|a| values[a.expect("checked")] as f32);
        if v.iter().any(|c| !c.is_finite()) {
            return Err(InputError::new(path, format!("vertex {i}"), "non-finite coordinate"));
        }
        mesh.vertices.push(v);
    }
    Ok(())
}

/// The faces of `element` into `mesh`: their vertex indices (each a vertex read before)
/// and their object id, other properties skipped.
fn read_faces<R: BufRead>(source: &mut ValueSource<R>, element: &Element, mesh: &mut SemanticMesh, path: &Path) -> Result<()> {
    let indices = property(element, "vertex_indices")
        .or_else(|| property(element, "vertex_index"))
        .ok_or_else(|| InputError::new(path, "header.face", "faces need a 'vertex_indices' list"))?;
    let object = property(element, "object_id").ok_or_else(|| InputError::new(path, "header.face", "faces need an 'object_id' property"))?;
    for i in 0..element.count {
        source.start_record()?;
        let mut object_id = 0;
        for (k, p) in element.properties.iter().enumerate() {
            match (k, p.list) {
                (k, Some(count_type)) if k == indices => {
                    let len = source.scalar(count_type)? as usize;
                    if len > MAX_FACE_VERTICES {
                        return Err(InputError::new(path, format!("face {i}"), format!("{len} vertices (at most {MAX_FACE_VERTICES})")));
                    }
                    for _ in 0..len {
                        let v = source.scalar(p.value)?;
                        if v < 0.0 || v as usize >= mesh.vertices.len() {
                            return Err(InputError::new(path, format!("face {i}"), format!("vertex index {v} is outside 0..{}", mesh.vertices.len())));
                        }
                        mesh.face_vertices.push(v as u32);
                    }
                }
                (_, Some(_)) => source.skip_list(p)?,
                (k, None) if k == object => object_id = source.scalar(p.value)? as i64,
                (_, None) => {
                    source.scalar(p.value)?;
                }
            }
        }
        mesh.face_offsets.push(mesh.face_vertices.len());
        mesh.face_objects.push(object_id);
    }
    Ok(())
}

/// Read past every record of an element the mesh does not use.
fn skip_element<R: BufRead>(source: &mut ValueSource<R>, element: &Element) -> Result<()> {
    for _ in 0..element.count {
        source.start_record()?;
        for p in &element.properties {
            if p.list.is_some() {
                source.skip_list(p)?;
            } else {
                source.scalar(p.value)?;
            }
        }
    }
    Ok(())
}

fn read_header(reader: &mut impl BufRead, path: &Path) -> Result<(Format, Vec<Element>)> {
    let bad = |m: String| InputError::new(path, "header", m);
    let mut lines = Vec::new();
    let mut ended = false;
    for _ in 0..1024 {
        let mut line = String::new();
        if reader.by_ref().take(4096).read_line(&mut line).map_err(|e| InputError::io(path, &e))? == 0 {
            return Err(bad("file ends before 'end_header'".into()));
        }
        let line = line.trim().to_string();
        if line == "end_header" {
            ended = true;
            break;
        }
        lines.push(line);
    }
    if !ended {
        return Err(bad("no 'end_header' within the first 1024 header lines".into()));
    }
    if lines.first().map(String::as_str) != Some("ply") {
        return Err(bad("not a PLY file (first line must be 'ply')".into()));
    }
    let mut format = None;
    let mut elements: Vec<Element> = Vec::new();
    for line in &lines[1..] {
        let words: Vec<&str> = line.split_whitespace().collect();
        match words.as_slice() {
            ["format", f, _] => {
                format = Some(match *f {
                    "ascii" => Format::Ascii,
                    "binary_little_endian" => Format::Little,
                    "binary_big_endian" => Format::Big,
                    other => return Err(bad(format!("unknown format '{other}'"))),
                })
            }
            ["element", name, count] => elements.push(Element {
                name: name.to_string(),
                count: count.parse().map_err(|_| bad(format!("element '{name}' has a bad count '{count}'")))?,
                properties: Vec::new(),
            }),
            ["property", "list", count_type, value_type, name] => {
                let element = elements.last_mut().ok_or_else(|| bad("property before any element".into()))?;
                let (c, v) = (Scalar::parse(count_type), Scalar::parse(value_type));
                match (c, v) {
                    (Some(c), Some(v)) => element.properties.push(Property { name: name.to_string(), list: Some(c), value: v }),
                    _ => return Err(bad(format!("list property '{name}' has unknown types"))),
                }
            }
            ["property", ty, name] => {
                let element = elements.last_mut().ok_or_else(|| bad("property before any element".into()))?;
                let value = Scalar::parse(ty).ok_or_else(|| bad(format!("property '{name}' has unknown type '{ty}'")))?;
                element.properties.push(Property { name: name.to_string(), list: None, value });
            }
            ["comment", ..] | ["obj_info", ..] | [] => {}
            _ => return Err(bad(format!("unexpected header line '{line}'"))),
        }
    }
    if let Some(e) = elements.iter().find(|e| e.properties.is_empty() && e.count > 0) {
        return Err(bad(format!("element '{}' has {} records but no properties", e.name, e.count)));
    }
    Ok((format.ok_or_else(|| bad("missing 'format' line".into()))?, elements))
}

/// Reads PLY values one at a time in either encoding.
struct ValueSource<'a, R: BufRead> {
    reader: &'a mut R,
    format: Format,
    path: &'a Path,
    line: Vec<String>,
    pos: usize,
}

impl<R: BufRead> ValueSource<'_, R> {
    fn start_record(&mut self) -> Result<()> {
        if self.format == Format::Ascii {
            let mut text = String::new();
            loop {
                text.clear();
                if self.reader.read_line(&mut text).map_err(|e| InputError::io(self.path, &e))? == 0 {
                    return Err(InputError::new(self.path, "data", "file is truncated: fewer records than the header declares"));
                }
                if !text.trim().is_empty() {
                    break;
                }
            }
            self.line = text.split_whitespace().map(str::to_string).collect();
            self.pos = 0;
        }
        Ok(())
    }

    fn scalar(&mut self, ty: Scalar) -> Result<f64> {
        if self.format == Format::Ascii {
            let word = self.line.get(self.pos).ok_or_else(|| InputError::new(self.path, "data", "a record has fewer values than its properties"))?;
            self.pos += 1;
            return word.parse::<f64>().map_err(|_| InputError::new(self.path, "data", format!("'{word}' is not a number")));
        }
        let mut buf = [0u8; 8];
        let bytes = &mut buf[..ty.size()];
        self.reader.read_exact(bytes).map_err(|_| InputError::new(self.path, "data", "file is truncated: fewer records than the header declares"))?;
        if self.format == Format::Big {
            bytes.reverse();
        }
        Ok(match ty {
            Scalar::I8 => bytes[0] as i8 as f64,
            Scalar::U8 => bytes[0] as f64,
            Scalar::I16 => i16::from_le_bytes([bytes[0], bytes[1]]) as f64,
            Scalar::U16 => u16::from_le_bytes([bytes[0], bytes[1]]) as f64,
            Scalar::I32 => i32::from_le_bytes(bytes[..4].try_into().expect("4")) as f64,
            Scalar::U32 => u32::from_le_bytes(bytes[..4].try_into().expect("4")) as f64,
            Scalar::F32 => f32::from_le_bytes(bytes[..4].try_into().expect("4")) as f64,
            Scalar::F64 => f64::from_le_bytes(buf),
        })
    }

    fn skip_list(&mut self, property: &Property) -> Result<()> {
        let len = self.scalar(property.list.expect("list property"))? as usize;
        if len > 1 << 16 {
            return Err(InputError::new(self.path, "data", format!("list '{}' of {len} items is too long", property.name)));
        }
        for _ in 0..len {
            self.scalar(property.value)?;
        }
        Ok(())
    }
}

/// Label every vertex by majority vote of its faces' classes, as the reference does:
/// a face of an unknown object votes -1, a vertex without faces is -1, and any tie
/// for the most votes is -1.
pub fn vertex_labels(mesh: &SemanticMesh, object_classes: &HashMap<i64, i64>) -> Vec<i64> {
    let mut votes: Vec<(u32, i64)> = Vec::with_capacity(mesh.face_vertices.len());
    for (face, &object) in mesh.face_objects.iter().enumerate() {
        let class = object_classes.get(&object).copied().unwrap_or(-1);
        for &v in &mesh.face_vertices[mesh.face_offsets[face]..mesh.face_offsets[face + 1]] {
            votes.push((v, class));
        }
    }
    votes.sort_unstable();
    let mut labels = vec![-1i64; mesh.vertices.len()];
    let mut i = 0;
    while i < votes.len() {
        let vertex = votes[i].0;
        let (mut best, mut best_count, mut tied) = (-1i64, 0usize, false);
        while i < votes.len() && votes[i].0 == vertex {
            let class = votes[i].1;
            let start = i;
            while i < votes.len() && votes[i] == (vertex, class) {
                i += 1;
            }
            let count = i - start;
            if count > best_count {
                (best, best_count, tied) = (class, count, false);
            } else if count == best_count {
                tied = true;
            }
        }
        labels[vertex as usize] = if tied { -1 } else { best };
    }
    labels
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn majority_vote_breaks_ties_to_minus_one() {
        let mesh = SemanticMesh {
            vertices: vec![[0.0; 3]; 5],
            face_vertices: vec![0, 1, 2, 0, 2, 3, 0, 1, 3],
            face_offsets: vec![0, 3, 6, 9],
            face_objects: vec![10, 10, 20],
        };
        let classes = HashMap::from([(10, 7), (20, 9)]);
        // v0: 7,7,9 -> 7; v1: 7,9 -> tie; v2: 7,7 -> 7; v3: 7,9 -> tie; v4: no face.
        assert_eq!(vertex_labels(&mesh, &classes), vec![7, -1, 7, -1, -1]);
    }
}

/// Write `mesh` as `binary_little_endian` PLY with Replica's properties
/// (float x, y, z; `list uchar int vertex_indices`; int `object_id`).
pub fn write_semantic_mesh(path: &Path, mesh: &SemanticMesh) -> Result<()> {
    use std::io::Write;
    let faces = mesh.face_objects.len();
    let mut out = format!(
        "ply\nformat binary_little_endian 1.0\nelement vertex {}\nproperty float x\nproperty float y\nproperty float z\nelement face {faces}\nproperty list uchar int vertex_indices\nproperty int object_id\nend_header\n",
        mesh.vertices.len()
    )
    .into_bytes();
    for v in &mesh.vertices {
        for c in v {
            out.extend_from_slice(&c.to_le_bytes());
        }
    }
    for face in 0..faces {
        let indices = &mesh.face_vertices[mesh.face_offsets[face]..mesh.face_offsets[face + 1]];
        let count = u8::try_from(indices.len()).map_err(|_| InputError::new(path, format!("face {face}"), "more than 255 vertices"))?;
        out.push(count);
        for &i in indices {
            out.extend_from_slice(&(i as i32).to_le_bytes());
        }
        out.extend_from_slice(&(mesh.face_objects[face] as i32).to_le_bytes());
    }
    let mut file = std::io::BufWriter::new(File::create(path).map_err(|e| InputError::io(path, &e))?);
    file.write_all(&out).and_then(|_| file.flush()).map_err(|e| InputError::io(path, &e))
}
