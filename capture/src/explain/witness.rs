//! The explanation: one behaviour of the model that produces every observation of a capture,
//! as a trace (the capture's own steps with every unseen gap replaced by the events chosen)
//! and in words (what happened that the host could not see).

use super::gap::{self, Lead, Plan};
use super::history::{chain, Node, NodeKind};
use super::lanes::{self, LaneDef};
use super::search::{Cand, Checkpoint, Lane, Tolerances};
use super::sim::Sim;
use crate::replay::ImportAs;
use crate::replay::Source;
use pmacwd_model::controller::{Controller, TripCause};
use pmacwd_specs::check::ChecksumTarget;
use pmacwd_specs::config::ModelConfig;
use pmacwd_specs::vocab::event::Event;
use pmacwd_specs::{Spec, SpecError};
use pmacwd_trace::{Expect, Step, TraceEvent};
use std::path::Path;
use std::sync::Arc;

/// The explanation of a capture under one lane.
///
/// Its steps are not kept: they are rebuilt from the search's choices and the capture each
/// time they are walked ([`Witness::walk`]), so that its memory is the choices' (a few words a
/// gap), not the steps' (a day-long host log's explanation held as steps took 700 MB).
pub struct Witness {
    /// The search's choices since its last checkpoint, oldest first (all of them on a capture
    /// too short for one).
    nodes: Vec<Arc<Node>>,
    /// The checkpoints before them, and what searches each segment again.
    segments: Segments,
    /// The capture, opened again for each walk.
    capture: Capture,
    /// The lane's configuration the choices are run under.
    cfg: ModelConfig,
    /// Steps in the explanation as a trace.
    pub steps: usize,
    /// What happened that the host could not see, in words, with the capture's lines.
    pub story: Vec<String>,
    pub cpu: u8,
    /// Whether the capture shows the CPU type (no other type explains it).
    pub cpu_decided: bool,
    /// The lowest X:$25 the witness reaches.
    pub lowest_min: i32,
    /// The witness run on the model: observations reproduced, or the first that is not.
    pub checked: Option<Result<usize, String>>,
    /// The card's own hardware delay and supply threshold, when they are not the stated ones
    /// (UM p.215 gives both only approximately); the written trace carries them in `card:`.
    pub tolerances: Option<super::search::Tolerances>,
    /// At how many status reads the checksum engine is set on an area at the start of a pass:
    /// the card's pass lengths are its own (`Tolerances::free_area`). No model event sets the
    /// area, so a walk gives it with the step it comes before, and a written trace says where
    /// `pmacwd run` differs.
    pub areas: usize,
}

/// A recorded search's checkpoints (`search::Checkpoint`) and the lane that searches the
/// segments between them again.
#[derive(Clone, Debug)]
struct Segments {
    checkpoints: Vec<Checkpoint>,
    def: LaneDef,
    tolerances: Tolerances,
}

/// The capture's steps and the choices of each segment in turn, as a walk reaches them.
struct Chains<'w> {
    segments: &'w Segments,
    last: &'w [Arc<Node>],
    capture: &'w Capture,
    /// The capture, read once for the searches of the segments and the walk.
    reader: super::search::Reader,
    name: String,
    card: Option<pmacwd_specs::config::CardConfig>,
    next: usize,
    /// The steps a segment's search read, which the walk takes before reading on.
    steps: std::collections::VecDeque<(usize, Step)>,
}

impl<'w> Chains<'w> {
    fn open(
        spec: &Spec,
        segments: &'w Segments,
        last: &'w [Arc<Node>],
        capture: &'w Capture,
    ) -> Result<Self, SpecError> {
        let source = capture.open(spec)?;
        let (name, card) = (source.configuration().to_string(), source.card_as(&capture.import()));
        let reader = super::search::Reader::new(source);
        Ok(Chains { segments, last, capture, reader, name, card, next: 0, steps: Default::default() })
    }

    /// The capture's next step, from the segment's search or read on.
    fn step(&mut self) -> Result<Option<(usize, Step)>, SpecError> {
        match self.steps.pop_front() {
            Some(s) => Ok(Some(s)),
            None => self.reader.next_step(),
        }
    }

    /// The next segment's choices, oldest first, and the event it ends at (its steps searched
    /// again and kept for [`Chains::step`]).
    fn next(&mut self, spec: &Spec) -> Result<(Vec<Arc<Node>>, u64), SpecError> {
        let s = self.next;
        let count = self.segments.checkpoints.len();
        self.next += 1;
        if s >= count {
            return Ok((self.last.to_vec(), u64::MAX));
        }
        let path = &self.capture.path;
        let Segments { checkpoints, def, tolerances } = self.segments;
        let name = &self.name;
        let mut lane = Lane::new(spec, name, self.card.as_ref(), def.clone(), true, Some(*tolerances))
            .map_err(|e| SpecError::whole_file(path, format!("configuration `{name}`: {}", e.message)))?;
        if s > 0 {
            lane.resume(&checkpoints[s - 1]);
        }
        let end = &checkpoints[s];
        super::search::search_segment(spec, path, &mut self.reader, &mut lane, end.event, &mut self.steps)?;
        match &lane.cands[..] {
            [c] if c.card == end.cand.card && c.cpu == end.cand.cpu => {
                let node = c.node.as_ref().expect("a recorded lane");
                Ok((chain(node), end.event))
            }
            _ => Err(SpecError::whole_file(
                path,
                format!(
                    "the search of the capture's events to {} again did not come to its checkpoint (replay's own \
                     fault: please report it with the capture)",
                    end.event
                ),
            )),
        }
    }
}

