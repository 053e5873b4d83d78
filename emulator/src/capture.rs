//! Captures: the requests and replies of host sessions, with timing, written as a trace
//! (JSON Lines, `docs/trace-format.md`) that `pmacwd replay` can judge. Used by `pmacwd record`
//! (a proxy in front of a real card or an emulator) and by `pmacwd serve --record`.
//!
//! A reply is split into its answers ([`framing::parse_reply`]) and the answers are matched to
//! the line's commands in order: `???`, I-variable reads, `RH` reads, `ver` and `cid` report
//! one message each, everything else none; an error ends the line. What is compared and what is
//! only kept as a note:
//!
//! - compared: `???`, `RH` of X:$6, Y:$6, X:$1080, X:$1090; reads of I8, I40, I41 and of any
//!   I-variable written in the capture since the last reset; error numbers; the `(ack)` of
//!   writes, `OPEN` and `CLOSE`; silence (a tripped card, UM p.215);
//! - compared only when the capture's timing is exact to the servo cycle (an emulator's own
//!   sessions, or virtual time): `RH` of X:$25 and Y:$25, which change every servo cycle;
//! - kept as notes: X:$0 (the card's counter starts anywhere; the model's at 0), reads of
//!   I-variables the capture did not write (the card's saved values are not in the model),
//!   `ver` and `cid`, and every command after an error or whose answers cannot be matched.
//!
//! With timing from a host's clock, a silence becomes `tripped: true` with a window of
//! `window_cycles` instead of an exact `(silence)`.

use crate::bounded::cut;
use crate::framing::{self, framing_write_out_of_range, ReadAnswer, FRAMING_VALUE_MAX};
use pmacwd_specs::check::{AllKeyword, ProfileSelection};
use pmacwd_specs::grammar::{self, Addressing, Command, Unreadable, VarKind};
use pmacwd_specs::vocab::command::{HostCommand, Register};
use pmacwd_specs::vocab::event::Event;
use pmacwd_trace::jsonl as trace_jsonl;
use pmacwd_trace::{Expect, Step, Trace, TraceEvent, FORMAT_VERSION, STEP_CYCLES_MAX};
use std::io::{self, Write};

/// Notes kept verbatim for one step: the first few say what happened, and beyond them a
/// count says how many more there were. A line of unknown commands makes a note per command
/// and a client can send such lines forever before any step is written (850 MB of notes in
/// 5 s were measured before this bound); eight keep every note of a normal exchange (a
/// handshake line has three commands) and the whole line stays a few kilobytes.
pub const NOTES_PER_STEP_MAX: usize = 8;

/// One note is cut to this many bytes. Notes quote a command and, when a reply cannot be
/// matched, the reply: a full command line is 1,492 bytes (the card's buffer), so a note is
/// cut before it can carry whole lines; 512 bytes keep the command, the reason and the start
/// of the reply, which is what a reader needs to find the exchange.
pub const NOTE_BYTES_MAX: usize = 512;

/// The notes waiting for a step, bounded in count ([`NOTES_PER_STEP_MAX`]) and size
/// ([`NOTE_BYTES_MAX`] each): the first are kept, the rest only counted.
#[derive(Debug, Default)]
struct Notes {
    kept: Vec<String>,
    omitted: u64,
}

impl Notes {
    fn push(&mut self, note: String) {
        if self.kept.len() < NOTES_PER_STEP_MAX {
            self.kept.push(cut(&note, NOTE_BYTES_MAX));
        } else {
            self.omitted = self.omitted.saturating_add(1);
        }
    }

    fn append(&mut self, other: Notes) {
        let omitted = other.omitted;
        for n in other.kept {
            self.push(n);
        }
        self.omitted = self.omitted.saturating_add(omitted);
    }

    /// The notes as a list, the count of those left out last.
    fn into_list(self) -> Vec<String> {
        let mut list = self.kept;
        if self.omitted > 0 {
            let s = if self.omitted == 1 { "" } else { "s" };
            list.push(format!("{} more note{s} like these omitted", self.omitted));
        }
        list
    }

    /// The notes as one step's note (`None`: no notes).
    fn into_note(self) -> Option<String> {
        let list = self.into_list();
        (!list.is_empty()).then(|| list.join("; "))
    }
}

