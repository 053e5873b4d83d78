//! # pmacwd-capture: what a real card's log says, judged against the reference model
//!
//! A controls engineer's question about a capture ("my card tripped last night: could a
//! correct card do this, and why did it trip?") is answered here, apart from the lockstep
//! comparison of implementations (`pmacwd-conformance`): [`import`] reads the field's records
//! (host logs, EPICS asyn traces, pcap/pcapng of port 1025) into trace steps; [`replay`] reads
//! captures of any form as steps; [`explain`] judges them by a search over what the host could
//! not see, with the diagnosis and the witness; [`timeline`] draws a capture as signals;
//! [`margin`] says how close a card is to a trip; [`decode`] explains a `???` reply.

pub mod decode;
pub mod explain;
pub mod import;
pub mod margin;
pub mod replay;
pub mod samples;
pub mod timeline;
