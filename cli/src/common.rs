//! What every subcommand shares: the spec directory, trace files, and unusable input.

use pmacwd_emulator::capture::CaptureWriter;
use pmacwd_specs::config::ModelConfig;
use pmacwd_specs::{Spec, SpecError};
use pmacwd_trace::LoadedTrace;
use std::io::Write;
use std::path::{Path, PathBuf};
use std::process::ExitCode;

/// For a server once it is up (`serve`, `record`): a write into a closed standard output or
/// error (a script that read the address line and closed the pipe) returns an error, which the
/// server's console ignores ([`pmacwd_emulator::bounded::to_stdout`]), instead of SIGPIPE
/// ending the server: `main` restores SIGPIPE's default for the commands whose output is the
/// point, and a server's console is not.
pub fn console_may_close() {
    // SAFETY: SIG_IGN is a valid disposition; changing it is async-signal-safe and affects
    // only writes to pipes, which every writer of this process checks or ignores by design.
    #[cfg(unix)]
    unsafe {
        libc::signal(libc::SIGPIPE, libc::SIG_IGN);
    }
}

/// Prints the reason and gives exit code 2 (unusable input).
pub fn unusable(msg: impl std::fmt::Display) -> ExitCode {
    eprintln!("pmacwd: {msg}");
    ExitCode::from(2)
}

/// The checker threads for `--threads`: 1 to the machine's cores (default: all of them). More
/// threads than cores only slow the checker down, and 0 would check nothing.
pub fn threads(requested: Option<usize>) -> Result<usize, ExitCode> {
    let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
    match requested {
        None => Ok(cores),
        Some(n) if (1..=cores).contains(&n) => Ok(n),
        Some(n) => Err(unusable(format!("--threads {n}: give 1 to {cores} (the cores of this machine)"))),
    }
}

/// The spec directory given with `--specs`, or the embedded one.
pub fn load_spec(specs: &Option<PathBuf>) -> Result<Spec, ExitCode> {
    match specs {
        Some(dir) => Spec::load_dir(dir),
        None => Spec::embedded(),
    }
    .map_err(|e| {
        eprintln!("pmacwd: {e}");
        ExitCode::from(2)
    })
}

/// A trace to run: a file, or a scenario compiled into the binary.
pub struct TraceFile {
    /// Where it is, or for an embedded scenario where it came from (`specs/scenarios/...`).
    pub path: PathBuf,
    embedded: Option<&'static str>,
}

impl TraceFile {
    /// The trace, in either form (YAML or JSON Lines, told apart as `replay` does).
    pub fn load(&self) -> Result<LoadedTrace, SpecError> {
        match self.embedded {
            Some(text) => pmacwd_trace::parse(&self.path, text),
            None => pmacwd_trace::load(&self.path),
        }
    }

    pub fn display(&self) -> std::path::Display<'_> {
        self.path.display()
    }
}

/// The scenario library: `scenarios/` of the `--specs` directory when one is given, otherwise
/// the copy compiled into the binary, so that every subcommand works from any folder.
pub fn scenario_library(specs: &Option<PathBuf>) -> Result<Vec<TraceFile>, String> {
    match specs {
        Some(dir) => trace_files(&[dir.join("scenarios")]),
        None => Ok(pmacwd_specs::scenarios::SCENARIOS
            .iter()
            .map(|(name, text)| TraceFile { path: Path::new("specs/scenarios").join(name), embedded: Some(text) })
            .collect()),
    }
}

/// The extensions of trace files a directory is searched for: both forms.
const TRACE_EXTENSIONS: [&str; 3] = ["yaml", "yml", "jsonl"];

