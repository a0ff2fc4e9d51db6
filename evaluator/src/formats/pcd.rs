//! Point Cloud Data (`.pcd`) files as Open3D reads and writes them: `DATA binary`
//! (what Open3D writes by default), `ascii` and `binary_compressed` are read;
//! binary is written, byte for byte as Open3D 0.20 writes it (`rgb` as `TYPE U`, the
//! bytes B, G, R, 0; older Open3D wrote the same bytes as `TYPE F`, also read).
//!
//! One file, over 400 lines, on purpose: one format in three encodings, read and
//! written, so the byte layouts sit side by side.

use std::fs::File;
use std::io::{BufRead, BufReader, BufWriter, Read, Write};
use std::path::Path;

use crate::error::{InputError, Result};

const MAX_HEADER_LINES: usize = 64;
/// Largest `COUNT` of one field and largest record, in bytes.
const MAX_FIELD_COUNT: usize = 4096;
const MAX_RECORD_BYTES: usize = 65_536;
const MAX_HEADER_LINE_BYTES: usize = 4096;
const RECORDS_PER_CHUNK: usize = 1 << 16;

/// A point cloud: float32 positions, optionally with 8-bit colours.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct PointCloud {
    /// Positions, one `[x, y, z]` per point.
    pub points: Vec<[f32; 3]>,
    /// Colours `[r, g, b]` aligned with `points`, when the file has an `rgb` field.
    pub colors: Option<Vec<[u8; 3]>>,
}

#[derive(Debug, Clone, Copy, PartialEq)]
enum Encoding {
    Ascii,
    Binary,
    BinaryCompressed,
}

#[derive(Debug, Clone)]
struct Field {
    name: String,
    size: usize,
    kind: char,
    count: usize,
}

#[derive(Debug)]
struct Header {
    fields: Vec<Field>,
    points: usize,
    encoding: Encoding,
}

impl Header {
    fn record_size(&self) -> usize {
        self.fields.iter().map(|f| f.size * f.count).sum()
    }

    /// Byte offset of a field inside one record, with the field.
    fn locate(&self, name: &str) -> Option<(usize, &Field)> {
        let mut offset = 0;
        for field in &self.fields {
            if field.name == name {
                return Some((offset, field));
            }
            offset += field.size * field.count;
        }
        None
    }
}

/// Read a `.pcd` file.
pub fn read_pcd(path: &Path) -> Result<PointCloud> {
    let file = File::open(path).map_err(|e| InputError::io(path, &e))?;
    let mut reader = BufReader::with_capacity(1 << 20, file);
    let header = read_header(&mut reader, path)?;
    match header.encoding {
        Encoding::Binary => read_binary(&mut reader, &header, path),
        Encoding::Ascii => read_ascii(&mut reader, &header, path),
        Encoding::BinaryCompressed => read_compressed(&mut reader, &header, path),
    }
}

fn read_header(reader: &mut impl BufRead, path: &Path) -> Result<Header> {
    let mut said = HeaderLines::default();
    for _ in 0..MAX_HEADER_LINES {
        let line = next_header_line(reader, path)?;
        let line = line.trim();
        if line.is_empty() || line.starts_with('#') {
            continue;
        }
        let mut words = line.split_whitespace();
        let key = words.next().unwrap_or_default().to_ascii_uppercase();
        let values: Vec<&str> = words.collect();
        if key == "DATA" {
            let encoding = match values.first().map(|s| s.to_ascii_lowercase()).as_deref() {
                Some("ascii") => Encoding::Ascii,
                Some("binary") => Encoding::Binary,
                Some("binary_compressed") => Encoding::BinaryCompressed,
                other => return Err(header_error(path, "DATA", format!("expected ascii, binary or binary_compressed, found '{}'", other.unwrap_or("")))),
            };
            return said.into_header(encoding, path);
        }
        said.take(&key, &values, path)?;
    }
    Err(header_error(path, "DATA", format!("no DATA line within the first {MAX_HEADER_LINES} header lines")))
}

/// The error of header line `field` of the file at `path`.
fn header_error(path: &Path, field: &str, msg: String) -> InputError {
    InputError::new(path, format!("header.{field}"), msg)
}

