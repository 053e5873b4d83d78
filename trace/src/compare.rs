//! What a step's expectations mean: one observation compared with them, the same for a run on
//! the model, a subject in lockstep and the replay search. It lives with the trace format,
//! whose `expect:` keys it reads, so that every reader of traces judges them alike.

use crate::{Expect, TraceEvent};
use pmacwd_specs::status::WordId;
use pmacwd_specs::vocab::event::Reply;
use pmacwd_specs::vocab::Observation;
use pmacwd_specs::Spec;

/// `Ok` for an event a deterministic run can apply; `elapsed` and the restarts say only what a host
/// saw, and only `pmacwd replay`, which searches for what happened, can judge them.
pub fn deterministic(event: &TraceEvent) -> Result<(), String> {
    match event {
        TraceEvent::Elapsed { .. } | TraceEvent::Restart | TraceEvent::RestartPossible => Err(format!(
            "`{event}` leaves open what happened; a deterministic run cannot choose it: judge this \
             trace with `pmacwd replay`"
        )),
        TraceEvent::Model(_) | TraceEvent::Run { .. } | TraceEvent::Unanswered { .. } => Ok(()),
    }
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
        // The card's own X:$1080: the model's is a token (UM p.217, MODEL), so no comparison
        // with it could hold; `pmacwd replay` reads it from the steps (the freeze of UM p.217).
        running_checksum: _,
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
