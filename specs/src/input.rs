//! Reading what a user gives us, in one place: regular files only (a FIFO or a device would
//! block or never end), bounded in size, and text checked as UTF-8 with the line and column of
//! the first bad byte. Every reader of spec files, traces, captures and host logs goes through
//! here, so these limits hold for all of them; `docs/trace-format.md` lists them.

use crate::error::{Position, SpecError};
use std::fs::File;
use std::io::{BufRead, Read};
use std::path::Path;

/// A spec file (`variables.yaml`, ...): the shipped ones are under 64 KiB.
pub const SPEC_FILE_BYTES_MAX: u64 = 4 << 20;
/// A trace read whole: a YAML trace, or a JSON Lines one that `pmacwd run` runs (`replay`
/// streams JSON Lines traces of any length).
pub const YAML_TRACE_BYTES_MAX: u64 = 64 << 20;
/// One line of a JSON Lines trace or of a host log.
pub const LINE_BYTES_MAX: usize = 1 << 20;

/// The UTF-8 byte-order mark some editors put at the start of a file.
const BOM: &str = "\u{feff}";

/// Opens `path` for reading if it is a regular file (after following symlinks).
pub fn open_regular(path: &Path) -> Result<File, SpecError> {
    let meta = std::fs::metadata(path).map_err(|e| SpecError::whole_file(path, format!("cannot read: {e}")))?;
    if !meta.is_file() {
        return Err(SpecError::whole_file(path, format!("not a regular file ({})", kind_of(&meta))));
    }
    File::open(path).map_err(|e| SpecError::whole_file(path, format!("cannot read: {e}")))
}

fn kind_of(meta: &std::fs::Metadata) -> &'static str {
    let t = meta.file_type();
    if t.is_dir() {
        return "a directory";
    }
    #[cfg(unix)]
    {
        use std::os::unix::fs::FileTypeExt;
        if t.is_fifo() {
            return "a FIFO";
        }
        if t.is_char_device() || t.is_block_device() {
            return "a device";
        }
        if t.is_socket() {
            return "a socket";
        }
    }
    "not a file"
}

/// The whole text of a regular file of at most `bytes_max` bytes, without a leading
/// byte-order mark.
pub fn read_text(path: &Path, bytes_max: u64) -> Result<String, SpecError> {
    let file = open_regular(path)?;
    let mut bytes = Vec::new();
    // Read one byte past the limit, so a file that grows while it is read is caught too.
    file.take(bytes_max + 1)
        .read_to_end(&mut bytes)
        .map_err(|e| SpecError::whole_file(path, format!("cannot read: {e}")))?;
    if bytes.len() as u64 > bytes_max {
        return Err(SpecError::whole_file(
            path,
            format!("larger than {} bytes, the most this reader takes", bytes_max),
        ));
    }
    let text = utf8(path, 1, bytes)?;
    Ok(match text.strip_prefix(BOM) {
        Some(rest) => rest.to_string(),
        None => text,
    })
}

/// `bytes` as text, or an error at the line and column (in characters) of the first byte that
/// is not UTF-8. `first_line` is the line number of the first byte.
pub fn utf8(path: &Path, first_line: usize, bytes: Vec<u8>) -> Result<String, SpecError> {
    String::from_utf8(bytes).map_err(|e| {
        let good = &e.as_bytes()[..e.utf8_error().valid_up_to()];
        // The prefix is valid UTF-8 by construction.
        let good = std::str::from_utf8(good).unwrap_or_default();
        let line = first_line + good.matches('\n').count();
        let column = good.rsplit('\n').next().map_or(0, |l| l.chars().count()) + 1;
        SpecError::at(path, Position { line, column }, "not valid UTF-8 text")
    })
}

/// Reads a file line by line, each at most [`LINE_BYTES_MAX`] bytes, as UTF-8 text without its
/// line end; a byte-order mark before the first line is dropped.
pub struct Lines<R: BufRead> {
    input: R,
    path: std::path::PathBuf,
    line: usize,
    buffer: Vec<u8>,
}

impl<R: BufRead> Lines<R> {
    pub fn new(path: &Path, input: R) -> Lines<R> {
        Lines { input, path: path.to_path_buf(), line: 0, buffer: Vec::new() }
    }

    /// The line number of the line last returned.
    pub fn line(&self) -> usize {
        self.line
    }

    /// The next line and its number; `None` at the end.
    #[allow(clippy::should_implement_trait)]
    pub fn next(&mut self) -> Result<Option<(usize, String)>, SpecError> {
        self.buffer.clear();
        self.line += 1;
        let limit = LINE_BYTES_MAX as u64 + 1;
        let n = (&mut self.input)
            .take(limit)
            .read_until(b'\n', &mut self.buffer)
            .map_err(|e| SpecError::whole_file(&self.path, format!("cannot read: {e}")))?;
        if n == 0 {
            return Ok(None);
        }
        if self.buffer.len() > LINE_BYTES_MAX {
            return Err(SpecError::at(
                &self.path,
                Position { line: self.line, column: 1 },
                format!("line longer than {LINE_BYTES_MAX} bytes, the most a line may have"),
            ));
        }
        while matches!(self.buffer.last(), Some(b'\n' | b'\r')) {
            self.buffer.pop();
        }
        let mut text = utf8(&self.path, self.line, std::mem::take(&mut self.buffer))?;
        if self.line == 1 {
            if let Some(rest) = text.strip_prefix(BOM) {
                text = rest.to_string();
            }
        }
        Ok(Some((self.line, text)))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bad_utf8_is_reported_at_its_line_and_column() {
        let e = utf8(Path::new("t"), 1, b"ok\nab\xffcd\n".to_vec()).unwrap_err();
        assert_eq!(e.position, Some(Position { line: 2, column: 3 }));
        let e = utf8(Path::new("t"), 100_002, b"\xc3(".to_vec()).unwrap_err();
        assert_eq!(e.position, Some(Position { line: 100_002, column: 1 }));
    }

    #[test]
    fn a_line_past_the_limit_is_an_error_with_its_number_and_the_reader_stays_bounded() {
        let mut text = b"{}\n".to_vec();
        text.extend(std::iter::repeat_n(b'x', LINE_BYTES_MAX + 10));
        let mut lines = Lines::new(Path::new("t.jsonl"), text.as_slice());
        assert_eq!(lines.next().unwrap(), Some((1, "{}".to_string())));
        let e = lines.next().unwrap_err();
        assert_eq!(e.position, Some(Position { line: 2, column: 1 }));
        assert!(e.message.contains("longer than"), "{}", e.message);
    }

    #[test]
    fn a_byte_order_mark_and_crlf_line_ends_are_dropped() {
        let mut lines = Lines::new(Path::new("t"), "\u{feff}{\"a\":1}\r\nx\r\n".as_bytes());
        assert_eq!(lines.next().unwrap(), Some((1, "{\"a\":1}".to_string())));
        assert_eq!(lines.next().unwrap(), Some((2, "x".to_string())));
        assert_eq!(lines.next().unwrap(), None);
    }

    #[test]
    fn only_regular_files_are_opened() {
        let e = open_regular(Path::new("/dev/null")).unwrap_err();
        assert!(e.message.contains("not a regular file (a device)"), "{}", e.message);
        let e = open_regular(Path::new("/")).unwrap_err();
        assert!(e.message.contains("a directory"), "{}", e.message);
    }
}
