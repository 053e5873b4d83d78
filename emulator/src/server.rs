//! `pmacwd serve`: the card on TCP. One thread per connection; the card's lock is held only
//! while one command is answered (microseconds; a line is answered a command at a time,
//! `card/line.rs`), never while a socket is read or written, so a slow or vanished client
//! cannot stall the others.
//!
//! What keeps the server from wedging: a request the card cannot follow (unknown code, a
//! length beyond its 1,492-byte buffer) closes that connection; a write that does not complete
//! in `WRITE_TIMEOUT` closes it; connections idle past `idle_timeout` (control connections:
//! `control_idle_timeout`) are closed; and when `clients_max` host connections (or
//! [`CONTROL_CLIENTS_MAX`] control connections) are open, the one idle longest makes room for
//! a new one (half-open connections are never the ones in use). The card's lock is held for
//! at most [`CYCLES_PER_HOLD_MAX`] servo cycles at a time.

use crate::bounded::{accepted, room_for_a_thread, spawn, CountedLog, Table};
use crate::card::{Card, Clock, Progress, CYCLES_PER_HOLD_MAX, SERVO_HZ_MAX};
use crate::card_turns::{CardTurns, LeftoverTurn};
use crate::control::{read_line_max, Control, CONTROL_LINE_BYTES_MAX};
use crate::host_reply::{HostReply, Turn};
use crate::listen::bind;
use crate::protocol::{read_or_end, trim_line, Header, Request, HEADER_BYTES};
use pmacwd_specs::grammar::Addressing;
use pmacwd_specs::vocab::event::Event;
use pmacwd_trace::jsonl::step_line;
use pmacwd_trace::{Expect, Step, TraceEvent, STEP_CYCLES_MAX};
use std::io::{self, BufReader, Write};
use std::net::{SocketAddr, TcpListener, TcpStream};
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::{Arc, Mutex, MutexGuard};
use std::thread;
use std::time::{Duration, Instant};

/// The byte a flush is acknowledged with (see `Request::Flush` in `serve_connection`).
pub const FLUSH_ACK: u8 = crate::protocol::DOWNLOAD;

/// A reply that cannot be written in this time closes the connection.
pub const WRITE_TIMEOUT: Duration = Duration::from_secs(5);
/// On the wall clock the card is brought up to date this often even when no one asks, so that
/// a request after a long silence finds at most this much time to catch up: at
/// [`SERVO_HZ_MAX`], 10,000 servo cycles, within one lock hold ([`CYCLES_PER_HOLD_MAX`]),
/// for ten wake-ups a second of a few microseconds each. Without it, a card idle for a day
/// ran its 200 million cycles (about a second) before answering the next request.
pub const CATCH_UP_INTERVAL: Duration = Duration::from_millis(100);
const _: () = assert!(
    SERVO_HZ_MAX as u128 * CATCH_UP_INTERVAL.as_millis() / 1000 <= CYCLES_PER_HOLD_MAX as u128,
    "a catch-up between two wake-ups fits one lock hold"
);
/// The shortest time between two error replies on one host connection. A client that answers
/// an error by polling again at once (dls-pmaccontrol sends `CLOSE` and polls again after
/// every failed poll line; measured at about 5,800 exchanges a second, with `--record`
/// growing 6 MB/s) is slowed to at most 100 errors a second; replies without an error are
/// never delayed. A real card takes milliseconds over a serial or Ethernet link too, so no
/// client can rely on faster errors. The wait happens with the card's lock released.
pub const ERROR_REPLY_INTERVAL: Duration = Duration::from_millis(10);
/// Control connections open at once; a newcomer beyond it closes the one idle longest. A test
/// bench uses one or two; sixteen leave room for several benches and a person with `nc`, and
/// bound the threads the control port can cost.
pub const CONTROL_CLIENTS_MAX: usize = 16;
/// A control connection silent this long is closed (`serve --control-idle-timeout`), as a host
/// connection is after `--idle-timeout`: ten minutes outlast any pause of a bench between
/// two commands, and free what a client that left without closing holds.
pub const CONTROL_IDLE_TIMEOUT_DEFAULT_SECONDS: u64 = 600;

