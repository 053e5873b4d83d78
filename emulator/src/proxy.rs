//! `pmacwd record`: a transparent proxy between host programs and a card (real or emulated)
//! that writes every command line and its reply, with timing, as a capture.
//!
//! Bytes are forwarded unchanged in both directions; the proxy only reads along. Per host
//! session, one thread carries requests to the card and one carries replies back.
//!
//! Replies are paired with requests by order, not by time: the card answers the requests of a
//! connection in the order it received them, so each request joins the session's queue before
//! it is forwarded and reply bytes belong to the oldest request waiting. A reply ends with its
//! ACK, or with the CR after an error's number; a reply whose end the framing does not show
//! (a bare BEL under I6 = 0 or 2, I3 = 0 or 1) ends when the host sends its next request. A
//! request that gets no reply byte for `silence` is a silence (a tripped card, UM p.215), even
//! when the host gave up on it sooner. Each reply is handed to the capture (its queue) before
//! its bytes go on to the host, so a fast host cannot overtake its own exchange.
//!
//! Control commands (`--control-listen`) reach the card only after every host request
//! forwarded before them has its reply or its silence recorded, so an INIT/ sent after a silent
//! command is recorded after that silence, in the order the card saw them.
//!
//! Time is the proxy's clock times the servo rate, or, with `--virtual-time`, the `step`
//! commands seen on the proxied control interface of a `pmacwd serve --virtual-time`.
//! Concurrent sessions share one timeline, in the order their exchanges complete.
//!
//! The capture is written by a thread of its own through the bounded queue of
//! [`crate::capture_queue`], as `serve --record`'s: a sink that stops taking bytes (a FIFO
//! nobody reads, a full disk) never holds a session; past the queue's bound recording stops,
//! and the capture ends with a note saying why.

use crate::bounded::{accepted, room_for_a_thread, spawn, CountedLog, Table};
use crate::capture::{CaptureWriter, Timing};
use crate::capture_queue::{CaptureQueue, Record, FINISH_WAIT};
use crate::control::{read_line_max, CONTROL_LINE_BYTES_MAX};
use crate::framing::{ACK, BEL, CR};
use crate::listen::bind;
use crate::protocol::{read_or_end, trim_line, Header, Request, HEADER_BYTES, VR_PMAC_GETBUFFER};
use crate::server::CONTROL_CLIENTS_MAX;
use pmacwd_specs::grammar::Addressing;
use pmacwd_specs::vocab::event::Event;
use pmacwd_trace::{Expect, Step, TraceEvent, STEP_CYCLES_MAX};
use std::collections::{BTreeMap, BTreeSet, VecDeque};
use std::io::{self, BufReader, Read, Write};
use std::net::{Shutdown, SocketAddr, TcpListener, TcpStream};
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::{Arc, Condvar, Mutex, MutexGuard};
use std::thread;
use std::time::{Duration, Instant};

/// Host sessions open at once (as `pmacwd serve --clients-max`'s default): a newcomer when
/// this many are open closes the one idle longest, so the proxy's threads and sockets stay
/// bounded (two threads a session; 2,000 idle sessions held 4,000 threads before) and sessions
/// gone silent never lock a new one out. Control sessions: `CONTROL_CLIENTS_MAX`, the same way.
pub const SESSIONS_MAX: usize = 128;

/// What the requests of one host session forwarded to the card and still waiting for their
/// replies may hold, in bytes: [`AWAITING_BYTES`] for each and its command line. A host that
/// does not wait, in front of a silent card (tripped, UM p.215), had every request kept, each
/// resolved only after `silence`: memory grew without bound (550 MB in 10 s). With this much
/// waiting, the host's next request is read only when the queue has drained to half (a host
/// that pipelines thousands of polls to a card that answers goes at the card's pace); when the
/// oldest has had no reply byte for half the silence, the session is closed instead, with a
/// note in the capture, the ones waiting recorded as silent. 4,003 `???` requests, or about
/// 320 of the longest lines (1,492 bytes); 128 sessions hold at most 64 MiB.
pub const WAITING_BYTES_MAX: usize = 512 * 1024;

/// What one waiting request is counted for besides its line: its entry in the queue (about
/// 100 bytes) and its place in the proxy's order, rounded up.
pub const AWAITING_BYTES: usize = 128;

/// A reply line from the proxied control interface is at most this long, its newline
/// included; a longer one ends that control session with an error line. The emulator's
/// longest reply (`help`) is about 400 bytes and a step's JSON a few hundred: ten times that
/// leaves room while a target that never ends its line costs at most 4 KiB.
pub const CONTROL_REPLY_BYTES_MAX: usize = 4096;

