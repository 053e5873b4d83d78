//! `check.yaml`: the bounded configurations the model checker explores, and which profiles
//! each is checked under. These are the "embedded default configuration" of `pmacwd check`.
//!
//! A configuration fixes the initial I-variables, the CPU cost model, and the finite menu of
//! environment events the checker may choose from at every state (loads, supply voltages,
//! host commands, resets, injected faults). Host commands are kept as text here and parsed by
//! the model, which reports a bad one at its position in this file.

use crate::facts::ServoClockRange;
use crate::yaml::SourceMap;
use crate::SpecError;
use serde::Deserialize;
use std::collections::BTreeMap;

/// The most motors a configuration may have (the model's default configuration has 8; an
/// observation shows this many, `vocab::observation::MOTORS_SHOWN`).
pub const MOTORS_MAX: usize = 8;

#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Check {
    pub configurations: BTreeMap<String, Configuration>,
    pub runs: Vec<Run>,
}

#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Run {
    pub configuration: String,
    /// `all`, or a list of profile names.
    pub profiles: ProfileSelection,
}

#[derive(Clone, Debug, Deserialize)]
#[serde(untagged)]
pub enum ProfileSelection {
    Keyword(AllKeyword),
    Named(Vec<String>),
}

#[derive(Clone, Copy, Debug, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum AllKeyword {
    All,
}

#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Configuration {
    pub summary: String,
    /// Servo clock in Hz, within `scheduling.yaml`'s `servo_clock_hz_range`; used to derive the
    /// hardware delay and to print times.
    pub servo_hz: u32,
    /// Initial (saved) values of I8, I40, I41; INIT/ and power-up restore them.
    pub i8: u8,
    pub i40: u16,
    pub i41: u8,
    /// Servo cycles without a strobe edge after which the hardware timer trips, or `derived`
    /// to compute it from `servo_hz` and the profile's `strobe_hz_min` reading.
    pub hardware_delay_cycles: Delay,
    /// Whether the checker may advance one servo cycle at a time. Without it, time advances only
    /// to the next point where something can change, and to the cycle just before it.
    pub single_servo_cycles: bool,
    /// Width of the X:$000000 servo counter kept in the state (24 on the card; 0 drops it
    /// from the checked state, since no rule reads it).
    pub servo_counter_bits: u8,
    pub cpu: Cpu,
    /// The processor fitted, which bits X21 and Y21 of `???` report (SRM p.289: the CPU
    /// options are the card's, not the firmware's); absent: DSP56303 (see [`Processor`]).
    #[serde(default)]
    pub processor: Processor,
    /// Loads the environment may switch between; the first is the load at power-up.
    pub loads: Vec<Load>,
    /// Supply voltages the environment may apply, in millivolts.
    pub supply_millivolts: Vec<u32>,
    /// Host commands the environment may send, as typed at a terminal.
    pub commands: Vec<String>,
    pub resets: Vec<ResetEvent>,
    #[serde(default)]
    pub checksum_faults: Vec<ChecksumTarget>,
    /// Background cycles one checksum pass over each area takes.
    pub checksum_pass_cycles: PassCycles,
    /// Whether the environment may clear bit 22 by a memory write.
    pub clear_rti_reentry: bool,
    /// What a write of an I-variable other than I8, I40 and I41 leaves (absent: `stored`).
    #[serde(default)]
    pub other_i_variable_writes: OtherIWrites,
    /// The motors and what the environment may do to them; absent: the default below.
    #[serde(default)]
    pub motion: MotionSetup,
}

