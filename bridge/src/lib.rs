//! The compact core in the vocabulary's terms: its configuration from a resolved
//! [`ModelConfig`], the vocabulary's events and commands as the core's, and the core's replies
//! and observations as the vocabulary's.
//!
//! `pmacwd-core` depends on nothing, so that it can be embedded anywhere and so that it cannot
//! share a wrong constant with the model; this crate is where it meets the rest of the
//! workspace. The conformance suite's `CoreSubject` and the emulator both drive the core
//! through it. Every conversion matches exhaustively, so a new event, command, register or
//! reply is a compile error here until it is mapped.

use pmacwd_core as core;
use pmacwd_specs::check::{ChecksumTarget, ResetKind};
use pmacwd_specs::config::ModelConfig;
use pmacwd_specs::profiles::{Bit12Meaning, RtiWarningLatch, StrobeStop, Strober};
use pmacwd_specs::vocab::{Buffer, Event, HostCommand, Observation, Register, Reply};

/// The core's configuration for a model configuration.
pub fn core_config(cfg: &ModelConfig) -> core::Config {
    let c = &cfg.profile.choices;
    core::Config {
        profile: core::Profile {
            reset_value_i40_zero: c.reset_value_when_i40_zero.cycles(),
            strobe_stop: match c.strobe_stop {
                StrobeStop::AtZero => core::StrobeStop::AtZero,
                StrobeStop::BelowZero => core::StrobeStop::BelowZero,
            },
            rti_strobes: c.strober == Strober::RealTimeInterrupt,
            bit12_firmware_error: c.bit12_meaning == Bit12Meaning::FirmwareChecksumError,
            rti_warning_sticky: c.rti_warning_latch == RtiWarningLatch::Sticky,
        },
        hardware_delay_cycles: cfg.hardware_delay_cycles,
        cycle_units: cfg.cpu.cycle_units,
        servo_units_per_motor: cfg.cpu.servo_units_per_motor,
        move_planning_units: cfg.cpu.move_planning_units,
        saved_i8: cfg.saved.i8,
        saved_i40: cfg.saved.i40,
        saved_i41: cfg.saved.i41,
        pass_firmware: cfg.pass_cycles.firmware,
        pass_user_program: cfg.pass_cycles.user_program,
        supply_min_millivolts: cfg.supply_min_millivolts,
        servo_counter_mask: cfg.servo_counter_mask,
        load: core_load(&cfg.loads[0]),
    }
}

pub fn core_load(l: &pmacwd_specs::check::Load) -> core::Load {
    core::Load { motors: l.motors, plc0_units: l.plc0_units, background_units: l.background_units }
}

/// The spec's load for the core's (the inverse of [`core_load`]).
pub fn spec_load(l: core::Load) -> pmacwd_specs::check::Load {
    pmacwd_specs::check::Load { motors: l.motors, plc0_units: l.plc0_units, background_units: l.background_units }
}

/// The core's command for a model command.
pub fn core_command(c: &HostCommand) -> core::Command {
    match c {
        HostCommand::GlobalStatus => core::Command::GlobalStatus,
        HostCommand::ReadI(n) => core::Command::ReadI(*n),
        HostCommand::WriteI(n, v) => core::Command::WriteI(*n, *v),
        HostCommand::ReadHex(r) => core::Command::ReadHex(match r {
            Register::ServoCycles => core::Register::ServoCycles,
            Register::StatusX => core::Register::StatusX,
            Register::StatusY => core::Register::StatusY,
            Register::WatchdogCounter => core::Register::WatchdogCounter,
            Register::WatchdogMinimum => core::Register::WatchdogMinimum,
            Register::RunningChecksum => core::Register::RunningChecksum,
            Register::ProgramChecksumReference => core::Register::ProgramChecksumReference,
        }),
        HostCommand::Reset => core::Command::Reset,
        HostCommand::Open(Buffer::Plc(_)) => core::Command::OpenPlc,
        HostCommand::Open(Buffer::Program(_)) => core::Command::OpenProgram,
        HostCommand::Close => core::Command::Close,
        HostCommand::Motion(_) => core::Command::Motion,
        HostCommand::Unrecognized(_) => core::Command::Unrecognized,
    }
}

/// The core's event for a model event.
pub fn core_event(e: &Event) -> core::Event {
    match e {
        Event::Servo { cycles } => core::Event::Servo(*cycles),
        Event::Background => core::Event::Background,
        Event::Load(l) => core::Event::Load(core_load(l)),
        Event::Command(c) => core::Event::Command(core_command(c)),
        Event::Supply { millivolts } => core::Event::Supply(*millivolts),
        Event::Reset(r) => core::Event::Reset(core::Reset {
            kind: match r.kind {
                ResetKind::Init => core::ResetKind::Init,
                ResetKind::Power => core::ResetKind::Power,
            },
            dpram_fault: r.dpram_fault,
            flash_fault: r.flash_fault,
            bootstrap: r.bootstrap,
        }),
        Event::ChecksumFault(ChecksumTarget::Firmware) => core::Event::ChecksumFault(core::Area::Firmware),
        Event::ChecksumFault(ChecksumTarget::UserProgram) => core::Event::ChecksumFault(core::Area::UserProgram),
        Event::ClearRtiReentry => core::Event::ClearRtiReentry,
        Event::EncoderInput(_) => core::Event::EncoderInput,
    }
}

/// The vocabulary's reply for the core's.
pub fn vocab_reply(r: core::Reply) -> Reply {
    match r {
        core::Reply::None => Reply::None,
        core::Reply::Silence => Reply::Silence,
        core::Reply::Ack => Reply::Ack,
        core::Reply::Status { x, y } => Reply::Status { x, y },
        core::Reply::Bootstrap => Reply::Bootstrap,
        core::Reply::Value(v) => Reply::Value(v),
        core::Reply::Hex(v) => Reply::Hex(v),
        core::Reply::Error(n) => Reply::Error(n),
    }
}

/// What the core shows after an event, in the model's terms.
pub fn core_observation(core: &core::Core, cfg: &core::Config, reply: core::Reply) -> Observation {
    let o = core.observe(cfg, reply);
    Observation {
        reply: vocab_reply(o.reply),
        led_red: o.tripped,
        fefco_on: o.tripped,
        relay_tripped: o.tripped,
        outputs_forced_off: o.tripped,
        counter: o.counter,
        counter_min: o.counter_min,
        status_x: o.status_x,
        status_y: o.status_y,
        // The core has no motors yet: it reports none, and lockstep does not compare them
        // (conformance's `lockstep::differences_after`, docs/conformance.md).
        motion: None,
    }
}
