//! `pmacwd check`: the model check of every profile at the bounded configurations, then a
//! conformance summary of the core against the model; as text (with a summary table at the
//! end) or as one JSON document (`--format json`, schema in `docs/commands.md`).

use crate::common::Format;
use crate::common::{load_spec, plural, scenario_library};
use crate::conform::scenarios_on_core;
use crate::progress::{thousands, Progress};
use pmacwd_conformance::check::{format_report, planned_runs, report_json, run_observed, verdict, Selection};
use pmacwd_conformance::path_trace::{paths_to_save, Outcome, SavedPath};
use pmacwd_model::checker::RunReport;
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
    /// Where to write the paths as traces (`--save`).
    pub save: Option<PathBuf>,
    pub threads: Option<usize>,
    pub no_conformance: bool,
    pub format: Format,
}

pub fn check(a: CheckArgs) -> ExitCode {
    let CheckArgs { specs, profile, configuration, witnesses, save, threads, no_conformance, format } = a;
    let text = matches!(format, Format::Text);
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
    if let Some(dir) = &save {
        if let Err(e) = std::fs::create_dir_all(dir) {
            eprintln!("pmacwd: --save {}: {e}", dir.display());
            return ExitCode::from(2);
        }
    }
    let default_profile = spec.profiles.default_profile().name;
    if text {
        println!(
            "pmacwd check: {} from {}, {}",
            plural(runs.len() as u64, "run", "runs"),
            spec.dir.display(),
            plural(threads as u64, "thread", "threads")
        );
    }
    let mut reports: Vec<RunReport> = Vec::new();
    let mut saved_json: Vec<serde_json::Value> = Vec::new();
    let mut progress = Progress::start("model check", runs.len() as u64, "runs");
    for (i, cfg) in runs.iter().cloned().enumerate() {
        let name = format!("{} / {}", cfg.configuration, cfg.profile.name);
        let done = i as u64;
        let report = run_observed(cfg, threads, &mut |e| {
            progress.update(done, || format!("{name}: {} states, depth {}", thousands(e.states as u64), e.depth))
        });
        progress.update(done + 1, String::new);
        if text {
            progress.print(&format_report(&report, &default_profile, witnesses));
        }
        if let Some(dir) = &save {
            let paths = paths_to_save(&spec, &runs[i], &report, witnesses, threads);
            match save_paths(dir, &paths) {
                Ok(line) if text => progress.print(&line),
                Ok(_) => {}
                Err(e) => {
                    progress.finish();
                    eprintln!("pmacwd: --save {}: {e}", dir.display());
                    return ExitCode::from(2);
                }
            }
            saved_json.push(saved_paths_json(&report, &paths));
        }
        reports.push(report);
    }
    progress.finish();
    let states: usize = reports.iter().map(|r| r.states).sum();
    let seconds: f64 = reports.iter().map(|r| r.duration.as_secs_f64()).sum();
    let incomplete = reports.iter().filter(|r| !r.complete).count();
    let failures = reports.iter().filter(|r| r.complete && !r.all_hold()).count();
    if text {
        println!(
            "total: {states} states in {seconds:.2} s ({:.0} states/s); {}",
            states as f64 / seconds.max(1e-9),
            if incomplete > 0 {
                format!("{} stopped at the state bound, no verdict", plural(incomplete as u64, "run", "runs"))
            } else if failures == 0 {
                "every property holds".to_string()
            } else {
                format!("{} with failing properties", plural(failures as u64, "run", "runs"))
            }
        );
    }
    let mut conformance = None;
    if incomplete == 0 && !no_conformance {
        match conformance_summary(&spec, &runs, &specs, threads, text) {
            Ok(c) => conformance = Some(c),
            Err(code) => return code,
        }
    }
    let diverged = conformance.as_ref().is_some_and(|c| c.diverged);
    // A run cut short at the state bound proves nothing either way: unusable input.
    let code: u8 = if incomplete > 0 {
        2
    } else if failures == 0 && !diverged {
        0
    } else {
        1
    };
    match format {
        Format::Text => {
            if incomplete == 0 {
                print!("{}", summary_table(&reports, conformance.as_ref(), code));
            }
        }
        Format::Json => {
            let runs: Vec<serde_json::Value> = reports.iter().map(|r| report_json(r, &default_profile)).collect();
            let doc = serde_json::json!({
                "spec_dir": spec.dir.display().to_string(),
                "threads": threads,
                "runs": runs,
                "total": {
                    "states": states, "seconds": seconds, "runs": reports.len(),
                    "failing_runs": failures, "incomplete_runs": incomplete,
                },
                "conformance": conformance.as_ref().map(|c| &c.json),
                "saved": save.as_ref().map(|dir| serde_json::json!({"dir": dir.display().to_string(), "runs": saved_json})),
                "exit": code,
            });
            println!("{}", crate::common::json_document("check", crate::common::json_version::CHECK, doc));
        }
    }
    if incomplete > 0 {
        eprintln!(
            "pmacwd: {} stopped at the checker's state bound: no verdict for {}",
            plural(incomplete as u64, "run", "runs"),
            if incomplete == 1 { "it" } else { "them" }
        );
    }
    ExitCode::from(code)
}

