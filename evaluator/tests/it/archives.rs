//! Submission archives as participants make them: the commands the README and the docs
//! show, run literally, unpack to the files they hold; what is refused names paths
//! inside the archive only.

use std::path::Path;
use std::process::Command;

use osmab_evaluator::submission::archive::list_tree;
use osmab_evaluator::submission::{ArchiveLimits, unpack};

fn submission_tree(root: &Path) {
    for (name, data) in [("submission.json", &b"{}"[..]), ("maps/baseline/scene_000.npz", b"npz"), ("graphs/baseline/scene_000.json", b"{}")] {
        let path = root.join(name);
        std::fs::create_dir_all(path.parent().unwrap()).unwrap();
        std::fs::write(path, data).unwrap();
    }
}

fn run(dir: &Path, program: &str, args: &[&str]) {
    let out = Command::new(program).args(args).current_dir(dir).output().unwrap();
    assert!(out.status.success(), "{program} {args:?}: {}", String::from_utf8_lossy(&out.stderr));
}

#[test]
fn the_readme_s_tar_command_unpacks_to_the_submission_s_files() {
    let dir = tempfile::tempdir().unwrap();
    submission_tree(&dir.path().join("my-submission"));
    // README.md: `tar -cf sub.tar -C my-submission .` — its first entry is `./`.
    run(dir.path(), "tar", &["-cf", "sub.tar", "-C", "my-submission", "."]);
    run(dir.path(), "tar", &["-czf", "sub.tar.gz", "-C", "my-submission", "."]);
    run(dir.path(), "tar", &["-cf", "named.tar", "-C", "my-submission", "./submission.json", "./maps", "./graphs"]);
    for archive in ["sub.tar", "sub.tar.gz", "named.tar"] {
        let out = dir.path().join(format!("out-{archive}"));
        let unpacked = unpack(&dir.path().join(archive), &out, ArchiveLimits::default()).unwrap_or_else(|e| panic!("{archive}: {e}"));
        assert_eq!(unpacked.files.len(), 3, "{archive}");
        assert_eq!(list_tree(&out).unwrap(), list_tree(&dir.path().join("my-submission")).unwrap(), "{archive}");
    }
}

#[test]
fn a_refused_entry_is_named_by_its_path_inside_the_archive() {
    let dir = tempfile::tempdir().unwrap();
    // A file and a directory of the same name: the second cannot be written.
    let mut builder = tar::Builder::new(Vec::new());
    for name in ["maps", "maps/baseline/scene_000.npz"] {
        let mut header = tar::Header::new_gnu();
        header.set_size(1);
        header.set_mode(0o644);
        header.set_entry_type(tar::EntryType::Regular);
        builder.append_data(&mut header, name, &b"x"[..]).unwrap();
    }
    let archive = dir.path().join("upload.tar");
    std::fs::write(&archive, builder.into_inner().unwrap()).unwrap();
    let dest = dir.path().join("scratch-area/unpack-1");
    let err = unpack(&archive, &dest, ArchiveLimits::default()).unwrap_err();
    let shown = err.to_string();
    assert!(!shown.contains("scratch-area"), "the destination is not shown: {shown}");
    assert_eq!(err.field, "maps/baseline/scene_000.npz", "{shown}");
}

#[test]
fn v7_tar_archives_unpack_and_zips_naming_an_entry_twice_or_with_nul_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    submission_tree(&dir.path().join("my-submission"));
    run(dir.path(), "tar", &["--format=v7", "-cf", "v7.tar", "-C", "my-submission", "."]);
    let unpacked = unpack(&dir.path().join("v7.tar"), &dir.path().join("out-v7"), ArchiveLimits::default()).unwrap();
    assert_eq!(unpacked.files.len(), 3);

    // A zip writer refuses a name twice; rename the second entry in the bytes afterwards.
    let zip_of = |names: [&str; 2]| {
        use std::io::Write;
        let mut zip = zip::ZipWriter::new(std::io::Cursor::new(Vec::new()));
        for (name, data) in names.iter().zip([&b"{\"first\": 1}"[..], b"{\"second\": 2}"]) {
            zip.start_file(*name, zip::write::SimpleFileOptions::default()).unwrap();
            zip.write_all(data).unwrap();
        }
        zip.finish().unwrap().into_inner()
    };
    let replace = |bytes: Vec<u8>, from: &[u8], to: &[u8]| -> Vec<u8> {
        let mut out = bytes;
        let mut i = 0;
        while i + from.len() <= out.len() {
            if &out[i..i + from.len()] == from {
                out[i..i + from.len()].copy_from_slice(to);
            }
            i += 1;
        }
        out
    };
    for (label, bytes, needle) in [
        ("twice", replace(zip_of(["submission.json", "submissioX.json"]), b"submissioX.json", b"submission.json"), "twice"),
        ("nul", replace(zip_of(["a.json", "b.json"]), b"b.json", b"b\0json"), "NUL"),
    ] {
        let path = dir.path().join(format!("{label}.zip"));
        std::fs::write(&path, bytes).unwrap();
        let err = unpack(&path, &dir.path().join(format!("out-{label}")), ArchiveLimits::default()).unwrap_err();
        assert!(err.to_string().contains(needle), "{label}: {err}");
    }
}

