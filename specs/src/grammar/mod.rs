//! The card's command-line grammar: how one line of text becomes the on-line commands a Turbo
//! PMAC executes, in order.
//!
//! A host may run commands together without separators: DLS's `dls-pmaccontrol` polls with
//! `i65???&1??%#1?PVF m190 p99#2?PVF ...`, and the SRM's own examples do the same
//! (`@0&1B1R@1&1B7R`, SRM p.259). Spaces are allowed between commands and ignored. What
//! makes this readable without separators is that every command starts with a fixed symbol or
//! keyword and takes only what its own syntax allows (a number after `I`, a value after `=`),
//! so the next command starts where the previous one's syntax ends.
//!
//! Motor commands (`?`, `P`, `V`, `F`, `J+`, `K`, `HM`) act on the motor last addressed with
//! `#n`, coordinate-system commands (`??`, `%`, `A`, `R`, `Qn`) on the C.S. last addressed with
//! `&n`; the addressing stays until changed, on this port only (SRM p.270: "the individual motor
//! addressed with the # command"; UM p.46: motor-, C.S.-specific and global on-line commands),
//! so it is kept per connection in [`Addressing`]. Control characters are commands of their
//! own that need no carriage return (SRM p.259), so they may appear anywhere in a line.
//!
//! The parser stops at the first command it cannot read: the card answers ERR003 there and
//! runs nothing after it (`framing`'s module text says why).

pub mod definition;

use crate::vocab::command::{CsCommand, GlobalCommand, Motion, MotorCommand, Space, COORDINATE_SYSTEM_MAX, MOTOR_MAX};
use definition::{parse_address, Definition, Format};

/// The motor and coordinate system a connection addresses. A card powers up addressing motor
/// 1 and C.S. 1 (the SRM's examples send `J+` and `P1` without a `#` first, SRM p.259).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Addressing {
    pub motor: u8,
    pub cs: u8,
}

impl Default for Addressing {
    fn default() -> Self {
        Addressing { motor: 1, cs: 1 }
    }
}

/// The four kinds of numbered variable (UM p.243: 8192 of each, 0..8191).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum VarKind {
    I,
    M,
    P,
    Q,
}

/// The highest number of an I-, M-, P- or Q-variable (UM p.243).
pub const VARIABLE_MAX: u16 = 8191;

/// A character that would make a value the start of an expression (`I124=I124&$FDFFFF`),
/// which the emulator does not evaluate.
fn is_operator(c: u8) -> bool {
    matches!(c, b'&' | b'|' | b'*' | b'+' | b'-' | b'/' | b'^')
}

/// The largest feedrate override `%` takes, in percent. MODEL: the override register holds
/// I10-scaled time (PMAC-SRM p.29: delta-time is I10*(%value/100)) in a 24-bit word; this
/// bound keeps a value the emulator prints back within what that word could hold.
pub const FEED_MAX: f64 = 838_860.0;

/// How a jog command ends (SRM on-line commands `J+`, `J-`, `J/`, `J=`, `J^`, `J:`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Jog {
    Plus,
    Minus,
    Stop,
    /// `J=` to the last jog position, `J={value}` to a position in counts.
    To(Option<f64>),
    /// `J^{value}`: a distance from the present actual position; `J:{value}` from the commanded one.
    Relative(f64),
}

/// The data-gathering commands dls-pmaccontrol's gather window sends.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Gather {
    /// `DEFINE GATHER [n]`: reserve the buffer (n words; all free memory without n).
    Define(Option<u32>),
    /// `GATHER`: start gathering.
    Start,
    /// `ENDGATHER`: stop.
    End,
    /// `LIST GATHER`: report what was gathered.
    List,
    /// `DELETE GATHER`: free the buffer.
    Delete,
}

