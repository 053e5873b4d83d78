//! The controller as the manuals describe it, one event at a time.
//!
//! This is the reference semantics: plain, tick-by-tick, every rule next to its citation.
//! Time is counted in servo cycles. [`Controller::apply`] takes one [`Event`] and returns what
//! a host or an instrument could observe afterwards.
//!
//! Modelling choices the manuals leave open are marked `MODEL:` and explained where made.

use crate::motion::Axes;
use pmacwd_specs::check::{ChecksumTarget, Load, ResetEvent, ResetKind};
use pmacwd_specs::config::{ModelConfig, SavedIVariables};
use pmacwd_specs::profiles::{Bit12Meaning, RtiWarningLatch, StrobeStop, Strober};
use pmacwd_specs::status::WordId;
use pmacwd_specs::vocab::command::{Buffer, HostCommand, Register};
use pmacwd_specs::vocab::event::{Event, Reply};

/// Why the hardware timer tripped.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum TripCause {
    /// Supply below about 4.75 V (UM p.215).
    Undervoltage,
    /// No strobe edge for longer than the hardware delay (UM p.215: under-frequency).
    StrobeTimeout,
}

/// The status conditions the model drives; the words are built from these by name
/// ([`Controller::status_words`]).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct StatusFlags {
    /// X bit 22: an RTI came while the previous RTI tasks still ran; sticky (SRM p.289).
    pub rti_reentry: bool,
    /// X bit 9: an RTI task set took more than one RTI period (SRM p.290).
    pub rti_warning: bool,
    /// X bit 20: the servo routines could not complete (SRM p.289).
    pub servo_error: bool,
    /// X bit 11: the reset-time DPRAM check failed (SRM p.289).
    pub dpram_error: bool,
    /// X bit 10: reading saved data from flash at reset failed its checksum (SRM p.289).
    pub flash_error: bool,
    /// Y bit 17: a PLC buffer is open (GlobalStatus.py).
    pub plc_buffer_open: bool,
    /// Y bit 19: a motion program buffer is open (GlobalStatus.py).
    pub motion_buffer_open: bool,
    /// X bit 19: the data gathering function is active (SRM p.289), from GATHER until
    /// ENDGATHER or a reset (SRM p.307).
    pub data_gathering_on: bool,
}

/// The background checksum engine of UM p.217: it alternates between the firmware and the
/// user-program area, one step per background cycle, and stops for good on a mismatch.
///
/// MODEL: the model does not sum real memory. Each area's contents and its reference are
/// small tokens; an injected fault changes the contents, closing a buffer copies the program
/// contents into its reference (X:$1090), and a pass compares the two. X:$1080 is represented
/// by the engine's position, which changes every background cycle while the engine runs and
/// stays put once it stops: the only property of X:$1080 the manuals state.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct ChecksumEngine {
    pub area: ChecksumTarget,
    /// Background cycles done in the current pass.
    pub position: u8,
    /// The area whose mismatch stopped the engine (UM p.217), if any.
    pub error: Option<ChecksumTarget>,
    pub firmware: u8,
    pub firmware_reference: u8,
    pub program: u8,
    /// X:$001090: the program checksum computed when a buffer was last closed (UM p.217).
    pub program_reference: u8,
}

impl ChecksumEngine {
    /// The engine after a reset: at the start of a firmware pass, no error, every area's
    /// contents equal to its reference.
    pub fn fresh() -> Self {
        ChecksumEngine {
            area: ChecksumTarget::Firmware,
            position: 0,
            error: None,
            firmware: 0,
            firmware_reference: 0,
            program: 0,
            program_reference: 0,
        }
    }

    /// X:$001080 as the model represents it.
    pub fn running_value(&self) -> u32 {
        let area = match self.area {
            ChecksumTarget::Firmware => 0,
            ChecksumTarget::UserProgram => 1,
        };
        (area << 8) | u32::from(self.position)
    }
}

/// The watchdog's outputs and what a trip forces (UM p.215), as their own state: the trip
/// rule sets them, a reset clears them, and the properties check them against the trip.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct Outputs {
    /// "a red LED indicating watchdog failure".
    pub led_red: bool,
    /// FEFCO/, "turned on when the timer trips" (Turbo PMAC).
    pub fefco_on: bool,
    /// The watchdog relay has changed over (Turbo PMAC2).
    pub relay_tripped: bool,
    /// The ICs are held in reset: discrete outputs off, DAC/PWM/PFM at zero.
    pub forced_off: bool,
}

/// Bookkeeping that no rule reads; it exists so properties can be stated.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct Ghost {
    /// Servo cycles since the last background cycle (or reset).
    pub cycles_since_background: u32,
    /// The value the counter was last loaded with.
    pub last_reload: i32,
    /// How the card last left a tripped state, for the recovery witnesses.
    pub recovered_by: Option<ResetKind>,
}

