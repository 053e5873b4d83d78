//! A checked state as a person reads it: the card first (the trip and its outputs, Y:$25,
//! X:$25, the `???` words and the flags behind them), then the rest of the state the rules read,
//! then the bookkeeping only properties read. `pmacwd explore` shows states this way
//! (stateright's Explorer, through [`stateright::Model::format_state`]).
//!
//! Every field of the state is shown: the controller is destructured without `..`, so a field
//! added to it is a compile error here until it is shown, and two states the checker tells
//! apart never read the same.

use crate::controller::{ChecksumEngine, Controller, Ghost, Outputs, StatusFlags, TripCause};
use crate::monitor::MONITORS;
use crate::motion::Axes;
use crate::state::State;
use pmacwd_specs::check::{ChecksumTarget, Load};
use pmacwd_specs::config::ModelConfig;
use pmacwd_specs::vocab::event::{Event, Reply};
use std::fmt::Write as _;

/// The card's line of what an instrument sees, as `pmacwd check` prints a path's step: `Y:$25=3
/// X:$25=1 status=XXXXXXYYYYYY`, then ` TRIPPED ...` when the red LED is lit.
pub fn card_line(cfg: &ModelConfig, c: &Controller) -> String {
    let (x, y) = c.status_words(cfg);
    let mut line = format!("Y:$25={} X:$25={} status={x:06X}{y:06X}", c.counter, c.counter_min);
    if c.outputs.led_red {
        line.push_str(" TRIPPED (red LED, FEFCO/ on, relay over, outputs off)");
    }
    line
}

/// One step as the Explorer's "outcome": the concrete event (a time jump's servo cycles), the
/// reply, and the card line after it.
pub fn step_text(cfg: &ModelConfig, event: &Event, reply: Reply, next: &Controller) -> String {
    let mut s = format!("event: {event}\n");
    if reply != Reply::None {
        let _ = writeln!(s, "reply: {reply}");
    }
    s.push_str(&card_line(cfg, next));
    s
}

fn yes(b: bool) -> &'static str {
    if b {
        "yes"
    } else {
        "no"
    }
}

fn area(a: ChecksumTarget) -> &'static str {
    match a {
        ChecksumTarget::Firmware => "firmware",
        ChecksumTarget::UserProgram => "user program",
    }
}

