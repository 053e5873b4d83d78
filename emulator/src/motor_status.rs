//! The status words a host reads with `#n?` (two 24-bit words, SRM p.282-284) and `&n??`
//! (three, SRM p.284-287), composed from the motors as the safety chain sees them (the
//! vocabulary's [`MotorView`], with the motor's coordinate system and the stop under way as
//! the bridge's [`MotorStatus`] reports them from the core); every other bit is a documented
//! constant.

use pmacwd_bridge::MotorStatus;
use pmacwd_core::motion::Stop;
use pmacwd_specs::vocab::observation::MotorState;

/// First word (X), SRM p.282-283.
pub const MOTOR_ACTIVATED: u32 = 1 << 23;
pub const AMPLIFIER_ENABLED: u32 = 1 << 19;
pub const OPEN_LOOP: u32 = 1 << 18;
/// Ixx34 = 1, integrate only at rest (SRM p.283; the SRM's own example, `#1?` answered
/// `81200001C401`, has it set, SRM p.284).
pub const INTEGRATION_MODE: u32 = 1 << 16;
/// A move with a definite end point is under way (a jog to a position, a homing search).
pub const MOVE_TIMER: u32 = 1 << 17;
/// Past the positive / negative end of travel: a software limit or a limit switch (SRM p.283,
/// bits 21 and 22; the EPICS driver's high and low limit).
pub const POSITIVE_LIMIT: u32 = 1 << 21;
pub const NEGATIVE_LIMIT: u32 = 1 << 22;
/// A homing search is under way (SRM p.283, bit 10).
pub const HOME_SEARCH: u32 = 1 << 10;
pub const DESIRED_VELOCITY_ZERO: u32 = 1 << 13;
/// Decelerating after an abort (`A`, <CTRL-A>) or a limit (SRM p.283, bit 12).
pub const ABORT_DECELERATION: u32 = 1 << 12;
/// Second word (Y), SRM p.283-284: bits 20-23 the C.S. number less one, bit 15 assigned to
/// a C.S., bit 0 in position.
pub const ASSIGNED_TO_CS: u32 = 1 << 15;
/// A homing search has completed since power-up or reset (SRM p.284, bit 10).
pub const HOME_COMPLETE: u32 = 1 << 10;
/// The last move stopped on a position limit (SRM p.284, bit 11).
pub const STOPPED_ON_LIMIT: u32 = 1 << 11;
pub const CS_NUMBER_SHIFT: u32 = 20;
pub const IN_POSITION: u32 = 1 << 0;

/// What the words need of a motor's trajectory and I-variables (the card's `card/motion.rs`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct MotionBits {
    /// Ixx00 = 1 (SRM p.282, bit 23).
    pub activated: bool,
    /// Ixx34 = 1 (SRM p.283, bit 16).
    pub integration_mode: bool,
    /// The commanded velocity is zero and no move is under way.
    pub at_rest: bool,
    /// A move to a definite end point is under way (bit 17).
    pub move_timer: bool,
    /// A homing search is under way (bit 10).
    pub homing: bool,
    /// A homing search has completed (second word bit 10).
    pub home_complete: bool,
    /// The following error is within the in-position band Ixx28.
    pub within_band: bool,
    /// Past the positive / negative end: software limit or limit switch (bits 21, 22).
    pub plus_limit: bool,
    pub minus_limit: bool,
    /// The last move stopped on a limit (second word bit 11).
    pub limit_stop: bool,
}

impl Default for MotionBits {
    /// A motor activated, integrating at rest, standing still within its band, not homed.
    fn default() -> Self {
        MotionBits {
            activated: true,
            integration_mode: true,
            at_rest: true,
            move_timer: false,
            homing: false,
            home_complete: false,
            within_band: true,
            plus_limit: false,
            minus_limit: false,
            limit_stop: false,
        }
    }
}

/// `#n?` as `(first, second)` for a motor as the bridge reports it, with its trajectory; `None`
/// for a motor the configuration does not have.
pub fn motor_words(status: Option<&MotorStatus>, motion: &MotionBits) -> (u32, u32) {
    let Some(status) = status else {
        // Ixx00 = 0: a motor the configuration does not have is not activated, and a
        // deactivated motor reports nothing else (SRM p.282, bit 23).
        return (0, 0);
    };
    let m = &status.view;
    let mut x = 0;
    if motion.activated {
        x |= MOTOR_ACTIVATED;
    }
    if motion.integration_mode {
        x |= INTEGRATION_MODE;
    }
    // Every configured motor belongs to its coordinate system (the model's `coordinate_systems`
    // of check.yaml); the C.S. number goes in bits 20-23, less one (SRM p.284's example:
    // bits 20-23 all 0, "assigned to C.S.1").
    let cs = u32::from(status.coordinate_system.clamp(1, 16) - 1);
    let mut y = ASSIGNED_TO_CS | cs << CS_NUMBER_SHIFT;
    if matches!(status.stop, Some((Stop::Abort, _))) {
        x |= ABORT_DECELERATION;
    }
    if m.amplifier_enabled {
        x |= AMPLIFIER_ENABLED;
    }
    if motion.home_complete {
        y |= HOME_COMPLETE;
    }
    if motion.plus_limit {
        x |= POSITIVE_LIMIT;
    }
    if motion.minus_limit {
        x |= NEGATIVE_LIMIT;
    }
    if motion.limit_stop {
        y |= STOPPED_ON_LIMIT;
    }
    // SRM p.284, second word bit 0: in position when the loop is closed, the desired velocity
    // is zero, no move timer runs and the following error is within Ixx28.
    let still = |x: &mut u32, y: &mut u32| {
        *x |= DESIRED_VELOCITY_ZERO;
        if motion.within_band {
            *y |= IN_POSITION;
        }
    };
    match m.state {
        MotorState::Killed => x |= OPEN_LOOP,
        // Closed loop: at rest unless the trajectory still moves; jogging or decelerating:
        // moving until the trajectory has arrived (a jog to a position ends at rest with the
        // core's motor still jogging: the trajectory says it is still).
        MotorState::Closed | MotorState::Jogging | MotorState::Decelerating => {
            if motion.at_rest && !motion.move_timer {
                still(&mut x, &mut y);
            } else if motion.move_timer {
                x |= MOVE_TIMER;
            }
            if motion.homing {
                x |= HOME_SEARCH;
            }
        }
        // At rest on the path, but the program's move timer is on: not in position.
        MotorState::Holding => x |= DESIRED_VELOCITY_ZERO,
        MotorState::Program => {}
    }
    (x, y)
}