/// The capture an explanation was found for and how it was imported: what a walk opens again.
#[derive(Clone, Debug)]
struct Capture {
    path: std::path::PathBuf,
    configuration: Option<String>,
    format: Option<crate::import::LogFormat>,
    placement: crate::import::Placement,
    card_i40: Option<i64>,
}

impl Capture {
    fn of(path: &Path, import: ImportAs<'_>) -> Capture {
        Capture {
            path: path.to_path_buf(),
            configuration: import.configuration.map(str::to_string),
            format: import.format,
            placement: import.placement,
            card_i40: import.card_i40,
        }
    }

    fn import(&self) -> ImportAs<'_> {
        ImportAs {
            configuration: self.configuration.as_deref(),
            format: self.format,
            placement: self.placement,
            host_time_limit: None,
            deadline: None,
            card_i40: self.card_i40,
        }
    }

    fn open(&self, spec: &Spec) -> Result<Source, SpecError> {
        Source::open_with(spec, &self.path, self.import())
    }
}

/// Where a walk puts the steps: each with the checksum area the engine is set on before it,
/// if any; `Break` ends the walk.
pub type Sink<'s> = dyn FnMut(&Step, Option<ChecksumTarget>) -> std::ops::ControlFlow<()> + 's;

/// The steps a walk gives out, and the area waiting for the next.
struct Out<'e, 's> {
    sink: &'e mut Sink<'s>,
    area: Option<ChecksumTarget>,
    count: usize,
    areas: usize,
    stopped: bool,
}

impl Out<'_, '_> {
    fn step(&mut self, s: &Step) {
        if self.stopped {
            return;
        }
        self.count += 1;
        if (self.sink)(s, self.area.take()).is_break() {
            self.stopped = true;
        }
    }

    fn bare(&mut self, event: TraceEvent, note: Option<String>) {
        self.step(&Step { event, expect: Expect::default(), note });
    }
}

/// What a walk tells besides its steps.
struct Told {
    story: Vec<String>,
    lowest_min: i32,
    steps: usize,
    areas: usize,
}

fn area(a: ChecksumTarget) -> &'static str {
    match a {
        ChecksumTarget::Firmware => "firmware",
        ChecksumTarget::UserProgram => "user program",
    }
}

/// The plan for a gap: the search's, aimed at the X:$25 value read next if that read comes
/// before another gap.
fn realize<'a>(
    cfg: &'a ModelConfig,
    card: &Controller,
    node: (&Plan, &Plan, &super::End),
    need: Option<i32>,
    need_counter: Option<i32>,
) -> Option<Sim<'a>> {
    let (plan_hi, plan_lo, end) = node;
    // Y:$25 may have been merged into an interval by the search: a Y:$25 read that matters is
    // met through `need_counter`, and the whole witness is checked at the end.
    let same_end = |c: &Controller| end.same_but_counters(c);
    let fits = |c: &Controller| need.is_none_or(|v| c.counter_min == v) && need_counter.is_none_or(|v| c.counter == v);
    if need.is_none() && need_counter.is_none() {
        return gap::run(cfg, card, *plan_hi, true);
    }
    let r = i64::from(cfg.reset_value(card.i40));
    let mut tries = vec![*plan_hi, *plan_lo];
    // A Y:$25 the search merged from a starved gap and a scheduled one (`gap::group`).
    if let (Some(_), Plan::Schedule { cycles, .. } | Plan::Starved { cycles, .. }) = (need_counter, plan_hi) {
        tries.push(Plan::Starved { cycles: *cycles, heavy: 0, overrun_last: 0 });
    }
    let heavies = 0..=3 * (u32::from(card.i8) + 1) + 2;
    for (base, heavy) in [*plan_hi, *plan_lo].into_iter().flat_map(|b| heavies.clone().map(move |h| (b, h))) {
        if let Plan::Schedule { cycles, fault, tail, overrun_last, hold, .. } = base {
            if heavy >= cycles {
                continue;
            }
            let tail = match need_counter {
                Some(v) => match u32::try_from(r - i64::from(v)) {
                    Ok(t) if t <= cycles => t,
                    _ => continue,
                },
                None => tail,
            };
            let c0 = super::run_down(cfg, card.counter, heavy);
            let mut leads = vec![Lead::Steady];
            if card.background_possible() {
                leads.push(Lead::ReloadFirst);
            }
            if let Some(need) = need {
                leads.extend(
                    [
                        (c0 - i64::from(need)).try_into().ok().filter(|j| *j > 0).map(Lead::FirstAfter),
                        (r - i64::from(need)).try_into().ok().filter(|s| *s > 0).map(Lead::Stretch),
                    ]
                    .into_iter()
                    .flatten(),
                );
            }
            for lead in leads {
                for skip in [false, true] {
                    tries.push(Plan::Schedule { cycles, fault, heavy, lead, skip, tail, overrun_last, hold });
                }
            }
        }
    }
    // Best: the target met and Y:$25 left where the search continued from (the next gap's
    // plans start there); then the target met; then the search's own end.
    let (mut fitting, mut fallback) = (None, None);
    for plan in tries {
        if let Some(sim) = gap::run(cfg, card, plan, true) {
            if same_end(&sim.card) {
                if fits(&sim.card) {
                    if sim.card.counter == end.counter {
                        return Some(sim);
                    }
                    fitting.get_or_insert(sim);
                } else {
                    fallback.get_or_insert(sim);
                }
            }
        }
    }
    fitting.or(fallback).or_else(|| gap::run(cfg, card, *plan_hi, true))
}

