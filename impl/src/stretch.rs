//! Quiet stretches: the servo cycle that only counts (docs/core.md, "Quiet stretches").
//!
//! Most servo cycles of a running card change nothing a host sees at once. After a cycle taken
//! in full, the core may compute a stretch of the next cycles that it only counts
//! (`deferred_cycles`), and applies them with `advance`'s closed form when the card is next
//! changed (every `&mut` method settles first) or read through the configuration. The readers
//! that take no configuration answer exactly without settling, for the reasons
//! [`Core::quiet_cycles`] gives. `proofs::check_deferred_servo_cycles` checks that nothing can
//! tell a deferred cycle from one taken in full.

use crate::{counter, Config, Core};

impl Core {
    /// How many servo cycles are counted but not yet applied: what the speed of an idle card
    /// rests on, for tests and diagnostics. Nothing a reader answers depends on it.
    pub fn deferred_cycles(&self) -> u32 {
        self.deferred_cycles
    }

    /// How many more servo cycles may be deferred before one is taken in full: 0 outside a
    /// stretch. Like [`Self::deferred_cycles`], for tests and diagnostics only.
    pub fn quiet_cycles_left(&self) -> u32 {
        self.quiet_cycles_max.saturating_sub(self.deferred_cycles)
    }

    /// One servo interrupt and its RTI. In a quiet stretch (`quiet_cycles`) the cycle is only
    /// counted, and applied with the others in closed form when the card is next read or
    /// changed; otherwise it is taken in full, and the next stretch computed.
    #[inline]
    pub fn servo_cycle(&mut self, cfg: &Config) {
        if self.deferred_cycles < self.quiet_cycles_max {
            // Below the maximum, so no wrap.
            self.deferred_cycles = self.deferred_cycles.wrapping_add(1);
            return;
        }
        self.servo_cycle_then_stretch(cfg);
    }

    /// The end of a quiet stretch: its deferred cycles applied, this cycle taken in full, and
    /// the length of the next stretch.
    #[inline]
    fn servo_cycle_then_stretch(&mut self, cfg: &Config) {
        self.servo_cycle_exact(cfg);
        // A card outside stretches looks for one every eighth cycle only (by the servo
        // counter, X:$0): its other cycles cost a test, and a stretch begins at most seven
        // cycles late.
        if self.servo_cycles & 7 == 0 && self.may_be_quiet(cfg) {
            self.quiet_cycles_max = self.quiet_cycles(cfg);
        }
    }

    /// One servo interrupt and its RTI, taken in full, never deferred: the reference the
    /// deferral is checked against (`proofs::check_deferred_servo_cycles`).
    #[inline]
    pub fn servo_cycle_exact(&mut self, cfg: &Config) {
        self.settle(cfg);
        self.step(cfg);
    }

    /// Applies the deferred servo cycles, and ends the quiet stretch: called first by every
    /// method that changes the card, so that it changes the card as it stands.
    #[inline]
    pub(crate) fn settle(&mut self, cfg: &Config) {
        // No cycle is deferred without a stretch (`deferred_cycles <= quiet_cycles_max`): a
        // card outside stretches pays one comparison.
        if self.quiet_cycles_max != 0 {
            self.end_stretch(cfg);
        }
    }

    #[inline(never)]
    fn end_stretch(&mut self, cfg: &Config) {
        let n = self.deferred_cycles;
        self.deferred_cycles = 0;
        self.quiet_cycles_max = 0;
        self.advance_settled(cfg, n);
    }

    /// A stretch shorter than this costs more to compute and settle than it saves.
    const QUIET_CYCLES_MIN: u32 = 8;

    /// Whether a stretch of at least [`Self::QUIET_CYCLES_MIN`] cycles may follow, from two
    /// comparisons: the counter has fallen that far since its last reload and can fall as far
    /// again. A host that runs a background cycle whenever one can complete (the emulator, at a
    /// light load) reloads the counter every few servo cycles: it answers no here, and takes its
    /// cycles in full without computing a stretch (two divisions) that its next background
    /// cycle would end at once.
    #[inline]
    fn may_be_quiet(&self, cfg: &Config) -> bool {
        let min = Self::QUIET_CYCLES_MIN as i32;
        let reload = counter::reset_value(self.i40, cfg.profile.reset_value_i40_zero);
        self.running() && self.counter >= min && self.counter <= reload.saturating_sub(min)
    }

    /// How many of the next servo cycles may be deferred: only counted, with the readers that
    /// take no configuration answering for them exactly. That holds while, over the stretch:
    /// - the card runs, and no stop under way ends, so the motion changes only in the stops'
    ///   cycles left, which `motion` and `motor` count down by the deferred cycles;
    /// - the timer does not trip (`tripped`): the stretch ends the cycle before the trip;
    /// - the counter does not go below zero, so each cycle takes exactly one off it under both
    ///   readings of when the strobe stops (`counter`, `counter_min`);
    /// - whether a background cycle can complete does not change (`background_possible`): the
    ///   credit only grows between background cycles, by at most the spare units a cycle, and
    ///   stops at the cap; so a credit at the cap stays there, and one below it stays below for
    ///   (cap - credit - 1) / spare cycles at least.
    ///
    /// The readers that take the configuration (`status_words`, `observe`, `register`) settle a
    /// copy first. A stretch is a matter of speed only: its cycles are applied by `advance`,
    /// which equals single cycles (`proofs::check_advance_equals_single_steps`).
    #[inline(never)]
    fn quiet_cycles(&self, cfg: &Config) -> u32 {
        if !self.running() {
            return 0;
        }
        let before_stop_ends = u64::from(self.motion.cycles_before_a_stop_ends());
        let before_trip = self.trip_cycle(cfg).saturating_sub(1);
        let before_negative = u64::from(counter::strobing_cycles(self.counter));
        let cap = u32::from(self.load.background_units);
        let before_background = if self.background_credit >= cap {
            u64::MAX
        } else {
            // `free` 0: the credit never grows.
            u64::from(
                cap.saturating_sub(self.background_credit).saturating_sub(1).checked_div(self.free).unwrap_or(u32::MAX),
            )
        };
        u32::try_from(before_trip.min(before_negative).min(before_background).min(before_stop_ends)).unwrap_or(u32::MAX)
    }

    /// This state with its deferred servo cycles applied: the same card, every field as the
    /// readers report it. Two cores behave the same exactly when their settled forms are equal.
    pub fn settled(&self, cfg: &Config) -> Core {
        let mut c = *self;
        c.settle(cfg);
        c
    }
}
