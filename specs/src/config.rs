//! A model configuration: one profile's readings plus one bounded configuration of
//! `check.yaml`, resolved into the plain numbers the semantics use.
//!
//! Everything here comes from `specs/`: status bit positions by name (`status.yaml`), lockout
//! ranges (`variables.yaml`), the supply minimum and strobe rule (`watchdog.yaml`).

use crate::check::{ChecksumTarget, Configuration, Cpu, Delay, Load, PassCycles, Processor, ResetEvent};
use crate::profiles::{OutOfRangeAssignment, Profile, ResetValueWhenI40Zero};
use crate::status::WordId;
use crate::vocab::command::HostCommand;
use crate::{Spec, SpecError};

/// Where each status bit the model drives sits in the two words.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct StatusLayout {
    pub rti_reentry: (WordId, u8),
    pub servo_error: (WordId, u8),
    pub checksum_error: (WordId, u8),
    pub prom_checksum_active: (WordId, u8),
    pub dpram_error: (WordId, u8),
    pub flash_error: (WordId, u8),
    pub rti_warning: (WordId, u8),
    pub motion_buffer_open: (WordId, u8),
    pub plc_buffer_open: (WordId, u8),
    /// X bit 19: the data gathering function is on (SRM p.289), from GATHER to ENDGATHER.
    pub data_gathering_on: (WordId, u8),
    /// X bit 21 and Y bit 21: the CPU option (SRM p.289), from the configuration.
    pub cpu_type_bit1: (WordId, u8),
    pub cpu_type_bit0: (WordId, u8),
}

impl StatusLayout {
    /// Finds every bit the model drives in `status.yaml`, by name.
    pub fn of(spec: &Spec) -> Result<StatusLayout, SpecError> {
        let bit = |n: &str| {
            spec.status.bit(n).ok_or_else(|| {
                SpecError::at(
                    &spec.dir.join("status.yaml"),
                    crate::Position { line: 1, column: 1 },
                    format!("the model needs a status bit named `{n}`"),
                )
            })
        };
        Ok(StatusLayout {
            rti_reentry: bit("rti_reentry")?,
            servo_error: bit("servo_error")?,
            checksum_error: bit("checksum_error")?,
            prom_checksum_active: bit("prom_checksum_active")?,
            dpram_error: bit("dpram_error")?,
            flash_error: bit("flash_error")?,
            rti_warning: bit("rti_warning")?,
            motion_buffer_open: bit("motion_buffer_open")?,
            plc_buffer_open: bit("plc_buffer_open")?,
            data_gathering_on: bit("data_gathering_on")?,
            cpu_type_bit1: bit("cpu_type_bit1")?,
            cpu_type_bit0: bit("cpu_type_bit0")?,
        })
    }

    /// Every bit the model drives. Destructured without `..`: a new driven bit is a compile
    /// error here, so counts derived from this list stay true.
    pub fn driven(&self) -> [(WordId, u8); 12] {
        let StatusLayout {
            rti_reentry,
            servo_error,
            checksum_error,
            prom_checksum_active,
            dpram_error,
            flash_error,
            rti_warning,
            motion_buffer_open,
            plc_buffer_open,
            data_gathering_on,
            cpu_type_bit1,
            cpu_type_bit0,
        } = *self;
        [
            rti_reentry,
            servo_error,
            checksum_error,
            prom_checksum_active,
            dpram_error,
            flash_error,
            rti_warning,
            motion_buffer_open,
            plc_buffer_open,
            data_gathering_on,
            cpu_type_bit1,
            cpu_type_bit0,
        ]
    }
}

/// One row of UM p.217's stop-command table (`stop_commands.yaml`) as the model's stop rules
/// read it: the columns decide what a stop command does (`model/src/motion.rs`).
#[derive(Clone, Debug, PartialEq, Eq, Hash)]
pub struct StopRow {
    /// The first column (`J/`, `A`, `<CTRL-A>`, ...), as `Motion::stop_table_name` prints it.
    pub command: String,
    pub scope: crate::facts::StopScope,
    /// "Begin Immed?".
    pub begins_immediately: bool,
    /// "Stop on Path?".
    pub stops_on_path: crate::facts::Tristate,
    /// "Stop at Prog Pt?".
    pub stops_at_program_point: bool,
    /// "Decel Rate" printed: a stop that decelerates; an empty cell is a kill.
    pub decelerates: bool,
}

