//! The `pmacwd` command line.

use clap::{Parser, Subcommand};
use pmacwd_conformance::check::{format_report, planned_runs, run, Selection};
use pmacwd_specs::Spec;
use std::io::Write as _;
use std::path::PathBuf;
use std::process::ExitCode;

/// Executable specification of the Turbo PMAC / Geo Brick watchdog, reset latch and global status.
///
/// Exit codes: 0 all good, 1 a property is violated (or a divergence found), 2 unusable input.
#[derive(Parser)]
#[command(name = "pmacwd", version)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Turbo PMAC emulator on the card's Ethernet protocol (port 1025), backed by the compact
    /// core: `???`, I-variables with I41 lockout, X:$25, Y:$25, X:$0, `$$$`, `ver`, `cid`; the
    /// watchdog runs at the servo rate and a tripped card goes silent until INIT/ or power.
    /// Load and faults come through the control interface (docs/emulator.md).
    Serve(pmacwd_conformance::emulator::cli::ServeArgs),
    /// Transparent proxy between a host program and a card that writes every request and reply,
    /// with timing, as a capture for `pmacwd replay` (docs/emulator.md).
    Record(pmacwd_conformance::emulator::cli::RecordArgs),
    /// Model-check every profile at the bounded configurations of specs/check.yaml.
    ///
    /// Prints, per configuration and profile: states, depth, time, and every property with its
    /// verdict; the shortest counterexample of a violated property.
    Check {
        /// Spec directory to check instead of the embedded one (the specs/ of this build).
        #[arg(long, value_name = "DIR")]
        specs: Option<PathBuf>,
        /// Check only this profile.
        #[arg(long, value_name = "NAME")]
        profile: Option<String>,
        /// Check only this configuration of check.yaml.
        #[arg(long, value_name = "NAME")]
        configuration: Option<String>,
        /// Also print the shortest witness of every `sometimes` property.
        #[arg(long)]
        witnesses: bool,
        /// Checker threads (default: the machine's cores).
        #[arg(long, value_name = "N")]
        threads: Option<usize>,
        /// Skip the conformance summary (the core against the model) after the model check.
        #[arg(long)]
        no_conformance: bool,
    },
    /// Run traces (YAML, docs/trace-format.md) on the reference model and compare every
    /// expected observation, under each profile a trace names.
    ///
    /// PATH is a trace file or a directory of them (default: specs/scenarios). Prints one line
    /// per trace and profile, and for a divergence the step, line, expected and observed values
    /// and the events before it.
    Run {
        /// Trace files or directories.
        #[arg(value_name = "PATH")]
        paths: Vec<PathBuf>,
        /// Spec directory to use instead of the embedded one.
        #[arg(long, value_name = "DIR")]
        specs: Option<PathBuf>,
        /// Run only under this profile (default: the profiles each trace names).
        #[arg(long, value_name = "NAME")]
        profile: Option<String>,
    },
    /// Explain a ??? reply: every set bit of both words with its name and meaning, and whether
    /// the EPICS pmac driver's hardware-problem mask flags it.
    ///
    /// REPLY is 12 hex characters (e.g. 400000080000), `BOOTSTRAP PROM`, or an error reply
    /// (BEL ERRnnn CR). A malformed reply exits 2.
    Decode {
        #[arg(value_name = "REPLY")]
        reply: String,
        /// Print JSON instead of text.
        #[arg(long)]
        json: bool,
        /// Spec directory to take the bit descriptions from instead of the embedded one.
        #[arg(long, value_name = "DIR")]
        specs: Option<PathBuf>,
    },
    /// Replay a captured trace (YAML or JSON Lines) against the model under every profile.
    ///
    /// Streams the capture; reports per profile whether it is consistent, the first divergence
    /// with the events before it and the number of diverging events, then which readings of the
    /// manuals the capture supports or rules out. Exit 0 when some profile explains the capture,
    /// 1 when none does, 2 for unusable input.
    Replay {
        #[arg(value_name = "FILE")]
        file: PathBuf,
        /// Output format.
        #[arg(long, value_enum, default_value_t = Format::Text)]
        format: Format,
        /// Spec directory to use instead of the embedded one.
        #[arg(long, value_name = "DIR")]
        specs: Option<PathBuf>,
    },
    /// Run the conformance suite against the compact core (impl/) and print what it covered.
    ///
    /// Three parts, each in lockstep with the reference model (observations compared after
    /// every event): the scenario library (expectations also checked on the core), generated
    /// traces weighted toward the edges, and, unless --no-exhaustive, the exhaustive product of
    /// model and core at every bounded configuration of check.yaml. Then a coverage report: model
    /// events applied, status bits seen set, properties reached. A generated divergence is
    /// shrunk, printed and saved as a regression trace. Exit 0 no divergence, 1 a divergence,
    /// 2 unusable input.
    Conform {
        /// Generated traces to run.
        #[arg(long, value_name = "N", default_value_t = 10_000)]
        cases: u32,
        /// Longest generated trace, in steps.
        #[arg(long, value_name = "N", default_value_t = 1_000)]
        max_len: usize,
        /// Seed of the generator (default: fresh; printed either way, so a run can be repeated).
        #[arg(long, value_name = "N")]
        seed: Option<u64>,
        /// Scenario directory (default: specs/scenarios, or DIR/scenarios with --specs DIR).
        #[arg(long, value_name = "DIR")]
        scenarios: Option<PathBuf>,
        /// Spec directory to use instead of the embedded one.
        #[arg(long, value_name = "DIR")]
        specs: Option<PathBuf>,
        /// Skip the exhaustive product exploration.
        #[arg(long)]
        no_exhaustive: bool,
        /// Where a shrunk divergence is saved as a trace.
        #[arg(long, value_name = "DIR", default_value = "conformance/regressions")]
        save_regressions: PathBuf,
        /// Checker threads for the exhaustive part (default: the machine's cores).
        #[arg(long, value_name = "N")]
        threads: Option<usize>,
    },
    /// Turn a plain host log (commands, replies, X:$0 read alongside) into a trace.
    ///
    /// The log format and how to capture one from a real controller: docs/capturing.md. Writes
    /// JSON Lines (or YAML with --yaml) to --out, or to standard output.
    Import {
        #[arg(value_name = "LOG")]
        log: PathBuf,
        /// Where to write the trace (default: standard output).
        #[arg(long, value_name = "FILE")]
        out: Option<PathBuf>,
        /// The check.yaml configuration the trace names (CPU costs, hardware delay, I-variables).
        #[arg(long, value_name = "NAME", default_value = "i40-zero")]
        configuration: String,
        /// Write YAML instead of JSON Lines.
        #[arg(long)]
        yaml: bool,
    },
}