/// Trace files: each path a file, or a directory whose traces (`.yaml`, `.yml`, `.jsonl`) are
/// taken in name order. Host logs in a directory (`.log`) are not traces: they are named on
/// standard error with what to do with them, not run and not skipped silently.
pub fn trace_files(paths: &[PathBuf]) -> Result<Vec<TraceFile>, String> {
    let mut files = Vec::new();
    for p in paths {
        if p.is_dir() {
            let entries = std::fs::read_dir(p).map_err(|e| format!("{}: {e}", p.display()))?;
            let mut found: Vec<PathBuf> = Vec::new();
            let mut logs: Vec<PathBuf> = Vec::new();
            for path in entries.flatten().map(|e| e.path()) {
                let ext = path.extension().and_then(|x| x.to_str()).unwrap_or("");
                if TRACE_EXTENSIONS.contains(&ext) {
                    found.push(path);
                } else if ext == "log" {
                    logs.push(path);
                }
            }
            found.sort();
            logs.sort();
            if !logs.is_empty() {
                let names: Vec<String> = logs.iter().map(|l| l.display().to_string()).collect();
                eprintln!(
                    "pmacwd: not run: {}: {} (judge a host log with `pmacwd replay LOG`, or turn it into a trace with `pmacwd import`)",
                    plural(logs.len() as u64, "host log, not a trace", "host logs, not traces"),
                    names.join(", ")
                );
            }
            if found.is_empty() {
                return Err(format!("{}: no traces (.yaml, .yml, .jsonl) in this directory", p.display()));
            }
            files.extend(found.into_iter().map(|path| TraceFile { path, embedded: None }));
        } else if p.is_file() {
            files.push(TraceFile { path: p.clone(), embedded: None });
        } else if p.exists() {
            // A FIFO, a device: say what it is rather than "no such file".
            return Err(pmacwd_specs::input::open_regular(p)
                .err()
                .map_or_else(|| format!("{}: not a regular file", p.display()), |e| e.to_string()));
        } else {
            return Err(format!("{}: no such file or directory", p.display()));
        }
    }
    Ok(files)
}

/// The resolved configuration `serve` and `record` run with.
pub fn model_config(
    specs: &Option<PathBuf>,
    configuration: &str,
    profile: Option<&str>,
) -> Result<ModelConfig, String> {
    let spec = match specs {
        Some(dir) => Spec::load_dir(dir),
        None => Spec::embedded(),
    }
    .map_err(|e| e.to_string())?;
    let profile = match profile {
        Some(name) => spec
            .profiles
            .get(name)
            .ok_or_else(|| format!("no profile named `{name}` (profiles: {})", spec.profiles.names()))?,
        None => spec.profiles.default_profile(),
    };
    ModelConfig::from_spec(&spec, configuration, &profile).map_err(|e| e.to_string())
}

/// A capture file, opened for writing.
pub fn create_capture(
    path: &Path,
    description: &str,
    configuration: &str,
    timing: pmacwd_emulator::capture::Timing,
) -> Result<CaptureWriter<Box<dyn Write + Send>>, String> {
    let file = std::fs::File::create(path).map_err(|e| format!("{}: {e}", path.display()))?;
    let out: Box<dyn Write + Send> = Box::new(std::io::BufWriter::new(file));
    CaptureWriter::new(out, description, configuration, timing).map_err(|e| format!("{}: {e}", path.display()))
}

/// `1 run`, `2 runs`: `n` and the singular or plural words (given whole, for irregular ones:
/// `plural(n, "host log, not a trace", "host logs, not traces")`).
pub fn plural(n: impl Into<u128> + Copy, one: &str, many: &str) -> String {
    let n: u128 = n.into();
    format!("{n} {}", if n == 1 { one } else { many })
}

/// A listen address as `--listen` and `--control` take it: `HOST:PORT`, where HOST is an
/// address or a name (`localhost:1025`), resolved now; of several addresses the first IPv4 one,
/// as the default `127.0.0.1` is. For clap's `value_parser`.
pub fn listen_address(text: &str) -> Result<std::net::SocketAddr, String> {
    use std::net::ToSocketAddrs;
    let usage = "give HOST:PORT, HOST an address or a name: 127.0.0.1:1025, localhost:1025, [::1]:1025";
    let found: Vec<std::net::SocketAddr> = match text.to_socket_addrs() {
        Ok(addrs) => addrs.collect(),
        Err(e) => return Err(format!("{e}; {usage}")),
    };
    found
        .iter()
        .find(|a| a.is_ipv4())
        .or(found.first())
        .copied()
        .ok_or_else(|| format!("`{text}` names no address; {usage}"))
}

