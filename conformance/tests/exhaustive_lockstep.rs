//! Exhaustive lockstep: at every bounded configuration and profile that `pmacwd check` runs,
//! the checker explores the product of the model and the core, so every reachable transition
//! of the bounded model is applied to the core as well and their observations compared.

use pmacwd_bridge::core_config;
use pmacwd_conformance::check::{planned_runs, Selection};
use pmacwd_conformance::product::{check, check_product, ProductModel};
use pmacwd_model::checker::{Canary, WatchdogModel};
use pmacwd_specs::vocab::command::HostCommand;
use pmacwd_specs::vocab::event::Event;
use pmacwd_specs::Spec;

#[test]
fn the_core_agrees_with_the_model_in_every_reachable_state_of_every_bounded_run() {
    let spec = Spec::embedded().unwrap();
    let mut total = 0;
    for cfg in planned_runs(&spec, &Selection::default()).unwrap() {
        let r = check(cfg, 2);
        if let Some((events, d)) = &r.divergence {
            let lines: Vec<String> = events.iter().map(|e| format!("  {e}")).collect();
            panic!("{} / {}: {d}\nshortest path:\n{}", r.configuration, r.profile, lines.join("\n"));
        }
        assert!(r.states > 1_000, "{} / {}: only {} states", r.configuration, r.profile, r.states);
        total += r.states;
    }
    eprintln!("{total} product states, no divergence");
}

/// The product must find a divergence when there is one, and report the shortest path to it.
/// Here the model side is the deliberately broken canary that ignores I41 (the core is right):
/// the shortest path locks the motor range, writes a motor I-variable, and reads it back.
#[test]
fn a_divergence_comes_back_as_the_shortest_event_sequence_that_reaches_it() {
    let spec = Spec::embedded().unwrap();
    let cfg = pmacwd_specs::config::ModelConfig::from_spec(&spec, "lockout", &spec.profiles.default_profile()).unwrap();
    let product = ProductModel {
        core_cfg: core_config(&cfg),
        model: WatchdogModel {
            cfg,
            canary: Some(Canary::LockoutIgnored),
            detailed: false,
            longest_decelerations_only: false,
            named_properties: false,
        },
    };
    let r = check_product(product, 1);
    let (events, d) = r.divergence.expect("the broken model diverges from the core");
    let commands: Vec<String> = events
        .iter()
        .map(|e| match e {
            Event::Command(c) => c.to_string(),
            other => panic!("only commands are needed to show it, not {other}"),
        })
        .collect();
    assert_eq!(commands.len(), 3, "{commands:?}");
    assert!(commands[0].starts_with("I41="), "{commands:?}");
    assert!(matches!(events[2], Event::Command(HostCommand::ReadI(_))), "{commands:?}");
    assert!(d.fields[0].starts_with("reply"), "{d}");
}
