//! The configuration the core's tests and benchmarks share: the default profile at a realistic
//! operating point (I40 = 0, I8 = 2, eight motors, hardware delay 45 servo cycles: 2.25 kHz
//! servo against the 25 Hz strobe minimum), eight motors in &1 decelerating for 20 servo cycles.

use pmacwd_core::motion::MotorCommand;
use pmacwd_core::{Command, Config, Core, Event, FewIVariables, Load, MotionCommand, MotionConfig, Processor, Profile};

pub fn realistic_config() -> Config {
    Config {
        profile: Profile::UM_215,
        hardware_delay_cycles: 45,
        cycle_units: 100,
        servo_units_per_motor: 1,
        move_planning_units: 0,
        saved_i8: 2,
        saved_i40: 0,
        saved_i41: 0,
        pass_firmware: 2,
        pass_user_program: 1,
        supply_min_millivolts: 4750,
        servo_counter_mask: 0xFF_FFFF,
        load: Load { motors: 8, plc0_units: 30, background_units: 250 },
        motion: MotionConfig::all_in_cs1(8, 20),
        processor: Processor::Dsp56303,
        other_i_writes_card_own: false,
    }
}

/// A running card whose eight motors are closed-loop and jogging, `stopping` of them
/// decelerating from a J/ for `decel_cycles` servo cycles. Jogging motors cost a servo cycle
/// nothing (the core represents no trajectory); a stop under way is what a cycle has to count
/// down. (Not every test binary that includes this module uses it.)
#[allow(dead_code)]
pub fn moving(decel_cycles: u8, stopping: u8) -> (Config, Core) {
    let cfg = Config { motion: MotionConfig::all_in_cs1(8, decel_cycles), ..realistic_config() };
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
