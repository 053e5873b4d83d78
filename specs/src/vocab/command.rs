//! Host commands as a user types them at a terminal, parsed into the closed set the model
//! understands.
//!
//! | text | command | reply |
//! |---|---|---|
//! | `???` | [`HostCommand::GlobalStatus`] | 12 hex characters (SRM p.289) |
//! | `I40` | [`HostCommand::ReadI`] | the value in decimal |
//! | `I40=100` | [`HostCommand::WriteI`] | nothing (ignored silently when locked by I41, SRM p.57) |
//! | `RHX:$25`, `RHY:$000025` | [`HostCommand::ReadHex`] | the 24-bit word in hex |
//! | `$$$` | [`HostCommand::Reset`] | nothing; the card resets |
//! | `$$$***` | [`HostCommand::Reinitialize`] | nothing; the card resets with the factory-default I-variables (UM p.243) |
//! | `CHECKSUM`, `CHKS` | [`HostCommand::Checksum`] | the firmware's reference checksum in hex (UM p.217, SRM p.295) |
//! | `<MEMORY-WRITE I130=7>` | [`HostCommand::WriteIMemory`] | nothing; the I-variable's storage is written past I41 (SRM p.57) |
//! | `OPEN PLC 1`, `OPEN PROG 1` | [`HostCommand::Open`] | nothing |
//! | `CLOSE` | [`HostCommand::Close`] | nothing; X:$1090 takes the program checksum (UM p.217) |
//! | `GATHER`, `GAT` | [`HostCommand::Gather`] | nothing; data gathering starts, X:$000006 bit 19 (SRM p.289, p.307) |
//! | `ENDGATHER`, `ENDG` | [`HostCommand::EndGather`] | nothing; data gathering stops, bit 19 clears (SRM p.289, p.307) |
//! | `#1J+`, `#1J-`, `#1J/`, `#1J=`, `#1K` | [`HostCommand::Motion`], motor scope | nothing; `#1K` while motor 1's C.S. runs a program: ERR001 (UM p.319) |
//! | `&1A`, `&1Q`, `&1/`, `&1H`, `&1\`, `&1R`, `&1S`, `&1B`, `&1E`, `&1%0` | [`HostCommand::Motion`], C.S. scope | nothing |
//! | `<CTRL-A>`, `<CTRL-Q>`, `<CTRL-O>`, `<CTRL-K>` | [`HostCommand::Motion`], global | nothing |
//!
//! `<MEMORY-WRITE In=v>` is not text a card reads: it stands for an M-variable assignment or a
//! direct memory write command aimed at I-variable n's storage, which I41 does not lock (SRM
//! p.57). MODEL: the manual pages this project has do not give the address of any I-variable's
//! storage, so the command names its target I-variable instead of an address (a pseudo-target,
//! written like the control characters, in angle brackets).
//!
//! Motion commands carry their motor (`#n`, 1..=32) or coordinate system (`&n`, 1..=16): the
//! model does not track which motor or C.S. the host last addressed, so a bare `K` or `A` stays
//! [`HostCommand::Unrecognized`] (MODEL: see docs/model.md). The global control characters are
//! written as the manual prints them (UM p.217), `<CTRL-K>`, since a trace is text.
//!
//! Keywords are case-insensitive and spaces around `=` are allowed. Text that is not one of
//! these is kept as [`HostCommand::Unrecognized`]: the controller answers it with ERR003
//! (facts page s.3), so it is a legal input, not a parse failure. What *is* a parse failure
//! is a command the model cannot represent faithfully: a memory read of a register it does not
//! model, or an I-variable number beyond I8191.

use std::fmt;

/// X or Y memory.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Space {
    X,
    Y,
}

/// The registers the model holds, by address.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Register {
    /// X:$000000, servo cycle counter.
    ServoCycles,
    /// X:$000006, first status word.
    StatusX,
    /// Y:$000006, second status word.
    StatusY,
    /// Y:$000025, watchdog counter.
    WatchdogCounter,
    /// X:$000025, lowest watchdog counter value since reset.
    WatchdogMinimum,
    /// X:$001080, running checksum.
    RunningChecksum,
    /// X:$001090, user-program checksum reference.
    ProgramChecksumReference,
}

impl Register {
    pub const ALL: [(Register, Space, u32); 7] = [
        (Register::ServoCycles, Space::X, 0x0),
        (Register::StatusX, Space::X, 0x6),
        (Register::StatusY, Space::Y, 0x6),
        (Register::WatchdogCounter, Space::Y, 0x25),
        (Register::WatchdogMinimum, Space::X, 0x25),
        (Register::RunningChecksum, Space::X, 0x1080),
        (Register::ProgramChecksumReference, Space::X, 0x1090),
    ];

