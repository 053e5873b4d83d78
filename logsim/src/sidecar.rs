//! NAME.yaml: what the generator did for NAME.log, and what a correct judge must say.

use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;

use crate::card::{CardSpec, Readings};

/// What a family's scenario did that the sidecar reports: the trip's cause and time, notes,
/// whether I40 was written, the poll style. (Defined here, beside the sidecar it fills, so that
/// the families import the sidecar and not the other way round.)
pub struct Facts {
    pub cause: Option<&'static str>,
    pub trip_time_s: Option<f64>,
    pub notes: Vec<String>,
    pub i40_written: bool,
    pub poll: &'static str,
}

#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct Sidecar {
    pub name: String,
    pub family: String,
    pub seed: u64,
    /// `explained` (a correct card wrote it) or `impossible` (one observation no correct card
    /// can show, at `impossible_line`).
    pub expect: String,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub impossible_line: Option<usize>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub impossible_kind: Option<String>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub impossible_why: Option<String>,
    /// For a card that tripped: `starvation` or `supply_dip` (UM p.215).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub cause: Option<String>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub first_silent_line: Option<usize>,
    /// The option of each reading the card followed (specs/profiles.yaml names them).
    pub readings: BTreeMap<String, String>,
    pub card: CardFacts,
    pub stamps: String,
    /// What each poll reads: `full` (X:$0, ???, Y:$25, X:$25), `no-y25`, `status` (X:$0, ???).
    pub poll: String,
    pub commands_per_line: String,
    pub host_timeout_s: f64,
    pub exchanges: usize,
    #[serde(default)]
    pub notes: Vec<String>,
}

#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct CardFacts {
    pub i10: u32,
    pub servo_hz: f64,
    pub cpu: String,
    pub i8: i64,
    pub i40: i64,
    pub strobe_hz_min: f64,
    pub hardware_delay_cycles: u32,
    pub supply_min_mv: u32,
    pub firmware_pass_background_cycles: u32,
    pub user_pass_background_cycles: u32,
    pub servo_units: u32,
    pub background_units: u32,
}

pub const CPUS: [&str; 4] = ["DSP56303", "DSP56309", "DSP56311", "DSP56321"];

impl Sidecar {
    #[allow(clippy::too_many_arguments)]
    pub fn new(
        name: &str,
        family: &str,
        seed: u64,
        readings: &Readings,
        spec: &CardSpec,
        stamps: &str,
        many_per_line: bool,
        timeout_s: f64,
        exchanges: usize,
        facts: &Facts,
        first_silent_line: Option<usize>,
    ) -> Sidecar {
        Sidecar {
            name: name.to_string(),
            family: family.to_string(),
            seed,
            expect: "explained".into(),
            impossible_line: None,
            impossible_kind: None,
            impossible_why: None,
            cause: facts.cause.map(str::to_string),
            first_silent_line,
            readings: readings.names().into_iter().map(|(k, v)| (k.to_string(), v.to_string())).collect(),
            card: CardFacts {
                i10: spec.i10,
                servo_hz: (spec.servo_hz * 1000.0).round() / 1000.0,
                cpu: CPUS[usize::from(spec.cpu)].to_string(),
                i8: spec.saved[&8],
                i40: spec.saved[&40],
                strobe_hz_min: (spec.strobe_hz_min * 100.0).round() / 100.0,
                hardware_delay_cycles: spec.delay_cycles(),
                supply_min_mv: spec.supply_min_mv,
                firmware_pass_background_cycles: spec.firmware_pass_cycles,
                user_pass_background_cycles: spec.user_pass_cycles,
                servo_units: spec.servo_units,
                background_units: spec.background_units,
            },
            stamps: stamps.to_string(),
            poll: facts.poll.to_string(),
            commands_per_line: if many_per_line { "many" } else { "one" }.to_string(),
            host_timeout_s: (timeout_s * 1000.0).round() / 1000.0,
            exchanges,
            notes: facts.notes.clone(),
        }
    }

    pub fn to_yaml(&self) -> String {
        serde_yaml::to_string(self).expect("a sidecar serializes")
    }

    pub fn from_yaml(text: &str) -> Result<Sidecar, String> {
        let side: Sidecar = serde_yaml::from_str(text).map_err(|e| e.to_string())?;
        match side.expect.as_str() {
            "explained" if side.impossible_line.is_none() => Ok(side),
            "impossible" if side.impossible_line.is_some() => Ok(side),
            other => Err(format!(
                "expect: {other} with impossible_line {:?}: want `explained` without a line or `impossible` with one",
                side.impossible_line
            )),
        }
    }
}
