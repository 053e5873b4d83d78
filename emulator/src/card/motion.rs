//! The card's motors as they move: each motor's trajectory (`trajectory.rs`) driven by the jog
//! and homing commands and the motor I-variables, advanced by the servo clock, and held within
//! the core's abstract motor state (`pmacwd_core::motion`), which stays the model-checked one:
//!
//! - a trajectory moves only while the core says its motor jogs (a jog the core refuses, to a
//!   killed motor or in a running program, moves nothing);
//! - a stop the core carries out (J/, A, <CTRL-A>) lasts the servo cycles the core gives it, and
//!   the card chooses those cycles so that the motor decelerates at the manual's rate (Ixx19-21
//!   for J/, SRM p.100-101; Ixx15 for an abort, UM p.319), up to the core's longest stop of 255
//!   cycles (its one-byte counter: MODEL, a longer stop decelerates faster so that it still
//!   ends where the core says motion stops);
//! - a kill, a trip, a reset or a deactivated motor (Ixx00 = 0) stops the trajectory at once.
//!
//! A jog that comes to rest (at its target, at a limit, or refused by one) ends in the core as
//! the stop that ends a jog, `J/`, with nothing left to decelerate: the model's jogs end only
//! by a stop command, and a card's motor is then closed-loop at rest, from which a program may
//! start (`Card::conclude_jogs`). The status words report it from the trajectory.

use super::Card;
use crate::capture_queue::Record;
use crate::framing::Answer;
use crate::trajectory::{Axis, Goal, Homing, Limits};
use pmacwd_core as core;
use pmacwd_core::motion::{MotorState, MOTORS_MAX};
use pmacwd_specs::grammar::Command;
use pmacwd_specs::grammar::Jog;
use pmacwd_specs::vocab::command::{CsCommand, GlobalCommand, HostCommand, Motion, MotorCommand};

/// A commanded position is kept within this many counts of zero (MODEL: the card's motor
/// position range is +/-2^35 counts at the default scale, SRM p.95 for Ixx13; the bound keeps
/// every computation finite whatever a host sends).
pub const POSITION_MAX: f64 = 34_359_738_368.0;
/// Jog and home speeds are taken at most this many counts/ms (MODEL: ten million counts per
/// millisecond is beyond any encoder; the bound keeps trajectories finite).
pub const SPEED_MAX: f64 = 1.0e7;
/// Accelerations are taken within these counts/ms² (MODEL: the same purpose).
pub const ACCEL_MIN: f64 = 1.0e-9;
pub const ACCEL_MAX: f64 = 1.0e9;
/// The core's longest stop, servo cycles (its stop counter is one byte).
const STOP_CYCLES_MAX: f64 = 255.0;

/// The trajectories of the card's motors and what the control port has placed on the machine.
#[derive(Clone, Copy, Debug, Default)]
pub struct Motors {
    pub axes: [Axis; MOTORS_MAX],
    /// Where each motor's home flag triggers, counts from where the motor stood at power-up
    /// (the control port's `home-flag`); none: a homing search runs on until stopped.
    pub home_flags: [Option<f64>; MOTORS_MAX],
    /// Each motor's limit switches (the control port's `limit`): `[plus, minus]`, true when
    /// the switch at that end of travel is hit.
    pub limit_inputs: [[bool; 2]; MOTORS_MAX],
}

impl Motors {
    /// After a reset: every motor reads position 0 where it stands and has not been homed (UM
    /// p.243, PMAC-SRM p.82 "sets motor position to 0 on power-up/reset" with Ixx10 = 0); the
    /// home flags stay where they are on the machine, so they move by the same amount in counts.
    pub fn reset(&mut self) {
        for (axis, flag) in self.axes.iter_mut().zip(self.home_flags.iter_mut()) {
            if let Some(f) = flag {
                *f -= axis.pos;
            }
            let fe = axis.following_error;
            *axis = Axis { following_error: fe, ..Axis::default() };
        }
    }

    fn any_moving(&self) -> bool {
        self.axes.iter().any(|a| !a.at_rest())
    }
}

fn sane_speed(v: f64) -> f64 {
    if v.is_finite() {
        v.abs().min(SPEED_MAX)
    } else {
        0.0
    }
}

pub(super) fn sane_accel(a: f64) -> f64 {
    if a.is_finite() && a > 0.0 {
        a.clamp(ACCEL_MIN, ACCEL_MAX)
    } else {
        ACCEL_MAX
    }
}

pub(super) fn sane_position(p: f64) -> f64 {
    if p.is_finite() {
        p.clamp(-POSITION_MAX, POSITION_MAX)
    } else {
        0.0
    }
}

impl Card {
    /// I-variable `n` as a number, its fraction included (`I122=0.5`).
    pub(super) fn i_value(&self, n: u16) -> f64 {
        match self.store.fraction(n) {
            Some(v) => v,
            None => self.core.read_i(n, &self.store).unwrap_or(0) as f64,
        }
    }

    /// Motor `motor`'s I-variable `xx` (`Ixx22` of motor 1 is I122).
    fn motor_i(&self, motor: u8, xx: u16) -> f64 {
        self.i_value(u16::from(motor) * 100 + xx)
    }

