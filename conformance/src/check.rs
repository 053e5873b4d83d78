//! `pmacwd check`: model-check every profile at the bounded configurations of `check.yaml`.

use pmacwd_model::checker::{PropertyResult, RunReport, TraceStep, WatchdogModel};
use pmacwd_model::properties::Expectation;
use pmacwd_specs::config::ModelConfig;
use pmacwd_specs::{Spec, SpecError};
use std::fmt::Write as _;

/// Which runs to do.
#[derive(Clone, Debug, Default)]
pub struct Selection {
    /// Only this profile.
    pub profile: Option<String>,
    /// Only this configuration.
    pub configuration: Option<String>,
}

/// The (configuration, profile) pairs selected from `check.yaml`, as resolved model configs.
pub fn planned_runs(spec: &Spec, sel: &Selection) -> Result<Vec<ModelConfig>, SpecError> {
    if let Some(p) = &sel.profile {
        if spec.profiles.get(p).is_none() {
            let names: Vec<&str> = spec.profiles.profiles.keys().map(String::as_str).collect();
            return Err(SpecError::whole_file(
                &spec.dir.join("profiles.yaml"),
                format!("no profile named `{p}` (profiles: {})", names.join(", ")),
            ));
        }
    }
    if let Some(c) = &sel.configuration {
        if !spec.check.configurations.contains_key(c) {
            let names: Vec<&str> = spec.check.configurations.keys().map(String::as_str).collect();
            return Err(SpecError::whole_file(
                &spec.dir.join("check.yaml"),
                format!("no configuration named `{c}` (configurations: {})", names.join(", ")),
            ));
        }
    }
    let mut out = Vec::new();
    for run in &spec.check.runs {
        if sel.configuration.as_ref().is_some_and(|c| *c != run.configuration) {
            continue;
        }
        // The loader has checked every name of check.yaml's runs.
        let profiles = spec
            .profiles
            .select(&run.profiles)
            .map_err(|(_, n)| SpecError::whole_file(&spec.dir.join("check.yaml"), format!("no profile named `{n}`")))?;
        for profile in profiles {
            if sel.profile.as_ref().is_some_and(|p| *p != profile.name) {
                continue;
            }
            out.push(ModelConfig::from_spec(spec, &run.configuration, &profile)?);
        }
    }
    Ok(out)
}

pub fn run(cfg: ModelConfig, threads: usize) -> RunReport {
    WatchdogModel::new(cfg).check(threads)
}

/// As [`run`], telling `progress` how far the checker has come while it runs.
pub fn run_observed(
    cfg: ModelConfig,
    threads: usize,
    progress: &mut dyn FnMut(pmacwd_model::checker::Explored),
) -> RunReport {
    WatchdogModel::new(cfg).check_observed(threads, progress)
}

/// `1234567` as `1,234,567`.
pub fn thousands(n: u64) -> String {
    let s = n.to_string();
    let mut out = String::new();
    for (i, c) in s.chars().enumerate() {
        if i > 0 && (s.len() - i) % 3 == 0 {
            out.push(',');
        }
        out.push(c);
    }
    out
}

/// The report of one run, as printed. Witnesses of `sometimes` properties are printed only
/// when `witnesses` is set; counterexamples always are.
pub fn format_report(r: &RunReport, default_profile: &str, witnesses: bool) -> String {
    let mut s = String::new();
    let tag = if r.profile == default_profile { " (default profile)" } else { "" };
    let _ = writeln!(s, "== configuration {} / profile {}{} ==", r.configuration, r.profile, tag);
    let _ = writeln!(
        s,
        "   {} states, depth {}, {:.2} s, {} states/s",
        thousands(r.states as u64),
        r.depth,
        r.duration.as_secs_f64(),
        thousands(r.states_per_second() as u64)
    );
    if !r.complete {
        let _ = writeln!(
            s,
            "   INCOMPLETE: the checker stopped after generating {} states (its bound); no verdict below is earned. \
             Make the configuration smaller (I40, hardware delay, single_servo_cycles) to check it exhaustively.",
            thousands(pmacwd_model::checker::STATES_MAX as u64)
        );
    }
    for p in &r.properties {
        if !p.applicable {
            let _ = writeln!(s, "   n/a      sometimes {}  [{}]  (needs {})", p.name, p.cite, p.needs);
            continue;
        }
        let verdict = match (p.holds, p.expectation) {
            (true, Expectation::Always) => "holds   ",
            (true, Expectation::Sometimes) => "reached ",
            (false, Expectation::Always) => "VIOLATED",
            (false, Expectation::Sometimes) => "NEVER   ",
        };
        let kind = match p.expectation {
            Expectation::Always => "always   ",
            Expectation::Sometimes => "sometimes",
        };
        let _ = writeln!(s, "   {verdict} {kind} {}  [{}]", p.name, p.cite);
        let show = match p.expectation {
            Expectation::Always => !p.holds,
            Expectation::Sometimes => witnesses && p.holds,
        };
        if show {
            write_path(&mut s, p);
        }
        if !p.holds && p.expectation == Expectation::Sometimes {
            let _ = writeln!(s, "            no reachable state shows this: the configuration is too narrow, or the model lost the behaviour");
        }
    }
    s
}