fn import_log(log: &std::path::Path, out: Option<PathBuf>, configuration: &str, yaml: bool) -> ExitCode {
    let text = match std::fs::read_to_string(log) {
        Ok(t) => t,
        Err(e) => {
            eprintln!("pmacwd: {}: cannot read: {e}", log.display());
            return ExitCode::from(2);
        }
    };
    let trace = match pmacwd_conformance::import::import(log, &text, configuration) {
        Ok(t) => t,
        Err(e) => {
            eprintln!("pmacwd: {e}");
            return ExitCode::from(2);
        }
    };
    let written = if yaml { pmacwd_trace::to_yaml(&trace) } else { pmacwd_trace::jsonl::to_jsonl(&trace) };
    match out {
        Some(path) => {
            if let Err(e) = std::fs::write(&path, written) {
                eprintln!("pmacwd: {}: cannot write: {e}", path.display());
                return ExitCode::from(2);
            }
            eprintln!("pmacwd: wrote {} steps to {}", trace.steps.len(), path.display());
        }
        None => print!("{written}"),
    }
    ExitCode::SUCCESS
}

#[derive(Clone, Copy, clap::ValueEnum)]
enum Format {
    Text,
    Json,
}

fn replay_file(file: &std::path::Path, format: Format, specs: Option<PathBuf>) -> ExitCode {
    let spec = match load_spec(&specs) {
        Ok(s) => s,
        Err(code) => return code,
    };
    match pmacwd_conformance::replay::replay(&spec, file) {
        Ok(report) => {
            match format {
                Format::Text => {
                    print!("{}", pmacwd_conformance::replay::to_text(&report, &spec.profiles.default_profile().name))
                }
                Format::Json => println!("{}", pmacwd_conformance::replay::to_json(&report)),
            }
            if report.explained() {
                ExitCode::SUCCESS
            } else {
                ExitCode::from(1)
            }
        }
        Err(e) => {
            eprintln!("pmacwd: {e}");
            ExitCode::from(2)
        }
    }
}

