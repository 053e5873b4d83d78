//! Motors, coordinate systems and the commands that start and stop them: the stop-command
//! table of UM p.217 as behaviour, the kill rules of UM p.319, and the encoder-loss PLC of
//! UM p.214-215 that runs once per background cycle.
//!
//! The motion is abstract: a motor is killed, closed-loop at rest, jogging, running its
//! coordinate system's program, decelerating, or holding; positions, velocities and
//! trajectories are not represented. A stop's deceleration rate (Ixx15, Ixx19-21, TA/TS,
//! Isx95, Ixx17) decides how long it takes; MODEL: the model abstracts every rate to a length
//! of 1 to `decel_cycles_max` servo cycles, and the checker explores every length, so no
//! property depends on a rate's value. A trace (deterministic) decelerates for the longest.

use pmacwd_specs::check::MotionSetup;
use pmacwd_specs::config::ModelConfig;
use pmacwd_specs::facts::{StopScope, Tristate};
use pmacwd_specs::profiles::EncoderLossClear;
use pmacwd_specs::vocab::command::{CsCommand, GlobalCommand, Motion, MotorCommand, COORDINATE_SYSTEM_MAX};
use pmacwd_specs::vocab::event::Reply;
use pmacwd_specs::vocab::observation::{MotionView, MotorState, MotorView, MOTORS_SHOWN};

/// Which stop a decelerating (or finishing) motor is carrying out, with its row of UM p.217.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Stop {
    /// `J/`: to closed loop at rest, at Ixx19-21.
    Jog,
    /// `A`, `<CTRL-A>`: to closed loop at rest at Ixx15, off the path, not at a program point.
    Abort,
    /// `Q`, `<CTRL-Q>`: the calculated moves are finished first, then rest at a program point.
    Quit,
    /// `/`, and the one move of `S`: the currently executing move is finished, then rest at a
    /// program point.
    EndOfMove,
    /// `H`, `<CTRL-O>`, `\` (outside lookahead), `%0`: on the path to a feed hold.
    Hold,
}

/// One row of UM p.217 as the model carries it out; `stop_rules_match_the_table` checks every
/// column against `specs/stop_commands.yaml`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct StopRule {
    /// The first column, as `stop_commands.yaml` has it.
    pub command: &'static str,
    pub scope: StopScope,
    /// "Begin Immed?": a stop that does not begin immediately leaves the program running its
    /// calculated moves (the motors stay in `Program`) until it ends.
    pub begins_immediately: bool,
    /// "Stop on Path?": a stop on the path leaves the program resumable where it stopped; one
    /// off the path discards the lookahead ("no easy restart", UM p.319).
    pub stops_on_path: Tristate,
    /// "Stop at Prog Pt?": the program ends at a program point.
    pub stops_at_program_point: bool,
    /// "Decel Rate", as printed.
    pub decel_rate: Option<&'static str>,
    /// How the model carries it out; `None` for the kills, which do not decelerate at all.
    pub stop: Option<Stop>,
}

use StopScope::{CoordinateSystem as Cs, Global, Motor as MotorScope};

