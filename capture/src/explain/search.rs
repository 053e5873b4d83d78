//! The search itself: every lane's candidates, advanced one capture step at a time.

use super::gap::{self, Hints};
use super::history::{Node, NodeKind};
use super::key::CardKey;
use super::lanes::LaneDef;
use super::observe::observation;
use super::reads::{counter_read, min_read, signed_word};
use super::sim::FastMap;
use super::sim::Sim;
use super::{normalize, CANDIDATES_MAX};
use crate::replay::Source;
use pmacwd_model::controller::Controller;
use pmacwd_specs::check::{PassCycles, ResetEvent, ResetKind};
use pmacwd_specs::config::ModelConfig;
use pmacwd_specs::profiles::Bit12Meaning;
use pmacwd_specs::profiles::Profile;
use pmacwd_specs::status::WordId;
use pmacwd_specs::vocab::command::{HostCommand, Register};
use pmacwd_specs::vocab::event::{Event, Reply};
use pmacwd_specs::vocab::reply_text::{self, StatusReply};
use pmacwd_specs::{Position, Spec, SpecError};
use pmacwd_trace::compare::{compare, Mismatch};
use pmacwd_trace::{Expect, Step, TraceEvent};
use std::collections::VecDeque;
use std::path::Path;
use std::sync::Arc;

/// How far the search looks past a gap for the observations that aim its plans.
const LOOKAHEAD_STEPS: usize = 32;
/// How far it looks for the next status read, whose sticky bits an earlier gap may have set.
const LOOKAHEAD_STICKY_STEPS: usize = 512;
/// How far it looks for the next X:$25 read, which bounds the cards worth keeping after a gap
/// (`gap::MinLater`): a few polls.
const MIN_LATER_STEPS: usize = 64;
/// The most servo cycles of short gaps the reads after a gap may be behind it and still aim its
/// plans (the commands of one poll, placed by host time a few milliseconds apart).
const SHIFT_MAX_CYCLES: u32 = 24;
/// Servo cycles of later gaps beyond which a sticky bit seen later is left to them: an RTI
/// overrun or a checksum fault fits in far fewer (an overrun needs about 3(I8+1) cycles).
const STICKY_ROOM_CYCLES: u32 = 1024;

/// A candidate: one model state the capture so far allows.
#[derive(Clone, Debug)]
pub struct Cand {
    /// Y:$25 is anywhere in `counter_lo..=card.counter` (the steps after a gap did not read
    /// it); X:$25 in `min_lo..=card.counter_min`, and never above Y:$25.
    pub card: Controller,
    pub counter_lo: i32,
    /// X:$25 is anywhere in `min_lo..=card.counter_min`.
    pub min_lo: i32,
    /// The CPU type, 0..=3 (SRM p.289: X bit 21 is bit 1, Y bit 21 is bit 0).
    pub cpu: u8,
    pub node: Option<Arc<Node>>,
}

/// Of candidates that differ only in how long their strobe has been stopped, the one whose
/// strobe stopped last, before a gap longer than the hardware delay after which the card
/// answers. Exact: to answer, a card must not trip in the gap (UM p.215), and the gap is too
/// long for that without a strobe edge; so every schedule that keeps a card whose strobe
/// stopped earlier from tripping has an edge in the gap, keeps the other from tripping too
/// (its count stays lower), and from that edge on, where both counts restart, the two are the
/// same card. The one kept reaches every card after the gap that the others reach. (Cards
/// sitting at zero within the delay, one per cycle of it, were most of a starving log's
/// candidates: `starvation-trip` of the independent logs.)
///
/// Only cards whose counter has run out are compared (the strobe stops there, UM p.215, SRM
/// p.57): elsewhere a stopped strobe is the RTI's phase between its edges, which the cards
/// differ in anyway, and comparing them cost a healthy poll 6% of its time.
fn earliest_strobe_stops(cands: Vec<Cand>) -> Vec<Cand> {
    if cands.iter().filter(|c| c.card.counter <= 0).take(2).count() < 2 {
        return cands;
    }
    let mut at: FastMap<(CardKey, i32, i32, u8), usize> = FastMap::default();
    let mut out: Vec<Cand> = Vec::with_capacity(cands.len());
    for c in cands {
        if c.card.counter > 0 {
            out.push(c);
            continue;
        }
        let mut key = c.card.clone();
        key.cycles_since_strobe = 0;
        match at.entry((CardKey(key), c.counter_lo, c.min_lo, c.cpu)) {
            std::collections::hash_map::Entry::Occupied(e) => {
                let kept = &mut out[*e.get()];
                if c.card.cycles_since_strobe < kept.card.cycles_since_strobe {
                    *kept = c;
                }
            }
            std::collections::hash_map::Entry::Vacant(e) => {
                e.insert(out.len());
                out.push(c);
            }
        }
    }
    out
}

/// Where a lane died.
#[derive(Clone, Debug)]
pub struct Death {
    pub event: u64,
    pub line: usize,
    pub what: String,
    pub expected: String,
    pub observed: String,
    /// Candidates alive just before.
    pub candidates: usize,
    /// No card of the bands gets past it, whatever its timing: a status word no state of the
    /// checksum engine gives under the lane's readings (`words`), or X:$1080 moving after the
    /// checksum error showed (`refute::Freeze`).
    pub whatever_the_card: bool,
}

/// A card's own values of what the manual gives only approximately (UM p.215: a strobe of
/// "approximately 25 Hz", a supply of "about 4.75 V"): its hardware delay and its supply
/// threshold, each within the band of `watchdog.yaml`. Constant for a card, so initial
/// nondeterminism: a lane is searched under the stated values first and under the others only
/// if those do not explain the capture.
///
/// The checksum pass length is the card's own in the same way (UM p.217 gives none): a host
/// log sees it only through the area bit 12 shows (SRM p.289) and when a corruption is found,
/// so the lengths up to [`PASS_CYCLES_MAX`], each area's its own, are searched where a lane
/// compared either.
///
/// Where no pass length up to it explains the capture, the last card tried takes its passes as
/// its own whatever their length (`free_area`): at each status read on a line of its own, the
/// engine may be on either area (a read is answered in a background cycle of its own, UM
/// p.236, and one of a card's passes, of a length UM p.217 does not give, may have ended in
/// any of them). A pass length of 300 background cycles was "no correct card" under passes
/// of 1 and 2 where X:$25 pinned the background to every servo cycle (seed 37).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Tolerances {
    pub hardware_delay_cycles: u32,
    pub supply_min_millivolts: u32,
    pub checksum_pass_cycles: PassCycles,
    /// The checksum area at each status read is the card's own (its pass lengths are).
    pub free_area: bool,
}

/// The longest checksum pass, in background cycles, the search tries as the card's own, for
/// each area apart (`pass_lengths`). MODEL (search): with background cycles free to come or not
/// in every servo cycle, lengths of 1 and 2 give a read every checksum area a longer one would;
/// 3 and 4 made the fixed set's impossible supply-dip log take over 240 s (docs/replay.md).
pub const PASS_CYCLES_MAX: u8 = 2;

