//! NumPy `.npy` arrays: a strict reader for outside data and a writer that produces
//! what `np.save` writes.
//!
//! The reader never trusts the header: the element count must fit the limits, the
//! data is read in bounded chunks (a lying header cannot make it allocate more than
//! the bytes that actually arrive), and a short or overlong body is an error.
//!
//! One file, over 400 lines, on purpose: the reader and the writer share the header grammar,
//! and the strict reader's checks are the format's reference here.

use std::io::{Read, Write};
use std::path::Path;

use crate::error::{InputError, Result};

const MAGIC: &[u8; 6] = b"\x93NUMPY";
/// Longest header accepted; NumPy itself refuses headers above 10 000 bytes by default.
const MAX_HEADER_LEN: usize = 65_536;
/// Bytes read per chunk while converting to typed elements.
const CHUNK_BYTES: usize = 1 << 20;

/// Upper bounds on what a reader accepts from one file.
#[derive(Debug, Clone, Copy)]
pub struct ReadLimits {
    /// Largest array body in bytes.
    pub max_array_bytes: u64,
    /// Largest sum of the array bodies read from one `.npz` archive.
    pub max_archive_bytes: u64,
    /// Most points a map may hold (the service: one per pixel of the scene's sequence).
    pub max_points: u64,
}

impl Default for ReadLimits {
    /// Generous limits for local files; the service sets its own per submission.
    fn default() -> Self {
        Self { max_array_bytes: 16 << 30, max_archive_bytes: 32 << 30, max_points: u64::MAX }
    }
}

/// Element type of an array, as named by its `descr` (byte order handled separately).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Dtype {
    Bool,
    I8,
    U8,
    I16,
    U16,
    I32,
    U32,
    I64,
    U64,
    F32,
    F64,
}

impl Dtype {
    /// Bytes per element.
    pub fn size(self) -> usize {
        match self {
            Dtype::Bool | Dtype::I8 | Dtype::U8 => 1,
            Dtype::I16 | Dtype::U16 => 2,
            Dtype::I32 | Dtype::U32 | Dtype::F32 => 4,
            Dtype::I64 | Dtype::U64 | Dtype::F64 => 8,
        }
    }

    fn code(self) -> &'static str {
        match self {
            Dtype::Bool => "b1",
            Dtype::I8 => "i1",
            Dtype::U8 => "u1",
            Dtype::I16 => "i2",
            Dtype::U16 => "u2",
            Dtype::I32 => "i4",
            Dtype::U32 => "u4",
            Dtype::I64 => "i8",
            Dtype::U64 => "u8",
            Dtype::F32 => "f4",
            Dtype::F64 => "f8",
        }
    }

    fn from_code(code: &str) -> Option<Self> {
        Some(match code {
            "b1" => Dtype::Bool,
            "i1" => Dtype::I8,
            "u1" => Dtype::U8,
            "i2" => Dtype::I16,
            "u2" => Dtype::U16,
            "i4" => Dtype::I32,
            "u4" => Dtype::U32,
            "i8" => Dtype::I64,
            "u8" => Dtype::U64,
            "f4" => Dtype::F32,
            "f8" => Dtype::F64,
            _ => return None,
        })
    }

    /// NumPy's name for the type (`float32`, `int64`, ...), for messages.
    pub fn name(self) -> &'static str {
        match self {
            Dtype::Bool => "bool",
            Dtype::I8 => "int8",
            Dtype::U8 => "uint8",
            Dtype::I16 => "int16",
            Dtype::U16 => "uint16",
            Dtype::I32 => "int32",
            Dtype::U32 => "uint32",
            Dtype::I64 => "int64",
            Dtype::U64 => "uint64",
            Dtype::F32 => "float32",
            Dtype::F64 => "float64",
        }
    }
}

