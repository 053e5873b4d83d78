//! Generated lockstep traces: random event sequences, weighted toward the edges where
//! implementations go wrong, run on an implementation and the reference model side by side.
//!
//! Edges the weights aim at: the counter near 0 and the strobe gap near the hardware delay
//! ([`Choice::ServoToCounter`] and [`Choice::ServoPastStrobeStop`] land a few cycles either side),
//! long idle gaps (which an implementation may fast-forward), I40 = 0 and small I40 values,
//! RTI overruns (the configurations' heavy PLC 0 loads and I8 writes), trips by undervoltage
//! and starvation, INIT/ and power cycles with reset-time faults and bootstrap, locked
//! I-variable ranges under several I41 values, checksum faults, and motion: every stop command
//! of UM p.217 and the commands that start motion, with encoder inputs lost and restored
//! (servo runs then meet stops under way, background cycles the encoder-loss PLC); every
//! (configuration, profile) pair of the spec is drawn.
//!
//! A failing case is shrunk by proptest to a minimal one and returned as a [`Counterexample`],
//! which writes itself as a YAML trace (docs/trace-format.md) that reproduces it: the
//! regression files of `conformance/regressions/`.

use crate::lockstep::{Disagreement, Pair};
use crate::subject::{ModelSubject, Subject};
use pmacwd_model::motion::Program;
use pmacwd_specs::check::{ChecksumTarget, ProfileSelection, ResetEvent, ResetKind};
use pmacwd_specs::config::ModelConfig;
use pmacwd_specs::vocab::command::{CsCommand, HostCommand, Motion, MotorCommand};
use pmacwd_specs::vocab::event::Event;
use pmacwd_specs::vocab::observation::MotorState;
use pmacwd_specs::{Spec, SpecError};
use pmacwd_trace::{self as trace, Expect, Step, Trace, TraceEvent};
use proptest::prelude::*;
use proptest::test_runner::{Config as RunnerConfig, RngAlgorithm, TestError, TestRng, TestRunner};
use std::cell::{Cell, RefCell};

/// Every (configuration, profile) pair of the spec, with a 24-bit servo counter so long runs
/// do not wrap X:$0 into the small widths the model checker uses.
pub fn all_configs(spec: &Spec) -> Result<Vec<ModelConfig>, SpecError> {
    let mut v = Vec::new();
    for name in spec.check.configurations.keys() {
        for p in spec.profiles.all() {
            let mut cfg = ModelConfig::from_spec(spec, name, &p)?;
            cfg.servo_counter_mask = 0xFF_FFFF;
            v.push(cfg);
        }
    }
    Ok(v)
}

/// Host command lines the generator draws from: reads and writes in and out of every lockout
/// range, I41 values that lock some ranges and an out-of-range one, I40 and I8 near their
/// edges, the watchdog and checksum registers, buffers, `$$$` and an unknown command; memory
/// writes past I41 into a locked range, I40 and I41 (SRM p.57), `$$$***` (UM p.243) and
/// `CHECKSUM` (UM p.217), `GATHER` and `ENDGATHER` (SRM p.289).
pub const COMMANDS: &[&str] = &[
    "???",
    "I130",
    "I130=7",
    // The card's own commands and defaults (the grammar reads them; the model has no rule
    // for their answers, and a write it cannot compute makes I130 the card's own).
    "I130=*",
    "I40=*",
    "I130=I130*1.25",
    "CPU",
    "#1P",
    "&1#1->",
    "I5100=3",
    "I5100",
    "I6800=1",
    "I8000=2",
    "I8191=5",
    "I41=1",
    "I41=3",
    "I41=15",
    "I41=0",
    "I41=16",
    "I40=1",
    "I40=3",
    "I40=0",
    "I40=65535",
    "I40=65536",
    "I8=0",
    "I8=1",
    "I8=3",
    "I8=60",
    "I8=300",
    "RHX:$25",
    "RHY:$25",
    "RHX:$0",
    "RHX:$1080",
    "RHX:$1090",
    "RHX:$6",
    "RHY:$6",
    "OPEN PLC 1",
    "OPEN PROG 1",
    "CLOSE",
    "$$$",
    "$$$***",
    "CHECKSUM",
    // SRM p.289, p.307: data gathering on and off (bit 19).
    "GATHER",
    "ENDGATHER",
    "<MEMORY-WRITE I130=9>",
    "<MEMORY-WRITE I40=2>",
    "<MEMORY-WRITE I41=3>",
    "HELLO",
];

