//! A packet capture (pcap or pcapng, as tcpdump, Wireshark or dumpcap write them) of the
//! Ethernet protocol on TCP port 1025, read as the exchanges a host log carries
//! (`docs/capturing.md`, "Packet captures"). The file format is read by the `pcap-parser`
//! crate, the link, IP and TCP headers by `etherparse`, and the requests by the emulator's own
//! header decoding ([`pmacwd_specs::protocol::Header`]).
//!
//! Each TCP connection to port 1025 is put back together in sequence order (a retransmitted
//! segment is read once; a missing one is an error: the capture dropped packets). The host's
//! requests are read from the stream to the card; the card's bytes are matched to them in
//! order, as the recording proxy matches them (`emulator/src/proxy.rs`): a GETRESPONSE's
//! answer ends at its ACK or at the CR ending an error, a FLUSH takes one byte (its CTRL-X), a
//! READREADY two, a GETBUFFER with nothing waiting one NUL, and a GETBUFFER while a long answer
//! is coming continues it. A GETRESPONSE is a command line and its answer; FLUSH, READREADY
//! and GETBUFFER are not commands. A command whose answer had not begun when the host sent its
//! next GETRESPONSE or FLUSH (or when the capture ends) is silence, `(timeout)`; one whose
//! answer began but never ended takes what came.
//!
//! Positions are packet numbers (1 for the first packet, as Wireshark numbers frames), given
//! where a log's line numbers go.

use super::{Record, Records, Stamp};
use etherparse::{NetSlice, SlicedPacket, TransportSlice};
use pcap_parser::traits::PcapReaderIterator;
use pcap_parser::{create_reader, Block, PcapBlockOwned, PcapError};
use pmacwd_specs::protocol::{trim_line, Header, Request, HEADER_BYTES};
use pmacwd_specs::{Position, SpecError};
use std::collections::{HashMap, VecDeque};
use std::net::IpAddr;
use std::path::{Path, PathBuf};

/// The card's TCP port (Acc-54E and the Geo Brick's Ethernet port).
pub const CARD_PORT: u16 = 1025;

/// The most bytes of one answer kept (bounded memory); past it the answer is cut and kept as
/// answered but not shown.
const ANSWER_BYTES_MAX: usize = 64 << 10;
/// The most requests one connection may have waiting for their answers.
const AWAITING_MAX: usize = 64;
/// The most connections followed at once.
const CONNECTIONS_MAX: usize = 1024;

const ACK: u8 = 0x06;
const BEL: u8 = 0x07;
const CR: u8 = b'\r';

