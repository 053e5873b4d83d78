//! The controller as a stateright [`Model`]: the environment's choices at every state, and
//! the run-and-report API `pmacwd check` uses.
//!
//! ## Time in the checked model
//!
//! With `single_servo_cycles: true` the checker may advance one servo cycle at a time, so every
//! counter value is visited. Without it (the realistic I40 = 0 configurations, counter near
//! 4096), time advances only to the next servo cycle at which something a rule can read
//! changes ([`signature`]: the trip, the counter's sign, whether a background cycle could
//! complete, the status words) and to the cycle just before it. Between two such points the
//! environment has nothing new to react to, so the behaviours are the same; each jump is still
//! simulated one plain servo cycle at a time. A jump is the event `Servo { cycles }` (traces
//! show it so) and is checked as that event always is: the cycle monitors on every cycle, the
//! event monitors on the whole event.

use crate::controller::{Controller, CycleReport};
use crate::monitor::{Check, MONITORS};
use crate::properties::{Expectation, StateProperty, STATE_PROPERTIES};
pub use crate::state::State;
use pmacwd_specs::check::ChecksumTarget;
use pmacwd_specs::config::ModelConfig;
use pmacwd_specs::vocab::event::{Event, Reply};
use pmacwd_specs::vocab::Observation;
use stateright::{Checker, Model, Property};
use std::time::{Duration, Instant};

#[derive(Clone, Debug, PartialEq, Eq, Hash)]
pub enum Action {
    Do(Event),
    /// A motion command whose deceleration, if it starts one, takes `decel` servo cycles.
    Decelerating(Event, u8),
    /// Servo cycles up to the first cycle whose [`signature`] differs.
    ServoToNextChange,
    /// Servo cycles up to the cycle just before that one.
    ServoToJustBeforeChange,
}

pub struct WatchdogModel {
    pub cfg: ModelConfig,
    /// A deliberately broken semantics for the canary test: see [`Canary`].
    pub canary: Option<Canary>,
    /// Give stateright every `always` property separately (see [`WatchdogModel::check`]).
    pub detailed: bool,
    /// Offer each motion command with the longest deceleration only, as a trace's deterministic
    /// run takes it (`Controller::apply`), instead of every length: the witnesses found are
    /// then paths that `pmacwd run` reproduces (`check --save`), at the price of the behaviours
    /// only a shorter deceleration shows.
    pub longest_decelerations_only: bool,
    /// Give stateright every property separately under its own name (the sentence `pmacwd
    /// check` prints) instead of a short id: what stateright's Explorer shows (`pmacwd
    /// explore`). Slower to check (a lookup by name per property per state), and not what
    /// [`WatchdogModel::check`] reads back, which goes by id.
    pub named_properties: bool,
}

/// Deliberate bugs that the checker must catch: the canary tests, and the hand mutations of
/// `conformance/tests/mutations.rs`, each of which breaks one rule of the manuals and names the
/// statements of the requirements matrix that rule encodes (docs/requirements.md).
///
/// Each is applied after the event's own rule has run ([`WatchdogModel::check_event`]), as a
/// change to the state it produced or to the reply it gave: the same state a model with that
/// rule written wrong would reach. The cycle monitors run inside a servo event, before the
/// mutation, so they do not see it; every other property and monitor does.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Canary {
    /// I41 lockout is ignored: locked writes take effect (SRM p.57).
    LockoutIgnored,
    /// A restored supply undoes an undervoltage trip, as if the trip were not latched (UM p.215).
    SupplyRestoreUntrips,
    /// A trip leaves the amplifiers that were enabled enabled (the Servo ICs not held in reset,
    /// UM p.215).
    TripLeavesAmplifiersOn,
    /// A trip leaves the red LED dark (UM p.215).
    TripLeavesLedDark,
    /// A trip leaves FEFCO/ off (UM p.215).
    TripLeavesFefcoOff,
    /// A trip leaves the Turbo PMAC2's relay where it was (UM p.215).
    TripLeavesRelay,
    /// A trip leaves the discrete and proportional outputs live (UM p.215).
    TripLeavesOutputsLive,
    /// A reset of a tripped card leaves the red LED lit (UM p.215).
    ResetLeavesLedLit,
    /// A tripped card acknowledges a command instead of staying silent (UM p.215).
    TrippedCardAnswers,
    /// A tripped card's servo interrupt goes on decrementing the watchdog counter (UM p.215:
    /// "The processor stops operating").
    TrippedCardCounts,
    /// A tripped card takes an I41 write (UM p.215: "The processor stops operating").
    TrippedCardTakesWrites,
    /// A supply below the minimum does not trip the card (UM p.215).
    UndervoltageIgnored,
    /// A strobe gap one cycle longer than the hardware delay does not trip the card yet (UM
    /// p.215: the timer trips once the strobe has been missing for longer than its delay).
    StrobeTimeoutIgnored,
    /// A background cycle reloads the counter one above the reset value (UM p.215, SRM p.57).
    BackgroundReloadsOneHigh,
    /// X:$25 no longer follows the counter down in a servo event (SRM p.57).
    X25NotTracked,
    /// The running checksum X:$1080 moves on after a checksum error (UM p.217).
    ChecksumRunsOnAfterError,
    /// A background cycle clears bit 22 (SRM p.289: it stays until reset or a clear).
    Bit22ClearedByBackground,
    /// A write to I41 is ignored while I41 is not 0 (SRM p.57: I41 is never locked).
    I41LocksItself,
    /// A locked I-variable write answers ERR003 (SRM p.57: "no error is generated").
    LockedWriteAnswersError,
    /// A memory write honours I41 (SRM p.57: I41 does not prevent it).
    MemoryWriteHonoursLock,
    /// `$$$***` keeps the active I41 (UM p.243, SRM p.57: its default is 0).
    ReinitializeKeepsI41,
    /// `#nK` leaves the motor's amplifier enabled (UM p.319, SRM p.281).
    KillLeavesAmplifierOn,
    /// <CTRL-K> leaves motor 2 closed-loop at rest when it was (UM p.319: "Kill All").
    KillAllSparesMotor2,
    /// The encoder-loss PLC's CMD^K kills only the motor whose encoder is lost (UM p.214-215:
    /// the listing kills every motor; the bug issue 35 fixed).
    EncoderLossKillsOnlyItsMotor,
    /// The encoder-loss PLC kills but does not latch the loss (UM p.214-215).
    EncoderLossNotLatched,
    /// `???` answers a first word with a 25th bit set, thirteen characters (SRM p.289).
    StatusReplyTooWide,
    /// A card in bootstrap mode answers `???` with status words (SRM p.289: `BOOTSTRAP PROM`).
    BootstrapAnswersStatus,
    /// A background cycle sets the DPRAM error bit (SRM p.289: a reset-time check).
    DpramErrorSetByBackground,
    /// A background cycle clears the flash error bit (SRM p.289: a reset-time check).
    FlashErrorClearedByBackground,
    /// `K` is accepted while its coordinate system executes a program (UM p.319).
    KAcceptedDuringProgram,
    /// <CTRL-O> leaves the program of C.S. 2 running (SRM p.260: every coordinate system).
    HoldAllSparesCs2,
    /// `&nA` acts as `&nQ`: the motors go on with their calculated moves (UM p.217: A begins
    /// immediately).
    AbortActsAsQuit,
    /// `CLOSE` leaves X:$1090 as it was (UM p.217: the checksum is stored at CLOSE).
    CloseKeepsOldReference,
    /// The firmware's amplifier-fault kill kills every motor, as the encoder-loss PLC's CMD^K
    /// does (UM p.213: the offending motor is killed).
    AmplifierFaultKillsAll,
    /// The housekeeping's amplifier-fault check does nothing (UM p.213, UM p.237).
    AmplifierFaultIgnored,
    /// `ENDGATHER` leaves data gathering on (SRM p.289, p.307: bit 19 is 0 once gathering
    /// stops at ENDGATHER).
    EndGatherKeepsGathering,
    /// A strobe gap longer than the hardware delay never trips the card (UM p.215: the
    /// watchdog's fail-safe shutdown; UM p.236: a starved background trips it). Applied to
    /// each servo cycle.
    StarvationNeverTrips,
    /// The background gets the time the servo update leaves before the RTI tasks (UM p.236:
    /// the RTI tasks have the higher priority, the background gets the time remaining). Applied
    /// to each servo cycle.
    BackgroundAheadOfRti,
    /// A servo cycle that decrements the counter takes 2 off it (SRM p.57: by 1). Applied to
    /// each servo cycle, so the cycle monitors see it.
    CounterDropsByTwo,
    /// An RTI that finds the previous task set still running starts PLC 0 again (UM p.236: only
    /// when the previous tasks have completed). Applied to each servo cycle.
    PlcRestartsOnOverrun,
    /// Under the intended reading the encoder-loss PLC never clears a latched loss (UM p.215).
    EncoderLossNeverClears,
    /// A checksum pass never finds a mismatch: it starts over instead (UM p.217: the checksum
    /// is compared with its reference).
    ChecksumNeverMismatches,
    /// A checksum error shuts the card down (UM p.217: it takes no other action; a
    /// user-program error does not shut the card down).
    ChecksumErrorShutsDown,
    /// A write to an I-variable no bit of I41 locks is ignored while I41 is not 0 (SRM p.57:
    /// each bit controls its own set).
    UnlockedWriteIgnored,
    /// The counter steps from 0 to -1 under the at-zero reading (UM p.215: "as long as the
    /// counter is greater than zero").
    CounterGoesBelowZero,
    /// After a checksum error the engine moves on to the other area (UM p.217: it stops both).
    ChecksumSwitchesAreaAfterError,
    /// `CHECKSUM` answers the reference plus one (UM p.217, SRM p.295).
    ChecksumCommandOffByOne,
    /// Bit 9 is cleared after every servo event, so it is never seen set (SRM p.290).
    Bit9NeverSet,
    /// Bit 22 is cleared after every servo event, so it is never seen set (SRM p.289).
    Bit22NeverSet,
    /// The checksum engine never starts a user-program pass (UM p.217: it alternates).
    ChecksumStaysOnFirmware,
}

/// The most states one run generates (every successor of every state explored, seen before or
/// not: stateright's `target_state_count` counts these, so the distinct states of a cut run are
/// fewer). The configurations of `check.yaml` take at most about 750,000 distinct states; a
/// configuration whose state space is larger than this (a large I40 or hardware delay with
/// single servo cycles, say) would take minutes to hours and gigabytes, so the checker stops
/// here and the run is reported as incomplete instead of silently growing.
pub const STATES_MAX: usize = 10_000_000;

/// Whether `checker`, run with `target_state_count(states_max)`, explored every reachable state
/// rather than stopping at the bound. Stateright stops once the states it has generated (not
/// the distinct ones) reach the bound, so this compares those: comparing the distinct states
/// reported a run cut at 1.4 million distinct states of 10 million generated as complete, and
/// its `sometimes` properties as NEVER reached (`i40: 65535` in `timing`).
pub fn explored_all<M: Model, C: Checker<M>>(checker: &C, states_max: usize) -> bool {
    checker.state_count() < states_max
}

/// How far a running exploration has come: what a progress display shows.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Explored {
    /// Distinct states found so far.
    pub states: usize,
    /// The deepest of them, in actions from power-up.
    pub depth: usize,
}

/// The time between two reports of [`join_observed`].
pub const PROGRESS_INTERVAL: Duration = Duration::from_millis(100);

/// Waits for a spawned `checker` to finish, telling `progress` how far it has come every
/// [`PROGRESS_INTERVAL`] while it runs. The checker's threads are joined on a thread of their
/// own, which wakes this one the moment they are done: the run ends when it would with a plain
/// `join` (no polling delay), and the states are counted only once per interval.
pub fn join_observed<M: Model, C: Checker<M>>(mut checker: C, progress: &mut dyn FnMut(Explored)) -> C {
    let handles = checker.handles();
    let (done, finished) = std::sync::mpsc::channel::<()>();
    std::thread::scope(|s| {
        s.spawn(move || {
            for h in handles {
                h.join().expect("a checker thread panicked");
            }
            drop(done);
        });
        while let Err(std::sync::mpsc::RecvTimeoutError::Timeout) = finished.recv_timeout(PROGRESS_INTERVAL) {
            progress(Explored { states: checker.unique_state_count(), depth: checker.max_depth() });
        }
    });
    checker
}