/// The whole controller state.
#[derive(Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct Controller {
    /// The hardware watchdog has tripped: latched reset state (UM p.215).
    pub trip: Option<TripCause>,
    pub supply_low: bool,
    /// Started in bootstrap mode: `???` answers `BOOTSTRAP PROM` (SRM p.289).
    pub bootstrap: bool,
    /// Y:$000025.
    pub counter: i32,
    /// X:$000025.
    pub counter_min: i32,
    /// Servo cycles since the last strobe edge reached the hardware timer.
    pub cycles_since_strobe: u32,
    /// Servo cycles since the last RTI (0..=I8).
    pub rti_phase: u16,
    /// CPU units of the current RTI task set not yet done.
    pub rti_remaining: u32,
    /// CPU units the background has had toward its current cycle (capped at its cost).
    pub background_credit: u32,
    pub load: Load,
    pub i8: u8,
    pub i40: u16,
    pub i41: u8,
    /// Every other I-variable written since reset (all read 0 otherwise).
    pub other_i_variables: crate::ivars::IVariables,
    pub status: StatusFlags,
    pub checksum: ChecksumEngine,
    /// X:$000000, masked to the configured width.
    pub servo_cycles: u32,
    pub outputs: Outputs,
    /// The motors and coordinate systems (`motion.rs`).
    pub axes: Axes,
    pub ghost: Ghost,
}

/// Written out rather than derived for `clone_from`: the derived one builds a whole new
/// controller and drops the old, and the checker's leaps copy the controller into the same
/// buffer every servo cycle (`checker.rs`, `WatchdogModel::leap`: about 2 million times in a
/// check of `i40-zero`, the two leaps of a state sharing their cycles). Every field is destructured, so a field added to the controller is a compile
/// error here until it is copied.
impl Clone for Controller {
    fn clone(&self) -> Controller {
        let Controller {
            trip,
            supply_low,
            bootstrap,
            counter,
            counter_min,
            cycles_since_strobe,
            rti_phase,
            rti_remaining,
            background_credit,
            load,
            i8,
            i40,
            i41,
            other_i_variables,
            status,
            checksum,
            servo_cycles,
            outputs,
            axes,
            ghost,
        } = self;
        Controller {
            trip: *trip,
            supply_low: *supply_low,
            bootstrap: *bootstrap,
            counter: *counter,
            counter_min: *counter_min,
            cycles_since_strobe: *cycles_since_strobe,
            rti_phase: *rti_phase,
            rti_remaining: *rti_remaining,
            background_credit: *background_credit,
            load: *load,
            i8: *i8,
            i40: *i40,
            i41: *i41,
            other_i_variables: other_i_variables.clone(),
            status: *status,
            checksum: *checksum,
            servo_cycles: *servo_cycles,
            outputs: *outputs,
            axes: *axes,
            ghost: *ghost,
        }
    }

    fn clone_from(&mut self, source: &Controller) {
        let Controller {
            trip,
            supply_low,
            bootstrap,
            counter,
            counter_min,
            cycles_since_strobe,
            rti_phase,
            rti_remaining,
            background_credit,
            load,
            i8,
            i40,
            i41,
            other_i_variables,
            status,
            checksum,
            servo_cycles,
            outputs,
            axes,
            ghost,
        } = source;
        self.trip = *trip;
        self.supply_low = *supply_low;
        self.bootstrap = *bootstrap;
        self.counter = *counter;
        self.counter_min = *counter_min;
        self.cycles_since_strobe = *cycles_since_strobe;
        self.rti_phase = *rti_phase;
        self.rti_remaining = *rti_remaining;
        self.background_credit = *background_credit;
        self.load = *load;
        self.i8 = *i8;
        self.i40 = *i40;
        self.i41 = *i41;
        self.other_i_variables.clone_from(other_i_variables);
        self.status = *status;
        self.checksum = *checksum;
        self.servo_cycles = *servo_cycles;
        self.outputs = *outputs;
        self.axes = *axes;
        self.ghost = *ghost;
    }
}

/// What one servo cycle did, for monitors and traces.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct CycleReport {
    pub rti_started: bool,
    pub rti_overrun: bool,
    pub strobed: bool,
}

impl Controller {
    /// The card after power-up with the configured saved I-variables and first load.
    pub fn power_on(cfg: &ModelConfig) -> Controller {
        let mut c = Controller {
            trip: None,
            supply_low: false,
            bootstrap: false,
            counter: 0,
            counter_min: 0,
            cycles_since_strobe: 0,
            rti_phase: 0,
            rti_remaining: 0,
            background_credit: 0,
            load: cfg.loads[0],
            i8: cfg.saved.i8,
            i40: cfg.saved.i40,
            i41: cfg.saved.i41,
            other_i_variables: crate::ivars::IVariables::new(),
            status: StatusFlags::default(),
            checksum: ChecksumEngine::fresh(),
            servo_cycles: 0,
            outputs: Outputs::default(),
            axes: Axes::power_on(&cfg.motion),
            ghost: Ghost { cycles_since_background: 0, last_reload: 0, recovered_by: None },
        };
        c.restart(cfg, ResetEvent { kind: ResetKind::Power, dpram_fault: false, flash_fault: false, bootstrap: false });
        c
    }

