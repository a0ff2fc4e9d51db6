//! The release's class lexicon and the semantic normalisation of free-text object
//! names to it ("King Bed" → bed, "Coffee Mug" → mug, "Swivel Office Chair" → office
//! chair). Names that match nothing are reported, never silently dropped.

use serde::{Deserialize, Serialize};

use crate::classes::table;

/// Classes of the room's shell (and "other", names that matched nothing): not objects
/// a trajectory must observe or a question asks about.
pub fn is_shell_class(name: &str) -> bool {
    table().is_shell(name)
}

/// The lexicon entry of a class.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct ClassEntry {
    pub name: String,
    pub id: i64,
}

/// Every class as `{"name", "id"}`.
pub fn classes() -> Vec<ClassEntry> {
    table().classes().iter().map(|c| ClassEntry { name: c.name.clone(), id: c.id }).collect()
}

/// The id of canonical class `name`.
pub fn class_id(name: &str) -> Option<i64> {
    table().class(name).map(|c| c.id)
}

/// Lower case, punctuation and underscores as spaces, the last word singular.
fn normalise(name: &str) -> Vec<String> {
    let mut words: Vec<String> = name.to_lowercase().split(|c: char| !c.is_alphanumeric()).filter(|w| !w.is_empty()).map(str::to_string).collect();
    // Trailing numbers and hashes (chair 2, desk_0) are not part of the category.
    while words.last().is_some_and(|w| w.chars().all(|c| c.is_ascii_digit())) {
        words.pop();
    }
    if let Some(last) = words.last_mut() {
        let singular = if let Some(stem) = last.strip_suffix("shelves") {
            format!("{stem}shelf")
        } else if last.ends_with("ches") || last.ends_with("shes") || last.ends_with("xes") || last.ends_with("sses") {
            last[..last.len() - 2].to_string()
        } else if last.ends_with('s') && !last.ends_with("ss") && last.len() > 3 {
            last[..last.len() - 1].to_string()
        } else {
            last.clone()
        };
        *last = singular;
    }
    words
}

fn lookup(phrase: &str) -> Option<&'static str> {
    table().classes().iter().find(|c| c.name == phrase || c.synonyms.iter().any(|s| s == phrase)).map(|c| c.name.as_str())
}

/// The canonical class of a free-text object name: the whole name, then ever shorter
/// endings of it ("swivel office chair" → "office chair"), as a class or a synonym.
pub fn normalise_name(name: &str) -> Option<&'static str> {
    let words = normalise(name);
    (0..words.len()).find_map(|start| lookup(&words[start..].join(" ")))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn free_text_names_find_their_class() {
        for (name, class) in [
            ("King Bed", "bed"),
            ("Work Desk", "desk"),
            ("Office Chair", "office chair"),
            ("Swivel Office Chair", "office chair"),
            ("Coffee Mug", "mug"),
            ("dining_chair_3", "dining chair"),
            ("Bookshelves", "bookshelf"),
            ("Boxes", "box"),
            ("Printer", "printer"),
        ] {
            assert_eq!(normalise_name(name), Some(class), "{name}");
        }
        assert_eq!(normalise_name("Grand Piano"), None);
    }

    #[test]
    fn ids_are_positions_and_fit_sixteen_bits() {
        assert_eq!(class_id("other"), Some(0));
        assert_eq!(classes().len(), table().classes().len());
        assert!(classes().iter().enumerate().all(|(i, c)| c.id == i as i64));
        assert!(classes().len() < 65_536);
    }
}
