//! What a host or an instrument can observe of a controller.

use super::event::Reply;

/// Everything observable after an event.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct Observation {
    pub reply: Reply,
    /// The red watchdog LED (UM p.215).
    pub led_red: bool,
    /// FEFCO/ open-collector output on (Turbo PMAC, UM p.215).
    pub fefco_on: bool,
    /// The watchdog relay has changed over (Turbo PMAC2, UM p.215).
    pub relay_tripped: bool,
    /// Discrete outputs forced off, DAC/PWM/PFM at zero (UM p.215).
    pub outputs_forced_off: bool,
    /// Y:$000025, X:$000025 and the status words as the card holds them. A host cannot read
    /// them from a tripped card; an instrument (or the model) can.
    pub counter: i32,
    pub counter_min: i32,
    pub status_x: u32,
    pub status_y: u32,
    /// The motors: motion state, amplifier enable, commanded output, encoder-loss input and
    /// the encoder-loss PLC's latched status. `None` from an implementation that does not
    /// model motors; lockstep reports that as a difference from the model, which always does.
    pub motion: Option<MotionView>,
}

/// The most motors an observation shows: as many as a configuration may have.
pub const MOTORS_SHOWN: usize = crate::check::MOTORS_MAX;

/// The motors as an instrument sees them.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct MotionView {
    /// How many of `motors` exist.
    pub count: u8,
    pub motors: [MotorView; MOTORS_SHOWN],
}

impl MotionView {
    pub fn motors(&self) -> &[MotorView] {
        &self.motors[..usize::from(self.count)]
    }
}

/// One motor as an instrument sees it.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub struct MotorView {
    pub state: MotorState,
    /// The amplifier-enable output (SRM p.281, motor status bit 19).
    pub amplifier_enabled: bool,
    /// The commanded output (DAC/PWM/PFM) is held at zero.
    pub output_zero: bool,
    /// The encoder-loss input reports loss (UM p.214).
    pub encoder_lost: bool,
    /// The encoder-loss PLC's latched status, `Mtr1EncLossStatus` of UM p.215.
    pub encoder_loss_status: bool,
    /// The amplifier-fault input reports a fault (UM p.213).
    pub amplifier_fault: bool,
    /// The amplifier-fault motor status bit: set when the firmware killed the motor for the
    /// fault, cleared when the motor is re-enabled (UM p.213).
    pub amplifier_fault_status: bool,
}

/// A motor's motion, as abstract as the stop rules allow.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum MotorState {
    /// Open loop, amplifier disabled, output zero (UM p.319: "opening the servo loops, forcing
    /// zero-value command outputs, and disabling the amplifiers").
    #[default]
    Killed,
    /// Closed loop, at rest.
    Closed,
    /// Jogging.
    Jogging,
    /// Running a motion program in its coordinate system.
    Program,
    /// Decelerating toward rest after a stop command.
    Decelerating,
    /// At rest in a feed hold, on the program's path, resumable with R.
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

    /// The name a trace's `motors:` expectation uses.
    pub fn name(self) -> &'static str {
        match self {
            MotorState::Killed => "killed",
            MotorState::Closed => "closed",
            MotorState::Jogging => "jogging",
            MotorState::Program => "program",
            MotorState::Decelerating => "decelerating",
            MotorState::Holding => "holding",
        }
    }

    /// Whether the motor is commanded to move.
    pub fn moving(self) -> bool {
        matches!(self, MotorState::Jogging | MotorState::Program | MotorState::Decelerating)
    }
}