/// What a write of an I-variable other than I8, I40 and I41 does. Each I-variable has a range
/// (SRM p.42, p.57), and a value outside it is refused with ERR003 or rolled over into it by
/// modulo arithmetic (UM p.243, the reading `out_of_range_assignment`); `variables.yaml` holds
/// the ranges of I8, I40 and I41 alone.
#[derive(Clone, Copy, Debug, Default, Deserialize, PartialEq, Eq, Hash)]
#[serde(rename_all = "snake_case")]
pub enum OtherIWrites {
    /// MODEL: the project's card stores any value written (its ranges are not in the specs):
    /// the checker, the core and the emulator.
    #[default]
    Stored,
    /// A real card's: the range is the card's own, so the write's answer (acknowledged or
    /// ERR003) and the value it leaves are too, until the log reads it. Replay's `host-log`.
    CardOwn,
}

/// The motors of a configuration (the stop rules of UM p.217, the encoder-loss PLC of UM
/// p.214-215). Motion commands themselves are listed in `commands`.
#[derive(Clone, Debug, Deserialize, PartialEq, Eq, Hash)]
#[serde(deny_unknown_fields)]
pub struct MotionSetup {
    /// How many motors (1..=8); default 8.
    #[serde(default = "eight")]
    pub motors: u8,
    /// The coordinate system of each motor, in motor order; empty: every motor in &1.
    #[serde(default)]
    pub coordinate_systems: Vec<u8>,
    /// The longest deceleration, in servo cycles: a stop command's deceleration takes between
    /// 1 and this many cycles, each length explored by the checker (default 1).
    #[serde(default = "one")]
    pub decel_cycles_max: u8,
    /// Whether the environment may lose and restore each motor's encoder (UM p.214).
    #[serde(default)]
    pub encoder_inputs: bool,
    /// Whether the environment may set and clear each motor's amplifier-fault input (UM p.213).
    #[serde(default)]
    pub amplifier_fault_inputs: bool,
}

fn eight() -> u8 {
    8
}

fn one() -> u8 {
    1
}

impl Default for MotionSetup {
    fn default() -> Self {
        MotionSetup {
            motors: eight(),
            coordinate_systems: Vec::new(),
            decel_cycles_max: one(),
            encoder_inputs: false,
            amplifier_fault_inputs: false,
        }
    }
}

impl MotionSetup {
    /// The coordinate system of motor `m` (from 1).
    pub fn coordinate_system(&self, m: u8) -> u8 {
        self.coordinate_systems.get(usize::from(m) - 1).copied().unwrap_or(1)
    }
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Delay {
    Cycles(u16),
    Derived,
}

impl<'de> Deserialize<'de> for Delay {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        #[derive(Deserialize)]
        #[serde(untagged)]
        enum Raw {
            N(u16),
            S(String),
        }
        match Raw::deserialize(d)
            .map_err(|_| serde::de::Error::custom("expected a number of servo cycles (1..=65535) or `derived`"))?
        {
            Raw::N(0) => {
                Err(serde::de::Error::custom("a hardware delay of 0 cycles would trip between any two strobes"))
            }
            Raw::N(n) => Ok(Delay::Cycles(n)),
            Raw::S(s) if s == "derived" => Ok(Delay::Derived),
            Raw::S(s) => {
                Err(serde::de::Error::custom(format!("expected a number of servo cycles or `derived`, found `{s}`")))
            }
        }
    }
}

/// CPU time per servo cycle, in arbitrary units.
#[derive(Clone, Copy, Debug, Deserialize, PartialEq, Eq, Hash)]
#[serde(deny_unknown_fields)]
pub struct Cpu {
    /// Units of CPU time in one servo cycle.
    pub cycle_units: u16,
    /// Servo update cost of one motor per cycle (UM p.236: about 1% at 2.25 kHz).
    pub servo_units_per_motor: u16,
    /// Move-planning cost added to every RTI task set.
    pub move_planning_units: u16,
}

