//! What keeps a server's resources bounded whatever its clients do: threads started without
//! panicking, problems logged without letting a client fill standard error, and text cut to a
//! length before it is kept.
//!
//! `std::thread::spawn` panics when the system refuses a thread (too many threads, no memory
//! for a stack); in an accept loop that panic would end the loop and leave the listener open
//! but unanswered. [`spawn`] returns the error instead, so the caller can close that one
//! connection and keep accepting.
//!
//! A thread the system does start can still find no memory: under an address-space limit
//! (`ulimit -v`) its stack fit, and then its alternate signal stack or its first allocation did
//! not, and Rust aborts the whole process on either (SIGABRT: "memory allocation of 41 bytes
//! failed"). [`room_for_a_thread`] asks first for the stack and [`HEADROOM_BYTES`] besides,
//! and [`spawn`] refuses the thread when they are not there, so a server at the limit closes
//! the one connection that needed a thread and the ones already running keep their room.

use std::io;
use std::net::{Shutdown, TcpStream};
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Arc, Mutex, MutexGuard};
use std::thread::{Builder, JoinHandle};
use std::time::{Duration, Instant};

/// Address space kept free beyond a new thread's stack: what the thread needs next (its
/// alternate signal stack, 12 KiB; its buffers, a few KiB) and what the threads already
/// running may still allocate, many times over.
pub const HEADROOM_BYTES: usize = 4 << 20;

/// The stack std gives a thread when none is asked for (`RUST_MIN_STACK` unset).
const DEFAULT_STACK_BYTES: usize = 2 << 20;

/// Whether the address space has room for a thread's stack (`stack_bytes`, `None`: std's
/// default) and [`HEADROOM_BYTES`] besides: that much is mapped, never touched (no memory is
/// used) and unmapped at once. Mapped directly, not allocated: the allocator would keep a
/// freed block of that size for its next request and answer from it when the system has no
/// room left. An error says what was missing.
pub fn room_for_a_thread(stack_bytes: Option<usize>) -> io::Result<()> {
    #[cfg(unix)]
    {
        let bytes = stack_bytes.unwrap_or(DEFAULT_STACK_BYTES).saturating_add(HEADROOM_BYTES);
        // SAFETY: a fresh anonymous mapping that nothing reads or writes, unmapped right away;
        // mmap with a null hint never replaces an existing mapping.
        let p = unsafe {
            libc::mmap(
                std::ptr::null_mut(),
                bytes,
                libc::PROT_NONE,
                libc::MAP_PRIVATE | libc::MAP_ANONYMOUS | libc::MAP_NORESERVE,
                -1,
                0,
            )
        };
        if p == libc::MAP_FAILED {
            let e = io::Error::last_os_error();
            return Err(io::Error::new(
                io::ErrorKind::OutOfMemory,
                format!(
                    "no room in the address space for a thread's stack and {} MiB besides ({e})",
                    HEADROOM_BYTES >> 20
                ),
            ));
        }
        // SAFETY: exactly the mapping made above.
        unsafe { libc::munmap(p, bytes) };
    }
    #[cfg(not(unix))]
    let _ = stack_bytes;
    Ok(())
}

/// Starts `f` on a new thread named `name`. `stack_bytes` is the thread's stack (`None`: the
/// platform's default). The error is the system's refusal, or [`room_for_a_thread`]'s; `f` is
/// dropped with it, so whatever it owned (a connection's socket) is closed.
pub fn spawn<T: Send + 'static>(
    name: String,
    stack_bytes: Option<usize>,
    f: impl FnOnce() -> T + Send + 'static,
) -> io::Result<JoinHandle<T>> {
    room_for_a_thread(stack_bytes)?;
    let mut builder = Builder::new().name(name);
    if let Some(bytes) = stack_bytes {
        builder = builder.stack_size(bytes);
    }
    builder.spawn(f)
}

/// A connection's last request time before its first request.
pub(crate) const NEVER_SPOKE: u64 = 0;

pub(crate) struct Connection {
    id: u64,
    stream: TcpStream,
    last_active_ms: Arc<AtomicU64>,
}

/// The open connections of one kind (hosts, or control clients), at most `max` of them: a
/// newcomer to a full table closes one, so that connections that went silent (a half-open
/// socket, a client that never closes) can never lock a new client out. The one closed is a
/// connection that has not sent a request yet, the oldest of them, and only when every one has
/// spoken the one idle longest (issue 33): judged by last request alone, a burst of connections
/// that never speak is "newer" than a host polling every few hundred milliseconds, and pushed
/// it out; a legitimate client speaks as soon as it connects, and from then on only
/// connections idle longer than it go before it.
pub(crate) struct Table {
    pub(crate) max: usize,
    open: Mutex<Vec<Connection>>,
    next_id: AtomicU64,
}

impl Table {
    pub(crate) fn new(max: usize) -> Table {
        Table { max: max.max(1), open: Mutex::new(Vec::new()), next_id: AtomicU64::new(0) }
    }