/// The typed contents of an array, in C (row-major) order.
#[derive(Debug, Clone, PartialEq)]
pub enum NpyData {
    Bool(Vec<bool>),
    I8(Vec<i8>),
    U8(Vec<u8>),
    I16(Vec<i16>),
    U16(Vec<u16>),
    I32(Vec<i32>),
    U32(Vec<u32>),
    I64(Vec<i64>),
    U64(Vec<u64>),
    F32(Vec<f32>),
    F64(Vec<f64>),
}

/// An n-dimensional array read from or written to `.npy`.
#[derive(Debug, Clone, PartialEq)]
pub struct NpyArray {
    /// Dimensions, outermost first.
    pub shape: Vec<usize>,
    /// Elements in row-major order.
    pub data: NpyData,
}

impl NpyArray {
    /// A 1-D int64 array.
    pub fn from_i64(values: Vec<i64>) -> Self {
        Self { shape: vec![values.len()], data: NpyData::I64(values) }
    }

    /// A 2-D float32 array of `rows` × `cols`.
    pub fn from_f32_matrix(rows: usize, cols: usize, values: Vec<f32>) -> Self {
        assert_eq!(rows * cols, values.len(), "matrix shape does not match its data");
        Self { shape: vec![rows, cols], data: NpyData::F32(values) }
    }

    /// The element type.
    pub fn dtype(&self) -> Dtype {
        match &self.data {
            NpyData::Bool(_) => Dtype::Bool,
            NpyData::I8(_) => Dtype::I8,
            NpyData::U8(_) => Dtype::U8,
            NpyData::I16(_) => Dtype::I16,
            NpyData::U16(_) => Dtype::U16,
            NpyData::I32(_) => Dtype::I32,
            NpyData::U32(_) => Dtype::U32,
            NpyData::I64(_) => Dtype::I64,
            NpyData::U64(_) => Dtype::U64,
            NpyData::F32(_) => Dtype::F32,
            NpyData::F64(_) => Dtype::F64,
        }
    }

    fn shape_text(&self) -> String {
        shape_repr(&self.shape)
    }

    /// A 1-D integer array as int64 (any integer dtype is accepted).
    pub fn into_i64_vec(self, file: &Path, field: &str) -> Result<Vec<i64>> {
        if self.shape.len() != 1 {
            return Err(InputError::new(file, field, format!("expected a 1-D integer array, found shape {}", self.shape_text())));
        }
        let dtype = self.dtype();
        let values = match self.data {
            NpyData::I64(v) => v,
            NpyData::I32(v) => v.into_iter().map(i64::from).collect(),
            NpyData::I16(v) => v.into_iter().map(i64::from).collect(),
            NpyData::I8(v) => v.into_iter().map(i64::from).collect(),
            NpyData::U8(v) => v.into_iter().map(i64::from).collect(),
            NpyData::U16(v) => v.into_iter().map(i64::from).collect(),
            NpyData::U32(v) => v.into_iter().map(i64::from).collect(),
            NpyData::U64(v) => v
                .into_iter()
                .map(|x| i64::try_from(x))
                .collect::<std::result::Result<_, _>>()
                .map_err(|_| InputError::new(file, field, "uint64 value does not fit in int64"))?,
            _ => {
                return Err(InputError::new(file, field, format!("expected an integer array (int64), found {}", dtype.name())));
            }
        };
        Ok(values)
    }

