//! The class list of a release or sequence: `{"classes": [{"name", "id"}]}`
//! (`embed_semseg_classes.json`, `classes.json`).

use std::collections::BTreeMap;
use std::path::Path;

use serde::{Deserialize, Serialize};

use crate::error::{InputError, Result};

/// One semantic class.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct ClassEntry {
    /// Display name, e.g. `chair`.
    pub name: String,
    /// Class id as stored in semantic images and labels.
    pub id: i64,
}

/// The classes of a release, unique by id.
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub struct ClassList {
    by_id: BTreeMap<i64, String>,
}

#[derive(Serialize, Deserialize)]
struct ClassFile {
    classes: ClassListJson,
}

#[derive(Serialize, Deserialize)]
#[serde(untagged)]
enum ClassListJson {
    List(Vec<ClassEntry>),
    /// OSMa-Bench-v2's HaDaGe patch wraps the list twice; accept it.
    Nested {
        classes: Vec<ClassEntry>,
    },
}

impl ClassList {
    /// A class list from entries; ids must be unique.
    pub fn new(entries: impl IntoIterator<Item = ClassEntry>) -> std::result::Result<Self, String> {
        let mut by_id = BTreeMap::new();
        for entry in entries {
            if let Some(previous) = by_id.insert(entry.id, entry.name.clone()) {
                return Err(format!("class id {} is listed twice ('{previous}' and '{}')", entry.id, entry.name));
            }
        }
        Ok(Self { by_id })
    }

    /// Read a class list file.
    pub fn read(path: &Path) -> Result<Self> {
        let text = std::fs::read(path).map_err(|e| InputError::io(path, &e))?;
        let file: ClassFile = serde_json::from_slice(&text)
            .map_err(|e| InputError::new(path, "classes", format!("expected {{\"classes\": [{{\"name\": str, \"id\": int}}, ...]}}: {e}")))?;
        let entries = match file.classes {
            ClassListJson::List(list) | ClassListJson::Nested { classes: list } => list,
        };
        Self::new(entries).map_err(|m| InputError::new(path, "classes", m))
    }

    /// Write `{"classes": [...]}` sorted by id.
    pub fn write(&self, path: &Path) -> Result<()> {
        let file = ClassFile { classes: ClassListJson::List(self.entries()) };
        let text = serde_json::to_string_pretty(&file).expect("class lists serialise");
        std::fs::write(path, text + "\n").map_err(|e| InputError::io(path, &e))
    }

    /// Entries sorted by id.
    pub fn entries(&self) -> Vec<ClassEntry> {
        self.by_id.iter().map(|(&id, name)| ClassEntry { name: name.clone(), id }).collect()
    }

    /// Whether `id` is a class of this list.
    pub fn contains(&self, id: i64) -> bool {
        self.by_id.contains_key(&id)
    }

    /// Name of class `id`.
    pub fn name(&self, id: i64) -> Option<&str> {
        self.by_id.get(&id).map(String::as_str)
    }

    /// Number of classes.
    pub fn len(&self) -> usize {
        self.by_id.len()
    }

    /// Whether the list is empty.
    pub fn is_empty(&self) -> bool {
        self.by_id.is_empty()
    }
}
