//! `pmacwd replay`: does a captured trace fit the model, and under which readings?
//!
//! The capture (YAML or JSON Lines) is read one step at a time and applied to one model per
//! profile in lockstep, so memory does not grow with the capture. Observations may be partial:
//! only what the capture recorded is compared. Each profile gets a verdict (consistent, or the
//! number of diverging steps and the first divergence with the events before it); each
//! reading's options are then supported (some consistent profile chooses it), ruled out (every
//! profile that chooses it diverged) or not covered by any profile.

use crate::runner::{Mismatch, ModelLane};
use pmacwd_specs::config::ModelConfig;
use pmacwd_specs::profiles::{Choices, Profile};
use pmacwd_specs::yaml::SourceMap;
use pmacwd_specs::{Position, Spec, SpecError};
use pmacwd_trace::jsonl::StepReader;
use pmacwd_trace::{parse_yaml, Step, Trace, TraceEvent};
use std::collections::VecDeque;
use std::io::{BufRead, BufReader};
use std::path::{Path, PathBuf};

/// Where steps come from: a YAML trace (short, read whole), a JSON Lines capture (streamed),
/// or a host log imported on the fly (streamed through the importer, `docs/capturing.md`).
pub enum Source {
    Yaml { trace: Trace, map: SourceMap, next: usize },
    Jsonl(StepReader<BufReader<std::fs::File>>),
    HostLog(Box<crate::import::ImportStream>),
}

impl Source {
    /// Opens `path` as [`Source::open`] does, and a host log as [`Source::HostLog`], imported
    /// under `configuration` (default [`crate::import::DEFAULT_CONFIGURATION`]). A
    /// configuration given for a trace is an error: a trace names its own.
    pub fn open_with(spec: &Spec, path: &Path, configuration: Option<&str>) -> Result<Source, SpecError> {
        if crate::import::is_host_log(path)? {
            let name = configuration.unwrap_or(crate::import::DEFAULT_CONFIGURATION);
            return Ok(Source::HostLog(Box::new(crate::import::ImportStream::open(spec, path, name)?)));
        }
        if let Some(name) = configuration {
            return Err(SpecError::whole_file(
                path,
                format!("--configuration {name} is for host logs; this trace names its own configuration"),
            ));
        }
        Source::open(path)
    }

    /// What the capture says about the card (its `card:` header), if anything.
    pub fn card(&self) -> Option<pmacwd_specs::config::CardConfig> {
        match self {
            Source::Yaml { .. } => None,
            Source::Jsonl(r) => r.header.card,
            Source::HostLog(s) => s.card,
        }
    }

    /// Opens `path`, telling the forms apart by the first non-blank character (`{` is JSON Lines;
    /// a byte-order mark counts as blank). Only regular files are read; a YAML trace is read
    /// whole up to [`pmacwd_specs::input::YAML_TRACE_BYTES_MAX`], a JSON Lines one streamed.
    pub fn open(path: &Path) -> Result<Source, SpecError> {
        let file = pmacwd_specs::input::open_regular(path)?;
        let mut reader = BufReader::new(file);
        let first = loop {
            let buf = reader.fill_buf().map_err(|e| SpecError::whole_file(path, format!("cannot read: {e}")))?;
            let bom = if buf.starts_with(&[0xEF, 0xBB, 0xBF]) { 3 } else { 0 };
            match buf[bom..].iter().position(|b| !b.is_ascii_whitespace()) {
                Some(i) => break Some(buf[bom + i]),
                None if buf.is_empty() => break None,
                None => {
                    let n = buf.len();
                    reader.consume(n);
                }
            }
        };
        match first {
            None => Err(SpecError::whole_file(path, "empty trace")),
            Some(b'{') => Ok(Source::Jsonl(StepReader::new(path, reader)?)),
            Some(_) => {
                let text = pmacwd_specs::input::read_text(path, pmacwd_specs::input::YAML_TRACE_BYTES_MAX)?;

                let loaded = parse_yaml(path, &text)?;
                Ok(Source::Yaml { trace: loaded.trace, map: loaded.map, next: 0 })
            }
        }
    }

    /// The profiles the capture asks to be judged under (`all`, or the names it lists), each
    /// name checked against the spec.
    pub fn profiles(&self, spec: &Spec, path: &Path) -> Result<Vec<Profile>, SpecError> {
        let (selection, at) = match self {
            Source::Yaml { trace, map, .. } => (&trace.profiles, map.position("profiles")),
            Source::Jsonl(r) => (&r.header.profiles, Position { line: 1, column: 1 }),
            Source::HostLog(s) => (&s.header.profiles, Position { line: 1, column: 1 }),
        };
        spec.profiles.select(selection).map_err(|(_, n)| {
            SpecError::at(path, at, format!("no profile named `{n}` (profiles: {})", spec.profiles.names()))
        })
    }