/// Replays the capture at `path` with the choices of `cand`'s chain (a candidate of `lane`,
/// searched with its choices recorded): the explanation, its story, and whether it reproduces
/// every observation on the model under the lane's configuration (one walk).
pub fn build(
    spec: &pmacwd_specs::Spec,
    lane: &Lane,
    path: &Path,
    import_configuration: crate::replay::ImportAs<'_>,
    cand: &Cand,
    others: &[&ModelConfig],
) -> Result<(Witness, Vec<RunResult>), SpecError> {
    let cfg = &lane.cfg;
    let nodes = chain(cand.node.as_ref().expect("a recorded candidate"));
    let cpu = cand.cpu;
    let capture = Capture::of(path, import_configuration);
    let segments =
        Segments { checkpoints: lane.checkpoints.clone(), def: lane.def.clone(), tolerances: lane.tolerances };
    let cfgs: Vec<&ModelConfig> = std::iter::once(cfg).chain(others.iter().copied()).collect();
    let chains = Chains::open(spec, &segments, &nodes, &capture)?;
    let (told, mut runs) = with_runs(spec, cpu, &cfgs, false, |sink| walk_chain(spec, cfg, chains, sink))?;
    let own = runs.remove(0);
    let w = Witness {
        nodes,
        segments,
        capture,
        cfg: cfg.clone(),
        steps: told.steps,
        story: told.story,
        cpu,
        cpu_decided: false,
        lowest_min: told.lowest_min,
        checked: Some(own.map(|(n, _)| n)),
        tolerances: None,
        areas: told.areas,
    };
    Ok((w, runs))
}

impl Witness {
    /// Gives every step of the explanation to `sink`, in order (the capture read again).
    pub fn walk(&self, spec: &Spec, sink: &mut Sink<'_>) -> Result<(), SpecError> {
        let chains = Chains::open(spec, &self.segments, &self.nodes, &self.capture)?;
        walk_chain(spec, &self.cfg, chains, sink).map(|_| ())
    }

    /// Every step of the explanation, collected (for a short capture: a day-long one has
    /// millions).
    pub fn collect_steps(&self, spec: &Spec) -> Result<Vec<(Step, Option<ChecksumTarget>)>, SpecError> {
        let mut v = Vec::new();
        self.walk(spec, &mut |s, a| {
            v.push((s.clone(), a));
            std::ops::ControlFlow::Continue(())
        })?;
        Ok(v)
    }
}

/// Which gaps of a segment's choices meet which reads.
struct Aims {
    targets: super::sim::FastMap<usize, i32>,
    counter_targets: super::sim::FastMap<usize, i32>,
    starve: super::sim::FastSet<usize>,
}

impl Aims {
    fn of(cfg: &ModelConfig, nodes: &[Arc<Node>]) -> Aims {
        let mut aims =
            Aims { targets: Default::default(), counter_targets: Default::default(), starve: Default::default() };
        let reload = i64::from(cfg.reset_value(cfg.saved.i40));
        // Each X:$25 read that narrowed an interval is met by the latest gap before it that can
        // run down that far; the other gaps keep X:$25 as high as they can. Where that gap ran
        // no background cycle (a starved gap's X:$25 is where its start leaves it), the read is
        // the bottom of a run-down through it: met as a Y:$25 read of the same value would be
        // (below), by the gap where the run-down began (seed 38's sluggish log: a run-down
        // through four unanswered commands and the gaps between them, aimed at the last gap
        // of two cycles, missed the read by 109 cycles).
        for (p, node) in nodes.iter().enumerate() {
            if let NodeKind::Pin(v) = node.kind {
                let gap = (0..p).rev().find(|&g| {
                    matches!(&nodes[g].kind, NodeKind::Restart(_))
                        || matches!(&nodes[g].kind, NodeKind::Gap { lo, .. } if *lo <= v)
                });
                match gap.map(|g| (g, &nodes[g].kind)) {
                    Some((_, NodeKind::Gap { plan_hi: Plan::Starved { .. }, plan_lo: Plan::Starved { .. }, .. })) => {
                        aims.back_to_reload(nodes, p, v, reload, false);
                    }
                    Some((g, NodeKind::Gap { .. })) => {
                        aims.targets.insert(g, v);
                    }
                    _ => {}
                }
            }
        }
        // Each Y:$25 read that narrowed an interval is met by the latest gap before it with a
        // background cycle (through the starved gaps in between, which only shift the counter).
        // A gap shorter than the run-down such a read needs had no background cycle at all: it is
        // starved, and the read is met by the gap before it.
        for (p, node) in nodes.iter().enumerate() {
            if let NodeKind::CounterPin(v) = node.kind {
                aims.back_to_reload(nodes, p, v, reload, true);
            }
        }
        aims
    }

