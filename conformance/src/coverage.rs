//! What a conformance run exercised: the kinds of model events applied, the status bits seen
//! set, the reference model's named properties reached (`sometimes`) or checked (`always`) on
//! the states the run went through, and the trip causes seen. `pmacwd conform` prints it.

use crate::subject::ModelSubject;
use pmacwd_model::checker::{State, WatchdogModel};
use pmacwd_model::controller::TripCause;
use pmacwd_model::properties::{Expectation, STATE_PROPERTIES};
use pmacwd_specs::check::{ChecksumTarget, ResetKind};
use pmacwd_specs::config::{ModelConfig, StatusLayout};
use pmacwd_specs::vocab::command::{Buffer, HostCommand};
use pmacwd_specs::vocab::event::Event;
use pmacwd_specs::Spec;
use std::collections::{BTreeMap, BTreeSet};
use std::fmt::Write as _;

/// Every kind of event the model knows, as the report names them.
pub const EVENT_KINDS: &[&str] = &[
    "servo (1 cycle)",
    "servo (2+ cycles)",
    "background",
    "load change",
    "??? (global status)",
    "I-variable read",
    "I-variable write",
    "register read",
    "$$$ (reset command)",
    "OPEN PLC",
    "OPEN PROG",
    "CLOSE",
    "$$$*** (re-initialize)",
    "CHECKSUM",
    "GATHER",
    "ENDGATHER",
    "memory write to an I-variable",
    "I-variable default (I{n}=*)",
    "the card's own command",
    "unrecognized command",
    "supply below minimum",
    "supply at or above minimum",
    "INIT/ pulse",
    "power cycle",
    "reset finding a DPRAM fault",
    "reset finding a flash fault",
    "reset into bootstrap",
    "firmware checksum fault",
    "user-program checksum fault",
    "clear bit 22",
    "motion command that starts motion",
    "stop command (UM p.217)",
    "encoder lost",
    "encoder restored",
    "amplifier fault",
    "amplifier fault cleared",
];

fn kind(cfg: &ModelConfig, e: &Event) -> Vec<&'static str> {
    match e {
        Event::Servo { cycles: 1 } => vec!["servo (1 cycle)"],
        Event::Servo { .. } => vec!["servo (2+ cycles)"],
        Event::Background => vec!["background"],
        Event::Load(_) => vec!["load change"],
        Event::Command(c) => vec![match c {
            HostCommand::GlobalStatus => "??? (global status)",
            HostCommand::ReadI(_) => "I-variable read",
            HostCommand::WriteI(..) => "I-variable write",
            HostCommand::ReadHex(_) => "register read",
            HostCommand::Reset => "$$$ (reset command)",
            HostCommand::Open(Buffer::Plc(_)) => "OPEN PLC",
            HostCommand::Open(Buffer::Program(_)) => "OPEN PROG",
            HostCommand::Close => "CLOSE",
            HostCommand::Motion(m) if m.stop_table_name().is_some() => "stop command (UM p.217)",
            HostCommand::Motion(_) => "motion command that starts motion",
            HostCommand::Reinitialize => "$$$*** (re-initialize)",
            HostCommand::Checksum => "CHECKSUM",
            HostCommand::Gather => "GATHER",
            HostCommand::EndGather => "ENDGATHER",
            HostCommand::WriteIMemory(..) => "memory write to an I-variable",
            HostCommand::DefaultI(_) => "I-variable default (I{n}=*)",
            HostCommand::Card { .. } => "the card's own command",
            HostCommand::Unrecognized(_) => "unrecognized command",
        }],
        Event::Supply { millivolts } if *millivolts < cfg.supply_min_millivolts => vec!["supply below minimum"],
        Event::Supply { .. } => vec!["supply at or above minimum"],
        Event::Reset(r) => {
            let mut v = vec![match r.kind {
                ResetKind::Init => "INIT/ pulse",
                ResetKind::Power => "power cycle",
            }];
            if r.dpram_fault {
                v.push("reset finding a DPRAM fault");
            }
            if r.flash_fault {
                v.push("reset finding a flash fault");
            }
            if r.bootstrap {
                v.push("reset into bootstrap");
            }
            v
        }
        Event::ChecksumFault(ChecksumTarget::Firmware) => vec!["firmware checksum fault"],
        Event::ChecksumFault(ChecksumTarget::UserProgram) => vec!["user-program checksum fault"],
        Event::ClearRtiReentry => vec!["clear bit 22"],
        Event::EncoderInput(i) if i.lost => vec!["encoder lost"],
        Event::EncoderInput(_) => vec!["encoder restored"],
        Event::AmplifierFault(i) if i.fault => vec!["amplifier fault"],
        Event::AmplifierFault(_) => vec!["amplifier fault cleared"],
    }
}