    pub fn configuration(&self) -> &str {
        match self {
            Source::Yaml { trace, .. } => &trace.configuration,
            Source::Jsonl(r) => &r.header.configuration,
            Source::HostLog(s) => &s.header.configuration,
        }
    }

    pub fn description(&self) -> &str {
        match self {
            Source::Yaml { trace, .. } => &trace.description,
            Source::Jsonl(r) => &r.header.description,
            Source::HostLog(s) => &s.header.description,
        }
    }

    /// The next step with the line it is written on.
    pub fn next_step(&mut self) -> Result<Option<(usize, Step)>, SpecError> {
        match self {
            Source::Yaml { trace, map, next } => {
                let Some(step) = trace.steps.get(*next) else { return Ok(None) };
                let line = map.position(&format!("steps.{next}")).line;
                *next += 1;
                Ok(Some((line, step.clone())))
            }
            Source::Jsonl(r) => r.next_step(),
            Source::HostLog(s) => s.next_step(),
        }
    }
}

/// The first divergence under one profile.
#[derive(Clone, Debug)]
pub struct FirstDivergence {
    /// 1-based event number and the line it is on.
    pub event: u64,
    pub line: usize,
    pub what: String,
    pub expected: String,
    pub observed: String,
    /// The events just before, oldest first, the diverging one last.
    pub recent: Vec<String>,
}

#[derive(Clone, Debug)]
pub struct ProfileVerdict {
    pub profile: Profile,
    pub expectations: u64,
    /// Steps at which some expectation failed.
    pub divergences: u64,
    pub first: Option<FirstDivergence>,
}

impl ProfileVerdict {
    pub fn consistent(&self) -> bool {
        self.divergences == 0
    }
}

/// What a capture says about one option of one reading. Profiles fix all readings at once, so
/// an option is only *ruled out* when a profile choosing it diverged although a consistent
/// profile differs from it in this reading alone; otherwise the divergence may be another
/// reading's doing, and the option is merely *unexplained*.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum OptionVerdict {
    /// Some consistent profile chooses it: (consistent, choosing).
    Supported(usize, usize),
    /// (the diverging profile, the consistent profile that differs from it only here).
    RuledOut(String, String),
    /// Every profile choosing it diverged, but each also differs from every consistent profile
    /// in another reading: (choosing).
    Unexplained(usize),
    NotCovered,
}