/// Longest jump, in servo cycles, before the checker gives up looking for a change.
const JUMP_CYCLES_MAX: u32 = 1 << 20;

/// The servo cycles of a time jump, simulated ([`WatchdogModel::leap`]) but not yet checked
/// as an event.
#[derive(Clone, Debug)]
pub struct Leap {
    /// The cycle whose signature differs first (or [`JUMP_CYCLES_MAX`] when none did).
    pub cycles: u32,
    /// Whether a cycle's signature differed.
    pub changed: bool,
    /// The state after `cycles` cycles, with the cycle monitors' violations.
    pub after: State,
    /// The state after `cycles - 1` cycles, with the cycle monitors' violations.
    pub before: State,
}

/// What the environment can react to; time advances between changes of this.
pub fn signature(cfg: &ModelConfig, c: &Controller) -> Signature {
    Signature {
        trip: c.trip,
        counter_positive: c.counter > 0,
        counter_not_negative: c.counter >= 0,
        background_possible: c.background_possible(),
        status_words: c.status_words(cfg),
        motion: c.axes.motion_signature(),
    }
}

/// A card's [`signature`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Signature {
    trip: Option<crate::controller::TripCause>,
    counter_positive: bool,
    counter_not_negative: bool,
    background_possible: bool,
    status_words: (u32, u32),
    motion: (u128, u64),
}

impl Signature {
    /// Whether `c`'s signature is this one, `of`'s, where `of` is the card this one was taken
    /// of: `signature(cfg, c) == *self`, without building the status words when `c`'s inputs
    /// to them are `of`'s (`Controller::status_inputs`), as they are on nearly every servo
    /// cycle of a time jump (which asks this on every cycle).
    fn is_of(&self, cfg: &ModelConfig, of: &Controller, c: &Controller) -> bool {
        // Destructured without `..`: a part added to the signature is a compile error here
        // until it is compared.
        let Signature { trip, counter_positive, counter_not_negative, background_possible, status_words, motion } =
            self;
        c.trip == *trip
            && (c.counter > 0) == *counter_positive
            && (c.counter >= 0) == *counter_not_negative
            && c.background_possible() == *background_possible
            && (c.status_inputs() == of.status_inputs() || c.status_words(cfg) == *status_words)
            && c.axes.motion_signature() == *motion
    }
}

impl WatchdogModel {
    pub fn new(cfg: ModelConfig) -> Self {
        WatchdogModel { cfg, canary: None, detailed: false, longest_decelerations_only: false, named_properties: false }
    }

    /// Advances servo cycle by servo cycle up to the first cycle whose [`signature`] differs,
    /// or the cycle before it; returns the cycles taken and the state. Gives up after
    /// [`JUMP_CYCLES_MAX`] cycles.
    ///
    /// The leap is the event `Servo { cycles }` (a trace shows it so) and is checked as
    /// [`Self::step`] checks that event: the cycle monitors on every cycle, the event monitors
    /// on the whole event. The cycles are simulated by [`Self::leap`], which both leaps of a
    /// state share ([`Model::for_each_next_state`]).
    pub fn advance_to_change(&self, state: &State, just_before: bool) -> (u32, State) {
        self.end_leap(state, &self.leap(state), just_before)
    }

    /// The servo cycles of a time jump from `state`, simulated once for both of its ends: up to
    /// the first cycle whose [`signature`] differs from `state`'s (or [`JUMP_CYCLES_MAX`]
    /// cycles), with the cycle monitors run on every cycle and the event monitors not yet.
    ///
    /// A leap at I40 = 0 runs up to about 4,100 cycles, so the state is cloned once per leap
    /// and each cycle runs on it in place; the cycle monitors read the cycle's starting point
    /// from a second controller, overwritten each cycle (a copy into the same buffer, which
    /// allocates only for I-variables other than I8, I40 and I41 written since reset: no
    /// configuration that leaps writes any).
    pub fn leap(&self, state: &State) -> Leap {
        let cfg = &self.cfg;
        let start = signature(cfg, &state.controller);
        let mut after = state.clone();
        let mut before = state.controller.clone();
        let mut violations_before = state.violations;
        for n in 1..=JUMP_CYCLES_MAX {
            let mut report = after.controller.servo_cycle(cfg);
            if let Some(canary) = self.canary {
                mutate_cycle(cfg, canary, &before, &mut report, &mut after.controller);
            }
            after.violations |= cycle_violations(cfg, &before, report, &after.controller);
            if !start.is_of(cfg, &state.controller, &after.controller) {
                return Leap {
                    cycles: n,
                    changed: true,
                    after,
                    before: State { controller: before, violations: violations_before },
                };
            }
            before.clone_from(&after.controller);
            violations_before = after.violations;
        }
        Leap {
            cycles: JUMP_CYCLES_MAX,
            changed: false,
            after,
            before: State { controller: before, violations: violations_before },
        }
    }

    /// One end of `leap` (from `state`): the cycles up to the change, or up to just before it,
    /// and the state there, with the event monitors run on the whole event. A leap that found
    /// no change ends after [`JUMP_CYCLES_MAX`] cycles either way.
    pub fn end_leap(&self, state: &State, leap: &Leap, just_before: bool) -> (u32, State) {
        let (cycles, mut next) = if just_before && leap.changed {
            (leap.cycles - 1, leap.before.clone())
        } else {
            (leap.cycles, leap.after.clone())
        };
        // No cycle at all (the change was one cycle away): the state itself, nothing happened.
        if cycles > 0 {
            self.check_event(&state.controller, &mut next, &Event::Servo { cycles }, Reply::None);
        }
        (cycles, next)
    }

    /// The concrete event an action stands for in `state`, and the state after it.
    pub fn perform(&self, state: &State, action: &Action) -> (Event, Reply, State) {
        match action {
            Action::Do(e) => {
                let (reply, next) = self.step(state, e);
                (e.clone(), reply, next)
            }
            Action::Decelerating(e, decel) => {
                let (reply, next) = self.step_with_decel(state, e, *decel);
                (e.clone(), reply, next)
            }
            Action::ServoToNextChange | Action::ServoToJustBeforeChange => {
                let (cycles, next) = self.advance_to_change(state, *action == Action::ServoToJustBeforeChange);
                (Event::Servo { cycles }, Reply::None, next)
            }
        }
    }

    /// Applies `event` to `state`, running every monitor; returns the reply and next state.
    pub fn step(&self, state: &State, event: &Event) -> (Reply, State) {
        self.step_with_decel(state, event, self.cfg.motion.decel_cycles_max)
    }

    /// [`Self::step`], with any deceleration a stop command starts taking `decel` cycles.
    pub fn step_with_decel(&self, state: &State, event: &Event, decel: u8) -> (Reply, State) {
        let mut next = state.clone();
        let reply = self.apply_in_place(&state.controller, &mut next, event, decel);
        (reply, next)
    }

    /// Takes `next`, equal to `state`, to the state after `action`: what [`Self::perform`]
    /// returns, without building the event.
    fn take_action(&self, state: &State, next: &mut State, action: &Action) {
        let (event, decel) = match action {
            Action::Do(e) => (e, self.cfg.motion.decel_cycles_max),
            Action::Decelerating(e, decel) => (e, *decel),
            Action::ServoToNextChange | Action::ServoToJustBeforeChange => {
                *next = self.advance_to_change(state, *action == Action::ServoToJustBeforeChange).1;
                return;
            }
        };
        self.apply_in_place(&state.controller, next, event, decel);
    }

    /// Applies `event` to `next`, which the caller made equal to `prev` (with the violations
    /// so far), running every monitor; returns the reply. In place, so that the checker moves
    /// no state around per event.
    fn apply_in_place(&self, prev: &Controller, next: &mut State, event: &Event, decel: u8) -> Reply {
        let cfg = &self.cfg;
        let reply = match event {
            Event::Servo { cycles } => {
                // The first cycle starts from `prev`; a later one (a multi-cycle event, which
                // only replays use) from a copy of the state after the cycle before it.
                let mut later: Option<Controller> = None;
                for k in 0..*cycles {
                    if k > 0 {
                        later = Some(next.controller.clone());
                    }
                    let before = later.as_ref().unwrap_or(prev);
                    let mut report = next.controller.servo_cycle(cfg);
                    if let Some(canary) = self.canary {
                        mutate_cycle(cfg, canary, before, &mut report, &mut next.controller);
                    }
                    next.violations |= cycle_violations(cfg, before, report, &next.controller);
                }
                Reply::None
            }
            _ => next.controller.apply_with_decel(cfg, event, decel),
        };
        self.check_event(prev, next, event, reply)
    }

    /// After `event` took `prev` to `next`: the canary's deliberate bug, then the event
    /// monitors. Returns the reply, which a canary may change.
    fn check_event(&self, prev: &Controller, next: &mut State, event: &Event, reply: Reply) -> Reply {
        let cfg = &self.cfg;
        let mut reply = reply;
        if let Some(canary) = self.canary {
            mutate(cfg, canary, prev, &mut next.controller, event, &mut reply);
        }
        match (self.canary, event) {
            (Some(Canary::LockoutIgnored), Event::Command(pmacwd_specs::vocab::command::HostCommand::WriteI(n, v)))
                if !prev.tripped() && !prev.bootstrap =>
            {
                if let Some(bit) = cfg.lockout_bit(*n) {
                    if prev.i41 & (1 << bit) != 0 {
                        next.controller.other_i_variables.insert(*n, *v);
                    }
                }
            }
            (Some(Canary::SupplyRestoreUntrips), Event::Supply { millivolts })
                if *millivolts >= cfg.supply_min_millivolts
                    && next.controller.trip == Some(crate::controller::TripCause::Undervoltage) =>
            {
                next.controller.trip = None;
            }
            (Some(Canary::TripLeavesAmplifiersOn), _) if !prev.tripped() && next.controller.tripped() => {
                for (n, p) in next.controller.axes.motors_mut().iter_mut().zip(prev.axes.motors()) {
                    n.amplifier_enabled = p.amplifier_enabled;
                }
            }
            _ => {}
        }
        next.violations |= event_violations(cfg, prev, event, reply, &next.controller);
        reply
    }
}

/// The mutations of [`Canary`] that act within one servo cycle, before the cycle monitors
/// judge it: `after` and `report` as the cycle made them, changed as a broken rule would have.
fn mutate_cycle(
    cfg: &ModelConfig,
    canary: Canary,
    before: &Controller,
    report: &mut CycleReport,
    after: &mut Controller,
) {
    match canary {
        Canary::CounterDropsByTwo if after.counter > 0 && after.counter < before.counter => after.counter -= 1,
        // UM p.215 and UM p.236 broken: a strobe gap past the hardware delay leaves the card
        // running, as if the watchdog were not there (the cycle's trip undone, its outputs and
        // motors as before it; the gap held at the delay and the ghost's count of cycles
        // without a background cycle as it was, so the state space stays finite).
        Canary::StarvationNeverTrips
            if after.trip == Some(crate::controller::TripCause::StrobeTimeout) && !before.tripped() =>
        {
            after.trip = None;
            after.outputs = before.outputs;
            after.axes = before.axes;
            after.ghost = before.ghost;
            after.cycles_since_strobe = cfg.hardware_delay_cycles;
        }
        // UM p.236's priorities broken: the background is given the whole of what the servo
        // update leaves, whatever the RTI tasks still need (the credit is capped as the
        // model's, so the state space stays finite).
        Canary::BackgroundAheadOfRti if !after.tripped() && !after.bootstrap && !before.tripped() => {
            let servo = u32::from(after.load.motors) * u32::from(cfg.cpu.servo_units_per_motor);
            let free = u32::from(cfg.cpu.cycle_units).saturating_sub(servo);
            after.background_credit = (before.background_credit + free).min(u32::from(after.load.background_units));
        }
        Canary::PlcRestartsOnOverrun if report.rti_overrun => {
            report.rti_started = true;
            let planning = if after.axes.plans_moves() { u32::from(cfg.cpu.move_planning_units) } else { 0 };
            after.rti_remaining = u32::from(after.load.plc0_units) + planning;
        }
        _ => {}
    }
}

