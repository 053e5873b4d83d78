//! Runs a trace on the reference model and compares every expected observation.

use pmacwd_model::controller::Controller;
use pmacwd_specs::config::ModelConfig;
use pmacwd_specs::profiles::Profile;
use pmacwd_specs::vocab::event::{Event, Reply};
use pmacwd_specs::{Position, Spec, SpecError};
use pmacwd_trace::compare::{compare, deterministic, without_trip, Mismatch};
use pmacwd_trace::{Expect, LoadedTrace, Step, TraceEvent};
use std::fmt;

/// The first point where the model disagrees with a trace.
#[derive(Clone, Debug)]
pub struct Divergence {
    /// 0-based step index, and where the step is written.
    pub step: usize,
    pub position: Position,
    pub what: String,
    pub expected: String,
    pub observed: String,
    /// The events just before, oldest first, the diverging one last.
    pub recent: Vec<String>,
}

impl fmt::Display for Divergence {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        writeln!(
            f,
            "step {} (line {}): {}: expected {}, observed {}",
            self.step + 1,
            self.position.line,
            self.what,
            self.expected,
            self.observed
        )?;
        for (i, e) in self.recent.iter().enumerate() {
            let marker = if i + 1 == self.recent.len() { "->" } else { "  " };
            writeln!(f, "    {marker} {e}")?;
        }
        Ok(())
    }
}

impl Divergence {
    /// As JSON (`run --format json`, `docs/commands.md`): the step (1-based) and its line,
    /// what differed, and the events before it.
    pub fn to_json(&self) -> serde_json::Value {
        serde_json::json!({
            "step": self.step + 1, "line": self.position.line, "what": self.what,
            "expected": self.expected, "observed": self.observed, "recent": self.recent,
        })
    }
}

/// Why a trace run did not pass.
#[derive(Debug)]
pub enum Failure {
    /// The trace cannot be run: unknown configuration, profile or status bit name.
    Unusable(SpecError),
    Diverged(Divergence),
}

/// The profiles a trace's expectations hold under.
pub fn profiles_of(spec: &Spec, loaded: &LoadedTrace) -> Result<Vec<Profile>, SpecError> {
    spec.profiles
        .select(&loaded.trace.profiles)
        .map_err(|(i, n)| loaded.map.error(&format!("profiles.{i}"), format!("no profile named `{n}`")))
}

/// The model as a trace drives it: the controller, its configuration, and how many servo
/// cycles have passed since it tripped (its own counter X:$0 stops with the processor), which
/// timing windows need.
pub struct ModelLane {
    pub cfg: ModelConfig,
    pub card: Controller,
    pub cycles_since_trip: u64,
}

impl ModelLane {
    pub fn new(cfg: ModelConfig) -> ModelLane {
        let card = Controller::power_on(&cfg);
        ModelLane { cfg, card, cycles_since_trip: 0 }
    }

    fn servo_cycle(&mut self) {
        if self.card.tripped() {
            self.cycles_since_trip += 1;
        }
        self.card.servo_cycle(&self.cfg);
    }

    /// Applies one trace event. `Err` says why a claimed background cycle cannot complete (a
    /// divergence); `run` completes a background cycle after every servo cycle in which the
    /// load allows one.
    pub fn apply(&mut self, event: &TraceEvent) -> Result<Reply, String> {
        deterministic(event)?;
        let reply = match event {
            TraceEvent::Model(Event::Background) if !self.card.background_possible() => {
                return Err(if self.card.tripped() {
                    "it cannot: the card is tripped".into()
                } else {
                    "it cannot: the load has not yet given the background a cycle's CPU time".into()
                })
            }
            TraceEvent::Model(Event::Servo { cycles }) => {
                for _ in 0..*cycles {
                    self.servo_cycle();
                }
                Reply::None
            }
            TraceEvent::Model(e) => self.card.apply(&self.cfg, e),
            TraceEvent::Elapsed { .. } | TraceEvent::Restart | TraceEvent::RestartPossible => {
                unreachable!("refused by `deterministic`")
            }
            // The wait's servo cycles with no background cycle: `Controller::unanswered`, with
            // the cycles after a trip counted as every servo cycle here is.
            TraceEvent::Unanswered { wait_cycles, .. } => {
                for _ in 0..*wait_cycles {
                    self.servo_cycle();
                }
                Reply::Silence
            }
            TraceEvent::Run { cycles } => {
                for _ in 0..*cycles {
                    self.servo_cycle();
                    if self.card.background_possible() {
                        self.card.background_cycle(&self.cfg);
                    }
                }
                Reply::None
            }
        };
        // Only servo cycles after the trip count; a running card has none.
        if !self.card.tripped() {
            self.cycles_since_trip = 0;
        }
        Ok(reply)
    }

    /// Compares the observations after an event with a step's expectations. With
    /// `window_cycles: W`, an expected trip (or its absence) also holds if the model trips within
    /// the next W servo cycles (or tripped within the last W): captured timing is uncertain.
    pub fn check(&self, spec: &Spec, expect: &Expect, reply: Reply) -> Result<usize, Mismatch> {
        let obs = pmacwd_model::observe::of(&self.card, &self.cfg, reply);
        let (Some(window), Some(want)) = (expect.window_cycles, expect.tripped) else {
            return compare(spec, expect, &obs);
        };
        let tripped = self.card.tripped();
        let within = if want == tripped {
            true
        } else if want {
            let mut probe = self.card.clone();
            (0..window).any(|_| {
                probe.servo_cycle(&self.cfg);
                probe.tripped()
            })
        } else {
            self.cycles_since_trip <= u64::from(window)
        };
        if !within {
            return Err(Mismatch::Field(
                "tripped",
                format!("{want} within {window} servo cycles"),
                tripped.to_string(),
            ));
        }
        Ok(1 + compare(spec, &without_trip(expect, want), &obs)?)
    }
}

