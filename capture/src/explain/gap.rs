//! What a card can have become after servo cycles the host did not see.
//!
//! A host log says only that N servo cycles passed (X:$0 read twice). In between, background
//! cycles completed whenever the load allowed, the load itself may have changed, the supply
//! may have dipped. The search does not enumerate those schedules one by one (2^N of them);
//! it runs the model on a few *plans*, families of schedules chosen so that every observation
//! a host can make next is produced by one of them:
//!
//! - where the last background cycle fell (`tail`: cycles since it) decides Y:$25;
//! - the deepest run-down before it (a late first background cycle, or a stretch without one)
//!   decides X:$25, which no rule reads, so the search keeps X:$25 as an interval over the
//!   plans that differ only in it;
//! - one background cycle more or less flips the checksum engine's area (bit 12);
//! - an RTI overrun (bits 22, 9), a checksum fault (bits 13, 12), a supply dip or a starved
//!   background (a trip) are added when the next observations call for them.
//!
//! Every plan is run on the model itself ([`super::sim`]), so what the search keeps is what
//! the model reaches. That the plans miss no observation is checked, not argued: the property
//! tests in `tests/explain.rs` generate model runs with random schedules and loads, hide what
//! a host cannot see, and require the search to explain them.

use super::key::CardKey;
use super::sim::{self, FastMap, FastSet, Sim};
use pmacwd_model::controller::Controller;
use pmacwd_specs::check::ChecksumTarget;
use pmacwd_specs::config::ModelConfig;
use pmacwd_specs::profiles::{RtiWarningLatch, StrobeStop};
use pmacwd_specs::vocab::event::Event;

/// What the steps right after a gap observe, before anything changes the card: the search
/// aims its plans at these. (Hints only narrow what is tried; every successor is still
/// checked against the steps themselves.)
#[derive(Clone, Debug, Default, PartialEq, Eq, Hash)]
pub struct Hints {
    /// Whether the first command after the gap got no reply.
    pub silent: Option<bool>,
    /// Y:$25 as read.
    pub counter: Option<i32>,
    /// X:$25 as read.
    pub counter_min: Option<i32>,
    /// A status read shows bit 22 set.
    pub rti_reentry_seen: bool,
    /// A status read shows bit 9 set.
    pub rti_warning_seen: bool,
    /// A status read shows bit 13 set.
    pub checksum_error_seen: bool,
    /// A status read shows bit 13 clear.
    pub checksum_clear_seen: bool,
    /// Servo cycles of short gaps (at most this many in all) between the end of this gap and
    /// the reads above: a log placed by host time has a few cycles between the commands of
    /// one poll, and the reads still aim the plans, each value shifted by up to this many.
    pub shift: u32,
    /// The next X:$25 read, however far, where nothing before it can raise X:$25 or lower it
    /// faster than the servo clock: the search drops the cards that cannot read it then.
    /// Not a hint of the plans (a gap's outcomes do not depend on it, so the memo leaves it out).
    pub min_later: Option<MinLater>,
}

/// An X:$25 read after a gap, with the most servo cycles that can pass between the gap's end and
/// the read, on a stretch of the capture where nothing resets the card or writes I40.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct MinLater {
    pub value: i32,
    pub cycles_max: u64,
}

impl MinLater {
    /// Whether a card at a gap's end, with Y:$25 at least `counter_lo`, X:$25 in
    /// `min_lo..=min_hi` and a reload value `reload`, can read `value` from X:$25 then. X:$25 is
    /// the lowest value the counter has held since the reset (SRM p.57; the model also takes
    /// each reload into it), so without a reset it never rises; and the counter falls by at
    /// most one a servo cycle (SRM p.57, UM p.215) or is reloaded to `reload` (UM p.215): in
    /// `cycles_max` cycles it holds nothing below `counter_lo - cycles_max` or `reload`.
    pub fn reachable(&self, counter_lo: i32, min_lo: i32, min_hi: i32, reload: i32) -> bool {
        let lowest = i64::from(min_lo).min(i64::from(counter_lo) - self.cycles_max as i64).min(i64::from(reload));
        (lowest..=i64::from(min_hi)).contains(&i64::from(self.value))
    }
}

/// How a gap begins, before background cycles follow whenever the load allows.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Lead {
    /// The first background cycle at the first chance after a servo cycle.
    Steady,
    /// A background cycle before the gap's first servo cycle: the one in which the command
    /// just answered was processed ends, reloading the counter (UM p.236: host commands are
    /// processed in the background; UM p.215: the reload comes "at the end of each background
    /// cycle"). The counter then never drops below where the command read it, and the last
    /// reload may be the gap's very start.
    ReloadFirst,
    /// No background cycle for the first `j` servo cycles; one after the `j`-th.
    FirstAfter(u32),
    /// A background cycle after the first servo cycle, then none for `s` cycles, then one.
    Stretch(u32),
}

