//! User PLC programs 1-31 running in the card's background (UM p.236: "Each background cycle,
//! Turbo PMAC will execute one scan (to the end or to an ENDWHILE statement) of a single
//! active interpreted background PLC program"; "In between each scan ... Turbo PMAC will do its
//! general housekeeping, and respond to a host command, if any"). The statements are those of
//! `program.rs`, compiled into jumps by `plc.rs`; this module scans them.
//!
//! - Which run: PLCs enabled by `ENABLE PLC n` (and not disabled since, by a host or by a
//!   PLC's own `DISABLE PLC`), while I5 has its background bit (SRM p.39, I5: "2 Foreground
//!   PLCs off; background PLCs on", 3 both; "an individual PLC program still needs to be
//!   enabled to run"; the Turbo default is 1, `specs/variables.yaml`'s, which leaves
//!   background PLCs off), one per background cycle in turn, lowest number first
//!   (MODEL: the order of the single PLC each cycle runs).
//! - A scan ends at the program's end (the next starts at its top) or at an ENDWHILE (the next
//!   starts at its WHILE): a WHILE loop takes a pass a scan, so no PLC holds the card. MODEL:
//!   a scan runs at most [`OPS_PER_SCAN_MAX`] statements, the next one going on where it
//!   stopped (a card runs a scan to its end; the bound keeps a hostile PLC from holding the
//!   card's lock), and with PLCs running the card runs at most [`PLC_CYCLES_PER_HOLD_MAX`]
//!   servo cycles per hold of its lock.
//! - `COMMAND"..."` (`CMD`) is issued "as if it came from the host (except for addressing modes
//!   and response direction)" (SRM p.421): its commands go through the card's command path,
//!   so a PLC's `CMD"#1K"` or `CMD^K` reaches the core as a host's would, and the capture
//!   records it as an exchange. They are queued and run at the end of the scan (SRM p.422: "If
//!   issued from a PLC program, the command will not be interpreted before the end of the
//!   current scan of the PLC"); a full queue holds the PLC at that statement until there is
//!   room (SRM p.422: "program execution is temporarily halted until the new command can be
//!   placed on the queue"). Plain `COMMAND` "provides no response to any port" (SRM p.421),
//!   so a query (`CMD"P1"`) is not run (MODEL: reading changes nothing and its answer would go
//!   nowhere). A command with no motor or C.S. of its own addresses the PLC's `ADDRESS#n&m`
//!   (SRM p.422: "At power-up/reset, all PLC programs are addressing Motor 1 and C.S.1").
//! - `SEND"..."` goes to no port (MODEL: the emulator's hosts get no unsolicited messages).
//!
//! MODEL, the rest:
//!
//! - PLC 0 is the foreground PLC (SRM p.39, I5 bit 0; UM p.236: it runs every RTI). The
//!   watchdog model's PLC 0 is a CPU load, the control port's `plc0` knob, and a downloaded PLC
//!   0 is kept and listed but not run: running its statements every RTI would need its CPU
//!   time, which the model sets by that knob. Compiled PLCs (`ENABLE PLCC`) cannot be
//!   downloaded as text and are acknowledged only.
//! - A PLC's CPU time is not charged to the core's background cycle: the background's cost is
//!   the control port's `background` knob.
//! - At a reset every stored PLC is enabled (the DLS startup PLC 1 that disables the others
//!   "at startup" after a `$$$` relies on it: DiamondLightSource/pmac
//!   `pmacApp/pmc/PROG10_CS_motion.pmc`'s header); `$$$***` leaves none.
//! - A PLC whose buffer is open for entry is not scanned; a changed buffer is compiled again
//!   and scanned from its top.
//! - A condition or assignment with no value (a division by zero, `SQRT(-1)`) is false, or
//!   not assigned; the PLC goes on.
//! - An I-variable assignment runs as the on-line command `In=v` would (I41's lockout included)
//!   and a capture records it so (I8, I40, I41 are the watchdog's); P, Q and M assignments are
//!   not recorded (the model has none).

use super::Card;
use crate::buffers::BufferId;
use crate::capture_queue::Record;
use crate::plc::{compile, Op};
use crate::program::Statement;
use pmacwd_specs::grammar::{pieces, Addressing, Command, Expr, PlcSwitch, VarKind};
use std::collections::VecDeque;

/// The most statements (and jumps) one scan runs; the next scan goes on from there.
pub const OPS_PER_SCAN_MAX: u32 = 256;

