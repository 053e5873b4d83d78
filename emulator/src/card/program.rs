//! Coordinate systems running motion programs: `B{n}` points a C.S. at a stored program
//! (`buffers.rs`), `R` runs it, `S` runs one move, and its linear moves (`program.rs`) move
//! the motors its axis definitions (`&n#m->...`) name, so that the axes arrive where the
//! program says. A layer over the compact core, like the jogs (`card/motion.rs`):
//!
//! - the core decides whether a program runs: `R`, `S`, `B`, `A`, `Q`, `H` ... go to the core
//!   first (UM p.217, UM p.319), and the emulator executes the program only while the core's
//!   program of that C.S. runs (`Program::Running`) and moves a motor only while the core's
//!   motor is in its program (`MotorState::Program`);
//! - a stop the core carries out ends the motion in the servo cycles the core gives it: `A` at
//!   each motor's Ixx15 (UM p.319), `H` along the path in the program's acceleration time
//!   (MODEL: Isx95, the hold's slew rate, is not modelled), `Q` and `/` at the end of the move
//!   under way (UM p.217: "Finishes calculated moves"); a kill or a trip at once;
//! - a program that reaches its end (or `RETURN`) stops at that program point. The model has no
//!   event for a program ending by itself, so the core hears it as the stop that ends a
//!   program at a program point, `Q` (UM p.217 row 4), with nothing left to finish (one servo
//!   cycle); a capture records that `Q` as the exchange `&nQ`, so that it replays as before.
//!   MODEL: the model's programs run until stopped.
//!
//! - the program's flow (IF/ELSE/ENDIF, WHILE/ENDWHILE and the one-line forms of motion
//!   programs, UM p.252-253, SRM p.429-430) is compiled into jumps by `plc.rs`; a loop without
//!   a move waits for the next real-time interrupt at its second jump back (UM p.341-342, see
//!   [`JUMPS_BACK_PER_RTI`]), as `WAIT` does; `CMD"..."` goes onto the PLCs' command queue,
//!   addressed to motor 1 and C.S. 1 (SRM p.421-422).
//!
//! MODEL, where the emulator is simpler than a card: moves are LINEAR moves from rest to rest
//! (no blending: each move ends before the next starts; the card blends them unless Isx92 = 1),
//! accelerating at a constant rate over the acceleration time; the axes start where the motors
//! stand at each `R` or `S` (a position match); a move that reaches a software limit or a
//! limit switch stops the program with a run-time error.

use super::Card;
use crate::buffers::BufferId;
use crate::capture_queue::Record;
use crate::motor_status::{
    CS_AMPLIFIER_FAULT, CS_AXIS_BITS_SHIFT, CS_CONTINUOUS_REQUEST, CS_IN_POSITION, CS_MOVE_BY_TIME, CS_RUNNING_PROGRAM,
    CS_RUNTIME_ERROR, CS_SINGLE_STEP, IN_POSITION,
};
use crate::plc::{compile_as, Kind, Op};
use crate::program::{Statement, AXES};
use pmacwd_bridge::core_command;
use pmacwd_core::motion::{Program, MOTORS_MAX};
use pmacwd_specs::grammar::{Addressing, Command, Expr, VarKind};
use pmacwd_specs::vocab::command::{CsCommand, HostCommand, Motion};
use std::sync::Arc;

/// Statements executed per call at most: a program of many lines without motion is executed
/// over several real-time interrupts rather than in one hold of the card's lock (MODEL, as
/// the bound on a scan of a PLC).
const STATEMENTS_PER_CALL_MAX: usize = 4096;

/// Backward jumps (ENDWHILE) without a move or dwell between them after which the program's
/// calculation waits for the next real-time interrupt. UM p.341, the double-jump-back rule: "If
/// in the course of trying to calculate the next move, Turbo PMAC detects two backwards jumps
/// in the logic of the program, PMAC will not try to blend the last calculated move to an
/// upcoming move ... to prevent the possibility that it might be caught in an indefinitely true
/// set of loops with no movement" (p.342). MODEL: the emulator, which does not blend, takes the
/// second jump back as the end of the program's calculation for this RTI, as WAIT ends it (UM
/// p.342): a WHILE loop without a move makes at most two passes a real-time interrupt, so a
/// hostile program cannot hold the card's lock.
const JUMPS_BACK_PER_RTI: u8 = 2;

/// The most lines a motion program may have to run. MODEL: a bound on the work of compiling
/// it, which happens in one hold of the card's lock at its first `R` after a change; longer
/// programs stop with a run-time error, the console saying why.
pub const PROGRAM_LINES_MAX: usize = 16_384;

/// The vector feedrate axes at power-up. MODEL: X, Y and Z, the PMAC family's default; the
/// page with the power-up state of FRAX was not at hand.
const FRAX_DEFAULT: u16 = 0b111 << 6;

