//! A command line answered a command at a time (issue 33). The server takes the card's lock
//! for one [`Card::line_step`] and releases it before the next, so that another host's `???`
//! waits for at most one command, never for a whole line (a 1,492-byte line of ranges held the
//! lock about 0.1 s); and it asks for the next command only when the host has fetched what the
//! last ones answered, so that a reply far larger than its line (`P0..8191` 165 times) is never
//! built whole: a connection holds one packet and one command's answers.
//!
//! A range of more than [`RANGE_PART_MAX`] variables is read in parts of that many, each its
//! own step: one `M0..8191->` would otherwise hold the lock for 8,192 answers. The answers
//! and their framing are those of the whole range, since each variable's answer is framed on
//! its own (SRM p.37-38).
//!
//! A line waits for the card's background (UM p.236: "Background Tasks ... command
//! processing"; between each scan of a background PLC the card "will do its general
//! housekeeping, and respond to a host command, if any"): its first command runs in the first
//! background cycle that completes at or after the line arrives, so a card whose PLC 0 spaces
//! the background cycles out answers late ("communications ... will become sluggish", UM
//! p.236) before the watchdog trips it silent (UM p.215). See [`Card::background_turn`].

use super::{find_close, Card, Clock};
use crate::capture_queue::Record;
use crate::framing::Answer;
use pmacwd_specs::grammar::{pieces, Addressing, Command, Piece, Unreadable, VarRange, Vars};
use std::collections::VecDeque;
use std::time::Duration;

/// The longest a waiting line sleeps before it looks at the card again on the wall clock: a
/// load change from the control port or another host (a starving card's next background
/// cycle may be seconds away, or never come) is seen within this time. The server's catch-up
/// interval.
pub const BACKGROUND_WAIT_MAX: Duration = Duration::from_millis(100);

/// The most variables of a range read answered in one step. 64 answers are formatted in a few
/// microseconds, a few `???` round trips; a range of 8,192 is 128 steps.
pub const RANGE_PART_MAX: u16 = 64;

/// How a step left the line.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Progress {
    /// More commands to run.
    More,
    /// The line is done; its end (the acknowledgement) is framed.
    Ended,
    /// An error ended the line (its error framed, no acknowledgement).
    Failed,
    /// The card is tripped: it answers nothing (UM p.215), and the rest of the line is lost.
    Silent,
    /// The line waits for the background's turn (UM p.236): ask again after this time (zero:
    /// at once, once the card's lock has been released for others), without the lock.
    Waiting(Duration),
}

/// A command line and how far the card has answered it.
pub struct LineRun {
    line: Vec<u8>,
    /// The commands of the line's current segment not yet run; a segment ends where an `OPEN`
    /// makes the rest of the line program text, which the card reads again once it ran.
    queue: VecDeque<Piece>,
    /// Where the segment starts in the line (the pieces' offsets are the segment's).
    segment_at: usize,
    /// The connection's addressing after the segment was read, which `#` and `&` report.
    addressing_after: Addressing,
    started: bool,
    /// The background cycles the card had completed when the line arrived, less one when the
    /// line arrived in the instant one completed (virtual time); none before the first step.
    arrived: Option<u64>,
    ended: Option<Progress>,
}

impl LineRun {
    /// `bytes` (at most a line, 1,492 bytes: the request's length is checked before).
    pub fn new(bytes: &[u8]) -> LineRun {
        LineRun {
            line: bytes.to_vec(),
            queue: VecDeque::new(),
            segment_at: 0,
            addressing_after: Addressing::default(),
            started: false,
            arrived: None,
            ended: None,
        }
    }

    /// How the line ended, once it has.
    pub fn ended(&self) -> Option<Progress> {
        self.ended
    }

    fn end(&mut self, how: Progress) -> Progress {
        self.queue.clear();
        self.ended = Some(how);
        how
    }

    /// The text of a piece of the current segment, as the host wrote it.
    fn text(&self, p: &Piece) -> String {
        let at = self.segment_at;
        // An unreadable command takes the rest of the line with it.
        let end = if p.command.is_ok() { at + p.end } else { self.line.len() };
        String::from_utf8_lossy(self.line.get(at + p.start..end).unwrap_or_default()).trim().to_string()
    }

    /// The commands still queued, for a capture record.
    fn rest(&mut self) -> Vec<(String, Result<Command, Unreadable>)> {
        let queue = std::mem::take(&mut self.queue);
        queue.into_iter().map(|p| (self.text(&p), p.command)).collect()
    }
}

