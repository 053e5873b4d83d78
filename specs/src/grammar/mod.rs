//! The card's command language, parsed once: how one line of text becomes the on-line commands
//! a Turbo PMAC executes, in order. The model's vocabulary ([`crate::vocab::HostCommand`]), the
//! host-log importer, `pmacwd record` and the emulator all read command lines here; there is
//! no second parser of host command lines in the workspace. `docs/grammar.md` is the reference
//! table, one row per command with its citation.
//!
//! A host may run commands together without separators: DLS's `dls-pmaccontrol` polls with
//! `i65???&1??%#1?PVF m190 p99#2?PVF ...`, and the SRM's own examples do the same
//! (`@0&1B1R@1&1B7R`, SRM p.259). Spaces are allowed between commands and ignored. What
//! makes this readable without separators is that every command starts with a fixed symbol or
//! keyword and takes only what its own syntax allows (a number after `I`, an expression after
//! `=`), so the next command starts where the previous one's syntax ends.
//!
//! Motor commands (`?`, `P`, `V`, `F`, `J+`, `K`, `HM`) act on the motor last addressed with
//! `#n`, coordinate-system commands (`??`, `%`, `A`, `R`, `Qn`, `#n->`) on the C.S. last
//! addressed with `&n`; the addressing stays until changed, on this port only (SRM p.270: "the
//! individual motor addressed with the # command"; UM p.46: motor-, C.S.-specific and global
//! on-line commands), so it is kept per connection in [`Addressing`]. Control characters are
//! commands of their own that need no carriage return (SRM p.259), so they may appear anywhere
//! in a line.
//!
//! Values after `=` are expressions ([`expr`]): `I120=I120+5`, `M162=1000/0.0009765625`,
//! `I(P1*100+20)=10`, `Q71=Q81`. The grammar reads them; the card that holds the variables
//! evaluates them.
//!
//! The parser stops at the first command it cannot read: the card answers ERR003 there and
//! runs nothing after it (facts page s.3: ERR003, "data error or unrecognized command").

pub mod definition;
pub mod expr;
mod host_command;

use crate::vocab::command::{CsCommand, GlobalCommand, Motion, MotorCommand, Space, COORDINATE_SYSTEM_MAX, MOTOR_MAX};
use definition::{parse_address, Definition, Format};
pub use expr::{Env, EvalError, Expr, Index};
use std::fmt;

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
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum VarKind {
    I,
    M,
    P,
    Q,
}

/// The highest number of an I-, M-, P- or Q-variable (UM p.243).
pub const VARIABLE_MAX: u16 = 8191;

pub use crate::vocab::command::VarRange;

/// Which variables a read or an assignment names.
#[derive(Clone, Debug, PartialEq)]
pub enum Vars {
    Numbers(VarRange),
    /// `I(P1*100+20)`: the number computed on the card (UM p.248).
    Computed(Expr),
}

