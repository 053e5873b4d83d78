//! Host commands as a user types them at a terminal, parsed into the closed set the model
//! understands.
//!
//! | text | command | reply |
//! |---|---|---|
//! | `???` | [`HostCommand::GlobalStatus`] | 12 hex characters (SRM p.289) |
//! | `I40` | [`HostCommand::ReadI`] | the value in decimal |
//! | `I40=100` | [`HostCommand::WriteI`] | nothing (ignored silently when locked by I41, SRM p.57) |
//! | `RHX:$25`, `RHY:$000025` | [`HostCommand::ReadHex`] | the 24-bit word in hex |
//! | `$$$` | [`HostCommand::Reset`] | nothing; the card resets |
//! | `OPEN PLC 1`, `OPEN PROG 1` | [`HostCommand::Open`] | nothing |
//! | `CLOSE` | [`HostCommand::Close`] | nothing; X:$1090 takes the program checksum (UM p.217) |
//!
//! Keywords are case-insensitive and spaces around `=` are allowed. Text that is not one of
//! these is kept as [`HostCommand::Unrecognized`]: the controller answers it with ERR003
//! (facts page s.3), so it is a legal input, not a parse failure. What *is* a parse failure
//! is a command the model cannot represent faithfully: a memory read of a register it does not
//! model, or an I-variable number beyond I8191.

use std::fmt;

/// X or Y memory.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Space {
    X,
    Y,
}

/// The registers the model holds, by address.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Register {
    /// X:$000000, servo cycle counter.
    ServoCycles,
    /// X:$000006, first status word.
    StatusX,
    /// Y:$000006, second status word.
    StatusY,
    /// Y:$000025, watchdog counter.
    WatchdogCounter,
    /// X:$000025, lowest watchdog counter value since reset.
    WatchdogMinimum,
    /// X:$001080, running checksum.
    RunningChecksum,
    /// X:$001090, user-program checksum reference.
    ProgramChecksumReference,
}

impl Register {
    pub const ALL: [(Register, Space, u32); 7] = [
        (Register::ServoCycles, Space::X, 0x0),
        (Register::StatusX, Space::X, 0x6),
        (Register::StatusY, Space::Y, 0x6),
        (Register::WatchdogCounter, Space::Y, 0x25),
        (Register::WatchdogMinimum, Space::X, 0x25),
        (Register::RunningChecksum, Space::X, 0x1080),
        (Register::ProgramChecksumReference, Space::X, 0x1090),
    ];

    pub fn at(space: Space, address: u32) -> Option<Register> {
        Self::ALL.iter().find(|(_, s, a)| *s == space && *a == address).map(|(r, ..)| *r)
    }

    pub fn address(self) -> (Space, u32) {
        Self::ALL.iter().find(|(r, ..)| *r == self).map(|(_, s, a)| (*s, *a)).expect("every register is listed")
    }
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Buffer {
    /// `OPEN PLC n`: Y:$000006 bit 17.
    Plc(u8),
    /// `OPEN PROG n`: Y:$000006 bit 19.
    Program(u16),
}

#[derive(Clone, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum HostCommand {
    GlobalStatus,
    ReadI(u16),
    WriteI(u16, i64),
    ReadHex(Register),
    Reset,
    Open(Buffer),
    Close,
    /// Anything else: answered with ERR003.
    Unrecognized(String),
}

/// Why a command text cannot be given to the model.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct CommandError(pub String);

impl fmt::Display for CommandError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.0)
    }
}

/// The highest I-variable number of a Turbo PMAC.
pub const I_VARIABLE_MAX: u16 = 8191;

impl HostCommand {
    pub fn parse(text: &str) -> Result<HostCommand, CommandError> {
        let t = text.trim();
        if t.is_empty() {
            return Err(CommandError("an empty command: write the command text, e.g. `???`".into()));
        }
        let upper = t.to_ascii_uppercase();
        let compact: String = upper.split_whitespace().collect::<Vec<_>>().join(" ");
        if compact == "???" {
            return Ok(HostCommand::GlobalStatus);
        }
        if compact == "$$$" {
            return Ok(HostCommand::Reset);
        }
        if compact == "CLOSE" {
            return Ok(HostCommand::Close);
        }
        if let Some(rest) = compact.strip_prefix("OPEN ") {
            let words: Vec<&str> = rest.split(' ').collect();
            return Ok(match words.as_slice() {
                ["PLC", n] => match n.parse::<u8>() {
                    Ok(n) if n <= 31 => HostCommand::Open(Buffer::Plc(n)),
                    _ => HostCommand::Unrecognized(t.to_string()),
                },
                ["PROG", n] => match n.parse::<u16>() {
                    Ok(n) if n >= 1 => HostCommand::Open(Buffer::Program(n)),
                    _ => HostCommand::Unrecognized(t.to_string()),
                },
                _ => HostCommand::Unrecognized(t.to_string()),
            });
        }
        if let Some(rest) = compact.strip_prefix("RH") {
            let rest = rest.trim();
            let (space, addr) = match rest.split_once(":$") {
                Some(("X", a)) => (Space::X, a),
                Some(("Y", a)) => (Space::Y, a),
                _ => return Ok(HostCommand::Unrecognized(t.to_string())),
            };
            // Hex digits only: `from_str_radix` would also take a sign (`RHX:$+25`).
            if addr.is_empty() || !addr.chars().all(|c| c.is_ascii_hexdigit()) {
                return Ok(HostCommand::Unrecognized(t.to_string()));
            }
            let Ok(address) = u32::from_str_radix(addr, 16) else {
                return Ok(HostCommand::Unrecognized(t.to_string()));
            };
            if addr.len() > 6 {
                return Ok(HostCommand::Unrecognized(t.to_string()));
            }
            return match Register::at(space, address) {
                Some(r) => Ok(HostCommand::ReadHex(r)),
                None => Err(CommandError(format!(
                    "`{t}`: the model holds no register at {space:?}:${address:06X} (it models X:$0, X:$6, Y:$6, X:$25, Y:$25, X:$1080, X:$1090)"
                ))),
            };
        }
        if let Some(rest) = compact.strip_prefix('I') {
            let (num, value) = match rest.split_once('=') {
                Some((n, v)) => (n.trim(), Some(v.trim())),
                None => (rest.trim(), None),
            };
            if num.is_empty() || !num.chars().all(|c| c.is_ascii_digit()) {
                return Ok(HostCommand::Unrecognized(t.to_string()));
            }
            let number: u32 = num.parse().map_err(|_| CommandError(format!("`{t}`: I-variable number too long")))?;
            if number > u32::from(I_VARIABLE_MAX) {
                return Err(CommandError(format!(
                    "`{t}`: Turbo PMAC has I0..I{I_VARIABLE_MAX}; there is no I{number}"
                )));
            }
            let number = number as u16;
            return Ok(match value {
                None => HostCommand::ReadI(number),
                Some(v) => match parse_value(v) {
                    Some(v) => HostCommand::WriteI(number, v),
                    None => HostCommand::Unrecognized(t.to_string()),
                },
            });
        }
        Ok(HostCommand::Unrecognized(t.to_string()))
    }
}

