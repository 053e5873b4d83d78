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
use pmacwd_specs::config::{ModelConfig, StopRow};
use pmacwd_specs::facts::{StopScope, Tristate};
use pmacwd_specs::profiles::EncoderLossClear;
use pmacwd_specs::vocab::command::{CsCommand, Motion, MotorCommand, COORDINATE_SYSTEM_MAX};
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

/// How the model carries out one row of UM p.217: the stop its motors carry while they come to
/// rest (`None` for the kills, which do not decelerate). What the row's command does is decided
/// by the row's columns as `specs/stop_commands.yaml` prints them (`ModelConfig::stop_table`,
/// read by [`Axes::command`]: scope, "Begin Immed?", "Stop on Path?", "Stop at Prog Pt?",
/// whether a deceleration rate is printed); `stop_rules_match_the_table` checks that this
/// table names the same rows in the same order and that each stop fits its row's columns.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct StopRule {
    /// The first column, as `stop_commands.yaml` has it.
    pub command: &'static str,
    /// The stop its motors carry; `None` for the kills.
    pub stop: Option<Stop>,
}

/// The eleven rows of UM p.217, top to bottom. `\` acts as H (UM p.217: "Acts as H command if
/// outside of lookahead"; MODEL: the model has no lookahead buffer, Isx20 = 0).
pub const STOP_RULES: [StopRule; 11] = [
    StopRule { command: "J/", stop: Some(Stop::Jog) },
    StopRule { command: "A", stop: Some(Stop::Abort) },
    StopRule { command: "<CTRL-A>", stop: Some(Stop::Abort) },
    StopRule { command: "Q", stop: Some(Stop::Quit) },
    StopRule { command: "<CTRL-Q>", stop: Some(Stop::Quit) },
    StopRule { command: "/", stop: Some(Stop::EndOfMove) },
    StopRule { command: "H", stop: Some(Stop::Hold) },
    StopRule { command: "<CTRL-O>", stop: Some(Stop::Hold) },
    StopRule { command: "\\", stop: Some(Stop::Hold) },
    StopRule { command: "K", stop: None },
    StopRule { command: "<CTRL-K>", stop: None },
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
    /// The amplifier-fault input (FAULTn) reports a fault (UM p.213); a hardware input.
    pub amplifier_fault: bool,
    /// The amplifier-fault motor status bit: set when the firmware kills the motor for the
    /// fault, cleared when the motor is re-enabled (UM p.213).
    pub fault_status: bool,
}

impl Motor {
    /// MODEL: motors power up killed (Ixx80 = 0: not enabled at power-up/reset), the PLC's
    /// status clear; the encoder and amplifier-fault inputs keep their levels.
    fn power_on(encoder_lost: bool, amplifier_fault: bool) -> Motor {
        Motor {
            state: MotorState::Killed,
            stop: None,
            stop_cycles: 0,
            amplifier_enabled: false,
            output_zero: true,
            encoder_lost,
            loss_status: false,
            amplifier_fault,
            fault_status: false,
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
            amplifier_fault: self.amplifier_fault,
            amplifier_fault_status: self.fault_status,
        }
    }
}

