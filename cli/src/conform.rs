//! `pmacwd conform`: the conformance suite against the compact core, with its coverage.

use crate::common::Format;
use crate::common::{load_spec, plural, scenario_library, trace_files, TraceFile};
use crate::progress::{thousands, Progress};
use pmacwd_conformance::check::{planned_runs, Selection};
use pmacwd_conformance::runner::Divergence;
use pmacwd_specs::Spec;
use std::cell::RefCell;
use std::path::PathBuf;
use std::process::ExitCode;

/// The longest generated trace `--max-len` admits: the generator holds the whole tree of a
/// case while it runs and shrinks, about 9 KB a step (measured: 20 cases of up to 10,000 steps
/// peak at 91 MB; 100,000 steps at 648 MB; a huge value aborted allocating them).
const MAX_LEN_MAX: usize = 10_000;
const MAX_LEN_WHY: &str = " (a generated trace has at least 1 step; 10,000 take about 90 MB)";

/// The options of `pmacwd conform` (its help text is main.rs's, on the variant).
#[derive(clap::Args)]
pub struct ConformArgs {
    /// Generated traces to run.
    #[arg(long, allow_negative_numbers = true, value_name = "N", default_value_t = 10_000, value_parser = crate::common::ranged(0u32, u32::MAX, ""))]
    pub cases: u32,
    /// Longest generated trace, in steps.
    #[arg(long, allow_negative_numbers = true, value_name = "N", default_value_t = 1_000, value_parser = crate::common::ranged(1usize, MAX_LEN_MAX, MAX_LEN_WHY))]
    pub max_len: usize,
    /// Seed of the generator (default: fresh; printed either way, so a run can be repeated).
    #[arg(long, allow_negative_numbers = true, value_name = "N", value_parser = crate::common::ranged(0u64, u64::MAX, ""))]
    pub seed: Option<u64>,
    /// Scenario directory (default: specs/scenarios, or DIR/scenarios with --specs DIR).
    #[arg(long, value_name = "DIR")]
    pub scenarios: Option<PathBuf>,
    /// Spec directory to use instead of the embedded one.
    #[arg(long, value_name = "DIR")]
    pub specs: Option<PathBuf>,
    /// Skip the exhaustive product exploration.
    #[arg(long)]
    pub no_exhaustive: bool,
    /// Where a shrunk divergence is saved as a trace.
    #[arg(long, value_name = "DIR", default_value = "conformance/regressions")]
    pub save_regressions: PathBuf,
    /// Checker threads for the exhaustive part (default: the machine's cores).
    #[arg(long, allow_negative_numbers = true, value_name = "N", value_parser = crate::common::threads_flag)]
    pub threads: Option<usize>,
    /// Output format: text, or one JSON document (docs/json.md gives its schema).
    #[arg(long, value_enum, default_value_t = Format::Text)]
    pub format: Format,
}