/// One on-line command with its motor or C.S. resolved from the addressing.
#[derive(Clone, Debug, PartialEq)]
pub enum Command {
    /// `???`
    GlobalStatus,
    /// `??` of a C.S.
    CsStatus(u8),
    /// `?` of a motor.
    MotorStatus(u8),
    /// `P`, `V`, `F` of a motor.
    Position(u8),
    Velocity(u8),
    FollowingError(u8),
    /// `#` alone: report the addressed motor; `&` alone: the addressed C.S.
    ReportMotor,
    ReportCs,
    /// `%` of a C.S.: report its feedrate override.
    FeedRead(u8),
    /// `In`, `In..m`, `Mn`, `Pn`, `Qn` (Q-variables of the addressed C.S.).
    Read {
        kind: VarKind,
        first: u16,
        last: u16,
        cs: u8,
    },
    /// `In=v` and the like. `text` is the value as sent (an I-variable keeps its integer).
    Write {
        kind: VarKind,
        number: u16,
        value: f64,
        cs: u8,
    },
    /// `Mn[..m]->{definition}`: M-variable definitions (`M190->Y:$078F00,0,24,S`, UM p.246).
    MDefine {
        first: u16,
        last: u16,
        definition: Definition,
    },
    /// `Mn[..m]->`: report the definitions (PMAC-SRM p.253).
    MReport {
        first: u16,
        last: u16,
    },
    /// `Mn[..m]=v`: M-variable assignments (PMAC-SRM p.253: `M1..8=0`).
    MWrite {
        first: u16,
        last: u16,
        value: f64,
    },
    /// `W{X|Y|D|L}:{address},{value}[,{value}...]`: a direct memory write (SRM p.57), each value
    /// to the next address, as through an M-variable of `kind` (a whole 24-bit word for X and
    /// Y). MODEL: the pages at hand name the command, not its syntax; this is the PMAC family's
    /// `W{address},{constant}[,{constant}...]` form.
    MemoryWrite {
        kind: Definition,
        values: Vec<f64>,
    },
    /// `MSn,Im` and `MSn,Im=v`: a MACRO station's I-variable.
    MacroStation {
        station: u8,
        ivar: u16,
        value: Option<f64>,
    },
    /// `RHX:$25`: a register read, in the vocabulary's text form for its parser.
    ReadHex(String),
    /// A motion or stop command for the core (motor, C.S. or global; UM p.217).
    Motion(Motion),
    /// A jog with a target the vocabulary does not carry (`J=1000`, `J^1000`).
    Jog(u8, Jog),
    /// `HM` / `HOME`: a homing search move.
    Home(u8),
    /// `OPEN PLC n`, `OPEN PROG n`, `CLOSE`.
    OpenPlc(u8),
    OpenProgram(u16),
    Close,
    /// `ENABLE PLC n[,m...]`, `DISABLE PLC n`, and the PLCC forms.
    PlcSwitch,
    /// `$$$`
    Reset,
    /// `$$$***`: re-initialize to the factory defaults (UM p.243).
    Reinitialize,
    /// `CHECKSUM` / `CHKS`: the firmware's reference checksum (SRM p.295).
    Checksum,
    /// `<MEMORY-WRITE In=v>`: the vocabulary's pseudo-command for an M-variable assignment or a
    /// direct memory write into I-variable n's storage, which I41 does not lock (SRM p.57).
    WriteIMemory(u16, i64),
    /// `SAVE`
    Save,
    Version,
    CardId,
    Gather(Gather),
    /// A control character with no effect on this card (`<CTRL-X>`: nothing in progress to cancel).
    Ignored(u8),
}

/// Why a command could not be read: the card answers ERR003 (data error or unrecognized command).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Unreadable {
    /// The text from where the unreadable command starts.
    pub at: String,
    pub why: &'static str,
}

/// Reads a line into its commands, in order, updating `addressing` as `#n` and `&n` go by.
/// The last element is the error, if any; nothing after it is read.
pub fn parse_line(line: &[u8], addressing: &mut Addressing) -> Vec<Result<Command, Unreadable>> {
    parse_commands(line, addressing).into_iter().map(|(c, _)| c).collect()
}

/// As [`parse_line`], with where in `line` each command ends (an `OPEN` makes the rest of the
/// line program text, which the card then reads differently).
pub fn parse_commands(line: &[u8], addressing: &mut Addressing) -> Vec<(Result<Command, Unreadable>, usize)> {
    let mut p = Parser { s: line, i: 0, addressing };
    let mut out = Vec::new();
    while let Some(next) = p.next_command() {
        let failed = next.is_err();
        out.push((next, p.i));
        if failed {
            break;
        }
    }
    out
}

struct Parser<'a, 'b> {
    s: &'a [u8],
    i: usize,
    addressing: &'b mut Addressing,
}

/// Multi-letter keywords, longest first where one is a prefix of another, each with what it
/// starts. Single letters (`P`, `V`, `K`, `A`, ...) are tried only when none of these matches,
/// so that `SAVE` is not `S` (step) and `HM` is not `H` (hold).
const KEYWORDS: [&str; 24] = [
    "ENDGATHER",
    "CHECKSUM",
    "ENDG",
    "DEFINE",
    "DELETE",
    "DISABLE",
    "ENABLE",
    "GATHER",
    "CLOSE",
    "HOME",
    "LIST",
    "OPEN",
    "SAVE",
    "VER",
    "CID",
    "DEF",
    "DEL",
    "DIS",
    "ENA",
    "GAT",
    "LIS",
    "CHKS",
    "HM",
    "MS",
];

impl Parser<'_, '_> {
    fn peek(&self) -> Option<u8> {
        self.s.get(self.i).map(u8::to_ascii_uppercase)
    }

    fn skip_spaces(&mut self) {
        while matches!(self.s.get(self.i), Some(b' ' | b'\t')) {
            self.i += 1;
        }
    }

