//! The card's stored program buffers: motion programs (`OPEN PROG n`) and PLC programs (`OPEN
//! PLC n`), their lines kept as a host downloads them and listed back with `LIST PROG n` and
//! `LIST PLC n` (UM p.48: "Each program command is added onto the end of the list of commands in
//! the open buffer"; "use the CLEAR command immediately after opening to erase the existing
//! contents"). Motion programs are run by the coordinate systems (`card/program.rs`).
//!
//! MODEL, where the pages at hand leave the card's own form open:
//!
//! - A card compiles each line into its internal code and lists that code back (UM p.46: I9
//!   chooses the long or the short form of the listing); the emulator keeps each line as the
//!   host sent it, in upper case (the card's commands are case-insensitive), with its comment
//!   (from `;`) and the spaces at either end taken off, and lists those lines, one answer each.
//! - `LIST PROG n,start[,length]`: `start` counts the stored lines from 0 (the card counts
//!   words of compiled code) and `length` lines are listed (all the rest without it).
//! - A buffer no line was ever stored in lists nothing.
//! - One buffer open at a time for the whole card (UM p.48: "Only one port at a time may have
//!   an open program buffer"), the core's open bits (Y:$000006 bits 17 and 19) its mark.
//! - Buffers follow SAVE and a reset as the I-variables do (UM p.243: active memory is
//!   volatile; SAVE copies it to flash, a reset copies flash back, `$$$***` puts the factory
//!   state, no programs, in use).

use std::collections::BTreeMap;

/// The most bytes of program text all buffers together hold. MODEL: a Turbo PMAC has some
/// hundreds of kilowords of user program memory; the bound keeps the emulator's memory
/// bounded whatever a host downloads. A line past it is refused (ERR003).
pub const TEXT_BYTES_MAX: usize = 4 << 20;

/// Which buffer.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
pub enum BufferId {
    Program(u16),
    Plc(u8),
}

#[derive(Clone, Debug, Default, PartialEq)]
struct Store {
    lines: BTreeMap<BufferId, Vec<String>>,
    bytes: usize,
}

/// Every buffer's lines, the saved copy, and which buffer is open for entry.
#[derive(Clone, Debug, Default)]
pub struct Buffers {
    active: Store,
    saved: Store,
    open: Option<BufferId>,
    /// Changes so far, the last change of each buffer, and of all at once (a reset): what a
    /// PLC was compiled from is still in use while its [`Buffers::version`] is unchanged.
    changes: u64,
    changed: BTreeMap<BufferId, u64>,
    all_changed: u64,
}

/// A line of program text as the emulator stores it: its comment off, trimmed, upper case;
/// `None` when nothing is left.
pub fn stored_form(text: &str) -> Option<String> {
    let code = text.split(';').next().unwrap_or_default().trim();
    (!code.is_empty()).then(|| code.to_ascii_uppercase())
}

impl Buffers {
    /// `OPEN PROG n` / `OPEN PLC n` accepted by the core.
    pub fn open(&mut self, id: BufferId) {
        self.open = Some(id);
    }

    /// `CLOSE`, or a reset.
    pub fn close(&mut self) {
        self.open = None;
    }

    /// The buffer open for entry.
    pub fn open_buffer(&self) -> Option<BufferId> {
        self.open
    }

