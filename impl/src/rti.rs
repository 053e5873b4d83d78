//! The real-time interrupt and the CPU left to the background, one cycle at a time and a whole
//! number of RTI periods at once (for `advance`).

/// What one RTI tick found (UM p.236, SRM p.289-290).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Tick {
    /// No RTI in this cycle.
    None,
    /// The previous task set was done: a new one started.
    Started,
    /// The previous task set still ran: re-entry (bits 22 and 9), nothing started.
    Overrun,
}

/// The outcome of a number of whole RTI periods.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Periods {
    pub remaining: u64,
    /// CPU units left to the background over the periods.
    pub share: u64,
    pub any_overrun: bool,
    /// The outcome of the last tick (None when there were no periods).
    pub last: Tick,
}

/// `periods` whole RTI periods of `period` cycles each, starting at a tick with `remaining`
/// units of RTI work left; `task` units start at each tick that finds the previous set done;
/// `free` units per cycle are left after the servo update. Closed form: O(1) in `periods`.
pub fn whole_periods(remaining: u64, periods: u64, period: u64, free: u64, task: u64) -> Periods {
    if periods == 0 {
        return Periods { remaining, share: 0, any_overrun: false, last: Tick::None };
    }
    let capacity = period.saturating_mul(free);
    if capacity == 0 {
        // No CPU for the RTI at all: nothing drains; every tick after the first start overruns.
        let first_overruns = remaining > 0;
        let after_first = if first_overruns { remaining } else { task };
        let any_overrun = first_overruns || (task > 0 && periods > 1);
        let last = if after_first > 0 && (first_overruns || periods > 1) { Tick::Overrun } else { Tick::Started };
        return Periods { remaining: after_first, share: 0, any_overrun, last };
    }
    let mut remaining = remaining;
    let mut periods_left = periods;
    let mut share: u64 = 0;
    let mut any_overrun = false;
    let mut last = Tick::None;
    // Drain a carried-over task set: every tick until it is done overruns.
    if remaining > 0 {
        let draining = remaining.div_ceil(capacity).min(periods_left);
        let work = remaining.min(draining.saturating_mul(capacity));
        share = share.saturating_add(draining.saturating_mul(capacity).saturating_sub(work));
        remaining = remaining.saturating_sub(work);
        periods_left = periods_left.saturating_sub(draining);
        any_overrun = true;
        last = Tick::Overrun;
    }
    if periods_left == 0 {
        return Periods { remaining, share, any_overrun, last };
    }
    if task == 0 {
        // Every tick starts nothing and finds nothing running.
        share = share.saturating_add(periods_left.saturating_mul(capacity));
        return Periods { remaining: 0, share, any_overrun, last: Tick::Started };
    }
    // Steady cycle: a start, then (q - 1) overrunning ticks while the set drains.
    let q = task.div_ceil(capacity);
    // q >= 1: task > 0 and capacity > 0.
    let cycles = periods_left.checked_div(q).unwrap_or(0);
    let rest = periods_left.checked_rem(q).unwrap_or(0);
    let cycle_share = q.saturating_mul(capacity).saturating_sub(task);
    share = share.saturating_add(cycles.saturating_mul(cycle_share));
    if q > 1 && (cycles > 0 || rest > 1) {
        any_overrun = true;
    }
    if rest == 0 {
        // Ends exactly at the end of a cycle: the last tick overran unless q = 1.
        last = if q > 1 { Tick::Overrun } else { Tick::Started };
        remaining = 0;
    } else {
        let work = task.min(rest.saturating_mul(capacity));
        share = share.saturating_add(rest.saturating_mul(capacity).saturating_sub(work));
        remaining = task.saturating_sub(work);
        last = if rest > 1 { Tick::Overrun } else { Tick::Started };
    }
    Periods { remaining, share, any_overrun, last }
}

#[cfg(test)]
// The reference below is plain arithmetic on values below 10: nothing can overflow.
#[allow(clippy::arithmetic_side_effects)]
mod tests {
    use super::*;

    /// The same periods one servo cycle at a time, as `Core::rti_cycle` runs them: at each tick
    /// a set still running overruns (SRM p.289-290: bits 22 and 9, UM p.236: nothing restarted)
    /// and otherwise a new set of `task` units starts; every cycle the RTI takes what it can of
    /// the `free` units and leaves the rest to the background.
    fn stepped(mut remaining: u64, periods: u64, period: u64, free: u64, task: u64) -> Periods {
        let (mut share, mut any_overrun, mut last) = (0, false, Tick::None);
        for _ in 0..periods {
            if remaining > 0 {
                any_overrun = true;
                last = Tick::Overrun;
            } else {
                remaining = task;
                last = Tick::Started;
            }
            for _ in 0..period {
                let work = free.min(remaining);
                remaining -= work;
                share += free - work;
            }
        }
        Periods { remaining, share, any_overrun, last }
    }

    #[test]
    fn whole_periods_in_closed_form_equal_the_periods_stepped_cycle_by_cycle() {
        // Exhaustive over small values, including no CPU left for the RTI (free = 0), where a
        // single period that starts a set must report the start, not an overrun.
        for remaining in 0..7 {
            for periods in 0..6 {
                for period in 1..5 {
                    for free in 0..4 {
                        for task in 0..8 {
                            assert_eq!(
                                whole_periods(remaining, periods, period, free, task),
                                stepped(remaining, periods, period, free, task),
                                "remaining {remaining}, periods {periods}, period {period}, free {free}, task {task}"
                            );
                        }
                    }
                }
            }
        }
    }
}
