//! The reference semantics on short, hand-written histories. Each test tells one sentence of
//! the manuals as a story and checks what a host or an instrument would see.

use pmacwd_model::controller::{Controller, TripCause};
use pmacwd_specs::check::{ChecksumTarget, Load, ResetEvent, ResetKind};
use pmacwd_specs::config::ModelConfig;
use pmacwd_specs::vocab::command::HostCommand;
use pmacwd_specs::vocab::event::{Event, Reply};
use pmacwd_specs::Spec;

fn config(configuration: &str, profile: &str) -> ModelConfig {
    let spec = Spec::embedded().expect("embedded specs load");
    let profile = spec.profiles.get(profile).expect("profile exists");
    ModelConfig::from_spec(&spec, configuration, &profile).expect("configuration resolves")
}

fn cmd(c: &mut Controller, cfg: &ModelConfig, text: &str) -> Reply {
    c.apply(cfg, &Event::Command(HostCommand::parse(text).expect("command parses")))
}

fn servo(c: &mut Controller, cfg: &ModelConfig, cycles: u32) {
    c.apply(cfg, &Event::Servo { cycles });
}

const INIT: Event =
    Event::Reset(ResetEvent { kind: ResetKind::Init, dpram_fault: false, flash_fault: false, bootstrap: false });

#[test]
fn with_i40_zero_each_profile_reloads_its_own_reset_value() {
    // SRM p.57 says 4095, UM p.215 says 4096: the profile decides, and the counter shows it.
    for (profile, expected) in [("srm-57", 4095), ("um-215-4095", 4095), ("um-215", 4096)] {
        let cfg = config("i40-zero", profile);
        let mut card = Controller::power_on(&cfg);
        servo(&mut card, &cfg, 10);
        card.apply(&cfg, &Event::Background);
        assert_eq!(card.counter, expected, "{profile}");
    }
}

#[test]
fn a_starved_background_trips_the_card_reset_value_plus_delay_plus_one_cycles_after_it_last_ran() {
    // UM p.215: the strobe stops when the counter runs out, and the timer trips once it has
    // missed the strobe for longer than its delay (45 servo cycles at 2.25 kHz and 25 Hz).
    let cfg = config("i40-zero", "um-215");
    assert_eq!(cfg.hardware_delay_cycles, 45);
    let mut card = Controller::power_on(&cfg);
    servo(&mut card, &cfg, 4096 + 45);
    assert!(!card.tripped(), "one cycle before the deadline the card still runs");
    servo(&mut card, &cfg, 1);
    assert_eq!(card.trip, Some(TripCause::StrobeTimeout));
}

#[test]
fn a_background_cycle_one_cycle_before_the_deadline_saves_the_card_and_x25_records_the_near_miss() {
    let cfg = config("i40-zero", "um-215");
    let mut card = Controller::power_on(&cfg);
    servo(&mut card, &cfg, 4096 + 45);
    assert!(card.background_possible());
    card.apply(&cfg, &Event::Background);
    assert!(!card.tripped());
    assert_eq!(card.counter, 4096);
    // X:$25 remembers how close it came (SRM p.57, UM p.240).
    assert_eq!(cmd(&mut card, &cfg, "RHX:$25"), Reply::Hex(0));
    assert_eq!(cmd(&mut card, &cfg, "RHY:$25"), Reply::Hex(4096));
}

#[test]
fn under_the_srm_reading_the_counter_goes_below_zero_and_x25_shows_it_as_a_24_bit_word() {
    // SRM p.57: decremented every cycle; the strobe stops once the counter "becomes less than 0".
    let cfg = config("i40-zero", "srm-57");
    let mut card = Controller::power_on(&cfg);
    servo(&mut card, &cfg, 4095 + 3);
    assert_eq!(card.counter, -3);
    assert_eq!(cmd(&mut card, &cfg, "RHX:$25"), Reply::Hex(0xFF_FFFD));
}

#[test]
fn a_large_plc0_with_i8_small_starves_the_background_until_the_watchdog_trips() {
    // UM p.236: PLC 0 "too long ... will starve the background tasks"; "in the worst case, the
    // watchdog timer will trip". The starving load of `i40-zero` fills every RTI period.
    let cfg = config("i40-zero", "um-215");
    let mut card = Controller::power_on(&cfg);
    card.apply(&cfg, &Event::Load(Load { motors: 8, plc0_units: 276, background_units: 250 }));
    for _ in 0..(4096 + 46) {
        assert!(!card.background_possible(), "the background never gets a cycle's worth of CPU");
        servo(&mut card, &cfg, 1);
    }
    assert_eq!(card.trip, Some(TripCause::StrobeTimeout));
}

#[test]
fn an_rti_task_longer_than_its_period_sets_bits_22_and_9_and_bit_22_stays_until_cleared() {
    let cfg = config("timing", "um-215");
    let mut card = Controller::power_on(&cfg);
    // I8 = 1: an RTI every 2 servo cycles with 3 free units each; PLC 0 needs 8.
    card.apply(&cfg, &Event::Load(Load { motors: 1, plc0_units: 8, background_units: 3 }));
    // The first RTI comes at cycle 2 and leaves 2 units undone at cycle 4, the next RTI.
    servo(&mut card, &cfg, 4);
    let Reply::Status { x, .. } = cmd(&mut card, &cfg, "???") else { panic!("??? answers") };
    assert_eq!(x & (1 << 22 | 1 << 9), 1 << 22 | 1 << 9, "SRM p.289-290: both bits set; got {x:06X}");
    // Back to a light load: bit 9 (level reading) clears once an RTI finds its predecessor done;
    // bit 22 is sticky (SRM p.289).
    card.apply(&cfg, &Event::Load(Load { motors: 1, plc0_units: 0, background_units: 3 }));
    for _ in 0..8 {
        servo(&mut card, &cfg, 1);
        if card.background_possible() {
            card.apply(&cfg, &Event::Background);
        }
    }
    assert!(!card.tripped());
    let Reply::Status { x, .. } = cmd(&mut card, &cfg, "???") else { panic!() };
    assert_eq!(x & (1 << 22 | 1 << 9), 1 << 22);
    card.apply(&cfg, &Event::ClearRtiReentry);
    let Reply::Status { x, .. } = cmd(&mut card, &cfg, "???") else { panic!() };
    assert_eq!(x & (1 << 22), 0);
}