#[derive(Clone, Debug)]
pub struct ServeOptions {
    pub listen: SocketAddr,
    pub control: Option<SocketAddr>,
    pub clients_max: usize,
    pub idle_timeout: Option<Duration>,
    /// A control connection silent this long is closed (`None`: never).
    pub control_idle_timeout: Option<Duration>,
    pub verbose: bool,
    /// The stack of each connection's thread (`None`: the platform's default). A size the
    /// system cannot give makes every connection's thread fail to start, which is how the
    /// tests reach that path.
    pub thread_stack_bytes: Option<usize>,
}

impl ServeOptions {
    /// A free port on loopback, no control interface, no idle timeouts (for tests and benches).
    pub fn free_loopback_port(clients_max: usize) -> ServeOptions {
        ServeOptions {
            listen: SocketAddr::from(([127, 0, 0, 1], 0)),
            control: None,
            clients_max,
            idle_timeout: None,
            control_idle_timeout: None,
            verbose: false,
            thread_stack_bytes: None,
        }
    }
}

/// Counters for the summary and the tests.
#[derive(Default, Debug)]
pub struct Stats {
    pub connections: AtomicU64,
    pub refused_requests: AtomicU64,
    /// Host connections closed to make room for a newcomer.
    pub evicted: AtomicU64,
    /// Control connections closed to make room for a newcomer.
    pub control_evicted: AtomicU64,
    /// Connections closed because the system would not start a thread for them.
    pub spawn_failures: AtomicU64,
    /// Error replies held back to keep [`ERROR_REPLY_INTERVAL`] after the previous one.
    pub errors_slowed: AtomicU64,
}

struct Shared {
    card: Mutex<Card>,
    /// Who takes the card next: requests before the rest of abandoned lines (`card_turns`).
    turns: CardTurns,
    started: Instant,
    options: ServeOptions,
    hosts: Table,
    controls: Table,
    stats: Stats,
    stopping: AtomicBool,
    /// Connections the system would not start a thread for.
    spawn_failures: CountedLog,
    /// Requests the card cannot follow (each closes its connection): logged one by one only
    /// with `verbose`, otherwise summed up, so that a client sending garbage in a loop cannot
    /// fill standard error.
    protocol_errors: CountedLog,
    /// Accepts that failed (no file descriptor left, mostly).
    accept_errors: CountedLog,
}

impl Shared {
    fn card(&self) -> MutexGuard<'_, Card> {
        // A panic elsewhere must not take the card down with it: the state stays usable.
        self.card.lock().unwrap_or_else(|e| e.into_inner())
    }
    /// The card, caught up with its clock: the servo cycles due when the call began run
    /// [`CYCLES_PER_HOLD_MAX`] at a time, with the lock released between chunks, so that no
    /// one waits behind a long catch-up for more than one chunk.
    fn card_now(&self) -> MutexGuard<'_, Card> {
        let mut card = self.card();
        let target = card.due_cycles();
        while !card.run_towards(target) {
            drop(card);
            thread::yield_now();
            card = self.card();
        }
        card
    }
    /// The card for a request (see [`CardTurns`]).
    fn card_request(&self) -> CardHold<'_> {
        CardHold { card: self.turns.request(|| self.card_now()), _turn: None }
    }
    /// The card for the rest of an abandoned line, once its turn comes; `None` if its host left
    /// meanwhile.
    fn card_leftover(&self, host_gone: &dyn Fn() -> bool) -> Option<CardHold<'_>> {
        let (card, turn) = self.turns.leftover(|| self.card_now(), host_gone)?;
        Some(CardHold { card, _turn: Some(turn) })
    }
    /// Milliseconds since the start, plus one: 0 is a connection's `NEVER_SPOKE`.
    fn now_ms(&self) -> u64 {
        u64::try_from(self.started.elapsed().as_millis()).unwrap_or(u64::MAX).saturating_add(1)
    }
    fn log(&self, msg: &str) {
        if self.options.verbose {
            crate::bounded::to_stderr(format_args!("pmacwd serve: {msg}"));
        }
    }
}

