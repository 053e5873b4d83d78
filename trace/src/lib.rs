//! Traces: a configuration, a profile selection, and a sequence of events, each optionally
//! with the observations expected after it. The YAML form is documented in
//! `docs/trace-format.md`; this module is its schema.
//!
//! Parsing goes through `pmacwd_specs::yaml`, the one YAML module of the workspace, so every
//! error names file, line and column, and unknown keys are errors. [`jsonl`] is the JSON Lines
//! form, streamed.
//!
//! This crate depends only on `pmacwd-specs` (the vocabulary): the conformance suite, the
//! emulator's captures and the command line all read and write traces through it, and a
//! simulator author can use it without the model or the emulator.

pub mod compare;
pub mod jsonl;

use pmacwd_specs::check::{ChecksumTarget, Load, ProfileSelection, ResetEvent};
use pmacwd_specs::cite::Cites;
pub use pmacwd_specs::config::CardConfig;
use pmacwd_specs::vocab::command::HostCommand;
use pmacwd_specs::vocab::event::Event;
use pmacwd_specs::yaml::SourceMap;
use pmacwd_specs::SpecError;
use serde::de::{self, MapAccess, Visitor};
use serde::{Deserialize, Deserializer};
use std::fmt;
use std::path::Path;

/// The format version this build reads and writes.
pub const FORMAT_VERSION: u32 = 1;

#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Trace {
    /// Must be [`FORMAT_VERSION`].
    pub version: u32,
    /// What the trace shows, as a sentence.
    pub description: String,
    /// Where the behaviour is stated (scenarios) or where the capture came from.
    #[serde(default)]
    pub cite: Option<Cites>,
    /// A configuration of the spec's `check.yaml`: CPU costs, hardware delay, saved I-variables.
    pub configuration: String,
    /// `all`, or the profiles the expectations hold under.
    pub profiles: ProfileSelection,
    pub steps: Vec<Step>,
}

/// What a step does: one event of the model's vocabulary, or `run`, which a trace needs when
/// the background is not observed (a host log): N servo cycles with a background cycle
/// completing after each one in which the load allows it. The harness expands `run` into the
/// model's own events, so any implementation can be driven by it.
///
/// Two more events say what a host log knows and no more, for `replay`, which searches for
/// what happened: `elapsed` (servo cycles passed, as the card's X:$0 or the host's clock
/// measured them, and nothing is known of what happened meanwhile) and `restart` (the card
/// restarted, by INIT/, power or another host's `$$$`: the log cannot say which). A
/// deterministic run of the model (`run`, `conform`) refuses them.
#[derive(Clone, Debug, PartialEq)]
pub enum TraceEvent {
    Model(Event),
    Run {
        cycles: u32,
    },
    /// Between `cycles_min` and `cycles_max` servo cycles (unbounded if `None`) pass unseen:
    /// background cycles, load, supply dips, checksum progress and trips are for replay to
    /// choose.
    Elapsed {
        cycles_min: u32,
        cycles_max: Option<u32>,
    },
    /// The card restarted unseen (INIT/, power cycle, or `$$$` from another host).
    Restart,
    /// The card may have restarted unseen here, or not: what the log shows allows both (an
    /// answer after a silence with no X:$0 read to say which: a tripped card answers only after
    /// a reset, UM p.215, a starved one once its background runs again, UM p.236).
    RestartPossible,
    /// The host sent `command` and gave up after waiting `wait_cycles` servo cycles with no
    /// answer: the card was tripped (UM p.215), or no background cycle, which processes host
    /// commands (UM p.236), completed while it waited. The model runs the wait with no
    /// background cycle and answers silence (`Controller::unanswered`).
    Unanswered {
        command: HostCommand,
        wait_cycles: u32,
    },
}

impl fmt::Display for TraceEvent {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            TraceEvent::Model(e) => e.fmt(f),
            TraceEvent::Run { cycles } => write!(f, "run {cycles} servo cycles, background whenever possible"),
            TraceEvent::Elapsed { cycles_min, cycles_max: Some(max) } if max == cycles_min => {
                write!(f, "{cycles_min} servo cycles pass unseen")
            }
            TraceEvent::Elapsed { cycles_min, cycles_max: Some(max) } => {
                write!(f, "{cycles_min} to {max} servo cycles pass unseen")
            }
            TraceEvent::Elapsed { cycles_min, cycles_max: None } => {
                write!(f, "at least {cycles_min} servo cycles pass unseen")
            }
            TraceEvent::Restart => f.write_str("the card restarts unseen (INIT/, power or `$$$`)"),
            TraceEvent::RestartPossible => f.write_str("the card may have restarted unseen (INIT/, power or `$$$`)"),
            TraceEvent::Unanswered { command, wait_cycles } => {
                write!(
                    f,
                    "host command `{command}` unanswered after {wait_cycles} servo cycles without a background cycle"
                )
            }
        }
    }
}

/// One event and what should be observable after it.
#[derive(Clone, Debug, PartialEq)]
pub struct Step {
    pub event: TraceEvent,
    pub expect: Expect,
    pub note: Option<String>,
}