#[test]
fn undervoltage_trips_at_once_a_tripped_card_is_silent_and_init_restores_replies() {
    let cfg = config("timing", "um-215");
    let mut card = Controller::power_on(&cfg);
    card.apply(&cfg, &Event::Supply { millivolts: 4500 });
    assert_eq!(card.trip, Some(TripCause::Undervoltage));
    assert_eq!(cmd(&mut card, &cfg, "???"), Reply::Silence, "UM p.215: will not communicate");
    // INIT/ while the supply is still low: the circuit trips again at once.
    card.apply(&cfg, &INIT);
    assert!(card.tripped());
    card.apply(&cfg, &Event::Supply { millivolts: 5000 });
    assert!(card.tripped(), "a trip is latched: a good supply alone does not undo it");
    card.apply(&cfg, &INIT);
    assert!(!card.tripped());
    assert!(matches!(cmd(&mut card, &cfg, "???"), Reply::Status { .. }));
}

#[test]
fn i41_bit_0_makes_a_motor_setup_write_a_silent_no_op_while_i5100_and_i41_stay_writable() {
    let cfg = config("lockout", "um-215");
    let mut card = Controller::power_on(&cfg);
    assert_eq!(cmd(&mut card, &cfg, "I130=7"), Reply::Ack);
    assert_eq!(cmd(&mut card, &cfg, "I41=1"), Reply::Ack);
    assert_eq!(cmd(&mut card, &cfg, "I130=9"), Reply::Ack, "SRM p.57: ignored, no error");
    assert_eq!(cmd(&mut card, &cfg, "I130"), Reply::Value(7));
    assert_eq!(cmd(&mut card, &cfg, "I5100=5"), Reply::Ack);
    assert_eq!(cmd(&mut card, &cfg, "I5100"), Reply::Value(5));
    assert_eq!(cmd(&mut card, &cfg, "I41=0"), Reply::Ack);
    assert_eq!(cmd(&mut card, &cfg, "I130=9"), Reply::Ack);
    assert_eq!(cmd(&mut card, &cfg, "I130"), Reply::Value(9));
}

/// SRM p.57's table, as printed, over every value of I41 (0..15) and both edges of every range
/// and the variables just outside them: a write is ignored exactly when the bit of its range
/// is set. (Issue 35: swapping bits 2 and 3 passed every check, the only scenario setting both
/// at once.)
#[test]
fn every_i41_value_locks_exactly_the_ranges_of_its_bits_at_every_edge() {
    const PRINTED: [(u8, u16, u16); 4] = [(1, 100, 4899), (2, 5100, 6699), (4, 6800, 7999), (8, 8000, 8191)];
    let edges = [99u16, 100, 4899, 4900, 5099, 5100, 6699, 6700, 6799, 6800, 7999, 8000, 8191];
    let cfg = config("lockout", "um-215");
    for i41 in 0u8..16 {
        let mut card = Controller::power_on(&cfg);
        for n in edges {
            assert_eq!(cmd(&mut card, &cfg, &format!("I{n}=0")), Reply::Ack);
        }
        assert_eq!(cmd(&mut card, &cfg, &format!("I41={i41}")), Reply::Ack);
        for n in edges {
            let locked = PRINTED.iter().any(|(bit, first, last)| i41 & bit != 0 && (*first..=*last).contains(&n));
            assert_eq!(cmd(&mut card, &cfg, &format!("I{n}=1")), Reply::Ack, "I41={i41}, I{n}: no error");
            let want = if locked { 0 } else { 1 };
            assert_eq!(cmd(&mut card, &cfg, &format!("I{n}")), Reply::Value(want), "I41={i41}, I{n}");
        }
    }
}

#[test]
fn a_firmware_checksum_fault_sets_bits_12_and_13_and_freezes_x1080() {
    let cfg = config("status", "um-215");
    let mut card = Controller::power_on(&cfg);
    card.apply(&cfg, &Event::ChecksumFault(ChecksumTarget::Firmware));
    servo(&mut card, &cfg, 1);
    card.apply(&cfg, &Event::Background); // the firmware pass ends: mismatch (UM p.217)
    let Reply::Status { x, .. } = cmd(&mut card, &cfg, "???") else { panic!() };
    assert_eq!(x & (1 << 13 | 1 << 12), 1 << 13 | 1 << 12);
    let frozen = cmd(&mut card, &cfg, "RHX:$1080");
    for _ in 0..5 {
        servo(&mut card, &cfg, 1);
        card.apply(&cfg, &Event::Background);
    }
    assert_eq!(cmd(&mut card, &cfg, "RHX:$1080"), frozen, "no checksum operations after an error");
}

#[test]
fn a_user_program_fault_sets_bit_13_with_bit_12_clear_and_closing_a_buffer_first_hides_it() {
    let cfg = config("status", "um-215");
    // Detected: corrupt, then let the engine reach the user-program pass.
    let mut card = Controller::power_on(&cfg);
    card.apply(&cfg, &Event::ChecksumFault(ChecksumTarget::UserProgram));
    for _ in 0..2 {
        servo(&mut card, &cfg, 1);
        card.apply(&cfg, &Event::Background);
    }
    let Reply::Status { x, .. } = cmd(&mut card, &cfg, "???") else { panic!() };
    assert_eq!(x & (1 << 13 | 1 << 12), 1 << 13);
    // Not detected: CLOSE recomputes X:$1090 from the (corrupted) program first (UM p.217).
    let mut card = Controller::power_on(&cfg);
    card.apply(&cfg, &Event::ChecksumFault(ChecksumTarget::UserProgram));
    cmd(&mut card, &cfg, "CLOSE");
    for _ in 0..2 {
        servo(&mut card, &cfg, 1);
        card.apply(&cfg, &Event::Background);
    }
    let Reply::Status { x, .. } = cmd(&mut card, &cfg, "???") else { panic!() };
    assert_eq!(x & (1 << 13), 0);
}

