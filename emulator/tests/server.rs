//! `pmacwd serve` on real sockets: the protocol details real clients rely on, and robustness
//! against clients that misbehave. Each test runs its own server on a free loopback port.

use pmacwd_emulator::card::{Card, Clock};
use pmacwd_emulator::control::Control;
use pmacwd_emulator::protocol::{Header, REPLY_PACKET_BYTES};
use pmacwd_emulator::server::{ServeOptions, Server};
use std::io::{ErrorKind, Read, Write};
use std::net::TcpStream;
use std::sync::atomic::Ordering;
use std::time::{Duration, Instant};

fn server(clock: Clock, clients_max: usize, idle_timeout: Option<Duration>) -> Server {
    let options = ServeOptions { idle_timeout, ..ServeOptions::free_loopback_port(clients_max) };
    Server::start(Card::default_card(clock), options).expect("a free loopback port")
}

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

/// One packet as a host reads it (the server writes each packet whole).
fn packet(c: &mut TcpStream) -> Vec<u8> {
    let mut buf = vec![0u8; 4096];
    let n = c.read(&mut buf).expect("a reply");
    buf.truncate(n);
    buf
}

fn ask(c: &mut TcpStream, line: &str) -> Vec<u8> {
    send_line(c, line);
    packet(c)
}

/// Whether the server closed this connection (end of stream, or reset).
fn closed(c: &mut TcpStream) -> bool {
    let mut b = [0u8; 16];
    match c.read(&mut b) {
        Ok(0) => true,
        Err(e) => matches!(e.kind(), ErrorKind::ConnectionReset | ErrorKind::ConnectionAborted),
        Ok(_) => false,
    }
}

#[test]
fn a_long_reply_comes_in_1400_byte_packets_fetched_with_getbuffer() {
    // 373 `???` fill the card's 1,492-byte line; the answers (13 bytes each, and the ACK) take
    // four packets. dls-pmaclib reads on with GETBUFFER while a packet is 1,400 bytes.
    let s = server(Clock::Virtual, 8, None);
    let mut c = connect(&s);
    let line = "??? ".repeat(373);
    assert_eq!(line.len(), 1492);
    let mut reply = ask(&mut c, &line);
    assert_eq!(reply.len(), REPLY_PACKET_BYTES);
    loop {
        c.write_all(&Header::getbuffer().to_bytes()).unwrap();
        let p = packet(&mut c);
        reply.extend_from_slice(&p);
        if p.len() < REPLY_PACKET_BYTES {
            break;
        }
    }
    assert_eq!(reply.len(), 373 * 13 + 1);
    assert_eq!(reply.last(), Some(&0x06));
    assert!(reply.chunks(13).take(373).all(|a| a == b"001000000000\r"));
    // Nothing left: GETBUFFER gets a NUL, which hosts read as "no data".
    c.write_all(&Header::getbuffer().to_bytes()).unwrap();
    assert_eq!(packet(&mut c), [0]);
}

#[test]
fn malformed_headers_close_only_that_connection() {
    let s = server(Clock::Virtual, 8, None);
    let mut good = connect(&s);
    let bad_headers: [[u8; 8]; 3] = [
        [0x40, 0x12, 0, 0, 0, 0, 0, 0],       // unknown request code
        [0x40, 0xBF, 0, 0, 0, 0, 0xFF, 0xFF], // 65,535 data bytes: beyond the 1,492 the card takes
        [0xC0, 0xBF, 0, 0, 0, 0, 0, 3],       // GETRESPONSE with the upload request type
    ];
    for h in bad_headers {
        let mut c = connect(&s);
        c.write_all(&h).unwrap();
        c.write_all(b"???").unwrap();
        assert!(closed(&mut c), "{h:02X?} should close the connection");
        assert_eq!(ask(&mut good, "???"), b"001000000000\r\x06", "the other client is unaffected");
    }
    assert_eq!(s.stats().refused_requests.load(Ordering::Relaxed), 3);
}