/// The I-variable values restored by every reset (what was last saved to flash).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct SavedIVariables {
    pub i8: u8,
    pub i40: u16,
    pub i41: u8,
}

#[derive(Clone, Debug, PartialEq, Eq, Hash)]
pub struct ModelConfig {
    pub configuration: String,
    pub profile: Profile,
    pub servo_hz: u32,
    pub saved: SavedIVariables,
    /// The I-variables' factory defaults (`variables.yaml`), which `$$$***` puts in active
    /// memory (UM p.243).
    pub factory: SavedIVariables,
    /// The CPU option fitted (SRM p.289: `???` bits X21 and Y21).
    pub processor: Processor,
    pub hardware_delay_cycles: u32,
    /// The hardware delays a card may have, `(min, max)` cycles: the strobe minimum is only
    /// "approximately" known (UM p.215; `watchdog.yaml`, `strobe_hz_min.interval`). Replay
    /// admits any of them; the checker uses `hardware_delay_cycles`. A configuration that
    /// fixes the delay in cycles fixes the band too.
    pub hardware_delay_band: (u32, u32),
    pub single_servo_cycles: bool,
    /// Mask of the X:$000000 counter kept in the state (0: not kept).
    pub servo_counter_mask: u32,
    pub cpu: Cpu,
    pub loads: Vec<Load>,
    pub supply_millivolts: Vec<u32>,
    /// Below this the hardware timer trips (UM p.215: about 4.75 V).
    pub supply_min_millivolts: u32,
    /// The thresholds a card may have, `(min, max)` millivolts (UM p.215 "about 4.75 V";
    /// `watchdog.yaml`, `supply_volts_min.interval`). Replay admits any of them.
    pub supply_min_millivolts_band: (u32, u32),
    pub commands: Vec<HostCommand>,
    pub resets: Vec<ResetEvent>,
    pub checksum_faults: Vec<ChecksumTarget>,
    pub pass_cycles: PassCycles,
    pub clear_rti_reentry: bool,
    /// What a write of an I-variable other than I8, I40 and I41 leaves (`check.yaml`).
    pub other_i_writes: crate::check::OtherIWrites,
    /// The motors (`check.yaml`'s `motion`).
    pub motion: crate::check::MotionSetup,
    /// UM p.217's stop-command table, top to bottom (`stop_commands.yaml`): the model's stop
    /// rules read their columns here, so a column changed in the data changes the behaviour.
    pub stop_table: Vec<StopRow>,
    pub layout: StatusLayout,
    /// I41 lockout ranges, indexed by I41 bit (SRM p.57).
    pub lockout: [(u16, u16); 4],
    /// Valid value ranges of I8, I40, I41 (from `variables.yaml`).
    pub i8_range: (i64, i64),
    pub i40_range: (i64, i64),
    pub i41_range: (i64, i64),
    /// The servo clocks a card may run at, in Hz (`scheduling.yaml`'s `servo_clock_hz_range`).
    pub servo_hz_range: (u32, u32),
}

impl ModelConfig {
    /// What an assignment outside I8's, I40's or I41's range does: the profile's reading
    /// `out_of_range_assignment` (`profiles.yaml`: ERR003 and the variable unchanged, MODEL,
    /// SRM p.42/p.57; or UM p.243's modulo, I3=5 giving 1). Read from the profile's choices,
    /// the one place it is set (`um-243-modulo` chooses `modulo`; replay's lanes set it).
    pub fn out_of_range(&self) -> OutOfRangeAssignment {
        self.profile.choices.out_of_range_assignment
    }

    /// The row of UM p.217's table whose first column is `command`.
    pub fn stop_row(&self, command: &str) -> Option<&StopRow> {
        self.stop_table.iter().find(|r| r.command == command)
    }

