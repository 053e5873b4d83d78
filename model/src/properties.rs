//! The named properties the checker verifies, each with the sentence it encodes.
//!
//! - `always` over one state: [`STATE_PROPERTIES`] with [`Expectation::Always`];
//! - `always` over one transition: the monitors of [`crate::monitor::MONITORS`];
//! - bounded liveness is written as `always` ("starved for longer than the reset value plus
//!   the hardware delay implies tripped"), never with `eventually` (stateright 0.30.2's
//!   `eventually` can miss violations on cyclic paths);
//! - reachability as `sometimes`: a witness must exist, or the configuration is too narrow to
//!   show the behaviour at all.

use crate::controller::TripCause;
use crate::motion::{Program, Stop};
use crate::state::State;
use pmacwd_specs::check::{ChecksumTarget, ResetKind};
use pmacwd_specs::config::ModelConfig;
use pmacwd_specs::profiles::EncoderLossClear;
use pmacwd_specs::profiles::{Bit12Meaning, StrobeStop};
use pmacwd_specs::vocab::command::{Buffer, CsCommand, HostCommand, Motion, MotorCommand};
use pmacwd_specs::vocab::event::Reply;
use pmacwd_specs::vocab::MotorState;
use pmacwd_specs::vocab::Observation;

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Expectation {
    Always,
    Sometimes,
}

pub struct StateProperty {
    pub name: &'static str,
    pub expectation: Expectation,
    pub cite: &'static str,
    pub sentence: &'static str,
    pub holds: fn(&ModelConfig, &State) -> bool,
    /// Whether the configuration offers the events this property needs; a `sometimes`
    /// property that does not apply is reported as such instead of as unreachable. Every
    /// `sometimes` property must be reached by some configuration of every profile (a test
    /// in `conformance/` checks that).
    pub applies: fn(&ModelConfig) -> bool,
    /// What `applies` looks for, for the report.
    pub needs: &'static str,
}

fn any(_: &ModelConfig) -> bool {
    true
}

/// Some load's RTI task set is longer than its RTI period leaves it.
fn can_overrun(cfg: &ModelConfig) -> bool {
    cfg.loads.iter().any(|l| {
        let free = u32::from(cfg.cpu.cycle_units)
            .saturating_sub(u32::from(l.motors) * u32::from(cfg.cpu.servo_units_per_motor));
        let rti = u32::from(l.plc0_units) + u32::from(cfg.cpu.move_planning_units);
        rti > (u32::from(cfg.saved.i8) + 1) * free
    })
}

fn can_overload_servo(cfg: &ModelConfig) -> bool {
    cfg.loads
        .iter()
        .any(|l| u32::from(l.motors) * u32::from(cfg.cpu.servo_units_per_motor) > u32::from(cfg.cpu.cycle_units))
}

fn has_command(cfg: &ModelConfig, f: fn(&HostCommand) -> bool) -> bool {
    cfg.commands.iter().any(f)
}

fn obs(cfg: &ModelConfig, s: &State) -> Observation {
    crate::observe::of(&s.controller, cfg, Reply::None)
}

fn x_bit(cfg: &ModelConfig, s: &State, bit: (pmacwd_specs::status::WordId, u8)) -> bool {
    let (x, y) = s.controller.status_words(cfg);
    let word = match bit.0 {
        pmacwd_specs::status::WordId::X => x,
        pmacwd_specs::status::WordId::Y => y,
    };
    word & (1 << bit.1) != 0
}

fn running(s: &State) -> bool {
    !s.controller.tripped() && !s.controller.bootstrap
}

fn has_motion(cfg: &ModelConfig, f: fn(Motion) -> bool) -> bool {
    cfg.commands.iter().any(|c| matches!(c, HostCommand::Motion(m) if f(*m)))
}

fn motors(s: &State) -> &[crate::motion::Motor] {
    s.controller.axes.motors()
}

use Expectation::{Always, Sometimes};

