//! Proof harnesses, dual-use (design.md): each body is a function of its inputs; under Kani
//! (`cargo kani`) a `#[kani::proof]` calls it with `kani::any()` inputs, proving it for all of
//! them; under `cargo test` a twin runs the same body over the whole input domain (at most
//! 2^32 cases per harness). The whole-state `advance` harness has a domain far beyond that; its
//! twin is a proptest in `tests/advance.rs`.
//!
//! Why the counter domain is the whole reachable domain: a background cycle loads
//! `reset_value(i40)` for some `i40` in 0..=65535 (1..=65535, or 4095/4096 for 0), and every
//! later counter value is `after(reset, k)` for the `k` servo cycles since, so the pairs
//! (i40, k) with k in 0..=65535 reach every value down to -65535. A below-zero counter trips the
//! card within `hardware_delay_cycles + 1` cycles, and that delay is servo_hz / (2 x strobe
//! minimum): 800 cycles at 40 kHz and 25 Hz, far inside the enumerated range.

use crate::counter::{after, decrement, reset_value, StrobeStop};
use crate::motion::{
    pack, program_in, unpack, with_program, CsCommand, GlobalCommand, Motion, MotionCommand, MotionConfig,
    MotorCommand, MotorState, Program, Stop, COORDINATE_SYSTEMS_MAX,
};

#[cfg(test)]
extern crate std;

/// The two readings of the reset value for I40 = 0.
pub const RESET_VALUES_I40_ZERO: [u16; 2] = [4095, 4096];

/// The decrement path from a reload never overflows or panics, `after(reload, k)` equals k
/// single decrements (by induction: `after(c, 0) = c` and `after(c, k + 1)` is one decrement of
/// `after(c, k)`), and the counter never rises, so the minimum register, which takes the last
/// value, never exceeds any value the counter held since the reload.
pub fn check_counter_path(i40: u16, k: u16, stop: StrobeStop, reset_value_i40_zero: u16) {
    let reload = reset_value(i40, reset_value_i40_zero);
    assert!((1..=65_535).contains(&reload));
    let k = u32::from(k);
    assert_eq!(after(reload, 0, stop), reload);
    let now = after(reload, k, stop);
    let (stepped, _) = decrement(now, stop);
    let next = after(reload, k.saturating_add(1), stop);
    assert_eq!(next, stepped, "closed form equals one more single step");
    assert!(next <= now, "the counter never rises between reloads");
    let minimum = now.min(next);
    assert!(minimum <= next && minimum <= now && minimum <= reload);
    if stop == StrobeStop::AtZero {
        assert!(next >= 0, "UM p.215: the counter stops at zero");
    }
}

/// The I40 = 0 mapping of each profile: 4095 (SRM p.57) or 4096 (UM p.215), otherwise I40.
pub fn check_i40_mapping(i40: u16) {
    for rv in RESET_VALUES_I40_ZERO {
        let expected = if i40 == 0 { i32::from(rv) } else { i32::from(i40) };
        assert_eq!(reset_value(i40, rv), expected);
    }
}

/// `advance(n)` equals n single servo cycles on the whole state, and X:$25 reads the lowest
/// counter value of those cycles (SRM p.57: the minimum since reset), as the definition says:
/// the core keeps the minimum lazily (only a reload folds the falling run into it), so this is
/// checked against the minimum taken cycle by cycle here. Used by the Kani proof below (small
/// n) and by the proptest twin in `tests/advance.rs` (random configurations, states and n).
pub fn check_advance_equals_single_steps(cfg: &crate::Config, start: &crate::Core, n: u32) {
    let mut fast = *start;
    fast.advance(cfg, n);
    let mut slow = *start;
    let mut lowest = start.counter_min();
    for _ in 0..n {
        slow.servo_cycle_exact(cfg);
        lowest = lowest.min(slow.counter());
    }
    assert_eq!(fast, slow, "advance({n}) differs from {n} single cycles");
    assert!(fast.motion().consistent(), "the motion's redundant bits disagree with its motor bytes");
    assert_eq!(fast.counter_min(), lowest, "X:$25 is not the lowest counter value of the cycles");
}

/// `advance(n)` for any n (the whole u32 range) never panics, never raises the minimum
/// register (X:$25 at or below Y:$25 holds by construction: it reads the smaller of the two),
/// and splits: advance(a) then advance(n - a) equals
/// advance(n). With [`check_advance_equals_single_steps`] for small n, the split extends the
/// single-step equality to every n (any n is a sum of small steps).
pub fn check_advance_any_n(cfg: &crate::Config, start: &crate::Core, n: u32, split: u32) {
    let mut whole = *start;
    whole.advance(cfg, n);
    assert!(whole.counter_min() <= start.counter_min(), "X:$25 rose without a reset");
    assert!(whole.counter() >= -65_535, "the counter left its reachable domain");
    let a = split.min(n);
    let mut parts = *start;
    parts.advance(cfg, a);
    parts.advance(cfg, n.saturating_sub(a));
    assert_eq!(whole, parts, "advance({n}) differs from advance({a}) then advance({})", n.saturating_sub(a));
}