#[test]
fn under_the_rti_strober_reading_a_large_i8_trips_even_a_card_whose_background_keeps_up() {
    // SRM p.57 has the RTI task strobe: edges come only every I8+1 servo cycles, so an RTI
    // period longer than the hardware delay looks like a missing strobe. This is a consequence
    // of that reading worth knowing; the servo-interrupt reading (UM p.215) has no such limit.
    let cfg = config("i40-zero", "srm-57");
    let mut card = Controller::power_on(&cfg);
    assert_eq!(cmd(&mut card, &cfg, "I8=60"), Reply::Ack);
    for _ in 0..70 {
        servo(&mut card, &cfg, 1);
        if card.background_possible() {
            card.apply(&cfg, &Event::Background);
        }
    }
    assert_eq!(card.trip, Some(TripCause::StrobeTimeout));

    let cfg = config("i40-zero", "um-215");
    let mut card = Controller::power_on(&cfg);
    cmd(&mut card, &cfg, "I8=60");
    for _ in 0..70 {
        servo(&mut card, &cfg, 1);
        if card.background_possible() {
            card.apply(&cfg, &Event::Background);
        }
    }
    assert!(!card.tripped());
}

#[test]
fn bootstrap_mode_answers_bootstrap_prom_and_runs_no_servo_tasks() {
    let cfg = config("status", "um-215");
    let mut card = Controller::power_on(&cfg);
    card.apply(
        &cfg,
        &Event::Reset(ResetEvent { kind: ResetKind::Power, dpram_fault: false, flash_fault: false, bootstrap: true }),
    );
    assert_eq!(cmd(&mut card, &cfg, "???"), Reply::Bootstrap);
    assert_eq!(Reply::Bootstrap.to_string(), "BOOTSTRAP PROM");
    servo(&mut card, &cfg, 100);
    assert!(!card.tripped());
}

/// The same history under the two readings of the encoder-loss clear logic (UM p.215, facts
/// s.6): lose the encoder of a closed-loop motor, get it back, re-enable the motor, let the PLC
/// scan. Read as intended the latch clears; read literally it stays until a reset.
#[test]
fn the_two_readings_of_the_encoder_loss_clear_logic_end_differently() {
    use pmacwd_specs::vocab::EncoderInput;
    let mut outcome = Vec::new();
    for profile in ["um-215", "um-215-literal-plc"] {
        let cfg = config("encoder-loss", profile);
        let mut card = Controller::power_on(&cfg);
        let scan = |card: &mut Controller| {
            servo(card, &cfg, 1);
            assert!(card.background_possible());
            card.apply(&cfg, &Event::Background);
        };
        cmd(&mut card, &cfg, "#1J/");
        card.apply(&cfg, &Event::EncoderInput(EncoderInput { motor: 1, lost: true }));
        scan(&mut card);
        let m = card.axes.motors()[0];
        assert!(m.loss_status && !m.amplifier_enabled && m.output_zero, "{profile}: killed and latched");
        card.apply(&cfg, &Event::EncoderInput(EncoderInput { motor: 1, lost: false }));
        cmd(&mut card, &cfg, "#1J/");
        scan(&mut card);
        scan(&mut card);
        outcome.push(card.axes.motors()[0].loss_status);
        card.apply(&cfg, &INIT);
        assert!(!card.axes.motors()[0].loss_status, "{profile}: a reset clears the latch");
    }
    assert_eq!(outcome, [false, true], "intended: cleared; literal: still latched");
}

/// UM p.319: K is not permitted while the motor's C.S. runs a program, but A halts the program
/// and K then kills the motor without any servo cycle in between (UM p.217: begins immediately).
#[test]
fn k_waits_for_the_program_to_stop_and_then_kills_in_the_same_servo_cycle() {
    let cfg = config("motion", "um-215");
    let mut card = Controller::power_on(&cfg);
    for c in ["#1J/", "&1B", "&1R"] {
        assert_eq!(cmd(&mut card, &cfg, c), Reply::Ack, "{c}");
    }
    assert_eq!(cmd(&mut card, &cfg, "#1K"), Reply::Error(1));
    assert!(card.axes.motors()[0].amplifier_enabled);
    cmd(&mut card, &cfg, "&1A");
    assert_eq!(cmd(&mut card, &cfg, "#1K"), Reply::Ack);
    let m = card.axes.motors()[0];
    assert!(!m.amplifier_enabled && m.output_zero && !m.state.moving());
}

/// A trip drives the outputs state, not a reading of the trip flag: the LED, FEFCO/, relay and
/// forced-off outputs are set by the trip rule and cleared by INIT/ (UM p.215).
#[test]
fn a_trip_sets_the_outputs_and_init_clears_them() {
    let cfg = config("motion", "um-215");
    let mut card = Controller::power_on(&cfg);
    cmd(&mut card, &cfg, "#1J/");
    card.apply(&cfg, &Event::Supply { millivolts: 4500 });
    let o = card.outputs;
    assert!(o.led_red && o.fefco_on && o.relay_tripped && o.forced_off);
    assert!(card.axes.motors().iter().all(|m| !m.amplifier_enabled && m.output_zero));
    card.apply(&cfg, &Event::Supply { millivolts: 5000 });
    card.apply(&cfg, &INIT);
    assert_eq!(card.outputs, pmacwd_model::controller::Outputs::default());
}