    fn starts_with(&self, word: &str) -> bool {
        let w = word.as_bytes();
        self.s.len() >= self.i + w.len() && self.s[self.i..self.i + w.len()].eq_ignore_ascii_case(w)
    }

    fn error(&self, start: usize, why: &'static str) -> Unreadable {
        Unreadable { at: String::from_utf8_lossy(&self.s[start..]).into_owned(), why }
    }

    /// Decimal digits as a number (at most 9 of them); `None` when there are none.
    fn number(&mut self) -> Option<u32> {
        let start = self.i;
        while self.peek().is_some_and(|c| c.is_ascii_digit()) && self.i - start < 9 {
            self.i += 1;
        }
        std::str::from_utf8(&self.s[start..self.i]).ok()?.parse().ok()
    }

    /// A constant: optional sign, `$hex` or decimal with an optional fraction.
    fn value(&mut self) -> Option<f64> {
        self.skip_spaces();
        let negative = match self.peek() {
            Some(b'-') => {
                self.i += 1;
                true
            }
            Some(b'+') => {
                self.i += 1;
                false
            }
            _ => false,
        };
        let magnitude = if self.peek() == Some(b'$') {
            self.i += 1;
            let start = self.i;
            while self.peek().is_some_and(|c| c.is_ascii_hexdigit()) && self.i - start < 12 {
                self.i += 1;
            }
            let digits = std::str::from_utf8(&self.s[start..self.i]).ok()?;
            i64::from_str_radix(digits, 16).ok()? as f64
        } else {
            let start = self.i;
            while self.peek().is_some_and(|c| c.is_ascii_digit() || c == b'.') && self.i - start < 24 {
                self.i += 1;
            }
            let text = std::str::from_utf8(&self.s[start..self.i]).ok()?;
            if !text.bytes().any(|c| c.is_ascii_digit()) {
                return None;
            }
            text.parse::<f64>().ok()?
        };
        Some(if negative { -magnitude } else { magnitude })
    }

    fn next_command(&mut self) -> Option<Result<Command, Unreadable>> {
        // Addressing (`#n`, `&n`) answers nothing: read on to the command that follows it.
        loop {
            self.skip_spaces();
            let start = self.i;
            let c = self.peek()?;
            if c == b'#' || c == b'&' {
                self.i += 1;
                match self.address(start, c == b'#') {
                    Ok(true) => continue,
                    Ok(false) => return Some(Ok(if c == b'#' { Command::ReportMotor } else { Command::ReportCs })),
                    Err(e) => return Some(Err(e)),
                }
            }
            return Some(self.command(c, start));
        }
    }

    fn command(&mut self, c: u8, start: usize) -> Result<Command, Unreadable> {
        match c {
            0..=0x1F => {
                self.i += 1;
                self.control(c, start)
            }
            b'?' => {
                let mut n = 0;
                while self.peek() == Some(b'?') && n < 3 {
                    self.i += 1;
                    n += 1;
                }
                Ok(match n {
                    3 => Command::GlobalStatus,
                    2 => Command::CsStatus(self.addressing.cs),
                    _ => Command::MotorStatus(self.addressing.motor),
                })
            }
            b'%' => {
                self.i += 1;
                self.skip_spaces();
                if self.peek().is_some_and(|c| c.is_ascii_digit() || c == b'.') {
                    match self.value() {
                        // The vocabulary's feedrate is whole percent; the card's `%` takes
                        // fractions, rounded here. The range is the card's (0 to 838860%).
                        Some(v) if (0.0..=FEED_MAX).contains(&v) => {
                            Ok(self.cs_command(CsCommand::Feedrate(v.round().min(f64::from(u16::MAX)) as u16)))
                        }
                        _ => Err(self.error(start, "a feedrate override is 0 to 838860 %")),
                    }
                } else {
                    Ok(Command::FeedRead(self.addressing.cs))
                }
            }
            b'$' if self.starts_with("$$$") => {
                self.i += 3;
                if self.starts_with("***") {
                    self.i += 3;
                    return Ok(Command::Reinitialize);
                }
                Ok(Command::Reset)
            }
            b'<' if self.starts_with("<MEMORY-WRITE") => self.memory_write(start),
            b'/' => {
                self.i += 1;
                Ok(self.cs_command(CsCommand::EndOfMove))
            }
            b'\\' => {
                self.i += 1;
                Ok(self.cs_command(CsCommand::QuickStop))
            }
            b'A'..=b'Z' => self.word(start),
            _ => Err(self.error(start, "no command starts with this character")),
        }
    }