    /// Resolves configuration `name` of the spec's `check.yaml` under `profile`.
    pub fn from_spec(spec: &Spec, name: &str, profile: &Profile) -> Result<ModelConfig, SpecError> {
        let map = &spec.check_map;
        let path = format!("configurations.{name}");
        let c: &Configuration = spec
            .check
            .configurations
            .get(name)
            .ok_or_else(|| map.error("configurations", format!("no configuration named `{name}`")))?;
        let layout = StatusLayout::of(spec)?;
        let vars = &spec.variables;
        let range = |r: &crate::common::Range| (r.min, r.max);
        let (i8_range, i40_range, i41_range) =
            (range(&vars.i_variables.i8.range), range(&vars.i_variables.i40.range), range(&vars.i_variables.i41.range));
        for (field, v, r) in [
            ("i8", i64::from(c.i8), i8_range),
            ("i40", i64::from(c.i40), i40_range),
            ("i41", i64::from(c.i41), i41_range),
        ] {
            if v < r.0 || v > r.1 {
                return Err(map.error(
                    &format!("{path}.{field}"),
                    format!("{field} = {v} is outside its range {}..={}", r.0, r.1),
                ));
            }
        }
        let mut lockout = [(0u16, 0u16); 4];
        for r in &vars.lockout {
            lockout[usize::from(r.bit)] = (r.first, r.last);
        }
        let (hardware_delay_cycles, hardware_delay_band) = match c.hardware_delay_cycles {
            Delay::Cycles(n) => (u32::from(n), (u32::from(n), u32::from(n))),
            Delay::Derived => (
                derived_delay_cycles(c.servo_hz, strobe_edge_hz(&profile.choices)),
                derived_delay_band(spec, c.servo_hz, strobe_edge_hz(&profile.choices)),
            ),
        };
        let mut commands = Vec::new();
        for (i, text) in c.commands.iter().enumerate() {
            commands.push(HostCommand::parse(text).map_err(|e| map.error(&format!("{path}.commands.{i}"), e.0))?);
        }
        let supply = &spec.watchdog.hardware.supply_volts_min;
        let millivolts = |v: f64| (v * 1000.0).round() as u32;
        let supply_min_millivolts = millivolts(supply.value);
        let supply_min_millivolts_band = supply
            .interval
            .as_ref()
            .map_or((supply_min_millivolts, supply_min_millivolts), |b| (millivolts(b.min), millivolts(b.max)));
        // variables.yaml's loader keeps each default within its range; the ranges fit the
        // model's types, which a wrong range would break here with a message, not a panic.
        let variables_file = spec.dir.join("variables.yaml");
        let factory_default = |v: i64, range: (i64, i64)| {
            u16::try_from(v).map_err(|_| {
                SpecError::whole_file(
                    &variables_file,
                    format!(
                        "the factory default {v} does not fit the model's variable (range {}..={})",
                        range.0, range.1
                    ),
                )
            })
        };
        let narrow = |v: u16| {
            u8::try_from(v).map_err(|_| {
                SpecError::whole_file(&variables_file, format!("the factory default {v} of I8 or I41 is above 255"))
            })
        };
        Ok(ModelConfig {
            configuration: name.to_string(),
            profile: profile.clone(),
            servo_hz: c.servo_hz,
            saved: SavedIVariables { i8: c.i8, i40: c.i40, i41: c.i41 },
            factory: SavedIVariables {
                i8: narrow(factory_default(vars.i_variables.i8.default, i8_range)?)?,
                i40: factory_default(vars.i_variables.i40.default, i40_range)?,
                i41: narrow(factory_default(vars.i_variables.i41.default, i41_range)?)?,
            },
            processor: c.processor,
            hardware_delay_cycles,
            hardware_delay_band,
            single_servo_cycles: c.single_servo_cycles,
            servo_counter_mask: if c.servo_counter_bits == 0 { 0 } else { (1u32 << c.servo_counter_bits) - 1 },
            cpu: c.cpu,
            loads: c.loads.clone(),
            supply_millivolts: c.supply_millivolts.clone(),
            supply_min_millivolts,
            supply_min_millivolts_band,
            commands,
            resets: c.resets.clone(),
            checksum_faults: c.checksum_faults.clone(),
            pass_cycles: c.checksum_pass_cycles,
            clear_rti_reentry: c.clear_rti_reentry,
            other_i_writes: c.other_i_variable_writes,
            stop_table: spec
                .stop_commands
                .rows
                .iter()
                .map(|r| StopRow {
                    command: r.command.clone(),
                    scope: r.scope,
                    begins_immediately: r.begins_immediately,
                    stops_on_path: r.stops_on_path,
                    stops_at_program_point: r.stops_at_program_point,
                    decelerates: r.decel_rate.is_some(),
                })
                .collect(),
            motion: c.motion.clone(),
            layout,
            lockout,
            i8_range,
            i40_range,
            i41_range,
            servo_hz_range: (spec.scheduling.servo_clock_hz_range.min, spec.scheduling.servo_clock_hz_range.max),
        })
    }