    pub fn at(space: Space, address: u32) -> Option<Register> {
        Self::ALL.iter().find(|(_, s, a)| *s == space && *a == address).map(|(r, ..)| *r)
    }

    pub fn address(self) -> (Space, u32) {
        Self::ALL.iter().find(|(r, ..)| *r == self).map(|(_, s, a)| (*s, *a)).expect("every register is listed")
    }
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Buffer {
    /// `OPEN PLC n`: Y:$000006 bit 17.
    Plc(u8),
    /// `OPEN PROG n`: Y:$000006 bit 19.
    Program(u16),
}

/// A command that starts or stops motion: the stop commands of UM p.217, and the commands
/// that start motion as far as the stop rules need them.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Motion {
    /// `#n` followed by a motor command.
    Motor(u8, MotorCommand),
    /// `&n` followed by a coordinate-system command.
    CoordinateSystem(u8, CsCommand),
    /// A global control character.
    Global(GlobalCommand),
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum MotorCommand {
    /// `J+`: jog in the positive direction.
    JogPlus,
    /// `J-`: jog in the negative direction.
    JogMinus,
    /// `J/`: jog stop (UM p.217, row 1); on a killed motor it closes the loop.
    JogStop,
    /// `J=` (optionally `J={position}`): jog to a position.
    JogToPosition,
    /// `K`: kill (UM p.217, row 10).
    Kill,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum CsCommand {
    /// `A`: abort (UM p.217, row 2).
    Abort,
    /// `Q`: quit (row 4).
    Quit,
    /// `/`: stop at the end of the currently executing move (row 6).
    EndOfMove,
    /// `H`: feed hold (row 7).
    Hold,
    /// `\`: quick stop (row 9).
    QuickStop,
    /// `R`: run the program.
    Run,
    /// `S`: single-step the program (UM p.319: "resumed with an R or S command").
    Step,
    /// `B` or `B{n}`: point the C.S. at the beginning of a program.
    Begin,
    /// `%n`: feedrate override in percent.
    Feedrate(u16),
    /// `E`: enable the motors of the C.S. (the EPICS `pmac` driver's `&1E`, "to make sure axes
    /// are enabled" before a C.S. move). MODEL: the manual pages at hand do not describe `E`;
    /// each killed motor of the C.S. has its loop closed as `J/` closes a killed motor's
    /// (docs/grammar.md, `E`).
    Enable,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum GlobalCommand {
    /// `<CTRL-A>`: abort all (row 3).
    AbortAll,
    /// `<CTRL-Q>`: quit all (row 5).
    QuitAll,
    /// `<CTRL-O>`: feed hold all (row 8).
    HoldAll,
    /// `<CTRL-K>`: kill all (row 11).
    KillAll,
}

/// Turbo PMAC's motors are #1..#32 and its coordinate systems &1..&16.
pub const MOTOR_MAX: u8 = 32;
pub const COORDINATE_SYSTEM_MAX: u8 = 16;

impl Motion {
    /// The command as UM p.217 prints it in its first column (`J/`, `A`, `<CTRL-A>`, ...), for
    /// the stop commands; `None` for the commands that start motion.
    pub fn stop_table_name(self) -> Option<&'static str> {
        match self {
            Motion::Motor(_, MotorCommand::JogStop) => Some("J/"),
            Motion::Motor(_, MotorCommand::Kill) => Some("K"),
            Motion::Motor(_, MotorCommand::JogPlus | MotorCommand::JogMinus | MotorCommand::JogToPosition) => None,
            Motion::CoordinateSystem(_, c) => match c {
                CsCommand::Abort => Some("A"),
                CsCommand::Quit => Some("Q"),
                CsCommand::EndOfMove => Some("/"),
                CsCommand::Hold => Some("H"),
                CsCommand::QuickStop => Some("\\"),
                CsCommand::Run | CsCommand::Step | CsCommand::Begin | CsCommand::Feedrate(_) | CsCommand::Enable => {
                    None
                }
            },
            Motion::Global(g) => Some(match g {
                GlobalCommand::AbortAll => "<CTRL-A>",
                GlobalCommand::QuitAll => "<CTRL-Q>",
                GlobalCommand::HoldAll => "<CTRL-O>",
                GlobalCommand::KillAll => "<CTRL-K>",
            }),
        }
    }
}

impl fmt::Display for Motion {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Motion::Motor(n, c) => write!(
                f,
                "#{n}{}",
                match c {
                    MotorCommand::JogPlus => "J+",
                    MotorCommand::JogMinus => "J-",
                    MotorCommand::JogStop => "J/",
                    MotorCommand::JogToPosition => "J=",
                    MotorCommand::Kill => "K",
                }
            ),
            Motion::CoordinateSystem(n, CsCommand::Feedrate(p)) => write!(f, "&{n}%{p}"),
            Motion::CoordinateSystem(n, c) => write!(
                f,
                "&{n}{}",
                match c {
                    CsCommand::Abort => "A",
                    CsCommand::Quit => "Q",
                    CsCommand::EndOfMove => "/",
                    CsCommand::Hold => "H",
                    CsCommand::QuickStop => "\\",
                    CsCommand::Run => "R",
                    CsCommand::Step => "S",
                    CsCommand::Begin => "B",
                    CsCommand::Enable => "E",
                    CsCommand::Feedrate(_) => unreachable!("printed above"),
                }
            ),
            Motion::Global(_) => f.write_str(self.stop_table_name().expect("every global command is a stop command")),
        }
    }
}