/// The most servo cycles the card runs per hold of its lock while user PLCs run (each cycle
/// may complete a background cycle and so a scan): 64 scans of at most 256 statements.
pub const PLC_CYCLES_PER_HOLD_MAX: u32 = 64;

/// The most lines a PLC may have to run. MODEL: a bound on the work of compiling it, which
/// happens in one hold of the card's lock when the PLC first runs after a change (4,096 lines
/// compiled and scanned once in 0.8 ms, debug build); DLS's PLCs have tens to a few hundred
/// lines.
/// A longer PLC is kept and listed, and stops when enabled, the console saying why.
pub const PLC_LINES_MAX: usize = 4096;

/// The card's queue of commands issued by PLCs and not yet run (SRM p.422: a full queue halts
/// the program until there is room). MODEL: the card's queue length is not given.
pub const COMMAND_QUEUE_MAX: usize = 32;

/// What running the queued commands may cost per scan: one a command, and one per 16
/// variables of a range it writes. The rest wait for the next background cycle.
const COMMAND_WORK_PER_SCAN_MAX: u32 = 64;

/// One PLC's scan state.
#[derive(Clone, Debug, Default)]
struct PlcState {
    /// The compiled program and the buffer version it was compiled from; `Err` when its
    /// blocks do not match.
    ops: Option<Result<Vec<Op>, String>>,
    version: u64,
    /// The next op to run.
    pc: usize,
    /// ADDRESS#n&m.
    addressing: Addressing,
    /// Stopped on a statement it cannot run, until enabled again.
    stopped: bool,
}

/// Every PLC's state, which are enabled, and the commands they issued.
#[derive(Clone, Debug)]
pub struct Plcs {
    /// Bit n: PLC n enabled.
    enabled: u32,
    states: Vec<PlcState>,
    /// The PLC the last background cycle scanned.
    last: u8,
    queue: VecDeque<(Vec<u8>, Addressing)>,
}

impl Default for Plcs {
    fn default() -> Self {
        Plcs { enabled: 0, states: vec![PlcState::default(); 32], last: 0, queue: VecDeque::new() }
    }
}

/// The background PLCs' bit of I5 (SRM p.39).
const I5_BACKGROUND: i64 = 2;

impl Card {
    /// Whether any background PLC may run now: one enabled, and I5 lets them.
    pub(super) fn plcs_running(&self) -> bool {
        self.plcs.enabled & !1 != 0 && self.core.read_i(5, &self.store).unwrap_or(0) & I5_BACKGROUND != 0
    }

    /// The servo cycles the card runs per hold of its lock ([`super::CYCLES_PER_HOLD_MAX`],
    /// or [`PLC_CYCLES_PER_HOLD_MAX`] while user PLCs run): callers that share the card behind
    /// a lock split longer runs.
    pub fn cycles_per_hold(&self) -> u32 {
        if self.plcs_running() || !self.plcs.queue.is_empty() {
            PLC_CYCLES_PER_HOLD_MAX
        } else {
            super::CYCLES_PER_HOLD_MAX
        }
    }

    /// `ENABLE PLC ...` / `DISABLE PLC ...`: PLCs 1-31 (PLC 0 and PLCC: MODEL, not run).
    pub(super) fn switch_plcs(&mut self, p: PlcSwitch) {
        if p.compiled {
            return;
        }
        let background = p.plcs & !1;
        if p.enable {
            for n in 1..32 {
                if background & (1 << n) != 0 && (self.plcs.enabled & (1 << n) == 0 || self.plcs.states[n].stopped) {
                    // MODEL: a PLC enabled again starts at its top (the pages at hand do not
                    // say; Turbo PMAC's PAUSE PLC and RESUME PLC are the commands that keep the
                    // place); one already running goes on where it is.
                    self.plcs.states[n].stopped = false;
                    self.plcs.states[n].pc = 0;
                }
            }
            self.plcs.enabled |= background;
        } else {
            self.plcs.enabled &= !background;
        }
    }

    /// A reset: every stored PLC enabled from its top (MODEL, see the module's doc), the
    /// command queue emptied.
    pub(super) fn reset_plcs(&mut self) {
        let mut enabled = 0;
        for n in 1..32u8 {
            if self.buffers.plc(n).is_some_and(|l| !l.is_empty()) {
                enabled |= 1 << n;
            }
        }
        self.plcs = Plcs { enabled, ..Plcs::default() };
    }