/// The hand mutations of [`Canary`] beyond the first three (which [`WatchdogModel::check_event`]
/// applies itself): `next` and `reply` as the event's rule made them, changed as a model with
/// that rule broken would have made them.
fn mutate(
    cfg: &ModelConfig,
    canary: Canary,
    prev: &Controller,
    next: &mut Controller,
    event: &Event,
    reply: &mut Reply,
) {
    use pmacwd_specs::vocab::command::{CsCommand, GlobalCommand, HostCommand, Motion, MotorCommand};
    let tripped_now = !prev.tripped() && next.tripped();
    let locked = |n: u16| cfg.lockout_bit(n).is_some_and(|bit| prev.i41 & (1 << bit) != 0);
    match (canary, event) {
        (Canary::TripLeavesLedDark, _) if tripped_now => next.outputs.led_red = false,
        (Canary::TripLeavesFefcoOff, _) if tripped_now => next.outputs.fefco_on = false,
        (Canary::TripLeavesRelay, _) if tripped_now => next.outputs.relay_tripped = false,
        (Canary::TripLeavesOutputsLive, _) if tripped_now => next.outputs.forced_off = false,
        (Canary::ResetLeavesLedLit, Event::Reset(_)) if prev.tripped() => next.outputs.led_red = true,
        (Canary::TrippedCardAnswers, Event::Command(_)) if prev.tripped() => *reply = Reply::Ack,
        (Canary::TrippedCardCounts, Event::Servo { .. }) if prev.tripped() && next.counter > 0 => next.counter -= 1,
        (Canary::TrippedCardTakesWrites, Event::Command(HostCommand::WriteI(41, v))) if prev.tripped() => {
            next.i41 = (*v & 0xF) as u8;
        }
        (Canary::UndervoltageIgnored, Event::Supply { .. })
            if tripped_now && next.trip == Some(crate::controller::TripCause::Undervoltage) =>
        {
            next.trip = None;
            next.outputs = prev.outputs;
        }
        // Off by one: the first cycle past the hardware delay does not trip (the next does, so
        // the state space stays finite).
        (Canary::StrobeTimeoutIgnored, Event::Servo { .. })
            if tripped_now
                && next.trip == Some(crate::controller::TripCause::StrobeTimeout)
                && next.cycles_since_strobe == cfg.hardware_delay_cycles + 1 =>
        {
            next.trip = None;
            next.outputs = prev.outputs;
        }
        (Canary::BackgroundReloadsOneHigh, Event::Background) if next.ghost.cycles_since_background == 0 => {
            next.counter += 1;
            next.ghost.last_reload = next.counter;
        }
        (Canary::X25NotTracked, Event::Servo { .. }) => next.counter_min = prev.counter_min,
        (Canary::ChecksumRunsOnAfterError, Event::Background) if prev.checksum.error.is_some() => {
            // Flips between two values, so that the state space stays as small as the model's.
            next.checksum.position ^= 1;
        }
        (Canary::Bit22ClearedByBackground, Event::Background) => next.status.rti_reentry = false,
        (Canary::I41LocksItself, Event::Command(HostCommand::WriteI(41, _))) if prev.i41 != 0 => next.i41 = prev.i41,
        (Canary::LockedWriteAnswersError, Event::Command(HostCommand::WriteI(n, _)))
            if !prev.tripped() && !prev.bootstrap && *n != 41 && locked(*n) =>
        {
            *reply = Reply::Error(3);
        }
        (Canary::MemoryWriteHonoursLock, Event::Command(HostCommand::WriteIMemory(n, _)))
            if !prev.tripped() && *n != 41 && locked(*n) =>
        {
            next.other_i_variables.clone_from(&prev.other_i_variables);
        }
        (Canary::ReinitializeKeepsI41, Event::Command(HostCommand::Reinitialize)) if !prev.tripped() => {
            next.i41 = prev.i41;
        }
        (Canary::KillLeavesAmplifierOn, Event::Command(HostCommand::Motion(Motion::Motor(m, MotorCommand::Kill)))) => {
            let k = usize::from(*m).wrapping_sub(1);
            if let (Some(p), Some(n)) = (prev.axes.motors().get(k), next.axes.motors_mut().get_mut(k)) {
                if p.amplifier_enabled {
                    n.amplifier_enabled = true;
                }
            }
        }
        (Canary::KillAllSparesMotor2, Event::Command(HostCommand::Motion(Motion::Global(GlobalCommand::KillAll)))) => {
            // Only a motor at rest, closed-loop: a moving one left as it was runs on into states
            // no rule of the model bounds.
            if let (Some(p), Some(n)) = (prev.axes.motors().get(1), next.axes.motors_mut().get_mut(1)) {
                if p.state == pmacwd_specs::vocab::MotorState::Closed {
                    *n = *p;
                }
            }
        }
        (Canary::EncoderLossKillsOnlyItsMotor, Event::Background) => {
            for (p, n) in prev.axes.motors().iter().zip(next.axes.motors_mut()) {
                if !p.encoder_lost {
                    *n = *p;
                }
            }
        }
        (Canary::ChecksumNeverMismatches, Event::Background)
            if prev.checksum.error.is_none() && next.checksum.error.is_some() =>
        {
            next.checksum.error = None;
            next.checksum.position = 0;
        }
        (Canary::ChecksumErrorShutsDown, Event::Background)
            if prev.checksum.error.is_none() && next.checksum.error.is_some() =>
        {
            next.trip_now(crate::controller::TripCause::StrobeTimeout);
        }
        (Canary::EncoderLossNeverClears, Event::Background) => {
            for (p, n) in prev.axes.motors().iter().zip(next.axes.motors_mut()) {
                n.loss_status |= p.loss_status;
            }
        }
        (Canary::EncoderLossNotLatched, Event::Background) => {
            for (p, n) in prev.axes.motors().iter().zip(next.axes.motors_mut()) {
                n.loss_status = p.loss_status;
            }
        }
        (Canary::StatusReplyTooWide, Event::Command(HostCommand::GlobalStatus)) => {
            if let Reply::Status { x, y } = *reply {
                *reply = Reply::Status { x: x | (1 << 24), y };
            }
        }
        (Canary::BootstrapAnswersStatus, Event::Command(HostCommand::GlobalStatus)) if *reply == Reply::Bootstrap => {
            *reply = Reply::Status { x: 0, y: 0 };
        }
        (Canary::DpramErrorSetByBackground, Event::Background) => next.status.dpram_error = true,
        (Canary::FlashErrorClearedByBackground, Event::Background) => next.status.flash_error = false,
        (Canary::KAcceptedDuringProgram, Event::Command(HostCommand::Motion(Motion::Motor(_, MotorCommand::Kill))))
            if matches!(reply, Reply::Error(_)) =>
        {
            *reply = Reply::Ack;
        }
        (Canary::HoldAllSparesCs2, Event::Command(HostCommand::Motion(Motion::Global(GlobalCommand::HoldAll)))) => {
            if let (Some(p), Some(n)) = (prev.axes.programs().get(1), next.axes.programs_mut().get_mut(1)) {
                *n = *p;
            }
            for (k, (p, n)) in prev.axes.motors().iter().zip(next.axes.motors_mut()).enumerate() {
                if cfg.motion.coordinate_system(k as u8 + 1) == 2 {
                    *n = *p;
                }
            }
        }
        // A acts as Q: the motors go on with their calculated moves (a state the model reaches
        // by Q, so the state space stays the model's own).
        (
            Canary::AbortActsAsQuit,
            Event::Command(HostCommand::Motion(Motion::CoordinateSystem(cs, CsCommand::Abort))),
        ) => {
            let mut quit = prev.clone();
            *reply =
                quit.apply(cfg, &Event::Command(HostCommand::Motion(Motion::CoordinateSystem(*cs, CsCommand::Quit))));
            *next = quit;
        }
        (Canary::CloseKeepsOldReference, Event::Command(HostCommand::Close)) => {
            next.checksum.program_reference = prev.checksum.program_reference;
        }
        (Canary::UnlockedWriteIgnored, Event::Command(HostCommand::WriteI(n, _)))
            if prev.i41 != 0 && *n != 41 && !locked(*n) =>
        {
            next.clone_from(prev);
        }
        (Canary::CounterGoesBelowZero, Event::Servo { .. })
            if cfg.profile.choices.strobe_stop == pmacwd_specs::profiles::StrobeStop::AtZero
                && next.counter == 0
                && !next.tripped() =>
        {
            next.counter = -1;
        }
        (Canary::ChecksumSwitchesAreaAfterError, Event::Background) if prev.checksum.error.is_some() => {
            next.checksum.area = prev.checksum.area.other();
        }
        (Canary::ChecksumCommandOffByOne, Event::Command(HostCommand::Checksum)) => {
            if let Reply::Hex(v) = *reply {
                *reply = Reply::Hex(v + 1);
            }
        }
        (Canary::AmplifierFaultKillsAll, Event::Background)
            if prev.axes.motors().iter().zip(next.axes.motors()).any(|(p, n)| !p.fault_status && n.fault_status) =>
        {
            next.axes.force_off();
        }
        (Canary::AmplifierFaultIgnored, Event::Background)
            if prev.axes.motors().iter().zip(next.axes.motors()).any(|(p, n)| !p.fault_status && n.fault_status) =>
        {
            next.axes = prev.axes;
        }
        (Canary::EndGatherKeepsGathering, Event::Command(HostCommand::EndGather)) => {
            next.status.data_gathering_on = prev.status.data_gathering_on;
        }
        (Canary::Bit9NeverSet, Event::Servo { .. }) => next.status.rti_warning = false,
        (Canary::Bit22NeverSet, Event::Servo { .. }) => next.status.rti_reentry = false,
        (Canary::ChecksumStaysOnFirmware, Event::Background)
            if next.checksum.area == pmacwd_specs::check::ChecksumTarget::UserProgram
                && prev.checksum.area == pmacwd_specs::check::ChecksumTarget::Firmware =>
        {
            next.checksum.area = pmacwd_specs::check::ChecksumTarget::Firmware;
        }
        _ => {}
    }
}

// ---------------------------------------------------------------------- monitor dispatch
//
// The monitors run on every transition the checker generates (about eight per state), so their
// calling cost counts: a loop over `MONITORS`, calling each closure through a fn pointer the
// compiler cannot see through, was 40% of the checker's instructions on `timing` (callgrind).
// Below, each monitor index gets its own call with the index as a constant, so the compiler
// knows which closure runs and can inline it. Same monitors, same order, same bits.

/// Monitor K's violation bit on `event` (0 when it holds, or monitor K is a cycle monitor or
/// beyond the table).
#[inline(always)]
fn event_bit<const K: usize>(
    cfg: &ModelConfig,
    prev: &Controller,
    event: &Event,
    reply: Reply,
    next: &Controller,
) -> u64 {
    match MONITORS.get(K) {
        Some(crate::monitor::Monitor { check: Check::Event(f), .. }) if !f(cfg, prev, event, reply, next) => 1 << K,
        _ => 0,
    }
}

/// Monitor K's violation bit on one servo cycle, as [`event_bit`] for the cycle monitors.
#[inline(always)]
fn cycle_bit<const K: usize>(cfg: &ModelConfig, before: &Controller, report: CycleReport, after: &Controller) -> u64 {
    match MONITORS.get(K) {
        Some(crate::monitor::Monitor { check: Check::Cycle(f), .. }) if !f(cfg, before, report, after) => 1 << K,
        _ => 0,
    }
}