/// One family of schedules for a gap.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Plan {
    /// The card is tripped or in bootstrap: servo cycles change nothing.
    Idle { cycles: u32 },
    /// The supply dips below its minimum at the start of the gap and comes back (UM p.215).
    Undervoltage { cycles: u32 },
    /// No background cycle completes in the whole gap (or until the card trips); for the
    /// first `heavy` cycles (all of them if `heavy >= cycles`) because PLC 0 takes longer
    /// than an RTI period, and PLC 0 overruns again for the last `overrun_last` cycles (where
    /// the gap ends in its pattern of an overrun every other RTI decides bit 9 under its
    /// level reading, SRM p.290).
    Starved { cycles: u32, heavy: u32, overrun_last: u32 },
    /// `lead`, then background cycles whenever the load allows (one fewer if `skip`), the last
    /// one `tail` servo cycles before the end of the gap.
    /// `overrun_last`: PLC 0 takes longer than an RTI period for the gap's last `overrun_last`
    /// cycles (0: never). Equal to `tail`, the tail is a run-down with the RTI overrunning;
    /// longer, background cycles still complete where the overrunning PLC 0 leaves them CPU
    /// time (UM p.236: PLC 0 starts only at an RTI that finds the previous task set done, so a
    /// PLC 0 just over one period overruns every other RTI and the background runs between;
    /// under the level reading of bit 9, SRM p.290, the bit then reads set or clear by where
    /// the gap ends in that pattern).
    /// `heavy`: PLC 0 takes longer than an RTI period for the first `heavy` cycles, in which
    /// no background cycle completes.
    /// `fault`: memory is corrupted at the start of the gap, for the checksum to find.
    Schedule {
        cycles: u32,
        fault: Option<ChecksumTarget>,
        heavy: u32,
        lead: Lead,
        skip: bool,
        tail: u32,
        overrun_last: u32,
        /// With PLC 0 overrunning in the middle: no background cycle completes in the `hold`
        /// cycles before the middle's last, so the CPU time they had stays the background's
        /// (the model's credit) and the last can complete in a cycle PLC 0 took whole.
        hold: u8,
    },
}

/// Runs `plan` from `card`; `None` if the model cannot follow it (a background cycle the load
/// does not allow, a lead longer than the gap).
pub fn run<'a>(cfg: &'a ModelConfig, card: &Controller, plan: Plan, record: bool) -> Option<Sim<'a>> {
    run_cached(cfg, card, plan, record, None)
}

