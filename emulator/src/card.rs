//! One emulated card: the compact core (`pmacwd-core`), its I-variables with their saved
//! values, a clock, and the framing of its answers. The server and the control interface share
//! one `Card` behind a lock; every event that reaches the core also goes to the capture when
//! the session is recorded.

use crate::buffers::BufferId;
use crate::capture::CaptureWriter;
use crate::capture_queue::{CaptureQueue, Record, FINISH_WAIT};
use crate::control::{Control, HELP};
use crate::framing::{framing_write_out_of_range, Answer, Framing};
use crate::memory::{format_value, HostDefaults, Memory};
use crate::motor_status::{hex_words, motor_words};
use crate::mvar::MemoryMap;
use motion::Motors;
use pmacwd_bridge::{core_command, core_event, spec_load};
use pmacwd_core as core;
use pmacwd_core::motion::Program;
use pmacwd_core::IVariableStore;
use pmacwd_specs::check::Load;
use pmacwd_specs::config::ModelConfig;
use pmacwd_specs::grammar::{Addressing, Assigned, Command, Env, Gather, Jog, Listing, VarKind, Vars, VARIABLE_MAX};
use pmacwd_specs::vocab::command::{CsCommand, GlobalCommand, HostCommand, Motion, MotorCommand, Register};
use pmacwd_specs::vocab::event::Event;
use pmacwd_specs::vocab::Buffer;
use pmacwd_trace::jsonl::step_line;
use pmacwd_trace::{Expect, Step, TraceEvent};
use std::io::Write;
use std::time::Instant;

mod line;
mod memory_access;
mod motion;
mod plc;
mod program;

pub use line::{LineRun, Progress, BACKGROUND_WAIT_MAX, RANGE_PART_MAX};

/// What `ver` and `cid` answer: a firmware version (dls-pmaclib checks `^\d+\.\d+`) and a card
/// ID (603382 is the Geo Brick, one of the three dls-pmaclib knows).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Identity {
    pub version: String,
    pub card_id: String,
}

impl Default for Identity {
    fn default() -> Self {
        Identity { version: "1.947".into(), card_id: "603382".into() }
    }
}

/// The fastest servo clock the card runs at. MODEL: the clock registers allow tens of MHz
/// (I7000 = 0, SRM p.214-216), so the bound is the CPU's: on a 20 MHz PMAC the servo update
/// costs about 30 us per motor plus 30 us of general tasks (PMAC Quick Reference Guide p.8),
/// and a Turbo CPU some ten times faster still needs several microseconds per cycle with one
/// motor; 100 kHz is above any rate a real card sustains (the default is 2.26 kHz). For the
/// emulator it bounds the work of time: at about 4 ns a cycle, 100 kHz of servo cycles cost
/// under 0.1% of a core, so the card always catches up with the wall clock.
pub const SERVO_HZ_MAX: u32 = 100_000;

/// The `check.yaml` configuration of the card `pmacwd serve` (and `pmacwd record`) takes by
/// default: i40-zero's card with no background PLC, whose background cycle (housekeeping and
/// command processing, UM p.236-237) completes every servo cycle (MODEL: the configuration's
/// summary says why). A capture of the default card names it, so replay runs the same load.
pub const DEFAULT_CONFIGURATION: &str = "emulated";

/// The servo rate to run at: `flag` (`--servo-hz`), or else the configuration's; refused,
/// with the range, unless it is within the spec's servo clocks (`scheduling.yaml`'s
/// `servo_clock_hz_range`, carried by `model`) and at most [`SERVO_HZ_MAX`], the emulator's own
/// bound (a spec directory given with `--specs` may allow more).
pub fn servo_rate(flag: Option<u32>, model: &ModelConfig) -> Result<u32, String> {
    let (min, max) = (model.servo_hz_range.0.max(1), model.servo_hz_range.1.min(SERVO_HZ_MAX));
    let hz = flag.unwrap_or(model.servo_hz);
    if (min..=max).contains(&hz) {
        return Ok(hz);
    }
    Err(match flag {
        Some(_) => format!(
            "--servo-hz {hz}: the servo clock ranges {min}..{max} Hz (at least {min}, at most {max}; scheduling.yaml's servo_clock_hz_range)"
        ),
        None => format!(
            "configuration {} has a servo clock of {hz} Hz; the emulator's ranges {min}..{max} Hz (give --servo-hz)",
            model.configuration
        ),
    })
}

/// The most servo cycles the card runs in one call (a catch-up with the wall clock, or one
/// chunk of a `step`), so that whoever shares it behind a lock waits at most that long: about
/// 0.4 ms at the measured 4 ns a cycle (a few times a `???` round trip on loopback), while
/// the cost of taking the lock again (well under a microsecond) stays negligible.
pub const CYCLES_PER_HOLD_MAX: u32 = 100_000;

/// How time passes for the card.
#[derive(Clone, Copy, Debug)]
pub enum Clock {
    /// The servo rate against the wall clock (at most [`SERVO_HZ_MAX`]): the cycles due are
    /// run before every request and control command, [`CYCLES_PER_HOLD_MAX`] at a time.
    Wall { start: Instant, servo_hz: u32 },
    /// Only `step` and `servo` on the control interface move time (for tests).
    Virtual,
}

/// I0..I8191, the values saved in flash that a reset restores, and the firmware's defaults
/// that `$$$***` restores (the core holds I8, I40, I41 itself).
pub struct FlashIVariables {
    values: Box<core::AllIVariables>,
    saved: Box<core::AllIVariables>,
    factory: Box<core::AllIVariables>,
    /// The exact values of I-variables last written with a fraction (`I222=0.5`); the core's
    /// store holds whole numbers, this the rest. Saved and restored with the others.
    fractions: std::collections::BTreeMap<u16, f64>,
    saved_fractions: std::collections::BTreeMap<u16, f64>,
    /// The firmware defaults with a fraction (Ixx19 = 0.15625 counts/ms², SRM p.100).
    factory_fractions: std::collections::BTreeMap<u16, f64>,
}

impl FlashIVariables {
    /// `saved`: what flash holds; `factory`: the firmware's defaults (a later value of one
    /// I-variable overrides an earlier one).
    pub fn new(saved: &[(u16, f64)], factory: &[(u16, f64)]) -> FlashIVariables {
        let table = |values: &[(u16, f64)]| {
            let mut t = Box::<core::AllIVariables>::default();
            let mut fractions = std::collections::BTreeMap::new();
            for &(n, v) in values {
                t.write(n, v.trunc() as i64);
                if v.fract() == 0.0 {
                    fractions.remove(&n);
                } else {
                    fractions.insert(n, v);
                }
            }
            (t, fractions)
        };
        let (flash, saved_fractions) = table(saved);
        let (factory, factory_fractions) = table(factory);
        FlashIVariables {
            values: flash.clone(),
            saved: flash,
            factory,
            fractions: saved_fractions.clone(),
            saved_fractions,
            factory_fractions,
        }
    }

    /// I`n`'s exact value when it holds a fraction.
    pub fn fraction(&self, n: u16) -> Option<f64> {
        self.fractions.get(&n).copied()
    }

    /// I`n` = `v`, a fraction kept.
    pub fn write_exact(&mut self, n: u16, v: f64) {
        self.values.write(n, v.trunc() as i64);
        if v.fract() == 0.0 {
            self.fractions.remove(&n);
        } else {
            self.fractions.insert(n, v);
        }
    }

    /// I`n` back to the firmware's default (`I{n}=*`).
    pub fn restore_factory(&mut self, n: u16) {
        let v = self.factory.read(n).unwrap_or(0);
        self.values.write(n, v);
        match self.factory_fractions.get(&n) {
            Some(f) => self.fractions.insert(n, *f),
            None => self.fractions.remove(&n),
        };
    }
}

impl FlashIVariables {
    /// `SAVE`: the values in use become the ones a reset restores (UM p.243).
    pub fn save(&mut self) {
        self.saved.0 = self.values.0;
        self.saved_fractions = self.fractions.clone();
    }
}

/// The emulated card knows every I-variable: one never written holds its firmware default,
/// 0 unless `variables.yaml` gives another (MODEL).
impl IVariableStore for FlashIVariables {
    fn read(&self, n: u16) -> Option<i64> {
        Some(self.values.read(n).unwrap_or(0))
    }
    fn write(&mut self, n: u16, v: i64) -> bool {
        self.fractions.remove(&n);
        self.values.write(n, v)
    }
    /// Nothing is unknown on the emulated card: a command it runs computes every value.
    fn forget(&mut self, _: u16) {}
    fn restore(&mut self) {
        self.values.0 = self.saved.0;
        self.fractions = self.saved_fractions.clone();
    }
    /// `$$$***`: the firmware's defaults in use; what was saved stays in flash, unused, until
    /// the next reset (UM p.243).
    fn factory(&mut self) {
        self.values.0 = self.factory.0;
        self.fractions = self.factory_fractions.clone();
    }
}

/// Expressions are evaluated against the card's own variables (UM p.248).
impl Env for Card {
    fn var(&mut self, kind: VarKind, n: u16, _cs: u8) -> f64 {
        match kind {
            VarKind::I => match self.store.fraction(n) {
                Some(v) if !matches!(n, 8 | 40 | 41) => v,
                _ => self.core.read_i(n, &self.store).unwrap_or(0) as f64,
            },
            VarKind::M => self.m_value(n),
            VarKind::P | VarKind::Q => self.memory.read(kind, n),
        }
    }
}