/// Motion command lines the generator draws from (UM p.217, UM p.319): every row of the stop
/// table and every command that starts motion, on motors #1 and #2 and coordinate systems &1
/// and &2 (the `motion` configuration has one motor in each, every other configuration its
/// motors in &1), a motor and a coordinate system beyond every configuration's (#9, &3), and
/// the global control characters; B and R often enough that programs run and stops meet them;
/// `E` (the EPICS driver's enable, MODEL: each killed motor of the C.S. closes its loop) on &1,
/// &2 and &3.
pub const MOTION_COMMANDS: &[&str] = &[
    "#1J/", "#1J+", "#1J-", "#1J=", "#1K", "#2J/", "#2J+", "#2K", "#9J/", "#9K", "&1B", "&1B", "&1R", "&1R", "&1S",
    "&1A", "&1Q", "&1/", "&1H", "&1\\", "&1%0", "&1%100", "&2B", "&2R", "&2S", "&2A", "&2Q", "&2/", "&2H", "&3B",
    "&3R", "<CTRL-A>", "<CTRL-Q>", "<CTRL-O>", "<CTRL-K>", "&1E", "&2E", "&3E",
];

/// One step of a generated trace, resolved against the model's state when it is applied.
#[derive(Clone, Debug)]
pub enum Choice {
    Event(Event),
    /// The configuration's load number `i` (modulo how many it has).
    Load(usize),
    /// A background cycle, if one can complete (otherwise nothing happens).
    Background,
    /// Servo cycles until the counter is `offset` from 0 (at least one cycle).
    ServoToCounter(i32),
    /// Servo cycles until the strobe has been stopped for the hardware delay plus `offset`.
    ServoPastStrobeStop(i32),
    /// The next command toward a running program in coordinate system `cs` (1 or 2): `#nJ/`
    /// on its lowest-numbered killed motor (J/ closes a killed motor's loop), else `&csB` when
    /// no program is pointed at, else `&csR`. A program runs only when every motor of its C.S.
    /// is closed-loop at rest (UM p.319), which random commands rarely achieve with eight motors
    /// in &1 before the card trips; the stop commands then meet running programs.
    TowardProgram(u8),
    /// A stop command of UM p.217 for an executing program: row `i` of the table (`i` modulo
    /// 11) sent to the lowest coordinate system whose program executes (to its first motor for
    /// J/ and K; as it is for the global ones), or, when no program executes, a step
    /// [`Choice::TowardProgram`] in &1 or &2 (by `i`'s parity). Without it each row met an
    /// executing program only 1 to 18 times in 10,000 traces (`pmacwd conform --seed 1`):
    /// random commands rarely leave a program running before the next stop or trip.
    StopProgram(usize),
}

/// Row `i` (modulo 11) of UM p.217's stop table aimed at the program of coordinate system `cs`,
/// whose first motor is `motor`.
pub fn program_stop(i: usize, cs: u8, motor: u8) -> Motion {
    use pmacwd_specs::vocab::command::GlobalCommand;
    match i % 11 {
        0 => Motion::Motor(motor, MotorCommand::JogStop),
        1 => Motion::CoordinateSystem(cs, CsCommand::Abort),
        2 => Motion::Global(GlobalCommand::AbortAll),
        3 => Motion::CoordinateSystem(cs, CsCommand::Quit),
        4 => Motion::Global(GlobalCommand::QuitAll),
        5 => Motion::CoordinateSystem(cs, CsCommand::EndOfMove),
        6 => Motion::CoordinateSystem(cs, CsCommand::Hold),
        7 => Motion::Global(GlobalCommand::HoldAll),
        8 => Motion::CoordinateSystem(cs, CsCommand::QuickStop),
        9 => Motion::Motor(motor, MotorCommand::Kill),
        _ => Motion::Global(GlobalCommand::KillAll),
    }
}

