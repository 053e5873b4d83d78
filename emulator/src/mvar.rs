//! M-variables as pointers into the card's memory, and the direct memory write: how
//! `M100->X:$000025,0,24,S`, `M100`, `M100=5` and `WY:$2082,7` reach a register.
//!
//! An M-variable is defined to point at a register, or at part of one (UM p.246: the kinds X,
//! Y, D, L, DP, F, the thumbwheel kinds and `*`; PMAC-SRM p.262: an X or Y definition names
//! the address, the starting bit, the width, default 1, and the format, U, S, D or C, default
//! U). Its value is read from that register and an assignment writes it there (PMAC-SRM
//! p.253). A value that does not fit is rolled over and a fraction rounded (PMAC-UM "M-variables":
//! "PMAC automatically rolls over the value to within that range", "rounds to the nearest
//! integer").
//!
//! What a definition can point at, in the emulator:
//!
//! - a register of the safety core (`specs/variables.yaml`, `registers`: X:$0, X:$6, Y:$6,
//!   X:$25, Y:$25, X:$1080, X:$1090): read through the core, as `RHX:` reads it. A write is
//!   not applied (MODEL: the firmware owns these registers; the emulator changes the core only
//!   through its vocabulary) and the console says so once;
//! - the storage of I-variable n, at `D:$002000 + n` (MODEL, `variables.yaml`,
//!   `i_variable_storage`: the pages at hand give no address; this one lies just below the
//!   M-variable definitions, which UM p.246 places at $004000-$005FFF). A write there changes
//!   the I-variable whatever I41 holds (SRM p.57: "I41 does not prevent changes to an
//!   I-variable by means of an M-variable assignment or a direct memory write command"); the
//!   core hears it as [`HostCommand::WriteIMemory`](pmacwd_specs::vocab::HostCommand);
//! - any other address: a word the emulator keeps, 0 until written, cleared by a reset.
//!   At most [`WORDS_MAX`] distinct words are kept; a write to one more is ERR003.
//!
//! Thumbwheel-multiplexer definitions (`TWD:`, `TWB:`, `TWS:`, `TWR:`) are refused: the
//! emulated card has no Acc-18 port.

use pmacwd_specs::vocab::command::Space;
use std::collections::BTreeMap;

pub use pmacwd_specs::grammar::definition::{parse_address, Definition, Format, ADDRESS_MAX};

/// How many distinct 24-bit words (and 48-bit floats) the emulator keeps for addresses that
/// are neither a core register nor I-variable storage. MODEL: a bound for the emulator's memory,
/// far above what host programs write (a host's whole M-variable table is 8,192 entries).
pub const WORDS_MAX: usize = 65_536;

/// The M-variable definitions: UM p.246, "$004000 (for M0) to $005FFF (for M8191)".
pub const DEFINITIONS: usize = 8192;

fn mask(width: u8) -> u32 {
    if width >= 32 {
        u32::MAX
    } else {
        (1u32 << width) - 1
    }
}

/// The value of `width` bits from bit `offset` of `word`, decoded as `format`.
pub fn field_value(word: u32, offset: u8, width: u8, format: Format) -> i64 {
    let bits = (word >> offset) & mask(width);
    match format {
        Format::U => i64::from(bits),
        Format::S => {
            let sign = 1u32 << (width - 1);
            if bits & sign != 0 {
                i64::from(bits) - (1i64 << width)
            } else {
                i64::from(bits)
            }
        }
        Format::D => bcd_value(bits, width),
        Format::C => bcd_value(!bits & mask(width), width),
    }
}

/// `word` with `width` bits from bit `offset` set to `value` encoded as `format`, rolled over
/// to the width (PMAC-UM: a value outside the range is rolled over, without an error).
pub fn with_field(word: u32, offset: u8, width: u8, format: Format, value: i64) -> u32 {
    let m = mask(width);
    let bits = match format {
        // Two's complement wraps both: -1 in 4 bits is $F.
        Format::U | Format::S => (value as u32) & m,
        Format::D => bcd_bits(value, width),
        Format::C => !bcd_bits(value, width) & m,
    };
    (word & !(m << offset)) | (bits << offset)
}

