//! What a log itself shows of each stretch in which the card did not answer, in the log's own
//! lines and host clock: when it last answered, when the host gave up, what the card last
//! acknowledged before, and when it answered again. Read from the exchanges alone, never from
//! the search's choices (issue 29: "the diagnosis says only what the log shows ... in host
//! clock time when the log has stamps, naming when the background stopped and what was sent
//! just before").
//!
//! Why these bound when the background stopped: host commands are processed in the background
//! (UM p.236), so a command answered shows a background cycle completed by its reply, and a
//! command the host gave up on shows that none completed from its arrival until the host gave
//! up; a tripped card answers nothing at all (UM p.215). So the card last completed a
//! background cycle between the reply before the silence and the sending of the first line it
//! did not answer, whichever of starvation or a trip silenced it.

use crate::import::{open_records, Answer, Exchange, LogFormat, LogParser};
use pmacwd_specs::SpecError;
use std::path::Path;

/// How many silences a report describes; the rest are counted.
pub const SILENCES_SHOWN_MAX: usize = 20;

/// A line of the log and its host time (ns on the log's timeline), when stamped.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct At {
    pub line: usize,
    pub ns: Option<i128>,
}

/// One stretch of command lines in a row that the host gave up on.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Silence {
    /// The first line the host gave up on, when it was sent, and its commands as logged.
    pub first_sent: At,
    pub first_commands: String,
    /// Its reply line, where the host gave up.
    pub gave_up: At,
    /// How many command lines in a row went unanswered.
    pub lines: usize,
    /// The reply line of the last answered exchange before it.
    pub last_answer: Option<At>,
    /// The last command the card acknowledged without a value before it (an action, not a
    /// read), where it was sent.
    pub last_action: Option<(String, At)>,
    /// The reply line of the next answered exchange, if the card answered again.
    pub answered_again: Option<At>,
}

/// The silences of a log, the first [`SILENCES_SHOWN_MAX`] of them.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct Silences {
    pub shown: Vec<Silence>,
    /// Those past the first [`SILENCES_SHOWN_MAX`].
    pub more: usize,
    /// Whether the log is stamped (the lines' host times are known).
    pub stamped: bool,
}

/// Reads the log at `path` in `format` for its silences. Bounded: one exchange at a time and
/// at most [`SILENCES_SHOWN_MAX`] silences kept.
pub fn silences(path: &Path, format: LogFormat) -> Result<Silences, SpecError> {
    let mut records = open_records(path, format)?;
    let mut parser = LogParser::new(path);
    let mut out = Silences::default();
    let mut last_answer: Option<At> = None;
    let mut last_action: Option<(String, At)> = None;
    let mut open: Option<Silence> = None;
    while let Some(record) = records.next_record()? {
        let Some(ex) = parser.record(record)? else { continue };
        out.stamped |= ex.at.is_some();
        let silent = ex.commands.iter().any(|c| matches!(c.answer, Answer::Timeout));
        if silent {
            match &mut open {
                Some(s) => s.lines += 1,
                None => {
                    open = Some(Silence {
                        first_sent: At { line: ex.line, ns: ex.sent_at.map(|(lo, _)| lo) },
                        first_commands: ex.commands.iter().map(|c| c.text.as_str()).collect::<Vec<_>>().join(" "),
                        gave_up: replied(&ex),
                        lines: 1,
                        last_answer: last_answer.clone(),
                        last_action: last_action.clone(),
                        answered_again: None,
                    })
                }
            }
            continue;
        }
        if let Some(mut s) = open.take() {
            s.answered_again = Some(replied(&ex));
            keep(&mut out, s);
        }
        last_answer = Some(replied(&ex));
        if let Some(c) = ex.commands.iter().rev().find(|c| matches!(c.answer, Answer::Ack)) {
            last_action = Some((c.text.clone(), At { line: ex.line, ns: ex.sent_at.map(|(lo, _)| lo) }));
        }
    }
    if let Some(s) = open.take() {
        keep(&mut out, s);
    }
    Ok(out)
}

/// The reply line of `ex` and its host time (the end of the exchange's interval less the
/// stamps' resolution is the reply's stamp; the command's when only it is stamped).
fn replied(ex: &Exchange) -> At {
    let ns = match (ex.at, ex.sent_at) {
        (Some((_, hi)), Some((s_lo, s_hi))) => Some(hi - (s_hi - s_lo)),
        _ => None,
    };
    At { line: ex.reply_line, ns }
}

fn keep(out: &mut Silences, s: Silence) {
    if out.shown.len() < SILENCES_SHOWN_MAX {
        out.shown.push(s);
    } else {
        out.more += 1;
    }
}