/// One coordinate system's program as the emulator executes it.
#[derive(Clone, Debug)]
pub struct CsRun {
    /// The program `B` pointed at, compiled (`plc.rs`) from the buffer version noted, and
    /// the next op to execute.
    program: Option<u16>,
    ops: Option<Arc<Result<Vec<Op>, String>>>,
    version: u64,
    pc: usize,
    /// Backward jumps since the last move or dwell (see [`JUMPS_BACK_PER_RTI`]).
    jumps_back: u8,
    /// Waiting for the next real-time interrupt (WAIT, the double-jump-back rule, a full
    /// command queue): `left` is the time to it; no move or dwell is under way.
    waiting: bool,
    /// Executing (after `R` or `S`, while the core's program runs).
    executing: bool,
    /// Under `S`: one move, then stop.
    single_step: bool,
    /// `Q` or `/`: finish the move under way, then stop.
    quitting: bool,
    /// Incremental axes and vector feedrate axes, one bit each in the order of `AXES`.
    inc: u16,
    frax: u16,
    /// Moves specified by time (TM) rather than by feedrate (F); SRM p.189: "After power-up/
    /// reset, the coordinate system is in feedrate mode".
    time_mode: bool,
    /// The commanded axis positions (user units).
    axes: [f64; 9],
    /// The move or dwell under way: ms left, whether a dwell, the motors it moves with their
    /// targets (counts from the home position), speeds and accelerations.
    left: f64,
    dwell: bool,
    moving: u8,
    targets: [f64; MOTORS_MAX],
    speeds: [f64; MOTORS_MAX],
    accels: [f64; MOTORS_MAX],
    /// Stopped on a statement it could not execute (SRM p.286, bit 22).
    runtime_error: bool,
    /// Reached its end: the core was told `Q`.
    ended: bool,
}

impl Default for CsRun {
    fn default() -> Self {
        CsRun {
            program: None,
            ops: None,
            version: 0,
            pc: 0,
            jumps_back: 0,
            waiting: false,
            executing: false,
            single_step: false,
            quitting: false,
            inc: 0,
            frax: FRAX_DEFAULT,
            time_mode: false,
            axes: [0.0; 9],
            left: 0.0,
            dwell: false,
            moving: 0,
            targets: [0.0; MOTORS_MAX],
            speeds: [0.0; MOTORS_MAX],
            accels: [0.0; MOTORS_MAX],
            runtime_error: false,
            ended: false,
        }
    }
}

/// What executing one statement came to.
enum Executed {
    Done,
    /// It cannot be executed: the program stops with a run-time error.
    Failed,
    /// It must wait (the command queue is full): tried again at the next RTI.
    Retry,
}

/// An axis definition's terms: `(scale, axis)`, the axis an index of [`AXES`].
pub type AxisTerms = Vec<(f64, usize)>;

/// A motor's axis definition as terms `scale x axis` and an offset (SRM `#{constant}->`);
/// `None` for an inverse-kinematic axis (`I`), which the emulator does not move.
pub fn axis_terms(definition: &str) -> Option<(AxisTerms, f64)> {
    if definition == "I" {
        return None;
    }
    let b = definition.as_bytes();
    let (mut i, mut terms, mut offset) = (0, Vec::new(), 0.0);
    while i < b.len() {
        let from = i;
        if matches!(b[i], b'+' | b'-') {
            i += 1;
        }
        while i < b.len() && (b[i].is_ascii_digit() || b[i] == b'.') {
            i += 1;
        }
        let number = &definition[from..i];
        match b.get(i).and_then(|c| crate::program::axis_index(*c)) {
            Some(k) => {
                let scale = match number {
                    "" | "+" => 1.0,
                    "-" => -1.0,
                    n => n.parse().ok()?,
                };
                terms.push((scale, k));
                i += 1;
            }
            None => offset += number.parse::<f64>().ok()?,
        }
    }
    Some((terms, offset))
}

/// The time (ms) a move from rest of `d` counts takes at most `v` counts/ms accelerating and
/// decelerating at `a` counts/ms².
fn trapezoid_time(d: f64, v: f64, a: f64) -> f64 {
    if d <= 0.0 || v <= 0.0 || a <= 0.0 {
        return 0.0;
    }
    if d >= v * v / a {
        d / v + v / a
    } else {
        2.0 * (d / a).sqrt()
    }
}

impl Card {
    fn cs_run(&mut self, cs: u8) -> Option<&mut CsRun> {
        usize::from(cs).checked_sub(1).and_then(|k| self.programs.get_mut(k))
    }

