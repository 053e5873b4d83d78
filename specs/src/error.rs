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

/// The longest message an error keeps, in bytes: the loader's own sentences with the names
/// they list are well under it, and a message quoting the input (serde's "unknown field
/// `...`") stays one readable line when that input is a 100,000-character key.
pub const MESSAGE_BYTES_MAX: usize = 2000;

/// `message` cut to [`MESSAGE_BYTES_MAX`] bytes at a character boundary, saying how much went.
fn bounded(message: String) -> String {
    if message.len() <= MESSAGE_BYTES_MAX {
        return message;
    }
    let mut end = MESSAGE_BYTES_MAX;
    while !message.is_char_boundary(end) {
        end -= 1;
    }
    format!("{}... ({} more bytes)", &message[..end], message.len() - end)
}

impl SpecError {
    pub fn at(file: &Path, position: Position, message: impl Into<String>) -> Self {
        SpecError { file: file.to_path_buf(), position: Some(position), message: bounded(message.into()) }
    }

    pub fn whole_file(file: &Path, message: impl Into<String>) -> Self {
        SpecError { file: file.to_path_buf(), position: None, message: bounded(message.into()) }
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_error_quoting_a_huge_key_is_cut_to_a_readable_line_that_says_how_much_went() {
        // Issue 15's 100,000-character key came back whole in "unknown field `kkk...`".
        let key = "k".repeat(100_000);
        let e = SpecError::at(Path::new("t.yaml"), Position { line: 7, column: 3 }, format!("unknown field `{key}`"));
        assert!(e.message.len() < MESSAGE_BYTES_MAX + 40, "{} bytes", e.message.len());
        assert!(e.message.ends_with("more bytes)"), "{}", &e.message[e.message.len() - 40..]);
        assert!(e.to_string().starts_with("t.yaml:7:3: unknown field `kkk"));
        // Cut at a character boundary, never inside one.
        let e = SpecError::whole_file(Path::new("t"), "é".repeat(MESSAGE_BYTES_MAX));
        assert!(e.message.starts_with('é') && e.message.len() < MESSAGE_BYTES_MAX + 40);
        let short = SpecError::whole_file(Path::new("t"), "not a regular file (a FIFO)");
        assert_eq!(short.message, "not a regular file (a FIFO)");
    }
}
