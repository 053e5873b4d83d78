//! A trace run on the model servo cycle by servo cycle, as signals over time: Y:$25, X:$25,
//! the strobe, the trip, the background cycles and every status bit, at absolute servo cycles
//! (and milliseconds at the configuration's servo clock). `pmacwd timeline` writes them as CSV,
//! VCD or a plot; this module only produces them, one change at a time, so that memory stays
//! flat however long the trace.
//!
//! The run is the one `pmacwd run` makes (the trace's configuration and `card:` header under
//! one profile); its expectations are not checked here, only marked where the trace reads
//! Y:$25 or X:$25. A trace with `elapsed` or `restart` steps leaves open what happened:
//! `pmacwd replay --witness` turns a capture into a trace this can draw.

use crate::replay::Source;
use pmacwd_model::controller::Controller;
use pmacwd_specs::config::ModelConfig;
use pmacwd_specs::profiles::Profile;
use pmacwd_specs::status::WordId;
use pmacwd_specs::vocab::command::{HostCommand, Register};
use pmacwd_specs::vocab::event::Event;
use pmacwd_specs::{Spec, SpecError};
use pmacwd_trace::compare::deterministic;
use pmacwd_trace::TraceEvent;
use std::path::Path;

/// The signals after a servo cycle or an event.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Signals {
    /// Servo cycles since the start of the trace.
    pub cycle: u64,
    /// Y:$000025, the watchdog counter.
    pub counter: i32,
    /// X:$000025, its lowest value since reset.
    pub counter_min: i32,
    /// The strobe line to the hardware timer: it changes level at each edge (UM p.215).
    pub strobe: bool,
    /// The hardware timer has tripped (UM p.215).
    pub tripped: bool,
    /// Changes level at each completed background cycle.
    pub background: bool,
    /// The two `???` status words (SRM p.289-290), CPU type bits 0.
    pub x: u32,
    pub y: u32,
}

/// Something the timeline says happened.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Item {
    /// A signal changed.
    Change(Signals),
    /// A trace step that is not servo time: a host command, a reset, a load change; with the
    /// value the trace expects when it reads Y:$25 or X:$25.
    Mark { cycle: u64, line: usize, text: String, reads: Option<(Register, String)> },
}

/// What the timeline was drawn from.
pub struct Header {
    pub configuration: String,
    pub profile: String,
    pub servo_hz: u32,
    /// Every status bit, `(word, bit, name)`, X word first.
    pub bits: Vec<(WordId, u8, String)>,
}

impl Header {
    pub fn ms(&self, cycle: u64) -> f64 {
        cycle as f64 * 1000.0 / f64::from(self.servo_hz)
    }
}

fn signals(cfg: &ModelConfig, card: &Controller, cycle: u64, strobe: bool, background: bool) -> Signals {
    let (x, y) = card.status_words(cfg);
    Signals {
        cycle,
        counter: card.counter,
        counter_min: card.counter_min,
        strobe,
        tripped: card.tripped(),
        background,
        x,
        y,
    }
}

/// Opens the trace at `path`, resolves its configuration under `profile` (default: the trace's
/// first profile, the default profile when it lists `all`), and returns the header.
fn open(spec: &Spec, path: &Path, profile: Option<&str>) -> Result<(Source, ModelConfig, Header), SpecError> {
    if crate::import::detect_format(path)?.is_some() {
        return Err(SpecError::whole_file(
            path,
            "a log says only what the host saw; `pmacwd replay LOG --witness W.jsonl` finds a behaviour \
             that produces it, and `pmacwd timeline W.jsonl` draws that",
        ));
    }
    let source = Source::open(path)?;
    let allowed = source.profiles(spec, path)?;
    let chosen: Profile = match profile {
        Some(name) => allowed.iter().find(|p| p.name == name).cloned().ok_or_else(|| {
            SpecError::whole_file(
                path,
                format!(
                    "--profile {name}: the trace is for {}",
                    allowed.iter().map(|p| p.name.as_str()).collect::<Vec<_>>().join(", ")
                ),
            )
        })?,
        None if allowed.len() == spec.profiles.all().len() => spec.profiles.default_profile(),
        None => allowed[0].clone(),
    };
    let name = source.configuration().to_string();
    let mut cfg = ModelConfig::from_spec(spec, &name, &chosen)
        .map_err(|e| SpecError::whole_file(path, format!("configuration `{name}`: {}", e.message)))?;
    if let Some(card) = source.card() {
        cfg = cfg.with_card(spec, &card).map_err(|e| SpecError::whole_file(path, e))?;
    }
    // A trace runs with the card's real 24-bit servo counter, as `pmacwd run` does.
    cfg.servo_counter_mask = 0xFF_FFFF;
    let mut bits = Vec::new();
    for (id, word) in [(WordId::X, &spec.status.words.x), (WordId::Y, &spec.status.words.y)] {
        for (b, e) in &word.bits {
            bits.push((id, *b, e.name.clone()));
        }
    }
    let header = Header { configuration: name, profile: chosen.name.clone(), servo_hz: cfg.servo_hz, bits };
    Ok((source, cfg, header))
}

