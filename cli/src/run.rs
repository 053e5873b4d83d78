//! `pmacwd run`: traces on the reference model.

use crate::common::Format;
use crate::common::{load_spec, plural, scenario_library, trace_files};
use std::path::PathBuf;
use std::process::ExitCode;

pub fn run_traces(paths: Vec<PathBuf>, specs: Option<PathBuf>, profile: Option<String>, format: Format) -> ExitCode {
    use pmacwd_conformance::runner::{profiles_of, run_on_model, Failure};
    let spec = match load_spec(&specs) {
        Ok(s) => s,
        Err(code) => return code,
    };
    // No path: the scenario library.
    let found = if paths.is_empty() { scenario_library(&specs) } else { trace_files(&paths) };
    let files = match found {
        Ok(f) => f,
        Err(e) => {
            eprintln!("pmacwd: {e}");
            return ExitCode::from(2);
        }
    };
    let text = matches!(format, Format::Text);
    // One trace may take minutes (many steps of millions of servo cycles, each run per
    // profile): say which run is under way.
    let now = std::sync::Arc::new(std::sync::Mutex::new((0u64, String::new())));
    let shown = std::sync::Arc::clone(&now);
    let ticker = crate::progress::Ticker::start("run", files.len() as u64, "traces", move || {
        shown.lock().map(|s| s.clone()).unwrap_or_default()
    });
    let (mut passed, mut diverged) = (0usize, 0usize);
    let mut results: Vec<serde_json::Value> = Vec::new();
    for (done, file) in files.iter().enumerate() {
        let loaded = match file.load() {
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
            let trace = file.display().to_string();
            if let Ok(mut now) = now.lock() {
                *now = (done as u64, format!("{trace} [{}]", p.name));
            }
            match run_on_model(&spec, &loaded, &p) {
                Ok(n) => {
                    passed += 1;
                    if text {
                        ticker.println(&format!(
                            "ok        {trace} [{}] ({})",
                            p.name,
                            plural(n as u64, "expectation", "expectations")
                        ));
                    }
                    results.push(serde_json::json!({
                        "trace": trace, "profile": p.name, "verdict": "ok", "expectations": n, "divergence": null,
                    }));
                }
                Err(Failure::Unusable(e)) => {
                    eprintln!("pmacwd: {e}");
                    return ExitCode::from(2);
                }
                Err(Failure::Diverged(d)) => {
                    diverged += 1;
                    if text {
                        ticker.println(&format!("DIVERGED  {trace} [{}]\n  {d}", p.name));
                    }
                    results.push(serde_json::json!({
                        "trace": trace, "profile": p.name, "verdict": "diverged", "expectations": null,
                        "divergence": d.to_json(),
                    }));
                }
            }
        }
    }
    ticker.finish();
    let code = if diverged == 0 { 0 } else { 1 };
    match format {
        Format::Text => println!("{passed} passed, {diverged} failed"),
        Format::Json => println!(
            "{}",
            crate::common::json_document(
                "run",
                crate::common::json_version::RUN,
                serde_json::json!({"runs": results, "passed": passed, "failed": diverged, "exit": code}),
            )
        ),
    }
    ExitCode::from(code)
}