/// [`run`], its stretches without a background cycle taken from `cache` where it has them
/// (exact, [`Sim::servo_cached`]).
pub fn run_cached<'a>(
    cfg: &'a ModelConfig,
    card: &Controller,
    plan: Plan,
    record: bool,
    mut cache: Option<&mut sim::RunCache>,
) -> Option<Sim<'a>> {
    let mut sim = Sim::new(cfg, card.clone(), record);
    match plan {
        Plan::Idle { cycles } => sim.servo(cycles),
        Plan::Undervoltage { cycles } => {
            // UM p.215: below about 4.75 V the relay trips and the card shuts down; the
            // trip is latched, so the supply coming back changes nothing until a reset.
            sim.event(Event::Supply { millivolts: cfg.supply_min_millivolts.saturating_sub(1) });
            sim.event(Event::Supply { millivolts: cfg.supply_min_millivolts.max(5000) });
            sim.servo(cycles);
        }
        Plan::Starved { cycles, heavy, overrun_last } => {
            let light_until = u64::from(cycles.checked_sub(overrun_last)?);
            let mut ran = 0u64;
            if heavy > 0 {
                sim.event(Event::Load(sim::overrun_load(cfg, sim.card.i8)));
                ran = sim.servo_until_trip(u64::from(heavy).min(light_until));
                if heavy < cycles {
                    sim.event(Event::Load(sim::light_load()));
                }
            } else if sim.card.load != sim::light_load() {
                // A PLC 0 that overran at the end of the last gap is not running on by itself.
                sim.event(Event::Load(sim::light_load()));
            }
            ran += sim.servo_until_trip(light_until.saturating_sub(ran));
            if overrun_last > 0 && !sim.card.tripped() {
                sim.event(Event::Load(sim::overrun_load(cfg, sim.card.i8)));
                ran += sim.servo_until_trip(u64::from(cycles) - ran);
            }
            // A tripped card's servo cycles change nothing; written for the witness's timing.
            sim.servo(cycles - ran as u32);
        }
        Plan::Schedule { cycles, fault, heavy, lead, skip, tail, overrun_last, hold } => {
            if let Some(area) = fault {
                sim.event(Event::ChecksumFault(area));
            }
            // The background cycle the command just answered was processed in ends first.
            if lead == Lead::ReloadFirst && !sim.background() {
                return None;
            }
            if heavy > 0 {
                sim.event(Event::Load(sim::overrun_load(cfg, sim.card.i8)));
                sim.servo(heavy);
            }
            if sim.card.load != sim::light_load() {
                sim.event(Event::Load(sim::light_load()));
            }
            let last = cycles.checked_sub(tail)?;
            let lead_ends_with_background = match lead {
                Lead::Steady => false,
                // Ran before PLC 0's overrun, above; it ends with a background cycle only if
                // nothing came between.
                Lead::ReloadFirst => heavy == 0,
                Lead::FirstAfter(j) => {
                    if j == 0 || u64::from(j) + sim.cycles > u64::from(last) {
                        return None;
                    }
                    sim.servo_cached(j, cache.as_deref_mut());
                    if !sim.background() {
                        return None;
                    }
                    true
                }
                Lead::Stretch(s) => {
                    if s == 0 || 1 + u64::from(s) + sim.cycles > u64::from(last) {
                        return None;
                    }
                    sim.servo(1);
                    if !sim.background() {
                        return None;
                    }
                    sim.servo_cached(s, cache.as_deref_mut());
                    if !sim.background() {
                        return None;
                    }
                    true
                }
            };
            let middle = u64::from(last).checked_sub(sim.cycles)? as u32;
            // The middle's last cycles under the overrunning PLC 0: they come at the end of its
            // final greedy stretch (a plan that would need them earlier is another plan's).
            let overrun_middle = overrun_last.saturating_sub(tail);
            // Background cycles whenever the load allows for `n` cycles, the last of them
            // ending one; PLC 0 overrunning for the last `overrun_middle`, and none completing
            // in the `hold` cycles before the last (their CPU time stays the background's).
            let greedy_end = |sim: &mut Sim, n: u32| -> Option<()> {
                let hold = u32::from(hold);
                let switch_at = n.checked_sub(overrun_middle)?;
                if hold > 0 && (overrun_middle == 0 || hold + 1 > n) {
                    return None;
                }
                let bulk = switch_at.min(n - 1 - hold);
                sim.greedy(bulk);
                for i in bulk..n {
                    if i == switch_at && overrun_middle > 0 {
                        sim.event(Event::Load(sim::overrun_load(cfg, sim.card.i8)));
                    }
                    if i + 1 + hold >= n && i + 1 < n {
                        sim.servo(1);
                    } else {
                        sim.greedy(1);
                    }
                }
                Some(())
            };
            if middle == 0 {
                if !lead_ends_with_background || skip || overrun_middle > 0 {
                    return None;
                }
            } else {
                if skip {
                    // The background cycle left out is the second one, so that the stretch it
                    // makes (two cycles from a reload) runs down no deeper than it must.
                    match middle {
                        0 | 1 => return None,
                        2 => {
                            sim.servo(1);
                            greedy_end(&mut sim, 1)?;
                        }
                        _ => {
                            sim.greedy(1);
                            sim.servo(1);
                            greedy_end(&mut sim, middle - 2)?;
                        }
                    }
                } else {
                    greedy_end(&mut sim, middle)?;
                }
                if !sim.card.tripped() && sim.card.ghost.cycles_since_background != 0 {
                    return None;
                }
            }
            if overrun_last > 0 && overrun_last <= tail {
                // PLC 0 starts overrunning within the tail.
                sim.servo_cached(tail - overrun_last, cache);
                sim.event(Event::Load(sim::overrun_load(cfg, sim.card.i8)));
                sim.servo(overrun_last);
            } else {
                sim.servo_cached(tail, cache);
            }
        }
    }
    Some(sim)
}

/// One successor: the card after the gap, with X:$25 anywhere in `min_lo..=card.counter_min`
/// and Y:$25 anywhere in `counter_lo..=card.counter`.
#[derive(Clone, Debug)]
pub struct Outcome {
    pub card: Controller,
    pub counter_lo: i32,
    pub min_lo: i32,
    /// The plan reaching the top of the interval, and one reaching its bottom.
    pub plan_hi: Plan,
    pub plan_lo: Plan,
    /// The Y:$25 `plan_hi` starts from: the card's, or a lower one its interval allowed.
    pub start_hi: i32,
}

/// A map that forgets everything when full: memory stays flat whatever the log's length, and a
/// healthy log, which meets the same few cards over and over, fills it again at once.
struct Bounded<K, V> {
    map: FastMap<K, V>,
    entries_max: usize,
}

impl<K: std::hash::Hash + Eq, V: Clone> Bounded<K, V> {
    fn new(entries_max: usize) -> Self {
        Bounded { map: FastMap::default(), entries_max }
    }

    /// The value for `key`, worked out by `make` the first time.
    fn get_or(&mut self, key: K, make: impl FnOnce() -> V) -> V {
        if let Some(v) = self.map.get(&key) {
            return v.clone();
        }
        let v = make();
        if self.map.len() >= self.entries_max {
            self.map.clear();
        }
        self.map.insert(key, v.clone());
        v
    }
}