    fn lock(&self) -> MutexGuard<'_, Vec<Connection>> {
        self.open.lock().unwrap_or_else(|e| e.into_inner())
    }

    /// Enters `stream`, closing one connection if the table is full (see [`Table`]): its id and
    /// the clock its thread sets at each request (in ms, at least 1; [`NEVER_SPOKE`] until the
    /// first), and the id of the connection closed, if any.
    pub(crate) fn admit(&self, stream: &TcpStream) -> io::Result<(u64, Arc<AtomicU64>, Option<u64>)> {
        let handle = stream.try_clone()?;
        let id = self.next_id.fetch_add(1, Ordering::Relaxed) + 1;
        let last_active_ms = Arc::new(AtomicU64::new(NEVER_SPOKE));
        let mut open = self.lock();
        let mut evicted = None;
        if open.len() >= self.max {
            // Never spoken (0) first, the oldest of them (ids rise); then the idlest.
            let idlest = open
                .iter()
                .enumerate()
                .min_by_key(|(_, c)| (c.last_active_ms.load(Ordering::Relaxed), c.id))
                .map(|(i, _)| i);
            if let Some(i) = idlest {
                let old = open.swap_remove(i);
                let _ = old.stream.shutdown(Shutdown::Both);
                evicted = Some(old.id);
            }
        }
        open.push(Connection { id, stream: handle, last_active_ms: last_active_ms.clone() });
        Ok((id, last_active_ms, evicted))
    }

    /// The connection's thread ended: it leaves the table.
    pub(crate) fn forget(&self, id: u64) {
        self.lock().retain(|c| c.id != id);
    }

    /// Closes the connection and takes it out of the table.
    pub(crate) fn close(&self, id: u64) {
        let mut open = self.lock();
        if let Some(i) = open.iter().position(|c| c.id == id) {
            let _ = open.swap_remove(i).stream.shutdown(Shutdown::Both);
        }
    }

    pub(crate) fn close_all(&self) {
        for c in self.lock().iter() {
            let _ = c.stream.shutdown(Shutdown::Both);
        }
    }
}

/// Writes `line` to standard error, ignoring a failure: a server's log is a side channel, and
/// one whose reader has gone (`pmacwd serve 2>&1 | head -1`) must not end the server, as
/// `eprintln!`'s panic (or SIGPIPE) would.
pub fn to_stderr(line: std::fmt::Arguments<'_>) {
    use std::io::Write;
    let mut err = io::stderr().lock();
    let _ = err.write_fmt(line).and_then(|()| err.write_all(b"\n"));
}

/// Writes `line` to standard output and flushes it, ignoring a failure, as [`to_stderr`]: a
/// script that reads the address line and closes the pipe leaves the server running.
pub fn to_stdout(line: std::fmt::Arguments<'_>) {
    use std::io::Write;
    let mut out = io::stdout().lock();
    let _ = out.write_fmt(line).and_then(|()| out.write_all(b"\n")).and_then(|()| out.flush());
}

/// After an accept fails (mostly for want of a file descriptor, EMFILE), the accept loop
/// waits this long before the next: retrying at once would spin a core for as long as the
/// descriptors stay taken. 50 ms bounds that to 20 tries a second and delays a client by at
/// most 50 ms once descriptors come free.
pub const ACCEPT_ERROR_PAUSE: Duration = Duration::from_millis(50);

/// The connection an accept loop got, or `None` after the failure is counted in `errors` and
/// the loop has paused for [`ACCEPT_ERROR_PAUSE`].
pub fn accepted(r: io::Result<TcpStream>, errors: &CountedLog) -> Option<TcpStream> {
    match r {
        Ok(s) => Some(s),
        Err(e) => {
            errors.report(&format!("cannot accept a connection: {e}"));
            std::thread::sleep(ACCEPT_ERROR_PAUSE);
            None
        }
    }
}

/// Without `--verbose`, one line per kind of problem at most this often: a client that sends
/// garbage in a loop (53,595 protocol errors in 3 minutes were measured before this bound)
/// then costs one line a minute, and an operator still learns within a minute that something
/// is wrong.
pub const SUMMARY_INTERVAL: Duration = Duration::from_secs(60);

/// The last reason quoted in a summary is cut to this many bytes: reasons are the server's own
/// sentences with an address and a request code, well under it; the bound keeps a summary one
/// line whatever a reason holds.
pub const REASON_BYTES_MAX: usize = 240;

/// Problems of one kind that clients (or the system) cause: with `verbose`, each is logged on
/// its own line; without it they are counted, and a one-line summary (the count and the last
/// reason) is printed when the first comes and then at most once per [`SUMMARY_INTERVAL`]:
/// by the next report after the interval, by [`CountedLog::flush_due`] (which the servers
/// call from a housekeeping thread, so that the count of a burst is not held back until the
/// next problem) or by [`CountedLog::flush`] at shutdown. Standard error stays bounded
/// whatever clients do.
pub struct CountedLog {
    program: &'static str,
    /// What the problems are called in a summary, in the plural: "protocol errors".
    what: &'static str,
    verbose: bool,
    window: Mutex<Window>,
}