/// How exact the capture's timing is.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Timing {
    /// Servo cycles counted by the emulator itself: every reading is compared.
    Exact,
    /// Servo cycles estimated from a host's clock: counter reads become notes and a silence
    /// may come up to this many servo cycles early or late.
    HostClock { window_cycles: u32 },
}

/// Writes a capture one step at a time, flushing after each, so an interrupted session keeps
/// everything up to its last exchange.
pub struct CaptureWriter<W: Write> {
    out: W,
    timing: Timing,
    pending_cycles: u64,
    /// I-variables written since the last reset: the model knows their values.
    written: Vec<bool>,
    /// Whether an M-variable assignment or a direct memory write went by since the last reset:
    /// it may have changed any I-variable past I41 (SRM p.57), and the capture cannot tell which
    /// (the address of I-variable storage is the emulator's, not every card's), so I-variable
    /// reads are notes from then on.
    memory_written: bool,
    pending_notes: Notes,
    pub steps: u64,
}

/// How the commands of a line line up with the answers of its reply.
enum Matched {
    /// The command ran and this is what to expect of it.
    Step(Box<Step>),
    /// Kept as a note only (not executed, or not expressible in a trace).
    Note(String),
}

impl<W: Write> CaptureWriter<W> {
    /// Writes the header line.
    pub fn new(mut out: W, description: &str, configuration: &str, timing: Timing) -> io::Result<Self> {
        let header = Trace {
            version: FORMAT_VERSION,
            description: description.to_string(),
            cite: None,
            configuration: configuration.to_string(),
            profiles: ProfileSelection::Keyword(AllKeyword::All),
            steps: Vec::new(),
        };
        writeln!(out, "{}", trace_jsonl::header_line(&header))?;
        out.flush()?;
        Ok(CaptureWriter {
            out,
            timing,
            pending_cycles: 0,
            written: vec![false; usize::from(pmacwd_core::I_VARIABLE_MAX) + 1],
            memory_written: false,
            pending_notes: Notes::default(),
            steps: 0,
        })
    }

    /// `cycles` servo cycles passed: written before the next step as `run` steps (exact
    /// timing: background whenever possible) or `elapsed` ranges (a host's clock).
    pub fn elapse(&mut self, cycles: u64) {
        self.pending_cycles = self.pending_cycles.saturating_add(cycles);
    }

    /// Writes `step` after the `run` steps due; its note gathers the notes waiting, its own,
    /// and `after` (notes about commands that followed it in its line), within the bounds.
    fn write_step(&mut self, mut step: Step, after: Notes) -> io::Result<()> {
        while self.pending_cycles > 0 {
            // Long gaps become several steps: a reader takes at most STEP_CYCLES_MAX per step.
            let cycles = u32::try_from(self.pending_cycles.min(u64::from(STEP_CYCLES_MAX))).unwrap_or(STEP_CYCLES_MAX);
            self.pending_cycles -= u64::from(cycles);
            // An emulator's own clock is exact: the background ran whenever it could (`run`).
            // A host's clock is not: the time is a range, and what happened in it is for
            // replay's search to find (`elapsed`).
            let event = match self.timing {
                Timing::Exact => TraceEvent::Run { cycles },
                Timing::HostClock { window_cycles } => TraceEvent::Elapsed {
                    cycles_min: cycles.saturating_sub(window_cycles),
                    cycles_max: Some(cycles.saturating_add(window_cycles).min(STEP_CYCLES_MAX)),
                },
            };
            self.write_line(Step { event, expect: Expect::default(), note: None })?;
        }
        let mut notes = std::mem::take(&mut self.pending_notes);
        if let Some(own) = step.note.take() {
            notes.push(own);
        }
        notes.append(after);
        step.note = notes.into_note();
        if let TraceEvent::Model(Event::Reset(_) | Event::Command(HostCommand::Reset | HostCommand::Reinitialize)) =
            step.event
        {
            self.written.fill(false);
            self.memory_written = false;
        }
        self.write_line(step)
    }

    fn write_line(&mut self, step: Step) -> io::Result<()> {
        writeln!(self.out, "{}", trace_jsonl::step_line(&step))?;
        self.out.flush()?;
        self.steps += 1;
        Ok(())
    }

    /// An event the bench caused (a control command): load, supply, reset, checksum fault.
    pub fn event(&mut self, step: Step) -> io::Result<()> {
        match step.event {
            TraceEvent::Run { cycles } => {
                self.elapse(u64::from(cycles));
                Ok(())
            }
            _ => self.write_step(step, Notes::default()),
        }
    }

