//! What every subcommand shares: the spec directory, trace files, and unusable input.

use pmacwd_emulator::capture::CaptureWriter;
use pmacwd_specs::config::ModelConfig;
use pmacwd_specs::{Spec, SpecError};
use pmacwd_trace::LoadedTrace;
use std::io::Write;
use std::path::{Path, PathBuf};
use std::process::ExitCode;

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
    pub fn load(&self) -> Result<LoadedTrace, SpecError> {
        match self.embedded {
            Some(text) => pmacwd_trace::parse_yaml(&self.path, text),
            None => pmacwd_trace::load_yaml(&self.path),
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

/// Trace files: each path a file, or a directory whose `.yaml` files are taken in name order.
pub fn trace_files(paths: &[PathBuf]) -> Result<Vec<TraceFile>, String> {
    let mut files = Vec::new();
    for p in paths {
        if p.is_dir() {
            let entries = std::fs::read_dir(p).map_err(|e| format!("{}: {e}", p.display()))?;
            let mut found: Vec<PathBuf> = entries
                .flatten()
                .map(|e| e.path())
                .filter(|f| f.extension().is_some_and(|x| x == "yaml" || x == "yml"))
                .collect();
            found.sort();
            if found.is_empty() {
                return Err(format!("{}: no .yaml traces in this directory", p.display()));
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