/// Deferred servo cycles cannot be told apart from cycles taken in full: a card running
/// `servo_cycle` (which in a quiet stretch only counts the cycle, `Core::quiet_cycles`) and its
/// twin running `servo_cycle_exact` (each cycle in full, the old single cycle) side by side for
/// `n` cycles, with a background cycle after every `background_every`-th cycle where one can
/// complete (0: never). After every cycle each reader answers the same on both, and the first
/// card, settled, equals the second field for field. With
/// [`check_advance_equals_single_steps`] (the cycles a stretch defers are applied by
/// `advance`), this makes the deferral a matter of speed only.
pub fn check_deferred_servo_cycles(cfg: &crate::Config, start: &crate::Core, n: u32, background_every: u32) {
    use crate::{Register, Reply};
    let mut deferred = *start;
    let mut exact = start.settled(cfg);
    for i in 1..=n {
        deferred.servo_cycle(cfg);
        exact.servo_cycle_exact(cfg);
        assert_eq!(deferred.tripped(), exact.tripped(), "tripped, cycle {i}");
        assert_eq!(deferred.counter(), exact.counter(), "the counter, cycle {i}");
        assert_eq!(deferred.counter_min(), exact.counter_min(), "X:$25, cycle {i}");
        assert_eq!(deferred.background_possible(), exact.background_possible(), "background possible, cycle {i}");
        assert_eq!(deferred.motion(), exact.motion(), "the motion, cycle {i}");
        assert_eq!((deferred.load(), deferred.spare_units()), (exact.load(), exact.spare_units()));
        assert_eq!(deferred.status_words(cfg), exact.status_words(cfg), "X:$6 and Y:$6, cycle {i}");
        assert_eq!(deferred.observe(cfg, Reply::None), exact.observe(cfg, Reply::None), "cycle {i}");
        for r in [
            Register::ServoCycles,
            Register::StatusX,
            Register::StatusY,
            Register::WatchdogCounter,
            Register::WatchdogMinimum,
            Register::RunningChecksum,
            Register::ProgramChecksumReference,
        ] {
            assert_eq!(deferred.register(cfg, r), exact.register(cfg, r), "{r:?}, cycle {i}");
        }
        assert_eq!(deferred.settled(cfg), exact, "the settled state, cycle {i}");
        if i.checked_rem(background_every) == Some(0) && exact.background_possible() {
            deferred.background_cycle(cfg);
            exact.background_cycle(cfg);
        }
    }
}

/// A motor's byte holds its state and stop and gives both back: `unpack(pack(s, t)) = (s, t)`
/// for every state and stop, distinct pairs pack to distinct bytes, and the all-zero byte is a
/// motor at power-up (killed, no stop), which `Motion::power_on` relies on.
pub fn check_motor_byte_round_trip(state: MotorState, stop: Option<Stop>) {
    let byte = pack(state, stop);
    assert_eq!(unpack(byte), (state, stop), "round trip of {state:?} {stop:?}");
    assert!(byte < 64, "a motor byte uses six bits");
    assert_eq!(unpack(0), (MotorState::Killed, None));
}

/// Replacing one coordinate system's program in the packed word changes that program and no
/// other, for every program and every word; a number outside &1..&16 changes nothing and
/// reads no program.
pub fn check_program_word(word: u64, cs: u8, p: Program) {
    let next = with_program(word, cs, p);
    if cs == 0 || cs > COORDINATE_SYSTEMS_MAX {
        assert_eq!(next, word, "&{cs} is not a coordinate system");
        assert_eq!(program_in(word, cs), Program::None);
        return;
    }
    assert_eq!(program_in(next, cs), p, "&{cs} reads back");
    for other in 1..=COORDINATE_SYSTEMS_MAX {
        if other != cs {
            assert_eq!(program_in(next, other), program_in(word, other), "&{other} unchanged by &{cs}");
        }
    }
    assert_eq!(next >> 48, word >> 48, "the bits above &16 are untouched");
}

/// The motion's closed form over servo cycles equals single cycles: after `commands` on a
/// fresh card, `servo_cycles(n)` in one call equals `n` calls of one cycle, and the redundant
/// bits stay consistent with the motor bytes after every step.
pub fn check_motion_closed_form(cfg: &MotionConfig, commands: &[MotionCommand], n: u32) {
    let mut m = Motion::power_on();
    for c in commands {
        m.command(cfg, *c);
        assert!(m.consistent(), "after {c:?}");
    }
    let mut fast = m;
    fast.servo_cycles(cfg, n);
    let mut slow = m;
    for _ in 0..n {
        slow.servo_cycles(cfg, 1);
        assert!(slow.consistent());
    }
    assert_eq!(fast, slow, "{n} servo cycles at once differ from one by one after {commands:?}");
}

