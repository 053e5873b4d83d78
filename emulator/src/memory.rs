//! The card's user variables beside the safety core's: the P-, Q- and M-variables, the
//! feedrate override of each coordinate system, which I-variables print in hex, and the
//! values a card reports for the variables host programs read (`specs/variables.yaml`,
//! `host_i_variables` and `host_m_variables`, each cited there).
//!
//! Memory is bounded: 8192 of each kind of variable (UM p.243), held in fixed tables.

use pmacwd_specs::grammar::{VarKind, VARIABLE_MAX};
use pmacwd_specs::variables::{variable_numbers, Variables};

const COUNT: usize = VARIABLE_MAX as usize + 1;

/// The values and formats the spec gives for host-read variables, resolved to numbers.
#[derive(Clone, Debug, Default)]
pub struct HostDefaults {
    /// I-variable defaults, applied at power-on before the saved values.
    pub i_defaults: Vec<(u16, f64)>,
    /// Address I-variables, printed `$...` when I9 bit 1 is set (SRM p.42).
    pub i_hex: Vec<u16>,
    /// M-variables with a defined value (documented constants).
    pub m_constants: Vec<(u16, i64)>,
    /// The address of I0's storage for M-variables and memory writes (`variables.yaml`,
    /// `i_variable_storage`); `None` without a spec: then no address reaches an I-variable.
    pub i_storage_base: Option<u32>,
}

impl HostDefaults {
    /// From a spec's `variables.yaml` (checked when it was loaded: every number is valid).
    pub fn from_spec(v: &Variables) -> HostDefaults {
        let mut d = HostDefaults::default();
        for h in &v.host_i_variables {
            for n in variable_numbers(&h.number, 'I').unwrap_or_default() {
                d.i_defaults.push((n, h.default));
                if h.hex {
                    d.i_hex.push(n);
                }
            }
        }
        d.i_storage_base = v.i_variable_storage.base_address();
        for h in &v.host_m_variables {
            for n in variable_numbers(&h.number, 'M').unwrap_or_default() {
                d.m_constants.push((n, h.value));
            }
        }
        d
    }

    /// The embedded spec's.
    pub fn embedded() -> HostDefaults {
        match pmacwd_specs::Spec::embedded() {
            Ok(spec) => HostDefaults::from_spec(&spec.variables),
            Err(_) => HostDefaults::default(),
        }
    }
}

/// The feedrate override a coordinate system powers up with, in percent (PMAC-SRM p.29: "The
/// default % value is 100").
pub const FEED_DEFAULT: f64 = 100.0;

/// The user variables and formats of one card.
pub struct Memory {
    p: Box<[f64]>,
    q: Box<[f64]>,
    m: Box<[f64]>,
    /// M-variables whose value the card defines; a write to one changes nothing (MODEL: they
    /// stand for registers the emulator does not model).
    m_constant: Box<[Option<i64>]>,
    i_hex: Box<[bool]>,
    feed: [f64; 16],
    /// Axis definitions by (C.S., motor): SRM `#{constant}->{axis definition}`. MODEL: kept
    /// across resets, as a card keeps them in its saved set after SAVE.
    axes: std::collections::BTreeMap<(u8, u8), String>,
}

impl Memory {
    pub fn new(d: &HostDefaults) -> Memory {
        let mut m_constant = vec![None; COUNT].into_boxed_slice();
        for &(n, v) in &d.m_constants {
            m_constant[usize::from(n)] = Some(v);
        }
        let mut i_hex = vec![false; COUNT].into_boxed_slice();
        for &n in &d.i_hex {
            i_hex[usize::from(n)] = true;
        }
        Memory {
            p: vec![0.0; COUNT].into_boxed_slice(),
            q: vec![0.0; COUNT].into_boxed_slice(),
            m: vec![0.0; COUNT].into_boxed_slice(),
            m_constant,
            i_hex,
            feed: [FEED_DEFAULT; 16],
            axes: Default::default(),
        }
    }

    /// M-variable `n`'s card-defined value (`variables.yaml`, `host_m_variables`), if any.
    pub fn constant(&self, n: u16) -> Option<i64> {
        self.m_constant.get(usize::from(n)).copied().flatten()
    }

    pub fn define_axis(&mut self, cs: u8, motor: u8, definition: String) {
        // A motor belongs to one C.S. at a time: a new definition moves it.
        self.axes.retain(|(_, m), _| *m != motor);
        self.axes.insert((cs, motor), definition);
    }

    pub fn axis(&self, cs: u8, motor: u8) -> Option<&str> {
        self.axes.get(&(cs, motor)).map(String::as_str)
    }

