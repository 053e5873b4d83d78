//! The prose-fact files: `watchdog.yaml`, `checksums.yaml`, `stop_commands.yaml` and
//! `scheduling.yaml`. They are mostly lists of cited rules; the model cites the same pages in
//! its code. The model reads the supply minimum from here; the strobe minimum it takes from the
//! profile's `strobe_hz_min` reading (this file holds the Turbo manual's 25 Hz). The servo clock
//! and the per-motor servo cost are the figures behind the `i40-zero` configuration of
//! `check.yaml` (2,250 Hz, 1 unit of 100 per motor).

use crate::cite::Cites;
use crate::common::{unique_rule_ids, Quantity, Rule};
use crate::yaml::SourceMap;
use crate::SpecError;
use serde::Deserialize;

/// `watchdog.yaml`.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Watchdog {
    pub hardware: WatchdogHardware,
    /// The counter: reset, decrement, strobe, trip.
    pub rules: Vec<Rule>,
    /// What a trip does (UM p.215).
    pub trip_actions: Vec<Rule>,
    /// The only ways out of a trip.
    pub recovery: Vec<Rule>,
    /// The diagnosis procedure's facts worth keeping.
    #[serde(default)]
    pub diagnosis: Vec<Rule>,
}

#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct WatchdogHardware {
    pub supply_volts_min: Quantity,
    /// The Turbo manual's figure; the `strobe_hz_min` reading of the profiles may replace it.
    pub strobe_hz_min: Quantity,
    /// How the hardware delay in servo cycles follows from the strobe frequency.
    pub delay_rule: Rule,
}

/// `checksums.yaml`.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Checksums {
    pub firmware: Vec<Rule>,
    pub user_program: Vec<Rule>,
    /// Registers and bits shared by both checks.
    pub common: Vec<Rule>,
}

/// `stop_commands.yaml`: the table of UM p.217.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct StopCommands {
    /// Why the command column is marked reconstructed.
    pub reconstruction_note: String,
    pub rows: Vec<StopCommand>,
}

#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct StopCommand {
    pub command: String,
    /// True when the command text was lost from the page and restored from its prose.
    pub command_reconstructed: bool,
    pub scope: StopScope,
    pub begins_immediately: bool,
    /// `yes`, `no`, or `not_applicable` (the page prints a dash).
    pub stops_on_path: Tristate,
    pub stops_at_program_point: bool,
    /// Deceleration source as printed (`Ixx15`, `TA, TS`, ...), or null when the cell is empty.
    pub decel_rate: Option<String>,
    pub notes: Option<String>,
    pub cite: Cites,
}

#[derive(Clone, Copy, Debug, Deserialize, PartialEq, Eq, Hash)]
#[serde(rename_all = "snake_case")]
pub enum StopScope {
    Motor,
    CoordinateSystem,
    Global,
}

#[derive(Clone, Copy, Debug, Deserialize, PartialEq, Eq, Hash)]
#[serde(rename_all = "snake_case")]
pub enum Tristate {
    Yes,
    No,
    NotApplicable,
}

/// `scheduling.yaml`.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Scheduling {
    pub servo_clock_hz: Quantity,
    /// The servo clocks taken anywhere one is given (`check.yaml`, a trace's `card:` header,
    /// `serve`/`record --servo-hz`).
    pub servo_clock_hz_range: ServoClockRange,
    pub servo_cost_per_motor_percent: Quantity,
    pub phase_and_servo_load_max_percent: Quantity,
    /// Task priorities, highest first.
    pub priorities: Vec<Rule>,
    pub rti: Vec<Rule>,
    pub plc0: Vec<Rule>,
    pub background: Vec<Rule>,
    #[serde(default)]
    pub registers_note: Option<String>,
    pub cite: Cites,
}

/// `scheduling.yaml`'s `servo_clock_hz_range`: inclusive bounds in Hz, with why.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ServoClockRange {
    pub min: u32,
    pub max: u32,
    pub reason: String,
    pub cite: Cites,
}

