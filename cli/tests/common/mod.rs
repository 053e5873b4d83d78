//! What the command-line test files share.

use std::path::{Path, PathBuf};

/// A temporary directory, removed when the test is done with it.
pub struct TempDir(pub PathBuf);

impl TempDir {
    /// `pmacwd-cli-{pid}-{name}` in the system's temporary directory, made empty.
    pub fn new(name: &str) -> TempDir {
        let dir = std::env::temp_dir().join(format!("pmacwd-cli-{}-{name}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).unwrap();
        TempDir(dir)
    }
}

impl Drop for TempDir {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.0);
    }
}

impl std::ops::Deref for TempDir {
    type Target = Path;
    fn deref(&self) -> &Path {
        &self.0
    }
}

impl AsRef<std::ffi::OsStr> for TempDir {
    fn as_ref(&self) -> &std::ffi::OsStr {
        self.0.as_os_str()
    }
}