/// Every pair of pass lengths searched, equal ones first.
fn pass_lengths() -> impl Iterator<Item = PassCycles> {
    let equal = (1..=PASS_CYCLES_MAX).map(|n| PassCycles { firmware: n, user_program: n });
    let pairs = (1..=PASS_CYCLES_MAX)
        .flat_map(|f| (1..=PASS_CYCLES_MAX).map(move |u| PassCycles { firmware: f, user_program: u }));
    equal.chain(pairs.filter(|p| p.firmware != p.user_program))
}

impl Tolerances {
    pub fn of(cfg: &ModelConfig) -> Tolerances {
        Tolerances {
            hardware_delay_cycles: cfg.hardware_delay_cycles,
            supply_min_millivolts: cfg.supply_min_millivolts,
            checksum_pass_cycles: cfg.pass_cycles,
            free_area: false,
        }
    }

    /// Every distinct card the bands of `cfg` admit, the stated values first, then the others
    /// by their distance from them. Supply thresholds differ only by which of the capture's
    /// supply levels (`levels`, in millivolts) they call low, so one threshold stands for each
    /// such class.
    /// With `passes`, also every other pair of checksum pass lengths up to [`PASS_CYCLES_MAX`]
    /// ([`pass_lengths`]), after the bands' cards.
    pub fn variants(cfg: &ModelConfig, levels: &[u32], passes: bool) -> Vec<Tolerances> {
        let stated = Tolerances::of(cfg);
        let (dlo, dhi) = cfg.hardware_delay_band;
        let mut delays: Vec<u32> = (dlo..=dhi).chain([stated.hardware_delay_cycles]).collect();
        delays.sort_by_key(|d| (d.abs_diff(stated.hardware_delay_cycles), *d));
        delays.dedup();
        let (slo, shi) = cfg.supply_min_millivolts_band;
        // Threshold t calls level v low when v < t: the classes change at t = v + 1.
        let mut thresholds: Vec<u32> =
            std::iter::once(slo).chain(levels.iter().filter(|v| (slo..shi).contains(*v)).map(|v| v + 1)).collect();
        let class = |t: u32| levels.iter().filter(|v| **v < t).count();
        thresholds.retain(|t| class(*t) != class(stated.supply_min_millivolts));
        thresholds.sort_unstable();
        thresholds.dedup_by_key(|t| class(*t));
        let supplies = std::iter::once(stated.supply_min_millivolts).chain(thresholds);
        let supplies: Vec<u32> = supplies.collect();
        let mut out = Vec::with_capacity(delays.len() * supplies.len() + pass_lengths().count());
        for s in &supplies {
            for d in &delays {
                out.push(Tolerances { hardware_delay_cycles: *d, supply_min_millivolts: *s, ..stated });
            }
        }
        out.sort_by_key(|t| t.supply_min_millivolts != stated.supply_min_millivolts);
        // The pass lengths with the stated delay and supply only. MODEL (search): a log that
        // needs both a pass and a delay or threshold of its own is not searched (each such
        // pass would search the bands again, for every impossible log).
        // Each area's length its own (the areas differ in size; UM p.217 gives neither): the
        // configuration i40-zero's card, passes of 2 and 1, is one the search must meet.
        if passes {
            out.extend(
                pass_lengths()
                    .filter(|p| *p != stated.checksum_pass_cycles)
                    .map(|p| Tolerances { checksum_pass_cycles: p, ..stated }),
            );
            out.push(Tolerances { free_area: true, ..stated });
        }
        out
    }
}

pub struct Lane {
    pub def: LaneDef,
    pub cfg: ModelConfig,
    /// The card's values of what the manual states approximately, this search's.
    pub tolerances: Tolerances,
    /// How many cards of [`Tolerances::variants`] were searched (1: only the stated values).
    pub tolerances_tried: usize,
    /// How many cards the bands admit (0: not counted, the stated values explained it).
    pub tolerances_admitted: usize,
    /// The configuration's stated values (UM p.215's 25 Hz and 4.75 V).
    pub stated: Tolerances,
    pub cands: Vec<Cand>,
    pub death: Option<Death>,
    pub peak: usize,
    /// What this lane's gaps have worked out once (bounded).
    pub memo: gap::Memo,
    /// Whether any card the search made had its strobe stopped for longer than the shortest
    /// hardware delay of the band: if none did, every card of the band behaves alike (the
    /// model reads the delay only there, UM p.215) and the others need not be searched.
    pub delay_mattered: bool,
    /// A status read compared what the checksum engine decides (bit 12 as the area, SRM
    /// p.289, or bit 13): the card's pass length could have judged it differently.
    pub pass_mattered: bool,
    /// Not searched: the explanation of the lane named here, run on the model under this
    /// lane's readings, reproduces every observation (`share`).
    pub shown_by: Option<String>,
    /// Under `tolerances.free_area`, the line of the last status read: the reads of one line
    /// are answered in one background cycle, which shows one area.
    pub free_line: Option<usize>,
    /// With choices recorded, on a long capture: where the search had one candidate, whose
    /// history was then let go (see [`Checkpoint`]).
    pub checkpoints: Vec<Checkpoint>,
}

/// A point of a long capture where a recorded search had a single candidate: the chain of
/// choices starts again there (`NodeKind::Root`), and the choices of the segment before are
/// found again, when an explanation is walked, by searching that segment once more from the
/// checkpoint before it, which gives the same single candidate (the search is deterministic,
/// and from one candidate it does the same work). So a recorded search holds one segment of
/// choices, not the whole capture's (a week-long log's chain took over a gigabyte).
#[derive(Clone, Debug)]
pub struct Checkpoint {
    /// The capture event after which the candidate was taken.
    pub event: u64,
    /// The candidate (its history let go).
    pub cand: Cand,
    pub free_line: Option<usize>,
}

/// Capture events between checkpoints at the least.
pub const CHECKPOINT_EVENTS: u64 = 1 << 15;

/// The capture's steps with a window to look ahead.
pub struct Reader {
    source: Source,
    ahead: VecDeque<(usize, Step)>,
    pub events: u64,
}

fn read_only(step: &Step) -> bool {
    matches!(
        step.event,
        TraceEvent::Model(Event::Command(HostCommand::GlobalStatus | HostCommand::ReadI(_) | HostCommand::ReadHex(_)))
            | TraceEvent::Unanswered {
                command: HostCommand::GlobalStatus | HostCommand::ReadI(_) | HostCommand::ReadHex(_),
                ..
            }
    )
}

impl Reader {
    pub fn new(source: Source) -> Reader {
        Reader { source, ahead: VecDeque::new(), events: 0 }
    }

    pub fn next_step(&mut self) -> Result<Option<(usize, Step)>, SpecError> {
        let s = match self.ahead.pop_front() {
            Some(s) => Some(s),
            None => self.source.next_step()?,
        };
        if s.is_some() {
            self.events += 1;
        }
        Ok(s)
    }