    /// A 2-D float array as float32 rows of `cols` columns (`cols` = None accepts any
    /// width). float64 is converted; NaN and infinity are rejected with their position.
    pub fn into_f32_matrix(self, file: &Path, field: &str, cols: Option<usize>) -> Result<(usize, usize, Vec<f32>)> {
        let expected = match cols {
            Some(c) => format!("an (N, {c}) float32 or float64 array"),
            None => "an (N, D) float32 array".to_string(),
        };
        if self.shape.len() != 2 || cols.is_some_and(|c| self.shape[1] != c) {
            return Err(InputError::new(file, field, format!("expected {expected}, found shape {}", self.shape_text())));
        }
        let (rows, width) = (self.shape[0], self.shape[1]);
        let dtype = self.dtype();
        let values: Vec<f32> = match self.data {
            NpyData::F32(v) => v,
            NpyData::F64(v) => {
                if let Some(pos) = v.iter().position(|x| x.is_finite() && (x.abs() as f32).is_infinite()) {
                    return Err(InputError::new(
                        file,
                        field,
                        format!("row {}, column {} is {}, outside the float32 range", pos / width.max(1), pos % width.max(1), v[pos]),
                    ));
                }
                v.into_iter().map(|x| x as f32).collect()
            }
            _ => {
                return Err(InputError::new(file, field, format!("expected {expected}, found dtype {}", dtype.name())));
            }
        };
        if let Some(pos) = values.iter().position(|x| !x.is_finite()) {
            return Err(InputError::new(
                file,
                field,
                format!("row {}, column {} is {}; every value must be a finite number", pos / width.max(1), pos % width.max(1), values[pos]),
            ));
        }
        Ok((rows, width, values))
    }
}

fn shape_repr(shape: &[usize]) -> String {
    match shape {
        [one] => format!("({one},)"),
        _ => format!("({})", shape.iter().map(|d| d.to_string()).collect::<Vec<_>>().join(", ")),
    }
}

/// Parsed `.npy` header.
#[derive(Debug, Clone, PartialEq, Eq)]
struct Header {
    dtype: Dtype,
    big_endian: bool,
    fortran_order: bool,
    shape: Vec<usize>,
}

/// Read one `.npy` array from `reader`; `file` names it in errors.
pub fn read_npy(reader: &mut impl Read, file: &Path, limits: ReadLimits) -> Result<NpyArray> {
    let header = read_header(reader, file)?;
    let count = header
        .shape
        .iter()
        .try_fold(1usize, |acc, &d| acc.checked_mul(d))
        .filter(|&n| (n as u64).saturating_mul(header.dtype.size() as u64) <= limits.max_array_bytes)
        .ok_or_else(|| {
            InputError::new(
                file,
                "header.shape",
                format!("array of shape {} is larger than the limit of {} bytes", shape_repr(&header.shape), limits.max_array_bytes),
            )
        })?;
    let data = read_body(reader, file, header.dtype, header.big_endian, count)?;
    let mut array = NpyArray { shape: header.shape.clone(), data };
    if header.fortran_order && array.shape.len() > 1 {
        array = fortran_to_c_order(array);
    }
    Ok(array)
}

/// Read a whole `.npy` file.
pub fn read_npy_file(path: &Path, limits: ReadLimits) -> Result<NpyArray> {
    let file = std::fs::File::open(path).map_err(|e| InputError::io(path, &e))?;
    let mut reader = std::io::BufReader::with_capacity(CHUNK_BYTES, file);
    let array = read_npy(&mut reader, path, limits)?;
    ensure_at_end(&mut reader, path)?;
    Ok(array)
}

/// Error unless `reader` has nothing left: a body longer than its header is corrupt.
pub fn ensure_at_end(reader: &mut impl Read, file: &Path) -> Result<()> {
    let mut probe = [0u8; 1];
    match reader.read(&mut probe) {
        Ok(0) => Ok(()),
        Ok(_) => Err(InputError::new(file, "data", "file is longer than its header's shape and dtype declare")),
        Err(e) => Err(InputError::io(file, &e)),
    }
}

/// The element type and shape an `.npy` stream declares, read from its header only (no
/// body byte is read).
pub fn read_npy_shape(reader: &mut impl Read, file: &Path) -> Result<(Dtype, Vec<usize>)> {
    let header = read_header(reader, file)?;
    Ok((header.dtype, header.shape))
}

