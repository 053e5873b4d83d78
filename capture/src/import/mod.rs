//! `pmacwd import`: a plain host log (commands and replies, the servo counter X:$0 read
//! alongside, host timestamps optional) turned into a trace. The log format and what each
//! situation in a log becomes are documented in `docs/capturing.md`:
//!
//! ```text
//! # comment
//! 12:00:00.125 > ???
//! 12:00:00.127 < 001000000000
//! 12:00:00.130 > RHX:$0
//! 12:00:00.131 < 01A2B3
//! ```
//!
//! Every command becomes a `command` step expecting its reply. A host cannot see background
//! cycles, so the time between two X:$0 reads becomes an `elapsed` step (servo cycles passed,
//! nothing known of what happened meanwhile: `pmacwd replay` chooses), placed before the
//! command that read the counter; commands between two counter reads are placed at the earlier
//! read. The counter's own value is kept as the step's note, not compared.
//!
//! The log is read one line at a time, twice when the trace is written: a first pass
//! ([`CardScan`]) collects what the log says about the card (I8, I40, I41, I10 read before any
//! write), since the trace's header comes first; the second ([`Importer`]) writes the steps.
//! Both hold a bounded state whatever the log's length.

use pmacwd_specs::check::{AllKeyword, ProfileSelection};
use pmacwd_specs::config::{servo_hz_of_i10, CardConfig};
use pmacwd_specs::grammar::{self, Addressing};
use pmacwd_specs::input::Lines;
use pmacwd_specs::vocab::command::{HostCommand, Register};
use pmacwd_specs::vocab::event::Event;
use pmacwd_specs::{Position, Spec, SpecError};
use pmacwd_trace::{Expect, Step, Trace, TraceEvent, FORMAT_VERSION, STEP_CYCLES_MAX};
use std::collections::VecDeque;
use std::io::BufReader;
use std::path::{Path, PathBuf};

pub mod asyn;
mod first_pass;
pub mod pcap;

/// The configuration a log is imported under when none is named (`--configuration`).
pub const DEFAULT_CONFIGURATION: &str = "host-log";

/// The servo cycle counter wraps at 2^24 (M100->X:$000000,0,24,U).
const SERVO_COUNTER_MODULUS: u64 = 1 << 24;

/// MODEL: how far the host's clock and the card's servo clock may disagree, in percent, when
/// host time is turned into servo cycles. No manual gives the servo clock's accuracy; a
/// crystal and a host clock are both far better than 1 % (tens of ppm), so ±1 % is a generous
/// bound that also absorbs an I10 or `servo_hz` a little off the hardware (SRM p.43: I10 only
/// tells the firmware the period the hardware sets).
pub const CLOCK_TOLERANCE_PERCENT: u64 = 1;

const NS_PER_S: i128 = 1_000_000_000;

/// A host time interval in ns on the log's timeline: (earliest, latest).
type HostTime = (i128, i128);
const DAY_NS: i128 = 86_400 * NS_PER_S;

/// A host timestamp: nanoseconds since midnight (time only) or since 1970-01-01 (with a date),
/// and its resolution (a stamp with 3 fraction digits is true to 1 ms).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Stamp {
    dated: bool,
    ns: i128,
    resolution_ns: i128,
}

impl Stamp {
    /// A dated stamp `ns` nanoseconds after 1970-01-01 00:00 UTC, true to `resolution_ns`
    /// (a packet capture's timestamps).
    pub fn since_epoch(ns: i128, resolution_ns: i128) -> Stamp {
        Stamp { dated: true, ns, resolution_ns: resolution_ns.max(1) }
    }
}

/// Days since 1970-01-01 of a civil date (H. Hinnant's `days_from_civil`).
fn days_from_civil(y: i64, m: i64, d: i64) -> i64 {
    let y = if m <= 2 { y - 1 } else { y };
    let era = if y >= 0 { y } else { y - 399 } / 400;
    let yoe = y - era * 400;
    let doy = (153 * (if m > 2 { m - 3 } else { m + 9 }) + 2) / 5 + d - 1;
    let doe = yoe * 365 + yoe / 4 - yoe / 100 + doy;
    era * 146_097 + doe - 719_468
}

/// `n` ASCII digits at `at` of `b`, as a number.
fn digits(b: &[u8], at: usize, n: usize) -> Option<i64> {
    let s = b.get(at..at + n)?;
    s.iter().all(u8::is_ascii_digit).then(|| s.iter().fold(0i64, |v, c| v * 10 + i64::from(c - b'0')))
}

/// A timestamp at the start of `l` (`HH:MM:SS(.f+)`, `YYYY-MM-DD HH:MM:SS(.f+)`, with `T`
/// instead of the space, or with slashes `YYYY/MM/DD` as EPICS and many loggers write it;
/// optionally in square brackets) and the byte offset just past it and the spaces or tabs
/// after it; `Err` with the column of what is wrong.
pub(crate) fn parse_stamp(l: &str) -> Result<(Stamp, usize), (usize, String)> {
    const FORMS: &str = "`HH:MM:SS`, `HH:MM:SS.fff`, `YYYY-MM-DD HH:MM:SS(.fff)`, `YYYY/MM/DD HH:MM:SS(.fff)` \
                         or `YYYY-MM-DDTHH:MM:SS(.fff)`, optionally in [brackets], then a space or a tab";
    let b = l.as_bytes();
    let bad = |at: usize| Err((at + 1, format!("expected a timestamp ({FORMS}) before `>` or `<`")));
    let mut i = usize::from(b.first() == Some(&b'['));
    let mut day_ns = None;
    if let Some(&sep @ (b'-' | b'/')) = b.get(i + 4) {
        let (Some(y), Some(m), Some(d)) = (digits(b, i, 4), digits(b, i + 5, 2), digits(b, i + 8, 2)) else {
            return bad(i);
        };
        if b.get(i + 7) != Some(&sep) || !(1..=12).contains(&m) || !(1..=31).contains(&d) {
            return bad(i);
        }
        if !matches!(b.get(i + 10), Some(b' ' | b'T')) {
            return bad(i + 10);
        }
        day_ns = Some(i128::from(days_from_civil(y, m, d)) * DAY_NS);
        i += 11;
    }
    let (Some(h), Some(mi), Some(s)) = (digits(b, i, 2), digits(b, i + 3, 2), digits(b, i + 6, 2)) else {
        return bad(i);
    };
    if b.get(i + 2) != Some(&b':') || b.get(i + 5) != Some(&b':') || h > 23 || mi > 59 || s > 59 {
        return bad(i);
    }
    i += 8;
    let mut ns = i128::from((h * 60 + mi) * 60 + s) * NS_PER_S;
    let mut resolution_ns = NS_PER_S;
    if b.get(i) == Some(&b'.') {
        i += 1;
        let start = i;
        while b.get(i).is_some_and(u8::is_ascii_digit) {
            // Digits beyond nanoseconds say nothing more: read, not counted.
            if i - start < 9 {
                resolution_ns /= 10;
                ns += i128::from(b[i] - b'0') * resolution_ns;
            }
            i += 1;
        }
        if i == start {
            return bad(i);
        }
    }
    if b.first() == Some(&b'[') {
        if b.get(i) != Some(&b']') {
            return bad(i);
        }
        i += 1;
    }
    if !matches!(b.get(i), Some(b' ' | b'\t')) {
        return bad(i);
    }
    while matches!(b.get(i), Some(b' ' | b'\t')) {
        i += 1;
    }
    Ok((Stamp { dated: day_ns.is_some(), ns: ns + day_ns.unwrap_or(0), resolution_ns }, i))
}

/// What the card answered one command of a line.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Answer {
    /// `(timeout)`: nothing came (a tripped card is silent, UM p.215).
    Timeout,
    /// An empty reply: the command only acknowledged.
    Ack,
    /// A reply value as logged.
    Value(String),
    /// The card answered, but the record does not show what (an asyn trace cut the data line
    /// and the driver's `response:` line cannot be split): kept without an expectation.
    Unseen(String),
}

/// A reply whose end the record does not show: `rest` is what the record says the values not
/// seen add up to (the asyn driver's `response:` line with the values seen taken off), and
/// `why` says where the reply was cut.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Cut {
    pub rest: String,
    pub why: String,
}

/// One element of a log, whatever its format: a command line sent or the reply that came, with
/// its line (or packet) and column in the file and its host time.
#[derive(Clone, Debug)]
pub enum Record {
    Command {
        line: usize,
        column: usize,
        stamp: Option<Stamp>,
        text: String,
    },
    /// `text` in the host log's reply syntax (values separated by whitespace or a written `\r`,
    /// `(timeout)` for silence); `cut` when the reply's end was not recorded.
    Reply {
        line: usize,
        column: usize,
        stamp: Option<Stamp>,
        text: String,
        cut: Option<Cut>,
    },
}

/// Line `line` of a host log as a [`Record`]; `None` for a blank or comment line.
pub fn host_log_record(file: &Path, line: usize, raw: &str) -> Result<Option<Record>, SpecError> {
    let err = |column: usize, msg: String| SpecError::at(file, Position { line, column }, msg);
    let l = raw.trim_end();
    if l.trim().is_empty() || l.trim_start().starts_with('#') {
        return Ok(None);
    }
    let (stamp, off) = if l.starts_with(|c: char| c.is_ascii_digit() || c == '[') {
        let (s, off) = parse_stamp(l).map_err(|(col, m)| err(col, m))?;
        (Some(s), off)
    } else {
        (None, 0)
    };
    let rest = &l[off..];
    if let Some(cmd) = rest.strip_prefix("> ") {
        return Ok(Some(Record::Command { line, column: off + 3, stamp, text: cmd.to_string() }));
    }
    let Some(reply) = rest.strip_prefix("< ").or_else(|| (rest == "<").then_some("")) else {
        return Err(err(off + 1, "expected `> command`, `< reply`, a `#` comment or a blank line".into()));
    };
    Ok(Some(Record::Reply { line, column: off + 3, stamp, text: reply.to_string(), cut: None }))
}

/// One command of a log line and what it got.
#[derive(Clone, Debug)]
pub struct Exchanged {
    pub text: String,
    pub command: HostCommand,
    /// How many values the card answers it with (the grammar's [`Command::values`]); `None`
    /// when that depends on the card (a listing, or text the grammar cannot read).
    pub values: Option<usize>,
    pub answer: Answer,
    /// Where the command's text starts on its line.
    pub column: usize,
}

