//! The Turbo PMAC Ethernet protocol (Acc-54E) as host programs use it: every request is an
//! 8-byte header, then up to 1,492 data bytes; replies are the bare bytes of the answer
//! (facts s.3a; request codes as in DiamondLightSource/pmac `pmacAsynIPPort.c`, epics-modules/tpmac
//! and dls-pmaclib).
//!
//! ```text
//! byte 0     RequestType   0x40 host-to-controller, 0xC0 controller-to-host
//! byte 1     Request       0xBF VR_PMAC_GETRESPONSE, 0xC5 VR_PMAC_GETBUFFER, ...
//! bytes 2-3  wValue        big-endian
//! bytes 4-5  wIndex        big-endian
//! bytes 6-7  wLength       big-endian: the data bytes that follow (0x40 requests), or the
//!                          most the host will take (0xC0 requests)
//! ```

pub const HEADER_BYTES: usize = 8;
/// The most data one request carries, and the most one reply packet carries.
pub const DATA_BYTES_MAX: usize = 1492;
/// Long replies go out in packets of this size; the host fetches the rest with GETBUFFER
/// (dls-pmaclib treats a packet under 1,400 bytes as the last one).
pub const REPLY_PACKET_BYTES: usize = 1400;

pub const DOWNLOAD: u8 = 0x40;
pub const UPLOAD: u8 = 0xC0;

pub const VR_PMAC_SENDLINE: u8 = 0xB0;
pub const VR_PMAC_GETLINE: u8 = 0xB1;
pub const VR_PMAC_FLUSH: u8 = 0xB3;
pub const VR_PMAC_GETRESPONSE: u8 = 0xBF;
pub const VR_PMAC_READREADY: u8 = 0xC2;
pub const VR_CTRL_RESPONSE: u8 = 0xC4;
pub const VR_PMAC_GETBUFFER: u8 = 0xC5;

/// Reads exactly `buf.len()` bytes; `Ok(false)` on a clean end of stream before the first,
/// an error when the stream ends part-way (a peer that left mid-request).
pub fn read_or_end(r: &mut impl std::io::Read, buf: &mut [u8]) -> std::io::Result<bool> {
    use std::io::ErrorKind;
    let mut got = 0;
    while got < buf.len() {
        match r.read(&mut buf[got..]) {
            Ok(0) if got == 0 => return Ok(false),
            Ok(0) => return Err(std::io::Error::new(ErrorKind::UnexpectedEof, "the peer left mid-request")),
            Ok(n) => got += n,
            Err(e) if e.kind() == ErrorKind::Interrupted => {}
            Err(e) => return Err(e),
        }
    }
    Ok(true)
}

/// A command line without its trailing CR, LF and NUL, which end the line and are not commands.
pub fn trim_line(data: &[u8]) -> &[u8] {
    let end = data.iter().rposition(|b| !matches!(b, b'\r' | b'\n' | 0)).map_or(0, |i| i + 1);
    &data[..end]
}

/// A request header.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Header {
    pub request_type: u8,
    pub request: u8,
    pub value: u16,
    pub index: u16,
    pub length: u16,
}

/// What a request asks for, once its header is checked.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Request {
    /// A command line follows (`length` bytes); answer it. `reply` is false for SENDLINE, whose
    /// answer waits for GETLINE.
    Line { data_bytes: usize, reply: bool },
    /// The next packet of a long reply (GETBUFFER), or the waiting answer (GETLINE).
    NextPacket,
    /// Is an answer waiting? Two bytes.
    ReadReady,
    /// Drop any waiting answer; one byte.
    Flush,
    /// One control character in `wValue` (`<CTRL-A>`, `<CTRL-K>`, ...).
    Control(u8),
}

impl Header {
    pub fn parse(bytes: &[u8; HEADER_BYTES]) -> Header {
        let word = |i: usize| u16::from_be_bytes([bytes[i], bytes[i + 1]]);
        Header { request_type: bytes[0], request: bytes[1], value: word(2), index: word(4), length: word(6) }
    }

