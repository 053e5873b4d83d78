//! The proptest twin of the `advance` proof harness: random configurations, random states
//! reached by random events, random n up to 20,000 (crossing the strobe stop and the trip).

mod common;

use pmacwd_core::motion::{CsCommand, GlobalCommand, MotorCommand, MOTORS_MAX};
use pmacwd_core::proofs::{check_advance_any_n, check_advance_equals_single_steps, check_deferred_servo_cycles};
use pmacwd_core::{
    Area, Command, Config, Core, Event, FewIVariables, Load, MotionCommand, MotionConfig, Processor, Profile, Reset,
    ResetKind, StrobeStop,
};
use proptest::prelude::*;

fn config() -> impl Strategy<Value = Config> {
    (
        (any::<bool>(), any::<bool>(), any::<bool>(), any::<bool>(), any::<bool>()),
        (1u32..=60, 1u16..=120, 0u16..=30, 0u16..=20, 0u8..=6, 0u16..=400),
        (0u8..=12, 0u16..=600, 0u16..=400),
        // Motors in up to three coordinate systems, decelerations shorter and longer than the
        // servo runs below, the encoder-loss PLC's two readings, and the two readings of an
        // out-of-range assignment (UM p.243's modulo, or ERR003).
        (1u8..=8, prop::array::uniform8(1u8..=3), 0u8..=60, any::<bool>(), any::<bool>()),
    )
        .prop_map(
            |(
                (r4096, below, rti, m83, sticky),
                (delay, cycle, per_motor, planning, i8, i40),
                (motors, plc0, bg),
                (count, cs, decel, intended, modulo),
            )| {
                Config {
                    profile: Profile {
                        reset_value_i40_zero: if r4096 { 4096 } else { 4095 },
                        strobe_stop: if below { StrobeStop::BelowZero } else { StrobeStop::AtZero },
                        rti_strobes: rti,
                        bit12_firmware_error: m83,
                        rti_warning_sticky: sticky,
                        encoder_loss_clear_intended: intended,
                        out_of_range_modulo: modulo,
                    },
                    hardware_delay_cycles: delay,
                    cycle_units: cycle,
                    servo_units_per_motor: per_motor,
                    move_planning_units: planning,
                    saved_i8: i8,
                    saved_i40: i40,
                    saved_i41: 0,
                    pass_firmware: 2,
                    pass_user_program: 1,
                    supply_min_millivolts: 4750,
                    servo_counter_mask: 0xFF_FFFF,
                    load: Load { motors, plc0_units: plc0, background_units: bg },
                    motion: MotionConfig { motors: count, coordinate_systems: cs, decel_cycles: decel },
                    processor: Processor::Dsp56311,
                    other_i_writes_card_own: false,
                }
            },
        )
}

fn event() -> impl Strategy<Value = Event> {
    prop_oneof![
        4 => (1u32..50).prop_map(Event::Servo),
        4 => Just(Event::Background),
        1 => (0u8..=12, 0u16..=600, 0u16..=400).prop_map(|(m, p, b)| Event::Load(Load { motors: m, plc0_units: p, background_units: b })),
        1 => (0u16..=8).prop_map(|v| Event::Command(Command::WriteI(8, i64::from(v)))),
        1 => (0u16..=50).prop_map(|v| Event::Command(Command::WriteI(40, i64::from(v)))),
        // I40 changed by a memory write (SRM p.57), and the re-initialization to factory
        // defaults (I8 = 2, I40 = 0: UM p.243), both of which change what `advance` computes.
        1 => (0u16..=50).prop_map(|v| Event::Command(Command::WriteIMemory(40, i64::from(v)))),
        1 => Just(Event::Command(Command::Reinitialize)),
        1 => Just(Event::Reset(Reset { kind: ResetKind::Init, dpram_fault: false, flash_fault: false, bootstrap: false })),
        1 => Just(Event::ChecksumFault(Area::Firmware)),
        1 => Just(Event::ClearRtiReentry),
        6 => motion_command().prop_map(|m| Event::Command(Command::Motion(m))),
        1 => (0u8..=9, any::<bool>()).prop_map(|(motor, lost)| Event::EncoderInput { motor, lost }),
    ]
}

