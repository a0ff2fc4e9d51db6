//! A zip's central directory read on its own, entry by entry: the zip reader keeps one
//! entry per name (a later copy silently replaces an earlier one), so whether an archive
//! names a file twice can only be told from the directory itself. ZIP64 archives (whose
//! counts and offsets live in the ZIP64 end record) are read the same way; an archive whose
//! entries cannot all be listed is refused rather than trusted.

use std::collections::HashSet;
use std::fs::File;
use std::io::{BufReader, Read, Seek, SeekFrom};
use std::path::Path;

use crate::error::{InputError, Result};

const END: &[u8; 4] = b"PK\x05\x06";
const END_LEN: usize = 22;
const ZIP64_LOCATOR: &[u8; 4] = b"PK\x06\x07";
const ZIP64_LOCATOR_LEN: u64 = 20;
const ZIP64_END: &[u8; 4] = b"PK\x06\x06";
const ENTRY: &[u8; 4] = b"PK\x01\x02";
const ENTRY_LEN: usize = 46;

/// Where the central directory lies and how many entries it declares.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
struct Directory {
    entries: u64,
    offset: u64,
    size: u64,
}

/// Check that every entry of the central directory of the zip at `path` can be read, that
/// there are at most `max_entries`, and that no name appears twice.
pub fn check_names_are_unique(path: &Path, max_entries: usize) -> Result<()> {
    let refuse = |why: String| InputError::new(path, "(archive)", format!("refused: {why}"));
    let mut file = File::open(path).map_err(|e| InputError::io(path, &e))?;
    let directory =
        locate(&mut file).map_err(|why| refuse(format!("the zip's central directory cannot be read ({why}), so its entries cannot all be listed")))?;
    if directory.entries > max_entries as u64 {
        return Err(InputError::new(path, "(archive)", format!("more than {max_entries} entries, the most this archive may hold")));
    }
    file.seek(SeekFrom::Start(directory.offset)).map_err(|e| InputError::io(path, &e))?;
    let mut reader = BufReader::new(file).take(directory.size);
    let mut seen = HashSet::new();
    for k in 0..directory.entries {
        let name = read_entry_name(&mut reader).map_err(|why| {
            refuse(format!("entry {k} of the {} the central directory declares cannot be read ({why}), so its entries cannot all be listed", directory.entries))
        })?;
        if !seen.insert(name.clone()) {
            return Err(InputError::new(path, String::from_utf8_lossy(&name).into_owned(), "refused: the zip archive holds this name twice"));
        }
    }
    Ok(())
}

/// One central-directory record: its name, with the rest of the record skipped.
fn read_entry_name(reader: &mut impl Read) -> std::result::Result<Vec<u8>, String> {
    let mut fixed = [0u8; ENTRY_LEN];
    reader.read_exact(&mut fixed).map_err(|_| "the directory ends early".to_string())?;
    if &fixed[..4] != ENTRY {
        return Err("no entry signature where one belongs".into());
    }
    let length = |at: usize| u16::from_le_bytes([fixed[at], fixed[at + 1]]) as usize;
    let (name_len, extra_len, comment_len) = (length(28), length(30), length(32));
    let mut name = vec![0u8; name_len];
    reader.read_exact(&mut name).map_err(|_| "the directory ends inside a name".to_string())?;
    let rest = (extra_len + comment_len) as u64;
    let skipped = std::io::copy(&mut reader.take(rest), &mut std::io::sink()).map_err(|e| e.to_string())?;
    if skipped != rest {
        return Err("the directory ends inside an entry".into());
    }
    Ok(name)
}

/// The central directory of the zip in `file`, from its end record (or, where that record
/// defers to it, the ZIP64 end record).
fn locate(file: &mut File) -> std::result::Result<Directory, String> {
    let size = file.seek(SeekFrom::End(0)).map_err(|e| e.to_string())?;
    let tail_len = size.min((END_LEN + u16::MAX as usize) as u64);
    let tail_start = size - tail_len;
    file.seek(SeekFrom::Start(tail_start)).map_err(|e| e.to_string())?;
    let mut tail = Vec::with_capacity(tail_len as usize);
    file.read_to_end(&mut tail).map_err(|e| e.to_string())?;
    // The last end signature whose comment runs exactly to the end of the file.
    let at = (0..tail.len().saturating_sub(END_LEN - 1))
        .rev()
        .find(|&i| &tail[i..i + 4] == END && i + END_LEN + u16::from_le_bytes([tail[i + 20], tail[i + 21]]) as usize == tail.len())
        .ok_or("no end-of-central-directory record")?;
    let record = &tail[at..at + END_LEN];
    let u16_at = |k: usize| u16::from_le_bytes([record[k], record[k + 1]]);
    let u32_at = |k: usize| u32::from_le_bytes([record[k], record[k + 1], record[k + 2], record[k + 3]]);
    let (entries, dir_size, offset) = (u16_at(10), u32_at(12), u32_at(16));
    if u16_at(4) != 0 || u16_at(6) != 0 {
        return Err("a multi-disk archive".into());
    }
    let end_at = tail_start + at as u64;
    if entries != u16::MAX && dir_size != u32::MAX && offset != u32::MAX {
        return within(Directory { entries: entries as u64, offset: offset as u64, size: dir_size as u64 }, end_at);
    }
    // ZIP64: the locator sits just before the end record and points at the ZIP64 end record.
    let locator_at = end_at.checked_sub(ZIP64_LOCATOR_LEN).ok_or("a ZIP64 count without its ZIP64 records")?;
    let mut locator = [0u8; ZIP64_LOCATOR_LEN as usize];
    read_at(file, locator_at, &mut locator)?;
    if &locator[..4] != ZIP64_LOCATOR {
        return Err("a ZIP64 count without its ZIP64 locator".into());
    }
    let record_at = u64::from_le_bytes(locator[8..16].try_into().expect("8 bytes"));
    let mut record = [0u8; 56];
    if record_at.checked_add(56).is_none_or(|end| end > locator_at) {
        return Err("the ZIP64 end record lies outside the archive".into());
    }
    read_at(file, record_at, &mut record)?;
    if &record[..4] != ZIP64_END {
        return Err("no ZIP64 end record where the locator points".into());
    }
    let u64_at = |k: usize| u64::from_le_bytes(record[k..k + 8].try_into().expect("8 bytes"));
    within(Directory { entries: u64_at(32), size: u64_at(40), offset: u64_at(48) }, record_at)
}

/// `directory`, if it ends at or before `limit` (the record after it).
fn within(directory: Directory, limit: u64) -> std::result::Result<Directory, String> {
    match directory.offset.checked_add(directory.size) {
        Some(end) if end <= limit => Ok(directory),
        _ => Err("the central directory lies outside the archive".into()),
    }
}

fn read_at(file: &mut File, at: u64, buf: &mut [u8]) -> std::result::Result<(), String> {
    file.seek(SeekFrom::Start(at)).map_err(|e| e.to_string())?;
    file.read_exact(buf).map_err(|_| "the archive ends early".to_string())
}
