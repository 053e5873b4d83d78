//! The I-variable stores the core delegates to, and the size of the core itself.

mod common;

use common::realistic_config as config;
use pmacwd_core::{AllIVariables, Area, Command, Core, Event, FewIVariables, Load, Register, Reply};

/// The design asks for the state "packed into a few machine words": the I-variable store is
/// outside the core, so copying a core (as `advance` benchmarks and checkers do) stays cheap.
/// The watchdog is 59 bytes (64 with padding: eleven words, among them the two of the quiet
/// stretch, and fifteen bytes) and the motion of eight motors and sixteen coordinate systems 32
/// (`motion.rs`: a byte per motor, a byte of stop length per motor, three bits per program,
/// four one-bit-per-motor masks).
#[test]
fn the_core_state_fits_in_twelve_machine_words() {
    assert!(core::mem::size_of::<Core>() <= 96, "Core is {} bytes", core::mem::size_of::<Core>());
    assert!(
        core::mem::size_of::<pmacwd_core::motion::Motion>() <= 32,
        "Motion is {} bytes",
        core::mem::size_of::<pmacwd_core::motion::Motion>()
    );
}

/// A small store holds the variables written since the last reset, zero included (a value
/// the log wrote is known, whatever it is); when it is full the next write answers ERR003 and
/// the value is not half-stored. A variable never written reads as the card's own.
#[test]
fn a_full_small_store_refuses_the_next_write_with_err003_and_forgetting_frees_a_slot() {
    let cfg = config();
    let mut core = Core::power_on(&cfg);
    let mut store = FewIVariables::<2>::default();
    let cmd = |core: &mut Core, store: &mut FewIVariables<2>, c| core.apply(&cfg, Event::Command(c), store);
    assert_eq!(cmd(&mut core, &mut store, Command::ReadI(130)), Reply::CardOwn, "never written: the card's own");
    assert_eq!(cmd(&mut core, &mut store, Command::WriteI(130, 0)), Reply::Ack);
    assert_eq!(cmd(&mut core, &mut store, Command::ReadI(130)), Reply::Value(0), "zero is a value the log wrote");
    assert_eq!(cmd(&mut core, &mut store, Command::WriteI(131, 6)), Reply::Ack);
    assert_eq!(cmd(&mut core, &mut store, Command::WriteI(132, 7)), Reply::Error(3));
    assert_eq!(cmd(&mut core, &mut store, Command::ReadI(132)), Reply::CardOwn);
    let forget = Command::CardOwn { forgets: Some((130, 1, 1)), past_lockout: false };
    assert_eq!(cmd(&mut core, &mut store, forget), Reply::CardOwn);
    assert_eq!(
        cmd(&mut core, &mut store, Command::ReadI(130)),
        Reply::CardOwn,
        "written with a value the core cannot compute"
    );
    assert_eq!(cmd(&mut core, &mut store, Command::WriteI(132, 7)), Reply::Ack, "the freed slot");
    assert_eq!(cmd(&mut core, &mut store, Command::ReadI(131)), Reply::Value(6));
    assert_eq!(cmd(&mut core, &mut store, Command::ReadI(132)), Reply::Value(7));
}

/// `$$$` resets the card: I-variables go back to their saved values, which this core does not
/// know (the card's own), in the store too; I8, I40 and I41 to theirs inside the core.
#[test]
fn a_reset_command_restores_the_stored_i_variables() {
    let cfg = config();
    let mut core = Core::power_on(&cfg);
    let mut store = Box::<AllIVariables>::default();
    assert_eq!(core.apply(&cfg, Event::Command(Command::WriteI(8191, -3)), &mut *store), Reply::Ack);
    assert_eq!(core.apply(&cfg, Event::Command(Command::ReadI(8191)), &mut *store), Reply::Value(-3));
    core.apply(&cfg, Event::Command(Command::Reset), &mut *store);
    assert_eq!(core.apply(&cfg, Event::Command(Command::ReadI(8191)), &mut *store), Reply::CardOwn);
}