    /// What the read-only steps after the current one observe.
    pub fn hints(&mut self, spec: &Spec) -> Result<Hints, SpecError> {
        let mut h = self.hints_near(spec)?;
        // Where the steps right after the gap read X:$25, its plans are aimed at that read and
        // the read itself comes next: no later one is looked for (a healthy poll's every gap).
        if h.counter_min.is_none() {
            h.min_later = self.min_later()?;
        }
        Ok(h)
    }

    /// The next X:$25 read within [`MIN_LATER_STEPS`] steps, if only reads, waits for replies
    /// and gaps of bounded length come before it (nothing that resets the card, writes I40 or
    /// leaves time unbounded), with the servo cycles they may take at most.
    fn min_later(&mut self) -> Result<Option<gap::MinLater>, SpecError> {
        let mut cycles_max = 0u64;
        for i in 0..MIN_LATER_STEPS {
            if !self.has_ahead(i)? {
                return Ok(None);
            }
            let step = &self.ahead[i].1;
            match step.event {
                TraceEvent::Elapsed { cycles_max: Some(m), .. } => cycles_max += u64::from(m),
                TraceEvent::Unanswered { wait_cycles, .. } if read_only(step) => cycles_max += u64::from(wait_cycles),
                _ if read_only(step) => {
                    if let Some(value) = min_read(step) {
                        return Ok(Some(gap::MinLater { value, cycles_max }));
                    }
                }
                _ => return Ok(None),
            }
        }
        Ok(None)
    }

    /// Whether the capture has an `i`-th step after the current one, read into `ahead` if it
    /// was not yet.
    fn has_ahead(&mut self, i: usize) -> Result<bool, SpecError> {
        while self.ahead.len() <= i {
            match self.source.next_step()? {
                Some(s) => self.ahead.push_back(s),
                None => return Ok(false),
            }
        }
        Ok(true)
    }

    /// [`Reader::hints`] but the later X:$25 read.
    fn hints_near(&mut self, spec: &Spec) -> Result<Hints, SpecError> {
        let mut h = Hints::default();
        // In the window (the read-only steps right after the gap) everything counts; past it,
        // only the sticky bits 22 and 13 of the next status read, which an earlier gap may
        // have to set (SRM p.289: they stay set until a reset).
        let mut in_window = true;
        let mut later_cycles = 0u32;
        let mut i = 0;
        loop {
            // Past the limit, only the steps already read (another look read them) are looked at.
            let limit = if in_window { LOOKAHEAD_STEPS } else { LOOKAHEAD_STICKY_STEPS };
            if i == self.ahead.len() && (i >= limit || !self.has_ahead(i)?) {
                break;
            }
            let step = &self.ahead[i].1;
            i += 1;
            if !read_only(step) {
                let resets = matches!(
                    step.event,
                    TraceEvent::Restart
                        | TraceEvent::RestartPossible
                        | TraceEvent::Model(Event::Reset(_))
                        | TraceEvent::Model(Event::Command(HostCommand::Reset | HostCommand::Reinitialize))
                        | TraceEvent::Model(Event::ClearRtiReentry)
                );
                if resets {
                    break;
                }
                if let TraceEvent::Elapsed { cycles_min, cycles_max } = step.event {
                    later_cycles = later_cycles.saturating_add(cycles_min);
                    if later_cycles >= STICKY_ROOM_CYCLES {
                        // A later gap has room to set the bit: this one need not try.
                        break;
                    }
                    // A short gap (the commands of one poll placed by host time) keeps the
                    // window open: the reads after it still aim this gap's plans, shifted.
                    let short = cycles_max.map(|m| h.shift.saturating_add(m)).filter(|s| *s <= SHIFT_MAX_CYCLES);
                    if let (true, Some(s)) = (in_window, short) {
                        h.shift = s;
                        continue;
                    }
                }
                in_window = false;
                continue;
            }
            if let TraceEvent::Unanswered { wait_cycles, .. } = step.event {
                // A read the host gave up on: the card was tripped, or its background starved
                // for the wait (UM p.236); the wait runs the counter down as a short gap does.
                if in_window && h.silent.is_none() {
                    h.silent = Some(true);
                }
                later_cycles = later_cycles.saturating_add(wait_cycles);
                match h.shift.checked_add(wait_cycles).filter(|s| *s <= SHIFT_MAX_CYCLES) {
                    Some(s) if in_window => h.shift = s,
                    _ => in_window = false,
                }
                continue;
            }
            let TraceEvent::Model(Event::Command(cmd)) = &step.event else { break };
            let reply = step.expect.reply.as_deref();
            if in_window {
                if h.silent.is_none() {
                    // An answer the log does not compare (X:$0, a checksum) still shows the card
                    // running: `tripped: false` is what the importer expects of it.
                    h.silent =
                        reply.map(|r| r == "(silence)").or((step.expect.tripped == Some(false)).then_some(false));
                }
                // Past a short gap, a read only fills what the reads before it left open: the
                // first value read after this gap aims it best.
                if let Some(c) = step.expect.counter.filter(|_| h.shift == 0 || h.counter.is_none()) {
                    h.counter = Some(c);
                }
                if let Some(m) = step.expect.counter_min.filter(|_| h.shift == 0 || h.counter_min.is_none()) {
                    h.counter_min = Some(m);
                }
            }
            let mut status_read = false;
            match (cmd, reply) {
                (HostCommand::ReadHex(Register::WatchdogCounter), Some(r))
                    if in_window && (h.shift == 0 || h.counter.is_none()) =>
                {
                    h.counter = signed_word(r).or(h.counter)
                }
                (HostCommand::ReadHex(Register::WatchdogMinimum), Some(r))
                    if in_window && (h.shift == 0 || h.counter_min.is_none()) =>
                {
                    h.counter_min = signed_word(r).or(h.counter_min)
                }
                (HostCommand::GlobalStatus, Some(r)) => {
                    if let Ok(StatusReply::Words { x, y }) = reply_text::decode(r) {
                        status_read = true;
                        let on = |name: &str| {
                            spec.status.bit(name).is_some_and(|(w, b)| {
                                (match w {
                                    WordId::X => x,
                                    WordId::Y => y,
                                }) & (1 << b)
                                    != 0
                            })
                        };
                        h.rti_reentry_seen |= on("rti_reentry");
                        h.rti_warning_seen |= in_window && on("rti_warning");
                        h.checksum_error_seen |= on("checksum_error");
                        h.checksum_clear_seen |= !on("checksum_error");
                    }
                }
                _ => {}
            }
            for name in &step.expect.status_set {
                h.rti_reentry_seen |= name == "rti_reentry";
                h.rti_warning_seen |= in_window && name == "rti_warning";
                h.checksum_error_seen |= name == "checksum_error";
            }
            for name in &step.expect.status_clear {
                h.checksum_clear_seen |= name == "checksum_error";
            }
            status_read |= !step.expect.status_set.is_empty() || !step.expect.status_clear.is_empty();
            if status_read && !in_window {
                break;
            }
        }
        Ok(h)
    }
}

