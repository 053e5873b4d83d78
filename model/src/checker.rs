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
//! simulated one plain servo cycle at a time.

use crate::controller::Controller;
use crate::monitor::{Check, MONITORS};
use crate::properties::{Expectation, STATE_PROPERTIES};
use pmacwd_specs::check::ChecksumTarget;
use pmacwd_specs::config::ModelConfig;
use pmacwd_specs::vocab::event::{Event, Reply};
use pmacwd_specs::vocab::Observation;
use stateright::{Checker, Model, Property};
use std::time::{Duration, Instant};

/// A checked state: the controller plus the sticky failures of the transition monitors.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct State {
    pub controller: Controller,
    /// Bit k set: monitor k of [`MONITORS`] has seen a violating transition.
    pub violations: u32,
}

/// Hashing is a third of the checker's time, and SipHash pays per `write` call: the state is fed
/// as a handful of packed words instead of field by field. Every field goes in, so states that
/// are equal hash equally, as `Hash` requires; `hash_feeds_every_field` below checks that.
impl std::hash::Hash for State {
    fn hash<H: std::hash::Hasher>(&self, h: &mut H) {
        let c = &self.controller;
        let e = &c.checksum;
        let s = &c.status;
        let flags = [
            s.rti_reentry,
            s.rti_warning,
            s.servo_error,
            s.dpram_error,
            s.flash_error,
            s.plc_buffer_open,
            s.motion_buffer_open,
            c.supply_low,
            c.bootstrap,
        ]
        .iter()
        .fold(0u64, |acc, b| acc << 1 | u64::from(*b));
        let trip = match c.trip {
            None => 0u64,
            Some(crate::controller::TripCause::Undervoltage) => 1,
            Some(crate::controller::TripCause::StrobeTimeout) => 2,
        };
        let area = |a: ChecksumTarget| match a {
            ChecksumTarget::Firmware => 1u64,
            ChecksumTarget::UserProgram => 2,
        };
        let recovered = match c.ghost.recovered_by {
            None => 0u64,
            Some(pmacwd_specs::check::ResetKind::Init) => 1,
            Some(pmacwd_specs::check::ResetKind::Power) => 2,
        };
        let words: [u64; 8] = [
            (c.counter as u32 as u64) << 32 | c.counter_min as u32 as u64,
            u64::from(c.cycles_since_strobe) << 32 | u64::from(c.rti_phase) << 16 | u64::from(c.i40),
            u64::from(c.rti_remaining) << 32 | u64::from(c.background_credit),
            u64::from(c.load.motors) << 48
                | u64::from(c.load.plc0_units) << 32
                | u64::from(c.load.background_units) << 16,
            u64::from(c.i8) << 56 | u64::from(c.i41) << 48 | flags << 16 | trip << 8 | recovered,
            area(e.area) << 60
                | e.error.map_or(0, area) << 56
                | u64::from(e.position) << 48
                | u64::from(e.firmware) << 24
                | u64::from(e.firmware_reference) << 16
                | u64::from(e.program) << 8
                | u64::from(e.program_reference),
            u64::from(c.servo_cycles) << 32 | u64::from(self.violations),
            u64::from(c.ghost.cycles_since_background) << 32 | c.ghost.last_reload as u32 as u64,
        ];
        let mut bytes = [0u8; 64];
        for (chunk, w) in bytes.chunks_exact_mut(8).zip(words) {
            chunk.copy_from_slice(&w.to_le_bytes());
        }
        h.write(&bytes);
        for (n, v) in &c.other_i_variables {
            h.write_u16(*n);
            h.write_i64(*v);
        }
    }
}

#[derive(Clone, Debug, PartialEq, Eq, Hash)]
pub enum Action {
    Do(Event),
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
}

/// Deliberate bugs that the checker must catch (the canary tests).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Canary {
    /// I41 lockout is ignored: locked writes take effect.
    LockoutIgnored,
    /// A restored supply undoes an undervoltage trip, as if the trip were not latched.
    SupplyRestoreUntrips,
}

/// Longest jump, in servo cycles, before the checker gives up looking for a change.
const JUMP_CYCLES_MAX: u32 = 1 << 20;

/// What the environment can react to; time advances between changes of this.
pub fn signature(cfg: &ModelConfig, c: &Controller) -> impl PartialEq {
    (c.trip, c.counter > 0, c.counter >= 0, c.background_possible(), c.status_words(cfg))
}

impl WatchdogModel {
    pub fn new(cfg: ModelConfig) -> Self {
        WatchdogModel { cfg, canary: None, detailed: false }
    }

    /// Advances servo cycle by servo cycle (monitors included) up to the first cycle whose
    /// [`signature`] differs, or the cycle before it; returns the cycles taken and the state.
    /// Gives up after [`JUMP_CYCLES_MAX`] cycles.
    pub fn advance_to_change(&self, state: &State, just_before: bool) -> (u32, State) {
        let start = signature(&self.cfg, &state.controller);
        let mut current = state.clone();
        for n in 1..=JUMP_CYCLES_MAX {
            let (_, next) = self.step(&current, &Event::Servo { cycles: 1 });
            if signature(&self.cfg, &next.controller) != start {
                return if just_before { (n - 1, current) } else { (n, next) };
            }
            current = next;
        }
        (JUMP_CYCLES_MAX, current)
    }

