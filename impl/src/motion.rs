//! Motors and coordinate systems: the stop-command table of UM p.217 as behaviour, the kill
//! rules of UM p.319, and the encoder-loss PLC of UM p.214-215 that runs once per background
//! cycle; the reference model's motion (`model/src/motion.rs`) in 28 bytes.
//!
//! The motion is abstract, as in the model: a motor is killed, closed-loop at rest, jogging,
//! running its coordinate system's program, decelerating, or holding; positions, velocities
//! and trajectories are not represented. A stop's deceleration rate (Ixx15, Ixx19-21, TA/TS,
//! Isx95, Ixx17) only decides how long the stop takes: [`MotionConfig::decel_cycles`] servo
//! cycles (the model's traces decelerate for their configuration's longest, and the
//! exhaustive product sets it to each length the checker explores).
//!
//! Representation (see [`Motion`]): one byte per motor packs its state and the stop it is
//! carrying out; the servo cycles left of each stop are one byte each; the sixteen programs are
//! three bits each in one word; the amplifier-enable outputs, the encoder-loss inputs, the
//! PLC's latched statuses and the motors with a stop under way are one bit per motor. With no
//! stop under way a servo cycle reads one byte, and a PLC scan with no encoder lost is a few
//! bit operations.

/// The most motors the core keeps (the model's configurations have 1 to 8).
pub const MOTORS_MAX: usize = 8;
/// Turbo PMAC's coordinate systems are &1..&16.
pub const COORDINATE_SYSTEMS_MAX: u8 = 16;

/// A motor's motion (the model's `MotorState`, the vocabulary's names).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum MotorState {
    /// Open loop, amplifier disabled, output zero (UM p.319).
    Killed,
    /// Closed loop, at rest.
    Closed,
    Jogging,
    /// Running a motion program in its coordinate system.
    Program,
    /// Decelerating toward rest after a stop command.
    Decelerating,
    /// At rest in a feed hold, on the program's path, resumable with R (SRM p.260).
    Holding,
}

impl MotorState {
    pub const ALL: [MotorState; 6] = [
        MotorState::Killed,
        MotorState::Closed,
        MotorState::Jogging,
        MotorState::Program,
        MotorState::Decelerating,
        MotorState::Holding,
    ];

    /// Its 3-bit code; Killed is 0, so an all-zero motor byte is a motor at power-up.
    const fn code(self) -> u8 {
        self as u8
    }

    /// The state a 3-bit code stands for (only [`Self::code`]'s values are ever stored).
    const fn of_code(c: u8) -> MotorState {
        match c & STATE_MASK {
            1 => MotorState::Closed,
            2 => MotorState::Jogging,
            3 => MotorState::Program,
            4 => MotorState::Decelerating,
            5 => MotorState::Holding,
            _ => MotorState::Killed,
        }
    }

    /// Closed loop and not moving: UM p.319 lets a program start only from here (MODEL, as
    /// the reference model: a held motor is at rest too, and R resumes it).
    pub const fn at_rest(self) -> bool {
        matches!(self, MotorState::Closed | MotorState::Holding)
    }
}

/// Which stop a decelerating (or finishing) motor is carrying out, with its row of UM p.217.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Stop {
    /// `J/` (row 1): to closed loop at rest, at Ixx19-21.
    Jog = 1,
    /// `A`, `<CTRL-A>` (rows 2, 3): to rest at Ixx15, off the path, not at a program point.
    Abort,
    /// `Q`, `<CTRL-Q>` (rows 4, 5): "Finishes calculated moves", then rest at a program point.
    Quit,
    /// `/` (row 6), and the one move of `S`: the "End of currently executing move".
    EndOfMove,
    /// `H`, `<CTRL-O>`, `\` outside lookahead, `%0` (rows 7-9): on the path to a feed hold.
    Hold,
}

impl Stop {
    pub const ALL: [Stop; 5] = [Stop::Jog, Stop::Abort, Stop::Quit, Stop::EndOfMove, Stop::Hold];

    /// Its 3-bit code (1..=5; 0 is "no stop").
    const fn code(self) -> u8 {
        self as u8
    }

    const fn of_code(c: u8) -> Option<Stop> {
        match c & STATE_MASK {
            1 => Some(Stop::Jog),
            2 => Some(Stop::Abort),
            3 => Some(Stop::Quit),
            4 => Some(Stop::EndOfMove),
            5 => Some(Stop::Hold),
            _ => None,
        }
    }
}