impl Card {
    /// Runs the next command of `run` (or part of a range), appending its framed answers to
    /// `out`; the connection's `addressing` follows the line as it is read (SRM p.270).
    pub fn line_step(&mut self, run: &mut LineRun, addressing: &mut Addressing, out: &mut Vec<u8>) -> Progress {
        if let Some(how) = run.ended {
            return how;
        }
        if !run.started {
            if let Some(wait) = self.background_turn(run) {
                return Progress::Waiting(wait);
            }
            run.started = true;
            if let Some(how) = self.line_start(run, addressing, out) {
                return how;
            }
        } else {
            self.catch_up();
            if self.core.tripped() && !self.fault.answers_when_tripped() {
                // Tripped between two commands of the line (the card's time runs between two
                // holds of its lock): the rest gets no answer.
                let commands = run.rest();
                self.capture_record(|| Record::Commands { commands, reply: None });
                return run.end(Progress::Silent);
            }
        }
        let Some(piece) = run.queue.pop_front() else {
            self.framing().push_line_end(out);
            return run.end(Progress::Ended);
        };
        let mut text = run.text(&piece);
        let command = match piece.command {
            Ok(c) => c,
            Err(e) => {
                let mut own = Vec::new();
                self.framing().push_answer(&mut own, &Answer::Error(3));
                out.extend_from_slice(&own);
                self.capture_record(|| Record::Commands { commands: vec![(text, Err(e))], reply: Some(own) });
                return run.end(Progress::Failed);
            }
        };
        let (now, later) = split_range(command);
        if let Some(later) = later {
            text = now.to_string();
            run.queue.push_front(Piece { command: Ok(later), start: piece.start, end: piece.end });
        }
        let opens = matches!(now, Command::OpenPlc(_) | Command::OpenProgram(_));
        let mut answers = Vec::new();
        self.command(now.clone(), run.addressing_after, &mut answers);
        // Each answer is framed as I3/I6 stand after its command: `i3=2` already counts.
        let (own, failed) = self.framing().answers(&answers);
        out.extend_from_slice(&own);
        if failed {
            // The commands after it are not executed; the capture notes them so.
            let mut commands = vec![(text, Ok(now))];
            commands.extend(run.rest());
            self.capture_record(|| Record::Commands { commands, reply: Some(own) });
            return run.end(Progress::Failed);
        }
        self.capture_record(|| Record::Commands { commands: vec![(text, Ok(now))], reply: Some(own) });
        if opens && self.buffer_open() {
            self.open_segment(run, run.segment_at + piece.end, addressing);
        }
        if run.queue.is_empty() {
            // The line's end goes with its last command, in the same hold.
            self.framing().push_line_end(out);
            return run.end(Progress::Ended);
        }
        Progress::More
    }

    /// Whether `run`, not started yet, must still wait for the background's turn, and if so
    /// how long before it asks again (UM p.236: command processing is a background task).
    ///
    /// MODEL: the card runs lazily, catching up on the servo cycles due when asked. A line
    /// arrives at the card's instant once the cycles due have run; the background cycles
    /// completed in those cycles came before it. Its first command runs in the first background
    /// cycle completing at or after that instant: on the wall clock in a servo cycle still to
    /// come, the card run up to it and no further (the cycles are those the wall clock has
    /// made due, so the reply never leaves before that cycle's time, `servo_hz`); in virtual
    /// time the card runs the cycles itself, as the host's wait lets them pass (recorded as a
    /// `run` step in a capture), and a line that arrives in the instant a background cycle
    /// completed, such as a second line sent with no step between, or the instant a reset
    /// ended (`Card::reset_ends_as_a_background_cycle`), is answered by that one.
    /// Every waiting line, from any connection, is answered by the same background cycle (the
    /// pages at hand do not say how a card shares its command slot among the Ethernet port's
    /// connections; one line per background cycle would make one host wait for all the
    /// others, issue 33). A tripped card answers nothing (UM p.215), and a card in bootstrap
    /// mode runs no background and answers from its bootstrap firmware at once (SRM p.289).
    fn background_turn(&mut self, run: &mut LineRun) -> Option<Duration> {
        let arrived = match run.arrived {
            Some(a) => a,
            None => {
                self.catch_up();
                let just_now = matches!(self.clock, Clock::Virtual) && self.background_at == Some(self.cycles);
                let a = if just_now { self.background_cycles.saturating_sub(1) } else { self.background_cycles };
                run.arrived = Some(a);
                a
            }
        };
        let go = |card: &Card| card.background_cycles > arrived || card.core.tripped() || card.core.bootstrap();
        if go(self) {
            return None;
        }
        match self.clock {
            Clock::Virtual => {
                // At most a hold's cycles (fewer while user PLCs run, `card/plc.rs`).
                self.run_until(u64::from(self.cycles_per_hold()), true);
                (!go(self)).then_some(Duration::ZERO)
            }
            Clock::Wall { start, servo_hz } => {
                // Up to the cycles due, stopping at the first background cycle.
                let due = self.due_cycles().min(self.cycles.saturating_add(u64::from(self.cycles_per_hold())));
                self.run_until(due.saturating_sub(self.cycles), true);
                if go(self) {
                    return None;
                }
                // Not yet: sleep until the servo cycle the core's next background cycle falls
                // in, as the load stands (looked for over at most BACKGROUND_WAIT_MAX).
                let hz = u64::from(servo_hz.max(1));
                let bound = u32::try_from(hz / 10).unwrap_or(u32::MAX).max(1);
                let ahead = self.cycles_to_background(bound).unwrap_or(bound);
                let at_ns = u128::from(self.cycles.saturating_add(u64::from(ahead))) * 1_000_000_000 / u128::from(hz);
                let at = Duration::from_nanos(u64::try_from(at_ns).unwrap_or(u64::MAX));
                Some(at.saturating_sub(start.elapsed()).min(BACKGROUND_WAIT_MAX))
            }
        }
    }

