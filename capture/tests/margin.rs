//! `pmacwd margin`'s figures are where the model itself trips: checked here against a trace
//! run on the model and against the scenario library.

use pmacwd_capture::margin;
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

/// A card's own X:$25 must tell the same story as its configuration: reading the X:$25 that the
/// load leaves (the lowest counter value of the steady stretch) gives back the load's longest
/// interval between background cycles and its margin, under every profile.
#[test]
fn reading_the_x25_a_load_leaves_gives_back_that_loads_margin() {
    let spec = Spec::embedded().unwrap();
    for p in spec.profiles.all() {
        let cfg = config(&p.name);
        let load = cfg.loads[0];
        let m = margin::measure(&cfg, load);
        let reading = margin::from_readings(&cfg, load, m.counter_min, None);
        let margin::ReadingMargin::Seen { longest_gap_cycles, spare_cycles, since_last_background_cycles } = reading
        else {
            panic!("{}: {reading:?}", p.name)
        };
        assert_eq!(Some(longest_gap_cycles), m.longest_interval_cycles, "{}", p.name);
        assert_eq!(Some(spare_cycles as i64), m.margin_cycles(), "{}", p.name);
        assert_eq!(since_last_background_cycles, None);
    }
}

/// The readings tell the readings of the manuals apart: X:$25 = 4096 is the reload under
/// UM p.215's I40 = 0 reading and above it under SRM p.57's 4095; X:$25 = -1 is the counter gone
/// below zero, which SRM p.57 allows (a card 44 cycles from its trip) and UM p.215's counter,
/// which stops at zero, never shows.
#[test]
fn x25_readings_of_4096_and_minus_1_each_rule_out_one_reading_of_the_reload() {
    let um = config("um-215");
    let srm = config("srm-57");
    let load = um.loads[0];
    let seen = |r: margin::ReadingMargin| matches!(r, margin::ReadingMargin::Seen { .. });
    assert!(seen(margin::from_readings(&um, load, 4096, None)));
    assert!(!seen(margin::from_readings(&srm, load, 4096, None)));
    assert!(!seen(margin::from_readings(&um, load, -1, None)));
    let margin::ReadingMargin::Seen { longest_gap_cycles, spare_cycles, .. } =
        margin::from_readings(&srm, load, -1, None)
    else {
        panic!("SRM p.57's counter goes below zero")
    };
    assert_eq!(longest_gap_cycles, 4096, "4095 down to -1");
    let trip = margin::measure(&srm, load).trip_after_cycles;
    assert_eq!(longest_gap_cycles + spare_cycles + 1, trip, "the reading sits on the way to the trip");
}

/// Y:$25 is the counter now and X:$25 its lowest value since reset, so Y below X is no card's
/// reading; Y above X says how long ago the last background cycle was.
#[test]
fn y25_below_x25_is_impossible_and_above_it_dates_the_last_background_cycle() {
    let cfg = config("um-215");
    let load = cfg.loads[0];
    assert!(matches!(margin::from_readings(&cfg, load, 4000, Some(3999)), margin::ReadingMargin::Impossible(_)));
    let margin::ReadingMargin::Seen { since_last_background_cycles, .. } =
        margin::from_readings(&cfg, load, 4000, Some(4090))
    else {
        panic!("possible")
    };
    assert_eq!(since_last_background_cycles, Some(6), "4096 down to 4090");
}