/// `$$$***` puts the factory defaults in use (UM p.243): in both stores every I-variable the
/// core does not keep itself is unknown afterwards (the card's own default). (The small store
/// was once left holding its values; only this test notices.)
#[test]
fn reinitialization_puts_the_factory_defaults_in_use_in_either_store() {
    let cfg = config();
    let mut core = Core::power_on(&cfg);
    let mut few = FewIVariables::<2>::default();
    let mut all = Box::<AllIVariables>::default();
    for (c, expected) in [
        (Command::WriteI(130, 5), Reply::Ack),
        (Command::ReadI(130), Reply::Value(5)),
        (Command::Reinitialize, Reply::None),
        (Command::ReadI(130), Reply::CardOwn),
    ] {
        assert_eq!(core.apply(&cfg, Event::Command(c), &mut few), expected, "small store: {c:?}");
    }
    let mut core = Core::power_on(&cfg);
    for (c, expected) in [
        (Command::WriteI(130, 5), Reply::Ack),
        (Command::Reinitialize, Reply::None),
        (Command::ReadI(130), Reply::CardOwn),
    ] {
        assert_eq!(core.apply(&cfg, Event::Command(c), &mut *all), expected, "full store: {c:?}");
    }
}

/// `I{n}=*` (SRM on-line commands): I40 to its factory default through the core, any other
/// I-variable unknown; both ignored while I41 locks them (SRM p.57).
#[test]
fn a_default_write_restores_i40_and_forgets_others_unless_locked() {
    let cfg = config();
    let mut core = Core::power_on(&cfg);
    let mut store = FewIVariables::<4>::default();
    let mut cmd = |c| core.apply(&cfg, Event::Command(c), &mut store);
    assert_eq!(cmd(Command::WriteI(40, 9)), Reply::Ack);
    assert_eq!(cmd(Command::WriteI(130, 9)), Reply::Ack);
    assert_eq!(cmd(Command::DefaultI(40)), Reply::Ack);
    assert_eq!(cmd(Command::ReadI(40)), Reply::Value(0));
    assert_eq!(cmd(Command::WriteI(41, 1)), Reply::Ack, "I41 bit 0 locks I100-I4899 (SRM p.57)");
    assert_eq!(cmd(Command::DefaultI(130)), Reply::Ack);
    assert_eq!(cmd(Command::ReadI(130)), Reply::Value(9), "locked: ignored");
    assert_eq!(cmd(Command::WriteI(41, 0)), Reply::Ack);
    assert_eq!(cmd(Command::DefaultI(130)), Reply::Ack);
    assert_eq!(cmd(Command::ReadI(130)), Reply::CardOwn);
}

/// SRM p.289: the first reply character is bits 23-20 of X:$000006, the twelfth bits 3-0 of
/// Y:$000006; RTI re-entry (X bit 22) alone reads `400000000000`.
#[test]
fn the_status_reply_text_puts_x_first_most_significant_nibble_first() {
    assert_eq!(&Reply::status_text(1 << 22, 0), b"400000000000");
    assert_eq!(&Reply::status_text(0x123456, 0x789ABC), b"123456789ABC");
    assert_eq!(&Reply::status_text(0, 1 << 17), b"000000020000");
}

/// The CPU a servo cycle leaves to the RTI and the background is the cycle's units less the
/// servo update's, about 1% of the CPU a motor (UM p.236), and none when the servo update does
/// not fit (SRM p.289 bit 20). The emulator's `starve` fills exactly this with PLC 0.
#[test]
fn the_spare_units_are_the_cycle_less_the_servo_update_of_every_motor() {
    let cfg = config();
    let mut core = Core::power_on(&cfg);
    let mut store = FewIVariables::<2>::default();
    let expected = |motors: u8| {
        u32::from(cfg.cycle_units).saturating_sub(u32::from(motors) * u32::from(cfg.servo_units_per_motor))
    };
    for motors in [0u8, 1, 8, 255] {
        let load = Load { motors, ..cfg.load };
        core.apply(&cfg, Event::Load(load), &mut store);
        assert_eq!(core.spare_units(), expected(motors), "{motors} motors");
    }
    assert!(expected(1) > 1 && expected(8) < expected(1), "the configuration tells the values apart");
}

