//! The status words a host reads with `#n?` (two 24-bit words, SRM p.282-284) and `&n??`
//! (three, SRM p.284-287), composed from the motors as the safety chain sees them (the
//! vocabulary's [`MotorView`], with the motor's coordinate system and the stop under way as
//! the bridge's [`MotorStatus`] reports them from the core); every other bit is a documented
//! constant.

use pmacwd_bridge::MotorStatus;
use pmacwd_core::motion::{Program, Stop};
use pmacwd_specs::vocab::observation::MotorState;

/// First word (X), SRM p.282-283.
pub const MOTOR_ACTIVATED: u32 = 1 << 23;
pub const AMPLIFIER_ENABLED: u32 = 1 << 19;
pub const OPEN_LOOP: u32 = 1 << 18;
/// Ixx34 = 1, integrate only at rest: a documented constant (the SRM's own example, `#1?`
/// answered `81200001C401`, has it set, SRM p.284).
pub const INTEGRATION_MODE: u32 = 1 << 16;
pub const DESIRED_VELOCITY_ZERO: u32 = 1 << 13;
/// Decelerating after an abort (`A`, <CTRL-A>) or a limit (SRM p.283, bit 12).
pub const ABORT_DECELERATION: u32 = 1 << 12;
/// Second word (Y), SRM p.283-284: bits 20-23 the C.S. number less one, bit 15 assigned to
/// a C.S., bit 0 in position.
pub const ASSIGNED_TO_CS: u32 = 1 << 15;
pub const CS_NUMBER_SHIFT: u32 = 20;
pub const IN_POSITION: u32 = 1 << 0;

/// `#n?` as `(first, second)` for a motor as the bridge reports it; `None` for a motor the
/// configuration does not have.
pub fn motor_words(status: Option<&MotorStatus>) -> (u32, u32) {
    let Some(status) = status else {
        // Ixx00 = 0: a motor the configuration does not have is not activated, and a
        // deactivated motor reports nothing else (SRM p.282, bit 23).
        return (0, 0);
    };
    let m = &status.view;
    let mut x = MOTOR_ACTIVATED | INTEGRATION_MODE;
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

/// First word bit 0 of `&n??`: the C.S. is running a motion program (SRM p.285).
pub const CS_RUNNING_PROGRAM: u32 = 1 << 0;

/// `&n??` as three words from the motors of that coordinate system: "running program" when
/// its program runs (the core's `Program::Running`); the other bits are constant 0.
pub fn cs_words(members: &[MotorStatus]) -> (u32, u32, u32) {
    let running = members.iter().any(|m| m.program == Program::Running);
    (if running { CS_RUNNING_PROGRAM } else { 0 }, 0, 0)
}

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
            program: Program::None,
            stop: None,
        }
    }

    #[test]
    fn a_killed_motor_is_activated_open_loop_with_its_amplifier_off() {
        // What the EPICS driver reads as "done, no power" and dls-pmaccontrol's status window
        // shows as open loop; assigned to C.S. 1.
        let (x, y) = motor_words(Some(&status(MotorState::Killed, false, 1)));
        assert_eq!(hex_words(&[x, y]), "850000008000");
        assert_eq!(motor_words(None), (0, 0), "a motor the card does not have");
    }

    #[test]
    fn the_bits_the_safety_chain_drives_follow_the_motor() {
        let (x, y) = motor_words(Some(&status(MotorState::Closed, true, 1)));
        assert_eq!(
            (x & AMPLIFIER_ENABLED, x & OPEN_LOOP, x & DESIRED_VELOCITY_ZERO, y & IN_POSITION),
            (AMPLIFIER_ENABLED, 0, DESIRED_VELOCITY_ZERO, IN_POSITION)
        );
        let (x, y) = motor_words(Some(&status(MotorState::Jogging, true, 1)));
        assert_eq!((x & DESIRED_VELOCITY_ZERO, y & IN_POSITION), (0, 0), "moving");
        // A kill opens the loop and disables the amplifier (UM p.319).
        let (x, _) = motor_words(Some(&status(MotorState::Killed, false, 1)));
        assert_eq!(x & (OPEN_LOOP | AMPLIFIER_ENABLED), OPEN_LOOP);
        let mut aborting = status(MotorState::Decelerating, true, 2);
        aborting.stop = Some((Stop::Abort, 3));
        let (x, y) = motor_words(Some(&aborting));
        assert_eq!(x & ABORT_DECELERATION, ABORT_DECELERATION);
        assert_eq!(y >> CS_NUMBER_SHIFT, 1, "C.S. 2 is 1 in bits 20-23");
    }

    #[test]
    fn a_program_running_shows_in_the_coordinate_system_status() {
        let mut m = status(MotorState::Program, true, 1);
        assert_eq!(cs_words(&[m]), (0, 0, 0), "no program pointed at");
        m.program = Program::Running;
        assert_eq!(cs_words(&[m]).0, CS_RUNNING_PROGRAM);
        assert_eq!(hex_words(&[1, 0, 0]).len(), 18);
    }
}