/// UM p.236: a PLC 0 that grows too long makes communications and background PLCs sluggish
/// first, and only in the worst case trips the watchdog. In the model the background cycle is
/// where a host command is answered and a background PLC scans (UM p.236), so sluggishness is
/// the interval between background cycles: it grows with PLC 0 while the card still runs, and
/// only past the last load that leaves the background any time does the card trip. (MODEL: the
/// model answers a command at once, with no latency of its own; docs/model.md.)
#[test]
fn a_longer_plc0_first_spaces_the_background_cycles_out_and_only_then_starves_them() {
    let cfg = config("um-215");
    let mut last = 0;
    let mut running_loads = 0;
    let mut tripped_at = None;
    // Up to 276 units, which fill every RTI period of i40-zero (8 motors leave 92 units a cycle,
    // RTI every 3 cycles). Beyond that PLC 0 overruns its period, is not restarted at the next
    // RTI (UM p.236) and so leaves the background some time again: a different story.
    for plc0_units in (0..=260).step_by(20).chain([270, 276]) {
        let m = margin::measure(&cfg, Load { plc0_units, ..cfg.loads[0] });
        match m.longest_interval_cycles {
            Some(interval) => {
                assert!(tripped_at.is_none(), "PLC 0 {plc0_units}: the background came back after starving");
                assert!(interval >= last, "PLC 0 {plc0_units}: the interval shrank ({last} -> {interval})");
                assert!(!m.tripped, "{m:?}");
                last = interval;
                running_loads += 1;
            }
            None => tripped_at = tripped_at.or(Some(plc0_units)),
        }
    }
    // Sluggish before starved: several loads run with ever longer intervals, then one trips.
    assert!(running_loads >= 3 && last > 3, "intervals up to {last} over {running_loads} loads");
    assert_eq!(tripped_at, Some(276), "the PLC 0 that fills every RTI period starves the background");
}

#[test]
fn microseconds_are_the_configuration_s_units_of_a_servo_cycle_rounded_up() {
    // i40-zero: 100 units in a servo cycle of 1,000,000 / 2250 = 444.44 µs (UM p.236), so a
    // unit is 4.444 µs and its 30 units of PLC 0 are 133.33 µs.
    let cfg = config("um-215");
    assert!((margin::us_per_unit(&cfg) - 4.444_444).abs() < 1e-5);
    assert_eq!(margin::units_of_us(&cfg, 0.0), Ok(0));
    assert_eq!(margin::units_of_us(&cfg, 133.333_333_333), Ok(30));
    assert_eq!(margin::units_of_us(&cfg, 133.0), Ok(30));
    // Past a whole unit, the part of the next one counts: the load is never less than given.
    assert_eq!(margin::units_of_us(&cfg, 133.4), Ok(31));
    assert_eq!(margin::units_of_us(&cfg, 1111.0), Ok(250));
    for bad in [-1.0, f64::NAN, f64::INFINITY, 300_000.0] {
        assert!(margin::units_of_us(&cfg, bad).is_err(), "{bad}");
    }
    // At another servo clock a unit is the same share of a shorter cycle.
    let mut fast = cfg.clone();
    fast.servo_hz = 4500;
    assert_eq!(margin::units_of_us(&fast, 133.333_333_333), Ok(60));
}

#[test]
fn a_plc0_ending_exactly_at_an_rti_makes_the_margin_rise_with_the_load_and_its_neighbours_say_so() {
    // i40-zero under um-215: 275 units of PLC 0 leave a margin, 276 starve the background (it
    // ends exactly at the RTI), 277 leave more margin than 275: not monotonic.
    let cfg = config("um-215");
    let at = |plc0_units: u16| Load { plc0_units, ..cfg.loads[0] };
    for units in [276, 277] {
        let found = margin::not_monotonic(&cfg, at(units));
        assert_eq!(found.len(), 1, "{units}: {found:?}");
        let n = &found[0];
        assert_eq!(n.cost, margin::Cost::Plc0);
        assert_eq!(n.units, vec![units - 1, units, units + 1]);
        for (u, m) in n.units.iter().zip(&n.margin_cycles) {
            assert_eq!(*m, margin::measure(&cfg, at(*u)).margin_cycles(), "{u}");
        }
        assert!(n.margin_cycles.contains(&None), "{n:?}");
    }
    // The shipped load and one unit short of the starving one are monotonic around them.
    for units in [30, 275] {
        assert_eq!(margin::not_monotonic(&cfg, at(units)), vec![], "{units}");
    }
    assert_eq!(margin::not_monotonic(&cfg, Load { plc0_units: 0, ..cfg.loads[0] }), vec![]);
}