    /// The servo period in ms: I10 in 1/8,388,608 ms (SRM p.42-43), which the card's
    /// trajectories are computed with; 0 or less reads as the default's (MODEL: a card with
    /// I10 = 0 computes nothing sensible; the emulator keeps moving at the default period).
    pub(super) fn servo_period_ms(&self) -> f64 {
        let i10 = self.i_value(10);
        if i10.is_finite() && i10 > 0.0 {
            i10 / 8_388_608.0
        } else {
            3_713_707.0 / 8_388_608.0
        }
    }

    /// Whether motor `motor` is activated (Ixx00 = 1, SRM p.282 first word bit 23).
    pub(super) fn activated(&self, motor: u8) -> bool {
        self.motor_i(motor, 0) != 0.0
    }

    /// The jog acceleration for a change of speed of `dv` counts/ms (SRM p.100-101): over the
    /// acceleration time, Ixx20, or 2 x Ixx21 when Ixx21 is more than half of Ixx20, and no
    /// faster than Ixx19. MODEL: at a constant rate over that time (the S-curve only sets how
    /// long the change takes).
    fn jog_accel(&self, motor: u8, dv: f64) -> f64 {
        let (max, ta, ts) = (self.motor_i(motor, 19), self.motor_i(motor, 20), self.motor_i(motor, 21));
        let time = if ts > ta / 2.0 { 2.0 * ts } else { ta };
        let by_time = if time > 0.0 { dv.abs() / time } else { f64::INFINITY };
        let rate = if max > 0.0 { by_time.min(max) } else { by_time };
        sane_accel(rate)
    }

    fn axis(&self, motor: u8) -> Option<&Axis> {
        usize::from(motor).checked_sub(1).and_then(|k| self.motors.axes.get(k))
    }

    fn axis_mut(&mut self, motor: u8) -> Option<&mut Axis> {
        usize::from(motor).checked_sub(1).and_then(|k| self.motors.axes.get_mut(k))
    }

    fn core_state(&self, motor: u8) -> Option<core::MotorStatus> {
        self.core.motor(&self.cfg, motor)
    }

    /// The software limits of motor `motor` in counts from power-up (Ixx13, Ixx14 from the
    /// origin, SRM p.96: "referenced to the most recent power-up zero position or homing-move
    /// zero position"; 0 is none) and the limit deceleration (Ixx15).
    fn limits(&self, motor: u8) -> Limits {
        let origin = self.axis(motor).map_or(0.0, |a| a.origin);
        let at = |v: f64| (v != 0.0 && v.is_finite()).then(|| sane_position(v + origin));
        Limits {
            plus: at(self.motor_i(motor, 13)),
            minus: at(self.motor_i(motor, 14)),
            decel: sane_accel(self.motor_i(motor, 15)),
        }
    }

    /// Whether motor `motor`'s limit switch at the end `direction` points to (> 0 plus) is hit
    /// and used: Ixx24 bit 17 set makes the motor ignore its limit inputs (PMAC-SRM p.80).
    fn hardware_limit(&self, motor: u8, direction: f64) -> bool {
        let Some(k) = usize::from(motor).checked_sub(1).filter(|k| *k < MOTORS_MAX) else { return false };
        let [plus, minus] = self.motors.limit_inputs[k];
        let used = (self.motor_i(motor, 24) as i64) & 0x20000 == 0;
        used && ((direction > 0.0 && plus) || (direction < 0.0 && minus))
    }

    /// Whether a limit forbids motion in `direction` (SRM p.96: "allows no further positive
    /// position increments ... as long as the limit is exceeded").
    fn limit_forbids(&self, motor: u8, direction: f64) -> bool {
        let pos = self.axis(motor).map_or(0.0, |a| a.pos);
        let l = self.limits(motor);
        self.hardware_limit(motor, direction)
            || (direction > 0.0 && l.plus.is_some_and(|p| pos >= p))
            || (direction < 0.0 && l.minus.is_some_and(|m| pos <= m))
    }

    /// `J+`, `J-`, `J=`, `J={v}`, `J^{v}`, `J:{v}` after the core has heard it: the trajectory
    /// starts if the core's motor now jogs (SRM p.101: at Ixx22, accelerating by Ixx19-21),
    /// unless a limit forbids its direction.
    pub(super) fn start_jog(&mut self, motor: u8, jog: Jog) {
        if !self.may_move(motor) {
            return;
        }
        let speed = sane_speed(self.motor_i(motor, 22));
        let accel = self.jog_accel(motor, speed);
        let Some(axis) = self.axis_mut(motor) else { return };
        let here = axis.pos;
        let origin = axis.origin;
        // Targets are in the position a host reads (from the origin); the trajectory's are from
        // power-up. MODEL: the actual position is the commanded one, so J^ and J: agree.
        let target = match jog {
            Jog::Plus | Jog::Minus | Jog::Stop => None,
            Jog::To(None) => Some(axis.pre_jog),
            Jog::To(Some(p)) => Some(sane_position(p) + origin),
            Jog::ByFromActual(d) | Jog::ByFromCommanded(d) => Some(sane_position(here + sane_position(d))),
        };
        let direction = match (jog, target) {
            (Jog::Minus, _) => -1.0,
            (_, Some(t)) => t - here,
            _ => 1.0,
        };
        if self.limit_forbids(motor, direction) {
            if let Some(axis) = self.axis_mut(motor) {
                axis.limit_stop = true;
            }
            return;
        }
        let Some(axis) = self.axis_mut(motor) else { return };
        axis.jog(target.map(sane_position), direction, speed, accel);
    }

