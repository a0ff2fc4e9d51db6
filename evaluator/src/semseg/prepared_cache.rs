//! Ground truth prepared for scoring, kept on disk: a scene's points and labels already in
//! Z-order, so every submission scored on a node after the first reads them back instead
//! of reading the release's cloud and ordering it again (most of a scene's fixed cost).
//!
//! An entry belongs to the very files it was made from: its header holds their paths,
//! sizes and modification times, and it is used only while they still match; its payload
//! carries a CRC-32, so a damaged entry is a miss, never a wrong score. Entries are written
//! to a temporary file of their own and renamed, so concurrent workers never read one half
//! written (and one a crash leaves unflushed fails its CRC). The cache keeps at most `capacity` bytes, dropping the entries used
//! longest ago. Nothing here is ever an error for the caller: a cache that cannot be read
//! or written only costs the time it would have saved.

use std::io::{Read, Seek, SeekFrom, Write};
use std::path::{Path, PathBuf};
use std::time::{SystemTime, UNIX_EPOCH};

use rayon::prelude::*;

use super::PreparedGroundTruth;
use super::reused_buffers::resize_to_overwrite;
use crate::formats::classes::ClassList;

/// First bytes of an entry (the trailing digit is the format's version).
const MAGIC: &[u8; 8] = b"OSMABZG1";
/// File name extension of entries.
const EXTENSION: &str = "zgt";
/// Age after which a temporary file is taken to be abandoned (an entry is written in seconds).
const ABANDONED_AFTER: std::time::Duration = std::time::Duration::from_secs(3600);
/// Bytes of the fixed part of the header after the identity: point count, label width, CRC-32.
const COUNTS: usize = 8 + 1 + 4;

/// A directory of prepared ground truths, at most `capacity` bytes.
#[derive(Debug, Clone)]
pub struct PreparedCache {
    dir: PathBuf,
    capacity: u64,
}

/// The files a prepared ground truth is made from, as they are now: canonical paths,
/// sizes and modification times.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct CacheKey {
    identity: String,
}

impl CacheKey {
    /// The key of the ground truth in `gt_dir` (`pointcloud.pcd` + `semantic.npy`), or
    /// `None` when either cannot be looked at (the scorer's read then says why).
    pub fn of(gt_dir: &Path) -> Option<Self> {
        let mut identity = String::new();
        for name in ["pointcloud.pcd", "semantic.npy"] {
            let path = std::fs::canonicalize(gt_dir.join(name)).ok()?;
            let meta = std::fs::metadata(&path).ok()?;
            let modified = meta.modified().ok()?.duration_since(UNIX_EPOCH).ok()?;
            identity.push_str(&format!("{}\t{}\t{}.{:09}\n", path.display(), meta.len(), modified.as_secs(), modified.subsec_nanos()));
        }
        Some(Self { identity })
    }

    /// The entry's file name: a hash of the identity (the header holds the identity
    /// itself, so a collision is a miss).
    fn file_name(&self) -> String {
        // FNV-1a, 64 bits: stable across builds, unlike std's hasher.
        let hash = self.identity.bytes().fold(0xcbf2_9ce4_8422_2325u64, |h, b| (h ^ u64::from(b)).wrapping_mul(0x0100_0000_01b3));
        format!("{hash:016x}.{EXTENSION}")
    }
}

/// Why an entry was not used or not stored (for the caller's log).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct CacheMiss(pub String);

impl PreparedCache {
    /// A cache in `dir` (created when first stored to) holding at most `capacity` bytes.
    pub fn new(dir: impl Into<PathBuf>, capacity: u64) -> Self {
        Self { dir: dir.into(), capacity }
    }

    /// The prepared ground truth stored under `key`, checked against `classes` as a
    /// freshly read one is; `Err` says why there is none to use.
    pub fn load(&self, key: &CacheKey, gt_dir: &Path, classes: &ClassList) -> Result<PreparedGroundTruth, CacheMiss> {
        self.load_reusing(key, gt_dir, classes, None)
    }