    pub fn tripped(&self) -> bool {
        self.trip.is_some()
    }

    /// Applies one event and returns the reply it produced (for host commands). A stop command
    /// decelerates for the configuration's longest deceleration (see [`Self::apply_with_decel`]).
    pub fn apply(&mut self, cfg: &ModelConfig, event: &Event) -> Reply {
        self.apply_with_decel(cfg, event, cfg.motion.decel_cycles_max)
    }

    /// [`Self::apply`], with any deceleration a stop command starts taking `decel` servo cycles
    /// (the checker explores every length from 1 to `decel_cycles_max`).
    pub fn apply_with_decel(&mut self, cfg: &ModelConfig, event: &Event, decel: u8) -> Reply {
        match event {
            Event::Servo { cycles } => {
                for _ in 0..*cycles {
                    self.servo_cycle(cfg);
                }
                Reply::None
            }
            Event::Background => {
                self.background_cycle(cfg);
                Reply::None
            }
            Event::Load(load) => {
                self.load = *load;
                Reply::None
            }
            Event::Command(cmd) => self.host_command_with_decel(cfg, cmd, decel),
            Event::Supply { millivolts } => {
                self.supply(cfg, *millivolts);
                Reply::None
            }
            Event::Reset(reset) => {
                self.reset(cfg, *reset);
                Reply::None
            }
            Event::ChecksumFault(area) => {
                self.inject_checksum_fault(*area);
                Reply::None
            }
            Event::ClearRtiReentry => {
                // SRM p.289: bit 22 "stays at 1 until the card is reset, or until this bit is
                // manually changed to 0" (a memory write or an M-variable assignment).
                if !self.tripped() {
                    self.status.rti_reentry = false;
                }
                Reply::None
            }
            Event::EncoderInput(input) => {
                // UM p.214: the encoder-loss circuit's status bit; a hardware input, which
                // changes whether or not the card runs.
                self.axes.encoder_input(input.motor, input.lost);
                Reply::None
            }
            Event::AmplifierFault(input) => {
                // UM p.213: the amplifier-fault line (FAULTn); a hardware input.
                self.axes.amplifier_fault_input(input.motor, input.fault);
                Reply::None
            }
        }
    }

    // ---------------------------------------------------------------- foreground: servo + RTI

