//! The foreground timer registers (UM p.238-239), from the CPU units the model charges each
//! task (`check.yaml`'s `cpu`), and back: the one mapping between the two, for the emulator's
//! registers and for any reading of a card's M70-M73 in the model's units.
//!
//! UM p.239: Y:$000037 "holds the number of timer increments elapsed from the beginning to the
//! end of the servo-interrupt tasks for the last interrupt"; X:$00000B the same for "the RTI
//! tasks for the last interrupt", Y:$00000B "the largest number of timer increments from the
//! beginning to the end of a set of RTI tasks since the last power-up/reset". A time longer
//! than a phase period (X:$FFFF8C) includes the phase tasks (X:$000037) that interrupted it,
//! and an RTI time longer than a servo period the servo tasks that interrupted it: UM p.240's
//! PLC subtracts them (P69, P68, P67) to get each duty cycle, as the EPICS pmac driver does
//! with M70-M73 (DiamondLightSource/pmac `pmacApp/src/pmacController.cpp:1850-1890`, the
//! definitions `etc/bootstrap/BRICK_M_variables.pmc:70-73`: M70->X:$FFFF8C, M71->X:$37,
//! M72->Y:$37, M73->X:$B, all "CPU cycles/2").
//!
//! MODEL: the model's CPU units are the time a servo period leaves after the phase tasks:
//! `cycle_units` of them make the phase periods of one servo period less their phase tasks,
//! `(I7002 + 1) x (X:$FFFF8C - X:$37)` increments. No page at hand gives the time of any task
//! in timer increments (UM p.236 gives the servo update only as "about 1%" a motor), so the
//! phase period and the phase tasks' time are the card's (read from M70 and M71) and the rest
//! is in proportion. A task that starts right after the servo tasks (the RTI) runs in what
//! each servo cycle leaves, so it is interrupted by one servo update per servo cycle it spans.

/// The largest value of a 24-bit register.
pub const REGISTER_MAX: u32 = 0xFF_FFFF;

/// What relates the model's CPU units to timer increments on one card.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct TimerScale {
    /// X:$FFFF8C (M70): timer increments between two phase interrupts.
    pub phase_period: u32,
    /// X:$000037 (M71): timer increments of the phase tasks.
    pub phase_task: u32,
    /// Phase interrupts per servo interrupt, I7002 + 1 (SRM p.43).
    pub phases_per_servo: u32,
    /// The model's CPU units in a servo cycle (`check.yaml` `cpu.cycle_units`).
    pub cycle_units: u16,
}

/// The timer registers of UM p.238-239 as a card holds them.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Timers {
    /// X:$FFFF8C (M70).
    pub phase_period: u32,
    /// X:$000037 (M71).
    pub phase_task: u32,
    /// Y:$000037 (M72): the last servo tasks, phase interruptions included.
    pub servo_task: u32,
    /// X:$00000B (M73): the last set of RTI tasks, phase and servo interruptions included.
    pub rti_task: u32,
}

impl TimerScale {
    /// Increments a phase period leaves after its phase tasks.
    fn phase_free(&self) -> u64 {
        u64::from(self.phase_period.saturating_sub(self.phase_task))
    }

    /// Increments of `units` CPU units of work, rounded down (MODEL, see the module).
    pub fn increments(&self, units: u64) -> u64 {
        let per_servo = self.phase_free().saturating_mul(u64::from(self.phases_per_servo));
        units.saturating_mul(per_servo).checked_div(u64::from(self.cycle_units)).unwrap_or(0)
    }

    /// The time from start to end of `net` increments of work that begins right after a phase
    /// interrupt's tasks: the work plus the phase tasks of each phase interrupt it spans. The
    /// count of those is `elapsed / X:$FFFF8C` again, as UM p.240 (P69, P68) takes it.
    fn with_phase_tasks(&self, net: u64) -> u64 {
        let spans = net.checked_div(self.phase_free()).unwrap_or(0);
        net.saturating_add(spans.saturating_mul(u64::from(self.phase_task)))
    }

    /// Y:$000037: the servo tasks of `servo_units` CPU units.
    pub fn servo_task(&self, servo_units: u32) -> u32 {
        clamp(self.with_phase_tasks(self.increments(u64::from(servo_units))))
    }

    /// X:$00000B: a set of RTI tasks of `rti_units` CPU units (PLC 0 and move planning, UM
    /// p.236) that starts after the servo tasks of `servo_units` and takes what each servo
    /// cycle leaves: interrupted by the servo tasks of every further servo cycle it spans.
    /// [`REGISTER_MAX`] when no servo cycle leaves it anything (it never ends).
    pub fn rti_task(&self, rti_units: u32, servo_units: u32) -> u32 {
        if rti_units == 0 {
            return 0;
        }
        let free = u32::from(self.cycle_units).saturating_sub(servo_units);
        if free == 0 {
            return REGISTER_MAX;
        }
        // The servo cycles after the first that the set takes: rti_units > 0, so at least 1.
        let cycles = rti_units.div_ceil(free).saturating_sub(1);
        let work = u64::from(rti_units).saturating_add(u64::from(cycles).saturating_mul(u64::from(servo_units)));
        clamp(self.with_phase_tasks(self.increments(work)))
    }