/// `f::<K> args` for every K of 0..64, joined by `op` (`|` for bits, `&&` for verdicts).
macro_rules! each_index {
    ($op:tt $f:ident $args:tt) => {
        each_index!(@ $op $f $args; 0 1 2 3 4 5 6 7 8 9 10 11 12 13 14 15 16 17 18 19 20 21 22 23 24 25 26 27 28 29
            30 31 32 33 34 35 36 37 38 39 40 41 42 43 44 45 46 47 48 49 50 51 52 53 54 55 56 57 58 59 60 61 62 63)
    };
    (@ | $f:ident $args:tt; $($k:literal)*) => {
        $($f::<$k> $args)|*
    };
    (@ && $f:ident $args:tt; $($k:literal)*) => {
        $($f::<$k> $args)&&*
    };
}

/// The violation bits of every event monitor on one event: the reference, each monitor run
/// ([`event_violations`] runs only those that can fail, and is tested against this).
#[cfg(test)]
fn event_violations_plain(cfg: &ModelConfig, prev: &Controller, event: &Event, reply: Reply, next: &Controller) -> u64 {
    each_index!(| event_bit(cfg, prev, event, reply, next))
}

/// The violation bits of every cycle monitor on one servo cycle: the reference, as
/// [`event_violations_plain`].
#[cfg(test)]
fn cycle_violations_plain(cfg: &ModelConfig, before: &Controller, report: CycleReport, after: &Controller) -> u64 {
    each_index!(| cycle_bit(cfg, before, report, after))
}

/// The monitors that hold on every transition that leaves the motors and the programs as they
/// were (`Axes` equal before and after): each one is about how a motor or a program changes,
/// and reads nothing else where they do not change (a killed motor that stays killed, a status
/// bit that stays as it was, a stop that did not end). The checker runs them only where the
/// axes changed; `monitors_holding_while_the_axes_stay_hold_there` checks the claim on every
/// transition of the bounded configurations, with the axes put back as they were.
///
/// Only the monitors that loop over the motors on every transition are here: the others that
/// would qualify look at one kind of event first, which costs less than the comparison.
const HOLD_WHILE_THE_AXES_STAY: [&str; 6] = [
    "a killed motor does not move until it is re-enabled",
    "the amplifier-fault status is set only by the fault kill and cleared only when the motor is re-enabled or the card reset",
    "the encoder-loss status is latched only by the PLC's scan in a background cycle",
    "under the literal reading a latched encoder loss stays latched until a reset",
    "Q and / stop at a program point",
    "H stops on the path: its motors end holding, and R can resume the program",
];

/// Whether two strings are equal, where a `const` needs it.
const fn same_text(a: &str, b: &str) -> bool {
    let (a, b) = (a.as_bytes(), b.as_bytes());
    if a.len() != b.len() {
        return false;
    }
    let mut i = 0;
    while i < a.len() {
        if a[i] != b[i] {
            return false;
        }
        i += 1;
    }
    true
}

/// Bit k set: monitor k of [`MONITORS`] is named in `names`. A name that is no monitor's does
/// not compile.
const fn monitor_mask(names: &[&str]) -> u64 {
    let mut mask = 0;
    let mut n = 0;
    while n < names.len() {
        let mut found = false;
        let mut k = 0;
        while k < MONITORS.len() {
            if same_text(MONITORS[k].name, names[n]) {
                mask |= 1 << k;
                found = true;
            }
            k += 1;
        }
        assert!(found, "HOLD_WHILE_THE_AXES_STAY names a monitor that does not exist");
        n += 1;
    }
    mask
}

/// [`HOLD_WHILE_THE_AXES_STAY`] as bits of monitor indices.
const AXES_MONITORS: u64 = monitor_mask(&HOLD_WHILE_THE_AXES_STAY);

/// Whether two cards' axes are equal (`==`), compared as their bytes: one `memcmp` where the
/// derived comparison goes field by field and motor by motor (about 360 instructions a
/// transition on `timing`, more than the monitors it spares; callgrind).
fn axes_stayed(before: &crate::motion::Axes, after: &crate::motion::Axes) -> bool {
    axes_bytes(before) == axes_bytes(after)
}

/// The bytes of `axes`.
fn axes_bytes(axes: &crate::motion::Axes) -> &[u8] {
    // SAFETY: every field of `Axes`, and of each `Motor` and `Program` in it, is one byte wide
    // (booleans, `u8`, field-less enums and an `Option` of one; the assertions below), so
    // `Axes` has alignment 1 and no padding: each of its bytes is initialized. Each of those
    // types has one byte per value, so equal bytes are equal axes and unequal bytes unequal
    // axes (`monitors_holding_while_the_axes_stay_hold_there` compares it with `==`).
    unsafe {
        std::slice::from_raw_parts(
            (axes as *const crate::motion::Axes).cast::<u8>(),
            std::mem::size_of::<crate::motion::Axes>(),
        )
    }
}

// No padding in `Axes`: nine one-byte fields a motor, a byte a program, three bytes more.
const _: () = {
    use crate::motion::{Axes, Motor, Program};
    use std::mem::{align_of, size_of};
    assert!(size_of::<Motor>() == 9 && align_of::<Motor>() == 1);
    assert!(size_of::<Program>() == 1);
    assert!(
        size_of::<Axes>()
            == 9 * pmacwd_specs::vocab::observation::MOTORS_SHOWN
                + pmacwd_specs::vocab::command::COORDINATE_SYSTEM_MAX as usize
                + 3
    );
    assert!(align_of::<Axes>() == 1);
};

/// [`event_bit`], or 0 without running the monitor when it is one of
/// [`HOLD_WHILE_THE_AXES_STAY`] and the axes stayed.
#[inline(always)]
fn event_bit_where_it_can_fail<const K: usize>(
    cfg: &ModelConfig,
    prev: &Controller,
    event: &Event,
    reply: Reply,
    next: &Controller,
    axes_stayed: bool,
) -> u64 {
    if AXES_MONITORS & (1 << K) != 0 && axes_stayed {
        0
    } else {
        event_bit::<K>(cfg, prev, event, reply, next)
    }
}

/// [`cycle_bit`], as [`event_bit_where_it_can_fail`].
#[inline(always)]
fn cycle_bit_where_it_can_fail<const K: usize>(
    cfg: &ModelConfig,
    before: &Controller,
    report: CycleReport,
    after: &Controller,
    axes_stayed: bool,
) -> u64 {
    if AXES_MONITORS & (1 << K) != 0 && axes_stayed {
        0
    } else {
        cycle_bit::<K>(cfg, before, report, after)
    }
}

/// The violation bits of every event monitor on one event: [`event_violations_plain`]'s, with
/// the monitors that cannot fail on it skipped ([`HOLD_WHILE_THE_AXES_STAY`]).
fn event_violations(cfg: &ModelConfig, prev: &Controller, event: &Event, reply: Reply, next: &Controller) -> u64 {
    let axes_stayed = axes_stayed(&prev.axes, &next.axes);
    each_index!(| event_bit_where_it_can_fail(cfg, prev, event, reply, next, axes_stayed))
}

/// The violation bits of every cycle monitor on one servo cycle: [`cycle_violations_plain`]'s,
/// as [`event_violations`].
fn cycle_violations(cfg: &ModelConfig, before: &Controller, report: CycleReport, after: &Controller) -> u64 {
    let axes_stayed = axes_stayed(&before.axes, &after.axes);
    each_index!(| cycle_bit_where_it_can_fail(cfg, before, report, after, axes_stayed))
}

/// State property K's verdict when it is an `always` property (true otherwise, or beyond the
/// table), for [`every_always_holds`].
#[inline(always)]
fn always_holds<const K: usize>(cfg: &ModelConfig, s: &State) -> bool {
    match STATE_PROPERTIES.get(K) {
        Some(p) if p.expectation == Expectation::Always => (p.holds)(cfg, s),
        _ => true,
    }
}

/// Whether every `always` state property holds in `s`: the conjunction stateright checks in
/// every state (see [`WatchdogModel::properties`]), one inlined call per property as the
/// monitors above.
fn every_always_holds(cfg: &ModelConfig, s: &State) -> bool {
    each_index!(&&always_holds(cfg, s))
}

impl Model for WatchdogModel {
    type State = State;
    type Action = Action;

    fn init_states(&self) -> Vec<State> {
        vec![State { controller: Controller::power_on(&self.cfg), violations: 0 }]
    }

    fn actions(&self, state: &State, actions: &mut Vec<Action>) {
        let cfg = &self.cfg;
        let c = &state.controller;
        let running = !c.tripped() && !c.bootstrap;
        if running {
            if cfg.single_servo_cycles {
                actions.push(Action::Do(Event::Servo { cycles: 1 }));
            } else {
                // When the change is one cycle away, "just before" is no move at all: stateright
                // sees the same state again and drops it.
                actions.push(Action::ServoToNextChange);
                actions.push(Action::ServoToJustBeforeChange);
            }
            if c.background_possible() {
                actions.push(Action::Do(Event::Background));
            }
            for load in &cfg.loads {
                if *load != c.load {
                    actions.push(Action::Do(Event::Load(*load)));
                }
            }
            for area in &cfg.checksum_faults {
                // One corruption per area until reset keeps the contents tokens two-valued.
                let clean = match area {
                    ChecksumTarget::Firmware => c.checksum.firmware == c.checksum.firmware_reference,
                    ChecksumTarget::UserProgram => c.checksum.program == c.checksum.program_reference,
                };
                if clean {
                    actions.push(Action::Do(Event::ChecksumFault(*area)));
                }
            }
            if cfg.clear_rti_reentry && c.status.rti_reentry {
                actions.push(Action::Do(Event::ClearRtiReentry));
            }
        }
        // Time passes for a tripped card too. Its servo interrupt does nothing (UM p.215: "The
        // processor stops operating"), so this adds no state, only the transition that lets
        // "a tripped card changes no state until it is reset" check that (one servo cycle: a
        // time jump would look for a change that never comes). Found by the hand mutation
        // `TrippedCardCounts` (conformance/tests/mutations.rs), which no check caught before.
        if c.tripped() {
            actions.push(Action::Do(Event::Servo { cycles: 1 }));
        }
        // Commands reach a tripped card too: it must stay silent. A motion command is offered
        // once per deceleration length when it can start a deceleration on a running card.
        for cmd in &cfg.commands {
            let event = Event::Command(cmd.clone());
            match cmd {
                pmacwd_specs::vocab::HostCommand::Motion(_)
                    if running && cfg.motion.decel_cycles_max > 1 && !self.longest_decelerations_only =>
                {
                    for decel in 1..=cfg.motion.decel_cycles_max {
                        actions.push(Action::Decelerating(event.clone(), decel));
                    }
                }
                _ => actions.push(Action::Do(event)),
            }
        }
        // UM p.214: each motor's encoder can be lost and come back at any time.
        if cfg.motion.encoder_inputs {
            for (k, m) in c.axes.motors().iter().enumerate() {
                let input = pmacwd_specs::vocab::EncoderInput { motor: k as u8 + 1, lost: !m.encoder_lost };
                actions.push(Action::Do(Event::EncoderInput(input)));
            }
        }
        // UM p.213: each motor's amplifier can report a fault and clear it at any time.
        if cfg.motion.amplifier_fault_inputs {
            for (k, m) in c.axes.motors().iter().enumerate() {
                let input = pmacwd_specs::vocab::AmplifierFaultInput { motor: k as u8 + 1, fault: !m.amplifier_fault };
                actions.push(Action::Do(Event::AmplifierFault(input)));
            }
        }
        // A supply reading is offered when it changes whether the supply is low by the rule's
        // own threshold, or by the manual's 4.75 V (UM p.215): a threshold moved either way in
        // the data or the rule then meets a reading between the two, where the monitor that
        // reads the printed figure tells them apart (issue 35: with the rule's threshold alone,
        // one moved down was never offered a reading below the manual's and so never caught).
        // While the two agree, the readings offered are the same as the rule's alone.
        for mv in &cfg.supply_millivolts {
            let low = *mv < cfg.supply_min_millivolts;
            let low_by_the_manual = *mv < crate::monitor::SUPPLY_MIN_MILLIVOLTS_PRINTED;
            if low != c.supply_low || low_by_the_manual != c.supply_low {
                actions.push(Action::Do(Event::Supply { millivolts: *mv }));
            }
        }
        for reset in &cfg.resets {
            actions.push(Action::Do(Event::Reset(*reset)));
        }
    }

