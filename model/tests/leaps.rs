//! The leaps in time are checked, not argued (docs/model.md, "Leaps checked against ticks"): on
//! configurations small enough to explore one servo cycle at a time, the model that leaps to
//! the next change (or just before it) and the model that ticks give the same verdict on every
//! property; everything the leaping model shows (counting the states a leap passes through)
//! the ticking one shows too; and what only ticking shows is the environment acting in the
//! middle of a quiet stretch, which leaps do not offer: each such observation is one the
//! leaping model shows, with the counter at another point of the same quiet stretch (same sign,
//! same distance from its lowest value).

use pmacwd_model::checker::{Action, State, WatchdogModel};
use pmacwd_specs::config::ModelConfig;
use pmacwd_specs::vocab::event::Event;
use pmacwd_specs::Spec;
use stateright::Model;
use std::collections::{HashSet, VecDeque};

/// What a host or an instrument could see of a state: the trip, both counters, the status
/// words, the saved and live I-variables, the load and the supply (UM p.215, SRM p.289).
type Seen = (bool, i32, i32, (u32, u32), u8, u16, u8, bool, bool, String);

fn seen(cfg: &ModelConfig, s: &State) -> Seen {
    let c = &s.controller;
    (
        c.tripped(),
        c.counter,
        c.counter_min,
        c.status_words(cfg),
        c.i8,
        c.i40,
        c.i41,
        c.supply_low,
        c.bootstrap,
        format!("{:?}", c.load),
    )
}

/// Every state the model reaches, breadth first, and what is seen in it and in every state a
/// leap passes through; `None` beyond `states_max` states.
fn explore(model: &WatchdogModel, states_max: usize) -> Option<(usize, HashSet<Seen>)> {
    let mut states: HashSet<State> = HashSet::new();
    let mut observed: HashSet<Seen> = HashSet::new();
    let mut queue: VecDeque<State> = model.init_states().into_iter().collect();
    let mut actions = Vec::new();
    while let Some(s) = queue.pop_front() {
        if !states.insert(s.clone()) {
            continue;
        }
        if states.len() > states_max {
            return None;
        }
        observed.insert(seen(&model.cfg, &s));
        actions.clear();
        model.actions(&s, &mut actions);
        for a in &actions {
            let (event, _, next) = model.perform(&s, a);
            if let (Action::ServoToNextChange | Action::ServoToJustBeforeChange, Event::Servo { cycles }) = (a, &event)
            {
                // The cycles a leap skips, one at a time.
                let mut at = s.clone();
                for _ in 0..*cycles {
                    at = model.step(&at, &Event::Servo { cycles: 1 }).1;
                    observed.insert(seen(&model.cfg, &at));
                }
                assert_eq!(at, next, "a leap ends where its cycles, one at a time, end");
            }
            if !states.contains(&next) {
                queue.push_back(next);
            }
        }
    }
    Some((states.len(), observed))
}

/// `timing` of check.yaml with I40 and the hardware delay replaced, ticking or leaping.
fn timing(i40: u16, delay: u32, tick: bool, profile: &str) -> ModelConfig {
    let spec = Spec::embedded().unwrap();
    let p = spec.profiles.all().into_iter().find(|p| p.name == profile).unwrap();
    let mut cfg = ModelConfig::from_spec(&spec, "timing", &p).unwrap();
    cfg.saved.i40 = i40;
    cfg.hardware_delay_cycles = delay;
    cfg.single_servo_cycles = tick;
    cfg
}

/// The sizes compared: a few under `cargo test`, more with `PMACWD_LEAPS_FULL=1`
/// (docs/model.md gives both runs' figures).
fn sizes() -> Vec<(&'static str, u16, u32)> {
    if std::env::var_os("PMACWD_LEAPS_FULL").is_some() {
        let mut v = Vec::new();
        for profile in ["um-215", "srm-57", "um-215-4095", "um-215-50hz"] {
            for (i40, delay) in [(2, 1), (3, 2), (5, 2), (6, 3), (9, 4), (12, 2), (16, 5)] {
                v.push((profile, i40, delay));
            }
        }
        v
    } else {
        vec![("um-215", 3, 2), ("um-215", 6, 3), ("srm-57", 5, 2)]
    }
}