/// The motion commands the closed-form harness draws from: every row of UM p.217 on motor #1 or
/// #2 and &1 or &2, the commands that start motion, and `&1E` (which closes killed loops).
pub const MOTION_COMMANDS: [MotionCommand; 17] = [
    MotionCommand::Motor(1, MotorCommand::JogStop),
    MotionCommand::Motor(1, MotorCommand::Jog),
    MotionCommand::Motor(1, MotorCommand::Kill),
    MotionCommand::Motor(2, MotorCommand::JogStop),
    MotionCommand::CoordinateSystem(1, CsCommand::Begin),
    MotionCommand::CoordinateSystem(1, CsCommand::Run),
    MotionCommand::CoordinateSystem(1, CsCommand::Step),
    MotionCommand::CoordinateSystem(1, CsCommand::Abort),
    MotionCommand::CoordinateSystem(1, CsCommand::Quit),
    MotionCommand::CoordinateSystem(1, CsCommand::EndOfMove),
    MotionCommand::CoordinateSystem(1, CsCommand::Hold),
    MotionCommand::CoordinateSystem(1, CsCommand::Enable),
    MotionCommand::CoordinateSystem(2, CsCommand::Begin),
    MotionCommand::CoordinateSystem(2, CsCommand::Run),
    MotionCommand::Global(GlobalCommand::QuitAll),
    MotionCommand::Global(GlobalCommand::HoldAll),
    MotionCommand::Global(GlobalCommand::AbortAll),
];

#[cfg(kani)]
mod kani_proofs {
    use super::*;

    /// Any configuration of every profile reading with I8 <= 3 (so the partial RTI periods
    /// `advance` steps stay within the unwind bound) and any motor count. `Width` sets the
    /// symbolic domain of the delay, the CPU costs, I40 and the PLC 0 and background costs: u8
    /// for the single-step comparison (which unrolls n servo cycles), u16 for the
    /// closed-form-only harness.
    fn any_config<Width: kani::Arbitrary + Into<u16>>() -> crate::Config {
        let wide = |w: Width| -> u16 { w.into() };
        crate::Config {
            profile: crate::Profile {
                reset_value_i40_zero: if kani::any() { 4095 } else { 4096 },
                strobe_stop: if kani::any() { StrobeStop::AtZero } else { StrobeStop::BelowZero },
                rti_strobes: kani::any(),
                bit12_firmware_error: kani::any(),
                rti_warning_sticky: kani::any(),
                encoder_loss_clear_intended: kani::any(),
                out_of_range_modulo: kani::any(),
            },
            hardware_delay_cycles: wide(kani::any()).into(),
            cycle_units: wide(kani::any()),
            servo_units_per_motor: wide(kani::any()),
            move_planning_units: wide(kani::any()),
            saved_i8: kani::any::<u8>() % 4,
            saved_i40: wide(kani::any()),
            saved_i41: 0,
            pass_firmware: 1,
            pass_user_program: 1,
            supply_min_millivolts: 4750,
            servo_counter_mask: 0xFF_FFFF,
            load: crate::Load {
                motors: kani::any(),
                plc0_units: wide(kani::any()),
                background_units: wide(kani::any()),
            },
            motion: MotionConfig::all_in_cs1(2, kani::any::<u8>() % 4),
            processor: crate::Processor::Dsp56321,
            other_i_writes_card_own: false,
        }
    }

    #[kani::proof]
    #[kani::unwind(10)]
    fn advance_equals_single_steps_for_small_n() {
        let cfg = any_config::<u8>();
        let n: u8 = kani::any();
        kani::assume(n <= 8);
        check_advance_equals_single_steps(&cfg, &crate::Core::power_on(&cfg), n.into());
    }

    #[kani::proof]
    #[kani::unwind(10)]
    fn deferred_servo_cycles_read_as_exact_ones_for_small_n() {
        let cfg = any_config::<u8>();
        let n: u8 = kani::any();
        kani::assume(n <= 8);
        check_deferred_servo_cycles(&cfg, &crate::Core::power_on(&cfg), n.into(), kani::any::<u32>() % 4);
    }

    #[kani::proof]
    #[kani::unwind(10)]
    fn advance_never_panics_and_splits_for_every_n() {
        let cfg = any_config::<u16>();
        check_advance_any_n(&cfg, &crate::Core::power_on(&cfg), kani::any(), kani::any());
    }

