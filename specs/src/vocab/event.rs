//! The vocabulary: everything that can happen to a controller, and what it can answer.

use super::reply_text::{self, StatusReply};
use crate::check::{ChecksumTarget, Load, ResetEvent, ResetKind};
use crate::vocab::command::HostCommand;
use std::fmt;

/// One event from the closed set of the design notes.
#[derive(Clone, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Event {
    /// `cycles` servo interrupts (each followed by its RTI when due), with no background
    /// cycle completing in between.
    Servo { cycles: u32 },
    /// A background cycle completes (possible only when the load leaves it CPU time).
    Background,
    /// The CPU load changes (motors, PLC 0 cost, background cycle cost).
    Load(Load),
    /// A host command line.
    Command(HostCommand),
    /// The logic supply changes.
    Supply { millivolts: u32 },
    /// INIT/ pulse or power cycle, with what the reset-time checks find.
    Reset(ResetEvent),
    /// Memory corruption that the background checksum will find.
    ChecksumFault(ChecksumTarget),
    /// The host writes 0 to bit 22 of X:$000006 (memory write or M-variable).
    ClearRtiReentry,
    /// A motor's encoder-loss input changes (UM p.214: the status bit is 1 for a valid encoder
    /// signal, 0 to signify encoder loss).
    EncoderInput(EncoderInput),
    /// A motor's amplifier-fault input (FAULTn) changes (UM p.213: "Without the use of the
    /// fault line, Turbo PMAC may not know when an amplifier has shut down").
    AmplifierFault(AmplifierFaultInput),
}

/// One motor's amplifier-fault input: `fault` while the amplifier reports a fault.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct AmplifierFaultInput {
    /// The motor, from 1.
    pub motor: u8,
    pub fault: bool,
}

/// One motor's encoder-loss input: `lost` when the detection circuit reports loss.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct EncoderInput {
    /// The motor, from 1.
    pub motor: u8,
    pub lost: bool,
}

/// How [`Reply::CardOwn`] prints.
pub const CARD_OWN: &str = "(the card's own)";

/// What a host sees in answer to a command.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Reply {
    /// The event was not a command (or `$$$`, which resets instead of answering).
    None,
    /// No answer at all: the card is tripped (UM p.215).
    Silence,
    /// Accepted, nothing to report.
    Ack,
    /// `???`: the two status words.
    Status { x: u32, y: u32 },
    /// `???` in bootstrap mode.
    Bootstrap,
    /// An I-variable value.
    Value(i64),
    /// A 24-bit memory word (`RH`).
    Hex(u32),
    /// `BEL ERRnnn CR`.
    Error(u16),
    /// An answer the model has no rule for: the card's own (a value of a variable it never
    /// saw written, a motor's position, the CPU type, ...). It matches any answer a running
    /// card gives, and never silence: a card that answers is running (UM p.215).
    CardOwn,
}

impl fmt::Display for Reply {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Reply::None => f.write_str("(none)"),
            Reply::Silence => f.write_str("(silence)"),
            Reply::Ack => f.write_str("(ack)"),
            Reply::Status { x, y } => f.write_str(&reply_text::encode(StatusReply::Words { x: *x, y: *y })),
            Reply::Bootstrap => f.write_str(&reply_text::encode(StatusReply::Bootstrap)),
            Reply::Value(v) => write!(f, "{v}"),
            Reply::Hex(v) => write!(f, "{v:06X}"),
            Reply::Error(n) => write!(f, "ERR{n:03}"),
            Reply::CardOwn => f.write_str(CARD_OWN),
        }
    }
}

impl fmt::Display for Event {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Event::Servo { cycles: 1 } => f.write_str("servo interrupt"),
            Event::Servo { cycles } => write!(f, "{cycles} servo interrupts"),
            Event::Background => f.write_str("background cycle completes"),
            Event::Load(l) => write!(
                f,
                "load: {} motors, PLC 0 {} units, background {} units",
                l.motors, l.plc0_units, l.background_units
            ),
            Event::Command(c) => write!(f, "host sends `{c}`"),
            Event::Supply { millivolts } => write!(f, "supply {}.{:03} V", millivolts / 1000, millivolts % 1000),
            Event::Reset(r) => {
                f.write_str(match r.kind {
                    ResetKind::Init => "INIT/ pulsed",
                    ResetKind::Power => "power cycled",
                })?;
                if r.dpram_fault {
                    f.write_str(", DPRAM check fails")?;
                }
                if r.flash_fault {
                    f.write_str(", flash read fails")?;
                }
                if r.bootstrap {
                    f.write_str(", bootstrap jumper on")?;
                }
                Ok(())
            }
            Event::ChecksumFault(ChecksumTarget::Firmware) => f.write_str("firmware memory corrupted"),
            Event::ChecksumFault(ChecksumTarget::UserProgram) => f.write_str("user program memory corrupted"),
            Event::ClearRtiReentry => f.write_str("host clears bit 22"),
            Event::EncoderInput(EncoderInput { motor, lost: true }) => write!(f, "motor {motor}'s encoder is lost"),
            Event::EncoderInput(EncoderInput { motor, lost: false }) => write!(f, "motor {motor}'s encoder is back"),
            Event::AmplifierFault(AmplifierFaultInput { motor, fault: true }) => {
                write!(f, "motor {motor}'s amplifier reports a fault")
            }
            Event::AmplifierFault(AmplifierFaultInput { motor, fault: false }) => {
                write!(f, "motor {motor}'s amplifier fault clears")
            }
        }
    }
}