    fn next_state(&self, state: &State, action: Action) -> Option<State> {
        let mut next = state.clone();
        self.take_action(state, &mut next, &action);
        Some(next)
    }

    /// [`Self::next_state`] for each action, except that the two time jumps of a state share
    /// their simulated cycles ([`WatchdogModel::leap`]): they run through the same cycles and
    /// end one cycle apart, so each was simulated twice (`i40-zero`: about 4,000 cycles a
    /// jump). Same successors, same order (`leaps_share_their_cycles_and_give_next_state_s_successors`).
    fn for_each_next_state<F>(&self, state: &State, actions: &mut Vec<Action>, mut visit: F)
    where
        F: FnMut(&mut Option<State>),
    {
        let mut leap: Option<Leap> = None;
        for action in actions.drain(..) {
            // Built in the `Option` that `visit` gets, as `next_state` builds it: a successor
            // returned and moved would be one more copy of the state per transition.
            let mut next = Some(state.clone());
            let n = next.as_mut().expect("a successor");
            match action {
                Action::ServoToNextChange | Action::ServoToJustBeforeChange => {
                    let leap = leap.get_or_insert_with(|| self.leap(state));
                    *n = self.end_leap(state, leap, action == Action::ServoToJustBeforeChange).1;
                }
                action => self.take_action(state, n, &action),
            }
            visit(&mut next);
        }
    }

    /// The Explorer's view of a state ([`crate::show::state_text`]): the card first.
    fn format_state(&self, state: &State) -> String {
        crate::show::state_text(&self.cfg, state)
    }

    /// The Explorer's "outcome" of an action: the concrete event (the servo cycles of a time
    /// jump), the reply and the card after it, as `pmacwd check` prints a path's step.
    fn format_step(&self, state: &State, action: Action) -> Option<String> {
        let (event, reply, next) = self.perform(state, &action);
        Some(crate::show::step_text(&self.cfg, &event, reply, &next.controller))
    }

    fn format_action(&self, action: &Action) -> String {
        match action {
            Action::Do(e) => e.to_string(),
            Action::Decelerating(e, decel) => format!("{e} (a deceleration takes {decel} servo cycles)"),
            Action::ServoToNextChange => "servo interrupts up to the next change".into(),
            Action::ServoToJustBeforeChange => "servo interrupts up to just before the next change".into(),
        }
    }

    /// stateright looks every property up by name in a SipHash-keyed map for every state it
    /// visits, so it gets short ids (`p00`, `p01`, ...) instead of the sentences, and, unless
    /// `detailed`, the `always` properties as two conjunctions (every monitor, every state
    /// property): 19 lookups per state instead of 51. [`WatchdogModel::check`] re-runs in detail
    /// when a conjunction fails, so each property still gets its own verdict and counterexample.
    ///
    /// A `sometimes` property that does not apply to the configuration (it lacks the events the
    /// property needs, see [`crate::properties::StateProperty::applies`]) is not given to
    /// stateright: its verdict is "n/a" whatever the search finds, and stateright would evaluate
    /// it on every state, since it is never reached (13 of them at `timing`).
    fn properties(&self) -> Vec<Property<Self>> {
        let applies = |p: &StateProperty| p.expectation == Expectation::Always || (p.applies)(&self.cfg);
        if self.named_properties {
            // The same properties as in detail below, each under its sentence.
            let mut v: Vec<Property<Self>> =
                MONITORS.iter().enumerate().map(|(k, m)| Property::always(m.name, MONITOR_HOLDS[k])).collect();
            for (k, p) in STATE_PROPERTIES.iter().enumerate().filter(|(_, p)| applies(p)) {
                v.push(match p.expectation {
                    Expectation::Always => Property::always(p.name, STATE_HOLDS[k]),
                    Expectation::Sometimes => Property::sometimes(p.name, STATE_HOLDS[k]),
                });
            }
            return v;
        }
        if !self.detailed {
            let mut v: Vec<Property<Self>> = vec![
                Property::always(PROPERTY_IDS[0], |_, s: &State| s.violations == 0),
                Property::always(PROPERTY_IDS[1], |m, s: &State| every_always_holds(&m.cfg, s)),
            ];
            for (k, p) in STATE_PROPERTIES.iter().enumerate() {
                if p.expectation == Expectation::Sometimes && applies(p) {
                    v.push(Property::sometimes(PROPERTY_IDS[v.len()], STATE_HOLDS[k]));
                }
            }
            return v;
        }
        // Each property by its position in `property_table`, which is its id.
        let mut v: Vec<Property<Self>> =
            MONITORS.iter().enumerate().map(|(k, _)| Property::always(PROPERTY_IDS[k], MONITOR_HOLDS[k])).collect();
        for (k, p) in STATE_PROPERTIES.iter().enumerate().filter(|(_, p)| applies(p)) {
            let id = PROPERTY_IDS[MONITORS.len() + k];
            v.push(match p.expectation {
                Expectation::Always => Property::always(id, STATE_HOLDS[k]),
                Expectation::Sometimes => Property::sometimes(id, STATE_HOLDS[k]),
            });
        }
        v
    }
}

fn monitor_holds<const K: usize>(_: &WatchdogModel, s: &State) -> bool {
    s.violations & (1u64 << K) == 0
}

const MONITOR_HOLDS: [fn(&WatchdogModel, &State) -> bool; 64] = [
    monitor_holds::<0>,
    monitor_holds::<1>,
    monitor_holds::<2>,
    monitor_holds::<3>,
    monitor_holds::<4>,
    monitor_holds::<5>,
    monitor_holds::<6>,
    monitor_holds::<7>,
    monitor_holds::<8>,
    monitor_holds::<9>,
    monitor_holds::<10>,
    monitor_holds::<11>,
    monitor_holds::<12>,
    monitor_holds::<13>,
    monitor_holds::<14>,
    monitor_holds::<15>,
    monitor_holds::<16>,
    monitor_holds::<17>,
    monitor_holds::<18>,
    monitor_holds::<19>,
    monitor_holds::<20>,
    monitor_holds::<21>,
    monitor_holds::<22>,
    monitor_holds::<23>,
    monitor_holds::<24>,
    monitor_holds::<25>,
    monitor_holds::<26>,
    monitor_holds::<27>,
    monitor_holds::<28>,
    monitor_holds::<29>,
    monitor_holds::<30>,
    monitor_holds::<31>,
    monitor_holds::<32>,
    monitor_holds::<33>,
    monitor_holds::<34>,
    monitor_holds::<35>,
    monitor_holds::<36>,
    monitor_holds::<37>,
    monitor_holds::<38>,
    monitor_holds::<39>,
    monitor_holds::<40>,
    monitor_holds::<41>,
    monitor_holds::<42>,
    monitor_holds::<43>,
    monitor_holds::<44>,
    monitor_holds::<45>,
    monitor_holds::<46>,
    monitor_holds::<47>,
    monitor_holds::<48>,
    monitor_holds::<49>,
    monitor_holds::<50>,
    monitor_holds::<51>,
    monitor_holds::<52>,
    monitor_holds::<53>,
    monitor_holds::<54>,
    monitor_holds::<55>,
    monitor_holds::<56>,
    monitor_holds::<57>,
    monitor_holds::<58>,
    monitor_holds::<59>,
    monitor_holds::<60>,
    monitor_holds::<61>,
    monitor_holds::<62>,
    monitor_holds::<63>,
];

const _: () = assert!(MONITORS.len() <= MONITOR_HOLDS.len(), "one violation bit per monitor");

/// State property K as the fn pointer stateright takes (the properties are judged on the
/// configuration alone, so they do not name the checker's model type).
fn state_holds<const K: usize>(m: &WatchdogModel, s: &State) -> bool {
    STATE_PROPERTIES.get(K).is_none_or(|p| (p.holds)(&m.cfg, s))
}

const STATE_HOLDS: [fn(&WatchdogModel, &State) -> bool; 48] = [
    state_holds::<0>,
    state_holds::<1>,
    state_holds::<2>,
    state_holds::<3>,
    state_holds::<4>,
    state_holds::<5>,
    state_holds::<6>,
    state_holds::<7>,
    state_holds::<8>,
    state_holds::<9>,
    state_holds::<10>,
    state_holds::<11>,
    state_holds::<12>,
    state_holds::<13>,
    state_holds::<14>,
    state_holds::<15>,
    state_holds::<16>,
    state_holds::<17>,
    state_holds::<18>,
    state_holds::<19>,
    state_holds::<20>,
    state_holds::<21>,
    state_holds::<22>,
    state_holds::<23>,
    state_holds::<24>,
    state_holds::<25>,
    state_holds::<26>,
    state_holds::<27>,
    state_holds::<28>,
    state_holds::<29>,
    state_holds::<30>,
    state_holds::<31>,
    state_holds::<32>,
    state_holds::<33>,
    state_holds::<34>,
    state_holds::<35>,
    state_holds::<36>,
    state_holds::<37>,
    state_holds::<38>,
    state_holds::<39>,
    state_holds::<40>,
    state_holds::<41>,
    state_holds::<42>,
    state_holds::<43>,
    state_holds::<44>,
    state_holds::<45>,
    state_holds::<46>,
    state_holds::<47>,
];

const _: () = assert!(STATE_PROPERTIES.len() <= STATE_HOLDS.len(), "one fn pointer per state property");

/// The ids stateright knows the properties by, in [`property_table`] order.
const PROPERTY_IDS: [&str; 96] = [
    "p00", "p01", "p02", "p03", "p04", "p05", "p06", "p07", "p08", "p09", "p10", "p11", "p12", "p13", "p14", "p15",
    "p16", "p17", "p18", "p19", "p20", "p21", "p22", "p23", "p24", "p25", "p26", "p27", "p28", "p29", "p30", "p31",
    "p32", "p33", "p34", "p35", "p36", "p37", "p38", "p39", "p40", "p41", "p42", "p43", "p44", "p45", "p46", "p47",
    "p48", "p49", "p50", "p51", "p52", "p53", "p54", "p55", "p56", "p57", "p58", "p59", "p60", "p61", "p62", "p63",
    "p64", "p65", "p66", "p67", "p68", "p69", "p70", "p71", "p72", "p73", "p74", "p75", "p76", "p77", "p78", "p79",
    "p80", "p81", "p82", "p83", "p84", "p85", "p86", "p87", "p88", "p89", "p90", "p91", "p92", "p93", "p94", "p95",
];

const _: () = assert!(MONITORS.len() + STATE_PROPERTIES.len() <= PROPERTY_IDS.len(), "one id per property");

// ---------------------------------------------------------------------------------- reporting

/// Everything known about one property after a run.
#[derive(Clone, Debug)]
pub struct PropertyResult {
    pub name: &'static str,
    pub expectation: Expectation,
    pub cite: &'static str,
    pub sentence: &'static str,
    pub holds: bool,
    /// False when the configuration lacks the events a `sometimes` property needs; such a
    /// property counts as holding and is reported as not applicable.
    pub applicable: bool,
    pub needs: &'static str,
    /// Counterexample (violated `always`) or witness (`sometimes`), shortest first (BFS).
    pub path: Option<Vec<TraceStep>>,
}

/// One step of a printed trace.
#[derive(Clone, Debug)]
pub struct TraceStep {
    pub event: Event,
    pub observation: Observation,
}

#[derive(Clone, Debug)]
pub struct RunReport {
    pub configuration: String,
    pub profile: String,
    /// Whether the whole reachable state space was explored. When the checker stopped at
    /// [`STATES_MAX`], `always` properties are only known on the states seen and `sometimes`
    /// properties may exist beyond them: the report earns no verdict.
    pub complete: bool,
    pub states: usize,
    pub depth: usize,
    pub duration: Duration,
    pub properties: Vec<PropertyResult>,
}

impl RunReport {
    pub fn all_hold(&self) -> bool {
        self.properties.iter().all(|p| p.holds)
    }

    pub fn states_per_second(&self) -> f64 {
        self.states as f64 / self.duration.as_secs_f64().max(1e-9)
    }
}