/// The bytes of one reply kept for the capture; the rest are forwarded and counted, not
/// kept. The emulator's longest reply is 4,850 bytes (a full line of `???`); a real card's
/// listing of a program can be longer, and a reply the model cannot match is only a note.
/// 256 KiB keeps every reply a capture can compare while a card that never ends its reply
/// costs a session at most that.
pub const REPLY_RECORDED_BYTES_MAX: usize = 256 * 1024;

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
    /// The stack of each session's threads (`None`: the platform's default). A size the
    /// system cannot give makes every session's thread fail to start, which is how the tests
    /// reach that path.
    pub thread_stack_bytes: Option<usize>,
}

/// The shared timeline and the capture: records go to the capture's writer thread without
/// waiting for its sink (`capture_queue`).
pub struct Recorder {
    capture: CaptureQueue,
    start: Instant,
    servo_hz: u32,
    virtual_time: bool,
    cycles_written: u64,
    pub exchanges: u64,
    /// Requests forwarded but not recorded since the last exchange, by request code: written
    /// as one note with the next exchange (or at the end), not one note each (a million
    /// READREADY polls were 118 MB of notes before).
    not_recorded: BTreeMap<u8, u64>,
}

impl Recorder {
    /// Starts the capture's writer thread; an error when the system will not start it.
    pub fn new(
        capture: CaptureWriter<Box<dyn Write + Send>>,
        servo_hz: u32,
        virtual_time: bool,
    ) -> io::Result<Recorder> {
        Ok(Recorder {
            capture: CaptureQueue::start(capture, "pmacwd record")?,
            start: Instant::now(),
            servo_hz,
            virtual_time,
            cycles_written: 0,
            exchanges: 0,
            not_recorded: BTreeMap::new(),
        })
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

    fn exchange(&mut self, at: Instant, line: &str, reply: Option<&[u8]>) {
        self.advance_to(at);
        self.note_not_recorded();
        let record = Record::Line {
            line: line.to_string(),
            addressing: Addressing::default(),
            reply: reply.map(<[u8]>::to_vec),
        };
        if self.capture.send(record) {
            self.exchanges += 1;
        }
    }

    /// An event of the card (a control reply). A `servo` step longer than a trace reader takes
    /// ([`STEP_CYCLES_MAX`]: an emulator answers `servo N` with the whole step) is written as
    /// several, the expectations and note on the last; `servo 0` ran nothing and is a note,
    /// since a reader refuses a step of no cycles. Before, such a capture's own `replay`
    /// refused it (exit 2).
    fn event(&mut self, at: Instant, step: Step) {
        self.advance_to(at);
        self.note_not_recorded();
        let TraceEvent::Model(Event::Servo { cycles }) = step.event else {
            self.capture.send(Record::Event(step));
            return;
        };
        if cycles == 0 {
            self.capture_note("control `servo 0`: no servo cycle ran".into());
            return;
        }
        let mut left = cycles;
        while left > STEP_CYCLES_MAX {
            let part = Step {
                event: TraceEvent::Model(Event::Servo { cycles: STEP_CYCLES_MAX }),
                expect: Expect::default(),
                note: None,
            };
            self.capture.send(Record::Event(part));
            left -= STEP_CYCLES_MAX;
        }
        self.capture.send(Record::Event(Step { event: TraceEvent::Model(Event::Servo { cycles: left }), ..step }));
    }

    /// A request forwarded to the card that the capture does not record (READREADY, FLUSH,
    /// SENDLINE, ...): counted by its code.
    fn count_not_recorded(&mut self, code: u8) {
        let n = self.not_recorded.entry(code).or_insert(0);
        *n = n.saturating_add(1);
    }

    /// The requests counted since the last exchange, as one note for the next step.
    fn note_not_recorded(&mut self) {
        if self.not_recorded.is_empty() {
            return;
        }
        let counts: Vec<String> =
            std::mem::take(&mut self.not_recorded).into_iter().map(|(code, n)| format!("0x{code:02X} x {n}")).collect();
        self.capture_note(format!("requests forwarded, not recorded (code x count): {}", counts.join(", ")));
    }

    fn capture_note(&mut self, note: String) {
        self.capture.send(Record::Note(note));
    }

    /// Ends the capture, waiting at most [`FINISH_WAIT`] for its sink to take what is queued:
    /// (exchanges, steps written, notes that found no step, a failed or stalled sink's among
    /// them).
    pub fn finish(mut self) -> (u64, u64, Vec<String>) {
        self.note_not_recorded();
        let (steps, notes) = self.capture.finish(FINISH_WAIT);
        (self.exchanges, steps, notes)
    }
}

struct Shared {
    recorder: Mutex<Option<Recorder>>,
    options: RecordOptions,
    sessions_ended: AtomicU64,
    stopping: AtomicBool,
    order: Order,
    /// Sessions the system would not start a thread for.
    spawn_failures: CountedLog,
    /// Sessions whose card (or control interface) could not be reached.
    unreachable: CountedLog,
    /// Accepts that failed (no file descriptor left, mostly).
    accept_errors: CountedLog,
    /// Open host sessions, at most [`SESSIONS_MAX`], and control sessions.
    hosts: Table,
    controls: Table,
    started: Instant,
}

impl Shared {
    fn recorder(&self) -> MutexGuard<'_, Option<Recorder>> {
        self.recorder.lock().unwrap_or_else(|e| e.into_inner())
    }
    /// Hands records to the capture's writer; never waits for its sink.
    fn record(&self, f: impl FnOnce(&mut Recorder)) {
        if let Some(rec) = self.recorder().as_mut() {
            f(rec);
        }
    }
    /// Milliseconds since the start, plus one: 0 is a connection's `NEVER_SPOKE`.
    fn now_ms(&self) -> u64 {
        u64::try_from(self.started.elapsed().as_millis()).unwrap_or(u64::MAX).saturating_add(1)
    }
    fn log(&self, msg: &str) {
        if self.options.verbose {
            crate::bounded::to_stderr(format_args!("pmacwd record: {msg}"));
        }
    }
}