fn read_header(reader: &mut impl Read, file: &Path) -> Result<Header> {
    let mut preamble = [0u8; 8];
    reader.read_exact(&mut preamble).map_err(|_| InputError::new(file, "header", "not a NumPy .npy file (shorter than the 8-byte preamble)"))?;
    if &preamble[..6] != MAGIC {
        return Err(InputError::new(file, "header", "not a NumPy .npy file (magic string \\x93NUMPY missing)"));
    }
    let major = preamble[6];
    let header_len = match major {
        1 => {
            let mut len = [0u8; 2];
            reader.read_exact(&mut len).map_err(|e| InputError::io(file, &e))?;
            u16::from_le_bytes(len) as usize
        }
        2 | 3 => {
            let mut len = [0u8; 4];
            reader.read_exact(&mut len).map_err(|e| InputError::io(file, &e))?;
            u32::from_le_bytes(len) as usize
        }
        other => {
            return Err(InputError::new(file, "header.version", format!("unsupported .npy format version {other} (expected 1, 2 or 3)")));
        }
    };
    if header_len > MAX_HEADER_LEN {
        return Err(InputError::new(file, "header", format!("header of {header_len} bytes is too long (at most {MAX_HEADER_LEN})")));
    }
    let mut text = vec![0u8; header_len];
    reader.read_exact(&mut text).map_err(|_| InputError::new(file, "header", "file is truncated inside the header"))?;
    let text = String::from_utf8(text).map_err(|_| InputError::new(file, "header", "header is not valid text"))?;
    parse_header(&text, file)
}

/// Parse the Python dict literal `{'descr': '<f4', 'fortran_order': False, 'shape': (3, 4), }`.
fn parse_header(text: &str, file: &Path) -> Result<Header> {
    let bad = |field: &str, msg: &str| InputError::new(file, format!("header.{field}"), msg.to_string());
    let body = text.trim().strip_prefix('{').and_then(|t| t.strip_suffix('}')).ok_or_else(|| bad("dict", "header is not a Python dict literal"))?;
    let value_of = |key: &str| -> Option<&str> {
        let start = body.find(&format!("'{key}'")).or_else(|| body.find(&format!("\"{key}\"")))?;
        let rest = &body[start + key.len() + 2..];
        Some(rest.trim_start().strip_prefix(':')?.trim_start())
    };
    let descr = value_of("descr").ok_or_else(|| bad("descr", "missing 'descr'"))?;
    let quote = descr.chars().next().filter(|c| *c == '\'' || *c == '"').ok_or_else(|| bad("descr", "expected a dtype string such as '<f4'"))?;
    let descr = &descr[1..descr[1..].find(quote).map(|i| i + 1).ok_or_else(|| bad("descr", "unterminated dtype string"))?];
    let (order, code) = match descr.chars().next() {
        Some(c @ ('<' | '>' | '|' | '=')) => (c, &descr[1..]),
        _ => ('=', descr),
    };
    let dtype = Dtype::from_code(code)
        .ok_or_else(|| bad("descr", &format!("unsupported dtype '{descr}' (expected a plain bool, integer or float type such as '<f4' or '<i8')")))?;
    let big_endian = order == '>' && dtype.size() > 1;

    let fortran = value_of("fortran_order").ok_or_else(|| bad("fortran_order", "missing 'fortran_order'"))?;
    let fortran_order = if fortran.starts_with("True") {
        true
    } else if fortran.starts_with("False") {
        false
    } else {
        return Err(bad("fortran_order", "expected True or False"));
    };

    let shape_text = value_of("shape").ok_or_else(|| bad("shape", "missing 'shape'"))?;
    let shape_text =
        shape_text.strip_prefix('(').and_then(|t| t.split_once(')')).map(|(inner, _)| inner).ok_or_else(|| bad("shape", "expected a tuple such as (3, 4)"))?;
    let shape = shape_text
        .split(',')
        .map(str::trim)
        .filter(|s| !s.is_empty())
        .map(|s| s.trim_end_matches('L').parse::<usize>())
        .collect::<std::result::Result<Vec<_>, _>>()
        .map_err(|_| bad("shape", "dimensions must be non-negative integers"))?;
    Ok(Header { dtype, big_endian, fortran_order, shape })
}

