//! What the steps of a capture alone show no correct card does, whatever its timing, its
//! tolerances, its I40 or where the commands fall in time ([`refuted`]). Such a capture needs
//! no search: `report::explain_timed` reads these rules first, and every lane of readings dies
//! at the line they name (issue 29: an impossible log took 86 s of search to be rejected at a
//! line these rules name at once).

use crate::replay::{ImportAs, Source};
use pmacwd_specs::vocab::command::HostCommand;
use pmacwd_specs::vocab::event::Event;
use pmacwd_specs::{Spec, SpecError};
use pmacwd_trace::TraceEvent;
use std::path::Path;

/// An observation no correct card shows ([`refuted`]), where the capture shows it.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Refuted {
    /// The capture's line.
    pub line: usize,
    /// The capture's event there, counted from 1 as the search counts them.
    pub event: u64,
    /// The capture's events in all.
    pub events: u64,
    /// What the observation is, what a correct card shows there, and what the log shows: a
    /// lane's death, as the report prints it.
    pub what: String,
    pub expected: String,
    pub observed: String,
    /// The whole finding, with its pages.
    pub why: String,
}

/// One rule's finding at the step it reads.
struct Finding {
    what: String,
    expected: String,
    observed: String,
    why: String,
}

/// The host command of a step: one the card answered, or one the host gave up on, which the
/// card may still have processed after the wait (`Controller::unanswered`): the rules here,
/// which hold whatever the timing, take both as the command.
pub(super) fn command_of(step: &pmacwd_trace::Step) -> Option<&HostCommand> {
    match &step.event {
        TraceEvent::Model(Event::Command(c)) | TraceEvent::Unanswered { command: c, .. } => Some(c),
        _ => None,
    }
}

/// Whether `step` changes I40 (a write, `I40=*`, `$$$***`, a memory write, or a command the
/// model cannot follow that writes it): reads after it say nothing of the saved value.
pub(super) fn writes_i40(step: &pmacwd_trace::Step) -> bool {
    match command_of(step) {
        Some(c) => match c {
            HostCommand::WriteI(40, _)
            | HostCommand::WriteIMemory(40, _)
            | HostCommand::DefaultI(40)
            | HostCommand::Reinitialize => true,
            HostCommand::Card { forgets: Some(r), .. } => r.numbers().any(|n| n == 40),
            _ => false,
        },
        None => false,
    }
}

/// What the capture shows that no correct card shows whatever its I40, read from the steps
/// alone (rules that do not read the counter's reload), with its line:
/// - X:$25 "the lowest value of the watchdog counter since the last power-on/reset" (SRM
///   p.57) rising between two reads with no reset between them (and no command that may write
///   memory, which could write X:$25);
/// - the CPU type (bit 21 of both `???` words, SRM p.289) changing: it is the card's;
/// - bit 13 of X:$000006 (a checksum error) shown clear after it showed set, with no reset
///   between (SRM p.289, UM p.217);
/// - an I-variable read back with a value other than the one just written ([`ReadBack`]);
/// - X:$1080 read with two values after a status read showed the checksum error, with no
///   reset between ([`Freeze`], UM p.217);
/// - an answer after a wait no card survives without tripping ([`Outlived`]);
/// - Y:$25 or X:$25 read above the highest reload the card's I40 gives (UM p.215, SRM p.57);
/// - bit 22 of X:$000006 shown clear after it showed set, with no reset and no memory write
///   between (SRM p.289).
///
/// None of these depends on the card's timing, its tolerances or where the commands fall in
/// time either, so a capture they refute needs no search (`report::explain_timed`).
pub fn refuted(spec: &Spec, path: &Path, import: ImportAs<'_>) -> Result<Option<Refuted>, SpecError> {
    let mut source = Source::open_with(spec, path, import)?;
    let mut rules = Rules {
        lowest: None,
        cpu: None,
        checksum_error: None,
        rti_reentry: None,
        read_back: ReadBack::default(),
        freeze: Freeze::default(),
        outlived: Outlived::new(spec, &source, &import)?,
    };
    let mut event = 0u64;
    let mut found: Option<Refuted> = None;
    while let Some((line, step)) = source.next_step()? {
        event += 1;
        if found.is_some() {
            // Only counted: the report gives the capture's events in all.
            continue;
        }
        if let Some(f) = rules.step(spec, line, &step) {
            found = Some(Refuted {
                line,
                event,
                events: 0,
                what: f.what,
                expected: f.expected,
                observed: f.observed,
                why: f.why,
            });
        }
    }
    Ok(found.map(|r| Refuted { events: event, ..r }))
}