/// What a request forwarded to the card is waiting for.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum ReplyEnd {
    /// A command line's reply: it ends with the ACK, or with the CR after an error's number.
    Line,
    /// As `Line`, or a lone NUL: a GETBUFFER or GETLINE with nothing waiting.
    LineOrNul,
    /// A fixed number of bytes (READREADY: 2, FLUSH and SENDLINE: 1).
    Bytes(usize),
}

/// A request forwarded to the card whose reply has not ended yet.
struct Awaiting {
    /// Its place in the proxy's order of requests (all sessions): the control interface waits
    /// for every request forwarded before it.
    id: u64,
    sent: Instant,
    /// The command line, for a VR_PMAC_GETRESPONSE; other requests are forwarded, not recorded.
    line: Option<String>,
    end: ReplyEnd,
    /// The reply's first [`REPLY_RECORDED_BYTES_MAX`] bytes.
    bytes: Vec<u8>,
    /// The reply's bytes beyond those kept.
    bytes_dropped: u64,
    /// The reply's last byte, kept or not (an error ends at a CR after a digit).
    last_byte: Option<u8>,
    /// Inside an error message (after its BEL), for [`ReplyEnd::Line`].
    in_error: bool,
}

impl Awaiting {
    /// Takes reply bytes from the front of `new` up to the end of this reply; returns how many
    /// it took and whether the reply is complete.
    fn take(&mut self, new: &[u8]) -> (usize, bool) {
        match self.end {
            ReplyEnd::Bytes(n) => {
                let take = n.saturating_sub(self.bytes.len()).min(new.len());
                self.bytes.extend_from_slice(&new[..take]);
                (take, self.bytes.len() >= n)
            }
            ReplyEnd::LineOrNul if self.bytes.is_empty() && new.first() == Some(&0) => {
                self.bytes.push(0);
                (1, true)
            }
            ReplyEnd::Line | ReplyEnd::LineOrNul => {
                for (i, &b) in new.iter().enumerate() {
                    // An error is `BEL ERRnnn CR` or `BEL CR ERRnnn CR` (I6 = 1, 3): it ends
                    // at the CR after its number. A bare BEL (I6 = 0, 2) ends only by what
                    // comes next: the host's next request or the silence.
                    let ends = match b {
                        ACK => true,
                        BEL => {
                            self.in_error = true;
                            false
                        }
                        CR => self.in_error && self.last_byte.is_some_and(|l| l.is_ascii_digit()),
                        _ => false,
                    };
                    self.keep(b);
                    if ends {
                        return (i + 1, true);
                    }
                }
                (new.len(), false)
            }
        }
    }

    /// One byte of a line's reply: kept up to [`REPLY_RECORDED_BYTES_MAX`], counted beyond.
    fn keep(&mut self, b: u8) {
        if self.bytes.len() < REPLY_RECORDED_BYTES_MAX {
            self.bytes.push(b);
        } else {
            self.bytes_dropped = self.bytes_dropped.saturating_add(1);
        }
        self.last_byte = Some(b);
    }