    /// The core's program of coordinate system `cs` (through any of its motors; `None` when
    /// the configuration puts no motor in it).
    pub(super) fn core_program(&self, cs: u8) -> Program {
        (1..=self.cfg.motion.motors)
            .filter_map(|n| self.core.motor(&self.cfg, n))
            .find(|m| m.coordinate_system == cs)
            .map_or(Program::None, |m| m.program)
    }

    /// The motors the program of `cs` moves: those with an axis definition in `cs` that the
    /// core also has in `cs` (MODEL: the core's coordinate systems are the configuration's,
    /// `check.yaml`; every motor of the default configuration is in C.S. 1), with their terms.
    fn cs_motors(&self, cs: u8) -> Vec<(u8, AxisTerms, f64)> {
        (1..=self.cfg.motion.motors.min(MOTORS_MAX as u8))
            .filter(|n| self.core.motor(&self.cfg, *n).is_some_and(|m| m.coordinate_system == cs))
            .filter_map(|n| {
                let (terms, offset) = axis_terms(self.memory.axis(cs, n)?)?;
                Some((n, terms, offset))
            })
            .collect()
    }

    /// `B{n}` after the core heard `B`: the C.S. points at the top of program n (SRM p.295),
    /// unless its program executes (the core refuses then).
    pub(super) fn begin_program(&mut self, cs: u8, program: Option<u16>) {
        if self.core_program(cs).executing() {
            return;
        }
        if let Some(run) = self.cs_run(cs) {
            if program.is_some() {
                run.program = program;
            }
            // Compiled again at the next R: another program, or the same one changed.
            run.ops = None;
            run.pc = 0;
            run.jumps_back = 0;
            run.waiting = false;
            run.executing = false;
            run.moving = 0;
            run.left = 0.0;
            run.dwell = false;
            run.runtime_error = false;
            run.ended = false;
        }
    }

    /// `R` or `S` after the core heard it: execution starts when the core's program now runs
    /// and the emulator was not executing it; a held move resumes where it stopped.
    pub(super) fn run_program(&mut self, cs: u8, single_step: bool) {
        if self.core_program(cs) != Program::Running {
            return;
        }
        let dt = self.servo_period_ms();
        // The axes start where the motors stand (MODEL, a position match).
        let mut matched = [None; 9];
        for (n, terms, offset) in self.cs_motors(cs) {
            if let [(scale, k)] = terms.as_slice() {
                if *scale != 0.0 {
                    let p = self.motors.axes[usize::from(n - 1)].reported_position();
                    matched[*k] = Some((p - offset) / scale);
                }
            }
        }
        let origins: Vec<f64> = self.motors.axes.iter().map(|a| a.origin).collect();
        let Some(run) = self.cs_run(cs) else { return };
        if run.executing {
            return;
        }
        for (axis, m) in run.axes.iter_mut().zip(matched) {
            if let Some(v) = m {
                *axis = v;
            }
        }
        run.executing = true;
        run.single_step = single_step;
        run.quitting = false;
        run.ended = false;
        run.runtime_error = false;
        if run.moving != 0 && run.left > 0.0 {
            // A feed hold resumed (SRM p.260: "can be started up again with an R"): the
            // interrupted move goes on to its end from where the motors stopped.
            let mut longest: f64 = 0.0;
            let moves: Vec<(usize, f64, f64, f64)> = (0..MOTORS_MAX)
                .filter(|k| run.moving & (1 << k) != 0)
                .map(|k| (k, run.targets[k] + origins[k], run.speeds[k], run.accels[k]))
                .collect();
            for (k, target, v, a) in moves {
                let axis = &mut self.motors.axes[k];
                longest = longest.max(trapezoid_time((target - axis.pos).abs(), v, a));
                axis.program_move(target, v, a);
            }
            if let Some(run) = self.cs_run(cs) {
                run.left = longest.max(dt);
            }
        }
        self.execute_program(cs);
    }

    /// After a stop or a kill the core carried out: the emulator stops executing what the core
    /// no longer runs (`card/motion.rs` stops the motors as the core says).
    pub(super) fn sync_programs(&mut self) {
        for cs in 1..=16u8 {
            let core = self.core_program(cs);
            let Some(run) = self.cs_run(cs) else { continue };
            match core {
                Program::Running => {}
                // Held on the path: the move resumes with R.
                Program::Held => run.executing = false,
                Program::None | Program::AtPoint | Program::Lost => {
                    run.executing = false;
                    run.moving = 0;
                    run.left = 0.0;
                    run.dwell = false;
                    run.waiting = false;
                    run.jumps_back = 0;
                }
            }
        }
    }

    /// Whether motor `motor` is in the move of a program the emulator executes.
    pub(super) fn in_program_move(&self, motor: u8) -> bool {
        let Some(k) = usize::from(motor).checked_sub(1).filter(|k| *k < MOTORS_MAX) else { return false };
        self.programs.iter().any(|r| r.executing && r.moving & (1 << k) != 0)
    }