/// [`refuted`]'s finding, as a sentence.
pub fn refutation(spec: &Spec, path: &Path, import: ImportAs<'_>) -> Result<Option<String>, SpecError> {
    Ok(refuted(spec, path, import)?.map(|r| r.why))
}

/// The rules of [`refuted`], and what each knows so far.
struct Rules {
    /// X:$25's lowest read since the last reset, and its line.
    lowest: Option<(i32, usize)>,
    /// The CPU type bits first read, and their line.
    cpu: Option<((bool, bool), usize)>,
    /// The status read that showed bit 13 (a checksum error) since the last reset.
    checksum_error: Option<usize>,
    /// The status read that showed bit 22 (RTI re-entry) since the last reset or clearing.
    rti_reentry: Option<usize>,
    read_back: ReadBack,
    freeze: Freeze,
    outlived: Outlived,
}

impl Rules {
    fn step(&mut self, spec: &Spec, line: usize, step: &pmacwd_trace::Step) -> Option<Finding> {
        use pmacwd_specs::vocab::reply_text::{self, StatusReply};
        if let Some(f) = self.read_back.step(spec, line, step) {
            return Some(f);
        }
        if let Some(thawed) = self.freeze.step(spec, line, step) {
            return Some(Finding {
                what: "X:$1080".into(),
                expected: thawed.expected(),
                observed: thawed.observed(),
                why: thawed.why(line),
            });
        }
        if let Some(f) = self.outlived.step(line, step) {
            return Some(f);
        }
        // The counter counts down from its reload (UM p.215, SRM p.57): Y:$25, and X:$25 (its
        // lowest), never read above the highest reload the card's I40 gives.
        let reload_max = i64::try_from(self.outlived.reload_max).unwrap_or(i64::MAX);
        for (register, read) in [("Y:$25", super::reads::counter_read(step)), ("X:$25", super::reads::min_read(step))] {
            if let Some(v) = read.filter(|v| i64::from(*v) > reload_max) {
                return Some(Finding {
                    what: register.into(),
                    expected: format!(
                        "at most {reload_max}, the highest reload the card's I40 gives (UM p.215, SRM p.57)"
                    ),
                    observed: format!("{v:06X} ({v})"),
                    why: format!(
                        "line {line}: {register} read {v:06X} ({v}), above {reload_max}, the highest value the counter \
                         is reloaded to under the card's I40 as the log shows it (I40 = 0 reloads 4095 or 4096, \
                         any other value itself; UM p.215, SRM p.57), whatever the timing"
                    ),
                });
            }
        }
        let resets = match (&step.event, command_of(step)) {
            (TraceEvent::Restart | TraceEvent::RestartPossible | TraceEvent::Model(Event::Reset(_)), _) => true,
            (_, Some(c)) => match c {
                HostCommand::Reset | HostCommand::Reinitialize => true,
                // A command the model cannot follow may be a memory write (`WX:$25,...`, an
                // M-variable pointed at X:$25): the rule stops there.
                HostCommand::Card { text, .. } | HostCommand::Unrecognized(text) => may_write_memory(text),
                _ => false,
            },
            _ => false,
        };
        if resets {
            self.lowest = None;
            self.checksum_error = None;
            self.rti_reentry = None;
        }
        if step.event == TraceEvent::Model(Event::ClearRtiReentry) {
            self.rti_reentry = None;
        }
        // Bit 22 of X:$000006, RTI re-entry, "stays at 1 until the card is reset, or until
        // this bit is manually changed to 0" (SRM p.289): a memory write may change it (it
        // ends the rule above), a reset clears it; nothing else does, under every reading.
        if let Some(at) = cleared(&mut self.rti_reentry, status_bit_shown(spec, step, "rti_reentry"), line) {
            return Some(Finding {
                what: "bit 22 of X:$000006 (RTI re-entry)".into(),
                expected: format!("set, as line {at} showed it, until a reset or a write of 0 (SRM p.289)"),
                observed: "clear".into(),
                why: format!(
                    "line {line}: bit 22 of X:$000006 (RTI re-entry, SRM p.289) is clear, where line {at} showed it \
                     set, with no reset and no memory write or M-variable assignment between: \"it stays at 1 until \
                     the card is reset, or until this bit is manually changed to 0\" (SRM p.289), whatever the timing"
                ),
            });
        }
        // Bit 13 of X:$000006, any checksum error, is cleared only by a reset: the checksum
        // operations stop after the error (SRM p.289; UM p.217). One meaning under every
        // reading (bit 12's two readings leave it alone).
        if let Some(at) = cleared(&mut self.checksum_error, checksum_error_shown(spec, step), line) {
            return Some(Finding {
                what: "bit 13 of X:$000006 (a checksum error)".into(),
                expected: format!("set, as line {at} showed it, until a reset (SRM p.289, UM p.217)"),
                observed: "clear".into(),
                why: format!(
                    "line {line}: bit 13 of X:$000006 (a checksum error, SRM p.289) is clear, where line {at} showed \
                     it set, with no reset between: it stays set until the card is reset, the checksum operations \
                     stopping at the error (SRM p.289, UM p.217), whatever I40 and the timing"
                ),
            });
        }
        if let Some(v) = super::reads::min_read(step) {
            if let Some((before, at)) = self.lowest.filter(|(before, _)| v > *before) {
                return Some(Finding {
                    what: "X:$25".into(),
                    expected: format!(
                        "at most {before:06X}, read at line {at}: the counter's lowest since the last reset (SRM p.57)"
                    ),
                    observed: format!("{v:06X}"),
                    why: format!(
                        "line {line}: X:$25 rose from {before:06X} (line {at}) to {v:06X} with no reset between: it \
                         is the lowest value of the counter since the last reset (SRM p.57), whatever I40 is"
                    ),
                });
            }
            if self.lowest.is_none_or(|(before, _)| v < before) {
                self.lowest = Some((v, line));
            }
        }
        if let (TraceEvent::Model(Event::Command(HostCommand::GlobalStatus)), Some(Ok(StatusReply::Words { x, y }))) =
            (&step.event, step.expect.reply.as_deref().map(reply_text::decode))
        {
            let bits = (x & 1 << 21 != 0, y & 1 << 21 != 0);
            let shown = |(x, y): (bool, bool)| format!("bit 21 of X {}, of Y {}", u8::from(x), u8::from(y));
            match self.cpu {
                Some((first, at)) if first != bits => {
                    return Some(Finding {
                        what: "the CPU type (bits 21 of both `???` words)".into(),
                        expected: format!("{}, as line {at} read them: the card's own (SRM p.289)", shown(first)),
                        observed: shown(bits),
                        why: format!(
                            "line {line}: the CPU type bits (21 of both `???` words, SRM p.289) changed from line \
                             {at}'s: they are the card's, whatever I40 is"
                        ),
                    });
                }
                None => self.cpu = Some((bits, line)),
                _ => {}
            }
        }
        None
    }
}

