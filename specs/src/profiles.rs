//! `profiles.yaml`: the readings where the sources disagree, and named profiles that fix one
//! option of every reading.
//!
//! The options of each reading are a closed set known to the model (an enum here); the YAML
//! documents each option with its citation and must document all of them. A profile must
//! choose an option for every reading (a missing one is an error, not a silent default), and
//! exactly one profile is the default, with its reason.

use crate::cite::Cites;
use crate::yaml::SourceMap;
use crate::SpecError;
use serde::Deserialize;
use std::collections::BTreeMap;

/// Counter reset value when I40 = 0.
#[derive(Clone, Copy, Debug, Deserialize, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum ResetValueWhenI40Zero {
    /// SRM p.57 (twice), UM p.240.
    #[serde(rename = "4095")]
    R4095,
    /// UM p.215, UM p.237, Brick hardware reference.
    #[serde(rename = "4096")]
    R4096,
}

impl ResetValueWhenI40Zero {
    pub const ALL: [Self; 2] = [Self::R4095, Self::R4096];
    pub fn cycles(self) -> u16 {
        match self {
            Self::R4095 => 4095,
            Self::R4096 => 4096,
        }
    }
}

/// When the watchdog strobe stops as the counter runs down.
#[derive(Clone, Copy, Debug, Deserialize, PartialEq, Eq, PartialOrd, Ord, Hash)]
#[serde(rename_all = "snake_case")]
pub enum StrobeStop {
    /// UM p.215: the servo interrupt decrements only while the counter is greater than zero,
    /// and that decrement is what toggles the strobe: strobing stops when it reaches 0.
    AtZero,
    /// SRM p.57: decremented every servo cycle; strobing stops once it becomes less than 0.
    BelowZero,
}

impl StrobeStop {
    pub const ALL: [Self; 2] = [Self::AtZero, Self::BelowZero];
}

/// Which task toggles the strobe bit.
#[derive(Clone, Copy, Debug, Deserialize, PartialEq, Eq, PartialOrd, Ord, Hash)]
#[serde(rename_all = "snake_case")]
pub enum Strober {
    /// UM p.215: the servo-interrupt routine, every servo cycle.
    ServoInterrupt,
    /// SRM p.57: the real-time interrupt task, every I8+1 servo cycles.
    RealTimeInterrupt,
}

impl Strober {
    pub const ALL: [Self; 2] = [Self::ServoInterrupt, Self::RealTimeInterrupt];
}

/// What bit 12 of X:$000006 reports.
#[derive(Clone, Copy, Debug, Deserialize, PartialEq, Eq, PartialOrd, Ord, Hash)]
#[serde(rename_all = "snake_case")]
pub enum Bit12Meaning {
    /// SRM p.289: 1 while evaluating the firmware checksum or after a firmware error.
    PromChecksumActive,
    /// Delta Tau suggested M-variable M83: 1 only after a firmware checksum error.
    FirmwareChecksumError,
}

impl Bit12Meaning {
    pub const ALL: [Self; 2] = [Self::PromChecksumActive, Self::FirmwareChecksumError];
}

/// How the encoder-loss PLC of UM p.215 clears a latched loss.
#[derive(Clone, Copy, Debug, Deserialize, PartialEq, Eq, PartialOrd, Ord, Hash)]
#[serde(rename_all = "snake_case")]
pub enum EncoderLossClear {
    /// The listing read literally: the clear branch needs the status already 0, so a latched
    /// loss is never cleared.
    Literal,
    /// The evident intent: clear a latched loss once the motor is closed-loop and the encoder OK.
    Intent,
}

impl EncoderLossClear {
    pub const ALL: [Self; 2] = [Self::Literal, Self::Intent];
}

/// The lowest strobe frequency the hardware timer accepts.
#[derive(Clone, Copy, Debug, Deserialize, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum StrobeHzMin {
    /// Turbo PMAC User Manual p.215.
    #[serde(rename = "25")]
    Hz25,
    /// The older, non-Turbo PMAC manual (an RTI rate of about 50 Hz).
    #[serde(rename = "50")]
    Hz50,
}

impl StrobeHzMin {
    pub const ALL: [Self; 2] = [Self::Hz25, Self::Hz50];
    pub fn hz(self) -> u32 {
        match self {
            Self::Hz25 => 25,
            Self::Hz50 => 50,
        }
    }
}

/// How the hardware timer's frequency detector counts the strobe against its minimum frequency
/// f (UM p.215: "a square wave ... of a frequency greater than approximately 25 Hz"; the card
/// must "set and clear this bit repeatedly at 25 Hz or greater"). The manual does not describe
/// the circuit: MODEL, both readings of the two sentences.
#[derive(Clone, Copy, Debug, Deserialize, PartialEq, Eq, PartialOrd, Ord, Hash)]
#[serde(rename_all = "snake_case")]
pub enum StrobeDetector {
    /// Every edge restarts the detector: a square wave at f toggles every 1/(2 f) s, so more
    /// than floor(servo_hz / (2 f)) servo cycles without an edge trips (45 at 2.25 kHz and
    /// 25 Hz).
    HalfPeriod,
    /// The detector needs one full set-and-clear per period of f: more than
    /// floor(servo_hz / f) servo cycles without one trips (90 at 2.25 kHz and 25 Hz).
    FullPeriod,
}

