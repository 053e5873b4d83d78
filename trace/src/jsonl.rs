//! The JSON Lines form of a trace, for long captures: a header object on the first line, then
//! one step per line, in the same vocabulary as the YAML form (`docs/trace-format.md`).
//! [`StepReader`] reads it one line at a time, so memory does not grow with the trace.

use crate::{CardConfig, Expect, Step, Trace, TraceEvent, FORMAT_VERSION};
use pmacwd_specs::check::{ChecksumTarget, ProfileSelection, ResetKind};
use pmacwd_specs::cite::Cites;
use pmacwd_specs::input::Lines;
use pmacwd_specs::vocab::event::Event;
use pmacwd_specs::{Position, SpecError};
use serde::Deserialize;
use std::io::BufRead;
use std::path::{Path, PathBuf};

/// The first line.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Header {
    /// Always `pmacwd-trace`: tells a trace from any other JSON Lines file.
    pub format: String,
    pub version: u32,
    pub description: String,
    #[serde(default)]
    pub cite: Option<Cites>,
    pub configuration: String,
    /// What the capture says about the card (`docs/trace-format.md`).
    #[serde(default)]
    pub card: Option<CardConfig>,
    pub profiles: ProfileSelection,
}

impl Header {
    /// The trace this header begins, with `steps`, and the `card:` it carries beside the trace.
    fn into_trace(self, steps: Vec<Step>) -> (Trace, Option<CardConfig>) {
        let Header { format: _, version, description, cite, configuration, card, profiles } = self;
        (Trace { version, description, cite, configuration, profiles, steps }, card)
    }
}

/// Reads steps one line at a time; each line at most [`pmacwd_specs::input::LINE_BYTES_MAX`]
/// bytes, so memory stays bounded whatever the file holds.
pub struct StepReader<R: BufRead> {
    file: PathBuf,
    lines: Lines<R>,
    /// The header's line, where a trace without steps is refused.
    header_line: usize,
    /// Steps read so far (only whether there was one matters).
    steps: u64,
    pub header: Header,
}

fn json_error(file: &Path, line: usize, e: &serde_json::Error) -> SpecError {
    // serde_json counts lines within the text it was given: one line here.
    let msg = e.to_string();
    let msg = match msg.rfind(" at line ") {
        Some(i) => msg[..i].to_string(),
        None => msg,
    };
    SpecError::at(file, Position { line, column: e.column().max(1) }, msg)
}

impl<R: BufRead> StepReader<R> {
    pub fn new(file: &Path, input: R) -> Result<Self, SpecError> {
        let mut lines = Lines::new(file, input);
        let (line, text) = loop {
            match lines.next()? {
                None => return Err(SpecError::whole_file(file, "empty trace: the first line must be the header")),
                Some((_, t)) if t.trim().is_empty() => continue,
                Some(l) => break l,
            }
        };
        let header: Header = serde_json::from_str(&text).map_err(|e| json_error(file, line, &e))?;
        let at = Position { line, column: 1 };
        if header.format != "pmacwd-trace" {
            return Err(SpecError::at(file, at, format!("`format` is `{}`, expected `pmacwd-trace`", header.format)));
        }
        if header.version != FORMAT_VERSION {
            return Err(SpecError::at(
                file,
                at,
                format!("trace format version {} is not supported (this build reads {FORMAT_VERSION})", header.version),
            ));
        }
        if let ProfileSelection::Named(names) = &header.profiles {
            if names.is_empty() {
                return Err(SpecError::at(
                    file,
                    at,
                    "an empty profile list runs nothing: name profiles, or write \"all\"",
                ));
            }
        }
        Ok(StepReader { file: file.to_path_buf(), lines, header_line: line, steps: 0, header })
    }

