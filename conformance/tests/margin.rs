//! `pmacwd margin`'s figures are where the model itself trips: checked here against a trace
//! run on the model and against the scenario library.

use pmacwd_conformance::margin;
use pmacwd_model::controller::Controller;
use pmacwd_specs::check::Load;
use pmacwd_specs::config::ModelConfig;
use pmacwd_specs::vocab::event::Event;
use pmacwd_specs::Spec;

fn config(profile: &str) -> ModelConfig {
    let spec = Spec::embedded().unwrap();
    let p = spec.profiles.all().into_iter().find(|p| p.name == profile).unwrap();
    ModelConfig::from_spec(&spec, "i40-zero", &p).unwrap()
}

/// A card with `load` after a background cycle, left `n` servo cycles with no other one.
fn left_without_background(cfg: &ModelConfig, load: Load, n: u64) -> Controller {
    let mut card = Controller::power_on(cfg);
    card.apply(cfg, &Event::Load(load));
    while !card.background_possible() {
        card.servo_cycle(cfg);
    }
    card.background_cycle(cfg);
    for _ in 0..n {
        card.servo_cycle(cfg);
    }
    card
}

#[test]
fn the_tolerated_run_is_exactly_where_the_model_trips_under_every_profile() {
    // The margin is only worth reading if one cycle more than it says trips the card and the
    // figure itself does not.
    let spec = Spec::embedded().unwrap();
    for p in spec.profiles.all() {
        let cfg = config(&p.name);
        let load = cfg.loads[0];
        let m = margin::measure(&cfg, load);
        assert!(!left_without_background(&cfg, load, m.trip_after_cycles - 1).tripped(), "{}", p.name);
        assert!(left_without_background(&cfg, load, m.trip_after_cycles).tripped(), "{}", p.name);
    }
}

#[test]
fn under_um_215_the_card_trips_46_cycles_after_its_4096_cycle_run_down_as_the_scenario_says() {
    // specs/scenarios/a-starved-background-trips-the-um-215-card-46-cycles-after-the-counter-runs-out.yaml:
    // reload 4096 (UM p.215, I40 = 0), then the hardware delay of 45 cycles (25 Hz at 2.25 kHz).
    let m = margin::measure(&config("um-215"), config("um-215").loads[0]);
    assert_eq!((m.reload, m.trip_after_cycles), (4096, 4096 + 46));
    assert!(m.margin_cycles().unwrap() > 4000, "{m:?}");
}

#[test]
fn a_plc0_that_takes_every_spare_unit_leaves_no_margin() {
    // check.yaml's i40-zero: 8 motors at 1 unit, RTI every 3 cycles of 100 units: 276 units of
    // PLC 0 leave the background nothing (its second load, "PLC 0 fills every RTI period").
    let cfg = config("um-215");
    let starved = cfg.loads[1];
    let m = margin::measure(&cfg, starved);
    assert!(m.tripped && m.margin_cycles().is_none() && m.longest_interval_cycles.is_none(), "{m:?}");
}