/// The card, held for one command; a leftover also holds its turn (`card_turns`). The card is
/// declared first, so it is released first.
struct CardHold<'a> {
    card: MutexGuard<'a, Card>,
    _turn: Option<LeftoverTurn<'a>>,
}

impl std::ops::Deref for CardHold<'_> {
    type Target = Card;
    fn deref(&self) -> &Card {
        &self.card
    }
}

impl std::ops::DerefMut for CardHold<'_> {
    fn deref_mut(&mut self) -> &mut Card {
        &mut self.card
    }
}

/// A running server.
pub struct Server {
    shared: Arc<Shared>,
    pub local_addr: SocketAddr,
    pub control_addr: Option<SocketAddr>,
    threads: Vec<thread::JoinHandle<()>>,
}

impl Server {
    /// Binds the listeners and starts accepting.
    pub fn start(card: Card, options: ServeOptions) -> io::Result<Server> {
        let listener = bind("host port", options.listen)?;
        let local_addr = listener.local_addr()?;
        let control = match options.control {
            Some(a) => Some(bind("control port", a)?),
            None => None,
        };
        let control_addr = control.as_ref().map(|l| l.local_addr()).transpose()?;
        let verbose = options.verbose;
        let shared = Arc::new(Shared {
            card: Mutex::new(card),
            turns: CardTurns::default(),
            started: Instant::now(),
            hosts: Table::new(options.clients_max),
            controls: Table::new(CONTROL_CLIENTS_MAX),
            options,
            stats: Stats::default(),
            stopping: AtomicBool::new(false),
            spawn_failures: CountedLog::new("pmacwd serve", "connections closed for want of a thread", verbose),
            protocol_errors: CountedLog::new("pmacwd serve", "protocol errors, each closing its connection", verbose),
            accept_errors: CountedLog::new("pmacwd serve", "failed accepts", verbose),
        });
        let mut threads = Vec::new();
        let s = shared.clone();
        threads.push(spawn("serve: housekeeping".into(), None, move || housekeeping(&s))?);
        let s = shared.clone();
        match spawn("serve: accept hosts".into(), None, move || accept_hosts(listener, s)) {
            Ok(t) => threads.push(t),
            Err(e) => {
                shared.stopping.store(true, Ordering::SeqCst);
                return Err(e);
            }
        }
        if let Some(l) = control {
            let s = shared.clone();
            match spawn("serve: accept control".into(), None, move || accept_control(l, s)) {
                Ok(t) => threads.push(t),
                Err(e) => {
                    // No server without its control interface: stop the host listener again.
                    shared.stopping.store(true, Ordering::SeqCst);
                    let _ = TcpStream::connect(local_addr);
                    return Err(e);
                }
            }
        }
        Ok(Server { shared, local_addr, control_addr, threads })
    }

    pub fn stats(&self) -> &Stats {
        &self.shared.stats
    }

    /// Runs `f` on the card (for tests and the final summary).
    pub fn with_card<T>(&self, f: impl FnOnce(&mut Card) -> T) -> T {
        f(&mut self.shared.card())
    }

    /// Blocks until the listeners stop (they do not, unless [`Server::stop`] is called).
    pub fn wait(mut self) {
        for t in self.threads.drain(..) {
            let _ = t.join();
        }
    }

    /// Stops accepting and closes every connection.
    pub fn stop(self) {
        self.stop_then(|_| ());
    }