    /// The scan of one background cycle: the next enabled PLC after the last one scanned,
    /// then the commands PLCs queued.
    pub(super) fn background_plc_scan(&mut self) {
        if self.plcs_running() {
            let open = self.buffers.open_buffer();
            let last = self.plcs.last;
            let next = (1..=31u8).map(|k| (last + k - 1) % 31 + 1).find(|&n| {
                self.plcs.enabled & (1 << n) != 0
                    && !self.plcs.states[usize::from(n)].stopped
                    && open != Some(BufferId::Plc(n))
                    && self.buffers.plc(n).is_some_and(|l| !l.is_empty())
            });
            if let Some(n) = next {
                self.plcs.last = n;
                self.scan(n);
            }
        }
        self.run_plc_commands();
    }

    /// One scan of PLC `n`.
    fn scan(&mut self, n: u8) {
        let k = usize::from(n);
        let version = self.buffers.version(BufferId::Plc(n));
        if self.plcs.states[k].ops.is_none() || self.plcs.states[k].version != version {
            let lines = self.buffers.plc(n).unwrap_or(&[]);
            if lines.len() > PLC_LINES_MAX {
                let why = format!("{} lines, more than the {PLC_LINES_MAX} a PLC may have to run", lines.len());
                self.stop_plc(n, &why);
                return;
            }
            let state = &mut self.plcs.states[k];
            state.ops = Some(compile(lines));
            state.version = version;
            state.pc = 0;
        }
        // The ops are taken out for the scan (statements need the whole card) and put back.
        let ops = match self.plcs.states[k].ops.take() {
            Some(Ok(ops)) => ops,
            Some(Err(why)) => {
                self.plcs.states[k].ops = Some(Err(why.clone()));
                self.stop_plc(n, &format!("its blocks do not match: {why}"));
                return;
            }
            None => return,
        };
        let mut pc = self.plcs.states[k].pc;
        for _ in 0..OPS_PER_SCAN_MAX {
            let Some(op) = ops.get(pc) else {
                // The end of the program: the next scan starts at its top.
                pc = 0;
                break;
            };
            match op {
                Op::Do(st) => {
                    if !self.plc_statement(n, st) {
                        // Held until the command queue has room (SRM p.422).
                        break;
                    }
                    pc += 1;
                    if self.plcs.enabled & (1 << n) == 0 {
                        // It disabled itself: the scan ends there (MODEL).
                        break;
                    }
                }
                Op::Unless { condition, to } => {
                    pc = if self.plc_condition(condition) { pc + 1 } else { *to };
                }
                Op::Jump(to) => pc = *to,
                Op::While { condition, exit } => {
                    pc = if self.plc_condition(condition) { pc + 1 } else { *exit };
                }
                Op::EndWhile { back } => {
                    pc = *back;
                    break;
                }
                Op::Stop(why) => {
                    let why = why.clone();
                    self.stop_plc(n, &why);
                    pc = 0;
                    break;
                }
            }
        }
        let state = &mut self.plcs.states[k];
        state.ops = Some(Ok(ops));
        state.pc = pc;
    }

    fn plc_condition(&mut self, condition: &crate::program::Condition) -> bool {
        condition.holds(&mut |e| e.eval(self).ok().filter(|v| v.is_finite())).unwrap_or(false)
    }

    /// One statement of PLC `n`; `false` when it must wait (the command queue is full).
    fn plc_statement(&mut self, n: u8, st: &Statement) -> bool {
        let k = usize::from(n);
        match st {
            // An I-variable assignment is run as the on-line command `In=v` (and so recorded
            // in a capture: I8, I40, I41 are the watchdog's, and the model must hear them);
            // P, Q and M ones directly.
            Statement::Assign { kind: VarKind::I, number, value } => {
                let finite = |card: &mut Card, e: &Expr| e.eval(card).ok().filter(|v| v.is_finite());
                if let (Some(n), Some(v)) = (finite(self, number), finite(self, value)) {
                    let n = n.round();
                    if (0.0..=8191.0).contains(&n) {
                        let text = format!("I{}={}", n as u16, crate::memory::format_value(v));
                        self.run_as_host(text.as_bytes(), self.plcs.states[k].addressing);
                    }
                }
            }
            Statement::Assign { kind, number, value } => {
                self.assign(*kind, number, value);
            }
            Statement::Command(text) => {
                if self.plcs.queue.len() >= COMMAND_QUEUE_MAX {
                    return false;
                }
                let addressing = self.plcs.states[k].addressing;
                self.plcs.queue.push_back((text.as_bytes().to_vec(), addressing));
            }
            Statement::Control(c) => {
                if self.plcs.queue.len() >= COMMAND_QUEUE_MAX {
                    return false;
                }
                self.plcs.queue.push_back((vec![*c], Addressing::default()));
            }
            Statement::Plc(p) => self.switch_plcs(*p),
            Statement::Address { motor, cs } => {
                let a = &mut self.plcs.states[k].addressing;
                if let Some(m) = motor {
                    a.motor = *m;
                }
                if let Some(c) = cs {
                    a.cs = *c;
                }
            }
            // SEND: no port (MODEL); what `plc::compile` lets through is the above.
            _ => {}
        }
        true
    }

