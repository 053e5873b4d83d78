//! Named hand mutations of the model, each breaking one rule of the manuals, and the check that
//! catches it: for each, the statements of the requirements matrix (specs/requirements.yaml)
//! whose rule it breaks, the `check.yaml` configuration it is checked at, and the properties or
//! monitors that must then be violated (or, for a `sometimes` property, never reached).
//!
//! A mutation is either a [`Canary`] of the model (the rule's effect changed after the event,
//! `model/src/checker.rs`) or a swapped constant of the resolved configuration (a status bit
//! placed elsewhere, the supply threshold moved, two rows of SRM p.57's lockout table swapped),
//! which the properties that read the manual's own figures must notice.
//!
//! docs/requirements.md lists, from this table, which statements' checks caught a mutation and
//! which statements were not tried; the last test holds the page to the table and the matrix.

use pmacwd_conformance::runner::{profiles_of, run_on_model, Failure};
use pmacwd_model::checker::{Canary, RunReport, WatchdogModel};
use pmacwd_specs::config::ModelConfig;
use pmacwd_specs::requirements::Category;
use pmacwd_specs::status::WordId;
use pmacwd_specs::Spec;
use std::collections::{BTreeMap, BTreeSet};

/// How a mutation breaks the model.
#[derive(Clone, Copy)]
enum Change {
    /// A deliberate bug of the model's rules.
    Canary(Canary),
    /// A constant of the resolved configuration swapped for a wrong one.
    Config(fn(&mut ModelConfig)),
}

struct Mutation {
    /// The name docs/requirements.md uses.
    name: &'static str,
    /// What it breaks, in words.
    what: &'static str,
    /// The statements of the matrix whose rule it breaks.
    statements: &'static [&'static str],
    configuration: &'static str,
    change: Change,
    /// Each must be violated (an `always` property) or never reached (a `sometimes` one).
    caught_by: &'static [&'static str],
    /// False for a mutation the model check is known not to catch (the reason at its entry):
    /// then each of `caught_by` must still hold, so that the day one catches it the table and
    /// docs/requirements.md are brought up to date (as wasmtime's known-failure list).
    caught: bool,
}

const fn canary(
    name: &'static str,
    what: &'static str,
    statements: &'static [&'static str],
    configuration: &'static str,
    c: Canary,
    caught_by: &'static [&'static str],
) -> Mutation {
    Mutation { name, what, statements, configuration, change: Change::Canary(c), caught_by, caught: true }
}

/// A mutation the model check does not catch, kept so that the gap stays written down.
const fn missed(m: Mutation) -> Mutation {
    Mutation { caught: false, ..m }
}

const TRIPPED_SILENT: &str = "a tripped card does not reply to any command";
const LOCKED_UNCHANGED: &str = "a locked I-variable never changes through an I-variable write";
const RELOAD: &str = "a background cycle reloads the counter from I40";
const NOT_MODELLED_BITS: &str =
    "bits X17 and X14 of ??? stay 0: the card gathers on no trigger and runs no leadscrew compensation";
const GATHERING_BIT: &str = "bit 19 of ??? is set by GATHER and cleared by ENDGATHER or a reset, and by nothing else";
const PLC_KILLS_ALL: &str =
    "a closed-loop motor whose encoder is lost has every motor killed at the next background cycle, its loss latched";

/// The row of UM p.217's table named `command` in a configuration, to change a column.
fn stop_row<'a>(cfg: &'a mut ModelConfig, command: &str) -> &'a mut pmacwd_specs::config::StopRow {
    cfg.stop_table.iter_mut().find(|r| r.command == command).expect("the row is in stop_commands.yaml")
}

