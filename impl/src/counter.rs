//! The watchdog counter path as pure functions of small integers, so that proofs and their
//! exhaustive twins can cover the whole input domain (see `proofs.rs`).

/// When the strobe stops (the profiles' `strobe_stop` reading).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum StrobeStop {
    /// UM p.215: decrement only while the counter is greater than zero; that decrement strobes.
    AtZero,
    /// SRM p.57: decrement every cycle; strobe while the counter is not below 0.
    BelowZero,
}

/// The counter value a background cycle loads (SRM p.57, UM p.215): I40, or the profile's
/// value for I40 = 0 (4095 or 4096).
pub fn reset_value(i40: u16, reset_value_i40_zero: u16) -> i32 {
    if i40 == 0 {
        i32::from(reset_value_i40_zero)
    } else {
        i32::from(i40)
    }
}

/// One servo cycle's decrement: the new counter and whether this cycle may strobe.
pub fn decrement(counter: i32, stop: StrobeStop) -> (i32, bool) {
    match stop {
        // UM p.215: "decrements a counter (as long as the counter is greater than zero), causing
        // the least significant bit of the timer to toggle".
        StrobeStop::AtZero => {
            if counter > 0 {
                (counter.saturating_sub(1), true)
            } else {
                (counter, false)
            }
        }
        // SRM p.57: decremented by 1 every servo cycle; "if the counter becomes less than 0, the
        // real-time interrupt task will no longer strobe".
        StrobeStop::BelowZero => {
            let next = counter.saturating_sub(1);
            (next, next >= 0)
        }
    }
}

/// The counter after `k` decrements, in closed form.
pub fn after(counter: i32, k: u32, stop: StrobeStop) -> i32 {
    match stop {
        StrobeStop::AtZero => {
            if counter <= 0 {
                counter
            } else {
                let k = i64::from(k);
                let c = i64::from(counter);
                // c > 0 and k >= 0: c - min(c, k) is in 0..=c.
                i32::try_from(c.saturating_sub(k.min(c))).unwrap_or(0)
            }
        }
        StrobeStop::BelowZero => {
            let v = i64::from(counter).saturating_sub(i64::from(k));
            i32::try_from(v).unwrap_or(i32::MIN)
        }
    }
}

/// How many of the next cycles may strobe, starting from `counter`: the first `allowed` ones.
/// Both readings strobe exactly while the decremented counter stays at or above 0.
pub fn strobing_cycles(counter: i32) -> u32 {
    u32::try_from(counter.max(0)).unwrap_or(0)
}