/// The four DSP56300-family CPU options of a Turbo PMAC (SRM p.289), by their processor.
/// CPU type bit 1 (X:$000006 bit 21) is 1 for the DSP56311 and DSP56321; bit 0 (Y:$000006
/// bit 21) tells the two of each pair apart (56303 = 0,0; 56309 = 0,1; 56311 = 1,0;
/// 56321 = 1,1; `status.yaml`).
///
/// MODEL: a configuration that names no processor has the DSP56303 (Option 5Cx), whose bits
/// are both 0: what `???` reported before the bits came from the configuration. The manuals
/// give no default; a card has whichever option was ordered.
#[derive(Clone, Copy, Debug, Default, Deserialize, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Processor {
    /// Option 5Cx.
    #[default]
    #[serde(rename = "DSP56303")]
    Dsp56303,
    /// Option 5Dx.
    #[serde(rename = "DSP56309")]
    Dsp56309,
    /// Option 5Ex.
    #[serde(rename = "DSP56311")]
    Dsp56311,
    /// Option 5Fx.
    #[serde(rename = "DSP56321")]
    Dsp56321,
}

impl Processor {
    pub const ALL: [Processor; 4] =
        [Processor::Dsp56303, Processor::Dsp56309, Processor::Dsp56311, Processor::Dsp56321];

    /// CPU type bits 1 and 0 (X:$000006 bit 21, Y:$000006 bit 21), SRM p.289.
    pub fn type_bits(self) -> (bool, bool) {
        match self {
            Processor::Dsp56303 => (false, false),
            Processor::Dsp56309 => (false, true),
            Processor::Dsp56311 => (true, false),
            Processor::Dsp56321 => (true, true),
        }
    }

    /// The name as `check.yaml` writes it (`DSP56321`).
    pub fn name(self) -> &'static str {
        match self {
            Processor::Dsp56303 => "DSP56303",
            Processor::Dsp56309 => "DSP56309",
            Processor::Dsp56311 => "DSP56311",
            Processor::Dsp56321 => "DSP56321",
        }
    }

    /// A processor by its name (case-insensitive, with or without `DSP`), or why not.
    pub fn parse(text: &str) -> Result<Processor, String> {
        let t = text.trim().to_ascii_uppercase();
        let t = t.strip_prefix("DSP").unwrap_or(&t);
        Processor::ALL.into_iter().find(|p| &p.name()[3..] == t).ok_or_else(|| {
            format!("`{text}` is not a Turbo PMAC CPU option: the processor is one of DSP56303, DSP56309, DSP56311, DSP56321 (SRM p.289)")
        })
    }
}

#[derive(Clone, Copy, Debug, Deserialize, PartialEq, Eq, Hash, PartialOrd, Ord)]
#[serde(deny_unknown_fields)]
pub struct Load {
    pub motors: u8,
    /// PLC 0 cost per RTI, in CPU units.
    pub plc0_units: u16,
    /// CPU units one background cycle needs (housekeeping, one PLC scan, a command).
    pub background_units: u16,
}

#[derive(Clone, Copy, Debug, Deserialize, PartialEq, Eq, Hash, PartialOrd, Ord)]
#[serde(rename_all = "snake_case")]
pub enum ResetKind {
    /// INIT/ taken low, then high.
    Init,
    /// Power cycled off and on.
    Power,
}

#[derive(Clone, Copy, Debug, Deserialize, PartialEq, Eq, Hash, PartialOrd, Ord)]
#[serde(deny_unknown_fields)]
pub struct ResetEvent {
    pub kind: ResetKind,
    /// The reset-time DPRAM check finds missing or defective DPRAM.
    #[serde(default)]
    pub dpram_fault: bool,
    /// Reading saved data from flash at reset fails its checksum.
    #[serde(default)]
    pub flash_fault: bool,
    /// The bootstrap jumper is on: the card starts in bootstrap mode.
    #[serde(default)]
    pub bootstrap: bool,
}

#[derive(Clone, Copy, Debug, Deserialize, PartialEq, Eq, Hash, PartialOrd, Ord)]
#[serde(rename_all = "snake_case")]
pub enum ChecksumTarget {
    Firmware,
    UserProgram,
}

