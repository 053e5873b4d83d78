//! `pmacwd replay`: a capture against the model under every profile.

use crate::common::{json_document_of_text, json_version, load_spec, Format};
use std::path::PathBuf;
use std::process::ExitCode;

/// What `pmacwd replay` was given.
pub struct ReplayArgs {
    pub file: PathBuf,
    pub format: Format,
    pub specs: Option<PathBuf>,
    pub configuration: Option<String>,
    pub log_format: Option<pmacwd_capture::import::LogFormat>,
    pub witness: Option<PathBuf>,
    pub host_time_seconds: u64,
    /// The card's saved I40 where the log does not read it.
    pub i40: Option<i64>,
}

pub fn replay_file(args: ReplayArgs) -> ExitCode {
    let ReplayArgs { file, format, specs, configuration, log_format, witness, host_time_seconds, i40 } = args;
    let file = file.as_path();
    let spec = match load_spec(&specs) {
        Ok(s) => s,
        Err(code) => return code,
    };
    use pmacwd_capture::explain::report;
    // A capture of millions of lines, or one step of millions of servo cycles, takes minutes:
    // say how far the search has come.
    let ticker = crate::progress::Ticker::start("replay", 1, "captures", || {
        let line = pmacwd_capture::explain::search::LINE_REACHED.load(std::sync::atomic::Ordering::Relaxed);
        (0, format!("searching at line {}", crate::progress::thousands(line as u64)))
    });
    let import = pmacwd_capture::replay::ImportAs {
        configuration: configuration.as_deref(),
        format: log_format,
        placement: pmacwd_capture::import::Placement::AtReads,
        host_time_limit: (host_time_seconds > 0).then(|| std::time::Duration::from_secs(host_time_seconds)),
        deadline: None,
        card_i40: i40,
    };
    let explained = report::explain_as(&spec, file, import);
    ticker.finish();
    match explained {
        Ok(report) => {
            if let (Some(out), Some((readings, w))) = (&witness, &report.witness) {
                let written = std::fs::File::create(out).and_then(|f| {
                    let mut f = std::io::BufWriter::new(f);
                    pmacwd_capture::explain::witness::write_trace(
                        &spec,
                        &mut f,
                        out.extension().is_some_and(|e| e == "yaml" || e == "yml"),
                        w,
                        pmacwd_capture::explain::witness::WitnessHeader {
                            configuration: &report.configuration,
                            card: report.card.as_ref(),
                            readings,
                            profiles: report.witness_profiles.clone(),
                        },
                    )?;
                    std::io::Write::flush(&mut f)
                });
                if let Err(e) = written {
                    eprintln!("pmacwd: {}: cannot write the witness: {e}", out.display());
                    return ExitCode::from(2);
                }
                eprintln!("pmacwd: the explanation written to {} ({} steps)", out.display(), w.steps);
            } else if let Some(out) = &witness {
                eprintln!("pmacwd: no explanation to write to {}: the capture is not explained", out.display());
            }
            match format {
                Format::Text => print!("{}", report::to_text(&report)),
                Format::Json => {
                    println!("{}", json_document_of_text("replay", json_version::REPLAY, &report::to_json(&report)))
                }
            }
            if report.explained() {
                ExitCode::SUCCESS
            } else if report.undecided() {
                // The log cannot be timed: no verdict, so not a violation (exit 2, as for a log
                // unusable for the question asked).
                ExitCode::from(2)
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