#[test]
fn a_packed_list_holds_exactly_its_files_and_its_size_is_known_before_packing() {
    use osmab_evaluator::submission::archive::{packed_size, tar_file_names};
    use osmab_evaluator::submission::pack_files_as;
    let dir = tempfile::tempdir().unwrap();
    let long = format!("results/{}.png", "n".repeat(120));
    let files: Vec<(String, usize)> =
        vec![("results/frame000000.jpg".into(), 0), ("results/depth000000.png".into(), 511), ("traj.txt".into(), 512), (long.clone(), 1300)];
    for (name, size) in &files {
        let path = dir.path().join("seq").join(name);
        std::fs::create_dir_all(path.parent().unwrap()).unwrap();
        std::fs::write(path, vec![7u8; *size]).unwrap();
    }
    // A file the list leaves out stays out of the archive.
    std::fs::write(dir.path().join("seq/results/semantic000000.png"), b"hidden").unwrap();
    let names: Vec<String> = files.iter().map(|(n, _)| n.clone()).collect();
    let prefix = "sequences/baseline/scene_001/";
    let archive = dir.path().join("seq.tar");
    assert_eq!(pack_files_as(&dir.path().join("seq"), &names, prefix, &archive).unwrap(), 4);
    let listed = tar_file_names(std::fs::File::open(&archive).unwrap(), &archive).unwrap();
    assert_eq!(listed, names.iter().map(|n| format!("{prefix}{n}")).collect::<Vec<_>>());
    let predicted = packed_size(files.iter().map(|(n, size)| (prefix.len() + n.len(), *size as u64)));
    assert_eq!(predicted, std::fs::metadata(&archive).unwrap().len(), "a long name's record counted too");
}

/// A zip of `names` (one small JSON document each).
fn zip_of(names: &[&str]) -> Vec<u8> {
    use std::io::Write;
    let mut zip = zip::ZipWriter::new(std::io::Cursor::new(Vec::new()));
    for (k, name) in names.iter().enumerate() {
        zip.start_file(*name, zip::write::SimpleFileOptions::default()).unwrap();
        write!(zip, "{{\"entry\": {k}}}").unwrap();
    }
    zip.finish().unwrap().into_inner()
}

/// `bytes` with every occurrence of `from` replaced by `to` (of the same length).
fn replace_all(mut bytes: Vec<u8>, from: &[u8], to: &[u8]) -> Vec<u8> {
    for i in 0..=bytes.len() - from.len() {
        if &bytes[i..i + from.len()] == from {
            bytes[i..i + from.len()].copy_from_slice(to);
        }
    }
    bytes
}

/// The same zip with its end record deferring to ZIP64 records (counts 0xFFFF, offset
/// 0xFFFFFFFF), as a writer does past 65,535 entries or 4 GiB.
fn as_zip64(zip: Vec<u8>) -> Vec<u8> {
    let end = zip.len() - 22;
    assert_eq!(&zip[end..end + 4], b"PK\x05\x06");
    let u16_at = |k: usize| u16::from_le_bytes([zip[k], zip[k + 1]]) as u64;
    let u32_at = |k: usize| u32::from_le_bytes(zip[k..k + 4].try_into().unwrap()) as u64;
    let (entries, size, offset) = (u16_at(end + 10), u32_at(end + 12), u32_at(end + 16));
    let mut out = zip[..end].to_vec();
    let record_at = out.len() as u64;
    out.extend_from_slice(b"PK\x06\x06");
    out.extend_from_slice(&44u64.to_le_bytes());
    out.extend_from_slice(&[45, 0, 45, 0, 0, 0, 0, 0, 0, 0, 0, 0]);
    for v in [entries, entries, size, offset] {
        out.extend_from_slice(&v.to_le_bytes());
    }
    out.extend_from_slice(b"PK\x06\x07\0\0\0\0");
    out.extend_from_slice(&record_at.to_le_bytes());
    out.extend_from_slice(&1u32.to_le_bytes());
    out.extend_from_slice(b"PK\x05\x06\0\0\0\0");
    out.extend_from_slice(&[0xff; 12]);
    out.extend_from_slice(b"\0\0");
    out
}

