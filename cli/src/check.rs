//! `pmacwd check`: the model check of every profile at the bounded configurations, then a
//! conformance summary of the core against the model.

use crate::common::{load_spec, plural, scenario_library};
use crate::conform::scenarios_on_core;
use crate::progress::{thousands, Progress};
use pmacwd_conformance::check::{format_report, planned_runs, run_observed, Selection};
use pmacwd_specs::Spec;
use std::cell::RefCell;
use std::path::PathBuf;
use std::process::ExitCode;

/// The options of `pmacwd check`.
pub struct CheckArgs {
    pub specs: Option<PathBuf>,
    pub profile: Option<String>,
    pub configuration: Option<String>,
    pub witnesses: bool,
    pub threads: Option<usize>,
    pub no_conformance: bool,
}

pub fn check(a: CheckArgs) -> ExitCode {
    let CheckArgs { specs, profile, configuration, witnesses, threads, no_conformance } = a;
    let spec = match load_spec(&specs) {
        Ok(s) => s,
        Err(code) => return code,
    };
    let runs = match planned_runs(&spec, &Selection { profile, configuration }) {
        Ok(r) if r.is_empty() => {
            eprintln!("pmacwd: the selection matches no run of {}", spec.dir.join("check.yaml").display());
            return ExitCode::from(2);
        }
        Ok(r) => r,
        Err(e) => {
            eprintln!("pmacwd: {e}");
            return ExitCode::from(2);
        }
    };
    let threads = match crate::common::threads(threads) {
        Ok(t) => t,
        Err(code) => return code,
    };
    let default_profile = spec.profiles.default_profile().name;
    println!(
        "pmacwd check: {} from {}, {}",
        plural(runs.len() as u64, "run", "runs"),
        spec.dir.display(),
        plural(threads as u64, "thread", "threads")
    );
    let (mut failures, mut incomplete) = (0usize, 0usize);
    let (mut states, mut seconds) = (0usize, 0f64);
    let mut progress = Progress::start("model check", runs.len() as u64, "runs");
    for (i, cfg) in runs.iter().cloned().enumerate() {
        let name = format!("{} / {}", cfg.configuration, cfg.profile.name);
        let done = i as u64;
        let report = run_observed(cfg, threads, &mut |e| {
            progress.update(done, || format!("{name}: {} states, depth {}", thousands(e.states as u64), e.depth))
        });
        progress.update(done + 1, String::new);
        states += report.states;
        seconds += report.duration.as_secs_f64();
        if !report.complete {
            incomplete += 1;
        } else if !report.all_hold() {
            failures += 1;
        }
        progress.print(&format_report(&report, &default_profile, witnesses));
    }
    progress.finish();
    println!(
        "total: {states} states in {seconds:.2} s ({:.0} states/s); {}",
        states as f64 / seconds.max(1e-9),
        if failures == 0 {
            "every property holds".to_string()
        } else {
            format!("{} with failing properties", plural(failures as u64, "run", "runs"))
        }
    );
    if incomplete > 0 {
        // A run cut short at the state bound proves nothing either way: unusable input.
        eprintln!(
            "pmacwd: {} stopped at the checker's state bound: no verdict for {}",
            plural(incomplete as u64, "run", "runs"),
            if incomplete == 1 { "it" } else { "them" }
        );
        return ExitCode::from(2);
    }
    let mut diverged = false;
    if !no_conformance {
        match conformance_summary(&spec, &runs, &specs, threads) {
            Ok(d) => diverged = d,
            Err(code) => return code,
        }
    }
    if failures == 0 && !diverged {
        ExitCode::SUCCESS
    } else {
        ExitCode::from(1)
    }
}

