//! One error type for everything that comes from outside: it names the file, the
//! field and what was expected, so a participant can act on it.

use std::fmt;
use std::path::Path;

/// A problem with an input file: which file, which field, and what was expected.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct InputError {
    /// The file (or archive member) the problem is in.
    pub file: String,
    /// The field, array, header key or line inside the file.
    pub field: String,
    /// What was expected and what was found.
    pub message: String,
}

/// Result of reading or checking outside data.
pub type Result<T> = std::result::Result<T, InputError>;

impl InputError {
    /// A problem with `field` of `file`.
    pub fn new(file: impl AsRef<Path>, field: impl Into<String>, message: impl Into<String>) -> Self {
        Self { file: file.as_ref().display().to_string(), field: field.into(), message: message.into() }
    }

    /// The file could not be opened, read or written at all.
    pub fn io(file: impl AsRef<Path>, err: &std::io::Error) -> Self {
        let message = match err.kind() {
            std::io::ErrorKind::NotFound => "file not found".to_string(),
            std::io::ErrorKind::UnexpectedEof => "file is truncated (ended early)".to_string(),
            _ => err.to_string(),
        };
        Self::new(file, "(file)", message)
    }
}

impl fmt::Display for InputError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}: {}: {}", self.file, self.field, self.message)
    }
}

impl std::error::Error for InputError {}
