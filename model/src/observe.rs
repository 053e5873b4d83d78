//! What a host or an instrument observes of the reference controller: the vocabulary's
//! [`Observation`], filled in from the model's state.

use crate::controller::Controller;
use pmacwd_specs::config::ModelConfig;
use pmacwd_specs::vocab::{Observation, Reply};

/// What the reference controller shows after an event whose reply was `reply`.
pub fn of(c: &Controller, cfg: &ModelConfig, reply: Reply) -> Observation {
    let (status_x, status_y) = c.status_words(cfg);
    // The outputs are their own state, set by the trip rule and cleared by a reset
    // (controller.rs, `trip_now` and `restart`).
    Observation {
        reply,
        led_red: c.outputs.led_red,
        fefco_on: c.outputs.fefco_on,
        relay_tripped: c.outputs.relay_tripped,
        outputs_forced_off: c.outputs.forced_off,
        counter: c.counter,
        counter_min: c.counter_min,
        status_x,
        status_y,
        motion: Some(c.axes.view()),
    }
}