/// A clap value parser for a numeric flag: a number in `min..=max`, or an error that gives the
/// accepted range (and `why`, when the bound has a reason), so that every numeric flag is
/// checked before any work and refused with exit 2 (issue 33: `conform --max-len` with a huge
/// value aborted allocating the generator's trees).
pub fn ranged<T>(min: T, max: T, why: &'static str) -> impl Fn(&str) -> Result<T, String> + Clone + Send + Sync
where
    T: std::str::FromStr + PartialOrd + Copy + std::fmt::Display + Send + Sync + 'static,
{
    move |text: &str| match text.trim().parse::<T>() {
        Ok(v) if min <= v && v <= max => Ok(v),
        _ => Err(format!("give {min} to {max}{why}")),
    }
}

/// `--servo-hz` as `serve`, `record` and `margin` take it: any whole number a `u32` holds goes
/// on to the check against the spec's servo clock range (which `--specs` may change); anything
/// else is refused here with the shipped range.
pub fn servo_hz(text: &str) -> Result<u32, String> {
    text.trim().parse::<u32>().map_err(|_| {
        format!(
            "the servo clock ranges 1..{} Hz (scheduling.yaml's servo_clock_hz_range)",
            pmacwd_emulator::card::SERVO_HZ_MAX
        )
    })
}

/// `--x25` / `--y25` of `pmacwd margin`: a watchdog counter value as the card gives it. The
/// reply of `RHX:$25` / `RHY:$25` is six hex digits (`000FF0`; `FFFFFF` is -1, the counter
/// gone below zero, SRM p.57), `$` and up to six hex digits is the card's own notation for a
/// hex value (`$FF0`), and anything else is decimal (`4080`, `-1`).
///
/// MODEL: the counter's word is 24 bits wide (six hex digits, as the reply shows), read as two's
/// complement, so `$800000` to `$FFFFFF` are -8,388,608 to -1. Six decimal digits are read as
/// the reply form, hex (`004080` is $4080, 16,512): a decimal reading has fewer digits or a sign.
pub fn card_reading(text: &str) -> Result<i32, String> {
    const USAGE: &str = "give the reading as RHX:$25 replies it, six hex digits (000FF0; FFFFFF is -1), as $ and up \
                         to six hex digits ($FF0), or in decimal (4080, -1)";
    let t = text.trim();
    let hex = |digits: &str| -> Option<i32> {
        if digits.is_empty() || digits.len() > 6 || !digits.chars().all(|c| c.is_ascii_hexdigit()) {
            return None;
        }
        let word = i32::from_str_radix(digits, 16).ok()?;
        Some(if word >= 0x80_0000 { word - 0x100_0000 } else { word })
    };
    let value = if let Some(digits) = t.strip_prefix('$') {
        hex(digits)
    } else if t.len() == 6 && t.chars().all(|c| c.is_ascii_hexdigit()) {
        hex(t)
    } else {
        t.parse::<i32>().ok().filter(|v| (-0x80_0000..0x80_0000).contains(v))
    };
    value.ok_or_else(|| format!("`{t}`: {USAGE}"))
}

/// `--plc0-us` / `--background-us` of `pmacwd margin`: a time in microseconds, 0 or more (a
/// decimal number: `133.3`); converted to CPU units by the configuration
/// (`pmacwd_capture::margin::units_of_us`).
pub fn micros(text: &str) -> Result<f64, String> {
    match text.trim().parse::<f64>() {
        Ok(us) if us.is_finite() && us >= 0.0 => Ok(us),
        _ => Err("give a time in microseconds, 0 or more (133.3)".to_string()),
    }
}

/// `--cpu-load` of `pmacwd margin`: a percentage of the CPU as the EPICS pmac driver shows it,
/// 0 to 100 (a decimal number: `26.2`). The driver's figure is the foreground's share of the
/// CPU (UM p.240), which cannot exceed the whole of it.
pub fn percent(text: &str) -> Result<f64, String> {
    match text.trim().parse::<f64>() {
        Ok(p) if p.is_finite() && (0.0..=100.0).contains(&p) => Ok(p),
        _ => Err("give a CPU load of 0 to 100 percent (26.2)".to_string()),
    }
}

/// `--threads`: 1 to the machine's cores, as [`threads`] checks it, refused at parse time too
/// when the number does not even fit.
pub fn threads_flag(text: &str) -> Result<usize, String> {
    let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
    match text.trim().parse::<usize>() {
        Ok(n) => Ok(n),
        Err(_) => Err(format!("give 1 to {cores} (the cores of this machine)")),
    }
}

/// `--format` of every command that prints a report: text for a person, or one JSON document
/// for a program. One type for every command, so that the flag reads and behaves the same
/// everywhere (issue 34); the documents' schemas are in docs/json.md.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum Format {
    /// Lines for a person to read.
    Text,
    /// One JSON document on standard output, with `command` and `version` (docs/json.md).
    Json,
}