/// A step's command is read with the addressing a card powers up with (SRM p.259: the
/// examples send `J+` without a `#` first): a bare `K` kills motor 1, a bare `A` aborts C.S. 1.
#[test]
fn a_stop_command_without_its_address_acts_on_motor_1_and_cs_1() {
    let cfg = config("motion", "um-215");
    let mut bare = Controller::power_on(&cfg);
    let mut addressed = Controller::power_on(&cfg);
    for (b, a) in [("#1J+", "#1J+"), ("K", "#1K"), ("A", "&1A")] {
        assert_eq!(cmd(&mut bare, &cfg, b), cmd(&mut addressed, &cfg, a), "{b}");
        assert_eq!(bare, addressed, "{b}");
    }
}

/// UM p.217: the card "continually computes the checksum of its firmware as a background task"
/// and X:$001080 is the running checksum register that an error leaves "frozen". So, before any
/// error, X:$1080 moves with every background cycle; a register that never moved would make
/// the freeze unobservable (found by cargo-mutants: `running_value` returning a constant).
#[test]
fn the_running_checksum_in_x1080_moves_with_every_background_cycle_while_no_error_is_found() {
    // UM p.217
    let cfg = config("status", "um-215");
    let mut card = Controller::power_on(&cfg);
    let mut seen = vec![cmd(&mut card, &cfg, "RHX:$1080")];
    for _ in 0..3 {
        servo(&mut card, &cfg, 1);
        card.apply(&cfg, &Event::Background);
        let now = cmd(&mut card, &cfg, "RHX:$1080");
        assert_ne!(Some(&now), seen.last(), "X:$1080 keeps running while no checksum error is found");
        seen.push(now);
    }
}

/// SRM p.289: X:$000006 bit 20, "Turbo PMAC could not properly complete its servo routines";
/// UM p.236: the servo update costs about 1% of the CPU per motor. So bit 20 is set exactly when
/// the motors' servo work (motors times the cost of one) needs more than the servo cycle has; a
/// load that just fills the cycle completes. The configurations of `check.yaml` all cost one unit
/// per motor, so the cost of one motor is raised here as well (found by cargo-mutants: `>` ->
/// `>=` and `*` -> `/` in the servo load survived).
#[test]
fn bit_20_is_set_exactly_when_the_motors_servo_work_needs_more_than_the_servo_cycle_has() {
    // SRM p.289, UM p.236
    let base = config("status", "um-215");
    let (word, bit) = base.layout.servo_error;
    assert_eq!((word, bit), (pmacwd_specs::status::WordId::X, 20));
    for (units_per_motor, motors, expected) in [(1, 4, false), (1, 5, true), (2, 2, false), (2, 3, true)] {
        let mut cfg = base.clone();
        cfg.cpu.servo_units_per_motor = units_per_motor;
        assert_eq!(cfg.cpu.cycle_units, 4);
        let mut card = Controller::power_on(&cfg);
        card.apply(&cfg, &Event::Load(Load { motors, plc0_units: 0, background_units: 1 }));
        servo(&mut card, &cfg, 1);
        let Reply::Status { x, .. } = cmd(&mut card, &cfg, "???") else { panic!("??? answers") };
        assert_eq!(
            x & (1 << 20) != 0,
            expected,
            "{motors} motors at {units_per_motor} units each against a cycle of 4 units: X:$000006 = {x:06X}"
        );
    }
}

/// UM p.236: "Every time Turbo PMAC starts executing a new move, it sets an internal flag
/// indicating that it is time to plan the next move in the program. This planning occurs at the
/// next RTI", alongside PLC 0, so while a program executes moves the RTI's task set is PLC 0
/// plus the planning; with no program running there is nothing to plan. With I8 = 1 an RTI
/// period has 6 free units: PLC 0 alone at 4 units finishes in time, PLC 0 with 3 units of
/// planning does not, and the next RTI finds it still executing (SRM p.289, bit 22). The
/// configurations of `check.yaml` all plan at no cost, so the cost is set here (found by
/// cargo-mutants: `+` -> `-` in the RTI task set survived). Before issue 35 the planning was
/// charged whether or not a program ran, so the case without a program overran too.
#[test]
fn move_planning_adds_to_plc0_in_the_rti_while_a_program_runs_and_can_make_it_overrun_its_period() {
    // UM p.236, SRM p.289
    let base = config("motion", "um-215");
    for (planning, program, overrun) in [(0, true, false), (3, true, true), (3, false, false)] {
        let mut cfg = base.clone();
        cfg.saved.i8 = 1;
        cfg.cpu = pmacwd_specs::check::Cpu { cycle_units: 4, servo_units_per_motor: 1, move_planning_units: planning };
        let mut card = Controller::power_on(&cfg);
        if program {
            for text in ["#1J/", "#2J/", "&1B", "&1R"] {
                assert_eq!(cmd(&mut card, &cfg, text), Reply::Ack, "{text}");
            }
            assert!(card.axes.plans_moves(), "the program of &1 runs");
        }
        card.apply(&cfg, &Event::Load(Load { motors: 1, plc0_units: 4, background_units: 3 }));
        servo(&mut card, &cfg, 4);
        let Reply::Status { x, .. } = cmd(&mut card, &cfg, "???") else { panic!("??? answers") };
        assert_eq!(
            x & (1 << 22) != 0,
            overrun,
            "PLC 0 = 4 units, planning = {planning}, program running: {program}: X:$000006 = {x:06X}"
        );
    }
}

/// SRM p.42 (I9): the card reports an I-variable "as the value alone", so `I8`, `I40` and `I41`
/// answer with the value each holds: the saved one after power-on, the new one after a write
/// (SRM p.57: I41 itself is always writable). Found by cargo-mutants: the model's read of I8
/// could fall through to the table of other I-variables (reading 0) and nothing noticed, since
/// no scenario or configuration reads I8 back.
#[test]
fn i8_i40_and_i41_read_back_the_saved_value_after_power_on_and_the_written_value_after_a_write() {
    // SRM p.42, SRM p.57
    let cfg = config("status", "um-215");
    let mut card = Controller::power_on(&cfg);
    let saved = [("I8", i64::from(cfg.saved.i8)), ("I40", i64::from(cfg.saved.i40)), ("I41", i64::from(cfg.saved.i41))];
    for (name, value) in saved {
        assert_eq!(cmd(&mut card, &cfg, name), Reply::Value(value), "{name} after power-on");
    }
    for (name, value) in [("I8", 7), ("I40", 1000), ("I41", 2)] {
        assert_eq!(cmd(&mut card, &cfg, &format!("{name}={value}")), Reply::Ack);
        assert_eq!(cmd(&mut card, &cfg, name), Reply::Value(value), "{name} after {name}={value}");
    }
}

