//! A model configuration: one profile's readings plus one bounded configuration of
//! `check.yaml`, resolved into the plain numbers the semantics use.
//!
//! Everything here comes from `specs/`: status bit positions by name (`status.yaml`), lockout
//! ranges (`variables.yaml`), the supply minimum and strobe rule (`watchdog.yaml`).

use crate::check::{ChecksumTarget, Configuration, Cpu, Delay, Load, PassCycles, ResetEvent};
use crate::profiles::{Profile, ResetValueWhenI40Zero};
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
        })
    }

    /// Every bit the model drives. Destructured without `..`: a new driven bit is a compile
    /// error here, so counts derived from this list stay true.
    pub fn driven(&self) -> [(WordId, u8); 9] {
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
        ]
    }
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
    pub hardware_delay_cycles: u32,
    pub single_servo_cycles: bool,
    /// Mask of the X:$000000 counter kept in the state (0: not kept).
    pub servo_counter_mask: u32,
    pub cpu: Cpu,
    pub loads: Vec<Load>,
    pub supply_millivolts: Vec<u32>,
    /// Below this the hardware timer trips (UM p.215: about 4.75 V).
    pub supply_min_millivolts: u32,
    pub commands: Vec<HostCommand>,
    pub resets: Vec<ResetEvent>,
    pub checksum_faults: Vec<ChecksumTarget>,
    pub pass_cycles: PassCycles,
    pub clear_rti_reentry: bool,
    pub layout: StatusLayout,
    /// I41 lockout ranges, indexed by I41 bit (SRM p.57).
    pub lockout: [(u16, u16); 4],
    /// Valid value ranges of I8, I40, I41 (from `variables.yaml`).
    pub i8_range: (i64, i64),
    pub i40_range: (i64, i64),
    pub i41_range: (i64, i64),
}

impl ModelConfig {
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
        let hardware_delay_cycles = match c.hardware_delay_cycles {
            Delay::Cycles(n) => u32::from(n),
            Delay::Derived => derived_delay_cycles(c.servo_hz, profile.choices.strobe_hz_min.hz()),
        };
        let mut commands = Vec::new();
        for (i, text) in c.commands.iter().enumerate() {
            commands.push(HostCommand::parse(text).map_err(|e| map.error(&format!("{path}.commands.{i}"), e.0))?);
        }
        let supply_min_millivolts = (spec.watchdog.hardware.supply_volts_min.value * 1000.0).round() as u32;
        Ok(ModelConfig {
            configuration: name.to_string(),
            profile: profile.clone(),
            servo_hz: c.servo_hz,
            saved: SavedIVariables { i8: c.i8, i40: c.i40, i41: c.i41 },
            hardware_delay_cycles,
            single_servo_cycles: c.single_servo_cycles,
            servo_counter_mask: if c.servo_counter_bits == 0 { 0 } else { (1u32 << c.servo_counter_bits) - 1 },
            cpu: c.cpu,
            loads: c.loads.clone(),
            supply_millivolts: c.supply_millivolts.clone(),
            supply_min_millivolts,
            commands,
            resets: c.resets.clone(),
            checksum_faults: c.checksum_faults.clone(),
            pass_cycles: c.checksum_pass_cycles,
            clear_rti_reentry: c.clear_rti_reentry,
            layout,
            lockout,
            i8_range,
            i40_range,
            i41_range,
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

/// The hardware delay of `watchdog.yaml`'s `hardware_delay_from_strobe_minimum` rule: a square
/// wave at `strobe_hz_min` toggles every 1/(2 f) s, so more servo cycles than that without an
/// edge is a strobe below the minimum frequency.
pub fn derived_delay_cycles(servo_hz: u32, strobe_hz_min: u32) -> u32 {
    (servo_hz / (2 * strobe_hz_min)).max(1)
}
