//! The explanation: one behaviour of the model that produces every observation of a capture,
//! as a trace (the capture's own steps with every unseen gap replaced by the events chosen)
//! and in words (what happened that the host could not see).

use super::gap::{self, Lead, Plan};
use super::history::{chain, Node, NodeKind};
use super::lanes::{self, LaneDef};
use super::search::Tolerances;
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

/// One step of an explanation, kept small: a day-long capture's explanation has over a
/// million, most of them servo and background events with nothing expected (24 bytes instead
/// of a whole step's 200).
#[derive(Clone, Debug)]
pub enum WitnessStep {
    Bare(TraceEvent),
    Full(Box<Step>),
}

impl WitnessStep {
    pub fn new(step: Step) -> WitnessStep {
        if step.note.is_none() && step.expect == Expect::default() {
            WitnessStep::Bare(step.event)
        } else {
            WitnessStep::Full(Box::new(step))
        }
    }

    pub fn event(&self) -> &TraceEvent {
        match self {
            WitnessStep::Bare(e) => e,
            WitnessStep::Full(s) => &s.event,
        }
    }

    pub fn expect(&self) -> Option<&Expect> {
        match self {
            WitnessStep::Bare(_) => None,
            WitnessStep::Full(s) => Some(&s.expect),
        }
    }

    /// The step in the trace format.
    pub fn to_step(&self) -> Step {
        match self {
            WitnessStep::Bare(e) => Step { event: e.clone(), expect: Expect::default(), note: None },
            WitnessStep::Full(s) => (**s).clone(),
        }
    }
}

