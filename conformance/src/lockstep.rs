//! Lockstep: an implementation ([`Subject`]) and the reference model driven by the same events,
//! their observations compared after every one. A divergence names the event, the fields that
//! differ and both values; [`Pair::applied`] keeps the events so far, so a divergence can be
//! written out as a trace that reproduces it.

use crate::subject::{ModelSubject, Subject};
use pmacwd_specs::config::ModelConfig;
use pmacwd_specs::vocab::event::Event;
use pmacwd_specs::vocab::{MotionView, Observation};
use pmacwd_trace::TraceEvent;
use std::fmt;

/// Where and how the implementation and the model parted.
#[derive(Clone, Debug, PartialEq)]
pub struct Disagreement {
    /// The event whose observations differ (or the background cycle only one side allows).
    pub event: Event,
    /// `field: model X, implementation Y` for each differing field.
    pub fields: Vec<String>,
}

impl fmt::Display for Disagreement {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "after `{}`: {}", self.event, self.fields.join("; "))
    }
}

/// The fields in which two observations differ, as `field: model X,
/// implementation Y`: every field, the motors included (an implementation that reports no
/// motors differs from the model, which always does).
pub fn differences(model: &Observation, subject: &Observation) -> Vec<String> {
    // The common case, and the only one lockstep meets at every step of a long run: nothing
    // differs, and nothing needs formatting (formatting every field of every step was 90% of
    // the scenario library's 27 s on the core once the motors were compared).
    if model == subject {
        return Vec::new();
    }
    // Destructured without `..`: a new observation is a compile error here until it is compared.
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
    } = model;
    let mut out = Vec::new();
    let mut field = |name: &str, m: String, s: String| {
        if m != s {
            out.push(format!("{name}: model {m}, implementation {s}"));
        }
    };
    field("reply", format!("{reply:?}"), format!("{:?}", subject.reply));
    field("led_red", led_red.to_string(), subject.led_red.to_string());
    field("fefco_on", fefco_on.to_string(), subject.fefco_on.to_string());
    field("relay_tripped", relay_tripped.to_string(), subject.relay_tripped.to_string());
    field("outputs_forced_off", outputs_forced_off.to_string(), subject.outputs_forced_off.to_string());
    field("Y:$25", counter.to_string(), subject.counter.to_string());
    field("X:$25", counter_min.to_string(), subject.counter_min.to_string());
    field("X:$6", format!("{status_x:06X}"), format!("{:06X}", subject.status_x));
    field("Y:$6", format!("{status_y:06X}"), format!("{:06X}", subject.status_y));
    match (motion, &subject.motion) {
        // Motor by motor, so a divergence names the motor (and its count when that differs).
        (Some(m), Some(s)) => {
            field("motor count", m.count.to_string(), s.count.to_string());
            for (n, (a, b)) in m.motors().iter().zip(s.motors()).enumerate() {
                field(&format!("motor #{}", n + 1), format!("{a:?}"), format!("{b:?}"));
            }
        }
        (m, s) => field("motors", reported(m), reported(s)),
    }
    out
}

fn reported(m: &Option<MotionView>) -> String {
    match m {
        Some(v) => format!("{} motors", v.count),
        None => "none reported".into(),
    }
}

/// The model and an implementation, powered up together.
pub struct Pair<S: Subject> {
    pub model: ModelSubject,
    pub subject: S,
    /// Events applied so far, when recording (see [`Pair::recording`]).
    pub applied: Option<Vec<Event>>,
    /// Events applied so far.
    pub count: u64,
}

impl<S: Subject> Pair<S> {
    pub fn power_on(cfg: &ModelConfig) -> Self {
        Pair { model: ModelSubject::power_on(cfg), subject: S::power_on(cfg), applied: None, count: 0 }
    }

    /// Keeps every applied event, so a divergence can be saved as a trace.
    pub fn recording(mut self) -> Self {
        self.applied = Some(Vec::new());
        self
    }

    /// Whether a background cycle can complete now; both must agree.
    pub fn background_possible(&self) -> Result<bool, Disagreement> {
        let (m, s) = (self.model.background_possible(), self.subject.background_possible());
        if m != s {
            return Err(Disagreement {
                event: Event::Background,
                fields: vec![format!("background cycle possible: model {m}, implementation {s}")],
            });
        }
        Ok(m)
    }

    /// Applies one event to both and compares what each observes, and whether a background
    /// cycle can complete after it. The second is compared here, on the event that made the
    /// two differ, as the exhaustive product does (`product.rs`), rather than only at the next
    /// `background` step: a divergence saved as a regression trace then ends with that event,
    /// and the trace still replays once the implementation is fixed. Ending with a
    /// `background` step that only the broken implementation could complete, it would fail
    /// on a fixed one ("neither the model nor the implementation can complete one").
    pub fn apply(&mut self, event: &Event) -> Result<Observation, Disagreement> {
        if let Some(v) = &mut self.applied {
            v.push(event.clone());
        }
        self.count += 1;
        let m = self.model.apply(event);
        let s = self.subject.apply(event);
        let mut fields = differences(&m, &s);
        let (bm, bs) = (self.model.background_possible(), self.subject.background_possible());
        if bm != bs {
            fields.push(format!("background cycle possible: model {bm}, implementation {bs}"));
        }
        if !fields.is_empty() {
            return Err(Disagreement { event: event.clone(), fields });
        }
        // The implementation's own observation: the expectations of a step are checked on it.
        Ok(s)
    }

    /// Applies a trace step: `run` expands into servo cycles with a background cycle after
    /// each one the load allows (asking both sides whether it can complete); a `background`
    /// step that neither side can complete is reported as `Ok(None)`.
    pub fn apply_trace_event(&mut self, event: &TraceEvent) -> Result<Option<Observation>, Disagreement> {
        match event {
            TraceEvent::Model(Event::Background) => {
                if self.background_possible()? {
                    self.apply(&Event::Background).map(Some)
                } else {
                    Ok(None)
                }
            }
            TraceEvent::Model(e) => self.apply(e).map(Some),
            // Neither side sees the command (no background cycle reached it): the wait's servo
            // cycles, and silence (`Controller::unanswered`).
            TraceEvent::Unanswered { wait_cycles, .. } => {
                let mut obs = self.apply(&Event::Servo { cycles: *wait_cycles })?;
                obs.reply = pmacwd_specs::vocab::event::Reply::Silence;
                Ok(Some(obs))
            }
            TraceEvent::Run { cycles } => {
                let mut last = None;
                for _ in 0..*cycles {
                    last = Some(self.apply(&Event::Servo { cycles: 1 })?);
                    if self.background_possible()? {
                        last = Some(self.apply(&Event::Background)?);
                    }
                }
                Ok(last)
            }
            // A deterministic run cannot choose what happened unseen; the runner refuses these
            // steps with a message before they get here (see `runner::deterministic`).
            TraceEvent::Elapsed { .. } | TraceEvent::Restart | TraceEvent::RestartPossible => Ok(None),
        }
    }
}
