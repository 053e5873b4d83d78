//! Host command text, `HostCommand::parse`, and its `Display`.
//!
//! Invariants:
//! - no panic; a refusal gives a reason;
//! - an accepted command prints (`Display`) a text that parses back to the same command, and
//!   that text is canonical: it prints itself again;
//! - text kept as `Unrecognized` (answered ERR003) is the input without the spaces and tabs the
//!   grammar skips before it and without white space after it, never empty (a CR or another
//!   space the grammar stops at is kept: it is what makes the text unreadable, and trimmed off
//!   it would read as commands; `pmacwd import` writes such steps).
#![no_main]

use libfuzzer_sys::fuzz_target;
use pmacwd_specs::vocab::command::HostCommand;

fuzz_target!(|data: &[u8]| {
    let Ok(text) = std::str::from_utf8(data) else { return };
    let command = match HostCommand::parse(text) {
        Ok(c) => c,
        Err(e) => return assert!(!e.0.is_empty(), "a refusal without a reason"),
    };
    if let HostCommand::Unrecognized(kept) = &command {
        assert_eq!(kept, text.trim_start_matches([' ', '\t']).trim_end());
        assert!(!kept.is_empty());
    }
    let printed = command.to_string();
    let again = HostCommand::parse(&printed);
    assert_eq!(again.as_ref(), Ok(&command), "`{}` prints as `{}`", text.escape_debug(), printed.escape_debug());
    assert_eq!(again.map(|c| c.to_string()), Ok(printed), "the printed form is not canonical");
});
