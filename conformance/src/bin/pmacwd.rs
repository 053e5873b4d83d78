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
    },
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    match cli.command {
        Command::Check { specs, profile, configuration, witnesses, threads } => {
            let spec = match &specs {
                Some(dir) => Spec::load_dir(dir),
                None => Spec::embedded(),
            };
            let spec = match spec {
                Ok(s) => s,
                Err(e) => {
                    eprintln!("pmacwd: {e}");
                    return ExitCode::from(2);
                }
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
            for (i, cfg) in runs.into_iter().enumerate() {
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
            if failures == 0 {
                ExitCode::SUCCESS
            } else {
                ExitCode::from(1)
            }
        }
    }
}