/// The explanation of a capture under one lane.
pub struct Witness {
    /// The capture with every gap replaced by concrete events (the trace format's steps).
    pub steps: Vec<WitnessStep>,
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
    /// Before the step of each index, the checksum engine is on this area at the start of a
    /// pass: the card's pass lengths are its own (`Tolerances::free_area`). No model event
    /// sets the area, so [`run`] sets it, and a written trace says where `pmacwd run` differs.
    pub areas: Vec<(usize, ChecksumTarget)>,
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

/// Replays the capture at `path` with the choices of `last`'s chain.
pub fn build(
    spec: &pmacwd_specs::Spec,
    cfg: &ModelConfig,
    path: &Path,
    import_configuration: crate::replay::ImportAs<'_>,
    last: &Arc<Node>,
) -> Result<Witness, SpecError> {
    let nodes = chain(last);
    let cpu = match nodes.first().map(|n| &n.kind) {
        Some(NodeKind::Start { cpu }) => *cpu,
        _ => 0,
    };
    let mut source = Source::open_with(spec, path, import_configuration)?;
    let mut card = Controller::power_on(cfg);
    let mut steps = Vec::new();
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
    let mut areas: Vec<(usize, ChecksumTarget)> = Vec::new();
    let mut area_lines: Vec<usize> = Vec::new();
    let push_events = |steps: &mut Vec<WitnessStep>, events: Vec<TraceEvent>, note: Option<String>| {
        let mut note = note;
        for e in events {
            steps.push(WitnessStep::new(Step { event: e, expect: Expect::default(), note: note.take() }));
        }
    };
    // Each X:$25 read that narrowed an interval is met by the latest gap before it that can
    // run down that far; the other gaps keep X:$25 as high as they can.
    let mut targets: std::collections::HashMap<usize, i32> = std::collections::HashMap::new();
    for (p, node) in nodes.iter().enumerate() {
        if let NodeKind::Pin(v) = node.kind {
            let gap = (0..p).rev().find(|&g| {
                matches!(&nodes[g].kind, NodeKind::Restart(_))
                    || matches!(&nodes[g].kind, NodeKind::Gap { lo, .. } if *lo <= v)
            });
            if let Some(g) = gap.filter(|&g| matches!(nodes[g].kind, NodeKind::Gap { .. })) {
                targets.insert(g, v);
            }
        }
    }
    // Each Y:$25 read that narrowed an interval is met by the latest gap before it with a
    // background cycle (through the starved gaps in between, which only shift the counter).
    // A gap shorter than the run-down such a read needs had no background cycle at all: it is
    // starved, and the read is met by the gap before it.
    let mut counter_targets: std::collections::HashMap<usize, i32> = std::collections::HashMap::new();
    let mut starve: std::collections::HashSet<usize> = std::collections::HashSet::new();
    let reload = i64::from(cfg.reset_value(cfg.saved.i40));
    for (p, node) in nodes.iter().enumerate() {
        if let NodeKind::CounterPin(v) = node.kind {
            let mut v = i64::from(v);
            for g in (0..p).rev() {
                match &nodes[g].kind {
                    NodeKind::Gap { plan_hi: Plan::Starved { cycles, .. }, .. } => v += i64::from(*cycles),
                    NodeKind::Gap { plan_hi: Plan::Schedule { cycles, .. }, .. }
                        if reload - v >= i64::from(*cycles) =>
                    {
                        starve.insert(g);
                        v += i64::from(*cycles);
                    }
                    NodeKind::Gap { .. } => {
                        if let Ok(v) = i32::try_from(v) {
                            counter_targets.insert(g, v);
                        }
                        break;
                    }
                    NodeKind::Restart(_) | NodeKind::Start { .. } => break,
                    // The host's wait ran the counter down with no background cycle (a read
                    // after it comes from a running card).
                    NodeKind::Wait { cycles, .. } => v += i64::from(*cycles),
                    NodeKind::Pin(_) | NodeKind::CounterPin(_) | NodeKind::Area(_) => {}
                }
            }
        }
    }
    while let Some((line, step)) = source.next_step()? {
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
                let need = targets.get(&at).copied();
                let starved = match plan_hi {
                    Plan::Schedule { cycles, .. } if starve.contains(&at) => {
                        gap::run(cfg, &card, Plan::Starved { cycles: *cycles, heavy: 0, overrun_last: 0 }, true)
                            .filter(|sim| end.same_but_counters(&sim.card))
                    }
                    _ => None,
                };
                let Some(sim) = starved
                    .or_else(|| realize(cfg, &card, (plan_hi, plan_lo, end), need, counter_targets.get(&at).copied()))
                else {
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
                push_events(&mut steps, sim.events.unwrap_or_default(), step.note.clone());
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
                steps.push(WitnessStep::new(Step {
                    event: TraceEvent::Model(e),
                    expect: step.expect.clone(),
                    note: step.note.clone(),
                }));
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
                steps.push(WitnessStep::new(step.clone()));
                if late && !card.tripped() {
                    let e = Event::Command(command.clone());
                    card.apply(cfg, &e);
                    story.push(format!(
                        "line {line}: the card processed `{command}` after the host gave up (its answer went \
                         unread)"
                    ));
                    steps.push(WitnessStep::new(Step {
                        event: TraceEvent::Model(e),
                        expect: Expect::default(),
                        note: Some("processed after the host gave up waiting; its answer is not in the log".into()),
                    }));
                }
            }
            TraceEvent::Run { cycles } => {
                let mut s = Sim::new(cfg, card.clone(), false);
                s.greedy(*cycles);
                card = s.card;
                now += u64::from(*cycles);
                steps.push(WitnessStep::new(step.clone()));
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
                    areas.push((steps.len(), a));
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
                steps.push(WitnessStep::new(step.clone()));
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
    Ok(Witness { steps, story, cpu, cpu_decided: false, lowest_min, checked: None, tolerances: None, areas })
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
    use super::observe::observation;
    let mut card = Controller::power_on(cfg);
    let mut checked = 0;
    let nothing = Expect::default();
    // In step order (`build` pushes them so): one cursor, not a search per step.
    let mut areas = w.areas.iter().peekable();
    for (i, step) in w.steps.iter().enumerate() {
        if let Some((_, a)) = areas.next_if(|(at, _)| *at == i) {
            card.checksum.area = *a;
            card.checksum.position = 0;
        }
        let reply = match step.event() {
            TraceEvent::Model(Event::Background) if !card.background_possible() => {
                return Err(format!("witness step {}: a background cycle the model cannot complete", i + 1))
            }
            TraceEvent::Model(e) => card.apply(cfg, e),
            TraceEvent::Unanswered { wait_cycles, .. } => card.unanswered(cfg, *wait_cycles),
            TraceEvent::Run { cycles } => {
                let mut s = Sim::new(cfg, card.clone(), false);
                s.greedy(*cycles);
                card = s.card;
                pmacwd_specs::vocab::event::Reply::None
            }
            TraceEvent::Elapsed { .. } | TraceEvent::Restart | TraceEvent::RestartPossible => {
                return Err(format!("witness step {}: `{}` left unresolved", i + 1, step.event()))
            }
        };
        let obs = observation(cfg, &card, w.cpu, reply);
        match super::search::compare_windowed(spec, cfg, step.expect().unwrap_or(&nothing), &card, &obs) {
            Ok(n) => checked += n,
            Err(pmacwd_trace::compare::Mismatch::Field(what, expected, observed)) => {
                return Err(format!(
                    "witness step {} (`{}`): {what}: expected {expected}, observed {observed}",
                    i + 1,
                    step.event()
                ))
            }
            Err(pmacwd_trace::compare::Mismatch::UnknownBit(_, _, name)) => {
                return Err(format!("unknown status bit `{name}`"))
            }
        }
    }
    Ok((checked, card))
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
            if w.areas.is_empty() {
                String::new()
            } else {
                format!(
                    " The card's checksum passes are of its own length: at {} status reads the area bit 12 shows \
                     is the log's, which no event of the model sets, so `pmacwd run` of this trace differs there.",
                    w.areas.len()
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
    for step in &w.steps {
        let mut step = step.to_step();
        if let Some(r) = &step.expect.reply {
            if let Ok(StatusReply::Words { x, y }) = reply_text::decode(r) {
                if r.len() == 12 {
                    let (x, y) = super::observe::with_cpu(&layout, configured_cpu, (x, y));
                    step.expect.reply = Some(reply_text::encode(StatusReply::Words { x, y }));
                }
            }
        }
        if yaml {
            write!(out, "{}", pmacwd_trace::yaml_step(&step))?;
        } else {
            writeln!(out, "{}", pmacwd_trace::jsonl::step_line(&step))?;
        }
    }
    Ok(())
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
    of_lane(spec, path, import_configuration, &lanes[0])
}

/// The explanation of a lane that explains the capture, searched with its choices recorded.
pub fn of_lane(
    spec: &Spec,
    path: &Path,
    import_configuration: ImportAs<'_>,
    lane: &super::search::Lane,
) -> Result<(String, Witness), SpecError> {
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
    let mut first: Option<Witness> = None;
    for c in cands.iter().take(WITNESS_TRIES) {
        let node = c.node.clone().expect("filtered");
        let mut w = build(spec, &lane.cfg, path, import_configuration, &node)?;
        w.tolerances = (tolerances != lane.stated).then_some(tolerances);
        w.cpu_decided = lane.cands.iter().all(|o| o.cpu == w.cpu);
        w.checked = Some(reproduces(spec, &lane.cfg, &w));
        if matches!(w.checked, Some(Ok(_))) {
            return Ok((label, w));
        }
        first.get_or_insert(w);
    }
    first
        .map(|w| (label, w))
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
