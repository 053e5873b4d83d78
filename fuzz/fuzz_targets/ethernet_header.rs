//! The 8-byte request header of the card's Ethernet protocol, `Header::parse` and
//! `Header::request`.
//!
//! Invariants:
//! - `to_bytes` gives back the 8 bytes `parse` read;
//! - `request` accepts a header only with the request type its code needs (0x40 for
//!   host-to-card requests, 0xC0 for card-to-host), and a command line only up to 1,492 bytes,
//!   the length the header gave; a refusal gives a reason;
//! - the headers the card's clients send (`getresponse`, `getbuffer`) are accepted.
#![no_main]

use libfuzzer_sys::fuzz_target;
use pmacwd_emulator::protocol::*;

fuzz_target!(|data: &[u8]| {
    let Some(bytes) = data.get(..HEADER_BYTES) else { return };
    let bytes: [u8; HEADER_BYTES] = bytes.try_into().expect("8 bytes");
    let h = Header::parse(&bytes);
    assert_eq!(h.to_bytes(), bytes);
    assert_eq!(Header::parse(&h.to_bytes()), h);
    match h.request() {
        Ok(Request::Line { data_bytes, reply }) => {
            assert!(matches!(h.request, VR_PMAC_GETRESPONSE | VR_PMAC_SENDLINE));
            assert_eq!(h.request_type, DOWNLOAD);
            assert_eq!(data_bytes, usize::from(h.length));
            assert!(data_bytes <= DATA_BYTES_MAX);
            assert_eq!(reply, h.request == VR_PMAC_GETRESPONSE);
        }
        Ok(Request::NextPacket) => {
            assert!(matches!(h.request, VR_PMAC_GETBUFFER | VR_PMAC_GETLINE));
            assert_eq!(h.request_type, UPLOAD);
        }
        Ok(Request::ReadReady) => assert_eq!((h.request, h.request_type), (VR_PMAC_READREADY, UPLOAD)),
        Ok(Request::Flush) => assert_eq!((h.request, h.request_type), (VR_PMAC_FLUSH, DOWNLOAD)),
        Ok(Request::Control(c)) => {
            assert_eq!((h.request, h.request_type), (VR_CTRL_RESPONSE, UPLOAD));
            assert_eq!(c, h.value.to_be_bytes()[1]);
        }
        Err(reason) => assert!(!reason.is_empty()),
    }
    let n = h.length % (DATA_BYTES_MAX as u16 + 1);
    assert_eq!(Header::getresponse(n).request(), Ok(Request::Line { data_bytes: usize::from(n), reply: true }));
    assert_eq!(Header::getbuffer().request(), Ok(Request::NextPacket));
});