/// The eleven rows of UM p.217, top to bottom.
pub const STOP_RULES: [StopRule; 11] = [
    StopRule {
        command: "J/",
        scope: MotorScope,
        begins_immediately: true,
        stops_on_path: Tristate::NotApplicable,
        stops_at_program_point: false,
        decel_rate: Some("Ixx19-21"),
        stop: Some(Stop::Jog),
    },
    StopRule {
        command: "A",
        scope: Cs,
        begins_immediately: true,
        stops_on_path: Tristate::No,
        stops_at_program_point: false,
        decel_rate: Some("Ixx15"),
        stop: Some(Stop::Abort),
    },
    StopRule {
        command: "<CTRL-A>",
        scope: Global,
        begins_immediately: true,
        stops_on_path: Tristate::No,
        stops_at_program_point: false,
        decel_rate: Some("Ixx15"),
        stop: Some(Stop::Abort),
    },
    StopRule {
        command: "Q",
        scope: Cs,
        begins_immediately: false,
        stops_on_path: Tristate::Yes,
        stops_at_program_point: true,
        decel_rate: Some("TA, TS"),
        stop: Some(Stop::Quit),
    },
    StopRule {
        command: "<CTRL-Q>",
        scope: Global,
        begins_immediately: false,
        stops_on_path: Tristate::Yes,
        stops_at_program_point: true,
        decel_rate: Some("TA, TS"),
        stop: Some(Stop::Quit),
    },
    StopRule {
        command: "/",
        scope: Cs,
        begins_immediately: false,
        stops_on_path: Tristate::Yes,
        stops_at_program_point: true,
        decel_rate: Some("TA, TS"),
        stop: Some(Stop::EndOfMove),
    },
    StopRule {
        command: "H",
        scope: Cs,
        begins_immediately: true,
        stops_on_path: Tristate::Yes,
        stops_at_program_point: false,
        decel_rate: Some("Isx95"),
        stop: Some(Stop::Hold),
    },
    StopRule {
        command: "<CTRL-O>",
        scope: Global,
        begins_immediately: true,
        stops_on_path: Tristate::Yes,
        stops_at_program_point: false,
        decel_rate: Some("Isx95"),
        stop: Some(Stop::Hold),
    },
    // UM p.217: "Acts as H command if outside of lookahead". MODEL: the model has no lookahead
    // buffer (Isx20 = 0), so `\` is always outside it and acts as H.
    StopRule {
        command: "\\",
        scope: Cs,
        begins_immediately: true,
        stops_on_path: Tristate::Yes,
        stops_at_program_point: false,
        decel_rate: Some("Ixx17/Isx95"),
        stop: Some(Stop::Hold),
    },
    StopRule {
        command: "K",
        scope: MotorScope,
        begins_immediately: true,
        stops_on_path: Tristate::No,
        stops_at_program_point: false,
        decel_rate: None,
        stop: None,
    },
    StopRule {
        command: "<CTRL-K>",
        scope: Global,
        begins_immediately: true,
        stops_on_path: Tristate::No,
        stops_at_program_point: false,
        decel_rate: None,
        stop: None,
    },
];

/// The row of a stop command.
pub fn rule(m: Motion) -> Option<&'static StopRule> {
    let name = m.stop_table_name()?;
    STOP_RULES.iter().find(|r| r.command == name)
}

/// Where a coordinate system's program stands.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Program {
    /// No program pointed at since reset (`B` points at one).
    #[default]
    None,
    /// Executing: its motors are in `Program`, or finishing calculated moves, or holding.
    Running,
    /// Stopped in a feed hold, on the path: `R` resumes where it stopped.
    Held,
    /// Stopped at a program point: `R` continues from it.
    AtPoint,
    /// Aborted or killed: the lookahead was discarded ("no easy restart", UM p.217; UM p.319:
    /// "execution would miss all of the discarded segments").
    Lost,
}

impl Program {
    /// UM p.319: the program is executing (K is refused) until it is halted.
    /// MODEL: a feed-held program still executes (R resumes it), so K is refused until it is
    /// aborted or has stopped at a program point.
    pub fn executing(self) -> bool {
        matches!(self, Program::Running | Program::Held)
    }
}

/// A motor's stop as one number, for the state's hash (`state.rs`) and the leaps' signature
/// ([`Axes::motion_signature`]): each stop its own, no stop one past them. These are the numbers
/// the compiler keeps in the motor's byte (the stops in declaration order, `None` the next
/// value), so reading one is a plain load (`None` as 0 cost a compare and a select per motor,
/// about 250 instructions per checked state on `timing`, callgrind). The match is exhaustive
/// on purpose: a new stop must be numbered here.
pub fn stop_code(stop: Option<Stop>) -> u64 {
    match stop {
        Some(Stop::Jog) => 0,
        Some(Stop::Abort) => 1,
        Some(Stop::Quit) => 2,
        Some(Stop::EndOfMove) => 3,
        Some(Stop::Hold) => 4,
        None => 5,
    }
}

/// One motor. `#[repr(C)]`: its fields stay in this order in memory, one byte each, which the
/// state's hash (`state.rs`) reads as they lie.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
#[repr(C)]
pub struct Motor {
    pub state: MotorState,
    /// The stop being carried out (`Decelerating`, or `Program` finishing its calculated moves).
    pub stop: Option<Stop>,
    /// Servo cycles until that stop is done.
    pub stop_cycles: u8,
    /// The amplifier-enable output.
    pub amplifier_enabled: bool,
    /// The commanded output is held at zero.
    pub output_zero: bool,
    /// The encoder-loss input reports loss (UM p.214); a hardware input.
    pub encoder_lost: bool,
    /// The encoder-loss PLC's `Mtr1EncLossStatus` (UM p.215).
    pub loss_status: bool,
}

