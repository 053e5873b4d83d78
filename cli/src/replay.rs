//! `pmacwd replay`: a capture against the model under every profile.

use crate::common::load_spec;
use std::path::PathBuf;
use std::process::ExitCode;

#[derive(Clone, Copy, clap::ValueEnum)]
pub enum Format {
    Text,
    Json,
}

pub fn replay_file(
    file: &std::path::Path,
    format: Format,
    specs: Option<PathBuf>,
    configuration: Option<String>,
) -> ExitCode {
    let spec = match load_spec(&specs) {
        Ok(s) => s,
        Err(code) => return code,
    };
    use pmacwd_conformance::explain::report;
    match report::explain(&spec, file, configuration.as_deref()) {
        Ok(report) => {
            match format {
                Format::Text => print!("{}", report::to_text(&report)),
                Format::Json => println!("{}", report::to_json(&report)),
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