/// Writes the saved paths of one run into `dir`; returns the line the text report prints.
fn save_paths(dir: &std::path::Path, paths: &[SavedPath]) -> std::io::Result<String> {
    let (mut direct, mut longest, mut at_power_up) = (0, 0, 0);
    let mut refused = Vec::new();
    for p in paths {
        let trace = match &p.outcome {
            Outcome::Saved { trace, .. } => {
                direct += 1;
                trace
            }
            Outcome::SavedLongestDecelerations { trace, .. } => {
                longest += 1;
                trace
            }
            Outcome::AtPowerUp => {
                at_power_up += 1;
                continue;
            }
            Outcome::NotReproducible(why) => {
                refused.push(format!("            not saved: {}: {why}\n", p.property));
                continue;
            }
        };
        let file = dir.join(&p.file_name);
        std::fs::write(&file, pmacwd_trace::to_yaml(trace))
            .map_err(|e| std::io::Error::new(e.kind(), format!("{}: {e}", file.display())))?;
    }
    let mut line = format!("   saved {} in {}", plural((direct + longest) as u64, "trace", "traces"), dir.display());
    let mut notes = Vec::new();
    if longest > 0 {
        notes.push(format!("{longest} as the shortest path with the longest decelerations, as `run` takes them"));
    }
    if at_power_up > 0 {
        notes.push(format!("{at_power_up} reached at power-up, no event to save"));
    }
    if !refused.is_empty() {
        notes.push(format!("{} not reproducible as a trace", refused.len()));
    }
    if !notes.is_empty() {
        line.push_str(&format!(" ({})", notes.join("; ")));
    }
    line.push('\n');
    line.extend(refused);
    Ok(line)
}

/// The saved paths of one run, for `--format json`.
fn saved_paths_json(report: &RunReport, paths: &[SavedPath]) -> serde_json::Value {
    let files: Vec<serde_json::Value> = paths
        .iter()
        .map(|p| {
            let (outcome, steps, why) = match &p.outcome {
                Outcome::Saved { steps, .. } => ("saved", Some(*steps), None),
                Outcome::SavedLongestDecelerations { steps, .. } => ("saved_longest_decelerations", Some(*steps), None),
                Outcome::AtPowerUp => ("at_power_up", None, None),
                Outcome::NotReproducible(why) => ("not_reproducible", None, Some(why.clone())),
            };
            let saved = matches!(outcome, "saved" | "saved_longest_decelerations");
            serde_json::json!({
                "property": p.property, "outcome": outcome, "steps": steps, "why": why,
                "file": saved.then(|| p.file_name.clone()),
            })
        })
        .collect();
    serde_json::json!({"configuration": report.configuration, "profile": report.profile, "paths": files})
}

/// The table at the end of the text report: per configuration, its runs, states and how many
/// property verdicts of each kind; then the conformance summary's verdicts and the exit code.
fn summary_table(reports: &[RunReport], conformance: Option<&Conformance>, code: u8) -> String {
    let mut configurations: Vec<&str> = Vec::new();
    for r in reports {
        if !configurations.contains(&r.configuration.as_str()) {
            configurations.push(&r.configuration);
        }
    }
    let verdicts = ["holds", "reached", "n/a", "VIOLATED", "NEVER"];
    let mut s = String::from("summary:\n");
    s.push_str(&format!("  {:<14} {:>5} {:>11}", "configuration", "runs", "states"));
    for v in verdicts {
        s.push_str(&format!(" {v:>8}"));
    }
    s.push('\n');
    for c in configurations {
        let of: Vec<&RunReport> = reports.iter().filter(|r| r.configuration == c).collect();
        let states: usize = of.iter().map(|r| r.states).sum();
        s.push_str(&format!("  {:<14} {:>5} {:>11}", c, of.len(), thousands(states as u64)));
        for v in verdicts {
            let n = of.iter().flat_map(|r| &r.properties).filter(|p| verdict(p) == v).count();
            s.push_str(&format!(" {n:>8}"));
        }
        s.push('\n');
    }
    if let Some(c) = conformance {
        s.push_str(&format!("  conformance: {}\n", c.verdicts.join("; ")));
    }
    let meaning = match code {
        0 => "every property holds and nothing diverged",
        1 => "a property failed or the core diverged",
        _ => "no verdict",
    };
    s.push_str(&format!("  exit {code}: {meaning}\n"));
    s
}

/// What the conformance summary found: whether anything diverged, one verdict per part for the
/// summary table, and the JSON of every part.
struct Conformance {
    diverged: bool,
    verdicts: Vec<String>,
    json: serde_json::Value,
}

