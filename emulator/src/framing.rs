//! Command lines and how a Turbo PMAC frames its answers to them.
//!
//! A host sends a line of one or more commands separated by spaces (`i6=1 i3=2 ver`). The card
//! answers each command that reports data with one message, and ends the line with its
//! acknowledgement; both follow I3 (SRM p.37-38) and errors follow I6 (PMAC2 SRM p.25, whose I6
//! text the Turbo card shares):
//!
//! | I3 | a message | end of a valid line |
//! |---|---|---|
//! | 0 | `DATA CR` | nothing |
//! | 1 | `LF DATA CR` | `LF` |
//! | 2 | `DATA CR` | `ACK` |
//! | 3 | `LF DATA CR` | `ACK` |
//!
//! | I6 | an error |
//! |---|---|
//! | 0, 2 | `BEL` |
//! | 1 | `BEL ERRnnn CR` |
//! | 3 | `BEL CR ERRnnn CR` |
//!
//! With I3 = 1 or 3 an error message also has an `LF` in front of it. An error ends the line:
//! the commands after it are not executed and no acknowledgement follows (MODEL: the manuals
//! show the `BEL` in place of the acknowledgement; that the rest of the line is dropped is this
//! emulator's reading, and `pmacwd record` assumes the same when it aligns answers).

/// I3 and I6 range 0 to 3 (SRM p.37 for I3; PMAC2 SRM p.25 for I6, whose text the Turbo card
/// shares). MODEL: the manuals do not say what the card does with a write outside the range.
/// The emulator answers ERR003 ("data error or unrecognized command") and leaves the variable
/// as it was, as the model and the core do for I8, I40 and I41. Keeping only the two low bits
/// instead would turn `I3=4` into I3 = 0, under which a valid line gets no acknowledgement at
/// all and a client waiting for one hangs.
pub const FRAMING_VALUE_MAX: i64 = 3;

/// Whether writing `value` to I-variable `n` is refused as outside the range of I3 or I6.
pub fn framing_write_out_of_range(n: u16, value: i64) -> bool {
    matches!(n, 3 | 6) && !(0..=FRAMING_VALUE_MAX).contains(&value)
}

pub const LF: u8 = 0x0A;
pub const CR: u8 = 0x0D;
pub const ACK: u8 = 0x06;
pub const BEL: u8 = 0x07;

/// What one command produced, before framing.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Answer {
    /// Nothing to report (a write, `OPEN`, `CLOSE`, `$$$`).
    Nothing,
    /// A message: `001000000000`, `4096`, `000FFF`, `1.947`.
    Data(String),
    /// An error number (3: data error or unrecognized command).
    Error(u16),
}

/// The I3 and I6 values a reply is framed under.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Framing {
    pub i3: i64,
    pub i6: i64,
}

impl Framing {
    /// Only the two low bits of I3 and I6 select a mode (their range is 0 to 3, and writes
    /// outside it are refused: [`FRAMING_VALUE_MAX`]; saved values are checked too).
    fn i3(self) -> i64 {
        self.i3 & 3
    }
    fn i6(self) -> i64 {
        self.i6 & 3
    }

    /// One command's answers, framed, up to and including the first error (the card stops
    /// answering there); and whether there was one.
    pub fn answers(self, answers: &[Answer]) -> (Vec<u8>, bool) {
        let mut out = Vec::new();
        for answer in answers {
            self.push_answer(&mut out, answer);
            if let Answer::Error(_) = answer {
                return (out, true);
            }
        }
        (out, false)
    }

    /// Appends one command's answer.
    pub fn push_answer(self, out: &mut Vec<u8>, answer: &Answer) {
        let lf = matches!(self.i3(), 1 | 3);
        match answer {
            Answer::Nothing => {}
            Answer::Data(text) => {
                if lf {
                    out.push(LF);
                }
                out.extend_from_slice(text.as_bytes());
                out.push(CR);
            }
            Answer::Error(n) => {
                out.push(BEL);
                let message = format!("ERR{n:03}");
                match self.i6() {
                    1 | 3 => {
                        if self.i6() == 3 {
                            out.push(CR);
                        }
                        if lf {
                            out.push(LF);
                        }
                        out.extend_from_slice(message.as_bytes());
                        out.push(CR);
                    }
                    _ => {}
                }
            }
        }
    }

    /// Appends the acknowledgement that ends a valid line.
    pub fn push_line_end(self, out: &mut Vec<u8>) {
        match self.i3() {
            1 => out.push(LF),
            2 | 3 => out.push(ACK),
            _ => {}
        }
    }
}

/// One answer read back from a reply, the inverse of [`Framing`] for any I3 and I6.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum ReadAnswer {
    Data(String),
    /// `None` when the card reported the error by `BEL` alone (I6 = 0 or 2).
    Error(Option<u16>),
}

/// A reply split into its answers, and whether it ended with an acknowledgement (`ACK`, or the
/// `LF` of I3 = 1) rather than an error.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct ParsedReply {
    pub answers: Vec<ReadAnswer>,
    pub acknowledged: bool,
}

