//! `pmacwd import`: a plain host log to a trace, streamed: the log is read one line at a time
//! and each step written as it is complete, so memory does not grow with the log.
//!
//! With `--out FILE` the trace goes to a temporary file beside FILE, renamed to FILE only when
//! the whole log imported, so a failed import never leaves a half trace under FILE. On standard
//! output the steps before an error have already been written; the error and exit code 2 say
//! the trace is incomplete.

use crate::common::unusable;
use pmacwd_conformance::import::{header, Importer};
use pmacwd_specs::input::{open_regular, Lines};
use pmacwd_specs::Spec;
use pmacwd_trace::Step;
use std::io::{BufReader, BufWriter, Write};
use std::path::{Path, PathBuf};
use std::process::ExitCode;

/// How the trace is written: JSON Lines or YAML, one step at a time.
#[derive(Clone, Copy)]
enum Form {
    Jsonl,
    Yaml,
}

impl Form {
    fn header(self, out: &mut dyn Write, trace: &pmacwd_trace::Trace) -> std::io::Result<()> {
        match self {
            Form::Jsonl => writeln!(out, "{}", pmacwd_trace::jsonl::header_line(trace)),
            Form::Yaml => out.write_all(pmacwd_trace::yaml_header(trace).as_bytes()),
        }
    }
    fn step(self, out: &mut dyn Write, step: &Step) -> std::io::Result<()> {
        match self {
            Form::Jsonl => writeln!(out, "{}", pmacwd_trace::jsonl::step_line(step)),
            Form::Yaml => out.write_all(pmacwd_trace::yaml_step(step).as_bytes()),
        }
    }
}

pub fn import_log(log: &Path, out: Option<PathBuf>, configuration: &str, yaml: bool) -> ExitCode {
    // The configuration is checked now, not at replay: the trace would name one that does not
    // exist.
    match Spec::embedded() {
        Ok(spec) if !spec.check.configurations.contains_key(configuration) => {
            let names: Vec<&str> = spec.check.configurations.keys().map(String::as_str).collect();
            return unusable(format!(
                "--configuration: no configuration named `{configuration}` (configurations: {})",
                names.join(", ")
            ));
        }
        Ok(_) => {}
        Err(e) => return unusable(e),
    }
    let file = match open_regular(log) {
        Ok(f) => f,
        Err(e) => return unusable(e),
    };
    let form = if yaml { Form::Yaml } else { Form::Jsonl };
    match out {
        Some(path) => {
            let partial = partial_path(&path);
            let result = std::fs::File::create(&partial)
                .map_err(|e| format!("{}: cannot write: {e}", partial.display()))
                .and_then(|f| {
                    let mut w = BufWriter::new(f);
                    let steps = write_trace(log, file, configuration, form, &mut w)?;
                    w.flush().map_err(|e| format!("{}: cannot write: {e}", partial.display()))?;
                    Ok(steps)
                })
                .and_then(|steps| {
                    std::fs::rename(&partial, &path).map_err(|e| format!("{}: cannot write: {e}", path.display()))?;
                    Ok(steps)
                });
            match result {
                Ok(steps) => {
                    eprintln!("pmacwd: wrote {steps} steps to {}", path.display());
                    ExitCode::SUCCESS
                }
                Err(e) => {
                    let _ = std::fs::remove_file(&partial);
                    unusable(e)
                }
            }
        }
        None => {
            let stdout = std::io::stdout();
            let mut w = BufWriter::new(stdout.lock());
            let result = write_trace(log, file, configuration, form, &mut w);
            let _ = w.flush();
            match result {
                Ok(_) => ExitCode::SUCCESS,
                Err(e) => unusable(e),
            }
        }
    }
}

/// `FILE.partial` beside `FILE`.
fn partial_path(path: &Path) -> PathBuf {
    let mut name = path.file_name().map(|n| n.to_os_string()).unwrap_or_default();
    name.push(".partial");
    path.with_file_name(name)
}

/// Imports the log into `out`; the number of steps written.
fn write_trace(
    log: &Path,
    file: std::fs::File,
    configuration: &str,
    form: Form,
    out: &mut dyn Write,
) -> Result<u64, String> {
    let write_error = |e: std::io::Error| format!("cannot write the trace: {e}");
    form.header(out, &header(log, configuration)).map_err(write_error)?;
    let mut importer = Importer::new(log);
    let mut lines = Lines::new(log, BufReader::new(file));
    let mut steps = 0u64;
    while let Some((n, text)) = lines.next().map_err(|e| e.to_string())? {
        for step in importer.line(n, &text).map_err(|e| e.to_string())? {
            form.step(out, &step).map_err(write_error)?;
            steps += 1;
        }
    }
    importer.finish().map_err(|e| e.to_string())?;
    Ok(steps)
}
