//! The card's command-line grammar, `pmacwd_specs::grammar::parse_line`, and the card
//! answering the same bytes.
//!
//! Invariants:
//! - no panic on any bytes;
//! - at most one command per input byte, plus one (an error or a bare `#`/`&` report);
//! - only the last element may be an error: the line stops at the first command it cannot read;
//! - the addressing stays a real motor (1..=32) and C.S. (1..=16);
//! - every command read prints (`Display`) as text the grammar reads back as one command that
//!   prints the same (parse, print, parse);
//! - the card answers every line it is not tripped for, and its reply reads back under its
//!   framing (`parse_reply`), acknowledged exactly when no command failed (commands after an
//!   OPEN on the same line are program text, which the card stores).
#![no_main]

use libfuzzer_sys::fuzz_target;
use pmacwd_emulator::card::{Card, Clock};
use pmacwd_emulator::framing::parse_reply;
use pmacwd_specs::grammar::{parse_line, Addressing, Command};

fuzz_target!(|data: &[u8]| {
    let mut a = Addressing::default();
    let commands = parse_line(data, &mut a);
    assert!(commands.len() <= data.len() + 1, "{} commands from {} bytes", commands.len(), data.len());
    if let Some((_, before)) = commands.split_last() {
        assert!(before.iter().all(Result::is_ok), "an error before the last command");
    }
    assert!((1..=32).contains(&a.motor) && (1..=16).contains(&a.cs), "{a:?}");
    for c in commands.iter().flatten() {
        let printed = c.to_string();
        let again = parse_line(printed.as_bytes(), &mut Addressing::default());
        assert_eq!(again.len(), 1, "`{}` reads as {} commands", printed.escape_debug(), again.len());
        let again =
            again[0].as_ref().unwrap_or_else(|e| panic!("`{}` does not read back: {e:?}", printed.escape_debug()));
        assert_eq!(again.to_string(), printed, "the printed form is not canonical");
    }

    // A line the card's buffer takes (1,492 bytes), on a fresh card each time.
    if data.len() <= 1492 {
        let mut card = Card::default_card(Clock::Virtual);
        if let Some(reply) = card.line(data) {
            let parsed = parse_reply(&reply).expect("the card's reply reads back under its framing");
            // After an OPEN the rest of the line is program text for the buffer (UM p.46), which
            // the card stores and acknowledges even where it is no on-line command (`X10`):
            // only what comes before the first OPEN is read as on-line commands.
            let mut online =
                commands.iter().take_while(|c| !matches!(c, Ok(Command::OpenPlc(_) | Command::OpenProgram(_))));
            let failed = online.any(Result::is_err) || data.iter().any(|b| *b > 127);
            if !failed && parsed.acknowledged {
                return;
            }
            // A command may also fail at the core (a locked or out-of-range write, ERR001):
            // then the reply is not acknowledged; an unreadable command never is.
            if failed {
                assert!(!parsed.acknowledged, "an unreadable line was acknowledged");
            }
        }
    }
});