impl ChecksumTarget {
    /// The area the background checksum turns to after this one (UM p.217: it alternates
    /// between the firmware and the user program).
    pub fn other(self) -> ChecksumTarget {
        match self {
            ChecksumTarget::Firmware => ChecksumTarget::UserProgram,
            ChecksumTarget::UserProgram => ChecksumTarget::Firmware,
        }
    }
}

#[derive(Clone, Copy, Debug, Deserialize, PartialEq, Eq, Hash)]
#[serde(deny_unknown_fields)]
pub struct PassCycles {
    pub firmware: u8,
    pub user_program: u8,
}

impl Check {
    pub(crate) fn validate(
        &self,
        map: &SourceMap,
        profile_names: &[String],
        servo_clocks: &ServoClockRange,
    ) -> Result<(), SpecError> {
        for (name, c) in &self.configurations {
            let p = format!("configurations.{name}");
            if !servo_clocks.contains(c.servo_hz) {
                return Err(map.error(
                    &format!("{p}.servo_hz"),
                    format!("servo_hz {} is outside the servo clock range {}", c.servo_hz, servo_clocks.describe()),
                ));
            }
            if c.i41 > 15 {
                return Err(map.error(&format!("{p}.i41"), "I41 is 4 bits (0..=15)"));
            }
            if c.servo_counter_bits > 24 {
                return Err(map.error(&format!("{p}.servo_counter_bits"), "X:$000000 is 24 bits"));
            }
            if c.cpu.cycle_units == 0 {
                return Err(map.error(&format!("{p}.cpu.cycle_units"), "a servo cycle must have some CPU time"));
            }
            if c.loads.is_empty() {
                return Err(map.error(&format!("{p}.loads"), "at least one load (the power-up load) is needed"));
            }
            if c.supply_millivolts.is_empty() {
                return Err(map.error(&format!("{p}.supply_millivolts"), "at least one supply voltage is needed"));
            }
            let m = &c.motion;
            if !(1..=MOTORS_MAX as u8).contains(&m.motors) {
                return Err(map.error(&format!("{p}.motion.motors"), "the model has 1 to 8 motors"));
            }
            if !m.coordinate_systems.is_empty() && m.coordinate_systems.len() != usize::from(m.motors) {
                return Err(map.error(
                    &format!("{p}.motion.coordinate_systems"),
                    "one coordinate system per motor, or none (every motor in &1)",
                ));
            }
            if m.coordinate_systems.iter().any(|cs| !(1..=crate::vocab::command::COORDINATE_SYSTEM_MAX).contains(cs)) {
                return Err(map.error(&format!("{p}.motion.coordinate_systems"), "coordinate systems are &1..&16"));
            }
            if m.decel_cycles_max == 0 {
                return Err(map.error(&format!("{p}.motion.decel_cycles_max"), "a deceleration takes at least 1 cycle"));
            }
            if c.checksum_pass_cycles.firmware == 0 || c.checksum_pass_cycles.user_program == 0 {
                return Err(map.error(
                    &format!("{p}.checksum_pass_cycles"),
                    "a checksum pass takes at least one background cycle",
                ));
            }
        }
        for (i, run) in self.runs.iter().enumerate() {
            if !self.configurations.contains_key(&run.configuration) {
                return Err(map.error(
                    &format!("runs.{i}.configuration"),
                    format!("no configuration named `{}`", run.configuration),
                ));
            }
            if let ProfileSelection::Named(names) = &run.profiles {
                for (j, n) in names.iter().enumerate() {
                    if !profile_names.contains(n) {
                        return Err(map.error(
                            &format!("runs.{i}.profiles.{j}"),
                            format!("no profile named `{n}` in profiles.yaml"),
                        ));
                    }
                }
            }
        }
        if self.runs.is_empty() {
            return Err(map.error("runs", "at least one run is needed"));
        }
        Ok(())
    }
}