    /// The time (ms) left of the move under way in the C.S. of motor `motor`'s program, for a
    /// `Q` or `/` that lets it finish.
    pub(super) fn program_move_left(&self, cs: u8) -> Option<f64> {
        let run = self.programs.get(usize::from(cs).checked_sub(1)?)?;
        (run.executing && run.left > 0.0 && !run.waiting).then_some(run.left)
    }

    /// The acceleration time (ms) of C.S. `cs`'s moves: Isx87, or 2 x Isx88 when Isx88 is more
    /// than half of it (SRM p.188-189).
    pub(super) fn program_accel_time(&self, cs: u8) -> f64 {
        let base = 5000 + 100 * u16::from(cs);
        let (ta, ts) = (self.i_value(base + 87), self.i_value(base + 88));
        let (ta, ts) = (if ta.is_finite() { ta.max(0.0) } else { 0.0 }, if ts.is_finite() { ts.max(0.0) } else { 0.0 });
        if ts > ta / 2.0 {
            2.0 * ts
        } else {
            ta
        }
    }

    /// `Q` or `/` heard by the core: the move under way finishes, then the program stops.
    pub(super) fn quit_program(&mut self, cs: u8) {
        if let Some(run) = self.cs_run(cs) {
            if run.executing {
                run.quitting = true;
            }
        }
    }

    /// Moves every executing program on by `ms`: its moves and dwells run for that long, and
    /// the statements after each one are executed when it ends, so that a long advance equals
    /// many short ones.
    pub(super) fn advance_programs(&mut self, ms: f64, advance: &mut dyn FnMut(&mut Card, f64)) {
        let mut left = ms;
        for _ in 0..STATEMENTS_PER_CALL_MAX {
            // The soonest end of a move or dwell among the executing programs.
            let next = self
                .programs
                .iter()
                .filter(|r| r.executing && r.left > 0.0)
                .map(|r| r.left)
                .fold(f64::INFINITY, f64::min);
            let piece = next.min(left);
            if piece > 0.0 {
                advance(self, piece);
                for r in self.programs.iter_mut().filter(|r| r.executing && r.left > 0.0) {
                    r.left -= piece;
                }
                left -= piece;
            }
            let mut ended_any = false;
            for cs in 1..=16u8 {
                let due =
                    self.programs[usize::from(cs - 1)].executing && self.programs[usize::from(cs - 1)].left <= 1e-9;
                if due {
                    self.end_of_move(cs);
                    self.execute_program(cs);
                    ended_any = true;
                }
            }
            if left <= 0.0 || (!ended_any && next.is_infinite()) {
                if left > 0.0 {
                    advance(self, left);
                }
                return;
            }
        }
        if left > 0.0 {
            advance(self, left);
        }
    }

    /// The move or dwell of `cs` has had its time: each motor is at its target (or where a
    /// limit stopped it: a run-time error).
    fn end_of_move(&mut self, cs: u8) {
        let Some(run) = self.programs.get(usize::from(cs - 1)) else { return };
        let (moving, targets) = (run.moving, run.targets);
        let mut stopped_short = false;
        for (k, (axis, target)) in self.motors.axes.iter_mut().zip(targets).enumerate() {
            if moving & (1 << k) == 0 {
                continue;
            }
            let target = target + axis.origin;
            axis.finish_move(target);
            if axis.limit_stop || (axis.pos - target).abs() > 1e-6 * (1.0 + target.abs()) {
                stopped_short = true;
            }
        }
        let Some(run) = self.cs_run(cs) else { return };
        run.moving = 0;
        run.left = 0.0;
        let was_move = !run.dwell && moving != 0;
        run.dwell = false;
        run.waiting = false;
        if stopped_short {
            run.runtime_error = true;
            self.end_program(cs);
        } else if run.quitting || (run.single_step && was_move) {
            run.executing = false;
        }
    }