    /// [`PreparedCache::load`] into the memory of `spare`, a prepared ground truth no longer
    /// needed (the scene scored before), where it is large enough: a scorer reads scene after
    /// scene into the same memory (see [`crate::semseg::scratch`]).
    pub fn load_reusing(
        &self,
        key: &CacheKey,
        gt_dir: &Path,
        classes: &ClassList,
        spare: Option<PreparedGroundTruth>,
    ) -> Result<PreparedGroundTruth, CacheMiss> {
        let path = self.dir.join(key.file_name());
        if !path.is_file() {
            return Err(CacheMiss("not cached yet".into()));
        }
        let buffers = spare.map(PreparedGroundTruth::into_buffers).unwrap_or_default();
        let (points, labels) = read_entry(&path, key, buffers).map_err(|why| CacheMiss(format!("{}: {why}", path.display())))?;
        // Marks the entry as used (eviction drops the least recently used first).
        if let Ok(file) = std::fs::File::options().append(true).open(&path) {
            let _ = file.set_modified(SystemTime::now());
        }
        PreparedGroundTruth::from_z_ordered(gt_dir, points, labels, classes).map_err(|e| CacheMiss(e.to_string()))
    }

    /// Whether an entry stored under `key` is there, whole in length (its payload's CRC is
    /// checked when it is loaded).
    pub fn holds(&self, key: &CacheKey) -> bool {
        read_header(&self.dir.join(key.file_name()), key).is_ok()
    }

    /// Store `prepared` under `key`, then drop the entries used longest ago while the
    /// cache holds more than its capacity.
    pub fn store(&self, key: &CacheKey, prepared: &PreparedGroundTruth) -> Result<(), CacheMiss> {
        let fail = |what: &str, e: std::io::Error| CacheMiss(format!("{what} {}: {e}", self.dir.display()));
        std::fs::create_dir_all(&self.dir).map_err(|e| fail("creating", e))?;
        let layout = Layout::of(key, prepared);
        if layout.file_len > self.capacity {
            return Err(CacheMiss(format!("an entry of {} bytes is larger than the cache's capacity of {} bytes", layout.file_len, self.capacity)));
        }
        let name = key.file_name();
        static STORES: std::sync::atomic::AtomicU64 = std::sync::atomic::AtomicU64::new(0);
        let serial = STORES.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
        let temporary = self.dir.join(format!(".{name}.{}-{serial}.tmp", std::process::id()));
        // Synced for the time it takes, not for safety (an entry a crash leaves half on disk
        // fails its CRC and is made again): the disk's time is spent here, by whoever keeps
        // the entry (a thread beside the scoring, an idle worker), and not later by whatever
        // writes next. Left to the kernel's write-back, a full release's 4 GB of entries
        // stalled the next submission's unpacking by 25 s.
        let written = write_entry(&temporary, key, prepared, &layout);
        if let Err(e) = written.and_then(|()| std::fs::rename(&temporary, self.dir.join(&name))) {
            let _ = std::fs::remove_file(&temporary);
            return Err(fail("writing to", e));
        }
        self.evict(&name);
        Ok(())
    }

    /// Drop the least recently used entries (never `keep`) while the cache is over capacity,
    /// and temporary files an hour old (left by a process killed while it wrote them).
    fn evict(&self, keep: &str) {
        let Ok(entries) = std::fs::read_dir(&self.dir) else { return };
        let entries: Vec<std::fs::DirEntry> = entries.flatten().collect();
        let abandoned = |e: &std::fs::DirEntry| {
            let name = e.file_name();
            let name = name.to_string_lossy();
            let age = e.metadata().and_then(|m| m.modified()).ok().and_then(|t| t.elapsed().ok());
            name.starts_with('.') && name.ends_with(".tmp") && age.is_some_and(|age| age > ABANDONED_AFTER)
        };
        for temporary in entries.iter().filter(|e| abandoned(e)) {
            let _ = std::fs::remove_file(temporary.path());
        }
        let mut entries: Vec<(SystemTime, u64, PathBuf)> = entries
            .iter()
            .filter(|e| e.path().extension().is_some_and(|x| x == EXTENSION))
            .filter_map(|e| {
                let meta = e.metadata().ok()?;
                Some((meta.modified().ok()?, meta.len(), e.path()))
            })
            .collect();
        let mut total: u64 = entries.iter().map(|(_, len, _)| len).sum();
        entries.sort();
        for (_, len, path) in entries {
            if total <= self.capacity {
                break;
            }
            if path.file_name().is_some_and(|n| n == keep) {
                continue;
            }
            if std::fs::remove_file(&path).is_ok() {
                total -= len;
            }
        }
    }
}