#[test]
fn clients_that_leave_mid_request_or_mid_reply_do_not_disturb_others() {
    let s = server(Clock::Virtual, 8, None);
    {
        // A header that promises 100 bytes, then 10, then gone.
        let mut c = connect(&s);
        c.write_all(&Header::getresponse(100).to_bytes()).unwrap();
        c.write_all(b"I130=1 I13").unwrap();
    }
    {
        // A long reply nobody reads: the server writes into a closed socket.
        let mut c = connect(&s);
        send_line(&mut c, &"??? ".repeat(373));
    }
    {
        // Half a header.
        let mut c = connect(&s);
        c.write_all(&[0x40, 0xBF, 0]).unwrap();
    }
    let mut c = connect(&s);
    assert_eq!(ask(&mut c, "I130"), b"2000\r\x06", "the half-sent write was never executed: the factory default");
    assert_eq!(ask(&mut c, "???"), b"001000000000\r\x06");
}

#[test]
fn idle_connections_make_room_for_new_clients() {
    // Half-open connections look to the server like clients that never speak again: when the
    // table is full, the one idle longest is closed for the newcomer.
    let s = server(Clock::Virtual, 8, None);
    let mut silent: Vec<TcpStream> = (0..8).map(|_| connect(&s)).collect();
    std::thread::sleep(Duration::from_millis(20));
    let mut newcomer = connect(&s);
    assert_eq!(ask(&mut newcomer, "???"), b"001000000000\r\x06");
    assert!(s.stats().evicted.load(Ordering::Relaxed) >= 1);
    assert!(closed(&mut silent[0]), "the longest idle connection was closed");
}

#[test]
fn a_connection_silent_past_the_idle_timeout_is_closed() {
    let s = server(Clock::Virtual, 8, Some(Duration::from_millis(200)));
    let mut c = connect(&s);
    assert_eq!(ask(&mut c, "I40"), b"0\r\x06");
    let t = Instant::now();
    assert!(closed(&mut c));
    assert!(t.elapsed() >= Duration::from_millis(150));
}

#[test]
fn a_tripped_card_reads_requests_and_answers_none_until_init() {
    // UM p.215: the tripped CPU does not communicate; the connection stays up, the host's read
    // times out, and after INIT/ the same connection gets answers again.
    let s = server(Clock::Virtual, 8, None);
    let mut c = connect(&s);
    assert_eq!(ask(&mut c, "???"), b"001000000000\r\x06");
    s.with_card(|card| {
        card.control(Control::parse("starve").unwrap());
        card.control(Control::parse("step 5000").unwrap());
    });
    c.set_read_timeout(Some(Duration::from_millis(200))).unwrap();
    for line in ["???", "ver", "I130=5", "GETBUFFER"] {
        if line == "GETBUFFER" {
            c.write_all(&Header::getbuffer().to_bytes()).unwrap();
        } else {
            send_line(&mut c, line);
        }
        let mut b = [0u8; 16];
        let e = c.read(&mut b).expect_err("silence");
        assert!(matches!(e.kind(), ErrorKind::WouldBlock | ErrorKind::TimedOut), "{line}: {e}");
    }
    s.with_card(|card| {
        card.control(Control::parse("plc0 30").unwrap());
        card.control(Control::parse("init").unwrap());
    });
    c.set_read_timeout(Some(Duration::from_secs(5))).unwrap();
    assert_eq!(
        ask(&mut c, "I130"),
        b"2000\r\x06",
        "the write sent while tripped was never executed: the factory default"
    );
}

