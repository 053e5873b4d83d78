//! The model's view of the grammar's commands: [`HostCommand::parse`] for a trace step's text
//! and [`HostCommand::from_grammar`] for a command read from a line. It lives with the grammar
//! so that the vocabulary (`vocab`) imports nothing of the grammar: the grammar reads into the
//! vocabulary's terms, never the other way round.

use super::{pieces, Addressing, Assigned, Command, Gather, Jog, VarKind, Vars, VARIABLE_MAX};
use crate::vocab::command::{
    Buffer, CommandError, CsCommand, HostCommand, Motion, MotorCommand, Register, VarRange, RULED_I_VARIABLES,
};

impl HostCommand {
    /// One command, as a trace step holds it, read by the card's grammar ([`crate::grammar`])
    /// with the addressing a card powers up with (motor 1, C.S. 1: a bare `K` kills motor 1,
    /// SRM p.259). Text the card would refuse is [`HostCommand::Unrecognized`] (ERR003), a
    /// legal input. What *is* an error: no command at all, several commands (a step holds
    /// one), and a command the model cannot follow faithfully (a write to I8, I40 or I41 whose
    /// value depends on the card's own variables).
    pub fn parse(text: &str) -> Result<HostCommand, CommandError> {
        // Only the spaces the grammar itself skips are trimmed at the start: a step holding a
        // command the card refused may begin with a byte the grammar stops at (a CR, a
        // non-breaking space), and that byte is what keeps it unreadable when read back.
        let t = text.trim_start_matches([' ', '\t']).trim_end();
        if t.is_empty() {
            return Err(CommandError("an empty command: write the command text, e.g. `???`".into()));
        }
        let mut addressing = Addressing::default();
        let pieces = pieces(t.as_bytes(), &mut addressing);
        if pieces.iter().any(|p| p.command.is_err()) {
            return Ok(HostCommand::Unrecognized(t.to_string()));
        }
        match pieces.as_slice() {
            [] => Err(CommandError(format!("`{t}` addresses a motor or C.S. but gives no command"))),
            [one] => match &one.command {
                Ok(c) => HostCommand::from_grammar(c).map_err(|why| CommandError(format!("`{t}`: {why}"))),
                Err(_) => unreachable!("errors are handled above"),
            },
            _ => Err(CommandError(format!(
                "`{t}` is {} commands; a step holds one (write one step per command)",
                pieces.len()
            ))),
        }
    }

