//! `variables.yaml`: the I-variables of the safety core, the I41 lockout table and the
//! memory registers the watchdog uses.

use crate::cite::Cites;
use crate::common::{unique_rule_ids, Range, Rule};
use crate::yaml::SourceMap;
use crate::SpecError;
use serde::Deserialize;
use std::collections::BTreeMap;

#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Variables {
    pub i_variables: IVariables,
    /// What the lowest valid and highest valid I-variable numbers are.
    pub i_variable_numbers: Range,
    pub lockout: Vec<LockoutRange>,
    /// What I41 does and does not do, beyond the table.
    pub lockout_rules: Vec<Rule>,
    /// Registers by address, e.g. `Y:$000025`.
    pub registers: BTreeMap<String, Register>,
}

#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct IVariables {
    #[serde(rename = "I8")]
    pub i8: IVariable,
    #[serde(rename = "I40")]
    pub i40: IVariable,
    #[serde(rename = "I41")]
    pub i41: IVariable,
}

#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct IVariable {
    pub title: String,
    pub range: Range,
    pub units: String,
    pub default: i64,
    pub meaning: String,
    /// Values with a special meaning, e.g. I40 = 0.
    #[serde(default)]
    pub special_values: BTreeMap<i64, String>,
    pub cite: Cites,
}

#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LockoutRange {
    /// Bit number of I41 (0..=3).
    pub bit: u8,
    /// `1 << bit`, written out as the manual's table does.
    pub value: u8,
    pub first: u16,
    pub last: u16,
    pub function: String,
    pub cite: Cites,
}

#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Register {
    pub name: String,
    pub width_bits: u8,
    pub signed: bool,
    pub meaning: String,
    pub cite: Cites,
}

/// The widest range the model and the impl can represent for each I-variable. A spec may
/// narrow these but not widen them: the counter reset value is 16 bits (SRM p.57 gives
/// 0..65,535), I8 is 8 bits, I41 is 4 bits.
pub const REPRESENTABLE: [(&str, i64, i64); 3] = [("I8", 0, 255), ("I40", 0, 65_535), ("I41", 0, 15)];

impl Variables {
    pub(crate) fn validate(&self, map: &SourceMap) -> Result<(), SpecError> {
        let iv = &self.i_variables;
        for ((name, lo, hi), var) in REPRESENTABLE.iter().zip([&iv.i8, &iv.i40, &iv.i41]) {
            let path = format!("i_variables.{name}");
            if var.range.min > var.range.max {
                return Err(map.error(
                    &format!("{path}.range"),
                    format!("{name}: range min {} is above max {}", var.range.min, var.range.max),
                ));
            }
            if var.range.min < *lo || var.range.max > *hi {
                return Err(map.error(
                    &format!("{path}.range"),
                    format!(
                        "{name}: range {}..={} is outside what {name} can hold ({lo}..={hi})",
                        var.range.min, var.range.max
                    ),
                ));
            }
            if !var.range.contains(var.default) {
                return Err(map.error(
                    &format!("{path}.default"),
                    format!("{name}: default {} is outside its range", var.default),
                ));
            }
            for v in var.special_values.keys() {
                if !var.range.contains(*v) {
                    return Err(map.error(
                        &format!("{path}.special_values.{v}"),
                        format!("{name}: special value {v} is outside its range"),
                    ));
                }
            }
        }
        let numbers = self.i_variable_numbers;
        if numbers.min != 0 || numbers.max < 8191 || numbers.max > 65_535 {
            return Err(map.error("i_variable_numbers", "I-variable numbers must start at 0 and reach at least I8191"));
        }
        let mut bits_seen = [false; 4];
        for (i, r) in self.lockout.iter().enumerate() {
            let path = format!("lockout.{i}");
            if r.bit > 3 {
                return Err(map.error(&path, format!("I41 has 4 bits; bit {} does not exist", r.bit)));
            }
            if std::mem::replace(&mut bits_seen[r.bit as usize], true) {
                return Err(map.error(&path, format!("I41 bit {} is listed twice", r.bit)));
            }
            if r.value != 1 << r.bit {
                return Err(map.error(&path, format!("bit {} has value {}, not {}", r.bit, 1u8 << r.bit, r.value)));
            }
            if r.first > r.last || i64::from(r.last) > numbers.max {
                return Err(map.error(&path, format!("I{}..I{} is not a valid I-variable range", r.first, r.last)));
            }
            if (r.first..=r.last).contains(&41) {
                return Err(map.error(&path, "I41 must not lock itself out (SRM p.57 lists no such range)"));
            }
            for (j, other) in self.lockout[..i].iter().enumerate() {
                if r.first <= other.last && other.first <= r.last {
                    return Err(map.error(&path, format!("range I{}..I{} overlaps lockout.{j}", r.first, r.last)));
                }
            }
        }
        if bits_seen.iter().any(|b| !b) {
            return Err(map.error("lockout", "the lockout table must list all four bits of I41"));
        }
        unique_rule_ids(map, "lockout_rules", &self.lockout_rules)?;
        for (addr, reg) in &self.registers {
            if parse_address(addr).is_none() {
                return Err(
                    map.error(&format!("registers.{addr}"), format!("`{addr}` is not an address like `Y:$000025`"))
                );
            }
            if reg.width_bits == 0 || reg.width_bits > 24 {
                return Err(
                    map.error(&format!("registers.{addr}.width_bits"), "a Turbo PMAC register is 1..=24 bits wide")
                );
            }
        }
        Ok(())
    }

    /// The I41 bit that locks I-variable `number`, if any.
    pub fn lockout_bit(&self, number: u16) -> Option<u8> {
        self.lockout.iter().find(|r| (r.first..=r.last).contains(&number)).map(|r| r.bit)
    }
}

/// Parses `X:$000025` / `Y:$25` into (space, address).
pub fn parse_address(text: &str) -> Option<(char, u32)> {
    let (space, hex) = text.split_once(":$")?;
    let space = match space {
        "X" => 'X',
        "Y" => 'Y',
        _ => return None,
    };
    if hex.is_empty() || hex.len() > 6 {
        return None;
    }
    u32::from_str_radix(hex, 16).ok().map(|a| (space, a))
}