/// Where a coordinate system's program stands.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Program {
    /// No program pointed at since reset (`B` points at one).
    None,
    /// Executing: its motors run it, finish calculated moves, or decelerate to a hold.
    Running,
    /// Stopped in a feed hold, on the path: `R` resumes it (SRM p.260).
    Held,
    /// Stopped at a program point: `R` continues from it.
    AtPoint,
    /// Aborted or killed: the lookahead was discarded ("no easy restart", UM p.217; UM p.319:
    /// "execution would miss all of the discarded segments").
    Lost,
}

impl Program {
    pub const ALL: [Program; 5] = [Program::None, Program::Running, Program::Held, Program::AtPoint, Program::Lost];

    const fn code(self) -> u64 {
        self as u64
    }

    const fn of_code(c: u64) -> Program {
        match c & PROGRAM_MASK {
            1 => Program::Running,
            2 => Program::Held,
            3 => Program::AtPoint,
            4 => Program::Lost,
            _ => Program::None,
        }
    }

    /// UM p.319: K is refused while the program executes. MODEL, as the reference model: a
    /// feed-held program still executes (R resumes it).
    pub const fn executing(self) -> bool {
        matches!(self, Program::Running | Program::Held)
    }
}

const STATE_MASK: u8 = 0b111;
const STOP_SHIFT: u32 = 3;
const PROGRAM_MASK: u64 = 0b111;
const PROGRAM_BITS: u32 = 3;

/// A motor's byte: bits 0-2 its state, bits 3-5 its stop (0: none).
pub const fn pack(state: MotorState, stop: Option<Stop>) -> u8 {
    let stop = match stop {
        Some(s) => s.code(),
        None => 0,
    };
    state.code() | stop << STOP_SHIFT
}

/// The state and stop a motor's byte holds (the inverse of [`pack`]; `proofs.rs` checks it).
pub const fn unpack(byte: u8) -> (MotorState, Option<Stop>) {
    (MotorState::of_code(byte), Stop::of_code(byte >> STOP_SHIFT))
}

/// The program of coordinate system `cs` (1..=16) in the packed program word; `None` for a
/// number outside 1..=16.
pub const fn program_in(word: u64, cs: u8) -> Program {
    match program_shift(cs) {
        Some(shift) => Program::of_code(word >> shift),
        None => Program::None,
    }
}

/// The program word with coordinate system `cs`'s program replaced (unchanged for a number
/// outside 1..=16).
pub const fn with_program(word: u64, cs: u8, p: Program) -> u64 {
    match program_shift(cs) {
        Some(shift) => (word & !(PROGRAM_MASK << shift)) | p.code() << shift,
        None => word,
    }
}

const fn program_shift(cs: u8) -> Option<u32> {
    if cs == 0 || cs > COORDINATE_SYSTEMS_MAX {
        return None;
    }
    Some((cs as u32).saturating_sub(1).saturating_mul(PROGRAM_BITS))
}

/// The motors of a configuration (the model's `MotionSetup`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct MotionConfig {
    /// How many motors (up to [`MOTORS_MAX`]); #n beyond it are not set up (Ixx00 = 0).
    pub motors: u8,
    /// The coordinate system of each motor (1..=16), motor #1 first.
    pub coordinate_systems: [u8; MOTORS_MAX],
    /// How many servo cycles a deceleration a stop command starts takes (at least 1).
    pub decel_cycles: u8,
}

impl MotionConfig {
    /// The first `motors` motors, in `&1`, decelerating for `decel_cycles`.
    pub const fn all_in_cs1(motors: u8, decel_cycles: u8) -> MotionConfig {
        MotionConfig { motors, coordinate_systems: [1; MOTORS_MAX], decel_cycles }
    }

    fn count(&self) -> usize {
        usize::from(self.motors).min(MOTORS_MAX)
    }

    /// The motors of coordinate system `cs`, one bit each (bit 0 is #1).
    fn members(&self, cs: u8) -> u8 {
        let mut mask = 0u8;
        for (k, c) in self.coordinate_systems.iter().take(self.count()).enumerate() {
            if *c == cs {
                mask |= 1 << k;
            }
        }
        mask
    }

    /// The coordinate system of motor index `k` (from 0).
    fn cs_of(&self, k: usize) -> u8 {
        self.coordinate_systems.get(k).copied().unwrap_or(1)
    }
}