    fn control(&mut self, c: u8, start: usize) -> Result<Command, Unreadable> {
        // SRM p.259-260 and the stop table, UM p.217.
        let global = match c {
            0x01 => GlobalCommand::AbortAll,
            0x0B => GlobalCommand::KillAll,
            0x0F => GlobalCommand::HoldAll,
            0x11 => GlobalCommand::QuitAll,
            // <CTRL-X> cancels communications in progress: a request is answered whole, so
            // nothing is ever in progress (SRM p.263).
            0x18 => return Ok(Command::Ignored(c)),
            _ => return Err(self.error(start, "this control character is not emulated")),
        };
        Ok(Command::Motion(Motion::Global(global)))
    }

    /// After `#` or `&`: `Ok(true)` when a number followed and is now addressed, `Ok(false)`
    /// when none did (the command then reports the addressed motor or C.S.).
    fn address(&mut self, start: usize, motor: bool) -> Result<bool, Unreadable> {
        self.skip_spaces();
        let Some(n) = self.number() else {
            return Ok(false);
        };
        let max = if motor { MOTOR_MAX } else { COORDINATE_SYSTEM_MAX };
        match u8::try_from(n) {
            Ok(n) if (1..=max).contains(&n) => {
                if motor {
                    self.addressing.motor = n;
                } else {
                    self.addressing.cs = n;
                }
                Ok(true)
            }
            _ => Err(self.error(start, if motor { "motors are #1..#32" } else { "coordinate systems are &1..&16" })),
        }
    }

    /// `<MEMORY-WRITE In=v>` up to its `>`: read by the vocabulary's own parser, so the
    /// emulator and a trace read it alike.
    fn memory_write(&mut self, start: usize) -> Result<Command, Unreadable> {
        let Some(len) = self.s[self.i..].iter().position(|&c| c == b'>') else {
            return Err(self.error(start, "<MEMORY-WRITE ...> ends with `>`"));
        };
        let text = String::from_utf8_lossy(&self.s[self.i..=self.i + len]).into_owned();
        match crate::vocab::HostCommand::parse(&text) {
            Ok(crate::vocab::HostCommand::WriteIMemory(n, v)) => {
                self.i += len + 1;
                Ok(Command::WriteIMemory(n, v))
            }
            _ => Err(self.error(start, "a memory write is <MEMORY-WRITE In=v>, n in 0..8191")),
        }
    }

    fn cs_command(&self, c: CsCommand) -> Command {
        Command::Motion(Motion::CoordinateSystem(self.addressing.cs, c))
    }

    fn motor_command(&self, c: MotorCommand) -> Command {
        Command::Motion(Motion::Motor(self.addressing.motor, c))
    }

    fn word(&mut self, start: usize) -> Result<Command, Unreadable> {
        if let Some(k) = KEYWORDS.iter().find(|k| self.starts_with(k)) {
            self.i += k.len();
            return self.keyword(k, start);
        }
        // `RHX:$25`, `RHY:$000025`: a register read.
        if self.starts_with("RH") {
            let from = self.i;
            self.i += 2;
            while self.peek().is_some_and(|c| matches!(c, b'X' | b'Y' | b':' | b'$' | b' ') || c.is_ascii_hexdigit()) {
                self.i += 1;
            }
            return Ok(Command::ReadHex(String::from_utf8_lossy(&self.s[from..self.i]).trim().to_string()));
        }
        // `WX:$2082,7`: a direct memory write (SRM p.57).
        if self.peek() == Some(b'W')
            && matches!(self.s.get(self.i + 1).map(u8::to_ascii_uppercase), Some(b'X' | b'Y' | b'D' | b'L'))
        {
            self.i += 1;
            return self.memory_write_command(start);
        }
        let letter = self.peek().unwrap_or(b' ');
        self.i += 1;
        let followed_by_digit = self.peek().is_some_and(|c| c.is_ascii_digit());
        let kind = match letter {
            b'I' => Some(VarKind::I),
            b'M' => Some(VarKind::M),
            b'P' => Some(VarKind::P),
            b'Q' => Some(VarKind::Q),
            _ => None,
        };
        if let (Some(kind), true) = (kind, followed_by_digit) {
            return self.variable(kind, start);
        }
        let motor = self.addressing.motor;
        Ok(match letter {
            b'P' => Command::Position(motor),
            b'V' => Command::Velocity(motor),
            b'F' => Command::FollowingError(motor),
            b'K' => self.motor_command(MotorCommand::Kill),
            b'J' => return self.jog(start),
            b'A' => self.cs_command(CsCommand::Abort),
            b'Q' => self.cs_command(CsCommand::Quit),
            b'H' => self.cs_command(CsCommand::Hold),
            b'R' => self.cs_command(CsCommand::Run),
            b'S' => self.cs_command(CsCommand::Step),
            b'B' => {
                // `B` or `B{program}`: the program number is not kept (the core runs none).
                self.number();
                self.cs_command(CsCommand::Begin)
            }
            _ => return Err(self.error(start, "not a command this emulator knows")),
        })
    }

