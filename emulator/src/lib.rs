//! A Turbo PMAC emulator on the card's Ethernet protocol (`pmacwd serve`), backed by the
//! compact core, and a recording proxy (`pmacwd record`) that writes host sessions as
//! captures in the trace format. `docs/emulator.md` is the user's guide.

pub mod bounded;
pub mod buffers;
pub mod capture;
pub mod capture_queue;
pub mod card;
pub mod card_turns;
pub mod control;
pub mod fault;
pub mod framing;
pub mod host_reply;
pub mod listen;
pub mod memory;
pub mod motor_status;
pub mod mvar;
pub mod plc;
pub mod program;
pub mod protocol;
pub mod proxy;
pub mod server;
pub mod trajectory;
