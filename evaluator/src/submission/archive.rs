//! Submission archives: `.tar`, `.tar.gz` and `.zip` unpacked with every hostile case
//! refused (path traversal, links, device files, duplicate names, too many entries,
//! too many bytes — counted as they are written, so a compression bomb stops at the
//! limit), and directories packed deterministically so the same files give the same
//! archive bytes and SHA-256.

use std::collections::HashSet;
use std::fs::File;
use std::io::{BufReader, Read, Seek, Write};
use std::path::{Component, Path, PathBuf};

use crate::error::{InputError, Result};

/// Upper bounds on what an archive may unpack to.
#[derive(Debug, Clone, Copy)]
pub struct ArchiveLimits {
    /// Largest number of entries (files and directories).
    pub max_entries: usize,
    /// Largest sum of unpacked file sizes.
    pub max_total_bytes: u64,
    /// Largest sum of unpacked file sizes as a multiple of the archive's own size, when set:
    /// a small compressed archive cannot make the unpacking write far more than it sent
    /// (a free dry run would otherwise turn 1 MB into gigabytes of scratch).
    pub max_expansion_ratio: Option<u64>,
}

impl Default for ArchiveLimits {
    fn default() -> Self {
        Self { max_entries: 20_000, max_total_bytes: 16 << 30, max_expansion_ratio: None }
    }
}

/// The container formats a submission may come in.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ArchiveKind {
    Tar,
    TarGz,
    Zip,
}

impl ArchiveKind {
    /// Recognise an archive by its first bytes (the declared content type is only a hint).
    pub fn sniff(path: &Path) -> Result<Self> {
        let mut head = [0u8; 512];
        let mut file = File::open(path).map_err(|e| InputError::io(path, &e))?;
        let mut n = 0;
        while n < head.len() {
            match file.read(&mut head[n..]) {
                Ok(0) => break,
                Ok(k) => n += k,
                Err(e) => return Err(InputError::io(path, &e)),
            }
        }
        if n >= 2 && head[..2] == [0x1f, 0x8b] {
            Ok(Self::TarGz)
        } else if n >= 4 && (head[..4] == *b"PK\x03\x04" || head[..4] == *b"PK\x05\x06") {
            Ok(Self::Zip)
        } else if n >= 262 && &head[257..262] == b"ustar" || n == 512 && is_v7_tar_header(&head) {
            Ok(Self::Tar)
        } else if n == 0 {
            Err(InputError::new(path, "(archive)", "the upload is empty; expected a .tar, .tar.gz or .zip archive"))
        } else {
            Err(InputError::new(path, "(archive)", "not a .tar, .tar.gz or .zip archive (unrecognised first bytes)"))
        }
    }
}

/// Whether `block` is a tar header without the ustar magic (the v7 format of
/// `tar --format=v7`): its checksum field matches the sum of its bytes.
fn is_v7_tar_header(block: &[u8; 512]) -> bool {
    let field = &block[148..156];
    let text: String = field.iter().take_while(|&&b| b != 0).map(|&b| b as char).collect();
    let Ok(declared) = u32::from_str_radix(text.trim(), 8) else { return false };
    let sum: u32 = block.iter().enumerate().map(|(i, &b)| if (148..156).contains(&i) { b' ' as u32 } else { b as u32 }).sum();
    declared == sum && block[0] != 0
}

/// A relative path inside an archive made safe to join under the destination: no
/// absolute paths, no `..`, no empty or odd components. A leading `./` is dropped.
pub fn safe_relative_path(archive: &Path, name: &str) -> Result<PathBuf> {
    let refuse = |why: &str| InputError::new(archive, name, format!("refused entry: {why}"));
    if name.contains('\0') || name.contains('\\') {
        return Err(refuse("names may not contain NUL or backslashes"));
    }
    let mut out = PathBuf::new();
    for component in Path::new(name).components() {
        match component {
            Component::Normal(part) => out.push(part),
            Component::CurDir => {}
            Component::ParentDir => return Err(refuse("the path leaves the archive ('..')")),
            Component::RootDir | Component::Prefix(_) => return Err(refuse("absolute paths are not allowed")),
        }
    }
    if out.as_os_str().is_empty() {
        return Err(refuse("empty path"));
    }
    Ok(out)
}

