//! The emulator's whole byte stream (issue 33): any bytes a host sends to `pmacwd serve`,
//! request headers and command lines pipelined as they come, delivered to a real server on a
//! loopback socket in pieces of any size down to one byte.
//!
//! The first input byte chooses the piece size (0: all at once, n: n bytes per write, each
//! sent on its own with TCP_NODELAY and a yield between, so the server reads across every
//! split); the rest is the stream. Then the host closes its side.
//!
//! Invariants:
//! - the server stays up and closes the connection (end of stream for the host) once the
//!   stream has ended, within a bound, whatever it held: a half header, half a line;
//! - the replies are bounded by the requests: at most one packet (1,400 bytes) per 8-byte
//!   header in the stream, so no reply is built beyond what was asked;
//! - a following well-formed request on a new connection is answered correctly: the line
//!   `CLOSE ???` (CLOSE leaves any program buffer the stream opened, and answers nothing)
//!   answered with one 12-digit status word under whatever framing (I3, I6) the stream left,
//!   or nothing if the card is tripped, which the card then says it is;
//! - every connection's thread ends within 10 s of its connection (the process is back to the
//!   threads it had before the input);
//! - memory stays bounded: libFuzzer's `-rss_limit_mb` (2 GB by default) fails a run that
//!   grows past it, and `-malloc_limit_mb` (the same) a single allocation past it.
//!
//! One server per fuzzing process, its card replaced by a fresh one before each input, so that
//! an input's outcome does not depend on the ones before.
#![no_main]

use libfuzzer_sys::fuzz_target;
use pmacwd_emulator::card::{Card, Clock};
use pmacwd_emulator::framing::{parse_reply, ReadAnswer};
use pmacwd_emulator::protocol::{Header, HEADER_BYTES, REPLY_PACKET_BYTES};
use pmacwd_emulator::server::{ServeOptions, Server};
use std::io::{Read, Write};
use std::net::{Shutdown, TcpStream};
use std::sync::OnceLock;
use std::time::Duration;

/// LeakSanitizer's suppressions for this target (a hook the sanitizer runtime calls at start).
/// The server's connection threads run while libFuzzer checks for leaks after an input, and
/// glibc's list of a live thread's thread-local destructors (`__cxa_thread_atexit_impl`, 32
/// bytes per thread) is reported as lost; it is freed when the thread ends. Everything else is
/// still checked.
#[no_mangle]
pub extern "C" fn __lsan_default_suppressions() -> *const std::ffi::c_char {
    c"leak:__cxa_thread_atexit_impl\n".as_ptr()
}

/// How long the server may take to end a connection after its stream ended: a line of ranges
/// runs to its end first (about 0.1 s on a release build; the sanitizers slow it many times).
const CLOSE_WITHIN: Duration = Duration::from_secs(30);

fn server() -> &'static Server {
    static SERVER: OnceLock<Server> = OnceLock::new();
    SERVER.get_or_init(|| {
        Server::start(Card::default_card(Clock::Virtual), ServeOptions::free_loopback_port(8))
            .expect("a free loopback port")
    })
}

/// The threads of this process (`/proc/self/status`).
fn threads() -> usize {
    let status = std::fs::read_to_string("/proc/self/status").expect("/proc/self/status (Linux)");
    status.lines().find_map(|l| l.strip_prefix("Threads:")).and_then(|v| v.trim().parse().ok()).expect("Threads:")
}

/// The threads before any connection: the server's own and the fuzzer's.
fn baseline() -> usize {
    static BASELINE: OnceLock<usize> = OnceLock::new();
    *BASELINE.get_or_init(|| {
        server();
        threads()
    })
}

/// How long a connection's thread may outlive its connection.
const THREAD_ENDS_WITHIN: Duration = Duration::from_secs(10);

fn connect(s: &Server) -> TcpStream {
    let c = TcpStream::connect(s.local_addr).expect("the server accepts");
    c.set_nodelay(true).unwrap();
    c.set_read_timeout(Some(CLOSE_WITHIN)).unwrap();
    c
}