trait Element: Copy + Default {
    const SIZE: usize;
    fn decode(bytes: &[u8], big_endian: bool) -> Self;
}

macro_rules! element {
    ($t:ty) => {
        impl Element for $t {
            const SIZE: usize = std::mem::size_of::<$t>();
            fn decode(bytes: &[u8], big_endian: bool) -> Self {
                let raw = bytes.try_into().expect("chunk has the element's size");
                if big_endian { <$t>::from_be_bytes(raw) } else { <$t>::from_le_bytes(raw) }
            }
        }
    };
}
element!(i8);
element!(u8);
element!(i16);
element!(u16);
element!(i32);
element!(u32);
element!(i64);
element!(u64);
element!(f32);
element!(f64);

/// Read `count` elements in bounded chunks: memory grows only as data arrives.
fn read_elements<T: Element>(reader: &mut impl Read, file: &Path, count: usize, big_endian: bool) -> Result<Vec<T>> {
    let mut out = Vec::with_capacity(count.min(CHUNK_BYTES / T::SIZE * 16));
    let mut buf = vec![0u8; CHUNK_BYTES - CHUNK_BYTES % T::SIZE];
    let mut remaining = count;
    while remaining > 0 {
        let take = remaining.min(buf.len() / T::SIZE);
        let bytes = &mut buf[..take * T::SIZE];
        reader.read_exact(bytes).map_err(|e| {
            if e.kind() == std::io::ErrorKind::UnexpectedEof {
                InputError::new(file, "data", format!("file is truncated: the header declares {count} elements but fewer are present"))
            } else {
                InputError::io(file, &e)
            }
        })?;
        out.extend(bytes.chunks_exact(T::SIZE).map(|c| T::decode(c, big_endian)));
        remaining -= take;
    }
    Ok(out)
}

fn read_body(reader: &mut impl Read, file: &Path, dtype: Dtype, big_endian: bool, count: usize) -> Result<NpyData> {
    Ok(match dtype {
        Dtype::Bool => {
            let raw: Vec<u8> = read_elements(reader, file, count, false)?;
            if raw.iter().any(|&b| b > 1) {
                return Err(InputError::new(file, "data", "bool array holds values other than 0 and 1"));
            }
            NpyData::Bool(raw.into_iter().map(|b| b == 1).collect())
        }
        Dtype::I8 => NpyData::I8(read_elements(reader, file, count, big_endian)?),
        Dtype::U8 => NpyData::U8(read_elements(reader, file, count, big_endian)?),
        Dtype::I16 => NpyData::I16(read_elements(reader, file, count, big_endian)?),
        Dtype::U16 => NpyData::U16(read_elements(reader, file, count, big_endian)?),
        Dtype::I32 => NpyData::I32(read_elements(reader, file, count, big_endian)?),
        Dtype::U32 => NpyData::U32(read_elements(reader, file, count, big_endian)?),
        Dtype::I64 => NpyData::I64(read_elements(reader, file, count, big_endian)?),
        Dtype::U64 => NpyData::U64(read_elements(reader, file, count, big_endian)?),
        Dtype::F32 => NpyData::F32(read_elements(reader, file, count, big_endian)?),
        Dtype::F64 => NpyData::F64(read_elements(reader, file, count, big_endian)?),
    })
}

