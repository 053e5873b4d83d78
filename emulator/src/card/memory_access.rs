//! The card's M-variables as pointers into memory and its direct memory write: the commands of
//! `mvar.rs`'s syntax, answered against the core's registers, the core's I-variables (past I41,
//! SRM p.57) and the words the emulator keeps. `mvar.rs` says what each address reaches.

use super::Card;
use crate::framing::Answer;
use crate::memory::format_value;
use crate::mvar::{self, Definition};
use pmacwd_bridge::core_command;
use pmacwd_core as core;
use pmacwd_core::timers;
use pmacwd_specs::grammar::VarKind;
use pmacwd_specs::vocab::command::{HostCommand, Register, Space};

/// M70-M73 as a Geo Brick's M-variable file defines them (DiamondLightSource/pmac
/// `etc/bootstrap/BRICK_M_variables.pmc:70-73`, the EPICS driver's CPU load, `pmacController.h:
/// 197-200`): the phase period, the phase tasks, the servo tasks, the last RTI tasks.
const BRICK_TIMER_M: [(u16, Space, u32); 4] =
    [(70, Space::X, 0xFF_FF8C), (71, Space::X, 0x37), (72, Space::Y, 0x37), (73, Space::X, 0x0B)];

impl Card {
    /// `Mn..m`: each value.
    pub(super) fn read_m(&mut self, first: u16, last: u16, out: &mut Vec<Answer>) {
        for n in first..=last {
            let value = self.m_value(n);
            out.push(Answer::Data(format_value(value)));
        }
    }

    /// `Mn..m->{definition}`. MODEL: every M-variable of a range gets the same definition.
    pub(super) fn define_m(&mut self, first: u16, last: u16, definition: Definition, out: &mut Vec<Answer>) {
        for n in first..=last {
            self.mvars.define(n, definition);
        }
        out.push(Answer::Nothing);
    }

    /// `Mn..m->`: PMAC-SRM p.253, the definition itself, or with I9 bit 0 the whole statement.
    pub(super) fn report_m(&mut self, first: u16, last: u16, out: &mut Vec<Answer>) {
        let whole_statement = self.core.read_i(9, &self.store).unwrap_or(0) & 1 != 0;
        for n in first..=last {
            let text = self.mvars.definition(n).report();
            out.push(Answer::Data(if whole_statement { format!("M{n}->{text}") } else { text }));
        }
    }

    /// `Mn..m=v`: each assignment in turn; an error ends the command.
    pub(super) fn write_m(&mut self, first: u16, last: u16, value: f64, out: &mut Vec<Answer>) {
        for n in first..=last {
            let answer = match self.mvars.definition(n) {
                Definition::SelfReferenced => {
                    self.memory.write(VarKind::M, n, value);
                    Answer::Nothing
                }
                d => self.write_through(d, value),
            };
            if !push_unless_error(out, answer) {
                break;
            }
        }
    }

    /// `W{X|Y|D|L}:{address},{v}...`: each value to the next address; an error ends it.
    pub(super) fn write_memory(&mut self, kind: Definition, values: Vec<f64>, out: &mut Vec<Answer>) {
        for (i, value) in values.into_iter().enumerate() {
            let answer = self.write_through(kind.at_offset(i as u32), value);
            if !push_unless_error(out, answer) {
                break;
            }
        }
    }

