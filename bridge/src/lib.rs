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
use pmacwd_core::motion as cm;
use pmacwd_specs::check::{ChecksumTarget, MotionSetup, Processor, ResetKind, MOTORS_MAX};
use pmacwd_specs::config::ModelConfig;
use pmacwd_specs::profiles::{
    Bit12Meaning, EncoderLossClear, OutOfRangeAssignment, RtiWarningLatch, StrobeStop, Strober,
};
use pmacwd_specs::vocab::command::{CsCommand, GlobalCommand, Motion, MotorCommand};
use pmacwd_specs::vocab::observation::{MotionView, MotorState, MotorView, MOTORS_SHOWN};
use pmacwd_specs::vocab::{Buffer, Event, HostCommand, Observation, Register, Reply};

// The core keeps as many motors as a configuration may have (it cannot import the constant).
const _: () = assert!(cm::MOTORS_MAX == MOTORS_MAX && MOTORS_SHOWN == MOTORS_MAX);

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
            encoder_loss_clear_intended: match c.encoder_loss_clear {
                EncoderLossClear::Intent => true,
                EncoderLossClear::Literal => false,
            },
            out_of_range_modulo: cfg.out_of_range() == OutOfRangeAssignment::Modulo,
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
        motion: core_motion_config(&cfg.motion),
        processor: core_processor(cfg.processor),
        other_i_writes_card_own: cfg.other_i_writes == pmacwd_specs::check::OtherIWrites::CardOwn,
    }
}

/// The core's CPU option for the configuration's (SRM p.289).
pub fn core_processor(p: Processor) -> core::Processor {
    match p {
        Processor::Dsp56303 => core::Processor::Dsp56303,
        Processor::Dsp56309 => core::Processor::Dsp56309,
        Processor::Dsp56311 => core::Processor::Dsp56311,
        Processor::Dsp56321 => core::Processor::Dsp56321,
    }
}

/// The core's motors for a configuration's. A trace (deterministic) decelerates for the
/// longest deceleration, as the model does when it is not exploring every length
/// (`Controller::apply`); the exhaustive product sets `decel_cycles` to each length the checker
/// explores (`conformance/src/product.rs`).
pub fn core_motion_config(m: &MotionSetup) -> core::MotionConfig {
    let mut coordinate_systems = [1u8; cm::MOTORS_MAX];
    for (n, cs) in (1..=m.motors).zip(coordinate_systems.iter_mut()) {
        *cs = m.coordinate_system(n);
    }
    core::MotionConfig { motors: m.motors, coordinate_systems, decel_cycles: m.decel_cycles_max }
}