/// Whether `head` begins as a pcap (either byte order, micro- or nanosecond) or pcapng file.
pub fn is_capture(head: &[u8]) -> bool {
    let Some(m) = head.get(..4) else { return false };
    matches!(
        m,
        [0xD4, 0xC3, 0xB2, 0xA1] | [0xA1, 0xB2, 0xC3, 0xD4] | [0x4D, 0x3C, 0xB2, 0xA1] | [0xA1, 0xB2, 0x3C, 0x4D]
    ) || m == [0x0A, 0x0D, 0x0D, 0x0A]
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum End {
    /// A command line's answer: up to its ACK, or the CR after an error's number.
    Line,
    /// As `Line`, or a lone NUL (a GETBUFFER with nothing waiting).
    LineOrNul,
    /// A fixed count of bytes (FLUSH 1, READREADY 2).
    Bytes(usize),
}

/// A command sent: its packet, host time and text.
#[derive(Clone, Debug)]
struct Sent {
    packet: usize,
    stamp: Stamp,
    text: String,
}

struct Awaiting {
    end: End,
    command: Option<Sent>,
    bytes: Vec<u8>,
    cut: bool,
    in_error: bool,
}

impl Awaiting {
    /// Takes the answer's bytes from the front of `new`: how many, and whether it ended.
    fn take(&mut self, new: &[u8]) -> (usize, bool) {
        match self.end {
            End::Bytes(n) => {
                let take = n.saturating_sub(self.bytes.len()).min(new.len());
                self.bytes.extend_from_slice(&new[..take]);
                (take, self.bytes.len() >= n)
            }
            End::LineOrNul if self.bytes.is_empty() && new.first() == Some(&0) => {
                self.bytes.push(0);
                (1, true)
            }
            End::Line | End::LineOrNul => {
                for (i, &b) in new.iter().enumerate() {
                    let ends = match b {
                        ACK => true,
                        BEL => {
                            self.in_error = true;
                            false
                        }
                        CR => self.in_error && self.bytes.last().is_some_and(u8::is_ascii_digit),
                        _ => false,
                    };
                    if self.bytes.len() < ANSWER_BYTES_MAX {
                        self.bytes.push(b);
                    } else {
                        self.cut = true;
                    }
                    if ends {
                        return (i + 1, true);
                    }
                }
                (new.len(), false)
            }
        }
    }
}

/// One direction of a TCP connection, put back in order.
#[derive(Default)]
struct Direction {
    next_seq: Option<u32>,
}

impl Direction {
    /// The new bytes of a segment of `payload` at `seq` (a retransmission's overlap dropped);
    /// `Err` with the count of bytes missing before it.
    fn accept<'a>(&mut self, seq: u32, syn: bool, payload: &'a [u8]) -> Result<&'a [u8], u32> {
        if syn {
            self.next_seq = Some(seq.wrapping_add(1));
            return Ok(&[]);
        }
        let next = *self.next_seq.get_or_insert(seq);
        let ahead = seq.wrapping_sub(next);
        if payload.is_empty() {
            return Ok(&[]);
        }
        if ahead == 0 {
            self.next_seq = Some(next.wrapping_add(payload.len() as u32));
            return Ok(payload);
        }
        if ahead < 1 << 31 {
            return Err(ahead);
        }
        // Behind: a retransmission; keep what goes beyond what was read.
        let behind = next.wrapping_sub(seq) as usize;
        if behind >= payload.len() {
            return Ok(&[]);
        }
        self.next_seq = Some(next.wrapping_add((payload.len() - behind) as u32));
        Ok(&payload[behind..])
    }
}

#[derive(Default)]
struct Connection {
    to_card: Direction,
    from_card: Direction,
    /// Request bytes not yet a whole request.
    request: Vec<u8>,
    awaiting: VecDeque<Awaiting>,
}

/// The records of a packet capture.
pub struct PcapRecords {
    file: PathBuf,
    reader: Box<dyn PcapReaderIterator + Send>,
    /// Per pcapng interface: link type, units per second, offset in seconds.
    interfaces: Vec<(i32, u64, i64)>,
    /// The legacy file's link type and units per second.
    legacy: Option<(i32, u64)>,
    packet: usize,
    connections: HashMap<(IpAddr, u16), Connection>,
    /// The connection that last sent a command still unanswered.
    busy: Option<(IpAddr, u16)>,
    queue: VecDeque<Record>,
    /// Packets not of the card's port (count), and bytes the card sent with no request
    /// waiting.
    other_packets: u64,
    stray_bytes: u64,
    requests: HashMap<&'static str, u64>,
    done: bool,
}

impl PcapRecords {
    pub fn new(path: &Path, file: std::fs::File) -> Result<PcapRecords, SpecError> {
        let reader = create_reader(1 << 16, file)
            .map_err(|e| SpecError::whole_file(path, format!("not a pcap or pcapng capture: {e:?}")))?;
        Ok(PcapRecords {
            file: path.to_path_buf(),
            reader,
            interfaces: Vec::new(),
            legacy: None,
            packet: 0,
            connections: HashMap::new(),
            busy: None,
            queue: VecDeque::new(),
            other_packets: 0,
            stray_bytes: 0,
            requests: HashMap::new(),
            done: false,
        })
    }

    fn err(&self, msg: impl std::fmt::Display) -> SpecError {
        SpecError::at(
            &self.file,
            Position { line: self.packet.max(1), column: 1 },
            format!("packet {}: {msg}", self.packet),
        )
    }