/// `.`, `./` or `./.` and the like: the archive's root directory, which `tar -C dir .`
/// writes as its first entry.
fn is_root(name: &str) -> bool {
    !name.is_empty() && !name.starts_with('/') && Path::new(name).components().all(|c| c == Component::CurDir)
}

/// What unpacking wrote.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct Unpacked {
    /// Files written (relative paths).
    pub files: Vec<PathBuf>,
    /// Their total size.
    pub bytes: u64,
}

struct Writer<'a> {
    archive: &'a Path,
    dest: &'a Path,
    limits: ArchiveLimits,
    /// Bytes this archive may unpack to, and what sets that bound.
    budget: (u64, Bound),
    seen: HashSet<PathBuf>,
    entries: usize,
    out: Unpacked,
    /// What a file's bytes pass through on their way out ([`COPY_BUFFER`] bytes).
    buffer: Vec<u8>,
}

/// Bytes an entry is copied in at a time: large enough that reading and writing a
/// gigabyte-sized submission takes few system calls (with `std::io::copy`'s 8 KiB, a
/// 1.6 GB archive took some 400,000).
const COPY_BUFFER: usize = 1 << 20;

/// Copy everything `from` holds to `to` through `buffer`; the bytes copied.
fn copy_through(from: &mut impl Read, to: &mut impl Write, buffer: &mut [u8]) -> std::io::Result<u64> {
    let mut copied = 0;
    loop {
        let n = match from.read(buffer) {
            Ok(0) => return Ok(copied),
            Ok(n) => n,
            Err(e) if e.kind() == std::io::ErrorKind::Interrupted => continue,
            Err(e) => return Err(e),
        };
        to.write_all(&buffer[..n])?;
        copied += n as u64;
    }
}

/// Which limit bounds an archive's unpacked bytes.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Bound {
    Total,
    Expansion { ratio: u64, archive_bytes: u64 },
}

impl Writer<'_> {
    fn entry(&mut self, name: &str) -> Result<PathBuf> {
        self.entries += 1;
        if self.entries > self.limits.max_entries {
            return Err(InputError::new(self.archive, "(archive)", format!("more than {} entries, the most this archive may hold", self.limits.max_entries)));
        }
        safe_relative_path(self.archive, name)
    }

    fn directory(&mut self, name: &str) -> Result<()> {
        // `tar -cf sub.tar -C dir .` starts with the archive's own root, `./`.
        if is_root(name) {
            self.entries += 1;
            return Ok(());
        }
        let relative = self.entry(name)?;
        std::fs::create_dir_all(self.dest.join(&relative)).map_err(|e| unwritable(self.archive, name, &e))
    }

    fn file(&mut self, name: &str, content: &mut dyn Read) -> Result<()> {
        let relative = self.entry(name)?;
        if !self.seen.insert(relative.clone()) {
            return Err(InputError::new(self.archive, name, "refused entry: the archive holds this path twice"));
        }
        let path = self.dest.join(&relative);
        if let Some(parent) = path.parent() {
            std::fs::create_dir_all(parent).map_err(|e| unwritable(self.archive, name, &e))?;
        }
        let mut file = File::create(&path).map_err(|e| unwritable(self.archive, name, &e))?;
        let (limit, bound) = self.budget;
        let budget = limit - self.out.bytes;
        // Count what actually arrives: declared sizes in headers can lie.
        let written = copy_through(&mut content.take(budget.saturating_add(1)), &mut file, &mut self.buffer).map_err(|e| truncated(self.archive, name, &e))?;
        if written > budget {
            let why = match bound {
                Bound::Total => format!("the archive unpacks to more than {limit} bytes (the submission size limit)"),
                Bound::Expansion { ratio, archive_bytes } => format!(
                    "the archive unpacks to more than {ratio} times its own {archive_bytes} bytes ({limit} bytes, the expansion limit): it is mostly compressed repetition"
                ),
            };
            return Err(InputError::new(self.archive, name, why));
        }
        file.flush().map_err(|e| unwritable(self.archive, name, &e))?;
        self.out.bytes += written;
        self.out.files.push(relative);
        Ok(())
    }
}