/// Counts gathered over a run.
#[derive(Default)]
pub struct Coverage {
    pub events: BTreeMap<&'static str, u64>,
    /// Stop command (UM p.217's name) -> times it met an executing program.
    pub stops_meeting_program: BTreeMap<&'static str, u64>,
    /// (word, bit) -> times seen set after an event.
    pub bits_set: BTreeMap<(char, u8), u64>,
    /// Property name -> states on which a `sometimes` property held.
    pub reached: BTreeMap<&'static str, u64>,
    /// Property name -> states on which an `always` property failed (a model bug if non-zero).
    pub always_failed: BTreeMap<&'static str, u64>,
    pub states_checked: u64,
    pub trips: BTreeSet<&'static str>,
    /// One checker per (configuration, profile), for the property predicates.
    models: BTreeMap<(String, String), WatchdogModel>,
}

impl Coverage {
    /// Records what one applied event exercised; `model` is the reference after it.
    pub fn record(&mut self, cfg: &ModelConfig, event: &Event, model: &ModelSubject) {
        for k in kind(cfg, event) {
            *self.events.entry(k).or_default() += 1;
        }
        if let Some(stop) = model.stop_met_program() {
            *self.stops_meeting_program.entry(stop).or_default() += 1;
        }
        let card = model.controller();
        let (x, y) = card.status_words(cfg);
        for (word, value) in [('X', x), ('Y', y)] {
            for bit in 0..24u8 {
                if value >> bit & 1 == 1 {
                    *self.bits_set.entry((word, bit)).or_default() += 1;
                }
            }
        }
        match card.trip {
            Some(TripCause::Undervoltage) => {
                self.trips.insert("undervoltage");
            }
            Some(TripCause::StrobeTimeout) => {
                self.trips.insert("strobe stopped (starvation)");
            }
            None => {}
        }
        let key = (cfg.configuration.clone(), cfg.profile.name.clone());
        let checker = self.models.entry(key).or_insert_with(|| WatchdogModel::new(cfg.clone()));
        let state = State { controller: card.clone(), violations: 0 };
        self.states_checked += 1;
        for p in STATE_PROPERTIES {
            let holds = (p.holds)(&checker.cfg, &state);
            match p.expectation {
                Expectation::Sometimes if holds => *self.reached.entry(p.name).or_default() += 1,
                Expectation::Always if !holds => *self.always_failed.entry(p.name).or_default() += 1,
                _ => {}
            }
        }
    }