/// A command line and its reply line, the commands split as the card splits them.
#[derive(Clone, Debug)]
pub struct Exchange {
    pub line: usize,
    pub reply_line: usize,
    /// The host time of the exchange as an interval in ns, [command stamp, reply stamp (or the
    /// command's) + the stamps' resolution], when the log is stamped.
    pub at: Option<(i128, i128)>,
    /// The shortest time (ns) the host can have waited for the reply: from the command's stamp
    /// plus its resolution to the reply's stamp; `None` when the reply line is not stamped.
    pub waited_ns_min: Option<i128>,
    /// The command line's own stamp as an interval (its stamp to its stamp plus the
    /// resolution), when the log is stamped: where a line the host gave up on was sent.
    pub sent_at: Option<(i128, i128)>,
    pub commands: Vec<Exchanged>,
}

/// The values of a card's raw answer bytes: the pieces between CRs, control bytes (ACK, BEL)
/// dropped, empty pieces left out; as the asyn and pcap readers both hand them on.
fn reply_values(bytes: &[u8]) -> Vec<String> {
    bytes
        .split(|b| *b == b'\r')
        .map(|v| String::from_utf8_lossy(v).chars().filter(|c| !c.is_control()).collect::<String>())
        .filter(|v| !v.is_empty())
        .collect()
}

/// A register's reply as a 24-bit word: hex digits only (`from_str_radix` would also take a
/// sign, `+10`), at most 0xFFFFFF (SRM p.295: `RH` answers the word in hex).
fn hex_word(reply: &str) -> Option<u32> {
    Some(reply)
        .filter(|r| !r.is_empty() && r.chars().all(|c| c.is_ascii_hexdigit()))
        .and_then(|r| u32::from_str_radix(r, 16).ok())
        .filter(|v| u64::from(*v) < SERVO_COUNTER_MODULUS)
}

fn is_error_reply(r: &str) -> bool {
    let r = r.as_bytes();
    r.len() == 6 && r[..3].eq_ignore_ascii_case(b"ERR") && r[3..].iter().all(u8::is_ascii_digit)
}

/// A host log's lines paired into [`Exchange`]s: the syntax of `docs/capturing.md` (comments,
/// timestamps and their order, a reply line after every command line, several commands on a
/// line and their replies). Holds one pending command line: bounded.
pub struct LogParser {
    file: PathBuf,
    /// Whether the command lines are stamped (decided by the first one).
    stamped: Option<bool>,
    /// The last stamp on the log's timeline (time-only stamps with their midnight rollovers
    /// added) and its line.
    last_stamp: Option<(Stamp, i128, usize)>,
    days: i128,
    /// The command line waiting for its reply: (line, column of its text, text, host time).
    pending: Option<(usize, usize, String, Option<HostTime>)>,
    commands: u64,
    /// The motor and C.S. the host addresses: `#n` and `&n` stay until changed (SRM p.270).
    addressing: Addressing,
}

impl LogParser {
    pub fn new(file: &Path) -> LogParser {
        LogParser {
            file: file.to_path_buf(),
            stamped: None,
            last_stamp: None,
            days: 0,
            pending: None,
            commands: 0,
            addressing: Addressing::default(),
        }
    }

    fn err(&self, line: usize, column: usize, msg: String) -> SpecError {
        SpecError::at(&self.file, Position { line, column }, msg)
    }

    /// Whether the command lines carry host timestamps (known after the first command line).
    pub fn stamped(&self) -> bool {
        self.stamped == Some(true)
    }

    /// The stamp on the log's timeline, checked not to go backwards. MODEL: a time-only stamp
    /// more than 12 hours before the previous one is the next day (midnight passed); a smaller
    /// step back is an error, as is any step back of a dated stamp.
    fn place(&mut self, line: usize, stamp: Stamp) -> Result<i128, SpecError> {
        let Some((prev, prev_t, prev_line)) = self.last_stamp else {
            self.last_stamp = Some((stamp, stamp.ns, line));
            return Ok(stamp.ns);
        };
        if prev.dated != stamp.dated {
            return Err(self.err(
                line,
                1,
                format!(
                    "this timestamp {} a date and the one on line {prev_line} {}: use one form throughout",
                    if stamp.dated { "has" } else { "has no" },
                    if prev.dated { "has" } else { "has not" }
                ),
            ));
        }
        let mut t = stamp.ns + self.days * DAY_NS;
        if t < prev_t {
            if !stamp.dated && prev_t - t > DAY_NS / 2 {
                self.days += 1;
                t += DAY_NS;
            } else {
                return Err(self.err(
                    line,
                    1,
                    format!(
                        "this timestamp is {:.3} s before the one on line {prev_line}: host time goes backwards",
                        (prev_t - t) as f64 / NS_PER_S as f64
                    ),
                ));
            }
        }
        self.last_stamp = Some((stamp, t, line));
        Ok(t)
    }

    /// Reads line `line` of the log; an [`Exchange`] when it is the reply line completing one.
    pub fn line(&mut self, line: usize, raw: &str) -> Result<Option<Exchange>, SpecError> {
        match host_log_record(&self.file, line, raw)? {
            Some(record) => self.record(record),
            None => Ok(None),
        }
    }

    /// Takes one record (a command line sent, or the reply to it), from a host log or from a
    /// foreign format's reader; an [`Exchange`] when it is the reply completing one.
    pub fn record(&mut self, record: Record) -> Result<Option<Exchange>, SpecError> {
        let placed = |me: &mut LogParser, line: usize, stamp: Option<Stamp>| -> Result<Option<HostTime>, SpecError> {
            match stamp {
                Some(s) => Ok(Some((me.place(line, s)?, s.resolution_ns))),
                None => Ok(None),
            }
        };
        match record {
            Record::Command { line, column, stamp, text } => {
                let time = placed(self, line, stamp)?;
                if let Some((at, _, text, _)) = &self.pending {
                    return Err(self.err(
                        *at,
                        1,
                        format!("`{text}` has no reply line (`< ...`) before the next command"),
                    ));
                }
                match self.stamped {
                    None => self.stamped = Some(time.is_some()),
                    Some(s) if s != time.is_some() => {
                        return Err(self.err(
                            line,
                            1,
                            if s {
                                "this command line has no timestamp, the ones before it have: stamp every command \
                                 line or none"
                                    .to_string()
                            } else {
                                "this command line has a timestamp, the ones before it have none: stamp every \
                                 command line or none"
                                    .to_string()
                            },
                        ));
                    }
                    Some(_) => {}
                }
                let at = time.map(|(t, res)| (t, t + res));
                self.pending = Some((line, column, text, at));
                Ok(None)
            }
            Record::Reply { line, column, stamp, text, cut } => {
                let time = placed(self, line, stamp)?;
                let Some((cmd_line, cmd_column, cmd_text, mut at)) = self.pending.take() else {
                    return Err(self.err(line, column, "a reply line without a command before it".into()));
                };
                let mut waited_ns_min = None;
                let sent_at = at;
                if let (Some((lo, hi)), Some((t, res))) = (at, time) {
                    waited_ns_min = Some((t - hi).max(0));
                    at = Some((lo, hi.max(t + res)));
                }
                self.commands += 1;
                let commands = self.split(cmd_line, cmd_column, &cmd_text, line, column, &text, cut.as_ref())?;
                Ok(Some(Exchange { line: cmd_line, reply_line: line, at, waited_ns_min, sent_at, commands }))
            }
        }
    }