/// A status bit that stays set once shown set (until what ends `shown`, which the caller
/// clears): records the first line showing it set; the line it was set at if `set` shows it
/// clear.
fn cleared(shown: &mut Option<usize>, set: Option<bool>, line: usize) -> Option<usize> {
    match (set?, *shown) {
        (false, Some(at)) => Some(at),
        (true, None) => {
            *shown = Some(line);
            None
        }
        _ => None,
    }
}

/// A host that waited longer for an answer than any card survives with no background cycle:
/// the counter runs out from its reload at the latest, and the strobe stops once it has
/// (UM p.215, SRM p.57); past the hardware delay the card trips (UM p.215), and a tripped card
/// does not communicate until it is reset. Host commands are processed in the background (UM
/// p.236), so a wait that long without an answer means no background cycle in it: any answer
/// after it with no reset between is no card's, whatever its timing and tolerances.
struct Outlived {
    /// The highest reload the card's I40 gives under either reading (UM p.215, SRM p.57), or
    /// I40's highest value where the log does not say it or writes it.
    reload_max: u64,
    /// The longest hardware delay any reading admits: a full period of the slowest strobe
    /// UM p.215's "approximately 25 Hz" allows (20 Hz), in servo cycles.
    delay_max: u64,
    /// I40's highest value (`variables.yaml`, SRM p.57).
    i40_max: u64,
    /// The line of the wait the card cannot have outlived, since the last reset.
    tripped_at: Option<(usize, u32)>,
}