/// SRM p.289 bit 20: the servo update could not complete. A servo load that fills the cycle
/// exactly still completes (no bit, nothing spare); one unit more does not.
#[test]
fn bit_20_is_set_only_when_the_servo_update_needs_more_than_the_cycle() {
    let mut cfg = config();
    cfg.cycle_units = 80;
    cfg.servo_units_per_motor = 10;
    let mut store = FewIVariables::<2>::default();
    for (motors, error) in [(7u8, false), (8, false), (9, true)] {
        let mut core = Core::power_on(&cfg);
        core.apply(&cfg, Event::Load(Load { motors, ..cfg.load }), &mut store);
        core.servo_cycle(&cfg);
        let (x, _) = core.status_words(&cfg);
        assert_eq!(x & pmacwd_core::bits::SERVO_ERROR != 0, error, "{motors} motors of 10 units in a cycle of 80");
    }
}

/// UM p.217: X:$1090 holds "the checksum value that was computed the last time one of these
/// buffers was closed". A user-program fault leaves the reference at the factory checksum
/// (`RHX:$1090` reads 0); CLOSE then takes the corrupted program's checksum into it (reads 1),
/// so the user-program pass that follows finds no mismatch (bit 13 stays clear, as the model's
/// story in `model/tests/semantics.rs` has it); without the CLOSE the same passes find it.
/// Nothing else read X:$1090 once it held 1.
#[test]
fn close_takes_the_program_checksum_into_x_1090() {
    let cfg = config();
    let mut store = FewIVariables::<2>::default();
    let reference = |core: &mut Core, store: &mut FewIVariables<2>| {
        core.apply(&cfg, Event::Command(Command::ReadHex(Register::ProgramChecksumReference)), store)
    };
    // Two firmware passes and two user-program passes, then bit 13 (SRM p.289).
    let checksum_error_after_passes = |core: &mut Core| {
        for _ in 0..6 {
            while !core.background_possible() {
                core.servo_cycle(&cfg);
            }
            core.background_cycle(&cfg);
        }
        core.status_words(&cfg).0 & pmacwd_core::bits::CHECKSUM_ERROR != 0
    };
    let mut core = Core::power_on(&cfg);
    core.apply(&cfg, Event::ChecksumFault(Area::UserProgram), &mut store);
    assert!(checksum_error_after_passes(&mut core), "without CLOSE the fault is found");

    let mut core = Core::power_on(&cfg);
    assert_eq!(reference(&mut core, &mut store), Reply::Hex(0));
    core.apply(&cfg, Event::ChecksumFault(Area::UserProgram), &mut store);
    assert_eq!(reference(&mut core, &mut store), Reply::Hex(0), "a fault does not touch the reference");
    assert_eq!(core.apply(&cfg, Event::Command(Command::Close), &mut store), Reply::Ack);
    assert_eq!(reference(&mut core, &mut store), Reply::Hex(1), "CLOSE takes the corrupted checksum");
    assert!(!checksum_error_after_passes(&mut core), "after CLOSE the passes find no mismatch");
}

/// UM p.243 ("Limited Range"): under `out_of_range_modulo` an assignment outside I8's, I40's
/// or I41's range answers no error and rolls over into the range (I3=5 gives 1 of 0..3);
/// without it (the MODEL reading `error`) the same writes answer ERR003 and change nothing.
/// A memory write past I41 (SRM p.57) rolls over alike.
#[test]
fn an_out_of_range_assignment_rolls_over_under_the_modulo_reading_and_answers_err003_otherwise() {
    for modulo in [false, true] {
        let mut cfg = config();
        cfg.profile.out_of_range_modulo = modulo;
        let mut core = Core::power_on(&cfg);
        let mut store = FewIVariables::<2>::default();
        for (n, v, rolled) in [(41u16, 16i64, 0i64), (41, -1, 15), (40, 65_537, 1), (8, 256, 0), (8, -2, 254)] {
            let before = core.read_i(n, &store);
            let reply = core.apply(&cfg, Event::Command(Command::WriteI(n, v)), &mut store);
            if modulo {
                assert_eq!((reply, core.read_i(n, &store)), (Reply::Ack, Some(rolled)), "I{n}={v}");
            } else {
                assert_eq!((reply, core.read_i(n, &store)), (Reply::Error(3), before), "I{n}={v}");
            }
        }
        let reply = core.apply(&cfg, Event::Command(Command::WriteIMemory(41, 18)), &mut store);
        let expected = if modulo { (Reply::Ack, Some(2)) } else { (Reply::Error(3), core.read_i(41, &store)) };
        assert_eq!((reply, core.read_i(41, &store)), expected, "a memory write of 18 to I41");
    }
}