    /// Aims the gaps before node `p` so that the counter reads `v` there: the latest gap with
    /// a background cycle ends with the counter at `v` plus the cycles of the starved gaps and
    /// waits after it (which only run it down), and a gap too short for that run-down is
    /// starved whole. `over`: this read's target replaces one an earlier read gave the same gap.
    /// A Y:$25 read's does (the X:$25 reads are aimed first). An X:$25 read's does not: a later
    /// read of the same run-down's bottom (the value read again after it) is met by the first
    /// one's aim, and adding the cycles between the two reads would aim the run-down deeper.
    fn back_to_reload(&mut self, nodes: &[Arc<Node>], p: usize, v: i32, reload: i64, over: bool) {
        let mut v = i64::from(v);
        for g in (0..p).rev() {
            match &nodes[g].kind {
                NodeKind::Gap { plan_hi: Plan::Starved { cycles, .. }, .. } => v += i64::from(*cycles),
                NodeKind::Gap { plan_hi: Plan::Schedule { cycles, .. }, .. } if reload - v >= i64::from(*cycles) => {
                    self.starve.insert(g);
                    v += i64::from(*cycles);
                }
                NodeKind::Gap { .. } => {
                    if let Ok(v) = i32::try_from(v) {
                        if over {
                            self.counter_targets.insert(g, v);
                        } else {
                            self.counter_targets.entry(g).or_insert(v);
                        }
                    }
                    break;
                }
                NodeKind::Restart(_) | NodeKind::Start { .. } | NodeKind::Root => break,
                // The host's wait ran the counter down with no background cycle (a read
                // after it comes from a running card).
                NodeKind::Wait { cycles, .. } => v += i64::from(*cycles),
                NodeKind::Pin(_) | NodeKind::CounterPin(_) | NodeKind::Area(_) => {}
            }
        }
    }
}