/// Reorder a column-major array into row-major order.
fn fortran_to_c_order(array: NpyArray) -> NpyArray {
    fn reorder<T: Copy>(values: &[T], shape: &[usize]) -> Vec<T> {
        let n = values.len();
        let mut out = Vec::with_capacity(n);
        let mut index = vec![0usize; shape.len()];
        for _ in 0..n {
            // Column-major offset of the current row-major index.
            let mut offset = 0;
            let mut stride = 1;
            for (i, &d) in index.iter().zip(shape) {
                offset += i * stride;
                stride *= d;
            }
            out.push(values[offset]);
            for axis in (0..shape.len()).rev() {
                index[axis] += 1;
                if index[axis] < shape[axis] {
                    break;
                }
                index[axis] = 0;
            }
        }
        out
    }
    let shape = array.shape.clone();
    let data = match array.data {
        NpyData::Bool(v) => NpyData::Bool(reorder(&v, &shape)),
        NpyData::I8(v) => NpyData::I8(reorder(&v, &shape)),
        NpyData::U8(v) => NpyData::U8(reorder(&v, &shape)),
        NpyData::I16(v) => NpyData::I16(reorder(&v, &shape)),
        NpyData::U16(v) => NpyData::U16(reorder(&v, &shape)),
        NpyData::I32(v) => NpyData::I32(reorder(&v, &shape)),
        NpyData::U32(v) => NpyData::U32(reorder(&v, &shape)),
        NpyData::I64(v) => NpyData::I64(reorder(&v, &shape)),
        NpyData::U64(v) => NpyData::U64(reorder(&v, &shape)),
        NpyData::F32(v) => NpyData::F32(reorder(&v, &shape)),
        NpyData::F64(v) => NpyData::F64(reorder(&v, &shape)),
    };
    NpyArray { shape, data }
}

/// The header `np.save` writes for this array (format 1.0, 64-byte aligned).
fn header_bytes(array: &NpyArray) -> Vec<u8> {
    let dtype = array.dtype();
    let order = if dtype.size() == 1 { '|' } else { '<' };
    let mut dict = format!("{{'descr': '{order}{}', 'fortran_order': False, 'shape': {}, }}", dtype.code(), shape_repr(&array.shape));
    // NumPy leaves room for the first axis to grow in place (GROWTH_AXIS_MAX_DIGITS = 21).
    if let Some(first) = array.shape.first() {
        dict.push_str(&" ".repeat(21usize.saturating_sub(first.to_string().len())));
    }
    let unpadded = MAGIC.len() + 2 + 2 + dict.len() + 1;
    dict.push_str(&" ".repeat((64 - unpadded % 64) % 64));
    dict.push('\n');
    let mut out = Vec::with_capacity(10 + dict.len());
    out.extend_from_slice(MAGIC);
    out.extend_from_slice(&[1, 0]);
    out.extend_from_slice(&(dict.len() as u16).to_le_bytes());
    out.extend_from_slice(dict.as_bytes());
    out
}

/// Write `array` in `.npy` format (little-endian, C order).
pub fn write_npy(writer: &mut impl Write, array: &NpyArray) -> std::io::Result<()> {
    writer.write_all(&header_bytes(array))?;
    macro_rules! body {
        ($v:expr) => {{
            let mut buf = Vec::with_capacity(CHUNK_BYTES);
            for chunk in $v.chunks(CHUNK_BYTES / 8) {
                buf.clear();
                for x in chunk {
                    buf.extend_from_slice(&x.to_le_bytes());
                }
                writer.write_all(&buf)?;
            }
        }};
    }
    match &array.data {
        NpyData::Bool(v) => writer.write_all(&v.iter().map(|&b| b as u8).collect::<Vec<_>>())?,
        NpyData::I8(v) => body!(v),
        NpyData::U8(v) => writer.write_all(v)?,
        NpyData::I16(v) => body!(v),
        NpyData::U16(v) => body!(v),
        NpyData::I32(v) => body!(v),
        NpyData::U32(v) => body!(v),
        NpyData::I64(v) => body!(v),
        NpyData::U64(v) => body!(v),
        NpyData::F32(v) => body!(v),
        NpyData::F64(v) => body!(v),
    }
    Ok(())
}