    /// The next step and its line number; `None` at the end. Blank lines are allowed. A header
    /// followed by no step is an error at the header's line, as the YAML form refuses
    /// `steps: []`: a trace without steps checks nothing, and would pass.
    pub fn next_step(&mut self) -> Result<Option<(usize, Step)>, SpecError> {
        loop {
            let Some((line, text)) = self.lines.next()? else {
                if self.steps == 0 {
                    return Err(SpecError::at(
                        &self.file,
                        Position { line: self.header_line, column: 1 },
                        "a trace needs at least one step: no step follows the header",
                    ));
                }
                return Ok(None);
            };
            if text.trim().is_empty() {
                continue;
            }
            let step: Step = serde_json::from_str(&text).map_err(|e| json_error(&self.file, line, &e))?;
            self.steps += 1;
            return Ok(Some((line, step)));
        }
    }
}

/// Reads a whole JSON Lines trace into memory with the line of every step, as a
/// [`crate::LoadedTrace`] like a YAML one: its header keys at the header's line, `steps.N` at
/// step N's line, so that what reports positions (a divergence's step and line) works for both
/// forms. For traces short enough to hold (`pmacwd run`); `replay` streams with [`StepReader`].
pub fn load_text(file: &Path, text: &str) -> Result<crate::LoadedTrace, SpecError> {
    let mut reader = StepReader::new(file, text.as_bytes())?;
    let header_at = Position { line: reader.header_line, column: 1 };
    let mut positions: Vec<(String, Position)> =
        ["version", "description", "cite", "configuration", "card", "profiles", "steps"]
            .iter()
            .map(|k| (k.to_string(), header_at))
            .collect();
    let mut steps = Vec::new();
    while let Some((line, step)) = reader.next_step()? {
        positions.push((format!("steps.{}", steps.len()), Position { line, column: 1 }));
        steps.push(step);
    }
    let (trace, card) = reader.header.into_trace(steps);
    let map = pmacwd_specs::yaml::SourceMap::from_positions(file, positions);
    Ok(crate::LoadedTrace { trace, map, card })
}

/// Reads a whole JSON Lines trace into memory (for short traces and tests).
pub fn read_all(file: &Path, input: impl BufRead) -> Result<Trace, SpecError> {
    let mut reader = StepReader::new(file, input)?;
    let mut steps = Vec::new();
    while let Some((_, step)) = reader.next_step()? {
        steps.push(step);
    }
    Ok(reader.header.into_trace(steps).0)
}

/// The header line of `trace`.
pub fn header_line(trace: &Trace) -> String {
    header_line_with_card(trace, None)
}

/// [`header_line`] with the optional `card` key (written only when some field is set).
pub fn header_line_with_card(trace: &Trace, card: Option<&CardConfig>) -> String {
    let profiles = match &trace.profiles {
        ProfileSelection::Keyword(_) => serde_json::json!("all"),
        ProfileSelection::Named(n) => serde_json::json!(n),
    };
    let mut v = serde_json::json!({
        "format": "pmacwd-trace", "version": trace.version, "description": trace.description,
        "configuration": trace.configuration, "profiles": profiles,
    });
    if let Some(card) = card.filter(|c| !c.is_empty()) {
        let fields: serde_json::Map<String, serde_json::Value> =
            card.fields().into_iter().map(|(k, v)| (k.to_string(), serde_json::json!(v))).collect();
        v["card"] = serde_json::Value::Object(fields);
    }
    if let Some(c) = &trace.cite {
        v["cite"] = serde_json::json!(c.0.iter().map(|c| c.to_string()).collect::<Vec<_>>());
    }
    v.to_string()
}

/// One step as a line.
pub fn step_line(step: &Step) -> String {
    let event = match &step.event {
        TraceEvent::Run { cycles } => serde_json::json!({ "run": cycles }),
        TraceEvent::Elapsed { cycles_min, cycles_max: Some(max) } if max == cycles_min => {
            serde_json::json!({ "elapsed": cycles_min })
        }
        TraceEvent::Elapsed { cycles_min, cycles_max: Some(max) } => {
            serde_json::json!({ "elapsed": { "min": cycles_min, "max": max } })
        }
        TraceEvent::Elapsed { cycles_min, cycles_max: None } => serde_json::json!({ "elapsed": { "min": cycles_min } }),
        TraceEvent::Restart => serde_json::json!({ "restart": 1 }),
        TraceEvent::RestartPossible => serde_json::json!({ "possible_restart": 1 }),
        TraceEvent::Unanswered { command, wait_cycles } => {
            serde_json::json!({ "unanswered": { "command": command.to_string(), "wait": wait_cycles } })
        }
        TraceEvent::Model(e) => model_event_json(e),
    };
    let mut v = event;
    if let Some(n) = &step.note {
        v["note"] = serde_json::json!(n);
    }
    if !step.expect.is_empty() {
        v["expect"] = expect_json(&step.expect);
    }
    v.to_string()
}