    /// The commands of line `line` with their answers from the reply `reply` (on
    /// `reply_line`, starting at `reply_column`).
    // The command's place and text, the reply's place and text, and what was cut off it: each
    // where an error may point, so none is bundled away.
    #[allow(clippy::too_many_arguments)]
    fn split(
        &mut self,
        line: usize,
        column: usize,
        text: &str,
        reply_line: usize,
        reply_column: usize,
        reply: &str,
        cut: Option<&Cut>,
    ) -> Result<Vec<Exchanged>, SpecError> {
        let reply = reply.trim();
        let mut parsed: Vec<Exchanged> = Vec::new();
        // The card's grammar reads the line (`grammar`): commands run together or spaced;
        // the first it cannot read ends the line (the card answers ERR003 there).
        for piece in grammar::pieces(text.as_bytes(), &mut self.addressing) {
            let at = piece.start;
            let (command, values, piece_text) = match &piece.command {
                Ok(c) => (
                    HostCommand::from_grammar(c).map_err(|why| self.err(line, column + at, why))?,
                    c.values(),
                    text[piece.start..piece.end].trim().to_string(),
                ),
                Err(_) => {
                    // From the byte the grammar stopped at (kept: it is what makes the rest
                    // unreadable on its own too, `HostCommand::parse`) to the line's end.
                    let rest = text[at..].trim_end().to_string();
                    if !matches!(HostCommand::parse(&rest), Ok(HostCommand::Unrecognized(_))) {
                        return Err(self.err(
                            line,
                            column + at,
                            format!("`{rest}` is refused by the card's grammar after what precedes it on the line, but reads as a command on its own: a trace step cannot hold it (split the line)"),
                        ));
                    }
                    (HostCommand::Unrecognized(rest.clone()), None, rest)
                }
            };
            parsed.push(Exchanged { text: piece_text, command, values, answer: Answer::Ack, column: column + at });
        }
        if parsed.is_empty() {
            return Err(self.err(line, column, "an empty command: write the command text, e.g. `???`".into()));
        }
        if reply == "(timeout)" {
            for c in &mut parsed {
                c.answer = Answer::Timeout;
            }
            return Ok(parsed);
        }
        if let Some(cut) = cut {
            return self.split_cut(parsed, line, reply_line, reply_column, reply, cut);
        }
        // What the card sent, without its framing: a reply that still holds the ACK, BEL or
        // another control byte (raw or written as an escape) was logged with its framing, and
        // its values cannot be told apart safely.
        if let Some(at) = reply.find(|c: char| c.is_control() && c != '\t') {
            return Err(self.err(
                reply_line,
                reply_column + at,
                "the reply holds a control byte (the card's ACK, BEL or CR framing?): write the values the card sent, separated by spaces or `\\r`".into(),
            ));
        }
        for escape in ["\\x06", "\\x07", "\\a", "\\x18", "\\x0d", "\\n"] {
            if let Some(at) = reply.to_ascii_lowercase().find(escape) {
                return Err(self.err(
                    reply_line,
                    reply_column + at,
                    format!("the reply holds `{}`, the card's framing written out: write the values the card sent, separated by spaces or `\\r`", &reply[at..at + escape.len()]),
                ));
            }
        }
        let single_value = !reply.contains(char::is_whitespace) && !reply.contains("\\r")
            || (parsed[0].command == HostCommand::GlobalStatus && reply == "BOOTSTRAP PROM");
        if parsed.len() == 1 && (parsed[0].values.is_none() || parsed[0].values.is_some_and(|v| v <= 1) && single_value)
        {
            parsed[0].answer = if reply.is_empty() { Answer::Ack } else { Answer::Value(reply.to_string()) };
            return self.checked(parsed, reply_line, reply_column);
        }
        // Several commands: the replies of those that answer, in order, separated by
        // whitespace or a written `\r` (the card ends each reply with CR).
        let spaced = reply.replace("\\r", " ");
        let values: Vec<&str> = spaced.split_whitespace().collect();
        // An error ends the line (facts page s.3): the commands before it answered as usual,
        // the one it answers got it, and those after it were never run.
        let first_error = values.iter().position(|v| is_error_reply(v));
        let answering = |c: &Exchanged| c.values.is_some_and(|v| v > 0);
        let known: usize = parsed.iter().filter_map(|c| c.values).sum();
        let unknown = parsed.iter().filter(|c| c.values.is_none()).count();
        if let Some(e) = first_error.filter(|e| *e + 1 == values.len()) {
            // Which command the error is: the one the grammar could not read (the card reads
            // the same grammar), else one of those it may answer: the commands answering
            // nothing that it meets and the one whose answers it falls among. With several,
            // the log cannot tell which one the card refused: MODEL: the first that is the
            // card's own (a command the model has no rule for, whose answer is the card's,
            // `&1A Q71=Q81` answered ERR003 by the DLS driver's card), else the first. Taking
            // the first always called a log impossible where the model acknowledges that one
            // and the card refused the next (issue 29).
            let unreadable = parsed.iter().position(|c| matches!(c.command, HostCommand::Unrecognized(_)));
            let mut before = 0;
            let mut may_err = Vec::new();
            for (k, c) in parsed.iter().enumerate() {
                let want = c.values.unwrap_or(0);
                let here = match unreadable {
                    Some(u) => k == u && before == e,
                    None => before <= e && (e < before + want || (want == 0 && before == e)),
                };
                if here {
                    may_err.push(k);
                    if want > 0 || unreadable.is_some() {
                        break;
                    }
                }
                before += want;
                if before > e {
                    break;
                }
            }
            let erring = may_err
                .iter()
                .copied()
                .find(|k| matches!(parsed[*k].command, HostCommand::Card { .. }))
                .or(may_err.first().copied());
            if let Some(k) = erring {
                let mut vals = values.iter();
                for c in parsed.iter_mut().take(k) {
                    let mine: Vec<&str> = vals.by_ref().take(c.values.unwrap_or(0)).copied().collect();
                    c.answer = if mine.is_empty() { Answer::Ack } else { Answer::Value(mine.join(" ")) };
                }
                let rest: Vec<&str> = vals.copied().collect();
                parsed[k].answer = Answer::Value(rest.join(" "));
                parsed.truncate(k + 1);
                return Ok(parsed);
            }
        }
        let unknown_answer = if values.len() == known {
            false
        } else if unknown > 0 && values.len() == known + unknown {
            true
        } else {
            let names = |want: Option<bool>| -> String {
                let v: Vec<String> = parsed
                    .iter()
                    .filter(|c| match want {
                        Some(true) => answering(c),
                        Some(false) => c.values == Some(0),
                        None => c.values.is_none(),
                    })
                    .map(|c| format!("`{}`", c.text.to_ascii_uppercase()))
                    .collect();
                if v.is_empty() {
                    "none".to_string()
                } else {
                    v.join(", ")
                }
            };
            let may = if unknown > 0 {
                format!(" and {unknown} not modelled that may or may not answer ({})", names(None))
            } else {
                String::new()
            };
            return Err(self.err(
                reply_line,
                reply_column,
                format!(
                    "the command line {line} holds {known} commands that answer ({}){may}, but this reply line \
                     holds {} values: write one reply value per answering command, in order, separated by \
                     spaces or `\\r`",
                    names(Some(true)),
                    values.len()
                ),
            ));
        };
        let mut values = values.into_iter();
        for c in &mut parsed {
            let n = c.values.unwrap_or(usize::from(unknown_answer));
            if n > 0 {
                let mine: Vec<&str> = values.by_ref().take(n).collect();
                c.answer = Answer::Value(mine.join(" "));
            }
        }
        self.checked(parsed, reply_line, reply_column)
    }

    /// Each value against the form its command's reply has: a `???` reply is 12 hex digits
    /// (SRM p.289) or `BOOTSTRAP PROM`, a register read at most 6 (a 24-bit word, SRM p.295);
    /// any command may answer `ERRnnn` instead. A value of another form is no card's reply.
    fn checked(
        &self,
        parsed: Vec<Exchanged>,
        reply_line: usize,
        reply_column: usize,
    ) -> Result<Vec<Exchanged>, SpecError> {
        for c in &parsed {
            let Answer::Value(v) = &c.answer else { continue };
            if is_error_reply(v) {
                continue;
            }
            let hex =
                |n: std::ops::RangeInclusive<usize>| n.contains(&v.len()) && v.chars().all(|c| c.is_ascii_hexdigit());
            let why = match c.command {
                HostCommand::GlobalStatus if !hex(12..=12) && v != "BOOTSTRAP PROM" => {
                    Some("a `???` reply is 12 hex digits (SRM p.289) or BOOTSTRAP PROM")
                }
                // X:$0 has its own check where its value is read for timing.
                HostCommand::ReadHex(r) if r != Register::ServoCycles && !hex(1..=6) => {
                    Some("a register read answers a 24-bit word: at most 6 hex digits (SRM p.295)")
                }
                _ => None,
            };
            if let Some(why) = why {
                return Err(self.err(reply_line, reply_column, format!("`{v}` answers `{}`: {why}", c.text)));
            }
        }
        Ok(parsed)
    }

    /// The answers of a reply whose end the record could not see (an asyn trace cuts its data
    /// lines): the values seen go to the commands in order (one to a command the grammar
    /// cannot count), the one value left when exactly one answering command remains is
    /// `cut.rest`, and any others are [`Answer::Unseen`].
    fn split_cut(
        &self,
        mut parsed: Vec<Exchanged>,
        line: usize,
        reply_line: usize,
        reply_column: usize,
        reply: &str,
        cut: &Cut,
    ) -> Result<Vec<Exchanged>, SpecError> {
        let spaced = reply.replace("\\r", "\r");
        let mut values = spaced.split('\r').filter(|v| !v.is_empty());
        let mut k = 0;
        while k < parsed.len() {
            let want = parsed[k].values.unwrap_or(1);
            if want == 0 {
                k += 1;
                continue;
            }
            let mine: Vec<&str> = values.by_ref().take(want).collect();
            if mine.len() < want {
                break;
            }
            parsed[k].answer = Answer::Value(mine.join(" "));
            if mine.last().is_some_and(|v| is_error_reply(v)) {
                // An error ends the line: the commands after it were never run.
                parsed.truncate(k + 1);
                return Ok(parsed);
            }
            k += 1;
        }
        if values.next().is_some() {
            return Err(self.err(
                reply_line,
                reply_column,
                format!("this reply holds more values than the commands of line {line} answer"),
            ));
        }
        let left: Vec<usize> = (k..parsed.len()).filter(|&j| parsed[j].values.unwrap_or(1) > 0).collect();
        match left.as_slice() {
            [one] if parsed[*one].values.unwrap_or(1) == 1 && !cut.rest.is_empty() => {
                parsed[*one].answer = Answer::Value(cut.rest.clone());
            }
            _ => {
                for j in left {
                    parsed[j].answer = Answer::Unseen(cut.why.clone());
                }
            }
        }
        Ok(parsed)
    }

    /// The end of the log: a command left without its reply, or a log without commands, is an
    /// error.
    pub fn finish(&self) -> Result<(), SpecError> {
        if let Some((at, _, text, _)) = &self.pending {
            return Err(self.err(*at, 1, format!("`{text}` has no reply line at the end of the log")));
        }
        if self.commands == 0 {
            return Err(SpecError::whole_file(&self.file, "the log has no commands"));
        }
        Ok(())
    }
}

/// An I-variable reply: decimal, or `$` hex (I9 bit 1, SRM p.42), optionally negative.
fn i_value(reply: &str) -> Option<i64> {
    let (neg, body) = match reply.strip_prefix('-') {
        Some(b) => (true, b),
        None => (false, reply),
    };
    let v = match body.strip_prefix('$') {
        Some(h) if !h.is_empty() && h.len() <= 12 && h.chars().all(|c| c.is_ascii_hexdigit()) => {
            i64::from_str_radix(h, 16).ok()?
        }
        None if !body.is_empty() && body.len() <= 15 && body.chars().all(|c| c.is_ascii_digit()) => {
            body.parse().ok()?
        }
        _ => return None,
    };
    Some(if neg { -v } else { v })
}

/// What the log says about the card, with where it says it.
#[derive(Clone, Debug, Default)]
pub struct CardFromLog {
    pub card: CardConfig,
    /// Every value taken: (the header field, the I-variable read, its value, its line).
    pub sources: Vec<(&'static str, &'static str, i64, usize)>,
}

/// The first pass: the replies to reads of I8, I40, I41 and I10 that come before any write of
/// that variable (what the card was configured with when the log began), and, for a stamped
/// log that does not read I10, the servo clock its X:$0 reads show over host time. Bounded:
/// four values and at most [`CLOCK_PAIRS_MAX`] rates.
pub struct CardScan {
    parser: LogParser,
    /// Per variable (I8, I10, I40, I41): the value read and its line, and whether it was written.
    read: [Option<(i64, usize)>; 4],
    written: [bool; 4],
    /// The last X:$0 read usable for the clock: its value, host time (ns) and line.
    last_x0: Option<(u32, i128, usize)>,
    /// Servo cycles per second between X:$0 reads, and the line of the first read of the first.
    rates: Vec<f64>,
    rates_from: Option<usize>,
    /// The last X:$0 read of a slower exchange (up to [`CLOCK_SLOW_READ_NS_MAX`]): its value,
    /// the exchange's first and last stamps (ns), and its line.
    last_slow: Option<(u32, i128, i128, usize)>,
    /// The servo clocks (Hz) every pair of slow reads allows, intersected: a read happens
    /// between its exchange's stamps, so each pair bounds the clock both ways.
    slow_bounds: Option<(f64, f64)>,
}