pub const STATE_PROPERTIES: &[StateProperty] = &[
    // ------------------------------------------------------------ what a trip does (UM p.215)
    StateProperty {
        name: "a tripped card forces discrete outputs off and proportional outputs to zero",
        expectation: Always,
        applies: any,
        needs: "",
        cite: "UM p.215",
        sentence: "All Servo, MACRO, and I/O ICs are forced into their reset states, which force discrete outputs off, and proportional outputs (DAC, PWM, PFM) to zero-level.",
        holds: |cfg, s| !s.controller.tripped() || obs(cfg, s).outputs_forced_off,
    },
    StateProperty {
        name: "a tripped card lights the red watchdog LED",
        expectation: Always,
        applies: any,
        needs: "",
        cite: "UM p.215",
        sentence: "the system is latched into a reset state, with a red LED indicating watchdog failure.",
        holds: |cfg, s| !s.controller.tripped() || obs(cfg, s).led_red,
    },
    StateProperty {
        name: "a tripped Turbo PMAC turns FEFCO/ on",
        expectation: Always,
        applies: any,
        needs: "",
        cite: "UM p.215",
        sentence: "there is a solid-state open-collector output called FEFCO/ that is turned on when the timer trips.",
        holds: |cfg, s| !s.controller.tripped() || obs(cfg, s).fefco_on,
    },
    StateProperty {
        name: "a tripped Turbo PMAC2 changes its watchdog relay over",
        expectation: Always,
        applies: any,
        needs: "",
        cite: "UM p.215",
        sentence: "In Turbo PMAC2 systems there is a hard-contact relay with both normally open and normally closed contacts.",
        holds: |cfg, s| !s.controller.tripped() || obs(cfg, s).relay_tripped,
    },
    StateProperty {
        name: "a running card shows no trip on its LED, FEFCO/, relay or outputs",
        expectation: Always,
        applies: any,
        needs: "",
        cite: "UM p.215",
        sentence: "FEFCO/ ... is turned on when the timer trips (and not otherwise).",
        holds: |cfg, s| {
            let o = obs(cfg, s);
            s.controller.tripped() || !(o.led_red || o.fefco_on || o.relay_tripped || o.outputs_forced_off)
        },
    },
    StateProperty {
        name: "after a trip every amplifier is disabled, every output zero and no motor moves",
        expectation: Always,
        applies: any,
        needs: "",
        cite: "UM p.215",
        sentence: "All Servo, MACRO, and I/O ICs are forced into their reset states, which force discrete outputs off, and proportional outputs (DAC, PWM, PFM) to zero-level.",
        holds: |_, s| {
            !s.controller.tripped()
                || motors(s).iter().all(|m| !m.amplifier_enabled && m.output_zero && !m.state.moving())
        },
    },
    // ------------------------------------------------------------ motors (UM p.217, p.319)
    StateProperty {
        name: "a motor's amplifier is enabled and its output live exactly when it is not killed",
        expectation: Always,
        applies: any,
        needs: "",
        cite: "SRM p.281",
        sentence: "Amplifier Enabled: This bit is 1 when the outputs for this motor's amplifier are enabled ... It is 0 when the outputs are disabled (killed).",
        holds: |_, s| {
            motors(s).iter().all(|m| {
                let killed = m.state == MotorState::Killed;
                m.amplifier_enabled != killed && m.output_zero == killed
            })
        },
    },
    StateProperty {
        name: "on a running card an executing program has no killed motor",
        expectation: Always,
        applies: any,
        needs: "",
        cite: "UM p.319",
        sentence: "the motor-specific K kill command is not permitted when the motor is in a coordinate system that is executing a motion program.",
        holds: |cfg, s| {
            !running(s)
                || motors(s).iter().enumerate().all(|(k, m)| {
                    let cs = cfg.motion.coordinate_system(k as u8 + 1);
                    !s.controller.axes.programs()[usize::from(cs) - 1].executing() || m.state != MotorState::Killed
                })
        },
    },
    StateProperty {
        name: "a stop under way ends within the longest deceleration",
        expectation: Always,
        applies: any,
        needs: "",
        cite: "UM p.217",
        sentence: "Decel Rate: Ixx19-21, Ixx15, TA/TS, Isx95, Ixx17 (MODEL: each a length of 1 to decel_cycles_max servo cycles).",
        holds: |cfg, s| {
            motors(s).iter().all(|m| m.stop.is_some() == (m.stop_cycles > 0) && m.stop_cycles <= cfg.motion.decel_cycles_max)
        },
    },
    // ------------------------------------------------------------ hardware conditions
    StateProperty {
        name: "a supply below the minimum means tripped",
        expectation: Always,
        applies: any,
        needs: "",
        cite: "UM p.215",
        sentence: "it must see a DC voltage greater than approximately 4.75V.",
        holds: |_, s| !s.controller.supply_low || s.controller.tripped(),
    },
    StateProperty {
        name: "a strobe gap longer than the hardware delay means tripped",
        expectation: Always,
        applies: any,
        needs: "",
        cite: "UM p.215",
        sentence: "the timer must see a square wave input ... of a frequency greater than approximately 25 Hz.",
        holds: |cfg, s| s.controller.cycles_since_strobe <= cfg.hardware_delay_cycles || s.controller.tripped(),
    },
    StateProperty {
        name: "a background starved for longer than the reset value plus the hardware delay means tripped",
        expectation: Always,
        applies: any,
        needs: "",
        cite: "SRM p.57",
        sentence: "one background cycle must execute every I40 servo cycles, or the board will shut down.",
        holds: |cfg, s| {
            let c = &s.controller;
            !running(s) || i64::from(c.ghost.cycles_since_background) <= i64::from(c.ghost.last_reload) + i64::from(cfg.hardware_delay_cycles)
        },
    },
    // ------------------------------------------------------------ the counter and X:$25
    StateProperty {
        name: "X:$25 is never above the watchdog counter Y:$25",
        expectation: Always,
        applies: any,
        needs: "",
        cite: "SRM p.57",
        sentence: "Register X:$25 contains the lowest value that the counter has reached before being reset since the last power-on/reset.",
        holds: |_, s| s.controller.counter_min <= s.controller.counter,
    },
    StateProperty {
        name: "the counter never exceeds the value it was last loaded with",
        expectation: Always,
        applies: any,
        needs: "",
        cite: "UM p.215",
        sentence: "the CPU resets the counter value to a maximum value set by variable I40.",
        holds: |_, s| s.controller.counter <= s.controller.ghost.last_reload,
    },
    StateProperty {
        name: "under the at-zero reading the counter never goes below zero",
        expectation: Always,
        applies: any,
        needs: "",
        cite: "UM p.215",
        sentence: "the servo-interrupt routine decrements a counter (as long as the counter is greater than zero).",
        holds: |cfg, s| cfg.profile.choices.strobe_stop != StrobeStop::AtZero || s.controller.counter >= 0,
    },
    // ------------------------------------------------------------ checksums (UM p.217, SRM p.289)
    StateProperty {
        name: "after a firmware checksum error bits 12 and 13 are set",
        expectation: Always,
        applies: any,
        needs: "",
        cite: "UM p.217",
        sentence: "it sets global status bits (bits 12 and 13 of X:$000006).",
        holds: |cfg, s| {
            s.controller.checksum.error != Some(ChecksumTarget::Firmware)
                || (x_bit(cfg, s, cfg.layout.checksum_error) && x_bit(cfg, s, cfg.layout.prom_checksum_active))
        },
    },
    StateProperty {
        name: "after a user-program checksum error bit 13 is set and bit 12 clear",
        expectation: Always,
        applies: any,
        needs: "",
        cite: "SRM p.289",
        sentence: "It is 0 if Turbo PMAC ... has found a user program checksum error (Bit 13 = 1).",
        holds: |cfg, s| {
            s.controller.checksum.error != Some(ChecksumTarget::UserProgram)
                || (x_bit(cfg, s, cfg.layout.checksum_error) && !x_bit(cfg, s, cfg.layout.prom_checksum_active))
        },
    },
    StateProperty {
        name: "bit 13 is set exactly when a checksum error has been found",
        expectation: Always,
        applies: any,
        needs: "",
        cite: "SRM p.289",
        sentence: "Bit 13 Any Memory Checksum Error: This bit is 1 if a checksum error has been detected for either the Turbo PMAC firmware or the user program buffer space.",
        holds: |cfg, s| x_bit(cfg, s, cfg.layout.checksum_error) == s.controller.checksum.error.is_some(),
    },
    StateProperty {
        name: "bits X21 and Y21 of ??? report the configured processor",
        expectation: Always,
        applies: any,
        needs: "",
        cite: "SRM p.289",
        sentence: "Bit 21 CPU Type Bit 1: This bit is 1 if the Turbo PMAC has an Option 5Ex DSP56311 or an Option 5Fx DSP56321 processor ... bit 21 in the second word returned (Y:$000006) distinguishes between processor types.",
        holds: |cfg, s| {
            let (bit1, bit0) = cfg.processor.type_bits();
            x_bit(cfg, s, cfg.layout.cpu_type_bit1) == bit1 && x_bit(cfg, s, cfg.layout.cpu_type_bit0) == bit0
        },
    },
    StateProperty {
        name: "bits X17 and X14 of ??? stay 0: the card gathers on no trigger and runs no leadscrew compensation",
        expectation: Always,
        applies: any,
        needs: "",
        cite: "SRM p.289",
        sentence: "Bit 17 Data Gather to Start on Trigger: ... It is 0 otherwise. ... Bit 14 Leadscrew Compensation On: ... It is 0 if the compensation is not active.",
        // SRM p.289: the positions as the page prints them, not from status.yaml's layout, so
        // that a driven bit placed on one of them (Y17, PLC buffer open, put in the X word)
        // is caught. MODEL: the model has neither function; no command of its own starts one
        // (a host's `GATHER TRIGGER`-style setup and `DEFINE GATHER` are the card's own,
        // docs/grammar.md). Bit 19 (data gathering on) is driven: see its monitor.
        holds: |cfg, s| {
            const NOT_MODELLED: u32 = (1 << 17) | (1 << 14);
            s.controller.status_words(cfg).0 & NOT_MODELLED == 0
        },
    },
    // ------------------------------------------------------------ reachability
    StateProperty {
        name: "bit 22 (RTI re-entry) can be set",
        expectation: Sometimes,
        applies: can_overrun,
        needs: "a load whose RTI tasks outlast their period",
        cite: "SRM p.289",
        sentence: "This bit is 1 if a real-time interrupt task has taken long enough so that it was still executing when the next real-time interrupt came.",
        holds: |cfg, s| running(s) && x_bit(cfg, s, cfg.layout.rti_reentry),
    },
    StateProperty {
        name: "bit 9 (RTI warning) can be set",
        expectation: Sometimes,
        applies: can_overrun,
        needs: "a load whose RTI tasks outlast their period",
        cite: "SRM p.290",
        sentence: "an RTI task (motion program or PLC 0) took more than one interrupt period.",
        holds: |cfg, s| running(s) && x_bit(cfg, s, cfg.layout.rti_warning),
    },
    StateProperty {
        name: "bit 20 (servo error) can be set",
        expectation: Sometimes,
        applies: can_overload_servo,
        needs: "a load with more servo work than a cycle",
        cite: "SRM p.289",
        sentence: "This bit is 1 if Turbo PMAC could not properly complete its servo routines.",
        holds: |cfg, s| running(s) && x_bit(cfg, s, cfg.layout.servo_error),
    },
    StateProperty {
        name: "a firmware checksum error can be found",
        expectation: Sometimes,
        applies: |c| c.checksum_faults.contains(&ChecksumTarget::Firmware),
        needs: "an injected firmware fault",
        cite: "UM p.217",
        sentence: "If Turbo PMAC detects a mismatch between its calculated checksum and the reference checksum, it sets global status bits.",
        holds: |_, s| running(s) && s.controller.checksum.error == Some(ChecksumTarget::Firmware),
    },
    StateProperty {
        name: "a user-program checksum error can be found",
        expectation: Sometimes,
        applies: |c| c.checksum_faults.contains(&ChecksumTarget::UserProgram),
        needs: "an injected user-program fault",
        cite: "UM p.217",
        sentence: "If Turbo PMAC detects a mismatch between these two checksums, it sets a global status bit (bit 13).",
        holds: |_, s| running(s) && s.controller.checksum.error == Some(ChecksumTarget::UserProgram),
    },
    StateProperty {
        name: "bit 12 can show a firmware pass in progress (prom_checksum_active reading)",
        expectation: Sometimes,
        applies: any,
        needs: "",
        cite: "SRM p.289",
        sentence: "This bit is 1 if Turbo PMAC is currently evaluating a firmware checksum (Bit 13 = 0).",
        holds: |cfg, s| {
            cfg.profile.choices.bit12_meaning == Bit12Meaning::FirmwareChecksumError
                || (running(s) && x_bit(cfg, s, cfg.layout.prom_checksum_active) && !x_bit(cfg, s, cfg.layout.checksum_error))
        },
    },
    StateProperty {
        name: "bit 12 can show a user-program pass in progress",
        expectation: Sometimes,
        applies: any,
        needs: "",
        cite: "SRM p.289",
        sentence: "It is 0 if Turbo PMAC is evaluating a user program checksum (Bit 13 = 0).",
        holds: |cfg, s| running(s) && s.controller.checksum.error.is_none() && s.controller.checksum.area == ChecksumTarget::UserProgram && !x_bit(cfg, s, cfg.layout.prom_checksum_active),
    },
    StateProperty {
        name: "bit 11 (DPRAM error) can be set",
        expectation: Sometimes,
        applies: |c| c.resets.iter().any(|r| r.dpram_fault),
        needs: "a reset that finds a DPRAM fault",
        cite: "SRM p.289",
        sentence: "This bit is 1 if Turbo PMAC detected an error in its automatic DPRAM check function at power-up/reset.",
        holds: |cfg, s| running(s) && x_bit(cfg, s, cfg.layout.dpram_error),
    },
    StateProperty {
        name: "bit 10 (flash error) can be set",
        expectation: Sometimes,
        applies: |c| c.resets.iter().any(|r| r.flash_fault),
        needs: "a reset that finds a flash fault",
        cite: "SRM p.289",
        sentence: "This bit is 1 if Turbo PMAC detected a checksum error in reading saved data from the flash memory on board reset.",
        holds: |cfg, s| running(s) && x_bit(cfg, s, cfg.layout.flash_error),
    },
    StateProperty {
        name: "bit 19 (data gathering on) can be set",
        expectation: Sometimes,
        applies: |c| has_command(c, |x| matches!(x, HostCommand::Gather)),
        needs: "a GATHER command",
        cite: "SRM p.289",
        sentence: "Bit 19 Data Gathering Function On : This bit is 1 when the data gathering function is active",
        holds: |cfg, s| running(s) && x_bit(cfg, s, cfg.layout.data_gathering_on),
    },
    StateProperty {
        name: "second-word bit 19 (motion buffer open) can be set",
        expectation: Sometimes,
        applies: |c| has_command(c, |x| matches!(x, HostCommand::Open(Buffer::Program(_)))),
        needs: "an OPEN PROG command",
        cite: "GlobalStatus.py",
        sentence: "motion buffer (PROG or ROT) open.",
        holds: |cfg, s| running(s) && x_bit(cfg, s, cfg.layout.motion_buffer_open),
    },
    StateProperty {
        name: "second-word bit 17 (PLC buffer open) can be set",
        expectation: Sometimes,
        applies: |c| has_command(c, |x| matches!(x, HostCommand::Open(Buffer::Plc(_)))),
        needs: "an OPEN PLC command",
        cite: "GlobalStatus.py",
        sentence: "PLC buffer open.",
        holds: |cfg, s| running(s) && x_bit(cfg, s, cfg.layout.plc_buffer_open),
    },
    StateProperty {
        name: "the card can start in bootstrap mode",
        expectation: Sometimes,
        applies: |c| c.resets.iter().any(|r| r.bootstrap),
        needs: "a reset with the bootstrap jumper on",
        cite: "SRM p.289",
        sentence: "If the Turbo PMAC is in bootstrap mode (suitable for the downloading of new firmware) ...",
        holds: |_, s| s.controller.bootstrap && !s.controller.tripped(),
    },
    StateProperty {
        name: "the card can trip on low supply voltage",
        expectation: Sometimes,
        applies: |c| c.supply_millivolts.iter().any(|mv| *mv < c.supply_min_millivolts),
        needs: "a supply voltage below the minimum",
        cite: "UM p.215",
        sentence: "If the supply voltage is below this value, the circuit's relay will trip and the card will shut down.",
        holds: |_, s| s.controller.trip == Some(TripCause::Undervoltage),
    },
    StateProperty {
        name: "the card can trip on a starved background",
        expectation: Sometimes,
        applies: any,
        needs: "",
        cite: "UM p.236",
        sentence: "In the worst case, the watchdog timer will trip, shutting down the card, because the housekeeping tasks in background did not have the time to keep it updated.",
        holds: |_, s| s.controller.trip == Some(TripCause::StrobeTimeout),
    },
    StateProperty {
        name: "a tripped card can be recovered by INIT/",
        expectation: Sometimes,
        applies: |c| c.resets.iter().any(|r| r.kind == ResetKind::Init),
        needs: "an INIT/ reset",
        cite: "UM p.215",
        sentence: "the INIT/ hardware reset line must be taken low, then high, to restore normal functioning.",
        holds: |_, s| running(s) && s.controller.ghost.recovered_by == Some(ResetKind::Init),
    },
    StateProperty {
        name: "a tripped card can be recovered by a power cycle",
        expectation: Sometimes,
        applies: |c| c.resets.iter().any(|r| r.kind == ResetKind::Power),
        needs: "a power cycle",
        cite: "UM p.215",
        sentence: "power to the Turbo PMAC must be cycled off and on.",
        holds: |_, s| running(s) && s.controller.ghost.recovered_by == Some(ResetKind::Power),
    },
    StateProperty {
        name: "a motor can jog",
        expectation: Sometimes,
        applies: |c| has_motion(c, |m| matches!(m, Motion::Motor(_, MotorCommand::JogPlus))),
        needs: "a J+ command",
        cite: "UM p.217",
        sentence: "J/: Scope Motor, Begin Immed? Yes, Decel Rate Ixx19-21 (a jog to stop).",
        holds: |_, s| running(s) && motors(s).iter().any(|m| m.state == MotorState::Jogging),
    },
    StateProperty {
        name: "a program can finish its calculated moves after Q",
        expectation: Sometimes,
        applies: |c| has_motion(c, |m| matches!(m, Motion::CoordinateSystem(_, CsCommand::Quit))),
        needs: "a Q command",
        cite: "UM p.217",
        sentence: "Q: Begin Immed? No ... Finishes calculated moves.",
        holds: |_, s| running(s) && motors(s).iter().any(|m| m.state == MotorState::Program && m.stop == Some(Stop::Quit)),
    },
    StateProperty {
        name: "a program can be held on its path, its motors at rest",
        expectation: Sometimes,
        applies: |c| has_motion(c, |m| matches!(m, Motion::CoordinateSystem(_, CsCommand::Hold))),
        needs: "an H command",
        cite: "UM p.217",
        sentence: "H: Stop on Path? Yes ... Similar to %0.",
        holds: |_, s| running(s) && s.controller.axes.programs().contains(&Program::Held) && motors(s).iter().any(|m| m.state == MotorState::Holding),
    },
    StateProperty {
        name: "an aborted program can lose its lookahead while its motors decelerate",
        expectation: Sometimes,
        applies: |c| has_motion(c, |m| matches!(m, Motion::CoordinateSystem(_, CsCommand::Abort))),
        needs: "an A command",
        cite: "UM p.319",
        sentence: "Segments and synchronous M-variable assignments already in the lookahead buffer are discarded; they cannot be recovered.",
        holds: |_, s| {
            running(s)
                && s.controller.axes.programs().contains(&Program::Lost)
                && motors(s).iter().any(|m| m.stop == Some(Stop::Abort))
        },
    },
    StateProperty {
        name: "an amplifier fault can kill a motor, leaving its fault status set",
        expectation: Sometimes,
        applies: |c| c.motion.amplifier_fault_inputs,
        needs: "amplifier-fault inputs (check.yaml motion.amplifier_fault_inputs)",
        cite: "UM p.213",
        sentence: "The offending motor is killed ... Turbo PMAC sets the amplifier fault motor status bit.",
        holds: |_, s| running(s) && s.controller.axes.motors().iter().any(|m| m.fault_status && m.state == MotorState::Killed),
    },
    StateProperty {
        name: "the encoder-loss PLC can kill a motor and latch the loss",
        expectation: Sometimes,
        applies: |c| c.motion.encoder_inputs,
        needs: "encoder inputs",
        cite: "UM p.214-215",
        sentence: "the encoder-loss PLC kills a motor when its feedback is lost.",
        holds: |_, s| running(s) && motors(s).iter().any(|m| m.state == MotorState::Killed && m.loss_status),
    },
    StateProperty {
        name: "the encoder-loss PLC can find a re-enabled motor with its encoder OK and a latched loss, and clear it as its reading says",
        expectation: Sometimes,
        applies: |c| c.motion.encoder_inputs && has_motion(c, |m| matches!(m, Motion::Motor(_, MotorCommand::JogStop))),
        needs: "encoder inputs and a J/ command",
        cite: "UM p.215",
        sentence: "IF (Mtr1OpenLoop=0 AND Enc1LossIn=OK AND Mtr1EncLossStatus=0) Mtr1EncLossStatus=0: as printed the latched loss stays (bit 1 of the ghost); as intended it clears (bit 0).",
        holds: |cfg, s| {
            running(s)
                && s.controller.axes.ghost_healthy_latched_scans
                    == match cfg.profile.choices.encoder_loss_clear {
                        EncoderLossClear::Intent => 1,
                        EncoderLossClear::Literal => 2,
                    }
        },
    },
    StateProperty {
        name: "a near miss leaves X:$25 at the last strobing value on a running card",
        expectation: Sometimes,
        applies: any,
        needs: "",
        cite: "UM p.240",
        sentence: "X:$000025 ... near 0 means the card nearly tripped.",
        holds: |_, s| running(s) && s.controller.counter_min == 0 && s.controller.counter > 0,
    },
];