/// Where the parts of an entry go. The header (magic, identity, point count, label width,
/// CRC-32 of the payload) comes first, then the payload: every point's x, y, z as
/// little-endian f32, then every label as little-endian i32 (width 4) or i64 (width 8,
/// when a label does not fit in 32 bits).
struct Layout {
    /// Bytes of the header.
    header_len: u64,
    /// Bytes of each label.
    width: usize,
    /// Bytes of the whole entry.
    file_len: u64,
}

impl Layout {
    fn of(key: &CacheKey, prepared: &PreparedGroundTruth) -> Self {
        let narrow = prepared.labels().iter().all(|&l| i32::try_from(l).is_ok());
        let width = if narrow { 4 } else { 8 };
        let header_len = (MAGIC.len() + 4 + key.identity.len() + COUNTS) as u64;
        Self { header_len, width, file_len: header_len + prepared.len() as u64 * (12 + width as u64) }
    }
}

/// Write the entry of `prepared` for `key` to a new file at `path`, the payload encoded
/// a chunk at a time (this runs beside the scoring, on a thread of its own: one core's
/// worth of encoding keeps up with the disk), the header last.
fn write_entry(path: &Path, key: &CacheKey, prepared: &PreparedGroundTruth, layout: &Layout) -> std::io::Result<()> {
    let (points, labels) = (prepared.points(), prepared.labels());
    let mut file = std::fs::File::create(path)?;
    file.seek(SeekFrom::Start(layout.header_len))?;
    let mut crc = flate2::Crc::new();
    let mut bytes = Vec::with_capacity(READ_CHUNK * 12);
    for chunk in points.chunks(READ_CHUNK) {
        bytes.clear();
        chunk.iter().flatten().for_each(|c| bytes.extend_from_slice(&c.to_le_bytes()));
        crc.update(&bytes);
        file.write_all(&bytes)?;
    }
    for chunk in labels.chunks(READ_CHUNK) {
        bytes.clear();
        if layout.width == 4 {
            chunk.iter().for_each(|&l| bytes.extend_from_slice(&(l as i32).to_le_bytes()));
        } else {
            chunk.iter().for_each(|&l| bytes.extend_from_slice(&l.to_le_bytes()));
        }
        crc.update(&bytes);
        file.write_all(&bytes)?;
    }
    let mut header = Vec::with_capacity(layout.header_len as usize);
    header.extend_from_slice(MAGIC);
    header.extend_from_slice(&(key.identity.len() as u32).to_le_bytes());
    header.extend_from_slice(key.identity.as_bytes());
    header.extend_from_slice(&(points.len() as u64).to_le_bytes());
    header.push(layout.width as u8);
    header.extend_from_slice(&crc.sum().to_le_bytes());
    file.seek(SeekFrom::Start(0))?;
    file.write_all(&header)?;
    file.sync_data()
}

/// Points encoded at once when writing, read and decoded by one task when reading.
const READ_CHUNK: usize = 1 << 16;

/// What an entry's header says, checked against `key` and the file's length.
struct Header {
    /// Bytes of the header.
    len: usize,
    /// Points in the entry.
    count: usize,
    /// Bytes of each label.
    width: usize,
    /// CRC-32 of the payload.
    crc: u32,
}

