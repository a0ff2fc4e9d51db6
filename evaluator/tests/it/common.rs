//! Helpers shared by the evaluator tests.

use std::path::PathBuf;

use osmab_evaluator::formats::classes::{ClassEntry, ClassList};

/// `../shared/fixtures` beside the repository (present in every checkout and in CI).
pub fn fixtures() -> PathBuf {
    let dir = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../shared/fixtures");
    assert!(dir.is_dir(), "fixtures missing at {}: the tests need ../shared beside the repository", dir.display());
    dir
}

/// Classes 0 (other) and 1..=n named `class_i`.
pub fn classes(n: i64) -> ClassList {
    let mut entries = vec![ClassEntry { name: "other".into(), id: 0 }];
    entries.extend((1..=n).map(|id| ClassEntry { name: format!("class_{id}"), id }));
    ClassList::new(entries).unwrap()
}