    /// `HM`: a homing search at Ixx23 (its sign the direction), accelerating as a jog does
    /// (SRM p.101); the home flag is the control port's.
    pub(super) fn start_home(&mut self, motor: u8) {
        if !self.may_move(motor) {
            return;
        }
        let v = self.motor_i(motor, 23);
        let v = if v.is_finite() { v.clamp(-SPEED_MAX, SPEED_MAX) } else { 0.0 };
        let accel = self.jog_accel(motor, v);
        if self.hardware_limit(motor, v) {
            return;
        }
        let Some(axis) = self.axis_mut(motor) else { return };
        if v == 0.0 {
            // MODEL: a home speed of 0 cannot search; the motor is homed where it stands.
            axis.halt();
            axis.home_here();
        } else {
            axis.home(v, accel);
        }
    }

    /// `HMZ`: the present position becomes the home position, 0, without moving (SRM on-line
    /// command HMZ; MODEL: for an activated motor the core has closed-loop or jogging).
    pub(super) fn home_zero(&mut self, motor: u8) {
        if !self.activated(motor) {
            return;
        }
        if let Some(axis) = self.axis_mut(motor) {
            axis.home_here();
        }
    }

    /// Whether the core lets motor `motor` move now: it jogs (the core accepted the jog) and is
    /// activated.
    fn may_move(&self, motor: u8) -> bool {
        self.activated(motor) && self.core_state(motor).is_some_and(|m| m.state == MotorState::Jogging)
    }

    /// The servo cycles the stop a motion command starts should take (`None`: the core's own
    /// length, nothing is moving): the longest any motor it stops needs to come to rest at its
    /// rate, 1..=255.
    pub(super) fn stop_cycles(&self, m: &Motion) -> Option<u8> {
        let dt = self.servo_period_ms();
        let cycles = |ms: f64| Some((ms / dt).ceil().clamp(1.0, STOP_CYCLES_MAX) as u8);
        // A program's stops (`card/program.rs`): S runs one move, which the core ends after
        // the cycles it is given: the most the core's counter holds (MODEL: the move is not
        // known before the program executes; a longer move is cut there). Q and / finish the
        // move under way; H, \ and <CTRL-O> stop on the path in the program's acceleration
        // time (MODEL: Isx95 is not modelled).
        match *m {
            Motion::CoordinateSystem(_, CsCommand::Step) => return Some(STOP_CYCLES_MAX as u8),
            Motion::CoordinateSystem(cs, CsCommand::Quit | CsCommand::EndOfMove) => {
                return self.program_move_left(cs).and_then(cycles)
            }
            Motion::Global(GlobalCommand::QuitAll) => {
                return (1..=16).filter_map(|cs| self.program_move_left(cs)).reduce(f64::max).and_then(cycles)
            }
            Motion::CoordinateSystem(cs, CsCommand::Hold | CsCommand::QuickStop | CsCommand::Feedrate(0)) => {
                return self.program_move_left(cs).and_then(|_| cycles(self.program_accel_time(cs)))
            }
            Motion::Global(GlobalCommand::HoldAll) => {
                return (1..=16)
                    .filter(|cs| self.program_move_left(*cs).is_some())
                    .map(|cs| self.program_accel_time(cs))
                    .reduce(f64::max)
                    .and_then(cycles)
            }
            _ => {}
        }
        if !self.motors.any_moving() {
            return None;
        }
        let motors = self.cfg.motion.motors.min(MOTORS_MAX as u8);
        let in_cs =
            |cs: u8| (1..=motors).filter(move |n| self.core_state(*n).is_some_and(|m| m.coordinate_system == cs));
        let (stopped, abort): (Vec<u8>, bool) = match *m {
            Motion::Motor(n, MotorCommand::JogStop) => (vec![n], false),
            Motion::CoordinateSystem(cs, CsCommand::Abort) => (in_cs(cs).collect(), true),
            Motion::Global(GlobalCommand::AbortAll) => ((1..=motors).collect(), true),
            _ => return None,
        };
        let mut longest: f64 = 1.0;
        for n in stopped {
            let Some(axis) = self.axis(n) else { continue };
            // UM p.319: an abort decelerates at Ixx15; J/ at the jog rate (UM p.217 row 1).
            let rate = if abort { sane_accel(self.motor_i(n, 15)) } else { self.jog_accel(n, axis.vel) };
            longest = longest.max((axis.stop_time(rate) / dt).ceil());
        }
        Some(longest.min(STOP_CYCLES_MAX) as u8)
    }