/// An entry that cannot be written where it belongs, named inside the archive (never by
/// the server's own path to it).
fn unwritable(archive: &Path, name: &str, e: &std::io::Error) -> InputError {
    InputError::new(
        archive,
        name,
        format!("refused entry: it cannot be written ({}); does the archive use one name for both a file and a directory?", e.kind()),
    )
}

fn truncated(archive: &Path, name: &str, e: &std::io::Error) -> InputError {
    InputError::new(archive, name, format!("the archive is truncated or corrupt while reading this entry ({e})"))
}

/// Unpack `archive` into the empty directory `dest`.
pub fn unpack(archive: &Path, dest: &Path, limits: ArchiveLimits) -> Result<Unpacked> {
    let kind = ArchiveKind::sniff(archive)?;
    std::fs::create_dir_all(dest).map_err(|e| InputError::io(dest, &e))?;
    let archive_bytes = std::fs::metadata(archive).map_err(|e| InputError::io(archive, &e))?.len();
    let budget = match limits.max_expansion_ratio {
        Some(ratio) if ratio.saturating_mul(archive_bytes) < limits.max_total_bytes => {
            (ratio.saturating_mul(archive_bytes), Bound::Expansion { ratio, archive_bytes })
        }
        _ => (limits.max_total_bytes, Bound::Total),
    };
    let mut writer = Writer { archive, dest, limits, budget, seen: HashSet::new(), entries: 0, out: Unpacked::default(), buffer: vec![0; COPY_BUFFER] };
    let file = File::open(archive).map_err(|e| InputError::io(archive, &e))?;
    match kind {
        ArchiveKind::Tar => unpack_tar(BufReader::new(file), &mut writer)?,
        // Every member of a multi-member gzip (`cat a.gz b.gz`, what bgzip writes), never the first alone.
        ArchiveKind::TarGz => unpack_tar(flate2::read::MultiGzDecoder::new(BufReader::new(file)), &mut writer)?,
        ArchiveKind::Zip => unpack_zip(file, &mut writer)?,
    }
    if writer.out.files.is_empty() {
        return Err(InputError::new(archive, "(archive)", "the archive holds no files"));
    }
    Ok(writer.out)
}

fn unpack_tar(mut reader: impl Read, writer: &mut Writer<'_>) -> Result<()> {
    let archive_path = writer.archive;
    read_tar_entries(&mut reader, writer)?;
    // What follows the end of the archive must be its zero padding: anything else (bytes
    // appended, another gzip member that does not decode) is refused, never ignored.
    let mut rest = reader.take(writer.limits.max_total_bytes);
    let mut chunk = vec![0u8; 64 << 10];
    loop {
        let n = rest.read(&mut chunk).map_err(|e| truncated(archive_path, "(archive)", &e))?;
        if n == 0 {
            return Ok(());
        }
        if chunk[..n].iter().any(|&b| b != 0) {
            return Err(InputError::new(archive_path, "(archive)", "refused: data follows the end of the tar archive; is it two archives in one file?"));
        }
    }
}