/// The servo cycle counts a gap is tried with: all of an exact gap; for a range, enough to
/// give every RTI phase at the shortest time and at a time long enough for any run-down.
fn cycle_set(min: u32, max: Option<u32>, card: &Controller, cfg: &ModelConfig) -> Vec<u32> {
    if max == Some(min) {
        return vec![min];
    }
    let max = u64::from(max.unwrap_or(pmacwd_trace::STEP_CYCLES_MAX));
    let period = u64::from(card.i8) + 1;
    let long = u64::from(min)
        + 2 * (u64::from(cfg.reset_value(card.i40).unsigned_abs()) + u64::from(cfg.hardware_delay_cycles) + 2 * period);
    // A range that ends before `long`: its longest gaps (the last RTI phases it holds) stand in
    // for it, not lengths past its end, which left the range tried at its shortest only (seed
    // 39's unstamped sluggish log: a gap of 0 to 1,938 cycles after a stall, in which the
    // counter must reload, tried at 0 cycles: "no correct card").
    let long = long.min((max + 1).saturating_sub(period).max(u64::from(min)));
    let mut out: Vec<u32> = Vec::new();
    // A gap at least `long - min` cycles long already has room for any run-down: its RTI
    // phases are all the longer gap's outcomes differ in (X:$0, which differs too, is not
    // compared). The first X:$0 read of a card up for hours is such a gap.
    let starts: &[u64] =
        if long - u64::from(min) <= u64::from(min) { &[u64::from(min)] } else { &[u64::from(min), long] };
    for &start in starts {
        for n in start..start + period {
            if n <= max && !out.contains(&(n as u32)) {
                out.push(n as u32);
            }
        }
    }
    if out.is_empty() {
        out.push(max as u32);
    }
    out
}

/// Adds `c` to `same` (candidates that differ from it only in Y:$25 and X:$25), or merges it
/// into one of them; returns whether it merged (the candidate count did not grow).
///
/// - One whose Y:$25 and X:$25 intervals both hold the other's stands for it: every card the
///   smaller allows, the larger allows, and what follows from it too.
/// - Equal Y:$25 intervals whose X:$25 intervals meet are one: the union of two overlapping
///   intervals is exactly the values either allows. With witnesses recorded, only where one
///   holds the other, so that the history kept reaches every value of the merged interval.
/// - Without witnesses, equal X:$25 intervals whose Y:$25 intervals meet are one, likewise.
///
/// Without it, a status poll that never reads Y:$25 keeps a candidate for every gap since
/// which the card may have starved (Y:$25 one gap's cycles lower each), each held by the
/// widest.
fn absorb(same: &mut Vec<Cand>, c: Cand, record: bool) -> bool {
    let (y_lo, y_hi, x_lo, x_hi) = (c.counter_lo, c.card.counter, c.min_lo, c.card.counter_min);
    let holds = |o: &Cand, lo: i32, hi: i32, xlo: i32, xhi: i32| {
        o.counter_lo <= lo && hi <= o.card.counter && o.min_lo <= xlo && xhi <= o.card.counter_min
    };
    if same.iter().any(|o| holds(o, y_lo, y_hi, x_lo, x_hi)) {
        return true;
    }
    if let Some(o) = same.iter_mut().find(|o| holds(&c, o.counter_lo, o.card.counter, o.min_lo, o.card.counter_min)) {
        *o = c;
        return true;
    }
    let meet =
        |a_lo: i32, a_hi: i32, b_lo: i32, b_hi: i32| a_lo <= b_hi.saturating_add(1) && b_lo <= a_hi.saturating_add(1);
    let same_y = |o: &Cand| o.counter_lo == y_lo && o.card.counter == y_hi;
    let same_x = |o: &Cand| o.min_lo == x_lo && o.card.counter_min == x_hi;
    if !record {
        if let Some(o) = same.iter_mut().find(|o| same_y(o) && meet(o.min_lo, o.card.counter_min, x_lo, x_hi)) {
            o.card.counter_min = o.card.counter_min.max(x_hi);
            o.min_lo = o.min_lo.min(x_lo);
            return true;
        }
        if let Some(o) = same.iter_mut().find(|o| same_x(o) && meet(o.counter_lo, o.card.counter, y_lo, y_hi)) {
            if y_hi > o.card.counter {
                o.card = Controller { counter_min: o.card.counter_min, ..c.card };
            }
            o.counter_lo = o.counter_lo.min(y_lo);
            return true;
        }
    }
    same.push(c);
    false
}

/// Applies `f` to a candidate and, if its Y:$25 is an interval, to the card at the interval's
/// bottom as well: one candidate again when the two agree but for Y:$25 and X:$25, else both
/// ends as candidates of their own. Returns each with the reply `f` gave.
///
/// When the ends part, each keeps the history so far plus a pin of the Y:$25 it stands for
/// (the value before the step), so that its explanation meets that value.
fn both_ends(
    c: &Cand,
    event_no: u64,
    reply_seen: bool,
    mut f: impl FnMut(&mut Controller) -> Reply,
) -> Vec<(Cand, Reply)> {
    let mut hi = c.clone();
    let reply = f(&mut hi.card);
    normalize(&mut hi.card);
    // Values the counter takes now lower every X:$25 of the interval alike.
    hi.min_lo = hi.min_lo.min(hi.card.counter_min);
    if c.counter_lo == c.card.counter {
        hi.counter_lo = hi.card.counter;
        return vec![(hi, reply)];
    }
    let mut lo = c.clone();
    lo.card.counter = c.counter_lo;
    lo.card.counter_min = lo.card.counter_min.min(c.counter_lo);
    let lo_reply = f(&mut lo.card);
    normalize(&mut lo.card);
    // A reply nobody recorded (an unread Y:$25) does not split the interval.
    let same = super::same_but_counters(&hi.card, &lo.card) && (reply == lo_reply || !reply_seen);
    if same && lo.card.counter <= hi.card.counter {
        hi.counter_lo = lo.card.counter;
        hi.min_lo = hi.min_lo.min(lo.card.counter_min);
        vec![(hi, reply)]
    } else {
        hi.counter_lo = hi.card.counter;
        lo.counter_lo = lo.card.counter;
        lo.min_lo = lo.min_lo.min(lo.card.counter_min);
        let pin = |n: &Option<Arc<Node>>, v: i32| {
            n.as_ref()
                .map(|p| Arc::new(Node { parent: Some(p.clone()), event: event_no, kind: NodeKind::CounterPin(v) }))
        };
        hi.node = pin(&c.node, c.card.counter);
        lo.node = pin(&c.node, c.counter_lo);
        vec![(hi, reply), (lo, lo_reply)]
    }
}

