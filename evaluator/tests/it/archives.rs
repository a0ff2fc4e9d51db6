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