/// One row of [`property_table`].
#[derive(Clone, Copy)]
pub struct PropertyInfo {
    pub name: &'static str,
    pub expectation: Expectation,
    pub cite: &'static str,
    pub sentence: &'static str,
    pub applies: fn(&ModelConfig) -> bool,
    pub needs: &'static str,
}

impl PropertyInfo {
    /// This property's verdict after a run.
    fn result(&self, holds: bool, applicable: bool, path: Option<Vec<TraceStep>>) -> PropertyResult {
        PropertyResult {
            name: self.name,
            expectation: self.expectation,
            cite: self.cite,
            sentence: self.sentence,
            holds,
            applicable,
            needs: self.needs,
            path,
        }
    }
}

/// Every property's name, kind and citation, in checking order.
pub fn property_table() -> Vec<PropertyInfo> {
    fn any(_: &ModelConfig) -> bool {
        true
    }
    let mut v: Vec<_> = MONITORS
        .iter()
        .map(|m| PropertyInfo {
            name: m.name,
            expectation: Expectation::Always,
            cite: m.cite,
            sentence: m.sentence,
            applies: any,
            needs: "",
        })
        .collect();
    v.extend(STATE_PROPERTIES.iter().map(|p| PropertyInfo {
        name: p.name,
        expectation: p.expectation,
        cite: p.cite,
        sentence: p.sentence,
        applies: p.applies,
        needs: p.needs,
    }));
    v
}

impl WatchdogModel {
    /// Explores every reachable state breadth-first and reports each property.
    pub fn check(self, threads: usize) -> RunReport {
        self.check_bounded(threads, STATES_MAX)
    }

    /// As [`WatchdogModel::check`], telling `progress` how far it has come while it runs (see
    /// [`join_observed`]).
    pub fn check_observed(self, threads: usize, progress: &mut dyn FnMut(Explored)) -> RunReport {
        self.check_bounded_observed(threads, STATES_MAX, progress)
    }

    /// As [`WatchdogModel::check`], stopping after about `states_max` states; the report then
    /// says it is incomplete.
    pub fn check_bounded(self, threads: usize, states_max: usize) -> RunReport {
        self.check_bounded_observed(threads, states_max, &mut |_| {})
    }

    fn check_bounded_observed(
        self,
        threads: usize,
        states_max: usize,
        progress: &mut dyn FnMut(Explored),
    ) -> RunReport {
        if self.detailed {
            return self.check_detailed(threads, states_max, progress);
        }
        let (cfg, canary, longest_decelerations_only) =
            (self.cfg.clone(), self.canary, self.longest_decelerations_only);
        let start = Instant::now();
        let spawned = self.checker().threads(threads).target_state_count(states_max).spawn_bfs();
        let checker = join_observed(spawned, progress);
        let duration = start.elapsed();
        let discoveries = checker.discoveries();
        if discoveries.contains_key(PROPERTY_IDS[0]) || discoveries.contains_key(PROPERTY_IDS[1]) {
            // Some `always` property fails: check each one on its own, for its verdict and its own
            // shortest counterexample.
            let mut report =
                WatchdogModel { cfg, canary, detailed: true, longest_decelerations_only, named_properties: false }
                    .check_detailed(threads, states_max, progress);
            report.duration += duration;
            return report;
        }
        let model = checker.model();
        let mut sometimes_seen = 0;
        let properties = property_table()
            .into_iter()
            .map(|info| {
                let applicable = (info.applies)(&model.cfg);
                let (holds, path) = match info.expectation {
                    // Both conjunctions held in every reachable state.
                    Expectation::Always => (true, None),
                    // Not searched (see `properties`): n/a, which counts as holding.
                    Expectation::Sometimes if !applicable => (true, None),
                    Expectation::Sometimes => {
                        let found = discoveries.get(PROPERTY_IDS[2 + sometimes_seen]);
                        sometimes_seen += 1;
                        (found.is_some(), found.map(|p| model.replay(&p.clone().into_actions())))
                    }
                };
                info.result(holds, applicable, path)
            })
            .collect();
        RunReport {
            configuration: model.cfg.configuration.clone(),
            profile: model.cfg.profile.name.clone(),
            complete: explored_all(&checker, states_max),
            states: checker.unique_state_count(),
            depth: checker.max_depth(),
            duration,
            properties,
        }
    }

    /// One stateright property per named property.
    fn check_detailed(self, threads: usize, states_max: usize, progress: &mut dyn FnMut(Explored)) -> RunReport {
        let configuration = self.cfg.configuration.clone();
        let profile = self.cfg.profile.name.clone();
        let start = Instant::now();
        let spawned = self.checker().threads(threads).target_state_count(states_max).spawn_bfs();
        let checker = join_observed(spawned, progress);
        let duration = start.elapsed();
        let model = checker.model();
        let discoveries = checker.discoveries();
        let properties = property_table()
            .into_iter()
            .enumerate()
            .map(|(k, info)| {
                let found = discoveries.get(PROPERTY_IDS[k]);
                let applicable = (info.applies)(&model.cfg);
                let holds = match info.expectation {
                    Expectation::Always => found.is_none(),
                    Expectation::Sometimes => found.is_some() || !applicable,
                };
                info.result(holds, applicable, found.map(|p| model.replay(&p.clone().into_actions())))
            })
            .collect();
        RunReport {
            configuration,
            profile,
            complete: explored_all(&checker, states_max),
            states: checker.unique_state_count(),
            depth: checker.max_depth(),
            duration,
            properties,
        }
    }

