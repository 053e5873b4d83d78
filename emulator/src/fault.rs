//! Deliberately broken behaviours for testing a tester: `pmacwd serve --fault NAME` (hidden)
//! makes the emulator answer as a simulator with one of the bugs a simulator author is likely
//! to write, so that `pmacwd probe` can be shown to catch and name each one
//! (`cli/tests/probe.rs`). Each is a departure from one manual page; none is ever on by default.
//!
//! The card calls in at three points only: where a core command's answer is produced
//! ([`FaultState::before`], [`FaultState::after`]), where a tripped card decides to stay silent
//! ([`FaultState::answers_when_tripped`]) and where the trip happens ([`FaultState::tripped_at`]).

use crate::framing::Answer;
use pmacwd_bridge::core_event;
use pmacwd_core as core;
use pmacwd_specs::vocab::command::{HostCommand, Register};
use pmacwd_specs::vocab::event::Event;

/// One broken behaviour.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Fault {
    /// RHX:$25 answers the watchdog counter as it is now, not its lowest value since reset
    /// (SRM p.57: X:$25 holds the minimum).
    X25NotLatched,
    /// I41 locks nothing: a write to a locked I-variable is applied (SRM p.57).
    I41Ignored,
    /// Bit 22 of `???` (RTI re-entry) clears when it has been read, instead of staying set
    /// until the host writes it to 0 (SRM p.289).
    Bit22NotSticky,
    /// The card keeps answering after its watchdog has run out (UM p.215: a tripped card will
    /// not communicate).
    NeverTrips,
    /// `???` answers the same 12 digits whatever the card's state (SRM p.289).
    StatusConstant,
}

impl Fault {
    /// Every fault with its name on the command line.
    pub const ALL: [(&'static str, Fault); 5] = [
        ("x25-not-latched", Fault::X25NotLatched),
        ("i41-ignored", Fault::I41Ignored),
        ("bit22-not-sticky", Fault::Bit22NotSticky),
        ("never-trips", Fault::NeverTrips),
        ("status-constant", Fault::StatusConstant),
    ];

    pub fn parse(name: &str) -> Result<Fault, String> {
        Fault::ALL.iter().find(|(n, _)| *n == name).map(|(_, f)| *f).ok_or_else(|| {
            format!(
                "no fault named `{name}` (faults: {})",
                Fault::ALL.iter().map(|(n, _)| *n).collect::<Vec<_>>().join(", ")
            )
        })
    }
}

/// The fault a card runs with, and what it remembers to misbehave consistently.
#[derive(Clone, Debug, Default)]
pub struct FaultState {
    fault: Option<Fault>,
    /// `status-constant`: the first `???` answer, given ever after.
    status: Option<Answer>,
    /// `never-trips`: X:$0 when the watchdog ran out, and the card's cycle then (the core stops
    /// counting at the trip; this card's counter goes on).
    trip: Option<(u32, u64)>,
}

impl FaultState {
    /// The state of a card running `fault` from now on, nothing of it seen yet.
    pub fn injected(fault: Fault) -> FaultState {
        FaultState { fault: Some(fault), ..FaultState::default() }
    }

    pub fn fault(&self) -> Option<Fault> {
        self.fault
    }

    /// Whether a tripped card answers all the same (`never-trips`).
    pub fn answers_when_tripped(&self) -> bool {
        self.fault == Some(Fault::NeverTrips)
    }

    /// The core tripped at the card's servo cycle `cycle`, its X:$0 then `x0`.
    pub fn tripped_at(&mut self, x0: u32, cycle: u64) {
        if self.fault == Some(Fault::NeverTrips) {
            self.trip = Some((x0, cycle));
        }
    }

    /// An answer of the broken card before the core is asked, if it gives one.
    pub fn before(
        &mut self,
        command: &HostCommand,
        core: &mut core::Core,
        cfg: &core::Config,
        store: &mut dyn core::IVariableStore,
        cycles: u64,
    ) -> Option<Answer> {
        match self.fault? {
            Fault::I41Ignored => match command {
                // The write goes through as a memory write does (SRM p.57: I41 does not stop those).
                HostCommand::WriteI(n, v) if core.write_locked(*n) => {
                    Some(reply(core.command(cfg, core::Command::WriteIMemory(*n, *v), store)))
                }
                _ => None,
            },
            Fault::NeverTrips if core.tripped() => Some(match command {
                HostCommand::GlobalStatus => {
                    let (x, y) = core.status_words(cfg);
                    Answer::Data(String::from_utf8_lossy(&core::Reply::status_text(x, y)).into_owned())
                }
                HostCommand::ReadHex(Register::ServoCycles) => {
                    let (x0, at) = self.trip.unwrap_or((core.register(cfg, core::Register::ServoCycles), cycles));
                    Answer::Data(format!("{:06X}", (u64::from(x0) + cycles.saturating_sub(at)) & 0xFF_FFFF))
                }
                HostCommand::ReadHex(r) => Answer::Data(format!("{:06X}", core.register(cfg, core_register(*r)))),
                HostCommand::ReadI(n) => match core.read_i(*n, store) {
                    Some(v) => Answer::Data(v.to_string()),
                    None => Answer::Error(3),
                },
                _ => Answer::Nothing,
            }),
            _ => None,
        }
    }

    /// The broken card's answer in place of the core's `answer`.
    pub fn after(
        &mut self,
        command: &HostCommand,
        answer: Answer,
        core: &mut core::Core,
        cfg: &core::Config,
        store: &mut dyn core::IVariableStore,
    ) -> Answer {
        match (self.fault, command) {
            (Some(Fault::X25NotLatched), HostCommand::ReadHex(Register::WatchdogMinimum)) => {
                Answer::Data(format!("{:06X}", core.register(cfg, core::Register::WatchdogCounter)))
            }
            (Some(Fault::StatusConstant), HostCommand::GlobalStatus) => self.status.get_or_insert(answer).clone(),
            (Some(Fault::Bit22NotSticky), HostCommand::GlobalStatus) => {
                // Read-clears: the bit goes once the host has seen it.
                core.apply(cfg, core_event(&Event::ClearRtiReentry), store);
                answer
            }
            _ => answer,
        }
    }
}

fn reply(r: core::Reply) -> Answer {
    match r {
        core::Reply::Value(v) => Answer::Data(v.to_string()),
        core::Reply::Hex(v) => Answer::Data(format!("{v:06X}")),
        core::Reply::Error(n) => Answer::Error(n),
        _ => Answer::Nothing,
    }
}

fn core_register(r: Register) -> core::Register {
    match r {
        Register::ServoCycles => core::Register::ServoCycles,
        Register::StatusX => core::Register::StatusX,
        Register::StatusY => core::Register::StatusY,
        Register::WatchdogCounter => core::Register::WatchdogCounter,
        Register::WatchdogMinimum => core::Register::WatchdogMinimum,
        Register::RunningChecksum => core::Register::RunningChecksum,
        Register::ProgramChecksumReference => core::Register::ProgramChecksumReference,
    }
}