    /// One servo interrupt, with the RTI that follows it when one is due.
    pub fn servo_cycle(&mut self, cfg: &ModelConfig) -> CycleReport {
        let mut report = CycleReport::default();
        // UM p.215: "The processor stops operating" once tripped. MODEL: the bootstrap firmware
        // runs no servo or RTI tasks, and keeps the watchdog satisfied while it waits for a download.
        if self.tripped() || self.bootstrap {
            return report;
        }
        self.servo_cycles = self.servo_cycles.wrapping_add(1) & cfg.servo_counter_mask;
        self.ghost.cycles_since_background = self.ghost.cycles_since_background.saturating_add(1);

        // Servo update: about 1% of the CPU per motor at 2.25 kHz (UM p.236). If it needs more
        // than the cycle has, "Turbo PMAC could not properly complete its servo routines" (SRM p.289, bit 20).
        let cycle = u32::from(cfg.cpu.cycle_units);
        let servo_units = u32::from(self.load.motors) * u32::from(cfg.cpu.servo_units_per_motor);
        self.status.servo_error = servo_units > cycle;
        let mut free = cycle.saturating_sub(servo_units);
        // The motors' stops under way advance one servo cycle (motion.rs).
        self.axes.servo_cycle(&cfg.motion);

        // Watchdog counter, in the servo interrupt.
        let strobe_allowed = match cfg.profile.choices.strobe_stop {
            // UM p.215: "the servo-interrupt routine decrements a counter (as long as the counter
            // is greater than zero), causing the least significant bit of the timer to toggle."
            StrobeStop::AtZero => {
                if self.counter > 0 {
                    self.counter -= 1;
                    true
                } else {
                    false
                }
            }
            // SRM p.57: "Each servo interrupt cycle, Turbo PMAC decrements this counter by 1 ...
            // and if the counter becomes less than 0, the real-time interrupt task will no longer
            // strobe the watchdog circuit."
            StrobeStop::BelowZero => {
                self.counter -= 1;
                self.counter >= 0
            }
        };
        // SRM p.57, UM p.240: X:$25 holds the lowest value the counter has reached since reset.
        self.counter_min = self.counter_min.min(self.counter);

        // RTI: every I8+1 servo cycles, right after the servo update (UM p.236).
        let rti_due = self.rti_phase >= u16::from(self.i8);
        self.rti_phase = if rti_due { 0 } else { self.rti_phase + 1 };
        if rti_due {
            if self.rti_remaining > 0 {
                // SRM p.289: bit 22 is 1 "if a real-time interrupt task has taken long enough so
                // that it was still executing when the next real-time interrupt came"; SRM p.290:
                // bit 9 when an RTI task "took more than one interrupt period". UM p.236: PLC 0
                // runs every RTI "as long as the tasks from the previous RTI have been completed",
                // so no new task set starts.
                self.status.rti_reentry = true;
                self.status.rti_warning = true;
                report.rti_overrun = true;
            } else {
                if cfg.profile.choices.rti_warning_latch == RtiWarningLatch::Level {
                    // MODEL (profile reading rti_warning_latch = level): the previous task set
                    // finished within its period, so the warning no longer holds.
                    self.status.rti_warning = false;
                }
                // UM p.236: move planning and PLC 0 / PLCC 0 run at the RTI. "Every time Turbo
                // PMAC starts executing a new move, it sets an internal flag indicating that it
                // is time to plan the next move in the program. This planning occurs at the next
                // RTI": planning is charged while a program executes moves (`Axes::plans_moves`).
                // MODEL: the model's programs have no moves of their own, so it takes the worst
                // case, a new move started in every RTI period.
                let planning = if self.axes.plans_moves() { u32::from(cfg.cpu.move_planning_units) } else { 0 };
                self.rti_remaining = u32::from(self.load.plc0_units) + planning;
                report.rti_started = true;
            }
        }
        // RTI tasks have priority over the background (UM p.236): the background gets what
        // is left of the cycle.
        let rti_work = free.min(self.rti_remaining);
        self.rti_remaining -= rti_work;
        free -= rti_work;
        self.background_credit = (self.background_credit + free).min(u32::from(self.load.background_units));

        // Who toggles the strobe: the servo routine (UM p.215) or the RTI task (SRM p.57).
        let strobe = strobe_allowed
            && match cfg.profile.choices.strober {
                Strober::ServoInterrupt => true,
                Strober::RealTimeInterrupt => rti_due,
            };
        report.strobed = strobe;
        if strobe {
            self.cycles_since_strobe = 0;
        } else {
            self.cycles_since_strobe = self.cycles_since_strobe.saturating_add(1);
            // UM p.215: the timer must see a square wave above about 25 Hz, or it trips.
            if self.cycles_since_strobe > cfg.hardware_delay_cycles {
                self.trip_now(TripCause::StrobeTimeout);
            }
        }
        report
    }

    // ---------------------------------------------------------------- background

    /// Whether a background cycle can complete now: the card runs and the background has had
    /// the CPU time one cycle costs (UM p.236: the background runs "in the time not taken by
    /// any of the higher-priority tasks").
    pub fn background_possible(&self) -> bool {
        !self.tripped() && !self.bootstrap && self.background_credit >= u32::from(self.load.background_units)
    }

    /// The end of one background cycle. Callers check [`Self::background_possible`] first.
    pub fn background_cycle(&mut self, cfg: &ModelConfig) {
        if !self.background_possible() {
            return;
        }
        self.background_credit = 0;
        // UM p.215: "At the end of each background cycle, the CPU resets the counter value to a
        // maximum value set by variable I40"; SRM p.57: "reset each background cycle".
        self.counter = cfg.reset_value(self.i40);
        // MODEL: X:$25 tracks every value the counter holds, reloads included, so that it is
        // "never above any value Y:$25 held since reset" even when I40 was lowered: a reload to a
        // new, smaller I40 is a value "the counter has reached" (SRM p.57).
        self.counter_min = self.counter_min.min(self.counter);
        self.ghost.cycles_since_background = 0;
        self.ghost.last_reload = self.counter;
        // UM p.217: the checksums are computed "as a background task".
        self.checksum_step(cfg);
        // UM p.215: the safety PLCs scan once per background cycle.
        self.axes.encoder_loss_plc(cfg);
        // UM p.237: the cycle ends with the housekeeping's safety checks, among them the
        // amplifier-fault check of UM p.213 (the firmware's own, after the PLC's scan).
        self.axes.amplifier_fault_check(&cfg.motion);
    }

    fn checksum_step(&mut self, cfg: &ModelConfig) {
        let engine = &mut self.checksum;
        // UM p.217: after a mismatch Turbo PMAC "stops performing any checksum operations",
        // "freezing the running checksum value in X:$001080".
        if engine.error.is_some() {
            return;
        }
        engine.position += 1;
        let pass = match engine.area {
            ChecksumTarget::Firmware => cfg.pass_cycles.firmware,
            ChecksumTarget::UserProgram => cfg.pass_cycles.user_program,
        };
        if engine.position < pass {
            return;
        }
        let mismatch = match engine.area {
            // UM p.217: the firmware checksum is compared with the reference register.
            ChecksumTarget::Firmware => engine.firmware != engine.firmware_reference,
            // UM p.217: the user-program checksum is compared with X:$001090.
            ChecksumTarget::UserProgram => engine.program != engine.program_reference,
        };
        if mismatch {
            engine.error = Some(engine.area);
        } else {
            engine.position = 0;
            engine.area = engine.area.other();
        }
    }

