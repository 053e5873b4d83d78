//! `pmacwd check --save DIR` writes every counterexample and witness as a trace. A saved path is
//! only worth keeping if `pmacwd run` gives back what the checker saw: these tests write the
//! witnesses of real checker runs as trace files, read them back as `run` reads them, and run
//! them on the model with every observation of the path expected at every step.

use pmacwd_conformance::check::{planned_runs, run, Selection};
use pmacwd_conformance::path_trace::{file_name, path_trace, paths_to_save, reproduces, Outcome};
use pmacwd_specs::Spec;

/// Checks `configuration` under every profile check.yaml runs it with, and returns how many
/// paths were saved and reproduced, failing on the first that `run` does not reproduce.
fn every_path_reproduces(configuration: &str) -> usize {
    let spec = Spec::embedded().unwrap();
    let sel = Selection { profile: None, configuration: Some(configuration.into()) };
    let mut reproduced = 0;
    for cfg in planned_runs(&spec, &sel).unwrap() {
        let report = run(cfg, 1);
        assert!(report.complete, "{configuration} must be checked exhaustively");
        for p in &report.properties {
            let Some(trace) = path_trace(&spec, &report, p) else { continue };
            reproduced += 1;
            match reproduces(&spec, &trace) {
                Ok(expectations) => {
                    assert!(expectations > 0, "{} saved a path with nothing expected", file_name(&report, p))
                }
                Err(e) => panic!(
                    "{} does not reproduce under `pmacwd run`: {e:?}\n{}",
                    file_name(&report, p),
                    pmacwd_trace::to_yaml(&trace)
                ),
            }
        }
    }
    reproduced
}

/// The `timing` configuration's witnesses (the trip, the recovery, the counter's values) are
/// paths of servo cycles, background cycles and commands: each one, saved as a trace, runs on
/// the model with every observation the checker made.
#[test]
fn every_witness_of_the_timing_configuration_reproduces_as_a_trace() {
    assert!(every_path_reproduces("timing") >= 10, "timing has many sometimes properties");
}

/// The `motion` configuration's witnesses start and stop motors. The checker explores every
/// deceleration length, while a trace decelerates for the longest, so a shortest witness that
/// chose a shorter one does not reproduce (holding a program is one: `&1H`, one servo cycle,
/// held). `--save` then saves the shortest path with the longest decelerations: this checks
/// that every witness is saved one way or the other, and that both ways occur.
#[test]
fn every_witness_of_the_motion_configuration_is_saved_as_a_trace_that_reproduces() {
    let spec = Spec::embedded().unwrap();
    let sel = Selection { profile: None, configuration: Some("motion".into()) };
    let (mut direct, mut longest) = (0, 0);
    for cfg in planned_runs(&spec, &sel).unwrap() {
        let report = run(cfg.clone(), 1);
        for saved in paths_to_save(&spec, &cfg, &report, true, 1) {
            match saved.outcome {
                Outcome::Saved { trace, .. } => {
                    reproduces(&spec, &trace).unwrap();
                    direct += 1;
                }
                Outcome::SavedLongestDecelerations { trace, .. } => {
                    reproduces(&spec, &trace).unwrap();
                    longest += 1;
                }
                Outcome::AtPowerUp => {}
                Outcome::NotReproducible(why) => panic!("{}: {why}", saved.file_name),
            }
        }
    }
    assert!(direct >= 10, "most witnesses need no deceleration choice ({direct})");
    assert!(longest >= 1, "holding a program needs one ({longest})");
}

/// A counterexample is saved whatever `witnesses` says; a witness only when asked.
#[test]
fn witnesses_are_saved_only_when_asked() {
    let spec = Spec::embedded().unwrap();
    let sel = Selection { profile: None, configuration: Some("timing".into()) };
    let cfg = planned_runs(&spec, &sel).unwrap().remove(0);
    let report = run(cfg.clone(), 1);
    assert!(report.all_hold(), "timing holds every property, so it has no counterexample");
    assert!(paths_to_save(&spec, &cfg, &report, false, 1).is_empty());
    assert!(!paths_to_save(&spec, &cfg, &report, true, 1).is_empty());
}

/// A saved file's name says where the path came from and stays a plain file name.
#[test]
fn saved_file_names_name_configuration_profile_and_property() {
    let spec = Spec::embedded().unwrap();
    let sel = Selection { profile: None, configuration: Some("timing".into()) };
    let cfg = planned_runs(&spec, &sel).unwrap().remove(0);
    let report = run(cfg, 1);
    let p = report.properties.iter().find(|p| p.path.is_some()).unwrap();
    let name = file_name(&report, p);
    assert!(name.starts_with(&format!("timing-{}-", report.profile)), "{name}");
    assert!(name.ends_with(".yaml"));
    assert!(name.chars().all(|c| c.is_ascii_alphanumeric() || "-_.".contains(c)), "{name}");
}