#[test]
fn a_hundred_concurrent_clients_each_get_their_own_answers() {
    // Bounded load: 100 clients x 200 lines, each writing and reading back its own I-variable,
    // so a reply delivered to the wrong client or out of order shows up as a wrong value.
    let s = server(Clock::Wall { start: Instant::now(), servo_hz: 2250 }, 128, None);
    let addr = s.local_addr;
    let started = Instant::now();
    let clients: Vec<_> = (0..100u16)
        .map(|k| {
            std::thread::spawn(move || {
                let mut c = TcpStream::connect(addr).unwrap();
                c.set_read_timeout(Some(Duration::from_secs(10))).unwrap();
                c.set_nodelay(true).unwrap();
                // I6000..I6101 less I6011 and I6012: no address I-variable among them, so every
                // value reads back in decimal, and no countdown timer (C.S. 10's Isx11 and
                // Isx12 count down every servo cycle, SRM p.176).
                let n = 6000 + k + if k >= 11 { 2 } else { 0 };
                for j in 0..200u32 {
                    let value = u32::from(k) * 1000 + j;
                    let reply = ask(&mut c, &format!("I{n}={value} I{n}"));
                    assert_eq!(reply, format!("{value}\r\x06").as_bytes(), "client {k} line {j}");
                }
            })
        })
        .collect();
    for c in clients {
        c.join().expect("no client saw a wrong answer");
    }
    let seconds = started.elapsed().as_secs_f64();
    eprintln!("100 clients x 200 lines in {seconds:.2} s ({:.0} lines/s)", 20_000.0 / seconds);
    assert_eq!(s.stats().connections.load(Ordering::Relaxed), 100);
    let mut c = connect(&s);
    let status = ask(&mut c, "???");
    // Bit 12 follows the checksum pass on the wall clock; the rest stays clear.
    assert!(status == b"001000000000\r\x06" || status == b"000000000000\r\x06", "still serving: {status:?}");
}

#[test]
fn a_connection_whose_thread_cannot_start_is_closed_and_the_server_keeps_accepting() {
    // When the system refuses a connection's thread (here: a stack larger than the address
    // space), that connection is closed and the accept loop goes on. Before, the accept thread
    // panicked: every later client waited in the listen backlog, unanswered, while the process
    // stayed up. Each of these clients must see its connection closed, not a timeout.
    let options = ServeOptions {
        control: Some("127.0.0.1:0".parse().unwrap()),
        thread_stack_bytes: Some(1 << 60),
        ..ServeOptions::free_loopback_port(8)
    };
    let s = Server::start(Card::default_card(Clock::Virtual), options).expect("a free loopback port");
    for k in 0..3 {
        let mut c = connect(&s);
        // The write may already find the connection closed.
        let _ = c.write_all(&Header::getresponse(3).to_bytes()).and_then(|()| c.write_all(b"???"));
        assert!(closed(&mut c), "host client {k} closed, not left waiting");
    }
    let mut control = TcpStream::connect(s.control_addr.unwrap()).unwrap();
    control.set_read_timeout(Some(Duration::from_secs(5))).unwrap();
    let _ = control.write_all(b"state\n");
    assert!(closed(&mut control), "the control client too");
    assert_eq!(s.stats().spawn_failures.load(Ordering::Relaxed), 4);
    s.stop();
}

