//! The model driven by a chosen schedule of unseen events, recording them as trace events.
//!
//! Everything the search concludes about a gap comes from running the reference model's own
//! rules here (`Controller::servo_cycle`, `background_cycle`, `apply`): a successor the search
//! keeps is a state the model really reaches, and the events recorded are its witness.

use super::key::CardKey;
use pmacwd_model::controller::Controller;
use pmacwd_specs::check::Load;
use pmacwd_specs::config::ModelConfig;
use pmacwd_specs::vocab::event::Event;
use pmacwd_trace::TraceEvent;

/// The load the search runs a card at when nothing says otherwise: no motors, no PLC 0 and a
/// background cycle of one CPU unit, so that a background cycle can complete after every
/// servo cycle. With it, *when* background cycles complete is the search's choice alone.
pub fn light_load() -> Load {
    Load { motors: 0, plc0_units: 0, background_units: 1 }
}

/// A PLC 0 just longer than one RTI period: the next RTI finds the task set still running
/// (SRM p.289, bit 22; SRM p.290, bit 9), while the background gets no CPU time meanwhile.
pub fn overrun_load(cfg: &ModelConfig, i8: u8) -> Load {
    let units = u32::from(cfg.cpu.cycle_units) * (u32::from(i8) + 1) + 1;
    Load { motors: 0, plc0_units: u16::try_from(units).unwrap_or(u16::MAX), background_units: 1 }
}

/// A `HashMap` with a fast hasher: the search's keys are whole cards, its own states, not a
/// client's input, so hashing them with SipHash's flood resistance bought nothing and cost a
/// fifth of replay's time (issue 32). Fixed seed: the same capture is searched the same way.
pub type FastMap<K, V> = std::collections::HashMap<K, V, foldhash::fast::FixedState>;
/// The set of [`FastMap`].
pub type FastSet<K> = std::collections::HashSet<K, foldhash::fast::FixedState>;

/// Runs without a background cycle worked out from a card (X:$0 and X:$25 left out of it):
/// for each start card, the cards its run reached after so many cycles. Kept by a lane across
/// its gaps and the start cards of one gap, which meet the same stretches again and again:
/// tails differing by a whole steady period start from the same card, a lead's run-down is the
/// same for every tail, and cards that differ only in X:$25 run alike. Every run asked for
/// is kept as a point to go on from: the start cards of one gap each ask for the same tails
/// in turn, and a run kept only at its furthest point would be run again from its start by
/// the next start card's shorter tails.
#[derive(Default)]
pub struct RunCache {
    runs: FastMap<CardKey, Vec<(u32, Controller)>>,
    points: usize,
}

impl RunCache {
    /// Shorter runs cost less than the lookup.
    const CYCLES_MIN: u32 = 64;
    /// Cards kept in all (about 400 bytes each with their keys): a lane's cache stays under
    /// a megabyte, and forgets everything when full.
    const POINTS_MAX: usize = 2048;

    /// The furthest point of the run from `key` at or before `n` cycles.
    fn best(&self, key: &CardKey, n: u32) -> Option<&(u32, Controller)> {
        self.runs.get(key)?.iter().rev().find(|(d, _)| *d <= n)
    }

    fn keep(&mut self, key: CardKey, n: u32, card: &Controller) {
        if self.points >= Self::POINTS_MAX {
            self.runs.clear();
            self.points = 0;
        }
        let points = self.runs.entry(key).or_default();
        if let Err(at) = points.binary_search_by_key(&n, |(d, _)| *d) {
            points.insert(at, (n, card.clone()));
            self.points += 1;
        }
    }
}

/// A card being driven, with the events that drove it when `record` is on.
pub struct Sim<'a> {
    pub cfg: &'a ModelConfig,
    pub card: Controller,
    /// Servo cycles simulated so far.
    pub cycles: u64,
    pub events: Option<Vec<TraceEvent>>,
}

