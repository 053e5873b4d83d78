//! Type-driven properties (quickcheck) of the two text formats a host sees: the `???` reply and
//! the host-command syntax. Random inputs find the corner cases hand-picked examples miss.

use pmacwd_specs::vocab::command::{Buffer, HostCommand, Register};
use pmacwd_specs::vocab::reply_text::{decode, encode, ErrorNumber, StatusReply};
use quickcheck::{quickcheck, Arbitrary, Gen, TestResult};

quickcheck! {
    /// Any two 24-bit words survive encoding to twelve hex characters and decoding back.
    fn status_words_round_trip_through_the_reply_text(x: u32, y: u32) -> bool {
        let (x, y) = (x & 0xFF_FFFF, y & 0xFF_FFFF);
        let text = encode(StatusReply::Words { x, y });
        text.len() == 12 && decode(&text) == Ok(StatusReply::Words { x, y })
    }

    /// The compact core formats its `???` reply itself (nibble lookups on the wire-layout
    /// words); for any two 24-bit words its twelve characters are what the suite's encoder
    /// writes and its decoder reads back.
    fn the_core_formats_the_status_reply_as_the_suite_encodes_it(x: u32, y: u32) -> bool {
        let (x, y) = (x & 0xFF_FFFF, y & 0xFF_FFFF);
        let core_text = pmacwd_core::Reply::status_text(x, y);
        core_text.as_slice() == encode(StatusReply::Words { x, y }).as_bytes()
    }

    /// Any error number the type can hold survives the BEL ERRnnn CR form, and a number
    /// without a three-digit form cannot be held.
    fn error_replies_round_trip(n: u16) -> bool {
        match ErrorNumber::new(n) {
            Some(e) => decode(&encode(StatusReply::Error(e))) == Ok(StatusReply::Error(e)),
            None => n > 999,
        }
    }

    /// Decoding is case-insensitive in the hex digits and encoding is upper case: any valid
    /// reply text comes back as its upper-case self.
    fn valid_reply_text_comes_back_upper_case(digits: Vec<u8>) -> TestResult {
        if digits.len() < 12 {
            return TestResult::discard();
        }
        let text: String = digits[..12].iter().map(|d| "0123456789abcdefABCDEF".chars().nth(usize::from(*d) % 22).unwrap()).collect();
        match decode(&text) {
            Ok(reply) => TestResult::from_bool(encode(reply) == text.to_ascii_uppercase()),
            Err(_) => TestResult::failed(),
        }
    }

    /// Text of any other length, or with a non-hex character, is refused, never misread.
    fn malformed_reply_text_is_refused(text: String) -> TestResult {
        let t = text.trim_end_matches('\u{6}').trim_matches(|c: char| c == '\r' || c == '\n' || c == ' ');
        let well_formed = (t.len() == 12 && t.chars().all(|c| c.is_ascii_hexdigit())) || t == "BOOTSTRAP PROM" || t.starts_with('\u{7}') || t.starts_with("ERR");
        if well_formed {
            return TestResult::discard();
        }
        TestResult::from_bool(decode(&text).is_err())
    }

    /// Every command the model knows prints in a form that parses back to itself.
    fn host_commands_round_trip_through_their_text(cmd: ArbitraryCommand) -> bool {
        HostCommand::parse(&cmd.0.to_string()) == Ok(cmd.0.clone())
    }

    /// The parser never panics, whatever it is given: a command is accepted, kept as
    /// unrecognized (ERR003), or refused with a message.
    fn the_command_parser_accepts_any_text_without_panicking(text: String) -> bool {
        match HostCommand::parse(&text) {
            Ok(_) => true,
            Err(e) => !e.0.is_empty(),
        }
    }
}

#[derive(Clone, Debug)]
struct ArbitraryCommand(HostCommand);

impl Arbitrary for ArbitraryCommand {
    fn arbitrary(g: &mut Gen) -> Self {
        let n = u16::arbitrary(g) % 8192;
        let cmd = match u8::arbitrary(g) % 8 {
            0 => HostCommand::GlobalStatus,
            1 => HostCommand::ReadI(n),
            2 => HostCommand::WriteI(n, i64::from(i32::arbitrary(g))),
            3 => HostCommand::ReadHex(*g.choose(&Register::ALL.map(|(r, ..)| r)).unwrap()),
            4 => HostCommand::Reset,
            5 => HostCommand::Open(Buffer::Plc(u8::arbitrary(g) % 32)),
            6 => HostCommand::Open(Buffer::Program(1 + u16::arbitrary(g) % 1000)),
            _ => HostCommand::Close,
        };
        ArbitraryCommand(cmd)
    }
}