impl StrobeDetector {
    pub const ALL: [Self; 2] = [Self::HalfPeriod, Self::FullPeriod];

    /// Strobe edges per period of the minimum frequency that the detector waits for before
    /// it trips: one (half a period) or two (a set and a clear, a whole period).
    pub fn edges_per_period(self) -> u32 {
        match self {
            Self::HalfPeriod => 1,
            Self::FullPeriod => 2,
        }
    }
}

/// Whether bit 9 (RTI warning) stays set once an RTI task overran.
#[derive(Clone, Copy, Debug, Deserialize, PartialEq, Eq, PartialOrd, Ord, Hash)]
#[serde(rename_all = "snake_case")]
pub enum RtiWarningLatch {
    /// Set by an overrun, cleared at the next RTI whose previous tasks had completed.
    Level,
    /// Set by an overrun, cleared only by reset, like bit 22.
    Sticky,
}

impl RtiWarningLatch {
    pub const ALL: [Self; 2] = [Self::Level, Self::Sticky];
}

/// What an assignment of a value outside an I-variable's range does (I8, I40, I41: the ranges
/// the model knows, `variables.yaml`).
#[derive(Clone, Copy, Debug, Deserialize, PartialEq, Eq, PartialOrd, Ord, Hash)]
#[serde(rename_all = "snake_case")]
pub enum OutOfRangeAssignment {
    /// Refused with ERR003, the variable unchanged (MODEL: the ranges of SRM p.42, p.57 read as
    /// limits; UM p.237's ERR003 "data error").
    Error,
    /// No error: the value is rolled over into the range by modulo arithmetic, `I3=5` giving 1
    /// (UM p.243, "Limited Range").
    Modulo,
}

impl OutOfRangeAssignment {
    pub const ALL: [Self; 2] = [Self::Error, Self::Modulo];

    /// The value an assignment of `v` to a variable of range `lo..=hi` stores, or None when
    /// the card refuses it (ERR003).
    pub fn stored(self, v: i64, (lo, hi): (i64, i64)) -> Option<i64> {
        if (lo..=hi).contains(&v) {
            return Some(v);
        }
        match self {
            Self::Error => None,
            // UM p.243: "rolled over to within the range by modulo arithmetic (truncation)",
            // (5 modulo 4) = 1 for I3's 0 to 3; a negative value rolls over the same way (the
            // low bits, as truncation of a two's-complement word keeps them).
            Self::Modulo => Some(lo + (v - lo).rem_euclid(hi - lo + 1)),
        }
    }
}

/// Documentation of one option of a reading.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct OptionDoc {
    pub statement: String,
    pub cite: Cites,
}

/// A reading: the question, and every option documented.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
#[serde(bound(deserialize = "O: Deserialize<'de> + Ord"))]
pub struct Reading<O: Ord> {
    pub question: String,
    pub options: BTreeMap<O, OptionDoc>,
}

#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Readings {
    pub reset_value_when_i40_zero: Reading<ResetValueWhenI40Zero>,
    pub strobe_stop: Reading<StrobeStop>,
    pub strober: Reading<Strober>,
    pub bit12_meaning: Reading<Bit12Meaning>,
    pub encoder_loss_clear: Reading<EncoderLossClear>,
    pub strobe_hz_min: Reading<StrobeHzMin>,
    pub rti_warning_latch: Reading<RtiWarningLatch>,
    /// `error` in every profile but `um-243-modulo` (UM p.243); the configuration reads it
    /// from the profile ([`crate::config::ModelConfig::out_of_range`]).
    pub out_of_range_assignment: Reading<OutOfRangeAssignment>,
    /// Half a period of the strobe minimum in every profile but `um-215-full-period`; only
    /// the hardware delay the configuration derives reads it, through the strobe's edge rate
    /// ([`crate::config::strobe_edge_hz`]).
    pub strobe_detector: Reading<StrobeDetector>,
}

/// The option a profile chose for every reading. Every field is required.
#[derive(Clone, Copy, Debug, Deserialize, PartialEq, Eq, Hash, PartialOrd, Ord)]
#[serde(deny_unknown_fields)]
pub struct Choices {
    pub reset_value_when_i40_zero: ResetValueWhenI40Zero,
    pub strobe_stop: StrobeStop,
    pub strober: Strober,
    pub bit12_meaning: Bit12Meaning,
    pub encoder_loss_clear: EncoderLossClear,
    pub strobe_hz_min: StrobeHzMin,
    pub rti_warning_latch: RtiWarningLatch,
    pub out_of_range_assignment: OutOfRangeAssignment,
    pub strobe_detector: StrobeDetector,
}

#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ProfileDef {
    #[serde(default)]
    pub default: bool,
    pub summary: String,
    /// Why this profile is the default; required on the default profile.
    #[serde(default)]
    pub reason: Option<String>,
    pub readings: Choices,
}