    /// [`Coverage::report`] as JSON (`conform --format json`, `docs/commands.md`): the same
    /// counts, keyed by event kind, status bit and property name.
    pub fn report_json(&self, spec: &Spec) -> serde_json::Value {
        let events: serde_json::Map<String, serde_json::Value> =
            EVENT_KINDS.iter().map(|k| (k.to_string(), self.events.get(k).copied().unwrap_or(0).into())).collect();
        let mut bits = Vec::new();
        for (word, w) in [('X', &spec.status.words.x), ('Y', &spec.status.words.y)] {
            for (bit, b) in &w.bits {
                bits.push(serde_json::json!({
                    "word": word.to_string(), "bit": bit, "name": b.name,
                    "states_set": self.bits_set.get(&(word, *bit)).copied().unwrap_or(0),
                }));
            }
        }
        let count = |m: &BTreeMap<&'static str, u64>, e: Expectation| -> serde_json::Map<String, serde_json::Value> {
            STATE_PROPERTIES
                .iter()
                .filter(|p| p.expectation == e)
                .map(|p| (p.name.to_string(), m.get(p.name).copied().unwrap_or(0).into()))
                .collect()
        };
        serde_json::json!({
            "events": events,
            "stops_meeting_program": spec
                .stop_commands
                .rows
                .iter()
                .map(|r| (r.command.clone(), self.stops_meeting_program.get(r.command.as_str()).copied().unwrap_or(0).into()))
                .collect::<serde_json::Map<String, serde_json::Value>>(),
            "status_bits": bits,
            "driven_bits": StatusLayout::of(spec).map_or(0, |l| l.driven().len()),
            "sometimes_reached": count(&self.reached, Expectation::Sometimes),
            "always_failed": count(&self.always_failed, Expectation::Always),
            "states_checked": self.states_checked,
            "trips": self.trips.iter().collect::<Vec<_>>(),
        })
    }

    /// The report: every event kind, status bit and property, with what the run did to it.
    pub fn report(&self, spec: &Spec) -> String {
        let mut s = String::new();
        let seen = EVENT_KINDS.iter().filter(|k| self.events.contains_key(*k)).count();
        let _ = writeln!(s, "model events applied: {seen} of {} kinds", EVENT_KINDS.len());
        for k in EVENT_KINDS {
            let _ = writeln!(s, "  {:>10}  {k}", self.events.get(k).copied().unwrap_or(0));
        }
        // UM p.217's program cases: each row of the table sent while a program it stops was
        // executing (begin immediately or not, stop at a program point or on the path).
        let _ = writeln!(s, "stop commands meeting an executing program (UM p.217):");
        for row in &spec.stop_commands.rows {
            let n = self.stops_meeting_program.get(row.command.as_str()).copied().unwrap_or(0);
            let _ = writeln!(s, "  {n:>10}  {}", row.command);
        }
        let mut bits = Vec::new();
        for (word, w) in [('X', &spec.status.words.x), ('Y', &spec.status.words.y)] {
            for (bit, b) in &w.bits {
                bits.push((word, *bit, b.name.as_str()));
            }
        }
        let set = bits.iter().filter(|(w, b, _)| self.bits_set.contains_key(&(*w, *b))).count();
        // The bits the model sets or clears (the others are described in status.yaml but not
        // modelled), counted from the model's layout.
        let driven = StatusLayout::of(spec).map_or(0, |l| l.driven().len());
        let _ = writeln!(s, "status bits seen set: {set} of {} ({driven} are driven by the model)", bits.len());
        for (word, bit, name) in &bits {
            if let Some(n) = self.bits_set.get(&(*word, *bit)) {
                let _ = writeln!(s, "  {n:>10}  {word}{bit:<2} {name}");
            }
        }
        let sometimes: Vec<_> = STATE_PROPERTIES.iter().filter(|p| p.expectation == Expectation::Sometimes).collect();
        let always: Vec<_> = STATE_PROPERTIES.iter().filter(|p| p.expectation == Expectation::Always).collect();
        let reached = sometimes.iter().filter(|p| self.reached.contains_key(p.name)).count();
        let _ = writeln!(s, "`sometimes` properties reached: {reached} of {}", sometimes.len());
        for p in &sometimes {
            let n = self.reached.get(p.name).copied().unwrap_or(0);
            let _ = writeln!(s, "  {:>10}  {}{}", n, p.name, if n == 0 { "  (NOT REACHED)" } else { "" });
        }
        let failing = always.iter().filter(|p| self.always_failed.contains_key(p.name)).count();
        let _ = writeln!(
            s,
            "`always` properties checked on {} model states: {} hold, {failing} failed",
            self.states_checked,
            always.len() - failing
        );
        for (name, n) in &self.always_failed {
            let _ = writeln!(s, "  FAILED on {n} states: {name}");
        }
        let trips: Vec<&str> = self.trips.iter().copied().collect();
        let _ = writeln!(s, "trip causes seen: {}", if trips.is_empty() { "none".into() } else { trips.join(", ") });
        s
    }
}