/// Motion commands on motors #0..#9 and coordinate systems &0..&4 (both ranges one past the
/// configurations' on each side), so that stops are under way when `advance` runs.
fn motion_command() -> impl Strategy<Value = MotionCommand> {
    let motor = prop::sample::select(&[MotorCommand::Jog, MotorCommand::JogStop, MotorCommand::Kill][..]);
    let cs = prop::sample::select(
        &[
            CsCommand::Abort,
            CsCommand::Quit,
            CsCommand::EndOfMove,
            CsCommand::Hold,
            CsCommand::QuickStop,
            CsCommand::Run,
            CsCommand::Step,
            CsCommand::Begin,
            CsCommand::Enable,
            CsCommand::Feedrate(0),
            CsCommand::Feedrate(100),
        ][..],
    );
    let global = prop::sample::select(
        &[GlobalCommand::AbortAll, GlobalCommand::QuitAll, GlobalCommand::HoldAll, GlobalCommand::KillAll][..],
    );
    prop_oneof![
        3 => (0u8..=MOTORS_MAX as u8 + 1, motor).prop_map(|(n, c)| MotionCommand::Motor(n, c)),
        4 => (0u8..=4, cs).prop_map(|(n, c)| MotionCommand::CoordinateSystem(n, c)),
        1 => global.prop_map(MotionCommand::Global),
    ]
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 4000, ..ProptestConfig::default() })]

    /// advance(n) equals n single servo cycles, on every field of the state.
    #[test]
    fn advance_equals_n_single_servo_cycles(cfg in config(), prefix in prop::collection::vec(event(), 0..40), n in prop_oneof![0u32..300, 300u32..20_000]) {
        let mut core = Core::power_on(&cfg);
        for e in prefix {
            if e == Event::Background && !core.background_possible() {
                continue;
            }
            core.apply(&cfg, e, &mut FewIVariables::<4>::default());
        }
        check_advance_equals_single_steps(&cfg, &core, n);
    }

    /// The servo cycle defers the cycles of a quiet stretch and applies them in closed form
    /// when the card is next read or changed; nothing may tell that apart from taking each
    /// cycle in full. A card and its twin run the same random events with random runs of
    /// single servo cycles before each (so events land inside stretches, at their ends and
    /// outside them), the card with `servo_cycle`, the twin with `servo_cycle_exact`: after
    /// every event the two observe the same and the card, settled, equals its twin; then
    /// `check_deferred_servo_cycles` compares every reader after each of up to 6,000 more
    /// cycles (crossing the strobe stop and the trip), with background cycles between them.
    #[test]
    fn deferred_servo_cycles_cannot_be_told_apart_from_exact_ones(cfg in config(), prefix in prop::collection::vec((0u32..40, event()), 0..30), n in 0u32..6_000, background_every in 0u32..6) {
        let mut core = Core::power_on(&cfg);
        let mut twin = core;
        let (mut store, mut twin_store) = (FewIVariables::<4>::default(), FewIVariables::<4>::default());
        for (cycles, e) in prefix {
            for _ in 0..cycles {
                core.servo_cycle(&cfg);
                twin.servo_cycle_exact(&cfg);
            }
            prop_assert_eq!(core.background_possible(), twin.background_possible());
            if e == Event::Background && !twin.background_possible() {
                continue;
            }
            let reply = core.apply(&cfg, e, &mut store);
            let twin_reply = twin.apply(&cfg, e, &mut twin_store);
            prop_assert_eq!(core.observe(&cfg, reply), twin.observe(&cfg, twin_reply));
            prop_assert_eq!(core.settled(&cfg), twin);
        }
        check_deferred_servo_cycles(&cfg, &core, n, background_every);
    }

    /// The twin of the Kani harness for every n: advance over the whole u32 range never panics,
    /// keeps X:$25 at or below Y:$25, and splits at any point.
    #[test]
    fn advance_of_any_length_never_panics_and_splits_anywhere(cfg in config(), prefix in prop::collection::vec(event(), 0..40), n in any::<u32>(), split in any::<u32>()) {
        let mut core = Core::power_on(&cfg);
        for e in prefix {
            if e == Event::Background && !core.background_possible() {
                continue;
            }
            core.apply(&cfg, e, &mut FewIVariables::<4>::default());
        }
        check_advance_any_n(&cfg, &core, n, split);
    }
}