/// Reads a reply as a host receives it. `Err` names what does not fit the framing (for a
/// capture note: the reply is kept, its answers are not compared).
pub fn parse_reply(bytes: &[u8]) -> Result<ParsedReply, String> {
    let mut answers = Vec::new();
    let mut i = 0;
    let mut acknowledged = false;
    while i < bytes.len() {
        match bytes[i] {
            ACK => {
                acknowledged = true;
                i += 1;
                if i != bytes.len() {
                    return Err(format!("{} bytes after the ACK", bytes.len() - i));
                }
            }
            LF if i + 1 == bytes.len() => {
                // I3 = 1: the final LF is the acknowledgement.
                acknowledged = true;
                i += 1;
            }
            LF => i += 1,
            BEL => {
                i += 1;
                let mut j = i;
                while j < bytes.len() && (bytes[j] == CR || bytes[j] == LF) {
                    j += 1;
                }
                if bytes[j..].starts_with(b"ERR") {
                    let digits = bytes.get(j + 3..j + 6).ok_or("an ERR without three digits")?;
                    if !digits.iter().all(u8::is_ascii_digit) {
                        // Digits only: `parse` would also take a sign (`ERR+03`).
                        return Err(format!("`ERR{}` is not ERRnnn", digits.escape_ascii()));
                    }
                    let text = std::str::from_utf8(digits).map_err(|_| "an ERR without three digits")?;
                    let n: u16 = text.parse().map_err(|_| format!("`ERR{}` is not ERRnnn", text.escape_debug()))?;
                    answers.push(ReadAnswer::Error(Some(n)));
                    i = j + 6;
                    if bytes.get(i) == Some(&CR) {
                        i += 1;
                    }
                } else {
                    answers.push(ReadAnswer::Error(None));
                }
                if i != bytes.len() {
                    return Err(format!("{} bytes after an error", bytes.len() - i));
                }
            }
            _ => {
                let end = bytes[i..]
                    .iter()
                    .position(|&b| b == CR)
                    .ok_or_else(|| format!("a message without its CR: `{}`", String::from_utf8_lossy(&bytes[i..])))?;
                let text = std::str::from_utf8(&bytes[i..i + end]).map_err(|_| "a message that is not text")?;
                answers.push(ReadAnswer::Data(text.to_string()));
                i += end + 1;
            }
        }
    }
    Ok(ParsedReply { answers, acknowledged })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn framed(i3: i64, i6: i64, answers: &[Answer], end: bool) -> Vec<u8> {
        let f = Framing { i3, i6 };
        let mut out = Vec::new();
        for a in answers {
            f.push_answer(&mut out, a);
        }
        if end {
            f.push_line_end(&mut out);
        }
        out
    }

    #[test]
    fn the_manual_examples_of_i3_frame_as_printed() {
        // SRM p.38: `P1..3` answered `25<CR>50<CR>75<CR><ACK>` under I3 = 2, with an LF before
        // each message under I3 = 3.
        let data: Vec<Answer> = ["25", "50", "75"].iter().map(|s| Answer::Data(s.to_string())).collect();
        assert_eq!(framed(2, 1, &data, true), b"25\r50\r75\r\x06");
        assert_eq!(framed(3, 1, &data, true), b"\n25\r\n50\r\n75\r\x06");
        assert_eq!(framed(0, 1, &data, true), b"25\r50\r75\r");
        assert_eq!(framed(1, 1, &data, true), b"\n25\r\n50\r\n75\r\n");
        // A valid command without data: only the acknowledgement.
        assert_eq!(framed(2, 1, &[Answer::Nothing], true), b"\x06");
    }

    #[test]
    fn errors_follow_i6() {
        assert_eq!(framed(2, 1, &[Answer::Error(3)], false), b"\x07ERR003\r");
        assert_eq!(framed(2, 0, &[Answer::Error(3)], false), b"\x07");
        assert_eq!(framed(2, 3, &[Answer::Error(3)], false), b"\x07\rERR003\r");
        assert_eq!(framed(3, 1, &[Answer::Error(3)], false), b"\x07\nERR003\r");
    }

    #[test]
    fn every_framing_reads_back_to_its_answers() {
        // The capture writer relies on this inverse for every I3 and I6.
        let answers = [Answer::Data("1.947".into()), Answer::Nothing, Answer::Data("000FFF".into())];
        for i3 in 0..4 {
            for i6 in 0..4 {
                let parsed = parse_reply(&framed(i3, i6, &answers, true)).unwrap();
                assert_eq!(parsed.answers, vec![ReadAnswer::Data("1.947".into()), ReadAnswer::Data("000FFF".into())]);
                assert_eq!(parsed.acknowledged, i3 != 0, "I3={i3}");
                let parsed = parse_reply(&framed(i3, i6, &[answers[0].clone(), Answer::Error(3)], false)).unwrap();
                let code = if i6 & 1 == 1 { Some(3) } else { None };
                assert_eq!(
                    parsed.answers,
                    vec![ReadAnswer::Data("1.947".into()), ReadAnswer::Error(code)],
                    "I3={i3} I6={i6}"
                );
                assert!(!parsed.acknowledged);
            }
        }
    }

    #[test]
    fn an_error_number_is_three_digits_and_a_sign_is_not_one() {
        // Found by the fuzz target framing: `BEL ERR+03` was read as ERR003, an error number
        // the card never printed that way.
        for reply in [&b"\x07ERR+03"[..], b"\x07ERR-03\r", b"\x07ERR 03\r", b"\x07\rERR+3\r"] {
            let e = parse_reply(reply).unwrap_err();
            assert!(e.contains("is not ERRnnn"), "{}: {e}", reply.escape_ascii());
        }
        assert_eq!(parse_reply(b"\x07ERR003\r").unwrap().answers, [ReadAnswer::Error(Some(3))]);
    }

    #[test]
    fn replies_that_break_the_framing_are_refused_with_the_reason() {
        assert!(parse_reply(b"1.947").unwrap_err().contains("without its CR"));
        assert!(parse_reply(b"\x07ERR0").unwrap_err().contains("three digits"));
        assert!(parse_reply(b"\x06\x06").unwrap_err().contains("after the ACK"));
    }
}