/// What an assignment gives.
#[derive(Clone, Debug, PartialEq)]
pub enum Assigned {
    Expr(Expr),
    /// `I130=*`: the variable's factory default (SRM on-line commands, `I{data}=*`).
    Default,
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
    /// `J^{value}`: a distance from the present actual position.
    ByFromActual(f64),
    /// `J:{value}`: a distance from the present commanded position.
    ByFromCommanded(f64),
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

/// A buffer `LIST` reports (SRM on-line commands `LIST PROG`, `LIST PLC`, `LIST FORWARD`,
/// `LIST INVERSE`), with the `,start[,length]` of the partial forms.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Listing {
    Program {
        number: u16,
        start: Option<u32>,
        length: Option<u32>,
    },
    Plc {
        number: u8,
        start: Option<u32>,
        length: Option<u32>,
    },
    /// Forward and inverse kinematics of a C.S. (`&1 list forward,0,1`, the EPICS driver).
    Forward {
        cs: u8,
        start: Option<u32>,
        length: Option<u32>,
    },
    Inverse {
        cs: u8,
        start: Option<u32>,
        length: Option<u32>,
    },
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
    /// `%{constant}` of a C.S.: set its feedrate override, in percent (0 holds the C.S.).
    Feed {
        cs: u8,
        percent: f64,
    },
    /// `In`, `In..m`, `In,count,step`, `I(expr)`; and of `M`, `P`, `Q` (Q of the addressed C.S.).
    Read {
        kind: VarKind,
        vars: Vars,
        cs: u8,
    },
    /// `In=expr`, `In=*`, `Mn..m=expr`, `Q71=Q81`, `I(P1*100+20)=10`.
    Write {
        kind: VarKind,
        vars: Vars,
        value: Assigned,
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
    /// `RHX:$25`, `RHY:$000025`: read a 24-bit word in hex (SRM p.295 `RH`).
    ReadHex {
        space: Space,
        address: u32,
    },
    /// A motion or stop command for the core (motor, C.S. or global; UM p.217).
    Motion(Motion),
    /// A jog with a target or a distance (`J=1000`, `J^1000`, `J:-5`).
    Jog(u8, Jog),
    /// `HM` / `HOME`: a homing search move; `HMZ` / `HOMEZ`: zero the position where it stands.
    Home(u8),
    HomeZero(u8),
    /// `#m->{definition}` in C.S. `cs`: assign motor m to axes (`#1->1000X`, `#2->X+Y+10`,
    /// `#3->I` for inverse kinematics; SRM on-line commands `#{constant}->{axis definition}`).
    AxisDefine {
        cs: u8,
        motor: u8,
        definition: String,
    },
    /// `#m->` (and the EPICS driver's `#m->,`): report motor m's axis definition in C.S. `cs`.
    AxisReport {
        cs: u8,
        motor: u8,
    },
    /// `UNDEFINE`: erase the axis definitions of C.S. `cs`; `UNDEFINE ALL`: of every C.S.
    Undefine {
        cs: Option<u8>,
    },
    /// `B{n}` of C.S. `cs`: point it at the top of motion program n (SRM p.295); the core hears
    /// its `B` (`CsCommand::Begin`).
    Begin {
        cs: u8,
        program: Option<u16>,
    },
    /// `OPEN PLC n`, `OPEN PROG n`, `CLOSE`.
    OpenPlc(u8),
    OpenProgram(u16),
    Close,
    /// `ENABLE PLC n[,m...]`, `DISABLE PLC n..m`, and the PLCC forms: which programs (SRM p.39,
    /// I5: PLC 0 the foreground one, 1 to 31 the background ones).
    PlcSwitch(PlcSwitch),
    /// `LIST PROG n`, `LIST PLC n`, `LIST FORWARD`, `LIST INVERSE`.
    List(Listing),
    /// `DEFINE LOOKAHEAD {segments},{outputs}` of C.S. `cs`, and `DELETE ALL TEMPS`
    /// (the EPICS driver's C.S. group set-up): buffer management a host may send.
    DefineLookahead {
        cs: u8,
        segments: u32,
        outputs: u32,
    },
    DeleteAllTemps,
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
    /// `VER`, `CID`, `CPU`: firmware version, card ID, CPU type.
    Version,
    CardId,
    Cpu,
    Gather(Gather),
    /// A control character with no effect on this card (`<CTRL-X>`: nothing in progress to cancel).
    Ignored(u8),
}

/// `ENABLE PLC ...` / `DISABLE PLC ...` (`PLCC`: the compiled programs).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct PlcSwitch {
    pub enable: bool,
    pub compiled: bool,
    /// Bit n: PLC n (0..31).
    pub plcs: u32,
}

impl fmt::Display for PlcSwitch {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let verb = if self.enable { "ENABLE" } else { "DISABLE" };
        let kind = if self.compiled { "PLCC" } else { "PLC" };
        write!(f, "{verb} {kind} ")?;
        let numbers: Vec<String> = (0..32).filter(|n| self.plcs & (1 << n) != 0).map(|n: u32| n.to_string()).collect();
        f.write_str(&numbers.join(","))
    }
}

impl Command {
    /// How many values the card answers this command with (each ended by CR): `None` when the
    /// number depends on what the card holds (a listing). Any command may instead answer an
    /// error, which ends the line.
    pub fn values(&self) -> Option<usize> {
        Some(match self {
            Command::GlobalStatus
            | Command::CsStatus(_)
            | Command::MotorStatus(_)
            | Command::Position(_)
            | Command::Velocity(_)
            | Command::FollowingError(_)
            | Command::ReportMotor
            | Command::ReportCs
            | Command::FeedRead(_)
            | Command::ReadHex { .. }
            | Command::AxisReport { .. }
            | Command::Checksum
            | Command::Version
            | Command::CardId
            | Command::Cpu => 1,
            Command::Read { vars: Vars::Numbers(r), .. } => usize::from(r.count),
            Command::Read { vars: Vars::Computed(_), .. } => 1,
            Command::MReport { first, last } => usize::from(last - first) + 1,
            Command::MacroStation { value, .. } => usize::from(value.is_none()),
            Command::List(_) | Command::Gather(Gather::List) => return None,
            Command::Feed { .. }
            | Command::Write { .. }
            | Command::MDefine { .. }
            | Command::MemoryWrite { .. }
            | Command::Motion(_)
            | Command::Jog(..)
            | Command::Home(_)
            | Command::HomeZero(_)
            | Command::AxisDefine { .. }
            | Command::Undefine { .. }
            | Command::Begin { .. }
            | Command::OpenPlc(_)
            | Command::OpenProgram(_)
            | Command::Close
            | Command::PlcSwitch(_)
            | Command::DefineLookahead { .. }
            | Command::DeleteAllTemps
            | Command::Reset
            | Command::Reinitialize
            | Command::WriteIMemory(..)
            | Command::Save
            | Command::Gather(Gather::Define(_) | Gather::Start | Gather::End | Gather::Delete)
            | Command::Ignored(_) => 0,
        })
    }
}

/// Why a command could not be read: the card answers ERR003 (data error or unrecognized command).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Unreadable {
    /// The text from where the unreadable command starts.
    pub at: String,
    /// Where in the line it starts (a byte offset).
    pub offset: usize,
    pub why: &'static str,
}

