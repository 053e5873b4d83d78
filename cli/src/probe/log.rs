//! The campaign's record: a stamped host log (docs/capturing.md) written as the exchanges
//! happen, so that `pmacwd replay` can judge it again, and the same exchanges kept in memory
//! with the check and unit each one belongs to, for judging the log without some units.

use super::check::Check;
use super::wire::Reply;
use std::fs::File;
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};
use std::time::SystemTime;

/// One command line and its reply, where the log holds it.
#[derive(Clone, Debug)]
pub struct Exchange {
    pub line: String,
    pub reply: Reply,
    pub sent: SystemTime,
    pub got: SystemTime,
    /// The log's line number of the `>` line.
    pub log_line: usize,
    pub check: &'static Check,
    /// The unit the exchange belongs to.
    pub unit: usize,
}

pub struct HostLog {
    path: PathBuf,
    out: BufWriter<File>,
    lines: usize,
    pub exchanges: Vec<Exchange>,
}

impl HostLog {
    pub fn create(path: &Path) -> Result<HostLog, String> {
        let file = File::create(path).map_err(|e| format!("{}: cannot write the log: {e}", path.display()))?;
        Ok(HostLog { path: path.to_path_buf(), out: BufWriter::new(file), lines: 0, exchanges: Vec::new() })
    }

    pub fn comment(&mut self, text: &str) -> Result<(), String> {
        for l in text.lines() {
            self.write_line(&format!("# {l}"))?;
        }
        Ok(())
    }

    pub fn record(
        &mut self,
        line: &str,
        reply: Reply,
        sent: SystemTime,
        got: SystemTime,
        check: &'static Check,
        unit: usize,
    ) -> Result<(), String> {
        self.write_line(&format!("{} > {line}", stamp(sent)))?;
        let log_line = self.lines;
        let text = reply.log_text();
        self.write_line(&format!("{} <{}{text}", stamp(got), if text.is_empty() { "" } else { " " }))?;
        // Each exchange is on disk as soon as it is complete: a probe stopped half-way leaves a
        // log that replay reads.
        self.out.flush().map_err(|e| format!("{}: {e}", self.path.display()))?;
        self.exchanges.push(Exchange { line: line.to_string(), reply, sent, got, log_line, check, unit });
        Ok(())
    }

    fn write_line(&mut self, text: &str) -> Result<(), String> {
        self.lines += 1;
        writeln!(self.out, "{text}").map_err(|e| format!("{}: {e}", self.path.display()))
    }

    pub fn finish(mut self) -> Result<Vec<Exchange>, String> {
        self.out.flush().map_err(|e| format!("{}: {e}", self.path.display()))?;
        Ok(self.exchanges)
    }
}

/// Some exchanges of the log as a host log of their own: its text, and for each of its lines the line
/// of the whole log it came from (0 for its header).
pub fn segment_text(title: &str, exchanges: &[Exchange]) -> (String, Vec<usize>) {
    let mut text = format!("# {title}\n");
    let mut map = vec![0];
    for e in exchanges {
        text.push_str(&format!("{} > {}\n", stamp(e.sent), e.line));
        map.push(e.log_line);
        let r = e.reply.log_text();
        text.push_str(&format!("{} <{}{r}\n", stamp(e.got), if r.is_empty() { "" } else { " " }));
        map.push(e.log_line + 1);
    }
    (text, map)
}

/// `YYYY-MM-DD HH:MM:SS.ffffff` in UTC (the host log's dated stamp, microsecond resolution).
pub fn stamp(t: SystemTime) -> String {
    let d = t.duration_since(SystemTime::UNIX_EPOCH).unwrap_or_default();
    let secs = d.as_secs();
    let (days, rest) = (secs / 86_400, secs % 86_400);
    let (y, m, day) = civil(days as i64);
    format!("{y:04}-{m:02}-{day:02} {:02}:{:02}:{:02}.{:06}", rest / 3600, rest / 60 % 60, rest % 60, d.subsec_micros())
}

/// Days since 1970-01-01 to a civil date (Howard Hinnant's algorithm).
fn civil(z: i64) -> (i64, u32, u32) {
    let z = z + 719_468;
    let era = z.div_euclid(146_097);
    let doe = z.rem_euclid(146_097);
    let yoe = (doe - doe / 1460 + doe / 36_524 - doe / 146_096) / 365;
    let y = yoe + era * 400;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let d = (doy - (153 * mp + 2) / 5 + 1) as u32;
    let m = if mp < 10 { mp + 3 } else { mp - 9 } as u32;
    (if m <= 2 { y + 1 } else { y }, m, d)
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::time::Duration;

    #[test]
    fn stamps_are_utc_dates_with_microseconds() {
        let t = SystemTime::UNIX_EPOCH + Duration::from_micros(1_795_000_000_123_456);
        assert_eq!(stamp(t), "2026-11-18 11:06:40.123456");
        assert_eq!(stamp(SystemTime::UNIX_EPOCH), "1970-01-01 00:00:00.000000");
        assert_eq!(civil(59), (1970, 3, 1));
        assert_eq!(civil(11_016), (2000, 2, 29));
    }
}