impl<'a> Sim<'a> {
    pub fn new(cfg: &'a ModelConfig, card: Controller, record: bool) -> Sim<'a> {
        Sim { cfg, card, cycles: 0, events: record.then(Vec::new) }
    }

    fn push(&mut self, e: TraceEvent) {
        if let Some(events) = &mut self.events {
            // Consecutive servo runs are written as one step.
            if let (
                Some(TraceEvent::Model(Event::Servo { cycles: a })),
                TraceEvent::Model(Event::Servo { cycles: b }),
            ) = (events.last_mut(), &e)
            {
                if let Some(sum) = a.checked_add(*b) {
                    *a = sum;
                    return;
                }
            }
            events.push(e);
        }
    }

    /// `n` servo cycles with no background cycle completing.
    pub fn servo(&mut self, n: u32) {
        if n == 0 {
            return;
        }
        run_without_background(&mut self.card, self.cfg, u64::from(n));
        self.cycles += u64::from(n);
        self.push(TraceEvent::Model(Event::Servo { cycles: n }));
    }

    /// [`Self::servo`], continuing a run from the same card that `cache` remembers when one
    /// is there. Exact: the card `cache` gives is the one the cycles reach. X:$0 and X:$25,
    /// which no rule reads (the model only writes them: `servo_cycle`, `background_cycle`),
    /// are kept out of the key: X:$0 is advanced by the cycles run, and X:$25 is the lower of
    /// the start's and the lowest the counter reached in the run (the run's own, from a key
    /// whose X:$25 is the highest there is).
    pub fn servo_cached(&mut self, n: u32, cache: Option<&mut RunCache>) {
        let Some(cache) = cache.filter(|_| self.events.is_none() && n >= RunCache::CYCLES_MIN) else {
            return self.servo(n);
        };
        let base = self.card.servo_cycles;
        let counter_min = self.card.counter_min;
        let mut key = CardKey(self.card.clone());
        key.0.servo_cycles = 0;
        key.0.counter_min = i32::MAX;
        let mut done = 0;
        match cache.best(&key, n) {
            Some((d, after)) => {
                done = *d;
                self.card.clone_from(after);
            }
            None => self.card.clone_from(&key.0),
        }
        run_without_background(&mut self.card, self.cfg, u64::from(n - done));
        if done < n {
            cache.keep(key, n, &self.card);
        }
        self.card.servo_cycles = base.wrapping_add(self.card.servo_cycles) & self.cfg.servo_counter_mask;
        self.card.counter_min = self.card.counter_min.min(counter_min);
        self.cycles += u64::from(n);
    }

    /// Servo cycles without a background cycle until the card trips, at most `max`; returns
    /// how many ran.
    pub fn servo_until_trip(&mut self, max: u64) -> u64 {
        let n = run_without_background(&mut self.card, self.cfg, max);
        self.cycles += n;
        let mut left = n;
        while left > 0 {
            let step = left.min(u64::from(pmacwd_trace::STEP_CYCLES_MAX)) as u32;
            self.push(TraceEvent::Model(Event::Servo { cycles: step }));
            left -= u64::from(step);
        }
        n
    }

    /// Whether servo cycles change nothing: the model's `servo_cycle` returns at once on a
    /// tripped card (UM p.215: "the processor stops operating") and in bootstrap mode, and no
    /// background cycle can complete. Long gaps (a first X:$0 read millions of cycles after
    /// the last restart) are then not run cycle by cycle.
    fn frozen(&self) -> bool {
        self.card.tripped() || self.card.bootstrap
    }

    /// A background cycle completes; `false` (and nothing done) if the model says it cannot.
    pub fn background(&mut self) -> bool {
        if !self.card.background_possible() {
            return false;
        }
        self.card.background_cycle(self.cfg);
        self.push(TraceEvent::Model(Event::Background));
        true
    }

    pub fn event(&mut self, e: Event) {
        self.card.apply(self.cfg, &e);
        self.push(TraceEvent::Model(e));
    }

    /// `n` servo cycles with a background cycle after each one the load allows: the trace
    /// format's `run`. A deterministic run that comes back to a state it was in repeats
    /// itself from there, so whole periods are skipped once one is seen (exact: the model is
    /// deterministic here, and X:$0, which no rule reads, is advanced by the cycles skipped).
    pub fn greedy(&mut self, n: u32) {
        if n == 0 {
            return;
        }
        self.push(TraceEvent::Run { cycles: n });
        // The card repeats at the latest after a whole number of RTI periods and of checksum
        // rounds (a pass over each area) once the load lets one background cycle complete a
        // servo cycle; a load that spaces them out repeats later, so a period that brings no
        // repeat in four tries is doubled (up to `PERIOD_MAX`). Only an exact repeat is leapt.
        const PERIOD_MAX: u32 = 1 << 16;
        let round = (u32::from(self.cfg.pass_cycles.firmware) + u32::from(self.cfg.pass_cycles.user_program)).max(1);
        let mut period = (u32::from(self.card.i8) + 1).saturating_mul(round).min(PERIOD_MAX);
        let mut misses = 0u32;
        let mut left = n;
        let mut mark: Option<Controller> = None;
        let mut since_mark = 0u32;
        while left > 0 {
            if self.frozen() {
                // X:$0 stops with the rest (no servo cycle runs): nothing left changes.
                break;
            }
            self.card.servo_cycle(self.cfg);
            if self.card.background_possible() {
                self.card.background_cycle(self.cfg);
            }
            left -= 1;
            since_mark += 1;
            if since_mark == period {
                since_mark = 0;
                // X:$0 counts on (no rule reads it): compared without it, advanced on a leap.
                let mut now = self.card.clone();
                now.servo_cycles = 0;
                if mark.as_ref() == Some(&now) {
                    let skipped = left - left % period;
                    self.card.servo_cycles = self.card.servo_cycles.wrapping_add(skipped) & self.cfg.servo_counter_mask;
                    left %= period;
                    mark = None;
                } else {
                    if mark.is_some() {
                        misses += 1;
                    }
                    if misses == 4 && period < PERIOD_MAX {
                        misses = 0;
                        period *= 2;
                        mark = None;
                    } else {
                        mark = Some(now);
                    }
                }
            }
        }
        self.cycles += u64::from(n);
    }
}

/// Runs up to `n` servo cycles of `card` with no background cycle completing, as
/// `Controller::servo_cycle` does one by one; returns how many ran before the card froze
/// (tripped, or in bootstrap: the model's servo cycle then changes nothing).
///
/// A run-down repeats itself: while the counter is above zero the strobe toggles every cycle
/// it is due, and nothing in the servo cycle reads the counter but that test (Y:$25's value,
/// X:$25, X:$0 and the ghost's count of cycles since the background are only written). So
/// once the card is the same, those four aside, as `k` RTI periods earlier (`k` up to
/// [`RUN_DOWN_LAGS_MAX`]), every further `k` periods until the counter could reach zero are
/// the same again, and are leapt: the counter
/// falls by the cycles leapt, X:$25 follows it, X:$0 and the ghost's count advance. The last
/// stretch to zero and the trip are run cycle by cycle. Exact (`tests::a_leapt_run_down_is_the_run_cycle_by_cycle`).
pub fn run_without_background(card: &mut Controller, cfg: &ModelConfig, n: u64) -> u64 {
    let period = u64::from(card.i8) + 1;
    let mut ran = 0u64;
    // The shapes at the ends of the last few periods, newest last: a run-down may repeat
    // only every few periods (a PLC 0 just over one RTI period overruns every other RTI,
    // UM p.236), and then repeats with that many periods' length.
    let mut marks: Vec<Controller> = Vec::with_capacity(RUN_DOWN_LAGS_MAX);
    // Marks not live are buffers kept for their allocations (`clone_from` reuses them).
    let mut live = 0usize;
    let mut newest = RUN_DOWN_LAGS_MAX - 1;
    let mut since_mark = 0u64;
    while ran < n {
        if card.tripped() || card.bootstrap {
            break;
        }
        card.servo_cycle(cfg);
        ran += 1;
        since_mark += 1;
        if since_mark < period {
            continue;
        }
        since_mark = 0;
        if n - ran < period {
            // Too few cycles left for a repetition found now to leap anything.
            continue;
        }
        // The card's shape compared in place (its four written-only fields set aside), so
        // that a period costs a copy only when it is kept as a mark. `marks` is a ring:
        // the newest at `newest`, `live` of them in use.
        let kept = RunDownOnly::take(card);
        let lags = (1..=live).find(|k| marks[(newest + RUN_DOWN_LAGS_MAX + 1 - k) % RUN_DOWN_LAGS_MAX] == *card);
        if lags.is_none() {
            newest = (newest + 1) % RUN_DOWN_LAGS_MAX;
            if newest == marks.len() {
                marks.push(card.clone());
            } else {
                marks[newest].clone_from(card);
            }
            live = (live + 1).min(RUN_DOWN_LAGS_MAX);
        }
        kept.put_back(card);
        let Some(lags) = lags.map(|k| k as u64) else { continue };
        live = 0;
        // Every cycle leapt begins with the counter at 1 or more (so the strobe is allowed in
        // each, as in the periods just compared, whose counter was higher still).
        let span = lags * period;
        let leap = (n - ran).min(u64::try_from(card.counter.max(0)).unwrap_or(0)) / span * span;
        if leap == 0 {
            continue;
        }
        let Ok(leap_i32) = i32::try_from(leap) else { continue };
        card.counter -= leap_i32;
        card.counter_min = card.counter_min.min(card.counter);
        card.servo_cycles = card.servo_cycles.wrapping_add(leap as u32) & cfg.servo_counter_mask;
        card.ghost.cycles_since_background =
            card.ghost.cycles_since_background.saturating_add(u32::try_from(leap).unwrap_or(u32::MAX));
        ran += leap;
    }
    ran
}

/// How many periods back [`run_without_background`] looks for the card's shape: a run-down
/// that repeats only every 2, 3 or 4 RTI periods is leapt too.
const RUN_DOWN_LAGS_MAX: usize = 4;

/// What a run-down only writes (see [`run_without_background`]): set aside so that cards are
/// compared without it, then put back.
struct RunDownOnly {
    counter: i32,
    counter_min: i32,
    servo_cycles: u32,
    cycles_since_background: u32,
}

impl RunDownOnly {
    fn take(card: &mut Controller) -> RunDownOnly {
        let kept = RunDownOnly {
            counter: card.counter,
            counter_min: card.counter_min,
            servo_cycles: card.servo_cycles,
            cycles_since_background: card.ghost.cycles_since_background,
        };
        card.counter = 0;
        card.counter_min = 0;
        card.servo_cycles = 0;
        card.ghost.cycles_since_background = 0;
        kept
    }

