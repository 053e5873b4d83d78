//! What a host or an instrument can observe of a controller.

use crate::config::ModelConfig;
use crate::controller::Controller;
use crate::event::Reply;

/// Everything observable after an event.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct Observation {
    pub reply: Reply,
    /// The red watchdog LED (UM p.215).
    pub led_red: bool,
    /// FEFCO/ open-collector output on (Turbo PMAC, UM p.215).
    pub fefco_on: bool,
    /// The watchdog relay has changed over (Turbo PMAC2, UM p.215).
    pub relay_tripped: bool,
    /// Discrete outputs forced off, DAC/PWM/PFM at zero (UM p.215).
    pub outputs_forced_off: bool,
    /// Y:$000025, X:$000025 and the status words as the card holds them. A host cannot read
    /// them from a tripped card; an instrument (or the model) can.
    pub counter: i32,
    pub counter_min: i32,
    pub status_x: u32,
    pub status_y: u32,
}

impl Observation {
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
}