/// The core's motion command for the vocabulary's.
pub fn core_motion(m: &Motion) -> core::MotionCommand {
    match *m {
        Motion::Motor(n, c) => core::MotionCommand::Motor(
            n,
            match c {
                // Direction and target are positions, which neither the model nor the core has.
                MotorCommand::JogPlus | MotorCommand::JogMinus | MotorCommand::JogToPosition => cm::MotorCommand::Jog,
                MotorCommand::JogStop => cm::MotorCommand::JogStop,
                MotorCommand::Kill => cm::MotorCommand::Kill,
            },
        ),
        Motion::CoordinateSystem(n, c) => core::MotionCommand::CoordinateSystem(
            n,
            match c {
                CsCommand::Abort => cm::CsCommand::Abort,
                CsCommand::Quit => cm::CsCommand::Quit,
                CsCommand::EndOfMove => cm::CsCommand::EndOfMove,
                CsCommand::Hold => cm::CsCommand::Hold,
                CsCommand::QuickStop => cm::CsCommand::QuickStop,
                CsCommand::Run => cm::CsCommand::Run,
                CsCommand::Step => cm::CsCommand::Step,
                CsCommand::Begin => cm::CsCommand::Begin,
                CsCommand::Enable => cm::CsCommand::Enable,
                CsCommand::Feedrate(p) => cm::CsCommand::Feedrate(p),
            },
        ),
        Motion::Global(g) => core::MotionCommand::Global(match g {
            GlobalCommand::AbortAll => cm::GlobalCommand::AbortAll,
            GlobalCommand::QuitAll => cm::GlobalCommand::QuitAll,
            GlobalCommand::HoldAll => cm::GlobalCommand::HoldAll,
            GlobalCommand::KillAll => cm::GlobalCommand::KillAll,
        }),
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
        HostCommand::Motion(m) => core::Command::Motion(core_motion(m)),
        HostCommand::Reinitialize => core::Command::Reinitialize,
        HostCommand::Checksum => core::Command::Checksum,
        HostCommand::Gather => core::Command::Gather,
        HostCommand::EndGather => core::Command::EndGather,
        HostCommand::WriteIMemory(n, v) => core::Command::WriteIMemory(*n, *v),
        HostCommand::DefaultI(n) => core::Command::DefaultI(*n),
        HostCommand::Card { forgets, past_lockout, .. } => {
            core::Command::CardOwn { forgets: forgets.map(|r| (r.first, r.count, r.step)), past_lockout: *past_lockout }
        }
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
        Event::EncoderInput(i) => core::Event::EncoderInput { motor: i.motor, lost: i.lost },
        Event::AmplifierFault(i) => core::Event::AmplifierFault { motor: i.motor, fault: i.fault },
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
        core::Reply::CardOwn => Reply::CardOwn,
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
        motion: Some(motion_view(core, cfg)),
    }
}

/// The vocabulary's name for a core motor state.
pub fn vocab_motor_state(s: cm::MotorState) -> MotorState {
    match s {
        cm::MotorState::Killed => MotorState::Killed,
        cm::MotorState::Closed => MotorState::Closed,
        cm::MotorState::Jogging => MotorState::Jogging,
        cm::MotorState::Program => MotorState::Program,
        cm::MotorState::Decelerating => MotorState::Decelerating,
        cm::MotorState::Holding => MotorState::Holding,
    }
}

/// One core motor as an instrument sees it (what lockstep compares).
pub fn motor_view(m: &core::MotorStatus) -> MotorView {
    MotorView {
        state: vocab_motor_state(m.state),
        amplifier_enabled: m.amplifier_enabled,
        output_zero: m.output_zero,
        encoder_lost: m.encoder_lost,
        encoder_loss_status: m.encoder_loss_status,
        amplifier_fault: m.amplifier_fault,
        amplifier_fault_status: m.amplifier_fault_status,
    }
}

/// The core's motors as the vocabulary's observation shows them.
pub fn motion_view(core: &core::Core, cfg: &core::Config) -> MotionView {
    let mut motors = [MotorView::default(); MOTORS_SHOWN];
    let mut count = 0u8;
    for (n, slot) in (1..=cfg.motion.motors).zip(motors.iter_mut()) {
        if let Some(m) = core.motor(cfg, n) {
            *slot = motor_view(&m);
            count = n;
        }
    }
    MotionView { count, motors }
}

/// Motor `n` (from 1) of the core, for an emulator answering `#n?` (SRM p.281, the motor
/// status words): the observed view (state, amplifier enable, commanded output, encoder input,
/// latched loss), the motor's coordinate system, where that system's program stands and the
/// stop under way with its cycles left. `None` for a motor the configuration does not have.
pub fn motor_status(core: &core::Core, cfg: &core::Config, n: u8) -> Option<MotorStatus> {
    core.motor(cfg, n).map(|m| MotorStatus {
        view: motor_view(&m),
        coordinate_system: m.coordinate_system,
        program: m.program,
        stop: m.stop,
    })
}

/// A motor as [`motor_status`] reports it.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct MotorStatus {
    pub view: MotorView,
    /// The motor's coordinate system (1..=16).
    pub coordinate_system: u8,
    /// Where that coordinate system's program stands (running, held, at a program point...).
    pub program: cm::Program,
    /// The stop being carried out (UM p.217's row, as the core's `Stop`) and its servo cycles left.
    pub stop: Option<(cm::Stop, u8)>,
}
