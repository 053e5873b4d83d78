//! M-variable definitions and memory addresses as the card reads them (`M100->X:$000025,0,24,S`,
//! `WY:$2082,7`): the text after `->` and the address of a direct memory write.
//!
//! UM p.246: the kinds X, Y, D, L, DP, F, the thumbwheel kinds and `*`; PMAC-SRM p.262: an X or
//! Y definition names the address, the starting bit, the width, default 1, and the format, U, S,
//! D or C, default U. What a definition does when read or written is the emulator's
//! (`emulator/src/mvar.rs`).

use crate::vocab::command::Space;

/// The highest address a host names in an M-variable definition, an `RH` read or a `W` write:
/// a Turbo PMAC address is a 24-bit word, six hex digits. UM p.246: a definition keeps the
/// address it points at in a 24-bit Y-register ($004000 + n), and its examples name six digits
/// (`M1->Y:$078C02,8,1`); UM p.239 names X:$FFFF8C (the time between phase interrupts, on the
/// DSP's own peripheral page), which UM p.240's PLC reads as M70, as the EPICS driver's Geo Brick
/// file defines it (`M70->X:$FFFF8C,0,24`). SRM p.170's 19 bits ("bits 0 to 19; bit 19 must be
/// 0") are the address field of a data-gathering source (I5001..I5048), whose first hex digit
/// chooses the part of the word to read: not the range of M-variable addresses, for which this
/// bound once took them. MODEL: every 24-bit address is accepted; what is behind one the
/// emulator does not know is a word it keeps (`emulator/src/mvar.rs`).
pub const ADDRESS_MAX: u32 = 0xFF_FFFF;

/// How an X or Y definition decodes its bits (PMAC-SRM p.262).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Format {
    /// Unsigned integer.
    U,
    /// Signed (two's complement over the width).
    S,
    /// Binary-coded decimal.
    D,
    /// Complementary binary-coded decimal (MODEL: the BCD of the inverted bits).
    C,
}

/// What an M-variable points at.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Definition {
    /// `*`: no address; the M-variable holds its own value (UM p.246). A card powers up and
    /// re-initializes with every M-variable so (MODEL: UM p.246 recommends `M0..8191->*` to clear
    /// stray definitions).
    SelfReferenced,
    /// `X:` or `Y:`: `width` bits from bit `offset` of one 24-bit word.
    Word { space: Space, address: u32, offset: u8, width: u8, format: Format },
    /// `D:` (48-bit fixed point across X and Y) and `DP:` (32 bits, the low 16 of X and Y):
    /// integers. MODEL: X holds the high part.
    Fixed { address: u32, dual_ported: bool },
    /// `L:` (48-bit floating point across X and Y) and `F:` (32-bit, dual-ported): the value as
    /// written (MODEL: the DSP's float format is not reproduced bit for bit).
    Float { address: u32, dual_ported: bool },
}