    /// A command line and its reply (`None`: no reply came).
    pub fn exchange(&mut self, line: &str, reply: Option<&[u8]>) -> io::Result<()> {
        self.exchange_addressed(line, Addressing::default(), reply)
    }

    /// As [`CaptureWriter::exchange`], for a connection that addressed `addressing` (`#n`,
    /// `&n`) before this line.
    pub fn exchange_addressed(&mut self, line: &str, addressing: Addressing, reply: Option<&[u8]>) -> io::Result<()> {
        let reads = reads_of(line, addressing);
        let matched = self.match_reads(line, &reads, reply);
        self.write_matched(matched)
    }

    /// Commands the card ran in one hold of its lock (`serve` answers a line a command at a
    /// time, issue 33), each with its text as the host wrote it, and the answers they gave
    /// (`None`: none, the card is tripped). The first may have ended the line with an error,
    /// and the others then follow it unexecuted.
    pub fn commands(
        &mut self,
        commands: &[(String, Result<Command, Unreadable>)],
        reply: Option<&[u8]>,
    ) -> io::Result<()> {
        let reads: Vec<Read> = commands.iter().map(|(text, c)| Read::of(text, c)).collect();
        let line = commands.iter().map(|(t, _)| t.as_str()).collect::<Vec<_>>().join(" ");
        let matched = self.match_reads(&line, &reads, reply);
        self.write_matched(matched)
    }

    /// Writes each step matched, with the notes that follow it in its line.
    fn write_matched(&mut self, matched: Vec<Matched>) -> io::Result<()> {
        // A note goes with the line's step before it, or with the next step written.
        let mut last: Option<(Step, Notes)> = None;
        for m in matched {
            match m {
                Matched::Step(s) => {
                    if let Some((previous, after)) = last.replace((*s, Notes::default())) {
                        self.write_step(previous, after)?;
                    }
                }
                Matched::Note(n) => match &mut last {
                    Some((_, after)) => after.push(n),
                    None => self.pending_notes.push(n),
                },
            }
        }
        match last {
            Some((step, after)) => self.write_step(step, after),
            None => Ok(()),
        }
    }

    /// A note for the next step.
    pub fn note(&mut self, note: String) {
        self.pending_notes.push(note);
    }

    /// Notes that found no step to go with (at the end of a capture), within the same bounds
    /// as a step's.
    pub fn finish(mut self) -> io::Result<Vec<String>> {
        self.out.flush()?;
        Ok(std::mem::take(&mut self.pending_notes).into_list())
    }