impl Motor {
    /// MODEL: motors power up killed (Ixx80 = 0: not enabled at power-up/reset), the PLC's
    /// status clear; the encoder input keeps its level.
    fn power_on(encoder_lost: bool) -> Motor {
        Motor {
            state: MotorState::Killed,
            stop: None,
            stop_cycles: 0,
            amplifier_enabled: false,
            output_zero: true,
            encoder_lost,
            loss_status: false,
        }
    }

    /// UM p.319: a kill opens the servo loop, forces a zero command output and disables the
    /// amplifier, at once.
    fn kill(&mut self) {
        self.state = MotorState::Killed;
        self.stop = None;
        self.stop_cycles = 0;
        self.amplifier_enabled = false;
        self.output_zero = true;
    }

    /// Closed loop at rest: the amplifier is enabled and the servo loop drives the output.
    fn close_loop(&mut self) {
        self.state = MotorState::Closed;
        self.stop = None;
        self.stop_cycles = 0;
        self.amplifier_enabled = true;
        self.output_zero = false;
    }

    fn start(&mut self, state: MotorState, stop: Option<Stop>, cycles: u8) {
        self.state = state;
        self.stop = stop;
        self.stop_cycles = if stop.is_some() { cycles } else { 0 };
    }

    /// Whether the motor is on its way to rest or at rest under closed-loop control.
    pub fn at_rest(&self) -> bool {
        matches!(self.state, MotorState::Closed | MotorState::Holding)
    }

    pub fn view(&self) -> MotorView {
        MotorView {
            state: self.state,
            amplifier_enabled: self.amplifier_enabled,
            output_zero: self.output_zero,
            encoder_lost: self.encoder_lost,
            encoder_loss_status: self.loss_status,
        }
    }
}

/// The motors and coordinate systems of a card.
#[derive(Clone, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct Axes {
    /// Motor `m` is `motor_slots[m - 1]`, the first `motor_count` of them (fixed arrays: the
    /// checker clones the state every servo cycle of a time jump, so no allocation).
    pub motor_slots: [Motor; MOTORS_SHOWN],
    pub motor_count: u8,
    /// Coordinate system `n` is `program_slots[n - 1]`, the first `program_count` of them (up
    /// to the highest C.S. a motor is in).
    pub program_slots: [Program; COORDINATE_SYSTEM_MAX as usize],
    pub program_count: u8,
    /// Ghost, read by no rule: bit 0 set when the encoder-loss PLC found a closed-loop motor
    /// with its encoder OK and a latched loss and cleared it, bit 1 when it left it latched.
    pub ghost_healthy_latched_scans: u8,
}

impl Axes {
    pub fn power_on(setup: &MotionSetup) -> Axes {
        let highest = (1..=setup.motors).map(|m| setup.coordinate_system(m)).max().unwrap_or(1);
        Axes {
            motor_slots: [Motor::power_on(false); MOTORS_SHOWN],
            motor_count: setup.motors,
            program_slots: [Program::None; COORDINATE_SYSTEM_MAX as usize],
            program_count: highest,
            ghost_healthy_latched_scans: 0,
        }
    }

    pub fn motors(&self) -> &[Motor] {
        &self.motor_slots[..usize::from(self.motor_count)]
    }

    pub fn motors_mut(&mut self) -> &mut [Motor] {
        &mut self.motor_slots[..usize::from(self.motor_count)]
    }

    pub fn programs(&self) -> &[Program] {
        &self.program_slots[..usize::from(self.program_count)]
    }

    pub fn programs_mut(&mut self) -> &mut [Program] {
        &mut self.program_slots[..usize::from(self.program_count)]
    }

    /// After a reset: every motor and program as at power-up; the encoder inputs keep their level.
    pub fn restart(&mut self) {
        for m in self.motors_mut() {
            *m = Motor::power_on(m.encoder_lost);
        }
        for p in self.programs_mut() {
            *p = Program::None;
        }
        self.ghost_healthy_latched_scans = 0;
    }