    /// The concrete event an action stands for in `state`, and the state after it.
    pub fn perform(&self, state: &State, action: &Action) -> (Event, Reply, State) {
        match action {
            Action::Do(e) => {
                let (reply, next) = self.step(state, e);
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
        let cfg = &self.cfg;
        let prev = &state.controller;
        let mut next = State { controller: prev.clone(), violations: state.violations };
        let reply = match event {
            Event::Servo { cycles } => {
                for _ in 0..*cycles {
                    let before = next.controller.clone();
                    let report = next.controller.servo_cycle(cfg);
                    for (k, m) in MONITORS.iter().enumerate() {
                        if let Check::Cycle(f) = m.check {
                            if !f(cfg, &before, report, &next.controller) {
                                next.violations |= 1 << k;
                            }
                        }
                    }
                }
                Reply::None
            }
            _ => next.controller.apply(cfg, event),
        };
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
            _ => {}
        }
        for (k, m) in MONITORS.iter().enumerate() {
            if let Check::Event(f) = m.check {
                if !f(cfg, prev, event, reply, &next.controller) {
                    next.violations |= 1 << k;
                }
            }
        }
        (reply, next)
    }
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
        // Commands reach a tripped card too: it must stay silent.
        for cmd in &cfg.commands {
            actions.push(Action::Do(Event::Command(cmd.clone())));
        }
        for mv in &cfg.supply_millivolts {
            let low = *mv < cfg.supply_min_millivolts;
            if low != c.supply_low {
                actions.push(Action::Do(Event::Supply { millivolts: *mv }));
            }
        }
        for reset in &cfg.resets {
            actions.push(Action::Do(Event::Reset(*reset)));
        }
    }

    fn next_state(&self, state: &State, action: Action) -> Option<State> {
        Some(self.perform(state, &action).2)
    }

    fn format_action(&self, action: &Action) -> String {
        match action {
            Action::Do(e) => e.to_string(),
            Action::ServoToNextChange => "servo interrupts up to the next change".into(),
            Action::ServoToJustBeforeChange => "servo interrupts up to just before the next change".into(),
        }
    }

    /// stateright looks every property up by name in a SipHash-keyed map for every state it
    /// visits, so it gets short ids (`p00`, `p01`, ...) instead of the sentences, and, unless
    /// `detailed`, the `always` properties as two conjunctions (every monitor, every state
    /// property): 19 lookups per state instead of 51. [`WatchdogModel::check`] re-runs in detail
    /// when a conjunction fails, so each property still gets its own verdict and counterexample.
    fn properties(&self) -> Vec<Property<Self>> {
        if !self.detailed {
            let mut v: Vec<Property<Self>> = vec![
                Property::always(PROPERTY_IDS[0], |_, s: &State| s.violations == 0),
                Property::always(PROPERTY_IDS[1], |m, s: &State| {
                    STATE_PROPERTIES.iter().filter(|p| p.expectation == Expectation::Always).all(|p| (p.holds)(m, s))
                }),
            ];
            for p in STATE_PROPERTIES.iter().filter(|p| p.expectation == Expectation::Sometimes) {
                v.push(Property::sometimes(PROPERTY_IDS[v.len()], p.holds));
            }
            return v;
        }
        let mut v: Vec<Property<Self>> =
            MONITORS.iter().enumerate().map(|(k, _)| Property::always(PROPERTY_IDS[k], MONITOR_HOLDS[k])).collect();
        for p in STATE_PROPERTIES {
            let id = PROPERTY_IDS[v.len()];
            v.push(match p.expectation {
                Expectation::Always => Property::always(id, p.holds),
                Expectation::Sometimes => Property::sometimes(id, p.holds),
            });
        }
        v
    }
}

fn monitor_holds<const K: usize>(_: &WatchdogModel, s: &State) -> bool {
    s.violations & (1 << K) == 0
}

const MONITOR_HOLDS: [fn(&WatchdogModel, &State) -> bool; 32] = [
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
];

const _: () = assert!(MONITORS.len() <= MONITOR_HOLDS.len(), "one violation bit per monitor");