/// The capture read with the choices `chains` gives segment by segment, every step given to
/// `sink`.
fn walk_chain(spec: &Spec, cfg: &ModelConfig, mut chains: Chains<'_>, sink: &mut Sink<'_>) -> Result<Told, SpecError> {
    let mut card = Controller::power_on(cfg);
    let mut out = Out { sink, area: None, count: 0, areas: 0, stopped: false };
    let mut story = Vec::new();
    let mut event = 0u64;
    let mut at = 1usize;
    // Servo cycles since the start of the capture, for the story's times.
    let mut now = 0u64;
    let mut last_line = 0usize;
    let mut lowest_min = card.counter_min;
    let mut dip_line = 0usize;
    // Whether the capture reads X:$25: the dip is told only where the log can see it (issue
    // 29: the explanation's own choices in what the log does not read are not findings).
    let mut x25_read = false;
    let mut area_lines: Vec<usize> = Vec::new();
    let (mut nodes, mut ends) = (Vec::new(), 0u64);
    let mut aims = Aims::of(cfg, &nodes);
    loop {
        while event >= ends {
            // At a checkpoint (or the start): the next segment's choices, its first node the
            // start or the root.
            (nodes, ends) = chains.next(spec)?;
            aims = Aims::of(cfg, &nodes);
            at = 1;
        }
        let Some((line, step)) = chains.step()? else { break };
        if out.stopped {
            break;
        }
        x25_read |= super::reads::min_read(&step).is_some();
        event += 1;
        while at < nodes.len() && nodes[at].event < event {
            at += 1;
        }
        // A pin recorded at a gap (the Y:$25 its plan started from) comes before the gap's node.
        while at < nodes.len()
            && nodes[at].event == event
            && matches!(nodes[at].kind, NodeKind::Pin(_) | NodeKind::CounterPin(_))
            && matches!(step.event, TraceEvent::Elapsed { .. })
        {
            at += 1;
        }
        match &step.event {
            TraceEvent::Elapsed { .. } => {
                let Some(NodeKind::Gap { plan_hi, plan_lo, end, .. }) =
                    nodes.get(at).filter(|n| n.event == event).map(|n| &n.kind)
                else {
                    story.push(format!("line {line}: (no choice recorded for this gap)"));
                    continue;
                };
                let need = aims.targets.get(&at).copied();
                let starved = match plan_hi {
                    Plan::Schedule { cycles, .. } if aims.starve.contains(&at) => {
                        gap::run(cfg, &card, Plan::Starved { cycles: *cycles, heavy: 0, overrun_last: 0 }, true)
                            .filter(|sim| end.same_but_counters(&sim.card))
                    }
                    _ => None,
                };
                let Some(sim) = starved.or_else(|| {
                    realize(cfg, &card, (plan_hi, plan_lo, end), need, aims.counter_targets.get(&at).copied())
                }) else {
                    story.push(format!("line {line}: (the recorded plan could not be replayed)"));
                    continue;
                };
                let plan = if sim.card.counter_min == end.counter_min { *plan_hi } else { *plan_lo };
                let between = format!("between lines {last_line} and {line}");
                match plan {
                    Plan::Undervoltage { .. } => story.push(format!(
                        "{between}: the logic supply dipped below its minimum (about 4.75 V, UM p.215) and the \
                         card tripped"
                    )),
                    Plan::Starved { cycles, heavy, .. } if sim.card.tripped() && !card.tripped() => {
                        let (edge, trip) = strobe_and_trip(cfg, &card, sim.events.as_deref().unwrap_or_default());
                        let at = |t: u64| {
                            format!(
                                "servo cycle {} of the capture ({} into the gap, {:.1} ms)",
                                now + t,
                                t,
                                t as f64 * 1000.0 / f64::from(cfg.servo_hz)
                            )
                        };
                        let when = match (edge, trip) {
                            (Some(e), Some(t)) => format!(
                                "the last strobe edge came at {}; with no edge for more than {} cycles (the hardware \
                                 delay) the card tripped at {}",
                                at(e),
                                cfg.hardware_delay_cycles,
                                at(t)
                            ),
                            (None, Some(t)) => format!("the card tripped at {}", at(t)),
                            _ => format!("the card tripped within the gap's {cycles} servo cycles"),
                        };
                        story.push(format!(
                            "{between}: no background cycle completed{}, so nothing reloaded the counter (Y:$25 was \
                             {} at the start of the gap); it ran down and the strobe stopped: {when} (UM p.215)",
                            if heavy >= cycles { " (PLC 0 overran every RTI period and took the CPU)" } else { "" },
                            card.counter
                        ))
                    }
                    Plan::Starved { heavy: 1.., .. }
                    | Plan::Starved { overrun_last: 1.., .. }
                    | Plan::Schedule { overrun_last: 1.., .. } => story.push(format!(
                        "{between}: PLC 0 (or another RTI task) ran longer than an RTI period and the RTI \
                         overran (bits 22 and 9, SRM p.289-290)"
                    )),
                    Plan::Schedule { heavy: 1.., .. } => story.push(format!(
                        "{between}: an RTI task set (PLC 0, move planning) ran longer than an RTI period, so the \
                         next RTI overran (bits 22 and 9, SRM p.289-290)"
                    )),
                    Plan::Schedule { fault: Some(a), .. } => story.push(format!(
                        "{between}: {} memory was corrupted and the background checksum found it (bit 13, UM p.217)",
                        area(a)
                    )),
                    _ => {}
                }
                now += sim.cycles;
                card = sim.card.clone();
                if card.counter_min < lowest_min {
                    lowest_min = card.counter_min;
                    dip_line = line;
                }
                let mut note = step.note.clone();
                for e in sim.events.unwrap_or_default() {
                    out.bare(e, note.take());
                }
            }
            TraceEvent::Restart | TraceEvent::RestartPossible => {
                let Some(NodeKind::Restart(reset)) = nodes.get(at).filter(|n| n.event == event).map(|n| &n.kind) else {
                    if step.event == TraceEvent::Restart {
                        story.push(format!("line {line}: (no choice recorded for this restart)"));
                    }
                    continue;
                };
                let was = if card.tripped() { "the tripped card" } else { "the card" };
                let mut findings = String::new();
                if reset.dpram_fault {
                    findings.push_str(", its DPRAM check failed");
                }
                if reset.flash_fault {
                    findings.push_str(", its flash read failed");
                }
                if reset.bootstrap {
                    findings.push_str(", in bootstrap mode");
                }
                story.push(format!(
                    "between lines {last_line} and {line}: {was} was reset (INIT/, a power cycle or `$$$`: the \
                     log cannot tell which){findings}"
                ));
                let e = Event::Reset(*reset);
                card.apply(cfg, &e);
                lowest_min = card.counter_min;
                out.step(&Step { event: TraceEvent::Model(e), expect: step.expect.clone(), note: step.note.clone() });
            }
            TraceEvent::Unanswered { command, wait_cycles } => {
                let late = nodes[at.min(nodes.len())..]
                    .iter()
                    .take_while(|n| n.event == event)
                    .any(|n| matches!(n.kind, NodeKind::Wait { late: true, .. }));
                let running = !card.tripped();
                card.unanswered(cfg, *wait_cycles);
                now += u64::from(*wait_cycles);
                // A wait of 0 (a timeout the log did not stamp) tells nothing worth a line.
                if running && (*wait_cycles > 0 || card.tripped()) {
                    story.push(format!(
                        "line {line}: `{command}` was not answered: no background cycle, which processes host \
                         commands (UM p.236), completed in the {wait_cycles} servo cycles the host waited{}",
                        if card.tripped() { ", and the card tripped meanwhile (UM p.215)" } else { "" }
                    ));
                }
                out.step(&step);
                if late && !card.tripped() {
                    let e = Event::Command(command.clone());
                    card.apply(cfg, &e);
                    story.push(format!(
                        "line {line}: the card processed `{command}` after the host gave up (its answer went \
                         unread)"
                    ));
                    out.bare(
                        TraceEvent::Model(e),
                        Some("processed after the host gave up waiting; its answer is not in the log".into()),
                    );
                }
            }
            TraceEvent::Run { cycles } => {
                let mut s = Sim::new(cfg, card.clone(), false);
                s.greedy(*cycles);
                card = s.card;
                now += u64::from(*cycles);
                out.step(&step);
            }
            TraceEvent::Model(e) => {
                if let Event::Servo { cycles } = e {
                    now += u64::from(*cycles);
                }
                let chosen =
                    nodes[at.min(nodes.len())..].iter().take_while(|n| n.event == event).find_map(|n| match n.kind {
                        NodeKind::Area(a) => Some(a),
                        _ => None,
                    });
                if let Some(a) = chosen {
                    area_lines.push(line);
                    card.checksum.area = a;
                    card.checksum.position = 0;
                    out.area = Some(a);
                    out.areas += 1;
                }
                card.apply(cfg, e);
                if matches!(
                    e,
                    Event::Command(
                        pmacwd_specs::vocab::command::HostCommand::Reset
                            | pmacwd_specs::vocab::command::HostCommand::Reinitialize
                    )
                ) {
                    lowest_min = card.counter_min;
                }
                out.step(&step);
            }
        }
        last_line = line;
    }
    if !area_lines.is_empty() {
        let shown: Vec<String> = area_lines.iter().take(AREA_LINES_TOLD).map(|l| l.to_string()).collect();
        let more = area_lines.len().saturating_sub(AREA_LINES_TOLD);
        story.push(format!(
            "the card's checksum passes are of its own length (UM p.217 gives none): a pass ended before the \
             status read of line{} {}{}, whose bit 12 shows the other area (SRM p.289)",
            if area_lines.len() == 1 { "" } else { "s" },
            shown.join(", "),
            if more > 0 { format!(" and {more} more") } else { String::new() }
        ));
    }
    if lowest_min < cfg.reset_value(card.i40) - 1 && dip_line > 0 && x25_read {
        story.push(format!(
            "the longest run without a background cycle took X:$25 down to {lowest_min} (by line {dip_line})"
        ));
    }
    Ok(Told { story, lowest_min, steps: out.count, areas: out.areas })
}