/// SRM p.42 gives I8 the range 0 to 255 and SRM p.57 gives I40 "Range: 0 65,535". MODEL (the
/// manuals do not say what the firmware does with a value outside): the write is refused with
/// ERR003 and the variable keeps its value, rather than the value being truncated to the
/// variable's width (I8=256 would become 0, an RTI every servo cycle). Found by cargo-mutants:
/// the range guard of I8 could be dropped and nothing noticed; I41's has a scenario.
#[test]
fn an_i8_or_i40_beyond_its_documented_range_is_refused_with_err003_and_keeps_its_value() {
    // SRM p.42, SRM p.57
    let cfg = config("status", "um-215");
    assert_eq!((cfg.i8_range, cfg.i40_range), ((0, 255), (0, 65_535)));
    let mut card = Controller::power_on(&cfg);
    for (name, beyond) in [("I8", 256), ("I8", -1), ("I40", 65_536), ("I40", -1)] {
        let before = cmd(&mut card, &cfg, name);
        assert_eq!(cmd(&mut card, &cfg, &format!("{name}={beyond}")), Reply::Error(3), "{name}={beyond}");
        assert_eq!(cmd(&mut card, &cfg, name), before, "{name} keeps its value after {name}={beyond}");
    }
}

/// UM p.243 ("Limited Range"): an out-of-range assignment causes no error and is rolled over
/// into the range by modulo arithmetic (I3=5 gives 1 of I3's 0 to 3). Under the reading
/// `out_of_range_assignment: modulo` the model does so for the ranges it knows (I8, I40, I41);
/// under `error` (every other profile's) the test above holds instead.
#[test]
fn under_the_modulo_reading_an_out_of_range_assignment_rolls_over_without_an_error() {
    use pmacwd_specs::profiles::OutOfRangeAssignment;
    assert_eq!(config("lockout", "um-215").out_of_range(), OutOfRangeAssignment::Error, "the default's reading");
    // The named profile that chooses it (profiles.yaml); the configuration reads the choice.
    let cfg = config("lockout", "um-243-modulo");
    assert_eq!(cfg.out_of_range(), OutOfRangeAssignment::Modulo);
    let mut card = Controller::power_on(&cfg);
    for (write, name, stored) in [
        ("I41=16", "I41", 0),
        ("I41=17", "I41", 1),
        ("I41=-1", "I41", 15),
        ("I40=65536", "I40", 0),
        ("I40=65537", "I40", 1),
        ("I8=256", "I8", 0),
        ("I8=-1", "I8", 255),
        ("I8=258", "I8", 2),
    ] {
        assert_eq!(cmd(&mut card, &cfg, write), Reply::Ack, "{write}: no error (UM p.243)");
        assert_eq!(cmd(&mut card, &cfg, name), Reply::Value(stored), "{write} rolls over to {stored}");
    }
    // In range, and past the lockout (SRM p.57: a memory write), as under `error`.
    assert_eq!(cmd(&mut card, &cfg, "I41=3"), Reply::Ack);
    assert_eq!(cmd(&mut card, &cfg, "<MEMORY-WRITE I41=20>"), Reply::Ack);
    assert_eq!(cmd(&mut card, &cfg, "I41"), Reply::Value(4));
}

/// UM p.215: "If the supply voltage is below this value, the circuit's relay will trip and the
/// card will shut down." Below, not at: a supply exactly at the threshold keeps the card running,
/// one millivolt less trips it. Found by cargo-mutants: `<` -> `<=` in the supply check survived,
/// since the configurations only offer supplies well above or well below the threshold.
#[test]
fn a_supply_exactly_at_the_threshold_keeps_the_card_running_and_one_millivolt_below_trips_it() {
    // UM p.215
    let cfg = config("timing", "um-215");
    let threshold = cfg.supply_min_millivolts;
    let mut card = Controller::power_on(&cfg);
    card.apply(&cfg, &Event::Supply { millivolts: threshold });
    assert!(!card.tripped(), "{threshold} mV is not below {threshold} mV");
    card.apply(&cfg, &Event::Supply { millivolts: threshold - 1 });
    assert_eq!(card.trip, Some(TripCause::Undervoltage));
}

/// UM p.217: the checksum computed in the background is compared with the reference, and only
/// a mismatch sets bits 12 and 13. MODEL (shared with the core): an injected fault flips one bit
/// of the area's memory, so a second fault on the same area before the pass reaches it restores
/// the memory and the comparison finds nothing, while one fault is found. Found by
/// cargo-mutants: the firmware fault as a stuck bit (`^=` -> `|=`) survived; the user-program
/// fault's was caught only by a pinned state count.
#[test]
fn two_faults_on_the_same_area_restore_its_memory_and_the_checksum_pass_finds_no_error() {
    // UM p.217
    let cfg = config("status", "um-215");
    for (area, faults, error) in [
        (ChecksumTarget::Firmware, 1, true),
        (ChecksumTarget::Firmware, 2, false),
        (ChecksumTarget::UserProgram, 1, true),
        (ChecksumTarget::UserProgram, 2, false),
    ] {
        let mut card = Controller::power_on(&cfg);
        for _ in 0..faults {
            card.apply(&cfg, &Event::ChecksumFault(area));
        }
        for _ in 0..2 {
            servo(&mut card, &cfg, 1);
            card.apply(&cfg, &Event::Background); // both passes (one cycle each) end
        }
        let Reply::Status { x, .. } = cmd(&mut card, &cfg, "???") else { panic!("??? answers") };
        assert_eq!(x & (1 << 13) != 0, error, "{faults} fault(s) on {area:?}: X:$000006 = {x:06X}");
    }
}