#[cfg(test)]
mod tests {
    //! Each `always` property handed a state its sentence forbids (it must fail) and states it
    //! allows (it must hold). A property weakened until it holds everywhere still holds on every
    //! state a correct model reaches, so no checker run can notice; only such a hand-made state
    //! shows it (cargo-mutants: the survivors of properties.rs).
    use super::*;
    use crate::controller::Controller;
    use pmacwd_specs::vocab::event::Event;
    use pmacwd_specs::vocab::HostCommand;
    use pmacwd_specs::Spec;

    fn config(name: &str, profile: &str) -> ModelConfig {
        let spec = Spec::embedded().unwrap();
        ModelConfig::from_spec(&spec, name, &spec.profiles.get(profile).unwrap()).unwrap()
    }

    /// The `holds` of the property named `name`, with its expectation checked.
    fn holds(name: &str, expectation: Expectation) -> fn(&ModelConfig, &State) -> bool {
        let p = STATE_PROPERTIES.iter().find(|p| p.name == name).unwrap_or_else(|| panic!("no property {name:?}"));
        assert_eq!(p.expectation, expectation, "{name}");
        p.holds
    }

    fn state(c: Controller) -> State {
        State { controller: c, violations: 0 }
    }

    /// `motion` after power-on and `commands` (motor 1 in &1, motor 2 in &2).
    fn motion_card(commands: &[&str]) -> (ModelConfig, Controller) {
        let cfg = config("motion", "um-215");
        let mut c = Controller::power_on(&cfg);
        for text in commands {
            c.apply(&cfg, &Event::Command(HostCommand::parse(text).unwrap()));
        }
        (cfg, c)
    }

