//! Issue 33's hostile clients against `pmacwd serve`, each test written before its fix and
//! seen failing: a line whose reply is far larger than the line, a capture sink that stalls
//! (under `serve --record` and under `pmacwd record` in front of `serve`), and connections that
//! never speak pushing out a client that does.

use pmacwd_emulator::capture::{CaptureWriter, Timing};
use pmacwd_emulator::card::{Card, Clock};
use pmacwd_emulator::protocol::{Header, REPLY_PACKET_BYTES};
use pmacwd_emulator::server::{ServeOptions, Server};
use std::io::{ErrorKind, Read, Write};
use std::net::TcpStream;
use std::sync::{mpsc, Arc, Mutex};
use std::time::{Duration, Instant};

fn connect(s: &Server) -> TcpStream {
    let c = TcpStream::connect(s.local_addr).unwrap();
    c.set_read_timeout(Some(Duration::from_secs(5))).unwrap();
    c.set_nodelay(true).unwrap();
    c
}

fn send_line(c: &mut TcpStream, line: &str) {
    c.write_all(&Header::getresponse(line.len() as u16).to_bytes()).unwrap();
    c.write_all(line.as_bytes()).unwrap();
}

fn packet(c: &mut TcpStream) -> Vec<u8> {
    let mut buf = vec![0u8; 4096];
    let n = c.read(&mut buf).expect("a reply within the read timeout");
    buf.truncate(n);
    buf
}

fn ask(c: &mut TcpStream, line: &str) -> Vec<u8> {
    send_line(c, line);
    packet(c)
}

/// The longest line of `M0..8191->` the card's 1,492-byte buffer takes: once every M-variable
/// points somewhere (`define`), each command reports 8,192 definitions of 17 bytes (about
/// 140 KB), the line about 19 MB, from 1,485 bytes.
fn definitions_line() -> String {
    "M0..8191-> ".repeat(1492 / 11)
}

/// Points every M-variable at X:$0, so that `M0..8191->` reports 17 bytes for each.
fn define(c: &mut TcpStream) {
    assert_eq!(ask(c, "M0..8191->X:$0,0,24,S"), b"\x06");
}

#[test]
fn a_line_of_range_reads_does_not_hold_the_card_from_another_host() {
    // Before: the card's lock was held for the whole line (a 1,492-byte line of ranges, about
    // 0.1 s in a release build and seconds in a debug one), so another host's `???` waited
    // behind it. Now the lock is taken per command (and per part of a range).
    let s = Server::start(Card::default_card(Clock::Virtual), ServeOptions::free_loopback_port(8)).unwrap();
    let mut hog = connect(&s);
    define(&mut hog);
    let line = definitions_line();
    let (done_tx, done_rx) = mpsc::channel();
    let hog_thread = std::thread::spawn(move || {
        for _ in 0..3 {
            send_line(&mut hog, &line);
            let first = packet(&mut hog);
            assert_eq!(first.len(), REPLY_PACKET_BYTES);
        }
        done_tx.send(()).unwrap();
        hog
    });
    let mut poller = connect(&s);
    let mut worst = Duration::ZERO;
    let mut polls = 0;
    let started = Instant::now();
    while done_rx.try_recv().is_err() && started.elapsed() < Duration::from_secs(60) {
        let t = Instant::now();
        assert_eq!(ask(&mut poller, "???"), b"001000000000\r\x06");
        worst = worst.max(t.elapsed());
        polls += 1;
        std::thread::sleep(Duration::from_millis(2));
    }
    drop(hog_thread.join().unwrap());
    // A debug build on a shared machine: far above a release build's microseconds, far below
    // a whole line's hold.
    assert!(worst < Duration::from_millis(100), "a `???` waited {worst:?} behind another host's line");
    eprintln!("worst `???` round trip {worst:?} over {polls} polls");
    assert!(polls >= 5, "only {polls} polls while the long lines ran");
}