    fn inject_checksum_fault(&mut self, area: ChecksumTarget) {
        if self.tripped() {
            return;
        }
        match area {
            ChecksumTarget::Firmware => self.checksum.firmware ^= 1,
            ChecksumTarget::UserProgram => self.checksum.program ^= 1,
        }
    }

    // ---------------------------------------------------------------- host commands

    /// A host command. Commands are answered by the background's command processing (UM
    /// p.236); MODEL: a command the model applies is one a background cycle processed, and it
    /// answers at once; a command no background cycle reached while the host waited is
    /// [`Self::unanswered`].
    pub fn host_command(&mut self, cfg: &ModelConfig, cmd: &HostCommand) -> Reply {
        self.host_command_with_decel(cfg, cmd, cfg.motion.decel_cycles_max)
    }

    /// A command line the host sent and gave up on after `wait_cycles` servo cycles in which no
    /// background cycle completed. UM p.236: host commands are processed in the background,
    /// "in the time not taken by any of the higher-priority tasks", so a card whose background
    /// is starved answers nothing ("communications become sluggish") and still runs its servo
    /// and RTI tasks; a tripped card answers nothing at all (UM p.215). Either way the host
    /// sees silence. MODEL: the command is not processed (the host flushes the line when it
    /// gives up, as the EPICS driver's `pmacFlush` does); a replay that cannot tell also
    /// tries it processed right after the wait (docs/replay.md, "Sluggish replies").
    pub fn unanswered(&mut self, cfg: &ModelConfig, wait_cycles: u32) -> Reply {
        for _ in 0..wait_cycles {
            self.servo_cycle(cfg);
        }
        Reply::Silence
    }

