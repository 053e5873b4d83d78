//! The JSON Lines trace reader, `pmacwd_trace::jsonl::read_all`, on arbitrary bytes.
//!
//! Invariants:
//! - no panic; an error names the file, at a 1-based line inside the input;
//! - an accepted trace, written with `to_jsonl`, reads back equal (through `Debug`) and writes
//!   the same lines again;
//! - it also survives the YAML form (`to_yaml`, `parse_yaml`); both readers refuse a trace
//!   without steps, so every accepted trace has one.
#![no_main]

use libfuzzer_sys::fuzz_target;
use pmacwd_fuzz::{check_error, newline_lines};
use pmacwd_trace::{jsonl, parse_yaml, to_yaml};
use std::path::Path;

fuzz_target!(|data: &[u8]| {
    let file = Path::new("fuzz.jsonl");
    let trace = match jsonl::read_all(file, data) {
        Ok(t) => t,
        Err(e) => return check_error(&e, file, newline_lines(data)),
    };
    let lines = jsonl::to_jsonl(&trace);
    let back = match jsonl::read_all(file, lines.as_bytes()) {
        Ok(t) => t,
        Err(e) => panic!("an accepted trace, written by to_jsonl, is refused: {e}\n{lines}"),
    };
    assert_eq!(format!("{trace:?}"), format!("{back:?}"), "to_jsonl then read_all changed the trace:\n{lines}");
    assert_eq!(lines, jsonl::to_jsonl(&back), "to_jsonl is not stable");

    assert!(!trace.steps.is_empty(), "a trace without steps was accepted:\n{lines}");
    let yaml = to_yaml(&trace);
    let again = match parse_yaml(Path::new("fuzz.yaml"), &yaml) {
        Ok(l) => l.trace,
        Err(e) => panic!("an accepted JSON Lines trace, written by to_yaml, is refused: {e}\n{yaml}"),
    };
    assert_eq!(format!("{trace:?}"), format!("{again:?}"), "to_yaml then parse_yaml changed the trace:\n{yaml}");
});