    /// Executes statements of `cs`'s program until a move or dwell is under way, it waits for
    /// the next real-time interrupt, or the program ends.
    fn execute_program(&mut self, cs: u8) {
        let k = usize::from(cs - 1);
        let Some(ops) = self.program_ops(cs) else { return };
        let ops = match ops.as_ref() {
            Ok(ops) => ops,
            Err(why) => {
                let line = format!("motion program of &{cs} not run at {}: {why}", self.moment());
                self.say(&line);
                self.programs[k].runtime_error = true;
                self.end_program(cs);
                return;
            }
        };
        for _ in 0..STATEMENTS_PER_CALL_MAX {
            let run = &mut self.programs[k];
            if !run.executing || run.left > 0.0 {
                return;
            }
            let pc = run.pc;
            match ops.get(pc) {
                None => {
                    // The end of the program: it stops there. MODEL: the next R runs it from
                    // its top, as after B (the EPICS driver sends B10R each time).
                    self.end_program(cs);
                    return;
                }
                Some(Op::Do(statement)) => {
                    run.pc += 1;
                    match self.execute(cs, statement.clone()) {
                        Executed::Done => {}
                        Executed::Failed => {
                            self.programs[k].runtime_error = true;
                            self.end_program(cs);
                            return;
                        }
                        Executed::Retry => {
                            // The command queue is full (SRM p.422: "program execution is
                            // temporarily halted until the new command can be placed on the
                            // queue"): tried again at the next real-time interrupt.
                            self.programs[k].pc = pc;
                            self.wait_for_rti(cs);
                            return;
                        }
                    }
                    let run = &mut self.programs[k];
                    if run.left > 0.0 && !run.waiting {
                        run.jumps_back = 0;
                    }
                }
                Some(Op::Unless { condition, to }) => {
                    let holds = self.program_condition(condition);
                    self.programs[k].pc = if holds { pc + 1 } else { *to };
                }
                Some(Op::While { condition, exit }) => {
                    let holds = self.program_condition(condition);
                    self.programs[k].pc = if holds { pc + 1 } else { *exit };
                }
                Some(Op::Jump(to)) => run.pc = *to,
                Some(Op::EndWhile { back }) => {
                    run.pc = *back;
                    run.jumps_back += 1;
                    if run.jumps_back >= JUMPS_BACK_PER_RTI {
                        self.wait_for_rti(cs);
                        return;
                    }
                }
                Some(Op::Stop(why)) => {
                    let line = format!("motion program of &{cs} stopped at {}: {why}", self.moment());
                    self.say(&line);
                    self.programs[k].runtime_error = true;
                    self.end_program(cs);
                    return;
                }
            }
        }
        // As many statements as one call runs and still no move: the rest at the next
        // real-time interrupt (MODEL, see STATEMENTS_PER_CALL_MAX).
        self.wait_for_rti(cs);
    }

    /// The compiled program of `cs`, compiled again when its buffer changed since (from its
    /// top); `None` when the C.S. has none.
    fn program_ops(&mut self, cs: u8) -> Option<Arc<Result<Vec<Op>, String>>> {
        let k = usize::from(cs - 1);
        let p = self.programs.get(k)?.program;
        let version = p.map_or(0, |p| self.buffers.version(BufferId::Program(p)));
        let run = &self.programs[k];
        if let Some(ops) = run.ops.as_ref().filter(|_| run.version == version) {
            return Some(Arc::clone(ops));
        }
        let lines = p.and_then(|p| self.buffers.program(p)).unwrap_or(&[]);
        let compiled = if lines.len() > PROGRAM_LINES_MAX {
            Err(format!("{} lines, more than the {PROGRAM_LINES_MAX} a motion program may have to run", lines.len()))
        } else {
            compile_as(lines, Kind::Motion { cs })
        };
        let ops = Arc::new(compiled);
        let run = &mut self.programs[k];
        if run.ops.is_some() {
            run.pc = 0;
        }
        run.ops = Some(Arc::clone(&ops));
        run.version = version;
        Some(ops)
    }

    /// A condition of the program (UM p.252); one with no value (a division by zero) is false
    /// (MODEL, as in a PLC).
    fn program_condition(&mut self, condition: &crate::program::Condition) -> bool {
        condition.holds(&mut |e| e.eval(self).ok().filter(|v| v.is_finite())).unwrap_or(false)
    }

    /// The program of `cs` waits for the next real-time interrupt, every I8 + 1 servo cycles
    /// (SRM p.42, I8).
    fn wait_for_rti(&mut self, cs: u8) {
        let i8 = self.core.read_i(8, &self.store).unwrap_or(2).clamp(0, 255);
        let ms = (i8 + 1) as f64 * self.servo_period_ms();
        let run = &mut self.programs[usize::from(cs - 1)];
        run.jumps_back = 0;
        run.waiting = true;
        run.dwell = false;
        run.moving = 0;
        run.left = ms;
    }

    /// One statement of a program: flow is compiled into ops, so these are the program's
    /// commands, waits and motion.
    fn execute(&mut self, cs: u8, statement: Statement) -> Executed {
        match statement {
            // SRM p.421: "as if it came from the host (except for addressing modes and
            // response direction)"; SRM p.422: "Any motor-specific or coordinate-system-
            // specific command issued from within a motion program without a specifier is
            // automatically addressed to Motor 1 or C.S.1"; queued, run in the background
            // as a PLC's are (`card/plc.rs`).
            Statement::Command(text) => {
                if self.queue_command(text.into_bytes(), Addressing::default()) {
                    Executed::Done
                } else {
                    Executed::Retry
                }
            }
            // SRM p.423: control characters are global.
            Statement::Control(c) => {
                if self.queue_command(vec![c], Addressing::default()) {
                    Executed::Done
                } else {
                    Executed::Retry
                }
            }
            Statement::Plc(p) => {
                self.switch_plcs(p);
                Executed::Done
            }
            // SEND: no port (MODEL, as from a PLC).
            Statement::Send(_) => Executed::Done,
            Statement::Wait => {
                self.wait_for_rti(cs);
                Executed::Done
            }
            other => {
                if self.execute_motion(cs, other) {
                    Executed::Done
                } else {
                    Executed::Failed
                }
            }
        }
    }