    /// The registers under a load: `servo_units` of servo tasks, `rti_units` of RTI tasks.
    pub fn timers(&self, servo_units: u32, rti_units: u32) -> Timers {
        Timers {
            phase_period: self.phase_period,
            phase_task: self.phase_task,
            servo_task: self.servo_task(servo_units),
            rti_task: self.rti_task(rti_units, servo_units),
        }
    }
}

/// The CPU units a timer reading stands for: the inverse of a mapping from units to a reading
/// (`TimerScale::servo_task`, `TimerScale::rti_task`, or UM p.240's duty cycles of them),
/// searched over `0..=max_units`. A card's task is no whole number of the model's units, so a
/// reading lies between the readings of two unit counts, and a mapping that rounds can give
/// one reading to several: the inverse is then not unique, and both ends are returned for the
/// caller to choose from (a safety tool takes the one that leaves the smaller margin).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct UnitsRange {
    /// The fewest units whose reading is at least the reading given, or the most whose
    /// reading is at most it, whichever is fewer.
    pub least: u32,
    /// The other of the two.
    pub most: u32,
}

/// [`UnitsRange`] of `reading` under `reading_of`: the most units in `0..=max_units` whose
/// reading is at most `reading` and the fewest whose reading is at least it, searched one unit
/// at a time (so a mapping that is not monotonic, as UM p.240's subtractions can make the
/// duty cycles, is inverted too). `None` when no unit count reads at most `reading` (it is
/// below what no load at all reads) or none reads at least it (beyond `max_units`).
pub fn units_of(reading: u64, max_units: u32, reading_of: impl Fn(u32) -> u64) -> Option<UnitsRange> {
    let (mut below, mut above) = (None, None);
    for units in 0..=max_units {
        let r = reading_of(units);
        if r <= reading {
            below = Some(units);
        }
        if r >= reading && above.is_none() {
            above = Some(units);
        }
    }
    let (below, above) = (below?, above?);
    Some(UnitsRange { least: below.min(above), most: below.max(above) })
}

impl Timers {
    /// The duty cycles, in parts per million of the CPU, that UM p.240's PLC computes from
    /// M70-M73 (P71 the phase tasks, P72 the servo tasks, P73 the RTI tasks; the EPICS driver's
    /// CPU load is their sum), for RTI periods of `i8 + 1` servo cycles and `phases_per_servo`
    /// phase interrupts a servo cycle: the readings' way back to the model's units (a duty
    /// cycle of the servo tasks times `cycle_units` is their CPU units, MODEL).
    pub fn duty_ppm(&self, phases_per_servo: u32, i8: u8) -> (u64, u64, u64) {
        let (m70, m71, m72, m73) = (
            u64::from(self.phase_period),
            u64::from(self.phase_task),
            u64::from(self.servo_task),
            u64::from(self.rti_task),
        );
        let p70 = u64::from(phases_per_servo);
        let ppm = |num: u64, den: u64| num.saturating_mul(1_000_000).checked_div(den).unwrap_or(0);
        let p71 = ppm(m71, m70);
        let p69 = m72.checked_div(m70).unwrap_or(0);
        let servo_net = m72.saturating_sub(p69.saturating_mul(m71));
        let p72 = ppm(servo_net, m70.saturating_mul(p70));
        let p68 = m73.checked_div(m70).unwrap_or(0);
        let p67 = m73.checked_div(m70.saturating_mul(p70)).unwrap_or(0);
        let rti_net = m73.saturating_sub(p68.saturating_mul(m71)).saturating_sub(p67.saturating_mul(servo_net));
        let p73 = ppm(rti_net, m70.saturating_mul(p70).saturating_mul(u64::from(i8).saturating_add(1)));
        (p71, p72, p73)
    }

    /// The EPICS driver's CPU load, `P74 = 100 x (P71 + P72 + P73)` percent
    /// (DiamondLightSource/pmac `pmacApp/src/pmacController.cpp:1850-1890`, after UM p.240's
    /// PLC), in parts per million: the sum of [`Timers::duty_ppm`], each share rounded down, so
    /// at most 3 ppm below the driver's floating-point figure.
    pub fn load_ppm(&self, phases_per_servo: u32, i8: u8) -> u64 {
        let (phase, servo, rti) = self.duty_ppm(phases_per_servo, i8);
        phase.saturating_add(servo).saturating_add(rti)
    }
}