/// Expected observations; every field is optional (partial observation is normal).
#[derive(Clone, Debug, Default, Deserialize, PartialEq, Eq)]
#[serde(deny_unknown_fields)]
pub struct Expect {
    /// The reply as printed: `001000000000`, `BOOTSTRAP PROM`, `ERR003`, `(silence)`, `(ack)`,
    /// `(none)`, a decimal I-variable value, or a 6-digit hex word.
    pub reply: Option<String>,
    pub tripped: Option<bool>,
    pub led_red: Option<bool>,
    pub fefco_on: Option<bool>,
    pub relay_tripped: Option<bool>,
    pub outputs_forced_off: Option<bool>,
    /// Y:$000025.
    pub counter: Option<i32>,
    /// X:$000025.
    pub counter_min: Option<i32>,
    /// X:$001080, the running checksum, as the card answered it (a 24-bit word): the card's own
    /// value, never compared with the model's, which sums no memory and holds a token
    /// (UM p.217, MODEL). `pmacwd replay` reads it for what UM p.217 says of it, that it
    /// freezes once a checksum mismatch stops the engine (`capture::explain::refute::Freeze`);
    /// `pmacwd run` ignores it.
    #[serde(default, deserialize_with = "word24")]
    pub running_checksum: Option<u32>,
    /// Timing uncertainty for `tripped`: the expectation also holds if the model trips within
    /// this many servo cycles after the step, or tripped within this many before it.
    pub window_cycles: Option<u32>,
    /// Status bits (names of `status.yaml`) that must be 1.
    #[serde(default)]
    pub status_set: Vec<String>,
    /// Status bits that must be 0.
    #[serde(default)]
    pub status_clear: Vec<String>,
    /// Each motor's motion state, in motor order (`killed`, `closed`, `jogging`, `program`,
    /// `decelerating`, `holding`); empty: not expected. An implementation that reports no
    /// motors (the compact core today) is not checked against it (docs/conformance.md).
    #[serde(default)]
    pub motors: Vec<String>,
    /// Each motor's latched encoder-loss status (the PLC's `Mtr1EncLossStatus`, UM p.215).
    #[serde(default)]
    pub encoder_loss: Vec<bool>,
}

/// `running_checksum`: a 24-bit word, as a register of the card holds it.
fn word24<'de, D: Deserializer<'de>>(d: D) -> Result<Option<u32>, D::Error> {
    let v = u32::deserialize(d)?;
    if v > 0xFF_FFFF {
        return Err(de::Error::custom(format!("`running_checksum: {v}` is more than a 24-bit word (16777215)")));
    }
    Ok(Some(v))
}

impl Expect {
    pub fn is_empty(&self) -> bool {
        *self == Expect::default()
    }
}

/// The most servo cycles one `servo` or `run` step may take: 2^24, one turn of the card's
/// servo counter X:$0 (about 2 hours at 2.25 kHz). A reader refuses more with the step's
/// line, so one line of a trace cannot make `run` or `replay` spend minutes on it; longer
/// spans are written as several steps (a capture does that by itself).
pub const STEP_CYCLES_MAX: u32 = 1 << 24;

/// The keys a step may have besides its one event key.
const STEP_EXTRAS: [&str; 2] = ["expect", "note"];
/// The event keys.
const EVENT_KEYS: [&str; 15] = [
    "servo",
    "run",
    "elapsed",
    "background",
    "load",
    "command",
    "unanswered",
    "supply_mv",
    "reset",
    "restart",
    "possible_restart",
    "checksum_fault",
    "clear_rti_reentry",
    "encoder",
    "amplifier_fault",
];

/// `elapsed: N` or `elapsed: {min: A, max: B}` (`max` optional: unbounded).
#[derive(Deserialize)]
#[serde(untagged)]
enum ElapsedForm {
    Exact(u32),
    Range(ElapsedRange),
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct ElapsedRange {
    min: u32,
    #[serde(default)]
    max: Option<u32>,
}

/// `unanswered: {command: TEXT, wait: N}`.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct UnansweredForm {
    command: String,
    wait: u32,
}

fn elapsed_event<E: de::Error>(form: ElapsedForm) -> Result<TraceEvent, E> {
    let (min, max) = match form {
        ElapsedForm::Exact(n) => (n, Some(n)),
        ElapsedForm::Range(r) => (r.min, r.max),
    };
    if let Some(max) = max {
        if max < min {
            return Err(E::custom(format!("`elapsed`: max {max} is below min {min}")));
        }
        if max > STEP_CYCLES_MAX {
            return Err(E::custom(format!(
                "`elapsed` up to {max} servo cycles is more than {STEP_CYCLES_MAX}, the most one step \
                 takes; split it into several steps, or leave `max` out for an unbounded time"
            )));
        }
    }
    if min > STEP_CYCLES_MAX {
        return Err(E::custom(format!(
            "`elapsed` of at least {min} servo cycles is more than {STEP_CYCLES_MAX}; split it"
        )));
    }
    Ok(TraceEvent::Elapsed { cycles_min: min, cycles_max: max })
}