impl Outlived {
    fn new(spec: &Spec, source: &Source, import: &ImportAs<'_>) -> Result<Outlived, SpecError> {
        let card = source.card_as(import);
        let cfg = pmacwd_specs::config::ModelConfig::from_spec(
            spec,
            source.configuration(),
            &spec.profiles.default_profile(),
        )?;
        let servo_hz = card.and_then(|c| c.servo_hz).unwrap_or(cfg.servo_hz);
        let i40_max = cfg.i40_range.1.max(0) as u64;
        let reload_max = match card.and_then(|c| c.i40) {
            // UM p.215: I40 = 0 reloads 4096 (SRM p.57: 4095).
            Some(0) => 4096,
            Some(v) => v.max(0) as u64,
            None => i40_max,
        };
        Ok(Outlived { reload_max, delay_max: u64::from(servo_hz).div_ceil(20), i40_max, tripped_at: None })
    }

    fn step(&mut self, line: usize, step: &pmacwd_trace::Step) -> Option<Finding> {
        if writes_i40(step) {
            // The reload is the new value's from here: take the highest I40 can be.
            self.reload_max = self.reload_max.max(self.i40_max);
        }
        match (&step.event, command_of(step)) {
            (TraceEvent::Restart | TraceEvent::RestartPossible | TraceEvent::Model(Event::Reset(_)), _)
            | (_, Some(HostCommand::Reset | HostCommand::Reinitialize)) => {
                self.tripped_at = None;
                return None;
            }
            _ => {}
        }
        if let TraceEvent::Unanswered { wait_cycles, .. } = step.event {
            // Counter, one cycle past it (below zero), the delay, and the cycle that trips.
            if u64::from(wait_cycles) > self.reload_max + self.delay_max + 2 && self.tripped_at.is_none() {
                self.tripped_at = Some((line, wait_cycles));
            }
            return None;
        }
        let answered =
            matches!(step.expect.reply.as_deref(), Some(r) if r != "(silence)") || step.expect.tripped == Some(false);
        match self.tripped_at {
            Some((at, wait)) if answered && matches!(step.event, TraceEvent::Model(Event::Command(_))) => {
                Some(Finding {
                    what: "an answer".into(),
                    expected: format!(
                        "(silence): tripped after line {at}'s wait of {wait} servo cycles, with no reset since (UM p.215, \
                         p.236)"
                    ),
                    observed: step.expect.reply.clone().unwrap_or_else(|| "an answer".into()),
                    why: format!(
                        "line {line}: the card answered, where at line {at} the host waited {wait} servo cycles for an \
                         answer that did not come: host commands are processed in the background (UM p.236), and no \
                         card runs that long without a background cycle (its reload of at most {} plus a hardware \
                         delay of at most {} cycles) without tripping; a tripped card does not communicate until it \
                         is reset (UM p.215), and no reset comes between, whatever the timing",
                        self.reload_max, self.delay_max
                    ),
                })
            }
            _ => None,
        }
    }
}

/// Whether a command the model cannot follow may write memory: an assignment (an M-variable
/// may point at any word, SRM p.57: I41 does not stop it) or a `W` memory write.
fn may_write_memory(text: &str) -> bool {
    text.contains('=') || text.trim_start().starts_with(['W', 'w'])
}

/// Whether the status word a step reads (`???`, or `RHX:$6`) shows bit 13 of X:$000006, the
/// checksum error bit (SRM p.289); `None` if the step reads no such word.
fn checksum_error_shown(spec: &Spec, step: &pmacwd_trace::Step) -> Option<bool> {
    status_bit_shown(spec, step, "checksum_error")
}

/// Whether the status word a step reads (`???`, or `RHX:$6`/`RHY:$6`) shows the bit of
/// `status.yaml` named `name`; `None` if the step reads no word holding it.
fn status_bit_shown(spec: &Spec, step: &pmacwd_trace::Step, name: &str) -> Option<bool> {
    use pmacwd_specs::status::WordId;
    use pmacwd_specs::vocab::command::Register;
    use pmacwd_specs::vocab::reply_text::{self, StatusReply};
    let (word, bit) = spec.status.bit(name)?;
    let reply = step.expect.reply.as_deref()?;
    let TraceEvent::Model(Event::Command(command)) = &step.event else { return None };
    let w = match (command, word) {
        (HostCommand::GlobalStatus, _) => match reply_text::decode(reply) {
            Ok(StatusReply::Words { x, y }) => match word {
                WordId::X => x,
                WordId::Y => y,
            },
            _ => return None,
        },
        (HostCommand::ReadHex(Register::StatusX), WordId::X) | (HostCommand::ReadHex(Register::StatusY), WordId::Y) => {
            super::reads::signed_word(reply)? as u32 & 0xFF_FFFF
        }
        _ => return None,
    };
    Some(w & (1 << bit) != 0)
}

