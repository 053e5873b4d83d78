//! `pmacwd decode`: a `???` reply explained bit by bit from `specs/status.yaml`.

use pmacwd_specs::status::WordId;
use pmacwd_specs::vocab::reply_text::{decode, DecodeError, StatusReply};
use pmacwd_specs::Spec;
use std::fmt::Write as _;

/// First-word bits the EPICS pmac driver (`pmacHardwareTurbo.cpp`) treats as a hardware problem:
/// 9, 10, 11, 13, 15, 20 (mask 0x10AE00).
pub const EPICS_HARDWARE_PROBLEM_BITS: [u8; 6] = [9, 10, 11, 13, 15, 20];

pub fn epics_mask() -> u32 {
    EPICS_HARDWARE_PROBLEM_BITS.iter().fold(0, |m, b| m | 1 << b)
}

/// One set bit, with its description.
pub struct SetBit {
    pub word: WordId,
    pub bit: u8,
    pub name: String,
    pub meaning: String,
    pub cite: String,
}

pub struct Decoded {
    pub text: String,
    pub reply: StatusReply,
    pub set: Vec<SetBit>,
    /// The EPICS mask bits that are set.
    pub epics_flagged: Vec<u8>,
}

pub fn explain(spec: &Spec, text: &str) -> Result<Decoded, DecodeError> {
    let reply = decode(text)?;
    let mut set = Vec::new();
    let mut epics_flagged = Vec::new();
    if let StatusReply::Words { x, y } = reply {
        for (word, value) in [(WordId::X, x), (WordId::Y, y)] {
            for bit in (0..24u8).rev() {
                if value & (1 << bit) != 0 {
                    let entry = spec.status.entry(word, bit).expect("validated: all 24 bits described");
                    set.push(SetBit {
                        word,
                        bit,
                        name: entry.name.clone(),
                        meaning: entry.meaning.trim().to_string(),
                        cite: entry.cite.to_string(),
                    });
                }
            }
        }
        epics_flagged = EPICS_HARDWARE_PROBLEM_BITS.iter().copied().filter(|b| x & (1 << b) != 0).collect();
    }
    Ok(Decoded { text: text.to_string(), reply, set, epics_flagged })
}

fn word_name(w: WordId) -> &'static str {
    match w {
        WordId::X => "X:$000006",
        WordId::Y => "Y:$000006",
    }
}

pub fn to_text(d: &Decoded) -> String {
    let mut s = String::new();
    match d.reply {
        StatusReply::Bootstrap => {
            s.push_str("BOOTSTRAP PROM: the card is in bootstrap mode (SRM p.289); no status words.\n");
            return s;
        }
        StatusReply::Error(n) => {
            let _ = writeln!(
                s,
                "ERR{n}: an error reply, not status words (ERR003 is \"data error or unrecognized command\")."
            );
            return s;
        }
        StatusReply::Words { x, y } => {
            let _ = writeln!(s, "first word  X:$000006 = {x:06X}\nsecond word Y:$000006 = {y:06X}");
        }
    }
    if d.set.is_empty() {
        s.push_str("no bit is set\n");
    }
    for b in &d.set {
        let _ = writeln!(
            s,
            "{} bit {:>2}  {:<28} {}  [{}]",
            word_name(b.word),
            b.bit,
            b.name,
            one_line(&b.meaning),
            b.cite
        );
    }
    let _ =
        write!(s, "EPICS pmac hardware-problem mask (first word bits 9, 10, 11, 13, 15, 20 = ${:06X}): ", epics_mask());
    if d.epics_flagged.is_empty() {
        s.push_str("not flagged\n");
    } else {
        let bits: Vec<String> = d.epics_flagged.iter().map(u8::to_string).collect();
        let _ = writeln!(s, "FLAGGED by bit {}", bits.join(", "));
    }
    s
}

fn one_line(text: &str) -> String {
    text.split_whitespace().collect::<Vec<_>>().join(" ")
}

pub fn to_json(d: &Decoded) -> String {
    let (kind, x, y, error) = match d.reply {
        StatusReply::Words { x, y } => ("status", Some(format!("{x:06X}")), Some(format!("{y:06X}")), None),
        StatusReply::Bootstrap => ("bootstrap", None, None, None),
        StatusReply::Error(n) => ("error", None, None, Some(n.get())),
    };
    let bits: Vec<serde_json::Value> = d
        .set
        .iter()
        .map(|b| {
            serde_json::json!({
                "word": word_name(b.word), "bit": b.bit, "name": b.name,
                "meaning": one_line(&b.meaning), "cite": b.cite,
            })
        })
        .collect();
    serde_json::json!({
        "reply": d.text, "kind": kind, "x": x, "y": y, "error": error, "set_bits": bits,
        "epics_hardware_problem": !d.epics_flagged.is_empty(), "epics_flagged_bits": d.epics_flagged,
    })
    .to_string()
}