#[test]
fn zip64_archives_unpack_and_naming_an_entry_twice_is_refused_in_them_too() {
    let dir = tempfile::tempdir().unwrap();
    let names = ["submission.json", "maps/baseline/scene_000.npz"];
    let good = dir.path().join("good64.zip");
    std::fs::write(&good, as_zip64(zip_of(&names))).unwrap();
    let unpacked = unpack(&good, &dir.path().join("out-good64"), ArchiveLimits::default()).unwrap();
    assert_eq!(unpacked.files.len(), 2, "a ZIP64 archive is read in full");

    let twice = replace_all(zip_of(&["submission.json", "submissioX.json"]), b"submissioX.json", b"submission.json");
    for (label, bytes) in [("zip", twice.clone()), ("zip64", as_zip64(twice))] {
        let path = dir.path().join(format!("twice-{label}.zip"));
        std::fs::write(&path, bytes).unwrap();
        let err = unpack(&path, &dir.path().join(format!("out-{label}")), ArchiveLimits::default()).unwrap_err();
        assert_eq!(err.field, "submission.json", "{label}: {err}");
        assert!(err.to_string().contains("twice"), "{label}: {err}");
    }
}

#[test]
fn a_zip_whose_entries_cannot_all_be_listed_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let zip = zip_of(&["submission.json", "graphs/baseline/scene_000.json"]);
    let end = zip.len() - 22;
    // The end record declares three entries where the directory holds two.
    let mut more = zip.clone();
    more[end + 8..end + 12].copy_from_slice(&[3, 0, 3, 0]);
    // A ZIP64 count with no ZIP64 records before it.
    let mut orphan = zip.clone();
    orphan[end + 8..end + 12].copy_from_slice(&[0xff; 4]);
    // A directory that would run past the end record.
    let mut beyond = zip;
    beyond[end + 12..end + 16].copy_from_slice(&u32::MAX.wrapping_sub(1).to_le_bytes());
    for (label, bytes, needle) in [("more", more, "entry 2 of the 3"), ("orphan", orphan, "ZIP64"), ("beyond", beyond, "outside the archive")] {
        let path = dir.path().join(format!("{label}.zip"));
        std::fs::write(&path, bytes).unwrap();
        let err = unpack(&path, &dir.path().join(format!("out-{label}")), ArchiveLimits::default()).unwrap_err();
        let shown = err.to_string();
        assert!(shown.contains("cannot all be listed") && shown.contains(needle), "{label}: {shown}");
    }
}

#[test]
fn every_member_of_a_multi_member_gzip_is_read_and_trailing_bytes_are_refused() {
    use std::io::Write;
    let dir = tempfile::tempdir().unwrap();
    submission_tree(&dir.path().join("my-submission"));
    run(dir.path(), "tar", &["-cf", "sub.tar", "-C", "my-submission", "."]);
    let tar = std::fs::read(dir.path().join("sub.tar")).unwrap();
    // `cat a.gz b.gz`: the tar's first half in one member, the rest in another.
    let member = |bytes: &[u8]| {
        let mut gz = flate2::write::GzEncoder::new(Vec::new(), flate2::Compression::default());
        gz.write_all(bytes).unwrap();
        gz.finish().unwrap()
    };
    let cut = 1536; // after the first file's header and content
    let two_members = [member(&tar[..cut]), member(&tar[cut..])].concat();
    let path = dir.path().join("bgzip.tar.gz");
    std::fs::write(&path, &two_members).unwrap();
    let unpacked = unpack(&path, &dir.path().join("out-two"), ArchiveLimits::default()).unwrap();
    assert_eq!(list_tree(&dir.path().join("out-two")).unwrap(), list_tree(&dir.path().join("my-submission")).unwrap());
    assert_eq!(unpacked.files.len(), 3, "no file of the second member is dropped");

    let garbage = [member(&tar), b"not a gzip member".to_vec()].concat();
    let path = dir.path().join("trailing.tar.gz");
    std::fs::write(&path, garbage).unwrap();
    let err = unpack(&path, &dir.path().join("out-trailing"), ArchiveLimits::default()).unwrap_err();
    assert!(err.to_string().contains("truncated or corrupt"), "{err}");

    let appended = [tar.clone(), b"PK\x03\x04 a zip appended".to_vec()].concat();
    let path = dir.path().join("appended.tar");
    std::fs::write(&path, appended).unwrap();
    let err = unpack(&path, &dir.path().join("out-appended"), ArchiveLimits::default()).unwrap_err();
    assert!(err.to_string().contains("data follows the end of the tar archive"), "{err}");
}

