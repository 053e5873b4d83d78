//! Runs a trace on the reference model and compares every expected observation.

use pmacwd_model::controller::Controller;
use pmacwd_specs::config::ModelConfig;
use pmacwd_specs::profiles::Profile;
use pmacwd_specs::status::WordId;
use pmacwd_specs::vocab::event::{Event, Reply};
use pmacwd_specs::vocab::Observation;
use pmacwd_specs::{Position, Spec, SpecError};
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

/// `Ok` for an event a deterministic run can apply; `elapsed` and `restart` say only what a host
/// saw, and only `pmacwd replay`, which searches for what happened, can judge them.
pub fn deterministic(event: &TraceEvent) -> Result<(), String> {
    match event {
        TraceEvent::Elapsed { .. } | TraceEvent::Restart => Err(format!(
            "`{event}` leaves open what happened; a deterministic run cannot choose it: judge this \
             trace with `pmacwd replay`"
        )),
        TraceEvent::Model(_) | TraceEvent::Run { .. } => Ok(()),
    }
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
            TraceEvent::Elapsed { .. } | TraceEvent::Restart => unreachable!("refused by `deterministic`"),
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

/// `expect` without the trip and the observations that follow from it (LED, FEFCO/, relay,
/// outputs) where they say `want`: what is left to compare once a timing window has decided
/// the trip.
pub fn without_trip(expect: &Expect, want: bool) -> Expect {
    let mut rest = expect.clone();
    for field in [
        &mut rest.tripped,
        &mut rest.led_red,
        &mut rest.fefco_on,
        &mut rest.relay_tripped,
        &mut rest.outputs_forced_off,
    ] {
        if *field == Some(want) {
            *field = None;
        }
    }
    rest
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

/// How an observation fails an expectation.
pub enum Mismatch {
    /// An expectation names a status bit `status.yaml` does not have: (list, index, name).
    UnknownBit(&'static str, usize, String),
    /// (what, expected, observed).
    Field(&'static str, String, String),
}

/// Compares one observation with one step's expectations; returns how many were checked.
pub fn compare(spec: &Spec, e: &Expect, o: &Observation) -> Result<usize, Mismatch> {
    // Destructured without `..`: a new expectation is a compile error here until it is
    // compared (`window_cycles` qualifies `tripped` and is applied by the caller).
    let Expect {
        reply,
        tripped,
        led_red,
        fefco_on,
        relay_tripped,
        outputs_forced_off,
        counter,
        counter_min,
        window_cycles: _,
        status_set,
        status_clear,
        motors,
        encoder_loss,
    } = e;
    let mut n = 0;
    if let Some(r) = reply {
        n += 1;
        // The card's own answer (a command the model has no rule for) matches whatever a
        // running card answers, and never silence (UM p.215: a tripped card does not answer).
        let matches = match o.reply {
            Reply::CardOwn => r != "(silence)",
            _ => *r == o.reply.to_string(),
        };
        if !matches {
            return Err(Mismatch::Field("reply", r.clone(), o.reply.to_string()));
        }
    }
    for (what, expected, observed) in [
        ("tripped", *tripped, o.led_red),
        ("red LED", *led_red, o.led_red),
        ("FEFCO/", *fefco_on, o.fefco_on),
        ("relay", *relay_tripped, o.relay_tripped),
        ("outputs forced off", *outputs_forced_off, o.outputs_forced_off),
    ] {
        if let Some(x) = expected {
            n += 1;
            if x != observed {
                return Err(Mismatch::Field(what, x.to_string(), observed.to_string()));
            }
        }
    }
    for (what, expected, observed) in [("Y:$25", *counter, o.counter), ("X:$25", *counter_min, o.counter_min)] {
        if let Some(x) = expected {
            n += 1;
            if x != observed {
                return Err(Mismatch::Field(what, x.to_string(), observed.to_string()));
            }
        }
    }
    // The motors: an implementation that reports none fails any expectation about them.
    if o.motion.is_none() && !(motors.is_empty() && encoder_loss.is_empty()) {
        return Err(Mismatch::Field("motors", "motors reported".into(), "none reported".into()));
    }
    if let Some(view) = o.motion {
        let shown = view.motors();
        if !motors.is_empty() {
            n += 1;
            let observed: Vec<&str> = shown.iter().map(|m| m.state.name()).collect();
            if *motors != observed {
                return Err(Mismatch::Field("motors", motors.join(", "), observed.join(", ")));
            }
        }
        if !encoder_loss.is_empty() {
            n += 1;
            let observed: Vec<bool> = shown.iter().map(|m| m.encoder_loss_status).collect();
            if *encoder_loss != observed {
                return Err(Mismatch::Field(
                    "encoder-loss status",
                    format!("{encoder_loss:?}"),
                    format!("{observed:?}"),
                ));
            }
        }
    }
    for (list, want, field) in [(status_set, true, "status_set"), (status_clear, false, "status_clear")] {
        for (j, name) in list.iter().enumerate() {
            let Some((word, bit)) = spec.status.bit(name) else {
                return Err(Mismatch::UnknownBit(field, j, name.clone()));
            };
            let w = match word {
                WordId::X => o.status_x,
                WordId::Y => o.status_y,
            };
            n += 1;
            if (w & (1 << bit) != 0) != want {
                return Err(Mismatch::Field(
                    "status bit",
                    format!("{name} = {}", u8::from(want)),
                    format!("{name} = {} (words {:06X} {:06X})", u8::from(!want), o.status_x, o.status_y),
                ));
            }
        }
    }
    Ok(n)
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
            TraceEvent::Run { cycles } => Event::Servo { cycles: *cycles },
            TraceEvent::Elapsed { .. } | TraceEvent::Restart => unreachable!("refused by `deterministic`"),
        };
        observe(&cfg, &event, &pair.model);
        if step.expect.window_cycles.is_some() {
            return Ok(0);
        }
        compare(spec, &step.expect, &obs)
    })
}