    /// `c` after a supply sag below the minimum: tripped as the model trips.
    fn tripped(cfg: &ModelConfig, c: &Controller) -> Controller {
        let mut t = c.clone();
        t.apply(cfg, &Event::Supply { millivolts: cfg.supply_min_millivolts - 1 });
        assert!(t.tripped());
        t
    }

    #[test]
    fn sentence_um_215_a_tripped_card_shows_every_trip_output_and_a_running_one_none() {
        // UM p.215: a trip forces the ICs' outputs off, lights the red LED, turns FEFCO/ on
        // and changes the PMAC2 relay over; FEFCO/ is on "when the timer trips" (and not
        // otherwise). Each of the five properties fails when one output disagrees.
        let (cfg, c) = motion_card(&["#1J/", "#1J+"]);
        let t = tripped(&cfg, &c);
        type Output = fn(&mut crate::controller::Outputs) -> &mut bool;
        let outputs: [(&str, Output); 4] = [
            ("a tripped card forces discrete outputs off and proportional outputs to zero", |o| &mut o.forced_off),
            ("a tripped card lights the red watchdog LED", |o| &mut o.led_red),
            ("a tripped Turbo PMAC turns FEFCO/ on", |o| &mut o.fefco_on),
            ("a tripped Turbo PMAC2 changes its watchdog relay over", |o| &mut o.relay_tripped),
        ];
        let quiet = holds("a running card shows no trip on its LED, FEFCO/, relay or outputs", Always);
        for (name, output) in outputs {
            let p = holds(name, Always);
            assert!(p(&cfg, &state(t.clone())) && p(&cfg, &state(c.clone())), "{name}: the model's states hold");
            let mut off = t.clone();
            *output(&mut off.outputs) = false;
            assert!(!p(&cfg, &state(off)), "{name}: a tripped card without it fails");
            assert!(quiet(&cfg, &state(t.clone())), "a tripped card showing it is no running card's business");
            let mut on = c.clone();
            *output(&mut on.outputs) = true;
            assert!(!quiet(&cfg, &state(on)), "{name}: a running card showing it fails");
        }
        assert!(quiet(&cfg, &state(c)), "a running card showing nothing holds");
    }

