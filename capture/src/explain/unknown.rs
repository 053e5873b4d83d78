//! What a host log leaves open about the card itself: its saved I40, the value the watchdog
//! counter is reloaded to at the end of each background cycle (SRM p.57, UM p.215).
//!
//! The `host-log` configuration's saved I-variables are this project's defaults, not the
//! card's. A log that never reads I40 (before writing it) does not say what the card's is, so
//! replay does not compare the log with the configuration's 0 (issue 36: a card saved with
//! I40 = 2000 whose X:$25 read 0007CE was "no correct card"). The search tries the values the
//! log admits instead, and says which one explains it; where it cannot try every value the log
//! admits, a log none of the tried values explains is undecided, not impossible.
//!
//! What the log shows about I40 (read before any write of it):
//! - Y:$25 (the counter) and X:$25 (its lowest since the reset) never exceed the reload value
//!   (SRM p.57; UM p.215): the highest value read is a lower bound.
//! - Without a counter read and without a silence, a larger I40 never hurts: the counter of a
//!   card reloaded higher is higher at every cycle, so it trips later or never, and nothing
//!   else reads it (a tripped card is silent, UM p.215, and the log has no silence). A run that
//!   explains the log under one I40 explains it under 65,535, so trying 65,535 decides.

use crate::replay::{ImportAs, Source};
use pmacwd_specs::vocab::command::HostCommand;
use pmacwd_specs::vocab::event::Event;
use pmacwd_specs::{Spec, SpecError};
use pmacwd_trace::TraceEvent;
use std::path::Path;

/// MODEL: how far above the highest counter value the log reads the reload value is searched.
/// A counter read by a poll is a few servo cycles below its reload (the cycles since the last
/// background cycle: at I8 = 2 a light load completes one within 2(I8+1) cycles, UM p.236); a
/// card whose every read came deeper into a starved background is not searched, and a log
/// no tried value explains is then undecided.
pub const ABOVE_HIGHEST_READ: i64 = 16;

/// What the search learnt about a capture's unknown I40, for the report.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct OpenI40 {
    /// The values tried, in the order tried (each a whole search).
    pub tried: Vec<u16>,
    /// The value whose search explains the capture, if one does.
    pub explaining: Option<u16>,
    /// Whether the values tried stand for every value the log admits (then a capture none
    /// explains is impossible).
    pub complete: bool,
    /// The highest Y:$25 or X:$25 value read before any write of I40, if any.
    pub highest_read: Option<i32>,
    /// What the capture shows that no card shows, whatever its I40 ([`refutation`]): the
    /// values tried then stand for every value.
    pub refuted: Option<String>,
}

/// What the capture shows that bears on I40, read once ([`evidence`]).
pub struct Evidence {
    highest_read: Option<i32>,
    silent: bool,
    configured: u16,
}

/// The host command of a step: one the card answered, or one the host gave up on, which the
/// card may still have processed after the wait (`Controller::unanswered`): the rules here,
/// which hold whatever the timing, take both as the command.
fn command_of(step: &pmacwd_trace::Step) -> Option<&HostCommand> {
    match &step.event {
        TraceEvent::Model(Event::Command(c)) | TraceEvent::Unanswered { command: c, .. } => Some(c),
        _ => None,
    }
}