    fn jog(&mut self, start: usize) -> Result<Command, Unreadable> {
        let motor = self.addressing.motor;
        let c = self.peek();
        self.i += 1;
        match c {
            Some(b'+') => Ok(self.motor_command(MotorCommand::JogPlus)),
            Some(b'-') => Ok(self.motor_command(MotorCommand::JogMinus)),
            Some(b'/') => Ok(self.motor_command(MotorCommand::JogStop)),
            Some(b'=') => {
                let at = self.i;
                match self.value() {
                    Some(v) => Ok(Command::Jog(motor, Jog::To(Some(v)))),
                    None => {
                        self.i = at;
                        Ok(Command::Jog(motor, Jog::To(None)))
                    }
                }
            }
            Some(b'^' | b':') => match self.value() {
                Some(v) => Ok(Command::Jog(motor, Jog::Relative(v))),
                None => Err(self.error(start, "J^ and J: take a distance")),
            },
            _ => Err(self.error(start, "J is followed by +, -, /, =, ^ or :")),
        }
    }

    fn variable(&mut self, kind: VarKind, start: usize) -> Result<Command, Unreadable> {
        let too_high = "variables are numbered 0..8191";
        let first = match self.number().and_then(|n| u16::try_from(n).ok()) {
            Some(n) if n <= VARIABLE_MAX => n,
            _ => return Err(self.error(start, too_high)),
        };
        let cs = self.addressing.cs;
        if kind == VarKind::M {
            return self.m_variable(first, start);
        }
        self.skip_spaces();
        if self.starts_with("..") {
            self.i += 2;
            return match self.number().and_then(|n| u16::try_from(n).ok()) {
                Some(last) if last <= VARIABLE_MAX && last >= first => Ok(Command::Read { kind, first, last, cs }),
                _ => Err(self.error(start, "a range runs from a lower to a higher number, at most 8191")),
            };
        }
        if self.starts_with("->") {
            return Err(self.error(start, "only M-variables are defined with ->"));
        }
        if self.peek() == Some(b'=') {
            self.i += 1;
            return match self.value() {
                // A value must end where the next command can start: `I124=I124&$FDFFFF`
                // is an expression, which the emulator does not evaluate.
                Some(value) if !self.peek().is_some_and(is_operator) => {
                    Ok(Command::Write { kind, number: first, value, cs })
                }
                _ => Err(self.error(start, "the value is a constant (expressions are not evaluated)")),
            };
        }
        Ok(Command::Read { kind, first, last: first, cs })
    }

    /// `Mn`, `Mn..m`, `Mn->`, `Mn->{definition}`, `Mn=v`, each also over a range.
    fn m_variable(&mut self, first: u16, start: usize) -> Result<Command, Unreadable> {
        let mut last = first;
        self.skip_spaces();
        if self.starts_with("..") {
            self.i += 2;
            last = match self.number().and_then(|n| u16::try_from(n).ok()) {
                Some(l) if l <= VARIABLE_MAX && l >= first => l,
                _ => return Err(self.error(start, "a range runs from a lower to a higher number, at most 8191")),
            };
        }
        if self.starts_with("->") {
            self.i += 2;
            let from = self.i;
            // The definition runs to the next space (`Y:$078F00,0,24,S`, `*`).
            while self.s.get(self.i).is_some_and(|c| *c > b' ') {
                self.i += 1;
            }
            if self.i == from {
                return Ok(Command::MReport { first, last });
            }
            let text = String::from_utf8_lossy(&self.s[from..self.i]).into_owned();
            return match Definition::parse(&text) {
                Ok(definition) => Ok(Command::MDefine { first, last, definition }),
                Err(why) => Err(self.error(start, why)),
            };
        }
        if self.peek() == Some(b'=') {
            self.i += 1;
            return match self.value() {
                Some(value) if !self.peek().is_some_and(is_operator) => Ok(Command::MWrite { first, last, value }),
                _ => Err(self.error(start, "the value is a constant (expressions are not evaluated)")),
            };
        }
        Ok(Command::Read { kind: VarKind::M, first, last, cs: self.addressing.cs })
    }