/// When, in servo cycles from the start of `events` run on `card`, the last strobe edge came
/// and the card tripped (UM p.215: a strobe slower than the minimum trips the timer).
fn strobe_and_trip(cfg: &ModelConfig, card: &Controller, events: &[TraceEvent]) -> (Option<u64>, Option<u64>) {
    let mut c = card.clone();
    let (mut t, mut edge, mut trip) = (0u64, None, None);
    for e in events {
        match e {
            TraceEvent::Model(Event::Servo { cycles }) => {
                for _ in 0..*cycles {
                    if c.tripped() {
                        break;
                    }
                    c.servo_cycle(cfg);
                    t += 1;
                    if c.cycles_since_strobe == 0 {
                        edge = Some(t);
                    }
                    if c.tripped() {
                        trip = Some(t);
                    }
                }
            }
            TraceEvent::Model(e) => {
                c.apply(cfg, e);
                if c.tripped() && trip.is_none() {
                    trip = Some(t);
                }
            }
            // Gap plans write only model events.
            TraceEvent::Run { .. }
            | TraceEvent::Elapsed { .. }
            | TraceEvent::Restart
            | TraceEvent::RestartPossible
            | TraceEvent::Unanswered { .. } => {}
        }
        if trip.is_some() {
            break;
        }
    }
    (edge, trip)
}

/// Runs a witness on the model (the search's configuration, the witness's CPU type) and
/// checks every observation it carries: `Ok(n)` with the number checked, or the first step
/// that does not hold. An explanation is only printed once this holds.
pub fn reproduces(spec: &pmacwd_specs::Spec, cfg: &ModelConfig, w: &Witness) -> Result<usize, String> {
    run(spec, cfg, w).map(|(checked, _)| checked)
}

/// Runs the witness on the model under `cfg` from power-on, comparing every step's
/// expectations: how many were checked, and the card at the end.
pub fn run(spec: &pmacwd_specs::Spec, cfg: &ModelConfig, w: &Witness) -> Result<(usize, Controller), String> {
    run_many(spec, &[cfg], w).map_err(|e| e.to_string())?.pop().expect("one configuration, one result")
}

/// Runs the witness on the model under each of `cfgs` in one walk (the capture is read once
/// for all): for each, as [`run`].
pub fn run_many(spec: &pmacwd_specs::Spec, cfgs: &[&ModelConfig], w: &Witness) -> Result<Vec<RunResult>, SpecError> {
    with_runs(spec, w.cpu, cfgs, true, |sink| w.walk(spec, sink)).map(|((), runs)| runs)
}

/// Runs the steps `walk` gives its sink on the model under each of `cfgs` (as [`run`]);
/// `stop`: the walk ends once every run has failed. With more than a few runs, the walking
/// thread runs the first half and a second thread the rest, fed the steps in chunks (a
/// day-long log's explanation checked under 95 lanes' readings took 12 s on one core).
fn with_runs<T>(
    spec: &Spec,
    cpu: u8,
    cfgs: &[&ModelConfig],
    stop: bool,
    walk: impl FnOnce(&mut Sink<'_>) -> Result<T, SpecError>,
) -> Result<(T, Vec<RunResult>), SpecError> {
    use std::ops::ControlFlow;
    use std::sync::atomic::{AtomicBool, Ordering};
    let shared = cfgs.len() >= RUNS_SHARED_MIN;
    let (here, there) = cfgs.split_at(if shared { cfgs.len().div_ceil(2) } else { cfgs.len() });
    let mut runners: Vec<Runner<'_>> = here.iter().map(|c| Runner::new(c)).collect();
    // The second thread's runs have all failed (or there are none): its steps need not be sent.
    let there_done = AtomicBool::new(there.is_empty());
    std::thread::scope(|scope| {
        let (to_there, chunks) = std::sync::mpsc::sync_channel::<Vec<(Step, Option<ChecksumTarget>)>>(2);
        let done = &there_done;
        let helper = (!there.is_empty()).then(|| {
            scope.spawn(move || {
                let mut runners: Vec<Runner<'_>> = there.iter().map(|c| Runner::new(c)).collect();
                for chunk in chunks {
                    for (step, area) in &chunk {
                        for r in runners.iter_mut() {
                            r.step(spec, cpu, step, *area);
                        }
                    }
                    if runners.iter().all(|r| r.failed.is_some()) {
                        done.store(true, Ordering::Relaxed);
                    }
                }
                runners.into_iter().map(Runner::result).collect::<Vec<_>>()
            })
        });
        let mut chunk = Vec::new();
        let walked = walk(&mut |step, area| {
            for r in runners.iter_mut() {
                r.step(spec, cpu, step, area);
            }
            let there_running = !there_done.load(Ordering::Relaxed);
            if there_running {
                chunk.push((step.clone(), area));
                // A helper that stopped (it panicked) is found at its join.
                if chunk.len() == RUN_CHUNK_STEPS
                    && to_there.send(std::mem::replace(&mut chunk, Vec::with_capacity(RUN_CHUNK_STEPS))).is_err()
                {
                    return ControlFlow::Break(());
                }
            }
            if stop && !there_running && runners.iter().all(|r| r.failed.is_some()) {
                ControlFlow::Break(())
            } else {
                ControlFlow::Continue(())
            }
        });
        if !chunk.is_empty() {
            let _ = to_there.send(chunk);
        }
        drop(to_there);
        let theirs = helper.map(|h| h.join());
        let walked = walked?;
        let mut results: Vec<RunResult> = runners.into_iter().map(Runner::result).collect();
        if let Some(theirs) = theirs {
            results.extend(theirs.map_err(|_| SpecError::whole_file(Path::new("replay"), "a witness run panicked"))?);
        }
        Ok((walked, results))
    })
}

/// From how many runs [`with_runs`] shares them out over two threads.
const RUNS_SHARED_MIN: usize = 8;

/// Steps handed to the second thread of [`with_runs`] at a time.
const RUN_CHUNK_STEPS: usize = 2048;

/// A run's observations checked and its card at the end, or its first mismatch.
pub type RunResult = Result<(usize, Controller), String>;

/// A witness run on the model under one configuration from power-on, step by step, every
/// step's expectations compared (as `pmacwd run` runs a trace).
struct Runner<'c> {
    cfg: &'c ModelConfig,
    card: Controller,
    checked: usize,
    steps: usize,
    failed: Option<String>,
}