/// The next line of the header as text (at most [`MAX_HEADER_LINE_BYTES`]).
fn next_header_line(reader: &mut impl BufRead, path: &Path) -> Result<String> {
    let mut line = Vec::new();
    let read = reader.take(MAX_HEADER_LINE_BYTES as u64).read_until(b'\n', &mut line).map_err(|e| InputError::io(path, &e))?;
    if read == 0 {
        return Err(header_error(path, "DATA", "file ends before the header's DATA line".into()));
    }
    if !line.ends_with(b"\n") && line.len() >= MAX_HEADER_LINE_BYTES {
        return Err(header_error(path, "line", format!("header line longer than {MAX_HEADER_LINE_BYTES} bytes")));
    }
    String::from_utf8(line).map_err(|_| header_error(path, "line", "header is not text; is this a PCD file?".into()))
}

/// What the header's lines before DATA have said.
#[derive(Default)]
struct HeaderLines {
    fields: Vec<String>,
    sizes: Vec<usize>,
    types: Vec<char>,
    counts: Vec<usize>,
    width: Option<usize>,
    height: Option<usize>,
    points: Option<usize>,
}

impl HeaderLines {
    /// Take the line `key values` (any keyword but DATA).
    fn take(&mut self, key: &str, values: &[&str], path: &Path) -> Result<()> {
        let bad = |field: &str, msg: String| header_error(path, field, msg);
        let number = |key: &str, v: &[&str]| -> Result<usize> {
            v.first().and_then(|s| s.parse().ok()).ok_or_else(|| bad(key, format!("expected a non-negative integer, found '{}'", v.join(" "))))
        };
        match key {
            "VERSION" | "VIEWPOINT" => {}
            "FIELDS" => self.fields = values.iter().map(|s| s.to_string()).collect(),
            "SIZE" => {
                self.sizes = values
                    .iter()
                    .map(|s| s.parse::<usize>())
                    .collect::<std::result::Result<_, _>>()
                    .map_err(|_| bad("SIZE", "sizes must be 1, 2, 4 or 8".into()))?
            }
            "TYPE" => self.types = values.iter().map(|s| s.chars().next().unwrap_or('?').to_ascii_uppercase()).collect(),
            "COUNT" => {
                self.counts = values
                    .iter()
                    .map(|s| s.parse::<usize>())
                    .collect::<std::result::Result<_, _>>()
                    .map_err(|_| bad("COUNT", "counts must be positive integers".into()))?
            }
            "WIDTH" => self.width = Some(number("WIDTH", values)?),
            "HEIGHT" => self.height = Some(number("HEIGHT", values)?),
            "POINTS" => self.points = Some(number("POINTS", values)?),
            other => return Err(bad("line", format!("unknown header keyword '{other}'"))),
        }
        Ok(())
    }

    /// The header these lines and the DATA line's `encoding` describe, checked: its fields
    /// (supported types, x, y and z single floats) and its number of points.
    fn into_header(self, encoding: Encoding, path: &Path) -> Result<Header> {
        let bad = |field: &str, msg: String| header_error(path, field, msg);
        let HeaderLines { fields, sizes, types, mut counts, width, height, points } = self;
        if counts.is_empty() {
            counts = vec![1; fields.len()];
        }
        if fields.is_empty() || sizes.len() != fields.len() || types.len() != fields.len() || counts.len() != fields.len() {
            return Err(bad(
                "FIELDS",
                format!(
                    "FIELDS ({}), SIZE ({}), TYPE ({}) and COUNT ({}) must list the same number of entries",
                    fields.len(),
                    sizes.len(),
                    types.len(),
                    counts.len()
                ),
            ));
        }
        let fields: Vec<Field> =
            fields.into_iter().zip(sizes).zip(types).zip(counts).map(|(((name, size), kind), count)| Field { name, size, kind, count }).collect();
        for f in &fields {
            let valid = matches!((f.kind, f.size), ('F', 4 | 8) | ('I' | 'U', 1 | 2 | 4 | 8));
            if !valid || f.count == 0 || f.count > MAX_FIELD_COUNT {
                return Err(bad("TYPE", format!("field '{}' has unsupported type {}{} x {} (counts 1..={MAX_FIELD_COUNT})", f.name, f.kind, f.size, f.count)));
            }
        }
        let record: usize = fields.iter().map(|f| f.size * f.count).sum();
        if record > MAX_RECORD_BYTES {
            return Err(bad("SIZE", format!("records of {record} bytes are larger than {MAX_RECORD_BYTES}")));
        }
        let points = match (points, width, height) {
            (Some(p), _, _) => p,
            (None, Some(w), Some(h)) => w.checked_mul(h).ok_or_else(|| bad("POINTS", "WIDTH x HEIGHT overflows".into()))?,
            _ => return Err(bad("POINTS", "missing POINTS (or WIDTH and HEIGHT)".into())),
        };
        if let (Some(w), Some(h)) = (width, height)
            && w.checked_mul(h) != Some(points)
        {
            return Err(bad("POINTS", format!("POINTS {points} disagrees with WIDTH {w} x HEIGHT {h}")));
        }
        let header = Header { fields, points, encoding };
        for axis in ["x", "y", "z"] {
            match header.locate(axis) {
                Some((_, f)) if f.kind == 'F' && f.count == 1 => {}
                Some(_) => return Err(bad("FIELDS", format!("field '{axis}' must be a single float"))),
                None => {
                    return Err(bad(
                        "FIELDS",
                        format!("missing field '{axis}' (found: {})", header.fields.iter().map(|f| f.name.as_str()).collect::<Vec<_>>().join(" ")),
                    ));
                }
            }
        }
        Ok(header)
    }
}