/// Decimal digits, one per nibble, least significant first. MODEL: a nibble above 9 counts
/// as its binary value.
fn bcd_value(bits: u32, width: u8) -> i64 {
    let mut value = 0i64;
    let mut scale = 1i64;
    let mut shift = 0;
    while shift < u32::from(width) {
        value += i64::from((bits >> shift) & 0xF) * scale;
        scale *= 10;
        shift += 4;
    }
    value
}

/// The magnitude of `value` in BCD, as many digits as the width holds (rolled over).
fn bcd_bits(value: i64, width: u8) -> u32 {
    let mut v = value.unsigned_abs();
    let mut bits = 0u32;
    let mut shift = 0;
    while shift < u32::from(width) {
        bits |= ((v % 10) as u32) << shift;
        v /= 10;
        shift += 4;
    }
    bits & mask(width)
}

/// A value assigned to an integer M-variable: rounded to the nearest integer (PMAC-UM), and
/// kept within what 48 bits hold.
pub fn whole(value: f64) -> i64 {
    const LIMIT: f64 = (1u64 << 47) as f64;
    if value.is_nan() {
        0
    } else {
        value.round().clamp(-LIMIT, LIMIT - 1.0) as i64
    }
}

/// A 48-bit value from its X (high) and Y (low) words (MODEL, see [`Definition::Fixed`]).
pub fn join48(x: u32, y: u32) -> i64 {
    let raw = (u64::from(x & 0xFF_FFFF) << 24) | u64::from(y & 0xFF_FFFF);
    ((raw << 16) as i64) >> 16
}

/// The X (high) and Y (low) words of a 48-bit value.
pub fn split48(v: i64) -> (u32, u32) {
    let raw = v as u64;
    (((raw >> 24) & 0xFF_FFFF) as u32, (raw & 0xFF_FFFF) as u32)
}

/// A 32-bit dual-ported value from the low 16 bits of X (high half) and Y (low half).
pub fn join32(x: u32, y: u32) -> i64 {
    i64::from((((x & 0xFFFF) << 16) | (y & 0xFFFF)) as i32)
}

/// The X and Y words that hold a 32-bit dual-ported value in their low 16 bits.
pub fn split32(v: i64) -> (u32, u32) {
    let raw = v as u32;
    (raw >> 16, raw & 0xFFFF)
}

/// The M-variable definitions, active and saved, and the words of memory the emulator keeps.
pub struct MemoryMap {
    active: Box<[Definition]>,
    saved: Box<[Definition]>,
    words: BTreeMap<(u8, u32), u32>,
    floats: BTreeMap<u32, f64>,
    /// The address of I0's storage (`variables.yaml`, `i_variable_storage`), if known.
    pub i_storage_base: Option<u32>,
}

/// Why a write to memory was not applied.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Full {
    /// [`WORDS_MAX`] distinct words are already kept.
    Words,
}

fn space_key(space: Space) -> u8 {
    match space {
        Space::X => 0,
        Space::Y => 1,
    }
}

impl MemoryMap {
    pub fn new(i_storage_base: Option<u32>) -> MemoryMap {
        MemoryMap {
            active: vec![Definition::SelfReferenced; DEFINITIONS].into_boxed_slice(),
            saved: vec![Definition::SelfReferenced; DEFINITIONS].into_boxed_slice(),
            words: BTreeMap::new(),
            floats: BTreeMap::new(),
            i_storage_base,
        }
    }

    pub fn definition(&self, n: u16) -> Definition {
        self.active.get(usize::from(n)).copied().unwrap_or(Definition::SelfReferenced)
    }