    /// M-variable `n`'s value: its own (`*`, or a documented constant), or what its
    /// definition points at (module `mvar`).
    pub(super) fn m_value(&mut self, n: u16) -> f64 {
        match self.mvars.definition(n) {
            // M70-M73 with their card-defined values read the timer registers that a Geo
            // Brick's M-variable file points them at (UM p.238-239; the EPICS driver's
            // `etc/bootstrap/BRICK_M_variables.pmc:70-73`).
            Definition::SelfReferenced if self.memory.constant(n).is_some() => {
                match BRICK_TIMER_M.iter().find(|t| t.0 == n) {
                    Some(&(_, space, address)) => f64::from(self.word_at(space, address)),
                    None => self.memory.read(VarKind::M, n),
                }
            }
            Definition::SelfReferenced => self.memory.read(VarKind::M, n),
            Definition::Word { space, address, offset, width, format } => {
                mvar::field_value(self.word_at(space, address), offset, width, format) as f64
            }
            Definition::Fixed { address, dual_ported } => {
                if let Some(i) = self.mvars.i_variable_at(address) {
                    return self.core.read_i(i, &self.store).unwrap_or(0) as f64;
                }
                let (x, y) = (self.word_at(Space::X, address), self.word_at(Space::Y, address));
                (if dual_ported { mvar::join32(x, y) } else { mvar::join48(x, y) }) as f64
            }
            Definition::Float { address, .. } => match self.mvars.i_variable_at(address) {
                Some(i) => self.core.read_i(i, &self.store).unwrap_or(0) as f64,
                None if Register::at(Space::X, address).is_some() || Register::at(Space::Y, address).is_some() => {
                    mvar::join48(self.word_at(Space::X, address), self.word_at(Space::Y, address)) as f64
                }
                None => self.mvars.float(address),
            },
        }
    }

    /// The 24-bit word at `space:address`: a core register read as `RH` reads it, half of an
    /// I-variable's storage (X the high 24 bits, Y the low), or a word the emulator keeps.
    pub(super) fn word_at(&mut self, space: Space, address: u32) -> u32 {
        if let Some(v) = self.timer_word(space, address) {
            return v;
        }
        if let Some(v) = self.motor_register_word(space, address) {
            return v;
        }
        if let Some(r) = Register::at(space, address) {
            let read = core_command(&HostCommand::ReadHex(r));
            return match self.core.command(&self.cfg, read, &mut self.store) {
                core::Reply::Hex(v) => v & 0xFF_FFFF,
                _ => 0,
            };
        }
        if let Some(i) = self.mvars.i_variable_at(address) {
            let (x, y) = mvar::split48(self.core.read_i(i, &self.store).unwrap_or(0));
            return if space == Space::X { x } else { y };
        }
        self.mvars.word(space, address)
    }

    /// The motor registers a Geo Brick's suggested M-variables point at, from the motor's
    /// trajectory (DiamondLightSource/pmac `etc/bootstrap/BRICK_M_variables.pmc:166-170`, and
    /// the same for each motor $80 words further: `M162->D:$00008B ; #1 Actual position
    /// (1/[Ixx08*32] cts)`; PMAC Quick Reference Guide p.63: `P2=M162/(I108*32*10000)...`
    /// "converting radial (M162) ... positions"): motor n's commanded position at D:$000088 +
    /// $80 x (n - 1) (Mxx61) and its actual position at D:$00008B + ... (Mxx62), each in
    /// 1/(Ixx08 x 32) counts, 48 bits, X the high word; its actual velocity at X:$00009D + ...
    /// (Mxx66) in 1/(Ixx09 x 32) counts per servo cycle, 24 bits signed, and its averaged
    /// actual velocity at D:$0000EF + ... (Mxx74, `BRICK_M_variables.pmc:178`) in the same
    /// units, 48 bits (MODEL: the velocity is the trajectory's, no averaging filter). `None`
    /// for any other address. MODEL: the commanded position is the actual one (no servo loop), both counted
    /// from the home position as `P` reports them (the card keeps the home offset apart, in its
    /// position bias, Mxx64, which reads 0 here); a host write there is kept and not read (the
    /// servo loop writes these every cycle).
    fn motor_register_word(&mut self, space: Space, address: u32) -> Option<u32> {
        let offset = address.checked_sub(0x80)?;
        let (motor, word) = (offset / 0x80 + 1, offset % 0x80 + 0x80);
        if motor > u32::from(self.cfg.motion.motors.min(32)) {
            return None;
        }
        let motor = motor as u8;
        let axis = usize::from(motor - 1);
        let axis = self.motors.axes.get(axis)?;
        match (space, word) {
            (Space::X | Space::Y, 0x88 | 0x8B) => {
                let scale = self.i_value(u16::from(motor) * 100 + 8) * 32.0;
                let v = (axis.reported_position() * scale).round();
                let v = if v.is_finite() { v.clamp(-(2f64.powi(47)), 2f64.powi(47) - 1.0) as i64 } else { 0 };
                let (x, y) = mvar::split48(v);
                Some(if space == Space::X { x } else { y })
            }
            (Space::X, 0x9D) => {
                let scale = self.i_value(u16::from(motor) * 100 + 9) * 32.0;
                let v = (axis.vel * self.servo_period_ms() * scale).round();
                let v = if v.is_finite() { v.clamp(-(2f64.powi(23)), 2f64.powi(23) - 1.0) as i64 } else { 0 };
                Some((v as u32) & 0xFF_FFFF)
            }
            (Space::X | Space::Y, 0xEF) => {
                let scale = self.i_value(u16::from(motor) * 100 + 9) * 32.0;
                let v = (axis.vel * self.servo_period_ms() * scale).round();
                let v = if v.is_finite() { v.clamp(-(2f64.powi(47)), 2f64.powi(47) - 1.0) as i64 } else { 0 };
                let (x, y) = mvar::split48(v);
                Some(if space == Space::X { x } else { y })
            }
            _ => None,
        }
    }