fn model_event_json(e: &Event) -> serde_json::Value {
    match e {
        Event::Servo { cycles } => serde_json::json!({ "servo": cycles }),
        Event::Background => serde_json::json!({ "background": 1 }),
        Event::ClearRtiReentry => serde_json::json!({ "clear_rti_reentry": 1 }),
        Event::Load(l) => {
            serde_json::json!({ "load": { "motors": l.motors, "plc0_units": l.plc0_units, "background_units": l.background_units } })
        }
        Event::Command(c) => serde_json::json!({ "command": c.to_string() }),
        Event::Supply { millivolts } => serde_json::json!({ "supply_mv": millivolts }),
        Event::Reset(r) => serde_json::json!({ "reset": {
            "kind": match r.kind { ResetKind::Init => "init", ResetKind::Power => "power" },
            "dpram_fault": r.dpram_fault, "flash_fault": r.flash_fault, "bootstrap": r.bootstrap } }),
        Event::ChecksumFault(ChecksumTarget::Firmware) => serde_json::json!({ "checksum_fault": "firmware" }),
        Event::ChecksumFault(ChecksumTarget::UserProgram) => serde_json::json!({ "checksum_fault": "user_program" }),
        Event::EncoderInput(i) => serde_json::json!({ "encoder": { "motor": i.motor, "lost": i.lost } }),
        Event::AmplifierFault(i) => serde_json::json!({ "amplifier_fault": { "motor": i.motor, "fault": i.fault } }),
    }
}

fn expect_json(e: &Expect) -> serde_json::Value {
    // Destructured without `..`: a new expectation is a compile error here until it is written.
    let Expect {
        reply,
        tripped,
        led_red,
        fefco_on,
        relay_tripped,
        outputs_forced_off,
        counter,
        counter_min,
        running_checksum,
        window_cycles,
        status_set,
        status_clear,
        motors,
        encoder_loss,
    } = e;
    let mut m = serde_json::Map::new();
    if let Some(r) = reply {
        m.insert("reply".into(), serde_json::json!(r));
    }
    for (k, v) in [
        ("tripped", tripped),
        ("led_red", led_red),
        ("fefco_on", fefco_on),
        ("relay_tripped", relay_tripped),
        ("outputs_forced_off", outputs_forced_off),
    ] {
        if let Some(v) = v {
            m.insert(k.into(), serde_json::json!(v));
        }
    }
    if let Some(v) = window_cycles {
        m.insert("window_cycles".into(), serde_json::json!(v));
    }
    if let Some(v) = counter {
        m.insert("counter".into(), serde_json::json!(v));
    }
    if let Some(v) = counter_min {
        m.insert("counter_min".into(), serde_json::json!(v));
    }
    if let Some(v) = running_checksum {
        m.insert("running_checksum".into(), serde_json::json!(v));
    }
    if !status_set.is_empty() {
        m.insert("status_set".into(), serde_json::json!(status_set));
    }
    if !status_clear.is_empty() {
        m.insert("status_clear".into(), serde_json::json!(status_clear));
    }
    if !motors.is_empty() {
        m.insert("motors".into(), serde_json::json!(motors));
    }
    if !encoder_loss.is_empty() {
        m.insert("encoder_loss".into(), serde_json::json!(encoder_loss));
    }
    serde_json::Value::Object(m)
}

/// The whole trace as JSON Lines.
pub fn to_jsonl(trace: &Trace) -> String {
    let mut s = header_line(trace);
    s.push('\n');
    for step in &trace.steps {
        s.push_str(&step_line(step));
        s.push('\n');
    }
    s
}