    /// `UNDEFINE` of one C.S., `UNDEFINE ALL` of every one.
    pub fn undefine(&mut self, cs: Option<u8>) {
        match cs {
            Some(cs) => self.axes.retain(|(c, _), _| *c != cs),
            None => self.axes.clear(),
        }
    }

    /// A P-, Q- or M-variable (not I: those are the core's store). Q-variables are one table
    /// for all coordinate systems (MODEL: the card gives each C.S. its own block by a
    /// setting the emulator does not model).
    pub fn read(&self, kind: VarKind, n: u16) -> f64 {
        let i = usize::from(n.min(VARIABLE_MAX));
        match kind {
            VarKind::P => self.p[i],
            VarKind::Q => self.q[i],
            VarKind::M => self.m_constant[i].map_or(self.m[i], |v| v as f64),
            VarKind::I => 0.0,
        }
    }

    pub fn write(&mut self, kind: VarKind, n: u16, v: f64) {
        let i = usize::from(n.min(VARIABLE_MAX));
        match kind {
            VarKind::P => self.p[i] = v,
            VarKind::Q => self.q[i] = v,
            VarKind::M => self.m[i] = v,
            VarKind::I => {}
        }
    }

    pub fn feed(&self, cs: u8) -> f64 {
        self.feed[usize::from(cs.clamp(1, 16) - 1)]
    }

    pub fn set_feed(&mut self, cs: u8, percent: f64) {
        self.feed[usize::from(cs.clamp(1, 16) - 1)] = percent;
    }

    /// What a reset clears: P-, Q- and undefined M-variables hold what the program put there
    /// and are not saved (MODEL: the card can save P and Q with I14; the emulator does not),
    /// and the feedrate overrides go back to 100%.
    pub fn reset(&mut self) {
        self.p.fill(0.0);
        self.q.fill(0.0);
        self.m.fill(0.0);
        self.feed = [FEED_DEFAULT; 16];
    }

    /// How the card prints I-variable `n` holding `v` under `i9` (SRM p.42: bit 1, address
    /// I-variables in hex; bit 0, the whole statement `I10=...`).
    pub fn format_i(&self, n: u16, v: i64, i9: i64) -> String {
        let hex = self.i_hex[usize::from(n.min(VARIABLE_MAX))] && i9 & 2 != 0;
        let value = if hex { format!("${:X}", v & 0xFFFF_FFFF_FFFF) } else { v.to_string() };
        self.format_i_value(n, &value, i9)
    }

    /// `value` as I`n`'s answer under I9 bit 0 (the whole statement).
    pub fn format_i_value(&self, n: u16, value: &str, i9: i64) -> String {
        if i9 & 1 != 0 {
            format!("I{n}={value}")
        } else {
            value.to_string()
        }
    }
}

/// A value as the card prints a P-, Q- or M-variable or a position: whole numbers without a
/// point, others with the digits they need (`-250.5`).
pub fn format_value(v: f64) -> String {
    if v.is_finite() && v == v.trunc() && v.abs() < 1e15 {
        format!("{}", v as i64)
    } else {
        format!("{v}")
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn memory() -> Memory {
        Memory::new(&HostDefaults::embedded())
    }

    #[test]
    fn address_i_variables_print_in_hex_only_when_i9_says_so() {
        // dls-pmaclib counts MACRO ICs by comparing I20..I23 with `$0`.
        let m = memory();
        assert_eq!(m.format_i(20, 0, 2), "$0");
        assert_eq!(m.format_i(124, 0x20001, 2), "$20001", "a hex write reads back in hex");
        assert_eq!(m.format_i(124, 0x20001, 0), "131073");
        assert_eq!(m.format_i(10, 3_713_707, 2), "3713707", "I10 is not an address");
        assert_eq!(m.format_i(20, 0, 3), "I20=$0", "bit 0: the whole statement");
    }

    #[test]
    fn defined_m_variables_are_constants_and_the_rest_hold_what_was_written() {
        let mut m = memory();
        assert_eq!(m.read(VarKind::M, 70), 13279.0);
        m.write(VarKind::M, 190, 5.0);
        assert_eq!(m.read(VarKind::M, 190), 0.0, "M190 is the amplifier status, a constant");
        m.write(VarKind::M, 5000, 1.0);
        assert_eq!(m.read(VarKind::M, 5000), 1.0);
        m.write(VarKind::P, 99, -2.5);
        assert_eq!(format_value(m.read(VarKind::P, 99)), "-2.5");
        m.reset();
        assert_eq!(m.read(VarKind::P, 99), 0.0);
    }

    #[test]
    fn feedrate_override_is_per_coordinate_system_and_starts_at_100() {
        let mut m = memory();
        m.set_feed(2, 50.0);
        assert_eq!((m.feed(1), m.feed(2)), (100.0, 50.0));
    }
}