#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Profiles {
    pub readings: Readings,
    pub profiles: BTreeMap<String, ProfileDef>,
}

/// A named profile as the model uses it.
#[derive(Clone, Debug, PartialEq, Eq, Hash)]
pub struct Profile {
    pub name: String,
    pub choices: Choices,
}

fn all_documented<O: Ord + Copy + std::fmt::Debug>(
    map: &SourceMap,
    name: &str,
    reading: &Reading<O>,
    all: &[O],
) -> Result<(), SpecError> {
    for o in all {
        if !reading.options.contains_key(o) {
            return Err(map.error(
                &format!("readings.{name}.options"),
                format!("reading `{name}` does not document option {o:?}"),
            ));
        }
    }
    Ok(())
}

impl Profiles {
    pub(crate) fn validate(&self, map: &SourceMap) -> Result<(), SpecError> {
        let r = &self.readings;
        all_documented(map, "reset_value_when_i40_zero", &r.reset_value_when_i40_zero, &ResetValueWhenI40Zero::ALL)?;
        all_documented(map, "strobe_stop", &r.strobe_stop, &StrobeStop::ALL)?;
        all_documented(map, "strober", &r.strober, &Strober::ALL)?;
        all_documented(map, "bit12_meaning", &r.bit12_meaning, &Bit12Meaning::ALL)?;
        all_documented(map, "encoder_loss_clear", &r.encoder_loss_clear, &EncoderLossClear::ALL)?;
        all_documented(map, "strobe_hz_min", &r.strobe_hz_min, &StrobeHzMin::ALL)?;
        all_documented(map, "rti_warning_latch", &r.rti_warning_latch, &RtiWarningLatch::ALL)?;
        all_documented(map, "out_of_range_assignment", &r.out_of_range_assignment, &OutOfRangeAssignment::ALL)?;
        all_documented(map, "strobe_detector", &r.strobe_detector, &StrobeDetector::ALL)?;
        if self.profiles.is_empty() {
            return Err(map.error("profiles", "at least one profile is needed"));
        }
        let mut default_paths: Vec<String> =
            self.profiles.iter().filter(|(_, p)| p.default).map(|(n, _)| format!("profiles.{n}")).collect();
        map.sort_by_position(&mut default_paths);
        let defaults: Vec<&str> = default_paths.iter().map(|p| &p["profiles.".len()..]).collect();
        match defaults.as_slice() {
            [] => return Err(map.error("profiles", "no profile is marked `default: true`")),
            [one] => {
                if self.profiles[*one as &str].reason.as_deref().is_none_or(|r| r.trim().is_empty()) {
                    return Err(
                        map.error(&format!("profiles.{one}"), format!("the default profile `{one}` needs a `reason`"))
                    );
                }
            }
            [_, second, ..] => {
                return Err(map.error(&format!("profiles.{second}.default"), "more than one profile is the default"))
            }
        }
        let mut seen: BTreeMap<Choices, &String> = BTreeMap::new();
        for (name, p) in &self.profiles {
            if !crate::common::is_identifier(&name.replace('-', "_")) {
                return Err(map.error(
                    &format!("profiles.{name}"),
                    format!("profile name `{name}` must be lower-case words joined by `-`"),
                ));
            }
            if let Some(other) = seen.insert(p.readings, name) {
                return Err(map.error(
                    &format!("profiles.{name}.readings"),
                    format!("profile `{name}` makes the same choices as `{other}`"),
                ));
            }
        }
        Ok(())
    }

    pub fn default_profile(&self) -> Profile {
        let (name, p) = self.profiles.iter().find(|(_, p)| p.default).expect("validated: one default");
        Profile { name: name.clone(), choices: p.readings }
    }

    pub fn get(&self, name: &str) -> Option<Profile> {
        self.profiles.get(name).map(|p| Profile { name: name.to_string(), choices: p.readings })
    }

    /// Every profile, the default first.
    pub fn all(&self) -> Vec<Profile> {
        let d = self.default_profile();
        let mut v = vec![d.clone()];
        v.extend(
            self.profiles
                .iter()
                .filter(|(n, _)| **n != d.name)
                .map(|(n, p)| Profile { name: n.clone(), choices: p.readings }),
        );
        v
    }

    /// The profiles a selection names (`all`: every profile, the default first), or the first
    /// name that is not a profile, with its index in the list.
    pub fn select(&self, selection: &crate::check::ProfileSelection) -> Result<Vec<Profile>, (usize, String)> {
        match selection {
            crate::check::ProfileSelection::Keyword(_) => Ok(self.all()),
            crate::check::ProfileSelection::Named(names) => {
                names.iter().enumerate().map(|(i, n)| self.get(n).ok_or_else(|| (i, n.clone()))).collect()
            }
        }
    }

    /// The profile names, for error messages.
    pub fn names(&self) -> String {
        self.profiles.keys().cloned().collect::<Vec<_>>().join(", ")
    }
}