impl<'de> Deserialize<'de> for Step {
    /// A step is a bare word (`background`, `clear_rti_reentry`) or a mapping with exactly one
    /// event key plus optional `expect` and `note`.
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct StepVisitor;
        impl<'de> Visitor<'de> for StepVisitor {
            type Value = Step;
            fn expecting(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
                write!(
                    f,
                    "an event: `background`, `clear_rti_reentry`, or a mapping with one of {}",
                    EVENT_KEYS.join(", ")
                )
            }
            fn visit_str<E: de::Error>(self, v: &str) -> Result<Step, E> {
                let event = match v {
                    "restart" => return Ok(Step { event: TraceEvent::Restart, expect: Expect::default(), note: None }),
                    "background" => Event::Background,
                    "clear_rti_reentry" => Event::ClearRtiReentry,
                    other => {
                        return Err(E::custom(format!(
                            "unknown event `{other}`; expected one of {}",
                            EVENT_KEYS.join(", ")
                        )))
                    }
                };
                Ok(Step { event: TraceEvent::Model(event), expect: Expect::default(), note: None })
            }
            fn visit_map<A: MapAccess<'de>>(self, mut map: A) -> Result<Step, A::Error> {
                let mut event: Option<TraceEvent> = None;
                let mut expect = None;
                let mut note = None;
                while let Some(key) = map.next_key::<String>()? {
                    let e = match key.as_str() {
                        // A key given twice would otherwise keep only its last value.
                        "expect" => {
                            if expect.replace(map.next_value::<Expect>()?).is_some() {
                                return Err(de::Error::custom("duplicate key `expect`"));
                            }
                            continue;
                        }
                        "note" => {
                            if note.replace(map.next_value::<String>()?).is_some() {
                                return Err(de::Error::custom("duplicate key `note`"));
                            }
                            continue;
                        }
                        "servo" | "run" => {
                            let cycles: u32 = map.next_value()?;
                            if cycles == 0 {
                                return Err(de::Error::custom(format!("`{key}` needs at least 1 cycle")));
                            }
                            if cycles > STEP_CYCLES_MAX {
                                return Err(de::Error::custom(format!(
                                    "`{key}: {cycles}` is more than {STEP_CYCLES_MAX} servo cycles, the most one step \
                                     takes; split it into several steps"
                                )));
                            }
                            if key == "run" {
                                TraceEvent::Run { cycles }
                            } else {
                                TraceEvent::Model(Event::Servo { cycles })
                            }
                        }
                        "elapsed" => elapsed_event(map.next_value::<ElapsedForm>()?)?,
                        "restart" | "possible_restart" => {
                            let n: u32 = map.next_value()?;
                            if n != 1 {
                                return Err(de::Error::custom(format!(
                                    "`{key}` takes no count other than 1; write one step per occurrence"
                                )));
                            }
                            if key == "restart" {
                                TraceEvent::Restart
                            } else {
                                TraceEvent::RestartPossible
                            }
                        }
                        "background" | "clear_rti_reentry" => {
                            let n: u32 = map.next_value()?;
                            if n != 1 {
                                return Err(de::Error::custom(format!(
                                    "`{key}` takes no count other than 1; write one step per occurrence"
                                )));
                            }
                            TraceEvent::Model(if key == "background" {
                                Event::Background
                            } else {
                                Event::ClearRtiReentry
                            })
                        }
                        "load" => TraceEvent::Model(Event::Load(map.next_value::<Load>()?)),
                        "command" => {
                            let text: String = map.next_value()?;
                            TraceEvent::Model(Event::Command(
                                HostCommand::parse(&text).map_err(|e| de::Error::custom(e.0))?,
                            ))
                        }
                        "unanswered" => {
                            let UnansweredForm { command, wait } = map.next_value()?;
                            if wait > STEP_CYCLES_MAX {
                                return Err(de::Error::custom(format!(
                                    "`unanswered` waiting {wait} servo cycles is more than {STEP_CYCLES_MAX}, the most \
                                     one step takes"
                                )));
                            }
                            TraceEvent::Unanswered {
                                command: HostCommand::parse(&command).map_err(|e| de::Error::custom(e.0))?,
                                wait_cycles: wait,
                            }
                        }
                        "supply_mv" => TraceEvent::Model(Event::Supply { millivolts: map.next_value()? }),
                        "encoder" => TraceEvent::Model(Event::EncoderInput(
                            map.next_value::<pmacwd_specs::vocab::EncoderInput>()?,
                        )),
                        "amplifier_fault" => TraceEvent::Model(Event::AmplifierFault(
                            map.next_value::<pmacwd_specs::vocab::AmplifierFaultInput>()?,
                        )),
                        "reset" => TraceEvent::Model(Event::Reset(map.next_value::<ResetEvent>()?)),
                        "checksum_fault" => {
                            TraceEvent::Model(Event::ChecksumFault(map.next_value::<ChecksumTarget>()?))
                        }
                        other => {
                            return Err(de::Error::custom(format!(
                                "unknown key `{other}`; a step has one of {} plus optional {}",
                                EVENT_KEYS.join(", "),
                                STEP_EXTRAS.join(", ")
                            )))
                        }
                    };
                    if event.replace(e).is_some() {
                        return Err(de::Error::custom("a step has exactly one event; split it into two steps"));
                    }
                }
                let event = event.ok_or_else(|| {
                    de::Error::custom(format!("a step needs one event key: {}", EVENT_KEYS.join(", ")))
                })?;
                Ok(Step { event, expect: expect.unwrap_or_default(), note })
            }
        }
        d.deserialize_any(StepVisitor)
    }
}