/// Compares as `runner::compare`, with a capture's timing window as `pmacwd run` applies it
/// (`Runner::check`): with `window_cycles: W`, an expected trip also holds if the candidate
/// trips within the next W servo cycles (docs/trace-format.md). The candidate itself is not
/// advanced, as in a run. MODEL: an expected *absence* of a trip is held exactly here (the
/// search keeps no count of cycles since a trip), which can only reject, never explain.
pub(super) fn compare_windowed(
    spec: &Spec,
    cfg: &ModelConfig,
    expect: &Expect,
    card: &Controller,
    obs: &pmacwd_specs::vocab::Observation,
) -> Result<usize, Mismatch> {
    let (Some(window), Some(true)) = (expect.window_cycles, expect.tripped) else {
        return compare(spec, expect, obs);
    };
    if card.tripped() {
        return compare(spec, expect, obs);
    }
    let mut probe = card.clone();
    if !(0..window).any(|_| {
        probe.servo_cycle(cfg);
        probe.tripped()
    }) {
        return Err(Mismatch::Field("tripped", format!("true within {window} servo cycles"), "false".into()));
    }
    // The trip-derived observations follow the windowed verdict.
    Ok(1 + compare(spec, &pmacwd_trace::compare::without_trip(expect, true), obs)?)
}

/// The reset-time findings a `restart` may have had (SRM p.289, bits 10 and 11; bootstrap).
fn restart_variants() -> Vec<ResetEvent> {
    let mut v = Vec::new();
    for bootstrap in [false, true] {
        for dpram_fault in [false, true] {
            for flash_fault in [false, true] {
                v.push(ResetEvent { kind: ResetKind::Init, dpram_fault, flash_fault, bootstrap });
            }
        }
    }
    v
}

impl Lane {
    pub fn new(
        spec: &Spec,
        configuration: &str,
        card: Option<&pmacwd_specs::config::CardConfig>,
        def: LaneDef,
        record: bool,
        tolerances: Option<Tolerances>,
    ) -> Result<Lane, SpecError> {
        let profile = Profile { name: super::lanes::label(&def.choices), choices: def.choices };
        let mut cfg = ModelConfig::from_spec(spec, configuration, &profile)?;
        if let Some(card) = card {
            cfg = cfg.with_card(spec, card).map_err(|e| SpecError::whole_file(&spec.dir, e))?;
        }
        let stated = Tolerances::of(&cfg);
        if let Some(t) = tolerances {
            cfg.hardware_delay_cycles = t.hardware_delay_cycles;
            cfg.supply_min_millivolts = t.supply_min_millivolts;
            cfg.pass_cycles = t.checksum_pass_cycles;
        }
        // A capture reads the card's real 24-bit servo counter (as `pmacwd run` does). The
        // load starts as the configuration's first; in unseen gaps it is the search's choice.
        // The checksum pass lengths are the configuration's (`host-log`: one background cycle
        // each, so that any background cycle may end a pass).
        cfg.servo_counter_mask = 0xFF_FFFF;
        let mut card = Controller::power_on(&cfg);
        normalize(&mut card);
        let cands = (0..4u8)
            .map(|cpu| Cand {
                counter_lo: card.counter,
                card: card.clone(),
                min_lo: card.counter_min,
                cpu,
                node: record.then(|| Arc::new(Node { parent: None, event: 0, kind: NodeKind::Start { cpu } })),
            })
            .collect();
        Ok(Lane {
            def,
            tolerances: Tolerances { free_area: tolerances.is_some_and(|t| t.free_area), ..Tolerances::of(&cfg) },
            free_line: None,
            tolerances_tried: 1,
            tolerances_admitted: 0,
            stated,
            cfg,
            cands,
            death: None,
            peak: 4,
            memo: gap::Memo::default(),
            delay_mattered: false,
            pass_mattered: false,
            shown_by: None,
            checkpoints: Vec::new(),
        })
    }

    pub fn alive(&self) -> bool {
        self.death.is_none()
    }

    /// After event `event_no`: on a recorded search, a checkpoint where there is one candidate,
    /// its Y:$25 and X:$25 exact (so no later read pins a gap before it), at least
    /// [`CHECKPOINT_EVENTS`] after the last.
    pub fn checkpoint(&mut self, event_no: u64) {
        let since = self.checkpoints.last().map_or(0, |c| c.event);
        let [c] = &mut self.cands[..] else { return };
        if self.death.is_some()
            || c.node.is_none()
            || event_no - since < CHECKPOINT_EVENTS
            || c.counter_lo != c.card.counter
            || c.min_lo != c.card.counter_min
        {
            return;
        }
        self.checkpoints.push(Checkpoint {
            event: event_no,
            cand: Cand { node: None, ..c.clone() },
            free_line: self.free_line,
        });
        c.node = Some(Arc::new(Node { parent: None, event: event_no, kind: NodeKind::Root }));
    }

    /// Starts this (new, recorded) lane from `from`, as the search was there.
    pub fn resume(&mut self, from: &Checkpoint) {
        self.cands = vec![Cand {
            node: Some(Arc::new(Node { parent: None, event: from.event, kind: NodeKind::Root })),
            ..from.cand.clone()
        }];
        self.free_line = from.free_line;
    }