/// An observation with the counter left out but what the environment can react to in it kept:
/// the counter's sign (the leaps stop where it changes, [`pmacwd_model::checker::signature`])
/// and its distance above the lowest value since reset (X:$25 follows the counter down in a
/// first descent, and stays put in a later one).
type Twin = (bool, bool, bool, i32, (u32, u32), u8, u16, u8, bool, bool, String);

fn twin(o: &Seen) -> Twin {
    let (tripped, counter, counter_min, words, i8, i40, i41, supply_low, bootstrap, load) = o.clone();
    (tripped, counter > 0, counter >= 0, counter - counter_min, words, i8, i40, i41, supply_low, bootstrap, load)
}

#[test]
fn leaping_never_sees_what_ticking_cannot_gives_the_same_verdicts_and_misses_only_mid_stretch_events() {
    // What only ticking reaches is an I40 write, a load change or a supply dip taken at a
    // counter value no leap stops at. Each is checked to be, counter aside, an observation the
    // leaping model makes at another point of the same quiet stretch: the leaps lose where in
    // a stretch the environment acted, nothing else.
    for (profile, i40, delay) in sizes() {
        {
            let tick = WatchdogModel::new(timing(i40, delay, true, profile));
            let leap = WatchdogModel::new(timing(i40, delay, false, profile));
            let (tick_states, tick_seen) = explore(&tick, 3_000_000).expect("tick model within bounds");
            let (leap_states, leap_seen) = explore(&leap, 3_000_000).expect("leap model within bounds");
            let missing: Vec<_> = tick_seen.difference(&leap_seen).collect();
            let leap_twins: HashSet<Twin> = leap_seen.iter().map(twin).collect();
            let unexplained: Vec<_> = missing.iter().filter(|o| !leap_twins.contains(&twin(o))).take(3).collect();
            assert!(
                unexplained.is_empty(),
                "{profile}, I40 = {i40}, delay {delay}: leaping misses observations ticking reaches that are not \
                 a leaping observation at another point of a quiet stretch: {unexplained:?}"
            );
            let extra: Vec<_> = leap_seen.difference(&tick_seen).take(3).collect();
            assert!(
                extra.is_empty(),
                "{profile}, I40 = {i40}, delay {delay}: leaping sees what ticking never does: {extra:?}"
            );
            let verdicts = |m: WatchdogModel| -> Vec<(&'static str, bool, bool)> {
                m.check(1).properties.iter().map(|p| (p.name, p.holds, p.applicable)).collect()
            };
            assert_eq!(
                verdicts(WatchdogModel::new(timing(i40, delay, true, profile))),
                verdicts(WatchdogModel::new(timing(i40, delay, false, profile))),
                "{profile}, I40 = {i40}, delay {delay}: the verdicts differ"
            );
            eprintln!(
                "{profile} I40 = {i40} delay {delay}: {} observations ticking, {} missed by leaping (e.g. {:?}); \
                 {tick_states} states ticking, {leap_states} leaping",
                tick_seen.len(),
                missing.len(),
                missing.first()
            );
        }
    }
}

/// Where a counter value stands against the reload value `r` (I40, or 4096 for I40 = 0 as the
/// `um-215` profile reads it): at the reload, strictly between 1 and it, at 1, at 0, below 0,
/// or above the reload (a lowered I40). The rules compare the counter with 0 and the reload
/// and count it down by one (UM p.215, SRM p.57); no rule tells 4 from 4,000 in between.
fn level(c: i32, r: i32) -> u8 {
    match c {
        _ if c == r => 0,
        _ if c > r => 1,
        2.. => 2,
        1 => 3,
        0 => 4,
        _ => 5,
    }
}

/// An observation's class: the observation with the counter and X:$25 as their levels, whether
/// they are equal (a first descent), and I40 as "the configured value" or the value written.
type Class = (bool, u8, u8, bool, (u32, u32), u8, bool, u16, u8, bool, bool, String);