    pub fn to_bytes(self) -> [u8; HEADER_BYTES] {
        let [v0, v1] = self.value.to_be_bytes();
        let [i0, i1] = self.index.to_be_bytes();
        let [l0, l1] = self.length.to_be_bytes();
        [self.request_type, self.request, v0, v1, i0, i1, l0, l1]
    }

    /// A VR_PMAC_GETRESPONSE header for `data_bytes` of command line.
    pub fn getresponse(data_bytes: u16) -> Header {
        Header { request_type: DOWNLOAD, request: VR_PMAC_GETRESPONSE, value: 0, index: 0, length: data_bytes }
    }

    /// A VR_PMAC_GETBUFFER header as dls-pmaclib sends it (wLength 2048).
    pub fn getbuffer() -> Header {
        Header { request_type: UPLOAD, request: VR_PMAC_GETBUFFER, value: 0, index: 0, length: 2048 }
    }

    /// Checks the header; `Err` says why the stream cannot be read further (the request type
    /// does not match the code, the code is unknown, or the data would overrun the card's
    /// buffer), after which the connection is closed: with no length to trust, there is no
    /// next header to find.
    pub fn request(&self) -> Result<Request, String> {
        let expect_type = |t: u8, r: Request| {
            if self.request_type == t {
                Ok(r)
            } else {
                Err(format!(
                    "request 0x{:02X} needs request type 0x{t:02X}, got 0x{:02X}",
                    self.request, self.request_type
                ))
            }
        };
        match self.request {
            VR_PMAC_GETRESPONSE | VR_PMAC_SENDLINE => {
                let data_bytes = usize::from(self.length);
                if data_bytes > DATA_BYTES_MAX {
                    return Err(format!(
                        "a command line of {data_bytes} bytes: the card's buffer takes {DATA_BYTES_MAX}"
                    ));
                }
                expect_type(DOWNLOAD, Request::Line { data_bytes, reply: self.request == VR_PMAC_GETRESPONSE })
            }
            VR_PMAC_GETBUFFER | VR_PMAC_GETLINE => expect_type(UPLOAD, Request::NextPacket),
            VR_PMAC_READREADY => expect_type(UPLOAD, Request::ReadReady),
            VR_PMAC_FLUSH => expect_type(DOWNLOAD, Request::Flush),
            VR_CTRL_RESPONSE => expect_type(UPLOAD, Request::Control(self.value.to_be_bytes()[1])),
            other => Err(format!("unknown request code 0x{other:02X} (request type 0x{:02X})", self.request_type)),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_dls_pmaclib_headers_read_as_their_requests() {
        // dls-pmaclib: struct.pack("8B", 0x40, 0xBF, 0, 0, 0, 0, 0, len(cmd)).
        let h = Header::parse(&[0x40, 0xBF, 0, 0, 0, 0, 0, 13]);
        assert_eq!(h.request(), Ok(Request::Line { data_bytes: 13, reply: true }));
        // GETBUFFER with wLength 0x0800.
        let h = Header::parse(&[0xC0, 0xC5, 0, 0, 0, 0, 0x08, 0]);
        assert_eq!(h.request(), Ok(Request::NextPacket));
        assert_eq!(Header::getbuffer().to_bytes(), [0xC0, 0xC5, 0, 0, 0, 0, 0x08, 0]);
        assert_eq!(Header::getresponse(258).to_bytes(), [0x40, 0xBF, 0, 0, 0, 0, 1, 2]);
    }

    #[test]
    fn headers_the_card_cannot_follow_are_refused_with_the_reason() {
        let too_long = Header::parse(&[0x40, 0xBF, 0, 0, 0, 0, 0x05, 0xD5]); // 1493 bytes
        assert!(too_long.request().unwrap_err().contains("1493 bytes"));
        let wrong_type = Header::parse(&[0xC0, 0xBF, 0, 0, 0, 0, 0, 3]);
        assert!(wrong_type.request().unwrap_err().contains("needs request type 0x40"));
        let unknown = Header::parse(&[0x40, 0x12, 0, 0, 0, 0, 0, 0]);
        assert!(unknown.request().unwrap_err().contains("unknown request code 0x12"));
    }
}