/// What `$$$***` sets besides `variables.yaml`'s host defaults: the factory framing, I3 = 1
/// (SRM p.37), so that the host that re-initialized the card still gets its lines
/// acknowledged (LF-framed). I6 has no documented Turbo default in the pages this project has
/// and reads 0 like any other I-variable (MODEL).
pub const FACTORY_FRAMING: [(u16, i64); 1] = [(3, 1)];

/// The values saved in flash unless told otherwise: I3 = 2 and I6 = 1, the framing host
/// drivers expect (`DATA CR ... ACK`, `BEL ERRnnn CR`). A factory-new card has I3 = 1
/// (SRM p.37); `--saved I3=1` gives that.
pub const SAVED_DEFAULT: [(u16, i64); 2] = [(3, 2), (6, 1)];

/// Where a card tells its operator what happened to it: a trip (with its cause and the cycle),
/// INIT/, a power cycle, a host's `$$$`, the recovery. `pmacwd serve` prints each line on its
/// standard output (issue 19: a trip used to pass without a word).
pub type Console = Box<dyn FnMut(&str) + Send>;

pub struct Card {
    cfg: core::Config,
    core: core::Core,
    store: FlashIVariables,
    clock: Clock,
    /// Servo cycles run since power-up (wall clock: against `start`).
    cycles: u64,
    /// Background cycles completed since power-up, and the servo cycle (of `cycles`) in which
    /// the last one completed: a host's line waits for the next one (UM p.236, `card/line.rs`).
    /// A reset's end counts as one ([`Card::reset_ends_as_a_background_cycle`]).
    background_cycles: u64,
    background_at: Option<u64>,
    /// Y:$00000B: the longest set of RTI tasks since power-up/reset, in timer increments (UM
    /// p.239, `card/memory_access.rs`).
    rti_time_max: u32,
    identity: Identity,
    /// Where records go when the session is recorded: a queue a thread of its own writes
    /// from, so that the card never waits for the capture's sink (`capture_queue`).
    capture: Option<CaptureQueue>,
    /// P-, Q-, M-variables, feedrate overrides, I-variable formats.
    memory: Memory,
    /// M-variable definitions and the memory words they point at.
    mvars: MemoryMap,
    /// Whether the console has said that writes to the core's registers are not applied.
    register_write_said: bool,
    /// The addressing of callers that keep none of their own ([`Card::line`]); connections
    /// keep theirs ([`Card::line_addressed`]).
    addressing: Addressing,
    /// Where the card's console lines go ([`Card::on_console`]); none by default.
    console: Option<Console>,
    /// Whether the console last saw the card tripped: a line is written when this changes.
    tripped_seen: bool,
    /// Each motor's trajectory, and the home flags the control port placed (`card/motion.rs`).
    motors: Motors,
    /// Motion program and PLC buffers (`buffers.rs`).
    buffers: crate::buffers::Buffers,
    /// Each coordinate system's program as it executes (`card/program.rs`).
    programs: [program::CsRun; 16],
    /// The user PLCs: which are enabled, where each scan stands (`card/plc.rs`).
    plcs: plc::Plcs,
    /// A deliberately broken behaviour (`serve --fault`, `fault.rs`); none by default.
    pub(crate) fault: crate::fault::FaultState,
}

impl Card {
    /// A card with the embedded spec's host-variable defaults (`variables.yaml`); `saved`
    /// overrides them.
    pub fn power_on(cfg: core::Config, saved: &[(u16, i64)], clock: Clock, identity: Identity) -> Card {
        Card::power_on_with(cfg, &HostDefaults::embedded(), saved, clock, identity)
    }

    pub fn power_on_with(
        cfg: core::Config,
        defaults: &HostDefaults,
        saved: &[(u16, i64)],
        clock: Clock,
        identity: Identity,
    ) -> Card {
        // What flash holds: the firmware defaults, then what was saved over them (UM p.243:
        // the last saved values are copied into active memory at power-up).
        let mut flash = defaults.i_defaults.clone();
        flash.extend(saved.iter().map(|&(n, v)| (n, v as f64)));
        let mut factory = defaults.i_defaults.clone();
        factory.extend(FACTORY_FRAMING.iter().map(|&(n, v)| (n, v as f64)));
        Card {
            core: core::Core::power_on(&cfg),
            cfg,
            store: FlashIVariables::new(&flash, &factory),
            clock,
            cycles: 0,
            background_cycles: 1,
            background_at: Some(0),
            rti_time_max: 0,
            identity,
            capture: None,
            memory: Memory::new(defaults),
            mvars: MemoryMap::new(defaults.i_storage_base),
            register_write_said: false,
            addressing: Addressing::default(),
            console: None,
            tripped_seen: false,
            motors: Motors::default(),
            buffers: Default::default(),
            programs: std::array::from_fn(|_| program::CsRun::default()),
            plcs: plc::Plcs::default(),
            fault: Default::default(),
        }
    }

    /// Sends the card's console lines to `console` from now on: one line when the card trips
    /// (when, and why as far as the card can tell), at INIT/, a power cycle or a host's `$$$`,
    /// and when a reset brings a tripped card back.
    pub fn on_console(&mut self, console: Console) {
        self.tripped_seen = self.core.tripped();
        self.console = Some(console);
    }

    fn say(&mut self, line: &str) {
        if let Some(c) = &mut self.console {
            c(line);
        }
    }

    /// The card's time now for a console line.
    fn moment(&self) -> String {
        self.moment_at(self.cycles)
    }

    /// Servo cycle `cycle` since power-up for a console line, and on the wall clock the
    /// seconds it stands for.
    fn moment_at(&self, cycle: u64) -> String {
        match self.clock {
            Clock::Wall { servo_hz, .. } => {
                format!("servo cycle {cycle} ({:.3} s)", cycle as f64 / f64::from(servo_hz.max(1)))
            }
            Clock::Virtual => format!("servo cycle {cycle} (virtual time)"),
        }
    }

    /// [`Card::watch_trip_at`] now.
    fn watch_trip(&mut self, cause: &str) {
        self.watch_trip_at(cause, self.cycles);
    }

    /// Writes a console line when the card has tripped or recovered since the last look;
    /// `cause` says what the card was doing when it tripped, at servo cycle `cycle`.
    fn watch_trip_at(&mut self, cause: &str, cycle: u64) {
        if self.console.is_none() {
            return;
        }
        let now = self.core.tripped();
        if now && !self.tripped_seen {
            let line = format!(
                "TRIPPED at {}: {cause} (Y:$25 = {}, X:$25 = {}); silent until INIT/ or a power cycle (UM p.215)",
                self.moment_at(cycle),
                self.core.counter(),
                self.core.counter_min()
            );
            self.say(&line);
        } else if !now && self.tripped_seen {
            let line = format!("running again at {}: the trip is cleared", self.moment());
            self.say(&line);
        }
        self.tripped_seen = now;
    }

    /// The card `pmacwd serve` emulates by default: the embedded spec's
    /// [`DEFAULT_CONFIGURATION`] under its default profile, with the default saved I-variables.
    pub fn default_card(clock: Clock) -> Card {
        // The configuration and host defaults are resolved once per process, since tests and
        // the card_grammar fuzz target make a fresh card per case (under the fuzzer's
        // sanitizers reading the spec took seconds, and the target ran 119 cases in 10 minutes).
        static DEFAULTS: std::sync::OnceLock<(core::Config, HostDefaults)> = std::sync::OnceLock::new();
        let (cfg, defaults) = DEFAULTS.get_or_init(|| {
            let spec = pmacwd_specs::Spec::embedded().expect("the embedded spec is checked by its own tests");
            let model = pmacwd_specs::config::ModelConfig::from_spec(
                &spec,
                DEFAULT_CONFIGURATION,
                &spec.profiles.default_profile(),
            )
            .expect("the default configuration is one of the embedded spec");
            (pmacwd_bridge::core_config(&model), HostDefaults::from_spec(&spec.variables))
        });
        Card::power_on_with(*cfg, defaults, &SAVED_DEFAULT, clock, Identity::default())
    }

    /// How time passes for this card.
    pub fn clock(&self) -> Clock {
        self.clock
    }

    /// Records every exchange and event from now on, through a writer thread of its own; an
    /// error when the system will not start it.
    pub fn record(&mut self, capture: CaptureWriter<Box<dyn Write + Send>>) -> std::io::Result<()> {
        self.capture = Some(CaptureQueue::start(capture, "pmacwd serve")?);
        Ok(())
    }

    /// Whether the session is being recorded (a sink that failed or stalled stops it).
    pub fn is_recording(&self) -> bool {
        self.capture.as_ref().is_some_and(CaptureQueue::is_recording)
    }

    /// Ends the recording; returns notes that found no step (normally none).
    pub fn finish_recording(&mut self) -> Vec<String> {
        self.finish_recording_counted().1
    }

    /// Ends the recording, waiting at most [`FINISH_WAIT`] for the sink to take what is
    /// queued; returns the steps it wrote and the notes that found no step.
    pub fn finish_recording_counted(&mut self) -> (u64, Vec<String>) {
        match self.capture.take() {
            Some(capture) => capture.finish(FINISH_WAIT),
            None => (0, Vec::new()),
        }
    }

    /// Hands a record to the capture, if the session is recorded (`record` is not built
    /// otherwise). Never waits for the sink.
    fn capture_record(&mut self, record: impl FnOnce() -> Record) {
        if let Some(c) = &mut self.capture {
            c.send(record());
        }
    }