/// What a lane has worked out once and asks again on every gap of a long capture (X:$0, which
/// no rule reads, is cleared in the search's cards, so the same card recurs): running a card
/// down cycle by cycle to its trip, and the plans of whole gaps, were most of a stamped log's
/// time.
pub struct Memo {
    /// Servo cycles each card takes to trip without a background cycle (4,096 cards).
    trip: Bounded<(CardKey, u64), u64>,
    /// Whole gaps: a healthy poll asks for the same card, cycles and hints again and again
    /// (512 gaps of a few cards each: about 1 MB a lane).
    gaps: Bounded<(CardKey, i32, u32, Hints), Vec<Outcome>>,
    /// Stretches without a background cycle, for the plans of every gap (`sim::RunCache`).
    runs: sim::RunCache,
}

impl Default for Memo {
    fn default() -> Memo {
        Memo { trip: Bounded::new(4096), gaps: Bounded::new(512), runs: sim::RunCache::default() }
    }
}

impl Memo {
    fn cycles_to_trip(&mut self, cfg: &ModelConfig, card: &Controller, max: u64) -> u64 {
        self.trip.get_or((CardKey(card.clone()), max), || cycles_to_trip(cfg, card, max))
    }
}

/// Servo cycles from `card` without a background cycle until it trips (at most `max`).
fn cycles_to_trip(cfg: &ModelConfig, card: &Controller, max: u64) -> u64 {
    let mut probe = card.clone();
    let n = sim::run_without_background(&mut probe, cfg, max);
    if probe.tripped() {
        n
    } else {
        u64::MAX
    }
}

/// Every card the search keeps after `cycles` unseen servo cycles from a card whose Y:$25 is
/// anywhere in `counter_lo..=card.counter`, grouped so that cards differing only in X:$25 (and,
/// when the steps after the gap do not read it, Y:$25) are one outcome with intervals.
pub fn successors(
    cfg: &ModelConfig,
    memo: &mut Memo,
    card: &Controller,
    counter_lo: i32,
    cycles: u32,
    hints: &Hints,
) -> Vec<Outcome> {
    let key = (CardKey(card.clone()), counter_lo, cycles, Hints { min_later: None, ..hints.clone() });
    if let Some(out) = memo.gaps.map.get(&key) {
        return out.clone();
    }
    // Worked out outside `get_or`: the plans use the memo's trip counts too.
    let out = successors_uncached(cfg, memo, card, counter_lo, cycles, hints);
    memo.gaps.get_or(key, || out)
}

fn successors_uncached(
    cfg: &ModelConfig,
    memo: &mut Memo,
    card: &Controller,
    counter_lo: i32,
    cycles: u32,
    hints: &Hints,
) -> Vec<Outcome> {
    let mut runs: Vec<(Controller, Plan)> = Vec::new();
    let mut starts = vec![card.clone()];
    if counter_lo < card.counter {
        let mut lo = card.clone();
        lo.counter = counter_lo;
        starts.push(lo);
        // Y:$25 read after a gap with no background cycle: the start it ran down from.
        if let Some(v) = hints.counter {
            let from = i64::from(v) + i64::from(cycles);
            if from > i64::from(counter_lo) && from < i64::from(card.counter) {
                let mut mid = card.clone();
                mid.counter = from as i32;
                starts.push(mid);
            }
        }
    }
    for start in starts {
        for plan in plans_for(cfg, memo, &start, cycles, hints) {
            runs.push((start.clone(), plan));
        }
    }
    // Y:$25 read after short gaps says less of this gap's end than one read right after it:
    // the outcome keeps it as an interval, which the read then narrows.
    group(cfg, runs, hints.counter.is_none() || hints.shift > 0, &mut memo.runs)
}