/// A generated case: which (configuration, profile) pair, and the steps.
#[derive(Clone, Debug)]
pub struct Generated {
    pub which: usize,
    pub choices: Vec<Choice>,
}

fn choice() -> impl Strategy<Value = Choice> {
    let reset = (any::<bool>(), prop::bool::weighted(0.2), prop::bool::weighted(0.2), prop::bool::weighted(0.1))
        .prop_map(|(power, d, f, b)| {
            Choice::Event(Event::Reset(ResetEvent {
                kind: if power { ResetKind::Power } else { ResetKind::Init },
                dpram_fault: d,
                flash_fault: f,
                bootstrap: b,
            }))
        });
    prop_oneof![
        6 => (1u32..=4).prop_map(|c| Choice::Event(Event::Servo { cycles: c })),
        2 => (5u32..=200).prop_map(|c| Choice::Event(Event::Servo { cycles: c })),
        1 => (200u32..=20_000).prop_map(|c| Choice::Event(Event::Servo { cycles: c })),
        2 => (-2i32..=2).prop_map(Choice::ServoToCounter),
        1 => (-2i32..=2).prop_map(Choice::ServoPastStrobeStop),
        8 => Just(Choice::Background),
        2 => (0usize..4).prop_map(Choice::Load),
        5 => prop::sample::select(COMMANDS).prop_map(|t| Choice::Event(Event::Command(
            HostCommand::parse(t).expect("the generator's commands parse")
        ))),
        4 => prop::sample::select(MOTION_COMMANDS).prop_map(|t| Choice::Event(Event::Command(
            HostCommand::parse(t).expect("the generator's motion commands parse")
        ))),
        1 => prop::sample::select(&[4500u32, 4749, 4750, 5000][..]).prop_map(|mv| Choice::Event(Event::Supply { millivolts: mv })),
        1 => reset,
        1 => prop::sample::select(&[ChecksumTarget::Firmware, ChecksumTarget::UserProgram][..])
            .prop_map(|a| Choice::Event(Event::ChecksumFault(a))),
        1 => Just(Choice::Event(Event::ClearRtiReentry)),
        3 => (1u8..=2).prop_map(Choice::TowardProgram),
        8 => (0usize..11).prop_map(Choice::StopProgram),
        2 => (1u8..=3, any::<bool>())
            .prop_map(|(motor, lost)| Choice::Event(Event::EncoderInput(pmacwd_specs::vocab::EncoderInput { motor, lost }))),
        2 => (1u8..=3, any::<bool>())
            .prop_map(|(motor, fault)| Choice::Event(Event::AmplifierFault(pmacwd_specs::vocab::AmplifierFaultInput { motor, fault }))),
    ]
}

/// Cases over `configs` pairs with 1..=`max_len` steps.
pub fn strategy(configs: usize, max_len: usize) -> impl Strategy<Value = Generated> {
    (0..configs.max(1), prop::collection::vec(choice(), 1..=max_len.max(1)))
        .prop_map(|(which, choices)| Generated { which, choices })
}

/// Longest servo run a targeted choice asks for (the I40 = 0 reset value plus any delay fits).
const TARGETED_CYCLES_MAX: i64 = 100_000;