    /// The servo cycles that have passed since power-up by the card's clock: on the wall clock
    /// those due by now, in virtual time those run so far.
    pub fn due_cycles(&self) -> u64 {
        match self.clock {
            Clock::Wall { start, servo_hz } => {
                let due = start.elapsed().as_nanos().saturating_mul(u128::from(servo_hz)) / 1_000_000_000;
                u64::try_from(due).unwrap_or(u64::MAX)
            }
            Clock::Virtual => self.cycles,
        }
    }

    /// Runs the cycles still to run up to `target` (a [`Card::due_cycles`]), at most
    /// [`CYCLES_PER_HOLD_MAX`] of them; `true` once the card has reached `target`. A caller
    /// that holds the card behind a lock releases it between calls, so that no one waits
    /// longer than one call for it.
    pub fn run_towards(&mut self, target: u64) -> bool {
        let n = target.saturating_sub(self.cycles).min(u64::from(self.cycles_per_hold()));
        if n > 0 {
            self.run(n);
        }
        self.cycles >= target
    }

    /// Runs the servo cycles the wall clock says are due, at most [`CYCLES_PER_HOLD_MAX`] of
    /// them: a caller that let the card fall further behind catches up over several calls.
    fn catch_up(&mut self) {
        let target = self.due_cycles();
        self.run_towards(target);
    }

    /// `n` servo cycles, a background cycle completing after each one in which the load allows
    /// it: the `run` step of the trace format. Stops early once tripped (a tripped card does
    /// nothing until INIT/ or power, UM p.215).
    fn run(&mut self, n: u64) {
        self.run_until(n, false);
    }

    /// [`Card::run`], ending after the first servo cycle in which a background cycle completes
    /// when `to_background`; the cycles run.
    fn run_until(&mut self, n: u64, to_background: bool) -> u64 {
        // A program's move or dwell that ends within the cycles ends in its own cycle, so
        // that what the program does next (a stop at its end, which the core hears) happens
        // then, not at the end of the cycles run (`card/program.rs`).
        let mut left = n;
        while left > 0 {
            // A jog that came to rest since (refused by a limit, or arrived) ends in the core
            // first (`card/motion.rs`).
            self.conclude_jogs();
            // With user PLCs running, a cycle at a time: each background cycle's scan sees the
            // motors where that cycle left them (`card/plc.rs`).
            let piece = left.min(self.cycles_to_program_event()).min(if self.plcs_running() { 1 } else { u64::MAX });
            let (ran, background) = self.run_piece(piece, to_background);
            left -= ran;
            if self.core.tripped() || background {
                break;
            }
        }
        n - left
    }

    /// [`Card::run`] for cycles in which no program move or dwell ends before the last; with
    /// `to_background`, only up to the first background cycle. The cycles run, and whether
    /// that background cycle came.
    fn run_piece(&mut self, n: u64, to_background: bool) -> (u64, bool) {
        let first = self.cycles;
        if n > 0 && !self.core.tripped() {
            // The RTI tasks these cycles run, for Y:$00000B (UM p.239).
            self.note_rti_time();
        }
        let mut tripped_at = None;
        let mut ran = n;
        let mut background = false;
        let background_before = self.background_cycles;
        for i in 0..n {
            if self.core.tripped() {
                break;
            }
            self.core.servo_cycle(&self.cfg);
            if self.core.tripped() {
                tripped_at = Some(first.saturating_add(i + 1));
            }
            if self.core.background_possible() {
                self.core.background_cycle(&self.cfg);
                self.background_cycles = self.background_cycles.saturating_add(1);
                self.background_at = Some(first.saturating_add(i + 1));
                if to_background {
                    ran = i + 1;
                    background = true;
                    break;
                }
            }
        }
        // A tripped card's clock runs on: the cycles pass whether or not the core runs them.
        self.cycles = self.cycles.saturating_add(ran);
        if let Some(c) = &mut self.capture {
            c.elapse(ran);
        }
        // The trajectories move for the cycles the card ran (up to a trip, which forces every
        // output off, UM p.215), then stay within what the core says of each motor; the user
        // countdown timers count those cycles (SRM p.176).
        let servoed = tripped_at.map_or(ran, |c| c.saturating_sub(first));
        self.count_down_timers(servoed);
        self.advance_motion(servoed);
        self.sync_motion();
        if tripped_at.is_none() {
            self.conclude_jogs();
            // One PLC scan per background cycle that completed (UM p.236); with PLCs running a
            // piece is one servo cycle, so at most one.
            if self.background_cycles != background_before {
                self.background_plc_scan();
            }
        }
        // The supply trips at its event, not in a servo cycle: a trip found here is the
        // watchdog's, its strobe stopped for want of a background cycle (UM p.215, SRM p.57).
        if let Some(cycle) = tripped_at {
            self.fault.tripped_at(self.core.register(&self.cfg, core::Register::ServoCycles), cycle);
            self.watch_trip_at("the watchdog timer ran out: no background cycle reloaded its counter in time", cycle);
        }
        (ran, background)
    }

    /// MODEL: a card leaves power-up or reset with its watchdog counter loaded as at the end
    /// of a background cycle (UM p.215; the core's restart), and enters its background loop:
    /// a line that arrives in that instant (virtual time) is answered by it, as by a background
    /// cycle that completed in it (`card/line.rs`).
    fn reset_ends_as_a_background_cycle(&mut self) {
        self.background_cycles = self.background_cycles.saturating_add(1);
        self.background_at = Some(self.cycles);
    }

    pub fn tripped(&mut self) -> bool {
        self.catch_up();
        self.core.tripped()
    }

    /// Runs this card with `fault` from now on (`pmacwd serve --fault`, `fault.rs`).
    pub fn inject_fault(&mut self, fault: crate::fault::Fault) {
        self.fault = crate::fault::FaultState::injected(fault);
    }

    fn framing(&self) -> Framing {
        Framing { i3: self.core.read_i(3, &self.store).unwrap_or(0), i6: self.core.read_i(6, &self.store).unwrap_or(0) }
    }

    /// Answers a command line with the card's own addressing (for callers that keep none:
    /// tests, benches); `None` when the card is silent (tripped).
    pub fn line(&mut self, bytes: &[u8]) -> Option<Vec<u8>> {
        let mut addressing = self.addressing;
        let reply = self.line_addressed(bytes, &mut addressing);
        self.addressing = addressing;
        reply
    }

    /// Answers a whole command line from a connection that keeps its own `#n`/`&n`
    /// addressing (SRM p.270: the addressed motor is the port's); `None` when the card is
    /// silent. The reply is built whole: for tests and tools; the server answers a command
    /// at a time ([`Card::line_step`]).
    pub fn line_addressed(&mut self, bytes: &[u8], addressing: &mut Addressing) -> Option<Vec<u8>> {
        let mut run = LineRun::new(bytes);
        let mut out = Vec::new();
        loop {
            match self.line_step(&mut run, addressing, &mut out) {
                Progress::More => {}
                Progress::Waiting(wait) => {
                    if !wait.is_zero() {
                        std::thread::sleep(wait);
                    }
                }
                Progress::Ended | Progress::Failed => return Some(out),
                Progress::Silent => return None,
            }
        }
    }

    /// Whether a PLC or motion program buffer is open (the core's Y:$000006 bits 17 and 19).
    fn buffer_open(&self) -> bool {
        let (_, y) = self.core.status_words(&self.cfg);
        y & (core::bits::PLC_BUFFER_OPEN | core::bits::MOTION_BUFFER_OPEN) != 0
    }