/// How many pairs of X:$0 reads [`CardScan`] takes the servo clock from.
pub const CLOCK_PAIRS_MAX: usize = 1001;
/// The shortest host time between two X:$0 reads whose count gives the clock, and the longest
/// an exchange may take for its read to be placed by its stamps (a read happens between the
/// command's stamp and the reply's: 5 ms over 0.4 s is 1.25%, and the median of the pairs is
/// taken).
const CLOCK_PAIR_NS_MIN: i128 = 400_000_000;
const CLOCK_READ_NS_MAX: i128 = 5_000_000;
/// The longest an exchange may take for its X:$0 read to bound the clock when no faster one
/// gives it (each pair then gives the clocks it allows, not a value).
const CLOCK_SLOW_READ_NS_MAX: i128 = 50_000_000;

const CARD_VARIABLES: [(u16, &str, &str); 4] =
    [(8, "I8", "i8"), (10, "I10", "servo_hz"), (40, "I40", "i40"), (41, "I41", "i41")];

impl CardScan {
    pub fn new(file: &Path) -> CardScan {
        CardScan {
            parser: LogParser::new(file),
            read: [None; 4],
            written: [false; 4],
            last_x0: None,
            rates: Vec::new(),
            rates_from: None,
            last_slow: None,
            slow_bounds: None,
        }
    }

    pub fn line(&mut self, line: usize, raw: &str) -> Result<(), SpecError> {
        match host_log_record(&self.parser.file, line, raw)? {
            Some(record) => self.record(record),
            None => Ok(()),
        }
    }

    /// Takes one record of the log (any format).
    pub fn record(&mut self, record: Record) -> Result<(), SpecError> {
        let Some(ex) = self.parser.record(record)? else { return Ok(()) };
        self.clock(&ex);
        for c in &ex.commands {
            let (n, write) = match c.command {
                HostCommand::ReadI(n) => (n, false),
                HostCommand::WriteI(n, _) => (n, true),
                _ => continue,
            };
            let Some(k) = CARD_VARIABLES.iter().position(|(v, ..)| *v == n) else { continue };
            if write {
                self.written[k] = true;
            } else if let (false, None, Answer::Value(r)) = (self.written[k], self.read[k], &c.answer) {
                if let Some(v) = i_value(r) {
                    self.read[k] = Some((v, ex.reply_line));
                }
            }
        }
        Ok(())
    }

    /// Counts the servo clock from consecutive X:$0 reads (SRM p.295: X:$0 counts servo
    /// cycles) over the host's stamps. A silence or a reset between two reads may have
    /// restarted the count: the pair is not taken.
    fn clock(&mut self, ex: &Exchange) {
        let restarted = ex.commands.iter().any(|c| {
            matches!(c.answer, Answer::Timeout) || matches!(c.command, HostCommand::Reset | HostCommand::Reinitialize)
        });
        if restarted {
            self.last_x0 = None;
            self.last_slow = None;
            return;
        }
        let read = ex.commands.iter().find_map(|c| match (&c.command, &c.answer) {
            (HostCommand::ReadHex(Register::ServoCycles), Answer::Value(r)) => hex_word(r),
            _ => None,
        });
        let (Some(v), Some((lo, hi))) = (read, ex.at) else { return };
        if hi - lo <= CLOCK_SLOW_READ_NS_MAX {
            if let Some((pv, plo, phi, line)) = self.last_slow {
                if lo - phi >= CLOCK_PAIR_NS_MIN {
                    let cycles = f64::from(v.wrapping_sub(pv) & 0xFF_FFFF);
                    let (least, most) = (cycles / ((hi - plo) as f64 / 1e9), cycles / ((lo - phi) as f64 / 1e9));
                    let (a, b) = self.slow_bounds.unwrap_or((least, most));
                    self.slow_bounds = Some((a.max(least), b.min(most)));
                    self.rates_from.get_or_insert(line);
                    self.last_slow = Some((v, lo, hi, ex.reply_line));
                }
            } else {
                self.last_slow = Some((v, lo, hi, ex.reply_line));
            }
        }
        if hi - lo > CLOCK_READ_NS_MAX {
            return;
        }
        let t = lo + (hi - lo) / 2;
        match self.last_x0 {
            Some((pv, pt, line)) if t - pt >= CLOCK_PAIR_NS_MIN => {
                let cycles = u64::from(v.wrapping_sub(pv) & 0xFF_FFFF);
                if self.rates.len() < CLOCK_PAIRS_MAX {
                    self.rates.push(cycles as f64 / ((t - pt) as f64 / 1e9));
                    self.rates_from.get_or_insert(line);
                }
                self.last_x0 = Some((v, t, ex.reply_line));
            }
            Some(_) => {}
            None => self.last_x0 = Some((v, t, ex.reply_line)),
        }
    }

    /// What was found, each value checked: I10 must give a servo period within the servo clock
    /// range of `scheduling.yaml`, I8, I40 and I41 must be in their ranges of `variables.yaml`
    /// (the error names the reply's line). A log that does not read I10 and whose X:$0 reads
    /// count a servo clock more than 1% from `configured_hz` (the configuration's) is taken at
    /// the clock they count (the median over pairs of reads): the card's clock is its own
    /// (MODEL: the count and the stamps are the log's own evidence of it).
    pub fn finish(self, spec: &Spec, configured_hz: u32) -> Result<CardFromLog, SpecError> {
        self.parser.finish()?;
        let iv = &spec.variables.i_variables;
        let mut out = CardFromLog::default();
        for ((_, var, field), read) in CARD_VARIABLES.iter().zip(self.read) {
            let Some((v, line)) = read else { continue };
            let at = Position { line, column: 1 };
            let range = match *field {
                "i8" => Some(&iv.i8.range),
                "i40" => Some(&iv.i40.range),
                "i41" => Some(&iv.i41.range),
                _ => None,
            };
            if let Some(r) = range {
                if v < r.min || v > r.max {
                    return Err(SpecError::at(
                        &self.parser.file,
                        at,
                        format!("{var} reads {v}, outside its range {}..={} (variables.yaml)", r.min, r.max),
                    ));
                }
            }
            match *field {
                "i8" => out.card.i8 = Some(v),
                "i40" => out.card.i40 = Some(v),
                "i41" => out.card.i41 = Some(v),
                _ => {
                    let hz = servo_hz_of_i10(v).ok_or_else(|| {
                        SpecError::at(
                            &self.parser.file,
                            at,
                            format!(
                                "I10 reads {v}: a servo period needs 1..=8388607 (units of 1/8388608 ms, SRM p.43)"
                            ),
                        )
                    })?;
                    let clocks = &spec.scheduling.servo_clock_hz_range;
                    if !clocks.contains(hz) {
                        return Err(SpecError::at(
                            &self.parser.file,
                            at,
                            format!("I10 reads {v}: a servo clock of {hz} Hz, outside {}", clocks.describe()),
                        ));
                    }
                    out.card.servo_hz = Some(hz);
                }
            }
            out.sources.push((field, var, v, line));
        }
        if out.card.servo_hz.is_none() && !self.rates.is_empty() {
            let mut rates = self.rates;
            rates.sort_by(f64::total_cmp);
            let median = rates[rates.len() / 2];
            let hz = median.round() as u32;
            let off = (f64::from(hz) - f64::from(configured_hz)).abs() / f64::from(configured_hz);
            if off > 0.01 && spec.scheduling.servo_clock_hz_range.contains(hz) {
                out.card.servo_hz = Some(hz);
                out.sources.push(("servo_hz", "X:$0 over host time", i64::from(hz), self.rates_from.unwrap_or(1)));
            }
        } else if let (None, Some((least, most))) = (out.card.servo_hz, self.slow_bounds) {
            // Only slow exchanges (a terminal server, a loaded host): the clock is taken only
            // where the configuration's lies outside what every pair allows (its host clock
            // within 1%), and then as the middle of it.
            let configured = f64::from(configured_hz);
            let outside = configured < least * 0.99 || configured > most * 1.01;
            let hz = ((least + most) / 2.0).round() as u32;
            if least <= most && outside && spec.scheduling.servo_clock_hz_range.contains(hz) {
                out.card.servo_hz = Some(hz);
                out.sources.push(("servo_hz", "X:$0 over host time", i64::from(hz), self.rates_from.unwrap_or(1)));
            }
        }
        Ok(out)
    }
}

/// What an import found, for its summary.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct Summary {
    /// Command lines (each with its reply line).
    pub exchanges: u64,
    /// Commands (a line may hold several).
    pub commands: u64,
    /// X:$0 reads that gave a value.
    pub counter_reads: u64,
    /// Restarts read from the counter going backwards (or not fitting the host clock).
    pub restarts: u64,
    /// Commands the grammar cannot read that the card answered without an error, kept
    /// without an expectation.
    pub not_modelled: u64,
    /// Commands whose answer is the card's own (`CPU`, `#1P`, `P1=5`, reads of I-variables
    /// no rule fixes): the model has no rule for the value and accepts whatever a running card
    /// answers, but not silence.
    pub card_own: u64,
    /// `elapsed` steps bounded by host time alone, while the card was silent.
    pub silent_gaps: u64,
    /// Unbounded `elapsed` steps before a command that timed out in a log without stamps: the
    /// host waited, for how long the log does not say.
    pub waits_unknown: u64,
    /// Unanswered commands whose wait the stamps time (the reply line stamped): no background
    /// cycle completed in that many servo cycles unless the card was tripped (UM p.236).
    pub waits_timed: u64,
    /// `elapsed` steps bounded by host time alone before answered commands
    /// ([`Placement::HostTime`]).
    pub placed_by_host_time: u64,
    /// Whether the log has host timestamps.
    pub stamped: bool,
    /// The most host time, in ns, between an X:$0 read and an exchange after it (before the
    /// next read): what [`Placement::AtReads`] leaves out.
    pub spread_ns_max: i128,
    /// Commands whose answer the log does not show ([`Answer::Unseen`]), kept without an
    /// expectation.
    pub unseen: u64,
}

impl Summary {
    /// A warning when the log gives no timing at all: without two X:$0 reads (or host time
    /// over a silent card) every command happens at one instant.
    /// Whether placing the commands at the reads' instants leaves out more host time than the
    /// search's hints allow for between the commands of one poll (about 10 ms): then a verdict
    /// against the log is checked again with every exchange at its own host time.
    pub fn spread_between_reads(&self) -> bool {
        const SPREAD_NS_MAX: i128 = 10_000_000;
        self.stamped && (self.counter_reads < 2 || self.spread_ns_max > SPREAD_NS_MAX)
    }

