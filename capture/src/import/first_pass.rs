//! What the first pass over a log found ([`super::CardScan`]), remembered for the process.
//!
//! `pmacwd replay` opens the same log a dozen times (the steps alone, I40's evidence, each
//! search, each explanation); every open needs the card the first pass reads (I8, I40, I41,
//! I10, the servo clock of the X:$0 reads) before its first step. On a day-long log that pass
//! cost a fifth of the run, once per open. Remembered here, keyed by the file's content (a
//! hash of its bytes, which costs a read, not a parse), so a file rewritten in place between
//! two opens is scanned again.

use super::{CardFromLog, LogFormat};
use std::collections::HashMap;
use std::hash::{Hash, Hasher};
use std::path::Path;
use std::sync::Mutex;

/// How many logs are remembered; past it the memory starts over (a process judges one log,
/// a test binary a few hundred small ones).
const LOGS_MAX: usize = 16;

#[derive(Clone, PartialEq, Eq, Hash)]
struct Key {
    path: std::path::PathBuf,
    format: LogFormat,
    configured_hz: u32,
    /// The ranges of I8, I40 and I41 the scan checked the values against (`CardScan::finish`).
    ranges: String,
    len: u64,
    content: u64,
}

static REMEMBERED: Mutex<Option<HashMap<Key, CardFromLog>>> = Mutex::new(None);

fn key(path: &Path, format: LogFormat, configured_hz: u32, ranges: String) -> Option<Key> {
    use std::io::Read;
    let mut file = std::fs::File::open(path).ok()?;
    let mut h = std::hash::BuildHasher::build_hasher(&foldhash::fast::FixedState::default());
    let mut buf = vec![0u8; 1 << 16];
    let mut len = 0u64;
    loop {
        let n = file.read(&mut buf).ok()?;
        if n == 0 {
            break;
        }
        buf[..n].hash(&mut h);
        len += n as u64;
    }
    Some(Key { path: path.to_path_buf(), format, configured_hz, ranges, len, content: h.finish() })
}

/// The first pass's finding for this log, if this process scanned the same content before.
pub fn remembered(
    path: &Path,
    format: LogFormat,
    configured_hz: u32,
    ranges: String,
) -> (Option<CardFromLog>, Remember) {
    let key = key(path, format, configured_hz, ranges);
    let found =
        key.as_ref().and_then(|k| REMEMBERED.lock().ok().and_then(|m| m.as_ref().and_then(|m| m.get(k).cloned())));
    (found, Remember(key))
}

/// Where to keep what a scan found (the key of the content scanned).
pub struct Remember(Option<Key>);

impl Remember {
    pub fn keep(self, found: &CardFromLog) {
        let Some(key) = self.0 else { return };
        if let Ok(mut m) = REMEMBERED.lock() {
            let m = m.get_or_insert_with(HashMap::new);
            if m.len() >= LOGS_MAX {
                m.clear();
            }
            m.insert(key, found.clone());
        }
    }
}