    /// One command's answers: one for most, one per variable for a range, none for a write.
    /// `addressing` is the connection's as it stands after the command was read.
    fn command(&mut self, c: Command, addressing: Addressing, out: &mut Vec<Answer>) {
        let data = Answer::Data;
        match c {
            Command::Version => out.push(data(self.identity.version.clone())),
            Command::CardId => out.push(data(self.identity.card_id.clone())),
            // MODEL: the CPU's part name, as the `???` CPU type bits of this card name it
            // (SRM p.289); the EPICS driver asks right after `cid` and keeps the text.
            Command::Cpu => out.push(data(
                match self.cfg.processor {
                    core::Processor::Dsp56303 => "DSP56303",
                    core::Processor::Dsp56309 => "DSP56309",
                    core::Processor::Dsp56311 => "DSP56311",
                    core::Processor::Dsp56321 => "DSP56321",
                }
                .into(),
            )),
            Command::GlobalStatus => out.push(self.core_answer(&HostCommand::GlobalStatus)),
            // A register of the core through the core; any other word as the memory map holds it.
            Command::ReadHex { space, address } => match Register::at(space, address) {
                Some(r) => out.push(self.core_answer(&HostCommand::ReadHex(r))),
                None => {
                    let word = self.word_at(space, address);
                    out.push(data(format!("{word:06X}")));
                }
            },
            Command::Reset => out.push(self.core_answer(&HostCommand::Reset)),
            Command::Reinitialize => out.push(self.core_answer(&HostCommand::Reinitialize)),
            Command::Checksum => out.push(self.core_answer(&HostCommand::Checksum)),
            Command::WriteIMemory(n, v) => out.push(self.core_answer(&HostCommand::WriteIMemory(n, v))),
            Command::Close => {
                out.push(self.core_answer(&HostCommand::Close));
                self.buffers.close();
            }
            // The buffer takes the program text that follows until CLOSE (`card/line.rs`).
            Command::OpenPlc(n) => {
                out.push(self.core_answer(&HostCommand::Open(Buffer::Plc(n))));
                if self.buffer_open() {
                    self.buffers.open(BufferId::Plc(n));
                }
            }
            Command::OpenProgram(n) => {
                out.push(self.core_answer(&HostCommand::Open(Buffer::Program(n))));
                if self.buffer_open() {
                    self.buffers.open(BufferId::Program(n));
                }
            }
            Command::Feed { cs, percent } => {
                self.memory.set_feed(cs, percent);
                // %0 holds a running program as H does (UM p.217); a non-zero % resumes it.
                let usual = self.cfg.motion.decel_cycles;
                let held = self.core_program(cs) == Program::Held;
                if percent == 0.0 {
                    if let Some(cycles) = self.stop_cycles(&Motion::CoordinateSystem(cs, CsCommand::Feedrate(0))) {
                        self.cfg.motion.decel_cycles = cycles;
                    }
                }
                out.push(self.grammar_answer(&c));
                self.cfg.motion.decel_cycles = usual;
                if percent != 0.0 && held {
                    self.run_program(cs, false);
                }
                self.sync_motion();
            }
            // Motion and stop commands, jogs to a target or by a distance, and homing: the
            // core hears what the vocabulary makes of them (`HostCommand::from_grammar`), and
            // the trajectories follow (`card/motion.rs`). A stop lasts the cycles its motors
            // need at their rates (the core's stop length, chosen per command). `&nE` is the
            // core's `E`: each killed motor of the C.S. closes its loop (MODEL, docs/grammar.md).
            Command::Motion(m) => {
                let usual = self.cfg.motion.decel_cycles;
                if let Some(cycles) = self.stop_cycles(&m) {
                    self.cfg.motion.decel_cycles = cycles;
                }
                // R and S start a program only when the core's was not running already.
                let was_running = match m {
                    Motion::CoordinateSystem(cs, _) => self.core_program(cs) == Program::Running,
                    _ => false,
                };
                out.push(self.grammar_answer(&c));
                self.cfg.motion.decel_cycles = usual;
                match m {
                    Motion::Motor(n, MotorCommand::JogPlus) => self.start_jog(n, Jog::Plus),
                    Motion::Motor(n, MotorCommand::JogMinus) => self.start_jog(n, Jog::Minus),
                    Motion::CoordinateSystem(cs, CsCommand::Run) if !was_running => self.run_program(cs, false),
                    Motion::CoordinateSystem(cs, CsCommand::Step) if !was_running => self.run_program(cs, true),
                    Motion::CoordinateSystem(cs, CsCommand::Quit | CsCommand::EndOfMove) => self.quit_program(cs),
                    Motion::Global(GlobalCommand::QuitAll) => (1..=16).for_each(|cs| self.quit_program(cs)),
                    _ => {}
                }
                self.sync_motion();
            }
            Command::Begin { cs, program } => {
                out.push(self.grammar_answer(&c));
                self.begin_program(cs, program);
            }
            Command::Jog(n, jog) => {
                out.push(self.grammar_answer(&c));
                self.start_jog(n, jog);
                self.sync_motion();
            }
            Command::Home(n) => {
                out.push(self.grammar_answer(&c));
                self.start_home(n);
                self.sync_motion();
            }
            Command::MotorStatus(n) => {
                let bits = self.motion_bits(n);
                let (x, y) = motor_words(self.reported_motor(n).as_ref(), &bits);
                out.push(data(hex_words(&[x, y])));
            }
            Command::CsStatus(cs) => {
                let words = |n: u8| {
                    let bits = self.motion_bits(n);
                    motor_words(self.reported_motor(n).as_ref(), &bits)
                };
                let (a, b, c) = self.cs_status(cs, &words);
                out.push(data(hex_words(&[a, b, c])));
            }
            // Positions, velocities and following errors from the trajectories.
            Command::Position(n) => out.push(self.position_answer(n)),
            Command::Velocity(n) => out.push(self.velocity_answer(n)),
            Command::FollowingError(n) => out.push(self.following_error_answer(n)),
            Command::HomeZero(n) => {
                self.home_zero(n);
                out.push(Answer::Nothing)
            }
            // Reported as `#1`, `&1` (SRM p.270: the motor "reported with the #{constant}
            // command").
            Command::ReportMotor => out.push(data(format!("#{}", addressing.motor))),
            Command::ReportCs => out.push(data(format!("&{}", addressing.cs))),
            Command::FeedRead(cs) => out.push(data(format_value(self.memory.feed(cs)))),
            // MODEL: one table of Q-variables for every C.S. (`memory.rs`), so the C.S. is not used.
            Command::Read { kind, vars, cs: _ } => {
                let Some(numbers) = self.numbers(&vars) else {
                    out.push(Answer::Error(3));
                    return;
                };
                for n in numbers {
                    match kind {
                        VarKind::I => out.push(self.read_i_answer(n)),
                        VarKind::M => self.read_m(n, n, out),
                        VarKind::P | VarKind::Q => out.push(data(format_value(self.memory.read(kind, n)))),
                    }
                }
            }
            Command::Write { kind, vars, value, .. } => {
                let Some(numbers) = self.numbers(&vars) else {
                    out.push(Answer::Error(3));
                    return;
                };
                // The value is computed once, before any variable is written (UM p.248: the
                // expression is evaluated, then assigned).
                let value = match &value {
                    Assigned::Expr(e) => match e.eval(self) {
                        Ok(v) => Some(v),
                        Err(_) => {
                            out.push(Answer::Error(3));
                            return;
                        }
                    },
                    Assigned::Default => None,
                };
                for n in numbers {
                    let answer = match (kind, value) {
                        (VarKind::I, Some(v)) => self.write_i(n, v),
                        (VarKind::I, None) => self.default_i(n),
                        (VarKind::M, Some(v)) => {
                            let mut one = Vec::new();
                            self.write_m(n, n, v, &mut one);
                            one.pop().unwrap_or(Answer::Nothing)
                        }
                        (VarKind::P | VarKind::Q, Some(v)) => {
                            self.memory.write(kind, n, v);
                            Answer::Nothing
                        }
                        // The grammar reads `=*` for I-variables only.
                        (_, None) => Answer::Error(3),
                    };
                    match answer {
                        // A write answers nothing: no answer per variable is kept (a range of
                        // 8,192 made 256 KB of them for every such command).
                        Answer::Nothing => {}
                        Answer::Error(_) => {
                            out.push(answer);
                            return;
                        }
                        Answer::Data(_) => out.push(answer),
                    }
                }
                // A motor deactivated (Ixx00 = 0) stops at once (`card/motion.rs`).
                if kind == VarKind::I {
                    self.sync_motion();
                }
            }
            // No MACRO ring on the emulated card (I20..I23 = $0): a station's variables read
            // 0 and writes change nothing (MODEL: a card without the ring reports its
            // auxiliary-communication error bit; the emulator does not model the ring).
            Command::MacroStation { value, .. } => {
                out.push(if value.is_some() { Answer::Nothing } else { data("0".into()) })
            }
            // M-variables as pointers into memory, and the direct memory write (`card/memory_access.rs`).
            Command::MDefine { first, last, definition } => self.define_m(first, last, definition, out),
            Command::MReport { first, last } => self.report_m(first, last, out),
            Command::MemoryWrite { kind, values } => self.write_memory(kind, values, out),
            // Axis definitions of each C.S. (SRM `#{constant}->`): kept and reported back;
            // a motor with none reports 0 (MODEL: the pages at hand do not print the report
            // of an undefined motor).
            Command::AxisDefine { cs, motor, definition } => {
                self.memory.define_axis(cs, motor, definition);
                out.push(Answer::Nothing)
            }
            Command::AxisReport { cs, motor } => out.push(data(self.memory.axis(cs, motor).unwrap_or("0").to_string())),
            Command::Undefine { cs } => {
                self.memory.undefine(cs);
                out.push(Answer::Nothing)
            }
            // User PLCs 1-31 run in the background (`card/plc.rs`); PLC 0 and compiled PLCs
            // are acknowledged and not run (MODEL there).
            Command::PlcSwitch(p) => {
                self.switch_plcs(p);
                out.push(Answer::Nothing)
            }
            // The stored lines, one answer each (`buffers.rs`, MODEL there for the form).
            // MODEL: no kinematics buffers are kept (`OPEN FORWARD` is not read), so their
            // listings are empty.
            Command::List(l) => {
                let lines = match l {
                    Listing::Program { number, start, length } => {
                        self.buffers.list(BufferId::Program(number), start, length)
                    }
                    Listing::Plc { number, start, length } => self.buffers.list(BufferId::Plc(number), start, length),
                    Listing::Forward { .. } | Listing::Inverse { .. } => &[],
                };
                if lines.is_empty() {
                    out.push(Answer::Nothing);
                }
                out.extend(lines.iter().map(|l| data(l.clone())));
            }
            // Look-ahead buffers and the temporary buffers the EPICS driver's C.S. groups
            // define and delete: nothing the emulator runs uses them.
            Command::DefineLookahead { .. } | Command::DeleteAllTemps => out.push(Answer::Nothing),
            Command::Save => {
                self.store.save();
                self.mvars.save();
                self.buffers.save();
                out.push(Answer::Nothing);
            }
            // Data gathering to the level dls-pmaccontrol uses it: GATHER and ENDGATHER start
            // and stop the function in the core (X:$000006 bit 19, SRM p.289, p.307); the
            // other commands are accepted and LIST GATHER reports no samples (MODEL: nothing
            // the emulator models changes between samples, so there is nothing to gather).
            Command::Gather(Gather::Start) => out.push(self.core_answer(&HostCommand::Gather)),
            Command::Gather(Gather::End) => out.push(self.core_answer(&HostCommand::EndGather)),
            Command::Gather(Gather::Define(_) | Gather::List | Gather::Delete) => out.push(Answer::Nothing),
            Command::Ignored(_) => out.push(Answer::Nothing),
        }
    }

