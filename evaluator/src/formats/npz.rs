//! NumPy `.npz` archives (a zip of `.npy` members), as written by `np.savez` and
//! `np.savez_compressed`.

use std::fs::File;
use std::io::{BufReader, BufWriter, Write};
use std::path::{Path, PathBuf};

use zip::ZipArchive;
use zip::write::SimpleFileOptions;

use super::npy::{Dtype, NpyArray, ReadLimits, ensure_at_end, read_npy, read_npy_shape, write_npy};
use crate::error::{InputError, Result};

/// An opened `.npz` archive whose arrays are read on demand.
pub struct NpzReader {
    path: PathBuf,
    archive: ZipArchive<BufReader<File>>,
    limits: ReadLimits,
    /// Bytes of array bodies read so far (bounded by `limits.max_archive_bytes`).
    read_bytes: u64,
}

impl NpzReader {
    /// Open `path`, checking that it is a zip archive that starts where the file does, as
    /// NumPy reads it: `np.load` takes a file for an `.npz` only by its first bytes (a zip
    /// member's or an empty zip's signature), so data before the archive (a polyglot, an
    /// `.npz` wrapped in a tar) is refused, though a zip reader that searches from the end
    /// would find the archive inside.
    pub fn open(path: &Path, limits: ReadLimits) -> Result<Self> {
        let mut file = File::open(path).map_err(|e| InputError::io(path, &e))?;
        let mut start = [0u8; 4];
        let complete = std::io::Read::read_exact(&mut file, &mut start).is_ok();
        if !complete || !(start == *b"PK\x03\x04" || start == *b"PK\x05\x06") {
            return Err(InputError::new(
                path,
                "(archive)",
                "not an .npz: it must start with a zip signature ('PK\\x03\\x04'), as np.load requires; this file has other data first \
                 (another format, or an .npz inside another archive)",
            ));
        }
        std::io::Seek::rewind(&mut file).map_err(|e| InputError::io(path, &e))?;
        let archive =
            ZipArchive::new(BufReader::new(file)).map_err(|e| InputError::new(path, "(archive)", format!("not a readable .npz (zip) archive: {e}")))?;
        if archive.offset() != 0 {
            return Err(InputError::new(
                path,
                "(archive)",
                format!("not an .npz: its zip archive starts {} bytes into the file, after data np.load would not skip", archive.offset()),
            ));
        }
        Ok(Self { path: path.to_path_buf(), archive, limits, read_bytes: 0 })
    }

    /// Names of the arrays in the archive (member names without `.npy`), sorted.
    pub fn keys(&self) -> Vec<String> {
        let mut keys: Vec<String> = self.archive.file_names().filter_map(|n| n.ok()).filter_map(|n| n.strip_suffix(".npy").map(str::to_string)).collect();
        keys.sort();
        keys
    }

    /// Whether the archive holds array `key`.
    pub fn contains(&self, key: &str) -> bool {
        self.archive.index_for_name(&format!("{key}.npy")).is_some()
    }

    /// The element type and shape of array `key` (its header only), if the archive holds it.
    pub fn shape(&mut self, key: &str) -> Result<Option<(Dtype, Vec<usize>)>> {
        let member = format!("{key}.npy");
        let label = PathBuf::from(format!("{}:{member}", self.path.display()));
        let mut entry = match self.archive.by_name(&member) {
            Ok(entry) => entry,
            Err(zip::result::ZipError::FileNotFound) => return Ok(None),
            Err(e) => return Err(InputError::new(&label, "(member)", format!("cannot read: {e}"))),
        };
        read_npy_shape(&mut entry, &label).map(Some)
    }

    /// Read array `key`; a missing array is an error that lists what is there.
    pub fn array(&mut self, key: &str) -> Result<NpyArray> {
        let member = format!("{key}.npy");
        let label = PathBuf::from(format!("{}:{member}", self.path.display()));
        let keys = self.keys();
        let mut entry = match self.archive.by_name(&member) {
            Ok(entry) => entry,
            Err(zip::result::ZipError::FileNotFound) => {
                return Err(InputError::new(&self.path, key, format!("array '{key}' is missing (the archive holds: {})", list_or_none(&keys))));
            }
            Err(e) => return Err(InputError::new(&label, "(member)", format!("cannot read: {e}"))),
        };
        if entry.size() > self.limits.max_array_bytes.saturating_add(1 << 20) {
            return Err(InputError::new(
                &label,
                "(member)",
                format!("member of {} bytes is larger than the limit of {} bytes", entry.size(), self.limits.max_array_bytes),
            ));
        }
        let remaining = self.limits.max_archive_bytes.saturating_sub(self.read_bytes);
        let limits = ReadLimits { max_array_bytes: self.limits.max_array_bytes.min(remaining), ..self.limits };
        let array = read_npy(&mut entry, &label, limits)?;
        ensure_at_end(&mut entry, &label)?;
        self.read_bytes += (array.shape.iter().product::<usize>() * array.dtype().size()) as u64;
        Ok(array)
    }
}

fn list_or_none(keys: &[String]) -> String {
    if keys.is_empty() { "no arrays".into() } else { keys.join(", ") }
}

/// Write `arrays` as an `.npz` archive; `compress` chooses `np.savez_compressed`'s
/// deflate over `np.savez`'s stored members.
pub fn write_npz(path: &Path, arrays: &[(&str, &NpyArray)], compress: bool) -> Result<()> {
    let file = File::create(path).map_err(|e| InputError::io(path, &e))?;
    let mut zip = zip::ZipWriter::new(BufWriter::with_capacity(1 << 20, file));
    let method = if compress { zip::CompressionMethod::Deflated } else { zip::CompressionMethod::Stored };
    let options = SimpleFileOptions::default().compression_method(method).large_file(true);
    let zip_error = |e: zip::result::ZipError| InputError::new(path, "(archive)", format!("cannot write: {e}"));
    for (name, array) in arrays {
        zip.start_file(format!("{name}.npy"), options).map_err(zip_error)?;
        write_npy(&mut zip, array).map_err(|e| InputError::io(path, &e))?;
    }
    let mut inner = zip.finish().map_err(zip_error)?;
    inner.flush().map_err(|e| InputError::io(path, &e))
}
