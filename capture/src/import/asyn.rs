//! An EPICS IOC's asyn trace of the pmac driver's port, read as the exchanges a host log
//! carries (`docs/capturing.md`, "EPICS asyn trace"). The trace interleaves the driver's own
//! lines and asyn's I/O lines:
//!
//! ```text
//! 2026/11/26 14:47:10.820 pmacMessageBroker::lowLevelWriteRead: command: I68
//! 2026/11/26 14:47:10.820 127.0.0.1:45459 write 8
//! @\xb3\x00\x00\x00\x00\x00\x00
//! 2026/11/26 14:47:10.820 127.0.0.1:45459 read 1
//! \x18
//! 2026/11/26 14:47:10.820 127.0.0.1:45459 write 12
//! @\xbf\x00\x00\x00\x00\x00\x04I68\n
//! 2026/11/26 14:47:10.820 127.0.0.1:45459 read 4
//! 15\r\x06
//! 2026/11/26 14:47:10.820 pmacMessageBroker::lowLevelWriteRead: response: 15
//! ```
//!
//! The command line is the driver's `command:` line (asyn cuts a `write N` line's data at its
//! truncate size, 80 bytes by default); the request headers are decoded as the emulator decodes
//! them ([`pmacwd_specs::protocol::Header`]), and the GETRESPONSE's data is checked against
//! the `command:` line. The answer is the card's byte stream after the GETRESPONSE (every
//! `read N` until the `response:` line, in order), up to its ACK or the CR ending an error, as
//! the recording proxy reads it: the driver's own `response:` line drops the CRs between
//! values, and loses an answer that came late. FLUSH requests and their CTRL-X are not
//! commands. No byte after the GETRESPONSE is silence (`(timeout)`), whether the driver then
//! logged `pmacFlush failed`, `pmacReadReady failed` or nothing. When a read's data line is
//! cut before the answer ends, the values seen are kept, and the `response:` line (the answer
//! with its CRs taken out) gives the one value left, if exactly one is; otherwise the rest are
//! kept as answered but not shown ([`super::Answer::Unseen`]).
//!
//! Lines that are neither (the IOC shell, other drivers' messages, record names) are counted
//! in the summary, never read as exchanges. Only asyn's escaped I/O form
//! (`asynSetTraceIOMask(port, 0, 2)`) can be read: the ASCII form (mask 1) writes the raw
//! bytes, the request headers' and CRs included, so a data line cannot be told from the next.

use super::{parse_stamp, Cut, Record, Records, Stamp};
use pmacwd_specs::input::Lines;
use pmacwd_specs::protocol::{trim_line, Header, Request, HEADER_BYTES};
use pmacwd_specs::{Position, SpecError};
use std::collections::VecDeque;
use std::io::BufRead;
use std::path::{Path, PathBuf};

const COMMAND: &str = "pmacMessageBroker::lowLevelWriteRead: command:";
const RESPONSE: &str = "pmacMessageBroker::lowLevelWriteRead: response:";

/// The most reply bytes kept for one command: past it the answer is cut as a truncated data
/// line is (bounded memory whatever the trace).
const REPLY_BYTES_MAX: usize = 64 << 10;

const ACK: u8 = 0x06;
const BEL: u8 = 0x07;
const CR: u8 = b'\r';

/// Whether a line is one of the asyn trace's own: the pmac driver's `command:` line or an asyn
/// `PORT write N` / `PORT read N` line.
pub fn is_asyn_line(line: &str) -> bool {
    line.contains(COMMAND) || io_line(line).is_some()
}

/// An asyn I/O line (`[stamp] PORT write N` or `read N`): whether it is a write, and N.
fn io_line(line: &str) -> Option<(bool, usize)> {
    // Without a stamp (asynSetTraceInfoMask without the time) the line starts with the port,
    // which may start with a digit (`127.0.0.1:1025`).
    let rest = match parse_stamp(line) {
        Ok((_, off)) => &line[off..],
        Err(_) => line,
    };
    let mut words = rest.split(' ');
    let (port, dir, n) = (words.next()?, words.next()?, words.next()?);
    if words.next().is_some() || port.is_empty() {
        return None;
    }
    let write = match dir {
        "write" => true,
        "read" => false,
        _ => return None,
    };
    Some((write, n.parse().ok()?))
}