/// Decimal or `$`-prefixed hex, optionally negative.
fn parse_value(v: &str) -> Option<i64> {
    let (neg, body) = match v.strip_prefix('-') {
        Some(b) => (true, b),
        None => (false, v),
    };
    let magnitude = match body.strip_prefix('$') {
        // Hex digits only: `from_str_radix` would also take a sign (`I5=$-5`).
        Some(hex) if !hex.is_empty() && hex.len() <= 12 && hex.chars().all(|c| c.is_ascii_hexdigit()) => {
            i64::from_str_radix(hex, 16).ok()?
        }
        Some(_) => return None,
        None if !body.is_empty() && body.len() <= 15 && body.chars().all(|c| c.is_ascii_digit()) => {
            body.parse().ok()?
        }
        None => return None,
    };
    Some(if neg { -magnitude } else { magnitude })
}

impl fmt::Display for HostCommand {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            HostCommand::GlobalStatus => f.write_str("???"),
            HostCommand::ReadI(n) => write!(f, "I{n}"),
            HostCommand::WriteI(n, v) => write!(f, "I{n}={v}"),
            HostCommand::ReadHex(r) => {
                let (s, a) = r.address();
                write!(f, "RH{s:?}:${a:X}")
            }
            HostCommand::Reset => f.write_str("$$$"),
            HostCommand::Open(Buffer::Plc(n)) => write!(f, "OPEN PLC {n}"),
            HostCommand::Open(Buffer::Program(n)) => write!(f, "OPEN PROG {n}"),
            HostCommand::Close => f.write_str("CLOSE"),
            HostCommand::Unrecognized(t) => f.write_str(t),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn commands_parse_case_insensitively_and_print_back_in_canonical_form() {
        for (text, canonical) in [
            ("???", "???"),
            ("i40", "I40"),
            ("I130 = 7", "I130=7"),
            ("I5100=$10", "I5100=16"),
            ("rhy:$000025", "RHY:$25"),
            ("RHX:$1080", "RHX:$1080"),
            ("$$$", "$$$"),
            ("open plc 1", "OPEN PLC 1"),
            ("OPEN PROG 10", "OPEN PROG 10"),
            ("close", "CLOSE"),
        ] {
            assert_eq!(HostCommand::parse(text).unwrap().to_string(), canonical, "{text}");
        }
    }

    #[test]
    fn text_the_controller_would_reject_is_kept_for_an_err003_reply() {
        // A real controller answers these with ERR003, so the model must too: they are inputs.
        for text in ["HELLO", "I40=abc", "OPEN PLC 99", "RHZ:$25", "I"] {
            assert!(matches!(HostCommand::parse(text), Ok(HostCommand::Unrecognized(_))), "{text}");
        }
    }

    #[test]
    fn commands_the_model_cannot_represent_are_errors_not_guesses() {
        assert!(HostCommand::parse("RHX:$1234").unwrap_err().0.contains("no register"));
        assert!(HostCommand::parse("I9000=1").unwrap_err().0.contains("I0..I8191"));
    }

    #[test]
    fn an_empty_command_is_an_error_and_signs_are_not_hex_digits() {
        // A trace step `command: ""` used to run as an empty command; `$+25` and `$-5` were
        // read as hex because the standard parser accepts a sign. A card answers neither as a
        // register read or a write: they are unrecognized (ERR003).
        assert!(HostCommand::parse("  ").unwrap_err().0.contains("empty command"));
        assert_eq!(HostCommand::parse("RHX:$+25").unwrap(), HostCommand::Unrecognized("RHX:$+25".into()));
        assert_eq!(HostCommand::parse("I5=$-5").unwrap(), HostCommand::Unrecognized("I5=$-5".into()));
        assert_eq!(HostCommand::parse("I5=-$5").unwrap(), HostCommand::WriteI(5, -5));
    }
}