    /// Advances every candidate over one step; `Err` for a capture the search cannot judge.
    pub fn step(
        &mut self,
        spec: &Spec,
        file: &Path,
        event_no: u64,
        line: usize,
        step: &Step,
        hints: &Hints,
    ) -> Result<(), SpecError> {
        if self.death.is_some() {
            return Ok(());
        }
        let record = self.cands.first().is_some_and(|c| c.node.is_some());
        let cfg = &self.cfg;
        // Candidates that differ only in Y:$25 and X:$25 are kept together: one whose intervals
        // hold another's stands for it, and intervals that meet are one (see `absorb`).
        let mut next: FastMap<(CardKey, u8), Vec<Cand>> = FastMap::default();
        let mut count = 0usize;
        let mut first_failure: Option<(String, String, String)> = None;
        let before = self.cands.len();
        let label = super::lanes::label(&self.def.choices);
        let mut insert = |c: Cand, next: &mut FastMap<(CardKey, u8), Vec<Cand>>| -> Result<(), SpecError> {
            let mut key = c.card.clone();
            key.counter_min = i32::MIN;
            key.counter = i32::MIN;
            let same = next.entry((CardKey(key), c.cpu)).or_default();
            if !absorb(same, c, record) {
                count += 1;
            }
            if count > CANDIDATES_MAX {
                return Err(SpecError::at(
                    file,
                    Position { line, column: 1 },
                    format!(
                        "the capture leaves more than {CANDIDATES_MAX} states of the card possible here (under \
                         the readings {label}); read Y:$25 and X:$25 more often, or shorten the gaps without a \
                         reply (docs/replay.md, bounds)"
                    ),
                ));
            }
            Ok(())
        };
        let free_area_read = self.tolerances.free_area
            && cfg.profile.choices.bit12_meaning == Bit12Meaning::PromChecksumActive
            && self.free_line != Some(line)
            && matches!(
                step.event,
                TraceEvent::Model(Event::Command(
                    HostCommand::GlobalStatus | HostCommand::ReadHex(pmacwd_specs::vocab::command::Register::StatusX)
                ))
            );
        if free_area_read {
            self.free_line = Some(line);
        }
        if let TraceEvent::Elapsed { cycles_min, .. } = step.event {
            if hints.silent == Some(false) && cycles_min > cfg.hardware_delay_cycles {
                self.cands = earliest_strobe_stops(std::mem::take(&mut self.cands));
            }
        }
        let nothing_expected = step.expect == Expect::default();
        for cand in std::mem::take(&mut self.cands) {
            let mut results: Vec<(Cand, Reply)> = Vec::new();
            match &step.event {
                TraceEvent::Elapsed { cycles_min, cycles_max } => {
                    for n in cycle_set(*cycles_min, *cycles_max, &cand.card, cfg) {
                        for o in gap::successors(cfg, &mut self.memo, &cand.card, cand.counter_lo, n, hints) {
                            let node = cand.node.as_ref().filter(|_| record).map(|p| {
                                // A plan run from lower in the Y:$25 interval: the gap before
                                // must end there, a pin for the explanation to meet.
                                let p = if o.start_hi != cand.card.counter {
                                    Arc::new(Node {
                                        parent: Some(p.clone()),
                                        event: event_no,
                                        kind: NodeKind::CounterPin(o.start_hi),
                                    })
                                } else {
                                    p.clone()
                                };
                                Arc::new(Node {
                                    parent: Some(p),
                                    event: event_no,
                                    kind: NodeKind::Gap {
                                        plan_hi: o.plan_hi,
                                        plan_lo: o.plan_lo,
                                        lo: o.min_lo,
                                        end: super::End::of(&o.card),
                                    },
                                })
                            });
                            let min_lo = cand.min_lo.min(o.min_lo);
                            results.push((
                                Cand { card: o.card, counter_lo: o.counter_lo, min_lo, cpu: cand.cpu, node },
                                Reply::None,
                            ));
                        }
                    }
                }
                TraceEvent::Restart | TraceEvent::RestartPossible => {
                    if step.event == TraceEvent::RestartPossible {
                        // The log allows the card to have gone on without a reset.
                        results.push((cand.clone(), Reply::None));
                    }
                    for reset in restart_variants() {
                        let mut card = cand.card.clone();
                        card.apply(cfg, &Event::Reset(reset));
                        normalize(&mut card);
                        let node = cand.node.as_ref().map(|p| {
                            Arc::new(Node { parent: Some(p.clone()), event: event_no, kind: NodeKind::Restart(reset) })
                        });
                        let min_lo = card.counter_min;
                        results
                            .push((Cand { counter_lo: card.counter, card, min_lo, cpu: cand.cpu, node }, Reply::None));
                    }
                }
                TraceEvent::Run { cycles } => {
                    for c in both_ends(&cand, event_no, false, |card| {
                        let mut s = Sim::new(cfg, card.clone(), false);
                        s.greedy(*cycles);
                        *card = s.card;
                        Reply::None
                    }) {
                        results.push(c);
                    }
                }
                TraceEvent::Unanswered { command, wait_cycles } => {
                    // UM p.236: no background cycle processed the command while the host
                    // waited (a tripped card's wait changes nothing, UM p.215).
                    let wait = |card: &mut Controller| card.unanswered(cfg, *wait_cycles);
                    // The wait's node follows the pins `both_ends` may record (the counter as
                    // the command found it).
                    let after_pins = |(mut c, reply): (Cand, Reply), late: bool| {
                        c.node = c.node.take().map(|p| {
                            Arc::new(Node {
                                parent: Some(p),
                                event: event_no,
                                kind: NodeKind::Wait { cycles: *wait_cycles, late },
                            })
                        });
                        (c, reply)
                    };
                    results.extend(both_ends(&cand, event_no, true, wait).into_iter().map(|r| after_pins(r, false)));
                    // MODEL: a card that did not see the host's flush processes the command
                    // at its next background cycle; where that changes the card, it is tried
                    // right after the wait as well.
                    let command = Event::Command(command.clone());
                    let processed = |card: &mut Controller| {
                        let reply = card.unanswered(cfg, *wait_cycles);
                        if !card.tripped() {
                            card.apply(cfg, &command);
                        }
                        reply
                    };
                    let (mut waited, mut late) = (cand.card.clone(), cand.card.clone());
                    wait(&mut waited);
                    processed(&mut late);
                    normalize(&mut waited);
                    normalize(&mut late);
                    if late != waited {
                        results.extend(
                            both_ends(&cand, event_no, true, processed).into_iter().map(|r| after_pins(r, true)),
                        );
                    }
                }
                TraceEvent::Model(Event::Background) if !cand.card.background_possible() => {
                    first_failure.get_or_insert((
                        "event".into(),
                        "a background cycle can complete".into(),
                        "the model cannot complete one here".into(),
                    ));
                }
                TraceEvent::Model(e) => {
                    let mut c = cand.clone();
                    // The card's own pass lengths: the area at a status read on a line of its
                    // own may be either, where the engine runs over uncorrupted areas (a
                    // corruption is found at the end of a pass, UM p.217: no area is skipped).
                    let engine = &c.card.checksum;
                    let other_area = (free_area_read
                        && engine.error.is_none()
                        && engine.firmware == engine.firmware_reference
                        && engine.program == engine.program_reference)
                        .then_some(engine.area.other());
                    // Y:$25 read: its interval narrows to the value read, if it holds it.
                    if let Some(v) = counter_read(step) {
                        if (c.counter_lo..=c.card.counter).contains(&v) {
                            if c.counter_lo != c.card.counter {
                                c.node = c.node.as_ref().map(|p| {
                                    Arc::new(Node {
                                        parent: Some(p.clone()),
                                        event: event_no,
                                        kind: NodeKind::CounterPin(v),
                                    })
                                });
                            }
                            c.card.counter = v;
                            c.counter_lo = v;
                            // X:$25 is the lowest value since reset, Y:$25's included.
                            c.card.counter_min = c.card.counter_min.min(v);
                            if c.min_lo > c.card.counter_min {
                                first_failure.get_or_insert((
                                    "X:$25 <= Y:$25".into(),
                                    format!("Y:$25 = {v}"),
                                    format!("X:$25 at least {}", c.min_lo),
                                ));
                                continue;
                            }
                        }
                    }
                    // X:$25 read: the interval narrows to the value read, if it holds it.
                    if let Some(v) = min_read(step) {
                        if (c.min_lo..=c.card.counter_min).contains(&v) {
                            if c.min_lo != c.card.counter_min {
                                c.node = c.node.as_ref().map(|p| {
                                    Arc::new(Node { parent: Some(p.clone()), event: event_no, kind: NodeKind::Pin(v) })
                                });
                            }
                            c.card.counter_min = v;
                            c.min_lo = v;
                            // Y:$25 is never below X:$25.
                            c.counter_lo = c.counter_lo.max(v.min(c.card.counter));
                        }
                    }
                    if let Some(area) = other_area {
                        let mut o = c.clone();
                        o.card.checksum.area = area;
                        o.card.checksum.position = 0;
                        o.node = o.node.as_ref().map(|p| {
                            Arc::new(Node { parent: Some(p.clone()), event: event_no, kind: NodeKind::Area(area) })
                        });
                        results.extend(both_ends(&o, event_no, step.expect.reply.is_some(), |card| card.apply(cfg, e)));
                    }
                    for r in both_ends(&c, event_no, step.expect.reply.is_some(), |card| card.apply(cfg, e)) {
                        results.push(r);
                    }
                }
            }
            for (c, reply) in results {
                // A strobe stopped longer than the band's shortest delay: a card of the band
                // could have judged this differently (see `search`).
                if c.card.cycles_since_strobe > self.cfg.hardware_delay_band.0 {
                    self.delay_mattered = true;
                }
                // A status word compared: bit 12 shows the checksum area (SRM p.289), or bit 13
                // a corruption found, when the card's pass length may have put it elsewhere.
                if matches!(reply, Reply::Status { .. })
                    && (cfg.profile.choices.bit12_meaning == Bit12Meaning::PromChecksumActive
                        || c.card.checksum.error.is_some()
                        || c.card.checksum.firmware != c.card.checksum.firmware_reference
                        || c.card.checksum.program != c.card.checksum.program_reference)
                {
                    self.pass_mattered = true;
                }
                // A step that expects nothing (a gap's) holds whatever the card shows.
                if nothing_expected {
                    insert(c, &mut next)?;
                    continue;
                }
                let obs = observation(cfg, &c.card, c.cpu, reply);
                match compare_windowed(spec, cfg, &step.expect, &c.card, &obs) {
                    Ok(_) => insert(c, &mut next)?,
                    Err(Mismatch::UnknownBit(_, _, name)) => {
                        return Err(SpecError::at(
                            file,
                            Position { line, column: 1 },
                            format!("no status bit named `{name}` in status.yaml"),
                        ))
                    }
                    Err(Mismatch::Field(what, expected, observed)) => {
                        first_failure.get_or_insert((what.to_string(), expected, observed));
                    }
                }
            }
        }
        self.cands = next.into_values().flatten().collect();
        // After a gap, the cards that cannot read the next X:$25 the capture shows (`MinLater`)
        // go: on a stretch of silent waits, each gap's range of cycles multiplied the cards
        // that the read then ruled out (seed 38's sluggish log: 2,662 cards into a gap whose
        // plans took 70 s). Where none could, all stay, to die at the read itself, named.
        if let (TraceEvent::Elapsed { .. }, Some(later)) = (&step.event, hints.min_later) {
            let reaches =
                |c: &Cand| later.reachable(c.counter_lo, c.min_lo, c.card.counter_min, cfg.reset_value(c.card.i40));
            if self.cands.iter().any(reaches) {
                self.cands.retain(reaches);
            }
        }
        // In a fixed order, so that reports (which failure is named) are the same every run.
        self.cands
            .sort_by(|a, b| (&a.card, a.counter_lo, a.min_lo, a.cpu).cmp(&(&b.card, b.counter_lo, b.min_lo, b.cpu)));
        self.peak = self.peak.max(self.cands.len());
        if self.cands.is_empty() {
            let (what, expected, observed) =
                first_failure.unwrap_or_else(|| ("event".into(), "a state of the card".into(), "none".into()));
            self.death = Some(Death {
                event: event_no,
                line,
                what,
                expected,
                observed,
                candidates: before,
                whatever_the_card: false,
            });
        }
        Ok(())
    }
}