    /// Stops as [`Server::stop`] does, then runs `f` on the card, which then holds everything
    /// the hosts sent before the stop (`pmacwd serve` finishes its recording so).
    pub fn stop_then<T>(mut self, f: impl FnOnce(&mut Card) -> T) -> T {
        self.shared.stopping.store(true, Ordering::SeqCst);
        // Wake the accept loops.
        let _ = TcpStream::connect(self.local_addr);
        if let Some(a) = self.control_addr {
            let _ = TcpStream::connect(a);
        }
        self.shared.hosts.close_all();
        self.shared.controls.close_all();
        for t in self.threads.drain(..) {
            let _ = t.join();
        }
        self.shared.spawn_failures.flush();
        self.shared.protocol_errors.flush();
        self.shared.accept_errors.flush();
        f(&mut self.shared.card())
    }
}

/// Until the server stops, every [`CATCH_UP_INTERVAL`]: brings a wall-clock card up to date,
/// and prints the summaries of the logs that are due.
fn housekeeping(shared: &Shared) {
    let wall_clock = matches!(shared.card().clock(), Clock::Wall { .. });
    while !shared.stopping.load(Ordering::SeqCst) {
        thread::sleep(CATCH_UP_INTERVAL);
        if wall_clock {
            drop(shared.card_now());
        }
        for log in [&shared.spawn_failures, &shared.protocol_errors, &shared.accept_errors] {
            log.flush_due();
        }
    }
}

fn accept_hosts(listener: TcpListener, shared: Arc<Shared>) {
    for stream in listener.incoming() {
        if shared.stopping.load(Ordering::SeqCst) {
            return;
        }
        let Some(stream) = accepted(stream, &shared.accept_errors) else { continue };
        if let Err(e) = room_for_a_thread(shared.options.thread_stack_bytes) {
            // Before the table or the thread allocate anything for it: closed, counted.
            shared.stats.spawn_failures.fetch_add(1, Ordering::Relaxed);
            shared.spawn_failures.report(&format!("a host connection: cannot start its thread: {e}"));
            continue;
        }
        let (id, last_active_ms, evicted) = match shared.hosts.admit(&stream) {
            Ok(admitted) => admitted,
            Err(e) => {
                shared.accept_errors.report(&format!("cannot keep a host connection: {e}"));
                continue;
            }
        };
        if let Some(old) = evicted {
            shared.stats.evicted.fetch_add(1, Ordering::Relaxed);
            shared.log(&format!("{} hosts open: closed #{old}, idle longest", shared.hosts.max));
        }
        shared.stats.connections.fetch_add(1, Ordering::Relaxed);
        let s = shared.clone();
        let started = spawn(format!("serve: host #{id}"), shared.options.thread_stack_bytes, move || {
            let peer = stream.peer_addr().map_or_else(|_| "?".into(), |a| a.to_string());
            s.log(&format!("#{id} {peer} connected"));
            match host_session(stream, &s, &last_active_ms) {
                Ok(()) => s.log(&format!("#{id} {peer} closed")),
                Err(e) => {
                    // Protocol errors are counted (each logged with --verbose); I/O endings
                    // are logged only with --verbose.
                    if e.kind() == io::ErrorKind::InvalidData {
                        s.protocol_errors.report(&format!("#{id} {peer}: {e}; connection closed"));
                    } else {
                        s.log(&format!("#{id} {peer}: {e}"));
                    }
                }
            }
            s.hosts.forget(id);
        });
        if let Err(e) = started {
            // The thread's closure, and the stream it owned, are gone; the table's handle is
            // the last one: close it, and keep accepting.
            shared.stats.spawn_failures.fetch_add(1, Ordering::Relaxed);
            shared.hosts.close(id);
            shared.spawn_failures.report(&format!("host connection #{id}: cannot start its thread: {e}"));
        }
    }
}