/// A gap of a billion cycles costs what one cycle costs: it still finishes at once and lands
/// where the closed form says (tripped, counter at its floor).
#[test]
fn a_billion_idle_cycles_trip_a_card_without_background() {
    let cfg = common::realistic_config();
    let mut core = Core::power_on(&cfg);
    core.advance(&cfg, 1_000_000_000);
    assert!(core.tripped());
    assert_eq!((core.counter(), core.counter_min()), (0, 0));
    // The trip came 4096 + 46 cycles in (UM p.215); the servo counter stopped there.
    assert_eq!(core.register(&cfg, pmacwd_core::Register::ServoCycles), 4142);
}

/// Every small configuration of the RTI-strobes reading (SRM p.57), stepped: advance(n) equals
/// n single cycles for every hardware delay 1..=5, saved I8 0..=8, I40 1..=4 and both strobe
/// stops, from every state k = 0..=8 servo cycles after power-on followed by a change of I8 to
/// any of 0..=8, for n up to 30. These are the states where an RTI period (I8 + 1, UM p.236)
/// longer than the delay meets a counter about to stop strobing. `trip_cycle` relies on the gap
/// since the last strobe never being shorter than the RTI phase (no special case for a tick
/// that would come inside the unstrobed window of a long period: such a state is unreachable);
/// an I8 change is the one event that moves the period under a running phase, so it is here.
#[test]
fn advance_equals_single_cycles_when_the_counter_stops_strobing_before_the_next_rti_tick() {
    let base = common::realistic_config();
    let mut checked = 0u32;
    for delay in 1..=5 {
        for saved_i8 in 0..=8 {
            for i40 in 1..=4 {
                for strobe_stop in [StrobeStop::AtZero, StrobeStop::BelowZero] {
                    let cfg = Config {
                        profile: Profile { rti_strobes: true, strobe_stop, ..base.profile },
                        hardware_delay_cycles: delay,
                        saved_i8,
                        saved_i40: i40,
                        ..base
                    };
                    let mut core = Core::power_on(&cfg);
                    for _ in 0..=8 {
                        for new_i8 in 0..=8 {
                            let mut changed = core;
                            let write = Event::Command(Command::WriteI(8, new_i8));
                            changed.apply(&cfg, write, &mut FewIVariables::<4>::default());
                            for n in 0..=30 {
                                check_advance_equals_single_steps(&cfg, &changed, n);
                                checked += 1;
                            }
                        }
                        core.apply(&cfg, Event::Servo(1), &mut FewIVariables::<4>::default());
                    }
                }
            }
        }
    }
    assert_eq!(checked, 5 * 9 * 4 * 2 * 9 * 9 * 31);
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 2000, ..ProptestConfig::default() })]

    /// A state and its canonical form (the lazily kept X:$25 settled) observe the same after
    /// every event of any sequence: the exhaustive lockstep identifies the two, which is sound
    /// only if nothing can tell them apart (SRM p.57: X:$25 is the minimum since reset, however
    /// the core keeps it).
    #[test]
    fn a_state_and_its_canonical_form_cannot_be_told_apart(cfg in config(), prefix in prop::collection::vec(event(), 0..40), suffix in prop::collection::vec(event(), 1..40)) {
        let mut core = Core::power_on(&cfg);
        let mut store = FewIVariables::<4>::default();
        for e in prefix {
            if e == Event::Background && !core.background_possible() {
                continue;
            }
            core.apply(&cfg, e, &mut store);
        }
        let mut settled = core.canonical(&cfg);
        let mut settled_store = store;
        for e in suffix {
            let reply = core.apply(&cfg, e, &mut store);
            let settled_reply = settled.apply(&cfg, e, &mut settled_store);
            prop_assert_eq!(core.observe(&cfg, reply), settled.observe(&cfg, settled_reply));
            prop_assert_eq!(core.background_possible(), settled.background_possible());
        }
        prop_assert_eq!(core.canonical(&cfg), settled.canonical(&cfg));
    }
}