    pub fn timing_warning(&self) -> Option<String> {
        (self.counter_reads < 2 && self.silent_gaps == 0 && self.placed_by_host_time == 0 && self.waits_unknown == 0)
            .then(|| {
                format!(
                    "warning: the log has {} X:$0 read{}: no timing can be derived, every command is placed at \
                 one instant (read RHX:$0 alongside the other commands, docs/capturing.md)",
                    if self.counter_reads == 0 { "no".to_string() } else { "a single".to_string() },
                    if self.counter_reads == 0 { "s" } else { "" }
                )
            })
    }
}

/// Where the commands between two X:$0 reads of a stamped log are placed in time.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Placement {
    /// At the instant of the read before them: the card runs no servo cycle between them. Fast,
    /// and exact for a poll whose commands follow each other within a few servo cycles; a log
    /// whose commands are spread between reads (a 10 Hz `???` with X:$0 once a second) can be
    /// judged impossible by it when bit 12 flips between two of them (issue 36).
    #[default]
    AtReads,
    /// Each exchange at its own host time: `elapsed` steps bounded by the host clock between
    /// it and the one before (±[`CLOCK_TOLERANCE_PERCENT`] and the stamps' resolution), the
    /// cycles they take subtracted from the next read's count. MODEL (import): the search
    /// takes each bound on its own, so the cycles between two reads may differ from X:$0's
    /// count by up to the sum of the bounds' widths (docs/replay.md).
    HostTime,
}

/// `elapsed` steps for between `min` and `max` (unbounded if `None`) servo cycles, split into
/// steps of at most [`STEP_CYCLES_MAX`] cycles whose bounds add up to the given ones.
fn elapsed_steps(min: u64, max: Option<u64>, note: Option<String>) -> Vec<Step> {
    let step_max = u64::from(STEP_CYCLES_MAX);
    let mut steps = Vec::new();
    match max {
        None => {
            let mut left = min;
            loop {
                let this = left.min(step_max);
                left -= this;
                let event = if left == 0 {
                    TraceEvent::Elapsed { cycles_min: this as u32, cycles_max: None }
                } else {
                    TraceEvent::Elapsed { cycles_min: this as u32, cycles_max: Some(this as u32) }
                };
                steps.push(Step { event, expect: Expect::default(), note: None });
                if left == 0 {
                    break;
                }
            }
        }
        Some(max) => {
            let (mut min_left, mut max_left) = (min.min(max), max);
            while max_left > 0 {
                let hi = max_left.min(step_max);
                let lo = min_left.min(hi);
                max_left -= hi;
                min_left -= lo;
                steps.push(Step {
                    event: TraceEvent::Elapsed { cycles_min: lo as u32, cycles_max: Some(hi as u32) },
                    expect: Expect::default(),
                    note: None,
                });
            }
        }
    }
    if let Some(first) = steps.first_mut() {
        first.note = note;
    }
    steps
}

/// `$$$` or `$$$***`: the card resets rather than answers (UM p.243).
fn is_reset(command: &HostCommand) -> bool {
    matches!(command, HostCommand::Reset | HostCommand::Reinitialize)
}

/// Servo cycles in `ns` of host time at `hz`, widened by [`CLOCK_TOLERANCE_PERCENT`]: the
/// fewest (rounded down) or the most (rounded up).
fn cycles_in(ns: i128, hz: u32, most: bool) -> u64 {
    let ns = ns.max(0) as u128;
    let pct = if most { 100 + CLOCK_TOLERANCE_PERCENT } else { 100 - CLOCK_TOLERANCE_PERCENT } as u128;
    let num = ns * u128::from(hz) * pct;
    let den = 100 * NS_PER_S as u128;
    let c = if most { num.div_ceil(den) } else { num / den };
    c.min(u128::from(u64::MAX)) as u64
}

/// The host log turned into steps, one line at a time: memory stays bounded whatever the log's
/// length.
pub struct Importer {
    parser: LogParser,
    servo_hz: u32,
    /// The last X:$0 value read and the host time of its exchange.
    last_read: Option<(u32, Option<(i128, i128)>)>,
    /// A `$$$` was sent since the last read: the next read counts from it exactly.
    reset_pending: bool,
    /// A reply timed out since the last read: the card fell silent, and host time alone places
    /// the commands that follow.
    silent: bool,
    /// The host time the model's clock is at (the last read, `$$$` or a step placed by host
    /// time).
    anchor: Option<(i128, i128)>,
    /// Where commands between reads go.
    placement: Placement,
    /// Cycles already given to silent-gap steps since the last read or `$$$`: (min, max).
    gap: (u64, u64),
    /// An unstamped timeout's unbounded wait was given, with nothing answered since.
    unknown_wait_open: bool,
    /// The next X:$0 read follows a `possible_restart` with no read to place it: its count
    /// bounds nothing (the card may or may not have restarted since the read before).
    count_from_zero: bool,
    /// Servo cycles of the last unanswered command's wait (an `unanswered` step), which the
    /// next gap placed by host time from that command does not give again.
    waited: u64,
    /// The steps from the first answer after a silence on, until an X:$0 read (or the log's
    /// end) says whether the card restarted before that answer.
    held: Option<Held>,
    /// Exchanges with a timeout so far, and how many there were when the last hold began: one
    /// silence, one restart before the answer after it.
    timeouts: u64,
    timeouts_when_held: u64,
    summary: Summary,
}

/// Steps held after a silence (issue 36): a tripped card does not communicate (UM p.215), so
/// a card that answers after a silence was reset before that answer (INIT/ or power, which
/// the host does not see). Where the reset came is the first answer; whether it came at all
/// the next X:$0 read says (a count that goes on from the last read allows none).
struct Held {
    /// The line of the first answer after the silence.
    line: usize,
    steps: Vec<(usize, Step)>,
}

/// The most steps held while waiting for an X:$0 read after an answer that followed a
/// silence; past it the reset is taken as shown (the answer needs it) and the next read counts
/// from an unknown time since it. Bounds the importer's memory on any log.
pub const HELD_STEPS_MAX: usize = 4096;

impl Importer {
    /// An importer whose host time becomes servo cycles at `servo_hz`, placing commands
    /// between reads at the read before them.
    pub fn new(file: &Path, servo_hz: u32) -> Importer {
        Importer::placing(file, servo_hz, Placement::AtReads)
    }

    /// An importer placing the commands between reads as `placement` says.
    pub fn placing(file: &Path, servo_hz: u32, placement: Placement) -> Importer {
        Importer {
            placement,
            parser: LogParser::new(file),
            servo_hz: servo_hz.max(1),
            last_read: None,
            reset_pending: false,
            silent: false,
            anchor: None,
            gap: (0, 0),
            waited: 0,
            count_from_zero: false,
            unknown_wait_open: false,
            held: None,
            timeouts: 0,
            timeouts_when_held: 0,
            summary: Summary::default(),
        }
    }

    fn err(&self, line: usize, column: usize, msg: String) -> SpecError {
        self.parser.err(line, column, msg)
    }

    /// Reads line `line` of the log; returns the steps it completes, each with the line of
    /// the reply it comes from.
    pub fn line(&mut self, line: usize, raw: &str) -> Result<Vec<(usize, Step)>, SpecError> {
        match self.parser.line(line, raw)? {
            Some(ex) => self.exchange_held(&ex),
            None => Ok(Vec::new()),
        }
    }

    /// Takes one record of the log (any format); returns the steps it completes, each with the
    /// line (or packet) of the reply it comes from.
    pub fn record(&mut self, record: Record) -> Result<Vec<(usize, Step)>, SpecError> {
        match self.parser.record(record)? {
            Some(ex) => self.exchange_held(&ex),
            None => Ok(Vec::new()),
        }
    }

    /// [`Self::exchange`], holding the steps from an answer after a silence until the next
    /// X:$0 read says whether the card restarted before it ([`Held`]).
    fn exchange_held(&mut self, ex: &Exchange) -> Result<Vec<(usize, Step)>, SpecError> {
        let answered =
            ex.commands.iter().any(|c| matches!(c.answer, Answer::Value(_) | Answer::Ack | Answer::Unseen(_)));
        let reads_counter = ex.commands.iter().any(Self::is_counter_read);
        let resets = ex.commands.iter().any(|c| is_reset(&c.command));
        let silent_before = self.silent;
        let was_held = self.held.is_some();
        let steps: Vec<(usize, Step)> = self.exchange(ex)?.into_iter().map(|s| (ex.reply_line, s)).collect();
        if resets {
            // `$$$` restarts the card itself: what was held stands as it came.
            let mut out = self.held.take().map(|h| h.steps).unwrap_or_default();
            out.extend(steps);
            return Ok(out);
        }
        if reads_counter && was_held {
            let held = self.held.take().expect("checked");
            return Ok(self.release(held, steps));
        }
        if ex.commands.iter().any(|c| c.answer == Answer::Timeout) {
            self.timeouts += 1;
        }
        if silent_before && answered && !reads_counter && !was_held && self.timeouts != self.timeouts_when_held {
            self.timeouts_when_held = self.timeouts;
            self.held = Some(Held { line: ex.reply_line, steps });
            return Ok(Vec::new());
        }
        match &mut self.held {
            Some(h) => {
                h.steps.extend(steps);
                if h.steps.len() > HELD_STEPS_MAX {
                    let held = self.held.take().expect("checked");
                    // The next read counts from an unknown time since the reset, or, if there
                    // was none, since the read before: any count from 0.
                    self.last_read = None;
                    self.count_from_zero = true;
                    self.summary.restarts += 1;
                    return Ok(self.restarted(held, None, "no X:$0 read came within the steps held for one"));
                }
                Ok(Vec::new())
            }
            None => Ok(steps),
        }
    }

