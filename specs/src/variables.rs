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
    /// The I-variables host programs read, with the values a card reports.
    #[serde(default)]
    pub host_i_variables: Vec<HostIVariable>,
    /// The M-variables host programs read whose value the card defines.
    #[serde(default)]
    pub host_m_variables: Vec<HostMVariable>,
    /// Where I-variable n's storage lies, for M-variable assignments and direct memory writes
    /// (SRM p.57).
    pub i_variable_storage: IVariableStorage,
}

/// Where the I-variables are stored in data memory: I-variable n at `base + n`, 48 bits across
/// X and Y (`D:`).
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct IVariableStorage {
    /// `D:$002000`: the address of I0.
    pub base: String,
    pub meaning: String,
    pub cite: Cites,
}

/// The highest address of a Turbo PMAC's data memory (SRM p.170: 19-bit addresses).
pub const DATA_ADDRESS_MAX: u32 = 0x07_FFFF;

impl IVariableStorage {
    /// The address of I0, when `base` is `D:$hex` and all 8192 I-variables fit below
    /// [`DATA_ADDRESS_MAX`].
    pub fn base_address(&self) -> Option<u32> {
        let hex = self.base.strip_prefix("D:$")?;
        if hex.is_empty() || hex.len() > 6 || !hex.bytes().all(|c| c.is_ascii_hexdigit()) {
            return None;
        }
        u32::from_str_radix(hex, 16).ok().filter(|a| a + 8191 <= DATA_ADDRESS_MAX)
    }
}

/// An I-variable a host program reads: its default and how the card prints it.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct HostIVariable {
    /// `I10`, or `Ixx24` for one per motor.
    pub number: String,
    /// The value, a fraction where the unit asks for one (Ixx19 = 0.15625 counts/ms²).
    pub default: f64,
    /// An address I-variable, reported as `$...` when I9 is 2 or 3 (SRM p.42).
    pub hex: bool,
    pub title: String,
    pub meaning: String,
    pub cite: Cites,
}

/// An M-variable with a value the card defines (a documented constant).
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct HostMVariable {
    /// `M70`, or `Mxx90` for one per motor.
    pub number: String,
    pub value: i64,
    pub title: String,
    pub meaning: String,
    pub cite: Cites,
}

/// Motors 1..=32 of a Turbo PMAC, which `xx` in `Ixx24` and `Mxx90` runs over.
pub const MOTOR_NUMBERS: std::ops::RangeInclusive<u16> = 1..=32;

/// Coordinate systems 1..=16 of a Turbo PMAC, which `sx` in `Isx87` runs over.
pub const COORDINATE_SYSTEM_NUMBERS: std::ops::RangeInclusive<u16> = 1..=16;

/// The variable numbers `I10`, `Ixx24` or `Isx87` (`letter` `I`) stands for: one number, one
/// per motor (`xx` = 01..32, so I124 ... I3224), or one per coordinate system (`sx` = 51..66,
/// so I5187 ... I6687, SRM p.188). `None` when the text is none of these or a number is beyond
/// 8191.
pub fn variable_numbers(text: &str, letter: char) -> Option<Vec<u16>> {
    let rest = text.strip_prefix(letter)?;
    let numbers: Vec<u16> = if let Some(offset) = rest.strip_prefix("sx").filter(|_| letter == 'I') {
        if offset.len() != 2 || !offset.bytes().all(|b| b.is_ascii_digit()) {
            return None;
        }
        let offset: u16 = offset.parse().ok()?;
        COORDINATE_SYSTEM_NUMBERS.map(|s| 5000 + s * 100 + offset).collect()
    } else if let Some(offset) = rest.strip_prefix("xx") {
        if offset.len() != 2 || !offset.bytes().all(|b| b.is_ascii_digit()) {
            return None;
        }
        let offset: u16 = offset.parse().ok()?;
        MOTOR_NUMBERS.map(|m| m * 100 + offset).collect()
    } else {
        if rest.is_empty() || rest.len() > 4 || !rest.bytes().all(|b| b.is_ascii_digit()) {
            return None;
        }
        vec![rest.parse().ok()?]
    };
    numbers.iter().all(|n| *n <= 8191).then_some(numbers)
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
        for (i, v) in self.host_i_variables.iter().enumerate() {
            if variable_numbers(&v.number, 'I').is_none() {
                return Err(map.error(
                    &format!("host_i_variables.{i}.number"),
                    format!("`{}` is none of `I<n>`, `Ixx<nn>`, `Isx<nn>` within I0..I8191", v.number),
                ));
            }
        }
        for (i, v) in self.host_m_variables.iter().enumerate() {
            if variable_numbers(&v.number, 'M').is_none() {
                return Err(map.error(
                    &format!("host_m_variables.{i}.number"),
                    format!("`{}` is neither `M<n>` nor `Mxx<nn>` within M0..M8191", v.number),
                ));
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
        let Some(base) = self.i_variable_storage.base_address() else {
            return Err(map.error(
                "i_variable_storage.base",
                format!(
                    "`{}` is not an address like `D:$002000` with room for I0..I8191 below $7FFFF",
                    self.i_variable_storage.base
                ),
            ));
        };
        for addr in self.registers.keys() {
            if let Some((_, a)) = parse_address(addr) {
                if (base..=base + 8191).contains(&a) {
                    return Err(map.error(
                        "i_variable_storage.base",
                        format!("I-variable storage D:${base:06X}.. overlaps the register {addr}"),
                    ));
                }
            }
        }
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

#[cfg(test)]
mod host_tests {
    use super::*;

    #[test]
    fn one_variable_or_one_per_motor() {
        assert_eq!(variable_numbers("I10", 'I'), Some(vec![10]));
        let per_motor = variable_numbers("Ixx24", 'I').unwrap();
        assert_eq!((per_motor.len(), per_motor[0], per_motor[31]), (32, 124, 3224));
        assert_eq!(variable_numbers("Mxx90", 'M').unwrap()[7], 890);
        let per_cs = variable_numbers("Isx87", 'I').unwrap();
        assert_eq!((per_cs.len(), per_cs[0], per_cs[15]), (16, 5187, 6687));
        assert_eq!(variable_numbers("Msx87", 'M'), None);
        for bad in ["I", "I8192", "Ix24", "Ixx2", "M10", "I1a"] {
            assert_eq!(variable_numbers(bad, 'I'), None, "{bad}");
        }
    }

    #[test]
    fn the_embedded_host_variables_are_read_and_i10_is_the_srm_default() {
        let spec = crate::Spec::embedded().unwrap();
        let v = &spec.variables;
        let i10 = v.host_i_variables.iter().find(|h| h.number == "I10").unwrap();
        assert_eq!(i10.default, 3_713_707.0, "SRM p.42-43");
        assert!(v.host_i_variables.iter().filter(|h| h.hex).any(|h| h.number == "I20"));
        assert!(v.host_m_variables.iter().any(|h| h.number == "Mxx90"));
    }
}