    /// Whether any reply byte came.
    fn answered(&self) -> bool {
        self.last_byte.is_some() || !self.bytes.is_empty()
    }
}

/// The requests of one host session in the order the card receives them. The card answers
/// them in that order, so reply bytes belong to the oldest request waiting; a reply is
/// recorded before its bytes are forwarded to the host, so the host's next request cannot
/// overtake it.
struct Session {
    waiting: VecDeque<Awaiting>,
    /// When the oldest request began to wait for its reply (or its last byte came).
    clock_from: Instant,
    /// Reply bytes that came when no request was waiting.
    unsolicited_bytes: u64,
    /// The requests' thread waits for the queue to drain (see [`WAITING_BYTES_MAX`]).
    host_waits: bool,
    /// What the waiting requests are counted for ([`AWAITING_BYTES`] and the line of each).
    waiting_bytes: usize,
}

impl Session {
    fn new() -> Session {
        Session {
            waiting: VecDeque::new(),
            clock_from: Instant::now(),
            unsolicited_bytes: 0,
            host_waits: false,
            waiting_bytes: 0,
        }
    }

    fn push(&mut self, shared: &Shared, line: Option<String>, end: ReplyEnd) {
        let now = Instant::now();
        if self.waiting.is_empty() {
            self.clock_from = now;
        }
        let id = shared.order.forwarded();
        self.waiting_bytes += AWAITING_BYTES + line.as_ref().map_or(0, String::len);
        self.waiting.push_back(Awaiting {
            id,
            sent: now,
            line,
            end,
            bytes: Vec::new(),
            bytes_dropped: 0,
            last_byte: None,
            in_error: false,
        });
    }

    /// A new request came while the oldest has part of a reply whose end the proxy cannot
    /// see (a bare BEL, or I3 = 0 or 1 framing): the host has read what it wanted and moved
    /// on, so that reply ends here. A request with no reply byte yet keeps waiting: the card
    /// answers in order, or the silence closes it.
    fn host_moved_on(&mut self, shared: &Shared) {
        if self.waiting.front().is_some_and(Awaiting::answered) {
            self.resolve_front(shared);
        }
    }

    /// Takes reply bytes from the card: each completed reply is recorded, in order.
    fn reply_bytes(&mut self, shared: &Shared, mut new: &[u8]) {
        let now = Instant::now();
        while !new.is_empty() {
            let Some(front) = self.waiting.front_mut() else {
                self.unsolicited_bytes += new.len() as u64;
                return;
            };
            let (taken, complete) = front.take(new);
            new = &new[taken..];
            self.clock_from = now;
            if complete {
                self.resolve_front(shared);
            }
        }
    }

    /// Closes the oldest request as silent when no reply byte came for `silence`.
    fn check_silence(&mut self, shared: &Shared, silence: Duration) {
        while !self.waiting.is_empty() && self.clock_from.elapsed() >= silence {
            self.resolve_front(shared);
        }
    }

    fn resolve_front(&mut self, shared: &Shared) {
        let Some(a) = self.waiting.pop_front() else { return };
        self.waiting_bytes = self.waiting_bytes.saturating_sub(AWAITING_BYTES + a.line.as_ref().map_or(0, String::len));
        if let Some(line) = &a.line {
            let reply = a.answered().then_some(a.bytes.as_slice());
            let dropped = a.bytes_dropped;
            shared.record(|r| {
                if dropped > 0 {
                    r.capture_note(format!(
                        "the reply to `{line}` had {dropped} more bytes than the {REPLY_RECORDED_BYTES_MAX} kept: forwarded, not recorded"
                    ));
                }
                r.exchange(a.sent, line, reply)
            });
        }
        // The next request's wait for its reply counts from here.
        self.clock_from = Instant::now();
        shared.order.resolved(a.id);
    }

    /// The end of the session: what still waits is recorded as it stands.
    fn finish(&mut self, shared: &Shared) {
        while !self.waiting.is_empty() {
            self.resolve_front(shared);
        }
        if self.unsolicited_bytes > 0 {
            let n = self.unsolicited_bytes;
            shared.record(|r| {
                r.capture_note(format!("{n} reply bytes came with no request waiting: forwarded, not recorded"));
            });
            self.unsolicited_bytes = 0;
        }
    }
}

/// The order of requests over all sessions, so that a control command reaches the card only
/// after every request forwarded before it has its reply or its silence recorded: the capture
/// then has the events in the order the card saw them (an INIT/ after a silent command comes
/// after that silence).
struct Order {
    next: AtomicU64,
    waiting: Mutex<BTreeSet<u64>>,
    resolved: Condvar,
}