fn host_session(stream: TcpStream, shared: &Shared, last_active_ms: &AtomicU64) -> io::Result<()> {
    // `#n` and `&n` stay until changed, on this connection only (SRM p.270).
    let mut addressing = Addressing::default();
    let mut reply = HostReply::default();
    let ended = serve_requests(stream, shared, last_active_ms, &mut reply, &mut addressing);
    // The host has gone: the commands of its line not yet run go with it, as with a flush.
    // MODEL: a card has read the whole line and would run it; running a line of ranges whose
    // answers nobody fetches kept a thread per departed connection busy (behind the requests
    // of the hosts still there), and those threads outgrew the connection table (1,163 for 128
    // connections in a 30 s soak). Only commands past the first packet of answers are affected: a line whose
    // answers fit a packet has run whole when its first packet went.
    reply.flush();
    ended
}

fn serve_requests(
    stream: TcpStream,
    shared: &Shared,
    last_active_ms: &AtomicU64,
    reply: &mut HostReply,
    addressing: &mut Addressing,
) -> io::Result<()> {
    stream.set_nodelay(true)?;
    stream.set_write_timeout(Some(WRITE_TIMEOUT))?;
    stream.set_read_timeout(shared.options.idle_timeout)?;
    let mut reader = BufReader::new(stream.try_clone()?);
    // A look at the socket for the rest of an abandoned line, which stops when the host left.
    let probe = stream.try_clone()?;
    let gone = move || host_gone(&probe);
    let mut writer = stream;
    let mut header = [0u8; HEADER_BYTES];
    let mut data = Vec::new();
    let mut last_error: Option<Instant> = None;
    // The card, caught up with its clock, for one command at a time.
    let card = |turn| match turn {
        Turn::Request => Some(shared.card_request()),
        Turn::Leftover => shared.card_leftover(&gone),
    };
    // Error replies are held to one per ERROR_REPLY_INTERVAL, with the card's lock released.
    let mut slow_errors = |ended: Option<Progress>| {
        if ended == Some(Progress::Failed) {
            if let Some(wait) = last_error.and_then(|t| ERROR_REPLY_INTERVAL.checked_sub(t.elapsed())) {
                shared.stats.errors_slowed.fetch_add(1, Ordering::Relaxed);
                thread::sleep(wait);
            }
            last_error = Some(Instant::now());
        }
    };
    loop {
        if !read_or_end(&mut reader, &mut header)? {
            return Ok(());
        }
        last_active_ms.store(shared.now_ms(), Ordering::Relaxed);
        let request = Header::parse(&header).request().map_err(|e| {
            shared.stats.refused_requests.fetch_add(1, Ordering::Relaxed);
            io::Error::new(io::ErrorKind::InvalidData, e)
        })?;
        let answer: Option<Vec<u8>> = match request {
            Request::Line { data_bytes, reply: now } => {
                data.resize(data_bytes, 0);
                if !read_or_end(&mut reader, &mut data)? && data_bytes > 0 {
                    return Err(io::Error::new(io::ErrorKind::UnexpectedEof, "the client left mid-request"));
                }
                reply.start(trim_line(&data), &card, addressing, &gone);
                let ended = reply.fill(&card, addressing);
                slow_errors(ended);
                match ended {
                    Some(Progress::Silent) => None,
                    _ if now => Some(reply.next_packet()),
                    // SENDLINE: one byte now, the answer on GETLINE.
                    _ => Some(vec![0x40]),
                }
            }
            Request::NextPacket => {
                if shared.card_request().tripped() {
                    None
                } else {
                    let ended = reply.fill(&card, addressing);
                    slow_errors(ended);
                    match ended {
                        Some(Progress::Silent) => None,
                        // Nothing waiting: NUL, which hosts read as "no data" (facts s.3).
                        _ if !reply.has_waiting() => Some(vec![0]),
                        _ => Some(reply.next_packet()),
                    }
                }
            }
            // UMAC Turbo CPU/Communications Board Hardware Manual p.36 (Ethernet Protocol,
            // VR_PMAC_READREADY): "Two bytes are returned. The first byte if non-zero
            // indicates there is data to be read"; the EPICS pmac driver tests `data[0]`.
            Request::ReadReady => {
                if shared.card_request().tripped() {
                    None
                } else {
                    let ended = reply.fill(&card, addressing);
                    slow_errors(ended);
                    (ended != Some(Progress::Silent)).then(|| vec![u8::from(reply.has_waiting()), 0])
                }
            }
            Request::Flush => {
                reply.flush();
                // The flush is acknowledged with one byte. MODEL: the manual's text says
                // CTRL-X; DLS's EPICS driver (pmacAsynIPPort.c, pmacFlush) records that real
                // cards send 0x40 (VR_DOWNLOAD) and reads any byte; the emulator sends what the
                // cards send.
                (!shared.card_request().tripped()).then(|| vec![FLUSH_ACK])
            }
            Request::Control(c) => shared.card_request().control_character(c),
        };
        // A tripped card says nothing: the host's read times out (UM p.215).
        if let Some(bytes) = answer {
            writer.write_all(&bytes)?;
        }
    }
}