    /// The held steps, now that the X:$0 read whose steps are `read` came: with the reset
    /// before the first answer if the read shows a restart, as they came if it does not (the
    /// search then finds that no correct card answers there).
    fn release(&mut self, held: Held, read: Vec<(usize, Step)>) -> Vec<(usize, Step)> {
        let restart_at = read.iter().position(|(_, s)| s.event == TraceEvent::Restart);
        let Some(at) = restart_at else {
            let mut out = held.steps;
            out.extend(read);
            return out;
        };
        // The read's count `v` is the cycles since the reset, which now comes before the held
        // answer: what the held steps and the read's gap take is at most `v` each (MODEL: taken
        // on their own, as an unknown wait is, docs/replay.md).
        let line = read[at].0;
        let mut rest = read;
        let after: Vec<(usize, Step)> = rest.split_off(at + 1);
        let v: u64 = after
            .iter()
            .take_while(|(_, s)| matches!(s.event, TraceEvent::Elapsed { .. }))
            .map(|(_, s)| match s.event {
                TraceEvent::Elapsed { cycles_max, cycles_min } => u64::from(cycles_max.unwrap_or(cycles_min)),
                _ => 0,
            })
            .sum();
        let mut out = self.restarted(held, Some(v), &format!("the X:$0 read at line {line} shows the restart"));
        for (n, mut s) in after {
            if let TraceEvent::Elapsed { cycles_min, .. } = &mut s.event {
                *cycles_min = 0;
            }
            out.push((n, s));
        }
        out
    }

    /// The held steps with the reset before the first answer: a `restart`, then the steps with
    /// their leading gap (host time since the last silent command) from 0, since the reset may
    /// have come anywhere in it, and at most `v` cycles when a read bounds it.
    /// (The restart is counted by the caller: a read that shows it has counted it already.)
    /// Without a read (`v` is `None`) the reset is only possible: a card whose background was
    /// starved answers again once it runs (UM p.236), with no reset (a `possible_restart`).
    fn restarted(&mut self, held: Held, v: Option<u64>, shown: &str) -> Vec<(usize, Step)> {
        let Held { line, steps } = held;
        let note = if v.is_some() {
            format!(
                "the card answered after a silence: a tripped card does not communicate (UM p.215), so it was \
                 reset (INIT/ or power, unseen) before this answer; {shown}"
            )
        } else {
            format!(
                "the card answered after a silence: a tripped card does not communicate until it is reset (UM \
                 p.215), a starved one once its background runs again (UM p.236), so it may have been reset \
                 (INIT/ or power, unseen) before this answer; {shown}"
            )
        };
        let event = if v.is_some() { TraceEvent::Restart } else { TraceEvent::RestartPossible };
        let mut out = vec![(line, Step { event, expect: Expect::default(), note: Some(note) })];
        let leading = steps.iter().take_while(|(_, s)| matches!(s.event, TraceEvent::Elapsed { .. })).count();
        if leading == 0 {
            let gap = elapsed_steps(0, v, Some("between the unseen reset and the answer after it".into()));
            out.extend(gap.into_iter().map(|s| (line, s)));
        }
        for (i, (n, mut s)) in steps.into_iter().enumerate() {
            if i < leading {
                if let TraceEvent::Elapsed { cycles_min, cycles_max } = &mut s.event {
                    *cycles_min = 0;
                    if let Some(v) = v {
                        let v = u32::try_from(v).unwrap_or(u32::MAX);
                        *cycles_max = Some(cycles_max.map_or(v, |m| m.min(v)));
                    }
                }
            }
            out.push((n, s));
        }
        out
    }

    /// The end of the log's steps: what is still held, with the reset its answer needs (no
    /// X:$0 read came after it to say otherwise).
    pub fn flush(&mut self) -> Vec<(usize, Step)> {
        match self.held.take() {
            Some(held) => {
                self.summary.restarts += 1;
                self.restarted(held, None, "no X:$0 read after it")
            }
            None => Vec::new(),
        }
    }

    fn is_counter_read(c: &Exchanged) -> bool {
        c.command == HostCommand::ReadHex(Register::ServoCycles) && matches!(c.answer, Answer::Value(_))
    }

    fn exchange(&mut self, ex: &Exchange) -> Result<Vec<Step>, SpecError> {
        self.summary.exchanges += 1;
        self.summary.stamped = self.parser.stamped();
        let mut steps = Vec::new();
        let timed_out = ex.commands.iter().any(|c| c.answer == Answer::Timeout);
        // An unstamped timeout that follows another with nothing answered between, on a line
        // of reads: its unknown wait adds nothing the first one's unbounded gap does not give
        // (a wait of 0 changes no card, and two gaps of any length are one), so it gets none.
        let read_only_line = ex
            .commands
            .iter()
            .all(|c| matches!(c.command, HostCommand::GlobalStatus | HostCommand::ReadI(_) | HostCommand::ReadHex(_)));
        let wait_given = self.silent && self.unknown_wait_open && read_only_line;
        if timed_out {
            self.silent = true;
        } else {
            self.unknown_wait_open = false;
        }
        let reads_counter = ex.commands.iter().any(Self::is_counter_read);
        // How far host time places this exchange after the last X:$0 read: what placing it at
        // the read's instant leaves out.
        if let (Some(now), Some((_, Some(read_at)))) = (ex.at, self.last_read) {
            if !reads_counter {
                self.summary.spread_ns_max = self.summary.spread_ns_max.max(now.1 - read_at.0);
            }
        }
        let first = self.summary.exchanges == 1;
        let resets = ex.commands.iter().any(|c| is_reset(&c.command));
        if first && self.placement == Placement::HostTime && ex.at.is_some() && !reads_counter && !resets {
            // Placed by host time from the first exchange on; the card ran an unknown time
            // before the log starts (as before a first X:$0 read), not from power-on.
            self.anchor = ex.at;
            steps.extend(elapsed_steps(
                0,
                None,
                Some("the card has run an unknown time before the log starts".to_string()),
            ));
        }
        let by_host_time = self.silent || self.placement == Placement::HostTime;
        // A line the host gave up on was sent at its own stamp; its wait is its own step.
        let placed_at = if timed_out { ex.sent_at } else { ex.at };
        if by_host_time && !reads_counter {
            if let (Some(now), Some(anchor)) = (placed_at, self.anchor) {
                // The card is silent, or the log is placed by host time: no counter places
                // this command, the host's clock does.
                // The wait of an unanswered command before (its own step) is not given twice:
                // the shortest time counts from the end of its reply line already, the longest
                // from its command line.
                let waited = std::mem::take(&mut self.waited);
                let lo = cycles_in(now.0 - anchor.1, self.servo_hz, false);
                let hi = cycles_in(now.1 - anchor.0, self.servo_hz, true).saturating_sub(waited).max(lo);
                self.gap = (self.gap.0.saturating_add(lo), self.gap.1.saturating_add(hi));
                self.anchor = ex.at;
                if self.silent {
                    self.summary.silent_gaps += 1;
                } else {
                    self.summary.placed_by_host_time += 1;
                }
                steps.extend(elapsed_steps(
                    lo,
                    Some(hi),
                    Some(format!(
                        "{}: host time since the last placed command gives {lo} to {hi} servo cycles at {} Hz \
                         ±{CLOCK_TOLERANCE_PERCENT}%",
                        if self.silent { "the card is silent" } else { "placed by host time" },
                        self.servo_hz
                    )),
                ));
            }
        }
        if ex.at.is_none() && !reads_counter && timed_out && !wait_given {
            // A timeout means the host waited; without stamps the wait is unknown, not zero
            // (issue 36): a card that answered and then fell silent may have starved meanwhile
            // (UM p.236) and tripped (UM p.215). The next X:$0 read's count then bounds only
            // what follows the wait (the search takes the two on their own, MODEL:
            // docs/replay.md).
            self.gap.1 = u64::MAX;
            self.summary.waits_unknown += 1;
            self.unknown_wait_open = true;
            steps.extend(elapsed_steps(
                0,
                None,
                Some(
                    "the host waited for a reply that did not come: the log has no stamps, so for an unknown time"
                        .into(),
                ),
            ));
        }
        // UM p.236: the background processes host commands, so a line the host gave up on
        // either found the card tripped (UM p.215) or waited with no background cycle: an
        // `unanswered` step with the wait the stamps show (the shortest: the command's stamp
        // plus its resolution to the reply's), 0 when the reply is not stamped (an unknown
        // wait, of which no part is known).
        let mut wait = ex
            .waited_ns_min
            .filter(|_| timed_out)
            .map_or(0, |ns| cycles_in(ns, self.servo_hz, false))
            .min(u64::from(STEP_CYCLES_MAX));
        if timed_out && ex.at.is_some() {
            // Given by this step; the next gap placed by host time from this command, or the
            // next X:$0 read, counts it as given.
            self.waited = wait;
            self.gap = (self.gap.0.saturating_add(wait), self.gap.1.saturating_add(wait));
        }
        for c in &ex.commands {
            self.summary.commands += 1;
            let expected = match &c.answer {
                Answer::Timeout => "(silence)".to_string(),
                Answer::Ack => "(ack)".to_string(),
                Answer::Value(r) => r.to_ascii_uppercase(),
                Answer::Unseen(_) => String::new(),
            };
            let mut note = None;
            let mut expect = Expect { reply: Some(expected), ..Expect::default() };
            // The checksums' values are the card's own: the model sums no memory and holds
            // tokens (UM p.217, MODEL), so a real card's X:$1080, X:$1090 or CHECKSUM reply is
            // never compared with them; the answer still shows the card running (UM p.215).
            // X:$1080's value is kept as `running_checksum` (issue 36), which replay reads for
            // what UM p.217 says of it: "This leaves the calculated value frozen in the running
            // checksum register X:$001080" once a mismatch stops the engine
            // (`explain::refute::Freeze`).
            let checksum = matches!(
                c.command,
                HostCommand::Checksum
                    | HostCommand::ReadHex(Register::RunningChecksum | Register::ProgramChecksumReference)
            );
            if let (true, Answer::Value(reply)) = (checksum, &c.answer) {
                if !is_error_reply(reply) {
                    note = Some(format!(
                        "the card's own checksum `{reply}`: not compared (the model's are tokens, UM p.217); the answer shows the card running"
                    ));
                    expect = Expect { tripped: Some(false), ..Expect::default() };
                    if c.command == HostCommand::ReadHex(Register::RunningChecksum) {
                        let value = hex_word(reply).ok_or_else(|| {
                            self.err(ex.reply_line, 3, format!("X:$1080 reply `{reply}` is not a 24-bit hex word"))
                        })?;
                        expect.running_checksum = Some(value);
                    }
                    self.summary.card_own += 1;
                }
            }
            if let Answer::Unseen(why) = &c.answer {
                self.summary.unseen += 1;
                note = Some(format!("the card answered, the log does not show what: {why}"));
                expect = Expect::default();
            }
            if let (HostCommand::ReadHex(Register::ServoCycles), Answer::Value(reply)) = (&c.command, &c.answer) {
                let value = hex_word(reply).ok_or_else(|| {
                    self.err(ex.reply_line, 3, format!("X:$0 reply `{reply}` is not a 24-bit hex word"))
                })?;
                steps.extend(self.counter_read(ex, value)?);
                note = Some(format!(
                    "the card's X:$0 read {reply} (used for timing, its value not compared; the answer shows the card running)"
                ));
                // An answer is evidence that the card was running (UM p.215: a tripped card
                // does not communicate): no explanation may have it tripped here (issue 36).
                expect = Expect { tripped: Some(false), ..Expect::default() };
            } else if c.command == HostCommand::ReadHex(Register::ServoCycles) && c.answer == Answer::Ack {
                return Err(self.err(ex.reply_line, 1, "X:$0 reply `` is not a 24-bit hex word".into()));
            }
            if is_reset(&c.command) {
                // The card restarts its servo counter, and resets rather than answers: what the
                // log shows after `$$$` (or `$$$***`, a reset with the factory defaults, UM
                // p.243) is the link's, not the model's, so it is kept as a note. MODEL: SRM p.37
                // has the card acknowledge every valid command line (I3 = 1..3), and no page
                // read says whether a reset's acknowledgement goes out before the card restarts;
                // the emulator acknowledges both, as its own capture expects (docs/emulator.md).
                self.last_read = None;
                self.reset_pending = true;
                self.silent = false;
                self.anchor = ex.at;
                self.gap = (0, 0);
                self.waited = 0;
                let shown = match &c.answer {
                    Answer::Value(r) => r.as_str(),
                    Answer::Ack => "",
                    Answer::Timeout => "(timeout)",
                    Answer::Unseen(_) => "(not shown)",
                };
                note = Some(format!("reply `{shown}` not compared: the card resets"));
                expect = Expect::default();
            }
            if let HostCommand::Card { .. } = c.command {
                self.summary.card_own += 1;
            }
            if let HostCommand::Unrecognized(_) = c.command {
                let replied = match &c.answer {
                    Answer::Value(r) if !is_error_reply(r) => Some(format!("replied `{r}`")),
                    Answer::Ack => Some("replied nothing".to_string()),
                    _ => None,
                };
                if let Some(replied) = replied {
                    // The model answers ERR003; the card knew the command. Kept, not compared.
                    self.summary.not_modelled += 1;
                    note = Some(format!("not modelled: `{}` {replied}", c.text.to_ascii_uppercase()));
                    expect = Expect::default();
                }
            }
            let event = if c.answer == Answer::Timeout && !is_reset(&c.command) {
                // The line's wait is the first command's; the card processes a line's commands
                // in order (SRM p.37), so the others waited no longer for the same background.
                let wait_cycles = u32::try_from(std::mem::take(&mut wait)).unwrap_or(STEP_CYCLES_MAX);
                if wait_cycles > 0 {
                    self.summary.waits_timed += 1;
                }
                TraceEvent::Unanswered { command: c.command.clone(), wait_cycles }
            } else {
                TraceEvent::Model(Event::Command(c.command.clone()))
            };
            steps.push(Step { event, expect, note });
        }
        Ok(steps)
    }

