//! The compact core against the reference model in lockstep.
//!
//! - Generated traces: 10,000 cases of up to 1,000 events over every (configuration, profile)
//!   pair, weighted toward the edges (see `pmacwd_conformance::generate`). The seed is printed
//!   first; `PMACWD_SEED=n cargo test -p pmacwd-conformance --test lockstep` reruns one. A divergence is shrunk to a
//!   minimal trace, printed, and saved in `conformance/regressions/` (commit it: every later run
//!   replays it).
//! - Regression files: every trace in `conformance/regressions/` must run in lockstep.
//! - The scenario library: every scenario, under every profile it names, on the core: lockstep
//!   with the model and the scenario's expectations checked on the core's own observations.
//! - Long gaps: one `Servo { n }` event equals n single cycles.

use pmacwd_conformance::generate::{self, Settings};
use pmacwd_conformance::lockstep::differences;
use pmacwd_conformance::runner::{profiles_of, run_on_subject, Failure};
use pmacwd_conformance::subject::{CoreSubject, ModelSubject, Subject};
use pmacwd_specs::vocab::event::Event;
use pmacwd_specs::Spec;
use pmacwd_trace::{load_yaml, to_yaml};
use std::path::{Path, PathBuf};

fn yaml_files(dir: &Path) -> Vec<PathBuf> {
    let mut files: Vec<PathBuf> = std::fs::read_dir(dir)
        .unwrap_or_else(|e| panic!("{}: {e}", dir.display()))
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "yaml"))
        .collect();
    files.sort();
    files
}

fn regressions_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("regressions")
}

/// The seed: `PMACWD_SEED` when set (to rerun a failure), otherwise fresh, so CI keeps
/// exploring new cases while every failure stays reproducible from the printed seed.
fn seed() -> u64 {
    match std::env::var("PMACWD_SEED") {
        Ok(s) => s.parse().unwrap_or_else(|_| panic!("PMACWD_SEED must be a number, not `{s}`")),
        Err(_) => generate::fresh_seed(),
    }
}

#[test]
fn ten_thousand_generated_traces_observe_the_same_on_the_core_as_on_the_model() {
    let spec = Spec::embedded().unwrap();
    let configs = generate::all_configs(&spec).unwrap();
    // PMACWD_LOCKSTEP_CASES lowers the count where time matters more than depth (the
    // mutation run in .cargo/mutants.toml); CI runs the full 10,000.
    let cases = std::env::var("PMACWD_LOCKSTEP_CASES").ok().and_then(|s| s.parse().ok()).unwrap_or(10_000);
    let settings = Settings { cases, max_len: 1_000, seed: seed() };
    eprintln!("lockstep seed {} (rerun with PMACWD_SEED={})", settings.seed, settings.seed);
    match generate::run::<CoreSubject>(&configs, settings, &|_| {}, &mut |_, _, _| {}) {
        Ok(stats) => {
            eprintln!("{} traces, {} events, no divergence", stats.traces, stats.events);
            assert_eq!(stats.traces, cases);
        }
        Err(found) => {
            let path = regressions_dir().join(found.file_name());
            let yaml = to_yaml(&found.to_trace());
            std::fs::create_dir_all(regressions_dir()).unwrap();
            std::fs::write(&path, &yaml).unwrap();
            panic!(
                "the core diverged from the model under {} / {}: {}\nshrunk trace, saved as {}:\n{yaml}",
                found.configuration,
                found.profile,
                found.disagreement,
                path.display()
            );
        }
    }
}

/// UM p.243's reading of an out-of-range assignment (`out_of_range_assignment: modulo`, chosen
/// by `um-243-modulo` only): generated traces under it, every
/// configuration with the default profile, keep the core and the model together. The
/// generator's commands include `I41=16`, `I40=65536` and `I8=256`; the test counts that some
/// were sent. A divergence is printed, not saved (a regression file replays under `error`).
#[test]
fn generated_traces_under_the_modulo_reading_observe_the_same_on_the_core_as_on_the_model() {
    use pmacwd_specs::profiles::OutOfRangeAssignment;
    use pmacwd_specs::vocab::command::HostCommand;
    let spec = Spec::embedded().unwrap();
    let default = spec.profiles.default_profile();
    let configs: Vec<_> = generate::all_configs(&spec)
        .unwrap()
        .into_iter()
        .filter(|c| c.profile == default)
        .map(|mut c| {
            c.profile.choices.out_of_range_assignment = OutOfRangeAssignment::Modulo;
            c
        })
        .collect();
    let settings = Settings { cases: 500, max_len: 300, seed: seed() };
    eprintln!("lockstep (modulo) seed {} (rerun with PMACWD_SEED={})", settings.seed, settings.seed);
    let mut beyond = 0usize;
    let mut count = |cfg: &pmacwd_specs::config::ModelConfig, ev: &Event, _: &ModelSubject| {
        if let Event::Command(HostCommand::WriteI(n, v) | HostCommand::WriteIMemory(n, v)) = ev {
            let range = match n {
                8 => cfg.i8_range,
                40 => cfg.i40_range,
                41 => cfg.i41_range,
                _ => return,
            };
            beyond += usize::from(!(range.0..=range.1).contains(v));
        }
    };
    match generate::run::<CoreSubject>(&configs, settings, &|_| {}, &mut count) {
        Ok(stats) => assert_eq!(stats.traces, 500),
        Err(found) => panic!(
            "the core diverged from the model under {} / {} with modulo: {}\n{}",
            found.configuration,
            found.profile,
            found.disagreement,
            to_yaml(&found.to_trace())
        ),
    }
    assert!(beyond > 0, "no out-of-range assignment was generated");
}