/// Reads a line into its commands, in order, updating `addressing` as `#n` and `&n` go by.
/// The last element is the error, if any; nothing after it is read.
pub fn parse_line(line: &[u8], addressing: &mut Addressing) -> Vec<Result<Command, Unreadable>> {
    parse_commands(line, addressing).into_iter().map(|(c, _)| c).collect()
}

/// One command read from a line: the command (or why not), and the text it was read from.
#[derive(Clone, Debug, PartialEq)]
pub struct Piece {
    pub command: Result<Command, Unreadable>,
    /// Where its text starts and ends in the line (byte offsets), addressing included.
    pub start: usize,
    pub end: usize,
}

/// As [`parse_line`], with where in `line` each command ends (an `OPEN` makes the rest of the
/// line program text, which the card then reads differently).
pub fn parse_commands(line: &[u8], addressing: &mut Addressing) -> Vec<(Result<Command, Unreadable>, usize)> {
    pieces(line, addressing).into_iter().map(|p| (p.command, p.end)).collect()
}

/// As [`parse_line`], with the span of text each command was read from.
pub fn pieces(line: &[u8], addressing: &mut Addressing) -> Vec<Piece> {
    let mut p = Parser { s: line, i: 0, addressing };
    let mut out = Vec::new();
    loop {
        p.skip_spaces();
        let start = p.i;
        let Some(next) = p.next_command() else { break };
        let failed = next.is_err();
        out.push(Piece { command: next, start, end: p.i });
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
const KEYWORDS: [&str; 30] = [
    "ENDGATHER",
    "UNDEFINE",
    "CHECKSUM",
    "DISABLE",
    "DEFINE",
    "DELETE",
    "ENABLE",
    "GATHER",
    "HOMEZ",
    "UNDEF",
    "CLOSE",
    "HOME",
    "LIST",
    "OPEN",
    "SAVE",
    "ENDG",
    "CHKS",
    "VER",
    "CID",
    "CPU",
    "DEF",
    "DEL",
    "DIS",
    "ENA",
    "GAT",
    "LIS",
    "HMZ",
    "CLS",
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
        // The rest of the line, at most a screenful: a reader of any length stays linear.
        let end = self.s.len().min(start + 80);
        Unreadable { at: String::from_utf8_lossy(&self.s[start..end]).into_owned(), offset: start, why }
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
        let start = self.i;
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
            let from = self.i;
            while self.peek().is_some_and(|c| c.is_ascii_hexdigit()) && self.i - from < 12 {
                self.i += 1;
            }
            let digits = std::str::from_utf8(&self.s[from..self.i]).ok()?;
            i64::from_str_radix(digits, 16).ok().map(|v| v as f64)
        } else {
            let from = self.i;
            let mut dot = false;
            while let Some(c) = self.peek() {
                if c == b'.' && !dot && !self.starts_with("..") {
                    dot = true;
                } else if !c.is_ascii_digit() || self.i - from >= expr::NUMBER_TEXT_MAX {
                    break;
                }
                self.i += 1;
            }
            let text = std::str::from_utf8(&self.s[from..self.i]).ok()?;
            expr::decimal_value(text)
        };
        match magnitude {
            Some(m) => Some(if negative { -m } else { m }),
            None => {
                self.i = start;
                None
            }
        }
    }

    /// An expression after `=` (or inside `I(...)`).
    fn expression(&mut self) -> Option<Expr> {
        expr::parse(self.s, &mut self.i, self.addressing.cs)
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
                    Ok(true) => {
                        // `#m->...`: motor m's axis definition in the addressed C.S.
                        if c == b'#' {
                            let save = self.i;
                            self.skip_spaces();
                            if self.starts_with("->") {
                                self.i += 2;
                                return Some(self.axis_definition(start));
                            }
                            self.i = save;
                        }
                        continue;
                    }
                    Ok(false) => return Some(Ok(if c == b'#' { Command::ReportMotor } else { Command::ReportCs })),
                    Err(e) => return Some(Err(e)),
                }
            }
            return Some(self.command(c, start));
        }
    }

    /// After `#m->`: a definition up to the first character that cannot continue it, or none
    /// (a report). MODEL: the EPICS driver polls `&n#m->,` on every Turbo PMAC it drives
    /// (pmacHardwareTurbo.cpp, CS_AXIS_MAPPING); the comma ends an empty definition, so it is
    /// read as part of the report.
    fn axis_definition(&mut self, start: usize) -> Result<Command, Unreadable> {
        let (cs, motor) = (self.addressing.cs, self.addressing.motor);
        // MODEL: the definition follows `->` directly; after a space, `#1-> UNDEFINE` is a
        // report and then a command of its own.
        let from = self.i;
        while self.peek().is_some_and(|c| c.is_ascii_digit() || matches!(c, b'.' | b'+' | b'-' | b'I') || is_axis(c)) {
            self.i += 1;
        }
        let text = String::from_utf8_lossy(&self.s[from..self.i]).to_ascii_uppercase();
        if text.is_empty() {
            if self.peek() == Some(b',') {
                self.i += 1;
            }
            return Ok(Command::AxisReport { cs, motor });
        }
        if !valid_axis_definition(&text) {
            return Err(self.error(
                start,
                "an axis definition is I, or scaled axes X Y Z A B C U V W and an offset (#1->1000X+10)",
            ));
        }
        Ok(Command::AxisDefine { cs, motor, definition: text })
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
                if self.peek().is_some_and(|c| c.is_ascii_digit() || c == b'.' || c == b'$') {
                    match self.value() {
                        // The card's range (0 to 838860 %), fractions kept (the EPICS driver
                        // writes `&1%100.000000`).
                        Some(v) if (0.0..=FEED_MAX).contains(&v) => {
                            Ok(Command::Feed { cs: self.addressing.cs, percent: v })
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
            b'<' => self.control_name(start),
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

    /// `<CTRL-K>` and the like: a control character written as the manual prints it, as a
    /// trace (which is text) holds it (UM p.217).
    fn control_name(&mut self, start: usize) -> Result<Command, Unreadable> {
        for (name, c) in
            [("<CTRL-A>", 0x01), ("<CTRL-K>", 0x0B), ("<CTRL-O>", 0x0F), ("<CTRL-Q>", 0x11), ("<CTRL-X>", 0x18)]
        {
            if self.starts_with(name) {
                self.i += name.len();
                return self.control(c, start);
            }
        }
        Err(self.error(start, "the control characters are written <CTRL-A>, <CTRL-K>, <CTRL-O>, <CTRL-Q>, <CTRL-X>"))
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

    /// `<MEMORY-WRITE In=v>` up to its `>`.
    fn memory_write(&mut self, start: usize) -> Result<Command, Unreadable> {
        const WHY: &str = "a memory write is <MEMORY-WRITE In=v>, n in 0..8191 and v a whole number";
        self.i += "<MEMORY-WRITE".len();
        self.skip_spaces();
        if self.peek() != Some(b'I') {
            return Err(self.error(start, WHY));
        }
        self.i += 1;
        let n = match self.number().and_then(|n| u16::try_from(n).ok()) {
            Some(n) if n <= VARIABLE_MAX => n,
            _ => return Err(self.error(start, WHY)),
        };
        self.skip_spaces();
        if self.peek() != Some(b'=') {
            return Err(self.error(start, WHY));
        }
        self.i += 1;
        let v = self.value().filter(|v| v.fract() == 0.0 && v.abs() < 1e15);
        self.skip_spaces();
        match (v, self.peek()) {
            (Some(v), Some(b'>')) => {
                self.i += 1;
                Ok(Command::WriteIMemory(n, v as i64))
            }
            _ => Err(self.error(start, WHY)),
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
            self.i += 2;
            return self.read_hex(start);
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
        let kind = match letter {
            b'I' => Some(VarKind::I),
            b'M' => Some(VarKind::M),
            b'P' => Some(VarKind::P),
            b'Q' => Some(VarKind::Q),
            _ => None,
        };
        if let Some(kind) = kind {
            if self.peek().is_some_and(|c| c.is_ascii_digit()) {
                return self.variable(kind, start);
            }
            if self.peek() == Some(b'(') {
                return self.computed_variable(kind, start);
            }
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
            // `B{constant}`: point the C.S. at the top of program {constant} (SRM p.295); `B`
            // alone at the top of the program it points at. MODEL: the line-label fraction
            // (`B3.025`) is not read.
            b'B' => {
                Command::Begin { cs: self.addressing.cs, program: self.number().and_then(|n| u16::try_from(n).ok()) }
            }
            // `E`: the EPICS driver sends `&{cs}E` "to make sure axes are enabled" before each
            // C.S. move (pmacHardwareTurbo::getCSEnableCommand). MODEL: the pages at hand do not
            // describe it; it closes the loop of each killed motor of the C.S., as J/ does
            // (`CsCommand::Enable`).
            b'E' => self.cs_command(CsCommand::Enable),
            _ => return Err(self.error(start, "not an on-line command of the card")),
        })
    }

    /// After `RH`: `X:$25`, `Y:$000025`, `X$25` (SRM p.295, `RH{address}`).
    fn read_hex(&mut self, start: usize) -> Result<Command, Unreadable> {
        self.skip_spaces();
        let space = match self.peek() {
            Some(b'X') => Space::X,
            Some(b'Y') => Space::Y,
            _ => return Err(self.error(start, "RH reads X: or Y: memory, e.g. RHX:$25")),
        };
        self.i += 1;
        if self.peek() == Some(b':') {
            self.i += 1;
        }
        let from = self.i;
        if self.peek() == Some(b'$') {
            self.i += 1;
            while self.peek().is_some_and(|c| c.is_ascii_hexdigit()) {
                self.i += 1;
            }
        } else {
            while self.peek().is_some_and(|c| c.is_ascii_digit()) {
                self.i += 1;
            }
        }
        let text = String::from_utf8_lossy(&self.s[from..self.i]).into_owned();
        match parse_address(&text) {
            Ok(address) => Ok(Command::ReadHex { space, address }),
            Err(why) => Err(self.error(start, why)),
        }
    }

    fn jog(&mut self, start: usize) -> Result<Command, Unreadable> {
        let motor = self.addressing.motor;
        let c = self.peek();
        self.i += 1;
        match c {
            Some(b'+') => Ok(self.motor_command(MotorCommand::JogPlus)),
            Some(b'-') => Ok(self.motor_command(MotorCommand::JogMinus)),
            Some(b'/') => Ok(self.motor_command(MotorCommand::JogStop)),
            Some(b'=') => Ok(Command::Jog(motor, Jog::To(self.value()))),
            Some(b'^') => match self.value() {
                Some(v) => Ok(Command::Jog(motor, Jog::ByFromActual(v))),
                None => Err(self.error(start, "J^ takes a distance")),
            },
            Some(b':') => match self.value() {
                Some(v) => Ok(Command::Jog(motor, Jog::ByFromCommanded(v))),
                None => Err(self.error(start, "J: takes a distance")),
            },
            _ => Err(self.error(start, "J is followed by +, -, /, =, ^ or :")),
        }
    }

    /// The variables after the letter: `n`, `n..m`, `n,count[,step]`.
    fn var_range(&mut self, start: usize) -> Result<VarRange, Unreadable> {
        let first = match self.number().and_then(|n| u16::try_from(n).ok()) {
            Some(n) if n <= VARIABLE_MAX => n,
            _ => return Err(self.error(start, "variables are numbered 0..8191")),
        };
        if self.starts_with("..") {
            self.i += 2;
            return match self.number().and_then(|n| u16::try_from(n).ok()) {
                Some(last) if last <= VARIABLE_MAX && last >= first => Ok(VarRange::run(first, last)),
                _ => Err(self.error(start, "a range runs from a lower to a higher number, at most 8191")),
            };
        }
        if self.peek() == Some(b',') && self.s.get(self.i + 1).is_some_and(u8::is_ascii_digit) {
            self.i += 1;
            let count = self.number().and_then(|n| u16::try_from(n).ok()).filter(|c| *c >= 1);
            let step = if self.peek() == Some(b',') && self.s.get(self.i + 1).is_some_and(u8::is_ascii_digit) {
                self.i += 1;
                self.number().and_then(|n| u16::try_from(n).ok()).filter(|s| *s >= 1)
            } else {
                Some(1)
            };
            let range = match (count, step) {
                (Some(count), Some(step)) => VarRange { first, count, step },
                _ => return Err(self.error(start, "I{n},{count},{step}: count and step are at least 1")),
            };
            if u32::from(range.first) + (u32::from(range.count) - 1) * u32::from(range.step) > u32::from(VARIABLE_MAX) {
                return Err(self.error(start, "the range runs past 8191"));
            }
            return Ok(range);
        }
        Ok(VarRange::one(first))
    }

    fn variable(&mut self, kind: VarKind, start: usize) -> Result<Command, Unreadable> {
        let range = self.var_range(start)?;
        let cs = self.addressing.cs;
        self.skip_spaces();
        if self.starts_with("->") {
            if kind != VarKind::M {
                return Err(self.error(start, "only M-variables are defined with ->"));
            }
            let Some((first, last)) = range.as_run() else {
                return Err(self.error(start, "M-variable definitions take n or n..m"));
            };
            return self.m_definition(first, last, start);
        }
        if self.peek() == Some(b'=') {
            self.i += 1;
            return self.assignment(kind, Vars::Numbers(range), start);
        }
        Ok(Command::Read { kind, vars: Vars::Numbers(range), cs })
    }

    /// `I(P1*100+20)` and `I(P1*100+20)=10` (UM p.248).
    fn computed_variable(&mut self, kind: VarKind, start: usize) -> Result<Command, Unreadable> {
        let before = self.i;
        let Some(Expr::Var { number, .. }) = ({
            self.i -= 1;
            self.expression()
        }) else {
            self.i = before;
            return Err(self.error(start, "the variable's number is an expression in parentheses"));
        };
        let Index::Computed(index) = *number else {
            return Err(self.error(start, "the variable's number is an expression in parentheses"));
        };
        self.skip_spaces();
        if self.peek() == Some(b'=') {
            self.i += 1;
            return self.assignment(kind, Vars::Computed(index), start);
        }
        Ok(Command::Read { kind, vars: Vars::Computed(index), cs: self.addressing.cs })
    }

    fn assignment(&mut self, kind: VarKind, vars: Vars, start: usize) -> Result<Command, Unreadable> {
        self.skip_spaces();
        let cs = self.addressing.cs;
        if self.peek() == Some(b'*') {
            if kind != VarKind::I {
                return Err(self.error(start, "only I-variables have a factory default (I{n}=*)"));
            }
            self.i += 1;
            return Ok(Command::Write { kind, vars, value: Assigned::Default, cs });
        }
        match self.expression() {
            Some(e) => Ok(Command::Write { kind, vars, value: Assigned::Expr(e), cs }),
            None => Err(self.error(start, "the value is an expression: constants, variables, functions and operators")),
        }
    }

    /// After `Mn[..m]->`: a definition, or a report when none follows.
    fn m_definition(&mut self, first: u16, last: u16, start: usize) -> Result<Command, Unreadable> {
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
        match Definition::parse(&text) {
            Ok(definition) => Ok(Command::MDefine { first, last, definition }),
            Err(why) => Err(self.error(start, why)),
        }
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
            return Err(self.error(start, "the values run past the last address, $FFFFFF"));
        }
        let kind = match letter {
            Some(b'X') => Definition::Word { space: Space::X, address, offset: 0, width: 24, format: Format::U },
            Some(b'Y') => Definition::Word { space: Space::Y, address, offset: 0, width: 24, format: Format::U },
            Some(b'D') => Definition::Fixed { address, dual_ported: false },
            _ => Definition::Float { address, dual_ported: false },
        };
        Ok(Command::MemoryWrite { kind, values })
    }

    /// `,start[,length]` after a listing's buffer.
    fn listing_range(&mut self) -> (Option<u32>, Option<u32>) {
        let mut part = || {
            let save = self.i;
            self.skip_spaces();
            if self.peek() == Some(b',') {
                self.i += 1;
                self.skip_spaces();
                if let Some(n) = self.number() {
                    return Some(n);
                }
            }
            self.i = save;
            None
        };
        let start = part();
        let length = start.and(part());
        (start, length)
    }

    fn keyword(&mut self, k: &str, start: usize) -> Result<Command, Unreadable> {
        Ok(match k {
            "VER" => Command::Version,
            "CID" => Command::CardId,
            "CPU" => Command::Cpu,
            "SAVE" => Command::Save,
            "CHECKSUM" | "CHKS" => Command::Checksum,
            "CLOSE" | "CLS" => Command::Close,
            "HM" | "HOME" => Command::Home(self.addressing.motor),
            "HMZ" | "HOMEZ" => Command::HomeZero(self.addressing.motor),
            "GATHER" | "GAT" => Command::Gather(Gather::Start),
            "ENDGATHER" | "ENDG" => Command::Gather(Gather::End),
            "UNDEFINE" | "UNDEF" => {
                let save = self.i;
                self.skip_spaces();
                if self.starts_with("ALL") {
                    self.i += 3;
                    Command::Undefine { cs: None }
                } else {
                    self.i = save;
                    Command::Undefine { cs: Some(self.addressing.cs) }
                }
            }
            "ENABLE" | "ENA" | "DISABLE" | "DIS" => {
                let enable = k.starts_with('E');
                self.skip_spaces();
                if !self.starts_with("PLC") {
                    return Err(self.error(start, "ENABLE and DISABLE take PLC or PLCC and the program numbers"));
                }
                self.i += 3;
                let compiled = self.peek() == Some(b'C');
                if compiled {
                    self.i += 1;
                }
                // `n`, `n,m`, `n..m`, and lists of these (`DISABLE PLC2..31`, `ENABLE PLC 1,2`).
                let mut plcs = 0u32;
                let mut first = true;
                loop {
                    if !first {
                        let save = self.i;
                        self.skip_spaces();
                        if self.peek() != Some(b',') {
                            self.i = save;
                            break;
                        }
                        self.i += 1;
                    }
                    first = false;
                    self.skip_spaces();
                    let from = match self.number() {
                        Some(n) if n <= 31 => n,
                        _ => return Err(self.error(start, "PLC programs are 0..31")),
                    };
                    let to = if self.starts_with("..") {
                        self.i += 2;
                        match self.number() {
                            Some(n) if (from..=31).contains(&n) => n,
                            _ => return Err(self.error(start, "a range of PLC programs is n..m with n <= m <= 31")),
                        }
                    } else {
                        from
                    };
                    for n in from..=to {
                        plcs |= 1 << n;
                    }
                }
                Command::PlcSwitch(PlcSwitch { enable, compiled, plcs })
            }
            "DEFINE" | "DEF" => {
                self.skip_spaces();
                if let Some(w) = ["GATHER", "GAT"].iter().find(|w| self.starts_with(w)) {
                    self.i += w.len();
                    self.skip_spaces();
                    Command::Gather(Gather::Define(self.number()))
                } else if let Some(w) = ["LOOKAHEAD", "LOOK"].iter().find(|w| self.starts_with(w)) {
                    self.i += w.len();
                    self.skip_spaces();
                    let segments = self.number();
                    let comma = self.peek() == Some(b',');
                    self.i += usize::from(comma);
                    let outputs = self.number();
                    match (segments, comma, outputs) {
                        (Some(segments), true, Some(outputs)) => {
                            Command::DefineLookahead { cs: self.addressing.cs, segments, outputs }
                        }
                        _ => return Err(self.error(start, "DEFINE LOOKAHEAD {segments},{outputs}")),
                    }
                } else {
                    return Err(self.error(start, "DEFINE takes GATHER or LOOKAHEAD"));
                }
            }
            "DELETE" | "DEL" => {
                self.skip_spaces();
                if let Some(w) = ["GATHER", "GAT"].iter().find(|w| self.starts_with(w)) {
                    self.i += w.len();
                    Command::Gather(Gather::Delete)
                } else if self.starts_with("ALL") {
                    self.i += 3;
                    self.skip_spaces();
                    if !self.starts_with("TEMPS") {
                        return Err(self.error(start, "DELETE ALL TEMPS"));
                    }
                    self.i += 5;
                    Command::DeleteAllTemps
                } else {
                    return Err(self.error(start, "DELETE takes GATHER or ALL TEMPS"));
                }
            }
            "LIST" | "LIS" => self.listing(start)?,
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
                    return Err(self.error(start, "OPEN PLC n or OPEN PROG n"));
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
                    return Err(self.error(start, "MS{station},I{n} is the MACRO station form"));
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

    /// After `LIST`: `GATHER`, `PROG n`, `PLC n`, `FORWARD`, `INVERSE`, with `,start,length`.
    fn listing(&mut self, start: usize) -> Result<Command, Unreadable> {
        self.skip_spaces();
        if let Some(w) = ["GATHER", "GAT"].iter().find(|w| self.starts_with(w)) {
            self.i += w.len();
            return Ok(Command::Gather(Gather::List));
        }
        for (word, forward) in [("FORWARD", true), ("FWD", true), ("INVERSE", false), ("INV", false)] {
            if self.starts_with(word) {
                self.i += word.len();
                let cs = self.addressing.cs;
                let (start, length) = self.listing_range();
                return Ok(Command::List(if forward {
                    Listing::Forward { cs, start, length }
                } else {
                    Listing::Inverse { cs, start, length }
                }));
            }
        }
        if self.starts_with("PLC") {
            self.i += 3;
            self.skip_spaces();
            let Some(number) = self.number().and_then(|n| u8::try_from(n).ok()).filter(|n| *n <= 31) else {
                return Err(self.error(start, "LIST PLC n: PLC programs are 0..31"));
            };
            let (start, length) = self.listing_range();
            return Ok(Command::List(Listing::Plc { number, start, length }));
        }
        if self.starts_with("PROG") {
            self.i += 4;
            self.skip_spaces();
            let Some(number) = self.number().and_then(|n| u16::try_from(n).ok()).filter(|n| *n >= 1) else {
                return Err(self.error(start, "LIST PROG n: motion programs are numbered from 1"));
            };
            let (start, length) = self.listing_range();
            return Ok(Command::List(Listing::Program { number, start, length }));
        }
        Err(self.error(start, "LIST takes GATHER, PROG n, PLC n, FORWARD or INVERSE"))
    }
}

/// The axis letters of a Turbo PMAC coordinate system (SRM `#{constant}->`).
fn is_axis(c: u8) -> bool {
    matches!(c, b'X' | b'Y' | b'Z' | b'A' | b'B' | b'C' | b'U' | b'V' | b'W')
}

/// `I`, or terms `[sign][scale]axis` joined by `+`/`-` with an optional constant offset last
/// (`1000X`, `X`, `-500Y+10`, `.5X+.5Y`, `0`: SRM `#{constant}->{axis definition}`).
fn valid_axis_definition(text: &str) -> bool {
    if text == "I" {
        return true;
    }
    let b = text.as_bytes();
    let mut i = 0;
    let mut terms = 0;
    let mut offset = false;
    while i < b.len() {
        if offset {
            return false;
        }
        if terms > 0 || matches!(b[i], b'+' | b'-') {
            if !matches!(b[i], b'+' | b'-') {
                return false;
            }
            i += 1;
        }
        let from = i;
        while i < b.len() && (b[i].is_ascii_digit() || b[i] == b'.') {
            i += 1;
        }
        let scale = &text[from..i];
        if !scale.is_empty() && scale.parse::<f64>().is_err() {
            return false;
        }
        if i < b.len() && is_axis(b[i]) {
            i += 1;
        } else if scale.is_empty() {
            return false;
        } else {
            offset = true;
        }
        terms += 1;
    }
    terms > 0
}

/// A command's text as a host would send it, with its motor or C.S. addressed explicitly:
/// reading it again gives the same command (the fuzz target `grammar` checks this).
impl fmt::Display for Command {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let opt = |v: &Option<u32>| v.map(|v| format!(",{v}")).unwrap_or_default();
        let kind_prefix = |kind: &VarKind, cs: &u8| if *kind == VarKind::Q { format!("&{cs}") } else { String::new() };
        match self {
            Command::GlobalStatus => f.write_str("???"),
            Command::CsStatus(cs) => write!(f, "&{cs}??"),
            Command::MotorStatus(m) => write!(f, "#{m}?"),
            Command::Position(m) => write!(f, "#{m}P"),
            Command::Velocity(m) => write!(f, "#{m}V"),
            Command::FollowingError(m) => write!(f, "#{m}F"),
            Command::ReportMotor => f.write_str("#"),
            Command::ReportCs => f.write_str("&"),
            Command::FeedRead(cs) => write!(f, "&{cs}%"),
            Command::Feed { cs, percent } => write!(f, "&{cs}%{}", expr::number_text(*percent)),
            Command::Read { kind, vars, cs } => write!(f, "{}{kind:?}{}", kind_prefix(kind, cs), vars_text(vars)),
            Command::Write { kind, vars, value, cs } => {
                let value = match value {
                    Assigned::Default => "*".to_string(),
                    Assigned::Expr(e) => e.to_string(),
                };
                write!(f, "{}{kind:?}{}={value}", kind_prefix(kind, cs), vars_text(vars))
            }
            Command::MDefine { first, last, definition } => {
                write!(f, "M{}->{}", VarRange::run(*first, *last), definition.report())
            }
            Command::MReport { first, last } => write!(f, "M{}->", VarRange::run(*first, *last)),
            Command::MemoryWrite { kind, values } => {
                let (letter, address) = match kind {
                    Definition::Word { space, address, .. } => (format!("{space:?}"), *address),
                    Definition::Fixed { address, .. } => ("D".into(), *address),
                    Definition::Float { address, .. } => ("L".into(), *address),
                    Definition::SelfReferenced => ("L".into(), 0),
                };
                write!(f, "W{letter}:${address:X}")?;
                for v in values {
                    write!(f, ",{}", expr::number_text(*v))?;
                }
                Ok(())
            }
            Command::MacroStation { station, ivar, value } => {
                write!(f, "MS{station},I{ivar}")?;
                match value {
                    Some(v) => write!(f, "={}", expr::number_text(*v)),
                    None => Ok(()),
                }
            }
            Command::ReadHex { space, address } => write!(f, "RH{space:?}:${address:X}"),
            Command::Motion(Motion::CoordinateSystem(cs, CsCommand::Feedrate(p))) => write!(f, "&{cs}%{p}"),
            Command::Motion(m) => write!(f, "{m}"),
            Command::Jog(m, j) => match j {
                Jog::Plus => write!(f, "#{m}J+"),
                Jog::Minus => write!(f, "#{m}J-"),
                Jog::Stop => write!(f, "#{m}J/"),
                Jog::To(None) => write!(f, "#{m}J="),
                Jog::To(Some(v)) => write!(f, "#{m}J={}", expr::number_text(*v)),
                Jog::ByFromActual(v) => write!(f, "#{m}J^{}", expr::number_text(*v)),
                Jog::ByFromCommanded(v) => write!(f, "#{m}J:{}", expr::number_text(*v)),
            },
            Command::Home(m) => write!(f, "#{m}HM"),
            Command::HomeZero(m) => write!(f, "#{m}HMZ"),
            Command::AxisDefine { cs, motor, definition } => write!(f, "&{cs}#{motor}->{definition}"),
            Command::AxisReport { cs, motor } => write!(f, "&{cs}#{motor}->"),
            Command::Undefine { cs: Some(cs) } => write!(f, "&{cs}UNDEFINE"),
            Command::Undefine { cs: None } => f.write_str("UNDEFINE ALL"),
            Command::Begin { cs, program: Some(n) } => write!(f, "&{cs}B{n}"),
            Command::Begin { cs, program: None } => write!(f, "&{cs}B"),
            Command::OpenPlc(n) => write!(f, "OPEN PLC {n}"),
            Command::OpenProgram(n) => write!(f, "OPEN PROG {n}"),
            Command::Close => f.write_str("CLOSE"),
            Command::PlcSwitch(p) => write!(f, "{p}"),
            Command::List(l) => match l {
                Listing::Program { number, start, length } => {
                    write!(f, "LIST PROG {number}{}{}", opt(start), opt(length))
                }
                Listing::Plc { number, start, length } => write!(f, "LIST PLC {number}{}{}", opt(start), opt(length)),
                Listing::Forward { cs, start, length } => write!(f, "&{cs}LIST FORWARD{}{}", opt(start), opt(length)),
                Listing::Inverse { cs, start, length } => write!(f, "&{cs}LIST INVERSE{}{}", opt(start), opt(length)),
            },
            Command::DefineLookahead { cs, segments, outputs } => {
                write!(f, "&{cs}DEFINE LOOKAHEAD {segments},{outputs}")
            }
            Command::DeleteAllTemps => f.write_str("DELETE ALL TEMPS"),
            Command::Reset => f.write_str("$$$"),
            Command::Reinitialize => f.write_str("$$$***"),
            Command::Checksum => f.write_str("CHECKSUM"),
            Command::WriteIMemory(n, v) => write!(f, "<MEMORY-WRITE I{n}={v}>"),
            Command::Save => f.write_str("SAVE"),
            Command::Version => f.write_str("VER"),
            Command::CardId => f.write_str("CID"),
            Command::Cpu => f.write_str("CPU"),
            Command::Gather(g) => match g {
                Gather::Define(None) => f.write_str("DEFINE GATHER"),
                Gather::Define(Some(n)) => write!(f, "DEFINE GATHER {n}"),
                Gather::Start => f.write_str("GATHER"),
                Gather::End => f.write_str("ENDGATHER"),
                Gather::List => f.write_str("LIST GATHER"),
                Gather::Delete => f.write_str("DELETE GATHER"),
            },
            Command::Ignored(c) => match c {
                0x18 => f.write_str("<CTRL-X>"),
                c => write!(f, "<{c:#04X}>"),
            },
        }
    }
}

fn vars_text(vars: &Vars) -> String {
    match vars {
        Vars::Numbers(r) => r.to_string(),
        Vars::Computed(e) => format!("({e})"),
    }
}

#[cfg(test)]
mod tests;