    fn host_command_with_decel(&mut self, cfg: &ModelConfig, cmd: &HostCommand, decel: u8) -> Reply {
        // UM p.215: a tripped card "will not communicate".
        if self.tripped() {
            return Reply::Silence;
        }
        if self.bootstrap {
            // SRM p.289: in bootstrap mode the reply to ??? "will simply be BOOTSTRAP PROM".
            // MODEL: the bootstrap firmware answers nothing else of this command set.
            return match cmd {
                HostCommand::GlobalStatus => Reply::Bootstrap,
                _ => Reply::Error(3),
            };
        }
        match cmd {
            HostCommand::GlobalStatus => {
                let (x, y) = self.status_words(cfg);
                Reply::Status { x, y }
            }
            // A variable no rule fixes and the log never wrote is the card's own (its saved
            // value, unknown to the model): not compared.
            HostCommand::ReadI(n) => self.i_variable(*n).map_or(Reply::CardOwn, Reply::Value),
            HostCommand::WriteI(n, v) => self.write_i_variable(cfg, *n, *v),
            HostCommand::ReadHex(r) => Reply::Hex(self.register(cfg, *r)),
            HostCommand::Reset => {
                // `$$$`: a full card reset, as INIT/ does but commanded from the host.
                self.restart(
                    cfg,
                    ResetEvent { kind: ResetKind::Init, dpram_fault: false, flash_fault: false, bootstrap: false },
                );
                Reply::None
            }
            HostCommand::Open(buffer) => {
                match buffer {
                    Buffer::Plc(_) => self.status.plc_buffer_open = true,
                    Buffer::Program(_) => self.status.motion_buffer_open = true,
                }
                Reply::Ack
            }
            HostCommand::Close => {
                self.status.plc_buffer_open = false;
                self.status.motion_buffer_open = false;
                // UM p.217: X:$001090 holds "the checksum value that was computed the last time
                // one of these buffers was closed".
                self.checksum.program_reference = self.checksum.program;
                Reply::Ack
            }
            // SRM p.289: bit 19 "is 1 when the data gathering function is active; it is 0 when
            // the function is not active". SRM p.307: gathering is "in progress" until
            // "an ENDGATHER command" is issued or "the gather buffer has ... filled up". MODEL:
            // the model holds no gather buffer (`DEFINE GATHER` is the card's own), so it reads
            // the buffer as one that never fills: I5000 = 1 or 3, "permit wrap-around" (SRM
            // p.170); a GATHER with no buffer defined starts gathering all the same.
            HostCommand::Gather => {
                self.status.data_gathering_on = true;
                Reply::Ack
            }
            HostCommand::EndGather => {
                self.status.data_gathering_on = false;
                Reply::Ack
            }
            // UM p.217, UM p.319: the stop commands and those that start motion (motion.rs).
            HostCommand::Motion(m) => self.axes.command(cfg, *m, decel),
            HostCommand::Reinitialize => {
                // UM p.243 (summary): re-initialization by `$$$***` puts the firmware's default
                // I-variable values in active memory; the values last saved stay in flash,
                // unused, so a later reset (`$$$`, INIT/, power) brings them back. Otherwise a
                // reset like `$$$`.
                self.restart_with(
                    cfg,
                    ResetEvent { kind: ResetKind::Init, dpram_fault: false, flash_fault: false, bootstrap: false },
                    cfg.factory,
                );
                Reply::None
            }
            // UM p.217: the reference register is "obtainable with the CHECKSUM command"; SRM
            // p.295: CHECKSUM reports the firmware's reference checksum in hex. MODEL: the model
            // sums no memory (see `ChecksumEngine`), so it reports its reference token; what it
            // keeps of the manual is that the reference, preloaded at the factory, does not
            // change when the firmware is corrupted or a checksum error is found.
            HostCommand::Checksum => Reply::Hex(u32::from(self.checksum.firmware_reference)),
            // SRM p.57: "I41 does not prevent changes to an I-variable by means of an M-variable
            // assignment or a direct memory write command".
            HostCommand::WriteIMemory(n, v) => self.store_i_variable(cfg, *n, *v),
            // SRM on-line commands `I{data}=*`: the factory default, through the lockout as
            // any write (SRM p.57). MODEL: the model knows the defaults of the variables it
            // rules on (variables.yaml); any other becomes the card's own.
            HostCommand::DefaultI(n) => match *n {
                8 => self.write_i_variable(cfg, 8, i64::from(cfg.factory.i8)),
                40 => self.write_i_variable(cfg, 40, i64::from(cfg.factory.i40)),
                41 => self.write_i_variable(cfg, 41, i64::from(cfg.factory.i41)),
                n => {
                    if !self.write_locked(cfg, n) {
                        self.other_i_variables.remove(&n);
                    }
                    Reply::Ack
                }
            },
            // The card's own commands: whatever they answer, the model has no rule for it. A
            // write the model cannot compute leaves the variables it wrote the card's own
            // (unless I41 locked them: SRM p.57, the write is then ignored; but not a direct
            // memory write or an M-variable assignment, which I41 "does not prevent").
            HostCommand::Card { forgets, past_lockout: false, .. } => {
                for n in forgets.iter().flat_map(|r| r.numbers()) {
                    if !self.write_locked(cfg, n) {
                        self.other_i_variables.remove(&n);
                    }
                }
                Reply::CardOwn
            }
            // Past the lockout, the range is usually every I-variable (a memory write): only
            // the variables known are looked at, not the 8,192 numbers.
            HostCommand::Card { forgets, past_lockout: true, .. } => {
                if let Some(r) = forgets {
                    let within = |n: u16| match (n.checked_sub(r.first), r.step) {
                        (Some(0), _) => r.count > 0,
                        (Some(d), step) if step > 0 => d % step == 0 && d / step < r.count,
                        _ => false,
                    };
                    let known: Vec<u16> =
                        self.other_i_variables.iter().map(|(n, _)| *n).filter(|n| within(*n)).collect();
                    for n in known {
                        self.other_i_variables.remove(&n);
                    }
                }
                Reply::CardOwn
            }
            // Facts s.3: ERR003, "data error or unrecognized command".
            HostCommand::Unrecognized(_) => Reply::Error(3),
        }
    }

    /// SRM p.57: whether I41 now locks I`n` against host writes (which are then ignored).
    fn write_locked(&self, cfg: &ModelConfig, n: u16) -> bool {
        cfg.lockout_bit(n).is_some_and(|bit| self.i41 & (1 << bit) != 0)
    }

    /// I`n`'s value, when the model knows it: I8, I40, I41 always; any other once the log
    /// wrote it since the last reset (before that it holds the card's own saved value).
    pub fn i_variable(&self, n: u16) -> Option<i64> {
        match n {
            8 => Some(i64::from(self.i8)),
            40 => Some(i64::from(self.i40)),
            41 => Some(i64::from(self.i41)),
            _ => self.other_i_variables.get(&n).copied(),
        }
    }

    fn write_i_variable(&mut self, cfg: &ModelConfig, n: u16, v: i64) -> Reply {
        // SRM p.57: with the controlling I41 bit set, "the command is ignored (no error is
        // generated)". I41 itself lies in no locked range, so it is always writable.
        if let Some(bit) = cfg.lockout_bit(n) {
            if self.i41 & (1 << bit) != 0 {
                return Reply::Ack;
            }
        }
        self.store_i_variable(cfg, n, v)
    }