fn write_path(s: &mut String, p: &PropertyResult) {
    let Some(path) = &p.path else { return };
    let what = if p.expectation == Expectation::Always { "shortest counterexample" } else { "shortest witness" };
    let _ = writeln!(s, "            {what} ({} events from power-up): \"{}\"", path.len(), p.sentence);
    for (i, step) in path.iter().enumerate() {
        let _ = writeln!(s, "            {:>3}. {}", i + 1, describe(step));
    }
}

/// The verdict word of a property, as the text report prints it and the JSON report names it:
/// `holds`, `reached`, `n/a`, `VIOLATED`, `NEVER`.
pub fn verdict(p: &PropertyResult) -> &'static str {
    match (p.applicable, p.holds, p.expectation) {
        (false, ..) => "n/a",
        (true, true, Expectation::Always) => "holds",
        (true, true, Expectation::Sometimes) => "reached",
        (true, false, Expectation::Always) => "VIOLATED",
        (true, false, Expectation::Sometimes) => "NEVER",
    }
}

/// One run as JSON (the schema is in `docs/commands.md`, `check --format json`): every
/// property with its verdict, and its shortest counterexample or witness as steps.
pub fn report_json(r: &RunReport, default_profile: &str) -> serde_json::Value {
    let properties: Vec<serde_json::Value> = r
        .properties
        .iter()
        .map(|p| {
            let path = p.path.as_ref().map(|path| {
                path.iter()
                    .map(|step| {
                        let o = &step.observation;
                        serde_json::json!({
                            "event": step.event.to_string(),
                            "reply": (o.reply != pmacwd_specs::vocab::event::Reply::None).then(|| o.reply.to_string()),
                            "counter": o.counter, "counter_min": o.counter_min,
                            "status": format!("{:06X}{:06X}", o.status_x, o.status_y),
                            "tripped": o.led_red,
                        })
                    })
                    .collect::<Vec<_>>()
            });
            serde_json::json!({
                "name": p.name,
                "kind": match p.expectation { Expectation::Always => "always", Expectation::Sometimes => "sometimes" },
                "verdict": verdict(p),
                "cite": p.cite,
                "needs": (!p.applicable).then_some(p.needs),
                "path": path,
            })
        })
        .collect();
    serde_json::json!({
        "configuration": r.configuration,
        "profile": r.profile,
        "default_profile": r.profile == default_profile,
        "complete": r.complete,
        "states": r.states,
        "depth": r.depth,
        "seconds": r.duration.as_secs_f64(),
        "properties": properties,
    })
}

/// One trace step as a line: the event, then what could be observed after it.
pub fn describe(step: &TraceStep) -> String {
    let o = &step.observation;
    let mut line = format!("{:<44}", step.event.to_string());
    if o.reply != pmacwd_specs::vocab::event::Reply::None {
        let _ = write!(line, " reply {:<14}", o.reply.to_string());
    }
    let _ = write!(line, " Y:$25={} X:$25={} status={:06X}{:06X}", o.counter, o.counter_min, o.status_x, o.status_y);
    if o.led_red {
        line.push_str(" TRIPPED (red LED, FEFCO/ on, relay over, outputs off)");
    }
    line
}
