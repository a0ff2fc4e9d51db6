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

/// Why a valid submission could not be scored, by whose the problem is.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum ScoreError {
    /// A file of the submission (a map, a graph, its text features or answers) is wrong:
    /// the team's to fix; scoring it again cannot help.
    Submission(InputError),
    /// The release (its ground truth or questions) or the machine failed: the service's;
    /// scoring again may help.
    Service(InputError),
}

impl ScoreError {
    /// The error inside, whoever's it is.
    pub fn into_input_error(self) -> InputError {
        match self {
            ScoreError::Submission(e) | ScoreError::Service(e) => e,
        }
    }
}

impl fmt::Display for ScoreError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            ScoreError::Submission(e) | ScoreError::Service(e) => e.fmt(f),
        }
    }
}

impl std::error::Error for ScoreError {}

impl InputError {
    /// The same problem with its file named relative to `root` when it lies inside it (a
    /// submission's file, as its team knows it).
    pub fn relative_to(self, root: &Path) -> InputError {
        match Path::new(&self.file).strip_prefix(root) {
            Ok(inside) => InputError { file: inside.display().to_string(), ..self },
            Err(_) => self,
        }
    }
}

impl fmt::Display for InputError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}: {}: {}", self.file, self.field, self.message)
    }
}

impl std::error::Error for InputError {}