    /// One motion statement; `false` when it cannot be executed.
    fn execute_motion(&mut self, cs: u8, statement: Statement) -> bool {
        let base = 5000 + 100 * u16::from(cs);
        let k = usize::from(cs - 1);
        // A value of the program: a number, finite.
        let value = |card: &mut Card, e: &pmacwd_specs::grammar::Expr| e.eval(card).ok().filter(|v| v.is_finite());
        match statement {
            Statement::Linear => {}
            Statement::Abs(axes) => self.programs[k].inc &= !axes,
            Statement::Inc(axes) => self.programs[k].inc |= axes,
            Statement::Frax(axes) => self.programs[k].frax = axes,
            // SRM p.188-189: "When polled, Isx87 will report the value from the most recently
            // executed TA command", Isx88 the TS, Isx89 the F or TM; TM puts the C.S. in
            // move-time mode and F in feedrate mode (SRM p.285, first word bit 3).
            Statement::Ta(e) | Statement::Ts(e) | Statement::Tm(e) | Statement::F(e)
                if value(self, &e).is_none_or(|v| v < 0.0) =>
            {
                return false
            }
            Statement::Ta(e) => {
                let v = value(self, &e).unwrap_or(0.0);
                self.store.write_exact(base + 87, v);
            }
            Statement::Ts(e) => {
                let v = value(self, &e).unwrap_or(0.0);
                self.store.write_exact(base + 88, v);
            }
            Statement::Tm(e) => {
                let v = value(self, &e).unwrap_or(0.0);
                self.store.write_exact(base + 89, v);
                self.programs[k].time_mode = true;
            }
            Statement::F(e) => {
                let v = value(self, &e).unwrap_or(0.0);
                self.store.write_exact(base + 89, v);
                self.programs[k].time_mode = false;
            }
            Statement::Dwell(e) => {
                let Some(v) = value(self, &e) else { return false };
                let run = &mut self.programs[k];
                run.left = v.max(0.0);
                run.dwell = true;
            }
            Statement::Assign { kind, number, value: v } => return self.assign(kind, &number, &v),
            Statement::Move(axes) => {
                let mut values = Vec::with_capacity(axes.len());
                for (axis, e) in &axes {
                    let Some(v) = value(self, e) else { return false };
                    values.push((*axis, v));
                }
                return self.start_move(cs, &values);
            }
            Statement::Return => self.end_program(cs),
            // Flow is compiled into ops (`plc.rs`), the rest is `execute`'s: none reach here.
            Statement::If(_)
            | Statement::While(_)
            | Statement::And(_)
            | Statement::Or(_)
            | Statement::Else
            | Statement::EndIf
            | Statement::EndWhile
            | Statement::Command(_)
            | Statement::Control(_)
            | Statement::Send(_)
            | Statement::Plc(_)
            | Statement::Address { .. }
            | Statement::Wait
            | Statement::Unsupported(_) => return false,
        }
        true
    }

    /// `{variable}={expression}` in a program (UM p.248: evaluated, then assigned; the
    /// variable's number may be an expression); `false` when either has no value or the
    /// write is refused.
    pub(super) fn assign(&mut self, kind: VarKind, number: &Expr, value: &Expr) -> bool {
        let finite = |card: &mut Card, e: &Expr| e.eval(card).ok().filter(|v| v.is_finite());
        let (Some(n), Some(v)) = (finite(self, number), finite(self, value)) else { return false };
        let n = n.round();
        if !(0.0..=8191.0).contains(&n) {
            return false;
        }
        let n = n as u16;
        match kind {
            VarKind::I => {
                if let crate::framing::Answer::Error(_) = self.write_i(n, v) {
                    return false;
                }
            }
            VarKind::M => {
                let mut out = Vec::new();
                self.write_m(n, n, v, &mut out);
                if out.iter().any(|a| matches!(a, crate::framing::Answer::Error(_))) {
                    return false;
                }
            }
            VarKind::P | VarKind::Q => self.memory.write(kind, n, v),
        }
        true
    }