    fn match_reads(&mut self, line: &str, commands: &[Read], reply: Option<&[u8]>) -> Vec<Matched> {
        if commands.iter().any(|c| c.memory == Some(MemoryAccess::Write)) {
            self.memory_written = true;
        }
        let command_step = |c: HostCommand, expect: Expect, note: Option<String>| {
            Matched::Step(Box::new(Step { event: TraceEvent::Model(Event::Command(c)), expect, note }))
        };
        // Every command as a step expecting `expect`; those a trace cannot hold as notes. So is
        // a write of I3 or I6 outside 0..3: the emulator refuses it (MODEL,
        // `framing::FRAMING_VALUE_MAX`) where the model would take it, and a replay that took
        // it would then read back a value the card never held.
        let each_command = |expect: Expect| -> Vec<Matched> {
            commands
                .iter()
                .map(|c| match &c.host {
                    Ok(HostCommand::WriteI(n, v)) if framing_write_out_of_range(*n, *v) => Matched::Note(format!(
                        "`{}` left out: I{n} ranges 0..{FRAMING_VALUE_MAX} (SRM p.37, PMAC2 SRM p.25), which the emulator enforces and the model does not",
                        c.text
                    )),
                    Ok(h) => command_step(h.clone(), expect.clone(), None),
                    Err(e) => Matched::Note(format!("`{}` left out: {e}", c.text)),
                })
                .collect()
        };
        let unmatched = |why: String| -> Vec<Matched> {
            let mut out = each_command(Expect::default());
            out.push(Matched::Note(why));
            out
        };
        let Some(bytes) = reply else {
            // A tripped card answers nothing (UM p.215).
            return each_command(match self.timing {
                Timing::Exact => Expect { reply: Some("(silence)".into()), ..Expect::default() },
                Timing::HostClock { window_cycles } => {
                    Expect { tripped: Some(true), window_cycles: Some(window_cycles), ..Expect::default() }
                }
            });
        };
        let shown = String::from_utf8_lossy(bytes).escape_debug().to_string();
        let parsed = match framing::parse_reply(bytes) {
            Ok(p) => p,
            Err(e) => return unmatched(format!("reply `{shown}` to `{line}` not compared: {e}")),
        };
        let mut answers = parsed.answers.into_iter().peekable();
        let mut out = Vec::new();
        let mut stopped = false;
        let unreadable_at = commands.iter().position(|c| matches!(c.host, Ok(HostCommand::Unrecognized(_))));
        for (k, c) in commands.iter().enumerate() {
            let text = &c.text;
            if stopped {
                out.push(Matched::Note(format!("`{text}` not executed: it follows an error in the line")));
                continue;
            }
            // An M-variable definition or assignment, or a direct memory write: answered with
            // nothing, or an error that ends the line; outside the model's vocabulary.
            if c.memory.is_some() {
                if let Some(ReadAnswer::Error(code)) = answers.peek() {
                    let code = code.map_or("an error".to_string(), |n| format!("ERR{n:03}"));
                    answers.next();
                    stopped = true;
                    out.push(Matched::Note(format!("`{text}` answered {code}: outside the model's vocabulary")));
                } else {
                    out.push(Matched::Note(format!(
                        "`{text}` kept as a note: M-variable definitions, assignments and memory writes are outside the model's vocabulary"
                    )));
                }
                continue;
            }
            // The command's answers: as many as it reports, or one error in their place. When
            // the grammar could not read a later command, the error is that command's (the
            // card reads the same grammar); otherwise the first command to meet it took it.
            let mut data = Vec::new();
            let mut error = None;
            let want = c.values.unwrap_or(0);
            let later_unreadable = unreadable_at.is_some_and(|u| u > k);
            loop {
                match answers.peek() {
                    Some(ReadAnswer::Error(_)) if later_unreadable => break,
                    Some(ReadAnswer::Error(n)) => {
                        error = Some(*n);
                        answers.next();
                        break;
                    }
                    Some(ReadAnswer::Data(_)) if data.len() < want || c.values.is_none() => {
                        if let Some(ReadAnswer::Data(d)) = answers.next() {
                            data.push(d.trim().to_string());
                        }
                    }
                    _ => break,
                }
            }
            if error.is_none() && data.len() < want {
                return unmatched(format!("reply `{shown}` to `{line}` not compared: fewer answers than commands"));
            }
            let command = match &c.host {
                // The emulator refuses I3 and I6 outside 0..3 (MODEL, `FRAMING_VALUE_MAX`)
                // where the model would take them: left out.
                Ok(HostCommand::WriteI(n, v)) if framing_write_out_of_range(*n, *v) => {
                    out.push(Matched::Note(format!(
                        "`{text}` left out: I{n} ranges 0..{FRAMING_VALUE_MAX} (SRM p.37, PMAC2 SRM p.25), which the emulator enforces and the model does not"
                    )));
                    stopped = error.is_some();
                    continue;
                }
                Ok(h) => h.clone(),
                Err(e) => {
                    out.push(Matched::Note(format!("`{text}` left out: {e}")));
                    stopped = error.is_some();
                    continue;
                }
            };
            let mut expect = Expect::default();
            let mut note = None;
            if let Some(code) = error {
                stopped = true;
                match code {
                    Some(n) => expect.reply = Some(format!("ERR{n:03}")),
                    None => note = Some("an error without its number (I6 = 0 or 2): not compared".to_string()),
                }
            } else if !data.is_empty() {
                (expect.reply, note) = self.expect_data(&command, &data.join(" "));
            } else if matches!(command, HostCommand::Reset | HostCommand::Reinitialize) {
                note = Some(format!("{command} resets the card: its acknowledgement is the link's, not compared"));
            } else {
                expect.reply = Some("(ack)".into());
                if let HostCommand::WriteI(n, _) | HostCommand::WriteIMemory(n, _) = command {
                    self.written[usize::from(n)] = true;
                }
            }
            out.push(command_step(command, expect, note));
        }
        if answers.next().is_some() {
            return unmatched(format!("reply `{shown}` to `{line}` not compared: more answers than commands"));
        }
        out
    }