/// A parsed trace with the positions of its steps, for error messages.
pub struct LoadedTrace {
    pub trace: Trace,
    pub map: SourceMap,
    /// The optional `card:` header: what the capture itself says about the card (I8, I40, I41,
    /// servo clock), overriding the configuration's values ([`ModelConfig::with_card`]).
    ///
    /// [`ModelConfig::with_card`]: pmacwd_specs::config::ModelConfig::with_card
    pub card: Option<CardConfig>,
}

/// The YAML top level: a [`Trace`] and the optional `card:` header key (kept beside the trace,
/// not in it, so that every writer of a [`Trace`] stays as it is).
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct TraceFile {
    version: u32,
    description: String,
    #[serde(default)]
    cite: Option<Cites>,
    configuration: String,
    #[serde(default)]
    card: Option<CardConfig>,
    profiles: ProfileSelection,
    steps: Vec<Step>,
}

impl LoadedTrace {
    pub fn step_position(&self, index: usize) -> pmacwd_specs::Position {
        self.map.position(&format!("steps.{index}"))
    }
}

/// Whether the first line that is not blank or a `#` comment is a host log's `> command`.
fn looks_like_host_log(text: &str) -> bool {
    text.lines()
        .map(str::trim_start)
        .find(|l| !l.is_empty() && !l.starts_with('#'))
        .is_some_and(|l| l.starts_with("> "))
}

/// Parses a YAML trace.
pub fn parse_yaml(file: &Path, text: &str) -> Result<LoadedTrace, SpecError> {
    if looks_like_host_log(text) {
        // A YAML syntax error would not tell the user what to do with a host log.
        return Err(SpecError::whole_file(
            file,
            "this is a host log (`> command`, `< reply`), not a trace: turn it into one with \
             `pmacwd import LOG --out trace.jsonl`, then use the trace (docs/capturing.md)",
        ));
    }
    let (f, map): (TraceFile, SourceMap) = pmacwd_specs::yaml::parse(file, text)?;
    let card = f.card;
    let trace = Trace {
        version: f.version,
        description: f.description,
        cite: f.cite,
        configuration: f.configuration,
        profiles: f.profiles,
        steps: f.steps,
    };
    if trace.version != FORMAT_VERSION {
        return Err(map.error(
            "version",
            format!("trace format version {} is not supported (this build reads {FORMAT_VERSION})", trace.version),
        ));
    }
    if trace.steps.is_empty() {
        return Err(map.error("steps", "a trace needs at least one step"));
    }
    if let ProfileSelection::Named(names) = &trace.profiles {
        if names.is_empty() {
            return Err(map.error("profiles", "an empty profile list runs nothing: name profiles, or write `all`"));
        }
    }
    Ok(LoadedTrace { trace, map, card })
}

pub fn load_yaml(file: &Path) -> Result<LoadedTrace, SpecError> {
    let text = pmacwd_specs::input::read_text(file, pmacwd_specs::input::YAML_TRACE_BYTES_MAX)?;
    parse_yaml(file, &text)
}

/// The two forms of a trace file.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Form {
    Yaml,
    Jsonl,
}

/// Which form `text` is in, told as `pmacwd replay` tells it: JSON Lines when the first
/// character that is not white space (after a byte-order mark) is `{`, YAML otherwise.
pub fn form_of(text: &str) -> Form {
    match text.trim_start_matches('\u{feff}').trim_start().starts_with('{') {
        true => Form::Jsonl,
        false => Form::Yaml,
    }
}

/// Parses a trace in either form ([`form_of`]), whole.
pub fn parse(file: &Path, text: &str) -> Result<LoadedTrace, SpecError> {
    match form_of(text) {
        Form::Jsonl => jsonl::load_text(file, text),
        Form::Yaml => parse_yaml(file, text),
    }
}

/// Reads a trace in either form whole, up to [`pmacwd_specs::input::YAML_TRACE_BYTES_MAX`]
/// bytes (a longer capture is for `pmacwd replay`, which streams it).
pub fn load(file: &Path) -> Result<LoadedTrace, SpecError> {
    let text = pmacwd_specs::input::read_text(file, pmacwd_specs::input::YAML_TRACE_BYTES_MAX)?;
    parse(file, &text)
}

