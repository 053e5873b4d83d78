//! The model check as CI runs it: every profile at the embedded configurations, with the
//! state counts pinned so that any change to the semantics or the state shows up here first.

use pmacwd_conformance::check::{planned_runs, run, Selection};
use pmacwd_model::checker::{Canary, WatchdogModel};
use pmacwd_model::properties::Expectation;
use pmacwd_specs::config::ModelConfig;
use pmacwd_specs::Spec;
use std::collections::{BTreeMap, BTreeSet};

/// (configuration, profile) -> unique states. Update deliberately, saying why in the commit.
const PINNED_STATES: &[(&str, &str, usize)] = &[
    ("timing", "um-215", 57_536),
    ("timing", "srm-57", 59_968),
    ("timing", "srm-57-sticky-bit9", 65_464),
    ("timing", "um-215-4095", 57_536),
    ("timing", "um-215-50hz", 57_536),
    ("timing", "um-215-literal-plc", 57_536),
    ("timing", "um-215-m83", 57_536),
    // UM p.243's modulo (um-243-modulo): the configurations assign nothing out of range, so
    // the counts are um-215's.
    ("timing", "um-243-modulo", 57_536),
    // The full-period detector (issue 36): the configurations fix the delay in cycles, so the
    // counts are um-215's; at i40-zero its delay is 90 cycles, and still um-215's count.
    ("timing", "um-215-full-period", 57_536),
    // The wider bound that reaches every observation class (model/tests/leaps.rs).
    ("timing-wide", "um-215", 193_480),
    ("timing-wide", "srm-57", 385_736),
    ("timing-wide", "um-215-4095", 193_480),
    ("timing-wide", "um-215-50hz", 193_480),
    // A reset keeps a checksum corruption (issue 35): a pass after the reset finds it again.
    ("status", "um-215", 52_056),
    ("status", "srm-57", 63_480),
    ("status", "srm-57-sticky-bit9", 63_480),
    ("status", "um-215-4095", 52_056),
    ("status", "um-215-50hz", 52_056),
    ("status", "um-215-literal-plc", 52_056),
    ("status", "um-215-m83", 52_056),
    ("status", "um-243-modulo", 52_056),
    ("status", "um-215-full-period", 52_056),
    ("lockout", "um-215", 5_112),
    ("lockout", "srm-57", 6_264),
    ("lockout", "srm-57-sticky-bit9", 6_264),
    ("lockout", "um-215-4095", 5_112),
    ("lockout", "um-215-50hz", 5_112),
    ("lockout", "um-215-literal-plc", 5_112),
    ("lockout", "um-215-m83", 5_112),
    ("lockout", "um-243-modulo", 5_112),
    ("lockout", "um-215-full-period", 5_112),
    // I41 bits 2 and 3 each alone (issue 35), apart from `lockout` (check.yaml says why).
    ("lockout-ic", "um-215", 1_224),
    ("lockout-ic", "srm-57", 1_512),
    // The supply and servo-work edges (issue 35).
    ("edges", "um-215", 1_780),
    ("edges", "srm-57", 2_236),
    ("i40-zero", "um-215", 3_578),
    ("i40-zero", "srm-57", 17_840),
    ("i40-zero", "um-215-4095", 3_668),
    ("i40-zero", "um-215-50hz", 3_578),
    ("i40-zero", "um-215-full-period", 3_578),
    ("motion", "um-215", 52_402),
    ("motion", "srm-57", 64_166),
    ("encoder-loss", "um-215", 14_680),
    ("encoder-loss", "srm-57", 17_880),
    ("encoder-loss", "srm-57-sticky-bit9", 17_880),
    ("encoder-loss", "um-215-4095", 14_680),
    ("encoder-loss", "um-215-50hz", 14_680),
    // The literal reading of the clear logic never clears a latched loss: fewer states.
    ("encoder-loss", "um-215-literal-plc", 11_064),
    ("encoder-loss", "um-215-m83", 14_680),
    ("encoder-loss", "um-243-modulo", 14_680),
    ("encoder-loss", "um-215-full-period", 14_680),
    // Two motors in two coordinate systems: the PLC's CMD^K kills both (UM p.214-215).
    ("encoder-loss-2", "um-215", 74_688),
    ("encoder-loss-2", "um-215-literal-plc", 65_984),
    // The firmware's amplifier-fault kill (issue 35, UM p.213).
    ("amplifier-fault", "um-215", 16_800),
    ("amplifier-fault", "srm-57", 21_488),
    ("amplifier-fault", "srm-57-sticky-bit9", 21_488),
    ("amplifier-fault", "um-215-4095", 16_800),
    ("amplifier-fault", "um-215-50hz", 16_800),
    ("amplifier-fault", "um-215-literal-plc", 16_800),
    ("amplifier-fault", "um-215-m83", 16_800),
    ("amplifier-fault", "um-243-modulo", 16_800),
    ("amplifier-fault", "um-215-full-period", 16_800),
];