/// Whether the host has closed its side or the connection was shut down (evicted): a look at
/// the socket that neither waits nor takes a byte. POLLRDHUP says the host closed even when
/// requests it sent before closing are still unread (a look at the bytes would see those and
/// not the close).
fn host_gone(stream: &TcpStream) -> bool {
    #[cfg(target_os = "linux")]
    {
        use std::os::fd::AsRawFd;
        let mut poll = libc::pollfd { fd: stream.as_raw_fd(), events: libc::POLLRDHUP, revents: 0 };
        // SAFETY: one pollfd of ours, no wait.
        let n = unsafe { libc::poll(&raw mut poll, 1, 0) };
        n > 0 && poll.revents & (libc::POLLRDHUP | libc::POLLHUP | libc::POLLERR | libc::POLLNVAL) != 0
    }
    #[cfg(not(target_os = "linux"))]
    {
        let _ = stream;
        false
    }
}

fn accept_control(listener: TcpListener, shared: Arc<Shared>) {
    for stream in listener.incoming() {
        if shared.stopping.load(Ordering::SeqCst) {
            return;
        }
        let Some(stream) = accepted(stream, &shared.accept_errors) else { continue };
        if let Err(e) = room_for_a_thread(shared.options.thread_stack_bytes) {
            shared.stats.spawn_failures.fetch_add(1, Ordering::Relaxed);
            shared.spawn_failures.report(&format!("a control connection: cannot start its thread: {e}"));
            continue;
        }
        let (id, last_active_ms, evicted) = match shared.controls.admit(&stream) {
            Ok(admitted) => admitted,
            Err(e) => {
                shared.accept_errors.report(&format!("cannot keep a control connection: {e}"));
                continue;
            }
        };
        if let Some(old) = evicted {
            shared.stats.control_evicted.fetch_add(1, Ordering::Relaxed);
            shared.log(&format!("{CONTROL_CLIENTS_MAX} control connections open: closed c{old}, idle longest"));
        }
        let s = shared.clone();
        let started = spawn(format!("serve: control c{id}"), shared.options.thread_stack_bytes, move || {
            if let Err(e) = control_session(stream, &s, &last_active_ms) {
                s.log(&format!("control connection c{id}: {e}"));
            }
            s.controls.forget(id);
        });
        if let Err(e) = started {
            // As for hosts: close the table's handle, the last one, and keep accepting.
            shared.stats.spawn_failures.fetch_add(1, Ordering::Relaxed);
            shared.controls.close(id);
            shared.spawn_failures.report(&format!("control connection c{id}: cannot start its thread: {e}"));
        }
    }
}