/// Runs the trace in `file` on the core in lockstep with the model under every profile it
/// names; returns the expectations checked on the core and one line per failure.
fn run_on_core(spec: &Spec, file: &Path) -> (usize, Vec<String>) {
    let loaded = load_yaml(file).unwrap_or_else(|e| panic!("{e}"));
    let (mut checked, mut failures) = (0, Vec::new());
    for profile in profiles_of(spec, &loaded).unwrap() {
        match run_on_subject::<CoreSubject>(spec, &loaded, &profile) {
            Ok(n) => checked += n,
            Err(Failure::Unusable(e)) => failures.push(format!("{}: {e}", file.display())),
            Err(Failure::Diverged(d)) => failures.push(format!("{} under {}: {d}", file.display(), profile.name)),
        }
    }
    (checked, failures)
}

/// Each file is a shrunk divergence found once (its description says how); the bug is fixed
/// when it runs in lockstep again, and it must stay so. (Regression traces carry no
/// expectations: the model after every event is the expectation.)
#[test]
fn every_saved_regression_trace_runs_in_lockstep() {
    let spec = Spec::embedded().unwrap();
    let files = yaml_files(&regressions_dir());
    assert!(!files.is_empty(), "the regression directory keeps at least its first case");
    let failures: Vec<String> = files.iter().flat_map(|f| run_on_core(&spec, f).1).collect();
    assert!(failures.is_empty(), "{} failures:\n{}", failures.len(), failures.join("\n"));
}

#[test]
fn every_scenario_holds_on_the_core_in_lockstep_with_the_model() {
    let spec = Spec::embedded().unwrap();
    let files = yaml_files(&Path::new(env!("CARGO_MANIFEST_DIR")).join("../specs/scenarios"));
    assert!(files.len() >= 30, "the library needs at least 30 scenarios; it has {}", files.len());
    let mut failures = Vec::new();
    let mut checked = 0;
    for file in &files {
        let (n, f) = run_on_core(&spec, file);
        checked += n;
        failures.extend(f);
    }
    assert!(failures.is_empty(), "{} failures:\n{}", failures.len(), failures.join("\n"));
    assert!(checked > 100, "{checked} expectations checked on the core");
}

/// `advance(n)` in one event equals n single servo cycles, over long gaps that cross the
/// strobe stop and the trip, for every configuration and profile.
#[test]
fn one_long_servo_event_equals_the_same_cycles_one_by_one() {
    let spec = Spec::embedded().unwrap();
    for cfg in generate::all_configs(&spec).unwrap() {
        for n in [1u32, 2, 3, 5, 7, 45, 46, 100, 4095, 4096, 4097, 4141, 4142, 5000, 10_000] {
            for load in &cfg.loads {
                let mut a = CoreSubject::power_on(&cfg);
                let mut b = ModelSubject::power_on(&cfg);
                a.apply(&Event::Load(*load));
                b.apply(&Event::Load(*load));
                let one = a.apply(&Event::Servo { cycles: n });
                for _ in 0..n - 1 {
                    b.apply(&Event::Servo { cycles: 1 });
                }
                let many = b.apply(&Event::Servo { cycles: 1 });
                // Compared as lockstep compares: every field, the motors included.
                let fields = differences(&many, &one);
                assert!(
                    fields.is_empty(),
                    "{} / {} load {load:?} n {n}: {fields:?}",
                    cfg.configuration,
                    cfg.profile.name
                );
            }
        }
    }
}

/// The model, except that it reports a counter of 0 as 1: a deliberate divergence, so that the
/// generator finds one and shrinks it.
struct CounterNeverZero(ModelSubject);