impl<'c> Runner<'c> {
    fn new(cfg: &'c ModelConfig) -> Runner<'c> {
        Runner { cfg, card: Controller::power_on(cfg), checked: 0, steps: 0, failed: None }
    }

    fn step(&mut self, spec: &Spec, cpu: u8, step: &Step, area: Option<ChecksumTarget>) {
        use super::observe::observation;
        if self.failed.is_some() {
            return;
        }
        self.steps += 1;
        let (cfg, card, i) = (self.cfg, &mut self.card, self.steps);
        if let Some(a) = area {
            card.checksum.area = a;
            card.checksum.position = 0;
        }
        let reply = match &step.event {
            TraceEvent::Model(Event::Background) if !card.background_possible() => {
                self.failed = Some(format!("witness step {i}: a background cycle the model cannot complete"));
                return;
            }
            TraceEvent::Model(e) => card.apply(cfg, e),
            TraceEvent::Unanswered { wait_cycles, .. } => card.unanswered(cfg, *wait_cycles),
            TraceEvent::Run { cycles } => {
                let mut s = Sim::new(cfg, card.clone(), false);
                s.greedy(*cycles);
                *card = s.card;
                pmacwd_specs::vocab::event::Reply::None
            }
            TraceEvent::Elapsed { .. } | TraceEvent::Restart | TraceEvent::RestartPossible => {
                self.failed = Some(format!("witness step {i}: `{}` left unresolved", step.event));
                return;
            }
        };
        // A step that expects nothing (a gap's) holds whatever the card shows.
        if step.expect == Expect::default() {
            return;
        }
        let obs = observation(cfg, card, cpu, reply);
        match super::search::compare_windowed(spec, cfg, &step.expect, card, &obs) {
            Ok(n) => self.checked += n,
            Err(pmacwd_trace::compare::Mismatch::Field(what, expected, observed)) => {
                self.failed = Some(format!(
                    "witness step {i} (`{}`): {what}: expected {expected}, observed {observed}",
                    step.event
                ))
            }
            Err(pmacwd_trace::compare::Mismatch::UnknownBit(_, _, name)) => {
                self.failed = Some(format!("unknown status bit `{name}`"))
            }
        }
    }

    fn result(self) -> Result<(usize, Controller), String> {
        match self.failed {
            Some(e) => Err(e),
            None => Ok((self.checked, self.card)),
        }
    }
}

/// Writes a witness as a JSON Lines trace: the capture's configuration, the named profiles of
/// its readings (or `all`, with the readings in the description), and every step. The CPU
/// type bits of the `???` replies it expects are those of the configuration's processor, which
/// the model reports (SRM p.289; the description says which type the capture showed), so that
/// `pmacwd run` reproduces it on the model as it stands.
/// What a written witness says about itself: the capture's configuration and card, the
/// readings it was found under and the named profiles choosing them.
pub struct WitnessHeader<'a> {
    pub configuration: &'a str,
    pub card: Option<&'a pmacwd_specs::config::CardConfig>,
    pub readings: &'a str,
    pub profiles: Vec<String>,
}