/// A motor command (`#n` ...).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum MotorCommand {
    /// `J+`, `J-`, `J=`: a jog. Direction and target are positions, which the core does not
    /// represent: a jog to a position runs until it is stopped like any jog (MODEL, as the
    /// reference model).
    Jog,
    /// `J/`: jog stop (UM p.217, row 1); on a killed motor it closes the loop.
    JogStop,
    /// `K`: kill (row 10).
    Kill,
}

/// A coordinate-system command (`&n` ...).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum CsCommand {
    /// `A` (row 2).
    Abort,
    /// `Q` (row 4).
    Quit,
    /// `/` (row 6).
    EndOfMove,
    /// `H` (row 7).
    Hold,
    /// `\` (row 9): acts as H outside lookahead, and the core has no lookahead.
    QuickStop,
    /// `R`.
    Run,
    /// `S`: one move, then a stop at a program point (UM p.319).
    Step,
    /// `B`: point at the start of the program.
    Begin,
    /// `%n`: %0 holds like H (UM p.217, "Similar to %0"); a non-zero value resumes a hold.
    Feedrate(u16),
    /// `E` (the EPICS driver's `&1E`): each killed motor of the C.S. closes its loop, as `J/`
    /// closes a killed motor's (MODEL, as the reference model: no page at hand describes `E`).
    Enable,
}

/// A global control character (UM p.217: each acts on every coordinate system).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum GlobalCommand {
    /// `<CTRL-A>` (row 3).
    AbortAll,
    /// `<CTRL-Q>` (row 5).
    QuitAll,
    /// `<CTRL-O>` (row 8).
    HoldAll,
    /// `<CTRL-K>` (row 11).
    KillAll,
}

/// A command that starts or stops motion.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum MotionCommand {
    /// Motor `n` (from 1).
    Motor(u8, MotorCommand),
    /// Coordinate system `n` (1..=16).
    CoordinateSystem(u8, CsCommand),
    Global(GlobalCommand),
}

/// How a motion command was taken.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Outcome {
    Accepted,
    /// UM p.319: K while the motor's coordinate system executes a program (the caller answers
    /// ERR001, as the reference model does).
    RefusedDuringProgram,
}

/// One motor as a host or an instrument sees it (the emulator's `#n?` reads this).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct MotorStatus {
    pub state: MotorState,
    /// The stop being carried out, and the servo cycles it has left.
    pub stop: Option<(Stop, u8)>,
    /// The amplifier-enable output (SRM p.281, motor status bit 19).
    pub amplifier_enabled: bool,
    /// The commanded output (DAC/PWM/PFM) is held at zero.
    pub output_zero: bool,
    /// The encoder-loss input reports loss (UM p.214).
    pub encoder_lost: bool,
    /// The encoder-loss PLC's `Mtr1EncLossStatus` (UM p.215).
    pub encoder_loss_status: bool,
    /// The amplifier-fault input reports a fault (UM p.213).
    pub amplifier_fault: bool,
    /// The amplifier-fault motor status bit: set by the fault kill, cleared when the motor is
    /// re-enabled (UM p.213).
    pub amplifier_fault_status: bool,
    /// The motor's coordinate system, and where its program stands.
    pub coordinate_system: u8,
    pub program: Program,
}

/// The motors and programs of a card.
///
/// Redundant bits, kept so the idle paths read one byte: `stopping` bit k is set exactly when
/// motor k's byte holds a stop, and `amplifiers` bit k exactly when its state is not Killed
/// (UM p.319: only a kill disables the amplifier, and a motor leaves Killed only by closing
/// its loop, which enables it). [`Motion::consistent`] states both; the tests check it.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct Motion {
    /// Per motor, [`pack`]ed state and stop.
    motors: [u8; MOTORS_MAX],
    /// Servo cycles until each motor's stop is done.
    stop_cycles: [u8; MOTORS_MAX],
    /// Three bits per coordinate system, &1 in bits 0-2 ([`program_in`]).
    programs: u64,
    /// Motors with a stop under way, one bit each (bit 0 is #1).
    stopping: u8,
    /// The amplifier-enable outputs.
    amplifiers: u8,
    /// The encoder-loss inputs (hardware: a reset keeps them).
    encoder_lost: u8,
    /// The PLC's latched `Mtr1EncLossStatus` of each motor.
    loss_status: u8,
    /// The amplifier-fault inputs (hardware: a reset keeps them), UM p.213.
    amplifier_fault: u8,
    /// The amplifier-fault motor status bits (UM p.213).
    fault_status: u8,
}

