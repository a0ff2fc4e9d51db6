//! JSON files as every stage of the project writes and reads them: pretty, with a final
//! newline, the folder made first; errors name the file.

use std::path::Path;

use serde::Serialize;
use serde::de::DeserializeOwned;

use crate::{InputError, Result};

/// Write `value` to `path` as pretty JSON ending in a newline, making its folder first.
pub fn write_pretty(path: &Path, value: &impl Serialize) -> Result<()> {
    if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir).map_err(|e| InputError::io(dir, &e))?;
    }
    let text = serde_json::to_string_pretty(value).map_err(|e| InputError::new(path, "(json)", format!("cannot serialise: {e}")))?;
    std::fs::write(path, text + "\n").map_err(|e| InputError::io(path, &e))
}

/// Read the JSON file at `path` as a `T`.
pub fn read<T: DeserializeOwned>(path: &Path) -> Result<T> {
    let bytes = std::fs::read(path).map_err(|e| InputError::io(path, &e))?;
    serde_json::from_slice(&bytes).map_err(|e| InputError::new(path, "(json)", e.to_string()))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_value_written_pretty_into_a_new_folder_reads_back_and_ends_in_a_newline() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("a/b/value.json");
        write_pretty(&path, &serde_json::json!({"scene": "scene_000", "frames": 642})).unwrap();
        let text = std::fs::read_to_string(&path).unwrap();
        assert!(text.ends_with("}\n") && text.contains("\n  \"frames\": 642"), "{text}");
        let back: serde_json::Value = read(&path).unwrap();
        assert_eq!(back["frames"], 642);
    }

    #[test]
    fn a_file_that_is_not_json_is_refused_naming_it() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("broken.json");
        std::fs::write(&path, "{not json").unwrap();
        let err = read::<serde_json::Value>(&path).unwrap_err().to_string();
        assert!(err.contains("broken.json") && err.contains("(json)"), "{err}");
        assert!(read::<serde_json::Value>(&dir.path().join("missing.json")).unwrap_err().to_string().contains("missing.json"));
    }
}