impl ServoClockRange {
    pub fn contains(&self, hz: u32) -> bool {
        (self.min..=self.max).contains(&hz)
    }

    /// `1..=100000 Hz (scheduling.yaml's servo_clock_hz_range)`, for error messages.
    pub fn describe(&self) -> String {
        format!("{}..={} Hz (scheduling.yaml's servo_clock_hz_range)", self.min, self.max)
    }
}

impl Watchdog {
    pub(crate) fn validate(&self, map: &SourceMap) -> Result<(), SpecError> {
        unique_rule_ids(map, "rules", &self.rules)?;
        unique_rule_ids(map, "trip_actions", &self.trip_actions)?;
        unique_rule_ids(map, "recovery", &self.recovery)?;
        unique_rule_ids(map, "diagnosis", &self.diagnosis)?;
        let v = self.hardware.supply_volts_min.value;
        if !(3.0..=6.0).contains(&v) {
            return Err(map.error(
                "hardware.supply_volts_min.value",
                format!("{v} V is not a plausible 5 V logic supply minimum"),
            ));
        }
        let f = self.hardware.strobe_hz_min.value;
        if !(1.0..=1000.0).contains(&f) {
            return Err(map.error("hardware.strobe_hz_min.value", format!("{f} Hz is not a plausible strobe minimum")));
        }
        for (key, q) in
            [("supply_volts_min", &self.hardware.supply_volts_min), ("strobe_hz_min", &self.hardware.strobe_hz_min)]
        {
            let Some(band) = &q.interval else {
                return Err(map.error(
                    &format!("hardware.{key}"),
                    "the manual gives this only approximately: an `interval` (min, max, reason, cite) is needed, \
                     the values replay admits",
                ));
            };
            if !(band.min > 0.0 && band.min <= q.value && q.value <= band.max) {
                return Err(map.error(
                    &format!("hardware.{key}.interval"),
                    format!(
                        "the interval {} to {} must be positive and hold the stated value {}",
                        band.min, band.max, q.value
                    ),
                ));
            }
        }
        Ok(())
    }
}

impl Checksums {
    pub(crate) fn validate(&self, map: &SourceMap) -> Result<(), SpecError> {
        unique_rule_ids(map, "firmware", &self.firmware)?;
        unique_rule_ids(map, "user_program", &self.user_program)?;
        unique_rule_ids(map, "common", &self.common)
    }
}

impl StopCommands {
    pub(crate) fn validate(&self, map: &SourceMap) -> Result<(), SpecError> {
        if self.rows.len() != 11 {
            return Err(map.error("rows", format!("the UM p.217 table has 11 rows, not {}", self.rows.len())));
        }
        for (i, r) in self.rows.iter().enumerate() {
            if self.rows[..i].iter().any(|o| o.command == r.command) {
                return Err(map.error(&format!("rows.{i}.command"), format!("command `{}` is listed twice", r.command)));
            }
        }
        Ok(())
    }
}

impl Scheduling {
    pub(crate) fn validate(&self, map: &SourceMap) -> Result<(), SpecError> {
        unique_rule_ids(map, "priorities", &self.priorities)?;
        unique_rule_ids(map, "rti", &self.rti)?;
        unique_rule_ids(map, "plc0", &self.plc0)?;
        unique_rule_ids(map, "background", &self.background)?;
        let r = &self.servo_clock_hz_range;
        if r.min == 0 || r.min > r.max {
            return Err(map.error(
                "servo_clock_hz_range",
                format!("{}..={} Hz is no range of servo clocks (at least 1 Hz, min <= max)", r.min, r.max),
            ));
        }
        let hz = self.servo_clock_hz.value;
        if !(f64::from(r.min)..=f64::from(r.max)).contains(&hz) {
            return Err(
                map.error("servo_clock_hz.value", format!("{hz} Hz is outside the servo clock range {}", r.describe()))
            );
        }
        Ok(())
    }
}