/// `HH:MM:SS.mmm` of a host time on the log's timeline (time of day; the log's own dates are
/// in its lines).
pub fn clock(ns: i128) -> String {
    let ms = ns.div_euclid(1_000_000);
    let day_ms = ms.rem_euclid(86_400_000);
    format!("{:02}:{:02}:{:02}.{:03}", day_ms / 3_600_000, day_ms / 60_000 % 60, day_ms / 1000 % 60, day_ms % 1000)
}

fn at_text(a: &At) -> String {
    match a.ns {
        Some(ns) => format!("{} (line {})", clock(ns), a.line),
        None => format!("line {}", a.line),
    }
}

impl Silence {
    /// The silence in words: what the log shows, then what it bounds.
    pub fn text(&self) -> String {
        let lines = if self.lines == 1 { "1 line".to_string() } else { format!("{} lines in a row", self.lines) };
        let mut s = format!(
            "unanswered from {}: `{}`, the host gave up at {} ({lines})",
            at_text(&self.first_sent),
            self.first_commands,
            at_text(&self.gave_up)
        );
        match &self.last_answer {
            Some(a) => {
                s.push_str(&format!("; the card last answered at {}", at_text(a)));
                s.push_str(&format!(
                    ", so it last completed a background cycle between {} and {} (UM p.236: commands are \
                     processed in the background; a tripped card answers nothing, UM p.215)",
                    at_text(a),
                    at_text(&self.first_sent)
                ));
            }
            None => s.push_str("; the card answered nothing before it in the log"),
        }
        if let Some((command, a)) = &self.last_action {
            let before = match (a.ns, self.first_sent.ns) {
                (Some(x), Some(y)) => format!(", {:.3} s before", (y - x) as f64 / 1e9),
                _ => String::new(),
            };
            s.push_str(&format!("; the last command it acknowledged before: `{command}` at {}{before}", at_text(a)));
        }
        match &self.answered_again {
            Some(a) => s.push_str(&format!("; it answered again at {}", at_text(a))),
            None => s.push_str("; it answered nothing after, to the end of the log"),
        }
        s
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn of(log: &str) -> Silences {
        let path = std::env::temp_dir().join(format!("pmacwd-silences-{}-{}.log", std::process::id(), log.len()));
        std::fs::write(&path, log).unwrap();
        let s = silences(&path, LogFormat::HostLog).unwrap();
        std::fs::remove_file(&path).ok();
        s
    }

    #[test]
    fn a_stamped_silence_is_bounded_by_the_last_answer_and_the_first_line_not_answered() {
        let s = of("10:00:00.000 > RHX:$0 ???\n10:00:00.001 < 000100 000000000000\n\
                    10:00:00.100 > ENABLE PLC 0\n10:00:00.101 <\n\
                    10:00:00.500 > ???\n10:00:01.500 < (timeout)\n\
                    10:00:01.600 > ???\n10:00:02.600 < (timeout)\n\
                    10:00:09.000 > ???\n10:00:09.001 < 000000000000\n");
        assert_eq!(s.shown.len(), 1);
        let t = s.shown[0].text();
        assert!(t.starts_with("unanswered from 10:00:00.500 (line 5): `???`, the host gave up at 10:00:01.500 (line 6) (2 lines in a row)"), "{t}");
        assert!(
            t.contains("last completed a background cycle between 10:00:00.101 (line 4) and 10:00:00.500 (line 5)"),
            "{t}"
        );
        assert!(t.contains("`ENABLE PLC 0` at 10:00:00.100 (line 3), 0.400 s before"), "{t}");
        assert!(t.ends_with("it answered again at 10:00:09.001 (line 10)"), "{t}");
    }

    #[test]
    fn without_stamps_the_silence_is_told_in_lines_and_one_at_the_end_says_so() {
        let s = of("> ???\n< 000000000000\n> ???\n< (timeout)\n");
        assert!(!s.stamped);
        let t = s.shown[0].text();
        assert!(t.starts_with("unanswered from line 3: `???`, the host gave up at line 4 (1 line)"), "{t}");
        assert!(t.ends_with("it answered nothing after, to the end of the log"), "{t}");
    }

    #[test]
    fn silences_past_the_most_shown_are_counted() {
        let log = "> ???\n< 000000000000\n> ???\n< (timeout)\n".repeat(SILENCES_SHOWN_MAX + 3);
        let s = of(&log);
        assert_eq!((s.shown.len(), s.more), (SILENCES_SHOWN_MAX, 3));
        assert_eq!(clock(((13 * 3600 + 5 * 60 + 7) * 1000 + 42) as i128 * 1_000_000), "13:05:07.042");
    }
}