/// The motor indices a one-bit-per-motor mask names, lowest first: only the set bits are
/// visited, so an idle mask costs one test.
fn motors_in(mask: u8) -> impl Iterator<Item = usize> {
    let mut rest = mask;
    core::iter::from_fn(move || {
        (rest != 0).then(|| {
            let k = rest.trailing_zeros() as usize;
            rest &= rest.wrapping_sub(1);
            k
        })
    })
}

impl Default for Motion {
    fn default() -> Self {
        Motion::power_on()
    }
}

impl Motion {
    /// MODEL, as the reference model: motors power up killed (Ixx80 = 0), no program pointed
    /// at, the encoder inputs reading OK.
    pub const fn power_on() -> Motion {
        Motion {
            motors: [0; MOTORS_MAX],
            stop_cycles: [0; MOTORS_MAX],
            programs: 0,
            stopping: 0,
            amplifiers: 0,
            encoder_lost: 0,
            loss_status: 0,
            amplifier_fault: 0,
            fault_status: 0,
        }
    }

    /// After a reset: every motor and program as at power-up; the encoder and amplifier-fault
    /// inputs keep their levels.
    pub fn restart(&mut self) {
        *self = Motion { encoder_lost: self.encoder_lost, amplifier_fault: self.amplifier_fault, ..Motion::power_on() };
    }

    /// UM p.215: a trip holds every Servo IC in reset, "which force discrete outputs off, and
    /// proportional outputs (DAC, PWM, PFM) to zero-level": every amplifier is disabled and
    /// every motor reads killed. The programs and the PLC's statuses are left as they were (a
    /// tripped card runs nothing until a reset clears them).
    pub fn force_off(&mut self) {
        *self = Motion {
            programs: self.programs,
            encoder_lost: self.encoder_lost,
            loss_status: self.loss_status,
            amplifier_fault: self.amplifier_fault,
            fault_status: self.fault_status,
            ..Motion::power_on()
        };
    }

    /// Whether the redundant bits agree with the motor bytes (see [`Motion`]).
    pub fn consistent(&self) -> bool {
        self.motors.iter().enumerate().all(|(k, byte)| {
            let (state, stop) = unpack(*byte);
            let bit = 1u8 << k;
            (self.stopping & bit != 0) == stop.is_some()
                && (self.amplifiers & bit != 0) == (state != MotorState::Killed)
                && pack(state, stop) == *byte
        })
    }

    fn state(&self, k: usize) -> MotorState {
        MotorState::of_code(self.motors.get(k).copied().unwrap_or(0))
    }

    /// Whether a program is executing moves (UM p.236: each new move is planned at the next
    /// RTI): some motor runs its program with no stop under way. Servo cycles only end stops,
    /// so this does not change within a run of servo cycles.
    pub fn plans_moves(&self) -> bool {
        let running = pack(MotorState::Program, None);
        self.motors.contains(&running)
    }

    /// Whether any motor has a stop under way (one byte read).
    pub fn stops_under_way(&self) -> bool {
        self.stopping != 0
    }

    fn stop(&self, k: usize) -> Option<Stop> {
        unpack(self.motors.get(k).copied().unwrap_or(0)).1
    }

    /// Motor index `k`'s state and stop, with the stop's length, keeping the redundant bits.
    fn set(&mut self, k: usize, state: MotorState, stop: Option<Stop>, cycles: u8) {
        let (Some(byte), Some(left)) = (self.motors.get_mut(k), self.stop_cycles.get_mut(k)) else { return };
        *byte = pack(state, stop);
        *left = if stop.is_some() { cycles } else { 0 };
        let bit = 1u8 << k;
        self.stopping = if stop.is_some() { self.stopping | bit } else { self.stopping & !bit };
        self.amplifiers = if state == MotorState::Killed { self.amplifiers & !bit } else { self.amplifiers | bit };
    }

    /// UM p.319: a kill opens the servo loop, forces a zero command output and disables the
    /// amplifier, at once.
    fn kill(&mut self, k: usize) {
        self.set(k, MotorState::Killed, None, 0);
    }

    /// Closed loop at rest: the amplifier is enabled and the servo loop drives the output.
    fn close_loop(&mut self, k: usize) {
        self.set(k, MotorState::Closed, None, 0);
    }

    pub fn program(&self, cs: u8) -> Program {
        program_in(self.programs, cs)
    }