/// `advance` is in closed form (docs/core.md: the RTI over whole periods, "at most two partial
/// RTI periods ... stepped"), so its cost does not grow with n. A card with a hardware delay of
/// 2^31 servo cycles (UM p.215: the trip comes only after the delay) and a background cycle
/// between runs (UM p.215: it resets the counter) runs 2^31 - 1 cycles a thousand times over
/// without tripping: at once in closed form, for hours if a loop stepped the cycles one by one
/// (the mutation check counts that as a timeout). Every other round starts with the RTI phase
/// past a lowered I8 (UM p.236: the RTI runs every I8 + 1 servo cycles; I8 = 8 for four
/// cycles, then I8 = 2), the one state in which `advance` steps its second partial period.
/// Every other test's card trips within its counter and delay, a few tens of thousands of
/// cycles, which stepping also finishes in time. The servo counter (X:$0) still counts every
/// cycle, modulo its mask.
#[test]
fn advance_costs_the_same_for_any_number_of_cycles() {
    let cfg = Config { hardware_delay_cycles: 1 << 31, ..common::realistic_config() };
    let mut core = Core::power_on(&cfg);
    let mut store = FewIVariables::<4>::default();
    let n = (1u32 << 31) - 1;
    let mut cycles = 0u64;
    for round in 0..1000 {
        if round % 2 == 1 {
            core.apply(&cfg, Event::Command(Command::WriteI(8, 8)), &mut store);
            core.advance(&cfg, 4);
            core.apply(&cfg, Event::Command(Command::WriteI(8, 2)), &mut store);
            cycles += 4;
        }
        core.advance(&cfg, n);
        cycles += u64::from(n);
        assert!(core.background_possible());
        core.background_cycle(&cfg);
    }
    assert!(!core.tripped());
    let mask = u64::from(cfg.servo_counter_mask);
    assert_eq!(u64::from(core.register(&cfg, pmacwd_core::Register::ServoCycles)), cycles & mask);
}

/// `canonical` settles the lazily kept minimum: once the counter has fallen below the minimum
/// remembered at the last reload, the state and its canonical form are different values that
/// read the same X:$25 (SRM p.57), and settling twice changes nothing more. Without this, a
/// `canonical` that returned the state unchanged would pass the proptest above (a state cannot
/// be told apart from itself) while the exhaustive lockstep counted each remembered minimum as
/// a state of its own. (cargo-mutants: the field dropped from `canonical`'s struct update.)
#[test]
fn canonical_settles_the_remembered_minimum_and_keeps_x25() {
    let cfg = common::realistic_config();
    let mut core = Core::power_on(&cfg);
    core.advance(&cfg, 10);
    let settled = core.canonical(&cfg);
    assert_ne!(settled, core, "ten cycles after power-on the counter is below the reload's minimum");
    assert_eq!((settled.counter_min(), settled.counter()), (core.counter_min(), core.counter()));
    assert_eq!(settled.canonical(&cfg), settled);
}