    /// One packet's link-layer bytes, of link type `link`, at `stamp`.
    fn packet(&mut self, link: i32, data: &[u8], stamp: Stamp) -> Result<(), SpecError> {
        let sliced = match link {
            1 => SlicedPacket::from_ethernet(data),
            0 | 108 => match data.get(4..) {
                Some(ip) => SlicedPacket::from_ip(ip),
                None => return Err(self.err("a loopback packet shorter than its 4-byte header")),
            },
            12 | 14 | 101 | 228 | 229 => SlicedPacket::from_ip(data),
            113 => SlicedPacket::from_linux_sll(data),
            other => {
                return Err(self.err(format!(
                    "link type {other}: the importer reads Ethernet (1), loopback (0, 108), raw IP (12, 14, 101, \
                     228, 229) and Linux cooked (113) captures"
                )))
            }
        };
        let Ok(sliced) = sliced else {
            self.other_packets += 1;
            return Ok(());
        };
        let (src, dst) = match &sliced.net {
            Some(NetSlice::Ipv4(ip)) => {
                (IpAddr::V4(ip.header().source_addr()), IpAddr::V4(ip.header().destination_addr()))
            }
            Some(NetSlice::Ipv6(ip)) => {
                (IpAddr::V6(ip.header().source_addr()), IpAddr::V6(ip.header().destination_addr()))
            }
            _ => {
                self.other_packets += 1;
                return Ok(());
            }
        };
        let Some(TransportSlice::Tcp(tcp)) = &sliced.transport else {
            self.other_packets += 1;
            return Ok(());
        };
        let (to_card, client) = if tcp.destination_port() == CARD_PORT {
            (true, (src, tcp.source_port()))
        } else if tcp.source_port() == CARD_PORT {
            (false, (dst, tcp.destination_port()))
        } else {
            self.other_packets += 1;
            return Ok(());
        };
        if !self.connections.contains_key(&client) && self.connections.len() >= CONNECTIONS_MAX {
            return Err(self.err(format!("more than {CONNECTIONS_MAX} connections to port {CARD_PORT} at once")));
        }
        let packet = self.packet;
        let conn = self.connections.entry(client).or_default();
        let dir = if to_card { &mut conn.to_card } else { &mut conn.from_card };
        let new = dir.accept(tcp.sequence_number(), tcp.syn(), tcp.payload()).map_err(|missing| {
            SpecError::at(
                &self.file,
                Position { line: packet, column: 1 },
                format!(
                    "packet {packet}: {missing} bytes of the TCP stream {} port {} are missing before this packet \
                     (the capture dropped packets)",
                    if to_card { "from" } else { "to" },
                    client.1
                ),
            )
        })?;
        if new.is_empty() {
            return Ok(());
        }
        if to_card {
            self.requests_from(client, new, stamp)
        } else {
            self.answers(client, new, stamp);
            Ok(())
        }
    }

    /// The host's request bytes `new` on connection `client`.
    fn requests_from(&mut self, client: (IpAddr, u16), new: &[u8], stamp: Stamp) -> Result<(), SpecError> {
        let packet = self.packet;
        let mut conn = self.connections.remove(&client).unwrap_or_default();
        conn.request.extend_from_slice(new);
        let result = (|| {
            while conn.request.len() >= HEADER_BYTES {
                let head: [u8; HEADER_BYTES] = conn.request[..HEADER_BYTES].try_into().expect("8 bytes");
                let request = Header::parse(&head).request().map_err(|e| self.err(format!("request header: {e}")))?;
                let data = match request {
                    Request::Line { data_bytes, .. } => data_bytes,
                    _ => 0,
                };
                if conn.request.len() < HEADER_BYTES + data {
                    break;
                }
                let line = conn.request[HEADER_BYTES..HEADER_BYTES + data].to_vec();
                conn.request.drain(..HEADER_BYTES + data);
                let (name, end, command) = match request {
                    Request::Line { reply: true, .. } => {
                        let text = String::from_utf8_lossy(trim_line(&line)).into_owned();
                        ("GETRESPONSE", End::Line, Some(Sent { packet, stamp, text }))
                    }
                    Request::Flush => ("FLUSH", End::Bytes(1), None),
                    Request::ReadReady => ("READREADY", End::Bytes(2), None),
                    Request::NextPacket => ("GETBUFFER", End::LineOrNul, None),
                    Request::Line { reply: false, .. } => {
                        return Err(self.err("a SENDLINE request: the importer reads GETRESPONSE exchanges only"))
                    }
                    Request::Control(c) => {
                        return Err(self.err(format!(
                            "a control-character request (0x{c:02X}): the importer reads GETRESPONSE exchanges only"
                        )))
                    }
                };
                *self.requests.entry(name).or_default() += 1;
                // A long answer still coming: the GETBUFFER fetches its next packet.
                if end == End::LineOrNul
                    && conn.awaiting.back().is_some_and(|a| a.command.is_some() && !a.bytes.is_empty())
                {
                    continue;
                }
                if command.is_some() || end == End::Bytes(1) {
                    // The host moved on: what it waited for and did not get is silence.
                    while let Some(a) = conn.awaiting.pop_front() {
                        self.finish_answer(a, None);
                    }
                    if command.is_some() {
                        if let Some(other) = self.busy.filter(|b| *b != client) {
                            if self
                                .connections
                                .get(&other)
                                .is_some_and(|c| c.awaiting.iter().any(|a| a.command.is_some()))
                            {
                                return Err(self.err(format!(
                                    "port {} sends a command while port {} waits for an answer: import one \
                                     connection at a time (Wireshark: tcp.port == {})",
                                    client.1, other.1, client.1
                                )));
                            }
                        }
                        self.busy = Some(client);
                    }
                }
                if conn.awaiting.len() >= AWAITING_MAX {
                    return Err(self.err(format!("more than {AWAITING_MAX} requests waiting for their answers")));
                }
                conn.awaiting.push_back(Awaiting { end, command, bytes: Vec::new(), cut: false, in_error: false });
            }
            if conn.request.len() > HEADER_BYTES + pmacwd_specs::protocol::DATA_BYTES_MAX {
                return Err(self.err("a request longer than the protocol allows"));
            }
            Ok(())
        })();
        self.connections.insert(client, conn);
        result
    }

