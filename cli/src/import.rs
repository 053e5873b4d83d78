//! `pmacwd import`: a plain host log to a trace.

use std::path::PathBuf;
use std::process::ExitCode;

pub fn import_log(log: &std::path::Path, out: Option<PathBuf>, configuration: &str, yaml: bool) -> ExitCode {
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