pub fn conform(a: ConformArgs) -> ExitCode {
    use pmacwd_conformance::coverage::Coverage;
    use pmacwd_conformance::generate::{self, Settings};
    use pmacwd_conformance::subject::CoreSubject;
    let text = matches!(a.format, Format::Text);
    let say = |line: String| {
        if text {
            println!("{line}");
        }
    };
    // Options are checked before any work starts.
    let threads = match crate::common::threads(a.threads) {
        Ok(t) => t,
        Err(code) => return code,
    };
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

    say("== scenarios on the core, in lockstep with the model".into());
    let scenarios_json = match scenarios_on_core(&spec, &files, &mut coverage) {
        Ok(tally) => {
            diverged |= tally.diverged();
            if text {
                print!("{}", tally.divergences_text(""));
            }
            say(format!(
                "{}, {}, {} met by the core",
                plural(files.len() as u64, "scenario", "scenarios"),
                plural(tally.runs as u64, "scenario-profile run", "scenario-profile runs"),
                plural(tally.expectations as u64, "expectation", "expectations")
            ));
            tally.to_json(files.len())
        }
        Err(code) => return code,
    };

    say("== generated traces".into());
    let configs = match generate::all_configs(&spec) {
        Ok(c) => c,
        Err(e) => {
            eprintln!("pmacwd: {e}");
            return ExitCode::from(2);
        }
    };
    let seed = a.seed.unwrap_or_else(generate::fresh_seed);
    say(format!(
        "seed {seed} (repeat with --seed {seed}); {} of up to {} over {} (configuration, profile) {}",
        plural(u64::from(a.cases), "trace", "traces"),
        plural(a.max_len as u64, "step", "steps"),
        configs.len(),
        if configs.len() == 1 { "pair" } else { "pairs" }
    ));
    let settings = Settings { cases: a.cases, max_len: a.max_len, seed };
    let progress = RefCell::new(Progress::start("generated traces", u64::from(a.cases), "traces"));
    let generated_start = std::time::Instant::now();
    let mut observe = |c: &_, e: &_, m: &_| coverage.record(c, e, m);
    let outcome = generate::run::<CoreSubject>(
        &configs,
        settings,
        &|g| {
            progress.borrow_mut().update(u64::from(g.traces), || match g.shrink_cases {
                0 => String::new(),
                n => format!("a trace diverged; shrinking it: {n} smaller cases tried"),
            })
        },
        &mut observe,
    );
    progress.into_inner().finish();
    let secs = generated_start.elapsed().as_secs_f64();
    let generated_json = match outcome {
        Ok(stats) => {
            say(format!(
                "{}, {}, no divergence ({secs:.1} s with coverage bookkeeping)",
                plural(u64::from(stats.traces), "trace", "traces"),
                plural(stats.events, "event", "events")
            ));
            serde_json::json!({
                "seed": seed, "cases": a.cases, "max_len": a.max_len, "traces": stats.traces,
                "events": stats.events, "seconds": secs, "divergence": null,
            })
        }
        Err(found) => {
            diverged = true;
            let yaml = pmacwd_trace::to_yaml(&found.to_trace());
            let path = a.save_regressions.join(found.file_name());
            let saved = std::fs::create_dir_all(&a.save_regressions).and_then(|_| std::fs::write(&path, &yaml));
            say(format!("DIVERGED under {} / {}: {}", found.configuration, found.profile, found.disagreement));
            let events = plural(found.events.len() as u64, "event", "events");
            match &saved {
                Ok(()) => say(format!("shrunk to {}, saved as {}:", events, path.display())),
                Err(e) => say(format!("shrunk to {} (could not save to {}: {e}):", events, path.display())),
            }
            if text {
                print!("{yaml}");
            }
            serde_json::json!({
                "seed": seed, "cases": a.cases, "max_len": a.max_len, "traces": null, "events": null,
                "seconds": secs,
                "divergence": {
                    "configuration": found.configuration, "profile": found.profile,
                    "disagreement": found.disagreement.to_string(), "events": found.events.len(),
                    "saved": saved.is_ok().then(|| path.display().to_string()), "trace_yaml": yaml,
                },
            })
        }
    };

    let mut exhaustive_json = serde_json::Value::Null;
    if !a.no_exhaustive {
        say("== exhaustive lockstep: the product of model and core at every bounded run".into());
        let runs = match planned_runs(&spec, &Selection::default()) {
            Ok(r) => r,
            Err(e) => {
                eprintln!("pmacwd: {e}");
                return ExitCode::from(2);
            }
        };
        let mut total = 0;
        let mut results = Vec::new();
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
                progress.finish();
                eprintln!("pmacwd: INCOMPLETE {} / {}: stopped at the state bound", r.configuration, r.profile);
                return ExitCode::from(2);
            }
            let divergence = match &r.divergence {
                None => {
                    if text {
                        progress.println(&format!(
                            "ok        {:<10} {:<20} {:>8} pair states, depth {:>3}, {:.2} s",
                            r.configuration,
                            r.profile,
                            r.states,
                            r.depth,
                            r.duration.as_secs_f64()
                        ));
                    }
                    serde_json::Value::Null
                }
                Some((events, d)) => {
                    diverged = true;
                    if text {
                        let mut t = format!("DIVERGED  {} / {}: {d}\n  shortest path:\n", r.configuration, r.profile);
                        for e in events {
                            t.push_str(&format!("    {e}\n"));
                        }
                        progress.print(&t);
                    }
                    serde_json::json!({
                        "disagreement": d.to_string(),
                        "path": events.iter().map(ToString::to_string).collect::<Vec<_>>(),
                    })
                }
            };
            results.push(serde_json::json!({
                "configuration": r.configuration, "profile": r.profile, "pair_states": r.states,
                "depth": r.depth, "seconds": r.duration.as_secs_f64(), "divergence": divergence,
            }));
        }
        progress.finish();
        say(format!("{total} pair states explored"));
        exhaustive_json = serde_json::json!({"pair_states": total, "runs": results});
    }

    let code: u8 = if diverged { 1 } else { 0 };
    match a.format {
        Format::Text => {
            println!("== coverage");
            print!("{}", coverage.report(&spec));
            println!("total {:.1} s", start.elapsed().as_secs_f64());
        }
        Format::Json => println!(
            "{}",
            crate::common::json_document(
                "conform",
                crate::common::json_version::CONFORM,
                serde_json::json!({
                    "scenarios": scenarios_json,
                    "generated": generated_json,
                    "exhaustive": exhaustive_json,
                    "coverage": coverage.report_json(&spec),
                    "seconds": start.elapsed().as_secs_f64(),
                    "exit": code,
                }),
            )
        ),
    }
    ExitCode::from(code)
}

/// What running the scenario library on the core found.
pub struct ScenarioTally {
    pub runs: usize,
    pub expectations: usize,
    /// (trace, profile, where and how it diverged), in the order found.
    pub divergences: Vec<(String, String, Divergence)>,
}

impl ScenarioTally {
    pub fn diverged(&self) -> bool {
        !self.divergences.is_empty()
    }

    /// The divergences as the text report prints them, each indented by `indent`.
    pub fn divergences_text(&self, indent: &str) -> String {
        let mut s = String::new();
        for (trace, profile, d) in &self.divergences {
            s.push_str(&format!("{indent}DIVERGED  {trace} [{profile}]\n{indent}  {d}\n"));
        }
        s
    }

    pub fn to_json(&self, files: usize) -> serde_json::Value {
        let divergences: Vec<serde_json::Value> = self
            .divergences
            .iter()
            .map(|(trace, profile, d)| serde_json::json!({"trace": trace, "profile": profile, "divergence": d.to_json()}))
            .collect();
        serde_json::json!({
            "files": files, "runs": self.runs, "expectations": self.expectations, "divergences": divergences,
        })
    }
}

/// Every scenario under every profile it names, on the core in lockstep with the model, with
/// its expectations checked on the core; divergences are collected for the caller to print.
pub fn scenarios_on_core(
    spec: &Spec,
    files: &[TraceFile],
    coverage: &mut pmacwd_conformance::coverage::Coverage,
) -> Result<ScenarioTally, ExitCode> {
    use pmacwd_conformance::runner::{profiles_of, run_on_subject_observed, Failure};
    use pmacwd_conformance::subject::CoreSubject;
    let mut tally = ScenarioTally { runs: 0, expectations: 0, divergences: Vec::new() };
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
                    tally.divergences.push((file.display().to_string(), p.name.clone(), d));
                }
            }
        }
    }
    Ok(tally)
}
