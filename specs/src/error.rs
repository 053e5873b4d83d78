//! One error type for every way a spec directory can be unusable.
//!
//! Every error names the file and, whenever the problem is inside a file, the 1-based line
//! and column of the offending key or value, so an editor can jump straight to it.

use std::fmt;
use std::path::{Path, PathBuf};

/// A position inside a YAML file, 1-based like editors show it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Position {
    pub line: usize,
    pub column: usize,
}

/// Why a spec directory (or one file of it) cannot be used.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct SpecError {
    pub file: PathBuf,
    /// `None` when the problem is the file as a whole (missing, unreadable).
    pub position: Option<Position>,
    pub message: String,
}

impl SpecError {
    pub fn at(file: &Path, position: Position, message: impl Into<String>) -> Self {
        SpecError { file: file.to_path_buf(), position: Some(position), message: message.into() }
    }

    pub fn whole_file(file: &Path, message: impl Into<String>) -> Self {
        SpecError { file: file.to_path_buf(), position: None, message: message.into() }
    }
}

impl fmt::Display for SpecError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self.position {
            Some(p) => write!(f, "{}:{}:{}: {}", self.file.display(), p.line, p.column, self.message),
            None => write!(f, "{}: {}", self.file.display(), self.message),
        }
    }
}

impl std::error::Error for SpecError {}