/// Write `array` to a `.npy` file.
pub fn write_npy_file(path: &Path, array: &NpyArray) -> Result<()> {
    let file = std::fs::File::create(path).map_err(|e| InputError::io(path, &e))?;
    let mut writer = std::io::BufWriter::with_capacity(CHUNK_BYTES, file);
    write_npy(&mut writer, array).and_then(|_| writer.flush()).map_err(|e| InputError::io(path, &e))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn roundtrip(array: &NpyArray) -> NpyArray {
        let mut bytes = Vec::new();
        write_npy(&mut bytes, array).unwrap();
        assert_eq!((bytes.len() - array_bytes(array)) % 64, 0, "header is 64-byte aligned");
        read_npy(&mut bytes.as_slice(), Path::new("a.npy"), ReadLimits::default()).unwrap()
    }

    fn array_bytes(array: &NpyArray) -> usize {
        array.shape.iter().product::<usize>() * array.dtype().size()
    }

    #[test]
    fn arrays_survive_a_write_and_read() {
        let labels = NpyArray::from_i64(vec![3, -1, 7]);
        assert_eq!(roundtrip(&labels), labels);
        let points = NpyArray::from_f32_matrix(2, 3, vec![0.5, 1.0, -2.0, 3.25, 4.0, 5.0]);
        assert_eq!(roundtrip(&points), points);
    }

    #[test]
    fn header_is_what_numpy_writes() {
        let bytes = header_bytes(&NpyArray::from_i64(vec![1, 2]));
        let text = String::from_utf8_lossy(&bytes[10..]);
        assert!(text.starts_with("{'descr': '<i8', 'fortran_order': False, 'shape': (2,), }"));
        assert!(text.ends_with('\n'));
        assert_eq!(bytes.len() % 64, 0);
    }

    #[test]
    fn fortran_order_arrays_are_reordered() {
        let header = "{'descr': '<i8', 'fortran_order': True, 'shape': (2, 3), }";
        let mut bytes = MAGIC.to_vec();
        bytes.extend_from_slice(&[1, 0]);
        bytes.extend_from_slice(&(header.len() as u16).to_le_bytes());
        bytes.extend_from_slice(header.as_bytes());
        // Column-major storage of [[1, 2, 3], [4, 5, 6]].
        for v in [1i64, 4, 2, 5, 3, 6] {
            bytes.extend_from_slice(&v.to_le_bytes());
        }
        let array = read_npy(&mut bytes.as_slice(), Path::new("f.npy"), ReadLimits::default()).unwrap();
        assert_eq!(array.data, NpyData::I64(vec![1, 2, 3, 4, 5, 6]));
    }

    #[test]
    fn hostile_headers_are_rejected_before_allocation() {
        let header = "{'descr': '<f8', 'fortran_order': False, 'shape': (100000000000000, 3), }";
        let mut bytes = MAGIC.to_vec();
        bytes.extend_from_slice(&[1, 0]);
        bytes.extend_from_slice(&(header.len() as u16).to_le_bytes());
        bytes.extend_from_slice(header.as_bytes());
        let err = read_npy(&mut bytes.as_slice(), Path::new("h.npy"), ReadLimits::default()).unwrap_err();
        assert_eq!(err.field, "header.shape");
        assert!(err.message.contains("larger than the limit"), "{err}");
    }

    #[test]
    fn truncated_bodies_are_reported() {
        let mut bytes = Vec::new();
        write_npy(&mut bytes, &NpyArray::from_i64(vec![1, 2, 3])).unwrap();
        bytes.truncate(bytes.len() - 4);
        let err = read_npy(&mut bytes.as_slice(), Path::new("t.npy"), ReadLimits::default()).unwrap_err();
        assert_eq!(err.field, "data");
        assert!(err.message.contains("truncated"), "{err}");
    }

    #[test]
    fn unsupported_dtypes_are_named() {
        let header = "{'descr': '<c16', 'fortran_order': False, 'shape': (1,), }";
        let err = parse_header(header, Path::new("c.npy")).unwrap_err();
        assert_eq!(err.field, "header.descr");
        assert!(err.message.contains("'<c16'"));
    }
}
