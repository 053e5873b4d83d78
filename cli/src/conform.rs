//! `pmacwd conform`: the conformance suite against the compact core, with its coverage.

use crate::common::{load_spec, plural, scenario_library, trace_files, TraceFile};
use crate::progress::{thousands, Progress};
use pmacwd_conformance::check::{planned_runs, Selection};
use pmacwd_specs::Spec;
use std::cell::RefCell;
use std::path::PathBuf;
use std::process::ExitCode;

pub struct ConformArgs {
    pub cases: u32,
    pub max_len: usize,
    pub seed: Option<u64>,
    pub scenarios: Option<PathBuf>,
    pub specs: Option<PathBuf>,
    pub no_exhaustive: bool,
    pub save_regressions: PathBuf,
    pub threads: Option<usize>,
}

pub fn conform(a: ConformArgs) -> ExitCode {
    use pmacwd_conformance::coverage::Coverage;
    use pmacwd_conformance::generate::{self, Settings};
    use pmacwd_conformance::subject::CoreSubject;
    // Options are checked before any work starts.
    let threads = match crate::common::threads(a.threads) {
        Ok(t) => t,
        Err(code) => return code,
    };
    if a.max_len == 0 {
        return crate::common::unusable("--max-len 0: a generated trace has at least 1 step");
    }
    let spec = match load_spec(&a.specs) {
        Ok(s) => s,
        Err(code) => return code,
    };
    let found = match &a.scenarios {
        Some(dir) => trace_files(std::slice::from_ref(dir)),
        None => scenario_library(&a.specs),
    };
    let files = match found {
        Ok(f) => f,
        Err(e) => {
            eprintln!("pmacwd: {e}");
            return ExitCode::from(2);
        }
    };
    let mut coverage = Coverage::default();
    let mut diverged = false;
    let start = std::time::Instant::now();

    println!("== scenarios on the core, in lockstep with the model");
    match scenarios_on_core(&spec, &files, &mut coverage) {
        Ok(tally) => {
            diverged |= tally.diverged;
            println!(
                "{}, {}, {} met by the core",
                plural(files.len() as u64, "scenario", "scenarios"),
                plural(tally.runs as u64, "scenario-profile run", "scenario-profile runs"),
                plural(tally.expectations as u64, "expectation", "expectations")
            );
        }
        Err(code) => return code,
    }

    println!("== generated traces");
    let configs = match generate::all_configs(&spec) {
        Ok(c) => c,
        Err(e) => {
            eprintln!("pmacwd: {e}");
            return ExitCode::from(2);
        }
    };
    let seed = a.seed.unwrap_or_else(generate::fresh_seed);
    println!(
        "seed {seed} (repeat with --seed {seed}); {} traces of up to {} steps over {} (configuration, profile) pairs",
        a.cases,
        a.max_len,
        configs.len()
    );
    let settings = Settings { cases: a.cases, max_len: a.max_len, seed };
    let progress = RefCell::new(Progress::start("generated traces", u64::from(a.cases), "traces"));
    let generated_start = std::time::Instant::now();
    let mut observe = |c: &_, e: &_, m: &_| coverage.record(c, e, m);
    let outcome = generate::run::<CoreSubject>(
        &configs,
        settings,
        &|done| progress.borrow_mut().update(u64::from(done), String::new),
        &mut observe,
    );
    progress.into_inner().finish();
    match outcome {
        Ok(stats) => {
            let secs = generated_start.elapsed().as_secs_f64();
            println!(
                "{} traces, {} events, no divergence ({secs:.1} s with coverage bookkeeping)",
                stats.traces, stats.events
            );
        }
        Err(found) => {
            diverged = true;
            let yaml = pmacwd_trace::to_yaml(&found.to_trace());
            let path = a.save_regressions.join(found.file_name());
            let saved = std::fs::create_dir_all(&a.save_regressions).and_then(|_| std::fs::write(&path, &yaml));
            println!("DIVERGED under {} / {}: {}", found.configuration, found.profile, found.disagreement);
            let events = plural(found.events.len() as u64, "event", "events");
            match saved {
                Ok(()) => println!("shrunk to {}, saved as {}:", events, path.display()),
                Err(e) => println!("shrunk to {} (could not save to {}: {e}):", events, path.display()),
            }
            print!("{yaml}");
        }
    }

    if !a.no_exhaustive {
        println!("== exhaustive lockstep: the product of model and core at every bounded run");
        let runs = match planned_runs(&spec, &Selection::default()) {
            Ok(r) => r,
            Err(e) => {
                eprintln!("pmacwd: {e}");
                return ExitCode::from(2);
            }
        };
        let mut total = 0;
        let mut progress = Progress::start("exhaustive lockstep", runs.len() as u64, "runs");
        for (i, cfg) in runs.into_iter().enumerate() {
            let name = format!("{} / {}", cfg.configuration, cfg.profile.name);
            let done = i as u64;
            let r = pmacwd_conformance::product::check_observed(cfg, threads, &mut |e| {
                progress.update(done, || format!("{name}: {} pair states", thousands(e.states as u64)))
            });
            progress.update(done + 1, String::new);
            total += r.states;
            if !r.complete {
                // Cut short at the state bound: no verdict, so unusable input, not a pass.
                progress
                    .println(&format!("INCOMPLETE {} / {}: stopped at the state bound", r.configuration, r.profile));
                progress.finish();
                return ExitCode::from(2);
            }
            match &r.divergence {
                None => progress.println(&format!(
                    "ok        {:<10} {:<20} {:>8} pair states, depth {:>3}, {:.2} s",
                    r.configuration,
                    r.profile,
                    r.states,
                    r.depth,
                    r.duration.as_secs_f64()
                )),
                Some((events, d)) => {
                    diverged = true;
                    let mut text = format!("DIVERGED  {} / {}: {d}\n  shortest path:\n", r.configuration, r.profile);
                    for e in events {
                        text.push_str(&format!("    {e}\n"));
                    }
                    progress.print(&text);
                }
            }
        }
        progress.finish();
        println!("{total} pair states explored");
    }

    println!("== coverage");
    print!("{}", coverage.report(&spec));
    println!("total {:.1} s", start.elapsed().as_secs_f64());
    if diverged {
        ExitCode::from(1)
    } else {
        ExitCode::SUCCESS
    }
}