    /// UM p.215: a trip holds every Servo IC in reset, "which force discrete outputs off, and
    /// proportional outputs (DAC, PWM, PFM) to zero-level". MODEL: the amplifier-enable lines
    /// are among the discrete outputs, so every amplifier is disabled, and a motor whose
    /// amplifier is off and output zero is not driven: its state reads killed.
    pub fn force_off(&mut self) {
        for m in self.motors_mut() {
            m.kill();
        }
    }

    /// Everything a servo cycle can change of the motors and programs, packed (no allocation:
    /// the checker's time jumps compute it every servo cycle): 14 bits per motor (up to 8),
    /// 3 bits per program (up to 16).
    pub fn motion_signature(&self) -> (u128, u64) {
        let motors = self.motors().iter().fold(0u128, |acc, m| {
            acc << 14 | (m.state as u128) << 11 | u128::from(stop_code(m.stop)) << 8 | u128::from(m.stop_cycles)
        });
        let programs = self.programs().iter().fold(0u64, |acc, p| acc << 3 | *p as u64);
        (motors, programs)
    }

    pub fn view(&self) -> MotionView {
        let mut motors = [MotorView::default(); MOTORS_SHOWN];
        for (v, m) in motors.iter_mut().zip(self.motors()) {
            *v = m.view();
        }
        MotionView { count: self.motor_count, motors }
    }