#[test]
fn hosts_keep_getting_answers_while_a_long_step_runs() {
    // `step 4000000000` is some 16 s of servo cycles. It used to hold the card's lock for all
    // of it, and every host waited; the server now runs it in chunks of CYCLES_PER_HOLD_MAX
    // and releases the lock between them. What is checked is the order of events, not a
    // time: a host's `???` is answered while the step's own reply has not come yet.
    let options = ServeOptions { control: Some("127.0.0.1:0".parse().unwrap()), ..ServeOptions::free_loopback_port(8) };
    let s = Server::start(Card::default_card(Clock::Virtual), options).expect("a free loopback port");
    let mut control = TcpStream::connect(s.control_addr.unwrap()).unwrap();
    control.write_all(b"step 4000000000\n").unwrap();
    // The step has begun once `state` on a second control connection shows cycles moving.
    let mut watcher = std::io::BufReader::new(TcpStream::connect(s.control_addr.unwrap()).unwrap());
    let cycles = |w: &mut std::io::BufReader<TcpStream>| -> u64 {
        w.get_mut().write_all(b"state\n").unwrap();
        let mut line = String::new();
        std::io::BufRead::read_line(w, &mut line).unwrap();
        let at = line.find("cycles=").expect("state names the cycles") + "cycles=".len();
        line[at..].split_whitespace().next().unwrap().parse().unwrap()
    };
    while cycles(&mut watcher) == 0 {
        std::thread::yield_now();
    }
    let mut host = connect(&s);
    for _ in 0..3 {
        // Twelve hex digits, CR, ACK (bit 12 follows the checksum pass the step is in).
        let status = ask(&mut host, "???");
        assert!(status.len() == 14 && status.ends_with(b"\r\x06"), "{status:?}");
    }
    control.set_read_timeout(Some(Duration::from_millis(1))).unwrap();
    let mut b = [0u8; 64];
    let still_stepping =
        matches!(control.read(&mut b), Err(e) if matches!(e.kind(), ErrorKind::WouldBlock | ErrorKind::TimedOut));
    assert!(still_stepping, "the host was answered before the step ended");
    assert!(cycles(&mut watcher) < 4_000_000_000);
    // Stopping the server closes the control connection and ends the step early.
    s.stop();
    control.set_read_timeout(Some(Duration::from_secs(10))).unwrap();
    let mut reply = String::new();
    let _ = std::io::BufRead::read_line(&mut std::io::BufReader::new(control), &mut reply);
    assert!(reply.is_empty() || reply.starts_with("error: the emulator is stopping"), "{reply}");
}

/// A control connection to `s` whose reads give up after 5 s.
fn control_client(s: &Server) -> std::io::BufReader<TcpStream> {
    let c = TcpStream::connect(s.control_addr.expect("a control interface")).unwrap();
    c.set_read_timeout(Some(Duration::from_secs(5))).unwrap();
    std::io::BufReader::new(c)
}

/// One control command and its reply line.
fn control_command(c: &mut std::io::BufReader<TcpStream>, line: &str) -> String {
    c.get_mut().write_all(format!("{line}\n").as_bytes()).unwrap();
    let mut reply = String::new();
    std::io::BufRead::read_line(c, &mut reply).unwrap();
    reply
}

#[test]
fn idle_control_connections_make_room_for_a_new_control_client() {
    // CONTROL_CLIENTS_MAX silent control connections used to lock every other control client
    // out, with no timeout. Now a newcomer to a full table closes the one idle longest, as
    // for hosts, so a bench can always get in.
    use pmacwd_emulator::server::CONTROL_CLIENTS_MAX;
    let options = ServeOptions { control: Some("127.0.0.1:0".parse().unwrap()), ..ServeOptions::free_loopback_port(8) };
    let s = Server::start(Card::default_card(Clock::Virtual), options).expect("a free loopback port");
    let mut silent: Vec<_> = (0..CONTROL_CLIENTS_MAX).map(|_| control_client(&s)).collect();
    // Each has been admitted once it answers; the first then stays silent longest.
    for c in silent.iter_mut() {
        assert!(control_command(c, "state").starts_with("ok tripped=false"));
        std::thread::sleep(Duration::from_millis(2));
    }
    let mut newcomer = control_client(&s);
    assert!(control_command(&mut newcomer, "state").starts_with("ok tripped=false"), "the newcomer got in");
    assert_eq!(s.stats().control_evicted.load(Ordering::Relaxed), 1);
    assert!(closed(silent[0].get_mut()), "the control connection idle longest was closed");
    assert!(control_command(&mut silent[1], "state").starts_with("ok"), "the others stay");
    s.stop();
}

#[test]
fn a_control_connection_silent_past_its_idle_timeout_is_closed() {
    // Control connections had no timeout: one left open by a client that went away held its
    // thread and its place for ever. Now they close after `control_idle_timeout`.
    let options = ServeOptions {
        control: Some("127.0.0.1:0".parse().unwrap()),
        control_idle_timeout: Some(Duration::from_millis(200)),
        ..ServeOptions::free_loopback_port(8)
    };
    let s = Server::start(Card::default_card(Clock::Virtual), options).expect("a free loopback port");
    let mut c = control_client(&s);
    assert!(control_command(&mut c, "state").starts_with("ok"));
    let t = Instant::now();
    assert!(closed(c.get_mut()));
    assert!(t.elapsed() >= Duration::from_millis(150));
    s.stop();
}