#[test]
fn every_property_holds_for_every_profile_and_the_state_counts_are_the_pinned_ones() {
    let spec = Spec::embedded().unwrap();
    let runs = planned_runs(&spec, &Selection::default()).unwrap();
    assert_eq!(runs.len(), PINNED_STATES.len(), "a run was added or removed: pin its state count");
    let mut reached: BTreeMap<String, BTreeSet<&'static str>> = BTreeMap::new();
    for cfg in runs {
        let report = run(cfg, 2);
        for p in &report.properties {
            assert!(
                p.holds,
                "{} / {}: `{}` fails; run `pmacwd check --configuration {} --profile {}`",
                report.configuration, report.profile, p.name, report.configuration, report.profile
            );
            if p.expectation == Expectation::Sometimes && p.applicable {
                reached.entry(report.profile.clone()).or_default().insert(p.name);
            }
        }
        let pinned = PINNED_STATES
            .iter()
            .find(|(c, p, _)| *c == report.configuration && *p == report.profile)
            .unwrap_or_else(|| panic!("no pinned count for {} / {}", report.configuration, report.profile));
        assert_eq!(report.states, pinned.2, "state count of {} / {} changed", report.configuration, report.profile);
    }
    // A `sometimes` property that no configuration of a profile reaches would be reported as
    // "n/a" everywhere and prove nothing: each must be reached somewhere, under every profile.
    let all: BTreeSet<&str> = pmacwd_model::checker::property_table()
        .iter()
        .filter(|p| p.expectation == Expectation::Sometimes)
        .map(|p| p.name)
        .collect();
    for profile in spec.profiles.profiles.keys() {
        let missing: Vec<_> = all.difference(reached.get(profile).unwrap_or(&BTreeSet::new())).copied().collect();
        assert!(missing.is_empty(), "profile {profile}: never reached {missing:?}");
    }
}

#[test]
fn there_are_at_least_25_named_properties_each_with_a_citation() {
    let table = pmacwd_model::checker::property_table();
    assert!(table.len() >= 25, "{} properties", table.len());
    let names: BTreeSet<_> = table.iter().map(|p| p.name).collect();
    assert_eq!(names.len(), table.len(), "property names are unique");
    for p in &table {
        pmacwd_specs::cite::Cite::parse(p.cite.split(';').next().unwrap())
            .unwrap_or_else(|e| panic!("{}: {e}", p.name));
        assert!(!p.sentence.is_empty());
    }
}

fn canary(canary: Canary, configuration: &str) -> pmacwd_model::checker::RunReport {
    let spec = Spec::embedded().unwrap();
    let cfg = ModelConfig::from_spec(&spec, configuration, &spec.profiles.default_profile()).unwrap();
    WatchdogModel {
        cfg,
        canary: Some(canary),
        detailed: false,
        longest_decelerations_only: false,
        named_properties: false,
    }
    .check(2)
}

#[test]
fn canary_a_model_that_ignores_i41_is_caught_with_the_shortest_counterexample() {
    // The checker must be able to fail: a model whose locked writes take effect.
    let report = canary(Canary::LockoutIgnored, "lockout");
    let p = report
        .properties
        .iter()
        .find(|p| p.name == "a locked I-variable never changes through an I-variable write")
        .unwrap();
    assert!(!p.holds);
    let path = p.path.as_ref().expect("a counterexample is reported");
    let events: Vec<String> = path.iter().map(|s| s.event.to_string()).collect();
    // Shortest: lock motor setup, then write a motor-setup variable.
    assert_eq!(events, ["host sends `I41=1`", "host sends `I130=1`"]);
}

#[test]
fn canary_a_model_whose_trip_is_not_latched_is_caught() {
    // A good supply alone must not undo an undervoltage trip (UM p.215: latched).
    let report = canary(Canary::SupplyRestoreUntrips, "timing");
    let p = report.properties.iter().find(|p| p.name == "a trip is undone only by INIT/ or a power cycle").unwrap();
    assert!(!p.holds);
    let events: Vec<String> = p.path.as_ref().unwrap().iter().map(|s| s.event.to_string()).collect();
    assert_eq!(events, ["supply 4.500 V", "supply 5.000 V"]);
}

#[test]
fn canary_a_model_whose_trip_leaves_amplifiers_enabled_is_caught() {
    // UM p.215: a trip holds the Servo ICs in reset, outputs off. A model that leaves an enabled
    // amplifier on must fail the trip property, with the shortest path: enable, sag the supply.
    let report = canary(Canary::TripLeavesAmplifiersOn, "motion");
    let p = report
        .properties
        .iter()
        .find(|p| p.name == "after a trip every amplifier is disabled, every output zero and no motor moves")
        .unwrap();
    assert!(!p.holds);
    let events: Vec<String> = p.path.as_ref().unwrap().iter().map(|s| s.event.to_string()).collect();
    assert_eq!(events, ["host sends `#1J/`", "supply 4.500 V"]);
}