/// Sends `line` with GETRESPONSE and reads one packet (`None`: no reply in 2 s, a silent card).
fn ask(c: &mut TcpStream, line: &[u8]) -> Option<Vec<u8>> {
    c.write_all(&Header::getresponse(line.len() as u16).to_bytes()).unwrap();
    c.write_all(line).unwrap();
    c.set_read_timeout(Some(Duration::from_secs(2))).unwrap();
    let mut buf = vec![0u8; 4096];
    loop {
        match c.read(&mut buf) {
            Ok(n) => {
                assert!(n > 0, "the server closed a connection that sent a well-formed request");
                buf.truncate(n);
                return Some(buf);
            }
            Err(e) if e.kind() == std::io::ErrorKind::WouldBlock => return None,
            // libFuzzer's timer (SIGALRM, every -timeout/2 + 1 s) interrupts a read: read again.
            Err(e) if e.kind() == std::io::ErrorKind::Interrupted => {}
            Err(e) => panic!("the well-formed request failed: {e}"),
        }
    }
}

fuzz_target!(|data: &[u8]| {
    let Some((&piece, stream)) = data.split_first() else { return };
    let before = baseline();
    let s = server();
    s.with_card(|c| *c = Card::default_card(Clock::Virtual));

    let mut host = connect(s);
    let piece = if piece == 0 { stream.len().max(1) } else { usize::from(piece) };
    for chunk in stream.chunks(piece) {
        // The server may have closed the connection already (a request it cannot follow).
        if host.write_all(chunk).is_err() {
            break;
        }
        std::thread::yield_now();
    }
    let _ = host.shutdown(Shutdown::Write);
    let mut replied = 0usize;
    let mut buf = vec![0u8; 64 * 1024];
    loop {
        match host.read(&mut buf) {
            Ok(0) => break,
            Ok(n) => replied += n,
            Err(e) if e.kind() == std::io::ErrorKind::ConnectionReset => break,
            // libFuzzer's timer (SIGALRM) interrupted the read at 601 s of a 600 s run, and
            // this took it for the server's fault (2026-11-27): read again.
            Err(e) if e.kind() == std::io::ErrorKind::Interrupted => {}
            Err(e) => panic!("the server did not end the connection within {CLOSE_WITHIN:?}: {e}"),
        }
    }
    let headers = stream.len() / HEADER_BYTES + 1;
    assert!(
        replied <= headers * REPLY_PACKET_BYTES,
        "{replied} reply bytes for at most {headers} requests of {} bytes",
        stream.len()
    );

    // One line: under I3 = 0 a line without data (`CLOSE` alone) gets no bytes at all.
    let mut next = connect(s);
    match ask(&mut next, b"CLOSE ???") {
        Some(reply) => {
            let parsed = parse_reply(&reply).unwrap_or_else(|e| panic!("`???` answered {reply:?}: {e}"));
            match parsed.answers.as_slice() {
                [ReadAnswer::Data(words)] => {
                    assert!(words.len() == 12 && words.bytes().all(|b| b.is_ascii_hexdigit()), "`???` answered {words:?}")
                }
                other => panic!("`???` answered {other:?}"),
            }
        }
        None => assert!(s.with_card(|c| c.tripped()), "`???` unanswered and the card is not tripped"),
    }
    drop(next);
    // Every connection's thread ends with its connection: the threads are bounded by the open
    // connections, and nothing of an input is left running into the next (nor into
    // LeakSanitizer's check after it, which counted a live thread's allocations as lost).
    let t = std::time::Instant::now();
    while threads() > before {
        assert!(t.elapsed() < THREAD_ENDS_WITHIN, "{} threads {THREAD_ENDS_WITHIN:?} after the input, {before} before", threads());
        std::thread::sleep(Duration::from_millis(1));
    }
});