    /// What to expect of a command that reported `data`, or why it is only a note.
    fn expect_data(&self, command: &HostCommand, data: &str) -> (Option<String>, Option<String>) {
        let exact = self.timing == Timing::Exact;
        let note = |why: &str| (None, Some(format!("reply `{data}` not compared: {why}")));
        match command {
            HostCommand::ReadI(_) if self.memory_written => note(
                "an M-variable assignment or memory write since the last reset may have changed it (SRM p.57: past I41), and the capture cannot tell which I-variable it reached",
            ),
            HostCommand::ReadHex(Register::ServoCycles) => note("X:$0 counts from wherever the card started"),
            HostCommand::ReadI(n) if is_countdown_timer(*n) => {
                note("Isx11 and Isx12 count down every servo cycle (SRM p.176); the model holds what was written")
            }
            HostCommand::Checksum => {
                note("a card's firmware reference checksum; the model's is a token (MODEL: it sums no memory)")
            }
            HostCommand::ReadHex(Register::WatchdogCounter | Register::WatchdogMinimum) if !exact => {
                note("timing from the host's clock is not exact to a servo cycle")
            }
            _ => (Some(data.to_ascii_uppercase()), None),
        }
    }
}

/// Whether I-variable `n` is a coordinate system's user countdown timer, Isx11 or Isx12 (SRM
/// p.176), which the card counts down by itself.
fn is_countdown_timer(n: u16) -> bool {
    (5100..=6699).contains(&n) && matches!(n % 100, 11 | 12)
}

/// The commands of `line` as the card's grammar reads it, as the card did
/// (`pmacwd_specs::grammar`), from `addressing`.
fn reads_of(line: &str, addressing: Addressing) -> Vec<Read> {
    let mut addressing = addressing;
    grammar::pieces(line.as_bytes(), &mut addressing)
        .into_iter()
        .map(|p| {
            // An unreadable command takes the rest of the line with it.
            let end = if p.command.is_ok() { p.end } else { line.len() };
            let text = line.get(p.start..end).unwrap_or(line);
            Read::of(text, &p.command)
        })
        .collect()
}

/// One command of a line as the grammar read it, with the model's view of it.
struct Read {
    text: String,
    host: Result<HostCommand, String>,
    /// How many values the card answers it with (`Command::values`).
    values: Option<usize>,
    memory: Option<MemoryAccess>,
}

impl Read {
    fn of(text: &str, command: &Result<Command, Unreadable>) -> Read {
        let text = text.trim().to_string();
        match command {
            Ok(c) => Read { memory: memory_access(c), values: c.values(), host: HostCommand::from_grammar(c), text },
            Err(e) => Read { text, host: Ok(HostCommand::Unrecognized(e.at.clone())), values: Some(0), memory: None },
        }
    }
}

/// What a command does to memory beyond the model's vocabulary.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum MemoryAccess {
    /// `M100->X:$25,0,24,S`, `M1..8->*`: a definition (answers nothing).
    Define,
    /// `M100=5`, `M1..8=0`, `WX:$2082,7`: a write that may reach an I-variable (SRM p.57).
    Write,
}