fn float_at(bytes: &[u8], size: usize) -> f32 {
    if size == 4 { f32::from_le_bytes(bytes[..4].try_into().expect("4 bytes")) } else { f64::from_le_bytes(bytes[..8].try_into().expect("8 bytes")) as f32 }
}

/// Open3D packs colours into a float's bytes as B, G, R, 0.
fn unpack_rgb(bytes: [u8; 4]) -> [u8; 3] {
    [bytes[2], bytes[1], bytes[0]]
}

fn check_finite(point: [f32; 3], index: usize, path: &Path) -> Result<()> {
    if point.iter().all(|v| v.is_finite()) {
        Ok(())
    } else {
        Err(InputError::new(path, "data", format!("point {index} has a non-finite coordinate {point:?}")))
    }
}

fn rgb_field(header: &Header) -> Option<usize> {
    header.locate("rgb").or_else(|| header.locate("rgba")).filter(|(_, f)| f.size == 4 && f.count == 1).map(|(offset, _)| offset)
}

fn read_binary(reader: &mut impl Read, header: &Header, path: &Path) -> Result<PointCloud> {
    let record = header.record_size();
    let axes: Vec<(usize, usize)> = ["x", "y", "z"].iter().map(|a| header.locate(a).map(|(o, f)| (o, f.size)).expect("checked")).collect();
    let rgb = rgb_field(header);
    let mut points = Vec::with_capacity(header.points.min(1 << 24));
    let mut colors = rgb.map(|_| Vec::with_capacity(header.points.min(1 << 24)));
    let mut buf = vec![0u8; record * RECORDS_PER_CHUNK.min(header.points.max(1))];
    let mut remaining = header.points;
    while remaining > 0 {
        let take = remaining.min(RECORDS_PER_CHUNK);
        let bytes = &mut buf[..take * record];
        reader.read_exact(bytes).map_err(|_| {
            InputError::new(path, "data", format!("file is truncated: the header declares {} points but only {} are present", header.points, points.len()))
        })?;
        for rec in bytes.chunks_exact(record) {
            let p = [float_at(&rec[axes[0].0..], axes[0].1), float_at(&rec[axes[1].0..], axes[1].1), float_at(&rec[axes[2].0..], axes[2].1)];
            check_finite(p, points.len(), path)?;
            points.push(p);
            if let (Some(offset), Some(colors)) = (rgb, colors.as_mut()) {
                colors.push(unpack_rgb(rec[offset..offset + 4].try_into().expect("4 bytes")));
            }
        }
        remaining -= take;
    }
    let mut probe = [0u8; 1];
    if reader.read(&mut probe).map_err(|e| InputError::io(path, &e))? != 0 {
        return Err(InputError::new(path, "data", format!("file holds more data than the {} points its header declares", header.points)));
    }
    Ok(PointCloud { points, colors })
}