/// An I-variable whose value the log shows, read again with another value with nothing
/// between that could change it: no card does that, whatever its timing, tolerances, I40 or
/// the placement of the commands in time, so the search need not try them (issue 36: the
/// impossible `ivar-reads` logs got no verdict in 30 s).
///
/// What the log shows of I{n}:
/// - a read answered with a number: the card's value then;
/// - for I8, I40 and I41, an acknowledged write within the range the pages give (SRM p.57;
///   no I41 bit locks them): stored; one outside is left to the search, whose readings of an
///   assignment outside the range say what it leaves (UM p.243);
/// - an acknowledged write. Each I-variable has a range (SRM p.42), an interval; a value
///   outside it is refused with ERR003 or rolled over into it by modulo arithmetic (UM p.243,
///   the reading `out_of_range_assignment`), and the ranges of other I-variables than I8, I40
///   and I41 are the card's own (not in `variables.yaml`). A value between (or at) the lowest
///   and highest values the log read of the variable lies in its range, so the card stored
///   it. Any other value of at least 1 was stored, or rolled over from above the range into
///   it, so to a smaller value: a read of a larger one is no card's. MODEL: every I-variable's
///   range starts at 1 or below (the SRM's start at 0, 1 or a negative number), so a value of
///   1 or more is never below it. A write of a value below 1 not known in range, or answered
///   with an error, leaves the variable unknown until it is read;
/// - a write I41 is known to lock: ignored, "no error is generated" (SRM p.57), the value
///   stays. I41 is known where the log read it since the last reset, or wrote it since with a
///   value in its range and an answer; without it, a write leaves the variable unknown.
///
/// What ends what is known: a reset or a restart (`$$$`, INIT/, a power cycle: the saved value
/// comes back, UM p.243), `I{n}=*`, a write the host gave up on (the card may have processed it
/// after the wait), a write answered other than with an acknowledgement, a command the model
/// cannot follow that may write it (an M-variable assignment or a memory write, which I41
/// does not prevent, SRM p.57), and text the grammar cannot read.
///
/// MODEL: nothing but the log's own commands writes an I-variable. A PLC or motion program on
/// the card that assigns one would make this rule cry wolf; a host log does not show such a
/// program, and the issue this answers asks for I-variables "fixed by their first read, then
/// tracked through the log's own writes" (docs/replay.md).
#[derive(Default)]
struct ReadBack {
    /// I41 as the log read or wrote it since the last reset.
    i41: Option<i64>,
    /// Variable -> what the log shows of its value since the last reset.
    known: std::collections::BTreeMap<u16, Shown>,
    /// Variable -> the lowest and highest values the log read of it, over the whole log: the
    /// variable's range (the card's, which no reset changes) holds both.
    read: std::collections::BTreeMap<u16, (i64, i64)>,
}

/// A value of an I-variable the log shows, and where.
#[derive(Clone, Copy)]
struct Shown {
    value: i64,
    line: usize,
    how: ShownBy,
}

#[derive(Clone, Copy, PartialEq, Eq)]
enum ShownBy {
    Read,
    /// A write of a value known in range: stored.
    WriteInRange,
    /// A write of I8, I40 or I41 within the range the pages give: stored.
    WriteInPagesRange,
    /// A write of a value not known in range: stored, or rolled over to a smaller one.
    WriteAtMost,
}

impl Shown {
    /// Whether a read of `read` is one a card answers.
    fn admits(&self, read: i64) -> bool {
        match self.how {
            ShownBy::Read | ShownBy::WriteInRange | ShownBy::WriteInPagesRange => read == self.value,
            ShownBy::WriteAtMost => read <= self.value,
        }
    }
}