/// The event a choice stands for now, or `None` when it does nothing (a background cycle that
/// cannot complete).
fn resolve<S: Subject>(pair: &Pair<S>, cfg: &ModelConfig, choice: &Choice) -> Result<Option<Event>, Disagreement> {
    let card = pair.model.controller();
    let servo = |cycles: i64| Event::Servo { cycles: cycles.clamp(1, TARGETED_CYCLES_MAX) as u32 };
    Ok(match choice {
        Choice::Event(e) => Some(e.clone()),
        Choice::Load(i) => Some(Event::Load(cfg.loads[i % cfg.loads.len()])),
        Choice::Background => pair.background_possible()?.then_some(Event::Background),
        Choice::ServoToCounter(offset) => Some(servo(i64::from(card.counter) - i64::from(*offset))),
        Choice::ServoPastStrobeStop(offset) => {
            Some(servo(i64::from(card.counter.max(0)) + i64::from(cfg.hardware_delay_cycles) + i64::from(*offset)))
        }
        Choice::StopProgram(i) => {
            let executing = card.axes.programs().iter().position(|p| p.executing());
            match executing.and_then(|cs| u8::try_from(cs + 1).ok()) {
                Some(cs) => {
                    let motor = (1..=cfg.motion.motors).find(|m| cfg.motion.coordinate_system(*m) == cs).unwrap_or(1);
                    Some(Event::Command(HostCommand::Motion(program_stop(*i, cs, motor))))
                }
                None => resolve(pair, cfg, &Choice::TowardProgram(if i % 2 == 0 { 1 } else { 2 }))?,
            }
        }
        Choice::TowardProgram(cs) => {
            let setup = &cfg.motion;
            let killed = (1..=setup.motors)
                .filter(|m| setup.coordinate_system(*m) == *cs)
                .find(|m| card.axes.motors()[usize::from(*m) - 1].state == MotorState::Killed);
            let program = card.axes.programs().get(usize::from(*cs) - 1).copied().unwrap_or_default();
            let m = match (killed, program) {
                (Some(n), _) => Motion::Motor(n, MotorCommand::JogStop),
                (None, Program::None) => Motion::CoordinateSystem(*cs, CsCommand::Begin),
                (None, _) => Motion::CoordinateSystem(*cs, CsCommand::Run),
            };
            Some(Event::Command(HostCommand::Motion(m)))
        }
    })
}

/// Runs `choices` on a fresh pair; returns the events applied, or the disagreement and (when
/// `record`) the events up to and including the one that diverged.
pub fn run_choices<S: Subject>(
    cfg: &ModelConfig,
    choices: &[Choice],
    record: bool,
    observe: &mut dyn FnMut(&ModelConfig, &Event, &ModelSubject),
) -> Result<u64, (Disagreement, Vec<Event>)> {
    let mut pair = Pair::<S>::power_on(cfg);
    if record {
        pair = pair.recording();
    }
    for c in choices {
        let outcome = resolve(&pair, cfg, c).and_then(|e| match e {
            Some(e) => pair.apply(&e).map(|_| observe(cfg, &e, &pair.model)),
            None => Ok(()),
        });
        if let Err(d) = outcome {
            let mut events = pair.applied.take().unwrap_or_default();
            // `Pair::apply` compares whether a background cycle can complete after every
            // event, so a disagreement in it ends the trace at the event that caused it, and a
            // fixed implementation replays the trace. Only at power-up, before any event, is
            // it found by asking: that trace is the one `background` step (a trace needs a
            // step), which a fixed implementation refuses as one neither side can complete.
            if d.event == Event::Background && events.is_empty() {
                events.push(Event::Background);
            }
            return Err((d, events));
        }
    }
    Ok(pair.count)
}

/// A shrunk divergence, ready to be saved as a regression trace.
#[derive(Clone, Debug)]
pub struct Counterexample {
    pub configuration: String,
    pub profile: String,
    pub events: Vec<Event>,
    pub disagreement: Disagreement,
    /// The seed of the run that found it.
    pub seed: u64,
}

impl Counterexample {
    /// The trace that reproduces it; its last step carries the disagreement as a note.
    pub fn to_trace(&self) -> Trace {
        let last = self.events.len().saturating_sub(1);
        Trace {
            version: trace::FORMAT_VERSION,
            description: format!(
                "Lockstep regression: found by generated traces (seed {}), shrunk to {} events. {}",
                self.seed,
                self.events.len(),
                self.disagreement
            ),
            cite: None,
            configuration: self.configuration.clone(),
            profiles: ProfileSelection::Named(vec![self.profile.clone()]),
            steps: self
                .events
                .iter()
                .enumerate()
                .map(|(i, e)| Step {
                    event: TraceEvent::Model(e.clone()),
                    expect: Expect::default(),
                    note: (i == last).then(|| format!("diverged here: {}", self.disagreement.fields.join("; "))),
                })
                .collect(),
        }
    }

    /// A stable file name: configuration, profile and a hash of the events.
    pub fn file_name(&self) -> String {
        // FNV-1a over the events' text: stable across runs and platforms.
        let mut h: u64 = 0xcbf2_9ce4_8422_2325;
        for e in &self.events {
            for b in e.to_string().bytes().chain([b'\n']) {
                h = (h ^ u64::from(b)).wrapping_mul(0x0000_0100_0000_01b3);
            }
        }
        format!("{}-{}-{:08x}.yaml", self.configuration, self.profile, h as u32)
    }
}