    /// The steps before an X:$0 read of `value`: the servo cycles since the last read (or the
    /// restart it shows), as `elapsed` (and `restart`) steps.
    fn counter_read(&mut self, ex: &Exchange, value: u32) -> Result<Vec<Step>, SpecError> {
        let v = u64::from(value);
        let hz = self.servo_hz;
        let mut restart = None;
        let mut note = None;
        // The cycles since the reference (the last read, or `$$$`): (min, max or unbounded).
        let total: (u64, Option<u64>) = if self.reset_pending {
            (v, Some(v))
        } else {
            match self.last_read {
                None if std::mem::take(&mut self.count_from_zero) => {
                    note = Some(
                        "the first X:$0 read after a possible unseen restart: any number of servo cycles since \
                         the steps before"
                            .to_string(),
                    );
                    (0, None)
                }
                None => {
                    note = Some(format!(
                        "the first X:$0 read: the card has run an unknown time since its last restart, at least \
                         {v} servo cycles (the counter may have wrapped)"
                    ));
                    (v, None)
                }
                Some((prev, prev_at)) => {
                    let p = u64::from(prev);
                    let d = (v + SERVO_COUNTER_MODULUS - p) % SERVO_COUNTER_MODULUS;
                    match (prev_at, ex.at) {
                        (Some(a), Some(b)) => {
                            let cmin = cycles_in(b.0 - a.1, hz, false);
                            let cmax = cycles_in(b.1 - a.0, hz, true);
                            let kmin = cmin.saturating_sub(d).div_ceil(SERVO_COUNTER_MODULUS);
                            let kmax = cmax.checked_sub(d).map(|x| x / SERVO_COUNTER_MODULUS);
                            match kmax.filter(|k| *k >= kmin) {
                                Some(kmax) => {
                                    if kmax > 0 {
                                        note = Some(format!(
                                            "X:$0 went from {prev:06X} to {value:06X}: with the host clock's {cmin} to \
                                             {cmax} servo cycles at {hz} Hz ±{CLOCK_TOLERANCE_PERCENT}%, it wrapped \
                                             {kmin} to {kmax} times"
                                        ));
                                    }
                                    (d + kmin * SERVO_COUNTER_MODULUS, Some(d + kmax * SERVO_COUNTER_MODULUS))
                                }
                                None if v <= cmax => {
                                    restart = Some(format!(
                                        "X:$0 went from {prev:06X} to {value:06X}: the host clock's {cmin} to {cmax} \
                                         servo cycles at {hz} Hz ±{CLOCK_TOLERANCE_PERCENT}% fit no count with wraps, \
                                         so the card restarted (INIT/, power or `$$$`) {v} cycles before this read"
                                    ));
                                    (v, Some(v))
                                }
                                None => {
                                    return Err(self.err(
                                        ex.reply_line,
                                        3,
                                        format!(
                                            "X:$0 went from {prev:06X} to {value:06X}, more servo cycles than the host \
                                             clock allows ({cmin} to {cmax} at {hz} Hz ±{CLOCK_TOLERANCE_PERCENT}%): is \
                                             the servo clock right? (the configuration's servo_hz, or read I10 in the log)"
                                        ),
                                    ));
                                }
                            }
                        }
                        _ if value >= prev => (d, Some(d)),
                        _ => {
                            restart = Some(format!(
                                "X:$0 went backwards from {prev:06X} to {value:06X}: without host timestamps this is \
                                 read as a restart (INIT/, power or `$$$` from elsewhere) {v} cycles before this read, \
                                 not as a 24-bit wrap"
                            ));
                            (v, Some(v))
                        }
                    }
                }
            }
        };
        let mut steps = Vec::new();
        let (lo, hi) = if restart.is_some() {
            (total.0, total.1)
        } else {
            // What silent-gap steps already gave since the reference is not given twice.
            (total.0.saturating_sub(self.gap.1), total.1.map(|h| h.saturating_sub(self.gap.0)))
        };
        if let Some(why) = restart {
            self.summary.restarts += 1;
            steps.push(Step { event: TraceEvent::Restart, expect: Expect::default(), note: Some(why) });
        }
        if (lo, hi) != (0, Some(0)) {
            steps.extend(elapsed_steps(lo, hi, note));
        }
        self.summary.counter_reads += 1;
        self.last_read = Some((value, ex.at));
        self.reset_pending = false;
        self.silent = false;
        self.anchor = ex.at;
        self.gap = (0, 0);
        self.waited = 0;
        Ok(steps)
    }

    /// The end of the log: a command left without its reply, or a log without commands, is an
    /// error. What the import found otherwise.
    pub fn finish(self) -> Result<Summary, SpecError> {
        self.parser.finish()?;
        Ok(self.summary)
    }
}

/// The trace an imported log becomes, without its steps (they are written as they come).
pub fn header(file: &Path, configuration: &str) -> Trace {
    Trace {
        version: FORMAT_VERSION,
        description: format!("imported from the host log {}", file.display()),
        cite: None,
        configuration: configuration.to_string(),
        profiles: ProfileSelection::Keyword(AllKeyword::All),
        steps: Vec::new(),
    }
}

/// The servo clock of configuration `name` of the spec's `check.yaml`.
pub fn configuration_servo_hz(spec: &Spec, name: &str) -> Result<u32, String> {
    spec.check.configurations.get(name).map(|c| c.servo_hz).ok_or_else(|| {
        let names: Vec<&str> = spec.check.configurations.keys().map(String::as_str).collect();
        format!("no configuration named `{name}` (configurations: {})", names.join(", "))
    })
}

/// A whole log imported at once (for short logs and tests).
#[derive(Debug)]
pub struct Imported {
    pub trace: Trace,
    /// What the log says about the card (the trace's `card:` header), if anything.
    pub card: Option<CardConfig>,
    pub from_log: CardFromLog,
    pub summary: Summary,
}

/// A whole log held in memory, imported at once under configuration `configuration`.
pub fn import(file: &Path, text: &str, configuration: &str) -> Result<Imported, SpecError> {
    let spec = Spec::embedded()?;
    let mut scan = CardScan::new(file);
    for (i, raw) in text.lines().enumerate() {
        scan.line(i + 1, raw)?;
    }
    let configured_hz = configuration_servo_hz(&spec, configuration).map_err(|e| SpecError::whole_file(file, e))?;
    let from_log = scan.finish(&spec, configured_hz)?;
    let hz = from_log.card.servo_hz.unwrap_or(configured_hz);
    let mut importer = Importer::new(file, hz);
    let mut trace = header(file, configuration);
    for (i, raw) in text.lines().enumerate() {
        trace.steps.extend(importer.line(i + 1, raw)?.into_iter().map(|(_, s)| s));
    }
    trace.steps.extend(importer.flush().into_iter().map(|(_, s)| s));
    let summary = importer.finish()?;
    let card = (!from_log.card.is_empty()).then_some(from_log.card);
    Ok(Imported { trace, card, from_log, summary })
}

/// The formats a log can be imported from.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum LogFormat {
    /// `> command` / `< reply` lines (`docs/capturing.md`).
    HostLog,
    /// An EPICS IOC's asyn trace of the pmac driver's port ([`asyn`]).
    Asyn,
    /// A pcap or pcapng capture of the Ethernet protocol ([`pcap`]).
    Pcap,
}

