//! `pmacwd replay` as a search: is there a behaviour of the model, under some combination of
//! readings, that produces every observation of a capture? What the capture does not show is
//! chosen by the search (docs/replay.md):
//!
//! - when background cycles completed, the load (RTI overruns), supply dips, checksum faults
//!   and the checksum engine's progress, in every `elapsed` gap ([`gap`]);
//! - which reset a `restart` was, and what its reset-time checks found;
//! - what the card is that the log does not say: its CPU type (bits 21 of `???`, SRM p.289).
//!
//! Each combination of readings is a *lane* searched on its own; a lane's candidates are
//! deduplicated model states, with X:$25 kept as an interval (no rule reads it). A lane dies
//! at the first step no candidate survives. The verdict per reading option follows from the
//! lanes alone: supported if a surviving lane chooses it, ruled out if none does.

pub mod gap;
pub mod history;
pub mod key;
pub mod lanes;
pub mod observe;
pub mod reads;
pub mod refute;
pub mod report;
pub mod search;
pub mod share;
pub mod silences;
pub mod sim;
pub mod unknown;
pub mod witness;
pub mod words;

use pmacwd_model::controller::{Controller, Ghost};

/// The most candidates one lane may hold after a step. A capture that leaves this much open
/// (for instance long gaps with nothing read) is refused with exit 2 rather than judged on a
/// subset: dropping candidates could turn an explanation into a false "no".
pub const CANDIDATES_MAX: usize = 200_000;

/// Clears what no rule reads (the ghost bookkeeping), so that equal cards are one candidate.
pub fn normalize(card: &mut Controller) {
    card.ghost = Ghost { cycles_since_background: 0, last_reload: 0, recovered_by: None };
    // X:$0: no rule reads it and the search does not compare it (the importer turns its
    // reads into `elapsed` steps); cleared so that the same card after gaps of different
    // lengths is one candidate.
    card.servo_cycles = 0;
}

/// Whether two cards are the same but for Y:$25, X:$25 and the background's CPU credit: what
/// the search keeps as intervals (the credit refills in the next servo cycle, before any plan
/// can use it).
pub fn same_but_counters(a: &Controller, b: &Controller) -> bool {
    blank(a) == blank(b)
}

/// A card but for Y:$25, X:$25 and the background's CPU credit.
pub(crate) fn blank(c: &Controller) -> Controller {
    let mut c = c.clone();
    normalize(&mut c);
    c.counter = 0;
    c.counter_min = 0;
    c.background_credit = 0;
    c
}

/// Where a gap of a recorded history ended, kept small (a history holds one per gap of the
/// capture): Y:$25, X:$25, and a fingerprint of the rest of the card. Comparing fingerprints
/// stands for [`same_but_counters`]; a collision could only pick a wrong plan for an
/// explanation, which is run on the model and checked before it is printed.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct End {
    pub counter: i32,
    pub counter_min: i32,
    rest: u64,
}

impl End {
    pub fn of(c: &Controller) -> End {
        use std::hash::BuildHasher;
        // The search's fixed fast hasher (a fingerprint compared within one run): SipHash,
        // over the whole card at every gap and every plan tried, was 5% of a replay's samples.
        End {
            counter: c.counter,
            counter_min: c.counter_min,
            rest: foldhash::fast::FixedState::default().hash_one(blank(c)),
        }
    }

    /// Whether `c` is this end but for Y:$25, X:$25 and the background's credit.
    pub fn same_but_counters(&self, c: &Controller) -> bool {
        End::of(c).rest == self.rest
    }
}

/// Y:$25 after `cycles` servo cycles without a background cycle from `counter`, as the
/// profile's strobe-stop reading decrements it (UM p.215: only while above zero; SRM p.57:
/// every cycle).
pub fn run_down(cfg: &pmacwd_specs::config::ModelConfig, counter: i32, cycles: u32) -> i64 {
    match cfg.profile.choices.strobe_stop {
        pmacwd_specs::profiles::StrobeStop::AtZero => (i64::from(counter) - i64::from(cycles)).max(0),
        pmacwd_specs::profiles::StrobeStop::BelowZero => i64::from(counter) - i64::from(cycles),
    }
}