    /// Keeps every trajectory within its core motor's state (see the module's doc).
    pub(super) fn sync_motion(&mut self) {
        self.sync_programs();
        let dt = self.servo_period_ms();
        for n in 1..=(MOTORS_MAX as u8) {
            let in_program = self.in_program_move(n);
            let core = self.core_state(n);
            let program_left =
                core.filter(|_| in_program).and_then(|m| self.program_move_left(m.coordinate_system)).unwrap_or(0.0);
            let active = self.activated(n);
            let Some(axis) = self.axis_mut(n) else { continue };
            match core {
                Some(m) if active => match m.state {
                    MotorState::Jogging => {
                        let direction = match axis.goal {
                            Goal::Velocity { v } => v,
                            Goal::Position { target, .. } => target - axis.pos,
                            Goal::Hold | Goal::Stop { .. } => 0.0,
                        };
                        if direction != 0.0 && self.hardware_limit(n, direction) {
                            let rate = sane_accel(self.motor_i(n, 15));
                            if let Some(axis) = self.axis_mut(n) {
                                axis.limit(rate);
                            }
                        }
                    }
                    MotorState::Decelerating => {
                        // At rest exactly when the core's stop ends: a new stop (J/ becoming
                        // an abort, say) starts the deceleration over for the cycles it has.
                        let ms = f64::from(m.stop.map_or(1, |(_, cycles)| cycles)) * dt;
                        let needs = match axis.goal {
                            Goal::Hold => None,
                            Goal::Stop { rate } => Some(axis.stop_time(rate)),
                            Goal::Velocity { .. } | Goal::Position { .. } => Some(f64::INFINITY),
                        };
                        if needs.is_some_and(|t| (t - ms).abs() > dt / 2.0) {
                            axis.stop_within(ms);
                        }
                    }
                    // A program's move goes on while the core runs the motor's program; a Q or /
                    // the core carries out leaves it the cycles the core gives (a move that needs
                    // longer decelerates to rest within them, MODEL as for the stops above).
                    MotorState::Program if in_program => {
                        if let Some((_, cycles)) = m.stop {
                            let ms = f64::from(cycles.max(1)) * dt;
                            let needs = match axis.goal {
                                Goal::Position { .. } => program_left,
                                Goal::Stop { rate } => axis.stop_time(rate),
                                Goal::Hold | Goal::Velocity { .. } => 0.0,
                            };
                            if needs > ms + dt / 2.0 && !matches!(axis.goal, Goal::Stop { .. }) {
                                if axis.vel == 0.0 {
                                    // Under S, a move from rest longer than the core's longest
                                    // stop (255 cycles) goes faster, to arrive when the core's
                                    // step ends (MODEL).
                                    axis.fit_move(ms);
                                } else {
                                    axis.stop_within(ms);
                                }
                            }
                        }
                    }
                    MotorState::Killed | MotorState::Closed | MotorState::Holding | MotorState::Program => {
                        if !axis.at_rest() || axis.homing != Homing::None {
                            axis.halt();
                        }
                    }
                },
                _ => {
                    if !axis.at_rest() {
                        axis.halt();
                    }
                }
            }
        }
    }