/// The plans tried from `card`.
fn plans_for(cfg: &ModelConfig, memo: &mut Memo, card: &Controller, cycles: u32, hints: &Hints) -> Vec<Plan> {
    let mut plans: Vec<Plan> = Vec::new();
    if card.tripped() || card.bootstrap {
        plans.push(Plan::Idle { cycles });
    } else {
        let r = cfg.reset_value(card.i40);
        let delay = i64::from(cfg.hardware_delay_cycles);
        let may_be_silent = hints.silent != Some(false);
        // No background cycle at all: the counter runs down from where it is.
        let starved_counter = super::run_down(cfg, card.counter, cycles);
        // Whether Y:$25 as read can follow from `v` at the end of this gap.
        let shift = i64::from(hints.shift);
        let counter_fits = |v: i64| hints.counter.is_none_or(|c| (v - shift..=v).contains(&i64::from(c)));
        // A card with no background cycle in the whole gap trips within its counter's run and
        // the hardware delay (UM p.215; the strobe stops at the latest when the counter runs
        // out, SRM p.57): past that, a starved plan ends tripped, which a command answered
        // after the gap rules out.
        let starved_may_answer = i64::from(cycles) <= i64::from(card.counter.max(0)) + delay + 2;
        let starved_useful = may_be_silent || starved_may_answer;
        if starved_useful && (may_be_silent || counter_fits(starved_counter)) {
            plans.push(Plan::Starved { cycles, heavy: 0, overrun_last: 0 });
        }
        // After the starved plans: where both end in the same tripped card, the explanation
        // keeps the first (a trip the log's own readings point at).
        if may_be_silent {
            plans.push(Plan::Undervoltage { cycles });
        }
        // A background cycle can end right after the command just answered (`Lead::ReloadFirst`);
        // it changes the card only if the counter has run down since the last reload.
        let reload_first = card.background_possible() && card.counter < r;
        // Cycles since the last background cycle, from Y:$25 when it is read: the whole gap
        // when the last one ended right at its start.
        let tail_top = if reload_first { cycles } else { cycles.saturating_sub(1) };
        let tail_max = u64::from(tail_top).min((i64::from(r) + delay + 2).max(0) as u64) as u32;
        let tails: Vec<u32> = match hints.counter {
            Some(c) if hints.silent == Some(false) || hints.silent.is_none() => {
                let mut t = std::collections::BTreeSet::new();
                let k = i64::from(r) - i64::from(c);
                if c == 0 && cfg.profile.choices.strobe_stop == StrobeStop::AtZero {
                    // At zero the counter stays: any tail from R on, until the trip.
                    t.extend((r.max(0) as u32)..=tail_max);
                }
                // The short gaps after this one ran the counter down by up to `shift` more.
                for s in 0..=shift {
                    if (0..=i64::from(tail_max)).contains(&(k - s)) {
                        t.insert((k - s) as u32);
                    }
                }
                if k <= shift {
                    // A background cycle may have come in the short gaps, reloading the
                    // counter: this gap's tail is then free, as if Y:$25 were not read.
                    t.extend(unread_tails(card, r, tail_max));
                }
                t.into_iter().collect()
            }
            // Y:$25 not read: every tail is possible. Tails while the counter stays well above
            // zero lead to the same card but for Y:$25 (and the checksum area, which `skip`
            // covers), so a few stand for all of them and the outcome keeps Y:$25 as an
            // interval; near zero, where the strobe stops, every tail is tried.
            _ => unread_tails(card, r, tail_max).into_iter().collect(),
        };
        // X:$25 read after the gap is the lowest the counter has been since the reset (SRM
        // p.57), so the counter never went below it, less what the short gaps after this one
        // ran it down: a tail reloaded at R that runs deeper is no schedule of this card.
        // (Under the at-zero reading, an X:$25 of 0 bounds nothing: the counter stays there.)
        let tail_fits = |t: u32| match hints.counter_min {
            Some(m) if m > 0 || cfg.profile.choices.strobe_stop == StrobeStop::BelowZero => {
                i64::from(r) - i64::from(t) >= i64::from(m) - shift
            }
            _ => true,
        };
        // The deepest tail that fits stands in for those cut (with Y:$25 unread, the tails
        // tried are the ends of the intervals the outcomes keep, `unread_tails`).
        let deepest_fitting = |tails: &[u32]| -> Vec<u32> {
            let Some(m) = hints.counter_min else { return Vec::new() };
            let top = i64::from(r) - i64::from(m) + shift;
            if tails.iter().all(|t| tail_fits(*t)) || top < 0 {
                return Vec::new();
            }
            let top = top.min(i64::from(tail_max)) as u32;
            vec![top.saturating_sub(1), top]
        };
        let cut = deepest_fitting(&tails);
        let mut tails: Vec<u32> = tails.into_iter().filter(|t| tail_fits(*t)).chain(cut).collect();
        tails.sort_unstable();
        tails.dedup();
        // An overrun is wanted where a status read shows bit 22 or bit 9 that the card does not
        // hold yet (bit 22 is sticky, SRM p.289; bit 9 too under its sticky reading, SRM p.290).
        // Once they are held, what an overrun does to the card besides is to take CPU time from
        // the background, and a light load leaves every background schedule open already.
        let level = cfg.profile.choices.rti_warning_latch == RtiWarningLatch::Level;
        let overrun_wanted = (hints.rti_reentry_seen && !card.status.rti_reentry)
            || (hints.rti_warning_seen && (level || !card.status.rti_warning));
        if starved_useful && (overrun_wanted || may_be_silent) {
            plans.push(Plan::Starved { cycles, heavy: cycles, overrun_last: 0 });
        }
        // PLC 0 overrunning at the end of the gap, with background cycles between its overruns
        // (a PLC 0 just over one period overruns every other RTI, UM p.236): under the level
        // reading of bit 9 (SRM p.290) a read shows it set or clear by where the gap ends in
        // that pattern, and background cycles between the overruns (on CPU time saved before
        // PLC 0 took a whole cycle) keep X:$25 near the reload; its last I8+2 to 3(I8+1)
        // cycles meet every phase. Y:$25, unread, may then come from a tail no background
        // cycle could end under a light load: every tail of the pattern is tried.
        let end_overruns: Vec<u32> = if overrun_wanted {
            let period = u32::from(card.i8) + 1;
            (period + 1..=3 * period).filter(|o| *o < cycles).collect()
        } else {
            Vec::new()
        };
        // The tails of those plans (below, without an overrun at the gap's start: with one, the
        // bits are set already and the end is a light load's).
        let mut end_tails = tails.clone();
        if hints.counter.is_none() && !end_overruns.is_empty() {
            let top = (3 * (u32::from(card.i8) + 1)).min(tail_max);
            end_tails.extend((0..=top).filter(|t| !tails.contains(t) && tail_fits(*t)));
            end_tails.sort_unstable();
        }
        if starved_useful && overrun_wanted && counter_fits(starved_counter) {
            for heavy in 1..(3 * (u32::from(card.i8) + 1) + 3).min(cycles) {
                plans.push(Plan::Starved { cycles, heavy, overrun_last: 0 });
            }
            for &overrun_last in &end_overruns {
                plans.push(Plan::Starved { cycles, heavy: 0, overrun_last });
            }
        }
        // PLC 0 longer than an RTI period at the start of the gap, for as long as it takes
        // the RTI to overrun and for up to a few periods more.
        // Once the card holds the bits a read shows (bit 22 is sticky; bit 9 is held now, or
        // under its level reading the gap's end decides it, `end_overruns`), an overrun at the
        // start only takes CPU time from the background, which the leads below do as well
        // (`Lead::FirstAfter`, `Lead::Stretch`). In a short gap the start's overrun may reach
        // the end: there it is tried still.
        let period = u32::from(card.i8) + 1;
        let start_overrun_wanted = (hints.rti_reentry_seen && !card.status.rti_reentry)
            || (hints.rti_warning_seen && !card.status.rti_warning)
            || (overrun_wanted && cycles <= 2 * (3 * period + 3));
        let heavies: Vec<u32> = if start_overrun_wanted {
            (0..=3 * (u32::from(card.i8) + 1) + 2).filter(|h| *h < cycles).collect()
        } else {
            vec![0]
        };
        for heavy in heavies {
            let c0 = super::run_down(cfg, card.counter, heavy);
            let room = cycles - heavy;
            let mut leads = vec![Lead::Steady];
            // Reloading first matters where the counter is at its lowest since reset (X:$25
            // then stays), or for a tail of the whole gap; elsewhere it is `Steady` but for
            // one background cycle more, whose checksum area `skip` covers.
            if reload_first && (card.counter == card.counter_min || tails.contains(&cycles)) {
                leads.push(Lead::ReloadFirst);
            }
            match hints.counter_min {
                Some(m) => {
                    // X:$25 as read, less what the short gaps after this one may have run down.
                    for s in 0..=shift {
                        let m = i64::from(m) + s;
                        if c0 - m >= 1 && !leads.contains(&Lead::FirstAfter((c0 - m) as u32)) {
                            leads.push(Lead::FirstAfter((c0 - m) as u32));
                        }
                        if i64::from(r) - m >= 1 && !leads.contains(&Lead::Stretch((i64::from(r) - m) as u32)) {
                            leads.push(Lead::Stretch((i64::from(r) - m) as u32));
                        }
                    }
                }
                None => {
                    // The deepest run-downs that do not trip the card: the rest of the interval.
                    let bound = (i64::from(r) + delay + 4 * (i64::from(card.i8) + 2)).max(1) as u64;
                    let mut start = Sim::new(cfg, card.clone(), false);
                    if heavy > 0 {
                        start.event(Event::Load(sim::overrun_load(cfg, card.i8)));
                        start.servo(heavy);
                        start.event(Event::Load(sim::light_load()));
                    }
                    let first = memo.cycles_to_trip(cfg, &start.card, bound).saturating_sub(1).min(u64::from(room));
                    if first >= 1 {
                        leads.push(Lead::FirstAfter(first as u32));
                    }
                    start.servo(1);
                    if start.background() {
                        let stretch =
                            memo.cycles_to_trip(cfg, &start.card, bound).saturating_sub(1).min(u64::from(room));
                        if stretch >= 1 {
                            leads.push(Lead::Stretch(stretch as u32));
                        }
                    }
                }
            }
            let corrupted = card.checksum.firmware != card.checksum.firmware_reference
                || card.checksum.program != card.checksum.program_reference;
            let faults: &[Option<ChecksumTarget>] = if card.checksum.error.is_none()
                && (hints.checksum_error_seen || (hints.checksum_clear_seen && corrupted))
            {
                // A corruption for the checksum to find; or, where a corruption the engine has
                // not found yet is not found by the next status read, the memory changed again
                // (the model's fault event flips the same word back).
                &[None, Some(ChecksumTarget::Firmware), Some(ChecksumTarget::UserProgram)]
            } else {
                &[None]
            };
            let tails_here = if heavy == 0 { &end_tails } else { &tails };
            for (&tail, &fault) in tails_here.iter().flat_map(|t| faults.iter().map(move |f| (t, f))) {
                // (A silent command after the gap needs no trip: a starved background is
                // silent too, UM p.236, and the command's own wait is its step's.)
                // PLC 0 overrunning at the end of the gap: through the tail (a run-down), or
                // for every phase of its pattern, with background cycles between its overruns
                // (`end_overruns`).
                let mut overruns = vec![0];
                if overrun_wanted && tail > 0 {
                    overruns.push(tail);
                }
                if heavy == 0 {
                    overruns.extend(end_overruns.iter().filter(|o| **o != tail));
                }
                for &lead in &leads {
                    for (skip, &overrun_last) in
                        [false, true].into_iter().flat_map(|s| overruns.iter().map(move |o| (s, o)))
                    {
                        let Some(span) = cycles.checked_sub(tail + heavy) else { continue };
                        if overrun_last > tail && overrun_last > span + tail {
                            continue;
                        }
                        let lead = match lead {
                            // A lead deeper than the gap allows is the deepest the gap allows.
                            // (With `skip`, one more cycle without a background cycle must fit.)
                            Lead::FirstAfter(j) => Lead::FirstAfter(j.min(span.saturating_sub(2 * u32::from(skip)))),
                            Lead::Stretch(s) => Lead::Stretch(s.min(span.saturating_sub(1 + 2 * u32::from(skip)))),
                            l => l,
                        };
                        // Holding background cycles back matters where Y:$25 is read and fixes
                        // the tail; unread, another tail gives what a hold would.
                        let holds = if overrun_last > tail && hints.counter.is_some() {
                            u8::try_from(u32::from(card.i8) + 1).unwrap_or(0)
                        } else {
                            0
                        };
                        for hold in 0..=holds {
                            plans.push(Plan::Schedule { cycles, fault, heavy, lead, skip, tail, overrun_last, hold });
                        }
                    }
                }
            }
        }
    }
    plans
}

