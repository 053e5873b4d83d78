//! The card's M-variables as pointers into memory and its direct memory write: the commands of
//! `mvar.rs`'s syntax, answered against the core's registers, the core's I-variables (past I41,
//! SRM p.57) and the words the emulator keeps. `mvar.rs` says what each address reaches.

use super::Card;
use crate::framing::Answer;
use crate::memory::format_value;
use crate::mvar::{self, Definition};
use pmacwd_bridge::core_command;
use pmacwd_core as core;
use pmacwd_specs::grammar::VarKind;
use pmacwd_specs::vocab::command::{HostCommand, Register, Space};

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
