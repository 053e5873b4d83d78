//! `pmacwd record`: a transparent proxy between host programs and a card (real or emulated)
//! that writes every command line and its reply, with timing, as a capture.
//!
//! Bytes are forwarded unchanged in both directions; the proxy only reads along. Per host
//! session, one thread carries requests to the card and one carries replies back. An exchange
//! is a VR_PMAC_GETRESPONSE line plus every reply byte up to the next request (GETBUFFER
//! continuations included); it is written once the reply ends (ACK, or an error's CR), the next
//! request comes, or `silence` passes without a byte: then it is a silence (a tripped card,
//! UM p.215). Time is the proxy's clock times the servo rate, or, with `--virtual-time`, the
//! `step` commands seen on the proxied control interface of a `pmacwd serve --virtual-time`.
//!
//! Concurrent sessions share one timeline, in the order their exchanges complete.

use super::capture::{CaptureWriter, Timing};
use super::framing::{ACK, BEL, CR};
use super::protocol::{read_or_end, trim_line, Header, Request, HEADER_BYTES, VR_PMAC_GETRESPONSE};
use crate::trace::Step;
use std::io::{self, BufRead, BufReader, Read, Write};
use std::net::{Shutdown, SocketAddr, TcpListener, TcpStream};
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::{Arc, Mutex, MutexGuard};
use std::thread;
use std::time::{Duration, Instant};

#[derive(Clone, Debug)]
pub struct RecordOptions {
    pub listen: SocketAddr,
    pub target: String,
    /// Proxy the emulator's control interface too: (listen, target).
    pub control: Option<(SocketAddr, String)>,
    pub servo_hz: u32,
    pub virtual_time: bool,
    /// No reply byte for this long: the card is silent.
    pub silence: Duration,
    /// Stop after this many host sessions have ended.
    pub sessions: Option<u64>,
    pub verbose: bool,
}

/// The shared timeline and the capture.
pub struct Recorder {
    capture: CaptureWriter<Box<dyn Write + Send>>,
    start: Instant,
    servo_hz: u32,
    virtual_time: bool,
    cycles_written: u64,
    pub exchanges: u64,
}

impl Recorder {
    pub fn new(capture: CaptureWriter<Box<dyn Write + Send>>, servo_hz: u32, virtual_time: bool) -> Recorder {
        Recorder { capture, start: Instant::now(), servo_hz, virtual_time, cycles_written: 0, exchanges: 0 }
    }

    /// The timing a capture made with these options has.
    pub fn timing(servo_hz: u32, virtual_time: bool) -> Timing {
        if virtual_time {
            Timing::Exact
        } else {
            // A tenth of a second either way: host scheduling, network and the card's own
            // polling (MODEL: a bound chosen for loopback and a quiet LAN).
            Timing::HostClock { window_cycles: (servo_hz / 10).max(1) }
        }
    }

    fn advance_to(&mut self, t: Instant) {
        if self.virtual_time {
            return;
        }
        let nanos = t.saturating_duration_since(self.start).as_nanos();
        let due = u64::try_from(nanos.saturating_mul(u128::from(self.servo_hz)) / 1_000_000_000).unwrap_or(u64::MAX);
        if due > self.cycles_written {
            self.capture.elapse(due - self.cycles_written);
            self.cycles_written = due;
        }
    }

    fn exchange(&mut self, at: Instant, line: &str, reply: Option<&[u8]>) -> io::Result<()> {
        self.advance_to(at);
        self.exchanges += 1;
        self.capture.exchange(line, reply)
    }

    fn event(&mut self, at: Instant, step: Step) -> io::Result<()> {
        self.advance_to(at);
        self.capture.event(step)
    }

    fn capture_note(&mut self, note: String) {
        self.capture.note(note);
    }

    pub fn finish(self) -> io::Result<(u64, u64, Vec<String>)> {
        let steps = self.capture.steps;
        Ok((self.exchanges, steps, self.capture.finish()?))
    }
}

struct Shared {
    recorder: Mutex<Option<Recorder>>,
    options: RecordOptions,
    sessions_ended: AtomicU64,
    stopping: AtomicBool,
}

impl Shared {
    fn recorder(&self) -> MutexGuard<'_, Option<Recorder>> {
        self.recorder.lock().unwrap_or_else(|e| e.into_inner())
    }
    fn record(&self, f: impl FnOnce(&mut Recorder) -> io::Result<()>) {
        let mut r = self.recorder();
        if let Some(rec) = r.as_mut() {
            if let Err(e) = f(rec) {
                eprintln!("pmacwd record: writing the capture failed: {e}; recording stopped");
                *r = None;
            }
        }
    }
    fn log(&self, msg: &str) {
        if self.options.verbose {
            eprintln!("pmacwd record: {msg}");
        }
    }
}

/// The exchange of one session waiting for its reply.
#[derive(Default)]
struct Pending {
    exchange: Option<(Instant, String, Vec<u8>)>,
    last_byte: Option<Instant>,
}