pub fn write_trace(
    spec: &pmacwd_specs::Spec,
    out: &mut dyn std::io::Write,
    yaml: bool,
    w: &Witness,
    header: WitnessHeader<'_>,
) -> std::io::Result<()> {
    let WitnessHeader { configuration, card, readings, profiles } = header;
    // A card whose delay or supply threshold is not the stated one says so in its header, so
    // that `pmacwd run` runs the witness on the same card.
    let mut own = card.copied().unwrap_or_default();
    if let Some(t) = w.tolerances {
        own.hardware_delay_cycles = Some(t.hardware_delay_cycles);
        own.supply_min_millivolts = Some(t.supply_min_millivolts);
        let p = t.checksum_pass_cycles;
        own.checksum_pass_cycles = Some(u32::from(p.firmware));
        if p.user_program != p.firmware {
            own.user_program_checksum_pass_cycles = Some(u32::from(p.user_program));
        }
    }
    let card = (!own.is_empty()).then_some(&own);
    use pmacwd_specs::vocab::reply_text::{self, StatusReply};
    // The CPU type the configuration's processor gives (X21 is bit 1, Y21 bit 0).
    let configured_cpu = spec.check.configurations.get(configuration).map_or(0, |c| {
        let (bit1, bit0) = c.processor.type_bits();
        (u8::from(bit1) << 1) | u8::from(bit0)
    });
    let layout = pmacwd_specs::config::StatusLayout::of(spec).map_err(|e| std::io::Error::other(e.message))?;
    let trace = pmacwd_trace::Trace {
        version: pmacwd_trace::FORMAT_VERSION,
        description: format!(
            "Witness found by pmacwd replay under the readings {readings}: the capture's steps with every \
             unseen gap replaced by events of the model. CPU type {} (bits 21 of ??? in the expected \
             replies are the configuration's processor's).{}",
            w.cpu,
            if w.areas == 0 {
                String::new()
            } else {
                format!(
                    " The card's checksum passes are of its own length: at {} status reads the area bit 12 shows \
                     is the log's, which no event of the model sets, so `pmacwd run` of this trace differs there.",
                    w.areas
                )
            }
        ),
        cite: None,
        configuration: configuration.to_string(),
        profiles: if profiles.is_empty() {
            pmacwd_specs::check::ProfileSelection::Keyword(pmacwd_specs::check::AllKeyword::All)
        } else {
            pmacwd_specs::check::ProfileSelection::Named(profiles)
        },
        steps: Vec::new(),
    };
    if yaml {
        write!(out, "{}", pmacwd_trace::yaml_header_with_card(&trace, card))?;
    } else {
        writeln!(out, "{}", pmacwd_trace::jsonl::header_line_with_card(&trace, card))?;
    }
    let mut failed: Option<std::io::Error> = None;
    let walked = w.walk(spec, &mut |step, _| {
        let mut step = step.clone();
        if let Some(r) = &step.expect.reply {
            if let Ok(StatusReply::Words { x, y }) = reply_text::decode(r) {
                if r.len() == 12 {
                    let (x, y) = super::observe::with_cpu(&layout, configured_cpu, (x, y));
                    step.expect.reply = Some(reply_text::encode(StatusReply::Words { x, y }));
                }
            }
        }
        let written = if yaml {
            write!(out, "{}", pmacwd_trace::yaml_step(&step))
        } else {
            writeln!(out, "{}", pmacwd_trace::jsonl::step_line(&step))
        };
        match written {
            Ok(()) => std::ops::ControlFlow::Continue(()),
            Err(e) => {
                failed = Some(e);
                std::ops::ControlFlow::Break(())
            }
        }
    });
    if let Some(e) = failed {
        return Err(e);
    }
    walked.map_err(|e| std::io::Error::other(e.to_string()))
}

/// Searches `path` again on one lane with its choices recorded, and builds the explanation.
pub fn witness_for(
    spec: &Spec,
    path: &Path,
    import_configuration: ImportAs<'_>,
    def: LaneDef,
    tolerances: Tolerances,
) -> Result<(String, Witness), SpecError> {
    let (lanes, _, _) = super::search::search_once(
        spec,
        path,
        import_configuration,
        std::iter::once((def, Some(tolerances))),
        true,
        true,
    )?;
    of_lane(spec, path, import_configuration, &lanes[0], &[]).map(|(label, w, _)| (label, w))
}

/// The explanation of a lane that explains the capture, searched with its choices recorded;
/// the walk that checks it also runs it under each of `others` (as [`run_many`]).
pub fn of_lane(
    spec: &Spec,
    path: &Path,
    import_configuration: ImportAs<'_>,
    lane: &super::search::Lane,
    others: &[&ModelConfig],
) -> Result<(String, Witness, Vec<RunResult>), SpecError> {
    let label = lanes::label(&lane.def.choices);
    let tolerances = lane.tolerances;
    // Prefer a card at the end that is as the log's last command found it (tripped if it went
    // unanswered: a starved card that has not tripped is silent too, UM p.236, but a log that
    // ends silent is told as a trip first), then the shallowest X:$25; a merged candidate
    // keeps one history, so the first whose witness reproduces the capture is taken.
    let ends_silent = ends_silent(spec, path, import_configuration)?;
    let mut cands: Vec<&super::search::Cand> = lane.cands.iter().filter(|c| c.node.is_some()).collect();
    // A starved background before a supply dip: both are possible where the card fell silent,
    // and the diagnosis lists both; the story tells the one the log's readings point at.
    cands.sort_by_key(|c| {
        (c.card.tripped() != ends_silent, c.card.trip == Some(TripCause::Undervoltage), -c.card.counter_min, c.cpu)
    });
    let mut first: Option<(Witness, Vec<RunResult>)> = None;
    for c in cands.iter().take(WITNESS_TRIES) {
        let (mut w, theirs) = build(spec, lane, path, import_configuration, c, others)?;
        w.tolerances = (tolerances != lane.stated).then_some(tolerances);
        w.cpu_decided = lane.cands.iter().all(|o| o.cpu == w.cpu);
        if matches!(w.checked, Some(Ok(_))) {
            return Ok((label, w, theirs));
        }
        first.get_or_insert((w, theirs));
    }
    first
        .map(|(w, theirs)| (label, w, theirs))
        .ok_or_else(|| SpecError::whole_file(path, "the second search found no explanation the first one found"))
}

/// Whether the capture's last command went unanswered.
fn ends_silent(spec: &Spec, path: &Path, import_configuration: ImportAs<'_>) -> Result<bool, SpecError> {
    let mut source = Source::open_with(spec, path, import_configuration)?;
    let mut silent = false;
    while let Some((_, step)) = source.next_step()? {
        match step.event {
            TraceEvent::Unanswered { .. } => silent = true,
            TraceEvent::Model(Event::Command(_)) => silent = step.expect.reply.as_deref() == Some("(silence)"),
            _ => {}
        }
    }
    Ok(silent)
}

/// How many lines the story names where the area bit 12 shows was taken from the log.
const AREA_LINES_TOLD: usize = 5;

/// How many end candidates are tried for a witness that reproduces the capture.
const WITNESS_TRIES: usize = 16;