impl ReadBack {
    fn step(&mut self, spec: &Spec, line: usize, step: &pmacwd_trace::Step) -> Option<Finding> {
        use pmacwd_specs::vocab::command::{VarRange, RULED_I_VARIABLES};
        // A command the host gave up on may have been processed after the wait: what it
        // writes is unknown.
        let unanswered;
        let (event, gave_up) = match &step.event {
            TraceEvent::Model(event) => (event, false),
            TraceEvent::Unanswered { command, .. } => {
                unanswered = Event::Command(command.clone());
                (&unanswered, true)
            }
            _ => {
                if matches!(step.event, TraceEvent::Restart | TraceEvent::RestartPossible) {
                    self.reset();
                }
                return None;
            }
        };
        let reply = if gave_up { None } else { step.expect.reply.as_deref() };
        let acknowledged = reply == Some("(ack)");
        let number = || reply.and_then(|r| r.trim().parse::<i64>().ok());
        let forget = |k: &mut std::collections::BTreeMap<u16, Shown>, r: &VarRange| {
            k.retain(|n, _| !r.numbers().any(|m| m == *n));
        };
        match event {
            Event::Reset(_) => self.reset(),
            Event::Command(c) => match c {
                HostCommand::Reset | HostCommand::Reinitialize | HostCommand::Unrecognized(_) => self.reset(),
                // I8, I40 and I41 have the ranges the pages give, and no I41 bit locks them (SRM
                // p.57): an acknowledged write within the range is stored under either reading of
                // an assignment outside it (UM p.243); one outside is left to the search.
                HostCommand::WriteI(n @ (8 | 40 | 41), v) => {
                    let iv = &spec.variables.i_variables;
                    let range = match n {
                        8 => &iv.i8.range,
                        40 => &iv.i40.range,
                        _ => &iv.i41.range,
                    };
                    let stored = acknowledged && (range.min..=range.max).contains(v);
                    if *n == 41 {
                        self.i41 = stored.then_some(*v);
                    }
                    if stored {
                        self.known.insert(*n, Shown { value: *v, line, how: ShownBy::WriteInPagesRange });
                    } else {
                        self.known.remove(n);
                    }
                }
                HostCommand::DefaultI(41) | HostCommand::WriteIMemory(41, _) => {
                    self.i41 = None;
                    self.known.remove(&41);
                }
                HostCommand::WriteI(n, v) if !RULED_I_VARIABLES.contains(n) => {
                    let locked =
                        self.i41.map(|i41| spec.variables.lockout_bit(*n).is_some_and(|bit| i41 & (1 << bit) != 0));
                    let in_range = self.read.get(n).is_some_and(|(lo, hi)| (*lo..=*hi).contains(v));
                    let how = if in_range { ShownBy::WriteInRange } else { ShownBy::WriteAtMost };
                    match locked {
                        // Ignored: the value stays (SRM p.57).
                        Some(true) if acknowledged => {}
                        Some(false) if acknowledged && (in_range || *v >= 1) => {
                            self.known.insert(*n, Shown { value: *v, line, how });
                        }
                        _ => {
                            self.known.remove(n);
                        }
                    }
                }
                HostCommand::DefaultI(n) | HostCommand::WriteIMemory(n, _) => {
                    self.known.remove(n);
                }
                HostCommand::Card { forgets: Some(r), past_lockout, .. } => {
                    forget(&mut self.known, r);
                    if r.numbers().any(|m| m == 41) || *past_lockout {
                        self.i41 = None;
                    }
                }
                HostCommand::ReadI(n) => {
                    // A read the log shows sets what is known of I41; one it does not show
                    // changes nothing.
                    if *n == 41 && reply.is_some() {
                        self.i41 = number();
                    }
                    let read = number()?;
                    if let Some(shown) = self.known.get(n).filter(|s| !s.admits(read)) {
                        let (at, v) = (shown.line, shown.value);
                        let (how, expected) = match shown.how {
                            ShownBy::Read => (format!("line {at} read {v}"), format!("{v}, as read at line {at}")),
                            ShownBy::WriteInRange => (
                                format!(
                                    "line {at} wrote {v}, within the values the log read of it before (so in its \
                                     range, SRM p.42)"
                                ),
                                format!("{v}, written at line {at} (SRM p.57)"),
                            ),
                            ShownBy::WriteInPagesRange => (
                                format!("line {at} wrote {v}, within I{n}'s range (SRM p.57)"),
                                format!("{v}, written at line {at} (SRM p.57)"),
                            ),
                            ShownBy::WriteAtMost => (
                                format!(
                                    "line {at} wrote {v}, acknowledged: stored, or rolled over from above the \
                                     variable's range to a smaller value (UM p.243)"
                                ),
                                format!("at most {v}, written at line {at} (SRM p.57, UM p.243)"),
                            ),
                        };
                        return Some(Finding {
                            what: format!("I{n}"),
                            expected,
                            observed: read.to_string(),
                            why: format!(
                                "line {line}: I{n} read {read}, where {how} and nothing between could change it (no \
                                 reset, no memory write or M-variable assignment, and no write I41 did not lock, \
                                 SRM p.57), whatever the card's timing"
                            ),
                        });
                    }
                    self.known.insert(*n, Shown { value: read, line, how: ShownBy::Read });
                    let r = self.read.entry(*n).or_insert((read, read));
                    *r = (r.0.min(read), r.1.max(read));
                }
                _ => {}
            },
            _ => {}
        }
        None
    }