    pub fn define(&mut self, n: u16, d: Definition) {
        if let Some(slot) = self.active.get_mut(usize::from(n)) {
            *slot = d;
        }
    }

    /// The I-variable whose storage is at `address`, if it is one.
    pub fn i_variable_at(&self, address: u32) -> Option<u16> {
        let n = address.checked_sub(self.i_storage_base?)?;
        u16::try_from(n).ok().filter(|n| usize::from(*n) < DEFINITIONS)
    }

    /// A word the emulator keeps (0 until written).
    pub fn word(&self, space: Space, address: u32) -> u32 {
        self.words.get(&(space_key(space), address)).copied().unwrap_or(0)
    }

    pub fn set_word(&mut self, space: Space, address: u32, word: u32) -> Result<(), Full> {
        let key = (space_key(space), address);
        if !self.words.contains_key(&key) && self.words.len() >= WORDS_MAX {
            return Err(Full::Words);
        }
        self.words.insert(key, word & 0xFF_FFFF);
        Ok(())
    }

    pub fn float(&self, address: u32) -> f64 {
        self.floats.get(&address).copied().unwrap_or(0.0)
    }

    pub fn set_float(&mut self, address: u32, v: f64) -> Result<(), Full> {
        if !self.floats.contains_key(&address) && self.floats.len() >= WORDS_MAX {
            return Err(Full::Words);
        }
        self.floats.insert(address, v);
        Ok(())
    }

    /// SAVE: the definitions go to flash with the I-variables (UM p.243: SAVE copies the
    /// active values to flash).
    pub fn save(&mut self) {
        self.saved.copy_from_slice(&self.active);
    }

    /// `$$$`: the saved definitions come back and the memory's words are cleared (active memory
    /// is volatile, UM p.243).
    pub fn reset(&mut self) {
        self.active.copy_from_slice(&self.saved);
        self.words.clear();
        self.floats.clear();
    }

