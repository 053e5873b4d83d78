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

use super::refute::writes_i40;
use crate::replay::{ImportAs, Source};
use pmacwd_specs::{Spec, SpecError};
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
    /// What the capture shows that no card shows, whatever its I40 ([`super::refute::refuted`]): the
    /// values tried then stand for every value.
    pub refuted: Option<String>,
}

/// What the capture shows that bears on I40, read once ([`evidence`]).
pub struct Evidence {
    highest_read: Option<i32>,
    silent: bool,
    configured: u16,
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
