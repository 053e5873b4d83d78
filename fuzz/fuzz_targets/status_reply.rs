//! The `???` reply text, `pmacwd_specs::vocab::reply_text::{decode, encode}`.
//!
//! Invariants:
//! - `decode` never panics, and refuses with a reason;
//! - a decoded reply re-encodes to the same text, normalized: without the surrounding
//!   CR/LF/space and trailing ACK `decode` ignores, without the BEL before ERRnnn it takes or
//!   leaves, hex in upper case; and decodes again to the same reply;
//! - `encode` then `decode` round-trips for every reply built from the input's bytes: any two
//!   24-bit words, `BOOTSTRAP PROM`, and every error number the type can hold (ERR000 to
//!   ERR999; any other `u16` cannot be made).
#![no_main]

use libfuzzer_sys::fuzz_target;
use pmacwd_specs::vocab::reply_text::{decode, encode, ErrorNumber, StatusReply};

/// What `decode` looks at: the text without what it ignores, hex digits upper-cased, and
/// without the BEL before an error number, which `decode` takes either way (`ERR003` as a log
/// writes it, `BEL ERR003 CR` as the card sends it; `encode` writes the card's form).
fn normalized(text: &str) -> String {
    let t = text.trim_end_matches('\u{6}').trim_matches(|c: char| c == '\r' || c == '\n' || c == ' ');
    t.strip_prefix('\u{7}').filter(|rest| rest.starts_with("ERR")).unwrap_or(t).to_ascii_uppercase()
}

fuzz_target!(|data: &[u8]| {
    if let Ok(text) = std::str::from_utf8(data) {
        match decode(text) {
            Ok(reply) => {
                let again = encode(reply);
                assert_eq!(normalized(&again), normalized(text), "{reply:?} encodes to another text");
                assert_eq!(decode(&again), Ok(reply), "`{}` does not decode back", again.escape_debug());
            }
            Err(e) => assert!(!e.0.is_empty(), "a refusal without a reason"),
        }
    }

    // A reply built from the bytes: encode, then decode.
    let word = |b: &[u8]| b.iter().fold(0u32, |w, &x| (w << 8) | u32::from(x));
    let reply = match data.first().map(|b| b % 3) {
        Some(0) if data.len() >= 7 => StatusReply::Words { x: word(&data[1..4]), y: word(&data[4..7]) },
        // Any u16: a number without a three-digit form cannot be made at all.
        Some(1) if data.len() >= 3 => {
            let n = word(&data[1..3]) as u16;
            match ErrorNumber::new(n) {
                Some(e) => StatusReply::Error(e),
                None => {
                    assert!(n > 999, "ERR{n:03} has a text form but cannot be made");
                    return;
                }
            }
        }
        Some(2) => StatusReply::Bootstrap,
        _ => return,
    };
    let text = encode(reply);
    assert_eq!(decode(&text), Ok(reply), "`{}` does not decode back", text.escape_debug());
});