/// Writes a trace back as YAML in the documented form (used to save shrunk failures and to
/// check that parsing and writing round-trip).
pub fn to_yaml(trace: &Trace) -> String {
    let mut s = yaml_header(trace);
    for step in &trace.steps {
        s.push_str(&yaml_step(step));
    }
    s
}

/// The YAML form up to and including `steps:` (the trace's own steps are not written), so that
/// a long trace can be written one [`yaml_step`] at a time.
pub fn yaml_header(trace: &Trace) -> String {
    yaml_header_with_card(trace, None)
}

/// [`yaml_header`] with the optional `card:` key (written only when some field is set).
pub fn yaml_header_with_card(trace: &Trace, card: Option<&CardConfig>) -> String {
    use std::fmt::Write as _;
    let mut s = String::new();
    let _ = writeln!(s, "version: {}", trace.version);
    let _ = writeln!(s, "description: {}", quote(&trace.description));
    if let Some(c) = &trace.cite {
        let items: Vec<String> = c.0.iter().map(|c| quote(&c.to_string())).collect();
        let _ = writeln!(s, "cite: [{}]", items.join(", "));
    }
    let _ = writeln!(s, "configuration: {}", quote(&trace.configuration));
    if let Some(card) = card.filter(|c| !c.is_empty()) {
        let fields: Vec<String> = card.fields().iter().map(|(k, v)| format!("{k}: {v}")).collect();
        let _ = writeln!(s, "card: {{{}}}", fields.join(", "));
    }
    match &trace.profiles {
        ProfileSelection::Keyword(_) => s.push_str("profiles: all\n"),
        ProfileSelection::Named(n) => {
            let items: Vec<String> = n.iter().map(|p| quote(p)).collect();
            let _ = writeln!(s, "profiles: [{}]", items.join(", "));
        }
    }
    s.push_str("steps:\n");
    s
}

/// One step of the YAML form, as a list item under `steps:`.
pub fn yaml_step(step: &Step) -> String {
    use std::fmt::Write as _;
    let mut s = String::new();
    {
        let event = match &step.event {
            TraceEvent::Run { cycles } => format!("run: {cycles}"),
            TraceEvent::Elapsed { cycles_min, cycles_max: Some(max) } if max == cycles_min => {
                format!("elapsed: {cycles_min}")
            }
            TraceEvent::Elapsed { cycles_min, cycles_max: Some(max) } => {
                format!("elapsed: {{min: {cycles_min}, max: {max}}}")
            }
            TraceEvent::Elapsed { cycles_min, cycles_max: None } => format!("elapsed: {{min: {cycles_min}}}"),
            TraceEvent::Restart => "restart: 1".into(),
            TraceEvent::RestartPossible => "possible_restart: 1".into(),
            TraceEvent::Unanswered { command, wait_cycles } => {
                format!("unanswered: {{command: {}, wait: {wait_cycles}}}", quote(&command.to_string()))
            }
            TraceEvent::Model(e) => match e {
                Event::Servo { cycles } => format!("servo: {cycles}"),
                Event::Background => "background: 1".into(),
                Event::ClearRtiReentry => "clear_rti_reentry: 1".into(),
                Event::Load(l) => format!(
                    "load: {{motors: {}, plc0_units: {}, background_units: {}}}",
                    l.motors, l.plc0_units, l.background_units
                ),
                Event::Command(c) => format!("command: {}", quote(&c.to_string())),
                Event::Supply { millivolts } => format!("supply_mv: {millivolts}"),
                Event::Reset(r) => format!(
                    "reset: {{kind: {}, dpram_fault: {}, flash_fault: {}, bootstrap: {}}}",
                    match r.kind {
                        pmacwd_specs::check::ResetKind::Init => "init",
                        pmacwd_specs::check::ResetKind::Power => "power",
                    },
                    r.dpram_fault,
                    r.flash_fault,
                    r.bootstrap
                ),
                Event::ChecksumFault(ChecksumTarget::Firmware) => "checksum_fault: firmware".into(),
                Event::ChecksumFault(ChecksumTarget::UserProgram) => "checksum_fault: user_program".into(),
                Event::EncoderInput(i) => format!("encoder: {{motor: {}, lost: {}}}", i.motor, i.lost),
                Event::AmplifierFault(i) => format!("amplifier_fault: {{motor: {}, fault: {}}}", i.motor, i.fault),
            },
        };
        let _ = writeln!(s, "  - {event}");
        if let Some(n) = &step.note {
            let _ = writeln!(s, "    note: {}", quote(n));
        }
        if !step.expect.is_empty() {
            // Destructured without `..`: a new expectation is a compile error here until it
            // is written.
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
            } = &step.expect;
            s.push_str("    expect:\n");
            if let Some(v) = reply {
                let _ = writeln!(s, "      reply: {}", quote(v));
            }
            for (k, v) in [
                ("tripped", tripped),
                ("led_red", led_red),
                ("fefco_on", fefco_on),
                ("relay_tripped", relay_tripped),
                ("outputs_forced_off", outputs_forced_off),
            ] {
                if let Some(v) = v {
                    let _ = writeln!(s, "      {k}: {v}");
                }
            }
            if let Some(v) = window_cycles {
                let _ = writeln!(s, "      window_cycles: {v}");
            }
            if let Some(v) = counter {
                let _ = writeln!(s, "      counter: {v}");
            }
            if let Some(v) = counter_min {
                let _ = writeln!(s, "      counter_min: {v}");
            }
            if let Some(v) = running_checksum {
                let _ = writeln!(s, "      running_checksum: {v}");
            }
            if !status_set.is_empty() {
                let _ = writeln!(s, "      status_set: [{}]", quoted_list(status_set));
            }
            if !status_clear.is_empty() {
                let _ = writeln!(s, "      status_clear: [{}]", quoted_list(status_clear));
            }
            if !motors.is_empty() {
                let _ = writeln!(s, "      motors: [{}]", quoted_list(motors));
            }
            if !encoder_loss.is_empty() {
                let list: Vec<String> = encoder_loss.iter().map(bool::to_string).collect();
                let _ = writeln!(s, "      encoder_loss: [{}]", list.join(", "));
            }
        }
    }
    s
}