/// The header of the entry at `path`, or why the entry cannot be the one made for `key`.
fn read_header(path: &Path, key: &CacheKey) -> Result<Header, String> {
    let mut file = std::fs::File::open(path).map_err(|e| e.to_string())?;
    let file_len = file.metadata().map_err(|e| e.to_string())?.len();
    let identity = key.identity.as_bytes();
    let header_len = MAGIC.len() + 4 + identity.len() + COUNTS;
    let mut header = vec![0u8; header_len];
    let got = read_up_to(&mut file, &mut header).map_err(|e| e.to_string())?;
    let header = &header[..got];
    let take = |at: usize, n: usize| header.get(at..at + n).ok_or_else(|| format!("truncated at byte {at}"));
    if take(0, MAGIC.len())? != MAGIC {
        return Err("not a prepared ground truth of this version".into());
    }
    let identity_len = u32::from_le_bytes(take(8, 4)?.try_into().expect("4 bytes")) as usize;
    if identity_len != identity.len() || take(12, identity_len)? != identity {
        return Err("made from other files".into());
    }
    let at = 12 + identity_len;
    let count = u64::from_le_bytes(take(at, 8)?.try_into().expect("8 bytes"));
    let width = take(at + 8, 1)?[0] as usize;
    let crc = u32::from_le_bytes(take(at + 9, 4)?.try_into().expect("4 bytes"));
    if width != 4 && width != 8 {
        return Err(format!("label width {width}, expected 4 or 8"));
    }
    let payload = file_len - header_len as u64;
    let expected = count.checked_mul(12 + width as u64).ok_or("a point count beyond memory")?;
    if payload != expected || count == 0 || usize::try_from(count).is_err() {
        return Err(format!("{payload} payload bytes for {count} points, expected {expected}"));
    }
    Ok(Header { len: header_len, count: count as usize, width, crc })
}

/// The points and labels of the entry at `path` made for `key`, or why it cannot be used:
/// read in chunks by all cores, each decoded while it is in cache, into `buffers` (points and
/// labels, of any length: every element is overwritten).
fn read_entry(path: &Path, key: &CacheKey, buffers: (Vec<[f32; 3]>, Vec<i64>)) -> Result<(Vec<[f32; 3]>, Vec<i64>), String> {
    let Header { len: header_len, count, width, crc } = read_header(path, key)?;
    let (points_at, labels_at) = (header_len as u64, (header_len + 12 * count) as u64);
    let (mut points, mut labels) = buffers;
    resize_to_overwrite(&mut points, count);
    resize_to_overwrite(&mut labels, count);
    let chunks: Vec<(flate2::Crc, flate2::Crc)> = points
        .par_chunks_mut(READ_CHUNK)
        .zip(labels.par_chunks_mut(READ_CHUNK))
        .enumerate()
        .map(|(c, (points, labels))| -> std::io::Result<(flate2::Crc, flate2::Crc)> {
            let first = (c * READ_CHUNK) as u64;
            let mut file = std::fs::File::open(path)?;
            let mut bytes = vec![0u8; points.len() * 12];
            file.seek(SeekFrom::Start(points_at + first * 12))?;
            file.read_exact(&mut bytes)?;
            let mut points_crc = flate2::Crc::new();
            points_crc.update(&bytes);
            let f = |b: &[u8]| f32::from_le_bytes(b.try_into().expect("4 bytes"));
            for (p, b) in points.iter_mut().zip(bytes.chunks_exact(12)) {
                *p = [f(&b[0..4]), f(&b[4..8]), f(&b[8..12])];
            }
            bytes.resize(labels.len() * width, 0);
            file.seek(SeekFrom::Start(labels_at + first * width as u64))?;
            file.read_exact(&mut bytes)?;
            let mut labels_crc = flate2::Crc::new();
            labels_crc.update(&bytes);
            if width == 4 {
                labels.iter_mut().zip(bytes.chunks_exact(4)).for_each(|(l, b)| *l = i64::from(i32::from_le_bytes(b.try_into().expect("4 bytes"))));
            } else {
                labels.iter_mut().zip(bytes.chunks_exact(8)).for_each(|(l, b)| *l = i64::from_le_bytes(b.try_into().expect("8 bytes")));
            }
            Ok((points_crc, labels_crc))
        })
        .collect::<std::io::Result<_>>()
        .map_err(|e| e.to_string())?;
    // The payload's CRC: the points' chunks in order, then the labels'.
    let mut whole = flate2::Crc::new();
    for (points_crc, _) in &chunks {
        whole.combine(points_crc);
    }
    for (_, labels_crc) in &chunks {
        whole.combine(labels_crc);
    }
    if whole.sum() != crc {
        return Err("damaged (CRC-32 mismatch)".into());
    }
    Ok((points, labels))
}

/// Fill as much of `buffer` as `file` has; returns how much.
fn read_up_to(file: &mut std::fs::File, buffer: &mut [u8]) -> std::io::Result<usize> {
    let mut filled = 0;
    while filled < buffer.len() {
        match file.read(&mut buffer[filled..])? {
            0 => break,
            n => filled += n,
        }
    }
    Ok(filled)
}