    #[test]
    fn sentence_um_215_after_a_trip_no_amplifier_is_enabled_no_output_live_and_no_motor_moves() {
        // UM p.215: "All Servo, MACRO, and I/O ICs are forced into their reset states, which
        // force discrete outputs off, and proportional outputs (DAC, PWM, PFM) to zero-level."
        let p = holds("after a trip every amplifier is disabled, every output zero and no motor moves", Always);
        let (cfg, c) = motion_card(&["#1J/", "#2J/", "#2J+"]);
        assert!(p(&cfg, &state(c.clone())), "a running card with a jogging motor holds");
        let t = tripped(&cfg, &c);
        assert!(p(&cfg, &state(t.clone())), "the model's trip holds");
        for k in 0..2 {
            let mut on = t.clone();
            on.axes.motors_mut()[k].amplifier_enabled = true;
            assert!(!p(&cfg, &state(on)), "motor {}'s amplifier enabled after the trip fails", k + 1);
            let mut live = t.clone();
            live.axes.motors_mut()[k].output_zero = false;
            assert!(!p(&cfg, &state(live)), "motor {}'s output live after the trip fails", k + 1);
            let mut moving = t.clone();
            moving.axes.motors_mut()[k].state = MotorState::Jogging;
            assert!(!p(&cfg, &state(moving)), "motor {} jogging after the trip fails", k + 1);
        }
    }

    #[test]
    fn sentence_srm_281_the_amplifier_is_enabled_and_the_output_live_exactly_when_the_motor_is_not_killed() {
        // SRM p.281: Amplifier Enabled "is 1 when the outputs for this motor's amplifier are
        // enabled ... It is 0 when the outputs are disabled (killed)".
        let p = holds("a motor's amplifier is enabled and its output live exactly when it is not killed", Always);
        let (cfg, c) = motion_card(&["#2J/"]);
        assert_eq!((c.axes.motors()[0].state, c.axes.motors()[1].state), (MotorState::Killed, MotorState::Closed));
        assert!(p(&cfg, &state(c.clone())), "the model's killed and enabled motors hold");
        for (k, what) in [(0, "killed"), (1, "enabled")] {
            let mut amp = c.clone();
            amp.axes.motors_mut()[k].amplifier_enabled ^= true;
            assert!(!p(&cfg, &state(amp)), "an {what} motor with its amplifier flipped fails");
            let mut out = c.clone();
            out.axes.motors_mut()[k].output_zero ^= true;
            assert!(!p(&cfg, &state(out)), "an {what} motor with its output flipped fails");
        }
    }

    #[test]
    fn sentence_um_319_on_a_running_card_no_motor_of_an_executing_program_is_killed() {
        // UM p.319: K "is not permitted when the motor is in a coordinate system that is
        // executing a motion program". Motor 2 is in &2, which runs nothing.
        let p = holds("on a running card an executing program has no killed motor", Always);
        let (cfg, c) = motion_card(&["#1J/", "&1B", "&1R"]);
        assert_eq!(c.axes.programs()[0], Program::Running);
        assert_eq!(c.axes.motors()[1].state, MotorState::Killed);
        assert!(p(&cfg, &state(c.clone())), "the model's state (motor 2 killed, &2 idle) holds");
        let mut killed = c.clone();
        killed.axes.motors_mut()[0].state = MotorState::Killed;
        assert!(!p(&cfg, &state(killed.clone())), "motor 1 killed while &1 runs fails");
        let mut t = killed.clone();
        t.trip = Some(TripCause::StrobeTimeout);
        assert!(p(&cfg, &state(t)), "a tripped card is not running: holds");
        let mut lost = killed;
        lost.axes.programs_mut()[0] = Program::Lost;
        assert!(p(&cfg, &state(lost)), "a killed motor of an aborted program holds");
    }

    #[test]
    fn sentence_um_217_a_stop_under_way_lasts_one_to_decel_cycles_max_servo_cycles() {
        // UM p.217: each stop decelerates at its rate (MODEL: 1 to decel_cycles_max cycles);
        // a stop under way has cycles left, and no cycles are left without one.
        let p = holds("a stop under way ends within the longest deceleration", Always);
        let (cfg, c) = motion_card(&["#1J/", "#1J+"]);
        let max = cfg.motion.decel_cycles_max;
        let with = |stop: Option<Stop>, cycles: u8| {
            let mut s = c.clone();
            s.axes.motors_mut()[0].stop = stop;
            s.axes.motors_mut()[0].stop_cycles = cycles;
            state(s)
        };
        assert!(p(&cfg, &with(None, 0)));
        assert!(p(&cfg, &with(Some(Stop::Jog), 1)));
        assert!(p(&cfg, &with(Some(Stop::Jog), max)), "the longest deceleration holds");
        assert!(!p(&cfg, &with(Some(Stop::Jog), max + 1)), "one cycle longer fails");
        assert!(!p(&cfg, &with(Some(Stop::Jog), 0)), "a stop with no cycles left fails");
        assert!(!p(&cfg, &with(None, 1)), "cycles left without a stop fail");
    }