#[test]
fn a_control_line_longer_than_the_maximum_closes_that_control_connection_with_an_error() {
    // The control port reads at most CONTROL_LINE_BYTES_MAX bytes of a line, so a client that
    // never sends a newline cannot grow the server's memory; it gets an error line and its
    // connection is closed, and other control clients are served as before. (Twice the
    // maximum in one write, read whole by the server, so the close is clean.)
    use pmacwd_emulator::control::CONTROL_LINE_BYTES_MAX;
    let options = ServeOptions { control: Some("127.0.0.1:0".parse().unwrap()), ..ServeOptions::free_loopback_port(8) };
    let s = Server::start(Card::default_card(Clock::Virtual), options).expect("a free loopback port");
    let mut long = control_client(&s);
    long.get_mut().write_all(&vec![b'x'; 2 * CONTROL_LINE_BYTES_MAX]).unwrap();
    let mut reply = String::new();
    let _ = long.read_to_string(&mut reply);
    assert_eq!(reply, format!("error: a control line is at most {CONTROL_LINE_BYTES_MAX} bytes\n"));
    assert!(control_command(&mut control_client(&s), "state").starts_with("ok tripped=false"));
    s.stop();
}

#[test]
fn a_client_that_writes_i3_4_still_gets_terminated_replies_afterwards() {
    // I3 ranges 0..3 (SRM p.37). `I3=4` used to be stored and framed as I3 = 0: no ACK after
    // any later line, so the client waited for ever. It is now refused with ERR003, whose CR
    // ends the reply, and the lines after it are acknowledged as before.
    let s = server(Clock::Virtual, 8, None);
    let mut c = connect(&s);
    assert_eq!(ask(&mut c, "I3=4"), b"\x07ERR003\r");
    assert_eq!(ask(&mut c, "???"), b"001000000000\r\x06");
    assert_eq!(ask(&mut c, "I3"), b"2\r\x06");
}

#[test]
fn a_client_looping_on_errors_is_slowed_and_one_answering_normally_is_not() {
    // dls-pmaccontrol answers a failed poll with CLOSE and polls again at once; the server
    // holds back each error reply until ERROR_REPLY_INTERVAL after the previous one, so such
    // a loop costs at most 100 error replies a second. Counted, not timed: the counter says
    // how many error replies had to wait.
    let s = server(Clock::Virtual, 4, None);
    let mut c = connect(&s);
    for _ in 0..20 {
        assert_eq!(ask(&mut c, "ZZZ"), b"\x07ERR003\r");
    }
    let slowed = s.stats().errors_slowed.load(Ordering::Relaxed);
    assert!(slowed >= 1, "back-to-back errors were not slowed ({slowed} of 19)");
    for _ in 0..20 {
        assert_eq!(ask(&mut c, "I10"), b"3713707\r\x06");
    }
    assert_eq!(s.stats().errors_slowed.load(Ordering::Relaxed), slowed, "replies without an error never wait");
}

#[test]
fn addressing_is_kept_per_connection() {
    // `#3` on one connection does not move another's addressed motor (SRM p.270).
    let s = server(Clock::Virtual, 4, None);
    let (mut a, mut b) = (connect(&s), connect(&s));
    assert_eq!(ask(&mut a, "#3"), b"\x06");
    assert_eq!(ask(&mut a, "#"), b"#3\r\x06");
    assert_eq!(ask(&mut b, "#"), b"#1\r\x06");
}

