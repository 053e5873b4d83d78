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

/// A card of `cfg` running `load` just after the first background cycle the load allows (the
/// counter reloaded there), searched for at most `max` servo cycles; a load that starves the
/// background from power-on gives the card at power-on, just reloaded too.
fn after_first_background(cfg: &ModelConfig, load: Load, max: u64) -> Controller {
    let mut card = settled(cfg, load);
    let mut n = 0u64;
    while !card.background_possible() && n < max {
        card.servo_cycle(cfg);
        n += 1;
    }
    if card.background_possible() {
        card.background_cycle(cfg);
        card
    } else {
        settled(cfg, load)
    }
}

/// Servo cycles from a background cycle until the timer trips with no other background
/// cycle, at most `max`.
fn cycles_to_trip(cfg: &ModelConfig, load: Load, max: u64) -> u64 {
    let mut card = after_first_background(cfg, load, max);
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

/// What measured readings of a card say under one profile: X:$25, the lowest value the
/// counter has reached since reset (SRM p.57, UM p.240), and optionally Y:$25, its value now.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum ReadingMargin {
    /// No card of this reading shows these values; why, with the citation.
    Impossible(String),
    /// What the readings prove happened, measured on the model.
    Seen {
        /// The longest run of servo cycles without a background cycle since reset: the
        /// counter came down from its reload to X:$25.
        longest_gap_cycles: u64,
        /// From that deepest point, servo cycles with no background cycle until the trip: a
        /// background cycle within `spare_cycles` cycles of it saved the card.
        spare_cycles: u64,
        /// With Y:$25: servo cycles since the last background cycle now.
        since_last_background_cycles: Option<u64>,
    },
}

/// What `x25` (and `y25`) read from a card of `cfg` running `load` say: measured by running the
/// model from a reload (the load's first background cycle, as [`measure`] does), servo cycle
/// by servo cycle with no background cycle, down to the counter value read, then on to the
/// trip. Nothing here is a formula of its own: a reading the model's counter never shows on a
/// running card is impossible under this profile. MODEL: where the trip is detected in the RTI
/// (the counter gone below zero, SRM p.57), the spare cycles depend on the RTI's phase at the
/// reload, which a reading does not give: they are counted at the phase [`measure`] uses, and
/// another phase moves them by at most I8 cycles.
pub fn from_readings(cfg: &ModelConfig, load: Load, x25: i32, y25: Option<i32>) -> ReadingMargin {
    let reload = cfg.reset_value(cfg.saved.i40);
    let card = after_first_background(cfg, load, 4 * (u64::from(reload.unsigned_abs()) + 64));
    if card.counter != reload {
        return ReadingMargin::Impossible(format!(
            "the load leaves no background cycle to reload the counter from ({} motors, PLC 0 {} units)",
            load.motors, load.plc0_units
        ));
    }
    if x25 > reload {
        return ReadingMargin::Impossible(format!(
            "X:$25 = {x25} is above the counter's reload {reload} ({}), and X:$25 holds the lowest value since reset",
            reload_cite(cfg)
        ));
    }
    if let Some(y) = y25 {
        if y < x25 {
            return ReadingMargin::Impossible(format!(
                "Y:$25 = {y} is below X:$25 = {x25}, which holds the lowest counter value since reset (SRM p.57, UM p.240)"
            ));
        }
        if y > reload {
            return ReadingMargin::Impossible(format!(
                "Y:$25 = {y} is above the counter's reload {reload} ({})",
                reload_cite(cfg)
            ));
        }
    }
    let bound = u64::from(reload.unsigned_abs()) + u64::from(cfg.hardware_delay_cycles) + 2;
    let steps_to = |target: i32| -> Option<(u64, Controller)> {
        let mut c = card.clone();
        let mut n = 0u64;
        // From the reload the counter only falls, so its value is the stretch's lowest.
        while c.counter > target {
            if c.tripped() || n > bound {
                return None;
            }
            c.servo_cycle(cfg);
            n += 1;
        }
        (c.counter == target && !c.tripped()).then_some((n, c))
    };
    let Some((gap, mut deepest)) = steps_to(x25) else {
        return ReadingMargin::Impossible(format!(
            "the counter of a running card never reads {x25}: it stops or the card trips first (UM p.215, SRM p.57)"
        ));
    };
    let mut spare = 0u64;
    while !deepest.tripped() && spare <= bound {
        deepest.servo_cycle(cfg);
        spare += 1;
    }
    let since_last_background_cycles = y25.and_then(|y| steps_to(y).map(|(n, _)| n));
    ReadingMargin::Seen { longest_gap_cycles: gap, spare_cycles: spare.saturating_sub(1), since_last_background_cycles }
}