    /// The times (ms) at which the jogs to a position under way arrive.
    pub(super) fn jog_arrivals(&self) -> impl Iterator<Item = f64> + '_ {
        (1..=(MOTORS_MAX as u8)).filter_map(move |n| {
            let jogging = self.core_state(n).is_some_and(|m| m.state == MotorState::Jogging);
            self.axis(n).filter(|_| jogging).and_then(Axis::time_to_arrive)
        })
    }

    /// A jog the core still has under way whose trajectory has come to rest (at its target, at
    /// a limit, or refused by one) has ended: the core hears the stop that ends a jog, `J/`
    /// (UM p.217 row 1), with nothing left to decelerate (one servo cycle), and a capture
    /// records it as the exchange `#nJ/`. MODEL: the model's jogs end only by a stop command;
    /// a card's jog to a position ends at its target with the motor closed-loop at rest, from
    /// which a program may start (UM p.319).
    pub(super) fn conclude_jogs(&mut self) {
        for n in 1..=self.cfg.motion.motors.min(MOTORS_MAX as u8) {
            let jogging = self.core_state(n).is_some_and(|m| m.state == MotorState::Jogging);
            let still = self.axis(n).is_some_and(|a| a.at_rest() && a.homing == Homing::None);
            if !(jogging && still) {
                continue;
            }
            let motion = Motion::Motor(n, MotorCommand::JogStop);
            let usual = self.cfg.motion.decel_cycles;
            self.cfg.motion.decel_cycles = 1;
            self.core.command(&self.cfg, pmacwd_bridge::core_command(&HostCommand::Motion(motion)), &mut self.store);
            self.cfg.motion.decel_cycles = usual;
            self.capture_record(|| Record::Commands {
                commands: vec![(format!("#{n}J/"), Ok(Command::Motion(motion)))],
                reply: Some(Vec::new()),
            });
        }
    }

    /// Moves every trajectory on by `cycles` servo cycles.
    pub(super) fn advance_motion(&mut self, cycles: u64) {
        let ms = cycles as f64 * self.servo_period_ms();
        if self.programs_executing() {
            // Programs execute their next statements as each move or dwell ends
            // (`card/program.rs`).
            self.advance_programs(ms, &mut |card, t| card.advance_axes(t));
        } else {
            self.advance_axes(ms);
        }
    }

    /// Moves every trajectory on by `ms`.
    fn advance_axes(&mut self, ms: f64) {
        if !self.motors.any_moving() {
            return;
        }
        for n in 1..=(MOTORS_MAX as u8) {
            let offset = self.motor_i(n, 26) / 16.0;
            let k = usize::from(n - 1);
            let flag = self.motors.home_flags[k];
            let limits = self.limits(n);
            let axis = &mut self.motors.axes[k];
            axis.advance(ms, flag, if offset.is_finite() { offset } else { 0.0 }, &limits);
            // MODEL: a motor stops at the end of its position range (+/-2^35 counts), however it
            // got there (a jog without end, a homing search that never finds its flag).
            if axis.pos.abs() > POSITION_MAX {
                axis.pos = axis.pos.clamp(-POSITION_MAX, POSITION_MAX);
                axis.halt();
                axis.limit_stop = true;
            }
        }
    }

    /// `P`: the position, counts from the origin, to 1/32 count (MODEL: as <CTRL-P> rounds it,
    /// SRM p.260).
    pub(super) fn position_answer(&self, motor: u8) -> Answer {
        let p = self.axis(motor).map_or(0.0, |a| a.reported_position() + a.following_error);
        Answer::Data(crate::memory::format_value((p * 32.0).round() / 32.0))
    }

    /// `V`: the velocity in counts per servo cycle, to a tenth (SRM p.402; PMAC-SRM p.175).
    pub(super) fn velocity_answer(&self, motor: u8) -> Answer {
        let v = self.axis(motor).map_or(0.0, |a| a.vel) * self.servo_period_ms();
        let tenths = (v * 10.0).round() / 10.0;
        Answer::Data(crate::memory::format_value(if tenths == 0.0 { 0.0 } else { tenths }))
    }

    /// `F`: the following error in counts (0 unless the control port injected one).
    pub(super) fn following_error_answer(&self, motor: u8) -> Answer {
        let f = self.axis(motor).map_or(0.0, |a| a.following_error);
        Answer::Data(crate::memory::format_value((f * 32.0).round() / 32.0))
    }

    /// The control port's `home-flag M AT|none`.
    pub(super) fn place_home_flag(&mut self, motor: u8, at: Option<i64>) -> String {
        let Some(k) = usize::from(motor).checked_sub(1).filter(|k| *k < MOTORS_MAX) else {
            return format!("error: motor {motor}: the card's motors are 1..{MOTORS_MAX}");
        };
        let origin = self.motors.axes[k].origin;
        self.motors.home_flags[k] = at.map(|p| sane_position(p as f64 + origin));
        "ok".into()
    }

    /// The control port's `limit M plus|minus on|off`.
    pub(super) fn set_limit_input(&mut self, motor: u8, plus: bool, on: bool) -> String {
        let Some(k) = usize::from(motor).checked_sub(1).filter(|k| *k < MOTORS_MAX) else {
            return format!("error: motor {motor}: the card's motors are 1..{MOTORS_MAX}");
        };
        self.motors.limit_inputs[k][usize::from(!plus)] = on;
        self.sync_motion();
        "ok".into()
    }

    /// The control port's `following-error M COUNTS`.
    pub(super) fn inject_following_error(&mut self, motor: u8, counts: i64) -> String {
        let Some(k) = usize::from(motor).checked_sub(1).filter(|k| *k < MOTORS_MAX) else {
            return format!("error: motor {motor}: the card's motors are 1..{MOTORS_MAX}");
        };
        self.motors.axes[k].following_error = sane_position(counts as f64);
        "ok".into()
    }

    /// What the status words need of motor `motor` beyond the core's state.
    pub(super) fn motion_bits(&self, motor: u8) -> crate::motor_status::MotionBits {
        let axis = self.axis(motor).copied().unwrap_or_default();
        // Ixx28 in 1/16 count (SRM p.284: following error below the in-position band).
        let band = self.motor_i(motor, 28) / 16.0;
        let l = self.limits(motor);
        crate::motor_status::MotionBits {
            plus_limit: self.hardware_limit(motor, 1.0) || l.plus.is_some_and(|p| axis.pos > p),
            minus_limit: self.hardware_limit(motor, -1.0) || l.minus.is_some_and(|m| axis.pos < m),
            limit_stop: axis.limit_stop,
            activated: self.activated(motor),
            integration_mode: self.motor_i(motor, 34) == 1.0,
            at_rest: axis.at_rest(),
            move_timer: axis.move_timer,
            homing: axis.homing != Homing::None,
            home_complete: axis.home_complete,
            within_band: axis.following_error.abs() < band,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::super::{Card, Clock};
    use crate::control::Control;

    /// The default card with a background cycle in every servo cycle (PLC 0 leaves 62 units a
    /// cycle, UM p.236), so that a line sent right after a step is answered in that instant
    /// (`card/line.rs`) and these tests count the motion's cycles exactly.
    fn card() -> Card {
        let mut c = Card::default_card(Clock::Virtual);
        assert!(c
            .control(Control::Load { motors: None, plc0_units: None, background_units: Some(60) })
            .starts_with("ok"));
        c
    }

    fn values(c: &mut Card, line: &str) -> Vec<String> {
        let reply = c.line(line.as_bytes()).expect("the card answers");
        let text = String::from_utf8_lossy(&reply).into_owned();
        assert!(text.ends_with('\x06') && !text.contains('\x07'), "{line}: {text:?}");
        text.trim_end_matches('\x06').split('\r').filter(|v| !v.is_empty()).map(str::to_string).collect()
    }

    fn step(c: &mut Card, cycles: u32) {
        assert!(c.control(Control::Step { cycles }).starts_with("ok"));
    }

    /// The two status words of `#n?`.
    fn status(c: &mut Card, motor: u8) -> (u32, u32) {
        let w = &values(c, &format!("#{motor}?"))[0];
        (u32::from_str_radix(&w[..6], 16).unwrap(), u32::from_str_radix(&w[6..], 16).unwrap())
    }

    /// The EPICS driver's "done" (pmacHardwareTurbo::parseAxisStatus): in position, or not
    /// activated, or the amplifier off.
    fn done(c: &mut Card, motor: u8) -> bool {
        let (x, y) = status(c, motor);
        y & 1 != 0 || x & (1 << 23) == 0 || x & (1 << 19) == 0
    }

    fn position(c: &mut Card, motor: u8) -> f64 {
        values(c, &format!("#{motor}P"))[0].parse().unwrap()
    }

    /// Servo cycles of the default I10 (SRM p.42-43) in `ms` milliseconds.
    fn cycles(ms: f64) -> u32 {
        (ms * 8_388_608.0 / 3_713_707.0).ceil() as u32
    }

    #[test]
    fn the_epics_drivers_move_arrives_at_its_target_and_reports_done_in_position() {
        let mut c = card();
        // pmacAxis::setClosedLoop(true), then pmacAxis::move: 0.5 counts/ms, 100 ms.
        values(&mut c, "#1 J/");
        assert!(done(&mut c, 1), "closed loop at rest: in position");
        values(&mut c, "I122=0.500000 I120=100.000000 #1 J=2000.00");
        assert!(!done(&mut c, 1), "the move has begun");
        // 2,000 counts at 0.5 counts/ms with 100 ms of acceleration each end: 4,100 ms.
        step(&mut c, cycles(2000.0));
        let halfway = position(&mut c, 1);
        assert!((900.0..1100.0).contains(&halfway), "{halfway}");
        assert_eq!(values(&mut c, "#1V")[0], "0.2", "0.5 counts/ms is 0.2 counts per servo cycle (SRM p.402)");
        assert!(!done(&mut c, 1));
        step(&mut c, cycles(2050.0));
        assert!(!done(&mut c, 1), "50 ms before the end it still moves");
        step(&mut c, cycles(60.0));
        assert!(done(&mut c, 1));
        assert_eq!(position(&mut c, 1), 2000.0);
        assert_eq!(values(&mut c, "#1F #1V"), ["0", "0"]);
        let (x, y) = status(&mut c, 1);
        assert_eq!(x & (1 << 13), 1 << 13, "desired velocity zero");
        assert_eq!(x & (1 << 17), 0, "no move timer");
        assert_eq!(y & 1, 1, "in position");
        // And back by a distance (J^), at the new speed.
        values(&mut c, "I122=4 #1J^-1000");
        step(&mut c, cycles(1000.0));
        assert!(done(&mut c, 1));
        assert_eq!(position(&mut c, 1), 1000.0);
    }

    #[test]
    fn a_jog_to_a_killed_motor_moves_nothing_and_the_driver_sees_it_done_with_its_amplifier_off() {
        // UM p.319: a killed motor has its loop open; the core refuses the jog (MODEL).
        let mut c = card();
        values(&mut c, "#1J=2000");
        step(&mut c, cycles(5000.0));
        assert_eq!(position(&mut c, 1), 0.0);
        let (x, _) = status(&mut c, 1);
        assert_eq!(x & ((1 << 18) | (1 << 19)), 1 << 18, "open loop, amplifier off");
    }

    #[test]
    fn j_slash_decelerates_at_the_jog_rate_and_ends_where_the_core_ends_the_stop() {
        let mut c = card();
        values(&mut c, "#2J/ I220=1 I221=0 I219=0.5 I222=20 #2J+");
        step(&mut c, cycles(200.0));
        assert_eq!(values(&mut c, "#2V")[0], format!("{:.1}", 20.0 * 3_713_707.0 / 8_388_608.0));
        let before = position(&mut c, 2);
        values(&mut c, "#2J/");
        // 20 counts/ms at 0.5 counts/ms²: 40 ms, 100 counts more (v²/2a = 400).
        let (x, _) = status(&mut c, 2);
        assert_eq!(x & (1 << 13), 0, "still moving");
        step(&mut c, cycles(40.0));
        let (x, y) = status(&mut c, 2);
        assert_eq!((x & (1 << 13), y & 1), (1 << 13, 1), "at rest, in position");
        let travelled = position(&mut c, 2) - before;
        // The stop lasts whole servo cycles (91 for 40 ms), a little longer than 40 ms.
        assert!((travelled - 400.0).abs() < 4.0, "{travelled}");
        let core = c.core.motor(&c.cfg, 2).unwrap();
        assert_eq!(core.state, pmacwd_core::motion::MotorState::Closed, "the core's stop is over too");
    }

    #[test]
    fn a_kill_stops_the_motor_at_once_and_an_abort_decelerates_at_ixx15() {
        let mut c = card();
        values(&mut c, "#3J/ #3J+ #4J/ #4J-");
        step(&mut c, cycles(1500.0));
        values(&mut c, "#3K");
        let at = position(&mut c, 3);
        step(&mut c, 100);
        assert_eq!(position(&mut c, 3), at, "a kill opens the loop: no further motion (MODEL: no coasting)");
        assert_eq!(values(&mut c, "#3V")[0], "0");
        // &1A: motor 4 at 32 counts/ms decelerates at Ixx15 (UM p.319): with I415 = 1, 32 ms.
        values(&mut c, "I415=1 &1A");
        let (x, _) = status(&mut c, 4);
        assert_eq!(x & (1 << 12), 1 << 12, "abort deceleration bit");
        step(&mut c, cycles(28.0));
        assert_eq!(status(&mut c, 4).0 & (1 << 13), 0, "4 ms before the end it still moves");
        step(&mut c, cycles(5.0));
        assert!(done(&mut c, 4) && status(&mut c, 4).0 & (1 << 13) != 0);
        // At the default Ixx15 = 0.25 the stop would take 128 ms, 290 servo cycles: longer than
        // the core's longest stop (255 cycles, 112.9 ms), so it decelerates faster and ends
        // where the core ends it (MODEL).
        values(&mut c, "I415=* #4J/ #4J-");
        step(&mut c, cycles(1500.0));
        values(&mut c, "&1A");
        step(&mut c, 254);
        assert_eq!(status(&mut c, 4).0 & (1 << 13), 0, "one cycle before the core's end");
        step(&mut c, 1);
        assert!(done(&mut c, 4) && status(&mut c, 4).0 & (1 << 13) != 0);
        assert_eq!(c.core.motor(&c.cfg, 4).unwrap().state, pmacwd_core::motion::MotorState::Closed);
    }

    #[test]
    fn an_abort_after_j_slash_ends_the_motion_when_the_core_ends_the_abort() {
        // The EPICS driver's stop: `#1 J/ M140=1`, then `&1A Q71=Q81`. The abort restarts the
        // stop at Ixx15 (UM p.319); the trajectory follows the core's new stop length.
        let mut c = card();
        values(&mut c, "#1J/ I122=5 I120=100 #1J+");
        step(&mut c, cycles(500.0));
        values(&mut c, "#1 J/ M140=1");
        step(&mut c, 5);
        values(&mut c, "&1A Q71=Q81");
        let left = c.core.motor(&c.cfg, 1).unwrap().stop.unwrap().1;
        step(&mut c, u32::from(left) - 1);
        assert_eq!(status(&mut c, 1).0 & (1 << 13), 0, "one cycle before the abort's end it moves");
        let v: f64 = values(&mut c, "#1V")[0].parse().unwrap();
        assert!(v <= 0.1, "slowed at Ixx15 to almost nothing, not cut off at speed: {v} counts/cycle");
        step(&mut c, 1);
        assert!(done(&mut c, 1) && status(&mut c, 1).0 & (1 << 13) != 0);
        let at = position(&mut c, 1);
        step(&mut c, 1000);
        assert_eq!(position(&mut c, 1), at);
    }

    #[test]
    fn homing_searches_for_the_flag_the_control_port_placed_and_completes() {
        let mut c = card();
        assert_eq!(c.control(Control::parse("home-flag 1 500").unwrap()), "ok");
        values(&mut c, "#1J/ I126=-1600 #1HM");
        let (x, y) = status(&mut c, 1);
        assert_eq!((x & (1 << 10), y & (1 << 10)), (1 << 10, 0), "searching, not complete");
        step(&mut c, cycles(3000.0));
        let (x, y) = status(&mut c, 1);
        assert_eq!((x & (1 << 10), y & (1 << 10), y & 1), (0, 1 << 10, 1), "complete and in position");
        // PMAC-SRM p.82: the motor stops Ixx26 (-100 counts) from the trigger and calls it zero.
        assert_eq!(position(&mut c, 1), 0.0);
        // A search with no flag runs on until stopped; J/ stops it, not complete.
        assert_eq!(c.control(Control::parse("home-flag 2 none").unwrap()), "ok");
        values(&mut c, "#2J/ #2HM");
        step(&mut c, cycles(3000.0));
        assert!(!done(&mut c, 2));
        values(&mut c, "#2J/");
        step(&mut c, 300);
        let (_, y) = status(&mut c, 2);
        assert_eq!((y & 1, y & (1 << 10)), (1, 0));
        // HMZ: here is zero, and homed.
        values(&mut c, "#2HMZ");
        assert_eq!(position(&mut c, 2), 0.0);
        assert_eq!(status(&mut c, 2).1 & (1 << 10), 1 << 10);
        assert!(c.control(Control::parse("home-flag 9 0").unwrap()).starts_with("error: motor 9"));
    }

    #[test]
    fn a_software_limit_stops_a_jog_past_it_and_forbids_going_further() {
        // SRM p.96-97: past Ixx13 the motor decelerates at Ixx15 and moves no further that way.
        let mut c = card();
        values(&mut c, "#6J/ I613=1000 I615=1 I622=10 I620=1 I621=0 I619=100 #6J=5000");
        step(&mut c, cycles(1000.0));
        let (x, y) = status(&mut c, 6);
        assert!(done(&mut c, 6));
        assert_eq!((x & (1 << 21), y & (1 << 11)), (1 << 21, 1 << 11), "past the positive limit, stopped on it");
        let p = position(&mut c, 6);
        // 10 counts/ms at 1 count/ms²: 50 counts past the limit.
        assert!((p - 1050.0).abs() < 1.0, "{p}");
        values(&mut c, "#6J+");
        step(&mut c, 100);
        assert_eq!(position(&mut c, 6), p, "no further positive motion");
        values(&mut c, "#6J=0");
        step(&mut c, cycles(1000.0));
        assert_eq!(position(&mut c, 6), 0.0, "back inside");
        assert_eq!(status(&mut c, 6).0 & (1 << 21), 0);
    }

    #[test]
    fn a_limit_switch_the_control_port_sets_stops_motion_towards_it_unless_ixx24_bit_17_is_set() {
        let mut c = card();
        values(&mut c, "#7J/ #7J+");
        step(&mut c, cycles(300.0));
        assert_eq!(c.control(Control::parse("limit 7 plus on").unwrap()), "ok");
        assert_eq!(status(&mut c, 7).0 & (1 << 21), 1 << 21, "positive limit set");
        step(&mut c, cycles(200.0));
        assert!(done(&mut c, 7), "decelerated at Ixx15 and stopped");
        let p = position(&mut c, 7);
        values(&mut c, "#7J+");
        step(&mut c, 100);
        assert_eq!(position(&mut c, 7), p, "no motion into the limit");
        values(&mut c, "#7J-");
        step(&mut c, 100);
        assert!(position(&mut c, 7) < p, "away from it is allowed");
        // pmacAxis::home's `i<n>24=i<n>24|$20000`: limits off.
        values(&mut c, "#7J/");
        step(&mut c, 300);
        values(&mut c, "I724=I724|$20000 #7J+");
        assert_eq!(status(&mut c, 7).0 & (1 << 21), 0);
        let q = position(&mut c, 7);
        step(&mut c, 100);
        assert!(position(&mut c, 7) > q);
        assert!(Control::parse("limit 7 up on").unwrap_err().contains("plus or minus"));
    }

    #[test]
    fn writing_ixx00_0_deactivates_the_motor_and_stops_it() {
        let mut c = card();
        values(&mut c, "#5J/ #5J+");
        step(&mut c, 100);
        values(&mut c, "I500=0");
        let at = position(&mut c, 5);
        step(&mut c, 100);
        assert_eq!(position(&mut c, 5), at);
        assert_eq!(status(&mut c, 5).0 & (1 << 23), 0, "SRM p.282: not activated");
        values(&mut c, "I500=1 I534=0");
        assert_eq!(status(&mut c, 5).0 & ((1 << 23) | (1 << 16)), 1 << 23, "activated, Ixx34 = 0: no integration mode");
    }

    #[test]
    fn the_motor_i_variables_read_their_factory_defaults_and_star_restores_one() {
        let mut c = card();
        assert_eq!(
            values(&mut c, "I100 I122 I119 I120 I121 I115 I128 I134 I900"),
            ["1", "32", "0.15625", "0", "50", "0.25", "160", "1", "0"]
        );
        values(&mut c, "I119=2 I122=7");
        values(&mut c, "I119=*");
        assert_eq!(values(&mut c, "I119 I122"), ["0.15625", "7"]);
        c.line(b"$$$***").unwrap();
        c.line(b"I3=2 I6=1").unwrap();
        assert_eq!(values(&mut c, "I122"), ["32"]);
    }

    #[test]
    fn a_reset_reads_position_0_and_a_trip_stops_every_motor() {
        let mut c = card();
        values(&mut c, "#1J/ #1J+");
        step(&mut c, cycles(500.0));
        assert!(position(&mut c, 1) > 0.0);
        c.control(Control::Starve);
        step(&mut c, 10_000);
        assert_eq!(c.line(b"#1P"), None, "tripped: silent");
        c.control(Control::parse("init").unwrap());
        assert_eq!(values(&mut c, "#1P #1V"), ["0", "0"]);
    }

    #[test]
    fn a_million_cycles_of_jogging_cost_what_one_does() {
        let mut c = card();
        for m in 1..=8 {
            values(&mut c, &format!("#{m}J/ #{m}J+"));
        }
        let t = std::time::Instant::now();
        step(&mut c, 1_000_000);
        let p = position(&mut c, 8);
        assert!(p > 1.0e6, "{p}");
        // The core's million cycles take a few ms; the trajectories add nothing per cycle.
        assert!(t.elapsed() < std::time::Duration::from_secs(5), "{:?}", t.elapsed());
    }

    #[test]
    fn hostile_settings_and_targets_leave_every_answer_a_finite_number() {
        // Bad input gets an answer, never a panic or a non-number: extreme speeds, rates,
        // times, targets, servo periods, each followed by time passing.
        let mut c = card();
        let lines = [
            "#1J/ I122=8999999999999999 I119=0.000000001 I120=0 I121=0 #1J=8999999999999999",
            "#2J/ I222=-5 I219=-1 I220=-100 I221=-3 #2J^-8999999999999999",
            "#3J/ I322=0 #3J+",
            "#4J/ I410=1 I10=1 #4J-",
            "I10=8999999999999999 #5J/ #5J+ #5HM",
            "I10=-7 #6J/ I623=0 #6HM",
            "#7J/ I713=-1 I714=1 I715=0 #7J=100",
            "#8J/ I826=8999999999999999 I823=-8999999999999999 #8HM",
        ];
        for line in lines {
            c.line(line.as_bytes()).expect("answered");
            for cycles in [1, 255, 100_000, 10_000_000] {
                step(&mut c, cycles);
                for m in 1..=8u8 {
                    for q in ["P", "V", "F"] {
                        let v = values(&mut c, &format!("#{m}{q}"));
                        let x: f64 = v[0].parse().unwrap_or_else(|_| panic!("#{m}{q} after `{line}`: {v:?}"));
                        assert!(x.is_finite() && x.abs() <= 1e15, "#{m}{q} after `{line}`: {x}");
                    }
                }
            }
        }
    }
}