    #[test]
    fn sentence_um_215_a_low_supply_and_a_long_strobe_gap_each_mean_tripped() {
        // UM p.215: the timer must see more than about 4.75 V and a strobe faster than about
        // 25 Hz; a gap longer than the hardware delay, or a low supply, on a running card fails.
        let cfg = config("lockout", "um-215");
        let running = Controller::power_on(&cfg);
        let supply = holds("a supply below the minimum means tripped", Always);
        let strobe = holds("a strobe gap longer than the hardware delay means tripped", Always);
        let mut low = running.clone();
        low.supply_low = true;
        assert!(!supply(&cfg, &state(low.clone())), "running on a low supply fails");
        low.trip = Some(TripCause::Undervoltage);
        assert!(supply(&cfg, &state(low)) && supply(&cfg, &state(running.clone())));
        let mut gap = running.clone();
        gap.cycles_since_strobe = cfg.hardware_delay_cycles;
        assert!(strobe(&cfg, &state(gap.clone())), "a gap of exactly the delay holds");
        gap.cycles_since_strobe += 1;
        assert!(!strobe(&cfg, &state(gap.clone())), "one cycle longer, running, fails");
        gap.trip = Some(TripCause::StrobeTimeout);
        assert!(strobe(&cfg, &state(gap)), "one cycle longer, tripped, holds");
    }

    #[test]
    fn sentence_srm_57_a_background_starved_past_the_reset_value_plus_the_delay_means_tripped() {
        // SRM p.57: "one background cycle must execute every I40 servo cycles, or the board
        // will shut down" (plus the hardware delay, UM p.215).
        let p =
            holds("a background starved for longer than the reset value plus the hardware delay means tripped", Always);
        let cfg = config("lockout", "um-215");
        let mut c = Controller::power_on(&cfg);
        c.ghost.last_reload = 3;
        c.ghost.cycles_since_background = 3 + cfg.hardware_delay_cycles;
        assert!(p(&cfg, &state(c.clone())), "exactly the reset value plus the delay holds");
        c.ghost.cycles_since_background += 1;
        assert!(!p(&cfg, &state(c.clone())), "one cycle more, running, fails");
        c.trip = Some(TripCause::StrobeTimeout);
        assert!(p(&cfg, &state(c)), "one cycle more, tripped, holds");
    }

    #[test]
    fn sentence_srm_57_and_um_215_x25_at_most_y25_and_y25_at_most_its_last_reload() {
        // SRM p.57: X:$25 is "the lowest value that the counter has reached"; UM p.215: the
        // counter is reset "to a maximum value set by variable I40"; UM p.215 (at zero): the
        // counter is decremented "as long as the counter is greater than zero".
        let cfg = config("lockout", "um-215");
        let min = holds("X:$25 is never above the watchdog counter Y:$25", Always);
        let max = holds("the counter never exceeds the value it was last loaded with", Always);
        let zero = holds("under the at-zero reading the counter never goes below zero", Always);
        let mut c = Controller::power_on(&cfg);
        (c.counter, c.counter_min, c.ghost.last_reload) = (2, 2, 2);
        assert!(min(&cfg, &state(c.clone())) && max(&cfg, &state(c.clone())), "all equal holds");
        let mut above = c.clone();
        above.counter_min = 3;
        assert!(!min(&cfg, &state(above)), "X:$25 above Y:$25 fails");
        let mut over = c.clone();
        over.counter = 3;
        assert!(!max(&cfg, &state(over)), "Y:$25 above its last reload fails");
        c.counter = 0;
        assert!(zero(&cfg, &state(c.clone())), "zero holds");
        c.counter = -1;
        assert!(!zero(&cfg, &state(c.clone())), "below zero under the at-zero reading fails");
        let srm = config("lockout", "srm-57");
        assert!(zero(&srm, &state(c)), "below zero under the below-zero reading holds");
    }

    /// Whether the `sometimes` property named `name` counts `c` as its witness.
    fn witness(cfg: &ModelConfig, name: &str, c: &Controller) -> bool {
        holds(name, Sometimes)(cfg, &state(c.clone()))
    }

    #[test]
    fn a_witness_of_a_status_bit_is_a_running_card_showing_that_bit() {
        // SRM p.289-290: bits 22, 9, 20, 11, 10 and (GlobalStatus.py) second-word bits 19 and
        // 17 "can be set": a witness must be a running card whose ??? would show the bit; a
        // tripped card answers nothing (UM p.215).
        let cfg = config("motion", "um-215");
        let running = Controller::power_on(&cfg);
        type Flag = fn(&mut crate::controller::StatusFlags);
        let bits: [(&str, Flag); 8] = [
            ("bit 22 (RTI re-entry) can be set", |f| f.rti_reentry = true),
            ("bit 9 (RTI warning) can be set", |f| f.rti_warning = true),
            ("bit 20 (servo error) can be set", |f| f.servo_error = true),
            ("bit 11 (DPRAM error) can be set", |f| f.dpram_error = true),
            ("bit 10 (flash error) can be set", |f| f.flash_error = true),
            ("second-word bit 19 (motion buffer open) can be set", |f| f.motion_buffer_open = true),
            ("bit 19 (data gathering on) can be set", |f| f.data_gathering_on = true),
            ("second-word bit 17 (PLC buffer open) can be set", |f| f.plc_buffer_open = true),
        ];
        for (name, set) in bits {
            assert!(!witness(&cfg, name, &running), "{name}: a card without the bit is no witness");
            let mut on = running.clone();
            set(&mut on.status);
            assert!(witness(&cfg, name, &on), "{name}: a running card with the bit is one");
            let t = tripped(&cfg, &on);
            assert!(!witness(&cfg, name, &t), "{name}: a tripped card is no witness");
        }
    }

