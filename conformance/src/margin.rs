//! How close a configuration runs to a watchdog trip, measured on the model itself: the
//! longest run without a background cycle the card survives, the longest run its load makes,
//! and the difference, in servo cycles and milliseconds, under each profile. `pmacwd margin`
//! prints it; nothing here is a formula of its own, so the figures are where the model trips.
//!
//! - **Tolerated:** from a background cycle (the counter just reloaded to I40, or 4095/4096 when
//!   I40 = 0: UM p.215, SRM p.57), servo cycles with no background cycle until the timer trips
//!   (UM p.215: the counter runs out, the strobe stops, and after the hardware delay the timer
//!   trips). A background cycle one cycle earlier saves the card
//!   (`a-background-cycle-one-cycle-before-the-trip-saves-the-card`).
//! - **Needed:** with the load given (motors, PLC 0 and background costs in CPU units of the
//!   configuration, UM p.236-237 on the task priorities), the longest interval between two
//!   background cycles over a steady stretch, the lowest counter value it leaves in X:$25, and
//!   whether the RTI overran (bit 22, SRM p.289).
//! - **Margin:** tolerated minus needed. A load that never lets a background cycle complete
//!   (PLC 0 or the servo routines taking every unit) has no margin: the card trips.

use pmacwd_model::controller::Controller;
use pmacwd_specs::check::Load;
use pmacwd_specs::config::ModelConfig;
use pmacwd_specs::vocab::event::Event;

/// What one profile says about one load.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Margin {
    /// The value a background cycle reloads the counter with.
    pub reload: i32,
    /// The hardware delay in servo cycles used (the stated strobe minimum, or a band end).
    pub hardware_delay_cycles: u32,
    /// Servo cycles from a background cycle to the trip when no other background cycle
    /// completes: a background cycle within `tolerated_cycles - 1` cycles saves the card.
    pub trip_after_cycles: u64,
    /// The longest interval between background cycles the load makes (`None`: none completes,
    /// the card trips).
    pub longest_interval_cycles: Option<u64>,
    /// X:$25 after the steady stretch: the lowest counter value since reset.
    pub counter_min: i32,
    /// The RTI overran (bit 22) while the load ran.
    pub rti_overran: bool,
    /// The servo routines did not fit a servo cycle (bit 20, SRM p.289).
    pub servo_overloaded: bool,
    /// The card tripped under the load.
    pub tripped: bool,
}

impl Margin {
    /// Servo cycles to spare: how much longer the longest interval could grow before the trip.
    pub fn margin_cycles(&self) -> Option<i64> {
        self.longest_interval_cycles.map(|g| self.trip_after_cycles as i64 - 1 - g as i64).filter(|_| !self.tripped)
    }
}

/// A card of `cfg` running `load` from power-on until its counter has been reloaded.
fn settled(cfg: &ModelConfig, load: Load) -> Controller {
    let mut card = Controller::power_on(cfg);
    card.apply(cfg, &Event::Load(load));
    card
}

/// Servo cycles from a background cycle until the timer trips with no other background
/// cycle, at most `max`.
fn cycles_to_trip(cfg: &ModelConfig, load: Load, max: u64) -> u64 {
    let mut card = settled(cfg, load);
    // The first background cycle the load allows: the counter reloads there.
    let mut n = 0u64;
    while !card.background_possible() && n < max {
        card.servo_cycle(cfg);
        n += 1;
    }
    if card.background_possible() {
        card.background_cycle(cfg);
    } else {
        // A load that starves the background from power-on: count from the power-on reload.
        card = settled(cfg, load);
    }
    let mut t = 0u64;
    while !card.tripped() && t < max {
        card.servo_cycle(cfg);
        t += 1;
    }
    t
}

/// How `load` runs on `cfg`: the figures of [`Margin`]. The steady stretch is `stretch_cycles`
/// long after the first background cycle (several RTI periods and counter run-downs).
pub fn measure(cfg: &ModelConfig, load: Load) -> Margin {
    let reload = cfg.reset_value(cfg.saved.i40);
    let bound =
        u64::from(reload.unsigned_abs()) + u64::from(cfg.hardware_delay_cycles) + 4 * (u64::from(cfg.saved.i8) + 1) + 8;
    let trip_after_cycles = cycles_to_trip(cfg, load, 4 * bound);
    let stretch = 4 * bound + 64 * (u64::from(cfg.saved.i8) + 1);
    let mut card = settled(cfg, load);
    let (mut since, mut longest, mut seen) = (0u64, 0u64, false);
    let (mut overran, mut overloaded) = (false, false);
    for _ in 0..stretch {
        card.servo_cycle(cfg);
        since += 1;
        overran |= card.status.rti_reentry;
        overloaded |= card.status.servo_error;
        if card.tripped() {
            break;
        }
        if card.background_possible() {
            card.background_cycle(cfg);
            // The interval from power-on to the first background cycle is not steady.
            if seen {
                longest = longest.max(since);
            }
            seen = true;
            since = 0;
        }
    }
    let tripped = card.tripped();
    Margin {
        reload,
        hardware_delay_cycles: cfg.hardware_delay_cycles,
        trip_after_cycles,
        longest_interval_cycles: (seen && !tripped && longest > 0).then_some(longest),
        counter_min: card.counter_min,
        rti_overran: overran,
        servo_overloaded: overloaded,
        tripped,
    }
}

/// [`measure`] over PLC 0 costs `0..=plc0_max` units in `steps` steps: for a plot of margin
/// against PLC 0 load.
pub fn sweep_plc0(cfg: &ModelConfig, load: Load, plc0_max: u16, steps: u16) -> Vec<(u16, Margin)> {
    let steps = steps.max(1);
    (0..=steps)
        .map(|i| {
            let units = (u32::from(plc0_max) * u32::from(i) / u32::from(steps)) as u16;
            (units, measure(cfg, Load { plc0_units: units, ..load }))
        })
        .collect()
}