    /// `WX:$2082,7`, `WY:$10000,1,2,3`, `WD:$2028,4096`, `WL:$1000,1.5`.
    fn memory_write_command(&mut self, start: usize) -> Result<Command, Unreadable> {
        let letter = self.peek();
        self.i += 1;
        if self.peek() == Some(b':') {
            self.i += 1;
        }
        let from = self.i;
        while self.peek().is_some_and(|c| c == b'$' || c.is_ascii_hexdigit()) {
            self.i += 1;
        }
        let text = String::from_utf8_lossy(&self.s[from..self.i]).into_owned();
        let address = parse_address(&text).map_err(|why| self.error(start, why))?;
        let mut values = Vec::new();
        while self.peek() == Some(b',') {
            self.i += 1;
            match self.value() {
                Some(v) => values.push(v),
                None => {
                    return Err(self.error(start, "W{X|Y|D|L}:{address},{value}[,{value}...]: each value is a constant"))
                }
            }
        }
        if values.is_empty() {
            return Err(self.error(start, "W{X|Y|D|L}:{address},{value}[,{value}...] writes at least one value"));
        }
        if u64::from(address) + values.len() as u64 - 1 > u64::from(definition::ADDRESS_MAX) {
            return Err(self.error(start, "the values run past the last address, $7FFFF"));
        }
        let kind = match letter {
            Some(b'X') => Definition::Word { space: Space::X, address, offset: 0, width: 24, format: Format::U },
            Some(b'Y') => Definition::Word { space: Space::Y, address, offset: 0, width: 24, format: Format::U },
            Some(b'D') => Definition::Fixed { address, dual_ported: false },
            _ => Definition::Float { address, dual_ported: false },
        };
        Ok(Command::MemoryWrite { kind, values })
    }