#[derive(Clone, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum HostCommand {
    GlobalStatus,
    ReadI(u16),
    WriteI(u16, i64),
    ReadHex(Register),
    Reset,
    Open(Buffer),
    Close,
    /// A command that starts or stops motion (UM p.217).
    Motion(Motion),
    /// `$$$***`: reset and re-initialize: the factory-default I-variables are copied into
    /// active memory; the values last saved are kept in flash, not used (UM p.243).
    Reinitialize,
    /// `CHECKSUM` (`CHKS`): report the firmware's reference checksum (UM p.217, SRM p.295).
    Checksum,
    /// `GATHER`: start the data gathering function; X:$000006 bit 19 "is 1 when the data
    /// gathering function is active" (SRM p.289). Gathering runs until "an ENDGATHER command"
    /// or until "the gather buffer has ... filled up" (SRM p.307).
    Gather,
    /// `ENDGATHER`: stop the data gathering function; bit 19 is 0 again (SRM p.289, p.307).
    EndGather,
    /// An M-variable assignment or a direct memory write into I-variable `n`'s storage, which
    /// I41 does not prevent (SRM p.57). Written `<MEMORY-WRITE In=v>` (see the module text).
    WriteIMemory(u16, i64),
    /// `I{n}=*`: I-variable n back to its factory default (SRM on-line commands, `I{data}=*`).
    DefaultI(u16),
    /// A command the card accepts and the model has no rule for (`CPU`, `#1P`, `P1=5`,
    /// `&1#1->`, `RHX:$78F00`, ...): its answer is the card's own, never compared with a value
    /// of the model's. `forgets` names the I-variables it writes with a value the model cannot
    /// compute (`I130=I130*1.25`, `I130,4,100=*`): from then on their values are the card's own
    /// too. `text` is the command as the grammar prints it. `past_lockout`: the write is a
    /// direct memory write or an M-variable assignment, which I41 does not prevent (SRM p.57),
    /// so it forgets a variable I41 locks too; a write by `I{n}=` to a locked variable is
    /// ignored and forgets nothing.
    Card {
        text: String,
        forgets: Option<VarRange>,
        past_lockout: bool,
    },
    /// Text the grammar cannot read: the card answers ERR003 (facts page s.3).
    Unrecognized(String),
}

/// Why a command text cannot be given to the model.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct CommandError(pub String);

impl fmt::Display for CommandError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.0)
    }
}

/// The highest I-variable number of a Turbo PMAC.
pub const I_VARIABLE_MAX: u16 = 8191;

/// The I-variables whose values the model's rules read (I8, I40, I41: `variables.yaml`): a
/// write the model cannot compute may not reach them, or the model would hold a value the
/// card does not.
pub const RULED_I_VARIABLES: [u16; 3] = [8, 40, 41];

/// Numbered variables of one kind: `I130` (one), `I20..23` (a run), `I130,4,100` (four,
/// 100 apart: I130, I230, I330, I430; SRM on-line commands, `I{constant}[,{constant}[,{constant}]]`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct VarRange {
    pub first: u16,
    pub count: u16,
    pub step: u16,
}

impl VarRange {
    pub fn one(n: u16) -> VarRange {
        VarRange { first: n, count: 1, step: 1 }
    }