/// UM p.217's table of stop commands, as the model looks a row up: each stop command finds its
/// own row (`stop_rules_match_the_table` checks the rows against `specs/stop_commands.yaml`),
/// and a command that starts motion finds none. Found by cargo-mutants: `motion::rule`, which
/// no rule of the model calls, could return `None` or the wrong row and nothing noticed.
#[test]
fn every_stop_command_of_the_um_217_table_finds_its_own_row_and_a_jog_finds_none() {
    // UM p.217
    for (text, row) in [
        ("#1K", Some("K")),
        ("#1J/", Some("J/")),
        ("&1A", Some("A")),
        ("&1Q", Some("Q")),
        ("&1H", Some("H")),
        ("#1J+", None),
    ] {
        let HostCommand::Motion(m) = HostCommand::parse(text).expect("command parses") else {
            panic!("{text} is a motion command")
        };
        assert_eq!(pmacwd_model::motion::rule(m).map(|r| r.command), row, "{text}");
    }
}

/// MODEL (model/src/motion.rs, `Axes::command`): a motor the configuration does not have is not
/// set up (Ixx00 = 0, motor not activated), so a command to it is acknowledged and does nothing:
/// the motors the card has keep their state and the card keeps running. Found by cargo-mutants:
/// the bound `k < motors` as `k <= motors` survived (the motor just past the last one would be
/// indexed), since no configuration addresses a motor it does not have.
#[test]
fn a_command_to_the_motor_just_past_the_last_one_is_acknowledged_and_changes_nothing() {
    let cfg = config("motion", "um-215");
    assert_eq!(cfg.motion.motors, 2);
    let mut card = Controller::power_on(&cfg);
    assert_eq!(cmd(&mut card, &cfg, "#1J/"), Reply::Ack);
    let before = card.axes.view();
    for text in ["#3J+", "#3J/", "#3K"] {
        assert_eq!(cmd(&mut card, &cfg, text), Reply::Ack, "{text}");
        assert_eq!(card.axes.view(), before, "{text} changes no motor");
    }
    assert!(!card.tripped());
}

/// One servo cycle of a healthy card: the servo interrupt, then a background cycle if one can
/// complete (keeps the watchdog of the small configurations satisfied).
fn healthy_cycle(c: &mut Controller, cfg: &ModelConfig) {
    servo(c, cfg, 1);
    if c.background_possible() {
        c.apply(cfg, &Event::Background);
    }
}

/// What a coordinate system's program and its motor 1 stand at (UM p.217, p.319).
fn cs1(c: &Controller) -> (pmacwd_model::motion::Program, pmacwd_specs::vocab::observation::MotorState) {
    (c.axes.programs()[0], c.axes.motors()[0].state)
}

/// MODEL (model/src/motion.rs, `cs_command`; UM p.319: a program "could be resumed with an R or
/// S command"): a program starts only when one is pointed at (B) and every motor of the
/// coordinate system is closed-loop at rest, and a non-zero `%` resumes only a program held by H
/// or `%0`: it does not start a program standing at a point. Found by cargo-mutants: R's
/// "pointed at and not running" joined with `||`, and `%n` falling through to R's rule, survived.
#[test]
fn r_starts_a_program_only_with_every_motor_closed_loop_at_rest_and_a_feedrate_only_resumes_a_held_one() {
    // UM p.319, UM p.217
    use pmacwd_model::motion::Program;
    use pmacwd_specs::vocab::observation::MotorState;
    let cfg = config("motion", "um-215");
    let mut card = Controller::power_on(&cfg);
    cmd(&mut card, &cfg, "#1J/");
    cmd(&mut card, &cfg, "&1R");
    assert_eq!(cs1(&card), (Program::None, MotorState::Closed), "R with no program pointed at starts nothing");
    cmd(&mut card, &cfg, "#1K");
    assert_eq!(cmd(&mut card, &cfg, "&1B"), Reply::Ack);
    assert_eq!(cs1(&card), (Program::AtPoint, MotorState::Killed));
    cmd(&mut card, &cfg, "&1R");
    assert_eq!(cs1(&card), (Program::AtPoint, MotorState::Killed), "R with motor 1 killed starts nothing");
    cmd(&mut card, &cfg, "#1J/");
    assert_eq!(cs1(&card), (Program::AtPoint, MotorState::Closed));
    cmd(&mut card, &cfg, "&1%100");
    assert_eq!(cs1(&card), (Program::AtPoint, MotorState::Closed), "%100 does not start a program at a point");
    cmd(&mut card, &cfg, "&1R");
    assert_eq!(cs1(&card), (Program::Running, MotorState::Program), "R does");
}

/// UM p.217: Q "finishes calculated moves" and stops at a program point: the calculated moves
/// are what they were, so a second Q while they finish neither restarts nor postpones the stop.
/// With decelerations of 2 servo cycles the program stands at its point 2 cycles after the
/// first Q, whatever Q follows. Found by cargo-mutants: `m.state == Program && m.stop.is_none()`
/// as `||` (a second Q restarting the countdown) survived.
#[test]
fn a_second_q_while_the_calculated_moves_finish_does_not_postpone_the_stop() {
    // UM p.217
    use pmacwd_model::motion::Program;
    use pmacwd_specs::vocab::observation::MotorState;
    let cfg = config("motion", "um-215");
    assert_eq!(cfg.motion.decel_cycles_max, 2);
    let mut card = Controller::power_on(&cfg);
    for text in ["#1J/", "&1B", "&1R"] {
        assert_eq!(cmd(&mut card, &cfg, text), Reply::Ack, "{text}");
    }
    assert_eq!(cs1(&card), (Program::Running, MotorState::Program));
    cmd(&mut card, &cfg, "&1Q");
    healthy_cycle(&mut card, &cfg);
    cmd(&mut card, &cfg, "&1Q");
    assert_eq!(cs1(&card), (Program::Running, MotorState::Program), "one cycle after the first Q");
    healthy_cycle(&mut card, &cfg);
    assert!(!card.tripped());
    assert_eq!(cs1(&card), (Program::AtPoint, MotorState::Closed), "two cycles after the first Q");
}

