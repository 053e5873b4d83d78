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

/// Whether `step` changes I40 (a write, `I40=*`, `$$$***`, a memory write, or a command the
/// model cannot follow that writes it): reads after it say nothing of the saved value.
fn writes_i40(step: &pmacwd_trace::Step) -> bool {
    match &step.event {
        TraceEvent::Model(Event::Command(c)) => match c {
            HostCommand::WriteI(40, _)
            | HostCommand::WriteIMemory(40, _)
            | HostCommand::DefaultI(40)
            | HostCommand::Reinitialize => true,
            HostCommand::Card { forgets: Some(r), .. } => r.numbers().any(|n| n == 40),
            _ => false,
        },
        _ => false,
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
/// - an I-variable read back with a value other than the one just written ([`ReadBack`]).
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
    while let Some((line, step)) = source.next_step()? {
        if let Some(why) = read_back.step(spec, line, &step) {
            return Ok(Some(why));
        }
        let resets = match &step.event {
            TraceEvent::Restart => true,
            TraceEvent::Model(Event::Reset(_)) => true,
            TraceEvent::Model(Event::Command(c)) => match c {
                HostCommand::Reset | HostCommand::Reinitialize => true,
                // A command the model cannot follow may be a memory write (`WX:$25,...`, an
                // M-variable pointed at X:$25): the rule stops there.
                HostCommand::Card { text, .. } | HostCommand::Unrecognized(text) => {
                    text.contains('=') || text.trim_start().starts_with(['W', 'w'])
                }
                _ => false,
            },
            _ => false,
        };
        if resets {
            lowest = None;
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
        let TraceEvent::Model(event) = &step.event else {
            if matches!(step.event, TraceEvent::Restart) {
                *self = ReadBack::default();
            }
            return None;
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

    #[test]
    fn lists_read_as_ranges() {
        assert_eq!(list(&[0, 1998, 1999, 2000, 2001]), "0, 1998..=2001");
        assert_eq!(list(&[0, 1]), "0, 1");
        assert_eq!(list(&[7]), "7");
    }
}