/// How many recent events a divergence report shows.
const RECENT_EVENTS: usize = 5;

/// The trace's configuration under `profile`.
fn trace_config(spec: &Spec, loaded: &LoadedTrace, profile: &Profile) -> Result<ModelConfig, Failure> {
    let trace = &loaded.trace;
    let mut cfg = ModelConfig::from_spec(spec, &trace.configuration, profile).map_err(|_| {
        Failure::Unusable(
            loaded
                .map
                .error("configuration", format!("no configuration named `{}` in check.yaml", trace.configuration)),
        )
    })?;
    if let Some(card) = &loaded.card {
        cfg = cfg.with_card(spec, card).map_err(|e| Failure::Unusable(loaded.map.error("card", e)))?;
    }
    // The checker drops X:$000000 from its states (no rule reads it); a trace runs with the
    // card's real 24-bit servo cycle counter, since a host can read it.
    cfg.servo_counter_mask = 0xFF_FFFF;
    Ok(cfg)
}

/// Runs `step` on every step of `loaded`, keeping the window of recent events, and turns the
/// first mismatch into a [`Failure`] that names the step, its line and the events before it.
/// A step no deterministic run can apply (`elapsed`, `restart`: see [`deterministic`]) makes
/// the trace unusable here, at its line, not a divergence: the trace is for `replay`.
/// Returns the number of expectations checked.
fn run_steps(loaded: &LoadedTrace, mut step: impl FnMut(&Step) -> Result<usize, Mismatch>) -> Result<usize, Failure> {
    let mut recent: Vec<String> = Vec::new();
    let mut checked = 0;
    for (i, s) in loaded.trace.steps.iter().enumerate() {
        deterministic(&s.event).map_err(|why| {
            Failure::Unusable(SpecError::at(
                loaded.map.file(),
                loaded.step_position(i),
                format!("step {}: {why}", i + 1),
            ))
        })?;
        recent.push(s.event.to_string());
        if recent.len() > RECENT_EVENTS {
            recent.remove(0);
        }
        checked += step(s).map_err(|e| match e {
            Mismatch::UnknownBit(field, j, name) => Failure::Unusable(loaded.map.error(
                &format!("steps.{i}.expect.{field}.{j}"),
                format!("no status bit named `{name}` in status.yaml"),
            )),
            Mismatch::Field(what, expected, observed) => Failure::Diverged(Divergence {
                step: i,
                position: loaded.step_position(i),
                what: what.to_string(),
                expected,
                observed,
                recent: recent.clone(),
            }),
        })?;
    }
    Ok(checked)
}

/// What a step claimed that could not happen: a background cycle when none can complete.
fn no_background(observed: String) -> Mismatch {
    Mismatch::Field("event", "a background cycle can complete".into(), observed)
}

/// Runs `loaded` on the model under `profile`; returns the number of expectations checked.
pub fn run_on_model(spec: &Spec, loaded: &LoadedTrace, profile: &Profile) -> Result<usize, Failure> {
    let mut lane = ModelLane::new(trace_config(spec, loaded, profile)?);
    run_steps(loaded, |step| {
        let reply = lane.apply(&step.event).map_err(no_background)?;
        lane.check(spec, &step.expect, reply)
    })
}

/// Runs `loaded` on an implementation in lockstep with the model under `profile`: after every
/// step the two must observe the same thing, and the implementation's observations must meet
/// the step's expectations. (A `window_cycles` expectation is about timing uncertainty in a
/// capture; there the lockstep comparison alone stands for it, and [`run_on_model`] checks the
/// window on the model.) Returns the number of expectations checked on the implementation.
pub fn run_on_subject<S: crate::subject::Subject>(
    spec: &Spec,
    loaded: &LoadedTrace,
    profile: &Profile,
) -> Result<usize, Failure> {
    run_on_subject_observed::<S>(spec, loaded, profile, &mut |_, _, _| {})
}

/// [`run_on_subject`], with `observe` called after every step (a `run` step is reported as
/// one servo event of its length) with the model as it stands: for coverage reports.
pub fn run_on_subject_observed<S: crate::subject::Subject>(
    spec: &Spec,
    loaded: &LoadedTrace,
    profile: &Profile,
    observe: &mut dyn FnMut(&ModelConfig, &Event, &crate::subject::ModelSubject),
) -> Result<usize, Failure> {
    let cfg = trace_config(spec, loaded, profile)?;
    let mut pair = crate::lockstep::Pair::<S>::power_on(&cfg);
    run_steps(loaded, |step| {
        let obs = match pair.apply_trace_event(&step.event) {
            Ok(Some(obs)) => obs,
            Ok(None) => return Err(no_background("neither the model nor the implementation can complete one".into())),
            Err(d) => {
                return Err(Mismatch::Field(
                    "implementation against the model",
                    "the model's observations".into(),
                    d.to_string(),
                ))
            }
        };
        let event = match &step.event {
            TraceEvent::Model(e) => e.clone(),
            TraceEvent::Run { cycles } | TraceEvent::Unanswered { wait_cycles: cycles, .. } => {
                Event::Servo { cycles: *cycles }
            }
            TraceEvent::Elapsed { .. } | TraceEvent::Restart | TraceEvent::RestartPossible => {
                unreachable!("refused by `deterministic`")
            }
        };
        observe(&cfg, &event, &pair.model);
        if step.expect.window_cycles.is_some() {
            return Ok(0);
        }
        compare(spec, &step.expect, &obs)
    })
}