impl Pending {
    /// Writes the waiting exchange, if any.
    fn finish(&mut self, shared: &Shared) {
        if let Some((at, line, bytes)) = self.exchange.take() {
            let reply = (!bytes.is_empty()).then_some(bytes.as_slice());
            shared.record(|r| r.exchange(at, &line, reply));
        }
        self.last_byte = None;
    }
}

/// A running proxy.
pub struct Proxy {
    shared: Arc<Shared>,
    pub local_addr: SocketAddr,
    pub control_addr: Option<SocketAddr>,
    accept: Vec<thread::JoinHandle<()>>,
}

impl Proxy {
    pub fn start(recorder: Recorder, options: RecordOptions) -> io::Result<Proxy> {
        let listener = TcpListener::bind(options.listen)?;
        let local_addr = listener.local_addr()?;
        let control = match &options.control {
            Some((listen, _)) => Some(TcpListener::bind(listen)?),
            None => None,
        };
        let control_addr = control.as_ref().map(|l| l.local_addr()).transpose()?;
        let shared = Arc::new(Shared {
            recorder: Mutex::new(Some(recorder)),
            options,
            sessions_ended: AtomicU64::new(0),
            stopping: AtomicBool::new(false),
        });
        let mut accept = Vec::new();
        let s = shared.clone();
        accept.push(thread::spawn(move || accept_hosts(listener, local_addr, s)));
        if let Some(l) = control {
            let s = shared.clone();
            accept.push(thread::spawn(move || accept_control(l, s)));
        }
        Ok(Proxy { shared, local_addr, control_addr, accept })
    }

    /// Waits until `--sessions` host sessions have ended (forever without it), then closes
    /// the capture: (exchanges, steps, notes left over).
    pub fn wait(mut self) -> io::Result<(u64, u64, Vec<String>)> {
        if let Some(t) = self.accept.drain(..1).next() {
            let _ = t.join();
        }
        self.close()
    }

    fn close(self) -> io::Result<(u64, u64, Vec<String>)> {
        self.shared.stopping.store(true, Ordering::SeqCst);
        if let Some(a) = self.control_addr {
            let _ = TcpStream::connect(a);
        }
        match self.shared.recorder().take() {
            Some(r) => r.finish(),
            None => Ok((0, 0, vec!["the capture was closed early after a write error".into()])),
        }
    }
}

fn accept_hosts(listener: TcpListener, own: SocketAddr, shared: Arc<Shared>) {
    let mut next = 0u64;
    for client in listener.incoming() {
        if shared.stopping.load(Ordering::SeqCst) {
            return;
        }
        let Ok(client) = client else { continue };
        next += 1;
        let id = next;
        let card = match TcpStream::connect(&shared.options.target) {
            Ok(c) => c,
            Err(e) => {
                eprintln!("pmacwd record: session {id}: cannot reach the card at {}: {e}", shared.options.target);
                continue;
            }
        };
        let s = shared.clone();
        thread::spawn(move || {
            s.log(&format!("session {id} opened"));
            host_session(client, card, &s);
            s.log(&format!("session {id} ended"));
            let ended = s.sessions_ended.fetch_add(1, Ordering::SeqCst) + 1;
            if s.options.sessions.is_some_and(|n| ended >= n) {
                s.stopping.store(true, Ordering::SeqCst);
                // Wake the accept loop so that it sees the flag.
                let _ = TcpStream::connect(own);
            }
        });
    }
}

fn host_session(client: TcpStream, card: TcpStream, shared: &Arc<Shared>) {
    let pending = Arc::new(Mutex::new(Pending::default()));
    let (Ok(client_w), Ok(card_r), Ok(card_w)) = (client.try_clone(), card.try_clone(), card.try_clone()) else {
        return;
    };
    let _ = client.set_nodelay(true);
    let _ = card.set_nodelay(true);
    let replies = {
        let shared = shared.clone();
        let pending = pending.clone();
        thread::spawn(move || replies_to_host(card_r, client_w, &shared, &pending))
    };
    requests_to_card(client, card_w, shared, &pending);
    let _ = card.shutdown(Shutdown::Write);
    let _ = replies.join();
    pending.lock().unwrap_or_else(|e| e.into_inner()).finish(shared);
}