#[test]
fn the_first_packet_of_a_huge_reply_comes_before_the_rest_is_built() {
    // Before: the whole 19 MB reply was built before its first packet was sent (and held until
    // the host fetched it or sent another line). Now the card answers as the host fetches.
    let s = Server::start(Card::default_card(Clock::Virtual), ServeOptions::free_loopback_port(8)).unwrap();
    let mut c = connect(&s);
    define(&mut c);
    let t = Instant::now();
    let first = ask(&mut c, &definitions_line());
    let waited = t.elapsed();
    assert_eq!(first.len(), REPLY_PACKET_BYTES);
    assert!(first.starts_with(b"X:$000000,0,24,S\r"), "{:?}", &first[..20]);
    assert!(waited < Duration::from_millis(500), "the first packet took {waited:?}");
    // The next packets follow on GETBUFFER, continuing where the first stopped.
    c.write_all(&Header::getbuffer().to_bytes()).unwrap();
    let second = packet(&mut c);
    assert_eq!(second.len(), REPLY_PACKET_BYTES);
    assert!(second.starts_with(b"000,0,24,S\rX:$000000"), "the second packet goes on where the first stopped");
    // A new line after an unfinished one is answered as usual.
    assert_eq!(ask(&mut c, "???"), b"001000000000\r\x06");
}

/// A sink that takes the capture's header, then blocks every write until released: a FIFO
/// nobody reads, a full disk on a network share.
struct Stalled {
    header_taken: bool,
    release: mpsc::Receiver<()>,
}

impl Write for Stalled {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        if self.header_taken {
            // Blocks until the test releases it (or drops the sender).
            let _ = self.release.recv();
            return Err(std::io::Error::new(ErrorKind::BrokenPipe, "released"));
        }
        Ok(buf.len())
    }
    fn flush(&mut self) -> std::io::Result<()> {
        self.header_taken = true;
        Ok(())
    }
}

#[test]
fn a_stalled_capture_sink_does_not_freeze_hosts_or_the_control_port() {
    // Before: `serve --record` wrote each step under the card's lock, so a sink that stopped
    // taking bytes froze every host and the control port. Now records go to a writer thread
    // through a bounded queue; when the queue is full, recording stops with a message.
    let (release_tx, release_rx) = mpsc::channel();
    let sink: Box<dyn Write + Send> = Box::new(Stalled { header_taken: false, release: release_rx });
    let capture =
        CaptureWriter::new(sink, "stalled", pmacwd_emulator::card::DEFAULT_CONFIGURATION, Timing::Exact).unwrap();
    let mut card = Card::default_card(Clock::Virtual);
    card.record(capture).unwrap();
    let options = ServeOptions {
        control: Some(std::net::SocketAddr::from(([127, 0, 0, 1], 0))),
        ..ServeOptions::free_loopback_port(8)
    };
    let s = Server::start(card, options).unwrap();
    let mut host = connect(&s);
    let long = "??? ".repeat(373);
    for _ in 0..400 {
        // Each long line makes 373 records; a few hundred fill any reasonable queue.
        let first = ask(&mut host, &long);
        assert_eq!(first.len(), REPLY_PACKET_BYTES);
    }
    assert_eq!(ask(&mut host, "???"), b"001000000000\r\x06");
    let mut control = std::io::BufReader::new(TcpStream::connect(s.control_addr.unwrap()).unwrap());
    control.get_ref().set_read_timeout(Some(Duration::from_secs(5))).unwrap();
    control.get_mut().write_all(b"state\n").unwrap();
    let mut reply = String::new();
    std::io::BufRead::read_line(&mut control, &mut reply).unwrap();
    assert!(!reply.is_empty());
    assert!(!s.with_card(|c| c.is_recording()), "the queue filled: recording stopped");
    drop(release_tx);
    let (_, left) = s.stop_then(|c| c.finish_recording_counted());
    assert!(left.iter().any(|n| n.contains("recording stopped")), "{left:?}");
}

/// Takes the capture's header, then blocks on its first write until the test releases it (or
/// drops the sender); from then on keeps what it is given.
struct StalledThenKept {
    header_taken: bool,
    release: Option<mpsc::Receiver<()>>,
    kept: Arc<Mutex<Vec<u8>>>,
}

impl Write for StalledThenKept {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        if self.header_taken {
            if let Some(release) = self.release.take() {
                let _ = release.recv();
            }
            self.kept.lock().unwrap().extend_from_slice(buf);
        }
        Ok(buf.len())
    }
    fn flush(&mut self) -> std::io::Result<()> {
        self.header_taken = true;
        Ok(())
    }
}