    /// The card's bytes `new` on connection `client`, matched to the requests in order.
    fn answers(&mut self, client: (IpAddr, u16), mut new: &[u8], stamp: Stamp) {
        let mut conn = self.connections.remove(&client).unwrap_or_default();
        while !new.is_empty() {
            let Some(front) = conn.awaiting.front_mut() else {
                self.stray_bytes += new.len() as u64;
                break;
            };
            let (took, ended) = front.take(new);
            new = &new[took..];
            if ended {
                let a = conn.awaiting.pop_front().expect("front");
                self.finish_answer(a, Some(stamp));
            }
        }
        self.connections.insert(client, conn);
    }

    /// An answer complete (`ended` the host time it ended), or abandoned: its records if it
    /// answers a command.
    fn finish_answer(&mut self, a: Awaiting, ended: Option<Stamp>) {
        let Some(sent) = a.command else { return };
        let (text, cut) = if a.bytes.is_empty() {
            ("(timeout)".to_string(), None)
        } else if a.cut {
            let kept = match a.bytes.iter().rposition(|b| *b == CR) {
                Some(i) => super::reply_values(&a.bytes[..i]),
                None => Vec::new(),
            };
            let why = format!("an answer longer than {ANSWER_BYTES_MAX} bytes, kept only so far");
            (kept.join("\\r"), Some(super::Cut { rest: String::new(), why }))
        } else {
            (super::reply_values(&a.bytes).join("\\r"), None)
        };
        self.queue.push_back(Record::Command {
            line: sent.packet,
            column: 1,
            stamp: Some(sent.stamp),
            text: sent.text,
        });
        self.queue.push_back(Record::Reply { line: sent.packet, column: 1, stamp: ended, text, cut });
    }