fn class(o: &Seen, configured_i40: u16) -> Class {
    let (tripped, counter, counter_min, words, i8, i40, i41, supply_low, bootstrap, load) = o.clone();
    let reload = if i40 == 0 { 4096 } else { i32::from(i40) };
    let i40_written = if i40 == configured_i40 { 0 } else { i40 };
    let configured = i40 == configured_i40;
    (
        tripped,
        level(counter, reload),
        level(counter_min, reload),
        counter == counter_min,
        words,
        i8,
        configured,
        i40_written,
        i41,
        supply_low,
        bootstrap,
        load,
    )
}

fn classes(i40: u16, delay: u32) -> HashSet<Class> {
    let leap = WatchdogModel::new(timing(i40, delay, false, "um-215"));
    let (_, seen) = explore(&leap, 3_000_000).expect("leap model within bounds");
    seen.iter().map(|o| class(o, i40)).collect()
}

/// The bound that shows every behaviour, checked: from I40 = 6 and a hardware delay of 3
/// servo cycles the leaping `timing` model reaches the same observation classes as at I40 = 9,
/// delay 4 (and, with `PMACWD_LEAPS_FULL=1`, at I40 = 16, delay 5); at the `timing`
/// configuration's own I40 = 3, delay 2 it reaches fewer, which is why check.yaml also checks
/// `timing-wide` at I40 = 6, delay 3 (docs/model.md, "Leaps checked against ticks").
#[test]
fn from_i40_6_and_delay_3_the_model_reaches_every_observation_class_of_larger_sizes() {
    let small = classes(3, 2);
    let wide = classes(6, 3);
    let mut larger = vec![(9, 4)];
    if std::env::var_os("PMACWD_LEAPS_FULL").is_some() {
        larger.push((16, 5));
    }
    for (i40, delay) in larger {
        let big = classes(i40, delay);
        let only_big: Vec<_> = big.difference(&wide).take(3).collect();
        let only_wide: Vec<_> = wide.difference(&big).take(3).collect();
        assert!(
            only_big.is_empty() && only_wide.is_empty(),
            "I40 = 6, delay 3 and I40 = {i40}, delay {delay} reach different classes: only the larger {only_big:?}, \
             only the smaller {only_wide:?}"
        );
        eprintln!("I40 = {i40}, delay {delay}: {} classes, as at I40 = 6, delay 3", big.len());
    }
    assert!(small.is_subset(&wide), "I40 = 3, delay 2 reaches a class the wider bound does not");
    eprintln!("I40 = 3, delay 2: {} classes of {}", small.len(), wide.len());
}

#[test]
fn a_violation_seen_before_a_leap_or_a_step_is_still_recorded_after_it() {
    // model/src/monitor.rs: a monitor's failure is "a sticky bit in the next state", which the
    // matching `always` property requires to stay clear. A leap runs the cycle monitors on
    // every cycle it passes and must add their bits to those already set, never drop them: a
    // leap that forgot an earlier violation would let a failing run pass.
    let cfg = timing(3, 2, false, "um-215");
    let model = WatchdogModel::new(cfg);
    let mut state = model.init_states().into_iter().next().expect("an initial state");
    state.violations = 1 << 5;
    for just_before in [false, true] {
        let (cycles, next) = model.advance_to_change(&state, just_before);
        assert_eq!(next.violations & (1 << 5), 1 << 5, "after a leap of {cycles} cycles (just before: {just_before})");
    }
    // So must a single step: servo cycles one at a time (the cycle monitors), and any other
    // event (the event monitors). A correct model adds no bit of its own: in particular the
    // cycle monitors of a two-cycle event (as replays take them) compare each cycle with the
    // one before it, not with the start ("the watchdog counter drops by at most one per servo
    // cycle", SRM p.57).
    for event in [Event::Servo { cycles: 1 }, Event::Servo { cycles: 2 }, Event::Background] {
        let (_, next) = model.step(&state, &event);
        assert_eq!(next.violations, 1 << 5, "after {event:?}");
    }
}
