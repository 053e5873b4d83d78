//! `&nE` (the EPICS `pmac` driver's C.S. enable) on the core against the model in lockstep:
//! every sequence of three motion commands over killed, closed, jogging and running motors in
//! and out of the coordinate system addressed, then `&1E`, `&2E` and `&3E` (a C.S. no motor is
//! in), on every configuration. MODEL (docs/grammar.md, `E`): each killed motor of the C.S.
//! closes its loop as J/ closes a killed motor's (UM p.319), the amplifier-fault status bit
//! clears (UM p.213); no other motor and no program changes.

use pmacwd_conformance::generate;
use pmacwd_conformance::lockstep::Pair;
use pmacwd_conformance::subject::CoreSubject;
use pmacwd_specs::vocab::command::{CsCommand, HostCommand, Motion};
use pmacwd_specs::vocab::event::{AmplifierFaultInput, Event};
use pmacwd_specs::vocab::observation::MotorState;
use pmacwd_specs::Spec;

fn command(text: &str) -> Event {
    Event::Command(HostCommand::parse(text).unwrap_or_else(|e| panic!("{text}: {e}")))
}

/// What `&nE` met, across the run: (a killed motor of the C.S., a killed motor of another C.S.,
/// a jogging motor of the C.S., a motor of the C.S. running its program, a motor of the C.S.
/// with its amplifier-fault status bit set), so the test shows it met each.
#[derive(Default, Debug)]
struct Met {
    killed_in: u64,
    killed_out: u64,
    jogging_in: u64,
    program_in: u64,
    fault_in: u64,
}

#[test]
fn e_agrees_on_the_core_and_the_model_over_killed_closed_jogging_and_running_motors_in_and_out_of_its_cs() {
    let spec = Spec::embedded().unwrap();
    let before = ["#1J/", "#2J/", "#1J+", "#2J+", "#1K", "#2K", "&1B", "&1R", "&2B", "&2R", "&1E", "&2E", "<CTRL-K>"];
    let enables = ["&1E", "&2E", "&3E"];
    let mut met = Met::default();
    let mut configurations = std::collections::BTreeSet::new();
    for cfg in generate::all_configs(&spec).unwrap() {
        // The motion rules do not branch on the profile: one profile per configuration.
        if !configurations.insert(cfg.configuration.clone()) {
            continue;
        }
        let faults = cfg.motion.amplifier_fault_inputs;
        for x in before {
            for y in before {
                for z in before {
                    let mut pair = Pair::<CoreSubject>::power_on(&cfg);
                    let mut events = Vec::new();
                    if faults {
                        // UM p.213: motor 2's fault kills it at the background's check and sets
                        // its status bit; the input clears before the commands.
                        events.push(Event::AmplifierFault(AmplifierFaultInput { motor: 2, fault: true }));
                        events.push(command("#2J/"));
                        events.push(Event::Servo { cycles: 1 });
                        events.push(Event::Background);
                        events.push(Event::AmplifierFault(AmplifierFaultInput { motor: 2, fault: false }));
                    }
                    events.extend([command(x), command(y), command(z), Event::Servo { cycles: 1 }]);
                    for e in &enables {
                        events.push(command(e));
                        events.push(Event::Servo { cycles: 1 });
                    }
                    for e in &events {
                        if let Event::Command(HostCommand::Motion(Motion::CoordinateSystem(cs, CsCommand::Enable))) = e
                        {
                            {
                                let cs = *cs;
                                let card = pair.model.controller();
                                for (k, motor) in card.axes.motors().iter().enumerate() {
                                    let inside = cfg.motion.coordinate_system(k as u8 + 1) == cs;
                                    match (motor.state, inside) {
                                        (MotorState::Killed, true) => met.killed_in += 1,
                                        (MotorState::Killed, false) => met.killed_out += 1,
                                        (MotorState::Jogging, true) => met.jogging_in += 1,
                                        (MotorState::Program, true) => met.program_in += 1,
                                        _ => {}
                                    }
                                    if inside && motor.fault_status {
                                        met.fault_in += 1;
                                    }
                                }
                            }
                        }
                        if *e == Event::Background && !pair.background_possible().unwrap() {
                            continue;
                        }
                        if let Err(d) = pair.apply(e) {
                            panic!("{} / {}: {x} {y} {z}, then {events:?}: {d:?}", cfg.configuration, cfg.profile.name);
                        }
                    }
                }
            }
        }
    }
    eprintln!("&nE met: {met:?}");
    assert!(
        met.killed_in > 0 && met.killed_out > 0 && met.jogging_in > 0 && met.program_in > 0 && met.fault_in > 0,
        "{met:?}"
    );
}
