//! A counterexample or witness of `pmacwd check` as a trace (`check --save DIR`): the path's
//! events, each with everything the checker observed after it as the step's expectation, so
//! that `pmacwd run` reproduces it on the model (and on any implementation), `pmacwd timeline`
//! draws it, and a reviewer can keep it as a regression scenario.
//!
//! The checker explores every deceleration length of a stop command (1 to the configuration's
//! `decel_cycles_max`, `model/src/motion.rs`); a trace has no way to choose one, and a
//! deterministic run decelerates for the longest. A path that took a shorter one is saved with
//! a note on the step that chose it, and [`reproduces`] tells whether `pmacwd run` gives back
//! every observation the checker saw.

use crate::runner::{self, Failure};
use pmacwd_model::checker::{PropertyResult, RunReport, TraceStep, WatchdogModel};
use pmacwd_model::properties::Expectation;
use pmacwd_specs::check::ProfileSelection;
use pmacwd_specs::cite::{Cite, Cites};
use pmacwd_specs::config::StatusLayout;
use pmacwd_specs::status::WordId;
use pmacwd_specs::vocab::observation::Observation;
use pmacwd_specs::Spec;
use pmacwd_trace::{Expect, Step, Trace, TraceEvent, FORMAT_VERSION};

/// The trace of `p`'s path in run `r`, or `None` when the property has no path (it holds as an
/// `always`, or as a `sometimes` it was never reached) or an empty one: a `sometimes` property
/// the power-up state already shows has no event to hang an expectation on (a trace needs at
/// least one step), which [`reached_at_power_up`] tells apart.
pub fn path_trace(spec: &Spec, r: &RunReport, p: &PropertyResult) -> Option<Trace> {
    let path = p.path.as_ref().filter(|path| !path.is_empty())?;
    let what = match p.expectation {
        Expectation::Always => "Shortest counterexample of",
        Expectation::Sometimes => "Shortest witness of",
    };
    // A property's citation is text such as `UM p.215` or `UM p.214-215; SRM p.57`; one that
    // does not parse as citations stays in the description rather than being lost.
    let cite: Result<Vec<Cite>, String> = p.cite.split(';').map(Cite::parse).collect();
    let (cite, cite_text) = match cite {
        Ok(c) if !c.is_empty() => (Some(Cites(c)), String::new()),
        _ => (None, format!(" [{}]", p.cite)),
    };
    Some(Trace {
        version: FORMAT_VERSION,
        description: format!(
            "{what} `{}` (\"{}\"){cite_text}, found by pmacwd check in configuration {} under profile {}: {} events from power-up.",
            p.name,
            p.sentence,
            r.configuration,
            r.profile,
            path.len()
        ),
        cite,
        configuration: r.configuration.clone(),
        profiles: ProfileSelection::Named(vec![r.profile.clone()]),
        steps: path.iter().map(|s| step(spec, s)).collect(),
    })
}

/// Whether `p`'s path is empty: the state at power-up already shows it.
pub fn reached_at_power_up(p: &PropertyResult) -> bool {
    p.path.as_ref().is_some_and(Vec::is_empty)
}

/// A file name for `p`'s trace in run `r`: `configuration-profile-property.yaml`, each part
/// kept to the characters a file name can always hold.
pub fn file_name(r: &RunReport, p: &PropertyResult) -> String {
    let clean = |s: &str| -> String {
        s.chars().map(|c| if c.is_ascii_alphanumeric() || c == '-' || c == '_' { c } else { '_' }).collect()
    };
    format!("{}-{}-{}.yaml", clean(&r.configuration), clean(&r.profile), clean(p.name))
}

/// One step: the event, and what the checker observed after it as the expectation.
fn step(spec: &Spec, s: &TraceStep) -> Step {
    Step { event: TraceEvent::Model(s.event.clone()), expect: expect_of(spec, &s.observation), note: None }
}

/// Everything of `o` a trace can expect. Destructured without `..`: a new observation is a
/// compile error here until a saved path expects it.
pub fn expect_of(spec: &Spec, o: &Observation) -> Expect {
    let Observation {
        reply,
        led_red,
        fefco_on,
        relay_tripped,
        outputs_forced_off,
        counter,
        counter_min,
        status_x,
        status_y,
        motion,
    } = o;
    // The status bits the model's rules drive (`StatusLayout::driven`), set or clear; the rest
    // of the two words are constants of the configuration (CPU type, reserved bits), which an
    // implementation may word differently without disagreeing on any rule.
    let mut status_set = Vec::new();
    let mut status_clear = Vec::new();
    let driven = StatusLayout::of(spec).map(|l| l.driven().to_vec()).unwrap_or_default();
    for (word_id, bit) in driven {
        let (word, value) = match word_id {
            WordId::X => (&spec.status.words.x, *status_x),
            WordId::Y => (&spec.status.words.y, *status_y),
        };
        let Some(b) = word.bits.get(&bit) else { continue };
        if value & (1 << bit) != 0 {
            status_set.push(b.name.clone());
        } else {
            status_clear.push(b.name.clone());
        }
    }
    let (motors, encoder_loss) = match motion {
        Some(view) => (
            view.motors().iter().map(|m| m.state.name().to_string()).collect(),
            view.motors().iter().map(|m| m.encoder_loss_status).collect(),
        ),
        None => (Vec::new(), Vec::new()),
    };
    Expect {
        // `Reply::None` (the event was no command) is printed `(none)` and expected as such.
        reply: Some(reply.to_string()),
        tripped: Some(*led_red),
        led_red: None,
        fefco_on: Some(*fefco_on),
        relay_tripped: Some(*relay_tripped),
        outputs_forced_off: Some(*outputs_forced_off),
        counter: Some(*counter),
        counter_min: Some(*counter_min),
        // The model's X:$1080 is a token, not a card's value (UM p.217, MODEL): never expected.
        running_checksum: None,
        window_cycles: None,
        status_set,
        status_clear,
        motors,
        encoder_loss,
    }
}