    /// The counter value a background cycle loads for a given I40 (SRM p.57, UM p.215).
    pub fn reset_value(&self, i40: u16) -> i32 {
        if i40 == 0 {
            // The readings disagree (facts s.6): 4095 (SRM p.57, UM p.240) or 4096 (UM p.215, p.237).
            i32::from(match self.profile.choices.reset_value_when_i40_zero {
                ResetValueWhenI40Zero::R4095 => 4095u16,
                ResetValueWhenI40Zero::R4096 => 4096,
            })
        } else {
            i32::from(i40)
        }
    }

    /// The I41 bit that locks I-variable `n`, if any (SRM p.57).
    pub fn lockout_bit(&self, n: u16) -> Option<u8> {
        self.lockout.iter().position(|(first, last)| (*first..=*last).contains(&n)).map(|b| b as u8)
    }
}

/// What a capture says about the card itself, overriding its configuration's saved values (the
/// optional `card:` header key of a trace, `docs/trace-format.md`). Every field is optional:
/// a host log says what it read and no more. The values are as read (wide types), so that a
/// value outside its range is refused by [`ModelConfig::with_card`] with the range of
/// `variables.yaml`, not by the parser with a type's bounds.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CardConfig {
    /// The servo clock, in Hz (from I10, SRM p.43: `8_388_608_000 / I10`).
    #[serde(default)]
    pub servo_hz: Option<u32>,
    #[serde(default)]
    pub i8: Option<i64>,
    #[serde(default)]
    pub i40: Option<i64>,
    #[serde(default)]
    pub i41: Option<i64>,
    /// The card's own hardware delay, in servo cycles, within the band its strobe minimum
    /// admits (UM p.215 "approximately 25 Hz"). Written by replay into an explanation.
    #[serde(default)]
    pub hardware_delay_cycles: Option<u32>,
    /// The card's own supply threshold, in millivolts, within the band of UM p.215's "about
    /// 4.75 V". Written by replay into an explanation.
    #[serde(default)]
    pub supply_min_millivolts: Option<u32>,
    /// The card's own checksum pass length, in background cycles, for both areas (UM p.217
    /// computes the checksums "continually ... as a background task" and gives no length).
    /// Written by replay into an explanation.
    #[serde(default)]
    pub checksum_pass_cycles: Option<u32>,
    /// The user-program area's pass length, where it differs from the firmware's (which
    /// `checksum_pass_cycles` then gives): the two areas differ in size, and UM p.217 gives
    /// neither length. Written by replay into an explanation.
    #[serde(default)]
    pub user_program_checksum_pass_cycles: Option<u32>,
}

impl CardConfig {
    pub fn is_empty(&self) -> bool {
        *self == CardConfig::default()
    }