    fn put_back(self, card: &mut Controller) {
        card.counter = self.counter;
        card.counter_min = self.counter_min;
        card.servo_cycles = self.servo_cycles;
        card.ghost.cycles_since_background = self.cycles_since_background;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use pmacwd_specs::Spec;

    /// `n` servo cycles one by one, as the model runs them; how many ran before it froze.
    fn plain(card: &mut Controller, cfg: &ModelConfig, n: u64) -> u64 {
        let mut ran = 0;
        while ran < n && !card.tripped() && !card.bootstrap {
            card.servo_cycle(cfg);
            ran += 1;
        }
        ran
    }

    #[test]
    fn a_leapt_run_down_is_the_run_cycle_by_cycle() {
        let spec = Spec::embedded().unwrap();
        let mut compared = 0;
        for profile in spec.profiles.all() {
            for configuration in ["host-log", "i40-zero", "timing", "motion"] {
                let cfg = ModelConfig::from_spec(&spec, configuration, &profile).unwrap();
                for i8 in [0u8, 2, 5, 7] {
                    // PLC 0 just over one RTI period overruns every other RTI, and just over
                    // two every third: run-downs that repeat only every 2 and 3 periods.
                    let two_periods =
                        Load { plc0_units: overrun_load(&cfg, i8).plc0_units * 2 - 1, ..overrun_load(&cfg, i8) };
                    for load in [
                        light_load(),
                        overrun_load(&cfg, i8),
                        two_periods,
                        Load { motors: 1, plc0_units: 3, background_units: 2 },
                    ] {
                        for counter in [-3, 0, 1, 7, 50, 4095, 4096, 40_000] {
                            let mut start = Controller::power_on(&cfg);
                            start.i8 = i8;
                            start.apply(&cfg, &Event::Load(load));
                            // A few cycles with background first, then the counter set.
                            let mut sim = Sim::new(&cfg, start, false);
                            sim.greedy(3);
                            let mut start = sim.card;
                            start.counter = counter;
                            start.counter_min = start.counter_min.min(counter);
                            for n in [0u64, 1, 5, 6, 13, 100, 4095, 4200, 41_000] {
                                let (mut a, mut b) = (start.clone(), start.clone());
                                let ran_a = run_without_background(&mut a, &cfg, n);
                                let ran_b = plain(&mut b, &cfg, n);
                                assert_eq!(
                                    (ran_a, &a),
                                    (ran_b, &b),
                                    "{} {configuration} I8={i8} {load:?} counter {counter}, {n} cycles",
                                    profile.name
                                );
                                compared += 1;
                            }
                        }
                    }
                }
            }
        }
        assert!(compared > 1000, "{compared}");
    }

    /// `n` servo cycles, each followed by a background cycle where the load allows, one by one.
    fn plain_greedy(card: &mut Controller, cfg: &ModelConfig, n: u32) {
        for _ in 0..n {
            if card.tripped() || card.bootstrap {
                break;
            }
            card.servo_cycle(cfg);
            if card.background_possible() {
                card.background_cycle(cfg);
            }
        }
    }

    #[test]
    fn a_leapt_greedy_run_is_the_run_cycle_by_cycle() {
        let spec = Spec::embedded().unwrap();
        let mut compared = 0;
        for profile in spec.profiles.all() {
            for configuration in ["host-log", "i40-zero", "timing"] {
                let mut cfg = ModelConfig::from_spec(&spec, configuration, &profile).unwrap();
                for (firmware, user_program) in [(1u8, 1u8), (2, 2), (3, 1)] {
                    cfg.pass_cycles = pmacwd_specs::check::PassCycles { firmware, user_program };
                    for i8 in [0u8, 3, 7] {
                        for load in [
                            light_load(),
                            Load { motors: 1, plc0_units: 3, background_units: 2 },
                            Load { motors: 2, plc0_units: 0, background_units: 40 },
                        ] {
                            let mut start = Controller::power_on(&cfg);
                            start.i8 = i8;
                            start.apply(&cfg, &Event::Load(load));
                            for n in [1u32, 7, 64, 1000, 100_000] {
                                let mut sim = Sim::new(&cfg, start.clone(), false);
                                sim.greedy(n);
                                let mut b = start.clone();
                                plain_greedy(&mut b, &cfg, n);
                                assert_eq!(
                                    sim.card, b,
                                    "{} {configuration} passes {firmware}/{user_program} I8={i8} {load:?}, {n} cycles",
                                    profile.name
                                );
                                compared += 1;
                            }
                        }
                    }
                }
            }
        }
        assert!(compared > 500, "{compared}");
    }
}