#[test]
fn the_recording_proxy_keeps_at_most_its_sessions_open_and_a_newcomer_closes_the_idlest() {
    // `pmacwd record` started two threads and a card connection for every host connection,
    // with no bound and no timeout: 2,000 idle connections held 4,000 threads. Now at most
    // SESSIONS_MAX are open; a newcomer to a full table closes the one idle longest (as `serve`
    // does), so silent sessions never lock a new one out.
    use pmacwd_emulator::capture::{CaptureWriter, Timing};
    use pmacwd_emulator::proxy::{Proxy, RecordOptions, Recorder, SESSIONS_MAX};
    let s = server(Clock::Virtual, SESSIONS_MAX + 8, None);
    let capture = CaptureWriter::new(
        Box::new(std::io::sink()) as Box<dyn Write + Send>,
        "t",
        pmacwd_emulator::card::DEFAULT_CONFIGURATION,
        Timing::Exact,
    )
    .unwrap();
    let options = RecordOptions {
        listen: "127.0.0.1:0".parse().unwrap(),
        target: s.local_addr.to_string(),
        control: None,
        servo_hz: 2250,
        virtual_time: true,
        silence: Duration::from_secs(1),
        sessions: None,
        verbose: false,
        thread_stack_bytes: None,
    };
    let proxy = Proxy::start(Recorder::new(capture, 2250, true).unwrap(), options).unwrap();
    let open = |_| {
        let mut c = TcpStream::connect(proxy.local_addr).unwrap();
        c.set_read_timeout(Some(Duration::from_secs(5))).unwrap();
        // Answered: admitted, and this is its last activity.
        assert_eq!(ask(&mut c, "???").last(), Some(&0x06));
        std::thread::sleep(Duration::from_millis(2));
        c
    };
    let mut sessions: Vec<TcpStream> = (0..SESSIONS_MAX).map(open).collect();
    let mut newcomer = open(0);
    assert_eq!(ask(&mut newcomer, "???").last(), Some(&0x06), "the newcomer is answered");
    assert!(closed(&mut sessions[0]), "the session idle longest was closed");
    assert_eq!(ask(&mut sessions[1], "???").last(), Some(&0x06), "the others stay");
    s.stop();
}

#[test]
fn readready_says_in_its_first_byte_and_flush_answers_as_real_cards_do() {
    // The EPICS pmac driver (pmacAsynIPPort.c) tests READREADY's first byte (UMAC Turbo CPU
    // manual p.36: "the first byte if non-zero indicates there is data to be read"), and reads
    // one byte after FLUSH, which real cards send as 0x40. READREADY used to answer [0, ready],
    // which the driver reads as "nothing waiting" for ever, and FLUSH CTRL-X.
    use pmacwd_emulator::protocol::{DOWNLOAD, UPLOAD, VR_PMAC_FLUSH, VR_PMAC_READREADY, VR_PMAC_SENDLINE};
    let s = server(Clock::Virtual, 8, None);
    let mut c = connect(&s);
    let header =
        |request_type, request, length| Header { request_type, request, value: 0, index: 0, length }.to_bytes();
    c.write_all(&header(UPLOAD, VR_PMAC_READREADY, 2)).unwrap();
    assert_eq!(packet(&mut c), [0, 0], "nothing waiting");
    // SENDLINE leaves the answer waiting for GETLINE.
    c.write_all(&header(DOWNLOAD, VR_PMAC_SENDLINE, 3)).unwrap();
    c.write_all(b"???").unwrap();
    assert_eq!(packet(&mut c).len(), 1);
    c.write_all(&header(UPLOAD, VR_PMAC_READREADY, 2)).unwrap();
    assert_eq!(packet(&mut c), [1, 0], "an answer waits: the first byte says so");
    c.write_all(&header(DOWNLOAD, VR_PMAC_FLUSH, 0)).unwrap();
    assert_eq!(packet(&mut c), [0x40], "the flush's acknowledgement");
    c.write_all(&header(UPLOAD, VR_PMAC_READREADY, 2)).unwrap();
    assert_eq!(packet(&mut c), [0, 0], "flushed");
}
