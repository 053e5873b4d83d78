//! The status words a host reads with `#n?` (two 24-bit words, SRM p.282-284) and `&n??`
//! (three, SRM p.284-287), composed from the motors as the safety chain sees them (the
//! vocabulary's [`MotorView`]); every other bit is a documented constant.
//!
//! The core reports its motors to the emulator as a [`MotionView`] once it models them (the
//! bridge's observation carries `motion: None` until then, docs/conformance.md "Not yet in
//! the core"): without one, every motor the configuration has is reported killed, the state a
//! Turbo PMAC's motors power up in unless Ixx80 says otherwise.

use pmacwd_specs::vocab::observation::{MotionView, MotorState, MotorView};

/// First word (X), SRM p.282-283.
pub const MOTOR_ACTIVATED: u32 = 1 << 23;
pub const AMPLIFIER_ENABLED: u32 = 1 << 19;
pub const OPEN_LOOP: u32 = 1 << 18;
/// Ixx34 = 1, integrate only at rest: a documented constant (the SRM's own example, `#1?`
/// answered `81200001C401`, has it set, SRM p.284).
pub const INTEGRATION_MODE: u32 = 1 << 16;
pub const DESIRED_VELOCITY_ZERO: u32 = 1 << 13;
/// Second word (Y), SRM p.283-284.
pub const IN_POSITION: u32 = 1 << 0;

/// `#n?` for motor `n` (1-based) of `count` activated motors, as `(first, second)`.
/// `view` is the motor as the core reports it, `None` when the core models no motors.
pub fn motor_words(n: u8, count: u8, view: Option<&MotorView>) -> (u32, u32) {
    if n == 0 || n > count {
        // Ixx00 = 0: a motor the configuration does not have is not activated, and a
        // deactivated motor reports nothing else (SRM p.282, bit 23).
        return (0, 0);
    }
    let killed = MotorView::default();
    let m = view.unwrap_or(&killed);
    let mut x = MOTOR_ACTIVATED | INTEGRATION_MODE;
    let mut y = 0;
    if m.amplifier_enabled {
        x |= AMPLIFIER_ENABLED;
    }
    match m.state {
        MotorState::Killed => x |= OPEN_LOOP,
        // Closed loop, no commanded move: desired velocity zero; the following error of an
        // emulated motor is 0, within any in-position band (bit 0: SRM p.284).
        MotorState::Closed => {
            x |= DESIRED_VELOCITY_ZERO;
            y |= IN_POSITION;
        }
        // At rest on the path, but the program's move timer is on: not in position.
        MotorState::Holding => x |= DESIRED_VELOCITY_ZERO,
        MotorState::Jogging | MotorState::Program | MotorState::Decelerating => {}
    }
    (x, y)
}

/// The motor view for motor `n` (1-based) from the core's motion, if it reports any.
pub fn motor_view(motion: Option<&MotionView>, n: u8) -> Option<&MotorView> {
    motion.and_then(|m| m.motors().get(usize::from(n).checked_sub(1)?))
}

/// First word bit 0 of `&n??`: the C.S. is running a motion program (SRM p.285).
pub const CS_RUNNING_PROGRAM: u32 = 1 << 0;

/// `&n??` as three words. No motor is assigned to a coordinate system on the emulated card
/// (no axis definitions), so only "running program" can be set, and only from a motor the
/// core reports in `Program` state; the other bits are constant 0.
pub fn cs_words(motion: Option<&MotionView>) -> (u32, u32, u32) {
    let running = motion.is_some_and(|m| m.motors().iter().any(|v| v.state == MotorState::Program));
    (if running { CS_RUNNING_PROGRAM } else { 0 }, 0, 0)
}

/// Words as the card prints them: six hex digits each, the first word first (SRM p.284).
pub fn hex_words(words: &[u32]) -> String {
    words.iter().map(|w| format!("{:06X}", w & 0xFF_FFFF)).collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use pmacwd_specs::vocab::observation::MOTORS_SHOWN;

    fn view(state: MotorState, amp: bool) -> MotorView {
        MotorView { state, amplifier_enabled: amp, ..MotorView::default() }
    }

    #[test]
    fn without_motors_from_the_core_every_motor_reads_killed() {
        // Activated, open loop, amplifier off: what the EPICS driver reads as "done, no
        // power" and dls-pmaccontrol's status window shows as open loop.
        let (x, y) = motor_words(1, 8, None);
        assert_eq!(hex_words(&[x, y]), "850000000000");
        assert_eq!(motor_words(9, 8, None), (0, 0), "a motor the card does not have");
    }

    #[test]
    fn the_bits_the_safety_chain_drives_follow_the_motor() {
        let (x, y) = motor_words(1, 8, Some(&view(MotorState::Closed, true)));
        assert_eq!(
            (x & AMPLIFIER_ENABLED, x & OPEN_LOOP, x & DESIRED_VELOCITY_ZERO, y),
            (AMPLIFIER_ENABLED, 0, DESIRED_VELOCITY_ZERO, IN_POSITION)
        );
        let (x, y) = motor_words(1, 8, Some(&view(MotorState::Jogging, true)));
        assert_eq!((x & DESIRED_VELOCITY_ZERO, y & IN_POSITION), (0, 0), "moving");
        // A kill opens the loop and disables the amplifier (UM p.319).
        let (x, _) = motor_words(1, 8, Some(&view(MotorState::Killed, false)));
        assert_eq!(x & (OPEN_LOOP | AMPLIFIER_ENABLED), OPEN_LOOP);
    }

    #[test]
    fn a_program_running_shows_in_the_coordinate_system_status() {
        let mut motors = [MotorView::default(); MOTORS_SHOWN];
        let motion = MotionView { count: 2, motors };
        assert_eq!(cs_words(Some(&motion)), (0, 0, 0));
        motors[1].state = MotorState::Program;
        let motion = MotionView { count: 2, motors };
        assert_eq!(cs_words(Some(&motion)).0, CS_RUNNING_PROGRAM);
        assert_eq!(motor_view(Some(&motion), 2).unwrap().state, MotorState::Program);
        assert_eq!(hex_words(&[1, 0, 0]).len(), 18);
    }
}