/// A YAML double-quoted string that reads back as `s`, whatever it holds: a character YAML
/// does not allow in a document (C0 and C1 controls, DEL, U+FEFF, U+FFFE, U+FFFF) or would
/// fold as a line break (CR, LF, NEL, LS, PS) is written as an escape.
fn quote(s: &str) -> String {
    use std::fmt::Write as _;
    let mut out = String::from("\"");
    for c in s.chars() {
        match c {
            '"' => out.push_str("\\\""),
            '\\' => out.push_str("\\\\"),
            '\n' => out.push_str("\\n"),
            '\r' => out.push_str("\\r"),
            '\t' => out.push_str("\\t"),
            '\u{0}'..='\u{1F}' | '\u{7F}'..='\u{9F}' => {
                let _ = write!(out, "\\x{:02X}", u32::from(c));
            }
            '\u{2028}' | '\u{2029}' | '\u{FEFF}' | '\u{FFFE}' | '\u{FFFF}' => {
                let _ = write!(out, "\\u{:04X}", u32::from(c));
            }
            c => out.push(c),
        }
    }
    out.push('"');
    out
}

/// A YAML flow sequence of quoted strings.
fn quoted_list(items: &[String]) -> String {
    items.iter().map(|i| quote(i)).collect::<Vec<_>>().join(", ")
}

#[cfg(test)]
mod tests {
    use super::*;

    const HEADER: &str =
        r#"{"format":"pmacwd-trace","version":1,"description":"t","configuration":"i40-zero","profiles":"all"}"#;

    fn jsonl(lines: &[&str]) -> Result<Trace, SpecError> {
        let text = std::iter::once(HEADER).chain(lines.iter().copied()).collect::<Vec<_>>().join("\n");
        jsonl::read_all(Path::new("t.jsonl"), text.as_bytes())
    }

    /// `trace` written as YAML and read again, compared field by field.
    fn yaml_round_trip(trace: &Trace) {
        let yaml = to_yaml(trace);
        let again = parse_yaml(Path::new("t.yaml"), &yaml).unwrap_or_else(|e| panic!("{e}\n{yaml}")).trace;
        assert_eq!(format!("{trace:?}"), format!("{again:?}"), "{yaml}");
    }