/// asyn's escaped form of bytes (`epicsStrnEscapedFromRaw`) read back; `Err` with the column
/// of what is not the escaped form.
fn unescape(s: &str) -> Result<Vec<u8>, (usize, String)> {
    let b = s.as_bytes();
    let mut out = Vec::with_capacity(b.len());
    let mut i = 0;
    while i < b.len() {
        let c = b[i];
        if c == b'\\' {
            let e = b.get(i + 1).copied();
            let byte =
                match e {
                    Some(b'a') => 0x07,
                    Some(b'b') => 0x08,
                    Some(b'f') => 0x0C,
                    Some(b'n') => b'\n',
                    Some(b'r') => b'\r',
                    Some(b't') => b'\t',
                    Some(b'v') => 0x0B,
                    Some(b'\\') => b'\\',
                    Some(b'\'') => b'\'',
                    Some(b'"') => b'"',
                    Some(b'x') => {
                        let hex = b.get(i + 2..i + 4).and_then(|h| std::str::from_utf8(h).ok());
                        match hex.and_then(|h| u8::from_str_radix(h, 16).ok()) {
                            Some(v) => {
                                out.push(v);
                                i += 4;
                                continue;
                            }
                            None => return Err((i + 1, "`\\x` needs two hex digits".into())),
                        }
                    }
                    _ => return Err((
                        i + 1,
                        "an unknown escape: asyn's escaped form has \\a \\b \\f \\n \\r \\t \\v \\\\ \\' \\\" \\xHH"
                            .into(),
                    )),
                };
            out.push(byte);
            i += 2;
        } else if (0x20..0x7F).contains(&c) {
            out.push(c);
            i += 1;
        } else {
            return Err((
                i + 1,
                format!(
                    "byte 0x{c:02X} is not asyn's escaped form: trace the port with asynSetTraceIOMask(port, 0, 2) \
                     (escaped); the ASCII form (1) cannot be read back"
                ),
            ));
        }
    }
    Ok(out)
}

/// The command whose `command:` line was read and whose `response:` line has not come yet.
struct Pending {
    line: usize,
    column: usize,
    stamp: Option<Stamp>,
    text: String,
    /// The GETRESPONSE carrying the command went out (its data line).
    sent: Option<usize>,
    /// The card's bytes since the GETRESPONSE, as far as the trace shows them.
    stream: Vec<u8>,
    /// A data line after the GETRESPONSE was cut: bytes are missing after `stream`. The line.
    hole: Option<usize>,
}

/// The records of an asyn trace, read line by line.
pub struct AsynRecords<R: BufRead> {
    file: PathBuf,
    lines: Lines<R>,
    queue: VecDeque<Record>,
    pending: Option<Pending>,
    /// Lines that are not the trace's (the IOC's own output): count and first line.
    other: (u64, usize),
    /// Lines with other output run into them before their stamp.
    glued: u64,
    /// Empty command lines (the driver's connection checks): answered, silent.
    empty: (u64, u64),
    /// The driver's failure lines (`pmacFlush failed`, `pmacReadReady failed`).
    failures: u64,
    /// I/O lines outside a `command:` ... `response:` pair.
    outside: u64,
    /// Commands the driver never sent (no GETRESPONSE before its `response:`).
    not_sent: u64,
}

impl<R: BufRead> AsynRecords<R> {
    pub fn new(file: &Path, input: R) -> AsynRecords<R> {
        AsynRecords {
            file: file.to_path_buf(),
            lines: Lines::new(file, input),
            queue: VecDeque::new(),
            pending: None,
            other: (0, 0),
            glued: 0,
            empty: (0, 0),
            failures: 0,
            outside: 0,
            not_sent: 0,
        }
    }

    fn err(&self, line: usize, column: usize, msg: impl Into<String>) -> SpecError {
        SpecError::at(&self.file, Position { line, column }, msg.into())
    }

    /// The stamp just before `at` on `raw` (the driver's line may have other output run into
    /// it before the stamp), and whether there was such output.
    fn stamp_before(&self, n: usize, raw: &str, at: usize) -> Result<(Option<Stamp>, bool), SpecError> {
        let before = raw[..at].trim_end_matches(' ');
        if before.is_empty() {
            return Ok((None, false));
        }
        // The time is the last word; a date `YYYY/MM/DD` (10 characters) and a space may come
        // before it.
        let time_start = before.rfind(' ').map_or(0, |i| i + 1);
        if !before[time_start..].starts_with(|c: char| c.is_ascii_digit()) {
            // No stamp (a trace without the time), only other output run into the line.
            return Ok((None, true));
        }
        let dated = time_start >= 11
            && before.as_bytes()[time_start - 1] == b' '
            && matches!(before.as_bytes()[time_start - 7], b'/' | b'-');
        let start = if dated { time_start - 11 } else { time_start };
        match parse_stamp(&raw[start..]) {
            Ok((stamp, off)) if start + off == at => Ok((Some(stamp), start > 0)),
            Ok(_) => Err(self.err(n, start + 1, "expected a timestamp right before the pmac driver's message")),
            Err((col, m)) => Err(self.err(n, start + col, m)),
        }
    }

