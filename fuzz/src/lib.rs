//! What the fuzz targets share: the checks every error of a strict reader must pass.
//!
//! The readers promise (`specs/src/error.rs`) that every error names its file and, when the
//! problem is inside the file, a 1-based line and column an editor can jump to. The targets
//! check that promise on every error they provoke, not only that nothing panics.

use pmacwd_specs::SpecError;
use std::path::Path;

/// How many lines `text` has for a YAML reader: `\r\n`, `\r`, `\n` and the Unicode line breaks
/// YAML 1.1 knows (NEL, LS, PS) each end one. A position may be one line past the last break
/// (the end of the text).
pub fn yaml_lines(text: &str) -> usize {
    let mut breaks = 0;
    let mut chars = text.chars().peekable();
    while let Some(c) = chars.next() {
        match c {
            '\r' => {
                if chars.peek() == Some(&'\n') {
                    chars.next();
                }
                breaks += 1;
            }
            '\n' | '\u{85}' | '\u{2028}' | '\u{2029}' => breaks += 1,
            _ => {}
        }
    }
    breaks + 1
}

/// How many lines `bytes` has for a line reader (only `\n` ends a line).
pub fn newline_lines(bytes: &[u8]) -> usize {
    bytes.iter().filter(|&&b| b == b'\n').count() + 1
}

/// An error of a reader given `file`: it names that file, says something, and a position, if
/// any, is 1-based and no further down than `lines`.
pub fn check_error(e: &SpecError, file: &Path, lines: usize) {
    assert_eq!(e.file, file, "the error names another file: {e}");
    assert!(!e.message.trim().is_empty(), "an error without a message: {e:?}");
    if let Some(p) = e.position {
        assert!(p.line >= 1 && p.column >= 1, "a position that is not 1-based: {e:?}");
        assert!(p.line <= lines, "line {} of a text of {lines} lines: {e:?}", p.line);
    }
}