/// The mutations, simplest rules first.
const MUTATIONS: &[Mutation] = &[
    canary(
        "TripLeavesLedDark",
        "a trip leaves the red LED dark",
        &["um215_red_led"],
        "timing",
        Canary::TripLeavesLedDark,
        &["a tripped card lights the red watchdog LED"],
    ),
    canary(
        "TripLeavesFefcoOff",
        "a trip leaves FEFCO/ off",
        &["um215_fefco_on"],
        "timing",
        Canary::TripLeavesFefcoOff,
        &["a tripped Turbo PMAC turns FEFCO/ on"],
    ),
    canary(
        "TripLeavesRelay",
        "a trip leaves the Turbo PMAC2's relay where it was",
        &["um215_pmac2_relay"],
        "timing",
        Canary::TripLeavesRelay,
        &["a tripped Turbo PMAC2 changes its watchdog relay over"],
    ),
    canary(
        "TripLeavesOutputsLive",
        "a trip leaves the discrete and proportional outputs live",
        &["um215_ics_reset_outputs_off"],
        "timing",
        Canary::TripLeavesOutputsLive,
        &["a tripped card forces discrete outputs off and proportional outputs to zero"],
    ),
    canary(
        "TripLeavesAmplifiersOn",
        "a trip leaves an enabled amplifier enabled",
        &["um215_ics_reset_outputs_off"],
        "motion",
        Canary::TripLeavesAmplifiersOn,
        &["after a trip every amplifier is disabled, every output zero and no motor moves"],
    ),
    canary(
        "ResetLeavesLedLit",
        "a reset of a tripped card leaves the red LED lit",
        &["um215_outputs_show_watchdog_state"],
        "timing",
        Canary::ResetLeavesLedLit,
        &["a running card shows no trip on its LED, FEFCO/, relay or outputs"],
    ),
    canary(
        "TrippedCardAnswers",
        "a tripped card acknowledges a command",
        &["um215_no_communication", "um215_trip_cannot_be_queried"],
        "lockout",
        Canary::TrippedCardAnswers,
        &[TRIPPED_SILENT],
    ),
    canary(
        "TrippedCardTakesWrites",
        "a tripped card takes an I41 write",
        &["um215_processor_stops"],
        "lockout",
        Canary::TrippedCardTakesWrites,
        &["a tripped card changes no state until it is reset"],
    ),
    // Caught since the checker gives a tripped card its servo interrupt too; before, it offered
    // time only to a running card, and this mutation was the one no check caught.
    canary(
        "TrippedCardCounts",
        "a tripped card's servo interrupt goes on decrementing the counter",
        &["um215_processor_stops"],
        "timing",
        Canary::TrippedCardCounts,
        &["a tripped card changes no state until it is reset"],
    ),
    canary(
        "SupplyRestoreUntrips",
        "a good supply undoes an undervoltage trip",
        &["um215_trip_latches_reset_state", "um215_recovery"],
        "timing",
        Canary::SupplyRestoreUntrips,
        &["a trip is undone only by INIT/ or a power cycle"],
    ),
    canary(
        "UndervoltageIgnored",
        "a supply below the minimum does not trip the card",
        &["um215_two_conditions", "um215_undervoltage_trips"],
        "timing",
        Canary::UndervoltageIgnored,
        &["a supply below the minimum means tripped", "a supply below the minimum trips the card at once"],
    ),
    canary(
        "StrobeTimeoutIgnored",
        "a strobe gap one cycle longer than the hardware delay does not trip the card yet",
        &[
            "um215_strobe_minimum",
            "um215_lsb_toggles_the_timer",
            "um215_under_frequency_trips",
            "srm57_background_deadline",
            "srm57_i40_sensitivity",
            "um237_watchdog_ensures_a_minimum_background_rate",
        ],
        "timing",
        Canary::StrobeTimeoutIgnored,
        &[
            "a strobe gap longer than the hardware delay means tripped",
            "a background starved for longer than the reset value plus the hardware delay means tripped",
        ],
    ),
    canary(
        "CounterGoesBelowZero",
        "the counter steps from 0 to -1 under the at-zero reading",
        &["um215_servo_decrements_while_positive"],
        "timing",
        Canary::CounterGoesBelowZero,
        &["under the at-zero reading the counter never goes below zero"],
    ),
    canary(
        "CounterDropsByTwo",
        "a servo cycle takes 2 off the counter",
        &["srm57_decrement_by_one"],
        "timing",
        Canary::CounterDropsByTwo,
        &["the watchdog counter drops by at most one per servo cycle"],
    ),
    canary(
        "PlcRestartsOnOverrun",
        "an RTI that finds the previous tasks still running starts PLC 0 again",
        &["um236_plc0_every_rti_if_previous_done"],
        "timing",
        Canary::PlcRestartsOnOverrun,
        &["PLC 0 starts only when the previous RTI tasks have completed"],
    ),
    canary(
        "BackgroundReloadsOneHigh",
        "a background cycle reloads the counter one above the reset value",
        &[
            "um215_background_resets_counter",
            "srm57_i40_reset_each_background_cycle",
            "um240_y25_reloaded_each_background_cycle",
            "um237_housekeeping_safety_checks_each_background_cycle",
            "um237_i40_is_servo_cycles_per_background_cycle",
        ],
        "timing",
        Canary::BackgroundReloadsOneHigh,
        &[RELOAD],
    ),
    canary(
        "X25NotTracked",
        "X:$25 no longer follows the counter down",
        &["srm57_x25_lowest_value", "um240_x25_lowest_since_reset", "um240_x25_near_zero_is_a_near_miss"],
        "timing",
        Canary::X25NotTracked,
        &[
            "X:$25 is never above the watchdog counter Y:$25",
            "a near miss leaves X:$25 at the last strobing value on a running card",
        ],
    ),
    canary(
        "Bit22ClearedByBackground",
        "a background cycle clears bit 22",
        &["srm289_x22_sticky"],
        "timing",
        Canary::Bit22ClearedByBackground,
        &["bit 22 once set stays set until reset or an explicit clear"],
    ),
    canary(
        "Bit22NeverSet",
        "bit 22 cleared after every servo event",
        &["srm289_x22_rti_reentry"],
        "timing",
        Canary::Bit22NeverSet,
        &["bit 22 (RTI re-entry) can be set"],
    ),
    canary(
        "Bit9NeverSet",
        "bit 9 cleared after every servo event",
        &["srm290_bit9_rti_warning"],
        "timing",
        Canary::Bit9NeverSet,
        &["bit 9 (RTI warning) can be set"],
    ),
    canary(
        "DpramErrorSetByBackground",
        "a background cycle sets the DPRAM error bit",
        &["srm289_x11_dpram_error"],
        "status",
        Canary::DpramErrorSetByBackground,
        &["the DPRAM and flash error bits change only at a reset"],
    ),
    canary(
        "FlashErrorClearedByBackground",
        "a background cycle clears the flash error bit",
        &["srm289_x10_flash_error"],
        "status",
        Canary::FlashErrorClearedByBackground,
        &["the DPRAM and flash error bits change only at a reset"],
    ),
    canary(
        "StatusReplyTooWide",
        "??? answers a first word of 25 bits, thirteen characters",
        &[
            "srm289_reply_twelve_hex_characters",
            "srm289_reply_first_word_characters",
            "srm289_reply_second_word_characters",
        ],
        "status",
        Canary::StatusReplyTooWide,
        &["the ??? reply is twelve hex characters, first word first"],
    ),
    canary(
        "BootstrapAnswersStatus",
        "a card in bootstrap mode answers ??? with status words",
        &["srm289_bootstrap_reply"],
        "status",
        Canary::BootstrapAnswersStatus,
        &["a card in bootstrap mode answers ??? with BOOTSTRAP PROM"],
    ),
    canary(
        "ChecksumRunsOnAfterError",
        "the running checksum X:$1080 moves on after a checksum error",
        &["um217_firmware_mismatch_freezes_x1080", "um217_user_mismatch_stops_and_freezes"],
        "status",
        Canary::ChecksumRunsOnAfterError,
        &["a checksum error freezes X:$1080"],
    ),
    canary(
        "ChecksumSwitchesAreaAfterError",
        "after a checksum error the engine moves on to the other area",
        &["um217_firmware_mismatch_stops_checksums"],
        "status",
        Canary::ChecksumSwitchesAreaAfterError,
        &["a checksum error stops both checksums"],
    ),
    canary(
        "ChecksumNeverMismatches",
        "a checksum pass never finds a mismatch; it starts over",
        &["um217_firmware_checksum_compared"],
        "status",
        Canary::ChecksumNeverMismatches,
        &["a firmware checksum error can be found", "a user-program checksum error can be found"],
    ),
    canary(
        "ChecksumErrorShutsDown",
        "a checksum error shuts the card down",
        &["um217_firmware_error_no_other_action", "um217_user_error_no_shutdown"],
        "status",
        Canary::ChecksumErrorShutsDown,
        &["a firmware checksum error can be found", "a user-program checksum error can be found"],
    ),
    canary(
        "ChecksumStaysOnFirmware",
        "the checksum engine never starts a user-program pass",
        &["um217_user_checksum_continual"],
        "status",
        Canary::ChecksumStaysOnFirmware,
        &["bit 12 can show a user-program pass in progress"],
    ),
    canary(
        "ChecksumCommandOffByOne",
        "CHECKSUM answers the reference plus one",
        &["um217_factory_reference", "srm295_checksum_reports_reference"],
        "status",
        Canary::ChecksumCommandOffByOne,
        &["CHECKSUM reports the factory reference, whatever faults and checksum errors came since"],
    ),
    canary(
        "CloseKeepsOldReference",
        "CLOSE leaves X:$1090 as it was",
        &["um217_user_checksum_compared_with_close_value"],
        "status",
        Canary::CloseKeepsOldReference,
        &["CLOSE stores the user program's checksum as it stands in X:$1090"],
    ),
    canary(
        "AmplifierFaultKillsAll",
        "the firmware's amplifier-fault kill kills every motor, as the encoder-loss PLC does",
        &["um213_fault_kills_the_offending_motor"],
        "amplifier-fault",
        Canary::AmplifierFaultKillsAll,
        &["an amplifier fault kills no motor outside the offending motors' coordinate systems"],
    ),
    canary(
        "AmplifierFaultIgnored",
        "the housekeeping's amplifier-fault check kills nothing",
        &["um213_fault_kills_the_offending_motor", "um237_housekeeping_safety_checks_each_background_cycle"],
        "amplifier-fault",
        Canary::AmplifierFaultIgnored,
        &[
            "an amplifier fault kills the offending motor at the next background cycle and sets its fault status",
            "an amplifier fault can kill a motor, leaving its fault status set",
        ],
    ),
    canary(
        "EndGatherKeepsGathering",
        "ENDGATHER leaves data gathering on",
        &["srm289_x19_data_gathering_on"],
        "status",
        Canary::EndGatherKeepsGathering,
        &[GATHERING_BIT],
    ),
    canary(
        "LockoutIgnored",
        "a locked I-variable write takes effect",
        &["srm57_i41_purpose", "srm57_i41_bit_set_locks", "srm57_i41_download_care"],
        "lockout",
        Canary::LockoutIgnored,
        &[LOCKED_UNCHANGED],
    ),
    canary(
        "UnlockedWriteIgnored",
        "a write outside every locked range is ignored while I41 is not 0",
        &["srm57_i41_bits_independent"],
        "lockout",
        Canary::UnlockedWriteIgnored,
        &["an I-variable write outside every locked range takes effect"],
    ),
    canary(
        "I41LocksItself",
        "a write to I41 is ignored while I41 is not 0",
        &["srm57_i41_table"],
        "lockout",
        Canary::I41LocksItself,
        &["I41 itself is never locked out"],
    ),
    canary(
        "LockedWriteAnswersError",
        "a locked I-variable write answers ERR003",
        &["srm57_i41_locked_write_ignored"],
        "lockout",
        Canary::LockedWriteAnswersError,
        &["a locked I-variable write is ignored without an error"],
    ),
    canary(
        "MemoryWriteHonoursLock",
        "a memory write to a locked I-variable is ignored",
        &["srm57_i41_other_paths_not_locked"],
        "lockout",
        Canary::MemoryWriteHonoursLock,
        &["an M-variable assignment or a memory write changes an I-variable whatever I41 holds"],
    ),
    canary(
        "KillLeavesAmplifierOn",
        "#nK leaves the motor's amplifier enabled",
        &["um319_kill_disables_at_once", "srm281_amplifier_enabled_bit"],
        "motion",
        Canary::KillLeavesAmplifierOn,
        &[
            "after K the motor's amplifier is disabled and its output zero in the same servo cycle",
            "a motor's amplifier is enabled and its output live exactly when it is not killed",
        ],
    ),
    canary(
        "KAcceptedDuringProgram",
        "K is acknowledged while its coordinate system executes a program",
        &["um319_k_not_in_a_running_program"],
        "motion",
        Canary::KAcceptedDuringProgram,
        &["K is refused while the motor's coordinate system executes a program"],
    ),
    canary(
        "KillAllSparesMotor2",
        "<CTRL-K> leaves motor 2 closed-loop at rest",
        &["um319_kill_all_at_once", "um217_stop_row_ctrl_k"],
        "motion",
        Canary::KillAllSparesMotor2,
        &["after <CTRL-K> every motor is killed at once"],
    ),
    canary(
        "HoldAllSparesCs2",
        "<CTRL-O> leaves the program of C.S. 2 running",
        &["srm260_ctrl_o_holds_every_coordinate_system", "um217_stop_row_ctrl_o"],
        "motion",
        Canary::HoldAllSparesCs2,
        &["<CTRL-O> holds every running program and <CTRL-Q> quits each"],
    ),
    canary(
        "AbortActsAsQuit",
        "&nA acts as &nQ: its motors go on with their calculated moves",
        &["um217_stop_row_a", "um319_abort_discards_the_lookahead"],
        "motion",
        Canary::AbortActsAsQuit,
        &[
            "A begins immediately: no motor of the coordinate system runs its program or jogs after it",
            "A does not finish calculated moves: an executing program loses its lookahead",
        ],
    ),
    canary(
        "EncoderLossKillsOnlyItsMotor",
        "the encoder-loss PLC kills only the motor whose encoder is lost",
        &["um214_encoder_loss_plc_kills_all_motors"],
        "encoder-loss-2",
        Canary::EncoderLossKillsOnlyItsMotor,
        &[PLC_KILLS_ALL],
    ),
    canary(
        "EncoderLossNeverClears",
        "under the intended reading the encoder-loss PLC never clears a latched loss",
        &["um215_encoder_loss_clear_logic"],
        "encoder-loss",
        Canary::EncoderLossNeverClears,
        &["under the intended reading the PLC clears a latched loss once the motor is closed-loop with its encoder OK"],
    ),
    canary(
        "EncoderLossNotLatched",
        "the encoder-loss PLC kills without latching the loss",
        &[
            "um215_encoder_loss_plc_example",
            "um236_one_plc_scan_per_background_cycle",
            "um237_compiled_plcs_one_scan_each_per_background_cycle",
        ],
        "encoder-loss",
        Canary::EncoderLossNotLatched,
        &[PLC_KILLS_ALL, "the encoder-loss PLC can kill a motor and latch the loss"],
    ),
    // Not caught: only `i40-zero` sends `$$$***`, and there the saved I8, I40 and I41 are the
    // factory defaults and no other I-variable is written, so the monitor cannot tell a
    // re-initialization from a reset; the same holds for I41 in every configuration. The
    // scenario dollar-dollar-dollar-star-star-star-reinitializes-and-a-reset-brings-the-saved-values-back
    // (on the `lockout` configuration, I41 = 1 before `$$$***`) would catch the same bug
    // written in `Controller::host_command`.
    missed(canary(
        "ReinitializeKeepsI41",
        "$$$*** keeps the active I41",
        &["srm57_i41_default", "um243_reinitialization_uses_factory_defaults"],
        "i40-zero",
        Canary::ReinitializeKeepsI41,
        &["after $$$*** the I-variables are the factory defaults"],
    )),
    Mutation {
        name: "MotionBufferBitOnX19",
        what: "the motion-buffer-open bit (Y19) placed on X19",
        statements: &["srm289_x19_data_gathering_on"],
        configuration: "status",
        change: Change::Config(|cfg| cfg.layout.motion_buffer_open = (WordId::X, 19)),
        caught_by: &[GATHERING_BIT],
        caught: true,
    },
    Mutation {
        name: "PlcBufferBitOnX17",
        what: "the PLC-buffer-open bit (Y17) placed on X17",
        statements: &["srm289_x17_gather_on_trigger"],
        configuration: "status",
        change: Change::Config(|cfg| cfg.layout.plc_buffer_open = (WordId::X, 17)),
        caught_by: &[NOT_MODELLED_BITS],
        caught: true,
    },
    Mutation {
        name: "DpramBitOnX14",
        what: "the DPRAM error bit (X11) placed on X14",
        statements: &["srm289_x14_leadscrew_compensation"],
        configuration: "status",
        change: Change::Config(|cfg| cfg.layout.dpram_error = (WordId::X, 14)),
        caught_by: &[NOT_MODELLED_BITS],
        caught: true,
    },
    Mutation {
        name: "LockoutBits0And1Swapped",
        what: "the I41 ranges of bits 0 and 1 swapped",
        statements: &["srm57_i41_bit0_motor_setup", "srm57_i41_bit1_coordinate_system_setup"],
        configuration: "lockout",
        change: Change::Config(|cfg| cfg.lockout.swap(0, 1)),
        caught_by: &[
            "an I-variable write takes effect exactly when the I41 bit of its range in SRM p.57's table is clear",
        ],
        caught: true,
    },
    Mutation {
        name: "SupplyThresholdRaised",
        what: "the supply minimum moved from 4,750 to 4,751 mV",
        statements: &["um215_supply_minimum"],
        configuration: "edges",
        change: Change::Config(|cfg| cfg.supply_min_millivolts = 4751),
        caught_by: &["a supply change trips a running card exactly when it falls below 4.75 V"],
        caught: true,
    },
    // Issue 35: the model carries each stop command out by its row of UM p.217's table as the
    // data holds it (`ModelConfig::stop_table`), so a column changed in the data is a rule
    // written wrong; the monitors read the page's columns as printed, per command.
    Mutation {
        name: "JogStopRowNotImmediate",
        what: "J/'s row says it does not begin immediately",
        statements: &["um217_stop_row_j_slash"],
        configuration: "motion",
        change: Change::Config(|cfg| stop_row(cfg, "J/").begins_immediately = false),
        caught_by: &["J/ begins immediately: a jogging motor decelerates at once, and no other motor changes"],
        caught: true,
    },
    Mutation {
        name: "QuitRowImmediate",
        what: "Q's row says it begins immediately",
        statements: &["um217_stop_row_q"],
        configuration: "motion",
        change: Change::Config(|cfg| stop_row(cfg, "Q").begins_immediately = true),
        caught_by: &["Q does not begin immediately: the program's motors go on with their calculated moves"],
        caught: true,
    },
    Mutation {
        name: "HoldRowOffThePath",
        what: "H's row says it does not stop on the path",
        statements: &["um217_stop_row_h"],
        configuration: "motion",
        change: Change::Config(|cfg| stop_row(cfg, "H").stops_on_path = pmacwd_specs::facts::Tristate::No),
        caught_by: &["H stops on the path: its motors end holding, and R can resume the program"],
        caught: true,
    },
    Mutation {
        name: "KillRowGlobal",
        what: "K's row says its scope is global: #nK kills every motor, whatever program runs",
        statements: &["um217_stop_row_k"],
        configuration: "motion",
        change: Change::Config(|cfg| stop_row(cfg, "K").scope = pmacwd_specs::facts::StopScope::Global),
        caught_by: &["K is refused while the motor's coordinate system executes a program"],
        caught: true,
    },
    // Issue 34's remaining rows: the stop rows no mutation had tried, each column changed as
    // a misread of UM p.217's row would change it.
    canary(
        "StarvationNeverTrips",
        "a strobe gap longer than the hardware delay never trips the card",
        &["um215_watchdog_fail_safe", "um236_starvation_trips_watchdog"],
        "timing",
        Canary::StarvationNeverTrips,
        &["the card can trip on a starved background"],
    ),
    canary(
        "BackgroundAheadOfRti",
        "the background gets the time the servo update leaves before PLC 0 and the RTI tasks",
        &[
            "um236_background_in_remaining_time",
            "um236_rti_fourth_priority",
            "um236_plc0_higher_priority",
            "um236_plc0_too_long_starves_background",
            "srm42_large_plc0_with_small_i8_starves_the_background",
        ],
        "i40-zero",
        Canary::BackgroundAheadOfRti,
        &["while the RTI tasks are unfinished the background gets no time"],
    ),
    Mutation {
        name: "CtrlARowNotImmediate",
        what: "<CTRL-A>'s row says it does not begin immediately",
        statements: &["um217_stop_row_ctrl_a", "um217_stop_command_table"],
        configuration: "motion",
        change: Change::Config(|cfg| stop_row(cfg, "<CTRL-A>").begins_immediately = false),
        caught_by: &["A begins immediately: no motor of the coordinate system runs its program or jogs after it"],
        caught: true,
    },
    Mutation {
        name: "CtrlQRowImmediate",
        what: "<CTRL-Q>'s row says it begins immediately",
        statements: &["um217_stop_row_ctrl_q"],
        configuration: "motion",
        change: Change::Config(|cfg| stop_row(cfg, "<CTRL-Q>").begins_immediately = true),
        caught_by: &["Q does not begin immediately: the program's motors go on with their calculated moves"],
        caught: true,
    },
    Mutation {
        name: "BackslashRowOffThePath",
        what: "\\'s row says it does not stop on the path",
        statements: &["um217_stop_row_backslash"],
        configuration: "motion",
        change: Change::Config(|cfg| stop_row(cfg, "\\").stops_on_path = pmacwd_specs::facts::Tristate::No),
        caught_by: &["H stops on the path: its motors end holding, and R can resume the program"],
        caught: true,
    },
    // Issue 35: before, the checker offered a supply reading only when it changed the rule's
    // own low flag, so with the threshold moved down no reading between the two came: this
    // mutation passed the model check. The checker now offers readings on both sides of the
    // printed 4.75 V as well.
    Mutation {
        name: "SupplyThresholdLowered",
        what: "the supply minimum moved from 4,750 to 4,749 mV",
        statements: &["um215_supply_minimum"],
        configuration: "edges",
        change: Change::Config(|cfg| cfg.supply_min_millivolts = 4749),
        caught_by: &["a supply change trips a running card exactly when it falls below 4.75 V"],
        caught: true,
    },
    Mutation {
        name: "LockoutBits2And3Swapped",
        what: "the I41 ranges of bits 2 and 3 swapped",
        statements: &["srm57_i41_bit2_ic_setup", "srm57_i41_bit3_conversion_table_setup"],
        configuration: "lockout-ic",
        change: Change::Config(|cfg| cfg.lockout.swap(2, 3)),
        caught_by: &[
            "an I-variable write takes effect exactly when the I41 bit of its range in SRM p.57's table is clear",
        ],
        caught: true,
    },
];