    /// In how many servo cycles the core's next background cycle completes under the load as
    /// it stands, looked for over at most `bound` cycles on a copy of the core; `None` when it
    /// does not come within them, or the card trips first.
    pub(super) fn cycles_to_background(&self, bound: u32) -> Option<u32> {
        let mut core = self.core;
        for k in 1..=bound {
            core.servo_cycle(&self.cfg);
            if core.tripped() {
                return None;
            }
            if core.background_possible() {
                return Some(k);
            }
        }
        None
    }

    /// The start of a line: a tripped card, or a byte above 127, answers the line at once
    /// (`Some`: how it ended); otherwise its first commands are read.
    fn line_start(&mut self, run: &mut LineRun, addressing: &mut Addressing, out: &mut Vec<u8>) -> Option<Progress> {
        let whole = |run: &LineRun| String::from_utf8_lossy(&run.line).into_owned();
        // UM p.215: a tripped card will not communicate (unless `serve --fault` breaks it).
        if self.core.tripped() && !self.fault.answers_when_tripped() {
            let (line, before) = (whole(run), *addressing);
            self.capture_record(|| Record::Line { line, addressing: before, reply: None });
            return Some(run.end(Progress::Silent));
        }
        if run.line.iter().any(|b| *b > 127) {
            // ERR004: illegal character, bad value (>127 ASCII).
            let mut own = Vec::new();
            self.framing().push_answer(&mut own, &Answer::Error(4));
            out.extend_from_slice(&own);
            let (line, before) = (whole(run), *addressing);
            self.capture_record(|| Record::Line { line, addressing: before, reply: Some(own) });
            return Some(run.end(Progress::Failed));
        }
        self.open_segment(run, 0, addressing);
        None
    }

    /// Reads the line from `from` on. While a program buffer is open, what comes before CLOSE
    /// is program text for it, not on-line commands (UM p.46: "P1=1 ... stored in the buffer
    /// if one is open"): the buffer keeps it (`buffers.rs`) and it is acknowledged. The capture
    /// keeps it as a note (the model holds no program text; read as on-line commands, `CLEAR`
    /// would be ERR003 to it). Text that the buffers have no room for ends the line with
    /// ERR003.
    fn open_segment(&mut self, run: &mut LineRun, from: usize, addressing: &mut Addressing) {
        let mut at = from.min(run.line.len());
        let mut refused = None;
        if self.buffer_open() {
            let skip = find_close(&run.line[at..]).unwrap_or(run.line.len() - at);
            let text = String::from_utf8_lossy(&run.line[at..at + skip]).trim().to_string();
            if !text.is_empty() {
                if let Err(why) = self.buffers.enter(&text) {
                    refused = Some(why);
                }
                if refused.is_none() {
                    self.capture_record(|| {
                        Record::Note(format!("`{text}`: program text for the open buffer (the model keeps none)"))
                    });
                }
            }
            if refused.is_none() {
                at += skip;
            }
        }
        run.segment_at = at;
        run.queue = match refused {
            Some(why) => {
                let at_text = String::from_utf8_lossy(&run.line[at..]).chars().take(80).collect();
                std::iter::once(Piece {
                    command: Err(Unreadable { at: at_text, offset: 0, why }),
                    start: 0,
                    end: run.line.len() - at,
                })
                .collect()
            }
            None => pieces(&run.line[at..], addressing).into(),
        };
        run.addressing_after = *addressing;
    }
}