fn requests_to_card(client: TcpStream, mut card: TcpStream, shared: &Shared, pending: &Mutex<Pending>) {
    let mut reader = BufReader::new(client);
    let mut header = [0u8; HEADER_BYTES];
    let mut data = Vec::new();
    loop {
        match read_or_end(&mut reader, &mut header) {
            Ok(true) => {}
            _ => return,
        }
        let h = Header::parse(&header);
        let request = h.request();
        let data_bytes = match request {
            Ok(Request::Line { data_bytes, .. }) => data_bytes,
            _ => 0,
        };
        data.resize(data_bytes, 0);
        if data_bytes > 0 && !matches!(read_or_end(&mut reader, &mut data), Ok(true)) {
            return;
        }
        {
            let mut p = pending.lock().unwrap_or_else(|e| e.into_inner());
            match request {
                Ok(Request::NextPacket) => {}
                Ok(Request::Line { .. }) if h.request == VR_PMAC_GETRESPONSE => {
                    p.finish(shared);
                    let line = String::from_utf8_lossy(trim_line(&data)).into_owned();
                    p.exchange = Some((Instant::now(), line, Vec::new()));
                }
                Ok(_) => {
                    p.finish(shared);
                    let code = h.request;
                    shared.record(|r| {
                        r.capture_note(format!("request 0x{code:02X} forwarded, not recorded"));
                        Ok(())
                    });
                }
                Err(e) => {
                    // Not a request the proxy can follow: forward the rest as it comes.
                    p.finish(shared);
                    shared.record(|r| {
                        r.capture_note(format!("{e}: the rest of this session was forwarded, not recorded"));
                        Ok(())
                    });
                    drop(p);
                    if card.write_all(&header).is_err() {
                        return;
                    }
                    let _ = io::copy(&mut reader, &mut card);
                    return;
                }
            }
        }
        if card.write_all(&header).and_then(|()| card.write_all(&data)).is_err() {
            return;
        }
    }
}

/// Whether `bytes` is a whole reply: it ends with the ACK, or with the CR of an error.
fn reply_complete(bytes: &[u8]) -> bool {
    match bytes.last() {
        Some(&ACK) => true,
        Some(&CR) => bytes.contains(&BEL),
        _ => false,
    }
}

fn replies_to_host(mut card: TcpStream, mut client: TcpStream, shared: &Shared, pending: &Mutex<Pending>) {
    let silence = shared.options.silence;
    let _ = card.set_read_timeout(Some(Duration::from_millis(20).min(silence)));
    let mut buf = [0u8; 4096];
    loop {
        match card.read(&mut buf) {
            Ok(0) => break,
            Ok(n) => {
                if client.write_all(&buf[..n]).is_err() {
                    break;
                }
                let mut p = pending.lock().unwrap_or_else(|e| e.into_inner());
                p.last_byte = Some(Instant::now());
                if let Some((_, _, bytes)) = &mut p.exchange {
                    bytes.extend_from_slice(&buf[..n]);
                    if reply_complete(bytes) {
                        p.finish(shared);
                    }
                }
            }
            Err(e) if matches!(e.kind(), io::ErrorKind::WouldBlock | io::ErrorKind::TimedOut) => {
                let mut p = pending.lock().unwrap_or_else(|e| e.into_inner());
                let since = p.last_byte.or(p.exchange.as_ref().map(|(at, _, _)| *at));
                if p.exchange.is_some() && since.is_some_and(|t| t.elapsed() >= silence) {
                    p.finish(shared);
                }
            }
            Err(e) if e.kind() == io::ErrorKind::Interrupted => {}
            Err(_) => break,
        }
    }
    let _ = client.shutdown(Shutdown::Both);
}

fn accept_control(listener: TcpListener, shared: Arc<Shared>) {
    let Some((_, target)) = shared.options.control.clone() else { return };
    for client in listener.incoming() {
        if shared.stopping.load(Ordering::SeqCst) {
            return;
        }
        let Ok(client) = client else { continue };
        let card = match TcpStream::connect(&target) {
            Ok(c) => c,
            Err(e) => {
                eprintln!("pmacwd record: cannot reach the control interface at {target}: {e}");
                continue;
            }
        };
        let s = shared.clone();
        thread::spawn(move || {
            if let Err(e) = control_session(client, card, &s) {
                s.log(&format!("control session: {e}"));
            }
        });
    }
}

/// Forwards control lines and their replies; an `ok {step}` reply is an event of the card.
fn control_session(client: TcpStream, card: TcpStream, shared: &Shared) -> io::Result<()> {
    let mut to_client = client.try_clone()?;
    let mut to_card = card.try_clone()?;
    let mut from_client = BufReader::new(client);
    let mut from_card = BufReader::new(card);
    let (mut line, mut reply) = (String::new(), String::new());
    loop {
        line.clear();
        if from_client.read_line(&mut line)? == 0 {
            return Ok(());
        }
        to_card.write_all(line.as_bytes())?;
        reply.clear();
        if from_card.read_line(&mut reply)? == 0 {
            return Ok(());
        }
        let at = Instant::now();
        to_client.write_all(reply.as_bytes())?;
        if let Some(json) = reply.trim_end().strip_prefix("ok {").map(|rest| format!("{{{rest}")) {
            match serde_json::from_str::<Step>(&json) {
                Ok(step) => shared.record(|r| r.event(at, step)),
                Err(e) => shared.record(|r| {
                    r.capture_note(format!("control reply `{json}` not understood: {e}"));
                    Ok(())
                }),
            }
        }
    }
}