    /// Reads the next block of the file; `false` at its end.
    fn next_block(&mut self) -> Result<bool, SpecError> {
        loop {
            match self.reader.next() {
                Ok((offset, block)) => {
                    let mut packet: Option<(i32, Vec<u8>, Stamp)> = None;
                    let mut problem = None;
                    match block {
                        PcapBlockOwned::LegacyHeader(h) => {
                            let units = if h.is_nanosecond_precision() { 1_000_000_000 } else { 1_000_000 };
                            self.legacy = Some((h.network.0, units));
                        }
                        PcapBlockOwned::Legacy(b) => {
                            let (link, units) = self.legacy.unwrap_or((1, 1_000_000));
                            let ns = i128::from(b.ts_sec) * 1_000_000_000
                                + i128::from(b.ts_usec) * (1_000_000_000 / units as i128);
                            packet =
                                Some((link, b.data.to_vec(), Stamp::since_epoch(ns, 1_000_000_000 / units as i128)));
                        }
                        PcapBlockOwned::NG(Block::SectionHeader(_)) => self.interfaces.clear(),
                        PcapBlockOwned::NG(Block::InterfaceDescription(idb)) => {
                            let units = idb.ts_resolution().unwrap_or(1_000_000).max(1);
                            self.interfaces.push((idb.linktype.0, units, idb.ts_offset()));
                        }
                        PcapBlockOwned::NG(Block::EnhancedPacket(epb)) => {
                            match self.interfaces.get(epb.if_id as usize) {
                                Some(&(link, units, offset)) => {
                                    let ticks = (u64::from(epb.ts_high) << 32) | u64::from(epb.ts_low);
                                    let ns = i128::from(ticks) * 1_000_000_000 / i128::from(units)
                                        + i128::from(offset) * 1_000_000_000;
                                    let res = (1_000_000_000 / i128::from(units)).max(1);
                                    packet = Some((link, epb.data.to_vec(), Stamp::since_epoch(ns, res)));
                                }
                                None => problem = Some(format!("interface {} is not described", epb.if_id)),
                            }
                        }
                        PcapBlockOwned::NG(Block::SimplePacket(_)) => {
                            problem = Some(
                                "a simple packet block has no timestamp: capture with enhanced packet blocks"
                                    .to_string(),
                            )
                        }
                        // Name resolution, statistics, comments and the like carry no packet.
                        PcapBlockOwned::NG(_) => {}
                    }
                    self.reader.consume(offset);
                    if let Some(p) = problem {
                        self.packet += 1;
                        return Err(self.err(p));
                    }
                    if let Some((link, data, stamp)) = packet {
                        self.packet += 1;
                        self.packet(link, &data, stamp)?;
                    }
                    return Ok(true);
                }
                Err(PcapError::Eof) => return Ok(false),
                Err(PcapError::UnexpectedEof) => {
                    self.packet += 1;
                    return Err(self.err("the capture ends in the middle of this packet (a cut file)"));
                }
                Err(PcapError::Incomplete(_)) => {
                    if self.reader.reader_exhausted() {
                        self.packet += 1;
                        return Err(self.err("the capture ends in the middle of this packet (a cut file)"));
                    }
                    if let Err(e) = self.reader.refill() {
                        let e = format!("cannot read: {e:?}");
                        return Err(self.err(e));
                    }
                }
                Err(e) => {
                    let e = format!("{e:?}");
                    self.packet += 1;
                    return Err(self.err(format!("not a valid capture block: {e}")));
                }
            }
        }
    }
}

impl Records for PcapRecords {
    fn next_record(&mut self) -> Result<Option<Record>, SpecError> {
        loop {
            if let Some(r) = self.queue.pop_front() {
                return Ok(Some(r));
            }
            if self.done {
                return Ok(None);
            }
            if !self.next_block()? {
                self.done = true;
                // The capture ends: what the host still waited for did not come in it.
                let mut keys: Vec<(IpAddr, u16)> = self.connections.keys().copied().collect();
                keys.sort();
                for k in keys {
                    if let Some(mut c) = self.connections.remove(&k) {
                        while let Some(a) = c.awaiting.pop_front() {
                            self.finish_answer(a, None);
                        }
                    }
                }
            }
        }
    }

    fn passed_over(&self) -> Vec<String> {
        let mut out = Vec::new();
        if self.other_packets > 0 {
            out.push(format!("{} packets not of a TCP connection to port {CARD_PORT}", self.other_packets));
        }
        let mut names: Vec<_> = self.requests.iter().filter(|(n, _)| **n != "GETRESPONSE").collect();
        names.sort();
        if !names.is_empty() {
            let list: Vec<String> = names.iter().map(|(n, c)| format!("{c} {n}")).collect();
            out.push(format!(
                "{} requests that are not commands, their answers matched and set aside",
                list.join(", ")
            ));
        }
        if self.stray_bytes > 0 {
            out.push(format!("{} bytes from the card with no request waiting for them", self.stray_bytes));
        }
        out
    }
}