fn read_ascii(reader: &mut impl BufRead, header: &Header, path: &Path) -> Result<PointCloud> {
    // Column of each field's first value in a line.
    let mut columns = Vec::new();
    let mut col = 0;
    for f in &header.fields {
        columns.push(col);
        col += f.count;
    }
    let total_columns = col;
    let column_of = |name: &str| header.fields.iter().position(|f| f.name == name).map(|i| columns[i]);
    let (cx, cy, cz) = (column_of("x").expect("checked"), column_of("y").expect("checked"), column_of("z").expect("checked"));
    let rgb = column_of("rgb").or_else(|| column_of("rgba")).filter(|_| rgb_field(header).is_some());
    let rgb_is_float = header.locate("rgb").or_else(|| header.locate("rgba")).is_some_and(|(_, f)| f.kind == 'F');
    let mut points = Vec::with_capacity(header.points.min(1 << 24));
    let mut colors = rgb.map(|_| Vec::new());
    let mut line = String::new();
    while points.len() < header.points {
        line.clear();
        if reader.read_line(&mut line).map_err(|e| InputError::io(path, &e))? == 0 {
            return Err(InputError::new(
                path,
                "data",
                format!("file is truncated: the header declares {} points but only {} are present", header.points, points.len()),
            ));
        }
        let values: Vec<&str> = line.split_whitespace().collect();
        if values.is_empty() {
            continue;
        }
        let index = points.len();
        if values.len() != total_columns {
            return Err(InputError::new(path, format!("point {index}"), format!("expected {total_columns} values, found {}", values.len())));
        }
        let parse = |c: usize| -> Result<f32> {
            values[c].parse::<f64>().map(|v| v as f32).map_err(|_| InputError::new(path, format!("point {index}"), format!("'{}' is not a number", values[c])))
        };
        let p = [parse(cx)?, parse(cy)?, parse(cz)?];
        check_finite(p, index, path)?;
        points.push(p);
        if let (Some(c), Some(colors)) = (rgb, colors.as_mut()) {
            let bad = || InputError::new(path, format!("point {index}"), format!("rgb '{}' is not a packed colour", values[c]));
            let bytes = if rgb_is_float {
                values[c].parse::<f32>().map_err(|_| bad())?.to_le_bytes()
            } else {
                values[c].parse::<u32>().map_err(|_| bad())?.to_le_bytes()
            };
            colors.push(unpack_rgb(bytes));
        }
    }
    Ok(PointCloud { points, colors })
}

fn read_compressed(reader: &mut impl Read, header: &Header, path: &Path) -> Result<PointCloud> {
    let mut sizes = [0u8; 8];
    reader.read_exact(&mut sizes).map_err(|_| InputError::new(path, "data", "file is truncated before the compressed block sizes"))?;
    let compressed = u32::from_le_bytes(sizes[..4].try_into().expect("4")) as usize;
    let uncompressed = u32::from_le_bytes(sizes[4..].try_into().expect("4")) as usize;
    let record = header.record_size();
    let expected = header.points.checked_mul(record).ok_or_else(|| InputError::new(path, "header.POINTS", "point count overflows"))?;
    if uncompressed != expected {
        return Err(InputError::new(
            path,
            "data",
            format!("compressed block unpacks to {uncompressed} bytes, but {} points of {record} bytes need {expected}", header.points),
        ));
    }
    let mut packed = Vec::with_capacity(compressed.min(1 << 24));
    reader.take(compressed as u64).read_to_end(&mut packed).map_err(|e| InputError::io(path, &e))?;
    if packed.len() != compressed {
        return Err(InputError::new(path, "data", "file is truncated inside the compressed block"));
    }
    let raw = lzf_decompress(&packed, uncompressed).map_err(|m| InputError::new(path, "data", m))?;
    // Compressed PCD stores fields column by column: all x, then all y, ...
    let mut field_start = Vec::new();
    let mut start = 0;
    for f in &header.fields {
        field_start.push(start);
        start += f.size * f.count * header.points;
    }
    let column = |name: &str| -> Option<(usize, usize)> {
        let i = header.fields.iter().position(|f| f.name == name)?;
        Some((field_start[i], header.fields[i].size * header.fields[i].count))
    };
    let axes: Vec<(usize, usize)> = ["x", "y", "z"].iter().map(|a| column(a).expect("checked")).collect();
    let rgb = rgb_field(header).and_then(|_| column("rgb").or_else(|| column("rgba")));
    let mut points = Vec::with_capacity(header.points);
    let mut colors = rgb.map(|_| Vec::with_capacity(header.points));
    // `raw` has exactly points × record bytes, so the header's count is now backed by data.
    for i in 0..header.points {
        let p = [
            float_at(&raw[axes[0].0 + i * axes[0].1..], axes[0].1),
            float_at(&raw[axes[1].0 + i * axes[1].1..], axes[1].1),
            float_at(&raw[axes[2].0 + i * axes[2].1..], axes[2].1),
        ];
        check_finite(p, i, path)?;
        points.push(p);
        if let (Some((start, _)), Some(colors)) = (rgb, colors.as_mut()) {
            colors.push(unpack_rgb(raw[start + 4 * i..start + 4 * i + 4].try_into().expect("4 bytes")));
        }
    }
    Ok(PointCloud { points, colors })
}