/// The tails tried when Y:$25 is not read after the gap: every tail is possible. Tails while
/// the counter stays well above zero lead to the same card but for Y:$25 (and the checksum
/// area, which `skip` covers), so a few stand for all of them and the outcome keeps Y:$25 as
/// an interval; near zero, where the strobe stops, every tail is tried.
fn unread_tails(card: &Controller, r: i32, tail_max: u32) -> std::collections::BTreeSet<u32> {
    let risky_from = (i64::from(r) - i64::from(card.i8) - 3).max(0) as u32;
    let safe_top = tail_max.min(risky_from.saturating_sub(1));
    let mut t: std::collections::BTreeSet<u32> = [0, 1, 2, safe_top.saturating_sub(1), safe_top].into_iter().collect();
    t.extend(risky_from..=tail_max);
    t.into_iter().filter(|k| *k <= tail_max).collect()
}

/// Runs every plan and merges the results that differ only in X:$25 into intervals; with
/// `merge_counter`, also those that differ only in Y:$25, over contiguous runs of values.
///
/// MODEL (search): merged, Y:$25 and X:$25 are two intervals with X:$25 <= Y:$25, which
/// allows pairs a run of the model would not reach together when both are read after a later
/// gap; docs/replay.md, "What the search keeps", says where this matters.
fn group(
    cfg: &ModelConfig,
    runs: Vec<(Controller, Plan)>,
    merge_counter: bool,
    cache: &mut sim::RunCache,
) -> Vec<Outcome> {
    struct Point {
        card: Controller,
        min_lo: i32,
        plan_hi: Plan,
        plan_lo: Plan,
        start_hi: i32,
    }
    let mut by_state: FastMap<(CardKey, u8), std::collections::BTreeMap<i32, Point>> = FastMap::default();
    let mut seen = FastSet::default();
    for (start, plan) in runs {
        if !seen.insert((start.counter, plan)) {
            continue;
        }
        let Some(sim) = run_cached(cfg, &start, plan, false, Some(&mut *cache)) else { continue };
        let mut end = sim.card;
        super::normalize(&mut end);
        let min = end.counter_min;
        let mut key = end.clone();
        key.counter_min = i32::MIN;
        // Y:$25 values merge within one kind of plan only: a starved gap's counter and a
        // scheduled one's lie apart, with values between that neither reaches.
        let kind = match plan {
            Plan::Idle { .. } => 0u8,
            Plan::Undervoltage { .. } => 1,
            Plan::Starved { .. } => 2,
            Plan::Schedule { .. } => 3,
        };
        if merge_counter {
            // The background's CPU credit stays in the key: a card whose last background cycle
            // ended a servo cycle or more ago may end another before the next one
            // (`Lead::ReloadFirst`), one that has just had one may not.
            key.counter = i32::MIN;
        }
        let points = by_state.entry((CardKey(key), kind)).or_default();
        match points.get_mut(&end.counter) {
            Some(p) => {
                if min > p.card.counter_min {
                    p.card.counter_min = min;
                    p.plan_hi = plan;
                    p.start_hi = start.counter;
                }
                if min < p.min_lo {
                    p.min_lo = min;
                    p.plan_lo = plan;
                }
            }
            None => {
                points.insert(
                    end.counter,
                    Point { card: end, min_lo: min, plan_hi: plan, plan_lo: plan, start_hi: start.counter },
                );
            }
        }
    }
    let mut out = Vec::new();
    for points in by_state.into_values() {
        // With `merge_counter`, every Y:$25 value of one kind of plan is one outcome (the
        // tails tried stand for those between them); otherwise each value is its own.
        let mut run: Option<Outcome> = None;
        for (counter, p) in points {
            match &mut run {
                Some(o) if merge_counter => {
                    let _ = counter;
                    o.min_lo = o.min_lo.min(p.min_lo);
                    if p.card.counter_min >= o.card.counter_min {
                        o.plan_hi = p.plan_hi;
                        o.start_hi = p.start_hi;
                    }
                    let counter_min = o.card.counter_min.max(p.card.counter_min);
                    o.card = Controller { counter_min, ..p.card };
                }
                _ => {
                    if let Some(o) = run.take() {
                        out.push(o);
                    }
                    run = Some(Outcome {
                        counter_lo: counter,
                        card: p.card,
                        min_lo: p.min_lo,
                        plan_hi: p.plan_hi,
                        plan_lo: p.plan_lo,
                        start_hi: p.start_hi,
                    });
                }
            }
        }
        out.extend(run);
    }
    if merge_counter {
        out = merge_touching(out);
    }
    out
}