    /// The foreground timer registers (UM p.238-239) under the load the card runs, through
    /// the one mapping of the model's CPU units to timer increments (`pmacwd_core::timers`,
    /// MODEL): X:$FFFF8C the phase period and X:$000037 the phase tasks (M70 and M71's values
    /// in `variables.yaml`: the model has no phase tasks), Y:$000037 the servo tasks (the
    /// motors' servo units), X:$00000B the RTI tasks (PLC 0, and the move planning while a
    /// program plans moves, UM p.236), Y:$00000B the largest of those since power-up/reset.
    /// `None` for any other address. A write there is kept and never read (MODEL: the firmware
    /// writes these every interrupt).
    fn timer_word(&mut self, space: Space, address: u32) -> Option<u32> {
        let timers = match (space, address) {
            (Space::X, 0xFF_FF8C) | (Space::X, 0x37) | (Space::Y, 0x37) | (Space::X, 0x0B) | (Space::Y, 0x0B) => {
                self.timers()
            }
            _ => return None,
        };
        Some(match (space, address) {
            (Space::X, 0xFF_FF8C) => timers.phase_period,
            (Space::X, 0x37) => timers.phase_task,
            (Space::Y, 0x37) => timers.servo_task,
            (Space::X, _) => timers.rti_task,
            _ => self.rti_time_max,
        })
    }

    /// The model's CPU units as timer increments on this card (`pmacwd_core::timers`): the
    /// phase period and phase tasks of M70 and M71's card-defined values, I7002 + 1 phase
    /// interrupts a servo interrupt (SRM p.43), the configuration's units a servo cycle.
    pub fn timer_scale(&self) -> timers::TimerScale {
        let constant = |n| self.memory.constant(n).and_then(|v| u32::try_from(v).ok()).unwrap_or(0);
        let i7002 = self.core.read_i(7002, &self.store).unwrap_or(0);
        timers::TimerScale {
            phase_period: constant(70),
            phase_task: constant(71),
            phases_per_servo: u32::try_from(i7002.saturating_add(1)).unwrap_or(1).max(1),
            cycle_units: self.cfg.cycle_units,
        }
    }

    /// The timer registers as the card's load stands, Y:$00000B's maximum brought up to date.
    pub fn timers(&mut self) -> timers::Timers {
        self.note_rti_time();
        let servo = u32::from(self.core.load().motors).saturating_mul(u32::from(self.cfg.servo_units_per_motor));
        self.timer_scale().timers(servo, self.rti_units())
    }

    /// Y:$00000B (UM p.239): the RTI time of the load as it stands joins the largest since
    /// power-up/reset.
    pub(super) fn note_rti_time(&mut self) {
        let servo = u32::from(self.core.load().motors).saturating_mul(u32::from(self.cfg.servo_units_per_motor));
        let now = self.timer_scale().rti_task(self.rti_units(), servo);
        self.rti_time_max = self.rti_time_max.max(now);
    }

    /// The CPU units of the RTI's task set (UM p.236): PLC 0, and the planning of the next
    /// move while a program executes moves (the core's own rule, `Core::rti_cycle`).
    fn rti_units(&self) -> u32 {
        let planning = if self.core.motion().plans_moves() { u32::from(self.cfg.move_planning_units) } else { 0 };
        u32::from(self.core.load().plc0_units).saturating_add(planning)
    }