/// LZF decompression (the codec of PCL's `binary_compressed`).
fn lzf_decompress(input: &[u8], output_len: usize) -> std::result::Result<Vec<u8>, String> {
    let corrupt = || "compressed block is corrupt".to_string();
    // LZF expands at most ~90x: never reserve more than the input can produce.
    let mut out = Vec::with_capacity(output_len.min(input.len().saturating_mul(96)));
    let mut i = 0;
    while i < input.len() {
        let ctrl = input[i] as usize;
        i += 1;
        if ctrl < 32 {
            let len = ctrl + 1;
            let literal = input.get(i..i + len).ok_or_else(corrupt)?;
            out.extend_from_slice(literal);
            i += len;
        } else {
            let mut len = ctrl >> 5;
            if len == 7 {
                len += *input.get(i).ok_or_else(corrupt)? as usize;
                i += 1;
            }
            let back = ((ctrl & 0x1f) << 8) + *input.get(i).ok_or_else(corrupt)? as usize + 1;
            i += 1;
            let start = out.len().checked_sub(back).ok_or_else(corrupt)?;
            for k in 0..len + 2 {
                out.push(out[start + k]);
            }
        }
        if out.len() > output_len {
            return Err(corrupt());
        }
    }
    if out.len() != output_len {
        return Err(corrupt());
    }
    Ok(out)
}

/// Write `cloud` as Open3D does (`DATA binary`, float32 xyz, `rgb` packed as a float).
pub fn write_pcd(path: &Path, cloud: &PointCloud) -> Result<()> {
    let file = File::create(path).map_err(|e| InputError::io(path, &e))?;
    let mut w = BufWriter::with_capacity(1 << 20, file);
    let n = cloud.points.len();
    let (fields, sizes, types, counts) =
        if cloud.colors.is_some() { ("x y z rgb", "4 4 4 4", "F F F U", "1 1 1 1") } else { ("x y z", "4 4 4", "F F F", "1 1 1") };
    let header = format!(
        "# .PCD v0.7 - Point Cloud Data file format\nVERSION 0.7\nFIELDS {fields}\nSIZE {sizes}\nTYPE {types}\nCOUNT {counts}\nWIDTH {n}\nHEIGHT 1\nVIEWPOINT 0 0 0 1 0 0 0\nPOINTS {n}\nDATA binary\n"
    );
    let io = |e: std::io::Error| InputError::io(path, &e);
    w.write_all(header.as_bytes()).map_err(io)?;
    let mut buf = Vec::with_capacity(16 * RECORDS_PER_CHUNK);
    for start in (0..n).step_by(RECORDS_PER_CHUNK) {
        buf.clear();
        for i in start..(start + RECORDS_PER_CHUNK).min(n) {
            for v in cloud.points[i] {
                buf.extend_from_slice(&v.to_le_bytes());
            }
            if let Some(colors) = &cloud.colors {
                let [r, g, b] = colors[i];
                buf.extend_from_slice(&[b, g, r, 0]);
            }
        }
        w.write_all(&buf).map_err(io)?;
    }
    w.flush().map_err(io)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn lzf_round_trips_a_known_stream() {
        // Literal 'a', then a back-reference of 7 + 0 + 2 = 9 bytes at distance 1.
        let out = lzf_decompress(&[0, b'a', 0xE0, 0, 0], 10).unwrap();
        assert_eq!(out, b"aaaaaaaaaa");
    }

    #[test]
    fn corrupt_lzf_is_an_error() {
        assert!(lzf_decompress(&[0x20, 0x05], 4).is_err());
    }
}