/// The whole state, card first.
pub fn state_text(cfg: &ModelConfig, s: &State) -> String {
    let State { controller, violations } = s;
    let Controller {
        trip,
        supply_low,
        bootstrap,
        counter: _,
        counter_min: _,
        cycles_since_strobe,
        rti_phase,
        rti_remaining,
        background_credit,
        load,
        i8,
        i40,
        i41,
        other_i_variables,
        status,
        checksum,
        servo_cycles,
        outputs,
        axes,
        ghost,
    } = controller;
    let mut out = String::new();
    let o = &mut out;
    let card = match (trip, bootstrap) {
        (Some(TripCause::Undervoltage), _) => "TRIPPED by a low supply (latched until INIT/ or power)",
        (Some(TripCause::StrobeTimeout), _) => {
            "TRIPPED: no strobe edge within the hardware delay (latched until INIT/ or power)"
        }
        (None, true) => "in bootstrap mode (no servo tasks)",
        (None, false) => "running",
    };
    let _ = writeln!(o, "card: {card}");
    let _ = writeln!(o, "{}", card_line(cfg, controller));
    let StatusFlags {
        rti_reentry,
        rti_warning,
        servo_error,
        dpram_error,
        flash_error,
        plc_buffer_open,
        motion_buffer_open,
        data_gathering_on,
    } = status;
    let flags: Vec<&str> = [
        (*rti_reentry, "RTI re-entry (X22)"),
        (*rti_warning, "RTI warning (X9)"),
        (*servo_error, "servo error (X20)"),
        (*dpram_error, "DPRAM error (X11)"),
        (*flash_error, "flash checksum error (X10)"),
        (*plc_buffer_open, "PLC buffer open (Y17)"),
        (*motion_buffer_open, "motion buffer open (Y19)"),
        (*data_gathering_on, "data gathering on (X19)"),
    ]
    .into_iter()
    .filter_map(|(on, name)| on.then_some(name))
    .collect();
    let _ = writeln!(o, "status flags: {}", if flags.is_empty() { "none".to_string() } else { flags.join(", ") });
    let Outputs { led_red, fefco_on, relay_tripped, forced_off } = outputs;
    let _ = writeln!(
        o,
        "outputs: red LED {}, FEFCO/ on {}, relay over {}, outputs forced off {}",
        yes(*led_red),
        yes(*fefco_on),
        yes(*relay_tripped),
        yes(*forced_off)
    );
    let _ = writeln!(o, "supply low: {}", yes(*supply_low));
    let _ = writeln!(
        o,
        "strobe: {cycles_since_strobe} servo cycles since the last edge (hardware delay {})",
        cfg.hardware_delay_cycles
    );
    let _ = writeln!(
        o,
        "RTI: phase {rti_phase} of I8+1 = {}, {rti_remaining} CPU units of its task set left",
        u32::from(*i8) + 1
    );
    let Load { motors, plc0_units, background_units } = load;
    let _ = writeln!(
        o,
        "load: motors {motors}, PLC 0 {plc0_units} units per RTI, background {background_units} units per cycle; \
         {background_credit} units toward the current background cycle"
    );
    let mut ivars = format!("I8={i8} I40={i40} I41={i41}");
    for (n, v) in other_i_variables.iter() {
        let _ = write!(ivars, " I{n}={v}");
    }
    let _ = writeln!(o, "I-variables: {ivars}");
    let ChecksumEngine { area: at, position, error, firmware, firmware_reference, program, program_reference } =
        checksum;
    let _ = writeln!(
        o,
        "checksum: {} pass, position {position}, {}; firmware {firmware} (reference {firmware_reference}), \
         program {program} (X:$1090 {program_reference})",
        area(*at),
        match error {
            Some(a) => format!("stopped on a {} mismatch", area(*a)),
            None => "no error".to_string(),
        }
    );
    let _ = writeln!(o, "servo cycles (X:$0): {servo_cycles}");
    let Axes { motor_slots: _, motor_count: _, program_slots: _, program_count: _, ghost_healthy_latched_scans } = axes;
    for (k, m) in axes.motors().iter().enumerate() {
        let crate::motion::Motor {
            state,
            stop,
            stop_cycles,
            amplifier_enabled,
            output_zero,
            encoder_lost,
            loss_status,
            amplifier_fault,
            fault_status,
        } = m;
        let _ = write!(
            o,
            "motor #{}: {}, amplifier {}, output {}, encoder {}, loss latched {}",
            k + 1,
            state.name(),
            if *amplifier_enabled { "enabled" } else { "disabled" },
            if *output_zero { "zero" } else { "not zero" },
            if *encoder_lost { "LOST" } else { "ok" },
            yes(*loss_status)
        );
        // Shown only when set: the configurations without amplifier-fault inputs print as before.
        if *amplifier_fault || *fault_status {
            let _ = write!(
                o,
                ", amplifier fault input {}, fault status {}",
                if *amplifier_fault { "FAULT" } else { "ok" },
                yes(*fault_status)
            );
        }
        if let Some(stop) = stop {
            let _ = write!(o, ", stopping ({stop:?}, {stop_cycles} cycles left)");
        } else if *stop_cycles != 0 {
            let _ = write!(o, ", {stop_cycles} stop cycles");
        }
        o.push('\n');
    }
    for (k, p) in axes.programs().iter().enumerate() {
        let _ = writeln!(o, "C.S. &{}: program {p:?}", k + 1);
    }
    let Ghost { cycles_since_background, last_reload, recovered_by } = ghost;
    let _ = writeln!(
        o,
        "for the properties: {cycles_since_background} servo cycles since a background cycle, last reload {last_reload}, \
         last recovery {}, encoder-loss scans {ghost_healthy_latched_scans:#04b}",
        match recovered_by {
            Some(r) => format!("{r:?}"),
            None => "none".to_string(),
        }
    );
    let broken: Vec<&str> =
        MONITORS.iter().enumerate().filter(|(k, _)| violations & (1u64 << k) != 0).map(|(_, m)| m.name).collect();
    if broken.is_empty() {
        out.push_str("monitors: no violation on the path here");
    } else {
        let _ = write!(out, "monitors VIOLATED on the path here: {}", broken.join("; "));
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::checker::WatchdogModel;
    use pmacwd_specs::Spec;
    use stateright::Model;
    use std::collections::{HashMap, HashSet, VecDeque};

    /// Every reachable state of `configuration` (default profile), breadth first.
    fn reachable(configuration: &str) -> (WatchdogModel, Vec<State>) {
        let spec = Spec::embedded().unwrap();
        let cfg = ModelConfig::from_spec(&spec, configuration, &spec.profiles.default_profile()).unwrap();
        let model = WatchdogModel::new(cfg);
        let mut seen: HashSet<State> = HashSet::new();
        let mut queue: VecDeque<State> = model.init_states().into();
        let mut all = Vec::new();
        while let Some(s) = queue.pop_front() {
            if !seen.insert(s.clone()) {
                continue;
            }
            queue.extend(model.next_states(&s));
            all.push(s);
        }
        (model, all)
    }

    /// The claim of the module doc: distinct states read differently, in configurations that
    /// vary the counter, the I-variables, the motors and the encoder-loss PLC, and the leaps.
    #[test]
    fn two_distinct_reachable_states_never_read_the_same() {
        for configuration in ["lockout-ic", "encoder-loss", "i40-zero"] {
            let (model, states) = reachable(configuration);
            assert!(states.len() > 1000, "{configuration}: {} states", states.len());
            let mut by_text: HashMap<String, &State> = HashMap::new();
            for s in &states {
                if let Some(other) = by_text.insert(model.format_state(s), s) {
                    panic!("{configuration}: two states read the same:\n{s:#?}\n{other:#?}");
                }
            }
        }
    }

    #[test]
    fn the_card_line_is_the_one_check_prints_for_a_step() {
        let (model, states) = reachable("lockout-ic");
        let tripped = states.iter().find(|s| s.controller.tripped()).expect("lockout-ic starves into a trip");
        let text = model.format_state(tripped);
        let line = text.lines().nth(1).unwrap();
        let (x, y) = tripped.controller.status_words(&model.cfg);
        assert_eq!(
            line,
            format!(
                "Y:$25={} X:$25={} status={x:06X}{y:06X} TRIPPED (red LED, FEFCO/ on, relay over, outputs off)",
                tripped.controller.counter, tripped.controller.counter_min
            )
        );
        assert!(text.starts_with("card: TRIPPED"), "{text}");
    }
}
