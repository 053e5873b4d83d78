//! What the core's benchmark and the best-of example both run: a card with its motors moving.

#[path = "../../tests/common/mod.rs"]
mod common;

pub use common::realistic_config;
use pmacwd_core::motion::MotorCommand;
use pmacwd_core::{Command, Config, Core, Event, FewIVariables, MotionCommand, MotionConfig};

/// A running card whose eight motors are closed-loop and jogging, `stopping` of them
/// decelerating from a J/ for 255 servo cycles (longer than a batch, so every cycle of the
/// batch has them under way). Jogging motors cost a servo cycle nothing (the core represents
/// no trajectory); a stop under way is what a cycle has to count down.
pub fn moving(stopping: u8) -> (Config, Core) {
    let cfg = Config { motion: MotionConfig::all_in_cs1(8, 255), ..realistic_config() };
    let mut core = Core::power_on(&cfg);
    let mut store = FewIVariables::<4>::default();
    let mut send = |core: &mut Core, n: u8, c: MotorCommand| {
        core.apply(&cfg, Event::Command(Command::Motion(MotionCommand::Motor(n, c))), &mut store)
    };
    for n in 1..=8 {
        send(&mut core, n, MotorCommand::JogStop);
        send(&mut core, n, MotorCommand::Jog);
    }
    for n in 1..=stopping {
        send(&mut core, n, MotorCommand::JogStop);
    }
    (cfg, core)
}