    /// Writes `value` where `d` points (an M-variable assignment or one value of a direct
    /// memory write). A write into I-variable storage goes to the core past I41 (SRM p.57).
    fn write_through(&mut self, d: Definition, value: f64) -> Answer {
        let (address, spaces): (u32, &[Space]) = match d {
            Definition::SelfReferenced => return Answer::Nothing,
            Definition::Word { space: Space::X, address, .. } => (address, &[Space::X]),
            Definition::Word { space: Space::Y, address, .. } => (address, &[Space::Y]),
            Definition::Fixed { address, .. } | Definition::Float { address, .. } => (address, &[Space::X, Space::Y]),
        };
        if let Some(r) = spaces.iter().find_map(|s| Register::at(*s, address)) {
            // SRM p.289: bit 22 of X:$000006 stays set "until the card is reset, or until this
            // bit is manually changed to 0": a host write that leaves it 0 clears it, through
            // the core's own event (recorded in a capture as the event it is). The word's other
            // bits stay the firmware's (MODEL).
            if r == Register::StatusX {
                let written = match d {
                    Definition::Word { offset, width, format, .. } => {
                        mvar::with_field(self.word_at(Space::X, address), offset, width, format, mvar::whole(value))
                    }
                    Definition::Fixed { dual_ported, .. } => {
                        let v = mvar::whole(value);
                        if dual_ported {
                            mvar::split32(v).0
                        } else {
                            mvar::split48(v).0
                        }
                    }
                    Definition::Float { .. } | Definition::SelfReferenced => self.word_at(Space::X, address),
                };
                if written & core::bits::RTI_REENTRY == 0
                    && self.word_at(Space::X, address) & core::bits::RTI_REENTRY != 0
                {
                    self.host_clears_rti_reentry();
                }
                return Answer::Nothing;
            }
            if !std::mem::replace(&mut self.register_write_said, true) {
                let line = format!(
                    "a host wrote to {r:?}'s register at {}: not applied, the firmware owns it (MODEL; said once)",
                    self.moment()
                );
                self.say(&line);
            }
            return Answer::Nothing;
        }
        let i_variable = self.mvars.i_variable_at(address);
        let stored = match d {
            Definition::Word { space, address, offset, width, format } => {
                let word = mvar::with_field(self.word_at(space, address), offset, width, format, mvar::whole(value));
                match i_variable {
                    Some(i) => {
                        let (x, y) = mvar::split48(self.core.read_i(i, &self.store).unwrap_or(0));
                        let v = if space == Space::X { mvar::join48(word, y) } else { mvar::join48(x, word) };
                        return self.core_answer(&HostCommand::WriteIMemory(i, v));
                    }
                    None => self.mvars.set_word(space, address, word),
                }
            }
            Definition::Fixed { address, dual_ported } => {
                let v = mvar::whole(value);
                if let Some(i) = i_variable {
                    return self.core_answer(&HostCommand::WriteIMemory(i, v));
                }
                let (x, y) = if dual_ported { mvar::split32(v) } else { mvar::split48(v) };
                self.mvars.set_word(Space::X, address, x).and_then(|()| self.mvars.set_word(Space::Y, address, y))
            }
            Definition::Float { address, .. } => {
                if let Some(i) = i_variable {
                    return self.core_answer(&HostCommand::WriteIMemory(i, mvar::whole(value)));
                }
                self.mvars.set_float(address, value)
            }
            Definition::SelfReferenced => Ok(()),
        };
        match stored {
            Ok(()) => Answer::Nothing,
            // MODEL: the emulator's bound on kept words (mvar::WORDS_MAX); a card has the memory.
            Err(_) => Answer::Error(3),
        }
    }
}

/// Pushes `answer`; false when it is an error, which ends the command (the card runs nothing
/// after an error in a line).
fn push_unless_error(out: &mut Vec<Answer>, answer: Answer) -> bool {
    let ok = !matches!(answer, Answer::Error(_));
    out.push(answer);
    ok
}