/// Whether `pmacwd run` reproduces `trace` on the model: the trace is written as the file
/// `--save` writes, read back as `run` reads it, and run under its profile; every observation
/// the checker saw is expected step by step. `Ok` gives the expectations met; `Err` the failure
/// as `run` reports it.
pub fn reproduces(spec: &Spec, trace: &Trace) -> Result<usize, Failure> {
    let file = std::path::Path::new("<saved path>");
    let loaded = pmacwd_trace::parse_yaml(file, &pmacwd_trace::to_yaml(trace)).map_err(Failure::Unusable)?;
    let profiles = runner::profiles_of(spec, &loaded).map_err(Failure::Unusable)?;
    let mut checked = 0;
    for profile in &profiles {
        checked += runner::run_on_model(spec, &loaded, profile)?;
    }
    Ok(checked)
}

/// One path `check --save` was asked for, and what became of it.
pub struct SavedPath {
    /// The file it is saved as, in the directory given.
    pub file_name: String,
    pub property: &'static str,
    pub outcome: Outcome,
}

/// What became of one path.
pub enum Outcome {
    /// Saved; `run` reproduces it (every observation expected at every step).
    Saved { trace: Trace, steps: usize },
    /// The checker's shortest path chose a deceleration shorter than a trace's run takes, so
    /// this one is the shortest with the longest decelerations: a different, longer path to
    /// the same property, which `run` reproduces.
    SavedLongestDecelerations { trace: Trace, steps: usize },
    /// The power-up state shows it: there is no event to expect it after.
    AtPowerUp,
    /// Only paths with a shorter deceleration than a trace's run reach it; the reason.
    NotReproducible(String),
}

/// The paths of `report` to save: every counterexample, and every witness when `witnesses`.
/// `cfg` is the run's configuration, checked again (with the longest decelerations only, on
/// `threads` threads) when a path cannot be reproduced as a trace.
pub fn paths_to_save(
    spec: &Spec,
    cfg: &pmacwd_specs::config::ModelConfig,
    report: &RunReport,
    witnesses: bool,
    threads: usize,
) -> Vec<SavedPath> {
    let mut longest: Option<RunReport> = None;
    let mut out = Vec::new();
    for p in &report.properties {
        let wanted = match p.expectation {
            Expectation::Always => !p.holds,
            Expectation::Sometimes => witnesses && p.holds && p.applicable,
        };
        if !wanted || p.path.is_none() {
            continue;
        }
        let outcome = if reached_at_power_up(p) {
            Outcome::AtPowerUp
        } else {
            let trace = path_trace(spec, report, p).expect("a non-empty path");
            match reproduces(spec, &trace) {
                Ok(_) => Outcome::Saved { steps: trace.steps.len(), trace },
                Err(first) => {
                    let again = longest.get_or_insert_with(|| {
                        WatchdogModel { longest_decelerations_only: true, ..WatchdogModel::new(cfg.clone()) }
                            .check(threads)
                    });
                    with_longest_decelerations(spec, again, p.name, &first)
                }
            }
        };
        out.push(SavedPath { file_name: file_name(report, p), property: p.name, outcome });
    }
    out
}

/// The outcome for property `name` from `again`, the run checked with the longest
/// decelerations only, after its shortest path failed `run` with `first`.
fn with_longest_decelerations(spec: &Spec, again: &RunReport, name: &str, first: &Failure) -> Outcome {
    let Some(mut t) = again.properties.iter().find(|q| q.name == name).and_then(|q| path_trace(spec, again, q)) else {
        return Outcome::NotReproducible(format!(
            "only a deceleration shorter than a trace's run takes reaches it ({})",
            failure_text(first)
        ));
    };
    if let Err(e) = reproduces(spec, &t) {
        return Outcome::NotReproducible(failure_text(&e));
    }
    t.description.push_str(
        " The checker's shortest path stops a motor faster than a trace's run does (it decelerates for the longest); this is the shortest path with the longest decelerations.",
    );
    Outcome::SavedLongestDecelerations { steps: t.steps.len(), trace: t }
}

fn failure_text(f: &Failure) -> String {
    match f {
        Failure::Unusable(e) => e.to_string(),
        Failure::Diverged(d) => d.to_string(),
    }
}