    /// The variables a read or write names; `None` when a computed number is not one.
    fn numbers(&mut self, vars: &Vars) -> Option<Vec<u16>> {
        match vars {
            Vars::Numbers(r) => Some(r.numbers().collect()),
            Vars::Computed(e) => {
                let v = e.eval(self).ok()?.round();
                (0.0..=f64::from(VARIABLE_MAX)).contains(&v).then(|| vec![v as u16])
            }
        }
    }

    /// `In`, as the card prints it under I9 (a fraction as written).
    fn read_i_answer(&mut self, n: u16) -> Answer {
        let i9 = self.core.read_i(9, &self.store).unwrap_or(0);
        match self.core.command(&self.cfg, core::Command::ReadI(n), &mut self.store) {
            core::Reply::Value(v) => match self.store.fraction(n) {
                Some(exact) => Answer::Data(self.memory.format_i_value(n, &format_value(exact), i9)),
                None => Answer::Data(self.memory.format_i(n, v, i9)),
            },
            other => reply_answer(other),
        }
    }

    /// `In={value}`: I8, I40, I41 and the framing variables through the core (their ranges);
    /// any other, past I41's lockout (SRM p.57), with the value as written, fraction and all
    /// (`I222=0.5`: a jog speed under one count per millisecond).
    fn write_i(&mut self, n: u16, v: f64) -> Answer {
        if !v.is_finite() || v.abs() >= 9.0e15 {
            return Answer::Error(3);
        }
        if matches!(n, 8 | 40 | 41) || v.fract() == 0.0 {
            // MODEL (as the vocabulary): a fraction written to I8, I40 or I41 is rounded.
            return self.core_answer(&HostCommand::WriteI(n, v.round() as i64));
        }
        if framing_write_out_of_range(n, v.round() as i64) || matches!(n, 3 | 6) {
            return Answer::Error(3);
        }
        if !self.core.write_locked(n) {
            self.store.write_exact(n, v);
        }
        Answer::Nothing
    }

    /// `In=*`: the factory default (SRM on-line commands), past I41's lockout.
    fn default_i(&mut self, n: u16) -> Answer {
        match n {
            8 | 40 | 41 => self.core_answer(&HostCommand::DefaultI(n)),
            n => {
                if !self.core.write_locked(n) {
                    self.store.restore_factory(n);
                }
                Answer::Nothing
            }
        }
    }

    /// A command the vocabulary maps for the core.
    fn grammar_answer(&mut self, c: &Command) -> Answer {
        match HostCommand::from_grammar(c) {
            Ok(h) => self.core_answer(&h),
            Err(_) => Answer::Error(3),
        }
    }

    /// A command for the core, checked as before for what the core cannot hold.
    fn core_answer(&mut self, command: &HostCommand) -> Answer {
        if let Some(a) = self.fault.before(command, &mut self.core, &self.cfg, &mut self.store, self.cycles) {
            return a;
        }
        // I3 and I6 range 0..3; a write outside it is refused and changes nothing (MODEL,
        // `framing::FRAMING_VALUE_MAX`). Neither lies in a range I41 locks (SRM p.57).
        if let HostCommand::WriteI(n, v) | HostCommand::WriteIMemory(n, v) = command {
            if framing_write_out_of_range(*n, *v) {
                return Answer::Error(3);
            }
        }
        let reply = self.core.command(&self.cfg, core_command(command), &mut self.store);
        if matches!(command, HostCommand::Reset | HostCommand::Reinitialize) && reply != core::Reply::Silence {
            self.memory.reset();
            // UM p.239: Y:$00000B is the largest RTI time "since the last power-up/reset".
            self.rti_time_max = 0;
            self.reset_ends_as_a_background_cycle();
            self.motors.reset();
            self.reset_programs();
            match command {
                HostCommand::Reinitialize => {
                    self.mvars.reinitialize();
                    self.buffers.reinitialize();
                }
                _ => {
                    self.mvars.reset();
                    self.buffers.reset();
                }
            }
            self.reset_plcs();
            let line = match command {
                HostCommand::Reinitialize => {
                    format!("$$$*** from a host at {}: the card resets to its factory defaults", self.moment())
                }
                _ => format!("$$$ from a host at {}: the card resets", self.moment()),
            };
            self.say(&line);
        }
        self.fault.after(command, reply_answer(reply), &mut self.core, &self.cfg, &mut self.store)
    }

    /// The answer to a control character sent on its own (VR_CTRL_RESPONSE): read as a line
    /// of one character, so the global stop commands go to the core and are acknowledged and
    /// others are ERR003.
    pub fn control_character(&mut self, c: u8) -> Option<Vec<u8>> {
        if self.tripped() {
            return None;
        }
        self.line(&[c])
    }

    /// A host's write of 0 to bit 22 (SRM p.289), from `card/memory_access.rs`: the core's event,
    /// recorded in a capture as a control port's `clear_rti_reentry` is.
    fn host_clears_rti_reentry(&mut self) {
        let event = Event::ClearRtiReentry;
        self.core.apply(&self.cfg, core_event(&event), &mut self.store);
        let step = Step { event: TraceEvent::Model(event), expect: Expect::default(), note: None };
        self.capture_record(|| Record::Event(step));
    }

    /// A control-interface command; the reply line without its newline.
    pub fn control(&mut self, c: Control) -> String {
        self.catch_up();
        let event = match c {
            Control::Load { motors, plc0_units, background_units } => {
                let now = spec_load(self.core.load());
                Event::Load(Load {
                    motors: motors.unwrap_or(now.motors),
                    plc0_units: plc0_units.unwrap_or(now.plc0_units),
                    background_units: background_units.unwrap_or(now.background_units),
                })
            }
            Control::Starve => {
                // PLC 0 takes exactly the CPU the servo leaves in each RTI period (UM p.236:
                // the RTI runs every I8+1 servo cycles), so the background never gets any.
                let period =
                    u32::try_from(self.core.read_i(8, &self.store).unwrap_or(0)).unwrap_or(0).saturating_add(1);
                let fill = self
                    .core
                    .spare_units()
                    .saturating_mul(period)
                    .saturating_sub(u32::from(self.cfg.move_planning_units));
                Event::Load(Load { plc0_units: u16::try_from(fill).unwrap_or(u16::MAX), ..spec_load(self.core.load()) })
            }
            Control::Supply { millivolts } => Event::Supply { millivolts },
            Control::Reset(r) => Event::Reset(r),
            Control::ChecksumFault(t) => Event::ChecksumFault(t),
            Control::ClearRtiReentry => Event::ClearRtiReentry,
            Control::Step { .. } | Control::Servo { .. } if matches!(self.clock, Clock::Wall { .. }) => {
                return "error: step and servo move virtual time; this card runs on the wall clock (serve --virtual-time)"
                    .into();
            }
            Control::Step { cycles } => {
                // A caller that shares the card splits long steps (`CYCLES_PER_HOLD_MAX`).
                self.run(u64::from(cycles));
                return Card::step_reply(cycles);
            }
            Control::Servo { cycles } => Event::Servo { cycles },
            Control::State => return format!("ok {}", self.state()),
            Control::HomeFlag { motor, at } => return self.place_home_flag(motor, at),
            Control::FollowingError { motor, counts } => return self.inject_following_error(motor, counts),
            Control::Limit { motor, plus, on } => return self.set_limit_input(motor, plus, on),
            Control::Help => return format!("ok {HELP}"),
        };
        self.core.apply(&self.cfg, core_event(&event), &mut self.store);
        if let Event::Servo { cycles } = event {
            self.cycles = self.cycles.saturating_add(u64::from(cycles));
        }
        let cause = match &event {
            Event::Reset(r) => {
                // A power cycle or INIT/ restarts the card as `$$$` does: active memory is
                // volatile and the saved values come back (UM p.243).
                self.memory.reset();
                self.rti_time_max = 0;
                self.reset_ends_as_a_background_cycle();
                self.motors.reset();
                self.reset_programs();
                self.mvars.reset();
                self.buffers.reset();
                self.reset_plcs();
                let faults: Vec<&str> =
                    [(r.dpram_fault, "DPRAM fault"), (r.flash_fault, "flash fault"), (r.bootstrap, "bootstrap mode")]
                        .into_iter()
                        .filter_map(|(on, what)| on.then_some(what))
                        .collect();
                let what = match r.kind {
                    pmacwd_specs::check::ResetKind::Init => "INIT/ pulse",
                    pmacwd_specs::check::ResetKind::Power => "power cycle",
                };
                let line = if faults.is_empty() {
                    format!("{what} at {}: the card restarts", self.moment())
                } else {
                    format!(
                        "{what} at {}: the card restarts, its reset-time checks finding {}",
                        self.moment(),
                        faults.join(", ")
                    )
                };
                self.say(&line);
                "the card tripped again as it restarted".to_string()
            }
            Event::Supply { millivolts } => {
                format!("the logic supply fell to {millivolts} mV, below its minimum of about 4.75 V")
            }
            Event::Servo { .. } => {
                "the watchdog timer ran out: no background cycle reloaded its counter in time".to_string()
            }
            other => format!("after the control event `{other}`"),
        };
        self.watch_trip(&cause);
        self.sync_motion();
        let step = Step { event: TraceEvent::Model(event), expect: Expect::default(), note: None };
        let line = step_line(&step);
        self.capture_record(|| Record::Event(step));
        format!("ok {line}")
    }

