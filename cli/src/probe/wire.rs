//! Talking to the card: one command line out, its answers back, on the Ethernet protocol
//! (port 1025: an 8-byte VR_PMAC_GETRESPONSE header, then the line) or on a terminal server's
//! plain line (`--telnet`: the line and a CR). Also the control port of `pmacwd serve`, when
//! the probe is given one.

use pmacwd_emulator::framing::{parse_reply, ReadAnswer, ACK, BEL, CR, LF};
use pmacwd_emulator::protocol::{DOWNLOAD, VR_PMAC_GETRESPONSE};
use std::io::{BufRead, BufReader, Read, Write};
use std::net::{SocketAddr, TcpStream, ToSocketAddrs};
use std::time::{Duration, Instant};

/// What the card answered to one line.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Reply {
    /// The answers in order (`ERRnnn` for an error, which ends the line).
    Answers(Vec<String>),
    /// Nothing came within the silence time (a tripped card, UM p.215).
    Silent,
}

impl Reply {
    /// As a host log writes it (docs/capturing.md).
    pub fn log_text(&self) -> String {
        match self {
            Reply::Answers(a) => a.join(" "),
            Reply::Silent => "(timeout)".into(),
        }
    }
}

/// How lines reach the card.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Transport {
    Ethernet,
    Telnet,
}

pub struct Link {
    stream: TcpStream,
    transport: Transport,
    silence: Duration,
}

/// `HOST:PORT`, or `HOST` alone with the card's port 1025 (23 for `--telnet`).
pub fn resolve(text: &str, transport: Transport) -> Result<SocketAddr, String> {
    let with_port = if text.rsplit_once(':').is_some_and(|(h, p)| !h.is_empty() && p.parse::<u16>().is_ok())
        && !text.ends_with(']')
    {
        text.to_string()
    } else {
        format!("{text}:{}", if transport == Transport::Telnet { 23 } else { 1025 })
    };
    let found: Vec<SocketAddr> =
        with_port.to_socket_addrs().map_err(|e| format!("`{text}`: {e} (give HOST or HOST:PORT)"))?.collect();
    found.iter().find(|a| a.is_ipv4()).or(found.first()).copied().ok_or_else(|| format!("`{text}` names no address"))
}

impl Link {
    pub fn connect(addr: SocketAddr, transport: Transport, silence: Duration) -> Result<Link, String> {
        let stream = TcpStream::connect_timeout(&addr, Duration::from_secs(3))
            .map_err(|e| format!("cannot reach {addr}: {e}"))?;
        stream.set_nodelay(true).ok();
        Ok(Link { stream, transport, silence })
    }

    /// Sends one command line and reads its answers.
    pub fn exchange(&mut self, line: &str) -> Result<Reply, String> {
        self.drain()?;
        let mut out = Vec::with_capacity(line.len() + 8);
        match self.transport {
            Transport::Ethernet => {
                let len = u16::try_from(line.len()).map_err(|_| "a line too long for one request")?;
                out.extend_from_slice(&[DOWNLOAD, VR_PMAC_GETRESPONSE, 0, 0, 0, 0]);
                out.extend_from_slice(&len.to_be_bytes());
                out.extend_from_slice(line.as_bytes());
            }
            Transport::Telnet => {
                out.extend_from_slice(line.as_bytes());
                out.push(CR);
            }
        }
        self.stream.write_all(&out).map_err(|e| format!("sending `{line}`: {e}"))?;
        let bytes = self.read_reply()?;
        if bytes.is_empty() {
            return Ok(Reply::Silent);
        }
        answers(&bytes)
            .map(Reply::Answers)
            .map_err(|e| format!("the reply to `{line}` ({}): {e}", bytes.escape_ascii()))
    }

    /// Drops bytes a late answer left (after a silence), so that the next reply is the next line's.
    fn drain(&mut self) -> Result<(), String> {
        self.stream.set_nonblocking(true).map_err(|e| e.to_string())?;
        let mut buf = [0u8; 2048];
        loop {
            match self.stream.read(&mut buf) {
                Ok(0) => {
                    self.stream.set_nonblocking(false).ok();
                    return Err("the card closed the connection".into());
                }
                Ok(_) => continue,
                Err(e) if e.kind() == std::io::ErrorKind::WouldBlock => break,
                Err(e) => return Err(e.to_string()),
            }
        }
        self.stream.set_nonblocking(false).map_err(|e| e.to_string())
    }