    #[test]
    fn a_witness_of_a_checksum_error_or_pass_is_a_running_card_in_that_error_or_pass() {
        // UM p.217: a firmware or a user-program checksum error "can be found"; SRM p.289: bit
        // 12 is 1 while the firmware is evaluated (bit 13 = 0) and 0 while the user program is.
        let cfg = config("motion", "um-215");
        let m83 = config("motion", "um-215-m83");
        let fresh = Controller::power_on(&cfg);
        assert_eq!((fresh.checksum.area, fresh.checksum.error), (ChecksumTarget::Firmware, None));
        let with = |area: ChecksumTarget, error: Option<ChecksumTarget>| {
            let mut c = fresh.clone();
            (c.checksum.area, c.checksum.error) = (area, error);
            c
        };
        let (fw, up) = (ChecksumTarget::Firmware, ChecksumTarget::UserProgram);
        let firmware = "a firmware checksum error can be found";
        let user = "a user-program checksum error can be found";
        let fw_pass = "bit 12 can show a firmware pass in progress (prom_checksum_active reading)";
        let up_pass = "bit 12 can show a user-program pass in progress";
        for (c, expect) in [
            (with(fw, None), [false, false, true, false]),
            (with(up, None), [false, false, false, true]),
            (with(fw, Some(fw)), [true, false, false, false]),
            (with(up, Some(up)), [false, true, false, false]),
        ] {
            let seen = [firmware, user, fw_pass, up_pass].map(|name| witness(&cfg, name, &c));
            assert_eq!(seen, expect, "area {:?}, error {:?}", c.checksum.area, c.checksum.error);
            let t = tripped(&cfg, &c);
            assert_eq!([firmware, user, fw_pass, up_pass].map(|name| witness(&cfg, name, &t)), [false; 4], "tripped");
        }
        // Under the M83 reading bit 12 is the firmware error bit: the firmware-pass witness is
        // not sought (holds anywhere), the user-program pass is still seen by its words.
        assert!(witness(&m83, fw_pass, &tripped(&m83, &fresh)));
        assert!(witness(&m83, up_pass, &with(up, None)) && !witness(&m83, up_pass, &with(fw, None)));
    }

    #[test]
    fn a_witness_of_a_trip_a_recovery_or_bootstrap_is_exactly_that_card() {
        // UM p.215: the card trips on a low supply or a starved background, and INIT/ or a
        // power cycle restores it; SRM p.289: the card can start in bootstrap mode.
        let cfg = config("motion", "um-215");
        let running = Controller::power_on(&cfg);
        let low = "the card can trip on low supply voltage";
        let starved = "the card can trip on a starved background";
        let init = "a tripped card can be recovered by INIT/";
        let power = "a tripped card can be recovered by a power cycle";
        let boot = "the card can start in bootstrap mode";
        let names = [low, starved, init, power, boot];
        let seen = |c: &Controller| names.map(|name| witness(&cfg, name, c));
        assert_eq!(seen(&running), [false; 5]);
        let mut c = running.clone();
        c.trip = Some(TripCause::Undervoltage);
        assert_eq!(seen(&c), [true, false, false, false, false]);
        c.trip = Some(TripCause::StrobeTimeout);
        assert_eq!(seen(&c), [false, true, false, false, false]);
        let mut c = running.clone();
        c.ghost.recovered_by = Some(ResetKind::Init);
        assert_eq!(seen(&c), [false, false, true, false, false]);
        c.trip = Some(TripCause::StrobeTimeout);
        assert_eq!(seen(&c), [false, true, false, false, false], "tripped again: no recovery");
        let mut c = running.clone();
        c.ghost.recovered_by = Some(ResetKind::Power);
        assert_eq!(seen(&c), [false, false, false, true, false]);
        let mut c = running.clone();
        c.bootstrap = true;
        assert_eq!(seen(&c), [false, false, false, false, true]);
        c.trip = Some(TripCause::StrobeTimeout);
        assert_eq!(seen(&c), [false, true, false, false, false], "a tripped bootstrap card");
    }

    #[test]
    fn a_witness_of_a_stop_behaviour_is_a_running_card_with_the_motor_and_program_it_names() {
        // UM p.217, p.319: a motor jogs; Q lets a program motor finish its calculated moves; H
        // holds a program on its path with its motors at rest; A loses the lookahead while the
        // motors decelerate.
        let (cfg, running) = motion_card(&["#1J/", "&1B", "&1R"]);
        let jog = "a motor can jog";
        let quit = "a program can finish its calculated moves after Q";
        let hold = "a program can be held on its path, its motors at rest";
        let abort = "an aborted program can lose its lookahead while its motors decelerate";
        let names = [jog, quit, hold, abort];
        let seen = |c: &Controller| names.map(|name| witness(&cfg, name, c));
        assert_eq!(seen(&running), [false; 4], "a program running, nothing stopping");
        let motor = |state: MotorState, stop: Option<Stop>, program: Program| {
            let mut c = running.clone();
            let m = &mut c.axes.motors_mut()[1];
            (m.state, m.stop, m.stop_cycles) = (state, stop, u8::from(stop.is_some()));
            c.axes.programs_mut()[0] = program;
            c
        };
        let cases = [
            (motor(MotorState::Jogging, None, Program::Running), [true, false, false, false]),
            (motor(MotorState::Program, Some(Stop::Quit), Program::Running), [false, true, false, false]),
            (motor(MotorState::Program, Some(Stop::EndOfMove), Program::Running), [false; 4]),
            (motor(MotorState::Decelerating, Some(Stop::Quit), Program::Running), [false; 4]),
            (motor(MotorState::Holding, None, Program::Held), [false, false, true, false]),
            (motor(MotorState::Holding, None, Program::Running), [false; 4]),
            (motor(MotorState::Closed, None, Program::Held), [false; 4]),
            (motor(MotorState::Decelerating, Some(Stop::Abort), Program::Lost), [false, false, false, true]),
            (motor(MotorState::Decelerating, Some(Stop::Abort), Program::AtPoint), [false; 4]),
            (motor(MotorState::Decelerating, Some(Stop::Jog), Program::Lost), [false; 4]),
        ];
        for (c, expect) in cases {
            assert_eq!(
                seen(&c),
                expect,
                "motor 2 {:?} {:?}, &1 {:?}",
                c.axes.motors()[1].state,
                c.axes.motors()[1].stop,
                c.axes.programs()[0]
            );
            let mut t = c.clone();
            t.trip = Some(TripCause::StrobeTimeout);
            assert_eq!(seen(&t), [false; 4], "tripped");
        }
    }