/// A stop under way changes the motion every servo cycle (a host reads the cycles it has left,
/// UM p.217), and its end changes the motor's state: a quiet stretch may run while stops are
/// under way, but must end before the first of them does. Here one, three or eight of eight
/// jogging motors decelerate for 1 to 64 cycles on a card whose counter and credit soon allow
/// a long stretch, and every reader, the motion included, must match cycles taken in full
/// throughout the stops and after they end. (cargo-mutants: `cycles_before_a_stop_ends`
/// answering 1 for a stop with 1 cycle left deferred the cycle that ends it; a 40-cycle stop
/// alone never had 1 left when a stretch was looked for.)
#[test]
fn a_quiet_stretch_ends_before_a_stop_under_way_does() {
    // Every length up to 64 cycles, so that a stretch is looked for (every eighth cycle) at
    // every number of cycles a stop can have left, 1 and 0 included; one stop and several.
    for decel in 1..=64 {
        for stopping in [1, 3, 8] {
            let (cfg, core) = common::moving(decel, stopping);
            assert!(core.motion().stops_under_way());
            check_deferred_servo_cycles(&cfg, &core, 100, 0);
        }
    }
}

/// UM p.215: the card trips once no strobe edge has come for longer than the hardware delay.
/// At the largest delay the core accepts, u32::MAX cycles, the gap since the last strobe
/// reaches the limit of its counter: a single servo cycle must still trip when `advance` says
/// it does (the spec loader bounds the delay far lower, but the core's `Config` takes any u32).
/// Here the counter runs out after 10 cycles, two long advances bring the gap to just below
/// the delay, and each of the next cycles is taken in full on one card and by `advance(1)` on
/// its twin: the two agree on every field, and both trip on the same cycle.
#[test]
fn at_the_largest_delay_single_cycles_trip_when_advance_does() {
    let cfg = Config { hardware_delay_cycles: u32::MAX, saved_i40: 10, ..common::realistic_config() };
    let mut core = Core::power_on(&cfg);
    core.advance(&cfg, u32::MAX);
    core.advance(&cfg, 8);
    assert!(!core.tripped());
    let mut twin = core;
    let mut tripped_at = None;
    for cycle in 1..=4 {
        core.servo_cycle_exact(&cfg);
        twin.advance(&cfg, 1);
        assert_eq!(core, twin, "cycle {cycle} after the long advances");
        if core.tripped() && tripped_at.is_none() {
            tripped_at = Some(cycle);
        }
    }
    assert_eq!(tripped_at, Some(3), "the gap passes u32::MAX on the third cycle");
}

/// The speed of an idle servo cycle rests on quiet stretches actually beginning, which no
/// reader can see (that is their point) and no test may time. So this counts them: a card
/// left alone from power-up takes its first eight cycles in full (a stretch may begin once the
/// counter has fallen eight, and is looked for every eighth cycle: the eighth) and defers the
/// other 992 of 1,000 (the stretch then runs to the counter's zero, 4,088 cycles on); a card whose host runs a background cycle whenever one can complete
/// (a light load: every few cycles) never computes a stretch (its counter never falls eight
/// from its reload), so none is pending after any of its cycles and nothing is deferred; and a
/// read through the configuration settles a copy, not the card. (cargo-mutants: the gate
/// `may_be_quiet` made always true, or or-ed with the every-eighth-cycle test, computes
/// stretches the next background cycle ends at once: only slower, caught here.)
#[test]
fn an_idle_card_defers_its_quiet_cycles_and_a_card_with_background_never_does() {
    let cfg = common::realistic_config();
    let mut idle = Core::power_on(&cfg);
    for _ in 0..1_000 {
        idle.servo_cycle(&cfg);
    }
    assert_eq!(idle.deferred_cycles(), 992, "of 1,000 cycles, all but the first eight deferred");
    assert_eq!(idle.quiet_cycles_left(), 4_088 - 992, "the stretch runs to the counter's zero");
    let status = idle.status_words(&cfg);
    assert_eq!(idle.settled(&cfg).status_words(&cfg), status);
    assert_eq!(idle.deferred_cycles(), 992, "reading the status settled the card itself");
    let mut busy = Core::power_on(&cfg);
    for _ in 0..1_000 {
        busy.servo_cycle(&cfg);
        assert_eq!((busy.deferred_cycles(), busy.quiet_cycles_left()), (0, 0));
        if busy.background_possible() {
            busy.background_cycle(&cfg);
        }
    }
    assert!(!busy.tripped());
}