    /// A LINEAR move of C.S. `cs` to (or by) `values` (UM p.272; SRM p.188-189): the move
    /// time is TM, or the vector distance over the feedrate axes at F per Isx90 ms; the
    /// acceleration time is the minimum move time ("the move will be done in the acceleration
    /// time instead"; 0.5 ms when TA and TS are 0); no motor goes faster than its Ixx16 (SRM
    /// p.98; the move is slowed instead, MODEL as the card's LINEAR moves without
    /// segmentation); the feedrate override scales the time (PMAC-SRM p.29). Every motor
    /// accelerates for the acceleration time and decelerates for it at the end, so that all
    /// arrive together, the move taking its time plus the acceleration time (MODEL: the
    /// linear blended move from rest to rest).
    fn start_move(&mut self, cs: u8, values: &[(usize, f64)]) -> bool {
        let k = usize::from(cs - 1);
        let base = 5000 + 100 * u16::from(cs);
        let run = &self.programs[k];
        let mut axes = run.axes;
        for &(a, v) in values {
            axes[a] = if run.inc & (1 << a) != 0 { run.axes[a] + v } else { v };
        }
        if axes.iter().any(|v| !v.is_finite()) {
            return false;
        }
        let (frax, time_mode, old) = (run.frax, run.time_mode, run.axes);
        let accel_time = self.program_accel_time(cs);
        let speed_value = self.i_value(base + 89);
        let mut time = if time_mode {
            speed_value
        } else {
            // SRM p.189: F in user units per Isx90 ms (default 1000: per second).
            let units = self.i_value(base + 90);
            let units = if units.is_finite() && units > 0.0 { units } else { 1000.0 };
            let along = |mask: u16| {
                (0..AXES.len()).filter(|a| mask & (1 << a) != 0).map(|a| (axes[a] - old[a]).powi(2)).sum::<f64>().sqrt()
            };
            // MODEL: a move of no feedrate axis goes at F over the distance of all its axes
            // (the card uses an alternate feedrate, Isx86, not modelled).
            let distance = if along(frax) > 0.0 { along(frax) } else { along(0x1FF) };
            if distance > 0.0 && !(speed_value.is_finite() && speed_value > 0.0) {
                return false;
            }
            if distance > 0.0 {
                distance / speed_value * units
            } else {
                0.0
            }
        };
        if !time.is_finite() || time < 0.0 {
            return false;
        }
        time = time.max(if accel_time > 0.0 { accel_time } else { 0.5 });
        let feed = self.memory.feed(cs);
        if feed > 0.0 {
            time /= feed / 100.0;
        }
        // Each motor's target (counts from its home position) and distance.
        let mut plan = Vec::new();
        for (n, terms, offset) in self.cs_motors(cs) {
            let target = super::motion::sane_position(terms.iter().map(|(s, a)| s * axes[*a]).sum::<f64>() + offset);
            let from = self.motors.axes[usize::from(n - 1)].reported_position();
            plan.push((n, target, target - from));
        }
        for &(n, _, d) in &plan {
            let max = self.i_value(u16::from(n) * 100 + 16);
            if max.is_finite() && max > 0.0 && d.abs() / time > max {
                time = d.abs() / max;
            }
        }
        let accel_time = accel_time.max(self.servo_period_ms() / 2.0);
        let run = &mut self.programs[k];
        run.axes = axes;
        run.moving = 0;
        for &(n, target, d) in &plan {
            let i = usize::from(n - 1);
            run.targets[i] = target;
            if d != 0.0 {
                let v = d.abs() / time;
                run.speeds[i] = v;
                run.accels[i] = super::motion::sane_accel(v / accel_time);
                run.moving |= 1 << i;
            }
        }
        run.left = time + accel_time;
        run.dwell = false;
        let (moving, targets, speeds, accels) = (run.moving, run.targets, run.speeds, run.accels);
        for i in 0..MOTORS_MAX {
            if moving & (1 << i) != 0 {
                let axis = &mut self.motors.axes[i];
                axis.program_move(targets[i] + axis.origin, speeds[i], accels[i]);
            }
        }
        true
    }

    /// The program of `cs` has stopped at its end, on `RETURN` or on an error: the core hears
    /// `Q` with nothing left to finish (one servo cycle), and the capture records it.
    fn end_program(&mut self, cs: u8) {
        let Some(run) = self.cs_run(cs) else { return };
        run.executing = false;
        run.ended = true;
        run.pc = 0;
        run.jumps_back = 0;
        run.waiting = false;
        run.left = 0.0;
        run.dwell = false;
        run.moving = 0;
        if self.core_program(cs) != Program::Running {
            return;
        }
        let motion = Motion::CoordinateSystem(cs, CsCommand::Quit);
        let usual = self.cfg.motion.decel_cycles;
        self.cfg.motion.decel_cycles = 1;
        self.core.command(&self.cfg, core_command(&HostCommand::Motion(motion)), &mut self.store);
        self.cfg.motion.decel_cycles = usual;
        self.capture_record(|| Record::Commands {
            commands: vec![(format!("&{cs}Q"), Ok(Command::Motion(motion)))],
            reply: Some(Vec::new()),
        });
    }