impl Format {
    /// `--format`, or JSON when the old `--json` flag of `decode` and `margin` was given (clap
    /// refuses the two together).
    pub fn or_json(self, json: bool) -> Format {
        if json {
            Format::Json
        } else {
            self
        }
    }
}

/// The schema versions of the JSON documents `--format json` prints, one per document kind
/// (docs/json.md, which gives every field). A version goes up when a field is removed or
/// renamed, or changes its type, unit or meaning; a field may be added without a new version,
/// so a reader ignores fields it does not know.
pub mod json_version {
    /// `pmacwd check --format json`.
    pub const CHECK: u32 = 1;
    /// `pmacwd run --format json`.
    pub const RUN: u32 = 1;
    /// `pmacwd conform --format json`.
    pub const CONFORM: u32 = 1;
    /// `pmacwd decode --format json`.
    pub const DECODE: u32 = 1;
    /// `pmacwd replay --format json`.
    pub const REPLAY: u32 = 1;
    /// `pmacwd margin --format json`.
    pub const MARGIN: u32 = 1;
    /// `pmacwd requirements --format json`.
    pub const REQUIREMENTS: u32 = 1;
    /// `pmacwd probe --format json`.
    pub const PROBE: u32 = 1;
}

/// A report as the JSON document `--format json` prints: the object with `command` (the
/// subcommand that printed it) and `version` (its schema's, [`json_version`]) added.
pub fn json_document(command: &str, version: u32, report: serde_json::Value) -> serde_json::Value {
    let mut object = match report {
        serde_json::Value::Object(o) => o,
        // Every report is an object; anything else is kept whole under `report`.
        other => std::iter::once(("report".to_string(), other)).collect(),
    };
    object.insert("command".to_string(), serde_json::Value::from(command));
    object.insert("version".to_string(), serde_json::Value::from(version));
    serde_json::Value::Object(object)
}

/// [`json_document`] of a report already written as JSON text (the capture crate's reports).
pub fn json_document_of_text(command: &str, version: u32, report: &str) -> serde_json::Value {
    let value = serde_json::from_str(report).unwrap_or_else(|_| serde_json::Value::String(report.to_string()));
    json_document(command, version, value)
}

/// `--log-format` of `pmacwd import` and `pmacwd replay`: the kind of log.
#[derive(Clone, Copy, Debug, clap::ValueEnum)]
pub enum LogFormatArg {
    /// `> command` / `< reply` lines.
    HostLog,
    /// An EPICS IOC's asyn trace of the pmac driver's port.
    Asyn,
    /// A pcap or pcapng capture of the Ethernet protocol (TCP port 1025).
    Pcap,
}

impl From<LogFormatArg> for pmacwd_capture::import::LogFormat {
    fn from(f: LogFormatArg) -> Self {
        use pmacwd_capture::import::LogFormat;
        match f {
            LogFormatArg::HostLog => LogFormat::HostLog,
            LogFormatArg::Asyn => LogFormat::Asyn,
            LogFormatArg::Pcap => LogFormat::Pcap,
        }
    }
}