    /// A reset or restart: the saved values come back (UM p.243), I41 with them.
    fn reset(&mut self) {
        self.i41 = None;
        self.known.clear();
    }
}

/// UM p.217's freeze of the running checksum, read from the steps alone. On a mismatch the
/// card "sets global status bits (bits 12 and 13 of X:$000006 – accessible with the ???
/// command) and stops performing any checksum operations. This leaves the calculated value
/// frozen in the running checksum register X:$001080" (firmware), and for the user program
/// "sets a global status bit (bit 13 of X:$000006 – accessible with ???) and stops performing
/// any program or firmware checksum operations ..., freezing the running checksum value in
/// X:$001080". So once a status read shows the error, every X:$1080 read until a reset
/// answers one value; a second value is what no card does, whatever its timing, tolerances,
/// I40 or the placement of the commands in time.
///
/// The values are the card's own (`Expect::running_checksum`, kept by the importer): the
/// model's X:$1080 is a token (UM p.217, MODEL), so the search compares no candidate with
/// them, and this rule is the only check of them (`search::search_once` applies it to every
/// lane).
///
/// MODEL choices, each one that cannot cry wolf:
/// - What shows the engine stopped: bit 13 of X:$000006, "any memory checksum error"
///   (SRM p.289), which UM p.217 has either mismatch set, in a `???` reply or an `RHX:$6`
///   read; it has that one meaning under every profile. Bit 12 is not read: the readings
///   (`bit12_meaning`) disagree on it, and where it means a firmware error (M83) UM p.217 has
///   the mismatch set bit 13 with it.
/// - Reads while the engine runs are not judged: UM p.217 says the card "continually
///   computes the checksum", not that X:$1080 differs between two reads. A running sum over
///   words that sum to nothing (unused program buffers are zero) stays put while it reads
///   them, so two equal reads with background cycles between them (answered commands show
///   those, UM p.236) are what a correct card can answer.
/// - What ends what is known: a reset or restart the steps show (`$$$`, `$$$***`, INIT/,
///   power, a `restart` the importer placed), as for X:$25; a command that may write memory
///   (an M-variable assignment, a `W` memory write: they could write X:$1080) ends the value
///   known, not the stop; a status read with bit 13 clear ends both (no correct card clears it
///   without a reset, SRM p.289, but the search judges that, not this rule).
#[derive(Default)]
pub struct Freeze {
    /// The line of the status read that showed the checksum error since the last reset.
    stopped: Option<usize>,
    /// The X:$1080 value read since then, and its line.
    frozen: Option<(u32, usize)>,
}

/// An X:$1080 read that [`Freeze`] shows no card answers.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Thawed {
    /// The status read that showed the checksum error.
    pub stopped_at: usize,
    /// The value read first after it, and its line.
    pub frozen: (u32, usize),
    /// The value this read answered.
    pub read: u32,
}

impl Thawed {
    /// What the card should have answered, as a lane's death says it.
    pub fn expected(&self) -> String {
        format!(
            "{:06X}, frozen since the checksum error line {} showed (UM p.217; read at line {})",
            self.frozen.0, self.stopped_at, self.frozen.1
        )
    }

    pub fn observed(&self) -> String {
        format!("{:06X}", self.read)
    }

    /// The refutation, said of the line of this read.
    pub fn why(&self, line: usize) -> String {
        format!(
            "line {line}: X:$1080 read {:06X}, where line {} read {:06X} after line {}'s status showed the checksum \
             error (bit 13 of X:$000006, SRM p.289), with no reset between: a mismatch stops the checksum, \
             \"freezing the running checksum value in X:$001080\" (UM p.217), whatever the card's timing",
            self.read, self.frozen.1, self.frozen.0, self.stopped_at
        )
    }
}