    /// The bytes of one reply: up to its acknowledgement or error, or what came before the
    /// silence time passed without a byte (nothing: a silent card).
    fn read_reply(&mut self) -> Result<Vec<u8>, String> {
        let mut got = Vec::new();
        let mut buf = [0u8; 2048];
        let mut deadline = Instant::now() + self.silence;
        loop {
            let left = deadline.saturating_duration_since(Instant::now());
            if left.is_zero() {
                return Ok(got);
            }
            self.stream.set_read_timeout(Some(left)).map_err(|e| e.to_string())?;
            match self.stream.read(&mut buf) {
                Ok(0) => return Err("the card closed the connection".into()),
                Ok(n) => {
                    got.extend_from_slice(&buf[..n]);
                    if complete(&got) {
                        return Ok(got);
                    }
                    // I3 = 0 ends a line with nothing: a short quiet after data ends it.
                    deadline = Instant::now() + self.silence.min(Duration::from_millis(200));
                }
                Err(e) if matches!(e.kind(), std::io::ErrorKind::WouldBlock | std::io::ErrorKind::TimedOut) => {
                    return Ok(got);
                }
                Err(e) => return Err(e.to_string()),
            }
        }
    }
}

/// Whether `bytes` hold a whole reply: ended by ACK (I3 = 2, 3), by an error (`BEL ERRnnn CR`),
/// or by the LF that acknowledges under I3 = 1 (SRM p.37-38; PMAC2 SRM p.25 for I6).
fn complete(bytes: &[u8]) -> bool {
    match bytes.last() {
        Some(&ACK) => true,
        // A message ends with CR, so a final LF is I3 = 1's acknowledgement.
        Some(&LF) => true,
        Some(&CR) => bytes.contains(&BEL) && bytes.windows(3).any(|w| w == b"ERR"),
        _ => false,
    }
}

/// The answers of a reply as a host log writes them: the data, and `ERRnnn` for an error.
fn answers(bytes: &[u8]) -> Result<Vec<String>, String> {
    let parsed = parse_reply(bytes)?;
    parsed
        .answers
        .into_iter()
        .map(|a| match a {
            ReadAnswer::Data(t) => Ok(t),
            ReadAnswer::Error(Some(n)) => Ok(format!("ERR{n:03}")),
            ReadAnswer::Error(None) => {
                Err("an error reported by BEL alone (I6 = 0 or 2): the probe needs error numbers (I6 = 1 or 3)".into())
            }
        })
        .collect()
}

/// The control interface of `pmacwd serve` (docs/emulator.md): one line out, one line back.
pub struct ControlPort {
    reader: BufReader<TcpStream>,
    writer: TcpStream,
}

impl ControlPort {
    pub fn connect(addr: SocketAddr) -> Result<ControlPort, String> {
        let stream = TcpStream::connect_timeout(&addr, Duration::from_secs(3))
            .map_err(|e| format!("cannot reach the control port {addr}: {e}"))?;
        stream.set_read_timeout(Some(Duration::from_secs(30))).ok();
        let writer = stream.try_clone().map_err(|e| e.to_string())?;
        Ok(ControlPort { reader: BufReader::new(stream), writer })
    }

    /// Sends `command`; the reply line (`ok ...`), or the `error: ...` it answered as an error.
    pub fn send(&mut self, command: &str) -> Result<String, String> {
        self.writer.write_all(format!("{command}\n").as_bytes()).map_err(|e| format!("control `{command}`: {e}"))?;
        let mut line = String::new();
        self.reader.read_line(&mut line).map_err(|e| format!("control `{command}`: {e}"))?;
        let line = line.trim_end().to_string();
        if line.starts_with("ok") {
            Ok(line)
        } else {
            Err(format!("control `{command}` answered `{line}`"))
        }
    }

    /// A field of `state` (`load=motors:8,plc0_units:30,background_units:250`).
    pub fn state_field(&mut self, name: &str) -> Result<String, String> {
        let state = self.send("state")?;
        state
            .split_whitespace()
            .find_map(|w| w.strip_prefix(&format!("{name}=")).map(str::to_string))
            .ok_or_else(|| format!("control `state` has no {name}: `{state}`"))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_reply_is_whole_at_its_ack_or_its_error() {
        assert!(complete(b"001000000000\r\x06"));
        assert!(complete(b"\x07ERR003\r"));
        assert!(!complete(b"001000000000\r"));
        assert!(!complete(b"\x07ERR0"));
        assert_eq!(answers(b"0\r4096\r\x06").unwrap(), ["0", "4096"]);
        assert_eq!(answers(b"5\r\x07ERR003\r").unwrap(), ["5", "ERR003"]);
        assert!(answers(b"\x07").is_err());
    }

    #[test]
    fn an_address_without_a_port_gets_the_cards() {
        assert_eq!(resolve("127.0.0.1", Transport::Ethernet).unwrap().port(), 1025);
        assert_eq!(resolve("127.0.0.1:7", Transport::Ethernet).unwrap().port(), 7);
        assert_eq!(resolve("127.0.0.1", Transport::Telnet).unwrap().port(), 23);
    }
}
