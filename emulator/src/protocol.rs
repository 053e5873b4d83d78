//! The Turbo PMAC Ethernet protocol: its request headers and their decoding live in
//! `pmacwd-specs` (`specs/src/protocol.rs`), so that the emulator, the recording proxy and the
//! importer of packet captures and asyn traces (`pmacwd-conformance`, which may not depend on
//! the emulator, docs/architecture.md) decode a request one way.

pub use pmacwd_specs::protocol::*;