impl LogFormat {
    /// The name `--log-format` takes.
    pub fn name(self) -> &'static str {
        match self {
            LogFormat::HostLog => "host-log",
            LogFormat::Asyn => "asyn",
            LogFormat::Pcap => "pcap",
        }
    }

    /// What the file is, in words.
    pub fn describe(self) -> &'static str {
        match self {
            LogFormat::HostLog => "a host log",
            LogFormat::Asyn => "an EPICS asyn trace",
            LogFormat::Pcap => "a packet capture (pcap or pcapng)",
        }
    }

    pub fn from_name(name: &str) -> Option<LogFormat> {
        [LogFormat::HostLog, LogFormat::Asyn, LogFormat::Pcap].into_iter().find(|f| f.name() == name)
    }
}

/// A log read as [`Record`]s, whatever its format. Bounded: each reader holds at most one
/// exchange in progress.
pub trait Records {
    /// The next record and the line (or packet) it is reported at; `None` at the end.
    fn next_record(&mut self) -> Result<Option<Record>, SpecError>;
    /// What the reader passed over that is not an exchange, in words, for the summary (nothing
    /// the file holds is dropped without being counted there).
    fn passed_over(&self) -> Vec<String> {
        Vec::new()
    }
}

/// A host log's records, line by line.
struct HostLogRecords {
    file: PathBuf,
    lines: Lines<BufReader<std::fs::File>>,
}

impl Records for HostLogRecords {
    fn next_record(&mut self) -> Result<Option<Record>, SpecError> {
        while let Some((n, text)) = self.lines.next()? {
            if let Some(r) = host_log_record(&self.file, n, &text)? {
                return Ok(Some(r));
            }
        }
        Ok(None)
    }
}

/// Opens the log `path` in format `format`.
pub fn open_records(path: &Path, format: LogFormat) -> Result<Box<dyn Records>, SpecError> {
    let file = pmacwd_specs::input::open_regular(path)?;
    Ok(match format {
        LogFormat::HostLog => {
            Box::new(HostLogRecords { file: path.to_path_buf(), lines: Lines::new(path, BufReader::new(file)) })
        }
        LogFormat::Asyn => Box::new(asyn::AsynRecords::new(path, BufReader::new(file))),
        LogFormat::Pcap => Box::new(pcap::PcapRecords::new(path, file)?),
    })
}

/// An error met reading `path` as `format`, with a hint when the file looks like another
/// format: the error alone would say why the file is not what it was taken for.
pub fn with_format_hint(e: SpecError, path: &Path, format: LogFormat) -> SpecError {
    match looks_like(path) {
        Ok(None) if !e.message.contains("--log-format") => SpecError {
            message: format!(
                "{}; this looks like no log pmacwd reads (a host log, an EPICS asyn trace, a pcap or pcapng \
                 capture: docs/capturing.md)",
                e.message
            ),
            ..e
        },
        Ok(Some(other)) if other != format && !e.message.contains("--log-format") => SpecError {
            message: format!("{}; this looks like {}: use --log-format {}", e.message, other.describe(), other.name()),
            ..e
        },
        _ => e,
    }
}

/// A log on disk, imported one step at a time: the first pass ([`CardScan`]) is done when it
/// opens, then [`ImportStream::next_step`] reads the log again record by record. For `pmacwd
/// import` and for `pmacwd replay` of a log.
pub struct ImportStream {
    pub header: Trace,
    pub card: Option<CardConfig>,
    pub from_log: CardFromLog,
    /// The servo clock host time is converted with (the log's I10, else the configuration's).
    pub servo_hz: u32,
    /// The format the log is read in.
    pub format: LogFormat,
    records: Box<dyn Records>,
    importer: Option<Importer>,
    summary: Option<Summary>,
    queue: VecDeque<(usize, Step)>,
    path: PathBuf,
}

impl ImportStream {
    /// Opens the host log `path` to be imported under configuration `configuration` of `spec`.
    pub fn open(spec: &Spec, path: &Path, configuration: &str) -> Result<ImportStream, SpecError> {
        ImportStream::open_as(spec, path, configuration, None)
    }

    /// Opens the log `path` in format `format` (by its content when `None`), placing the
    /// commands between X:$0 reads at the reads' instants.
    pub fn open_as(
        spec: &Spec,
        path: &Path,
        configuration: &str,
        format: Option<LogFormat>,
    ) -> Result<ImportStream, SpecError> {
        ImportStream::open_placed(spec, path, configuration, format, Placement::AtReads)
    }

    /// Opens the log `path` in format `format`, placing its commands as `placement` says.
    pub fn open_placed(
        spec: &Spec,
        path: &Path,
        configuration: &str,
        format: Option<LogFormat>,
        placement: Placement,
    ) -> Result<ImportStream, SpecError> {
        let config_hz = configuration_servo_hz(spec, configuration).map_err(|e| SpecError::whole_file(path, e))?;
        // A file that looks like none of the formats is read as a host log (the first format,
        // whose errors name a line), its errors saying what else it could have been.
        let format = match format {
            Some(f) => f,
            None => looks_like(path)?.unwrap_or(LogFormat::HostLog),
        };
        let hint = |e: SpecError| with_format_hint(e, path, format);
        let iv = &spec.variables.i_variables;
        let ranges = format!("{:?} {:?} {:?}", iv.i8.range, iv.i40.range, iv.i41.range);
        let from_log = match first_pass::remembered(path, format, config_hz, ranges) {
            (Some(known), _) => known,
            (None, remember) => {
                let mut scan = CardScan::new(path);
                let mut records = open_records(path, format).map_err(hint)?;
                while let Some(r) = records.next_record().map_err(hint)? {
                    scan.record(r).map_err(hint)?;
                }
                let from_log = scan.finish(spec, config_hz).map_err(hint)?;
                remember.keep(&from_log);
                from_log
            }
        };
        let servo_hz = from_log.card.servo_hz.unwrap_or(config_hz);
        let mut header = header(path, configuration);
        let noun = match format {
            LogFormat::HostLog => "the host log",
            LogFormat::Asyn => "the EPICS asyn trace",
            LogFormat::Pcap => "the packet capture",
        };
        header.description = format!("imported from {noun} {}", path.display());
        Ok(ImportStream {
            header,
            card: (!from_log.card.is_empty()).then_some(from_log.card),
            from_log,
            servo_hz,
            format,
            records: open_records(path, format)?,
            importer: Some(Importer::placing(path, servo_hz, placement)),
            summary: None,
            queue: VecDeque::new(),
            path: path.to_path_buf(),
        })
    }

    /// The next step and the log line (or packet) it comes from; `None` at the end of the log.
    pub fn next_step(&mut self) -> Result<Option<(usize, Step)>, SpecError> {
        let (path, format) = (self.path.clone(), self.format);
        let hint = |e: SpecError| with_format_hint(e, &path, format);
        loop {
            if let Some(s) = self.queue.pop_front() {
                return Ok(Some(s));
            }
            let Some(importer) = self.importer.as_mut() else { return Ok(None) };
            match self.records.next_record().map_err(hint)? {
                Some(r) => self.queue.extend(importer.record(r).map_err(hint)?),
                None => {
                    let mut importer = self.importer.take().expect("checked above");
                    self.queue.extend(importer.flush());
                    self.summary = Some(importer.finish().map_err(hint)?);
                }
            }
        }
    }

    /// What the import found, once [`ImportStream::next_step`] has returned `None`.
    pub fn summary(&self) -> Option<&Summary> {
        self.summary.as_ref()
    }

    /// What the reader passed over that is not an exchange (an IOC's own output, a driver's
    /// empty connection checks, packets of other connections), in words.
    pub fn passed_over(&self) -> Vec<String> {
        self.records.passed_over()
    }
}

/// The format of the log at `path` by its content: pcap and pcapng by their magic numbers, an
/// asyn trace by the pmac driver's `lowLevelWriteRead: command:` lines or asyn's `HOST:PORT
/// write N` lines among its first lines, a host log by a first line that is a `> command`.
/// `None` when it is none of them (a trace, or something else). Reads at most 64 KiB.
pub fn detect_format(path: &Path) -> Result<Option<LogFormat>, SpecError> {
    let head = read_head(path)?;
    if pcap::is_capture(&head) {
        return Ok(Some(LogFormat::Pcap));
    }
    let text = String::from_utf8_lossy(&head);
    for line in text.lines().take(1000) {
        if asyn::is_asyn_line(line) {
            return Ok(Some(LogFormat::Asyn));
        }
    }
    for line in text.lines() {
        let t = line.trim_start_matches('\u{feff}').trim();
        if t.is_empty() || t.starts_with('#') {
            continue;
        }
        return Ok(starts_as_host_log(t).then_some(LogFormat::HostLog));
    }
    Ok(None)
}

/// What the file at `path` looks like, more loosely than [`detect_format`] (a host log whose
/// first line is a reply or a bad stamp still looks like one), for the hint after an error.
pub fn looks_like(path: &Path) -> Result<Option<LogFormat>, SpecError> {
    if let Some(f) = detect_format(path)? {
        return Ok(Some(f));
    }
    let head = read_head(path)?;
    let text = String::from_utf8_lossy(&head);
    let host = text.lines().take(1000).any(|l| {
        let l = l.trim();
        l.starts_with("> ") || l.contains(" > ") || l.contains("\t> ")
    });
    Ok(host.then_some(LogFormat::HostLog))
}

/// The first 64 KiB of the file at `path`.
fn read_head(path: &Path) -> Result<Vec<u8>, SpecError> {
    use std::io::Read;
    let file = pmacwd_specs::input::open_regular(path)?;
    let mut head = Vec::new();
    file.take(64 << 10).read_to_end(&mut head).map_err(|e| SpecError::whole_file(path, format!("cannot read: {e}")))?;
    Ok(head)
}

/// Whether the file at `path` is a host log: its first line that is not blank or a `#`
/// comment is a `> command`, perhaps after a timestamp. Reads at most that line.
pub fn is_host_log(path: &Path) -> Result<bool, SpecError> {
    let file = pmacwd_specs::input::open_regular(path)?;
    let mut lines = Lines::new(path, BufReader::new(file));
    while let Some((_, text)) = lines.next()? {
        let t = text.trim_start_matches('\u{feff}').trim();
        if t.is_empty() || t.starts_with('#') {
            continue;
        }
        return Ok(starts_as_host_log(t));
    }
    Ok(false)
}

/// Whether a log line is a command line (`> ...`, perhaps after a timestamp).
pub fn starts_as_host_log(line: &str) -> bool {
    if line.starts_with("> ") {
        return true;
    }
    matches!(parse_stamp(line), Ok((_, off)) if line[off..].starts_with("> "))
}