    /// The reply to `step N`: `ok` and the trace step (also when the server ran it in chunks).
    pub fn step_reply(cycles: u32) -> String {
        let step = Step { event: TraceEvent::Run { cycles }, expect: Expect::default(), note: None };
        format!("ok {}", step_line(&step))
    }

    /// What a bench can see of the card, on one line.
    pub fn state(&mut self) -> String {
        self.catch_up();
        let (x, y) = self.core.status_words(&self.cfg);
        let l = self.core.load();
        format!(
            "tripped={} counter={} counter_min={} status={:06X}{:06X} cycles={} load=motors:{},plc0_units:{},background_units:{}",
            self.core.tripped(),
            self.core.counter(),
            self.core.counter_min(),
            x,
            y,
            self.cycles,
            l.motors,
            l.plc0_units,
            l.background_units
        )
    }
}

/// Where `CLOSE` (or its abbreviation `CLS`) starts in a line, as a word of its own.
fn find_close(line: &[u8]) -> Option<usize> {
    let upper = line.to_ascii_uppercase();
    ["CLOSE", "CLS"]
        .iter()
        .filter_map(|w| {
            upper.windows(w.len()).enumerate().find_map(|(i, win)| {
                let before = i == 0 || !upper[i - 1].is_ascii_alphanumeric();
                let after = upper.get(i + w.len()).is_none_or(|c| !c.is_ascii_alphanumeric());
                (win == w.as_bytes() && before && after).then_some(i)
            })
        })
        .min()
}