    /// Program text sent while a buffer is open: `CLEAR` at its start erases the buffer (UM
    /// p.48), the rest is one stored line. `Err` when it would take the text past
    /// [`TEXT_BYTES_MAX`]; nothing is stored then.
    pub fn enter(&mut self, text: &str) -> Result<(), &'static str> {
        let Some(id) = self.open else { return Ok(()) };
        let Some(mut line) = stored_form(text) else { return Ok(()) };
        // CLEAR (possibly more than once) at the start of the line, as a word of its own.
        while let Some(rest) = line.strip_prefix("CLEAR") {
            if rest.chars().next().is_some_and(|c| c.is_ascii_alphanumeric()) {
                break;
            }
            if let Some(old) = self.active.lines.remove(&id) {
                self.active.bytes -= old.iter().map(String::len).sum::<usize>();
            }
            self.touch(id);
            line = rest.trim_start().to_string();
        }
        if line.is_empty() {
            return Ok(());
        }
        if self.active.bytes + line.len() > TEXT_BYTES_MAX {
            return Err("the program buffers are full (buffers::TEXT_BYTES_MAX)");
        }
        self.active.bytes += line.len();
        self.active.lines.entry(id).or_default().push(line);
        self.touch(id);
        Ok(())
    }

    fn touch(&mut self, id: BufferId) {
        self.changes += 1;
        self.changed.insert(id, self.changes);
    }

    /// A number that changes whenever buffer `id`'s lines may have changed.
    pub fn version(&self, id: BufferId) -> u64 {
        self.changed.get(&id).copied().unwrap_or(0).max(self.all_changed)
    }

    /// PLC `n`'s lines (none when it was never downloaded).
    pub fn plc(&self, n: u8) -> Option<&[String]> {
        self.active.lines.get(&BufferId::Plc(n)).map(Vec::as_slice)
    }

    /// The lines of buffer `id`, from line `start` (0: the first), at most `length` of them.
    pub fn list(&self, id: BufferId, start: Option<u32>, length: Option<u32>) -> &[String] {
        let lines = self.active.lines.get(&id).map_or(&[][..], Vec::as_slice);
        let from = start.map_or(0, |s| s as usize).min(lines.len());
        let to = length.map_or(lines.len(), |l| from.saturating_add(l as usize)).min(lines.len());
        &lines[from..to]
    }

    /// Motion program `n`'s lines (none when it was never downloaded).
    pub fn program(&self, n: u16) -> Option<&[String]> {
        self.active.lines.get(&BufferId::Program(n)).map(Vec::as_slice)
    }

    /// `SAVE`: the buffers in use are what a reset brings back.
    pub fn save(&mut self) {
        self.saved = self.active.clone();
    }

    /// `$$$`, INIT/, a power cycle: the saved buffers come back, none is open.
    pub fn reset(&mut self) {
        self.active = self.saved.clone();
        self.open = None;
        self.changes += 1;
        self.all_changed = self.changes;
    }

    /// `$$$***`: no programs in use; what was saved stays in flash for the next reset.
    pub fn reinitialize(&mut self) {
        self.active = Store::default();
        self.open = None;
        self.changes += 1;
        self.all_changed = self.changes;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn clear_erases_comments_go_and_the_partial_forms_list_a_slice() {
        let mut b = Buffers::default();
        b.open(BufferId::Program(10));
        for line in ["CLEAR", "linear ; the mode", "ABS", "", "; only a comment", "TM(Q70)"] {
            b.enter(line).unwrap();
        }
        assert_eq!(b.list(BufferId::Program(10), None, None), ["LINEAR", "ABS", "TM(Q70)"]);
        assert_eq!(b.list(BufferId::Program(10), Some(1), Some(1)), ["ABS"]);
        assert_eq!(b.list(BufferId::Program(10), Some(2), None), ["TM(Q70)"]);
        assert!(b.list(BufferId::Program(10), Some(9), Some(2)).is_empty());
        b.enter("CLEAR X10").unwrap();
        assert_eq!(b.list(BufferId::Program(10), None, None), ["X10"]);
        assert_eq!(b.enter("CLEARANCE=1"), Ok(()), "a word that only starts with CLEAR is stored");
        assert_eq!(b.list(BufferId::Program(10), None, None).len(), 2);
        b.close();
        b.enter("X20").unwrap();
        assert_eq!(b.list(BufferId::Program(10), None, None).len(), 2, "nothing is open");
    }

    #[test]
    fn the_text_is_bounded_and_follows_save_reset_and_reinitialization() {
        let mut b = Buffers::default();
        b.open(BufferId::Plc(1));
        let long = "P1=1".repeat(1000);
        let mut refused = false;
        for _ in 0..(TEXT_BYTES_MAX / long.len() + 2) {
            refused |= b.enter(&long).is_err();
        }
        assert!(refused);
        assert!(b.active.bytes <= TEXT_BYTES_MAX);
        b.enter("CLEAR").unwrap();
        assert_eq!(b.active.bytes, 0, "CLEAR gives the room back");
        b.enter("P1=1").unwrap();
        b.save();
        b.enter("P2=2").unwrap();
        b.reset();
        assert_eq!(b.list(BufferId::Plc(1), None, None), ["P1=1"]);
        assert_eq!(b.open_buffer(), None);
        b.reinitialize();
        assert!(b.list(BufferId::Plc(1), None, None).is_empty());
        b.reset();
        assert_eq!(b.list(BufferId::Plc(1), None, None), ["P1=1"], "flash kept it");
    }
}