/// The start of the error a search past its deadline returns.
pub const OUT_OF_TIME: &str = "the search placing the log by host time ran past its time limit";

/// The line of the capture the search last reached (any thread, any pass): what `pmacwd
/// replay` shows as progress while a long capture, or one long step, is searched.
pub static LINE_REACHED: std::sync::atomic::AtomicUsize = std::sync::atomic::AtomicUsize::new(0);

/// Searches `path` on `lanes`, each under the card's stated tolerances first and, if those do
/// not explain the capture, under every other card the bands admit (in passes over the
/// capture, one per variant, with the lanes still unexplained). A lane no card explains keeps
/// the death that came latest. `record` keeps witness chains (for one lane). `configuration` is
/// the one a host log is imported under (a trace names its own).
pub fn search(
    spec: &Spec,
    path: &Path,
    configuration: crate::replay::ImportAs<'_>,
    defs: Vec<LaneDef>,
    record: bool,
) -> Result<(Vec<Lane>, u64), SpecError> {
    let (mut lanes, events, levels) =
        search_once(spec, path, configuration, defs.into_iter().map(|d| (d, None)), record, true)?;
    if lanes.iter().all(Lane::alive) {
        return Ok((lanes, events));
    }
    // A lane in which no strobe stopped long enough for the delay to count is judged alike by
    // every card of the delay band: only its supply variants (if any) are searched. The pass
    // lengths come last in each list, searched only when no lane explains the capture under
    // the cards before them (below).
    // A lane that died at a status word no state of its checksum engine gives is past every
    // card of the bands (`words`): only the card already searched.
    // The first such reply depends only on which pairs of bits 13 and 12 the lane's readings
    // allow: the capture is read once per set of pairs, not once per lane.
    let mut first_impossible: Vec<(super::words::Rules, Option<u64>)> = Vec::new();
    let mut beyond = Vec::with_capacity(lanes.len());
    for l in lanes.iter_mut() {
        let Some(d) = l.death.as_mut() else {
            beyond.push(false);
            continue;
        };
        if !d.whatever_the_card {
            let pairs = super::words::rules(&l.cfg);
            let at = match first_impossible.iter().find(|(p, _)| *p == pairs) {
                Some((_, at)) => *at,
                None => {
                    let at = super::words::first_impossible_reply(spec, path, configuration, &l.cfg)?;
                    first_impossible.push((pairs, at));
                    at
                }
            };
            d.whatever_the_card = at == Some(d.event);
        }
        beyond.push(d.whatever_the_card);
    }
    let variants: Vec<Vec<Tolerances>> = lanes
        .iter()
        .zip(&beyond)
        .map(|(l, beyond)| {
            if *beyond {
                return vec![l.tolerances];
            }
            let mut v = Tolerances::variants(&l.cfg, &levels, l.pass_mattered);
            if !l.delay_mattered {
                let stated = l.tolerances.hardware_delay_cycles;
                v.retain(|t| t.hardware_delay_cycles == stated);
            }
            v
        })
        .collect();
    let bands: Vec<usize> = variants
        .iter()
        .zip(&lanes)
        .map(|(v, l)| {
            v.iter().filter(|t| t.checksum_pass_cycles == l.tolerances.checksum_pass_cycles && !t.free_area).count()
        })
        .collect();
    // The cards the bands admit, all judged: those searched, and those the search showed alike
    // (no strobe stopped long enough for their delays to differ).
    let admitted = |l: &Lane, with_passes: bool| {
        let all = Tolerances::variants(&l.cfg, &levels, false).len();
        // The pass lengths but the stated one, and the passes of the card's own length.
        all + if with_passes && l.pass_mattered { pass_lengths().count() } else { 0 }
    };
    for (l, b) in lanes.iter_mut().zip(&bands) {
        l.tolerances_admitted = admitted(l, false).max(*b);
    }
    let first: Vec<Vec<Tolerances>> = variants.iter().zip(&bands).map(|(v, b)| v[..*b].to_vec()).collect();
    retry_variants(spec, path, configuration, record, &mut lanes, &first, &vec![0; first.len()])?;
    // MODEL (search): the card's own pass length is searched only where the stated one leaves
    // the capture unexplained under every reading: a search per length for every lane that
    // dies for a reading of its own would multiply the time of every log placed by host time.
    // A reading ruled out while another explains is ruled out at the stated pass length.
    // Nor in a search placed by host time, where each pass length of an impossible log took
    // minutes (x25-rising.log: over 10 minutes against about 2 before, release build).
    let at_reads = configuration.placement == crate::import::Placement::AtReads;
    if at_reads && !lanes.iter().any(Lane::alive) && variants.iter().zip(&bands).any(|(v, b)| v.len() > *b) {
        for l in lanes.iter_mut() {
            l.tolerances_admitted = admitted(l, true);
        }
        // Index 0 stands for the card already searched, as in the first round.
        let passes: Vec<Vec<Tolerances>> = variants.iter().zip(&bands).map(|(v, b)| v[b - 1..].to_vec()).collect();
        let base: Vec<usize> = bands.iter().map(|b| b - 1).collect();
        retry_variants(spec, path, configuration, record, &mut lanes, &passes, &base)?;
    }
    Ok((lanes, events))
}