    /// `first..last`.
    pub fn run(first: u16, last: u16) -> VarRange {
        VarRange { first, count: last - first + 1, step: 1 }
    }

    pub fn numbers(self) -> impl Iterator<Item = u16> {
        (0..self.count).map(move |k| self.first + k * self.step)
    }

    pub fn last(self) -> u16 {
        self.first + (self.count - 1) * self.step
    }

    /// The run `first..last` this is, if its step is 1.
    pub fn as_run(self) -> Option<(u16, u16)> {
        (self.step == 1).then(|| (self.first, self.last()))
    }
}

impl fmt::Display for VarRange {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match (self.count, self.step) {
            (1, _) => write!(f, "{}", self.first),
            (_, 1) => write!(f, "{}..{}", self.first, self.last()),
            _ => write!(f, "{},{},{}", self.first, self.count, self.step),
        }
    }
}

impl fmt::Display for HostCommand {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            HostCommand::GlobalStatus => f.write_str("???"),
            HostCommand::ReadI(n) => write!(f, "I{n}"),
            HostCommand::WriteI(n, v) => write!(f, "I{n}={v}"),
            HostCommand::ReadHex(r) => {
                let (s, a) = r.address();
                write!(f, "RH{s:?}:${a:X}")
            }
            HostCommand::Reset => f.write_str("$$$"),
            HostCommand::Open(Buffer::Plc(n)) => write!(f, "OPEN PLC {n}"),
            HostCommand::Open(Buffer::Program(n)) => write!(f, "OPEN PROG {n}"),
            HostCommand::Close => f.write_str("CLOSE"),
            HostCommand::Motion(m) => write!(f, "{m}"),
            HostCommand::Reinitialize => f.write_str("$$$***"),
            HostCommand::Checksum => f.write_str("CHECKSUM"),
            HostCommand::Gather => f.write_str("GATHER"),
            HostCommand::EndGather => f.write_str("ENDGATHER"),
            HostCommand::WriteIMemory(n, v) => write!(f, "<MEMORY-WRITE I{n}={v}>"),
            HostCommand::DefaultI(n) => write!(f, "I{n}=*"),
            HostCommand::Card { text, .. } => f.write_str(text),
            HostCommand::Unrecognized(t) => f.write_str(t),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn commands_parse_case_insensitively_and_print_back_in_canonical_form() {
        for (text, canonical) in [
            ("???", "???"),
            ("i40", "I40"),
            ("I130 = 7", "I130=7"),
            ("I5100=$10", "I5100=16"),
            ("rhy:$000025", "RHY:$25"),
            ("RHX:$1080", "RHX:$1080"),
            ("$$$", "$$$"),
            ("open plc 1", "OPEN PLC 1"),
            ("OPEN PROG 10", "OPEN PROG 10"),
            ("close", "CLOSE"),
            ("#1j/", "#1J/"),
            ("#2 K", "#2K"),
            ("#1J=1000", "#1J="),
            ("&1a", "&1A"),
            ("&1/", "&1/"),
            ("&1\\", "&1\\"),
            ("&2B1", "&2B"),
            ("&1E", "&1E"),
            ("&3e", "&3E"),
            ("&1%0", "&1%0"),
            ("<ctrl-k>", "<CTRL-K>"),
            ("<CTRL-O>", "<CTRL-O>"),
            ("$$$***", "$$$***"),
            ("chks", "CHECKSUM"),
            ("gat", "GATHER"),
            ("endg", "ENDGATHER"),
            ("<memory-write i130 = $10>", "<MEMORY-WRITE I130=16>"),
        ] {
            assert_eq!(HostCommand::parse(text).unwrap().to_string(), canonical, "{text}");
        }
    }

    #[test]
    fn text_the_controller_would_reject_is_kept_for_an_err003_reply() {
        // A card answers these with ERR003, so the model must too: they are inputs.
        for text in
            ["HELLO", "I40=abc", "OPEN PLC 99", "RHZ:$25", "I", "#0K", "#33J+", "&17A", "&1%x", "#1J=abc", "I9000=1"]
        {
            assert!(matches!(HostCommand::parse(text), Ok(HostCommand::Unrecognized(_))), "{text}");
        }
    }

    #[test]
    fn a_command_without_its_address_acts_on_motor_1_and_cs_1_as_a_card_powers_up() {
        // SRM p.259: the examples send `J+` without `#` first.
        assert_eq!(HostCommand::parse("K").unwrap().to_string(), "#1K");
        assert_eq!(HostCommand::parse("A").unwrap().to_string(), "&1A");
    }