    /// I`n` = `v` in the I-variable's storage, whatever I41 holds: what an I-variable write
    /// does once past the lockout, and what an M-variable assignment or a memory write does
    /// (SRM p.57).
    fn store_i_variable(&mut self, cfg: &ModelConfig, n: u16, v: i64) -> Reply {
        // A value outside the variable's range (SRM p.42, p.57) under the reading
        // `out_of_range_assignment`: refused with ERR003 and the variable unchanged (`error`,
        // MODEL), or rolled over into the range by modulo arithmetic without an error
        // (`modulo`, UM p.243: I3=5 gives 1).
        let stored = |r: (i64, i64)| cfg.out_of_range().stored(v, r);
        match n {
            8 => match stored(cfg.i8_range) {
                Some(v) => self.i8 = v as u8,
                None => return Reply::Error(3),
            },
            40 => match stored(cfg.i40_range) {
                Some(v) => self.i40 = v as u16,
                None => return Reply::Error(3),
            },
            41 => match stored(cfg.i41_range) {
                Some(v) => self.i41 = v as u8,
                None => return Reply::Error(3),
            },
            // A real card's range is its own (`OtherIWrites::CardOwn`, SRM p.42, UM p.243): it
            // may refuse the value or roll it over, so the answer and the value left are the
            // card's, until a read shows it.
            _ if cfg.other_i_writes == pmacwd_specs::check::OtherIWrites::CardOwn => {
                self.other_i_variables.remove(&n);
                return Reply::CardOwn;
            }
            _ => self.other_i_variables.insert(n, v),
        }
        Reply::Ack
    }

    /// A register as a 24-bit word.
    pub fn register(&self, cfg: &ModelConfig, r: Register) -> u32 {
        let word = |v: i32| (v as u32) & 0xFF_FFFF;
        match r {
            Register::ServoCycles => self.servo_cycles,
            Register::StatusX => self.status_words(cfg).0,
            Register::StatusY => self.status_words(cfg).1,
            Register::WatchdogCounter => word(self.counter),
            Register::WatchdogMinimum => word(self.counter_min),
            Register::RunningChecksum => self.checksum.running_value(),
            Register::ProgramChecksumReference => u32::from(self.checksum.program_reference),
        }
    }

    /// All that [`Self::status_words`] reads of the card (it reads the card through this
    /// alone): the status flags, and the checksum engine's error and area. Cards equal in these
    /// have equal status words under one configuration, so a comparison of words can compare
    /// these first: the checker compares words on every transition (the bit-19 monitor) and on
    /// every servo cycle of a time jump ([`crate::checker::signature`]).
    #[inline]
    pub fn status_inputs(&self) -> (StatusFlags, Option<ChecksumTarget>, ChecksumTarget) {
        (self.status, self.checksum.error, self.checksum.area)
    }

    /// X:$000006 and Y:$000006, built bit by bit from the named positions of `status.yaml`.
    pub fn status_words(&self, cfg: &ModelConfig) -> (u32, u32) {
        // Destructured without `..`: a bit added to the layout is a compile error here until
        // the model drives it.
        let pmacwd_specs::config::StatusLayout {
            rti_reentry,
            servo_error,
            checksum_error: checksum_error_bit,
            prom_checksum_active,
            dpram_error,
            flash_error,
            rti_warning,
            motion_buffer_open,
            plc_buffer_open,
            data_gathering_on,
            cpu_type_bit1,
            cpu_type_bit0,
        } = cfg.layout;
        // SRM p.289: bits X21 and Y21 say which of the four DSP56300-family CPU options the
        // card has: the configuration's processor, not a rule's.
        let (cpu1, cpu0) = cfg.processor.type_bits();
        let (s, error, area) = self.status_inputs();
        // SRM p.289 / UM p.217: bit 13 is any checksum error.
        let checksum_error = error.is_some();
        let bit12 = match cfg.profile.choices.bit12_meaning {
            // SRM p.289: 1 while evaluating the firmware checksum (13 = 0) or after a firmware
            // error (13 = 1); 0 while evaluating the user program or after its error.
            Bit12Meaning::PromChecksumActive => match error {
                Some(area) => area == ChecksumTarget::Firmware,
                None => area == ChecksumTarget::Firmware,
            },
            // M83: the firmware checksum error bit.
            Bit12Meaning::FirmwareChecksumError => error == Some(ChecksumTarget::Firmware),
        };
        let mut words = [0u32; 2];
        // One call per bit rather than a loop over a table of them: the checker's properties
        // and monitors read the words several times per state.
        let mut set = |on: bool, (word, bit): (WordId, u8)| {
            if on {
                words[match word {
                    WordId::X => 0,
                    WordId::Y => 1,
                }] |= 1 << bit;
            }
        };
        set(s.rti_reentry, rti_reentry);
        set(s.servo_error, servo_error);
        set(checksum_error, checksum_error_bit);
        set(bit12, prom_checksum_active);
        set(s.dpram_error, dpram_error);
        set(s.flash_error, flash_error);
        set(s.rti_warning, rti_warning);
        set(s.motion_buffer_open, motion_buffer_open);
        set(s.plc_buffer_open, plc_buffer_open);
        set(s.data_gathering_on, data_gathering_on);
        set(cpu1, cpu_type_bit1);
        set(cpu0, cpu_type_bit0);
        (words[0], words[1])
    }

