//! What a host or an instrument observes of the reference controller: the vocabulary's
//! [`Observation`], filled in from the model's state.

use crate::controller::Controller;
use pmacwd_specs::config::ModelConfig;
use pmacwd_specs::vocab::{Observation, Reply};

/// What the reference controller shows after an event whose reply was `reply`.
pub fn of(c: &Controller, cfg: &ModelConfig, reply: Reply) -> Observation {
    let tripped = c.tripped();
    let (status_x, status_y) = c.status_words(cfg);
    // UM p.215: on a trip the card is latched in reset "with a red LED indicating watchdog
    // failure"; "All Servo, MACRO, and I/O ICs are forced into their reset states, which
    // force discrete outputs off, and proportional outputs (DAC, PWM, PFM) to zero-level";
    // FEFCO/ "is turned on when the timer trips"; Turbo PMAC2 has a relay instead.
    Observation {
        reply,
        led_red: tripped,
        fefco_on: tripped,
        relay_tripped: tripped,
        outputs_forced_off: tripped,
        counter: c.counter,
        counter_min: c.counter_min,
        status_x,
        status_y,
    }
}