/// How a generated run went.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Stats {
    pub traces: u32,
    pub events: u64,
}

/// How far a generated run has come, for a progress display: the traces that passed, and once a
/// trace diverged, the cases tried while shrinking it (up to 50,000 runs of up to `max_len`
/// steps, which can take a while).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct RunProgress {
    pub traces: u32,
    pub shrink_cases: u32,
}

/// A seed for a fresh run (from the clock); runs print it so that any one can be repeated.
pub fn fresh_seed() -> u64 {
    std::time::SystemTime::now().duration_since(std::time::UNIX_EPOCH).map_or(0, |d| d.as_nanos() as u64)
}

/// What to generate.
#[derive(Clone, Copy, Debug)]
pub struct Settings {
    pub cases: u32,
    pub max_len: usize,
    pub seed: u64,
}

/// Runs `settings.cases` generated traces on `S` and the model over `configs`; on a divergence
/// returns the shrunk counterexample. `progress` is called after every case (see [`RunProgress`]);
/// `observe` sees every event applied (and the model after it) in traces that pass.
pub fn run<S: Subject>(
    configs: &[ModelConfig],
    settings: Settings,
    progress: &dyn Fn(RunProgress),
    observe: &mut dyn FnMut(&ModelConfig, &Event, &ModelSubject),
) -> Result<Stats, Box<Counterexample>> {
    let mut seed_bytes = [0u8; 32];
    seed_bytes[..8].copy_from_slice(&settings.seed.to_le_bytes());
    let config = RunnerConfig {
        cases: settings.cases,
        max_shrink_iters: 50_000,
        failure_persistence: None,
        ..RunnerConfig::default()
    };
    let mut runner = TestRunner::new_with_rng(config, TestRng::from_seed(RngAlgorithm::ChaCha, &seed_bytes));
    let stats = Cell::new(Stats::default());
    let observe = RefCell::new(observe);
    let shrinking = Cell::new(false);
    let shrink_cases = Cell::new(0u32);
    let result = runner.run(&strategy(configs.len(), settings.max_len), |g| {
        let cfg = &configs[g.which % configs.len()];
        let mut sink = |c: &ModelConfig, e: &Event, m: &ModelSubject| {
            if !shrinking.get() {
                (observe.borrow_mut())(c, e, m)
            }
        };
        match run_choices::<S>(cfg, &g.choices, false, &mut sink) {
            Ok(events) => {
                if !shrinking.get() {
                    let mut s = stats.get();
                    s.traces += 1;
                    s.events += events;
                    stats.set(s);
                    progress(RunProgress { traces: s.traces, shrink_cases: 0 });
                } else {
                    shrink_cases.set(shrink_cases.get() + 1);
                    progress(RunProgress { traces: stats.get().traces, shrink_cases: shrink_cases.get() });
                }
                Ok(())
            }
            Err((d, _)) => {
                if shrinking.get() {
                    shrink_cases.set(shrink_cases.get() + 1);
                    progress(RunProgress { traces: stats.get().traces, shrink_cases: shrink_cases.get() });
                }
                shrinking.set(true);
                Err(TestCaseError::fail(d.to_string()))
            }
        }
    });
    match result {
        Ok(()) => Ok(stats.get()),
        Err(TestError::Fail(_, g)) => {
            let cfg = &configs[g.which % configs.len()];
            let (disagreement, events) = match run_choices::<S>(cfg, &g.choices, true, &mut |_, _, _| {}) {
                Err(found) => found,
                Ok(_) => unreachable!("a shrunk failing case fails again: lockstep is deterministic"),
            };
            Err(Box::new(Counterexample {
                configuration: cfg.configuration.clone(),
                profile: cfg.profile.name.clone(),
                events,
                disagreement,
                seed: settings.seed,
            }))
        }
        Err(TestError::Abort(reason)) => {
            unreachable!("lockstep cases are never rejected, so proptest cannot abort: {reason}")
        }
    }
}