impl Subject for CounterNeverZero {
    fn name(&self) -> &'static str {
        "the model with a counter that never reads 0"
    }
    fn power_on(cfg: &pmacwd_specs::config::ModelConfig) -> Self {
        CounterNeverZero(ModelSubject::power_on(cfg))
    }
    fn background_possible(&self) -> bool {
        self.0.background_possible()
    }
    fn apply(&mut self, event: &Event) -> pmacwd_specs::vocab::Observation {
        let mut o = self.0.apply(event);
        if o.counter == 0 {
            o.counter = 1;
        }
        o
    }
}

/// The model, except that it claims a background cycle can complete once the counter is down
/// to 1 or below, whatever the load: a deliberate divergence in "background cycle possible",
/// which agrees at power-up and which only a `background` step used to reveal.
struct BackgroundPossibleNearZero(ModelSubject);

impl Subject for BackgroundPossibleNearZero {
    fn name(&self) -> &'static str {
        "the model with a background cycle possible near zero"
    }
    fn power_on(cfg: &pmacwd_specs::config::ModelConfig) -> Self {
        BackgroundPossibleNearZero(ModelSubject::power_on(cfg))
    }
    fn background_possible(&self) -> bool {
        self.0.background_possible() || self.0.controller().counter <= 1
    }
    fn apply(&mut self, event: &Event) -> pmacwd_specs::vocab::Observation {
        self.0.apply(event)
    }
}

/// A shrunk divergence in whether a background cycle can complete is saved ending with the
/// event after which the two differ, not with a `background` step: on a correct
/// implementation the saved trace replays in lockstep (the bug fixed, the regression passes),
/// where a trace ending with a `background` step that neither side can complete would fail
/// forever ("neither the model nor the implementation can complete one").
#[test]
fn a_background_divergence_is_saved_as_a_trace_a_fixed_implementation_replays() {
    let spec = Spec::embedded().unwrap();
    let configs = generate::all_configs(&spec).unwrap();
    let settings = Settings { cases: 200, max_len: 100, seed: 11 };
    let found = generate::run::<BackgroundPossibleNearZero>(&configs, settings, &|_| {}, &mut |_, _, _| {})
        .expect_err("a background cycle possible near zero diverges from the model");
    assert!(
        found.disagreement.to_string().contains("background cycle possible: model false, implementation true"),
        "{}",
        found.disagreement
    );
    assert_ne!(found.events.last(), Some(&Event::Background), "the trace ends before any background step");
    let yaml = to_yaml(&found.to_trace());
    let loaded = pmacwd_trace::parse_yaml(Path::new("regression.yaml"), &yaml).unwrap();
    for profile in profiles_of(&spec, &loaded).unwrap() {
        match run_on_subject::<CoreSubject>(&spec, &loaded, &profile) {
            Ok(_) => {}
            Err(Failure::Unusable(e)) => panic!("the saved trace does not run on the core: {e}\n{yaml}"),
            Err(Failure::Diverged(d)) => panic!("the core diverges on the saved trace: {d}\n{yaml}"),
        }
        assert!(
            run_on_subject::<BackgroundPossibleNearZero>(&spec, &loaded, &profile).is_err(),
            "the saved trace still catches the broken implementation"
        );
    }
}

#[test]
fn shrinking_a_divergence_reports_its_progress_case_by_case() {
    // `conform` and `check` show progress while traces are generated, and shrinking a divergence
    // (up to 50,000 smaller cases) must not look like a hang: every case tried is reported,
    // with the count of passed traces held where the divergence was found.
    use pmacwd_conformance::generate::RunProgress;
    let spec = Spec::embedded().unwrap();
    let configs = generate::all_configs(&spec).unwrap();
    let seen = std::cell::RefCell::new(Vec::<RunProgress>::new());
    let settings = Settings { cases: 1_000, max_len: 200, seed: 7 };
    let result =
        generate::run::<CounterNeverZero>(&configs, settings, &|p| seen.borrow_mut().push(p), &mut |_, _, _| {});
    let found = result.expect_err("a counter that never reads 0 diverges from the model");
    assert!(found.disagreement.to_string().contains("Y:$25: model 0, implementation 1"), "{}", found.disagreement);
    let seen = seen.into_inner();
    let shrinking: Vec<&RunProgress> = seen.iter().filter(|p| p.shrink_cases > 0).collect();
    assert!(!shrinking.is_empty(), "no shrink step was reported");
    assert!(shrinking.windows(2).all(|w| w[1].shrink_cases == w[0].shrink_cases + 1), "counted one by one");
    let passed = seen.iter().filter(|p| p.shrink_cases == 0).count() as u32;
    assert!(shrinking.iter().all(|p| p.traces == passed), "the passed traces stay as they were");
}