impl Freeze {
    /// Reads one step; the X:$1080 read no card answers here, if this is one.
    pub fn step(&mut self, spec: &Spec, line: usize, step: &pmacwd_trace::Step) -> Option<Thawed> {
        match (&step.event, command_of(step)) {
            (TraceEvent::Restart | TraceEvent::RestartPossible | TraceEvent::Model(Event::Reset(_)), _)
            | (_, Some(HostCommand::Reset | HostCommand::Reinitialize)) => {
                *self = Freeze::default();
                return None;
            }
            (_, Some(HostCommand::Card { text, .. } | HostCommand::Unrecognized(text))) if may_write_memory(text) => {
                self.frozen = None;
            }
            _ => {}
        }
        match checksum_error_shown(spec, step) {
            Some(true) if self.stopped.is_none() => self.stopped = Some(line),
            Some(false) => *self = Freeze::default(),
            _ => {}
        }
        let (Some(read), Some(stopped_at)) = (step.expect.running_checksum, self.stopped) else {
            return None;
        };
        match self.frozen {
            None => {
                self.frozen = Some((read, line));
                None
            }
            Some(frozen) if frozen.0 != read => Some(Thawed { stopped_at, frozen, read }),
            Some(_) => None,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The lines at which [`Freeze`] refutes `steps` (command text, reply, X:$1080 value).
    fn thawed(steps: &[(&str, Option<&str>, Option<u32>)]) -> Vec<(usize, Thawed)> {
        let spec = Spec::embedded().unwrap();
        let mut f = Freeze::default();
        let mut out = Vec::new();
        for (i, (command, reply, running_checksum)) in steps.iter().enumerate() {
            let event = match *command {
                "restart" => TraceEvent::Restart,
                c => TraceEvent::Model(Event::Command(HostCommand::parse(c).unwrap())),
            };
            let expect = pmacwd_trace::Expect {
                reply: reply.map(String::from),
                running_checksum: *running_checksum,
                ..Default::default()
            };
            if let Some(t) = f.step(&spec, i + 1, &pmacwd_trace::Step { event, expect, note: None }) {
                out.push((i + 1, t));
            }
        }
        out
    }

    #[test]
    fn x1080_moving_after_bit_13_showed_is_refuted_until_a_reset_and_equal_reads_while_running_never_are() {
        let x = "RHX:$1080";
        let error = Some("002000000000");
        // Running: any values, equal ones included (MODEL: a sum over zero words stays put).
        assert_eq!(thawed(&[(x, None, Some(1)), (x, None, Some(1)), ("???", Some("001000000000"), None)]), []);
        assert_eq!(thawed(&[(x, None, Some(1)), ("???", error, None), (x, None, Some(2))]), []);
        let t = thawed(&[("???", error, None), (x, None, Some(5)), (x, None, Some(5)), (x, None, Some(6))]);
        assert_eq!(t, [(4, Thawed { stopped_at: 1, frozen: (5, 2), read: 6 })]);
        assert!(t[0].1.why(4).starts_with("line 4: X:$1080 read 000006, where line 2 read 000005 after line 1's"));
        // RHX:$6 shows bit 13 too; RHY:$6 does not hold it.
        assert_eq!(thawed(&[("RHX:$6", Some("002000"), None), (x, None, Some(5)), (x, None, Some(6))]).len(), 1);
        assert_eq!(thawed(&[("RHY:$6", Some("002000"), None), (x, None, Some(5)), (x, None, Some(6))]), []);
        // A reset, a restart, or bit 13 shown clear ends it; a memory write ends the value known.
        for between in [("$$$", None), ("$$$***", None), ("restart", None), ("???", Some("001000000000"))] {
            let steps = [("???", error, None), (x, None, Some(5)), (between.0, between.1, None), (x, None, Some(6))];
            assert_eq!(thawed(&steps), [], "{between:?}");
        }
        let steps = [("???", error, None), (x, None, Some(5)), ("WX:$1080,0", None, None), (x, None, Some(0))];
        assert_eq!(thawed(&steps), []);
        let steps =
            [("???", error, None), (x, None, Some(5)), ("M1=1", None, None), (x, None, Some(0)), (x, None, Some(1))];
        assert_eq!(thawed(&steps).len(), 1, "the stop stays: the next value freezes again");
    }
}
