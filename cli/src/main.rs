//! The `pmacwd` command line: the subcommands and their options; each lives in its own module,
//! and `main` only dispatches.

mod check;
mod common;
mod conform;
mod control;
mod decode;
mod explore;
mod import;
mod interrupt;
mod margin;
mod probe;
mod progress;
mod record;
mod replay;
mod requirements;
mod run;
mod serve;
mod timeline;

use clap::{Parser, Subcommand};
use common::Format;
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
    #[command(after_help = "Exit codes: 0 stopped normally, 2 unusable arguments or a port that cannot be bound.")]
    Serve(serve::ServeArgs),
    /// Send commands to the control port of `pmacwd serve` (or of `pmacwd record
    /// --control-listen`): load, supply, INIT/, power, faults, virtual time, state
    /// (docs/emulator.md). One command per argument, or, with none, one per line from standard
    /// input (with a prompt on a terminal). Prints each reply line as it arrives.
    #[command(
        after_help = "Examples:\n  pmacwd control state\n  pmacwd control 'supply 4500' state init\n  printf 'starve\\nstep 4000\\nstate\\n' | pmacwd control\n\nExit codes: 0 every command answered ok, 1 a command answered with an error, 2 no control port at the address or the connection failed."
    )]
    Control {
        /// Commands, one per argument (`step 1000`, quoted when it has spaces); none: read them
        /// from standard input, one per line (`#` comments and blank lines skipped).
        #[arg(value_name = "COMMAND")]
        commands: Vec<String>,
        /// The control port, HOST:PORT (`pmacwd serve --control`).
        #[arg(long, value_name = "ADDR", default_value = "127.0.0.1:1026", value_parser = common::listen_address)]
        address: std::net::SocketAddr,
    },
    /// Transparent proxy between a host program and a card that writes every request and reply,
    /// with timing, as a capture for `pmacwd replay` (docs/emulator.md).
    #[command(
        after_help = "Exit codes: 0 the sessions asked for ended and the capture is closed, 2 unusable arguments or a port that cannot be bound."
    )]
    Record(record::RecordArgs),
    /// Test a card or a simulator over the wire: a seeded campaign of command sequences (`???`
    /// and its bits, Y:$25/X:$25 with X:$0, I40 reloads, I41 lockout, checksums, error numbers,
    /// stop commands on idle motors; resets and a trip when allowed), recorded as a stamped
    /// host log and judged by the replay search, again without each unit that had a fault
    /// (docs/probe.md).
    ///
    /// Prints the seed and the plan first; then every reading and named profile supported,
    /// ruled out or undecided, and every fault (an observation no correct card can show) with
    /// the exchange, what a correct card could have answered, and the manual page, counted by
    /// kind. Safe by default: reads, and I-variable writes read first and written back.
    #[command(
        after_help = "Examples:\n  pmacwd probe 192.168.0.200 --read-only\n  pmacwd probe 192.168.0.200 --yes --log bench.log\n  pmacwd probe 127.0.0.1:1025 --control 127.0.0.1:1026 --allow-writes --allow-reset --allow-trip --seed 7\n  pmacwd probe 127.0.0.1:5001 --telnet --format json\n\nExit codes: 0 every segment is explained by a correct card, 1 a fault found, 2 unusable arguments, an unreachable card, or segments undecided without a fault."
    )]
    Probe(probe::ProbeArgs),
    /// Model-check every profile at the bounded configurations of specs/check.yaml.
    ///
    /// Prints, per configuration and profile: states, depth, time, and every property with its
    /// verdict; the shortest counterexample of a violated property (docs/commands.md; what is
    /// checked: docs/model.md).
    #[command(
        after_help = "Exit codes: 0 every property holds and the core agrees with the model, 1 a property is violated or the core diverged, 2 unusable input (spec directory, options, a run too large to check)."
    )]
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
        /// Write every counterexample (and with --witnesses every witness) as a trace file in
        /// DIR, created if missing: `CONFIGURATION-PROFILE-PROPERTY.yaml`, every observation of
        /// the path expected at every step, so that `pmacwd run` reproduces it and `pmacwd
        /// timeline` draws it.
        #[arg(long, value_name = "DIR")]
        save: Option<PathBuf>,
        /// Checker threads (default: the machine's cores).
        #[arg(long, allow_negative_numbers = true, value_name = "N", value_parser = common::threads_flag)]
        threads: Option<usize>,
        /// Skip the conformance summary (the core against the model) after the model check.
        #[arg(long)]
        no_conformance: bool,
        /// Output format: text (with a summary table at the end), or one JSON document
        /// (docs/json.md gives its schema).
        #[arg(long, value_enum, default_value_t = Format::Text)]
        format: Format,
    },
    /// Serve stateright's Explorer over the model of one configuration and profile: a web page
    /// to walk the states from power-up, action by action, with every property `pmacwd check`
    /// names and the path to each discovery (docs/commands.md).
    ///
    /// Each state reads card first (the trip, Y:$25, X:$25, the ??? words, the outputs), then
    /// the rest the rules read; each action's outcome is the concrete event, the reply and the
    /// card after it, as `pmacwd check` prints a path's step. States are explored as the page
    /// opens them, or all of them after "run to completion". Serves until stopped (Ctrl-C).
    #[command(
        after_help = "Examples:\n  pmacwd explore                        # timing, default profile, http://127.0.0.1:3000/\n  pmacwd explore --configuration motion --profile srm-57 --listen 127.0.0.1:8080\n\nExit codes: 0 stopped normally, 2 unusable input (a configuration or profile that does not exist, a spec directory) or an address that cannot be bound."
    )]
    Explore(explore::ExploreArgs),
    /// Run traces (YAML or JSON Lines, docs/trace-format.md) on the reference model and compare
    /// every expected observation, under each profile a trace names.
    ///
    /// PATH is a trace file or a directory of them (.yaml, .yml, .jsonl; default: the scenario
    /// library, compiled in). Prints one line per trace and profile, and for a divergence the
    /// step, line, expected and observed values and the events before it. A trace with
    /// `elapsed` or `restart` steps (an imported host log) is for `pmacwd replay`.
    #[command(after_help = "Exit codes: 0 every expectation met, 1 a trace diverged, 2 unusable input.")]
    Run {
        /// Trace files (YAML or JSON Lines) or directories of them.
        #[arg(value_name = "PATH")]
        paths: Vec<PathBuf>,
        /// Spec directory to use instead of the embedded one.
        #[arg(long, value_name = "DIR")]
        specs: Option<PathBuf>,
        /// Run only under this profile (default: the profiles each trace names).
        #[arg(long, value_name = "NAME")]
        profile: Option<String>,
        /// Output format: text, or one JSON document (docs/json.md gives its schema).
        #[arg(long, value_enum, default_value_t = Format::Text)]
        format: Format,
    },
    /// Explain a ??? reply: every set bit of both words with its name and meaning, and whether
    /// the EPICS pmac driver's hardware-problem mask flags it.
    ///
    /// REPLY is 12 hex characters (e.g. 400000080000), `BOOTSTRAP PROM`, or an error reply
    /// (BEL ERRnnn CR, or ERRnnn as a log writes it). A malformed reply exits 2
    /// (docs/commands.md).
    #[command(after_help = "Exit codes: 0 explained, 2 not a reply a card sends.")]
    Decode {
        /// The reply: 12 hex characters, `BOOTSTRAP PROM`, `BEL ERRnnn CR` or `ERRnnn`.
        #[arg(value_name = "REPLY")]
        reply: String,
        /// Output format: text, or one JSON document (docs/json.md gives its schema).
        #[arg(long, value_enum, default_value_t = Format::Text)]
        format: Format,
        /// The same as `--format json`: the flag before `--format`, kept for scripts.
        #[arg(long, conflicts_with = "format")]
        json: bool,
        /// Spec directory to take the bit descriptions from instead of the embedded one.
        #[arg(long, value_name = "DIR")]
        specs: Option<PathBuf>,
    },
    /// Could a correct card have produced this capture, under which readings, and why did it trip?
    ///
    /// Searches, under every combination of the manuals' readings, for a behaviour of the model
    /// that produces every observation of the capture, choosing what the host could not see:
    /// when background cycles completed, the load (RTI overruns), supply dips, checksum faults,
    /// resets, the CPU type (docs/replay.md). Reports each reading's options as supported or
    /// ruled out, one explanation in words (checked on the model), and for a card that fell
    /// silent every cause of the trip that remains possible.
    #[command(
        after_help = "Exit codes: 0 a correct card can produce the capture, 1 none can (under any reading), 2 unusable input or a capture beyond the search's bounds."
    )]
    Replay {
        /// The capture: a trace in YAML or JSON Lines, or a host log (imported on the fly, as
        /// `pmacwd import` would).
        #[arg(value_name = "FILE")]
        file: PathBuf,
        /// For a host log: the check.yaml configuration to import it under (default host-log);
        /// what the log itself reads (I8, I40, I41, I10) overrides it.
        #[arg(long, value_name = "NAME")]
        configuration: Option<String>,
        /// Read FILE as this kind of log (default: by its content). `--format` is the report's
        /// own format, as for every command, so the log's is `--log-format` (docs/capturing.md).
        #[arg(long, value_enum, value_name = "FORMAT")]
        log_format: Option<common::LogFormatArg>,
        /// Write the explanation as a trace: the capture with every unseen gap replaced by the
        /// model events the search chose. JSON Lines, or YAML if FILE ends in .yaml (which
        /// `pmacwd run FILE` replays on the model).
        #[arg(long, value_name = "FILE")]
        witness: Option<PathBuf>,
        /// For a stamped log that no card explains with the commands between X:$0 reads at the
        /// reads' instants: how long the search placing every exchange at its own host time may
        /// take before the verdict is undecided (0: no limit).
        #[arg(long, value_name = "SECONDS", default_value_t = 300)]
        host_time_seconds: u64,
        /// The card's saved I40 (the watchdog counter's reload, SRM p.57), for a host log that
        /// does not read it. Without it, replay searches the values the log admits and names
        /// the one that explains it (docs/replay.md).
        #[arg(long, value_name = "N", allow_negative_numbers = true, value_parser = common::ranged(0i64, 65_535, " (I40's range, variables.yaml)"))]
        i40: Option<i64>,
        /// Output format: text, or one JSON document (docs/json.md gives its schema).
        #[arg(long, value_enum, default_value_t = Format::Text)]
        format: Format,
        /// Spec directory to use instead of the embedded one.
        #[arg(long, value_name = "DIR")]
        specs: Option<PathBuf>,
    },
    /// How close a configuration runs to a watchdog trip, under each profile, measured on the model.
    ///
    /// From a configuration of check.yaml (its CPU costs and first load), with the servo clock,
    /// I8, I40 and the load overridden as given: the longest run without a background cycle
    /// the card survives (the counter's reload, UM p.215 / SRM p.57, plus the hardware delay),
    /// the longest run the load makes (motors, PLC 0 and background in CPU units), the margin
    /// between them in servo cycles and ms (also with the shortest hardware delay the strobe
    /// minimum's band admits), and whether PLC 0 overruns the RTI or starves the background.
    /// Loads in CPU units or in microseconds (--plc0-us, --background-us); a warning where the
    /// margin rises with the load one unit either side. --plot FILE.svg draws the margin
    /// against PLC 0 load, the load given marked (docs/commands.md). With --x25 (and --y25)
    /// read from a card (000FF0 as RHX:$25 replies, $FF0, or decimal), also what those
    /// readings prove: the longest run without a background cycle since reset, and the servo
    /// cycles that were left to a trip then. The load also in the EPICS pmac driver's figures:
    /// the timer registers M70-M73 as it reads them (--m70 --m71 --m72 --m73) or its CPU load
    /// (--cpu-load PERCENT, the CPULOAD PV), read back to motors and PLC 0 units through the
    /// model's timer mapping; where they stand for more than one load, the one with the least
    /// margin is measured.
    #[command(
        after_help = "Exit codes: 0 measured, 1 the load trips the card under the default profile or no profile's card can show the readings, 2 unusable arguments."
    )]
    Margin(margin::MarginArgs),
    /// Draw a trace run on the model: Y:$25, X:$25, the strobe, the trip, the background cycles
    /// and every status bit over absolute servo cycles and milliseconds.
    ///
    /// Runs TRACE (YAML or JSON Lines) as `pmacwd run` does, under one profile, servo cycle by
    /// servo cycle, and writes every change: as CSV (host commands as comment lines), as VCD for
    /// GTKWave (time in ns at the configuration's servo clock), or as an SVG plot of Y:$25 and
    /// X:$25 with the trip and the trace's reads marked. A capture with `elapsed` or `restart`
    /// steps leaves open what happened: `pmacwd replay CAPTURE --witness W.jsonl` first, then
    /// `pmacwd timeline W.jsonl`. Expectations are not checked (that is `pmacwd run`;
    /// docs/commands.md).
    #[command(after_help = "Exit codes: 0 written, 2 unusable input (or a trace with elapsed/restart steps).")]
    Timeline {
        /// The trace: YAML or JSON Lines.
        #[arg(value_name = "TRACE")]
        trace: PathBuf,
        /// Output format. No JSON: the CSV is the data in a form programs read, one row per
        /// change (docs/json.md says why).
        #[arg(long, value_enum, default_value_t = timeline::TimelineFormat::Csv)]
        format: timeline::TimelineFormat,
        /// Write to FILE instead of standard output.
        #[arg(long, short, value_name = "FILE")]
        output: Option<PathBuf>,
        /// The profile to run under (default: the trace's first, or the default profile when
        /// it lists `all`).
        #[arg(long, value_name = "NAME")]
        profile: Option<String>,
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
    /// shrunk, printed and saved as a regression trace (docs/conformance.md). Exit 0 no
    /// divergence, 1 a divergence, 2 unusable input.
    #[command(after_help = "Exit codes: 0 no divergence, 1 a divergence (shrunk and saved), 2 unusable input.")]
    Conform(conform::ConformArgs),
    /// Print the requirements matrix: each normative statement of the manual pages, by page,
    /// with what encodes and checks it, and the coverage figures.
    ///
    /// Reads specs/requirements.yaml (docs/specs.md): a statement is encoded and checked (a
    /// model property, a scenario or a test names it), by definition (its checks hold by
    /// construction), data only (YAML that no rule reads), missing, or a deviation with its
    /// reason.
    #[command(after_help = "Exit codes: 0 printed, 2 unusable input (the spec directory).")]
    Requirements {
        /// Output format: text, or one JSON document (docs/json.md gives its schema).
        #[arg(long, value_enum, default_value_t = Format::Text)]
        format: Format,
        /// Spec directory to use instead of the embedded one.
        #[arg(long, value_name = "DIR")]
        specs: Option<PathBuf>,
    },
    /// Turn a log (a host log, an EPICS asyn trace, a pcap capture) into a trace.
    ///
    /// The log format and how to capture one from a real controller: docs/capturing.md. Writes
    /// JSON Lines (or YAML with --format yaml) to --out, or to standard output.
    #[command(after_help = "Exit codes: 0 imported, 2 unusable input (the log's file, line and column say where).")]
    Import {
        /// The log: `> command` and `< reply` lines, an EPICS asyn trace or a pcap/pcapng
        /// capture (docs/capturing.md).
        #[arg(value_name = "LOG")]
        log: PathBuf,
        /// Where to write the trace (default: standard output).
        #[arg(long, value_name = "FILE")]
        out: Option<PathBuf>,
        /// The check.yaml configuration the trace names (CPU costs, hardware delay, I-variables).
        #[arg(long, value_name = "NAME", default_value = pmacwd_capture::import::DEFAULT_CONFIGURATION)]
        configuration: String,
        /// Output format: the trace as JSON Lines (jsonl) or YAML (yaml), docs/trace-format.md.
        /// The log's kind is --log-format (docs/commands.md).
        #[arg(long, value_name = "FORMAT", default_value = "jsonl", value_parser = import::Form::parse)]
        format: import::Form,
        /// The same as `--format yaml`, kept for scripts.
        #[arg(long, conflicts_with = "format")]
        yaml: bool,
        /// Read LOG as this kind of log (default: by its content): a host log, an EPICS asyn
        /// trace of the pmac driver, or a pcap/pcapng capture of port 1025 (docs/capturing.md).
        #[arg(long, value_enum, value_name = "FORMAT")]
        log_format: Option<common::LogFormatArg>,
    },
}