/// SRM p.57: "Because I41 is typically set before any of the variables it controls, if it has
/// a non-zero value in this list, some of the subsequent variables will not get set." A
/// download of a saved list in the usual order (I41 first, then the rest): with I41 = 1 in the
/// list, the motor setup variables after it keep their values, the others take the list's; the
/// same list with I41 = 0 sets every one.
#[test]
fn a_download_that_sets_i41_first_leaves_the_variables_it_locks_unset() {
    let cfg = config("lockout", "um-215");
    let download = |i41: u8| {
        let mut card = Controller::power_on(&cfg);
        // What the card held before the download.
        for line in ["I130=1", "I4899=1", "I5100=1", "I6800=1"] {
            assert_eq!(cmd(&mut card, &cfg, line), Reply::Ack);
        }
        for line in [format!("I41={i41}"), "I130=9".into(), "I4899=9".into(), "I5100=9".into(), "I6800=9".into()] {
            assert_eq!(cmd(&mut card, &cfg, &line), Reply::Ack, "SRM p.57: a locked write is no error: {line}");
        }
        ["I130", "I4899", "I5100", "I6800"].map(|n| cmd(&mut card, &cfg, n))
    };
    // I41 bit 0 locks I100..I4899 (SRM p.57's table): those two did not get set.
    assert_eq!(download(1), [Reply::Value(1), Reply::Value(1), Reply::Value(9), Reply::Value(9)]);
    assert_eq!(download(0), [Reply::Value(9); 4]);
}

/// UM p.236: "At the default, the servo update of each motor takes approximately 1% of Turbo
/// PMAC's computational power." The configurations with the real counter run at the default
/// servo clock and charge each motor that share of the cycle (the small ones charge 1 of 4
/// units per motor to keep their state spaces small); the model charges it per motor, every
/// servo cycle, before the RTI and the background get any.
#[test]
fn the_configurations_with_the_real_counter_charge_each_motor_s_servo_update_the_default_share_of_the_cycle() {
    let spec = Spec::embedded().unwrap();
    let percent = spec.scheduling.servo_cost_per_motor_percent.value;
    let default_hz = spec.scheduling.servo_clock_hz.value;
    for configuration in ["i40-zero", "host-log"] {
        let cfg = config(configuration, "um-215");
        assert_eq!(f64::from(cfg.servo_hz), default_hz, "{configuration} runs at the default servo clock");
        let share = 100.0 * f64::from(cfg.cpu.servo_units_per_motor) / f64::from(cfg.cpu.cycle_units);
        assert_eq!(share, percent, "{configuration}: the servo update of one motor takes {share}% of a cycle");
        // The rule: with m motors the background gets the cycle less m shares (no RTI work).
        for motors in [1u8, 8] {
            let mut card = Controller::power_on(&cfg);
            card.apply(&cfg, &Event::Load(Load { motors, plc0_units: 0, background_units: 1000 }));
            servo(&mut card, &cfg, 1);
            let expected =
                u32::from(cfg.cpu.cycle_units) - u32::from(motors) * u32::from(cfg.cpu.servo_units_per_motor);
            assert_eq!(card.background_credit, expected, "{configuration}, {motors} motors");
        }
    }
}

/// UM p.236: the servo update first, the RTI tasks ("the fourth highest priority", right after
/// the servo update) next, and "the background tasks" with what is left. With a cycle of 4
/// units, 1 motor at 1 unit and PLC 0 at 5 units, I8 = 1 (an RTI every 2 cycles, the first at
/// the second cycle after power-on): the first cycle has no RTI and the background gets the 3
/// units the servo update leaves; the second cycle's RTI takes those 3 and the background gets
/// none; the third finishes PLC 0 with 2 units and the background gets the last 1.
#[test]
fn the_servo_update_runs_first_the_rti_tasks_next_and_the_background_gets_what_is_left() {
    let cfg = config("timing", "um-215");
    assert_eq!((cfg.cpu.cycle_units, cfg.cpu.servo_units_per_motor, cfg.saved.i8), (4, 1, 1));
    let mut card = Controller::power_on(&cfg);
    card.apply(&cfg, &Event::Load(Load { motors: 1, plc0_units: 5, background_units: 100 }));
    servo(&mut card, &cfg, 1);
    assert_eq!((card.rti_remaining, card.background_credit), (0, 3), "cycle 1: no RTI yet");
    servo(&mut card, &cfg, 1);
    assert_eq!(
        (card.rti_remaining, card.background_credit),
        (2, 3),
        "cycle 2: the RTI takes all the servo update leaves"
    );
    servo(&mut card, &cfg, 1);
    assert_eq!(
        (card.rti_remaining, card.background_credit),
        (0, 4),
        "cycle 3: PLC 0 finishes, the background gets the rest"
    );
    // A servo update that takes the whole cycle leaves the RTI nothing (and the background
    // nothing): the RTI's work waits.
    let mut card = Controller::power_on(&cfg);
    card.apply(&cfg, &Event::Load(Load { motors: 4, plc0_units: 1, background_units: 3 }));
    servo(&mut card, &cfg, 2);
    assert_eq!((card.rti_remaining, card.background_credit), (1, 0));
}

