//! The `???` reply as text: twelve hex characters (SRM p.289), `BOOTSTRAP PROM`, or an error
//! `BEL ERRnnn CR` (facts s.3), turned into words and back.

use std::fmt;

/// A decoded `???` reply.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum StatusReply {
    /// X:$000006 and Y:$000006, 24 bits each.
    Words {
        x: u32,
        y: u32,
    },
    Bootstrap,
    /// `BEL ERRnnn CR`.
    Error(ErrorNumber),
}

/// The number of an error reply, ERR000 to ERR999: three digits are all the text form has
/// (facts s.3), so a number it cannot write cannot be held, and every reply encodes to a text
/// [`decode`] reads back.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct ErrorNumber(u16);

impl ErrorNumber {
    pub const MAX: u16 = 999;

    /// `n` if it has a three-digit form (0 to 999).
    pub const fn new(n: u16) -> Option<ErrorNumber> {
        if n <= Self::MAX {
            Some(ErrorNumber(n))
        } else {
            None
        }
    }

    pub const fn get(self) -> u16 {
        self.0
    }
}

/// `003`: the three digits of the reply text.
impl fmt::Display for ErrorNumber {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{:03}", self.0)
    }
}

#[derive(Clone, Debug, PartialEq, Eq)]
pub struct DecodeError(pub String);

impl fmt::Display for DecodeError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.0)
    }
}

/// The text a controller sends for `reply` (without the trailing CR/ACK of the protocol).
pub fn encode(reply: StatusReply) -> String {
    match reply {
        // SRM p.289: the first character is bits 20-23 of the first word, the seventh bits
        // 20-23 of the second word.
        StatusReply::Words { x, y } => format!("{:06X}{:06X}", x & 0xFF_FFFF, y & 0xFF_FFFF),
        StatusReply::Bootstrap => "BOOTSTRAP PROM".to_string(),
        StatusReply::Error(n) => format!("\u{7}ERR{n}\r"),
    }
}

/// Reads a reply as a host would receive it. Surrounding whitespace and a trailing ACK are
/// ignored; hex digits may be either case.
pub fn decode(text: &str) -> Result<StatusReply, DecodeError> {
    let t = text.trim_end_matches('\u{6}').trim_matches(|c: char| c == '\r' || c == '\n' || c == ' ');
    if t == "BOOTSTRAP PROM" {
        return Ok(StatusReply::Bootstrap);
    }
    // `BEL ERRnnn CR` as the card sends it, or `ERRnnn` as logs and terminals write it.
    let error = match t.strip_prefix('\u{7}') {
        Some(rest) => Some(
            rest.strip_prefix("ERR")
                .ok_or_else(|| DecodeError(format!("`{}`: BEL not followed by ERRnnn", text.escape_debug())))?,
        ),
        None => t.strip_prefix("ERR"),
    };
    if let Some(digits) = error {
        if digits.len() != 3 || !digits.chars().all(|c| c.is_ascii_digit()) {
            return Err(DecodeError(format!(
                "`{}`: an error reply is BEL ERRnnn CR with three digits",
                text.escape_debug()
            )));
        }
        let n = digits.parse().ok().and_then(ErrorNumber::new).expect("three digits are 0 to 999");
        return Ok(StatusReply::Error(n));
    }
    // Counted in characters, as the message says: `00000000000é` is 12 characters, 13 bytes,
    // and fails as a non-hex character below.
    if t.chars().count() != 12 {
        return Err(DecodeError(format!(
            "`{}`: a ??? reply has 12 hex characters, this has {}",
            t.escape_debug(),
            t.chars().count()
        )));
    }
    if let Some(bad) = t.chars().find(|c| !c.is_ascii_hexdigit()) {
        return Err(DecodeError(format!("`{}`: `{}` is not a hex digit", t.escape_debug(), bad.escape_debug())));
    }
    let x = u32::from_str_radix(&t[..6], 16).expect("six hex digits");
    let y = u32::from_str_radix(&t[6..], 16).expect("six hex digits");
    Ok(StatusReply::Words { x, y })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_first_character_is_bits_20_to_23_of_the_first_word() {
        // SRM p.289: bit 22 alone is 0x400000 -> "4" first.
        assert_eq!(encode(StatusReply::Words { x: 1 << 22, y: 1 << 19 }), "400000080000");
        assert_eq!(decode("400000080000"), Ok(StatusReply::Words { x: 1 << 22, y: 1 << 19 }));
    }

    #[test]
    fn malformed_replies_are_refused_with_the_reason() {
        assert!(decode("12345").unwrap_err().0.contains("12 hex characters"));
        assert!(decode("12345678901G").unwrap_err().0.contains("`G` is not a hex digit"));
        assert!(decode("\u{7}ERR3\r").unwrap_err().0.contains("three digits"));
        let err3 = StatusReply::Error(ErrorNumber::new(3).unwrap());
        assert_eq!(decode("\u{7}ERR003\r"), Ok(err3));
        // As a log or a terminal writes it, without the BEL.
        assert_eq!(decode("ERR003"), Ok(err3));
        assert_eq!(decode("BOOTSTRAP PROM\r\u{6}"), Ok(StatusReply::Bootstrap));
        // Twelve characters but not twelve bytes: the bad character is named, not the count.
        assert!(decode("00000000000é").unwrap_err().0.contains("`é` is not a hex digit"));
    }

    #[test]
    fn an_error_number_as_a_log_writes_it_encodes_back_in_the_card_s_form() {
        // Found by the status_reply fuzz target (its seed `ERR003`): `decode` takes the number
        // without BEL and CR, as logs write it; `encode` writes what the card sends, which
        // decodes to the same reply.
        let reply = decode("ERR003").unwrap();
        assert_eq!(encode(reply), "\u{7}ERR003\r");
        assert_eq!(decode(&encode(reply)), Ok(reply));
    }

    #[test]
    fn every_error_number_the_type_holds_round_trips_and_no_other_can_be_made() {
        // Error(u16) used to hold 1000, which encoded to ERR1000 and did not decode (found by
        // writing the status_reply fuzz target, docs/fuzzing.md). The whole domain of u16:
        // 0..=999 are numbers and round-trip; the rest cannot be made.
        for n in 0..=u16::MAX {
            match ErrorNumber::new(n) {
                Some(e) => {
                    assert_eq!(e.get(), n);
                    let text = encode(StatusReply::Error(e));
                    assert_eq!(text, format!("\u{7}ERR{n:03}\r"));
                    assert_eq!(decode(&text), Ok(StatusReply::Error(e)), "{n}");
                }
                None => assert!(n > 999, "{n} has three digits"),
            }
        }
    }
}
