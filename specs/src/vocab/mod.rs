//! The vocabulary, defined once: everything that can happen to a controller ([`Event`], with
//! the host's [`HostCommand`]s) and everything a host or an instrument can observe of it
//! ([`Reply`], [`Observation`]; the status bits are data, in [`crate::status`]).
//!
//! The model, the compact core's bridge, the trace formats, the emulator and the command line
//! all speak these types, and they match on them exhaustively: a new event, command or
//! observation is a compile error at every place that must handle it.

pub mod command;
pub mod event;
pub mod observation;
pub mod reply_text;

pub use command::{Buffer, CsCommand, GlobalCommand, HostCommand, Motion, MotorCommand, Register, Space};
pub use event::{AmplifierFaultInput, EncoderInput, Event, Reply};
pub use observation::{MotionView, MotorState, MotorView, Observation};
