//! What a step of a capture reads of the watchdog counter: Y:$25 (the counter) and X:$25 (its
//! lowest value since the reset), SRM p.57. Read by the search, which aims its plans at them,
//! and by the refutations read from the steps alone (`unknown`).

use pmacwd_specs::vocab::command::{HostCommand, Register};
use pmacwd_specs::vocab::event::Event;
use pmacwd_trace::{Step, TraceEvent};

/// A 24-bit word as a host reads it, sign-extended (Y:$25 and X:$25 are signed).
pub(crate) fn signed_word(text: &str) -> Option<i32> {
    let v = u32::from_str_radix(text.trim(), 16).ok().filter(|v| *v <= 0xFF_FFFF && !text.trim().is_empty())?;
    Some(((v << 8) as i32) >> 8)
}

/// The Y:$25 value a step reads, if it reads one.
pub(crate) fn counter_read(step: &Step) -> Option<i32> {
    match (&step.event, step.expect.reply.as_deref()) {
        (TraceEvent::Model(Event::Command(HostCommand::ReadHex(Register::WatchdogCounter))), Some(r)) => signed_word(r),
        _ => None,
    }
    .or(step.expect.counter)
}

/// The X:$25 value a step reads, if it reads one.
pub(crate) fn min_read(step: &Step) -> Option<i32> {
    match (&step.event, step.expect.reply.as_deref()) {
        (TraceEvent::Model(Event::Command(HostCommand::ReadHex(Register::WatchdogMinimum))), Some(r)) => signed_word(r),
        _ => None,
    }
    .or(step.expect.counter_min)
}