fn memory_access(c: &Command) -> Option<MemoryAccess> {
    match c {
        Command::MDefine { .. } => Some(MemoryAccess::Define),
        Command::Write { kind: VarKind::M, .. } | Command::MemoryWrite { .. } => Some(MemoryAccess::Write),
        _ => None,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use pmacwd_trace::jsonl::read_all;
    use std::path::Path;

    fn capture(timing: Timing, exchanges: &[(&str, Option<&[u8]>)]) -> Trace {
        let mut buf = Vec::new();
        let mut w = CaptureWriter::new(&mut buf, "test", "i40-zero", timing).unwrap();
        for (line, reply) in exchanges {
            w.elapse(3);
            w.exchange(line, *reply).unwrap();
        }
        assert!(w.finish().unwrap().is_empty());
        read_all(Path::new("capture.jsonl"), buf.as_slice()).expect("a capture reads back as a trace")
    }

    fn replies(t: &Trace) -> Vec<(String, Option<String>)> {
        t.steps
            .iter()
            .filter_map(|s| match &s.event {
                TraceEvent::Model(Event::Command(c)) => Some((c.to_string(), s.expect.reply.clone())),
                _ => None,
            })
            .collect()
    }

    #[test]
    fn after_a_memory_write_i_variable_reads_are_notes_until_a_reset() {
        // SRM p.57: an M-variable assignment or a direct memory write changes an I-variable past
        // I41. The capture cannot tell which one (the storage address is not every card's), so
        // a read the model would otherwise be held to becomes a note, and a replay of a correct
        // card cannot diverge on it.
        let t = capture(
            Timing::Exact,
            &[
                ("I130=5 M100->D:$2082 I130", Some(b"5\r\x06")),
                ("M100=9 I130 I40", Some(b"9\r0\r\x06")),
                ("$$$", Some(b"\x06")),
                ("I130=1 I130", Some(b"1\r\x06")),
            ],
        );
        let r = replies(&t);
        assert_eq!(r[0], ("I130=5".into(), Some("(ack)".into())));
        assert_eq!(r[1], ("I130".into(), Some("5".into())), "the definition alone writes nothing");
        assert_eq!(r[2], ("I130".into(), None), "after M100=9");
        assert_eq!(r[3], ("I40".into(), None), "even I40: a memory write can reach it");
        assert_eq!(r[6], ("I130".into(), Some("1".into())), "compared again after the reset");
        let notes: Vec<_> = t.steps.iter().filter_map(|s| s.note.as_deref()).collect();
        assert!(notes.iter().any(|n| n.contains("`M100=9` kept as a note")), "{notes:?}");
    }

    #[test]
    fn a_refused_definition_ends_the_line_and_takes_its_error() {
        // `M1->Z:0` is ERR003 and nothing after it runs: the grammar cannot read it, so it and
        // the rest of the line are one unrecognized command that the model also answers
        // ERR003; I130 is not held to the error.
        let t =
            capture(Timing::Exact, &[("M1->Z:0 I130", Some(b"\x07ERR003\r")), ("???", Some(b"000000000000\r\x06"))]);
        assert_eq!(
            replies(&t),
            [
                ("M1->Z:0 I130".to_string(), Some("ERR003".to_string())),
                ("???".to_string(), Some("000000000000".to_string()))
            ],
            "I130 did not run"
        );
    }

    #[test]
    fn the_handshake_line_keeps_its_writes_and_notes_ver() {
        // dls-pmaclib's connect: `i6=1 i3=2 ver` answered `1.947 CR ACK`.
        let t = capture(Timing::Exact, &[("i6=1 i3=2 ver", Some(b"1.947\r\x06"))]);
        assert_eq!(t.steps[0].event, TraceEvent::Run { cycles: 3 });
        let r = replies(&t);
        assert_eq!(r[0], ("I6=1".into(), Some("(ack)".into())));
        assert_eq!(r[1], ("I3=2".into(), Some("(ack)".into())));
        // `ver` is the card's own answer: kept, and the model accepts whatever a running card says.
        assert_eq!(r[2], ("VER".into(), Some("1.947".into())));
    }

    #[test]
    fn reads_compare_only_what_the_model_can_know() {
        let t = capture(
            Timing::HostClock { window_cycles: 225 },
            &[
                ("I130 I40 RHY:$25 ??? RHX:$0", Some(b"7\r0\r000FF0\r000000000000\r01A2B3\r\x06")),
                ("I130=5 I130", Some(b"5\r\x06")),
            ],
        );
        let r = replies(&t);
        // I130 before any write: the card's saved value, which the model takes as the card's own.
        assert_eq!(r[0].1.as_deref(), Some("7"));
        assert_eq!(r[1].1.as_deref(), Some("0"));
        assert_eq!(r[2].1, None, "Y:$25 from a host clock");
        assert_eq!(r[3].1.as_deref(), Some("000000000000"));
        assert_eq!(r[4].1, None, "X:$0");
        assert_eq!(r[6].1.as_deref(), Some("5"), "I130 after the capture wrote it");
    }

    #[test]
    fn an_error_ends_the_line_and_silence_is_a_trip() {
        let t = capture(
            Timing::HostClock { window_cycles: 225 },
            &[("I130=1 ZZZ I131=1", Some(b"\x07ERR003\r")), ("???", None)],
        );
        let r = replies(&t);
        assert_eq!(r.len(), 3, "I131=1 follows the error: not a step of its own");
        assert_eq!(r[1], ("ZZZ I131=1".into(), Some("ERR003".into())));
        let last = t.steps.last().unwrap();
        assert_eq!((last.expect.tripped, last.expect.window_cycles), (Some(true), Some(225)));
        assert!(last.note.is_none());
    }

    #[test]
    fn answers_that_do_not_line_up_are_kept_but_not_compared() {
        // Two status reads answered with one value: neither is compared.
        let t = capture(Timing::Exact, &[("#1HM ???", Some(b"000000000000\r\x06")), ("??? ???", Some(b"1\r\x06"))]);
        let r = replies(&t);
        assert_eq!(r[0], ("#1J=".into(), Some("(ack)".into())), "a homing search starts motion as a jog does");
        assert_eq!(r[1].1.as_deref(), Some("000000000000"));
        assert!(r[2..].iter().all(|(_, r)| r.is_none()));
        let notes: Vec<&str> = t.steps.iter().filter_map(|s| s.note.as_deref()).collect();
        assert!(notes.iter().any(|n| n.contains("fewer answers than commands")));
    }

    #[test]
    fn notes_waiting_for_a_step_stay_bounded_however_many_lines_bring_them() {
        // A client that sends only commands the model cannot follow (I40 written from the
        // card's own variables) makes notes and no steps; the notes wait for the next step.
        // Before the bound they grew without limit (850 MB in 5 s) and the step that finally
        // came was one line of hundreds of MB. Now the first NOTES_PER_STEP_MAX are kept, each
        // cut to NOTE_BYTES_MAX, and the rest are counted.
        let long = format!("I40=I10{}", "+0".repeat(700));
        let mut buf = Vec::new();
        let mut w = CaptureWriter::new(&mut buf, "test", "i40-zero", Timing::Exact).unwrap();
        for _ in 0..10_000 {
            w.exchange(&format!("{long} I41=I10"), Some(b"\x06")).unwrap();
        }
        w.exchange("???", Some(b"000000000000\r\x06")).unwrap();
        assert!(w.finish().unwrap().is_empty(), "the notes went with the `???` step");
        let longest = buf.split(|b| *b == b'\n').map(<[u8]>::len).max().unwrap();
        assert!(longest <= NOTES_PER_STEP_MAX * (NOTE_BYTES_MAX + 2) + 200, "one step line is {longest} bytes");
        let t = read_all(Path::new("capture.jsonl"), buf.as_slice()).unwrap();
        let note = t.steps.last().unwrap().note.clone().unwrap();
        assert!(note.contains("19992 more notes like these omitted"), "{}", &note[note.len() - 80..]);
    }

    #[test]
    fn notes_left_at_the_end_are_bounded_too() {
        // The notes that no step took are handed back by finish, within the same bounds.
        let mut buf = Vec::new();
        let mut w = CaptureWriter::new(&mut buf, "test", "i40-zero", Timing::Exact).unwrap();
        for k in 0..100 {
            w.note(format!("note {k}: {}", "z".repeat(2000)));
        }
        let left = w.finish().unwrap();
        assert_eq!(left.len(), NOTES_PER_STEP_MAX + 1);
        assert!(left[..NOTES_PER_STEP_MAX].iter().all(|n| n.len() <= NOTE_BYTES_MAX));
        assert_eq!(left[NOTES_PER_STEP_MAX], "92 more notes like these omitted");
    }

    #[test]
    fn a_refused_framing_write_is_left_out_of_the_replay() {
        // The emulator answers `I3=4` with ERR003 (MODEL); the model would take it. A reply
        // with an error cannot be matched to a write (the error may be a later command's),
        // so the line's commands become steps without expectations, which a replay executes:
        // the model would then hold I3 = 4 and a later read of I3 (compared: the capture wrote
        // I3) would diverge. The refused write is left out, as a note.
        let t = capture(
            Timing::Exact,
            &[("i6=1 i3=2", Some(b"\x06")), ("I3=4", Some(b"\x07ERR003\r")), ("I3", Some(b"2\r\x06"))],
        );
        let r = replies(&t);
        assert_eq!(r.iter().filter(|(c, _)| c == "I3=4").count(), 0, "{r:?}");
        assert_eq!(r.last(), Some(&("I3".to_string(), Some("2".to_string()))));
        let note = t.steps.iter().find_map(|s| s.note.as_deref()).unwrap();
        assert!(note.contains("`I3=4` left out: I3 ranges 0..3"), "{note}");
    }
}
