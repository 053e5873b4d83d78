//! Host-log import, `pmacwd_capture::import::import` (the `Importer`, line by line).
//!
//! Invariants:
//! - no panic; an error names the log, at a 1-based line inside it;
//! - an imported trace is a trace this project reads: written as JSON Lines it reads back
//!   equal (through `Debug`), and so does its YAML form;
//! - the trace has a `command` step for every command of the log (a `> ` line holds one or
//!   more), and at least one per `> ` line.
#![no_main]

use libfuzzer_sys::fuzz_target;
use pmacwd_capture::import::import;
use pmacwd_fuzz::{check_error, newline_lines};
use pmacwd_specs::vocab::event::Event;
use pmacwd_trace::{jsonl, parse_yaml, to_yaml, TraceEvent};
use std::path::Path;

fuzz_target!(|data: &[u8]| {
    let Ok(text) = std::str::from_utf8(data) else { return };
    let file = Path::new("fuzz.log");
    let imported = match import(file, text, "i40-zero") {
        Ok(t) => t,
        Err(e) => return check_error(&e, file, newline_lines(data)),
    };
    let trace = imported.trace;
    // A command the card answered, or one the host gave up on (`unanswered`, UM p.236).
    let commands = trace
        .steps
        .iter()
        .filter(|s| matches!(s.event, TraceEvent::Model(Event::Command(_)) | TraceEvent::Unanswered { .. }))
        .count();
    let sent = text.lines().filter(|l| l.trim_end().starts_with("> ")).count();
    assert_eq!(commands as u64, imported.summary.commands, "not one command step per command");
    assert!(commands >= sent, "a `> ` line without a command step");

    let lines = jsonl::to_jsonl(&trace);
    let back = match jsonl::read_all(Path::new("fuzz.jsonl"), lines.as_bytes()) {
        Ok(t) => t,
        Err(e) => panic!("an imported trace, written as JSON Lines, is refused: {e}\n{lines}"),
    };
    assert_eq!(format!("{trace:?}"), format!("{back:?}"), "the JSON Lines form changed the trace:\n{lines}");

    let yaml = to_yaml(&trace);
    let again = match parse_yaml(Path::new("fuzz.yaml"), &yaml) {
        Ok(l) => l.trace,
        Err(e) => panic!("an imported trace, written as YAML, is refused: {e}\n{yaml}"),
    };
    assert_eq!(format!("{trace:?}"), format!("{again:?}"), "the YAML form changed the trace:\n{yaml}");
});