/// `c`, or its first [`RANGE_PART_MAX`] variables and the rest when it reads more.
fn split_range(c: Command) -> (Command, Option<Command>) {
    match c {
        Command::Read { kind, vars: Vars::Numbers(r), cs } if r.count > RANGE_PART_MAX => {
            let now = VarRange { first: r.first, count: RANGE_PART_MAX, step: r.step };
            let later =
                VarRange { first: r.first + RANGE_PART_MAX * r.step, count: r.count - RANGE_PART_MAX, step: r.step };
            (
                Command::Read { kind, vars: Vars::Numbers(now), cs },
                Some(Command::Read { kind, vars: Vars::Numbers(later), cs }),
            )
        }
        Command::MReport { first, last } if last - first >= RANGE_PART_MAX => (
            Command::MReport { first, last: first + RANGE_PART_MAX - 1 },
            Some(Command::MReport { first: first + RANGE_PART_MAX, last }),
        ),
        other => (other, None),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::card::Clock;

    fn whole(card: &mut Card, line: &str) -> (Vec<u8>, usize) {
        let mut run = LineRun::new(line.as_bytes());
        let mut addressing = Addressing::default();
        let mut out = Vec::new();
        let mut steps = 0;
        while card.line_step(&mut run, &mut addressing, &mut out) == Progress::More {
            steps += 1;
        }
        (out, steps + 1)
    }

    #[test]
    fn a_range_is_answered_in_parts_whose_answers_are_the_whole_range_s() {
        let mut card = Card::default_card(Clock::Virtual);
        card.line(b"P0..199=7").unwrap();
        let (out, steps) = whole(&mut card, "P0..199");
        assert_eq!(out, [&b"7\r".repeat(200)[..], b"\x06"].concat());
        assert_eq!(steps, 4, "64 + 64 + 64 + 8 variables, the line's end with the last");
        // With a step between the numbers (`I130,4,100`), the parts keep the step.
        card.line(b"I130,4,100=3").unwrap();
        let (out, _) = whole(&mut card, "I130,4,100");
        assert_eq!(out, b"3\r3\r3\r3\r\x06");
    }

    #[test]
    fn an_error_ends_the_line_without_running_the_rest() {
        let mut card = Card::default_card(Clock::Virtual);
        let (out, steps) = whole(&mut card, "P1=5 ZZZ P1=6");
        assert_eq!(out, b"\x07ERR003\r");
        assert_eq!(steps, 2);
        assert_eq!(card.line(b"P1").unwrap(), b"5\r\x06");
    }

    #[test]
    fn close_with_no_buffer_open_answers_nothing_and_the_line_goes_on() {
        // What the fuzz target emulator_stream sends after any stream, under whatever framing.
        let mut card = Card::default_card(Clock::Virtual);
        assert_eq!(card.line(b"CLOSE ???").unwrap(), b"001000000000\r\x06");
        card.line(b"I3=0").unwrap();
        assert_eq!(card.line(b"CLOSE ???").unwrap(), b"001000000000\r");
        assert_eq!(card.line(b"CLOSE").unwrap(), b"", "under I3 = 0 a line without data gets no bytes");
        // The fuzz target's first failure: `i3=1&i3=2` writes I3 = 1 & I3 = 0 (an expression).
        let mut card = Card::default_card(Clock::Virtual);
        assert_eq!(card.line(b"i3=1&i3=2; ve").unwrap(), b"\x07ERR003\r");
        assert_eq!(card.line(b"CLOSE ???").unwrap(), b"001000000000\r");
    }

    #[test]
    fn an_open_buffer_takes_the_rest_of_its_line_as_program_text_up_to_close() {
        let mut card = Card::default_card(Clock::Virtual);
        assert_eq!(card.line(b"OPEN PLC 1 P1=1 CLOSE P2=2").unwrap(), b"\x06");
        assert_eq!(card.line(b"P1 P2").unwrap(), b"0\r2\r\x06", "P1=1 was program text");
    }
}