impl Definition {
    /// Reads the text after `->`: `*`, `X:$078F00,0,24,S`, `Y$25,8`, `D:$8B`, `L:4161`,
    /// `DP:$060401`, `F:$0607FF`. The colon is optional (PMAC-SRM p.262); an address is decimal
    /// or `$` hex.
    pub fn parse(text: &str) -> Result<Definition, &'static str> {
        let t = text.trim().to_ascii_uppercase();
        if t == "*" {
            return Ok(Definition::SelfReferenced);
        }
        if t.starts_with("TW") {
            return Err("thumbwheel-multiplexer M-variables are not emulated (no Acc-18 port)");
        }
        let (kind, rest) = ["DP", "D", "L", "F", "X", "Y"]
            .iter()
            .find_map(|k| t.strip_prefix(k).map(|r| (*k, r)))
            .ok_or("an M-variable points at X:, Y:, D:, L:, DP: or F: memory, or is *")?;
        let rest = rest.strip_prefix(':').unwrap_or(rest);
        let mut fields = rest.split(',');
        let address = parse_address(fields.next().unwrap_or(""))?;
        let definition = match kind {
            "X" | "Y" => {
                let space = if kind == "X" { Space::X } else { Space::Y };
                let offset: u8 = fields
                    .next()
                    .and_then(|f| f.trim().parse().ok())
                    .filter(|o| *o <= 24)
                    .ok_or("an X or Y definition gives its starting bit, 0..23, or 24 for the whole word")?;
                let width: Option<u8> = match fields.next() {
                    None => None,
                    Some(f) => {
                        Some(f.trim().parse().ok().filter(|w| (1..=24).contains(w)).ok_or("the width is 1..24 bits")?)
                    }
                };
                let format = match fields.next().map(str::trim) {
                    None | Some("U") => Format::U,
                    Some("S") => Format::S,
                    Some("D") => Format::D,
                    Some("C") => Format::C,
                    Some(_) => return Err("the format is U, S, D or C"),
                };
                // PMAC-SRM p.262: offset 24 is the whole word.
                let (offset, width) = match (offset, width) {
                    (24, None | Some(24)) => (0, 24),
                    (24, Some(_)) => return Err("offset 24 is the whole word: its width is 24"),
                    (o, w) => (o, w.unwrap_or(1)),
                };
                if u32::from(offset) + u32::from(width) > 24 {
                    return Err("the bits run past bit 23 of the word");
                }
                Definition::Word { space, address, offset, width, format }
            }
            "D" | "DP" => Definition::Fixed { address, dual_ported: kind == "DP" },
            _ => Definition::Float { address, dual_ported: kind == "F" },
        };
        if fields.next().is_some() {
            return Err("the definition has more fields than its kind takes");
        }
        Ok(definition)
    }

    /// The same kind of definition `k` addresses further on: a direct memory write's `k`th value
    /// goes to the address after the one before it.
    pub fn at_offset(self, k: u32) -> Definition {
        let next = |a: u32| a.saturating_add(k).min(ADDRESS_MAX);
        match self {
            Definition::SelfReferenced => self,
            Definition::Word { space, address, offset, width, format } => {
                Definition::Word { space, address: next(address), offset, width, format }
            }
            Definition::Fixed { address, dual_ported } => Definition::Fixed { address: next(address), dual_ported },
            Definition::Float { address, dual_ported } => Definition::Float { address: next(address), dual_ported },
        }
    }

    /// The definition as `M{n}->` reports it (PMAC-SRM p.253: the definition itself, e.g.
    /// `Y:$FFC2,8`). MODEL: the Turbo form prints six hex digits and every field.
    pub fn report(&self) -> String {
        match *self {
            Definition::SelfReferenced => "*".into(),
            Definition::Word { space, address, offset, width, format } => {
                format!("{space:?}:${address:06X},{offset},{width},{format:?}")
            }
            Definition::Fixed { address, dual_ported } => {
                format!("{}:${address:06X}", if dual_ported { "DP" } else { "D" })
            }
            Definition::Float { address, dual_ported } => {
                format!("{}:${address:06X}", if dual_ported { "F" } else { "L" })
            }
        }
    }
}

/// `$2082` or `8322`, at most [`ADDRESS_MAX`].
pub fn parse_address(text: &str) -> Result<u32, &'static str> {
    let t = text.trim();
    let parsed = match t.strip_prefix('$') {
        Some(h) if !h.is_empty() && h.len() <= 6 && h.bytes().all(|c| c.is_ascii_hexdigit()) => {
            u32::from_str_radix(h, 16).ok()
        }
        Some(_) => None,
        None if !t.is_empty() && t.len() <= 7 && t.bytes().all(|c| c.is_ascii_digit()) => t.parse().ok(),
        None => None,
    };
    parsed.filter(|a| *a <= ADDRESS_MAX).ok_or("an address is $0..$FFFFFF (24 bits, UM p.246)")
}