/// The conformance summary `pmacwd check` prints after the model check: the exhaustive product
/// of model and core at the checked runs, the scenario library on the core, and 1,000
/// generated traces. Returns whether anything diverged.
fn conformance_summary(
    spec: &Spec,
    runs: &[pmacwd_specs::config::ModelConfig],
    specs: &Option<PathBuf>,
    threads: usize,
) -> Result<bool, ExitCode> {
    use pmacwd_conformance::generate::{self, Settings};
    use pmacwd_conformance::subject::CoreSubject;
    println!("conformance summary: the compact core (impl/) against the model (`pmacwd conform` for the full suite and its coverage)");
    let mut diverged = false;
    let start = std::time::Instant::now();
    let mut pairs = 0;
    let mut progress = Progress::start("exhaustive lockstep", runs.len() as u64, "runs");
    for (i, cfg) in runs.iter().enumerate() {
        let name = format!("{} / {}", cfg.configuration, cfg.profile.name);
        let done = i as u64;
        let r = pmacwd_conformance::product::check_observed(cfg.clone(), threads, &mut |e| {
            progress.update(done, || format!("{name}: {} pair states", thousands(e.states as u64)))
        });
        progress.update(done + 1, String::new);
        pairs += r.states;
        if !r.complete {
            progress.println(&format!("  INCOMPLETE {} / {}: stopped at the state bound", r.configuration, r.profile));
            progress.finish();
            return Err(ExitCode::from(2));
        }
        if let Some((events, d)) = &r.divergence {
            diverged = true;
            let mut text = format!("  DIVERGED  {} / {}: {d}\n  shortest path:\n", r.configuration, r.profile);
            for e in events {
                text.push_str(&format!("      {e}\n"));
            }
            progress.print(&text);
        }
    }
    progress.finish();
    println!(
        "  exhaustive lockstep: {pairs} pair states over {} runs, {} ({:.1} s)",
        runs.len(),
        if diverged { "DIVERGED" } else { "no divergence" },
        start.elapsed().as_secs_f64()
    );
    // A copy of the spec directory without its scenarios is checked without them.
    let missing = specs.as_ref().map(|d| d.join("scenarios")).filter(|d| !d.is_dir());
    if let Some(dir) = missing {
        println!("  scenarios: {} not found, skipped", dir.display());
    } else {
        let files = scenario_library(specs).map_err(|e| {
            eprintln!("pmacwd: {e}");
            ExitCode::from(2)
        })?;
        let tally = scenarios_on_core(spec, &files, &mut Default::default())?;
        diverged |= tally.diverged;
        println!(
            "  scenarios: {}, {}, {} met by the core{}",
            plural(files.len() as u64, "file", "files"),
            plural(tally.runs as u64, "scenario-profile run", "scenario-profile runs"),
            plural(tally.expectations as u64, "expectation", "expectations"),
            if tally.diverged { ", DIVERGED" } else { "" }
        );
    }
    let configs = generate::all_configs(spec).map_err(|e| {
        eprintln!("pmacwd: {e}");
        ExitCode::from(2)
    })?;
    let seed = generate::fresh_seed();
    let start = std::time::Instant::now();
    let cases = 1_000;
    let progress = RefCell::new(Progress::start("generated traces", u64::from(cases), "traces"));
    let outcome = generate::run::<CoreSubject>(
        &configs,
        Settings { cases, max_len: 1_000, seed },
        &|done| progress.borrow_mut().update(u64::from(done), String::new),
        &mut |_, _, _| {},
    );
    progress.into_inner().finish();
    match outcome {
        Ok(stats) => println!(
            "  generated: {} traces, {} events, seed {seed}, no divergence ({:.1} s)",
            stats.traces,
            stats.events,
            start.elapsed().as_secs_f64()
        ),
        Err(found) => {
            diverged = true;
            println!(
                "  generated: seed {seed}, DIVERGED under {} / {}: {}",
                found.configuration, found.profile, found.disagreement
            );
            print!("{}", pmacwd_trace::to_yaml(&found.to_trace()));
        }
    }
    Ok(diverged)
}
