//! Command lines and reply framing, `pmacwd_emulator::framing`.
//!
//! (Command lines are read by the card's grammar, fuzzed by `card_grammar`.)
//!
//! Invariants, on the same input two ways:
//! - `parse_reply` (the bytes as a reply): no panic; a message holds no CR; an error number
//!   was written as three digits (`ERRnnn`); an error ends the reply, so a reply with one is
//!   not acknowledged, and an acknowledged reply ends with ACK or LF;
//! - `Framing` then `parse_reply` (answers built from the bytes, under the I3 and I6 they
//!   choose, signs and high bits included): the reply reads back to its answers, acknowledged
//!   exactly when it ends a valid line under I3 = 1, 2 or 3.
#![no_main]

use libfuzzer_sys::fuzz_target;
use pmacwd_emulator::framing::{parse_reply, Answer, Framing, ReadAnswer};

fuzz_target!(|data: &[u8]| {
    // parse_reply on the raw bytes.
    match parse_reply(data) {
        Ok(reply) => {
            for a in &reply.answers {
                match a {
                    ReadAnswer::Data(t) => assert!(!t.contains('\r'), "a message with a CR: {t:?}"),
                    ReadAnswer::Error(Some(n)) => {
                        let written = format!("ERR{n:03}");
                        assert!(
                            data.windows(written.len()).any(|w| w == written.as_bytes()),
                            "error {n} read from `{}`, which does not hold {written}",
                            data.escape_ascii()
                        );
                    }
                    ReadAnswer::Error(None) => {}
                }
            }
            let error = reply.answers.iter().position(|a| matches!(a, ReadAnswer::Error(_)));
            if let Some(i) = error {
                assert_eq!(i + 1, reply.answers.len(), "answers after an error");
                assert!(!reply.acknowledged, "an error, acknowledged");
            }
            if reply.acknowledged {
                assert!(matches!(data.last(), Some(0x06 | 0x0A)));
            }
        }
        Err(reason) => assert!(!reason.is_empty()),
    }

    // Framing, then parse_reply.
    let [i3, i6, rest @ ..] = data else { return };
    let framing = Framing { i3: i64::from(*i3 as i8), i6: i64::from(*i6 as i8) };
    let mut out = Vec::new();
    let mut expected = Vec::new();
    let mut error = false;
    for chunk in rest.split(|&b| b == 0xFF) {
        let Some((&tag, body)) = chunk.split_first() else { continue };
        let answer = match tag % 4 {
            0 => Answer::Nothing,
            1 => {
                let n = (u16::from_be_bytes([body.first().copied().unwrap_or(0), body.get(1).copied().unwrap_or(0)]))
                    % 1000;
                Answer::Error(n)
            }
            _ => Answer::Data(String::from_utf8_lossy(body).chars().filter(|c| !c.is_control()).collect()),
        };
        framing.push_answer(&mut out, &answer);
        match answer {
            Answer::Nothing => {}
            Answer::Data(t) => expected.push(ReadAnswer::Data(t)),
            Answer::Error(n) => {
                expected.push(ReadAnswer::Error((framing.i6 & 1 == 1).then_some(n)));
                // An error ends the line: nothing after it, no acknowledgement.
                error = true;
                break;
            }
        }
    }
    if !error {
        framing.push_line_end(&mut out);
    }
    let reply = parse_reply(&out).unwrap_or_else(|e| panic!("{framing:?}: `{}` refused: {e}", out.escape_ascii()));
    assert_eq!(reply.answers, expected, "{framing:?}: `{}`", out.escape_ascii());
    assert_eq!(reply.acknowledged, !error && framing.i3 & 3 != 0, "{framing:?}: `{}`", out.escape_ascii());
});