impl Order {
    fn new() -> Order {
        Order { next: AtomicU64::new(0), waiting: Mutex::new(BTreeSet::new()), resolved: Condvar::new() }
    }

    fn lock(&self) -> MutexGuard<'_, BTreeSet<u64>> {
        self.waiting.lock().unwrap_or_else(|e| e.into_inner())
    }

    fn forwarded(&self) -> u64 {
        let id = self.next.fetch_add(1, Ordering::SeqCst);
        self.lock().insert(id);
        id
    }

    fn resolved(&self, id: u64) {
        self.lock().remove(&id);
        self.resolved.notify_all();
    }

    /// Waits until every request forwarded so far is resolved, or `limit` passes (a session
    /// whose replies stopped being read); `false` then.
    fn wait_for_earlier(&self, limit: Duration) -> bool {
        let before = self.next.load(Ordering::SeqCst);
        let deadline = Instant::now() + limit;
        let mut waiting = self.lock();
        while waiting.first().is_some_and(|&id| id < before) {
            let left = deadline.saturating_duration_since(Instant::now());
            if left.is_zero() {
                return false;
            }
            waiting = self.resolved.wait_timeout(waiting, left).unwrap_or_else(|e| e.into_inner()).0;
        }
        true
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
        let listener = bind("host port", options.listen)?;
        let local_addr = listener.local_addr()?;
        let control = match &options.control {
            Some((listen, _)) => Some(bind("control port", *listen)?),
            None => None,
        };
        let control_addr = control.as_ref().map(|l| l.local_addr()).transpose()?;
        let verbose = options.verbose;
        let shared = Arc::new(Shared {
            recorder: Mutex::new(Some(recorder)),
            options,
            sessions_ended: AtomicU64::new(0),
            stopping: AtomicBool::new(false),
            order: Order::new(),
            spawn_failures: CountedLog::new("pmacwd record", "sessions closed for want of a thread", verbose),
            unreachable: CountedLog::new("pmacwd record", "sessions closed: the card could not be reached", verbose),
            accept_errors: CountedLog::new("pmacwd record", "failed accepts", verbose),
            hosts: Table::new(SESSIONS_MAX),
            controls: Table::new(CONTROL_CLIENTS_MAX),
            started: Instant::now(),
        });
        let mut accept = Vec::new();
        let s = shared.clone();
        accept.push(spawn("record: accept hosts".into(), None, move || accept_hosts(listener, local_addr, s))?);
        let s = shared.clone();
        // A thread that cannot start stops the ones already running (the accept loop wakes on a
        // connection and sees the flag).
        let abandon = |e: io::Error| {
            shared.stopping.store(true, Ordering::SeqCst);
            let _ = TcpStream::connect(local_addr);
            Err(e)
        };
        if let Err(e) = spawn("record: summaries".into(), None, move || summaries(&s)) {
            return abandon(e);
        }
        if let Some(l) = control {
            let s = shared.clone();
            match spawn("record: accept control".into(), None, move || accept_control(l, s)) {
                Ok(t) => accept.push(t),
                // No proxy without the control interface it was asked for.
                Err(e) => return abandon(e),
            }
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

    /// Whether `--sessions` host sessions have ended (never without it): then [`Proxy::stop`]
    /// closes the capture as [`Proxy::wait`] would.
    pub fn sessions_ended(&self) -> bool {
        self.accept.first().is_none_or(|t| t.is_finished())
    }

    /// Stops now, and closes the capture as the end of the sessions does (`pmacwd record` on
    /// SIGINT or SIGTERM): (exchanges, steps, notes left over).
    pub fn stop(self) -> io::Result<(u64, u64, Vec<String>)> {
        self.close()
    }

    fn close(self) -> io::Result<(u64, u64, Vec<String>)> {
        self.shared.stopping.store(true, Ordering::SeqCst);
        self.shared.spawn_failures.flush();
        self.shared.unreachable.flush();
        self.shared.accept_errors.flush();
        if let Some(a) = self.control_addr {
            let _ = TcpStream::connect(a);
        }
        let recorder = self.shared.recorder().take();
        Ok(recorder.map_or_else(|| (0, 0, Vec::new()), Recorder::finish))
    }
}

/// How often the proxy looks whether a summary of its logs is due: a summary comes at most
/// every [`crate::bounded::SUMMARY_INTERVAL`], so a second's delay on it is nothing.
const SUMMARY_CHECK_INTERVAL: Duration = Duration::from_secs(1);

/// Until the proxy stops: prints the summaries of the logs that are due.
fn summaries(shared: &Shared) {
    while !shared.stopping.load(Ordering::SeqCst) {
        thread::sleep(SUMMARY_CHECK_INTERVAL);
        for log in [&shared.spawn_failures, &shared.unreachable, &shared.accept_errors] {
            log.flush_due();
        }
    }
}

fn accept_hosts(listener: TcpListener, own: SocketAddr, shared: Arc<Shared>) {
    for client in listener.incoming() {
        if shared.stopping.load(Ordering::SeqCst) {
            return;
        }
        let Some(client) = accepted(client, &shared.accept_errors) else { continue };
        if let Err(e) = room_for_a_thread(shared.options.thread_stack_bytes) {
            // Before the table or the threads allocate anything for it: closed, counted.
            shared.spawn_failures.report(&format!("a session: cannot start its threads: {e}"));
            continue;
        }
        let (id, last_active_ms, evicted) = match shared.hosts.admit(&client) {
            Ok(admitted) => admitted,
            Err(e) => {
                shared.accept_errors.report(&format!("cannot keep a host connection: {e}"));
                continue;
            }
        };
        if let Some(old) = evicted {
            shared.log(&format!("{SESSIONS_MAX} sessions open: closed session {old}, idle longest"));
        }
        let s = shared.clone();
        // The card is reached from the session's own thread: a card slow to answer the
        // connection holds up that session only, never the accepting of others.
        let started = spawn(format!("record: session {id}"), shared.options.thread_stack_bytes, move || {
            let card = match TcpStream::connect(&s.options.target) {
                Ok(c) => c,
                Err(e) => {
                    s.unreachable.report(&format!("session {id}: cannot reach the card at {}: {e}", s.options.target));
                    s.hosts.forget(id);
                    return;
                }
            };
            s.log(&format!("session {id} opened"));
            host_session(client, card, &s, id, &last_active_ms);
            s.hosts.forget(id);
            s.log(&format!("session {id} ended"));
            let ended = s.sessions_ended.fetch_add(1, Ordering::SeqCst) + 1;
            if s.options.sessions.is_some_and(|n| ended >= n) {
                s.stopping.store(true, Ordering::SeqCst);
                // Wake the accept loop so that it sees the flag.
                let _ = TcpStream::connect(own);
            }
        });
        if let Err(e) = started {
            // The closure and its socket are gone; the table's handle is the last: close it.
            shared.hosts.close(id);
            shared.spawn_failures.report(&format!("session {id}: cannot start its thread: {e}"));
        }
    }
}

fn host_session(client: TcpStream, card: TcpStream, shared: &Arc<Shared>, id: u64, last_active_ms: &AtomicU64) {
    let session = Arc::new(Mutex::new(Session::new()));
    let (Ok(client_w), Ok(card_r), Ok(card_w)) = (client.try_clone(), card.try_clone(), card.try_clone()) else {
        return;
    };
    let _ = client.set_nodelay(true);
    let _ = card.set_nodelay(true);
    // Signalled by the replies when the queue is down to half (see WAITING_BYTES_MAX).
    let room = Arc::new(Condvar::new());
    let replies = {
        let shared = shared.clone();
        let session = session.clone();
        let room = room.clone();
        spawn(format!("record: replies {id}"), shared.options.thread_stack_bytes, move || {
            replies_to_host(card_r, client_w, &shared, &session, &room)
        })
    };
    let replies = match replies {
        Ok(r) => r,
        Err(e) => {
            // Without a thread for the replies the session cannot be proxied: close both ends.
            let _ = client.shutdown(Shutdown::Both);
            let _ = card.shutdown(Shutdown::Both);
            shared.spawn_failures.report(&format!("session {id}: cannot start its reply thread: {e}"));
            return;
        }
    };
    requests_to_card(client, card_w, shared, &session, &room, last_active_ms);
    let _ = card.shutdown(Shutdown::Write);
    let _ = replies.join();
    lock(&session).finish(shared);
}

fn lock(session: &Mutex<Session>) -> MutexGuard<'_, Session> {
    session.lock().unwrap_or_else(|e| e.into_inner())
}