    fn set_program(&mut self, cs: u8, p: Program) {
        self.programs = with_program(self.programs, cs, p);
    }

    /// Motor `n` (from 1), if the configuration has it.
    pub fn motor(&self, cfg: &MotionConfig, n: u8) -> Option<MotorStatus> {
        let k = usize::from(n).checked_sub(1).filter(|k| *k < cfg.count())?;
        let bit = 1u8 << k;
        let cs = cfg.cs_of(k);
        let enabled = self.amplifiers & bit != 0;
        Some(MotorStatus {
            state: self.state(k),
            stop: self.stop(k).map(|s| (s, self.stop_cycles.get(k).copied().unwrap_or(0))),
            amplifier_enabled: enabled,
            // UM p.319: the output is forced to zero exactly when the motor is killed, which
            // is exactly when its amplifier is disabled.
            output_zero: !enabled,
            encoder_lost: self.encoder_lost & bit != 0,
            encoder_loss_status: self.loss_status & bit != 0,
            amplifier_fault: self.amplifier_fault & bit != 0,
            amplifier_fault_status: self.fault_status & bit != 0,
            coordinate_system: cs,
            program: self.program(cs),
        })
    }

    // ------------------------------------------------------------------ commands

    /// A motion command (UM p.217, UM p.319); any deceleration it starts takes
    /// `cfg.decel_cycles` servo cycles.
    pub fn command(&mut self, cfg: &MotionConfig, c: MotionCommand) -> Outcome {
        let decel = cfg.decel_cycles;
        match c {
            MotionCommand::Motor(n, c) => {
                // MODEL, as the reference model: a motor the configuration does not have is not
                // set up (Ixx00 = 0) and the command does nothing.
                let Some(k) = usize::from(n).checked_sub(1).filter(|k| *k < cfg.count()) else {
                    return Outcome::Accepted;
                };
                let executing = self.program(cfg.cs_of(k)).executing();
                match c {
                    MotorCommand::Kill => {
                        // UM p.319: "the motor-specific K kill command is not permitted when the
                        // motor is in a coordinate system that is executing a motion program";
                        // UM p.217: "Must stop program first".
                        if executing {
                            return Outcome::RefusedDuringProgram;
                        }
                        self.kill(k);
                    }
                    MotorCommand::JogStop => match self.state(k) {
                        // MODEL, as the reference model: J/ on a killed motor closes its loop;
                        // UM p.213: re-enabling clears the amplifier-fault status bit.
                        MotorState::Killed => {
                            self.close_loop(k);
                            self.fault_status &= !(1u8 << k);
                        }
                        // UM p.217 row 1: J/ begins immediately, decelerating at Ixx19-21.
                        MotorState::Jogging => self.set(k, MotorState::Decelerating, Some(Stop::Jog), decel),
                        // J/ stops jogs only; programs are stopped by the C.S. commands.
                        MotorState::Closed | MotorState::Program | MotorState::Decelerating | MotorState::Holding => {}
                    },
                    MotorCommand::Jog => {
                        // A jog needs a closed loop at rest outside an executing program: a
                        // killed motor does not move until re-enabled.
                        if self.state(k) == MotorState::Closed && !executing {
                            self.set(k, MotorState::Jogging, None, 0);
                        }
                    }
                }
            }
            MotionCommand::CoordinateSystem(cs, c) => self.cs_command(cfg, cs, c, decel),
            MotionCommand::Global(g) => match g {
                GlobalCommand::KillAll => self.kill_all(cfg),
                // UM p.217: the control characters act on every coordinate system (SRM p.260
                // for <CTRL-O>: "equivalent to issuing the H command to each").
                GlobalCommand::AbortAll => self.every_cs(cfg, CsCommand::Abort, decel),
                GlobalCommand::QuitAll => self.every_cs(cfg, CsCommand::Quit, decel),
                GlobalCommand::HoldAll => self.every_cs(cfg, CsCommand::Hold, decel),
            },
        }
        Outcome::Accepted
    }

    /// Every coordinate system, &1 to &16. (A coordinate system no motor is in can only have
    /// been pointed at by B, so a stop command does nothing there.)
    fn every_cs(&mut self, cfg: &MotionConfig, c: CsCommand, decel: u8) {
        for cs in 1..=COORDINATE_SYSTEMS_MAX {
            self.cs_command(cfg, cs, c, decel);
        }
    }

    fn members(cfg: &MotionConfig, cs: u8) -> impl Iterator<Item = usize> {
        let mask = cfg.members(cs);
        (0..MOTORS_MAX).filter(move |k| mask & (1 << k) != 0)
    }