#[derive(Default)]
struct Window {
    /// When the last summary was printed (`None`: never).
    summarized_at: Option<Instant>,
    /// Problems since then, and the last one's reason.
    count: u64,
    last: String,
    total: u64,
}

impl CountedLog {
    pub fn new(program: &'static str, what: &'static str, verbose: bool) -> CountedLog {
        CountedLog { program, what, verbose, window: Mutex::new(Window::default()) }
    }

    /// One problem, and why.
    pub fn report(&self, reason: &str) {
        let mut w = self.window.lock().unwrap_or_else(|e| e.into_inner());
        w.total = w.total.saturating_add(1);
        if self.verbose {
            to_stderr(format_args!("{}: {reason}", self.program));
            return;
        }
        w.count = w.count.saturating_add(1);
        w.last = cut(reason, REASON_BYTES_MAX);
        if w.summarized_at.is_none_or(|t| t.elapsed() >= SUMMARY_INTERVAL) {
            self.summarize(&mut w);
        }
    }

    /// Prints what was counted since the last summary, if anything and if the last summary is
    /// [`SUMMARY_INTERVAL`] old.
    pub fn flush_due(&self) {
        let mut w = self.window.lock().unwrap_or_else(|e| e.into_inner());
        if w.count > 0 && w.summarized_at.is_none_or(|t| t.elapsed() >= SUMMARY_INTERVAL) {
            self.summarize(&mut w);
        }
    }

    /// Prints what was counted since the last summary, if anything (at shutdown).
    pub fn flush(&self) {
        let mut w = self.window.lock().unwrap_or_else(|e| e.into_inner());
        if w.count > 0 {
            self.summarize(&mut w);
        }
    }

    /// Problems reported since the start, logged or counted.
    pub fn total(&self) -> u64 {
        self.window.lock().unwrap_or_else(|e| e.into_inner()).total
    }

    fn summarize(&self, w: &mut Window) {
        to_stderr(format_args!(
            "{}: {}: {} since the last summary, the last: {}; at most one such line every {} s, --verbose logs each",
            self.program,
            self.what,
            w.count,
            w.last,
            SUMMARY_INTERVAL.as_secs()
        ));
        w.count = 0;
        w.summarized_at = Some(Instant::now());
    }
}

/// `text` cut to at most `bytes_max` bytes on a character boundary, with `...` when cut.
pub fn cut(text: &str, bytes_max: usize) -> String {
    if text.len() <= bytes_max {
        return text.to_string();
    }
    let mut end = bytes_max.saturating_sub(3);
    while !text.is_char_boundary(end) {
        end -= 1;
    }
    format!("{}...", &text[..end])
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_system_refusal_to_start_a_thread_is_an_error_not_a_panic() {
        // A stack larger than the address space: the system refuses the thread, and spawn
        // says so instead of panicking (the accept loops rely on this).
        let r = spawn("too big".into(), Some(1 << 60), || ());
        assert!(r.is_err());
        assert!(spawn("fine".into(), None, || 7).unwrap().join().unwrap() == 7);
    }

    #[cfg(unix)]
    #[test]
    fn room_for_a_thread_maps_nothing_it_keeps_and_says_what_was_missing() {
        // The probe of the room a connection's thread needs: a stack the address space cannot
        // hold is refused with OutOfMemory and names the headroom; the default stack fits.
        let e = room_for_a_thread(Some(1 << 60)).unwrap_err();
        assert_eq!(e.kind(), io::ErrorKind::OutOfMemory);
        assert!(e.to_string().contains("a thread's stack and 4 MiB besides"), "{e}");
        for _ in 0..1000 {
            // Unmapped each time: a thousand probes of 6 MiB do not add up.
            room_for_a_thread(None).unwrap();
        }
    }

    #[test]
    fn cut_keeps_short_text_and_cuts_long_text_on_a_character_boundary() {
        // Reasons and notes may quote a client's bytes; the cut must not split a character.
        assert_eq!(cut("short", 10), "short");
        assert_eq!(cut("ééééé", 8), "éé...");
        assert!(cut(&"x".repeat(1000), 240).len() <= 240);
    }

    #[test]
    fn a_failed_accept_is_counted_and_skipped() {
        // EMFILE from accept used to be skipped silently and retried at once (a spinning
        // core while descriptors stay taken); now it is counted for the log and the loop
        // pauses before the next try.
        let errors = CountedLog::new("test", "failed accepts", false);
        let refused = accepted(Err(io::Error::from_raw_os_error(24)), &errors);
        assert!(refused.is_none());
        assert_eq!(errors.total(), 1);
    }
}