fn clamp(v: u64) -> u32 {
    u32::try_from(v.min(u64::from(REGISTER_MAX))).unwrap_or(REGISTER_MAX)
}

#[cfg(test)]
// Test arithmetic on small values.
#[allow(clippy::arithmetic_side_effects)]
mod tests {
    use super::*;

    /// The emulated Geo Brick's: M70 = 13279, M71 = 1328 (`variables.yaml`), I7002 = 3, 100
    /// units a servo cycle.
    const BRICK: TimerScale =
        TimerScale { phase_period: 13279, phase_task: 1328, phases_per_servo: 4, cycle_units: 100 };

    #[test]
    fn the_duty_cycles_ums_plc_computes_from_the_registers_give_back_the_units_charged() {
        // UM p.240's subtraction of the interrupting phase and servo tasks recovers each
        // task's share of what the servo period leaves, whatever the load: within a unit's
        // rounding (one increment in 478).
        let phase_ppm = 1_000_000 * 1328 / 13279;
        for motors in [0u32, 1, 8, 32, 60] {
            for rti in [0u32, 1, 30, 92, 150, 276, 600] {
                let t = BRICK.timers(motors, rti);
                let (p71, p72, p73) = t.duty_ppm(4, 2);
                assert_eq!(p71, phase_ppm);
                let share = |units: u32, periods: u64| {
                    1_000_000 * (1_000_000 - phase_ppm) * u64::from(units) / 100 / 1_000_000 / periods
                };
                let near = |got: u64, want: u64| got.abs_diff(want) <= 2_500;
                assert!(near(p72, share(motors, 1)), "{motors} motors: servo {p72} ppm, want {}", share(motors, 1));
                assert!(
                    near(p73, share(rti, 3)),
                    "{motors} motors, RTI {rti}: {p73} ppm, want {} ({t:?})",
                    share(rti, 3)
                );
            }
        }
    }

    #[test]
    fn units_of_gives_back_the_units_of_every_register_and_both_neighbours_between_two() {
        // Y:$000037 of 0 to 100 units of servo tasks, X:$00000B of 0 to 400 units of RTI tasks
        // after 8 of servo: each register's inverse is the units charged, and a reading one
        // increment short of a unit's register lies between it and the unit before.
        for units in 0..=100u32 {
            let reg = u64::from(BRICK.servo_task(units));
            let back = units_of(reg, 255, |u| u64::from(BRICK.servo_task(u)));
            assert_eq!(back, Some(UnitsRange { least: units, most: units }), "servo {units}");
            if units > 0 {
                let between = units_of(reg - 1, 255, |u| u64::from(BRICK.servo_task(u)));
                assert_eq!(between, Some(UnitsRange { least: units - 1, most: units }), "servo {units} - 1");
            }
        }
        for units in 0..=400u32 {
            let reg = u64::from(BRICK.rti_task(units, 8));
            let back = units_of(reg, 65_535, |u| u64::from(BRICK.rti_task(u, 8)));
            assert_eq!(back, Some(UnitsRange { least: units, most: units }), "RTI {units}");
        }
        // The CPU load the driver computes: 30 units of PLC 0 after 8 motors, back to 30.
        let ppm = |u: u32| BRICK.timers(8, u).load_ppm(4, 2);
        assert_eq!(units_of(ppm(30), 65_535, ppm), Some(UnitsRange { least: 30, most: 30 }));
        // Beyond the units searched, or below what no load reads: no inverse.
        assert_eq!(units_of(u64::from(BRICK.servo_task(256)), 255, |u| u64::from(BRICK.servo_task(u))), None);
        assert_eq!(units_of(ppm(0) - 1, 65_535, ppm), None);
    }

    #[test]
    fn the_rti_time_grows_with_its_units_and_counts_the_servo_cycles_it_spans() {
        let mut last = 0;
        for rti in 0..=400 {
            let t = BRICK.rti_task(rti, 8);
            assert!(t >= last, "{rti} units: {t} < {last}");
            last = t;
        }
        // 92 units fit the first servo cycle (100 - 8); 93 spans a second, interrupted once by
        // the servo tasks and by the phase tasks of the phase interrupts it spans.
        let one = u64::from(BRICK.rti_task(92, 8));
        let two = u64::from(BRICK.rti_task(93, 8));
        assert!(two >= one + u64::from(BRICK.servo_task(8)) - u64::from(BRICK.phase_task), "{one} then {two}");
        assert_eq!(BRICK.rti_task(1, 100), REGISTER_MAX, "no time left for the RTI: it never ends");
        assert_eq!(BRICK.rti_task(0, 100), 0);
    }
}