    /// `$$$***`: every definition back to `*`; the saved ones stay in flash for the next `$$$`
    /// (UM p.243: "The last saved values are not lost; they are just not used").
    pub fn reinitialize(&mut self) {
        self.active.fill(Definition::SelfReferenced);
        self.words.clear();
        self.floats.clear();
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn definitions_read_as_the_manuals_write_them_and_report_back_in_full() {
        // PMAC-SRM p.262: the colon is optional, the width defaults to 1, the format to U, and
        // offset 24 means the whole word.
        let cases = [
            ("Y:$078F00,0,24,S", "Y:$078F00,0,24,S"),
            ("X$25,24", "X:$000025,0,24,U"),
            ("y:$FFC2,8", "Y:$00FFC2,8,1,U"),
            ("X:37,4,4,D", "X:$000025,4,4,D"),
            ("D:$8B", "D:$00008B"),
            ("L:4161", "L:$001041"),
            ("DP:$060401", "DP:$060401"),
            ("F:$0607FF", "F:$0607FF"),
            // Six hex digits, the whole 24-bit address (UM p.246), past SRM p.170's 19-bit
            // gathering field: the EPICS driver's M70 (UM p.239).
            ("X:$FFFF8C,0,24", "X:$FFFF8C,0,24,U"),
            ("X:$80000,0", "X:$080000,0,1,U"),
            ("*", "*"),
        ];
        for (text, report) in cases {
            assert_eq!(Definition::parse(text).map(|d| d.report()).as_deref(), Ok(report), "{text}");
        }
    }

    #[test]
    fn definitions_outside_the_syntax_are_refused_with_the_reason() {
        for (text, why) in [
            ("X:$25", "starting bit"),
            ("X:$25,25", "starting bit"),
            ("X:$25,20,8", "past bit 23"),
            ("X:$25,24,8", "whole word"),
            ("X:$25,0,25", "1..24"),
            ("X:$25,0,8,Q", "U, S, D or C"),
            ("X:$1000000,0", "24 bits"),
            ("X:16777216,0", "24 bits"),
            ("X:$-5,0", "24 bits"),
            ("D:$8B,0", "more fields"),
            ("TWD:4,0,8.3,U", "thumbwheel"),
            ("Z:$25", "X:, Y:"),
        ] {
            let e = Definition::parse(text).unwrap_err();
            assert!(e.contains(why), "{text}: {e}");
        }
    }

    #[test]
    fn a_field_reads_and_writes_only_its_own_bits_in_its_format() {
        let word = 0x12_3456;
        assert_eq!(field_value(word, 4, 8, Format::U), 0x45);
        assert_eq!(field_value(0xFF_FFFF, 0, 24, Format::S), -1);
        assert_eq!(field_value(0x00_0F00, 8, 4, Format::S), -1);
        assert_eq!(field_value(0x00_1234, 0, 16, Format::D), 1234);
        assert_eq!(with_field(word, 4, 8, Format::U, 0xAB), 0x12_3AB6, "the other bits stay");
        // Rolled over to the width (PMAC-UM): 17 in 4 bits is 1, -1 is $F.
        assert_eq!(with_field(0, 0, 4, Format::U, 17), 1);
        assert_eq!(with_field(0, 0, 4, Format::S, -1), 0xF);
        assert_eq!(with_field(0, 0, 16, Format::D, 98765), 0x8765);
        for v in [0, 1, 42, 9999] {
            let w = with_field(0, 4, 16, Format::C, v);
            assert_eq!(field_value(w, 4, 16, Format::C), v, "C round-trips {v}");
        }
    }

    #[test]
    fn wide_values_split_into_x_high_and_y_low_and_join_back() {
        for v in [0, 1, -1, 0x7FFF_FFFF_FFFF, -0x8000_0000_0000, 4096, -4096] {
            let (x, y) = split48(v);
            assert!(x <= 0xFF_FFFF && y <= 0xFF_FFFF);
            assert_eq!(join48(x, y), v);
        }
        for v in [0, 1, -1, i64::from(i32::MAX), i64::from(i32::MIN)] {
            let (x, y) = split32(v);
            assert_eq!(join32(x, y), v);
        }
        assert_eq!(whole(2.5), 3, "rounded to the nearest integer");
        assert_eq!(whole(f64::INFINITY), (1i64 << 47) - 1);
    }

    #[test]
    fn i_variable_storage_is_8192_words_from_the_base() {
        let m = MemoryMap::new(Some(0x2000));
        assert_eq!(m.i_variable_at(0x2000), Some(0));
        assert_eq!(m.i_variable_at(0x2082), Some(130));
        assert_eq!(m.i_variable_at(0x3FFF), Some(8191));
        assert_eq!(m.i_variable_at(0x4000), None, "M0's definition (UM p.246)");
        assert_eq!(m.i_variable_at(0x1FFF), None);
    }

    #[test]
    fn memory_is_bounded_and_a_reset_clears_it_but_keeps_saved_definitions() {
        let mut m = MemoryMap::new(Some(0x2000));
        for a in 0..WORDS_MAX as u32 {
            m.set_word(Space::X, 0x10000 + a, a).unwrap();
        }
        assert_eq!(m.set_word(Space::X, 0x10000, 7), Ok(()), "a kept word can be rewritten");
        assert_eq!(m.set_word(Space::Y, 0x10000, 7), Err(Full::Words), "one more is refused");
        let d = Definition::parse("X:$25,0,24,S").unwrap();
        m.define(100, d);
        m.save();
        m.define(101, d);
        m.reset();
        assert_eq!(m.word(Space::X, 0x10000), 0);
        assert_eq!((m.definition(100), m.definition(101)), (d, Definition::SelfReferenced));
        m.reinitialize();
        assert_eq!(m.definition(100), Definition::SelfReferenced);
        m.reset();
        assert_eq!(m.definition(100), d, "$$$ brings the saved definitions back after $$$***");
    }
}