    /// Replays checker actions from power-up into readable steps.
    pub fn replay(&self, actions: &[Action]) -> Vec<TraceStep> {
        let mut state = self.init_states().remove(0);
        let mut steps = Vec::new();
        for a in actions {
            let (event, reply, next) = self.perform(&state, a);
            steps.push(TraceStep { event, observation: crate::observe::of(&next.controller, &self.cfg, reply) });
            state = next;
        }
        steps
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use pmacwd_specs::vocab::command::HostCommand;
    use pmacwd_specs::Spec;

    fn config(name: &str) -> ModelConfig {
        let spec = Spec::embedded().unwrap();
        ModelConfig::from_spec(&spec, name, &spec.profiles.default_profile()).unwrap()
    }

    fn monitor_index(name: &str) -> usize {
        crate::monitor::MONITORS.iter().position(|m| m.name == name).unwrap_or_else(|| panic!("no monitor {name:?}"))
    }

    /// The cycle monitors reach the violation bits: a servo cycle that drops the counter by
    /// three (SRM p.57: "Each servo interrupt cycle, Turbo PMAC decrements this counter by 1")
    /// and reports an RTI overrun without bits 22 and 9 (SRM p.289-290) sets exactly those two
    /// monitors' bits, and the model's own cycle sets none. On a correct model no cycle monitor
    /// ever fires, so only a hand-made violation shows that the dispatch still passes each
    /// monitor's verdict on, at its own bit (cargo-mutants: `cycle_bit` and `cycle_violations`
    /// answering 0, the guard dropped, `1 << K` turned to `1 >> K`).
    #[test]
    fn a_servo_cycle_that_breaks_two_cycle_monitors_sets_exactly_their_bits() {
        let cfg = config("timing");
        let before = Controller::power_on(&cfg);
        let mut after = before.clone();
        let report = after.servo_cycle(&cfg);
        assert_eq!(cycle_violations(&cfg, &before, report, &after), 0, "the model's own cycle");
        after.counter -= 2;
        let overrun = CycleReport { rti_overrun: true, ..report };
        let expected = 1u64 << monitor_index("the watchdog counter drops by at most one per servo cycle")
            | 1u64 << monitor_index("an RTI overrun sets bits 22 and 9");
        assert_eq!(cycle_violations(&cfg, &before, overrun, &after), expected);
    }

    /// The event monitors see a leap as one event (the servo interrupts up to the next change),
    /// as a trace shows it: a leap that takes a killed motor to closed loop without a `J/` sets
    /// the bit of "a killed motor does not move until it is re-enabled" (UM p.319). A correct
    /// model never leaps so, so the state is made by hand: a killed motor with a jog stop still
    /// counting down one cycle, which the servo cycle ends by closing its loop. (cargo-mutants: the
    /// event monitors skipped on a leap, `cycles > 0` turned to `==` or `<`.)
    #[test]
    fn a_leap_is_checked_by_the_event_monitors_as_one_event() {
        use crate::motion::Stop;
        use pmacwd_specs::vocab::MotorState;
        let cfg = config("motion");
        let mut start = State { controller: Controller::power_on(&cfg), violations: 0 };
        let m = &mut start.controller.axes.motors_mut()[0];
        assert_eq!(m.state, MotorState::Killed, "motors power up killed");
        (m.stop, m.stop_cycles) = (Some(Stop::Jog), 1);
        let (cycles, next) = WatchdogModel::new(cfg).advance_to_change(&start, false);
        assert_eq!((cycles, next.controller.axes.motors()[0].state), (1, MotorState::Closed));
        assert_eq!(next.violations, 1 << monitor_index("a killed motor does not move until it is re-enabled"));
    }

    /// The two leaps are the ones their names say, in `perform` (which a witness path replays)
    /// and in the checker's `next_state` alike: the leap to the next change ends on a state whose
    /// signature differs from the start, the leap to just before it one cycle earlier on a state
    /// whose signature is the start's. (cargo-mutants: the `==` choosing `just_before` turned
    /// to `!=` in either place, which swaps the two leaps.)
    #[test]
    fn each_leap_stops_where_its_name_says_in_perform_and_in_the_checker() {
        let cfg = config("i40-zero");
        assert!(!cfg.single_servo_cycles, "i40-zero leaps");
        let model = WatchdogModel::new(cfg.clone());
        let start = State { controller: Controller::power_on(&cfg), violations: 0 };
        let (to, _, at_change) = model.perform(&start, &Action::ServoToNextChange);
        let (before, _, just_before) = model.perform(&start, &Action::ServoToJustBeforeChange);
        let (Event::Servo { cycles: to }, Event::Servo { cycles: before }) = (to, before) else {
            panic!("leaps are servo events")
        };
        assert!(to > 1, "a leap of several cycles: {to}");
        assert_eq!(before, to - 1);
        let sig = |s: &State| signature(&cfg, &s.controller);
        assert!(sig(&at_change) != sig(&start) && sig(&just_before) == sig(&start));
        assert!(model.next_state(&start, Action::ServoToNextChange) == Some(at_change));
        assert!(model.next_state(&start, Action::ServoToJustBeforeChange) == Some(just_before));
    }

    /// The successors `for_each_next_state` gives (the two time jumps of a state sharing their
    /// simulated cycles) are `next_state`'s, action by action, in the first 300 states
    /// reachable in `i40-zero` (breadth first; every running state leaps), under both profiles
    /// that decrement differently (`srm-57` counts below zero) and with canaries that act within
    /// the cycles. (All of them take a minute and a half in a test build, 1,000 of each 19 s.)
    #[test]
    fn leaps_share_their_cycles_and_give_next_state_s_successors() {
        let spec = Spec::embedded().unwrap();
        let runs = [
            ("um-215", None),
            ("srm-57", None),
            ("um-215", Some(Canary::CounterDropsByTwo)),
            ("um-215", Some(Canary::StarvationNeverTrips)),
        ];
        for (profile, canary) in runs {
            let profile = spec.profiles.get(profile).expect("profile exists");
            let cfg = ModelConfig::from_spec(&spec, "i40-zero", &profile).unwrap();
            let model = WatchdogModel { canary, ..WatchdogModel::new(cfg) };
            let mut seen = std::collections::HashSet::new();
            let mut queue: std::collections::VecDeque<State> = model.init_states().into();
            let (mut states, mut leaps) = (0, 0);
            while let Some(s) = queue.pop_front() {
                if states == 300 {
                    break;
                }
                if !seen.insert(s.clone()) {
                    continue;
                }
                states += 1;
                let mut actions = Vec::new();
                model.actions(&s, &mut actions);
                leaps += actions.iter().filter(|a| **a == Action::ServoToNextChange).count();
                let one_by_one: Vec<Option<State>> = actions.iter().map(|a| model.next_state(&s, a.clone())).collect();
                let mut shared = Vec::new();
                model.for_each_next_state(&s, &mut actions, |n| shared.push(n.take()));
                assert!(actions.is_empty(), "the actions are drained");
                assert!(shared == one_by_one, "successors differ at {s:?}");
                queue.extend(one_by_one.into_iter().flatten());
            }
            assert!(leaps > 100, "{states} states, {leaps} leaping");
        }
    }

    /// `Signature::is_of`, which a time jump asks on every servo cycle, is the plain
    /// comparison of signatures: on every cycle of every time jump from the first 100 states of
    /// `i40-zero` (under both meanings of bit 12), and on cards changed in each part of the
    /// signature (status words changed through their inputs, or not: a flag no word shows).
    #[test]
    fn a_signature_compared_through_the_status_inputs_is_the_plain_comparison() {
        use crate::controller::TripCause;
        let spec = Spec::embedded().unwrap();
        for profile in ["um-215", "um-215-m83"] {
            let profile = spec.profiles.get(profile).expect("profile exists");
            let cfg = ModelConfig::from_spec(&spec, "i40-zero", &profile).unwrap();
            let model = WatchdogModel::new(cfg.clone());
            let mut seen = std::collections::HashSet::new();
            let mut queue: std::collections::VecDeque<State> = model.init_states().into();
            let (mut cycles, mut differing) = (0, 0);
            while let Some(s) = queue.pop_front() {
                if seen.len() == 100 {
                    break;
                }
                if !seen.insert(s.clone()) {
                    continue;
                }
                let start = signature(&cfg, &s.controller);
                let agrees = |c: &Controller| start.is_of(&cfg, &s.controller, c) == (signature(&cfg, c) == start);
                let edits: [fn(&mut Controller); 6] = [
                    |c| c.trip = Some(TripCause::Undervoltage),
                    |c| c.counter = -1 - c.counter,
                    |c| c.background_credit = u32::MAX - c.background_credit,
                    |c| c.status.data_gathering_on ^= true,
                    |c| c.checksum.error = Some(pmacwd_specs::check::ChecksumTarget::UserProgram),
                    |c| c.axes.motors_mut()[0].stop_cycles ^= 1,
                ];
                for edit in edits {
                    let mut c = s.controller.clone();
                    edit(&mut c);
                    assert!(agrees(&c), "{c:?}");
                    differing += usize::from(signature(&cfg, &c) != start);
                }
                let mut c = s.controller.clone();
                for _ in 0..JUMP_CYCLES_MAX {
                    c.servo_cycle(&cfg);
                    cycles += 1;
                    assert!(agrees(&c), "{c:?} from {s:?}");
                    if signature(&cfg, &c) != start {
                        break;
                    }
                }
                let mut actions = Vec::new();
                model.actions(&s, &mut actions);
                queue.extend(actions.into_iter().filter_map(|a| model.next_state(&s, a)));
            }
            assert!(cycles > 20_000 && differing > 300, "{cycles} cycles, {differing} differing");
        }
    }

    /// The bit-19 monitor compares the words only where the card's inputs to them changed
    /// (`Controller::status_inputs`): on every transition of `status` (GATHER, ENDGATHER,
    /// checksum errors, the buffers) under the profile with either meaning of bit 12, its
    /// verdict is the plain one, the words built on both sides; and cards with equal inputs
    /// have equal words. Also on transitions made to break it: bit 19 flipped by a servo cycle.
    #[test]
    fn the_bit_19_monitor_builds_the_words_only_where_they_can_differ() {
        use crate::monitor::MONITORS;
        let spec = Spec::embedded().unwrap();
        let name = "bit 19 of ??? is set by GATHER and cleared by ENDGATHER or a reset, and by nothing else";
        let Some(crate::monitor::Monitor { check: Check::Event(fast), .. }) = MONITORS.iter().find(|m| m.name == name)
        else {
            panic!("no event monitor {name:?}")
        };
        let plain = |cfg: &ModelConfig, prev: &Controller, ev: &Event, next: &Controller| {
            let before = prev.status_words(cfg).0 & 1 << 19 != 0;
            let after = next.status_words(cfg).0 & 1 << 19 != 0;
            let running = !prev.tripped() && !prev.bootstrap;
            match ev {
                Event::Command(HostCommand::Gather) if running => after,
                Event::Command(HostCommand::EndGather) if running => !after,
                Event::Reset(_) => !after,
                Event::Command(HostCommand::Reset | HostCommand::Reinitialize) if running => !after,
                _ => after == before,
            }
        };
        for profile in ["um-215", "um-215-m83"] {
            let profile = spec.profiles.get(profile).expect("profile exists");
            let cfg = ModelConfig::from_spec(&spec, "status", &profile).unwrap();
            let model = WatchdogModel::new(cfg.clone());
            let mut seen = std::collections::HashSet::new();
            let mut queue: std::collections::VecDeque<State> = model.init_states().into();
            let mut words_by_inputs = std::collections::HashMap::new();
            let (mut transitions, mut failing) = (0, 0);
            while let Some(s) = queue.pop_front() {
                if !seen.insert(s.clone()) {
                    continue;
                }
                let words = s.controller.status_words(&cfg);
                assert_eq!(*words_by_inputs.entry(s.controller.status_inputs()).or_insert(words), words);
                let mut actions = Vec::new();
                model.actions(&s, &mut actions);
                for action in actions {
                    let (event, reply, next) = model.perform(&s, &action);
                    let mut broken = next.controller.clone();
                    broken.status.data_gathering_on ^= true;
                    for n in [&next.controller, &broken] {
                        let verdict = fast(&cfg, &s.controller, &event, reply, n);
                        assert_eq!(verdict, plain(&cfg, &s.controller, &event, n), "{event:?} from {s:?}");
                        transitions += 1;
                        failing += usize::from(!verdict);
                    }
                    queue.push_back(next);
                }
            }
            assert!(transitions > 100_000 && failing > 10_000, "{transitions} transitions, {failing} failing");
        }
    }

    /// The monitors run only where they can fail give the plain monitors' bits: on every
    /// transition of the configurations with motors (up to 20,000 states each, under the
    /// default profile and the one that reads the encoder-loss PLC literally), on every single
    /// servo cycle from those states, and on the same transitions with a motor changed as a
    /// broken rule would (a killed motor closed, its fault and loss statuses flipped), so that
    /// the monitors fail. And the premise: each monitor of `HOLD_WHILE_THE_AXES_STAY` holds on
    /// each of these transitions with the axes put back as they were before it.
    #[test]
    fn monitors_holding_while_the_axes_stay_hold_there() {
        let spec = Spec::embedded().unwrap();
        let (mut transitions, mut axes_changed, mut failing) = (0usize, 0usize, 0usize);
        let mut check = |cfg: &ModelConfig, prev: &Controller, event: Option<(&Event, Reply)>, next: &Controller| {
            let mut broken = next.clone();
            if let Some(m) = broken.axes.motors_mut().first_mut() {
                if m.state == pmacwd_specs::vocab::MotorState::Killed {
                    m.state = pmacwd_specs::vocab::MotorState::Closed;
                }
                m.fault_status ^= true;
                m.loss_status ^= true;
                m.stop = None;
            }
            let mut stayed = next.clone();
            stayed.axes = prev.axes;
            for n in [next, &broken, &stayed] {
                let (fast, plain) = match event {
                    Some((event, reply)) => (
                        event_violations(cfg, prev, event, reply, n),
                        event_violations_plain(cfg, prev, event, reply, n),
                    ),
                    None => {
                        let report = CycleReport::default();
                        (cycle_violations(cfg, prev, report, n), cycle_violations_plain(cfg, prev, report, n))
                    }
                };
                assert_eq!(fast, plain, "{event:?} from {prev:?} to {n:?}");
                assert_eq!(axes_stayed(&prev.axes, &n.axes), prev.axes == n.axes);
                transitions += 1;
                axes_changed += usize::from(n.axes != prev.axes);
                failing += usize::from(plain & AXES_MONITORS != 0);
            }
            let (_, plain) = match event {
                Some((event, reply)) => (0, event_violations_plain(cfg, prev, event, reply, &stayed)),
                None => (0, cycle_violations_plain(cfg, prev, CycleReport::default(), &stayed)),
            };
            assert_eq!(
                plain & AXES_MONITORS,
                0,
                "a monitor of HOLD_WHILE_THE_AXES_STAY fails with the axes as they were: {event:?} from {prev:?}"
            );
        };
        for configuration in ["motion", "encoder-loss", "encoder-loss-2", "amplifier-fault"] {
            for profile in ["um-215", "um-215-literal-plc"] {
                let profile = spec.profiles.get(profile).expect("profile exists");
                let cfg = ModelConfig::from_spec(&spec, configuration, &profile).unwrap();
                let model = WatchdogModel::new(cfg.clone());
                let mut seen = std::collections::HashSet::new();
                let mut queue: std::collections::VecDeque<State> = model.init_states().into();
                while let Some(s) = queue.pop_front() {
                    if seen.len() == 20_000 {
                        break;
                    }
                    if !seen.insert(s.clone()) {
                        continue;
                    }
                    let mut after = s.controller.clone();
                    let report = after.servo_cycle(&cfg);
                    check(&cfg, &s.controller, None, &after);
                    // The cycle's own report too (the check above gives a quiet one).
                    assert_eq!(
                        cycle_violations(&cfg, &s.controller, report, &after),
                        cycle_violations_plain(&cfg, &s.controller, report, &after)
                    );
                    let mut actions = Vec::new();
                    model.actions(&s, &mut actions);
                    for action in actions {
                        let (event, reply, next) = model.perform(&s, &action);
                        check(&cfg, &s.controller, Some((&event, reply)), &next.controller);
                        queue.push_back(next);
                    }
                }
            }
        }
        assert!(
            transitions > 1_000_000 && axes_changed > 100_000 && failing > 100_000,
            "{transitions} transitions, {axes_changed} with the axes changed, {failing} failing"
        );
    }

    /// A single servo interrupt goes through the cycle monitors: a motor finishing a `Q` stop
    /// must end at rest with its program at a program point (UM p.217: "Q: Stop at Prog Pt?
    /// Yes"); a hand-made motor that finishes one while its coordinate system has no program
    /// sets that monitor's bit on the servo event. (cargo-mutants: the `Servo` arm of
    /// `apply_in_place` deleted, which left single cycles to the rule without their monitors.)
    #[test]
    fn a_single_servo_interrupt_runs_the_cycle_monitors() {
        use crate::motion::Stop;
        use pmacwd_specs::vocab::MotorState;
        let cfg = config("motion");
        let mut start = State { controller: Controller::power_on(&cfg), violations: 0 };
        let m = &mut start.controller.axes.motors_mut()[0];
        (m.state, m.stop, m.stop_cycles) = (MotorState::Decelerating, Some(Stop::Quit), 1);
        let (_, next) = WatchdogModel::new(cfg).step(&start, &Event::Servo { cycles: 1 });
        assert_eq!(next.controller.axes.motors()[0].state, MotorState::Closed);
        assert_eq!(next.violations, 1 << monitor_index("Q and / stop at a program point"));
    }

    /// The `always` conjunction that stateright checks in every state holds the `always`
    /// properties only: at power-up, where every `always` property holds and the `sometimes`
    /// ones (a trip, say) have not happened, it holds, and it fails as soon as one `always`
    /// property does. A conjunction that took in the `sometimes` properties too would fail
    /// almost everywhere and send every run to the slower detailed re-run, whose verdicts hide
    /// the mistake. (cargo-mutants: the guard of `always_holds` turned to `true`.)
    #[test]
    fn the_always_conjunction_takes_in_the_always_properties_only() {
        let cfg = config("timing");
        let start = State { controller: Controller::power_on(&cfg), violations: 0 };
        assert!(STATE_PROPERTIES.iter().any(|p| p.expectation == Expectation::Sometimes && !(p.holds)(&cfg, &start)));
        assert!(every_always_holds(&cfg, &start));
        let mut broken = start.clone();
        broken.controller.trip = Some(crate::controller::TripCause::StrobeTimeout);
        // Tripped with the outputs left as they were: "a tripped card forces its outputs off"
        // and the others of UM p.215 fail.
        assert!(!every_always_holds(&cfg, &broken));
    }

    fn actions_of(model: &WatchdogModel, s: &State) -> Vec<Action> {
        let mut actions = Vec::new();
        model.actions(s, &mut actions);
        actions
    }

    /// `<CLEAR-RTI-REENTRY>` (SRM p.289: bit 22 is sticky until cleared) is offered only where
    /// the configuration asks for it and the bit is set: elsewhere it would be a no-op the
    /// checker explores for nothing, or a clearing the configuration does not allow.
    /// (cargo-mutants: the `&&` of that condition turned to `||`.)
    #[test]
    fn the_rti_reentry_clearing_is_offered_only_when_allowed_and_set() {
        let cfg = config("timing");
        assert!(cfg.clear_rti_reentry);
        let clear = Action::Do(Event::ClearRtiReentry);
        let mut s = State { controller: Controller::power_on(&cfg), violations: 0 };
        assert!(!actions_of(&WatchdogModel::new(cfg.clone()), &s).contains(&clear), "bit clear");
        s.controller.status.rti_reentry = true;
        assert!(actions_of(&WatchdogModel::new(cfg.clone()), &s).contains(&clear), "bit set");
        let not_allowed = ModelConfig { clear_rti_reentry: false, ..cfg };
        assert!(!actions_of(&WatchdogModel::new(not_allowed), &s).contains(&clear), "not allowed");
    }

    /// A motion command is offered once per deceleration length (1 to `decel_cycles_max`) only
    /// where it can start a deceleration of that length: on a running card, when the
    /// configuration has more than one length, and unless the run takes the longest only. A
    /// tripped card gets each command once (it must stay silent, UM p.215). (cargo-mutants:
    /// the guard turned to `true`, its `&&`s to `||`, `> 1` to `>= 1`.)
    #[test]
    fn motion_commands_are_offered_per_deceleration_length_only_where_that_can_differ() {
        let cfg = config("motion");
        assert_eq!(cfg.motion.decel_cycles_max, 2);
        let running = State { controller: Controller::power_on(&cfg), violations: 0 };
        let mut tripped = running.clone();
        tripped.controller.trip = Some(crate::controller::TripCause::Undervoltage);
        let kill = Event::Command(HostCommand::parse("#1K").unwrap());
        let offered = |model: &WatchdogModel, s: &State| -> Vec<Action> {
            actions_of(model, s)
                .into_iter()
                .filter(|a| matches!(a, Action::Do(e) | Action::Decelerating(e, _) if *e == kill))
                .collect()
        };
        let model = WatchdogModel::new(cfg.clone());
        assert_eq!(
            offered(&model, &running),
            [Action::Decelerating(kill.clone(), 1), Action::Decelerating(kill.clone(), 2)]
        );
        assert_eq!(offered(&model, &tripped), [Action::Do(kill.clone())], "tripped");
        let longest = WatchdogModel { longest_decelerations_only: true, ..WatchdogModel::new(cfg.clone()) };
        assert_eq!(offered(&longest, &running), [Action::Do(kill.clone())], "longest only");
        let mut one = cfg;
        one.motion.decel_cycles_max = 1;
        assert_eq!(offered(&WatchdogModel::new(one), &running), [Action::Do(kill)], "one length");
    }

    /// A supply reading is offered exactly when it changes whether the supply is low, with the
    /// controller's own threshold (UM p.215: the trip below about 4.75 V): at the threshold
    /// itself the supply is not low, one millivolt below it is. (cargo-mutants: `<` turned to
    /// `<=` in the action's filter, which disagreed with the rule at the threshold.)
    #[test]
    fn a_supply_reading_is_offered_when_it_changes_the_low_supply_flag_at_the_rule_s_threshold() {
        let base = config("timing");
        let min = base.supply_min_millivolts;
        let cfg = ModelConfig { supply_millivolts: vec![min - 1, min, min + 1], ..base };
        let model = WatchdogModel::new(cfg.clone());
        let start = State { controller: Controller::power_on(&cfg), violations: 0 };
        for state in [start.clone(), model.step(&start, &Event::Supply { millivolts: min - 1 }).1] {
            let offered: Vec<u32> = actions_of(&model, &state)
                .into_iter()
                .filter_map(|a| match a {
                    Action::Do(Event::Supply { millivolts }) => Some(millivolts),
                    _ => None,
                })
                .collect();
            let changing: Vec<u32> = cfg
                .supply_millivolts
                .iter()
                .copied()
                .filter(|mv| {
                    model.step(&state, &Event::Supply { millivolts: *mv }).1.controller.supply_low
                        != state.controller.supply_low
                })
                .collect();
            assert_eq!(offered, changing, "supply low: {}", state.controller.supply_low);
        }
    }

    /// With the rule's threshold moved off the manual's 4.75 V (UM p.215), either way, the
    /// checker still offers the readings between the two from a good supply: the one the manual
    /// calls low and the rule does not (threshold moved down), and the one the rule calls low
    /// and the manual does not (moved up). Before issue 35 only the second was offered, so a
    /// threshold moved down was never caught.
    #[test]
    fn supply_readings_are_offered_on_both_sides_of_the_printed_threshold_when_the_rule_s_moves() {
        let printed = crate::monitor::SUPPLY_MIN_MILLIVOLTS_PRINTED;
        for moved in [printed - 1, printed + 1] {
            let base = config("edges");
            let cfg = ModelConfig { supply_min_millivolts: moved, ..base };
            let model = WatchdogModel::new(cfg.clone());
            let start = State { controller: Controller::power_on(&cfg), violations: 0 };
            let offered: Vec<u32> = actions_of(&model, &start)
                .into_iter()
                .filter_map(|a| match a {
                    Action::Do(Event::Supply { millivolts }) => Some(millivolts),
                    _ => None,
                })
                .collect();
            let between = if moved < printed { printed - 1 } else { printed };
            assert!(offered.contains(&between), "threshold {moved}: {between} mV offered, got {offered:?}");
        }
    }

    /// A path's steps are printed with their events: each kind of action says what it does,
    /// with the deceleration's length where it has one. (cargo-mutants: `format_action`
    /// answering an empty or a fixed text.)
    #[test]
    fn each_action_prints_as_its_event() {
        let model = WatchdogModel::new(config("motion"));
        let kill = Event::Command(HostCommand::parse("#1K").unwrap());
        assert_eq!(model.format_action(&Action::Do(Event::Background)), Event::Background.to_string());
        assert_eq!(
            model.format_action(&Action::Decelerating(kill.clone(), 2)),
            format!("{kill} (a deceleration takes 2 servo cycles)")
        );
        assert_eq!(model.format_action(&Action::ServoToNextChange), "servo interrupts up to the next change");
        assert_eq!(
            model.format_action(&Action::ServoToJustBeforeChange),
            "servo interrupts up to just before the next change"
        );
    }

    /// A run's report holds when every property holds, and not when one fails (the exit code
    /// of `pmacwd check` is read from it); its rate is states over seconds. (cargo-mutants:
    /// `all_hold` answering a constant, `states_per_second` a constant or another operator.)
    #[test]
    fn a_report_holds_only_when_every_property_holds_and_its_rate_is_states_over_seconds() {
        let table = property_table();
        let row = |holds: bool| table[0].result(holds, true, None);
        let mut report = RunReport {
            configuration: "timing".into(),
            profile: "um-215".into(),
            complete: true,
            states: 3_000,
            depth: 7,
            duration: Duration::from_millis(1_500),
            properties: vec![row(true), row(true)],
        };
        assert!(report.all_hold());
        report.properties[1] = row(false);
        assert!(!report.all_hold());
        assert_eq!(report.states_per_second(), 2_000.0);
    }

    /// Every monitor is an `always` property of every configuration: a monitor's row must not
    /// say it does not apply (it would be reported n/a instead of checked). (cargo-mutants:
    /// the monitors' `any` answering false.)
    #[test]
    fn every_monitor_applies_to_every_configuration() {
        let spec = Spec::embedded().unwrap();
        let table = property_table();
        for name in spec.check.configurations.keys() {
            let cfg = config(name);
            for m in MONITORS {
                let row = table.iter().find(|p| p.name == m.name).expect("each monitor has a row");
                assert!((row.applies)(&cfg), "{}: {name}", m.name);
            }
        }
    }

    /// An endless chain of states: each has one successor, the next number.
    struct Chain;

    impl Model for Chain {
        type State = u64;
        type Action = ();
        fn init_states(&self) -> Vec<u64> {
            vec![0]
        }
        fn actions(&self, _: &u64, actions: &mut Vec<()>) {
            actions.push(());
        }
        fn next_state(&self, s: &u64, _: ()) -> Option<u64> {
            Some(s + 1)
        }
        // A property that always holds: without one, stateright has nothing to look for and
        // stops at once.
        fn properties(&self) -> Vec<Property<Self>> {
            vec![Property::always("holds", |_, _| true)]
        }
    }

    /// A run that stateright stops with exactly `states_max` states generated was cut, not
    /// complete: `explored_all` must say so (a false "complete" would report the `sometimes`
    /// properties of an unexplored space as never reached, the false verdict issue 15 names).
    /// An endless chain never completes; one thread makes the count where it stops repeatable,
    /// so the second run is stopped exactly at its bound. (cargo-mutants: `<` turned to `<=`.)
    #[test]
    fn a_run_stopped_exactly_at_its_bound_is_not_reported_complete() {
        let first = Chain.checker().threads(1).target_state_count(2).spawn_bfs().join();
        let at_stop = first.state_count();
        assert!(at_stop > 2, "stateright stops only after a block of states: {at_stop}");
        let second = Chain.checker().threads(1).target_state_count(at_stop).spawn_bfs().join();
        assert_eq!(second.state_count(), at_stop, "stopped exactly at its bound");
        assert!(!explored_all(&second, at_stop));
    }

    /// The lockout canary ignores every bit of I41, not only bit 0: with I41 = 2 (bit 1 locks
    /// the coordinate-system variables such as I5100, SRM p.57) a write of I5100 takes effect
    /// under the canary and is ignored without it. (cargo-mutants: `1 << bit` turned to
    /// `1 >> bit`, which left the canary blind to every bit but 0, and its test, which locks
    /// with bit 0, passing.)
    #[test]
    fn the_lockout_canary_ignores_a_lock_by_any_bit_of_i41() {
        let cfg = config("lockout");
        let mut start = State { controller: Controller::power_on(&cfg), violations: 0 };
        start.controller.i41 = 2;
        let write = Event::Command(HostCommand::parse("I5100=1").unwrap());
        let honest = WatchdogModel::new(cfg.clone());
        assert_eq!(honest.step(&start, &write).1.controller.i_variable(5100), None, "locked: ignored");
        let canary = WatchdogModel { canary: Some(Canary::LockoutIgnored), ..WatchdogModel::new(cfg) };
        assert_eq!(canary.step(&start, &write).1.controller.i_variable(5100), Some(1), "the canary lets it through");
        // Only a running card's lockout: a tripped card stays silent and unchanged even so, or
        // the canary would break a second sentence (UM p.215) and blur what its test shows.
        // (cargo-mutants: the canary's guard turned to `true`.)
        let mut tripped = start.clone();
        tripped.controller.trip = Some(crate::controller::TripCause::StrobeTimeout);
        assert_eq!(canary.step(&tripped, &write).1.controller.i_variable(5100), None, "tripped: unchanged");
        // And only locked writes: an unlocked one leaves the state the honest model leaves,
        // down to the entry a write of 0 removes. (cargo-mutants: `&` turned to `|`.)
        let mut unlocked = start;
        unlocked.controller.i41 = 0;
        let zero = Event::Command(HostCommand::parse("I5100=0").unwrap());
        assert!(canary.step(&unlocked, &zero).1 == honest.step(&unlocked, &zero).1, "unlocked: as the model");
    }
}