/// The conformance summary `pmacwd check` prints after the model check: the exhaustive product
/// of model and core at the checked runs, the scenario library on the core, and 1,000
/// generated traces. Printed as it goes when `text`.
fn conformance_summary(
    spec: &Spec,
    runs: &[pmacwd_specs::config::ModelConfig],
    specs: &Option<PathBuf>,
    threads: usize,
    text: bool,
) -> Result<Conformance, ExitCode> {
    use pmacwd_conformance::generate::{self, Settings};
    use pmacwd_conformance::subject::CoreSubject;
    let say = |line: String| {
        if text {
            println!("{line}");
        }
    };
    say("conformance summary: the compact core (impl/) against the model (`pmacwd conform` for the full suite and its coverage)".into());
    let mut verdicts = Vec::new();
    let start = std::time::Instant::now();
    let mut pairs = 0;
    let mut lockstep_divergences = Vec::new();
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
            progress.finish();
            eprintln!(
                "pmacwd: exhaustive lockstep {} / {} stopped at the state bound: no verdict",
                r.configuration, r.profile
            );
            return Err(ExitCode::from(2));
        }
        if let Some((events, d)) = &r.divergence {
            if text {
                let mut t = format!("  DIVERGED  {} / {}: {d}\n  shortest path:\n", r.configuration, r.profile);
                for e in events {
                    t.push_str(&format!("      {e}\n"));
                }
                progress.print(&t);
            }
            lockstep_divergences.push(serde_json::json!({
                "configuration": r.configuration, "profile": r.profile, "disagreement": d.to_string(),
                "path": events.iter().map(ToString::to_string).collect::<Vec<_>>(),
            }));
        }
    }
    progress.finish();
    let lockstep_seconds = start.elapsed().as_secs_f64();
    let lockstep_diverged = !lockstep_divergences.is_empty();
    say(format!(
        "  exhaustive lockstep: {pairs} pair states over {}, {} ({lockstep_seconds:.1} s)",
        plural(runs.len() as u64, "run", "runs"),
        if lockstep_diverged { "DIVERGED" } else { "no divergence" },
    ));
    verdicts.push(format!("exhaustive lockstep {}", if lockstep_diverged { "DIVERGED" } else { "agrees" }));
    let exhaustive = serde_json::json!({
        "pair_states": pairs, "runs": runs.len(), "seconds": lockstep_seconds, "divergences": lockstep_divergences,
    });
    // A copy of the spec directory without its scenarios is checked without them.
    let missing = specs.as_ref().map(|d| d.join("scenarios")).filter(|d| !d.is_dir());
    let (scenarios, scenarios_diverged) = if let Some(dir) = missing {
        say(format!("  scenarios: {} not found, skipped", dir.display()));
        verdicts.push("scenarios skipped".into());
        (serde_json::Value::Null, false)
    } else {
        let files = scenario_library(specs).map_err(|e| {
            eprintln!("pmacwd: {e}");
            ExitCode::from(2)
        })?;
        let tally = scenarios_on_core(spec, &files, &mut Default::default())?;
        if text {
            print!("{}", tally.divergences_text("  "));
        }
        say(format!(
            "  scenarios: {}, {}, {} met by the core{}",
            plural(files.len() as u64, "file", "files"),
            plural(tally.runs as u64, "scenario-profile run", "scenario-profile runs"),
            plural(tally.expectations as u64, "expectation", "expectations"),
            if tally.diverged() { ", DIVERGED" } else { "" }
        ));
        verdicts.push(format!("scenarios {}", if tally.diverged() { "DIVERGED" } else { "agree" }));
        (tally.to_json(files.len()), tally.diverged())
    };
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
        &|g| {
            progress.borrow_mut().update(u64::from(g.traces), || match g.shrink_cases {
                0 => String::new(),
                n => format!("a trace diverged; shrinking it: {n} smaller cases tried"),
            })
        },
        &mut |_, _, _| {},
    );
    progress.into_inner().finish();
    let seconds = start.elapsed().as_secs_f64();
    let (generated, generated_diverged) = match outcome {
        Ok(stats) => {
            say(format!(
                "  generated: {} traces, {} events, seed {seed}, no divergence ({seconds:.1} s)",
                stats.traces, stats.events,
            ));
            let json = serde_json::json!({
                "seed": seed, "traces": stats.traces, "events": stats.events, "seconds": seconds, "divergence": null,
            });
            (json, false)
        }
        Err(found) => {
            let trace = pmacwd_trace::to_yaml(&found.to_trace());
            say(format!(
                "  generated: seed {seed}, DIVERGED under {} / {}: {}",
                found.configuration, found.profile, found.disagreement
            ));
            if text {
                print!("{trace}");
            }
            let json = serde_json::json!({
                "seed": seed, "traces": null, "events": null, "seconds": seconds,
                "divergence": {
                    "configuration": found.configuration, "profile": found.profile,
                    "disagreement": found.disagreement.to_string(), "trace_yaml": trace,
                },
            });
            (json, true)
        }
    };
    verdicts.push(format!("generated traces {}", if generated_diverged { "DIVERGED" } else { "agree" }));
    Ok(Conformance {
        diverged: lockstep_diverged || scenarios_diverged || generated_diverged,
        verdicts,
        json: serde_json::json!({"exhaustive": exhaustive, "scenarios": scenarios, "generated": generated}),
    })
}
