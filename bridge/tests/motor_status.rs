//! The bridge's reading of the core's motors: what an emulator answering `#n?` gets, and what
//! lockstep compares, come from the core's own state through the configuration's motor layout.

use pmacwd_bridge::{core_config, core_event, motion_view, motor_status};
use pmacwd_core::motion::{Program, Stop};
use pmacwd_core::{AllIVariables, Core};
use pmacwd_specs::config::ModelConfig;
use pmacwd_specs::vocab::{Event, HostCommand, MotorState};
use pmacwd_specs::Spec;

/// check.yaml's `motion` configuration: motor 1 in &1, motor 2 in &2, decelerations of up to
/// 2 servo cycles.
fn motion_config() -> ModelConfig {
    let spec = Spec::embedded().unwrap();
    ModelConfig::from_spec(&spec, "motion", &spec.profiles.default_profile()).unwrap()
}

/// Motor 1 enabled and running &1's program, then held: each step shows in `motor_status`
/// (state, amplifier, its C.S. and that C.S.'s program, the stop under way with the
/// configuration's longest deceleration), motor 2 stays killed in &2, and a motor the
/// configuration does not have reads `None`.
#[test]
fn motor_status_follows_the_core_through_a_program_and_a_hold() {
    let model = motion_config();
    let cfg = core_config(&model);
    let mut core = Core::power_on(&cfg);
    let mut store = Box::<AllIVariables>::default();
    for line in ["#1J/", "&1B", "&1R", "&1H"] {
        let e = Event::Command(HostCommand::parse(line).unwrap());
        core.apply(&cfg, core_event(&e), &mut *store);
    }
    let one = motor_status(&core, &cfg, 1).unwrap();
    assert_eq!(one.view.state, MotorState::Decelerating);
    assert!(one.view.amplifier_enabled && !one.view.output_zero);
    assert_eq!((one.coordinate_system, one.program), (1, Program::Held));
    assert_eq!(one.stop, Some((Stop::Hold, model.motion.decel_cycles_max)));
    let two = motor_status(&core, &cfg, 2).unwrap();
    assert_eq!((two.view.state, two.coordinate_system, two.program), (MotorState::Killed, 2, Program::None));
    assert!(!two.view.amplifier_enabled && two.view.output_zero);
    assert_eq!(motor_status(&core, &cfg, 3), None);
    assert_eq!(motor_status(&core, &cfg, 0), None);
    let view = motion_view(&core, &cfg);
    assert_eq!(view.motors(), &[one.view, two.view]);
}