    /// The fields that are set, as `name: value`, in header order.
    pub fn fields(&self) -> Vec<(&'static str, i64)> {
        [
            ("servo_hz", self.servo_hz.map(i64::from)),
            ("i8", self.i8),
            ("i40", self.i40),
            ("i41", self.i41),
            ("hardware_delay_cycles", self.hardware_delay_cycles.map(i64::from)),
            ("supply_min_millivolts", self.supply_min_millivolts.map(i64::from)),
            ("checksum_pass_cycles", self.checksum_pass_cycles.map(i64::from)),
            ("user_program_checksum_pass_cycles", self.user_program_checksum_pass_cycles.map(i64::from)),
        ]
        .into_iter()
        .filter_map(|(k, v)| v.map(|v| (k, v)))
        .collect()
    }
}

/// I10, the servo interrupt time in units of 1/8,388,608 ms (SRM p.43: 2^23 means one
/// millisecond; range 0..8,388,607), as a servo frequency in Hz, rounded. `None` for 0, which
/// is no period.
pub fn servo_hz_of_i10(i10: i64) -> Option<u32> {
    if !(1..=8_388_607).contains(&i10) {
        return None;
    }
    let i10 = i10 as u64;
    // I10 = 1 is 8.4 GHz, beyond u32: saturated, so that the range check refuses it as read
    // rather than a wrapped value.
    Some(u32::try_from((8_388_608_000u64 + i10 / 2) / i10).unwrap_or(u32::MAX))
}

impl ModelConfig {
    /// This configuration with what a capture says about the card (its `card:` header): the
    /// saved I8, I40, I41 and the servo clock replaced by the values given, each checked
    /// against its range in `variables.yaml` (the servo clock: `scheduling.yaml`'s), and a derived
    /// hardware delay (`hardware_delay_cycles: derived` in `check.yaml`) derived again from
    /// the new servo clock. The error names the field, its value and its range.
    pub fn with_card(mut self, spec: &Spec, card: &CardConfig) -> Result<ModelConfig, String> {
        let check = |field: &str, v: i64, r: (i64, i64)| {
            if v < r.0 || v > r.1 {
                Err(format!("card: {field} = {v} is outside its range {}..={} (variables.yaml)", r.0, r.1))
            } else {
                Ok(v)
            }
        };
        if let Some(v) = card.i8 {
            self.saved.i8 = check("i8", v, self.i8_range)? as u8;
        }
        if let Some(v) = card.i40 {
            self.saved.i40 = check("i40", v, self.i40_range)? as u16;
        }
        if let Some(v) = card.i41 {
            self.saved.i41 = check("i41", v, self.i41_range)? as u8;
        }
        if let Some(hz) = card.servo_hz {
            let range = &spec.scheduling.servo_clock_hz_range;
            if !range.contains(hz) {
                return Err(format!("card: servo_hz = {hz} is outside its range {}", range.describe()));
            }
            self.servo_hz = hz;
            let derived = spec
                .check
                .configurations
                .get(&self.configuration)
                .is_some_and(|c| matches!(c.hardware_delay_cycles, Delay::Derived));
            if derived {
                self.hardware_delay_cycles = derived_delay_cycles(hz, strobe_edge_hz(&self.profile.choices));
                self.hardware_delay_band = derived_delay_band(spec, hz, strobe_edge_hz(&self.profile.choices));
            }
        }
        if let Some(n) = card.hardware_delay_cycles {
            let (lo, hi) = self.hardware_delay_band;
            if !(lo..=hi).contains(&n) {
                return Err(format!(
                    "card: hardware_delay_cycles = {n} is outside the delays this configuration admits, {lo}..={hi} \
                     (watchdog.yaml, strobe_hz_min.interval, at {} Hz)",
                    self.servo_hz
                ));
            }
            self.hardware_delay_cycles = n;
        }
        if let Some(mv) = card.supply_min_millivolts {
            let (lo, hi) = self.supply_min_millivolts_band;
            if !(lo..=hi).contains(&mv) {
                return Err(format!(
                    "card: supply_min_millivolts = {mv} is outside the thresholds admitted, {lo}..={hi} \
                     (watchdog.yaml, supply_volts_min.interval)"
                ));
            }
            self.supply_min_millivolts = mv;
        }
        let pass_length = |field: &str, n: u32| {
            u8::try_from(n).ok().filter(|n| *n >= 1).ok_or_else(|| {
                format!("card: {field} = {n} is outside the pass lengths admitted, 1..=255 background cycles")
            })
        };
        if let Some(n) = card.checksum_pass_cycles {
            let n = pass_length("checksum_pass_cycles", n)?;
            self.pass_cycles = PassCycles { firmware: n, user_program: n };
        }
        if let Some(n) = card.user_program_checksum_pass_cycles {
            self.pass_cycles.user_program = pass_length("user_program_checksum_pass_cycles", n)?;
        }
        Ok(self)
    }
}