/// The motors and coordinate systems of a card.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
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
            motor_slots: [Motor::power_on(false, false); MOTORS_SHOWN],
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

    /// After a reset: every motor and program as at power-up; the encoder and amplifier-fault
    /// inputs keep their levels.
    pub fn restart(&mut self) {
        for m in self.motors_mut() {
            *m = Motor::power_on(m.encoder_lost, m.amplifier_fault);
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

    /// Whether a program is executing moves, so that new moves start and the next one has to
    /// be planned at the next RTI (UM p.236): some motor runs its program with no stop under
    /// way. A program finishing its calculated moves (Q, /, the one move of S), held or
    /// stopped starts no new move. Servo cycles do not change this (only commands, the
    /// background's kills and a trip do), so it holds for a whole leap in time.
    pub fn plans_moves(&self) -> bool {
        self.motors().iter().any(|m| m.state == MotorState::Program && m.stop.is_none())
    }

    /// Whether motor `m` (from 1)'s coordinate system is executing a program.
    pub fn motor_in_executing_program(&self, setup: &MotionSetup, m: u8) -> bool {
        self.program(setup.coordinate_system(m)).executing()
    }

    // ------------------------------------------------------------------ commands

    /// A motion command; `decel` is the length of any deceleration it starts. A stop command
    /// (UM p.217) is carried out by its row of the table ([`Self::stop_command`]); `%0` by H's
    /// row (UM p.217, H: "Similar to %0"); the commands that start motion by the rules below.
    pub fn command(&mut self, cfg: &ModelConfig, m: Motion, decel: u8) -> Reply {
        let setup = &cfg.motion;
        let row_name = match m {
            Motion::CoordinateSystem(_, CsCommand::Feedrate(0)) => Some("H"),
            _ => m.stop_table_name(),
        };
        if let Some(name) = row_name {
            let row = cfg.stop_row(name).expect("every stop command has its row in stop_commands.yaml");
            let stop = STOP_RULES.iter().find(|r| r.command == name).and_then(|r| r.stop);
            return self.stop_command(cfg, m, row, stop, decel);
        }
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
                    MotorCommand::JogPlus | MotorCommand::JogMinus | MotorCommand::JogToPosition => {
                        // MODEL: a jog needs a closed loop at rest outside a running program; a
                        // killed motor is not moved by a jog command ("a killed motor does not
                        // move until re-enabled"), and a jog to a position runs, in this
                        // position-free model, until it is stopped like any jog.
                        if motor.state == MotorState::Closed && !executing {
                            motor.start(MotorState::Jogging, None, 0);
                        }
                    }
                    MotorCommand::JogStop | MotorCommand::Kill => unreachable!("stop commands have their rows"),
                }
                Reply::Ack
            }
            Motion::CoordinateSystem(cs, c) => {
                self.cs_start(setup, cs, c, decel);
                Reply::Ack
            }
            Motion::Global(_) => unreachable!("every global command is a stop command"),
        }
    }

    /// A stop command carried out by its row of UM p.217 (`stop_commands.yaml`, as
    /// `ModelConfig::stop_table` holds it): the scope column says which motors and coordinate
    /// systems it acts on, an empty "Decel Rate" that it kills, "Begin Immed?", "Stop on Path?"
    /// and "Stop at Prog Pt?" how the motors and the program stop. `stop` is the stop the
    /// motors carry ([`STOP_RULES`]).
    fn stop_command(&mut self, cfg: &ModelConfig, m: Motion, row: &StopRow, stop: Option<Stop>, decel: u8) -> Reply {
        let setup = &cfg.motion;
        // The scope column: the motor `#n`, the coordinate system `&n`, or every one (UM p.217:
        // the control characters act on every coordinate system; SRM p.260 for <CTRL-O>:
        // "equivalent to issuing the H command to each coordinate system").
        let (motor, systems): (Option<u8>, Vec<u8>) = match (row.scope, m) {
            (StopScope::Motor, Motion::Motor(n, _)) => (Some(n), Vec::new()),
            (StopScope::CoordinateSystem, Motion::CoordinateSystem(cs, _)) => (None, vec![cs]),
            (StopScope::Global, _) => (None, (1..=self.program_count).collect()),
            // A row whose scope is not the command's own (only a changed table has one): the
            // command acts on the scope it addresses.
            (_, Motion::Motor(n, _)) => (Some(n), Vec::new()),
            (_, Motion::CoordinateSystem(cs, _)) => (None, vec![cs]),
            (_, Motion::Global(_)) => (None, (1..=self.program_count).collect()),
        };
        if let Some(n) = motor {
            let Some(k) = usize::from(n).checked_sub(1).filter(|k| *k < self.motors().len()) else {
                // MODEL: a motor the configuration does not have is not set up (Ixx00 = 0).
                return Reply::Ack;
            };
            let executing = self.motor_in_executing_program(setup, n);
            let motor = &mut self.motors_mut()[k];
            if !row.decelerates {
                // UM p.319: "the motor-specific K kill command is not permitted when the motor is
                // in a coordinate system that is executing a motion program. The program must
                // first be halted". UM p.217: "Must stop program first". MODEL: refused with
                // ERR001, Turbo PMAC's "command not allowed during program execution".
                if executing {
                    return Reply::Error(1);
                }
                motor.kill();
                return Reply::Ack;
            }
            match motor.state {
                // MODEL: J/ on a killed motor closes its loop (enables it), the usual way to
                // re-enable a motor; the excerpts do not say so. UM p.213: the amplifier-fault
                // status bit "is cleared when the motor is re-enabled".
                MotorState::Killed => {
                    motor.close_loop();
                    motor.fault_status = false;
                }
                // A motor-scope stop of the table (J/, row 1) stops the motor's jog, beginning
                // immediately ("Begin Immed?") or not, at its deceleration rate.
                MotorState::Jogging => {
                    let state = if row.begins_immediately { MotorState::Decelerating } else { MotorState::Jogging };
                    motor.start(state, stop, decel);
                }
                // MODEL: a motor-scope stop stops jogs only; program motion is stopped by the
                // C.S. commands.
                MotorState::Closed | MotorState::Program | MotorState::Decelerating | MotorState::Holding => {}
            }
            return Reply::Ack;
        }
        if !row.decelerates {
            // UM p.319: <CTRL-K> "breaks into the executing trajectory immediately, and disables
            // all motors ... by opening the servo loops, forcing zero-value command outputs, and
            // disabling the amplifiers"; the lookahead segments "are discarded". MODEL: the
            // "Must stop program first" note of its row (UM p.217) is read as about restarting;
            // UM p.319 restricts only K.
            for cs in systems {
                for k in Self::in_cs(setup, cs).collect::<Vec<_>>() {
                    self.motor_slots[k].kill();
                }
                if self.program(cs).executing() {
                    self.set_program(cs, Program::Lost);
                }
            }
            return Reply::Ack;
        }
        let stop = stop.expect("a stop that decelerates carries its stop");
        for cs in systems {
            self.cs_stop(setup, cs, row, stop, decel);
        }
        Reply::Ack
    }

    /// A decelerating stop of UM p.217 on coordinate system `cs`, by its row's columns.
    fn cs_stop(&mut self, setup: &MotionSetup, cs: u8, row: &StopRow, stop: Stop, decel: u8) {
        let members: Vec<usize> = Self::in_cs(setup, cs).collect();
        let program = self.program(cs);
        if !row.begins_immediately {
            // "Begin Immed?" no (Q: "Finishes calculated moves"; /: "End of currently executing
            // move"): the program's motors go on with their calculated moves until the stop
            // ends; "Stop at Prog Pt?" yes: it ends at a program point (the program then stands
            // there, `servo_cycle`), on the path, at TA/TS. MODEL: the blending that / undoes is
            // not represented.
            if program == Program::Running {
                for k in members {
                    let m = &mut self.motors_mut()[k];
                    if m.state == MotorState::Program && m.stop.is_none() {
                        m.start(MotorState::Program, Some(stop), decel);
                    }
                }
            }
        } else if row.stops_on_path == Tristate::Yes {
            // "Begin Immed?" yes, "Stop on Path?" yes, not at a program point (H, <CTRL-O>, `\`,
            // %0): the program's motors decelerate at once along the path to a feed hold, and
            // the program stays resumable (SRM p.260: "can be started up again with an R").
            if program == Program::Running {
                for k in members {
                    let m = &mut self.motors_mut()[k];
                    if m.state == MotorState::Program {
                        m.start(MotorState::Decelerating, Some(stop), decel);
                    }
                }
                self.set_program(cs, if row.stops_at_program_point { Program::AtPoint } else { Program::Held });
            }
        } else {
            // "Begin Immed?" yes, "Stop on Path?" no (A, <CTRL-A>). UM p.319: A "breaks into the
            // executing trajectory immediately, and brings all motors in the coordinate system
            // to a controlled stop, each at its own deceleration rate as set by Ixx15"; "not
            // necessarily at a programmed point", "not necessarily even along the programmed
            // path"; the lookahead is discarded.
            for k in members {
                let m = &mut self.motors_mut()[k];
                match m.state {
                    MotorState::Jogging | MotorState::Program | MotorState::Decelerating => {
                        m.start(MotorState::Decelerating, Some(stop), decel)
                    }
                    MotorState::Holding => m.close_loop(),
                    MotorState::Killed | MotorState::Closed => {}
                }
            }
            if program.executing() {
                self.set_program(cs, Program::Lost);
            }
        }
    }

    /// The coordinate-system commands that start motion or point at a program.
    fn cs_start(&mut self, setup: &MotionSetup, cs: u8, c: CsCommand, decel: u8) {
        let members: Vec<usize> = Self::in_cs(setup, cs).collect();
        let program = self.program(cs);
        match c {
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
            CsCommand::Enable => {
                // MODEL: `E` (the EPICS driver's `&1E`, "to make sure axes are enabled") is not
                // in the pages at hand. Enabling a killed motor is closing its loop (UM p.319:
                // a kill opens the loop, forces zero output and disables the amplifier, and a
                // program resumes "after re-enabling the servo loops"; SRM p.281: Amplifier
                // Enabled is 1 "either in open loop or closed-loop mode", 0 when killed), so
                // each killed motor of the C.S. closes its loop as J/ closes a killed motor's
                // (`stop_command`, J/'s row), and UM p.213's amplifier-fault status bit "is
                // cleared when the motor is re-enabled" (SRM p.286, the C.S.'s bit 20 alike).
                // Motors closed, jogging, running or stopping are left as they are, and the
                // program is not touched.
                for k in members {
                    let m = &mut self.motor_slots[k];
                    if m.state == MotorState::Killed {
                        m.close_loop();
                        m.fault_status = false;
                    }
                }
            }
            CsCommand::Abort | CsCommand::Quit | CsCommand::EndOfMove | CsCommand::Hold | CsCommand::QuickStop => {
                unreachable!("stop commands have their rows")
            }
        }
    }

    // ------------------------------------------------------------------ time

    /// One servo cycle of motion: each stop under way comes one cycle closer to its end.
    pub fn servo_cycle(&mut self, setup: &MotionSetup) {
        // Nothing below acts unless a motor has a stop under way or a program runs; asked of
        // every slot (those past the counts too, so a stricter test than the loops'), over the
        // fixed arrays, it is a few compares where the loops cost about 80 instructions a
        // cycle, and a time jump at I40 = 0 runs some 4,000 cycles with the axes at rest.
        if self.motor_slots.iter().all(|m| m.stop.is_none()) && !self.program_slots.contains(&Program::Running) {
            return;
        }
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

    /// UM p.213: a motor's amplifier-fault input changes (a hardware input, which changes
    /// whether or not the card runs).
    pub fn amplifier_fault_input(&mut self, motor: u8, fault: bool) {
        if let Some(m) = usize::from(motor).checked_sub(1).and_then(|k| self.motors_mut().get_mut(k)) {
            m.amplifier_fault = fault;
        }
    }

    /// The firmware's own amplifier-fault rule, in the housekeeping's safety checks at the end
    /// of each background cycle (UM p.237: the housekeeping's safety checks include "amplifier
    /// fault"). UM p.213: on an amplifier fault "The offending motor is killed and possibly
    /// other motors as set by bits 21 and 22 of Ixx24", and the amplifier-fault motor status
    /// bit is set. This is not the encoder-loss PLC's CMD^K (UM p.214-215), which kills every
    /// motor: here only the offending motor is killed.
    ///
    /// MODEL: the model has no Ixx24; it reads bits 21 and 22 as adding no motor outside the
    /// offending motor's program: a motor whose coordinate system executes a program cannot
    /// run on killed, so that program loses its lookahead (as a kill does, UM p.319) and the
    /// other motors of its coordinate system are killed with it (their status bits stay clear:
    /// they are not the offending motors). A motor already killed is not killed again, so its
    /// status bit is not set. Every motor enabled with its fault input on at the start of the
    /// check is an offending motor.
    pub fn amplifier_fault_check(&mut self, setup: &MotionSetup) {
        let offending: Vec<usize> = (0..self.motors().len())
            .filter(|k| self.motor_slots[*k].amplifier_fault && self.motor_slots[*k].state != MotorState::Killed)
            .collect();
        for k in offending {
            self.motor_slots[k].kill();
            self.motor_slots[k].fault_status = true;
            let cs = setup.coordinate_system(k as u8 + 1);
            if self.program(cs).executing() {
                self.set_program(cs, Program::Lost);
                for j in Self::in_cs(setup, cs).collect::<Vec<_>>() {
                    self.motor_slots[j].kill();
                }
            }
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

    /// A servo cycle's early return (axes at rest) leaves the axes as the loops would: at rest
    /// nothing changes, while a program running with its motors at rest still reaches its
    /// program point, and a motor's stop under way still advances, the last cycle of it too.
    #[test]
    fn a_servo_cycle_at_rest_changes_nothing_and_a_running_program_or_stop_still_moves() {
        let spec = pmacwd_specs::Spec::embedded().unwrap();
        let cfg =
            pmacwd_specs::config::ModelConfig::from_spec(&spec, "motion", &spec.profiles.default_profile()).unwrap();
        let base = Axes::power_on(&cfg.motion);
        let mut at_rest = base;
        at_rest.servo_cycle(&cfg.motion);
        assert_eq!(at_rest, base);
        let mut running = base;
        let cs = cfg.motion.coordinate_system(1);
        running.set_program(cs, Program::Running);
        for k in Axes::in_cs(&cfg.motion, cs).collect::<Vec<_>>() {
            running.motor_slots[k].state = MotorState::Closed;
        }
        running.servo_cycle(&cfg.motion);
        assert_eq!(running.program(cs), Program::AtPoint);
        let mut stopping = base;
        (stopping.motor_slots[0].state, stopping.motor_slots[0].stop, stopping.motor_slots[0].stop_cycles) =
            (MotorState::Decelerating, Some(Stop::Hold), 1);
        stopping.servo_cycle(&cfg.motion);
        assert_eq!((stopping.motor_slots[0].state, stopping.motor_slots[0].stop), (MotorState::Holding, None));
    }

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
                let mut changed = base;
                edit(&mut changed.motors_mut()[k]);
                assert!(changed.motion_signature() != base.motion_signature(), "motor {}: {what}", k + 1);
            }
            // Jog and Hold tell apart from each other too.
            let (mut jog, mut hold) = (base, base);
            jog.motors_mut()[k].stop = Some(Stop::Jog);
            hold.motors_mut()[k].stop = Some(Stop::Hold);
            assert!(jog.motion_signature() != hold.motion_signature(), "motor {}: the stops", k + 1);
        }
        for cs in 0..base.programs().len() {
            let mut changed = base;
            changed.programs_mut()[cs] = Program::Running;
            assert!(changed.motion_signature() != base.motion_signature(), "program of &{}", cs + 1);
        }
    }

    /// The model's stop rules name the rows of `specs/stop_commands.yaml` (UM p.217) in order,
    /// and the stop each row's motors carry fits the row's columns, which decide what the
    /// command does (`Axes::stop_command` reads them from `ModelConfig::stop_table`): a stop at
    /// a program point is a Quit or an end-of-move; a stop on the path that is not at a
    /// program point is a hold; a stop off the path is an abort or a kill; a kill has no
    /// deceleration rate.
    #[test]
    fn stop_rules_match_the_table() {
        let spec = pmacwd_specs::Spec::embedded().unwrap();
        let cfg =
            pmacwd_specs::config::ModelConfig::from_spec(&spec, "motion", &spec.profiles.default_profile()).unwrap();
        let rows = &cfg.stop_table;
        assert_eq!(rows.len(), STOP_RULES.len());
        for (row, rule) in rows.iter().zip(STOP_RULES.iter()) {
            assert_eq!(row.command, rule.command);
            assert_eq!(row.decelerates, rule.stop.is_some(), "{}", rule.command);
            match rule.stop {
                Some(Stop::Quit | Stop::EndOfMove) => assert!(row.stops_at_program_point && !row.begins_immediately),
                Some(Stop::Hold) => assert!(row.stops_on_path == Tristate::Yes && !row.stops_at_program_point),
                Some(Stop::Abort) | None => assert!(row.stops_on_path == Tristate::No && row.begins_immediately),
                Some(Stop::Jog) => assert_eq!(row.scope, StopScope::Motor),
            }
        }
    }
}