/// Which reading of the reload a configuration follows, with its citation: `I40, UM p.215`, or
/// for I40 = 0 the value of the profile's reading (4096: UM p.215, UM p.237; 4095: SRM p.57,
/// UM p.240).
pub fn reload_cite(cfg: &ModelConfig) -> &'static str {
    if cfg.saved.i40 != 0 {
        "I40, UM p.215"
    } else if cfg.reset_value(0) == 4096 {
        "I40 = 0: 4096, UM p.215, UM p.237"
    } else {
        "I40 = 0: 4095, SRM p.57, UM p.240"
    }
}

/// One CPU unit of `cfg` in microseconds: a servo cycle (1,000,000 / servo clock µs; the servo
/// clock is I10's, SRM p.43, 2.25 kHz "(440 µsec cycle)" by default, UM p.236) over the
/// configuration's `cpu.cycle_units`. check.yaml states every cost as units of a servo cycle:
/// at i40-zero 100 of them, so that a motor's servo update at 1 unit is UM p.236's "approximately
/// 1% of Turbo PMAC's computational power".
///
/// MODEL: a unit is a fixed share of a servo cycle, so at another servo clock (`--servo-hz`,
/// `--i10`) a unit is that much longer or shorter; the manuals give the computational power
/// only as this share.
pub fn us_per_unit(cfg: &ModelConfig) -> f64 {
    1_000_000.0 / f64::from(cfg.servo_hz) / f64::from(cfg.cpu.cycle_units)
}

/// A CPU time in microseconds as whole CPU units of `cfg` ([`us_per_unit`]), for a load a user
/// measured in time (a PLC 0 scan, a background cycle). MODEL: rounded up, so the load is never
/// less than the time given (a task that needs part of a unit holds the CPU for that unit);
/// a time within a millionth of a unit of a whole number of units is that number. A time that
/// is negative, not a number, or more units than a cost holds (65,535) is refused.
pub fn units_of_us(cfg: &ModelConfig, us: f64) -> Result<u16, String> {
    if !us.is_finite() || us < 0.0 {
        return Err(format!("{us} µs: give a time of 0 µs or more"));
    }
    let exact = us / us_per_unit(cfg);
    let units = (exact - 1e-6).ceil().max(0.0);
    if units > f64::from(u16::MAX) {
        return Err(format!(
            "{us} µs is {units:.0} CPU units of {:.4} µs, more than a cost holds ({})",
            us_per_unit(cfg),
            u16::MAX
        ));
    }
    Ok(units as u16)
}

/// Which cost of a load a neighbour changes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Cost {
    /// PLC 0's units per RTI.
    Plc0,
    /// One background cycle's units.
    Background,
}

impl Cost {
    /// The name JSON gives it: the load's field.
    pub fn key(self) -> &'static str {
        match self {
            Cost::Plc0 => "plc0_units",
            Cost::Background => "background_units",
        }
    }
}

/// Where the margin is not monotonic in one cost around a load: one unit less, the load's own
/// and one unit more, with the margin at each (`None`: the card trips).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct NotMonotonic {
    pub cost: Cost,
    pub units: Vec<u16>,
    pub margin_cycles: Vec<Option<i64>>,
}

/// The loads one unit of PLC 0 and one unit of background below and above `load`, measured,
/// and where the margin grows with the load among them: a more costly neighbour with more
/// margin, or a cheaper one with less (a load that trips counts as less margin than any). The
/// margin at one fixed cost is then no bound for a cost that varies around it. UM p.236: PLC 0
/// runs "every real-time interrupt as long as the tasks from the previous RTI have been
/// completed", so a PLC 0 that ends exactly at an RTI starves the background while one a unit
/// longer lets the next RTI pass without a scan (`i40-zero`: 276 units trips, 275 and 277 do not).
pub fn not_monotonic(cfg: &ModelConfig, load: Load) -> Vec<NotMonotonic> {
    let at = measure(cfg, load).margin_cycles();
    let mut found = Vec::new();
    for cost in [Cost::Plc0, Cost::Background] {
        let units = match cost {
            Cost::Plc0 => load.plc0_units,
            Cost::Background => load.background_units,
        };
        let with = |u: u16| match cost {
            Cost::Plc0 => Load { plc0_units: u, ..load },
            Cost::Background => Load { background_units: u, ..load },
        };
        let below = units.checked_sub(1).map(|u| (u, measure(cfg, with(u)).margin_cycles()));
        let above = units.checked_add(1).map(|u| (u, measure(cfg, with(u)).margin_cycles()));
        // `Option`'s order puts `None` (the card trips) below every margin.
        let rising = below.is_some_and(|(_, m)| m < at) || above.is_some_and(|(_, m)| m > at);
        if rising {
            let points: Vec<(u16, Option<i64>)> = below.into_iter().chain([(units, at)]).chain(above).collect();
            found.push(NotMonotonic {
                cost,
                units: points.iter().map(|p| p.0).collect(),
                margin_cycles: points.iter().map(|p| p.1).collect(),
            });
        }
    }
    found
}
