//! The compact core keeps its own constants (a shared table would let one wrong constant pass
//! every comparison); this checks each against `specs/`.

use pmacwd_core::{
    bits, motion, Command, MotionCommand, Processor, Profile, StrobeStop, I40_DEFAULT, I40_MAX, I41_DEFAULT, I41_MAX,
    I8_DEFAULT, I8_MAX, I_VARIABLE_MAX, LOCKOUT,
};
use pmacwd_specs::check::Processor as SpecProcessor;
use pmacwd_specs::facts::StopScope;
use pmacwd_specs::profiles::{EncoderLossClear, ResetValueWhenI40Zero, StrobeStop as SpecStop, Strober};
use pmacwd_specs::status::WordId;
use pmacwd_specs::vocab::HostCommand;
use pmacwd_specs::Spec;

#[test]
fn the_core_status_bits_sit_where_status_yaml_puts_them() {
    let spec = Spec::embedded().unwrap();
    for (name, word, mask) in [
        ("rti_reentry", WordId::X, bits::RTI_REENTRY),
        ("servo_error", WordId::X, bits::SERVO_ERROR),
        ("checksum_error", WordId::X, bits::CHECKSUM_ERROR),
        ("prom_checksum_active", WordId::X, bits::PROM_CHECKSUM_ACTIVE),
        ("dpram_error", WordId::X, bits::DPRAM_ERROR),
        ("flash_error", WordId::X, bits::FLASH_ERROR),
        ("rti_warning", WordId::X, bits::RTI_WARNING),
        ("motion_buffer_open", WordId::Y, bits::MOTION_BUFFER_OPEN),
        ("plc_buffer_open", WordId::Y, bits::PLC_BUFFER_OPEN),
        ("data_gathering_on", WordId::X, bits::DATA_GATHERING_ON),
        ("cpu_type_bit1", WordId::X, bits::CPU_TYPE_1),
        ("cpu_type_bit0", WordId::Y, bits::CPU_TYPE_0),
    ] {
        let (w, b) = spec.status.bit(name).unwrap_or_else(|| panic!("status.yaml has no `{name}`"));
        assert_eq!((w, 1u32 << b), (word, mask), "{name}");
    }
}

#[test]
fn the_core_lockout_table_and_i_variable_ranges_match_variables_yaml() {
    let spec = Spec::embedded().unwrap();
    let v = &spec.variables;
    let table: Vec<(u16, u16)> = v.lockout.iter().map(|r| (r.first, r.last)).collect();
    assert_eq!(table, LOCKOUT.to_vec());
    for (bit, r) in v.lockout.iter().enumerate() {
        assert_eq!(usize::from(r.bit), bit, "lockout.yaml lists bits in order");
    }
    assert_eq!(i64::from(I_VARIABLE_MAX), v.i_variable_numbers.max);
    assert_eq!(I8_MAX, v.i_variables.i8.range.max);
    assert_eq!(I40_MAX, v.i_variables.i40.range.max);
    assert_eq!(I41_MAX, v.i_variables.i41.range.max);
    // What `$$$***` puts in active memory (UM p.243).
    assert_eq!(i64::from(I8_DEFAULT), v.i_variables.i8.default);
    assert_eq!(i64::from(I40_DEFAULT), v.i_variables.i40.default);
    assert_eq!(i64::from(I41_DEFAULT), v.i_variables.i41.default);
}

#[test]
fn the_core_cpu_type_bits_of_each_processor_match_the_specs_table() {
    // SRM p.289: the core's own table of the four options against the spec's, bit by bit.
    for (spec, core) in SpecProcessor::ALL.into_iter().zip([
        Processor::Dsp56303,
        Processor::Dsp56309,
        Processor::Dsp56311,
        Processor::Dsp56321,
    ]) {
        assert_eq!(pmacwd_bridge::core_processor(spec), core, "{}", spec.name());
        let (x, y) = core.type_words();
        assert_eq!((x == bits::CPU_TYPE_1, y == bits::CPU_TYPE_0), spec.type_bits(), "{}", spec.name());
        assert!(x & !bits::CPU_TYPE_1 == 0 && y & !bits::CPU_TYPE_0 == 0, "{}: only bit 21 of each word", spec.name());
    }
}