#[test]
fn the_fast_check_with_conjoined_always_properties_agrees_with_the_detailed_one() {
    // `check` gives stateright the `always` properties as two conjunctions for speed; with
    // every property separate it must reach the same states and the same verdicts.
    let spec = Spec::embedded().unwrap();
    for name in ["status", "lockout"] {
        let cfg = ModelConfig::from_spec(&spec, name, &spec.profiles.default_profile()).unwrap();
        let fast = WatchdogModel {
            cfg: cfg.clone(),
            canary: None,
            detailed: false,
            longest_decelerations_only: false,
            named_properties: false,
        }
        .check(2);
        let detailed = WatchdogModel {
            cfg,
            canary: None,
            detailed: true,
            longest_decelerations_only: false,
            named_properties: false,
        }
        .check(2);
        assert_eq!(fast.states, detailed.states, "{name}");
        let verdicts = |r: &pmacwd_model::checker::RunReport| {
            r.properties.iter().map(|p| (p.name, p.holds, p.path.as_ref().map(Vec::len))).collect::<Vec<_>>()
        };
        assert_eq!(verdicts(&fast), verdicts(&detailed), "{name}");
    }
}

#[test]
fn a_run_stopped_at_the_state_bound_is_marked_incomplete_and_earns_no_verdict() {
    // A configuration too large to explore (a real I40 with single servo cycles) used to grow
    // for an hour; the checker now stops at a bound and the report says it is incomplete, so
    // that `check` exits 2 instead of printing `sometimes` properties as NEVER reached.
    let spec = Spec::embedded().unwrap();
    let cfg = ModelConfig::from_spec(&spec, "timing", &spec.profiles.default_profile()).unwrap();
    let cut = WatchdogModel::new(cfg.clone()).check_bounded(1, 1_000);
    assert!(!cut.complete, "{} states", cut.states);
    let text = pmacwd_conformance::check::format_report(&cut, "um-215", false);
    assert!(text.contains("INCOMPLETE"), "{text}");
    assert!(WatchdogModel::new(cfg).check(2).complete);
}

#[test]
fn a_run_cut_by_the_bound_is_incomplete_even_when_it_found_fewer_distinct_states_than_the_bound() {
    // Issue 15's input: `timing` with I40 = 65535 and a 65535-cycle hardware delay (both in
    // range). Stateright stops once it has generated the bound's number of states, duplicates
    // included; the report compared the distinct states with the bound, called the cut run
    // complete and printed "the card can trip on a starved background" as NEVER reached.
    let spec = Spec::embedded().unwrap();
    let mut cfg = ModelConfig::from_spec(&spec, "timing", &spec.profiles.default_profile()).unwrap();
    cfg.saved.i40 = 65535;
    cfg.hardware_delay_cycles = 65535;
    cfg.hardware_delay_band = (65535, 65535);
    let bound = 100_000;
    let cut = WatchdogModel::new(cfg).check_bounded(1, bound);
    assert!(cut.states < bound, "the distinct states ({}) stay under the bound", cut.states);
    assert!(!cut.complete, "a run the bound stopped is not complete ({} distinct states)", cut.states);
}

#[test]
fn a_watched_run_reports_growing_counts_and_ends_with_the_same_report_as_an_unwatched_one() {
    // `check` shows progress while a run explores (join_observed); watching must not change
    // what the run finds, every count it reports is one the run passes through on its way to
    // the final count, and a run longer than two intervals is reported on at least once.
    use pmacwd_model::checker::{Explored, PROGRESS_INTERVAL};
    let spec = Spec::embedded().unwrap();
    let cfg = ModelConfig::from_spec(&spec, "timing", &spec.profiles.default_profile()).unwrap();
    let mut seen: Vec<Explored> = Vec::new();
    let watched = WatchdogModel::new(cfg.clone()).check_observed(1, &mut |e| seen.push(e));
    let plain = WatchdogModel::new(cfg).check(1);
    assert_eq!((watched.states, watched.depth, watched.complete), (plain.states, plain.depth, plain.complete));
    let verdicts =
        |r: &pmacwd_model::checker::RunReport| r.properties.iter().map(|p| (p.name, p.holds)).collect::<Vec<_>>();
    assert_eq!(verdicts(&watched), verdicts(&plain));
    assert!(seen.windows(2).all(|w| w[0].states <= w[1].states && w[0].depth <= w[1].depth), "{seen:?}");
    assert!(seen.iter().all(|e| e.states <= watched.states && e.depth <= watched.depth), "{seen:?}");
    if watched.duration >= 2 * PROGRESS_INTERVAL {
        assert!(!seen.is_empty(), "a run of {:?} was never reported on", watched.duration);
    }
}