fn decode_reply(reply: &str, json: bool, specs: Option<PathBuf>) -> ExitCode {
    let spec = match load_spec(&specs) {
        Ok(s) => s,
        Err(code) => return code,
    };
    match pmacwd_conformance::decode::explain(&spec, reply) {
        Ok(d) if json => {
            println!("{}", pmacwd_conformance::decode::to_json(&d));
            ExitCode::SUCCESS
        }
        Ok(d) => {
            print!("{}", pmacwd_conformance::decode::to_text(&d));
            ExitCode::SUCCESS
        }
        Err(e) => {
            eprintln!("pmacwd: {e}");
            ExitCode::from(2)
        }
    }
}

fn load_spec(specs: &Option<PathBuf>) -> Result<Spec, ExitCode> {
    match specs {
        Some(dir) => Spec::load_dir(dir),
        None => Spec::embedded(),
    }
    .map_err(|e| {
        eprintln!("pmacwd: {e}");
        ExitCode::from(2)
    })
}

fn trace_files(paths: &[PathBuf]) -> Result<Vec<PathBuf>, String> {
    let paths = if paths.is_empty() { vec![PathBuf::from("specs/scenarios")] } else { paths.to_vec() };
    let mut files = Vec::new();
    for p in paths {
        if p.is_dir() {
            let entries = std::fs::read_dir(&p).map_err(|e| format!("{}: {e}", p.display()))?;
            let mut found: Vec<PathBuf> = entries
                .flatten()
                .map(|e| e.path())
                .filter(|f| f.extension().is_some_and(|x| x == "yaml" || x == "yml"))
                .collect();
            found.sort();
            if found.is_empty() {
                return Err(format!("{}: no .yaml traces in this directory", p.display()));
            }
            files.extend(found);
        } else if p.is_file() {
            files.push(p);
        } else {
            return Err(format!("{}: no such file or directory", p.display()));
        }
    }
    Ok(files)
}

fn run_traces(paths: Vec<PathBuf>, specs: Option<PathBuf>, profile: Option<String>) -> ExitCode {
    use pmacwd_conformance::runner::{profiles_of, run_on_model, Failure};
    let spec = match load_spec(&specs) {
        Ok(s) => s,
        Err(code) => return code,
    };
    let files = match trace_files(&paths) {
        Ok(f) => f,
        Err(e) => {
            eprintln!("pmacwd: {e}");
            return ExitCode::from(2);
        }
    };
    let (mut passed, mut diverged) = (0usize, 0usize);
    for file in &files {
        let loaded = match pmacwd_trace::load_yaml(file) {
            Ok(l) => l,
            Err(e) => {
                eprintln!("pmacwd: {e}");
                return ExitCode::from(2);
            }
        };
        let profiles = match profiles_of(&spec, &loaded) {
            Ok(p) => p,
            Err(e) => {
                eprintln!("pmacwd: {e}");
                return ExitCode::from(2);
            }
        };
        let profiles: Vec<_> = match &profile {
            Some(name) => match spec.profiles.get(name) {
                Some(p) => vec![p],
                None => {
                    eprintln!("pmacwd: no profile named `{name}`");
                    return ExitCode::from(2);
                }
            },
            None => profiles,
        };
        for p in profiles {
            match run_on_model(&spec, &loaded, &p) {
                Ok(n) => {
                    passed += 1;
                    println!("ok        {} [{}] ({n} expectations)", file.display(), p.name);
                }
                Err(Failure::Unusable(e)) => {
                    eprintln!("pmacwd: {e}");
                    return ExitCode::from(2);
                }
                Err(Failure::Diverged(d)) => {
                    diverged += 1;
                    println!("DIVERGED  {} [{}]\n  {d}", file.display(), p.name);
                }
            }
        }
    }
    println!("{passed} passed, {diverged} failed");
    if diverged == 0 {
        ExitCode::SUCCESS
    } else {
        ExitCode::from(1)
    }
}