/// The ids stateright knows the properties by, in [`property_table`] order.
const PROPERTY_IDS: [&str; 64] = [
    "p00", "p01", "p02", "p03", "p04", "p05", "p06", "p07", "p08", "p09", "p10", "p11", "p12", "p13", "p14", "p15",
    "p16", "p17", "p18", "p19", "p20", "p21", "p22", "p23", "p24", "p25", "p26", "p27", "p28", "p29", "p30", "p31",
    "p32", "p33", "p34", "p35", "p36", "p37", "p38", "p39", "p40", "p41", "p42", "p43", "p44", "p45", "p46", "p47",
    "p48", "p49", "p50", "p51", "p52", "p53", "p54", "p55", "p56", "p57", "p58", "p59", "p60", "p61", "p62", "p63",
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
        if self.detailed {
            return self.check_detailed(threads);
        }
        let (cfg, canary) = (self.cfg.clone(), self.canary);
        let start = Instant::now();
        let checker = self.checker().threads(threads).spawn_bfs().join();
        let duration = start.elapsed();
        let discoveries = checker.discoveries();
        if discoveries.contains_key(PROPERTY_IDS[0]) || discoveries.contains_key(PROPERTY_IDS[1]) {
            // Some `always` property fails: check each one on its own, for its verdict and its own
            // shortest counterexample.
            let mut report = WatchdogModel { cfg, canary, detailed: true }.check_detailed(threads);
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
                    Expectation::Sometimes => {
                        let found = discoveries.get(PROPERTY_IDS[2 + sometimes_seen]);
                        sometimes_seen += 1;
                        (found.is_some() || !applicable, found.map(|p| model.replay(&p.clone().into_actions())))
                    }
                };
                info.result(holds, applicable, path)
            })
            .collect();
        RunReport {
            configuration: model.cfg.configuration.clone(),
            profile: model.cfg.profile.name.clone(),
            states: checker.unique_state_count(),
            depth: checker.max_depth(),
            duration,
            properties,
        }
    }

    /// One stateright property per named property.
    fn check_detailed(self, threads: usize) -> RunReport {
        let configuration = self.cfg.configuration.clone();
        let profile = self.cfg.profile.name.clone();
        let start = Instant::now();
        let checker = self.checker().threads(threads).spawn_bfs().join();
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
    use std::hash::{Hash, Hasher};

    fn hash(s: &State) -> u64 {
        let mut h = std::collections::hash_map::DefaultHasher::new();
        s.hash(&mut h);
        h.finish()
    }

    /// The packed hash must see every field: change each one alone and the hash must change.
    /// (Equal hashes for unequal states would make the checker skip states it never saw.)
    #[test]
    fn hash_feeds_every_field() {
        let spec = pmacwd_specs::Spec::embedded().unwrap();
        let cfg = ModelConfig::from_spec(&spec, "timing", &spec.profiles.default_profile()).unwrap();
        let base = State { controller: Controller::power_on(&cfg), violations: 0 };
        type Edit = (&'static str, fn(&mut State));
        let edits: Vec<Edit> = vec![
            ("trip", |s| s.controller.trip = Some(crate::controller::TripCause::StrobeTimeout)),
            ("supply_low", |s| s.controller.supply_low = true),
            ("bootstrap", |s| s.controller.bootstrap = true),
            ("counter", |s| s.controller.counter -= 1),
            ("counter_min", |s| s.controller.counter_min -= 1),
            ("cycles_since_strobe", |s| s.controller.cycles_since_strobe += 1),
            ("rti_phase", |s| s.controller.rti_phase += 1),
            ("rti_remaining", |s| s.controller.rti_remaining += 1),
            ("background_credit", |s| s.controller.background_credit += 1),
            ("load.motors", |s| s.controller.load.motors += 1),
            ("load.plc0_units", |s| s.controller.load.plc0_units += 1),
            ("load.background_units", |s| s.controller.load.background_units += 1),
            ("i8", |s| s.controller.i8 += 1),
            ("i40", |s| s.controller.i40 += 1),
            ("i41", |s| s.controller.i41 += 1),
            ("other_i_variables", |s| {
                s.controller.other_i_variables.insert(130, 1);
            }),
            ("rti_reentry", |s| s.controller.status.rti_reentry = true),
            ("rti_warning", |s| s.controller.status.rti_warning = true),
            ("servo_error", |s| s.controller.status.servo_error = true),
            ("dpram_error", |s| s.controller.status.dpram_error = true),
            ("flash_error", |s| s.controller.status.flash_error = true),
            ("plc_buffer_open", |s| s.controller.status.plc_buffer_open = true),
            ("motion_buffer_open", |s| s.controller.status.motion_buffer_open = true),
            ("checksum.area", |s| s.controller.checksum.area = ChecksumTarget::UserProgram),
            ("checksum.position", |s| s.controller.checksum.position += 1),
            ("checksum.error", |s| s.controller.checksum.error = Some(ChecksumTarget::Firmware)),
            ("checksum.firmware", |s| s.controller.checksum.firmware ^= 1),
            ("checksum.firmware_reference", |s| s.controller.checksum.firmware_reference ^= 1),
            ("checksum.program", |s| s.controller.checksum.program ^= 1),
            ("checksum.program_reference", |s| s.controller.checksum.program_reference ^= 1),
            ("servo_cycles", |s| s.controller.servo_cycles += 1),
            ("ghost.cycles_since_background", |s| s.controller.ghost.cycles_since_background += 1),
            ("ghost.last_reload", |s| s.controller.ghost.last_reload += 1),
            ("ghost.recovered_by", |s| s.controller.ghost.recovered_by = Some(pmacwd_specs::check::ResetKind::Init)),
            ("violations", |s| s.violations = 1),
        ];
        for (name, edit) in edits {
            let mut changed = base.clone();
            edit(&mut changed);
            assert_ne!(changed, base, "{name}: the edit must change the state");
            assert_ne!(hash(&changed), hash(&base), "{name} is not hashed");
        }
    }
}
