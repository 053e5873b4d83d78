//! The configuration the core's tests and benchmarks share: the default profile at a realistic
//! operating point (I40 = 0, I8 = 2, eight motors, hardware delay 45 servo cycles: 2.25 kHz
//! servo against the 25 Hz strobe minimum), eight motors in &1 decelerating for 20 servo cycles.

use pmacwd_core::{Config, Load, MotionConfig, Processor, Profile};

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
    }
}