/// Searches each dead lane `i` again under `variants[i][k]` for every `k` from 1 (0 is the
/// card it was searched under), one pass over the capture per `k`, keeping the lane that came
/// furthest; `tried_base[i]` cards were searched before these.
fn retry_variants(
    spec: &Spec,
    path: &Path,
    configuration: crate::replay::ImportAs<'_>,
    record: bool,
    lanes: &mut [Lane],
    variants: &[Vec<Tolerances>],
    tried_base: &[usize],
) -> Result<(), SpecError> {
    for k in 1.. {
        let retry: Vec<usize> = (0..lanes.len()).filter(|i| !lanes[*i].alive() && variants[*i].len() > k).collect();
        if retry.is_empty() {
            break;
        }
        let again = retry.iter().map(|i| (lanes[*i].def.clone(), Some(variants[*i][k])));
        // The first pass read the whole capture (and refused it if any of it was unusable).
        let (found, _, _) = search_once(spec, path, configuration, again, record, false)?;
        for (i, mut l) in retry.into_iter().zip(found) {
            l.tolerances_tried = tried_base[i] + k + 1;
            l.tolerances_admitted = lanes[i].tolerances_admitted;
            let latest = |l: &Lane| l.death.as_ref().map(|d| d.event);
            if l.alive() || latest(&l) > latest(&lanes[i]) {
                lanes[i] = l;
            } else {
                lanes[i].tolerances_tried = tried_base[i] + k + 1;
            }
        }
    }
    Ok(())
}

/// Steps `lane` (new, recorded, started as the search was at the event `reader` is at) over
/// the capture's events up to `until`: a segment between checkpoints searched again. Its
/// steps go to `steps` as they are read (the explanation's walk reads them next).
pub fn search_segment(
    spec: &Spec,
    path: &Path,
    reader: &mut Reader,
    lane: &mut Lane,
    until: u64,
    steps: &mut VecDeque<(usize, Step)>,
) -> Result<(), SpecError> {
    while reader.events < until {
        let Some((line, step)) = reader.next_step()? else { break };
        let hints =
            if matches!(step.event, TraceEvent::Elapsed { .. }) { reader.hints(spec)? } else { Hints::default() };
        lane.step(spec, path, reader.events, line, &step, &hints)?;
        steps.push_back((line, step));
    }
    Ok(())
}

/// One pass over the capture with each lane under its tolerances (`None`: the stated ones).
/// With `to_end` the whole capture is read even after every lane died, to count its events and
/// find any unusable line; without, the pass stops there. Also returns the supply levels, in
/// millivolts, of the capture's own `supply` events (those read).
pub fn search_once(
    spec: &Spec,
    path: &Path,
    configuration: crate::replay::ImportAs<'_>,
    defs: impl Iterator<Item = (LaneDef, Option<Tolerances>)>,
    record: bool,
    to_end: bool,
) -> Result<(Vec<Lane>, u64, Vec<u32>), SpecError> {
    let source = Source::open_with(spec, path, configuration)?;
    let card = source.card_as(&configuration);
    let name = source.configuration().to_string();
    let mut lanes = defs
        .map(|(d, t)| Lane::new(spec, &name, card.as_ref(), d, record, t))
        .collect::<Result<Vec<_>, _>>()
        .map_err(|e| SpecError::whole_file(path, format!("configuration `{name}`: {}", e.message)))?;
    let mut reader = Reader::new(source);
    let mut levels = std::collections::BTreeSet::new();
    let mut freeze = super::refute::Freeze::default();
    while let Some((line, step)) = reader.next_step()? {
        LINE_REACHED.store(line, std::sync::atomic::Ordering::Relaxed);
        if configuration.deadline.is_some_and(|d| std::time::Instant::now() > d) {
            return Err(SpecError::whole_file(path, OUT_OF_TIME));
        }
        let event_no = reader.events;
        if let TraceEvent::Model(Event::Supply { millivolts }) = step.event {
            levels.insert(millivolts);
        }
        // The card's own X:$1080, which no candidate's token stands for, judged from the steps
        // alone: a value that moves after the checksum error showed ends every lane (UM p.217).
        if let Some(thawed) = freeze.step(spec, line, &step) {
            for lane in lanes.iter_mut().filter(|l| l.alive()) {
                let candidates = lane.cands.len();
                let (expected, observed) = (thawed.expected(), thawed.observed());
                lane.death = Some(Death {
                    event: event_no,
                    line,
                    what: "X:$1080".into(),
                    expected,
                    observed,
                    candidates,
                    whatever_the_card: true,
                });
                lane.cands.clear();
            }
        }
        if lanes.iter().all(|l| !l.alive()) {
            if !to_end {
                break;
            }
            continue;
        }
        let hints =
            if matches!(step.event, TraceEvent::Elapsed { .. }) { reader.hints(spec)? } else { Hints::default() };
        for lane in &mut lanes {
            lane.step(spec, path, event_no, line, &step, &hints)?;
            if record {
                lane.checkpoint(event_no);
            }
        }
    }
    if reader.events == 0 && to_end {
        return Err(SpecError::whole_file(path, "the capture has no events"));
    }
    Ok((lanes, reader.events, levels.into_iter().collect()))
}