fn requests_to_card(
    client: TcpStream,
    mut card: TcpStream,
    shared: &Shared,
    session: &Mutex<Session>,
    room: &Condvar,
    last_active_ms: &AtomicU64,
) {
    let mut reader = BufReader::new(client);
    let mut header = [0u8; HEADER_BYTES];
    let mut data = Vec::new();
    loop {
        match read_or_end(&mut reader, &mut header) {
            Ok(true) => {}
            _ => return,
        }
        last_active_ms.store(shared.now_ms(), Ordering::Relaxed);
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
            // The request joins the session's queue before it is forwarded, so that its reply
            // always finds it there.
            let mut s = lock(session);
            // A full queue: a host that pipelines waits here (it is not read meanwhile) while
            // a card that answers drains it to half (one wake-up per half a queue, not one per
            // reply); a card silent on the oldest request for half the silence, with a host
            // that does not wait, closes the session instead.
            let full = s.waiting_bytes >= WAITING_BYTES_MAX;
            while full && s.waiting_bytes > WAITING_BYTES_MAX / 2 {
                let silent = s.waiting.front().is_some_and(|a| !a.answered())
                    && s.clock_from.elapsed() >= shared.options.silence / 2;
                if silent || shared.stopping.load(Ordering::SeqCst) {
                    // The note goes with the first of the waiting requests, which `finish`
                    // writes as silent.
                    let waited = (shared.options.silence / 2).as_millis();
                    let (n, bytes) = (s.waiting.len(), s.waiting_bytes);
                    shared.record(|r| {
                        r.capture_note(format!(
                            "{n} requests of a host session ({bytes} bytes, at most {WAITING_BYTES_MAX}) were \
                             waiting for their replies, the oldest \
                             {waited} ms without a reply byte (a silent card, a host that does not wait), when \
                             it sent another: session closed, the waiting ones recorded as silent"
                        ));
                    });
                    s.finish(shared);
                    shared.log(&format!("a session had {n} requests waiting for a silent card: closed"));
                    drop(s);
                    let _ = reader.get_ref().shutdown(Shutdown::Both);
                    let _ = card.shutdown(Shutdown::Both);
                    return;
                }
                s.host_waits = true;
                s = room.wait_timeout(s, Duration::from_millis(10)).unwrap_or_else(|e| e.into_inner()).0;
            }
            s.host_waits = false;
            let code = h.request;
            let not_recorded = |shared: &Shared| {
                shared.record(|r| {
                    r.count_not_recorded(code);
                })
            };
            match request {
                Ok(Request::Line { reply: true, .. }) => {
                    s.host_moved_on(shared);
                    let line = String::from_utf8_lossy(trim_line(&data)).into_owned();
                    s.push(shared, Some(line), ReplyEnd::Line);
                }
                Ok(Request::NextPacket) => {
                    // The next packet of a long reply still coming belongs to that reply.
                    let continues = s.waiting.back().is_some_and(|a| a.line.is_some() && a.answered());
                    if !continues {
                        s.host_moved_on(shared);
                        if code != VR_PMAC_GETBUFFER {
                            not_recorded(shared);
                        }
                        s.push(shared, None, ReplyEnd::LineOrNul);
                    }
                }
                Ok(
                    request @ (Request::Line { reply: false, .. }
                    | Request::ReadReady
                    | Request::Flush
                    | Request::Control(_)),
                ) => {
                    s.host_moved_on(shared);
                    not_recorded(shared);
                    let end = match request {
                        Request::ReadReady => ReplyEnd::Bytes(2),
                        Request::Control(_) => ReplyEnd::Line,
                        _ => ReplyEnd::Bytes(1),
                    };
                    s.push(shared, None, end);
                }
                Err(e) => {
                    // Not a request the proxy can follow: forward the rest as it comes.
                    s.finish(shared);
                    shared.record(|r| {
                        r.capture_note(format!("{e}: the rest of this session was forwarded, not recorded"));
                    });
                    drop(s);
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

fn replies_to_host(
    mut card: TcpStream,
    mut client: TcpStream,
    shared: &Shared,
    session: &Mutex<Session>,
    room: &Condvar,
) {
    // Wakes the requests' thread when it waits for the queue to drain to half.
    let drained = |s: &mut Session| {
        if s.host_waits && s.waiting_bytes <= WAITING_BYTES_MAX / 2 {
            s.host_waits = false;
            room.notify_one();
        }
    };
    let silence = shared.options.silence;
    let _ = card.set_read_timeout(Some(Duration::from_millis(20).min(silence)));
    let mut buf = [0u8; 4096];
    loop {
        match card.read(&mut buf) {
            Ok(0) => break,
            Ok(n) => {
                // Recorded first, then forwarded: the host cannot send its next request
                // before this reply is in the capture.
                {
                    let mut s = lock(session);
                    s.reply_bytes(shared, &buf[..n]);
                    drained(&mut s);
                }
                if client.write_all(&buf[..n]).is_err() {
                    break;
                }
            }
            Err(e) if matches!(e.kind(), io::ErrorKind::WouldBlock | io::ErrorKind::TimedOut) => {
                let mut s = lock(session);
                s.check_silence(shared, silence);
                drained(&mut s);
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
        let Some(client) = accepted(client, &shared.accept_errors) else { continue };
        if let Err(e) = room_for_a_thread(shared.options.thread_stack_bytes) {
            shared.spawn_failures.report(&format!("a control session: cannot start its thread: {e}"));
            continue;
        }
        let (id, last_active_ms, evicted) = match shared.controls.admit(&client) {
            Ok(admitted) => admitted,
            Err(e) => {
                shared.accept_errors.report(&format!("cannot keep a control connection: {e}"));
                continue;
            }
        };
        if let Some(old) = evicted {
            shared.log(&format!("{CONTROL_CLIENTS_MAX} control sessions open: closed c{old}, idle longest"));
        }
        let s = shared.clone();
        let target = target.clone();
        let started = spawn("record: control".into(), shared.options.thread_stack_bytes, move || {
            let card = match TcpStream::connect(&target) {
                Ok(c) => c,
                Err(e) => {
                    s.unreachable.report(&format!("cannot reach the control interface at {target}: {e}"));
                    s.controls.forget(id);
                    return;
                }
            };
            if let Err(e) = control_session(client, card, &s, &last_active_ms) {
                s.log(&format!("control session: {e}"));
            }
            s.controls.forget(id);
        });
        if let Err(e) = started {
            shared.controls.close(id);
            shared.spawn_failures.report(&format!("control session: cannot start its thread: {e}"));
        }
    }
}

/// Forwards control lines and their replies; an `ok {step}` reply is an event of the card.
fn control_session(client: TcpStream, card: TcpStream, shared: &Shared, last_active_ms: &AtomicU64) -> io::Result<()> {
    let mut to_client = client.try_clone()?;
    let mut to_card = card.try_clone()?;
    let mut from_client = BufReader::new(client);
    let mut from_card = BufReader::new(card);
    let (mut line, mut reply) = (Vec::new(), Vec::new());
    loop {
        match read_line_max(&mut from_client, &mut line, CONTROL_LINE_BYTES_MAX) {
            Ok(true) => last_active_ms.store(shared.now_ms(), Ordering::Relaxed),
            Ok(false) => return Ok(()),
            Err(e) if e.kind() == io::ErrorKind::InvalidData => {
                // As the emulator's own control port answers: an error line, then the end.
                writeln!(to_client, "error: {e}")?;
                return Ok(());
            }
            Err(e) => return Err(e),
        }
        let text = String::from_utf8_lossy(&line);
        // The card sees this command after every host request forwarded before it has been
        // answered or found silent, and the capture has them in that order.
        let limit = shared.options.silence.saturating_mul(4).max(Duration::from_secs(2));
        if !shared.order.wait_for_earlier(limit) {
            shared.record(|r| {
                r.capture_note(format!(
                    "control `{}` forwarded while host requests still waited for replies after {} ms: their order is uncertain",
                    text.trim_end(),
                    limit.as_millis()
                ));
            });
        }
        to_card.write_all(&line)?;
        match read_line_max(&mut from_card, &mut reply, CONTROL_REPLY_BYTES_MAX) {
            Ok(true) => {}
            Ok(false) => return Ok(()),
            Err(e) if e.kind() == io::ErrorKind::InvalidData => {
                writeln!(
                    to_client,
                    "error: the control interface at the target sent a reply over {CONTROL_REPLY_BYTES_MAX} bytes"
                )?;
                return Ok(());
            }
            Err(e) => return Err(e),
        }
        let at = Instant::now();
        // Recorded before the reply goes on, as host replies are: the client's next request
        // cannot reach the capture ahead of this event.
        let text = String::from_utf8_lossy(&reply);
        if let Some(json) = text.trim_end().strip_prefix("ok {").map(|rest| format!("{{{rest}")) {
            // `{"servo":N}` past what one trace step takes is the emulator's answer to a long
            // `servo N`; the step reader refuses it, so it is read here and split when written.
            let long_servo = serde_json::from_str::<serde_json::Value>(&json).ok().and_then(|v| {
                let m = v.as_object().filter(|m| m.len() == 1)?;
                let cycles = u32::try_from(m.get("servo")?.as_u64()?).ok()?;
                Some(Step { event: TraceEvent::Model(Event::Servo { cycles }), expect: Expect::default(), note: None })
            });
            match long_servo.map_or_else(|| serde_json::from_str::<Step>(&json), Ok) {
                Ok(step) => shared.record(|r| r.event(at, step)),
                Err(e) => shared.record(|r| {
                    r.capture_note(format!("control reply `{json}` not understood: {e}"));
                }),
            }
        }
        to_client.write_all(&reply)?;
    }
}