/// Whether `step` changes I40 (a write, `I40=*`, `$$$***`, a memory write, or a command the
/// model cannot follow that writes it): reads after it say nothing of the saved value.
fn writes_i40(step: &pmacwd_trace::Step) -> bool {
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

/// Reads the capture for what bears on I40, when the capture leaves it open: a capture under
/// the `host-log` configuration whose `card:` (what the log read) has no I40, and no `--i40`.
pub fn evidence(spec: &Spec, path: &Path, import: ImportAs<'_>) -> Result<Option<Evidence>, SpecError> {
    if import.card_i40.is_some() {
        return Ok(None);
    }
    let mut source = Source::open_with(spec, path, import)?;
    if source.configuration() != crate::import::DEFAULT_CONFIGURATION || source.card().and_then(|c| c.i40).is_some() {
        return Ok(None);
    }
    let Some(configured) = spec.check.configurations.get(source.configuration()).map(|c| c.i40) else {
        return Ok(None);
    };
    let mut e = Evidence { highest_read: None, silent: false, configured };
    let mut written = false;
    while let Some((_, step)) = source.next_step()? {
        written |= writes_i40(&step);
        if !written {
            if let Some(v) = super::reads::counter_read(&step).or(super::reads::min_read(&step)) {
                e.highest_read = Some(e.highest_read.map_or(v, |h| h.max(v)));
            }
        }
        e.silent |= step.expect.reply.as_deref() == Some("(silence)") || step.expect.tripped == Some(true);
    }
    Ok(Some(e))
}

/// The values to try, in order, and whether they stand for all the log admits. The
/// configuration's value first (the usual card, and no cost beyond today's search when it
/// explains), then upwards from the highest value read.
fn values(e: &Evidence, range: (i64, i64)) -> (Vec<u16>, bool) {
    let (lo, hi) = (range.0.max(0), range.1.min(i64::from(u16::MAX)));
    let mut v: Vec<u16> = Vec::new();
    // I40 = 0 reloads 4095 or 4096 (the reading `reset_value_when_i40_zero`, both searched).
    let reload = |i40: i64| if i40 == 0 { 4096 } else { i40 };
    let admitted = |i40: i64| (lo..=hi).contains(&i40) && e.highest_read.is_none_or(|h| reload(i40) >= i64::from(h));
    if admitted(i64::from(e.configured)) {
        v.push(e.configured);
    }
    match e.highest_read {
        Some(h) => {
            let from = i64::from(h).max(lo.max(1));
            let to = (i64::from(h) + ABOVE_HIGHEST_READ).min(hi);
            v.extend((from..=to).map(|i| i as u16).filter(|i| *i != e.configured));
            // Every value the log admits was tried only when the window reaches the top.
            (v, to >= hi)
        }
        None if !e.silent => {
            if e.configured as i64 != hi {
                v.push(hi as u16);
            }
            (v, true)
        }
        None => (v, false),
    }
}

impl Evidence {
    /// The values to try, in order, and whether they stand for every value the log admits
    /// ([`values`]), within I40's range of `variables.yaml`.
    pub fn values(&self, spec: &Spec) -> (Vec<u16>, bool) {
        let r = &spec.variables.i_variables.i40.range;
        values(self, (r.min, r.max))
    }

    pub fn highest_read(&self) -> Option<i32> {
        self.highest_read
    }
}

/// What the capture shows that no correct card shows whatever its I40, read from the steps
/// alone (rules that do not read the counter's reload), with its line:
/// - X:$25 "the lowest value of the watchdog counter since the last power-on/reset" (SRM
///   p.57) rising between two reads with no reset between them (and no command that may write
///   memory, which could write X:$25);
/// - the CPU type (bit 21 of both `???` words, SRM p.289) changing: it is the card's;
/// - an I-variable read back with a value other than the one just written ([`ReadBack`]);
/// - X:$1080 read with two values after a status read showed the checksum error, with no
///   reset between ([`Freeze`], UM p.217).
///
/// None of these depends on the card's timing, its tolerances or where the commands fall in
/// time either, so a capture they refute needs no search of those (`search::search`,
/// `report::explain_timed`).
pub fn refutation(spec: &Spec, path: &Path, import: ImportAs<'_>) -> Result<Option<String>, SpecError> {
    use pmacwd_specs::vocab::reply_text::{self, StatusReply};
    let mut source = Source::open_with(spec, path, import)?;
    let mut lowest: Option<(i32, usize)> = None;
    let mut cpu: Option<((bool, bool), usize)> = None;
    let mut read_back = ReadBack::default();
    let mut freeze = Freeze::default();
    // The status read that showed bit 13 (a checksum error) since the last reset.
    let mut checksum_error: Option<usize> = None;
    let mut outlived = Outlived::new(spec, &source, &import)?;
    while let Some((line, step)) = source.next_step()? {
        if let Some(why) = read_back.step(spec, line, &step) {
            return Ok(Some(why));
        }
        if let Some(thawed) = freeze.step(spec, line, &step) {
            return Ok(Some(thawed.why(line)));
        }
        if let Some(why) = outlived.step(line, &step) {
            return Ok(Some(why));
        }
        let resets = match (&step.event, command_of(&step)) {
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
            lowest = None;
            checksum_error = None;
        }
        // Bit 13 of X:$000006, any checksum error, is cleared only by a reset: the checksum
        // operations stop after the error (SRM p.289; UM p.217). One meaning under every
        // reading (bit 12's two readings leave it alone).
        if let Some(set) = checksum_error_shown(spec, &step) {
            match checksum_error {
                Some(at) if !set => {
                    return Ok(Some(format!(
                        "line {line}: bit 13 of X:$000006 (a checksum error, SRM p.289) is clear, where line {at} \
                         showed it set, with no reset between: it stays set until the card is reset, the checksum \
                         operations stopping at the error (SRM p.289, UM p.217), whatever I40 and the timing"
                    )));
                }
                None if set => checksum_error = Some(line),
                _ => {}
            }
        }
        if let Some(v) = super::reads::min_read(&step) {
            if let Some((before, at)) = lowest.filter(|(before, _)| v > *before) {
                return Ok(Some(format!(
                    "line {line}: X:$25 rose from {before:06X} (line {at}) to {v:06X} with no reset between: it is \
                     the lowest value of the counter since the last reset (SRM p.57), whatever I40 is"
                )));
            }
            if lowest.is_none_or(|(before, _)| v < before) {
                lowest = Some((v, line));
            }
        }
        if let (TraceEvent::Model(Event::Command(HostCommand::GlobalStatus)), Some(Ok(StatusReply::Words { x, y }))) =
            (&step.event, step.expect.reply.as_deref().map(reply_text::decode))
        {
            let bits = (x & 1 << 21 != 0, y & 1 << 21 != 0);
            match cpu {
                Some((first, at)) if first != bits => {
                    return Ok(Some(format!(
                        "line {line}: the CPU type bits (21 of both `???` words, SRM p.289) changed from line {at}'s: \
                         they are the card's, whatever I40 is"
                    )));
                }
                None => cpu = Some((bits, line)),
                _ => {}
            }
        }
    }
    Ok(None)
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

    fn step(&mut self, line: usize, step: &pmacwd_trace::Step) -> Option<String> {
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
                Some(format!(
                    "line {line}: the card answered, where at line {at} the host waited {wait} servo cycles for an \
                 answer that did not come: host commands are processed in the background (UM p.236), and no card \
                 runs that long without a background cycle (its reload of at most {} plus a hardware delay of at \
                 most {} cycles) without tripping; a tripped card does not communicate until it is reset (UM \
                 p.215), and no reset comes between, whatever the timing",
                    self.reload_max, self.delay_max
                ))
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
    use pmacwd_specs::status::WordId;
    use pmacwd_specs::vocab::command::Register;
    use pmacwd_specs::vocab::reply_text::{self, StatusReply};
    let (word, bit) = spec.status.bit("checksum_error")?;
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

/// An I-variable written with a constant and read back with another value, with nothing
/// between that could change it: no card does that, whatever its timing, tolerances, I40 or
/// the placement of the commands in time, so the search need not try them (issue 36: the
/// impossible `ivar-reads` logs got no verdict in 30 s).
///
/// What could change it, each ending what is known: a reset or a restart (`$$$`, INIT/, a
/// power cycle: the saved value comes back, UM p.243), `I{n}=*`, a command the model cannot
/// follow that may write it (an M-variable assignment or a memory write, which I41 does not
/// prevent, SRM p.57), and text the grammar cannot read. A write the card ignores (I41 locks
/// its range, SRM p.57) is not known to have taken effect: a write counts only where the log
/// read I41 since the last reset, wrote it since with a value in its range, and its bits leave
/// the variable writable; and only where it was answered (a tripped card takes no command,
/// UM p.215). I8, I40 and I41 themselves are left to the search (their writes take values
/// in ranges and readings of their own).
#[derive(Default)]
struct ReadBack {
    /// I41 as the log read or wrote it since the last reset.
    i41: Option<i64>,
    /// Variable -> (value written, line of the write).
    written: std::collections::BTreeMap<u16, (i64, usize)>,
}

impl ReadBack {
    fn step(&mut self, spec: &Spec, line: usize, step: &pmacwd_trace::Step) -> Option<String> {
        use pmacwd_specs::vocab::command::{VarRange, RULED_I_VARIABLES};
        // A command the host gave up on is read as a command not answered: the card may have
        // processed it after the wait.
        let unanswered;
        let event = match &step.event {
            TraceEvent::Model(event) => event,
            TraceEvent::Unanswered { command, .. } => {
                unanswered = Event::Command(command.clone());
                &unanswered
            }
            _ => {
                if matches!(step.event, TraceEvent::Restart | TraceEvent::RestartPossible) {
                    *self = ReadBack::default();
                }
                return None;
            }
        };
        let answered = !matches!(step.expect.reply.as_deref(), Some("(silence)" | "(timeout)"));
        let number = || step.expect.reply.as_deref().and_then(|r| r.trim().parse::<i64>().ok());
        let forget = |w: &mut std::collections::BTreeMap<u16, (i64, usize)>, r: &VarRange| {
            w.retain(|n, _| !r.numbers().any(|m| m == *n));
        };
        match event {
            Event::Reset(_) => *self = ReadBack::default(),
            Event::Command(c) => match c {
                HostCommand::Reset | HostCommand::Reinitialize | HostCommand::Unrecognized(_) => {
                    *self = ReadBack::default()
                }
                // A read the log shows sets what is known of I41; one it does not show changes nothing.
                HostCommand::ReadI(41) if step.expect.reply.is_some() => self.i41 = number(),
                HostCommand::WriteI(41, v) => {
                    let range = &spec.variables.i_variables.i41.range;
                    self.i41 = (answered && (range.min..=range.max).contains(v)).then_some(*v);
                }
                HostCommand::DefaultI(41) | HostCommand::WriteIMemory(41, _) => self.i41 = None,
                HostCommand::WriteI(n, v) if !RULED_I_VARIABLES.contains(n) => {
                    let writable = self
                        .i41
                        .is_some_and(|i41| spec.variables.lockout_bit(*n).is_none_or(|bit| i41 & (1 << bit) == 0));
                    if answered && writable {
                        self.written.insert(*n, (*v, line));
                    } else {
                        self.written.remove(n);
                    }
                }
                HostCommand::DefaultI(n) | HostCommand::WriteIMemory(n, _) => {
                    self.written.remove(n);
                }
                HostCommand::Card { forgets: Some(r), past_lockout, .. } => {
                    forget(&mut self.written, r);
                    if r.numbers().any(|m| m == 41) || *past_lockout {
                        self.i41 = None;
                    }
                }
                HostCommand::ReadI(n) => {
                    if let (Some(&(v, at)), Some(read)) = (self.written.get(n), number()) {
                        if read != v {
                            return Some(format!(
                                "line {line}: I{n} read {read}, where line {at} wrote {v} and nothing between could change it \
                                 (no reset, no memory write or M-variable assignment, and I41 leaves it writable, \
                                 SRM p.57), whatever the card's timing"
                            ));
                        }
                    }
                }
                _ => {}
            },
            _ => {}
        }
        None
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

/// `0, 1998..=2014`: values, runs of consecutive ones as ranges.
pub fn list(values: &[u16]) -> String {
    let mut out: Vec<String> = Vec::new();
    let mut i = 0;
    while i < values.len() {
        let mut j = i;
        while j + 1 < values.len() && values[j + 1] == values[j] + 1 {
            j += 1;
        }
        out.push(if j > i + 1 {
            format!("{}..={}", values[i], values[j])
        } else if j == i + 1 {
            format!("{}, {}", values[i], values[j])
        } else {
            values[i].to_string()
        });
        i = j + 1;
    }
    out.join(", ")
}

#[cfg(test)]
mod tests {
    use super::*;

    fn e(highest_read: Option<i32>, silent: bool) -> Evidence {
        Evidence { highest_read, silent, configured: 0 }
    }

    #[test]
    fn values_start_with_the_configuration_s_and_go_up_from_the_highest_read() {
        assert_eq!(
            values(&e(Some(1998), false), (0, 65535)),
            ((std::iter::once(0).chain(1998..=2014)).collect(), false)
        );
        // A read above 4096 rules I40 = 0 out.
        assert_eq!(values(&e(Some(8000), true), (0, 65535)).0, (8000..=8016).collect::<Vec<u16>>());
        assert_eq!(values(&e(Some(65530), false), (0, 65535)), ((65530..=65535).collect(), true));
    }

    #[test]
    fn without_reads_or_silence_the_largest_value_decides() {
        assert_eq!(values(&e(None, false), (0, 65535)), (vec![0, 65535], true));
        assert_eq!(values(&e(None, true), (0, 65535)), (vec![0], false));
    }

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

    #[test]
    fn lists_read_as_ranges() {
        assert_eq!(list(&[0, 1998, 1999, 2000, 2001]), "0, 1998..=2001");
        assert_eq!(list(&[0, 1]), "0, 1");
        assert_eq!(list(&[7]), "7");
    }
}