#[test]
fn an_archive_unpacks_to_at_most_its_expansion_limit_and_its_total_limit() {
    use std::io::{Read, Write};
    let dir = tempfile::tempdir().unwrap();
    // 4 MiB of zeros in a gzip of a few kB.
    let mut builder = tar::Builder::new(Vec::new());
    let mut header = tar::Header::new_gnu();
    header.set_size(4 << 20);
    header.set_mode(0o644);
    header.set_entry_type(tar::EntryType::Regular);
    builder.append_data(&mut header, "maps/baseline/scene_000.npz", std::io::repeat(0).take(4 << 20)).unwrap();
    let mut gz = flate2::write::GzEncoder::new(Vec::new(), flate2::Compression::best());
    gz.write_all(&builder.into_inner().unwrap()).unwrap();
    let bomb = dir.path().join("zeros.tar.gz");
    std::fs::write(&bomb, gz.finish().unwrap()).unwrap();
    let size = std::fs::metadata(&bomb).unwrap().len();
    assert!(size < 40_000, "{size}");

    let limited = ArchiveLimits { max_expansion_ratio: Some(100), ..ArchiveLimits::default() };
    let err = unpack(&bomb, &dir.path().join("out-ratio"), limited).unwrap_err();
    assert!(err.to_string().contains(&format!("100 times its own {size} bytes")), "{err}");
    let written: u64 =
        list_tree(&dir.path().join("out-ratio")).unwrap().iter().map(|f| std::fs::metadata(dir.path().join("out-ratio").join(f)).unwrap().len()).sum();
    assert!(written <= 100 * size + 1, "at most the limit was written: {written}");

    let total = ArchiveLimits { max_total_bytes: 1 << 20, max_expansion_ratio: Some(10_000), ..ArchiveLimits::default() };
    let err = unpack(&bomb, &dir.path().join("out-total"), total).unwrap_err();
    assert!(err.to_string().contains(&format!("more than {} bytes (the submission size limit)", 1 << 20)), "{err}");
    let unbounded = ArchiveLimits::default();
    assert_eq!(unpack(&bomb, &dir.path().join("out-free"), unbounded).unwrap().bytes, 4 << 20, "without a ratio only the total limit counts");
}

#[test]
fn files_of_several_megabytes_unpack_byte_for_byte_in_every_format_up_to_the_exact_total_limit() {
    use std::io::Write;
    let dir = tempfile::tempdir().unwrap();
    // 3.5 MiB that never repeats within a copy buffer, and a small file after it.
    let mut state = 0x9E37_79B9_7F4A_7C15u64;
    let large: Vec<u8> = (0..(7 << 19))
        .map(|_| {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            state as u8
        })
        .collect();
    let files = [("maps/baseline/scene_000.npz", &large[..]), ("submission.json", &b"{}"[..])];
    let mut builder = tar::Builder::new(Vec::new());
    for (name, data) in files {
        let mut header = tar::Header::new_gnu();
        header.set_size(data.len() as u64);
        header.set_mode(0o644);
        header.set_entry_type(tar::EntryType::Regular);
        builder.append_data(&mut header, name, data).unwrap();
    }
    let tar_bytes = builder.into_inner().unwrap();
    let mut gz = flate2::write::GzEncoder::new(Vec::new(), flate2::Compression::fast());
    gz.write_all(&tar_bytes).unwrap();
    let mut zip = zip::ZipWriter::new(std::io::Cursor::new(Vec::new()));
    for (name, data) in files {
        zip.start_file(name, zip::write::SimpleFileOptions::default().compression_method(zip::CompressionMethod::Stored)).unwrap();
        zip.write_all(data).unwrap();
    }
    let total = (large.len() + 2) as u64;
    for (archive, bytes) in [("sub.tar", tar_bytes.clone()), ("sub.tar.gz", gz.finish().unwrap()), ("sub.zip", zip.finish().unwrap().into_inner())] {
        let path = dir.path().join(archive);
        std::fs::write(&path, bytes).unwrap();
        let exact = ArchiveLimits { max_total_bytes: total, max_expansion_ratio: None, ..ArchiveLimits::default() };
        let out = dir.path().join(format!("out-{archive}"));
        assert_eq!(unpack(&path, &out, exact).unwrap_or_else(|e| panic!("{archive}: {e}")).bytes, total, "{archive}");
        assert!(std::fs::read(out.join("maps/baseline/scene_000.npz")).unwrap() == large, "{archive}: the large file byte for byte");
        assert_eq!(std::fs::read(out.join("submission.json")).unwrap(), b"{}", "{archive}");
        let one_short = ArchiveLimits { max_total_bytes: total - 1, max_expansion_ratio: None, ..ArchiveLimits::default() };
        let err = unpack(&path, &dir.path().join(format!("short-{archive}")), one_short).unwrap_err();
        assert!(err.to_string().contains(&format!("more than {} bytes", total - 1)), "{archive}: {err}");
    }
}