    #[kani::proof]
    fn counter_path_never_overflows_and_equals_single_steps() {
        let stop = if kani::any() { StrobeStop::AtZero } else { StrobeStop::BelowZero };
        let rv = if kani::any() { 4095 } else { 4096 };
        check_counter_path(kani::any(), kani::any(), stop, rv);
    }

    #[kani::proof]
    fn i40_zero_mapping_matches_each_profile() {
        check_i40_mapping(kani::any());
    }

    #[kani::proof]
    fn motor_byte_round_trips() {
        let state = MotorState::ALL[usize::from(kani::any::<u8>() % 6)];
        let stop = if kani::any() { None } else { Some(Stop::ALL[usize::from(kani::any::<u8>() % 5)]) };
        check_motor_byte_round_trip(state, stop);
    }

    #[kani::proof]
    #[kani::unwind(17)]
    fn program_word_replaces_one_program() {
        check_program_word(kani::any(), kani::any(), Program::ALL[usize::from(kani::any::<u8>() % 5)]);
    }

    #[kani::proof]
    #[kani::unwind(17)]
    fn motion_closed_form_equals_single_cycles() {
        let cfg = MotionConfig {
            motors: 1 + kani::any::<u8>() % 2,
            coordinate_systems: [1 + kani::any::<u8>() % 2, 1 + kani::any::<u8>() % 2, 1, 1, 1, 1, 1, 1],
            decel_cycles: kani::any::<u8>() % 4,
        };
        let pick = || MOTION_COMMANDS[usize::from(kani::any::<u8>()) % MOTION_COMMANDS.len()];
        let n: u8 = kani::any();
        kani::assume(n <= 5);
        check_motion_closed_form(&cfg, &[pick(), pick(), pick()], n.into());
    }
}

#[cfg(test)]
mod exhaustive_twins {
    use super::*;

    /// All 2^32 (I40, cycles) pairs, under both strobe readings (the I40 = 0 reading only
    /// matters for I40 = 0, which is covered with both values).
    #[test]
    fn counter_path_never_overflows_and_equals_single_steps_for_every_i40_and_cycle_count() {
        for stop in [StrobeStop::AtZero, StrobeStop::BelowZero] {
            for i40 in 0..=u16::MAX {
                let readings: &[u16] = if i40 == 0 { &RESET_VALUES_I40_ZERO } else { &RESET_VALUES_I40_ZERO[..1] };
                for rv in readings {
                    for k in 0..=u16::MAX {
                        check_counter_path(i40, k, stop, *rv);
                    }
                }
            }
        }
    }

    #[test]
    fn i40_zero_mapping_matches_each_profile_for_every_i40() {
        for i40 in 0..=u16::MAX {
            check_i40_mapping(i40);
        }
    }

    #[test]
    fn motor_byte_round_trips_for_every_state_and_stop() {
        for state in MotorState::ALL {
            check_motor_byte_round_trip(state, None);
            for stop in Stop::ALL {
                check_motor_byte_round_trip(state, Some(stop));
            }
        }
    }

    /// Every coordinate-system number (0..=255, so the ones outside &1..&16 too) and program,
    /// on words holding every program in every slot (rotated so each slot sees each value next
    /// to each neighbour value) and on all-ones and all-zero words.
    #[test]
    fn program_word_replaces_one_program_for_every_cs_and_program() {
        let mut words = std::vec![0u64, u64::MAX];
        for rotation in 0..5u64 {
            let mut w = 0u64;
            for slot in 0..16u64 {
                w |= ((slot + rotation) % 5) << (3 * slot);
            }
            words.push(w);
            words.push(w | 0xFFFF << 48);
        }
        for word in words {
            for cs in 0..=u8::MAX {
                for p in Program::ALL {
                    check_program_word(word, cs, p);
                }
            }
        }
    }

    /// Every sequence of three of [`MOTION_COMMANDS`] (4,913), on one and two motors in each
    /// assignment to &1 and &2, with decelerations of 0 to 3 cycles, for n = 0..=5.
    #[test]
    fn motion_closed_form_equals_single_cycles_for_every_short_command_sequence() {
        for motors in 1..=2u8 {
            for (a, b) in [(1, 1), (1, 2), (2, 1), (2, 2)] {
                for decel in 0..=3u8 {
                    let cfg =
                        MotionConfig { motors, coordinate_systems: [a, b, 1, 1, 1, 1, 1, 1], decel_cycles: decel };
                    for x in MOTION_COMMANDS {
                        for y in MOTION_COMMANDS {
                            for z in MOTION_COMMANDS {
                                for n in 0..=5 {
                                    check_motion_closed_form(&cfg, &[x, y, z], n);
                                }
                            }
                        }
                    }
                }
            }
        }
    }
}