#[test]
fn a_stalled_capture_sink_does_not_freeze_the_recording_proxy_s_hosts_or_its_control_port() {
    // Before: `pmacwd record` wrote each exchange and event under the lock its host sessions
    // and control sessions share, so a sink that stopped taking bytes held every session (the
    // first reply never came). Now, as under `serve --record`, records go to a writer thread
    // through the bounded queue of `capture_queue`; when it is full, recording stops, and the
    // capture ends with a note saying why once the sink takes it.
    use pmacwd_emulator::proxy::{Proxy, RecordOptions, Recorder};
    let options = ServeOptions {
        control: Some(std::net::SocketAddr::from(([127, 0, 0, 1], 0))),
        ..ServeOptions::free_loopback_port(8)
    };
    let s = Server::start(Card::default_card(Clock::Virtual), options).unwrap();
    let (release_tx, release_rx) = mpsc::channel();
    let kept = Arc::new(Mutex::new(Vec::new()));
    let sink: Box<dyn Write + Send> =
        Box::new(StalledThenKept { header_taken: false, release: Some(release_rx), kept: kept.clone() });
    let capture =
        CaptureWriter::new(sink, "stalled", pmacwd_emulator::card::DEFAULT_CONFIGURATION, Timing::Exact).unwrap();
    let loopback = std::net::SocketAddr::from(([127, 0, 0, 1], 0));
    let options = RecordOptions {
        listen: loopback,
        target: s.local_addr.to_string(),
        control: Some((loopback, s.control_addr.unwrap().to_string())),
        servo_hz: 2250,
        virtual_time: true,
        silence: Duration::from_secs(1),
        sessions: None,
        verbose: false,
        thread_stack_bytes: None,
    };
    let proxy = Proxy::start(Recorder::new(capture, 2250, true).unwrap(), options).unwrap();
    let open = || {
        let c = TcpStream::connect(proxy.local_addr).unwrap();
        c.set_read_timeout(Some(Duration::from_secs(5))).unwrap();
        c.set_nodelay(true).unwrap();
        c
    };
    let mut host = open();
    let long = "??? ".repeat(373);
    let mut first = vec![0u8; REPLY_PACKET_BYTES];
    for _ in 0..2000 {
        // Each long line is one exchange of about 3 KB (the line and the packet fetched):
        // about 1,400 of them fill the queue.
        send_line(&mut host, &long);
        host.read_exact(&mut first).expect("the first packet of the reply, the sink stalled or not");
    }
    let mut other = open();
    send_line(&mut other, "???");
    let mut status = [0u8; 14];
    other.read_exact(&mut status).expect("another host is answered");
    assert_eq!(&status, b"001000000000\r\x06");
    let mut control = std::io::BufReader::new(TcpStream::connect(proxy.control_addr.unwrap()).unwrap());
    control.get_ref().set_read_timeout(Some(Duration::from_secs(5))).unwrap();
    for command in ["servo 10\n", "state\n"] {
        control.get_mut().write_all(command.as_bytes()).unwrap();
        let mut reply = String::new();
        std::io::BufRead::read_line(&mut control, &mut reply).expect("the control port answers");
        assert!(reply.starts_with("ok"), "{command}: {reply}");
    }
    drop(release_tx);
    let (_, _, left) = proxy.stop().unwrap();
    s.stop();
    assert!(
        left.iter().any(|n| n.contains("recording stopped: the capture's sink took nothing")),
        "the capture ends saying why: {left:?}"
    );
    let written = String::from_utf8(kept.lock().unwrap().clone()).unwrap();
    assert!(written.lines().count() > 1000, "the exchanges before the stop are in the capture");
}

#[test]
fn connections_that_never_speak_do_not_push_out_a_host_that_does() {
    // Before: a full table closed the connection idle longest, judged by its last request;
    // a burst of connections that never send anything is "newer" than a host polling every
    // few hundred milliseconds, which was closed for them. Now a connection that has not yet
    // sent a request goes first.
    let s = Server::start(Card::default_card(Clock::Virtual), ServeOptions::free_loopback_port(4)).unwrap();
    let mut poller = connect(&s);
    assert_eq!(ask(&mut poller, "???"), b"001000000000\r\x06");
    std::thread::sleep(Duration::from_millis(50));
    let mut silent = Vec::new();
    for _ in 0..20 {
        silent.push(connect(&s));
        std::thread::sleep(Duration::from_millis(5));
    }
    assert_eq!(ask(&mut poller, "???"), b"001000000000\r\x06", "the polling host keeps its connection");
}