    /// A command a motion program issues (SRM p.421-422), onto the queue PLCs' commands take;
    /// `false` when the queue is full.
    pub(super) fn queue_command(&mut self, text: Vec<u8>, addressing: Addressing) -> bool {
        if self.plcs.queue.len() >= COMMAND_QUEUE_MAX {
            return false;
        }
        self.plcs.queue.push_back((text, addressing));
        true
    }

    /// PLC `n` stops on what it cannot run: disabled until enabled again, the console told.
    fn stop_plc(&mut self, n: u8, why: &str) {
        let state = &mut self.plcs.states[usize::from(n)];
        if state.stopped {
            return;
        }
        state.stopped = true;
        let line = format!("PLC {n} stopped at {}: {why}", self.moment());
        self.say(&line);
    }

    /// The commands PLCs queued, as a host's (SRM p.421), within the work of one scan.
    fn run_plc_commands(&mut self) {
        let mut work = 0u32;
        while work < COMMAND_WORK_PER_SCAN_MAX {
            let Some((text, addressing)) = self.plcs.queue.pop_front() else { return };
            work = work.saturating_add(self.run_as_host(&text, addressing));
        }
    }

    /// `text` run through the card's command path as a host's line would be, with the PLC's
    /// `addressing`; each command recorded in a capture with its answer. The work it took.
    fn run_as_host(&mut self, text: &[u8], addressing: Addressing) -> u32 {
        let mut work = 0u32;
        let mut addressing = addressing;
        for piece in pieces(text, &mut addressing) {
            let Ok(command) = piece.command else {
                // An invalid command: its BEL goes to no port (SRM p.421); the rest of the
                // text is not run, as for a host's line.
                break;
            };
            // A query's answer goes to no port, and reading changes nothing (MODEL).
            if command.values() != Some(0) {
                continue;
            }
            work = work.saturating_add(1 + command_range(&command) / 16);
            let shown =
                String::from_utf8_lossy(text.get(piece.start..piece.end).unwrap_or_default()).trim().to_string();
            let mut answers = Vec::new();
            self.command(command.clone(), addressing, &mut answers);
            let (own, failed) = self.framing().answers(&answers);
            self.capture_record(|| Record::Commands { commands: vec![(shown, Ok(command))], reply: Some(own) });
            if failed {
                break;
            }
        }
        self.sync_motion();
        work
    }

    /// The coordinate systems' user countdown timers Isx11 and Isx12 after `cycles` servo
    /// cycles: "If Coordinate System 'x' is activated by I68, Isx11 will count down one unit
    /// per servo cycle ... until it reaches its maximum negative value of -8,388,608. It will
    /// not roll over" (SRM p.176). PLCs wait on them (`I5111=2259 WHILE (I5111>0) ENDWHILE`,
    /// the same page; DLS's start-up PLC 1 with I5112).
    pub(super) fn count_down_timers(&mut self, cycles: u64) {
        const LOWEST: i64 = -8_388_608;
        let active = (self.core.read_i(68, &self.store).unwrap_or(0).clamp(0, 15) + 1) as u16;
        let cycles = i64::try_from(cycles).unwrap_or(i64::MAX);
        for cs in 1..=active {
            for timer in [11, 12] {
                let n = 5000 + 100 * cs + timer;
                let v = self.core.read_i(n, &self.store).unwrap_or(0);
                if v > LOWEST {
                    self.store.write_exact(n, v.saturating_sub(cycles).max(LOWEST) as f64);
                }
            }
        }
    }
}

/// How many variables a command writes at once (a range), 0 for one.
fn command_range(c: &Command) -> u32 {
    match c {
        Command::Write { vars: pmacwd_specs::grammar::Vars::Numbers(r), .. } => u32::from(r.count),
        Command::MDefine { first, last, .. } => u32::from(last - first),
        _ => 0,
    }
}