    fn read_line(&mut self) -> Result<Option<(usize, String)>, SpecError> {
        self.lines.next()
    }

    /// Line `n` of the trace.
    fn take_line(&mut self, n: usize, raw: &str) -> Result<(), SpecError> {
        if let Some(p) = raw.find(COMMAND) {
            let (stamp, glued) = self.stamp_before(n, raw, p)?;
            self.glued += u64::from(glued);
            if let Some(prev) = &self.pending {
                return Err(self.err(
                    n,
                    p + 1,
                    format!("the command on line {} has no `response:` line before this one", prev.line),
                ));
            }
            let after = p + COMMAND.len();
            let text = raw[after..].strip_prefix(' ').unwrap_or(&raw[after..]);
            let column = raw.len() - text.len() + 1;
            self.pending = Some(Pending {
                line: n,
                column,
                stamp,
                text: text.to_string(),
                sent: None,
                stream: Vec::new(),
                hole: None,
            });
            return Ok(());
        }
        if let Some(p) = raw.find(RESPONSE) {
            let (stamp, glued) = self.stamp_before(n, raw, p)?;
            if raw[..p].contains("pmacFlush failed") || raw[..p].contains("pmacReadReady failed") {
                self.failures += 1;
            }
            self.glued += u64::from(glued);
            let after = p + RESPONSE.len();
            let response = raw[after..].strip_prefix(' ').unwrap_or(&raw[after..]).trim_end();
            let column = after + 2;
            let Some(pending) = self.pending.take() else {
                return Err(self.err(n, p + 1, "a `response:` line without a `command:` line before it"));
            };
            return self.respond(pending, n, column, stamp, response);
        }
        if let Some((write, bytes)) = io_line(raw) {
            let Some((m, data)) = self.read_line()? else {
                return Err(self.err(n, 1, "the trace ends before this I/O line's data line"));
            };
            let shown = unescape(&data).map_err(|(col, msg)| self.err(m, col, msg))?;
            if shown.len() > bytes {
                return Err(self.err(m, 1, format!("{} bytes shown for a {bytes}-byte transfer", shown.len())));
            }
            let cut = shown.len() < bytes;
            let file = self.file.clone();
            let err = |column: usize, msg: String| SpecError::at(&file, Position { line: m, column }, msg);
            let Some(pending) = self.pending.as_mut() else {
                self.outside += 1;
                return Ok(());
            };
            if write {
                let Some(head) = shown.get(..HEADER_BYTES) else {
                    return Err(err(1, "a request shorter than its 8-byte header".into()));
                };
                let head: [u8; HEADER_BYTES] = head.try_into().expect("8 bytes");
                let request = Header::parse(&head).request().map_err(|e| err(1, format!("request header: {e}")))?;
                match request {
                    Request::Line { reply: true, .. } => {
                        let data = &shown[HEADER_BYTES..];
                        let sent = if cut { data } else { trim_line(data) };
                        let ok = if cut {
                            pending.text.as_bytes().starts_with(sent)
                        } else {
                            pending.text.as_bytes() == sent
                        };
                        if !ok {
                            let (line, text) = (pending.line, pending.text.clone());
                            return Err(err(
                                1,
                                format!(
                                    "this GETRESPONSE carries `{}`, not the command `{text}` of line {line}",
                                    String::from_utf8_lossy(sent)
                                ),
                            ));
                        }
                        pending.sent = Some(m);
                        pending.stream.clear();
                        pending.hole = None;
                    }
                    Request::Line { reply: false, .. } => {
                        return Err(err(
                            1,
                            "a SENDLINE request: the asyn importer reads the pmac driver's GETRESPONSE exchanges only"
                                .into(),
                        ));
                    }
                    Request::Control(c) => {
                        return Err(err(
                            1,
                            format!(
                                "a control-character request (0x{c:02X}): the asyn importer reads the pmac driver's \
                                 GETRESPONSE exchanges only"
                            ),
                        ));
                    }
                    // A FLUSH and its CTRL-X, READREADY, GETBUFFER: their bytes are in the card's
                    // stream after the GETRESPONSE; the answer ends where it ends.
                    Request::Flush | Request::ReadReady | Request::NextPacket => {}
                }
            } else if pending.sent.is_some() && pending.hole.is_none() {
                let room = REPLY_BYTES_MAX - pending.stream.len();
                pending.stream.extend_from_slice(&shown[..shown.len().min(room)]);
                if cut || shown.len() > room {
                    pending.hole = Some(m);
                }
            }
            return Ok(());
        }
        if raw.contains("pmacFlush failed") || raw.contains("pmacReadReady failed") {
            self.failures += 1;
            return Ok(());
        }
        if self.other.0 == 0 {
            self.other.1 = n;
        }
        self.other.0 += 1;
        Ok(())
    }