/// A mutation of a spec file's text: a constant of the manuals swapped in a copy of `specs/`,
/// which the scenarios (run on the model, under the profiles each names) must notice.
struct SpecMutation {
    name: &'static str,
    what: &'static str,
    statements: &'static [&'static str],
    file: &'static str,
    /// Applied in order: after the one occurrence of the anchor, the first `from` becomes `to`.
    edits: &'static [(&'static str, &'static str, &'static str)],
    caught_by: Catch,
}

/// What must notice a spec mutation.
enum Catch {
    /// Each of these scenarios diverges under some profile it names.
    Scenarios(&'static [&'static str]),
    /// The model check of this configuration (default profile), on the mutated spec, fails
    /// each of these properties.
    Check(&'static str, &'static [&'static str]),
}

/// The edits that move status bit `a` (named) onto the position of bit `b` and back.
macro_rules! swap_names {
    ($a:literal, $b:literal) => {
        &[
            (concat!("name: ", $a, "\n"), concat!("name: ", $a), "name: swapped_for_the_mutation"),
            (concat!("name: ", $b, "\n"), concat!("name: ", $b), concat!("name: ", $a)),
            ("name: swapped_for_the_mutation", "name: swapped_for_the_mutation", concat!("name: ", $b)),
        ]
    };
}

const SPEC_MUTATIONS: &[SpecMutation] = &[
    SpecMutation {
        name: "UmReloadValuesSwapped",
        what: "the reset values of um-215 and um-215-4095 swapped (the loader refuses two profiles alike)",
        statements: &["um215_i40_zero_means_4096"],
        file: "profiles.yaml",
        edits: &[
            ("  um-215:\n", "reset_value_when_i40_zero: \"4096\"", "reset_value_when_i40_zero: \"4095\""),
            ("  um-215-4095:\n", "reset_value_when_i40_zero: \"4095\"", "reset_value_when_i40_zero: \"4096\""),
        ],
        caught_by: Catch::Scenarios(&["with-i40-zero-the-um-readings-reload-the-counter-to-4096"]),
    },
    SpecMutation {
        name: "SrmProfileReloads4096",
        what: "the SRM profile given UM p.215's 4096",
        statements: &["srm57_i40_zero_means_4095", "srm57_i40_default"],
        file: "profiles.yaml",
        edits: &[("  srm-57:\n", "reset_value_when_i40_zero: \"4095\"", "reset_value_when_i40_zero: \"4096\"")],
        caught_by: Catch::Scenarios(&["with-i40-zero-the-srm-readings-reload-the-counter-to-4095"]),
    },
    SpecMutation {
        name: "I41DefaultOne",
        what: "I41's factory default 1 instead of 0",
        statements: &["srm57_i41_default", "um243_reinitialization_uses_factory_defaults"],
        file: "variables.yaml",
        edits: &[("  I41:\n", "default: 0", "default: 1")],
        caught_by: Catch::Scenarios(&[
            "dollar-dollar-dollar-star-star-star-reinitializes-and-a-reset-brings-the-saved-values-back",
        ]),
    },
    SpecMutation {
        name: "I41RangeThreeBits",
        what: "I41's range 0..7 instead of 0..15 (a wider one the loader refuses: I41 holds 4 bits)",
        statements: &["srm57_i41_range"],
        file: "variables.yaml",
        edits: &[("  I41:\n", "range: {min: 0, max: 15}", "range: {min: 0, max: 7}")],
        caught_by: Catch::Scenarios(&[
            "i41-bit-3-alone-locks-the-conversion-table-from-i8000-to-i8191-and-nothing-else",
        ]),
    },
    SpecMutation {
        name: "ServoErrorOnBit19",
        what: "the servo error bit named at X19 instead of X20",
        statements: &["srm289_x20_servo_error"],
        file: "status.yaml",
        edits: swap_names!("servo_error", "data_gathering_on"),
        // The scenario of bit 20 names the bit (`status_set: [servo_error]`), so it moves with
        // the name; the monitor of bit 19 reads X19 where SRM p.289 prints it.
        caught_by: Catch::Check("timing", &[GATHERING_BIT]),
    },
    SpecMutation {
        name: "ChecksumErrorOnBit14",
        what: "the checksum error bit named at X14 instead of X13",
        statements: &[
            "srm289_x13_any_checksum_error",
            "srm289_bit_one_when_true",
            "um217_user_mismatch_sets_bit_13",
            "um217_firmware_mismatch_sets_bits",
        ],
        // Issue 34: the same move breaks UM p.217's "sets ... bits 12 and 13" for a firmware
        // mismatch (the status configuration injects both kinds). Placed on X14 in the resolved
        // configuration instead, the bit is not caught: the monitors of bits 12 and 13 read the
        // configuration's layout and move with it; X14's monitor reads SRM p.289's position.
        file: "status.yaml",
        edits: swap_names!("checksum_error", "leadscrew_compensation_on"),
        caught_by: Catch::Check("status", &[NOT_MODELLED_BITS]),
    },
    SpecMutation {
        name: "PromChecksumOnBit11",
        what: "the PROM-checksum-active bit named at X11 instead of X12",
        statements: &["srm289_x12_firmware", "srm289_x12_user_program", "um217_firmware_checksum_continual"],
        file: "status.yaml",
        edits: swap_names!("prom_checksum_active", "dpram_error"),
        caught_by: Catch::Scenarios(&["bit-12-alternates-between-the-firmware-and-user-program-passes"]),
    },
    SpecMutation {
        name: "CpuTypeBit1OnBit23",
        what: "CPU type bit 1 named at X23 instead of X21",
        statements: &["srm289_x21_cpu_type"],
        file: "status.yaml",
        edits: swap_names!("cpu_type_bit1", "reserved_x23"),
        // The DSP56309 scenario has bit 1 clear, which moving it does not change.
        caught_by: Catch::Scenarios(&["a-dsp56321-card-sets-both-cpu-type-bits-of-global-status"]),
    },
    SpecMutation {
        name: "SrmStrobeStopsAtZero",
        what: "the SRM profile's strobe stops at 0 instead of below 0",
        statements: &["srm57_below_zero_rti_stops_strobing"],
        file: "profiles.yaml",
        edits: &[("  srm-57:\n", "strobe_stop: below_zero", "strobe_stop: at_zero")],
        caught_by: Catch::Scenarios(&["under-the-srm-reading-the-counter-goes-below-zero-before-the-trip"]),
    },
    SpecMutation {
        name: "ServoCostFree",
        what: "i40-zero's motors cost no servo time (servo_units_per_motor 0 instead of 1)",
        statements: &["um236_servo_cost_per_motor"],
        file: "check.yaml",
        edits: &[("  i40-zero:\n", "servo_units_per_motor: 1", "servo_units_per_motor: 0")],
        // Issue 34: not caught while the scenario's steps were `servo: 4141`, which lets no
        // background cycle complete whatever the load (a stopped background trips any card):
        // the scenario now runs `run:` steps, a background cycle after every servo cycle whose
        // load allows one, so only a PLC 0 that takes the background's time trips it.
        caught_by: Catch::Scenarios(&[
            "a-plc0-that-fills-every-rti-period-starves-the-background-until-the-watchdog-trips",
        ]),
    },
    SpecMutation {
        name: "SlashRowImmediate",
        what: "/'s row says it begins immediately",
        statements: &["um217_stop_row_slash"],
        file: "stop_commands.yaml",
        edits: &[("  - command: /\n", "begins_immediately: false", "begins_immediately: true")],
        // Tried first on the row's "Stop at Prog Pt?" in the resolved configuration, which the
        // model check did not catch: / and Q take their program point from their stop (end of
        // move, quit), which model/src/motion.rs's stop_rules_match_the_table holds to the
        // printed column; the model does not read that column.
        caught_by: Catch::Scenarios(&["slash-stops-at-the-end-of-the-currently-executing-move"]),
    },
    SpecMutation {
        name: "AbortRowKills",
        what: "A's row has no deceleration rate: A kills instead of stopping at Ixx15",
        statements: &["um319_abort_breaks_in_at_ixx15"],
        file: "stop_commands.yaml",
        edits: &[("  - command: A\n", "decel_rate: Ixx15", "decel_rate: null")],
        caught_by: Catch::Scenarios(&["a-aborts-the-program-at-once-at-ixx15-and-the-motors-come-to-rest"]),
    },
];

/// A copy of the spec files of `specs/` with `m`'s edits, loaded.
fn mutated_spec(m: &SpecMutation) -> Spec {
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../specs");
    let dir = std::env::temp_dir().join(format!("pmacwd-spec-mutation-{}-{}", std::process::id(), m.name));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    for entry in std::fs::read_dir(&root).unwrap() {
        let path = entry.unwrap().path();
        if path.extension().is_some_and(|e| e == "yaml") {
            std::fs::copy(&path, dir.join(path.file_name().unwrap())).unwrap();
        }
    }
    let file = dir.join(m.file);
    let mut text = std::fs::read_to_string(&file).unwrap();
    for (anchor, from, to) in m.edits {
        assert_eq!(text.matches(anchor).count(), 1, "{}: the anchor {anchor:?} occurs once in {}", m.name, m.file);
        let at = text.find(anchor).unwrap();
        let pos = at + text[at..].find(from).unwrap_or_else(|| panic!("{}: no {from:?} after {anchor:?}", m.name));
        text.replace_range(pos..pos + from.len(), to);
    }
    std::fs::write(&file, text).unwrap();
    let spec = Spec::load_dir(&dir).unwrap_or_else(|e| panic!("{}: the mutated spec does not load: {e}", m.name));
    let _ = std::fs::remove_dir_all(&dir);
    spec
}

/// Every spec mutation makes each scenario it names diverge (not fail to run) under some
/// profile the scenario names, and every scenario it names holds on the real spec (the
/// scenario test checks the whole library; here only the named ones, under the same runner).
#[test]
fn every_spec_mutation_is_caught_by_the_scenarios_it_names() {
    let real = Spec::embedded().unwrap();
    let mut missed = Vec::new();
    for m in SPEC_MUTATIONS {
        let spec = mutated_spec(m);
        let scenarios = match m.caught_by {
            Catch::Scenarios(stems) => stems,
            Catch::Check(configuration, properties) => {
                let cfg = ModelConfig::from_spec(&spec, configuration, &spec.profiles.default_profile()).unwrap();
                let report = WatchdogModel::new(cfg).check(2);
                assert!(report.complete, "{}: the run was cut short", m.name);
                for name in properties {
                    let p = report.properties.iter().find(|p| p.name == *name).unwrap();
                    if p.holds {
                        missed.push(format!("{} ({}): `{name}` still holds at {configuration}", m.name, m.what));
                    }
                }
                &[]
            }
        };
        for stem in scenarios {
            let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join(format!("../specs/scenarios/{stem}.yaml"));
            let loaded = pmacwd_trace::load_yaml(&path).unwrap_or_else(|e| panic!("{}: {e}", m.name));
            for profile in profiles_of(&real, &loaded).unwrap() {
                assert!(run_on_model(&real, &loaded, &profile).is_ok(), "{stem} holds on the real spec");
            }
            let mut diverged = false;
            for profile in profiles_of(&spec, &loaded).unwrap() {
                match run_on_model(&spec, &loaded, &profile) {
                    Ok(_) => {}
                    Err(Failure::Diverged(_)) => diverged = true,
                    Err(Failure::Unusable(e)) => panic!("{}: {stem} cannot run on the mutated spec: {e}", m.name),
                }
            }
            if !diverged {
                missed.push(format!("{} ({}): {stem} still holds", m.name, m.what));
            }
        }
    }
    assert!(missed.is_empty(), "spec mutations not caught:\n{}", missed.join("\n"));
}

fn run(m: &Mutation) -> RunReport {
    let spec = Spec::embedded().unwrap();
    let mut cfg = ModelConfig::from_spec(&spec, m.configuration, &spec.profiles.default_profile())
        .unwrap_or_else(|e| panic!("{}: {e}", m.name));
    let canary = match m.change {
        Change::Canary(c) => Some(c),
        Change::Config(f) => {
            f(&mut cfg);
            None
        }
    };
    WatchdogModel { canary, ..WatchdogModel::new(cfg) }.check(2)
}

/// Every mutation is caught: each property it names fails under it (violated, or never
/// reached), and holds without it (the model check of `check.yaml`, `model_check.rs`, asserts
/// that every property holds everywhere; here only the properties named are compared). The
/// mutations known not to be caught must still not be.
#[test]
fn every_named_mutation_is_caught_by_the_checks_it_names() {
    let mut missed = Vec::new();
    let mut now_caught = Vec::new();
    for m in MUTATIONS {
        let report = run(m);
        assert!(report.complete, "{}: the run was cut short", m.name);
        for name in m.caught_by {
            let p = report
                .properties
                .iter()
                .find(|p| p.name == *name)
                .unwrap_or_else(|| panic!("{}: no property named `{name}`", m.name));
            assert!(p.applicable, "{}: `{name}` does not apply to {}", m.name, m.configuration);
            match (m.caught, p.holds) {
                (true, true) => {
                    missed.push(format!("{} ({}, at {}): `{name}` still holds", m.name, m.what, m.configuration))
                }
                (false, false) => now_caught.push(format!("{}: `{name}` now fails", m.name)),
                _ => {}
            }
        }
    }
    assert!(missed.is_empty(), "mutations not caught:\n{}", missed.join("\n"));
    assert!(
        now_caught.is_empty(),
        "mutations listed as not caught are caught now: mark them caught here and in docs/requirements.md:\n{}",
        now_caught.join("\n")
    );
}

/// The table names real statements, each checked (a statement's mutation shows its check can
/// fail), mutations once each.
#[test]
fn the_mutations_name_checked_statements_of_the_matrix() {
    let spec = Spec::embedded().unwrap();
    let category: BTreeMap<&str, Category> =
        spec.requirements.statements.iter().map(|s| (s.id.as_str(), s.category())).collect();
    let mut names = BTreeSet::new();
    let all =
        MUTATIONS.iter().map(|m| (m.name, m.statements)).chain(SPEC_MUTATIONS.iter().map(|m| (m.name, m.statements)));
    for (name, statements) in all {
        assert!(names.insert(name), "two mutations are named {name}");
        for id in statements {
            match category.get(id) {
                Some(Category::Checked) => {}
                Some(c) => panic!("{name}: statement {id} is {c:?}, not checked"),
                None => panic!("{name}: no statement {id} in specs/requirements.yaml"),
            }
        }
    }
}

/// docs/requirements.md lists each mutation with its statements and catching checks, and every
/// other checked statement as not tried: the page is held to this table and to the matrix.
#[test]
fn docs_requirements_md_lists_every_mutation_and_every_statement_not_tried() {
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
    let page = std::fs::read_to_string(root.join("docs/requirements.md")).expect("docs/requirements.md");
    // The table rows: | `Name` | what | `id`, `id` | configuration | check; check |
    let mut rows: BTreeMap<String, (BTreeSet<String>, bool)> = BTreeMap::new();
    for line in page.lines().filter(|l| l.starts_with("| `")) {
        let cells: Vec<&str> = line.split(" | ").collect();
        let name = cells[0].trim_start_matches("| ").trim_matches('`').to_string();
        let ids = cells[2].split(", ").map(|c| c.trim_matches('`').to_string()).collect();
        let caught = !cells.last().unwrap().contains("**not caught**");
        rows.insert(name, (ids, caught));
    }
    for m in MUTATIONS {
        let (ids, caught) =
            rows.get(m.name).unwrap_or_else(|| panic!("docs/requirements.md has no row for {}", m.name));
        let want: BTreeSet<String> = m.statements.iter().map(|s| s.to_string()).collect();
        assert_eq!(ids, &want, "docs/requirements.md: the statements of {}", m.name);
        assert_eq!(*caught, m.caught, "docs/requirements.md: whether {} is caught", m.name);
    }
    for m in SPEC_MUTATIONS {
        let (ids, caught) =
            rows.get(m.name).unwrap_or_else(|| panic!("docs/requirements.md has no row for {}", m.name));
        let want: BTreeSet<String> = m.statements.iter().map(|s| s.to_string()).collect();
        assert_eq!(ids, &want, "docs/requirements.md: the statements of {}", m.name);
        assert!(*caught, "docs/requirements.md: {} is caught", m.name);
    }
    assert_eq!(
        rows.len(),
        MUTATIONS.len() + SPEC_MUTATIONS.len(),
        "docs/requirements.md has rows for mutations the tables lack"
    );
    // The statements not tried: the section's backquoted ids.
    let section = page.split("## Checked statements no mutation was tried on").nth(1).expect("the not-tried section");
    let section = section.split("\n## ").next().unwrap();
    let not_tried: BTreeSet<String> =
        section.split('`').skip(1).step_by(2).filter(|w| w.contains('_')).map(String::from).collect();
    let tried: BTreeSet<String> = MUTATIONS
        .iter()
        .flat_map(|m| m.statements)
        .chain(SPEC_MUTATIONS.iter().flat_map(|m| m.statements))
        .map(|s| s.to_string())
        .collect();
    let spec = Spec::embedded().unwrap();
    let checked: BTreeSet<String> = spec
        .requirements
        .statements
        .iter()
        .filter(|s| s.category() == Category::Checked)
        .map(|s| s.id.clone())
        .collect();
    let want: BTreeSet<String> = checked.difference(&tried).cloned().collect();
    assert_eq!(not_tried, want, "docs/requirements.md: the checked statements no mutation was tried on");
    // The statements caught: the section's backquoted ids.
    let section =
        page.split("## Checked statements whose checks caught a mutation").nth(1).expect("the caught section");
    let section = section.split("\n## ").next().unwrap();
    let listed: BTreeSet<String> =
        section.split('`').skip(1).step_by(2).filter(|w| w.contains('_')).map(String::from).collect();
    let caught: BTreeSet<String> = MUTATIONS
        .iter()
        .filter(|m| m.caught)
        .flat_map(|m| m.statements)
        .chain(SPEC_MUTATIONS.iter().flat_map(|m| m.statements))
        .map(|s| s.to_string())
        .collect();
    assert_eq!(listed, caught, "docs/requirements.md: the checked statements whose checks caught a mutation");
    // The figures of the page's prose, computed here from the tables and the matrix: run with
    // `-- --nocapture` to print them.
    let tried_uncaught = tried.difference(&caught).count();
    let model_caught = MUTATIONS.iter().filter(|m| m.caught).count();
    let figures = [
        format!(
            "Of the {} checked statements, **{} have a check that caught a named mutation** of their rule, **{} tried \
             without a check catching it**, and **{} were not tried**",
            checked.len(),
            caught.len(),
            if tried_uncaught == 0 { "none was".to_string() } else { format!("{tried_uncaught} were") },
            want.len()
        ),
        format!(
            "{} mutations of the model ({model_caught} caught, {} known not to be caught",
            MUTATIONS.len(),
            MUTATIONS.len() - model_caught
        ),
        format!("and {} of the spec files (all caught)", SPEC_MUTATIONS.len()),
        format!(
            "runs the {} mutations of the model and the {} of the spec files",
            MUTATIONS.len(),
            SPEC_MUTATIONS.len()
        ),
        format!("{} statements, by page (the tables above say which mutation and which check)", caught.len()),
        format!("{} statements, by page. Most are checked", want.len()),
    ];
    let prose = page.split_whitespace().collect::<Vec<_>>().join(" ");
    for f in &figures {
        println!("{f}");
        assert!(prose.contains(f.as_str()), "docs/requirements.md does not say: {f}");
    }
}