/// The rate, in Hz, at which the hardware timer's detector needs strobe edges under `choices`:
/// a square wave at the strobe minimum f (`strobe_hz_min`) has 2 f edges a second; a detector
/// that needs one edge per half period (`strobe_detector: half_period`) asks for all of them
/// in time, one that needs a full set-and-clear per period (`full_period`) for a pair every
/// 1/f s, so an edge rate of f (UM p.215; MODEL: the page does not describe the detector).
/// Two readings with the same edge rate (25 Hz and a full period, 50 Hz and half a period)
/// give the same delays, servo clock for servo clock: replay searches them once.
pub fn strobe_edge_hz(choices: &crate::profiles::Choices) -> u32 {
    2 * choices.strobe_hz_min.hz() / choices.strobe_detector.edges_per_period()
}

/// The hardware delay of `watchdog.yaml`'s `hardware_delay_from_strobe_minimum` rule: more
/// servo cycles than 1/`edge_hz` s without a strobe edge is a strobe below the minimum
/// frequency ([`strobe_edge_hz`]: a square wave at 25 Hz toggles every 1/50 s, so 45 cycles
/// at 2,250 Hz for a half-period detector, 90 for a full-period one).
pub fn derived_delay_cycles(servo_hz: u32, edge_hz: u32) -> u32 {
    (servo_hz / edge_hz).max(1)
}