    /// The `response:` line `n` of `pending`: its records.
    fn respond(
        &mut self,
        pending: Pending,
        n: usize,
        column: usize,
        stamp: Option<Stamp>,
        response: &str,
    ) -> Result<(), SpecError> {
        if pending.sent.is_none() {
            self.not_sent += 1;
            return Ok(());
        }
        let s = &pending.stream;
        // The answer's end: its ACK, or the CR after an error's number (BEL ERRnnn CR).
        let mut end = None;
        let mut in_error = false;
        for (i, &b) in s.iter().enumerate() {
            match b {
                ACK => {
                    end = Some(i);
                    break;
                }
                BEL => in_error = true,
                CR if in_error && i > 0 && s[i - 1].is_ascii_digit() => {
                    end = Some(i + 1);
                    break;
                }
                _ => {}
            }
        }
        let response_values = super::reply_values(response.as_bytes());
        let (text, cut) = match (end, pending.hole) {
            // The driver's `response:` line is the answer as it read it, raw (CRs and the BEL of
            // an error kept), without the ACK: whole even where asyn cut a data line. The reads
            // that show the answer's end must agree with it.
            _ if !response.is_empty() => {
                if let Some(e) = end {
                    if super::reply_values(&s[..e]) != response_values {
                        return Err(self.err(
                            n,
                            column,
                            format!(
                                "the `response:` line is not what the reads after the GETRESPONSE (line {}) show: \
                                 `{}`",
                                pending.sent.unwrap_or(0),
                                super::reply_values(&s[..e]).join("\\r")
                            ),
                        ));
                    }
                }
                (response_values.join("\\r"), None)
            }
            // No `response:`: the driver lost an answer that came late (after a READREADY), or
            // the answer was only an ACK, or nothing came.
            (Some(e), _) => (super::reply_values(&s[..e]).join("\\r"), None),
            (None, Some(hole)) => {
                let whole = match s.iter().rposition(|b| *b == CR) {
                    Some(i) => super::reply_values(&s[..i]),
                    None => Vec::new(),
                };
                let why = format!(
                    "asyn cut the data line {hole} (its truncate size) and the driver's `response:` line on line {n} \
                     is empty"
                );
                (whole.join("\\r"), Some(Cut { rest: String::new(), why }))
            }
            (None, None) if s.iter().all(|b| *b == 0) => ("(timeout)".to_string(), None),
            (None, None) => (super::reply_values(s).join("\\r"), None),
        };
        if pending.text.trim().is_empty() {
            // The driver's connection check: an empty line, not a command of the card's
            // language.
            if text == "(timeout)" {
                self.empty.1 += 1;
            } else {
                self.empty.0 += 1;
            }
            return Ok(());
        }
        self.queue.push_back(Record::Command {
            line: pending.line,
            column: pending.column,
            stamp: pending.stamp,
            text: pending.text,
        });
        self.queue.push_back(Record::Reply { line: n, column, stamp, text, cut });
        Ok(())
    }
}

impl<R: BufRead> Records for AsynRecords<R> {
    fn next_record(&mut self) -> Result<Option<Record>, SpecError> {
        loop {
            if let Some(r) = self.queue.pop_front() {
                return Ok(Some(r));
            }
            match self.read_line()? {
                Some((n, raw)) => self.take_line(n, &raw)?,
                None => {
                    if let Some(p) = &self.pending {
                        return Err(self.err(
                            p.line,
                            p.column,
                            "this command has no `response:` line at the end of the trace",
                        ));
                    }
                    return Ok(None);
                }
            }
        }
    }

    fn passed_over(&self) -> Vec<String> {
        let mut out = Vec::new();
        if self.other.0 > 0 {
            out.push(format!(
                "{} lines of other output (the IOC shell, other messages), the first on line {}",
                self.other.0, self.other.1
            ));
        }
        if self.glued > 0 {
            out.push(format!("{} driver lines with other output run into them before their stamp", self.glued));
        }
        if self.empty != (0, 0) {
            out.push(format!(
                "{} empty command lines (the driver's connection checks: {} answered, {} silent), not commands",
                self.empty.0 + self.empty.1,
                self.empty.0,
                self.empty.1
            ));
        }
        if self.failures > 0 {
            out.push(format!(
                "{} driver failure lines (`pmacFlush failed`, `pmacReadReady failed`): their silences are the \
                 timeouts",
                self.failures
            ));
        }
        if self.outside > 0 {
            out.push(format!("{} I/O lines outside a `command:` ... `response:` pair", self.outside));
        }
        if self.not_sent > 0 {
            out.push(format!("{} commands the driver never sent (no GETRESPONSE)", self.not_sent));
        }
        out
    }
}