/// What running the scenario library on the core found.
pub struct ScenarioTally {
    pub runs: usize,
    pub expectations: usize,
    pub diverged: bool,
}

/// Every scenario under every profile it names, on the core in lockstep with the model, with
/// its expectations checked on the core; divergences are printed as they are found.
pub fn scenarios_on_core(
    spec: &Spec,
    files: &[TraceFile],
    coverage: &mut pmacwd_conformance::coverage::Coverage,
) -> Result<ScenarioTally, ExitCode> {
    use pmacwd_conformance::runner::{profiles_of, run_on_subject_observed, Failure};
    use pmacwd_conformance::subject::CoreSubject;
    let mut tally = ScenarioTally { runs: 0, expectations: 0, diverged: false };
    for file in files {
        let loaded = file.load().map_err(|e| {
            eprintln!("pmacwd: {e}");
            ExitCode::from(2)
        })?;
        let profiles = profiles_of(spec, &loaded).map_err(|e| {
            eprintln!("pmacwd: {e}");
            ExitCode::from(2)
        })?;
        for p in profiles {
            let mut observe = |c: &_, e: &_, m: &_| coverage.record(c, e, m);
            match run_on_subject_observed::<CoreSubject>(spec, &loaded, &p, &mut observe) {
                Ok(n) => {
                    tally.runs += 1;
                    tally.expectations += n;
                }
                Err(Failure::Unusable(e)) => {
                    eprintln!("pmacwd: {e}");
                    return Err(ExitCode::from(2));
                }
                Err(Failure::Diverged(d)) => {
                    tally.diverged = true;
                    println!("DIVERGED  {} [{}]\n  {d}", file.display(), p.name);
                }
            }
        }
    }
    Ok(tally)
}