fn read_tar_entries(reader: &mut impl Read, writer: &mut Writer<'_>) -> Result<()> {
    let archive_path = writer.archive;
    let mut tar = tar::Archive::new(reader);
    let entries = tar.entries().map_err(|e| truncated(archive_path, "(archive)", &e))?;
    for entry in entries {
        let mut entry = entry.map_err(|e| truncated(archive_path, "(archive)", &e))?;
        let name =
            String::from_utf8(entry.path_bytes().into_owned()).map_err(|_| InputError::new(archive_path, "(archive)", "an entry name is not valid UTF-8"))?;
        match entry.header().entry_type() {
            tar::EntryType::Regular | tar::EntryType::Continuous => writer.file(&name, &mut entry)?,
            tar::EntryType::Directory => writer.directory(&name)?,
            // pax and GNU long-name records describe the next entry; the tar reader applies them.
            tar::EntryType::XHeader | tar::EntryType::XGlobalHeader | tar::EntryType::GNULongName => {}
            tar::EntryType::Symlink | tar::EntryType::Link | tar::EntryType::GNULongLink => {
                return Err(InputError::new(archive_path, name, "refused entry: links are not allowed in a submission; archive the files themselves"));
            }
            other => return Err(InputError::new(archive_path, name, format!("refused entry: {other:?} entries are not allowed; only files and directories"))),
        }
    }
    Ok(())
}

fn unpack_zip(file: File, writer: &mut Writer<'_>) -> Result<()> {
    let archive_path = writer.archive;
    // The zip reader keeps one entry per name (a later copy would silently win): the
    // central directory is read on its own first, ZIP64 or not.
    super::zip_directory::check_names_are_unique(archive_path, writer.limits.max_entries)?;
    let mut zip =
        zip::ZipArchive::new(BufReader::new(file)).map_err(|e| InputError::new(archive_path, "(archive)", format!("not a readable zip archive: {e}")))?;
    for i in 0..zip.len() {
        let mut entry = zip.by_index(i).map_err(|e| InputError::new(archive_path, "(archive)", format!("entry {i} is unreadable: {e}")))?;
        if entry.name_raw().contains(&0) {
            return Err(InputError::new(archive_path, format!("entry {i}"), "refused entry: names may not contain NUL or backslashes"));
        }
        let name = entry.name().map_err(|e| InputError::new(archive_path, "(archive)", format!("entry {i} has an unreadable name: {e}")))?.to_string();
        if entry.is_symlink() {
            return Err(InputError::new(archive_path, name, "refused entry: links are not allowed in a submission; archive the files themselves"));
        }
        if entry.is_dir() {
            writer.directory(&name)?;
        } else {
            writer.file(&name, &mut entry)?;
        }
    }
    Ok(())
}

/// Every file under `dir` as sorted relative paths with '/' separators; links and other
/// special files are refused.
pub fn list_tree(dir: &Path) -> Result<Vec<String>> {
    fn walk(root: &Path, dir: &Path, out: &mut Vec<String>) -> Result<()> {
        let entries = std::fs::read_dir(dir).map_err(|e| InputError::io(dir, &e))?;
        for entry in entries {
            let entry = entry.map_err(|e| InputError::io(dir, &e))?;
            let path = entry.path();
            let kind = entry.file_type().map_err(|e| InputError::io(&path, &e))?;
            if kind.is_dir() {
                walk(root, &path, out)?;
            } else if kind.is_file() {
                let relative = path.strip_prefix(root).expect("under root");
                let text = relative.to_str().ok_or_else(|| InputError::new(&path, "(name)", "file names must be valid UTF-8"))?;
                out.push(text.replace(std::path::MAIN_SEPARATOR, "/"));
            } else {
                return Err(InputError::new(&path, "(file)", "links and special files cannot be part of a submission"));
            }
        }
        Ok(())
    }
    let mut out = Vec::new();
    walk(dir, dir, &mut out)?;
    out.sort();
    Ok(out)
}

/// Pack the files under `dir` into an uncompressed tar at `out`, deterministically:
/// sorted names, mode 0644, owner 0, time 0. Returns the number of files.
pub fn pack_directory(dir: &Path, out: &Path) -> Result<usize> {
    pack_directory_as(dir, "", out)
}

/// As [`pack_directory`], with every name inside the archive starting with `prefix`
/// (`sequences/baseline/scene_000/`).
pub fn pack_directory_as(dir: &Path, prefix: &str, out: &Path) -> Result<usize> {
    pack_files_as(dir, &list_tree(dir)?, prefix, out)
}