/// UM p.236: the background's tasks are command processing, the PLC programs and
/// housekeeping, one PLC scan each background cycle with housekeeping between scans; UM p.240
/// and p.215: the housekeeping reloads the watchdog counter. A completed background cycle
/// reloads the counter and scans the encoder-loss PLC (which kills a closed-loop motor whose
/// encoder is lost, UM p.214-215); servo cycles and host commands without one do neither.
#[test]
fn a_background_cycle_reloads_the_counter_and_scans_the_plc_and_nothing_else_does() {
    let cfg = config("encoder-loss", "um-215");
    let mut card = Controller::power_on(&cfg);
    assert_eq!(cmd(&mut card, &cfg, "#1J/"), Reply::Ack);
    servo(&mut card, &cfg, 1);
    let reload = card.counter + 1;
    card.apply(&cfg, &Event::EncoderInput(pmacwd_specs::vocab::EncoderInput { motor: 1, lost: true }));
    // Servo cycles and a command, no background cycle: no reload, no scan.
    servo(&mut card, &cfg, 1);
    let _ = cmd(&mut card, &cfg, "???");
    assert_eq!(card.counter, reload - 2, "the counter only counts down between background cycles");
    let m = card.axes.motors()[0];
    assert!(m.state != pmacwd_specs::vocab::MotorState::Killed && !m.loss_status, "no scan yet: {m:?}");
    assert!(card.background_possible(), "the load lets a background cycle complete");
    card.apply(&cfg, &Event::Background);
    assert_eq!(card.counter, reload, "the background cycle's housekeeping reloads the counter");
    let m = card.axes.motors()[0];
    assert!(m.state == pmacwd_specs::vocab::MotorState::Killed && m.loss_status, "the scan killed and latched: {m:?}");
}

/// MODEL (model/src/motion.rs, `cs_start`, `CsCommand::Enable`; docs/grammar.md, `E`): the
/// EPICS driver's `&nE` closes the loop of each killed motor of C.S. n, as `J/` closes a killed
/// motor's (UM p.319: re-enabling is closing the servo loops), and clears the amplifier-fault
/// status bit of a motor it re-enables (UM p.213). Motors of another C.S. stay killed; a
/// jogging or closed motor of the C.S., and its program, are left as they are.
#[test]
fn e_closes_the_loop_of_each_killed_motor_of_its_coordinate_system_and_of_no_other() {
    // UM p.319, UM p.213, SRM p.281
    use pmacwd_model::motion::Program;
    use pmacwd_specs::vocab::event::AmplifierFaultInput;
    use pmacwd_specs::vocab::observation::MotorState;
    let cfg = config("amplifier-fault", "um-215");
    assert_eq!((cfg.motion.coordinate_system(1), cfg.motion.coordinate_system(2)), (1, 2));
    let mut card = Controller::power_on(&cfg);
    let states = |c: &Controller| (c.axes.motors()[0].state, c.axes.motors()[1].state);
    assert_eq!(states(&card), (MotorState::Killed, MotorState::Killed), "motors power up killed");
    assert_eq!(cmd(&mut card, &cfg, "&1E"), Reply::Ack);
    assert_eq!(states(&card), (MotorState::Closed, MotorState::Killed), "&1E enables #1 (in &1) only");
    let m1 = card.axes.motors()[0];
    assert!(m1.amplifier_enabled && !m1.output_zero);
    // A jogging motor of the C.S. goes on jogging; a closed one stays closed.
    cmd(&mut card, &cfg, "#1J+");
    cmd(&mut card, &cfg, "&1E");
    assert_eq!(states(&card), (MotorState::Jogging, MotorState::Killed), "&1E does not stop a jog");
    cmd(&mut card, &cfg, "&2E");
    assert_eq!(states(&card), (MotorState::Jogging, MotorState::Closed), "&2E enables #2 and leaves #1's jog");
    cmd(&mut card, &cfg, "&2E");
    assert_eq!(states(&card), (MotorState::Jogging, MotorState::Closed), "a second &2E changes nothing");
    // UM p.213: the fault kills #2 and sets its status bit; E re-enables it and clears the bit.
    card.apply(&cfg, &Event::AmplifierFault(AmplifierFaultInput { motor: 2, fault: true }));
    healthy_cycle(&mut card, &cfg);
    assert_eq!(card.axes.motors()[1].state, MotorState::Killed);
    assert!(card.axes.motors()[1].fault_status);
    card.apply(&cfg, &Event::AmplifierFault(AmplifierFaultInput { motor: 2, fault: false }));
    cmd(&mut card, &cfg, "&2E");
    assert_eq!(card.axes.motors()[1].state, MotorState::Closed);
    assert!(!card.axes.motors()[1].fault_status, "re-enabled: the fault status bit clears (UM p.213)");
    // E touches no program: &2 points at one, and E neither starts nor loses it.
    cmd(&mut card, &cfg, "&2B");
    cmd(&mut card, &cfg, "&2E");
    assert_eq!(card.axes.programs()[1], Program::AtPoint);
    assert_eq!(card.axes.motors()[1].state, MotorState::Closed);
    assert!(!card.tripped());
}

#[test]
fn a_command_no_background_cycle_reached_is_silence_from_a_running_card_and_the_card_answers_again() {
    // UM p.236: host commands are processed in the background, so a card whose background is
    // starved answers nothing ("communications become sluggish") while its servo cycles run
    // on; it trips only once the counter has run out (UM p.215).
    let cfg = config("host-log", "um-215");
    let mut card = Controller::power_on(&cfg);
    card.apply(&cfg, &Event::Background);
    let counter = card.counter;
    assert!(counter > 100, "the counter is reloaded: {counter}");
    assert_eq!(card.unanswered(&cfg, 50), Reply::Silence);
    assert_eq!(
        card.counter,
        counter - 50,
        "the servo cycles ran through the wait, and no background cycle reloaded it"
    );
    assert!(!card.tripped(), "a wait shorter than the counter's run leaves the card running");
    card.apply(&cfg, &Event::Background);
    assert!(matches!(cmd(&mut card, &cfg, "???"), Reply::Status { .. }), "the next background cycle answers");
    // A wait past the counter and the hardware delay: the card tripped in it, and answers
    // nothing until reset (UM p.215).
    let long = u32::try_from(card.counter).expect("reloaded") + cfg.hardware_delay_cycles + 3;
    assert_eq!(card.unanswered(&cfg, long), Reply::Silence);
    assert!(card.tripped());
    card.apply(&cfg, &Event::Background);
    assert_eq!(cmd(&mut card, &cfg, "???"), Reply::Silence);
}