fn control_session(stream: TcpStream, shared: &Shared, last_active_ms: &AtomicU64) -> io::Result<()> {
    stream.set_write_timeout(Some(WRITE_TIMEOUT))?;
    stream.set_read_timeout(shared.options.control_idle_timeout)?;
    let mut writer = stream.try_clone()?;
    let mut reader = BufReader::new(stream);
    let mut line = Vec::new();
    loop {
        match read_line_max(&mut reader, &mut line, CONTROL_LINE_BYTES_MAX) {
            Ok(true) => {}
            Ok(false) => return Ok(()),
            Err(e) if e.kind() == io::ErrorKind::InvalidData => {
                writeln!(writer, "error: {e}")?;
                return Ok(());
            }
            Err(e) => return Err(e),
        }
        last_active_ms.store(shared.now_ms(), Ordering::Relaxed);
        let text = String::from_utf8_lossy(&line);
        let text = text.trim();
        if text.is_empty() {
            continue;
        }
        let reply = match Control::parse(text) {
            Ok(Control::Step { cycles }) => step_in_chunks(shared, cycles, last_active_ms),
            Ok(Control::Servo { cycles }) => servo_in_steps(shared, cycles),
            Ok(c) => shared.card_now().control(c),
            Err(e) => format!("error: {e}"),
        };
        writeln!(writer, "{reply}")?;
    }
}

/// `servo N` applied at most [`STEP_CYCLES_MAX`] cycles at a time, so that the card's own
/// capture (`serve --record`) writes each part as a `servo` step a trace reader takes: one
/// `servo 4294967295` was written as one step, which the capture's own `replay` refused (exit
/// 2). A servo run with no background is the core's closed form, so each part is one short
/// lock hold. `servo 0` runs nothing and writes nothing (a reader refuses a step of 0 cycles).
/// The reply is the whole step's, as if it had run at once.
fn servo_in_steps(shared: &Shared, cycles: u32) -> String {
    let whole = || {
        let step = Step { event: TraceEvent::Model(Event::Servo { cycles }), expect: Expect::default(), note: None };
        format!("ok {}", step_line(&step))
    };
    if cycles == 0 {
        // As `step 0`: refused on the wall clock, nothing to run otherwise.
        let reply = shared.card_now().control(Control::Step { cycles: 0 });
        return if reply.starts_with("ok") { whole() } else { reply };
    }
    let mut done = 0u32;
    while done < cycles {
        let n = (cycles - done).min(STEP_CYCLES_MAX);
        let reply = shared.card_now().control(Control::Servo { cycles: n });
        if !reply.starts_with("ok") || n == cycles {
            return reply;
        }
        done += n;
    }
    whole()
}

/// `step N` run [`CYCLES_PER_HOLD_MAX`] cycles per lock hold (fewer while user PLCs run,
/// [`Card::cycles_per_hold`]), so that hosts keep getting
/// answers during a long step (`step 1000000000` is about 4 s of servo cycles). A host that
/// asks meanwhile sees the card part-way through the step, as a host of a running card
/// would; the emulator's own capture records the exchange between the cycles before and
/// after it. The reply is the step's, as if it had run at once.
fn step_in_chunks(shared: &Shared, cycles: u32, last_active_ms: &AtomicU64) -> String {
    let mut done = 0u32;
    loop {
        let mut card = shared.card_now();
        let n = (cycles - done).min(card.cycles_per_hold());
        let reply = card.control(Control::Step { cycles: n });
        drop(card);
        if !reply.starts_with("ok") {
            return reply;
        }
        done += n;
        if done == cycles {
            return Card::step_reply(cycles);
        }
        if shared.stopping.load(Ordering::SeqCst) {
            return format!("error: the emulator is stopping: {done} of the {cycles} servo cycles ran");
        }
        // A connection stepping is busy, not idle: it is not the one to close for a newcomer.
        last_active_ms.store(shared.now_ms(), Ordering::Relaxed);
        thread::yield_now();
    }
}