/// As [`pack_directory_as`], packing only `files` (relative paths under `dir` with '/'
/// separators, in the order given): an archive holds what a list says, never whatever else
/// lies in the folder.
pub fn pack_files_as(dir: &Path, files: &[String], prefix: &str, out: &Path) -> Result<usize> {
    let sink = File::create(out).map_err(|e| InputError::io(out, &e))?;
    let writer = pack_files_into(dir, files, prefix, std::io::BufWriter::new(sink), out)?;
    writer.into_inner().map_err(|e| InputError::io(out, &e.into_error()))?.sync_all().map_err(|e| InputError::io(out, &e))?;
    Ok(files.len())
}

/// As [`pack_directory_as`], writing the archive to `sink` (named `out` in errors) and
/// giving it back, with the number of files, once the archive is complete.
pub fn pack_directory_into<W: std::io::Write>(dir: &Path, prefix: &str, sink: W, out: &Path) -> Result<(usize, W)> {
    let files = list_tree(dir)?;
    let writer = pack_files_into(dir, &files, prefix, sink, out)?;
    Ok((files.len(), writer))
}

/// Pack `files` (relative to `dir`) into a tar written to `sink`, as [`pack_files_as`].
pub fn pack_files_into<W: std::io::Write>(dir: &Path, files: &[String], prefix: &str, sink: W, out: &Path) -> Result<W> {
    let mut builder = tar::Builder::new(sink);
    builder.mode(tar::HeaderMode::Deterministic);
    for name in files {
        let path = dir.join(name);
        let mut file = File::open(&path).map_err(|e| InputError::io(&path, &e))?;
        let size = file.seek(std::io::SeekFrom::End(0)).map_err(|e| InputError::io(&path, &e))?;
        file.rewind().map_err(|e| InputError::io(&path, &e))?;
        let mut header = tar::Header::new_gnu();
        header.set_size(size);
        header.set_mode(0o644);
        header.set_mtime(0);
        header.set_uid(0);
        header.set_gid(0);
        header.set_entry_type(tar::EntryType::Regular);
        builder.append_data(&mut header, format!("{prefix}{name}"), &mut file).map_err(|e| InputError::io(out, &e))?;
    }
    builder.into_inner().map_err(|e| InputError::io(out, &e))
}

/// The size of the tar [`pack_files_into`] writes for files whose names inside the archive
/// (prefix included) are `name_bytes` long and whose contents are `size` bytes: a header
/// block a file (and a GNU long-name record before a name of more than 100 bytes), the
/// content rounded up to whole blocks, and the two closing blocks. Lets a stored archive be
/// checked against the list it should hold without reading it.
pub fn packed_size(files: impl IntoIterator<Item = (usize, u64)>) -> u64 {
    const BLOCK: u64 = 512;
    let blocks = |bytes: u64| bytes.div_ceil(BLOCK) * BLOCK;
    let entries: u64 = files
        .into_iter()
        .map(|(name_bytes, size)| {
            let long_name = if name_bytes > 100 { BLOCK + blocks(name_bytes as u64 + 1) } else { 0 };
            long_name + BLOCK + blocks(size)
        })
        .sum();
    entries + 2 * BLOCK
}

/// The names of the files a tar archive holds, in order (directories left out), read
/// without unpacking: what a check that an archive holds exactly a list needs.
pub fn tar_file_names(reader: impl Read, archive: &Path) -> Result<Vec<String>> {
    let mut tar = tar::Archive::new(reader);
    let entries = tar.entries().map_err(|e| truncated(archive, "(archive)", &e))?;
    let mut names = Vec::new();
    for entry in entries {
        let entry = entry.map_err(|e| truncated(archive, "(archive)", &e))?;
        let name = String::from_utf8(entry.path_bytes().into_owned()).map_err(|_| InputError::new(archive, "(archive)", "an entry name is not valid UTF-8"))?;
        match entry.header().entry_type() {
            tar::EntryType::Directory | tar::EntryType::XHeader | tar::EntryType::XGlobalHeader | tar::EntryType::GNULongName => {}
            _ => names.push(name),
        }
    }
    Ok(names)
}