/// Merges outcomes of different kinds of plan (a starved gap's and a scheduled one's) that
/// are the same card but for Y:$25 and X:$25 and whose Y:$25 intervals meet, touch, or leave
/// one value between them: each interval holds every value between its ends (see `group`),
/// and the value between is one the card reaches. (It is the Y:$25 of a gap with a single
/// background cycle, at its start: under the search's checksum passes of one background cycle
/// each, that cycle always moves the checksum engine to the other area, so the area of the
/// starved card is not reached with it; a card's passes are longer, and one background cycle
/// need not end one. MODEL: check.yaml, `host-log`.)
///
/// Without it, a status poll that never reads Y:$25 keeps a card that may have starved since
/// each gap apart from the others (Y:$25 one gap's cycles lower each time): cards that never
/// recur, until the counter would run out. Merged, the interval grows to the trip and the
/// same cards come back, so a lane's gaps are met from its memo.
fn merge_touching(outcomes: Vec<Outcome>) -> Vec<Outcome> {
    // Each outcome's card but for its counters, worked out once (not per pair compared).
    let mut blanks: Vec<Controller> = Vec::with_capacity(outcomes.len());
    let mut out: Vec<Outcome> = Vec::with_capacity(outcomes.len());
    for o in outcomes {
        let blank = super::blank(&o.card);
        let meets = |(m, m_blank): &(&mut Outcome, &Controller)| {
            **m_blank == blank
                && m.card.background_credit == o.card.background_credit
                && i64::from(o.counter_lo) <= i64::from(m.card.counter) + 2
                && i64::from(m.counter_lo) <= i64::from(o.card.counter) + 2
        };
        match out.iter_mut().zip(blanks.iter()).find(|pair| meets(pair)).map(|(m, _)| m) {
            Some(m) => {
                if o.card.counter_min > m.card.counter_min {
                    m.plan_hi = o.plan_hi;
                    m.start_hi = o.start_hi;
                }
                if o.min_lo < m.min_lo {
                    m.plan_lo = o.plan_lo;
                    m.min_lo = o.min_lo;
                }
                let counter_min = m.card.counter_min.max(o.card.counter_min);
                if o.card.counter > m.card.counter {
                    m.card = Controller { counter_min, ..o.card };
                } else {
                    m.card.counter_min = counter_min;
                }
                m.counter_lo = m.counter_lo.min(o.counter_lo);
            }
            None => {
                out.push(o);
                blanks.push(blank);
            }
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::MinLater;

    #[test]
    fn a_later_x25_read_keeps_every_card_that_can_reach_it_and_only_those() {
        // 300 cycles before a read of 473, on a card reloading to 1,000.
        let later = MinLater { value: 473, cycles_max: 300 };
        // X:$25 already holds it.
        assert!(later.reachable(900, 400, 600, 1000));
        // The counter can run down to it in time: 773 - 300 = 473.
        assert!(later.reachable(773, 700, 800, 1000));
        // One cycle short: the counter cannot get below 474 by the read, X:$25 is above it.
        assert!(!later.reachable(774, 700, 800, 1000));
        // X:$25 never rises without a reset: below the value already, nothing brings it back.
        assert!(!later.reachable(900, 100, 472, 1000));
        // A reload to a lowered I40 takes X:$25 with it.
        assert!(later.reachable(900, 700, 800, 400));
        // At the read itself (no cycles between), only an interval holding the value.
        let now = MinLater { value: 473, cycles_max: 0 };
        assert!(now.reachable(473, 473, 473, 1000));
        assert!(!now.reachable(474, 474, 480, 1000));
    }
}