    #[test]
    fn commands_the_card_accepts_and_the_model_has_no_rule_for_are_the_card_s_own() {
        for text in [
            "RHX:$1234",
            "CPU",
            "#1P",
            "P1=5",
            "&1#1->",
            "&1#1->,",
            "M162->D:$2082",
            "I130,4,100",
            "SAVE",
            "LIST PROG 1",
        ] {
            assert!(matches!(HostCommand::parse(text), Ok(HostCommand::Card { forgets: None, .. })), "{text}");
        }
        // A write the model cannot compute makes the variable the card's own.
        assert_eq!(
            HostCommand::parse("I130=1.25*I130").unwrap(),
            HostCommand::Card { text: "I130=1.25*I130".into(), forgets: Some(VarRange::one(130)), past_lockout: false }
        );
        assert_eq!(
            HostCommand::parse("I222=0.5").unwrap(),
            HostCommand::Card { text: "I222=0.5".into(), forgets: Some(VarRange::one(222)), past_lockout: false }
        );
        // SRM p.57: an M-variable assignment or a direct memory write may change any
        // I-variable, I41 notwithstanding (where it lands is not known): every one is forgotten.
        for text in ["M162=1000/0.0009765625", "WX:$2082,7", "WL:$3000,1.5"] {
            let all = Some(VarRange::run(0, 8191));
            assert_eq!(
                HostCommand::parse(text).unwrap(),
                HostCommand::Card {
                    text: HostCommand::parse(text).unwrap().to_string(),
                    forgets: all,
                    past_lockout: true
                },
                "{text}"
            );
        }
        assert_eq!(HostCommand::parse("I130=*").unwrap(), HostCommand::DefaultI(130));
        assert_eq!(HostCommand::parse("I40=5*2").unwrap(), HostCommand::WriteI(40, 10), "a constant expression");
        assert_eq!(HostCommand::parse("I(10*4)=3").unwrap(), HostCommand::WriteI(40, 3), "a constant index");
        assert_eq!(HostCommand::parse("I40=0.6").unwrap(), HostCommand::WriteI(40, 1), "MODEL: rounded");
        assert_eq!(
            HostCommand::parse("&1%100.000000").unwrap(),
            HostCommand::Motion(Motion::CoordinateSystem(1, CsCommand::Feedrate(100)))
        );
        assert_eq!(
            HostCommand::parse("&1%0.4").unwrap(),
            HostCommand::Motion(Motion::CoordinateSystem(1, CsCommand::Feedrate(1))),
            "not a hold"
        );
    }

    #[test]
    fn commands_the_model_cannot_follow_are_errors_not_guesses() {
        // A write of I8, I40 or I41 from the card's own variables, or a computed I-variable
        // number that might be one of them.
        assert!(HostCommand::parse("I40=I10/2").unwrap_err().0.contains("cannot follow"));
        assert!(HostCommand::parse("I(P1)=5").unwrap_err().0.contains("computed"));
        assert!(HostCommand::parse("I39..41=0").unwrap_err().0.contains("I40"));
        assert!(HostCommand::parse("I40 I41").unwrap_err().0.contains("2 commands"));
        assert!(HostCommand::parse("#1").unwrap_err().0.contains("no command"));
        // A memory write names an I-variable the card has and a whole value: else ERR003.
        assert!(matches!(HostCommand::parse("<MEMORY-WRITE I130>"), Ok(HostCommand::Unrecognized(_))));
        assert!(matches!(HostCommand::parse("<MEMORY-WRITE I9000=1>"), Ok(HostCommand::Unrecognized(_))));
    }

    #[test]
    fn an_empty_command_is_an_error_and_signs_are_not_hex_digits() {
        // A trace step `command: ""` used to run as an empty command; `$+25` and `$-5` were
        // read as hex because the standard parser accepts a sign. A card answers neither as a
        // register read or a write: they are unrecognized (ERR003).
        assert!(HostCommand::parse("  ").unwrap_err().0.contains("empty command"));
        assert_eq!(HostCommand::parse("RHX:$+25").unwrap(), HostCommand::Unrecognized("RHX:$+25".into()));
        assert_eq!(HostCommand::parse("I5=$-5").unwrap(), HostCommand::Unrecognized("I5=$-5".into()));
        assert_eq!(HostCommand::parse("I5=-$5").unwrap(), HostCommand::WriteI(5, -5));
    }
}