fn main() -> ExitCode {
    // Output into a closed pipe (`pmacwd run | head`) ends the process quietly, as for other
    // command-line tools, instead of a panic in `println!` (Rust ignores SIGPIPE by default).
    // SAFETY: called before any other thread exists; SIG_DFL is a valid disposition.
    #[cfg(unix)]
    unsafe {
        libc::signal(libc::SIGPIPE, libc::SIG_DFL);
    }
    // glibc keeps what the search threads free in their own arenas and raises its trim
    // threshold as large blocks are freed: a quarter-day host log's replay peaked at 230 MB of
    // RSS over 33 MB of heap (heaptrack). Its default threshold, set explicitly, stays fixed
    // and the memory goes back (42 MB, the same time).
    // SAFETY: called before any other thread exists; M_TRIM_THRESHOLD takes a byte count.
    #[cfg(all(target_os = "linux", target_env = "gnu"))]
    unsafe {
        libc::mallopt(libc::M_TRIM_THRESHOLD, 128 * 1024);
    }
    let cli = Cli::parse();
    if let Err(e) = progress::configure() {
        return common::unusable(e);
    }
    match cli.command {
        Command::Conform(args) => conform::conform(args),
        Command::Explore(args) => explore::explore(args),
        Command::Run { paths, specs, profile, format } => run::run_traces(paths, specs, profile, format),
        Command::Serve(args) => serve::serve(args),
        Command::Control { commands, address } => control::control(control::ControlArgs { address, commands }),
        Command::Record(args) => record::record(args),
        Command::Probe(args) => probe::probe(args),
        Command::Decode { reply, format, json, specs } => decode::decode_reply(&reply, format.or_json(json), specs),
        Command::Replay { file, format, specs, configuration, log_format, witness, host_time_seconds, i40 } => {
            replay::replay_file(replay::ReplayArgs {
                file,
                format,
                specs,
                configuration,
                log_format: log_format.map(Into::into),
                witness,
                host_time_seconds,
                i40,
            })
        }
        Command::Margin(args) => margin::margin(args),
        Command::Timeline { trace, format, output, profile, specs } => {
            timeline::timeline(timeline::TimelineArgs { trace, format, output, profile, specs })
        }
        Command::Requirements { format, specs } => requirements::requirements(format, specs),
        Command::Import { log, out, configuration, format, yaml, log_format } => {
            let form = if yaml { import::Form::Yaml } else { format };
            import::import_log(&log, out, &configuration, form, log_format.map(Into::into))
        }
        Command::Check { specs, profile, configuration, witnesses, save, threads, no_conformance, format } => {
            check::check(check::CheckArgs {
                specs,
                profile,
                configuration,
                witnesses,
                save,
                threads,
                no_conformance,
                format,
            })
        }
    }
}