    fn in_cs(setup: &MotionSetup, cs: u8) -> impl Iterator<Item = usize> + '_ {
        (1..=setup.motors).filter(move |m| setup.coordinate_system(*m) == cs).map(|m| usize::from(m) - 1)
    }

    fn program(&self, cs: u8) -> Program {
        self.programs().get(usize::from(cs) - 1).copied().unwrap_or_default()
    }

    fn set_program(&mut self, cs: u8, p: Program) {
        if let Some(slot) = self.programs_mut().get_mut(usize::from(cs) - 1) {
            *slot = p;
        }
    }

    /// Whether motor `m` (from 1)'s coordinate system is executing a program.
    pub fn motor_in_executing_program(&self, setup: &MotionSetup, m: u8) -> bool {
        self.program(setup.coordinate_system(m)).executing()
    }

    // ------------------------------------------------------------------ commands

    /// A motion command; `decel` is the length of any deceleration it starts.
    pub fn command(&mut self, cfg: &ModelConfig, m: Motion, decel: u8) -> Reply {
        let setup = &cfg.motion;
        match m {
            Motion::Motor(n, c) => {
                let Some(k) = usize::from(n).checked_sub(1).filter(|k| *k < self.motors().len()) else {
                    // MODEL: a motor the configuration does not have is not set up (Ixx00 = 0)
                    // and the command does nothing.
                    return Reply::Ack;
                };
                let executing = self.motor_in_executing_program(setup, n);
                let motor = &mut self.motors_mut()[k];
                match c {
                    MotorCommand::Kill => {
                        // UM p.319: "the motor-specific K kill command is not permitted when the
                        // motor is in a coordinate system that is executing a motion program.
                        // The program must first be halted". UM p.217: "Must stop program first".
                        // MODEL: refused with ERR001, Turbo PMAC's "command not allowed during
                        // program execution".
                        if executing {
                            return Reply::Error(1);
                        }
                        motor.kill();
                    }
                    MotorCommand::JogStop => match motor.state {
                        // MODEL: J/ on a killed motor closes its loop (enables it), the usual
                        // way to re-enable a motor; the excerpts do not say so.
                        MotorState::Killed => motor.close_loop(),
                        // UM p.217 row 1: J/ begins immediately, decelerating at Ixx19-21.
                        MotorState::Jogging => motor.start(MotorState::Decelerating, Some(Stop::Jog), decel),
                        // MODEL: J/ stops jogs only; program motion is stopped by the C.S. commands.
                        MotorState::Closed | MotorState::Program | MotorState::Decelerating | MotorState::Holding => {}
                    },
                    MotorCommand::JogPlus | MotorCommand::JogMinus | MotorCommand::JogToPosition => {
                        // MODEL: a jog needs a closed loop at rest outside a running program; a
                        // killed motor is not moved by a jog command ("a killed motor does not
                        // move until re-enabled"), and a jog to a position runs, in this
                        // position-free model, until it is stopped like any jog.
                        if motor.state == MotorState::Closed && !executing {
                            motor.start(MotorState::Jogging, None, 0);
                        }
                    }
                }
                Reply::Ack
            }
            Motion::CoordinateSystem(cs, c) => {
                self.cs_command(setup, cs, c, decel);
                Reply::Ack
            }
            Motion::Global(g) => {
                // UM p.217: the control characters are global: each acts on every coordinate
                // system (SRM p.260 for <CTRL-O>: "equivalent to issuing the H command to each
                // coordinate system").
                match g {
                    GlobalCommand::KillAll => self.kill_all(),
                    GlobalCommand::AbortAll => self.every_cs(setup, CsCommand::Abort, decel),
                    GlobalCommand::QuitAll => self.every_cs(setup, CsCommand::Quit, decel),
                    GlobalCommand::HoldAll => self.every_cs(setup, CsCommand::Hold, decel),
                }
                Reply::Ack
            }
        }
    }

    fn every_cs(&mut self, setup: &MotionSetup, c: CsCommand, decel: u8) {
        for cs in 1..=self.program_count {
            self.cs_command(setup, cs, c, decel);
        }
    }

    fn cs_command(&mut self, setup: &MotionSetup, cs: u8, c: CsCommand, decel: u8) {
        let members: Vec<usize> = Self::in_cs(setup, cs).collect();
        let program = self.program(cs);
        match c {
            CsCommand::Abort => {
                // UM p.319: A "breaks into the executing trajectory immediately, and brings all
                // motors in the coordinate system to a controlled stop, each at its own
                // deceleration rate as set by Ixx15"; "not necessarily at a programmed point",
                // "not necessarily even along the programmed path"; the lookahead is discarded.
                for k in members {
                    let m = &mut self.motors_mut()[k];
                    match m.state {
                        MotorState::Jogging | MotorState::Program | MotorState::Decelerating => {
                            m.start(MotorState::Decelerating, Some(Stop::Abort), decel)
                        }
                        MotorState::Holding => m.close_loop(),
                        MotorState::Killed | MotorState::Closed => {}
                    }
                }
                if program.executing() {
                    self.set_program(cs, Program::Lost);
                }
            }
            CsCommand::Quit | CsCommand::EndOfMove => {
                // UM p.217: Q "Finishes calculated moves", / ends at the "End of currently
                // executing move"; neither begins immediately; both stop on the path at a
                // program point, at TA/TS. MODEL: the blending that / undoes is not represented.
                if program == Program::Running {
                    let stop = if c == CsCommand::Quit { Stop::Quit } else { Stop::EndOfMove };
                    for k in members {
                        let m = &mut self.motors_mut()[k];
                        if m.state == MotorState::Program && m.stop.is_none() {
                            m.start(MotorState::Program, Some(stop), decel);
                        }
                    }
                }
            }
            CsCommand::Hold | CsCommand::QuickStop | CsCommand::Feedrate(0) => {
                // UM p.217: H begins immediately and stops on the path at Isx95, not at a
                // program point; "Similar to %0". SRM p.260: a held C.S. "can be started up
                // again with an R". `\` acts as H outside lookahead (see STOP_RULES).
                if program == Program::Running {
                    for k in members {
                        let m = &mut self.motors_mut()[k];
                        if m.state == MotorState::Program {
                            m.start(MotorState::Decelerating, Some(Stop::Hold), decel);
                        }
                    }
                    self.set_program(cs, Program::Held);
                }
            }
            CsCommand::Run | CsCommand::Step | CsCommand::Feedrate(_) => {
                // R runs from where the program stands; S runs one move and stops at a program
                // point (UM p.319: a program "could be resumed with an R or S command"). MODEL:
                // a non-zero %n resumes a program held by H or %0, as R does; elsewhere it only
                // sets the override, which the model does not represent. A program starts only
                // when one is pointed at and every motor of the C.S. is closed-loop at rest.
                let resumable = match c {
                    CsCommand::Feedrate(_) => program == Program::Held,
                    _ => program != Program::None && program != Program::Running,
                };
                let ready = !members.is_empty() && members.iter().all(|k| self.motor_slots[*k].at_rest());
                if resumable && ready {
                    let stop = if c == CsCommand::Step { Some(Stop::EndOfMove) } else { None };
                    for k in members {
                        self.motor_slots[k].start(MotorState::Program, stop, decel);
                    }
                    self.set_program(cs, Program::Running);
                }
            }
            CsCommand::Begin => {
                // MODEL: B points the C.S. at the start of its program (one program per C.S.);
                // refused silently while the program executes.
                if !program.executing() {
                    self.set_program(cs, Program::AtPoint);
                }
            }
        }
    }

    // ------------------------------------------------------------------ time

    /// One servo cycle of motion: each stop under way comes one cycle closer to its end.
    pub fn servo_cycle(&mut self, setup: &MotionSetup) {
        for m in self.motors_mut() {
            let Some(stop) = m.stop else { continue };
            m.stop_cycles = m.stop_cycles.saturating_sub(1);
            if m.stop_cycles > 0 {
                continue;
            }
            match stop {
                Stop::Jog | Stop::Abort | Stop::Quit | Stop::EndOfMove => m.close_loop(),
                Stop::Hold => {
                    m.state = MotorState::Holding;
                    m.stop = None;
                }
            }
        }
        // A program whose motors have all come to rest at a program point (Q, /, S) stands there.
        for cs in 1..=self.programs().len() as u8 {
            if self.program(cs) == Program::Running {
                let members: Vec<usize> = Self::in_cs(setup, cs).collect();
                if members.iter().all(|k| self.motor_slots[*k].state == MotorState::Closed) {
                    self.set_program(cs, Program::AtPoint);
                }
            }
        }
    }

    /// UM p.319: <CTRL-K> "breaks into the executing trajectory immediately, and disables all
    /// motors ... by opening the servo loops, forcing zero-value command outputs, and
    /// disabling the amplifiers"; the lookahead segments "are discarded". MODEL: the "Must stop
    /// program first" note of its row (UM p.217) is read as about restarting; UM p.319
    /// restricts only K.
    fn kill_all(&mut self) {
        for m in self.motors_mut() {
            m.kill();
        }
        for p in self.programs_mut() {
            if p.executing() {
                *p = Program::Lost;
            }
        }
    }

    // ------------------------------------------------------------------ inputs and PLCs

    pub fn encoder_input(&mut self, motor: u8, lost: bool) {
        if let Some(m) = usize::from(motor).checked_sub(1).and_then(|k| self.motors_mut().get_mut(k)) {
            m.encoder_lost = lost;
        }
    }

    /// The encoder-loss PLC of UM p.214-215, one scan per background cycle (UM p.215: safety
    /// PLCs are "best implemented in a compiled background PLC program, which scans ... once
    /// per background cycle. The above program of monitoring encoder loss is a good example").
    ///
    /// This is also the extension point for user-written safety checks (UM p.215): another
    /// scan would be one more function called here, reading the motors and acting through the
    /// same kill.
    pub fn encoder_loss_plc(&mut self, cfg: &ModelConfig) {
        // UM p.214-215: the listing is for motor 1 and "easy to duplicate for multiple axes";
        // the model runs one copy per motor. MODEL: the PLC's CMD^K is a command like a host's,
        // and command processing is a background task (UM p.236), so it takes effect when the
        // scan is over: every copy reads the motors as they were at the start of the scan.
        let mut kill_all = false;
        for k in 0..self.motors().len() {
            let open_loop = self.motor_slots[k].state == MotorState::Killed;
            let lost = self.motor_slots[k].encoder_lost;
            // UM p.214-215, "Logic to disable and set fault status":
            //   IF (Mtr1OpenLoop=0 AND Enc1LossIn=Lost)
            //    CMD^K                  ; Kill all motors
            //    Mtr1EncLossStatus=1    ; Indicate encoder loss
            // (the same listing in the Brick hardware reference). The firmware's own fault
            // kill (UM p.213, "the offending motor is killed") is a different mechanism: this
            // PLC kills every motor, in every coordinate system, as <CTRL-K> does (UM p.319).
            if !open_loop && lost {
                kill_all = true;
                self.motor_slots[k].loss_status = true;
                continue;
            }
            // UM p.215, "Logic to clear fault status":
            //   IF (Mtr1OpenLoop=0 AND Enc1LossIn=OK AND Mtr1EncLossStatus=0)
            //    Mtr1EncLossStatus=0
            // Read literally, the branch needs the status already 0, so a latched loss is
            // never cleared; read as intended (facts s.6), it clears a latched (=1) status.
            let tested = match cfg.profile.choices.encoder_loss_clear {
                EncoderLossClear::Literal => false,
                EncoderLossClear::Intent => true,
            };
            if !open_loop && !lost {
                let latched = self.motor_slots[k].loss_status;
                if latched == tested {
                    self.motor_slots[k].loss_status = false;
                }
                if latched {
                    self.ghost_healthy_latched_scans |= if self.motor_slots[k].loss_status { 2 } else { 1 };
                }
            }
        }
        if kill_all {
            self.kill_all();
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The leaps stop where `motion_signature` changes, so it must see every field a servo
    /// cycle can change, of every motor and program: each edit below alone changes it. A
    /// signature blind to one of them would let a leap run past that change, and the checker
    /// would miss the states in between; no configuration of `check.yaml` has leaps long enough
    /// over moving motors to show it, so it is checked here. (cargo-mutants: the `motion.rs`
    /// survivors in `motion_signature`, a field lost through `&`, `>>`, or the first stop
    /// counted as none through `*`.)
    #[test]
    fn motion_signature_sees_every_field_a_servo_cycle_changes() {
        let spec = pmacwd_specs::Spec::embedded().unwrap();
        let cfg =
            pmacwd_specs::config::ModelConfig::from_spec(&spec, "motion", &spec.profiles.default_profile()).unwrap();
        let base = Axes::power_on(&cfg.motion);
        assert!(base.motors().len() >= 2 && !base.programs().is_empty(), "several motors and a program");
        type Edit = (&'static str, fn(&mut Motor));
        let edits: [Edit; 5] = [
            ("state", |m| m.state = MotorState::Closed),
            ("a first stop", |m| m.stop = Some(Stop::Jog)),
            ("another stop", |m| m.stop = Some(Stop::Hold)),
            ("stop cycles", |m| m.stop_cycles = 7),
            ("stop cycles high", |m| m.stop_cycles = 200),
        ];
        for k in 0..base.motors().len() {
            for (what, edit) in edits {
                let mut changed = base.clone();
                edit(&mut changed.motors_mut()[k]);
                assert!(changed.motion_signature() != base.motion_signature(), "motor {}: {what}", k + 1);
            }
            // Jog and Hold tell apart from each other too.
            let (mut jog, mut hold) = (base.clone(), base.clone());
            jog.motors_mut()[k].stop = Some(Stop::Jog);
            hold.motors_mut()[k].stop = Some(Stop::Hold);
            assert!(jog.motion_signature() != hold.motion_signature(), "motor {}: the stops", k + 1);
        }
        for cs in 0..base.programs().len() {
            let mut changed = base.clone();
            changed.programs_mut()[cs] = Program::Running;
            assert!(changed.motion_signature() != base.motion_signature(), "program of &{}", cs + 1);
        }
    }

    /// Every column of every row of the model's stop rules is the table's, so a rule cannot
    /// drift from `specs/stop_commands.yaml` (UM p.217).
    #[test]
    fn stop_rules_match_the_table() {
        let spec = pmacwd_specs::Spec::embedded().unwrap();
        let rows = &spec.stop_commands.rows;
        assert_eq!(rows.len(), STOP_RULES.len());
        for (row, rule) in rows.iter().zip(STOP_RULES.iter()) {
            assert_eq!(row.command, rule.command);
            assert_eq!(row.scope, rule.scope, "{}", rule.command);
            assert_eq!(row.begins_immediately, rule.begins_immediately, "{}", rule.command);
            assert_eq!(row.stops_on_path, rule.stops_on_path, "{}", rule.command);
            assert_eq!(row.stops_at_program_point, rule.stops_at_program_point, "{}", rule.command);
            assert_eq!(row.decel_rate.as_deref(), rule.decel_rate, "{}", rule.command);
            // The behaviour follows the columns: a stop at a program point is a Quit or an
            // end-of-move; a stop on the path that is not at a program point is a hold; a stop
            // off the path is an abort or a kill.
            match rule.stop {
                Some(Stop::Quit | Stop::EndOfMove) => assert!(rule.stops_at_program_point && !rule.begins_immediately),
                Some(Stop::Hold) => assert!(rule.stops_on_path == Tristate::Yes && !rule.stops_at_program_point),
                Some(Stop::Abort) | None => assert!(rule.stops_on_path == Tristate::No && rule.begins_immediately),
                Some(Stop::Jog) => assert_eq!(rule.scope, MotorScope),
            }
        }
    }
}