/// `&n??` bits (SRM p.285-286), composed in `card/program.rs`. First word: running a motion
/// program, single-step mode, moves specified by time, continuous motion requested; bits 6
/// and 7 axis A's incremental mode and feedrate use, then two bits for each of B, C, U, V, W,
/// X, Y, Z up to bits 22 and 23.
pub const CS_RUNNING_PROGRAM: u32 = 1 << 0;
pub const CS_SINGLE_STEP: u32 = 1 << 1;
pub const CS_MOVE_BY_TIME: u32 = 1 << 3;
pub const CS_CONTINUOUS_REQUEST: u32 = 1 << 4;
pub const CS_AXIS_BITS_SHIFT: u32 = 6;
/// Second word: in position, amplifier fault, run-time error.
pub const CS_IN_POSITION: u32 = 1 << 17;
pub const CS_AMPLIFIER_FAULT: u32 = 1 << 20;
pub const CS_RUNTIME_ERROR: u32 = 1 << 22;

/// Words as the card prints them: six hex digits each, the first word first (SRM p.284).
pub fn hex_words(words: &[u32]) -> String {
    words.iter().map(|w| format!("{:06X}", w & 0xFF_FFFF)).collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use pmacwd_specs::vocab::observation::MotorView;

    fn status(state: MotorState, amp: bool, cs: u8) -> MotorStatus {
        MotorStatus {
            view: MotorView { state, amplifier_enabled: amp, ..MotorView::default() },
            coordinate_system: cs,
            program: pmacwd_core::motion::Program::None,
            stop: None,
        }
    }

    #[test]
    fn a_killed_motor_is_activated_open_loop_with_its_amplifier_off() {
        // What the EPICS driver reads as "done, no power" and dls-pmaccontrol's status window
        // shows as open loop; assigned to C.S. 1.
        let (x, y) = motor_words(Some(&status(MotorState::Killed, false, 1)), &MotionBits::default());
        assert_eq!(hex_words(&[x, y]), "850000008000");
        assert_eq!(motor_words(None, &MotionBits::default()), (0, 0), "a motor the card does not have");
    }

    #[test]
    fn the_bits_the_safety_chain_drives_follow_the_motor() {
        let (x, y) = motor_words(Some(&status(MotorState::Closed, true, 1)), &MotionBits::default());
        assert_eq!(
            (x & AMPLIFIER_ENABLED, x & OPEN_LOOP, x & DESIRED_VELOCITY_ZERO, y & IN_POSITION),
            (AMPLIFIER_ENABLED, 0, DESIRED_VELOCITY_ZERO, IN_POSITION)
        );
        let moving = MotionBits { at_rest: false, ..MotionBits::default() };
        let (x, y) = motor_words(Some(&status(MotorState::Jogging, true, 1)), &moving);
        assert_eq!((x & DESIRED_VELOCITY_ZERO, y & IN_POSITION), (0, 0), "moving");
        // A kill opens the loop and disables the amplifier (UM p.319).
        let (x, _) = motor_words(Some(&status(MotorState::Killed, false, 1)), &MotionBits::default());
        assert_eq!(x & (OPEN_LOOP | AMPLIFIER_ENABLED), OPEN_LOOP);
        let mut aborting = status(MotorState::Decelerating, true, 2);
        aborting.stop = Some((Stop::Abort, 3));
        let (x, y) = motor_words(Some(&aborting), &moving);
        assert_eq!(x & ABORT_DECELERATION, ABORT_DECELERATION);
        assert_eq!(y >> CS_NUMBER_SHIFT, 1, "C.S. 2 is 1 in bits 20-23");
    }

    #[test]
    fn the_coordinate_system_words_print_as_eighteen_digits() {
        assert_eq!(hex_words(&[CS_RUNNING_PROGRAM, CS_IN_POSITION, 0]), "000001020000000000");
    }
}