    /// `&n??` (SRM p.284-287): first word bit 0 running a program, bit 1 single-step mode,
    /// bit 3 moves specified by time, bit 4 continuous motion requested (under R), bits 6-23
    /// each axis's incremental mode and feedrate use (A to Z); second word bit 17 in position
    /// (every motor of the C.S. in position and no move or dwell under way; MODEL: a C.S.
    /// without motors is in position; its motors are those its axis definitions name, or
    /// the core's when it has none), bit 20 amplifier fault, bit 22 run-time error; the third
    /// word 0.
    pub(super) fn cs_status(&self, cs: u8, motor_words: &dyn Fn(u8) -> (u32, u32)) -> (u32, u32, u32) {
        let Some(run) = self.programs.get(usize::from(cs).saturating_sub(1)) else { return (0, 0, 0) };
        let core = self.core_program(cs);
        let running = core == Program::Running && !run.ended || core == Program::Held;
        let mut a = if running { CS_RUNNING_PROGRAM } else { 0 };
        if run.single_step && run.executing {
            a |= CS_SINGLE_STEP;
        }
        if run.time_mode {
            a |= CS_MOVE_BY_TIME;
        }
        if run.executing && !run.single_step {
            a |= CS_CONTINUOUS_REQUEST;
        }
        for axis in 0..AXES.len() as u32 {
            if run.inc & (1 << axis) != 0 {
                a |= 1 << (CS_AXIS_BITS_SHIFT + 2 * axis);
            }
            if run.frax & (1 << axis) != 0 {
                a |= 1 << (CS_AXIS_BITS_SHIFT + 1 + 2 * axis);
            }
        }
        let members: Vec<u8> = (1..=self.cfg.motion.motors)
            .filter(|n| self.core.motor(&self.cfg, *n).is_some_and(|m| m.coordinate_system == cs))
            .collect();
        // The motors of the C.S. are those its axis definitions name (SRM `#{constant}->`);
        // MODEL: with none defined, the core's members (the configuration's).
        let defined: Vec<u8> = self.cs_motors(cs).into_iter().map(|(n, _, _)| n).collect();
        let in_position = if defined.is_empty() { &members } else { &defined };
        let mut b = 0;
        let busy = run.executing && run.left > 0.0 && !run.waiting;
        if !busy && in_position.iter().all(|n| motor_words(*n).1 & IN_POSITION != 0) {
            b |= CS_IN_POSITION;
        }
        if members.iter().any(|n| self.core.motor(&self.cfg, *n).is_some_and(|m| m.amplifier_fault_status)) {
            b |= CS_AMPLIFIER_FAULT;
        }
        if run.runtime_error {
            b |= CS_RUNTIME_ERROR;
        }
        (a, b, 0)
    }
}

impl Card {
    /// Motor `n` as the status words report it. A program that has ended stops at its program
    /// point in the core one servo cycle later (the core's `Q`, see the module's doc); until
    /// that cycle has run its motors are reported at rest, closed loop, as the card has them.
    pub(super) fn reported_motor(&self, n: u8) -> Option<pmacwd_bridge::MotorStatus> {
        let mut m = pmacwd_bridge::motor_status(&self.core, &self.cfg, n)?;
        let ended = self.programs.get(usize::from(m.coordinate_system).saturating_sub(1)).is_some_and(|r| r.ended);
        if ended && m.view.state == pmacwd_specs::vocab::observation::MotorState::Program {
            m.view.state = pmacwd_specs::vocab::observation::MotorState::Closed;
            m.stop = None;
            m.program = Program::AtPoint;
        }
        Some(m)
    }

    /// How many servo cycles run before the soonest move or dwell of an executing program
    /// ends, or a jog to a position arrives (`card/motion.rs`), at least 1; `u64::MAX` with
    /// none.
    pub(super) fn cycles_to_program_event(&self) -> u64 {
        let programs = self.programs.iter().filter(|r| r.executing).map(|r| r.left);
        let soonest = programs.chain(self.jog_arrivals()).fold(f64::INFINITY, f64::min);
        if !soonest.is_finite() {
            return u64::MAX;
        }
        let cycles = (soonest / self.servo_period_ms()).ceil();
        if cycles >= 1.0 {
            cycles.min(1e15) as u64
        } else {
            1
        }
    }

    /// Whether any coordinate system executes a program.
    pub(super) fn programs_executing(&self) -> bool {
        self.programs.iter().any(|r| r.executing)
    }

    /// Every C.S. back to power-up (a reset): no program pointed at.
    pub(super) fn reset_programs(&mut self) {
        for r in self.programs.iter_mut() {
            *r = CsRun::default();
        }
    }
}