/// The delays of [`derived_delay_cycles`] over the strobe minimum's band: `watchdog.yaml`'s
/// `strobe_hz_min.interval` around its stated value, scaled to the profile's reading
/// (`strobe_hz_min`: 25 or 50 Hz), so 20 to 30 Hz, or 40 to 60 Hz, and so the edge rate
/// [`strobe_edge_hz`] within the same ratios. The highest frequency gives the shortest delay.
pub fn derived_delay_band(spec: &Spec, servo_hz: u32, edge_hz: u32) -> (u32, u32) {
    let stated = &spec.watchdog.hardware.strobe_hz_min;
    let (lo_ratio, hi_ratio) =
        stated.interval.as_ref().map_or((1.0, 1.0), |b| (b.min / stated.value, b.max / stated.value));
    let delay = |f: f64| ((f64::from(servo_hz) / f).floor() as u32).max(1);
    let f = f64::from(edge_hz);
    let (lo, hi) = (delay(f * hi_ratio), delay(f * lo_ratio));
    let nominal = derived_delay_cycles(servo_hz, edge_hz);
    (lo.min(nominal), hi.max(nominal))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::profiles::{StrobeDetector, StrobeHzMin};

    fn config(name: &str) -> (Spec, ModelConfig) {
        let spec = Spec::embedded().unwrap();
        let profile = spec.profiles.default_profile();
        let cfg = ModelConfig::from_spec(&spec, name, &profile).unwrap();
        (spec, cfg)
    }

    #[test]
    fn the_default_i10_is_the_2_26_khz_servo_clock_of_the_manual() {
        // SRM p.43: default I10 = 3,713,707, a servo cycle of 442.7 us.
        assert_eq!(servo_hz_of_i10(3_713_707), Some(2259));
        assert_eq!(servo_hz_of_i10(8_388_607), Some(1000));
        assert_eq!(servo_hz_of_i10(0), None, "I10 = 0 is no period");
        assert_eq!(servo_hz_of_i10(8_388_608), None, "beyond the range of I10");
    }

    #[test]
    fn a_card_header_overrides_the_saved_i_variables_and_the_servo_clock() {
        let (spec, cfg) = config("i40-zero");
        let card =
            CardConfig { servo_hz: Some(4518), i8: Some(3), i40: Some(100), i41: Some(1), ..CardConfig::default() };
        let c = cfg.clone().with_card(&spec, &card).unwrap();
        assert_eq!(c.saved, SavedIVariables { i8: 3, i40: 100, i41: 1 });
        assert_eq!(c.servo_hz, 4518);
        let empty = cfg.clone().with_card(&spec, &CardConfig::default()).unwrap();
        assert_eq!(empty, cfg, "an empty card changes nothing");
    }

    #[test]
    fn a_derived_hardware_delay_follows_the_card_s_servo_clock_and_a_fixed_one_does_not() {
        let spec = Spec::embedded().unwrap();
        let profile = spec.profiles.default_profile();
        let card = CardConfig { servo_hz: Some(9000), ..CardConfig::default() };
        for (name, c) in &spec.check.configurations {
            let cfg = ModelConfig::from_spec(&spec, name, &profile).unwrap();
            let with = cfg.clone().with_card(&spec, &card).unwrap();
            match c.hardware_delay_cycles {
                Delay::Derived => assert_eq!(
                    with.hardware_delay_cycles,
                    derived_delay_cycles(9000, strobe_edge_hz(&profile.choices)),
                    "{name}"
                ),
                Delay::Cycles(n) => assert_eq!(with.hardware_delay_cycles, u32::from(n), "{name}"),
            }
        }
    }

    #[test]
    fn approximately_25_hz_admits_delays_of_37_to_56_cycles_at_2250_hz_and_50_hz_18_to_28() {
        // UM p.215 "approximately 25 Hz", read as 20 to 30 Hz (watchdog.yaml's interval): a
        // square wave at 30 Hz toggles every 37.5 cycles of 2,250 Hz, at 20 Hz every 56.25.
        let spec = Spec::embedded().unwrap();
        let band = |hz, detector| {
            let mut c = spec.profiles.default_profile().choices;
            (c.strobe_hz_min, c.strobe_detector) = (hz, detector);
            derived_delay_band(&spec, 2250, strobe_edge_hz(&c))
        };
        assert_eq!(band(StrobeHzMin::Hz25, StrobeDetector::HalfPeriod), (37, 56));
        assert_eq!(band(StrobeHzMin::Hz50, StrobeDetector::HalfPeriod), (18, 28));
        // The stated figure lies inside its band.
        let (lo, hi) = derived_delay_band(&spec, 2250, 50);
        assert!((lo..=hi).contains(&derived_delay_cycles(2250, 50)));
    }

    #[test]
    fn a_full_period_detector_admits_twice_the_cycles_75_to_112_at_2250_hz_and_25_hz() {
        // UM p.215 "set and clear this bit repeatedly at 25 Hz or greater", read as one full
        // set-and-clear per period: a period at 30 Hz is 75 cycles of 2,250 Hz, at 20 Hz 112.5.
        let spec = Spec::embedded().unwrap();
        let mut c = spec.profiles.default_profile().choices;
        c.strobe_detector = StrobeDetector::FullPeriod;
        assert_eq!(derived_delay_cycles(2250, strobe_edge_hz(&c)), 90);
        assert_eq!(derived_delay_band(&spec, 2250, strobe_edge_hz(&c)), (75, 112));
        // 50 Hz with a full period asks for the edges 25 Hz with half a period does, at every
        // servo clock: replay searches the two as one lane.
        let mut d = spec.profiles.default_profile().choices;
        c.strobe_hz_min = StrobeHzMin::Hz50;
        d.strobe_detector = StrobeDetector::HalfPeriod;
        assert_eq!(strobe_edge_hz(&c), strobe_edge_hz(&d));
    }

    #[test]
    fn a_card_may_say_its_own_checksum_pass_length_from_1_to_255_background_cycles() {
        let (spec, cfg) = config("host-log");
        assert_eq!(cfg.pass_cycles, PassCycles { firmware: 1, user_program: 1 });
        let card = CardConfig { checksum_pass_cycles: Some(3), ..CardConfig::default() };
        assert_eq!(
            cfg.clone().with_card(&spec, &card).unwrap().pass_cycles,
            PassCycles { firmware: 3, user_program: 3 }
        );
        // Each area its own length: the user program's apart from the firmware's.
        let card = CardConfig {
            checksum_pass_cycles: Some(2),
            user_program_checksum_pass_cycles: Some(1),
            ..CardConfig::default()
        };
        assert_eq!(
            cfg.clone().with_card(&spec, &card).unwrap().pass_cycles,
            PassCycles { firmware: 2, user_program: 1 }
        );
        let card = CardConfig { user_program_checksum_pass_cycles: Some(0), ..CardConfig::default() };
        let e = cfg.clone().with_card(&spec, &card).unwrap_err();
        assert!(e.contains("user_program_checksum_pass_cycles = 0") && e.contains("1..=255"), "{e}");
        for n in [0, 256] {
            let e =
                cfg.clone().with_card(&spec, &CardConfig { checksum_pass_cycles: Some(n), ..CardConfig::default() });
            let e = e.unwrap_err();
            assert!(e.contains(&format!("checksum_pass_cycles = {n}")) && e.contains("1..=255"), "{e}");
        }
    }

    #[test]
    fn a_card_may_say_its_own_delay_and_supply_threshold_but_only_within_their_bands() {
        let (spec, cfg) = config("host-log");
        assert_eq!(cfg.supply_min_millivolts_band, (4650, 4850), "UM p.215 about 4.75 V, read as 4.65 to 4.85 V");
        let card =
            CardConfig { hardware_delay_cycles: Some(50), supply_min_millivolts: Some(4700), ..CardConfig::default() };
        let c = cfg.clone().with_card(&spec, &card).unwrap();
        assert_eq!((c.hardware_delay_cycles, c.supply_min_millivolts), (50, 4700));
        let far = CardConfig { hardware_delay_cycles: Some(57), ..CardConfig::default() };
        let e = cfg.clone().with_card(&spec, &far).unwrap_err();
        assert!(e.contains("hardware_delay_cycles = 57") && e.contains("37..=56"), "{e}");
        let low = CardConfig { supply_min_millivolts: Some(4500), ..CardConfig::default() };
        let e = cfg.with_card(&spec, &low).unwrap_err();
        assert!(e.contains("supply_min_millivolts = 4500") && e.contains("4650..=4850"), "{e}");
    }

    #[test]
    fn a_card_value_outside_its_range_is_refused_naming_the_field_and_the_range() {
        let (spec, cfg) = config("i40-zero");
        let e = cfg.clone().with_card(&spec, &CardConfig { i40: Some(70000), ..CardConfig::default() }).unwrap_err();
        assert!(e.contains("i40 = 70000") && e.contains("variables.yaml"), "{e}");
        let e = cfg.clone().with_card(&spec, &CardConfig { i8: Some(-1), ..CardConfig::default() }).unwrap_err();
        assert!(e.contains("i8 = -1"), "{e}");
        // The servo clock against scheduling.yaml's range, on both sides: 0 Hz is no clock, and
        // a clock above the range (I10 = 1 in a host log reads as 8.4 GHz) would make a derived
        // hardware delay of millions of cycles.
        let range = &spec.scheduling.servo_clock_hz_range;
        for hz in [range.min - 1, range.max + 1, u32::MAX] {
            let e =
                cfg.clone().with_card(&spec, &CardConfig { servo_hz: Some(hz), ..CardConfig::default() }).unwrap_err();
            assert!(e.contains(&format!("servo_hz = {hz}")) && e.contains("servo_clock_hz_range"), "{e}");
        }
        for hz in [range.min, range.max] {
            assert!(cfg.clone().with_card(&spec, &CardConfig { servo_hz: Some(hz), ..CardConfig::default() }).is_ok());
        }
    }
}