    // ---------------------------------------------------------------- supply, trips, resets

    fn supply(&mut self, cfg: &ModelConfig, millivolts: u32) {
        self.supply_low = millivolts < cfg.supply_min_millivolts;
        // UM p.215: "If the supply voltage is below this value, the circuit's relay will trip and
        // the card will shut down."
        if self.supply_low && !self.tripped() {
            self.trip_now(TripCause::Undervoltage);
        }
    }

    pub(crate) fn trip_now(&mut self, cause: TripCause) {
        // UM p.215: "the system is latched into a reset state, with a red LED indicating
        // watchdog failure"; "All Servo, MACRO, and I/O ICs are forced into their reset states,
        // which force discrete outputs off, and proportional outputs (DAC, PWM, PFM) to
        // zero-level"; FEFCO/ "is turned on when the timer trips"; on Turbo PMAC2 the relay
        // changes over. MODEL: a card has one of FEFCO/ and the relay; the model drives both.
        self.trip = Some(cause);
        self.outputs = Outputs { led_red: true, fefco_on: true, relay_tripped: true, forced_off: true };
        self.axes.force_off();
        self.ghost.recovered_by = None;
    }

    fn reset(&mut self, cfg: &ModelConfig, reset: ResetEvent) {
        let was_tripped = self.tripped();
        if reset.kind == ResetKind::Power {
            // MODEL: power comes back at a good supply voltage.
            self.supply_low = false;
        }
        // UM p.215: "power to the Turbo PMAC must be cycled off and on, or the INIT/ hardware
        // reset line must be taken low, then high, to restore normal functioning".
        self.restart(cfg, reset);
        if self.supply_low {
            // The undervoltage condition is still there: the circuit trips again at once.
            self.trip_now(TripCause::Undervoltage);
        } else if was_tripped {
            self.ghost.recovered_by = Some(reset.kind);
        }
    }

    /// Re-initialisation from saved settings, common to power-up, INIT/ and `$$$`.
    fn restart(&mut self, cfg: &ModelConfig, reset: ResetEvent) {
        // MODEL: a reset reloads the saved I-variables; unsaved writes are lost.
        self.restart_with(cfg, reset, cfg.saved);
    }

    /// [`Self::restart`] with the I-variables `i_variables` in active memory: the saved ones,
    /// or the factory defaults after `$$$***` (UM p.243).
    fn restart_with(&mut self, cfg: &ModelConfig, reset: ResetEvent, i_variables: SavedIVariables) {
        let recovered_by = self.ghost.recovered_by;
        self.trip = None;
        self.bootstrap = reset.bootstrap;
        self.i8 = i_variables.i8;
        self.i40 = i_variables.i40;
        self.i41 = i_variables.i41;
        self.other_i_variables.clear();
        self.counter = cfg.reset_value(self.i40);
        // SRM p.57: X:$25 is the lowest value "since the last power-on/reset".
        self.counter_min = self.counter;
        self.cycles_since_strobe = 0;
        self.rti_phase = 0;
        self.rti_remaining = 0;
        self.background_credit = 0;
        // SRM p.289: bits 11 and 10 report the reset-time DPRAM check and flash read; every
        // other driven bit starts clear (bit 22 "until the card is reset"). MODEL: a reset
        // also ends data gathering (bit 19): gathering is started only by the on-line GATHER
        // (SRM p.307), and no page says it survives a reset.
        self.status =
            StatusFlags { dpram_error: reset.dpram_fault, flash_error: reset.flash_fault, ..StatusFlags::default() };
        // MODEL: an injected fault corrupts the stored firmware or user program, which a reset
        // does not rewrite (no reset reprograms PROM or flash): the contents and references
        // keep the corruption and only the engine starts over, at a firmware pass with no
        // error, so the next pass over the corrupted area finds it again. This is what makes
        // the diagnosis "after the reset, look at the checksum" meaningful (issue 35; before,
        // a reset wiped the corruption and the check always came back clean).
        let ChecksumEngine { firmware, firmware_reference, program, program_reference, .. } = self.checksum;
        self.checksum =
            ChecksumEngine { firmware, firmware_reference, program, program_reference, ..ChecksumEngine::fresh() };
        self.servo_cycles = 0;
        // UM p.215: a reset restores "normal functioning": the LED, FEFCO/ and the relay return
        // to normal and the ICs leave reset; the motors start as at power-up.
        self.outputs = Outputs::default();
        self.axes.restart();
        self.ghost = Ghost { cycles_since_background: 0, last_reload: self.counter, recovered_by };
    }
}
