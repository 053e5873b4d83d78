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
pub mod lanes;
pub mod report;
pub mod search;
pub mod sim;
pub mod witness;

use pmacwd_model::controller::{Controller, Ghost};

/// The most candidates one lane may hold after a step. A capture that leaves this much open
/// (for instance long gaps with nothing read) is refused with exit 2 rather than judged on a
/// subset: dropping candidates could turn an explanation into a false "no".
pub const CANDIDATES_MAX: usize = 200_000;

/// Clears what no rule reads (the ghost bookkeeping), so that equal cards are one candidate.
pub fn normalize(card: &mut Controller) {
    card.ghost = Ghost { cycles_since_background: 0, last_reload: 0, recovered_by: None };
}
