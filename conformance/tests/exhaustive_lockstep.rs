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

/// The successors the product's `for_each_next_state` gives (the two time jumps of a pair
/// sharing the model's simulated cycles) are `next_state`'s, action by action, in the first 200
/// pair states reachable in `i40-zero` (breadth first; every running state leaps), under both
/// profiles that decrement differently (`srm-57` counts below zero), and with a canary that acts
/// within the cycles, so that pairs part at the end of a time jump.
#[test]
fn the_product_s_leaps_share_their_cycles_and_give_next_state_s_successors() {
    use pmacwd_model::checker::Action;
    use stateright::Model;
    let spec = Spec::embedded().unwrap();
    let runs = [("um-215", None), ("srm-57", None), ("um-215", Some(Canary::CounterDropsByTwo))];
    for (profile, canary) in runs {
        let profile = spec.profiles.get(profile).expect("profile exists");
        let cfg = pmacwd_specs::config::ModelConfig::from_spec(&spec, "i40-zero", &profile).unwrap();
        let product =
            ProductModel { core_cfg: core_config(&cfg), model: WatchdogModel { canary, ..WatchdogModel::new(cfg) } };
        let mut seen = std::collections::HashSet::new();
        let mut queue: std::collections::VecDeque<_> = product.init_states().into();
        let (mut states, mut leaps, mut diverged) = (0, 0, 0);
        while let Some(s) = queue.pop_front() {
            if states == 200 {
                break;
            }
            if !seen.insert(s.clone()) {
                continue;
            }
            states += 1;
            let mut actions = Vec::new();
            product.actions(&s, &mut actions);
            leaps += actions.iter().filter(|a| **a == Action::ServoToNextChange).count();
            let one_by_one: Vec<_> = actions.iter().map(|a| product.next_state(&s, a.clone())).collect();
            let mut shared = Vec::new();
            product.for_each_next_state(&s, &mut actions, |n| shared.push(n.take()));
            assert!(actions.is_empty(), "the actions are drained");
            assert!(shared == one_by_one, "successors differ at {s:?}");
            diverged += one_by_one.iter().flatten().filter(|n| n.diverged).count();
            queue.extend(one_by_one.into_iter().flatten());
        }
        if canary.is_some() {
            // A pair that parted has no successors: the canary's product is small.
            assert!(leaps > 5 && diverged > 0, "{states} states, {leaps} leaping, {diverged} parted");
        } else {
            assert!(leaps > 50, "{states} states, {leaps} leaping");
        }
    }
}