/// Reads the header only (for writers that need it before the first item).
pub fn header(spec: &Spec, path: &Path, profile: Option<&str>) -> Result<Header, SpecError> {
    open(spec, path, profile).map(|(_, _, h)| h)
}

/// The model as the timeline runs it, with the signal levels it keeps.
struct Run<'a> {
    cfg: &'a ModelConfig,
    card: Controller,
    cycle: u64,
    strobe: bool,
    background: bool,
    last: Signals,
}

impl Run<'_> {
    /// One servo cycle (and with `run`, a background cycle whenever the load allows).
    fn servo(&mut self, with_background: bool) {
        self.card.servo_cycle(self.cfg);
        self.cycle += 1;
        if self.card.cycles_since_strobe == 0 && !self.card.tripped() {
            self.strobe = !self.strobe;
        }
        if with_background && self.card.background_possible() {
            self.background_cycle();
        }
    }

    fn background_cycle(&mut self) {
        self.card.background_cycle(self.cfg);
        self.background = !self.background;
    }

    /// The signals now, if any changed since the last ones handed out.
    fn changed(&mut self) -> Option<Signals> {
        let now = signals(self.cfg, &self.card, self.cycle, self.strobe, self.background);
        if (Signals { cycle: self.last.cycle, ..now }) == self.last {
            return None;
        }
        self.last = now;
        Some(now)
    }
}

/// Runs the trace at `path` and hands `out` every change and mark, in time order. `out` may
/// stop the walk with an error (a closed pipe), which is returned as `Ok(Err(..))`.
pub fn walk(
    spec: &Spec,
    path: &Path,
    profile: Option<&str>,
    mut out: impl FnMut(&Header, Item) -> std::io::Result<()>,
) -> Result<std::io::Result<Header>, SpecError> {
    let (mut source, cfg, header) = open(spec, path, profile)?;
    let card = Controller::power_on(&cfg);
    let first = signals(&cfg, &card, 0, false, false);
    let mut run = Run { cfg: &cfg, card, cycle: 0, strobe: false, background: false, last: first };
    let emit = |run: &mut Run, out: &mut dyn FnMut(&Header, Item) -> std::io::Result<()>| match run.changed() {
        Some(now) => out(&header, Item::Change(now)),
        None => Ok(()),
    };
    if let Err(e) = out(&header, Item::Change(first)) {
        return Ok(Err(e));
    }
    while let Some((line, step)) = source.next_step()? {
        deterministic(&step.event).map_err(|e| SpecError::at(path, pmacwd_specs::Position { line, column: 1 }, e))?;
        let written = match &step.event {
            TraceEvent::Model(Event::Servo { cycles }) | TraceEvent::Run { cycles } => {
                let with_background = matches!(step.event, TraceEvent::Run { .. });
                let mut r = Ok(());
                for _ in 0..*cycles {
                    run.servo(with_background);
                    r = emit(&mut run, &mut out);
                    if r.is_err() {
                        break;
                    }
                }
                r
            }
            TraceEvent::Unanswered { command, wait_cycles } => {
                // The command marked where it was sent; the wait runs without a background cycle.
                let text = format!("`{command}` unanswered (no background cycle while the host waited)");
                let mut r = out(&header, Item::Mark { cycle: run.cycle, line, text, reads: None });
                for _ in 0..*wait_cycles {
                    if r.is_err() {
                        break;
                    }
                    run.servo(false);
                    r = emit(&mut run, &mut out);
                }
                r
            }
            TraceEvent::Model(Event::Background) if !run.card.background_possible() => {
                let what =
                    if run.card.tripped() { "the card is tripped" } else { "the load has not given it the time" };
                let text = format!("a background cycle the model cannot complete here ({what})");
                out(&header, Item::Mark { cycle: run.cycle, line, text, reads: None })
            }
            TraceEvent::Model(Event::Background) => {
                run.background_cycle();
                emit(&mut run, &mut out)
            }
            TraceEvent::Model(e) => {
                run.card.apply(&cfg, e);
                let reads = match (e, &step.expect.reply) {
                    (Event::Command(HostCommand::ReadHex(r @ Register::WatchdogCounter)), Some(v))
                    | (Event::Command(HostCommand::ReadHex(r @ Register::WatchdogMinimum)), Some(v)) => {
                        Some((*r, v.clone()))
                    }
                    _ => None,
                };
                out(&header, Item::Mark { cycle: run.cycle, line, text: e.to_string(), reads })
                    .and_then(|()| emit(&mut run, &mut out))
            }
            TraceEvent::Elapsed { .. } | TraceEvent::Restart | TraceEvent::RestartPossible => {
                unreachable!("refused by `deterministic`")
            }
        };
        if let Err(e) = written {
            return Ok(Err(e));
        }
    }
    Ok(Ok(header))
}