    fn keyword(&mut self, k: &str, start: usize) -> Result<Command, Unreadable> {
        Ok(match k {
            "VER" => Command::Version,
            "CID" => Command::CardId,
            "SAVE" => Command::Save,
            "CHECKSUM" | "CHKS" => Command::Checksum,
            "CLOSE" => Command::Close,
            "HM" | "HOME" => Command::Home(self.addressing.motor),
            "GATHER" | "GAT" => Command::Gather(Gather::Start),
            "ENABLE" | "ENA" | "DISABLE" | "DIS" => {
                self.skip_spaces();
                if !self.starts_with("PLC") {
                    return Err(self.error(start, "of ENABLE and DISABLE only the PLC forms are emulated"));
                }
                self.i += 3;
                if self.peek() == Some(b'C') {
                    self.i += 1;
                }
                // `n`, `n,m`, `n..m`.
                self.skip_spaces();
                if self.number().is_none() {
                    return Err(self.error(start, "ENABLE PLC takes PLC numbers"));
                }
                while self.peek().is_some_and(|c| c == b',' || c == b'.' || c.is_ascii_digit()) {
                    self.i += 1;
                }
                Command::PlcSwitch
            }
            "ENDGATHER" | "ENDG" => Command::Gather(Gather::End),
            "DEFINE" | "DEF" | "DELETE" | "DEL" | "LIST" | "LIS" => {
                self.skip_spaces();
                let what = ["GATHER", "GAT"].iter().find(|w| self.starts_with(w));
                let Some(w) = what else {
                    return Err(self.error(start, "of DEFINE, DELETE and LIST only the GATHER forms are emulated"));
                };
                self.i += w.len();
                Command::Gather(match k {
                    "DEFINE" | "DEF" => {
                        self.skip_spaces();
                        Gather::Define(self.number())
                    }
                    "DELETE" | "DEL" => Gather::Delete,
                    _ => Gather::List,
                })
            }
            "OPEN" => {
                self.skip_spaces();
                if self.starts_with("PLC") {
                    self.i += 3;
                    self.skip_spaces();
                    match self.number() {
                        Some(n) if n <= 31 => Command::OpenPlc(n as u8),
                        _ => return Err(self.error(start, "PLC programs are 0..31")),
                    }
                } else if self.starts_with("PROG") {
                    self.i += 4;
                    self.skip_spaces();
                    match self.number().and_then(|n| u16::try_from(n).ok()) {
                        Some(n) if n >= 1 => Command::OpenProgram(n),
                        _ => return Err(self.error(start, "motion programs are numbered from 1")),
                    }
                } else {
                    return Err(self.error(start, "OPEN PLC n and OPEN PROG n are emulated"));
                }
            }
            "MS" => {
                // `MS{station},I{n}[={value}]` (dls-pmaclib's getAxisMsIVars).
                let station = self.number().and_then(|n| u8::try_from(n).ok());
                self.skip_spaces();
                let comma = self.peek() == Some(b',');
                self.i += usize::from(comma);
                self.skip_spaces();
                let i = self.peek() == Some(b'I');
                self.i += usize::from(i);
                let ivar = self.number().and_then(|n| u16::try_from(n).ok());
                let (Some(station), true, true, Some(ivar)) = (station, comma, i, ivar) else {
                    return Err(self.error(start, "MS{station},I{n} is the MACRO station form emulated"));
                };
                let value = if self.peek() == Some(b'=') {
                    self.i += 1;
                    match self.value() {
                        Some(v) => Some(v),
                        None => return Err(self.error(start, "the value is a constant")),
                    }
                } else {
                    None
                };
                Command::MacroStation { station, ivar, value }
            }
            _ => unreachable!("every keyword is handled: {k}"),
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn parse(line: &str) -> Vec<Result<Command, Unreadable>> {
        parse_line(line.as_bytes(), &mut Addressing::default())
    }

    fn ok(line: &str) -> Vec<Command> {
        parse(line).into_iter().map(|r| r.unwrap_or_else(|e| panic!("{line}: {e:?}"))).collect()
    }

    #[test]
    fn the_dls_pmaccontrol_poll_line_reads_as_its_52_requests() {
        // commsThread.py builds this for 8 axes; the GUI splits the answer at CR and expects
        // 4 + 6 x 8 values, so each piece must be one command.
        let mut line = String::from("i65???&1??%");
        for m in 1..=8 {
            line += &format!("#{m}?PVF m{m}90 p99");
        }
        let cmds = ok(&line);
        assert_eq!(cmds.len(), 52);
        assert_eq!(cmds[0], Command::Read { kind: VarKind::I, first: 65, last: 65, cs: 1 });
        assert_eq!(cmds[1], Command::GlobalStatus);
        assert_eq!(cmds[2], Command::CsStatus(1));
        assert_eq!(cmds[3], Command::FeedRead(1));
        for m in 1..=8u8 {
            let row = &cmds[4 + 6 * usize::from(m - 1)..][..6];
            assert_eq!(
                row,
                [
                    Command::MotorStatus(m),
                    Command::Position(m),
                    Command::Velocity(m),
                    Command::FollowingError(m),
                    Command::Read {
                        kind: VarKind::M,
                        first: u16::from(m) * 100 + 90,
                        last: u16::from(m) * 100 + 90,
                        cs: 1
                    },
                    Command::Read { kind: VarKind::P, first: 99, last: 99, cs: 1 },
                ]
            );
        }
    }

    #[test]
    fn question_marks_count_one_two_or_three() {
        // `?` motor, `??` C.S., `???` global (SRM p.284 for ? and ??).
        let mut a = Addressing::default();
        let cmds: Vec<_> = parse_line(b"#3&2?????? ?", &mut a).into_iter().map(Result::unwrap).collect();
        assert_eq!(cmds, [Command::GlobalStatus, Command::GlobalStatus, Command::MotorStatus(3)]);
        assert_eq!(ok("&2??"), [Command::CsStatus(2)]);
    }

    #[test]
    fn addressing_persists_across_lines_of_one_connection() {
        let mut a = Addressing::default();
        parse_line(b"#4&3", &mut a);
        assert_eq!(a, Addressing { motor: 4, cs: 3 });
        let cmds: Vec<_> = parse_line(b"P ?? K", &mut a).into_iter().map(Result::unwrap).collect();
        assert_eq!(
            cmds,
            [Command::Position(4), Command::CsStatus(3), Command::Motion(Motion::Motor(4, MotorCommand::Kill))]
        );
        assert_eq!(parse_line(b"#", &mut a), [Ok(Command::ReportMotor)]);
    }

    #[test]
    fn jog_home_and_kill_as_the_gui_buttons_send_them() {
        assert_eq!(ok("#1J^1000"), [Command::Jog(1, Jog::Relative(1000.0))]);
        assert_eq!(ok("#1J^-250.5"), [Command::Jog(1, Jog::Relative(-250.5))]);
        assert_eq!(ok("#1HM"), [Command::Home(1)]);
        assert_eq!(ok("#1HOME"), [Command::Home(1)]);
        assert_eq!(ok("#1J/"), [Command::Motion(Motion::Motor(1, MotorCommand::JogStop))]);
        assert_eq!(ok("#1J=0"), [Command::Jog(1, Jog::To(Some(0.0)))]);
        assert_eq!(ok("#2J="), [Command::Jog(2, Jog::To(None))]);
        assert_eq!(ok("#1k"), [Command::Motion(Motion::Motor(1, MotorCommand::Kill))]);
        assert_eq!(
            ok("#1 J/ #2 K"),
            [
                Command::Motion(Motion::Motor(1, MotorCommand::JogStop)),
                Command::Motion(Motion::Motor(2, MotorCommand::Kill))
            ]
        );
    }

    #[test]
    fn control_characters_are_commands_anywhere_in_a_line() {
        // KILL ALL in dls-pmaccontrol sends CTRL-K as a line of its own (SRM p.289's <CTRL-K>).
        assert_eq!(ok("\x0b"), [Command::Motion(Motion::Global(GlobalCommand::KillAll))]);
        assert_eq!(ok("P1\x01P2").len(), 3);
        assert_eq!(ok("\x11\x0f")[1], Command::Motion(Motion::Global(GlobalCommand::HoldAll)));
        assert!(parse("\x02").last().unwrap().is_err(), "CTRL-B is not emulated: ERR003");
    }

    #[test]
    fn variables_read_write_and_ranges() {
        assert_eq!(ok("i20..23"), [Command::Read { kind: VarKind::I, first: 20, last: 23, cs: 1 }]);
        assert_eq!(ok("I124=$20001"), [Command::Write { kind: VarKind::I, number: 124, value: 131073.0, cs: 1 }]);
        assert_eq!(ok("P1=-1.5"), [Command::Write { kind: VarKind::P, number: 1, value: -1.5, cs: 1 }]);
        assert_eq!(ok("&2Q81"), [Command::Read { kind: VarKind::Q, first: 81, last: 81, cs: 2 }]);
        assert_eq!(ok("i6=1 i3=2 ver").len(), 3);
        assert!(parse("I8192").last().unwrap().is_err());
        assert!(parse("I124=I124&$FDFFFF").last().unwrap().is_err(), "expressions are refused, not half-run");
        let y = Definition::parse("Y:$078F00,0,24,S").unwrap();
        assert_eq!(
            ok("M190->Y:$078F00,0,24,S M191->* M0..8191->*"),
            [
                Command::MDefine { first: 190, last: 190, definition: y },
                Command::MDefine { first: 191, last: 191, definition: Definition::SelfReferenced },
                Command::MDefine { first: 0, last: 8191, definition: Definition::SelfReferenced },
            ]
        );
        assert_eq!(ok("M1..3->"), [Command::MReport { first: 1, last: 3 }], "a report, not a definition");
        assert_eq!(ok("M1..8=0"), [Command::MWrite { first: 1, last: 8, value: 0.0 }]);
        let x = Definition::Word { space: Space::X, address: 0x2082, offset: 0, width: 24, format: Format::U };
        assert_eq!(ok("WX:$2082,7,-1"), [Command::MemoryWrite { kind: x, values: vec![7.0, -1.0] }]);
        assert!(parse("M1->X:$25").last().unwrap().is_err(), "an X definition gives its bit");
        assert!(parse("P1->X:$0").last().unwrap().is_err());
        assert!(parse("I23..20").last().unwrap().is_err());
    }

    #[test]
    fn keywords_win_over_single_letters() {
        assert_eq!(ok("SAVE"), [Command::Save]);
        assert_eq!(
            ok("define gather 1000 gather list gather delete gather endgather"),
            [
                Command::Gather(Gather::Define(Some(1000))),
                Command::Gather(Gather::Start),
                Command::Gather(Gather::List),
                Command::Gather(Gather::Delete),
                Command::Gather(Gather::End),
            ]
        );
        assert_eq!(
            ok("ENABLE PLC 1,2 DISABLE PLCC 0..3 DIS PLC 5"),
            [Command::PlcSwitch, Command::PlcSwitch, Command::PlcSwitch]
        );
        assert_eq!(ok("ms0,i910"), [Command::MacroStation { station: 0, ivar: 910, value: None }]);
        assert_eq!(ok("OPEN PLC 1 CLOSE"), [Command::OpenPlc(1), Command::Close]);
        assert_eq!(
            ok("&1%50 %"),
            [Command::Motion(Motion::CoordinateSystem(1, CsCommand::Feedrate(50))), Command::FeedRead(1)]
        );
        assert_eq!(ok("RHX:$25"), [Command::ReadHex("RHX:$25".into())]);
        // UM p.243, SRM p.295, SRM p.57 (the memory write is the vocabulary's pseudo-command).
        assert_eq!(
            ok("$$$***CHKS checksum <memory-write i130=$10>I130"),
            [
                Command::Reinitialize,
                Command::Checksum,
                Command::Checksum,
                Command::WriteIMemory(130, 16),
                Command::Read { kind: VarKind::I, first: 130, last: 130, cs: 1 },
            ]
        );
        assert_eq!(ok("$$$ $$$***"), [Command::Reset, Command::Reinitialize]);
        assert!(parse("<MEMORY-WRITE I130>")[0].is_err(), "a memory write needs its value");
        assert!(parse("<MEMORY-WRITE I130=1")[0].is_err(), "and its closing `>`");
    }

    #[test]
    fn the_first_unreadable_command_ends_the_line() {
        let r = parse("I40 ZZZ I41");
        assert_eq!(r.len(), 2);
        let e = r[1].clone().unwrap_err();
        assert_eq!(e.at, "ZZZ I41");
        // Letters run together are commands of their own: `FOO` is `F` (following error),
        // then `O`, which starts nothing.
        let r = parse("FOO");
        assert_eq!(r[0], Ok(Command::FollowingError(1)));
        assert_eq!(r[1].clone().unwrap_err().at, "OO");
        assert!(parse("#33K").last().unwrap().is_err(), "motors are #1..#32");
        assert!(parse("&17A").last().unwrap().is_err());
        assert!(parse("$$$**").last().unwrap().is_err(), "`$$$` then `**`, which starts nothing");
    }
}
