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