    /// The model's view of a command the grammar read: its own variant where a rule of the
    /// manuals fixes the answer, [`HostCommand::Card`] where the answer is the card's own.
    /// `Err` for a write the model cannot follow (see [`HostCommand::parse`]).
    pub fn from_grammar(c: &Command) -> Result<HostCommand, String> {
        let card = |forgets: Option<VarRange>| HostCommand::Card { text: c.to_string(), forgets, past_lockout: false };
        // SRM p.57: "I41 does not prevent changes to an I-variable by means of an M-variable
        // assignment or a direct memory write command." Where such a write lands the model
        // cannot tell (no page read gives the address of I-variable storage, docs/probe.md), so
        // any I-variable may have changed: every one becomes the card's own, locked or not.
        // MODEL: I8, I40 and I41 stay the model's (it must follow them, and a write it can place
        // is `<MEMORY-WRITE In=v>`); the emulator's own storage address (variables.yaml,
        // i_variable_storage) is a MODEL of the emulator, not assumed of a card.
        let past_lockout = || HostCommand::Card {
            text: c.to_string(),
            forgets: Some(VarRange::run(0, VARIABLE_MAX)),
            past_lockout: true,
        };
        Ok(match c {
            Command::GlobalStatus => HostCommand::GlobalStatus,
            Command::Read { kind: VarKind::I, vars: Vars::Numbers(r), .. } if r.count == 1 => {
                HostCommand::ReadI(r.first)
            }
            Command::Write { kind: VarKind::I, vars, value, .. } => {
                let range = match vars {
                    Vars::Numbers(r) => *r,
                    Vars::Computed(e) => match e.constant().map(f64::round) {
                        Some(n) if (0.0..=f64::from(VARIABLE_MAX)).contains(&n) => VarRange::one(n as u16),
                        _ => {
                            return Err(format!(
                                "the I-variable written is computed from the card's own variables ({e}): it may be one of {RULED_I_VARIABLES:?}, which the model must follow"
                            ))
                        }
                    },
                };
                let ruled = range.numbers().find(|n| RULED_I_VARIABLES.contains(n));
                match (value, range.count) {
                    (Assigned::Default, 1) => HostCommand::DefaultI(range.first),
                    (Assigned::Expr(e), 1) => match e.constant() {
                        // MODEL: a fraction written to I8, I40 or I41 (integer variables, SRM
                        // p.42, p.57) is rounded to the nearest whole number.
                        Some(v) if v.abs() < 1e15 && (v.fract() == 0.0 || ruled.is_some()) => {
                            HostCommand::WriteI(range.first, v.round() as i64)
                        }
                        Some(_) => card(Some(range)),
                        None if ruled.is_some() => {
                            return Err(format!(
                                "I{} is written from the card's own variables ({e}); the model cannot follow its value",
                                range.first
                            ))
                        }
                        None => card(Some(range)),
                    },
                    (_, _) if ruled.is_some() => {
                        return Err(format!(
                        "a write of several I-variables reaches I{}: write it on its own so the model can follow it",
                        ruled.unwrap_or(0)
                    ))
                    }
                    (_, _) => card(Some(range)),
                }
            }
            Command::Write { kind: VarKind::M, .. } | Command::MemoryWrite { .. } => past_lockout(),
            Command::ReadHex { space, address } => match Register::at(*space, *address) {
                Some(r) => HostCommand::ReadHex(r),
                None => card(None),
            },
            Command::Reset => HostCommand::Reset,
            Command::Reinitialize => HostCommand::Reinitialize,
            Command::Checksum => HostCommand::Checksum,
            // SRM p.289: bit 19 is 1 while the data gathering function is active; SRM p.307:
            // gathering runs from GATHER until ENDGATHER (or a filled buffer).
            Command::Gather(Gather::Start) => HostCommand::Gather,
            Command::Gather(Gather::End) => HostCommand::EndGather,
            Command::WriteIMemory(n, v) => HostCommand::WriteIMemory(*n, *v),
            Command::OpenPlc(n) => HostCommand::Open(Buffer::Plc(*n)),
            Command::OpenProgram(n) => HostCommand::Open(Buffer::Program(*n)),
            Command::Close => HostCommand::Close,
            Command::Motion(m) => HostCommand::Motion(*m),
            Command::Begin { cs, .. } => HostCommand::Motion(Motion::CoordinateSystem(*cs, CsCommand::Begin)),
            // MODEL: the stop rules tell a zero override (a hold, UM p.217) from any other; a
            // fraction of a percent counts as a running override, rounded up.
            Command::Feed { cs, percent } => HostCommand::Motion(Motion::CoordinateSystem(
                *cs,
                CsCommand::Feedrate(if *percent == 0.0 {
                    0
                } else {
                    percent.ceil().clamp(1.0, f64::from(u16::MAX)) as u16
                }),
            )),
            // A jog to a target or by a distance, and a homing search, start motion as a jog
            // does (MODEL: the stop rules of UM p.217 treat every jog move alike, and a homing
            // search is a jog move until its trigger).
            Command::Jog(n, Jog::To(_) | Jog::ByFromActual(_) | Jog::ByFromCommanded(_)) | Command::Home(n) => {
                HostCommand::Motion(Motion::Motor(*n, MotorCommand::JogToPosition))
            }
            Command::Jog(n, Jog::Plus) => HostCommand::Motion(Motion::Motor(*n, MotorCommand::JogPlus)),
            Command::Jog(n, Jog::Minus) => HostCommand::Motion(Motion::Motor(*n, MotorCommand::JogMinus)),
            Command::Jog(n, Jog::Stop) => HostCommand::Motion(Motion::Motor(*n, MotorCommand::JogStop)),
            Command::Read { .. }
            | Command::Write { .. }
            | Command::CsStatus(_)
            | Command::MotorStatus(_)
            | Command::Position(_)
            | Command::Velocity(_)
            | Command::FollowingError(_)
            | Command::ReportMotor
            | Command::ReportCs
            | Command::FeedRead(_)
            | Command::MDefine { .. }
            | Command::MReport { .. }
            | Command::MacroStation { .. }
            | Command::HomeZero(_)
            | Command::AxisDefine { .. }
            | Command::AxisReport { .. }
            | Command::Undefine { .. }
            | Command::PlcSwitch(_)
            | Command::List(_)
            | Command::DefineLookahead { .. }
            | Command::DeleteAllTemps
            | Command::Save
            | Command::Version
            | Command::CardId
            | Command::Cpu
            | Command::Gather(Gather::Define(_) | Gather::List | Gather::Delete)
            | Command::Ignored(_) => card(None),
        })
    }
}