#[derive(Clone, Debug)]
pub struct ReadingVerdict {
    pub reading: &'static str,
    pub options: Vec<(&'static str, OptionVerdict)>,
}

#[derive(Clone, Debug)]
pub struct ReplayReport {
    pub file: PathBuf,
    pub description: String,
    pub events: u64,
    pub profiles: Vec<ProfileVerdict>,
    pub readings: Vec<ReadingVerdict>,
}

impl ReplayReport {
    pub fn explained(&self) -> bool {
        self.profiles.iter().any(ProfileVerdict::consistent)
    }
}

/// Every reading of a profile as (reading, option) in the words of `profiles.yaml`.
pub fn readings_of(c: &Choices) -> [(&'static str, &'static str); 7] {
    use pmacwd_specs::profiles::*;
    [
        (
            "reset_value_when_i40_zero",
            if c.reset_value_when_i40_zero == ResetValueWhenI40Zero::R4095 { "4095" } else { "4096" },
        ),
        ("strobe_stop", if c.strobe_stop == StrobeStop::AtZero { "at_zero" } else { "below_zero" }),
        ("strober", if c.strober == Strober::ServoInterrupt { "servo_interrupt" } else { "real_time_interrupt" }),
        (
            "bit12_meaning",
            if c.bit12_meaning == Bit12Meaning::PromChecksumActive {
                "prom_checksum_active"
            } else {
                "firmware_checksum_error"
            },
        ),
        ("encoder_loss_clear", if c.encoder_loss_clear == EncoderLossClear::Literal { "literal" } else { "intent" }),
        ("strobe_hz_min", if c.strobe_hz_min == StrobeHzMin::Hz25 { "25" } else { "50" }),
        ("rti_warning_latch", if c.rti_warning_latch == RtiWarningLatch::Level { "level" } else { "sticky" }),
    ]
}

/// Every option of every reading, in the words of `profiles.yaml`.
const ALL_OPTIONS: [(&str, [&str; 2]); 7] = [
    ("reset_value_when_i40_zero", ["4095", "4096"]),
    ("strobe_stop", ["at_zero", "below_zero"]),
    ("strober", ["servo_interrupt", "real_time_interrupt"]),
    ("bit12_meaning", ["prom_checksum_active", "firmware_checksum_error"]),
    ("encoder_loss_clear", ["literal", "intent"]),
    ("strobe_hz_min", ["25", "50"]),
    ("rti_warning_latch", ["level", "sticky"]),
];

/// Whether two profiles make the same choice in every reading but `reading`.
fn differ_only_in(a: &Choices, b: &Choices, reading: &str) -> bool {
    readings_of(a).iter().zip(readings_of(b).iter()).all(|(x, y)| x == y || x.0 == reading)
}

/// How many events before a divergence the report shows.
const RECENT_EVENTS: usize = 5;

struct Lane {
    model: ModelLane,
    verdict: ProfileVerdict,
}

/// Replays `path` under every profile of `spec`.
pub fn replay(spec: &Spec, path: &Path) -> Result<ReplayReport, SpecError> {
    replay_with(spec, path, None)
}

/// [`replay`], a host log imported on the fly under `configuration` ([`Source::open_with`]).
pub fn replay_with(spec: &Spec, path: &Path, configuration: Option<&str>) -> Result<ReplayReport, SpecError> {
    let mut source = Source::open_with(spec, path, configuration)?;
    let card = source.card();
    let configuration = source.configuration().to_string();
    let mut lanes = Vec::new();
    for profile in source.profiles(spec, path)? {
        let mut cfg = ModelConfig::from_spec(spec, &configuration, &profile).map_err(|_| {
            SpecError::at(
                path,
                Position { line: 1, column: 1 },
                format!("no configuration named `{configuration}` in check.yaml"),
            )
        })?;
        if let Some(card) = &card {
            cfg = cfg.with_card(spec, card).map_err(|e| SpecError::at(path, Position { line: 1, column: 1 }, e))?;
        }
        // A capture reads the card's real 24-bit servo counter.
        cfg.servo_counter_mask = 0xFF_FFFF;
        lanes.push(Lane {
            model: ModelLane::new(cfg),
            verdict: ProfileVerdict { profile, expectations: 0, divergences: 0, first: None },
        });
    }
    let mut recent: VecDeque<(usize, TraceEvent)> = VecDeque::with_capacity(RECENT_EVENTS);
    let mut events = 0u64;
    while let Some((line, step)) = source.next_step()? {
        events += 1;
        if recent.len() == RECENT_EVENTS {
            recent.pop_front();
        }
        recent.push_back((line, step.event.clone()));
        for lane in &mut lanes {
            let outcome = match lane.model.apply(&step.event) {
                Err(why) => Err(Mismatch::Field("event", "a background cycle can complete".into(), why)),
                Ok(reply) => lane.model.check(spec, &step.expect, reply),
            };
            match outcome {
                Ok(n) => lane.verdict.expectations += n as u64,
                Err(Mismatch::UnknownBit(_, _, name)) => {
                    return Err(SpecError::at(
                        path,
                        Position { line, column: 1 },
                        format!("no status bit named `{name}` in status.yaml"),
                    ));
                }
                Err(Mismatch::Field(what, expected, observed)) => {
                    lane.verdict.divergences += 1;
                    if lane.verdict.first.is_none() {
                        lane.verdict.first = Some(FirstDivergence {
                            event: events,
                            line,
                            what: what.to_string(),
                            expected,
                            observed,
                            recent: recent.iter().map(|(l, e)| format!("line {l}: {e}")).collect(),
                        });
                    }
                }
            }
        }
    }
    if events == 0 {
        return Err(SpecError::whole_file(path, "the capture has no events"));
    }
    let profiles: Vec<ProfileVerdict> = lanes.into_iter().map(|l| l.verdict).collect();
    let readings = ALL_OPTIONS
        .iter()
        .map(|(reading, options)| {
            let options = options
                .iter()
                .map(|option| {
                    let choosing: Vec<&ProfileVerdict> = profiles
                        .iter()
                        .filter(|p| readings_of(&p.profile.choices).contains(&(reading, option)))
                        .collect();
                    let consistent = choosing.iter().filter(|p| p.consistent()).count();
                    let v = if choosing.is_empty() {
                        OptionVerdict::NotCovered
                    } else if consistent > 0 {
                        OptionVerdict::Supported(consistent, choosing.len())
                    } else {
                        let decisive = choosing.iter().find_map(|bad| {
                            profiles
                                .iter()
                                .filter(|good| good.consistent())
                                .find(|good| differ_only_in(&bad.profile.choices, &good.profile.choices, reading))
                                .map(|good| (bad.profile.name.clone(), good.profile.name.clone()))
                        });
                        match decisive {
                            Some((bad, good)) => OptionVerdict::RuledOut(bad, good),
                            None => OptionVerdict::Unexplained(choosing.len()),
                        }
                    };
                    (*option, v)
                })
                .collect();
            ReadingVerdict { reading, options }
        })
        .collect();
    Ok(ReplayReport {
        file: path.to_path_buf(),
        description: source.description().to_string(),
        events,
        profiles,
        readings,
    })
}

pub fn to_text(r: &ReplayReport, default_profile: &str) -> String {
    use std::fmt::Write as _;
    let mut s = String::new();
    let _ = writeln!(s, "replay {}: {} events", r.file.display(), r.events);
    let _ = writeln!(s, "  {}", r.description.split_whitespace().collect::<Vec<_>>().join(" "));
    for p in &r.profiles {
        let tag = if p.profile.name == default_profile { " (default)" } else { "" };
        let name = format!("{}{tag}", p.profile.name);
        if p.consistent() {
            let _ = writeln!(s, "  {name:<30} consistent ({} expectations checked)", p.expectations);
        } else {
            let f = p.first.as_ref().expect("a divergence was recorded");
            let _ = writeln!(
                s,
                "  {name:<30} INCONSISTENT: {} diverging events; first at event {} (line {}): {}: expected {}, observed {}",
                p.divergences, f.event, f.line, f.what, f.expected, f.observed
            );
            for (i, e) in f.recent.iter().enumerate() {
                let marker = if i + 1 == f.recent.len() { "->" } else { "  " };
                let _ = writeln!(s, "      {marker} {e}");
            }
        }
    }
    s.push_str("readings:\n");
    for rv in &r.readings {
        let parts: Vec<String> = rv
            .options
            .iter()
            .map(|(o, v)| match v {
                OptionVerdict::Supported(k, n) => {
                    format!("{o} supported ({k} of {n} profiles choosing it explain the capture)")
                }
                OptionVerdict::RuledOut(bad, good) => {
                    format!("{o} RULED OUT ({bad} diverges, {good} differs from it only here and explains the capture)")
                }
                OptionVerdict::Unexplained(n) => {
                    format!("{o} unexplained (its {n} profiles diverge, each also differing elsewhere)")
                }
                OptionVerdict::NotCovered => format!("{o} not covered by any profile"),
            })
            .collect();
        let _ = writeln!(s, "  {}:", rv.reading);
        for part in parts {
            let _ = writeln!(s, "      {part}");
        }
    }
    let consistent = r.profiles.iter().filter(|p| p.consistent()).count();
    let _ = writeln!(
        s,
        "verdict: {}",
        if consistent == 0 {
            "no profile explains this capture".to_string()
        } else {
            format!("explained by {consistent} of {} profiles", r.profiles.len())
        }
    );
    s
}

pub fn to_json(r: &ReplayReport) -> String {
    let profiles: Vec<serde_json::Value> = r
        .profiles
        .iter()
        .map(|p| {
            serde_json::json!({
                "profile": p.profile.name, "consistent": p.consistent(), "expectations": p.expectations,
                "divergences": p.divergences,
                "first_divergence": p.first.as_ref().map(|f| serde_json::json!({
                    "event": f.event, "line": f.line, "what": f.what, "expected": f.expected,
                    "observed": f.observed, "recent_events": f.recent,
                })),
            })
        })
        .collect();
    let readings: serde_json::Map<String, serde_json::Value> = r
        .readings
        .iter()
        .map(|rv| {
            let opts: serde_json::Map<String, serde_json::Value> = rv
                .options
                .iter()
                .map(|(o, v)| {
                    let v = match v {
                        OptionVerdict::Supported(k, n) => {
                            serde_json::json!({"verdict": "supported", "explaining": k, "choosing": n})
                        }
                        OptionVerdict::RuledOut(bad, good) => {
                            serde_json::json!({"verdict": "ruled_out", "diverging": bad, "explaining": good})
                        }
                        OptionVerdict::Unexplained(n) => serde_json::json!({"verdict": "unexplained", "choosing": n}),
                        OptionVerdict::NotCovered => serde_json::json!({"verdict": "not_covered"}),
                    };
                    (o.to_string(), v)
                })
                .collect();
            (rv.reading.to_string(), serde_json::Value::Object(opts))
        })
        .collect();
    serde_json::json!({
        "file": r.file.display().to_string(), "events": r.events, "explained": r.explained(),
        "profiles": profiles, "readings": readings,
    })
    .to_string()
}