    #[test]
    fn a_witness_of_the_encoder_loss_plc_and_of_a_near_miss_is_a_running_card_showing_it() {
        // UM p.214-215: the PLC kills a motor and latches the loss; as printed it leaves a
        // healthy motor's latched loss (ghost bit 1), as intended it clears it (bit 0). UM
        // p.240: X:$25 near 0 "means the card nearly tripped".
        let (cfg, running) = motion_card(&["#1J/"]);
        let literal = config("motion", "um-215-literal-plc");
        let kill = "the encoder-loss PLC can kill a motor and latch the loss";
        let clear = "the encoder-loss PLC can find a re-enabled motor with its encoder OK and a latched loss, and clear it as its reading says";
        let near = "a near miss leaves X:$25 at the last strobing value on a running card";
        let mut c = running.clone();
        assert!(!witness(&cfg, kill, &c));
        c.axes.motors_mut()[0].loss_status = true;
        assert!(!witness(&cfg, kill, &c), "a latched loss on a motor still enabled");
        c.axes.motors_mut()[0].state = MotorState::Killed;
        assert!(witness(&cfg, kill, &c));
        assert!(!witness(&cfg, kill, &tripped(&cfg, &c)));
        let mut c = running.clone();
        for (ghost, intent, printed) in [(0, false, false), (1, true, false), (2, false, true), (3, false, false)] {
            c.axes.ghost_healthy_latched_scans = ghost;
            assert_eq!((witness(&cfg, clear, &c), witness(&literal, clear, &c)), (intent, printed), "ghost {ghost}");
        }
        c.axes.ghost_healthy_latched_scans = 1;
        assert!(!witness(&cfg, clear, &tripped(&cfg, &c)));
        let mut c = running;
        for (min, counter, seen) in [(0, 1, true), (0, 0, false), (1, 2, false), (-1, 1, false)] {
            (c.counter_min, c.counter) = (min, counter);
            assert_eq!(witness(&cfg, near, &c), seen, "X:$25 = {min}, Y:$25 = {counter}");
        }
        (c.counter_min, c.counter) = (0, 1);
        c.trip = Some(TripCause::StrobeTimeout);
        assert!(!witness(&cfg, near, &c), "tripped");
    }

    /// `timing` with one load and the CPU and I8 given: 10 units a servo cycle, 2 a motor,
    /// 1 of move planning a RTI, I8 = 2 (an RTI every 3 servo cycles).
    fn cpu_config(motors: u8, plc0_units: u16) -> ModelConfig {
        let mut cfg = config("timing", "um-215");
        cfg.cpu = pmacwd_specs::check::Cpu { cycle_units: 10, servo_units_per_motor: 2, move_planning_units: 1 };
        cfg.saved.i8 = 2;
        cfg.loads = vec![pmacwd_specs::check::Load { motors, plc0_units, background_units: 1 }];
        cfg
    }

    #[test]
    fn sentence_um_236_an_rti_can_overrun_only_when_its_tasks_outlast_the_period_the_servo_work_leaves() {
        // UM p.236: PLC 0 "will execute every real-time interrupt as long as the tasks from the
        // previous RTI have been completed"; the RTI tasks (PLC 0 and move planning) get what
        // the servo work leaves of the I8+1 servo cycles of an RTI period. With 3 motors at 2
        // units of 10, 4 units a cycle are left, 12 a period: 11 units of PLC 0 plus 1 of
        // planning exactly fill it, 12 plus 1 outlast it. The bits 22 and 9 witnesses are
        // sought only when some load can overrun.
        assert!(!can_overrun(&cpu_config(3, 11)), "exactly the period: no overrun");
        assert!(can_overrun(&cpu_config(3, 12)), "one unit more: an overrun");
        for name in ["bit 22 (RTI re-entry) can be set", "bit 9 (RTI warning) can be set"] {
            let p = STATE_PROPERTIES.iter().find(|p| p.name == name).unwrap();
            assert!(!(p.applies)(&cpu_config(3, 11)) && (p.applies)(&cpu_config(3, 12)), "{name}");
        }
    }

    #[test]
    fn sentence_srm_289_servo_work_overloads_only_when_the_motors_need_more_than_a_cycle() {
        // SRM p.289 bit 20: set "if Turbo PMAC could not properly complete its servo routines";
        // UM p.236: each motor costs its share of the servo cycle. 5 motors at 2 units fill the
        // 10 units of a cycle exactly; 6 need more.
        assert!(!can_overload_servo(&cpu_config(5, 0)), "exactly a cycle: no overload");
        assert!(can_overload_servo(&cpu_config(6, 0)), "one motor more: an overload");
        let p = STATE_PROPERTIES.iter().find(|p| p.name == "bit 20 (servo error) can be set").unwrap();
        assert!(!(p.applies)(&cpu_config(5, 0)) && (p.applies)(&cpu_config(6, 0)));
    }

    #[test]
    fn a_witness_that_needs_a_command_is_sought_only_where_the_configuration_offers_it() {
        // The `sometimes` properties are reachability checks of what a configuration offers:
        // OPEN PROG for bit 19, OPEN PLC for bit 17, J+ for a jog (GlobalStatus.py, UM p.217).
        // `status` offers OPEN PLC and OPEN PROG and no motion; `motion` offers J+ and no OPEN.
        let status = config("status", "um-215");
        let motion = config("motion", "um-215");
        let applies =
            |name: &str, cfg: &ModelConfig| (STATE_PROPERTIES.iter().find(|p| p.name == name).unwrap().applies)(cfg);
        for name in
            ["second-word bit 19 (motion buffer open) can be set", "second-word bit 17 (PLC buffer open) can be set"]
        {
            assert!(applies(name, &status) && !applies(name, &motion), "{name}");
        }
        assert!(applies("a motor can jog", &motion) && !applies("a motor can jog", &status));
        assert!(applies("the card can trip on a starved background", &status), "`any` applies everywhere");
    }

    #[test]
    fn a_witness_of_a_low_supply_trip_a_recovery_or_the_plc_s_clear_is_sought_only_where_the_configuration_can_show_it()
    {
        // UM p.215: "If the supply voltage is below this value ... the card will shut down": a
        // supply exactly at the minimum trips nothing, so no low-supply trip is sought there.
        // INIT/ and a power cycle recover a card only where the configuration offers them; the
        // PLC's clear (UM p.215) needs encoder inputs and a J/ to re-enable the motor.
        let applies =
            |name: &str, cfg: &ModelConfig| (STATE_PROPERTIES.iter().find(|p| p.name == name).unwrap().applies)(cfg);
        let low = "the card can trip on low supply voltage";
        let mut cfg = config("status", "um-215");
        let min = cfg.supply_min_millivolts;
        cfg.supply_millivolts = vec![5000, min];
        assert!(!applies(low, &cfg), "a supply exactly at the minimum");
        cfg.supply_millivolts = vec![5000, min - 1];
        assert!(applies(low, &cfg), "a supply one millivolt below it");
        let (init, power) =
            ("a tripped card can be recovered by INIT/", "a tripped card can be recovered by a power cycle");
        for (kind, expect) in [(ResetKind::Init, [true, false]), (ResetKind::Power, [false, true])] {
            cfg.resets = vec![pmacwd_specs::check::ResetEvent {
                kind,
                dpram_fault: false,
                flash_fault: false,
                bootstrap: false,
            }];
            assert_eq!([applies(init, &cfg), applies(power, &cfg)], expect, "{kind:?}");
        }
        let clear = "the encoder-loss PLC can find a re-enabled motor with its encoder OK and a latched loss, and clear it as its reading says";
        let mut encoder = config("encoder-loss", "um-215");
        assert!(applies(clear, &encoder), "encoder inputs and J/");
        assert!(!applies(clear, &config("motion", "um-215")), "J/ without encoder inputs");
        encoder.commands.retain(|c| !matches!(c, HostCommand::Motion(Motion::Motor(_, MotorCommand::JogStop))));
        assert!(!applies(clear, &encoder), "encoder inputs without J/");
    }
}