    fn cs_command(&mut self, cfg: &MotionConfig, cs: u8, c: CsCommand, decel: u8) {
        let program = self.program(cs);
        match c {
            CsCommand::Abort => {
                // UM p.319: A "brings all motors in the coordinate system to a controlled stop,
                // each at its own deceleration rate as set by Ixx15", "not necessarily at a
                // programmed point", "not necessarily even along the programmed path"; the
                // lookahead is discarded.
                for k in Self::members(cfg, cs) {
                    match self.state(k) {
                        MotorState::Jogging | MotorState::Program | MotorState::Decelerating => {
                            self.set(k, MotorState::Decelerating, Some(Stop::Abort), decel)
                        }
                        MotorState::Holding => self.close_loop(k),
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
                // program point, at TA/TS. The blending / undoes is not represented.
                if program == Program::Running {
                    let stop = if c == CsCommand::Quit { Stop::Quit } else { Stop::EndOfMove };
                    for k in Self::members(cfg, cs) {
                        if self.state(k) == MotorState::Program && self.stop(k).is_none() {
                            self.set(k, MotorState::Program, Some(stop), decel);
                        }
                    }
                }
            }
            CsCommand::Hold | CsCommand::QuickStop | CsCommand::Feedrate(0) => {
                // UM p.217: H begins immediately and stops on the path at Isx95, not at a
                // program point; "Similar to %0"; `\` "Acts as H command if outside of
                // lookahead". SRM p.260: a held C.S. "can be started up again with an R".
                if program == Program::Running {
                    for k in Self::members(cfg, cs) {
                        if self.state(k) == MotorState::Program {
                            self.set(k, MotorState::Decelerating, Some(Stop::Hold), decel);
                        }
                    }
                    self.set_program(cs, Program::Held);
                }
            }
            CsCommand::Run | CsCommand::Step | CsCommand::Feedrate(_) => {
                // R runs from where the program stands; S runs one move and stops at a program
                // point (UM p.319: "resumed with an R or S command"). MODEL, as the reference
                // model: a non-zero %n resumes a held program; a program starts only when one
                // is pointed at and every motor of the C.S. is closed-loop at rest.
                let resumable = match c {
                    CsCommand::Feedrate(_) => program == Program::Held,
                    _ => program != Program::None && program != Program::Running,
                };
                let mask = cfg.members(cs);
                let ready = mask != 0 && Self::members(cfg, cs).all(|k| self.state(k).at_rest());
                if resumable && ready {
                    let stop = if c == CsCommand::Step { Some(Stop::EndOfMove) } else { None };
                    for k in Self::members(cfg, cs) {
                        self.set(k, MotorState::Program, stop, decel);
                    }
                    self.set_program(cs, Program::Running);
                }
            }
            CsCommand::Begin => {
                // MODEL, as the reference model: B points the C.S. at the start of its program;
                // refused silently while the program executes.
                if !program.executing() {
                    self.set_program(cs, Program::AtPoint);
                }
            }
            CsCommand::Enable => {
                // MODEL, as the reference model: each killed motor of the C.S. closes its loop
                // as J/ closes a killed motor's (UM p.319: re-enabling closes the servo loops),
                // and UM p.213: re-enabling clears the amplifier-fault status bit. The killed
                // motors are the members whose amplifier is off; the others, and the program,
                // are left as they are.
                let killed = cfg.members(cs) & !self.amplifiers;
                for k in motors_in(killed) {
                    self.close_loop(k);
                }
                self.fault_status &= !killed;
            }
        }
    }

    // ------------------------------------------------------------------ time

    /// `n` servo cycles of motion: each stop under way comes `n` cycles closer to its end, in
    /// closed form: a stop with `c` cycles left ends within them when `c <= n` (one of 0 ends
    /// on the next cycle, as the model's `saturating_sub` has it). With no stop under way (the
    /// common case) it reads one byte; otherwise it visits only the motors with a stop.
    #[inline]
    pub fn servo_cycles(&mut self, cfg: &MotionConfig, n: u32) {
        if self.stopping == 0 || n == 0 {
            return;
        }
        let ended = self.count_down(n);
        if ended != 0 {
            // By value, not through `&mut self`: a pointer into the caller's state passed to a
            // function that is not inlined makes the whole `Core` escape, and the servo cycle
            // can no longer keep it in registers (measured: idle cycles 1.9x slower).
            *self = self.with_stops_ended(cfg, ended);
        }
    }

    /// Each stop under way comes `n` cycles closer to its end; returns the motors whose stop
    /// has no cycle left, which end now.
    #[inline]
    fn count_down(&mut self, n: u32) -> u8 {
        let step = u8::try_from(n).unwrap_or(u8::MAX);
        let mut ended = 0u8;
        for k in motors_in(self.stopping) {
            if let Some(left) = self.stop_cycles.get_mut(k) {
                *left = left.saturating_sub(step);
                if *left == 0 {
                    ended |= 1 << k;
                }
            }
        }
        ended
    }

    /// How many servo cycles pass before any stop under way ends (`u32::MAX` with none): a
    /// stop with `c` cycles left ends on the `c`-th cycle, or the next one when `c` is 0.
    pub fn cycles_before_a_stop_ends(&self) -> u32 {
        motors_in(self.stopping)
            .map(|k| u32::from(self.stop_cycles.get(k).copied().unwrap_or(0).saturating_sub(1)))
            .min()
            .unwrap_or(u32::MAX)
    }

    /// The motion `n` servo cycles on, when no stop ends within them
    /// ([`Self::cycles_before_a_stop_ends`] at least `n`): only the stops' cycles left change,
    /// so no configuration is needed.
    pub fn counted_down(mut self, n: u32) -> Motion {
        if n != 0 {
            let ended = self.count_down(n);
            debug_assert_eq!(ended, 0, "a stop ended in {n} cycles");
        }
        self
    }

    /// The stops of the motors in `ended` are done. Every stop ends at rest (closed loop, or
    /// holding), and a motor at rest stays there over servo cycles, so which motors are at
    /// rest after `n` cycles does not depend on when each stop ended, and neither does the
    /// program check below: the closed form of [`Self::servo_cycles`] equals single cycles
    /// (`proofs.rs`, `check_motion_closed_form`).
    #[cold]
    #[inline(never)]
    fn with_stops_ended(mut self, cfg: &MotionConfig, ended: u8) -> Motion {
        for k in 0..MOTORS_MAX {
            if ended & (1 << k) == 0 {
                continue;
            }
            match self.stop(k) {
                Some(Stop::Hold) => self.set(k, MotorState::Holding, None, 0),
                Some(Stop::Jog | Stop::Abort | Stop::Quit | Stop::EndOfMove) | None => self.close_loop(k),
            }
        }
        // A running program whose motors have all come to rest at a program point (Q, /, S)
        // stands there. Only a stop ending can make that true (R and S put every motor of the
        // C.S. into the program), so the check runs only then.
        for cs in 1..=COORDINATE_SYSTEMS_MAX {
            if self.program(cs) == Program::Running
                && Self::members(cfg, cs).all(|k| self.state(k) == MotorState::Closed)
            {
                self.set_program(cs, Program::AtPoint);
            }
        }
        self
    }

    // ------------------------------------------------------------------ inputs and PLCs

    /// UM p.214: a motor's encoder-loss input changes (a hardware input: it changes whether or
    /// not the card runs). Motors the configuration does not have have no input.
    pub fn encoder_input(&mut self, cfg: &MotionConfig, motor: u8, lost: bool) {
        let Some(k) = usize::from(motor).checked_sub(1).filter(|k| *k < cfg.count()) else { return };
        let bit = 1u8 << k;
        self.encoder_lost = if lost { self.encoder_lost | bit } else { self.encoder_lost & !bit };
    }

    /// UM p.213: a motor's amplifier-fault input changes (a hardware input). Motors the
    /// configuration does not have have no input.
    pub fn amplifier_fault_input(&mut self, cfg: &MotionConfig, motor: u8, fault: bool) {
        let Some(k) = usize::from(motor).checked_sub(1).filter(|k| *k < cfg.count()) else { return };
        let bit = 1u8 << k;
        self.amplifier_fault = if fault { self.amplifier_fault | bit } else { self.amplifier_fault & !bit };
    }

    /// The firmware's amplifier-fault check, in the housekeeping at the end of each background
    /// cycle (UM p.237). UM p.213: "The offending motor is killed", its amplifier-fault status
    /// bit set. MODEL, as the reference model: a motor whose coordinate system executes a
    /// program takes that program (lookahead lost, UM p.319) and the C.S.'s other motors with
    /// it; the offending motors are those enabled with a fault at the start of the check.
    pub fn amplifier_fault_check(&mut self, cfg: &MotionConfig) {
        let offending = self.amplifiers & self.amplifier_fault;
        if offending == 0 {
            return;
        }
        self.fault_status |= offending;
        for k in motors_in(offending) {
            self.kill(k);
            let cs = cfg.cs_of(k);
            if self.program(cs).executing() {
                self.set_program(cs, Program::Lost);
                for j in motors_in(cfg.members(cs)) {
                    self.kill(j);
                }
            }
        }
    }

    /// UM p.319: <CTRL-K> "disables all motors ... by opening the servo loops, forcing
    /// zero-value command outputs, and disabling the amplifiers", and the lookahead is
    /// discarded; only K is restricted during a program.
    #[inline(never)]
    fn kill_all(&mut self, cfg: &MotionConfig) {
        for k in 0..cfg.count() {
            self.kill(k);
        }
        for cs in 1..=COORDINATE_SYSTEMS_MAX {
            if self.program(cs).executing() {
                self.set_program(cs, Program::Lost);
            }
        }
    }

    /// The encoder-loss PLC of UM p.214-215, one scan per background cycle (UM p.215: safety
    /// PLCs are "best implemented in a compiled background PLC program, which scans ... once
    /// per background cycle"), over all motors at once as bit masks: one copy of the listing
    /// per motor ("easy to duplicate for multiple axes").
    ///
    /// The masks give the model's result because every copy reads the motors as they were
    /// at the start of the scan: the PLC's `CMD^K` is a command, processed in background
    /// after the scan (UM p.236; MODEL, as the reference model).
    pub fn encoder_loss_plc(&mut self, cfg: &MotionConfig, intended_clear: bool) {
        let closed = self.amplifiers;
        // UM p.215, "Logic to clear fault status": IF (Mtr1OpenLoop=0 AND Enc1LossIn=OK AND
        // Mtr1EncLossStatus=0) Mtr1EncLossStatus=0. Read literally the branch needs the status
        // already 0, so a latched loss is never cleared; read as intended, it clears it.
        if intended_clear {
            self.loss_status &= !(closed & !self.encoder_lost);
        }
        // UM p.214-215, "Logic to disable and set fault status": IF (Mtr1OpenLoop=0 AND
        // Enc1LossIn=Lost) CMD^K ("Kill all motors") and Mtr1EncLossStatus=1. Every motor is
        // killed, not only the one whose encoder was lost (UM p.213's "the offending motor is
        // killed" is the firmware's own fault rule, a different mechanism).
        let hit = closed & self.encoder_lost;
        if hit != 0 {
            self.loss_status |= hit;
            self.kill_all(cfg);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// [`Motion::consistent`] is what the tests and the proof harnesses check the redundant
    /// bits with: `stopping` bit k exactly when motor k carries a stop, `amplifiers` bit k
    /// exactly when it is not killed (UM p.319: only a kill disables the amplifier), every motor
    /// byte as [`pack`] writes it. It must say false when any of them is out of step, for motor
    /// #1 and for a later one (bit 3), and true for consistent states.
    #[test]
    fn consistent_notices_each_redundant_bit_out_of_step() {
        let closed = pack(MotorState::Closed, None);
        let stopping = pack(MotorState::Decelerating, Some(Stop::Jog));
        let killed = pack(MotorState::Killed, None);
        for k in [0usize, 3] {
            let bit = 1u8 << k;
            let with = |byte: u8, stopping: u8, amplifiers: u8| {
                let mut motors = [0u8; MOTORS_MAX];
                motors[k] = byte;
                Motion { motors, stopping, amplifiers, ..Motion::power_on() }
            };
            assert!(with(closed, 0, bit).consistent(), "#{}: closed loop at rest", k + 1);
            assert!(with(stopping, bit, bit).consistent(), "#{}: a stop under way", k + 1);
            assert!(!with(closed, bit, bit).consistent(), "#{}: a stopping bit without a stop", k + 1);
            assert!(!with(stopping, 0, bit).consistent(), "#{}: a stop without its bit", k + 1);
            assert!(!with(killed, 0, bit).consistent(), "#{}: a killed motor's amplifier on", k + 1);
            assert!(!with(closed, 0, 0).consistent(), "#{}: a closed loop's amplifier off", k + 1);
            assert!(!with(7, 0, 0).consistent(), "#{}: a byte pack never writes (code 7)", k + 1);
        }
        assert!(Motion::power_on().consistent());
    }
}