/// The framing-free answer for a core reply.
fn reply_answer(reply: core::Reply) -> Answer {
    match reply {
        core::Reply::None | core::Reply::Ack | core::Reply::Silence => Answer::Nothing,
        core::Reply::Status { x, y } => {
            Answer::Data(String::from_utf8_lossy(&core::Reply::status_text(x, y)).into_owned())
        }
        core::Reply::Bootstrap => Answer::Data("BOOTSTRAP PROM".into()),
        core::Reply::Value(v) => Answer::Data(v.to_string()),
        core::Reply::Hex(v) => Answer::Data(format!("{v:06X}")),
        core::Reply::Error(n) => Answer::Error(n),
        // The emulator answers every command itself before the core could call it the card's.
        core::Reply::CardOwn => Answer::Nothing,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use pmacwd_specs::check::{ResetEvent, ResetKind};

    fn card() -> Card {
        let spec = pmacwd_specs::Spec::embedded().unwrap();
        let cfg =
            pmacwd_specs::config::ModelConfig::from_spec(&spec, "i40-zero", &spec.profiles.default_profile()).unwrap();
        Card::power_on(pmacwd_bridge::core_config(&cfg), &SAVED_DEFAULT, Clock::Virtual, Identity::default())
    }

    #[test]
    fn the_emulator_runs_every_servo_clock_the_embedded_spec_allows_and_no_other() {
        // scheduling.yaml's servo_clock_hz_range is the range `--servo-hz` takes; the emulator
        // bounds it by SERVO_HZ_MAX for its own lock holds, and with the embedded spec that
        // bound must not cut the spec's range short.
        let spec = pmacwd_specs::Spec::embedded().unwrap();
        let model =
            pmacwd_specs::config::ModelConfig::from_spec(&spec, "i40-zero", &spec.profiles.default_profile()).unwrap();
        let (min, max) = model.servo_hz_range;
        assert!(max <= SERVO_HZ_MAX, "the spec allows {max} Hz, the emulator at most {SERVO_HZ_MAX}");
        for hz in [min, model.servo_hz, max] {
            assert_eq!(servo_rate(Some(hz), &model), Ok(hz));
        }
        for hz in [min - 1, max + 1, u32::MAX] {
            let e = servo_rate(Some(hz), &model).unwrap_err();
            assert!(e.contains(&format!("--servo-hz {hz}: the servo clock ranges {min}..{max} Hz")), "{e}");
        }
    }

    #[test]
    fn the_dls_pmaclib_handshake_gets_the_reply_it_checks_for() {
        // dls-pmaclib connects with `i6=1 i3=2 ver` and wants `^\d+\.\d+\s*\r\x06$`.
        assert_eq!(card().line(b"i6=1 i3=2 ver").unwrap(), b"1.947\r\x06");
    }

    #[test]
    fn answers_follow_i3_as_it_stands_after_each_command() {
        let mut c = card();
        assert_eq!(c.line(b"i3=3 I40 i3=2 I40").unwrap(), b"\n0\r0\r\x06");
        assert_eq!(c.line(b"I40 ZZZ I41").unwrap(), b"0\r\x07ERR003\r", "the error ends the line");
        assert_eq!(c.line(&[b'I', 0xC3, b'9']).unwrap(), b"\x07ERR004\r", "bytes above 127");
    }

    #[test]
    fn the_console_tells_the_trip_its_cause_and_cycle_the_reset_and_the_recovery() {
        // `pmacwd serve` used to say nothing when its card tripped or came back (issue 19).
        let lines = std::sync::Arc::new(std::sync::Mutex::new(Vec::<String>::new()));
        let mut c = card();
        let sink = lines.clone();
        c.on_console(Box::new(move |l| sink.lock().unwrap().push(l.to_string())));
        c.control(Control::Starve);
        c.control(Control::Step { cycles: 10_000 });
        c.control(Control::Reset(ResetEvent {
            kind: ResetKind::Init,
            dpram_fault: false,
            flash_fault: false,
            bootstrap: false,
        }));
        // Still starved after INIT/, the card would never answer (`card/line.rs`): a light
        // load first.
        c.control(Control::Load { motors: None, plc0_units: Some(30), background_units: None });
        c.line(b"$$$");
        c.control(Control::Supply { millivolts: 4500 });
        let lines = lines.lock().unwrap();
        assert_eq!(lines.len(), 5, "{lines:#?}");
        // Starved from cycle 0: the counter (4096) runs out and the hardware delay (45 cycles)
        // passes, UM p.215: the trip's own cycle, not the end of the step that found it.
        assert!(lines[0].starts_with("TRIPPED at servo cycle 4142 "), "{}", lines[0]);
        assert!(lines[0].contains("no background cycle reloaded its counter"), "{}", lines[0]);
        assert!(lines[1].starts_with("INIT/ pulse at servo cycle 10000"), "{}", lines[1]);
        assert!(lines[2].starts_with("running again"), "{}", lines[2]);
        assert!(lines[3].starts_with("$$$ from a host"), "{}", lines[3]);
        assert!(lines[4].contains("the logic supply fell to 4500 mV"), "{}", lines[4]);
    }

    /// SRM p.289: bit 22 stays set "until the card is reset, or until this bit is manually
    /// changed to 0": an M-variable on X:$6 bit 22 and a direct memory write both clear it;
    /// a write that leaves it 1, or another bit of the word, changes nothing. (Before issue 35
    /// both writes were acknowledged and bit 22 stayed set.)
    #[test]
    fn a_host_write_of_0_to_bit_22_clears_it() {
        let first_char = |c: &mut Card| values(&c.line(b"???").unwrap())[0].chars().next().unwrap();
        let overrun = |c: &mut Card| {
            // PLC 0 outlasting its RTI period (UM p.236) sets bits 22 and 9; then a light load.
            c.control(Control::Load { motors: Some(8), plc0_units: Some(1000), background_units: None });
            c.control(Control::Step { cycles: 6 });
            c.control(Control::Load { motors: Some(8), plc0_units: Some(30), background_units: None });
            c.control(Control::Step { cycles: 6 });
        };
        let mut c = card();
        overrun(&mut c);
        assert_eq!(first_char(&mut c), '4', "bit 22 set by the overrun");
        c.line(b"M1->X:$6,22,1").unwrap();
        c.line(b"M1=1").unwrap();
        assert_eq!(first_char(&mut c), '4', "writing 1 leaves it set");
        c.line(b"M1=0").unwrap();
        assert_eq!(first_char(&mut c), '0', "M1=0 clears it");
        overrun(&mut c);
        assert_eq!(first_char(&mut c), '4');
        c.line(b"WX:$6,0").unwrap();
        assert_eq!(first_char(&mut c), '0', "a direct memory write of 0 clears it");
    }

    #[test]
    fn a_starved_card_goes_silent_until_init() {
        let mut c = card();
        assert!(c.control(Control::parse("starve").unwrap()).starts_with("ok {\"load\""));
        // I40 = 0: 4096 (UM p.215) cycles of counter, then the hardware delay.
        assert!(c.control(Control::parse("step 5000").unwrap()).starts_with("ok {\"run\":5000}"));
        assert_eq!(c.line(b"???"), None);
        c.control(Control::parse("init").unwrap());
        // The load stays: the card, starved again, would trip before its background answers.
        c.control(Control::parse("plc0 30").unwrap());
        assert_eq!(c.line(b"???").unwrap().last(), Some(&0x06), "answers again after INIT/");
    }

    #[test]
    fn a_reset_restores_the_saved_framing() {
        let mut c = card();
        assert_eq!(c.line(b"i3=0 I40").unwrap(), b"0\r", "no ACK under I3 = 0");
        assert_eq!(c.line(b"$$$").unwrap(), b"\x06", "$$$ restores the saved I3 = 2");
    }

    #[test]
    fn one_call_runs_at_most_one_chunk_of_the_cycles_due() {
        // A card far behind the wall clock (here ten seconds at the fastest servo clock: a
        // million cycles) catches up CYCLES_PER_HOLD_MAX cycles per call, so that a caller
        // holding it behind a lock can let others in between chunks; the calls still reach
        // the target exactly.
        let start = Instant::now() - std::time::Duration::from_secs(10);
        let mut c = card();
        c.clock = Clock::Wall { start, servo_hz: SERVO_HZ_MAX };
        let target = c.due_cycles();
        assert!(target >= 1_000_000);
        assert!(!c.run_towards(target));
        assert_eq!(c.cycles, u64::from(CYCLES_PER_HOLD_MAX));
        let mut calls = 1;
        loop {
            calls += 1;
            if c.run_towards(target) {
                break;
            }
        }
        assert_eq!(c.cycles, target);
        assert_eq!(calls, target.div_ceil(u64::from(CYCLES_PER_HOLD_MAX)));
    }

    #[test]
    fn a_framing_write_outside_0_to_3_is_refused_and_the_framing_stays() {
        // `I3=4` used to be stored, and its low bits (0) then framed every reply: no ACK ever
        // again, so clients hung. Now it is ERR003 (MODEL, FRAMING_VALUE_MAX) and I3 stays 2.
        let mut c = card();
        assert_eq!(c.line(b"I3=4").unwrap(), b"\x07ERR003\r");
        assert_eq!(c.line(b"I6=-1").unwrap(), b"\x07ERR003\r");
        assert_eq!(c.line(b"I3 I6").unwrap(), b"2\r1\r\x06", "both unchanged, the line acknowledged");
        assert_eq!(c.line(b"I3=3 I3=2").unwrap(), b"\x06", "0..3 are written as before");
    }

    fn values(reply: &[u8]) -> Vec<String> {
        let text = String::from_utf8_lossy(reply);
        assert!(text.ends_with('\x06'), "acknowledged: {text:?}");
        text.trim_end_matches('\x06').split('\r').filter(|v| !v.is_empty()).map(str::to_string).collect()
    }

    #[test]
    fn the_dls_pmaccontrol_poll_line_gets_its_52_values() {
        // commsThread.py: 4 values, then 6 per motor; it takes I65 as the identity, the
        // second as `???`, the third as `&1??` (18 hex digits), the fourth as `%`.
        let mut line = String::from("i65???&1??%");
        for m in 1..=8 {
            line += &format!("#{m}?PVF m{m}90 p99");
        }
        let v = values(&card().line(line.as_bytes()).unwrap());
        assert_eq!(v.len(), 52, "{v:?}");
        assert_eq!(v[0], "0", "I65: identity not set");
        assert_eq!(v[1].len(), 12, "??? is 12 hex digits");
        // &1??: no program; X, Y and Z the feedrate axes (SRM p.285 bits 19, 21, 23; MODEL:
        // the power-up FRAX, card/program.rs); not in position, every motor killed.
        assert_eq!(v[2], "A80000000000000000");
        assert_eq!(v[3], "100", "feedrate override 100%");
        // Motor 1: activated, open loop (killed at power-up), in C.S. 1; at 0; no amp fault.
        assert_eq!(&v[4..10], ["850000008000", "0", "0", "0", "0", "0"]);
    }

    #[test]
    fn what_the_gui_reads_on_connect_is_what_a_card_answers() {
        let mut c = card();
        // I10: the servo period the GUI divides by (SRM p.42-43 default).
        assert_eq!(values(&c.line(b"I10").unwrap()), ["3713707"]);
        // I20..I23: no MACRO IC, in hex because I9 = 2 (SRM p.42), so the GUI polls 8 axes.
        assert_eq!(values(&c.line(b"i20 i21 i22 i23 ").unwrap()), ["$0", "$0", "$0", "$0"]);
        assert_eq!(values(&c.line(b"i20..23").unwrap()), ["$0", "$0", "$0", "$0"]);
        assert_eq!(values(&c.line(b"cid").unwrap()), ["603382"]);
    }

    #[test]
    fn a_hex_write_reads_back_in_hex_and_save_keeps_it_over_a_reset() {
        let mut c = card();
        assert_eq!(c.line(b"I124=$20001 I130=1000").unwrap(), b"\x06");
        assert_eq!(values(&c.line(b"I124 I130").unwrap()), ["$20001", "1000"]);
        assert_eq!(c.line(b"SAVE").unwrap(), b"\x06");
        c.line(b"I130=5");
        c.line(b"$$$");
        assert_eq!(values(&c.line(b"I124 I130").unwrap()), ["$20001", "1000"], "the saved values");
    }

    #[test]
    fn dollar_star_star_star_puts_the_factory_defaults_in_use_and_dollar_brings_the_saved_ones_back() {
        // UM p.243: re-initialization copies the firmware defaults into active memory; what
        // SAVE stored stays in flash, unused, until the next reset.
        let mut c = card();
        c.line(b"I130=1000 I40=7 SAVE");
        c.line(b"$$$***");
        // I3 = 1 (SRM p.37, the factory framing): each answer LF DATA CR, the line ends in LF.
        assert_eq!(c.line(b"I130 I40 I3 I10").unwrap(), b"\n2000\r\n0\r\n1\r\n3713707\r\n", "I130's factory default");
        c.line(b"I3=2");
        c.line(b"$$$");
        assert_eq!(values(&c.line(b"I130 I3").unwrap()), ["1000", "2"], "the saved values, again");
    }

    #[test]
    fn the_cpu_type_bits_of_global_status_are_the_configured_processor() {
        // SRM p.289: X21 and Y21 say which of the four CPU options the card has; `pmacwd serve
        // --processor` sets it in the core's configuration.
        let mut cfg = Card::default_card(Clock::Virtual).cfg;
        assert_eq!(
            values(&Card::power_on(cfg, &SAVED_DEFAULT, Clock::Virtual, Identity::default()).line(b"???").unwrap()),
            ["001000000000"]
        );
        cfg.processor = core::Processor::Dsp56321;
        let mut c = Card::power_on(cfg, &SAVED_DEFAULT, Clock::Virtual, Identity::default());
        assert_eq!(values(&c.line(b"???").unwrap()), ["201000200000"]);
    }

    #[test]
    fn a_memory_write_changes_an_i_variable_i41_locks_and_checksum_answers_the_reference() {
        // SRM p.57: I41 locks the {I-variable}={value} command, not a memory write.
        let mut c = card();
        c.line(b"I41=1 I130=5");
        assert_eq!(values(&c.line(b"I130").unwrap()), ["2000"], "locked: the factory default stays");
        assert_eq!(c.line(b"<MEMORY-WRITE I130=5>").unwrap(), b"\x06");
        assert_eq!(values(&c.line(b"I130").unwrap()), ["5"], "written past I41");
        // UM p.217, SRM p.295: CHECKSUM and CHKS answer the reference (the model's token).
        assert_eq!(values(&c.line(b"CHECKSUM CHKS").unwrap()), ["000000", "000000"]);
    }

    #[test]
    fn an_m_variable_assignment_and_a_direct_memory_write_change_an_i_variable_i41_locks() {
        // SRM p.57: "I41 does not prevent changes to an I-variable by means of an M-variable
        // assignment or a direct memory write command", here in the syntax a host sends, with
        // I130's storage at D:$002082 (variables.yaml, i_variable_storage: MODEL).
        let mut c = card();
        c.line(b"I41=1 I130=5");
        assert_eq!(values(&c.line(b"I130").unwrap()), ["2000"], "the on-line command is ignored");
        assert_eq!(c.line(b"M100->D:$002082 M100=9").unwrap(), b"\x06");
        assert_eq!(values(&c.line(b"I130 M100").unwrap()), ["9", "9"], "the M-variable reached I130");
        assert_eq!(c.line(b"WD:$2082,11").unwrap(), b"\x06");
        assert_eq!(values(&c.line(b"I130").unwrap()), ["11"], "and so did the direct memory write");
        // Each half of the storage on its own: Y is the low 24 bits, X the high (MODEL).
        c.line(b"M101->Y:$2082,0,24,S M102->X:$2082,0,24,S WY:$2082,-2");
        assert_eq!(values(&c.line(b"I130 M101 M102").unwrap()), ["16777214", "-2", "0"]);
        c.line(b"WX:$2082,$FFFFFF");
        assert_eq!(values(&c.line(b"I130").unwrap()), ["-2"], "X holds the sign of the 48-bit value");
        // A field of a word: bits 4..7 of I130's low word.
        c.line(b"I41=0 I130=0 M103->Y:$2082,4,4 M103=19");
        assert_eq!(values(&c.line(b"I130 M103").unwrap()), ["48", "3"], "19 rolled over to 4 bits is 3");
    }

    #[test]
    fn under_the_modulo_reading_an_out_of_range_assignment_rolls_over_and_under_error_answers_err003() {
        // UM p.243 ("Limited Range"): no error, the value rolled over by modulo arithmetic
        // (profile um-243-modulo, as `pmacwd serve --profile um-243-modulo` runs it); the MODEL
        // reading `error` (the default um-215's): ERR003 and the value kept. The emulator takes
        // the reading from the profile's choice, through the core.
        let spec = pmacwd_specs::Spec::embedded().unwrap();
        for (profile, reading) in [
            ("um-215", pmacwd_specs::profiles::OutOfRangeAssignment::Error),
            ("um-243-modulo", pmacwd_specs::profiles::OutOfRangeAssignment::Modulo),
        ] {
            let cfg =
                pmacwd_specs::config::ModelConfig::from_spec(&spec, "i40-zero", &spec.profiles.get(profile).unwrap())
                    .unwrap();
            assert_eq!(cfg.out_of_range(), reading, "{profile}");
            let mut c =
                Card::power_on(pmacwd_bridge::core_config(&cfg), &SAVED_DEFAULT, Clock::Virtual, Identity::default());
            let modulo = reading == pmacwd_specs::profiles::OutOfRangeAssignment::Modulo;
            for (write, read, rolled) in [("I41=17", "I41", "1"), ("I40=65538", "I40", "2"), ("I8=257", "I8", "1")] {
                let before = values(&c.line(read.as_bytes()).unwrap());
                let reply = c.line(write.as_bytes()).unwrap();
                let after = values(&c.line(read.as_bytes()).unwrap());
                if modulo {
                    assert_eq!((reply.as_slice(), after), (&b"\x06"[..], vec![rolled.to_string()]), "{write}");
                } else {
                    assert!(reply.starts_with(b"\x07ERR003"), "{write}: {reply:?}");
                    assert_eq!(after, before, "{write} changes nothing");
                }
            }
        }
    }

    #[test]
    fn m_variables_read_the_watchdog_registers_as_rh_reads_them_and_writes_there_are_not_applied() {
        // UM p.246: an M-variable reads the register it points at. The firmware owns the
        // watchdog's registers: a write is not applied (MODEL), and the console says so once.
        let mut c = card();
        let said = std::sync::Arc::new(std::sync::Mutex::new(Vec::<String>::new()));
        let log = said.clone();
        c.on_console(Box::new(move |l: &str| log.lock().unwrap().push(l.to_string())));
        c.line(b"M125->X:$25,0,24,S M126->Y:$000025,24,24,S M127->Y:$25,0,24,U");
        let rh = values(&c.line(b"RHX:$25 RHY:$25").unwrap());
        let m = values(&c.line(b"M125 M126 M127").unwrap());
        let signed = |h: &str| {
            let v = i64::from_str_radix(h, 16).unwrap();
            if v >= 1 << 23 {
                v - (1 << 24)
            } else {
                v
            }
        };
        assert_eq!(m[0], signed(&rh[0]).to_string());
        assert_eq!(m[1], signed(&rh[1]).to_string());
        assert_eq!(m[2], i64::from_str_radix(&rh[1], 16).unwrap().to_string(), "U reads the bits unsigned");
        assert_eq!(c.line(b"M127=5 WX:$25,7").unwrap(), b"\x06");
        assert_eq!(values(&c.line(b"RHX:$25").unwrap()), [rh[0].clone()], "X:$25 unchanged");
        let lines = said.lock().unwrap().clone();
        assert_eq!(lines.iter().filter(|l| l.contains("not applied")).count(), 1, "{lines:?}");
    }

    #[test]
    fn definitions_report_back_survive_a_reset_once_saved_and_go_at_reinitialization() {
        // PMAC-SRM p.253: `M{n}->` reports the definition, the whole statement when I9 bit 0
        // is set; UM p.243: SAVE keeps what $$$ brings back, $$$*** puts the defaults in use.
        let mut c = card();
        c.line(b"M1..2->X:$10000,8,8,U M3->*");
        assert_eq!(values(&c.line(b"M1..3->").unwrap()), ["X:$010000,8,8,U", "X:$010000,8,8,U", "*"]);
        c.line(b"I9=1");
        assert_eq!(values(&c.line(b"M1->").unwrap()), ["M1->X:$010000,8,8,U"]);
        c.line(b"I9=0 WX:$10000,$1234 M4->X:$10000,0,24");
        assert_eq!(values(&c.line(b"M1 M4").unwrap()), ["18", "4660"], "bits 8..15 of $001234");
        c.line(b"SAVE M5->D:$10000");
        c.line(b"$$$");
        assert_eq!(values(&c.line(b"M1-> M5-> M4").unwrap()), ["X:$010000,8,8,U", "*", "0"], "words cleared");
        c.line(b"$$$***");
        c.line(b"I3=2 I6=1"); // the factory framing ends answers with LF, not ACK
        assert_eq!(values(&c.line(b"M1->").unwrap()), ["*"]);
        c.line(b"$$$");
        assert_eq!(values(&c.line(b"M1->").unwrap()), ["X:$010000,8,8,U"], "flash kept it");
    }

    #[test]
    fn unreadable_definitions_and_memory_writes_are_err003_and_run_nothing_after() {
        let mut c = card();
        for bad in ["M1->X:$25", "M1->TWD:4,0,8.3,U", "M1->X:$1000000,0", "WX:$2082", "WX:$FFFFFF,1,2", "M1->Z:0"] {
            let line = format!("{bad} P1=7");
            assert_eq!(c.line(line.as_bytes()).unwrap(), b"\x07ERR003\r", "{bad}");
            assert_eq!(values(&c.line(b"P1").unwrap()), ["0"], "{bad}: P1=7 after it did not run");
        }
    }

    #[test]
    fn p_variables_hold_values_and_a_reset_clears_them() {
        let mut c = card();
        c.line(b"P1=-2.5 P2=$10");
        assert_eq!(values(&c.line(b"P1 P2 P1..2").unwrap()), ["-2.5", "16", "-2.5", "16"]);
        c.line(b"$$$");
        assert_eq!(values(&c.line(b"P1").unwrap()), ["0"]);
        // So do INIT/ and a power cycle (UM p.243: active memory is volatile), M-variable
        // definitions included, back to the saved ones.
        c.line(b"P1=3 M1->X:$10000,0,24 WX:$10000,7");
        assert_eq!(values(&c.line(b"P1 M1").unwrap()), ["3", "7"]);
        for kind in [ResetKind::Init, ResetKind::Power] {
            c.control(Control::Reset(ResetEvent { kind, dpram_fault: false, flash_fault: false, bootstrap: false }));
            assert_eq!(values(&c.line(b"P1 M1-> M1").unwrap()), ["0", "*", "0"], "{kind:?}");
            c.line(b"P1=3 M1->X:$10000,0,24 WX:$10000,7");
        }
    }

    #[test]
    fn jog_home_kill_and_kill_all_are_acknowledged_and_reach_the_core() {
        let mut c = card();
        for line in [&b"#1J^1000"[..], b"#1HM", b"#1J/", b"#1J=0", b"#1K", b"\x0b", b"&1%50"] {
            assert_eq!(c.line(line).unwrap(), b"\x06", "{}", line.escape_ascii());
        }
        assert_eq!(values(&c.line(b"&1%").unwrap()), ["50"]);
        assert_eq!(c.control_character(0x0b).unwrap(), b"\x06", "CTRL-K through the control-character request");
        assert_eq!(c.control_character(0x02).unwrap(), b"\x07ERR003\r", "CTRL-B is not emulated");
    }

    #[test]
    fn closing_a_loop_enables_the_amplifier_and_kill_all_disables_every_one() {
        // The core's motion (UM p.217: J/ on a killed motor closes its loop; UM p.319: a kill
        // opens it and disables the amplifier), read back as the GUI and EPICS read it.
        let mut c = card();
        let amp = |c: &mut Card, m: u8| {
            let w = u64::from_str_radix(&values(&c.line(format!("#{m}?").as_bytes()).unwrap())[0], 16).unwrap();
            (w >> 24) & (1 << 19) != 0
        };
        c.line(b"#1J/#2J/");
        assert!(amp(&mut c, 1) && amp(&mut c, 2) && !amp(&mut c, 3));
        assert_eq!(c.line(b"\x0b").unwrap(), b"\x06");
        assert!((1..=8).all(|m| !amp(&mut c, m)), "KILL ALL");
    }

    #[test]
    fn a_pmc_download_is_acknowledged_line_by_line() {
        // What dls-pmaccontrol's "load pmc" sends: settings, M-variable definitions, a PLC
        // (program text while the buffer is open), SAVE.
        let mut c = card();
        for line in [
            "I130=2000",
            "M190->Y:$078F00,0,24,S",
            "OPEN PLC 1 CLEAR",
            "DISABLE PLC 1",
            "IF (M1=1)",
            "  P1=P1+1",
            "ENDIF",
            "CLOSE",
            "ENABLE PLC 1",
        ] {
            assert_eq!(c.line(line.as_bytes()).unwrap(), b"\x06", "{line}");
        }
        assert_eq!(values(&c.line(b"P1 M190").unwrap()), ["0", "0"], "program text is not run");
        assert_eq!(c.line(b"IF (M1=1)").unwrap(), b"\x07ERR003\r", "outside a buffer it is not a command");
        // One line opening, filling and closing a buffer, then an on-line command.
        assert_eq!(values(&c.line(b"OPEN PROG 1 CLEAR X100 CLOSE I130").unwrap()), ["2000"]);
    }

    #[test]
    fn gather_macro_station_and_save_commands_get_the_answers_a_download_expects() {
        let mut c = card();
        for line in ["define gather 1000", "gather", "endgather", "list gather", "delete gather", "SAVE"] {
            assert_eq!(c.line(line.as_bytes()).unwrap(), b"\x06", "{line}");
        }
        assert_eq!(values(&c.line(b"ms0,i910").unwrap()), ["0"]);
    }

    #[test]
    fn addressing_persists_between_lines_of_one_caller() {
        let mut c = card();
        let mut a = Addressing::default();
        c.line_addressed(b"#5&2", &mut a);
        assert_eq!(values(&c.line_addressed(b"# &", &mut a).unwrap()), ["#5", "&2"]);
        let mut other = Addressing::default();
        assert_eq!(values(&c.line_addressed(b"#", &mut other).unwrap()), ["#1"], "another connection's own");
    }
}