    #[test]
    fn a_card_header_reads_and_writes_back_the_same_in_both_forms() {
        let yaml = "version: 1\ndescription: t\nconfiguration: i40-zero\ncard: {servo_hz: 2259, i40: 0}\n\
                    profiles: all\nsteps:\n  - servo: 1\n";
        let loaded = parse_yaml(Path::new("t.yaml"), yaml).unwrap();
        let card = CardConfig { servo_hz: Some(2259), i40: Some(0), ..CardConfig::default() };
        assert_eq!(loaded.card, Some(card));
        let again = yaml_header_with_card(&loaded.trace, Some(&card));
        assert!(again.contains("card: {servo_hz: 2259, i40: 0}\n"), "{again}");
        let line = jsonl::header_line_with_card(&loaded.trace, Some(&card));
        assert!(line.contains(r#""card":{"i40":0,"servo_hz":2259}"#), "{line}");
        let text = format!("{line}\n{{\"servo\":1}}\n");
        let r = jsonl::StepReader::new(Path::new("t.jsonl"), text.as_bytes()).unwrap();
        assert_eq!(r.header.card, Some(card));
        // No card, or an empty one: no key at all, so traces without one read as before.
        assert!(!yaml_header_with_card(&loaded.trace, Some(&CardConfig::default())).contains("card"));
        assert!(!jsonl::header_line(&loaded.trace).contains("card"));
    }

    #[test]
    fn an_unknown_or_mistyped_card_field_is_refused_with_its_line() {
        let yaml = "version: 1\ndescription: t\nconfiguration: i40-zero\ncard: {i10: 5}\nprofiles: all\nsteps:\n  - servo: 1\n";
        let e = parse_yaml(Path::new("t.yaml"), yaml).err().expect("refused");
        assert_eq!(e.position.map(|p| p.line), Some(4), "{e}");
        assert!(e.message.contains("i10"), "{e}");
        let line = r#"{"format":"pmacwd-trace","version":1,"description":"t","configuration":"c","card":{"i40":"x"},"profiles":"all"}"#;
        let e = jsonl::StepReader::new(Path::new("t.jsonl"), line.as_bytes()).err().expect("refused");
        assert_eq!(e.position.map(|p| p.line), Some(1), "{e}");
    }

    #[test]
    fn a_trace_whose_texts_hold_control_characters_writes_yaml_that_reads_back_the_same() {
        // Found by the fuzz target jsonl_trace: a DEL in a JSON description was written raw
        // into the YAML form, which YAML refuses ("control characters are not allowed").
        let capture = "{\"format\":\"pmacwd-trace\",\"version\":1,\"description\":\"SYNTHETIC: the card still!answres \
                       200 servo cycles after its co:unter arn out, with no backgr\u{7f}und cycle: no reading??? allows \
                       that.\",\"configuration\":\"i40-zero\",\"profiles\":\"all\"}\n{\"servo\":8600}\n\
                       {\"command\":\"??Y:$25\",\"expect\":{\"reply\":\"000000\"}}\n";
        yaml_round_trip(&jsonl::read_all(Path::new("t.jsonl"), capture.as_bytes()).unwrap());
        // Found by the fuzz target host_log: a host command `I130\x01\0\0\0=5` (kept for an
        // ERR003 reply) was written with its NUL, where YAML's reader stops.
        let mut trace = jsonl::read_all(Path::new("t.jsonl"), capture.as_bytes()).unwrap();
        trace.steps[1].event = TraceEvent::Model(Event::Command(HostCommand::parse("I130\u{1}\0\0\0=5").unwrap()));
        // Every character YAML would refuse or fold, in every text the writer quotes.
        let odd =
            "a\0b\u{1}\t\r\n\u{1b}\u{7f}\u{85}\u{9f}\u{2028}\u{2029}\u{feff}\u{fffe}\u{ffff} \"\\ é \u{10ffff} end ";
        trace.description = odd.into();
        trace.configuration = odd.into();
        trace.profiles = ProfileSelection::Named(vec![odd.into(), "all".into()]);
        trace.steps[1].note = Some(odd.into());
        trace.steps[1].expect.reply = Some(odd.into());
        yaml_round_trip(&trace);
    }

    #[test]
    fn status_bit_names_that_are_not_plain_yaml_words_write_yaml_that_reads_back_the_same() {
        // The writer listed `status_set` and `status_clear` unquoted: `[a, b]` for one name
        // `a, b`, a YAML error for `]`, a boolean for `true`.
        let mut trace =
            jsonl::read_all(Path::new("t.jsonl"), format!("{HEADER}\n{{\"servo\":1}}\n").as_bytes()).unwrap();
        let names: Vec<String> = ["a, b", "]", "true", "", "#x", "- y", "rti_reentry"].map(String::from).into();
        trace.steps[0].expect.status_set = names.clone();
        trace.steps[0].expect.status_clear = names;
        yaml_round_trip(&trace);
    }

    #[test]
    fn a_card_s_running_checksum_reads_and_writes_back_the_same_in_both_forms_and_more_than_24_bits_is_refused() {
        // Issue 36: the card's own X:$1080 is kept in the step (not compared with the model's
        // token) so that replay can check UM p.217's freeze.
        let trace =
            jsonl(&[r#"{"command":"RHX:$1080","expect":{"tripped":false,"running_checksum":3833633}}"#]).unwrap();
        assert_eq!(trace.steps[0].expect.running_checksum, Some(0x3A7F21));
        yaml_round_trip(&trace);
        assert!(to_yaml(&trace).contains("      running_checksum: 3833633\n"), "{}", to_yaml(&trace));
        let again = jsonl::read_all(Path::new("t.jsonl"), jsonl::to_jsonl(&trace).as_bytes()).unwrap();
        assert_eq!(again.steps, trace.steps);
        let e = jsonl(&[r#"{"servo":1}"#, r#"{"command":"RHX:$1080","expect":{"running_checksum":16777216}}"#])
            .unwrap_err();
        assert_eq!(e.position.map(|p| p.line), Some(3), "{e}");
        assert!(e.message.contains("24-bit"), "{e}");
        let yaml = "version: 1\ndescription: t\nconfiguration: i40-zero\nprofiles: all\nsteps:\n  - servo: 1\n  \
                    - command: RHX:$1080\n    expect: {running_checksum: 16777216}\n";
        let e = parse_yaml(Path::new("t.yaml"), yaml).err().expect("refused");
        assert_eq!(e.position.map(|p| p.line), Some(8), "{e}");
    }

    #[test]
    fn a_step_longer_than_one_counter_turn_is_refused_at_its_line() {
        // `{"servo": 2147483647}` used to run for minutes per profile; a reader now stops it
        // with the line, and a capture writes long gaps as several steps.
        let e = jsonl(&[r#"{"run": 16777216}"#, r#"{"servo": 2147483647}"#]).unwrap_err();
        assert_eq!(e.position.map(|p| p.line), Some(3), "{e}");
        assert!(e.message.contains("split it into several steps"), "{e}");
        let yaml = "version: 1\ndescription: t\nconfiguration: i40-zero\nprofiles: all\nsteps:\n  - run: 16777217\n";
        let e = parse_yaml(Path::new("t.yaml"), yaml).err().expect("refused");
        assert_eq!(e.position.map(|p| p.line), Some(6), "{e}");
    }

    #[test]
    fn a_key_given_twice_in_a_json_step_is_refused_not_overwritten() {
        // JSON objects may repeat a key; serde would keep the last `expect` and silently drop
        // the first, which could turn a failing expectation into a passing one.
        let e = jsonl(&[r#"{"command":"???","expect":{"reply":"X"},"expect":{}}"#]).unwrap_err();
        assert!(e.message.contains("duplicate key `expect`"), "{e}");
        let e = jsonl(&[r#"{"command":"???","note":"a","note":"b"}"#]).unwrap_err();
        assert!(e.message.contains("duplicate key `note`"), "{e}");
        let e = jsonl(&[r#"{"command":"???","expect":{"reply":"X","reply":"Y"}}"#]).unwrap_err();
        assert!(e.message.contains("duplicate field `reply`"), "{e}");
    }

    #[test]
    fn a_trace_without_steps_is_refused_in_both_forms_at_a_line() {
        // The JSON Lines reader used to accept a header alone, which the YAML reader refuses
        // (`steps: []`); run on it, such a trace checks nothing and passes. Both refuse it now,
        // the JSON Lines form at the header's line (blank lines after it change nothing).
        for text in [format!("{HEADER}\n"), format!("\n{HEADER}\n\n\n")] {
            let e = jsonl::read_all(Path::new("t.jsonl"), text.as_bytes()).unwrap_err();
            let header_line = text.lines().position(|l| l == HEADER).unwrap() + 1;
            assert_eq!(e.position.map(|p| p.line), Some(header_line), "{e}");
            assert!(e.message.contains("a trace needs at least one step"), "{e}");
        }
        let yaml = "version: 1\ndescription: t\nconfiguration: i40-zero\nprofiles: all\nsteps: []\n";
        let e = parse_yaml(Path::new("t.yaml"), yaml).err().expect("refused");
        assert_eq!(e.position.map(|p| p.line), Some(5), "{e}");
        assert!(e.message.contains("a trace needs at least one step"), "{e}");
        // One step is enough.
        assert_eq!(jsonl(&[r#"{"servo":1}"#]).unwrap().steps.len(), 1);
    }

    #[test]
    fn a_json_lines_trace_loads_whole_with_the_line_of_every_step() {
        // `pmacwd run` takes both forms; a divergence names the step's line, and an error about
        // the header (an unknown profile, configuration or card value) the header's line.
        let text = format!("\n{HEADER}\n{{\"servo\":1}}\n\n{{\"command\":\"???\"}}\n");
        assert_eq!(form_of(&text), Form::Jsonl);
        let loaded = parse(Path::new("t.jsonl"), &text).unwrap();
        assert_eq!(loaded.trace.steps.len(), 2);
        assert_eq!(loaded.step_position(0).line, 3);
        assert_eq!(loaded.step_position(1).line, 5);
        assert_eq!(loaded.map.position("profiles.0").line, 2);
        assert_eq!(loaded.map.position("steps.1.expect.status_set.0").line, 5);
        // The same trace in YAML is read as YAML, a byte-order mark and blank lines first or not.
        let yaml = to_yaml(&loaded.trace);
        assert_eq!(form_of(&format!("\u{feff}\n{yaml}")), Form::Yaml);
        assert_eq!(form_of(&format!("\u{feff} {HEADER}")), Form::Jsonl);
        let again = parse(Path::new("t.yaml"), &yaml).unwrap();
        assert_eq!(format!("{:?}", again.trace), format!("{:?}", loaded.trace));
    }

    #[test]
    fn an_empty_profile_list_is_refused_in_both_forms() {
        // `profiles: []` used to run nothing and report "0 passed, 0 failed" with exit 0.
        let text = HEADER.replace(r#""all""#, "[]") + "\n{\"servo\":1}\n";
        let e = jsonl::read_all(Path::new("t.jsonl"), text.as_bytes()).unwrap_err();
        assert!(e.message.contains("empty profile list"), "{e}");
        let yaml = "version: 1\ndescription: t\nconfiguration: i40-zero\nprofiles: []\nsteps:\n  - servo: 1\n";
        let e = parse_yaml(Path::new("t.yaml"), yaml).err().expect("refused");
        assert_eq!(e.position.map(|p| p.line), Some(4), "{e}");
    }
}