struct ConformArgs {
    cases: u32,
    max_len: usize,
    seed: Option<u64>,
    scenarios: Option<PathBuf>,
    specs: Option<PathBuf>,
    no_exhaustive: bool,
    save_regressions: PathBuf,
    threads: Option<usize>,
}

fn conform(a: ConformArgs) -> ExitCode {
    use pmacwd_conformance::coverage::Coverage;
    use pmacwd_conformance::generate::{self, Settings};
    use pmacwd_conformance::subject::CoreSubject;
    let spec = match load_spec(&a.specs) {
        Ok(s) => s,
        Err(code) => return code,
    };
    let scenario_dir = a.scenarios.clone().unwrap_or_else(|| match &a.specs {
        Some(d) => d.join("scenarios"),
        None => PathBuf::from("specs/scenarios"),
    });
    let files = match trace_files(&[scenario_dir]) {
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
                "{} scenarios, {} scenario-profile runs, {} expectations met by the core",
                files.len(),
                tally.runs,
                tally.expectations
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
    let step = (a.cases / 10).max(1);
    let progress = |done: u32| {
        if done % step == 0 {
            eprintln!("  {done} of {} traces", a.cases);
        }
    };
    let generated_start = std::time::Instant::now();
    let mut observe = |c: &_, e: &_, m: &_| coverage.record(c, e, m);
    match generate::run::<CoreSubject>(&configs, settings, &progress, &mut observe) {
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
            match saved {
                Ok(()) => println!("shrunk to {} events, saved as {}:", found.events.len(), path.display()),
                Err(e) => {
                    println!("shrunk to {} events (could not save to {}: {e}):", found.events.len(), path.display())
                }
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
        let threads = a.threads.unwrap_or_else(|| std::thread::available_parallelism().map_or(1, |n| n.get()));
        let mut total = 0;
        for cfg in runs {
            let r = pmacwd_conformance::product::check(cfg, threads);
            total += r.states;
            match &r.divergence {
                None => println!(
                    "ok        {:<10} {:<20} {:>8} pair states, depth {:>3}, {:.2} s",
                    r.configuration,
                    r.profile,
                    r.states,
                    r.depth,
                    r.duration.as_secs_f64()
                ),
                Some((events, d)) => {
                    diverged = true;
                    println!("DIVERGED  {} / {}: {d}\n  shortest path:", r.configuration, r.profile);
                    for e in events {
                        println!("    {e}");
                    }
                }
            }
        }
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
struct ScenarioTally {
    runs: usize,
    expectations: usize,
    diverged: bool,
}

/// Every scenario under every profile it names, on the core in lockstep with the model, with
/// its expectations checked on the core; divergences are printed as they are found.
fn scenarios_on_core(
    spec: &Spec,
    files: &[PathBuf],
    coverage: &mut pmacwd_conformance::coverage::Coverage,
) -> Result<ScenarioTally, ExitCode> {
    use pmacwd_conformance::runner::{profiles_of, run_on_subject_observed, Failure};
    use pmacwd_conformance::subject::CoreSubject;
    let mut tally = ScenarioTally { runs: 0, expectations: 0, diverged: false };
    for file in files {
        let loaded = pmacwd_trace::load_yaml(file).map_err(|e| {
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

/// The conformance summary `pmacwd check` prints after the model check: the exhaustive product
/// of model and core at the checked runs, the scenario library on the core, and 1,000
/// generated traces. Returns whether anything diverged.
fn conformance_summary(
    spec: &Spec,
    runs: &[pmacwd_specs::config::ModelConfig],
    scenario_dir: &std::path::Path,
    threads: usize,
) -> Result<bool, ExitCode> {
    use pmacwd_conformance::generate::{self, Settings};
    use pmacwd_conformance::subject::CoreSubject;
    println!("conformance summary: the compact core (impl/) against the model (`pmacwd conform` for the full suite and its coverage)");
    let mut diverged = false;
    let start = std::time::Instant::now();
    let mut pairs = 0;
    for cfg in runs {
        let r = pmacwd_conformance::product::check(cfg.clone(), threads);
        pairs += r.states;
        if let Some((events, d)) = &r.divergence {
            diverged = true;
            println!("  DIVERGED  {} / {}: {d}\n  shortest path:", r.configuration, r.profile);
            for e in events {
                println!("      {e}");
            }
        }
    }
    println!(
        "  exhaustive lockstep: {pairs} pair states over {} runs, {} ({:.1} s)",
        runs.len(),
        if diverged { "DIVERGED" } else { "no divergence" },
        start.elapsed().as_secs_f64()
    );
    if scenario_dir.is_dir() {
        let files = trace_files(&[scenario_dir.to_path_buf()]).map_err(|e| {
            eprintln!("pmacwd: {e}");
            ExitCode::from(2)
        })?;
        let tally = scenarios_on_core(spec, &files, &mut Default::default())?;
        diverged |= tally.diverged;
        println!(
            "  scenarios: {} files, {} scenario-profile runs, {} expectations met by the core{}",
            files.len(),
            tally.runs,
            tally.expectations,
            if tally.diverged { ", DIVERGED" } else { "" }
        );
    } else {
        println!("  scenarios: {} not found (run from the project root), skipped", scenario_dir.display());
    }
    let configs = generate::all_configs(spec).map_err(|e| {
        eprintln!("pmacwd: {e}");
        ExitCode::from(2)
    })?;
    let seed = generate::fresh_seed();
    let start = std::time::Instant::now();
    match generate::run::<CoreSubject>(
        &configs,
        Settings { cases: 1_000, max_len: 1_000, seed },
        &|_| {},
        &mut |_, _, _| {},
    ) {
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

fn main() -> ExitCode {
    let cli = Cli::parse();
    match cli.command {
        Command::Conform { cases, max_len, seed, scenarios, specs, no_exhaustive, save_regressions, threads } => {
            conform(ConformArgs { cases, max_len, seed, scenarios, specs, no_exhaustive, save_regressions, threads })
        }
        Command::Run { paths, specs, profile } => run_traces(paths, specs, profile),
        Command::Serve(args) => pmacwd_conformance::emulator::cli::serve(args),
        Command::Record(args) => pmacwd_conformance::emulator::cli::record(args),
        Command::Decode { reply, json, specs } => decode_reply(&reply, json, specs),
        Command::Replay { file, format, specs } => replay_file(&file, format, specs),
        Command::Import { log, out, configuration, yaml } => import_log(&log, out, &configuration, yaml),
        Command::Check { specs, profile, configuration, witnesses, threads, no_conformance } => {
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
            let threads = threads.unwrap_or_else(|| std::thread::available_parallelism().map_or(1, |n| n.get()));
            let default_profile = spec.profiles.default_profile().name;
            println!("pmacwd check: {} runs from {}, {} threads", runs.len(), spec.dir.display(), threads);
            let mut failures = 0usize;
            let (mut states, mut seconds) = (0usize, 0f64);
            for (i, cfg) in runs.iter().cloned().enumerate() {
                eprint!("[{}] checking {} / {} ...\r", i + 1, cfg.configuration, cfg.profile.name);
                let _ = std::io::stderr().flush();
                let report = run(cfg, threads);
                states += report.states;
                seconds += report.duration.as_secs_f64();
                if !report.all_hold() {
                    failures += 1;
                }
                print!("{}", format_report(&report, &default_profile, witnesses));
            }
            println!(
                "total: {states} states in {seconds:.2} s ({:.0} states/s); {}",
                states as f64 / seconds.max(1e-9),
                if failures == 0 {
                    "every property holds".to_string()
                } else {
                    format!("{failures} runs with failing properties")
                }
            );
            let mut diverged = false;
            if !no_conformance {
                let scenario_dir = match &specs {
                    Some(d) => d.join("scenarios"),
                    None => PathBuf::from("specs/scenarios"),
                };
                match conformance_summary(&spec, &runs, &scenario_dir, threads) {
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
    }
}
