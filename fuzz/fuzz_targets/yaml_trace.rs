//! The YAML trace reader, `pmacwd_trace::parse_yaml`.
//!
//! Invariants:
//! - no panic; an error names the file, at a 1-based line inside the text;
//! - an accepted trace, written back with `to_yaml`, reads again, equal (compared field by
//!   field through `Debug`, which shows every field), and writes the same YAML a second time;
//! - it also survives the other format: `to_jsonl`, then `jsonl::read_all`, gives it back.
#![no_main]

use libfuzzer_sys::fuzz_target;
use pmacwd_fuzz::{check_error, yaml_lines};
use pmacwd_trace::{jsonl, parse_yaml, to_yaml};
use std::path::Path;

fuzz_target!(|data: &[u8]| {
    let Ok(text) = std::str::from_utf8(data) else { return };
    let file = Path::new("fuzz.yaml");
    let trace = match parse_yaml(file, text) {
        Ok(loaded) => loaded.trace,
        Err(e) => return check_error(&e, file, yaml_lines(text)),
    };
    let written = to_yaml(&trace);
    let again = match parse_yaml(file, &written) {
        Ok(l) => l.trace,
        Err(e) => {
            panic!("an accepted trace, written by to_yaml, is refused: {e}\n--- input\n{text}\n--- written\n{written}")
        }
    };
    assert_eq!(format!("{trace:?}"), format!("{again:?}"), "to_yaml then parse_yaml changed the trace:\n{written}");
    assert_eq!(written, to_yaml(&again), "to_yaml is not stable");

    let lines = jsonl::to_jsonl(&trace);
    let back = match jsonl::read_all(Path::new("fuzz.jsonl"), lines.as_bytes()) {
        Ok(t) => t,
        Err(e) => panic!("an accepted YAML trace, written by to_jsonl, is refused: {e}\n{lines}"),
    };
    assert_eq!(format!("{trace:?}"), format!("{back:?}"), "to_jsonl then read_all changed the trace:\n{lines}");
});
