//! What a host or an instrument can observe of a controller.

use super::event::Reply;

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