#[test]
fn the_core_named_profiles_match_profiles_yaml() {
    let spec = Spec::embedded().unwrap();
    for (name, p) in [("um-215", Profile::UM_215), ("srm-57", Profile::SRM_57)] {
        let c = spec.profiles.get(name).unwrap().choices;
        let rv = match c.reset_value_when_i40_zero {
            ResetValueWhenI40Zero::R4095 => 4095,
            ResetValueWhenI40Zero::R4096 => 4096,
        };
        assert_eq!(p.reset_value_i40_zero, rv, "{name}");
        assert_eq!(p.strobe_stop == StrobeStop::BelowZero, c.strobe_stop == SpecStop::BelowZero, "{name}");
        assert_eq!(p.rti_strobes, c.strober == Strober::RealTimeInterrupt, "{name}");
        assert_eq!(p.encoder_loss_clear_intended, c.encoder_loss_clear == EncoderLossClear::Intent, "{name}");
        // The reading out_of_range_assignment: the configuration takes the profile's choice
        // (ModelConfig::out_of_range), `error` for both of these (ERR003).
        let cfg =
            pmacwd_specs::config::ModelConfig::from_spec(&spec, "timing", &spec.profiles.get(name).unwrap()).unwrap();
        assert_eq!(
            p.out_of_range_modulo,
            cfg.out_of_range() == pmacwd_specs::profiles::OutOfRangeAssignment::Modulo,
            "{name}"
        );
    }
}

/// The core keeps eight motors and sixteen coordinate systems: as many motors as a
/// configuration may have (check.rs) and Turbo PMAC's &1..&16 (the command parser's range).
#[test]
fn the_core_motor_and_coordinate_system_counts_match_the_spec() {
    assert_eq!(motion::MOTORS_MAX, pmacwd_specs::check::MOTORS_MAX);
    assert_eq!(motion::COORDINATE_SYSTEMS_MAX, pmacwd_specs::vocab::command::COORDINATE_SYSTEM_MAX);
}

/// Every row of UM p.217's stop table (`stop_commands.yaml`) reaches the core as a command of
/// the row's scope: a motor command for the motor rows, a coordinate-system command for the
/// C.S. rows, a global one for the control characters. (What each does is compared with the
/// model's rules, which are checked column by column against the same table, in lockstep.)
#[test]
fn every_row_of_the_stop_table_reaches_the_core_with_its_scope() {
    let spec = Spec::embedded().unwrap();
    assert_eq!(spec.stop_commands.rows.len(), 11);
    for row in &spec.stop_commands.rows {
        let text = match row.scope {
            StopScope::Motor => format!("#1{}", row.command),
            StopScope::CoordinateSystem => format!("&1{}", row.command),
            StopScope::Global => row.command.clone(),
        };
        let cmd = HostCommand::parse(&text).unwrap_or_else(|e| panic!("`{text}`: {e:?}"));
        let core = pmacwd_bridge::core_command(&cmd);
        let scope = match core {
            Command::Motion(MotionCommand::Motor(1, _)) => StopScope::Motor,
            Command::Motion(MotionCommand::CoordinateSystem(1, _)) => StopScope::CoordinateSystem,
            Command::Motion(MotionCommand::Global(_)) => StopScope::Global,
            other => panic!("`{text}` reaches the core as {other:?}"),
        };
        assert_eq!(scope, row.scope, "`{text}`");
    }
}

#[test]
fn the_core_supply_minimum_in_its_benchmarks_matches_watchdog_yaml() {
    let spec = Spec::embedded().unwrap();
    assert_eq!((spec.watchdog.hardware.supply_volts_min.value * 1000.0).round() as u32, 4750);
}
