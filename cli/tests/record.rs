//! `pmacwd record` on the wall clock: the proxy forwards bytes unchanged, times the exchanges
//! with its own clock, and writes a capture that replays as consistent.

use pmacwd_emulator::capture::CaptureWriter;
use pmacwd_emulator::card::{Card, Clock};
use pmacwd_emulator::protocol::Header;
use pmacwd_emulator::proxy::{Proxy, RecordOptions, Recorder};
use pmacwd_emulator::server::{ServeOptions, Server};
use pmacwd_trace::TraceEvent;
use std::io::{Read, Write};
use std::net::TcpStream;
use std::time::{Duration, Instant};

fn ask(c: &mut TcpStream, line: &str) -> Vec<u8> {
    c.write_all(&Header::getresponse(line.len() as u16).to_bytes()).unwrap();
    c.write_all(line.as_bytes()).unwrap();
    let mut buf = vec![0u8; 4096];
    let n = c.read(&mut buf).unwrap();
    buf.truncate(n);
    buf
}

#[test]
fn a_session_through_the_proxy_is_forwarded_unchanged_and_replays_as_consistent() {
    let spec = pmacwd_specs::Spec::embedded().unwrap();
    let model = pmacwd_specs::config::ModelConfig::from_spec(
        &spec,
        pmacwd_emulator::card::DEFAULT_CONFIGURATION,
        &spec.profiles.default_profile(),
    )
    .unwrap();
    let card = Card::default_card(Clock::Wall { start: Instant::now(), servo_hz: model.servo_hz });
    let server = Server::start(card, ServeOptions::free_loopback_port(8)).unwrap();

    // Taken before the recorder's clock starts, so that the session's length bounds the
    // cycles the capture counts.
    let started = Instant::now();
    let path = std::env::temp_dir().join(format!("pmacwd-record-test-{}.jsonl", std::process::id()));
    let timing = Recorder::timing(model.servo_hz, false);
    let out: Box<dyn Write + Send> = Box::new(std::fs::File::create(&path).unwrap());
    let capture = CaptureWriter::new(out, "proxy test", pmacwd_emulator::card::DEFAULT_CONFIGURATION, timing).unwrap();
    let options = RecordOptions {
        listen: "127.0.0.1:0".parse().unwrap(),
        target: server.local_addr.to_string(),
        control: None,
        servo_hz: model.servo_hz,
        virtual_time: false,
        silence: Duration::from_millis(200),
        sessions: Some(1),
        verbose: false,
        thread_stack_bytes: None,
    };
    let proxy = Proxy::start(Recorder::new(capture, model.servo_hz, false).unwrap(), options).unwrap();

    {
        let mut c = TcpStream::connect(proxy.local_addr).unwrap();
        c.set_read_timeout(Some(Duration::from_secs(5))).unwrap();
        assert_eq!(ask(&mut c, "i6=1 i3=2 ver"), b"1.947\r\x06");
        assert_eq!(ask(&mut c, "I130=5 I130"), b"5\r\x06");
        std::thread::sleep(Duration::from_millis(100));
        assert_eq!(ask(&mut c, "RHY:$25 I40").last(), Some(&0x06));
        assert_eq!(ask(&mut c, "ZZZ"), b"\x07ERR003\r");
    }
    let (exchanges, _, notes) = proxy.wait().unwrap();
    let elapsed = started.elapsed().as_secs_f64();
    assert_eq!(exchanges, 4);
    assert!(notes.is_empty(), "{notes:?}");

    let text = std::fs::read_to_string(&path).unwrap();
    let trace = pmacwd_trace::jsonl::read_all(&path, text.as_bytes()).unwrap();
    // Time from the proxy's clock: about 2,250 cycles a second, at most the session's length,
    // written as ranges (`elapsed`) since a host's clock is not exact to the servo cycle.
    let (low, high): (u64, u64) = trace
        .steps
        .iter()
        .map(|s| match s.event {
            TraceEvent::Run { cycles } => (u64::from(cycles), u64::from(cycles)),
            TraceEvent::Elapsed { cycles_min, cycles_max } => {
                (u64::from(cycles_min), cycles_max.map_or(u64::MAX, u64::from))
            }
            _ => (0, 0),
        })
        .fold((0, 0), |(a, b), (l, h)| (a + l, b.saturating_add(h)));
    assert!(high >= 200 && low as f64 <= elapsed * 2250.0 + 1.0, "{low}..{high} cycles in {elapsed:.3} s");
    // Y:$25 is kept as a note: a host clock is not exact to the servo cycle.
    assert!(text.contains("not exact to a servo cycle"), "{text}");
    assert_explained_by_default(&spec, &path);
    std::fs::remove_file(&path).ok();
}

/// `pmacwd replay` finds the capture explained under the default profile's readings.
fn assert_explained_by_default(spec: &pmacwd_specs::Spec, path: &std::path::Path) {
    use pmacwd_capture::explain::report;
    let r = report::explain(spec, path, None).unwrap();
    let default = spec.profiles.default_profile().name;
    assert!(r.profiles.iter().any(|(name, _, explains)| *name == default && *explains), "{}", report::to_text(&r));
}

/// The capture's command steps as (command, expected reply), in order.
fn recorded_replies(trace: &pmacwd_trace::Trace) -> Vec<(String, Option<String>)> {
    trace
        .steps
        .iter()
        .filter_map(|s| match &s.event {
            TraceEvent::Model(pmacwd_specs::vocab::event::Event::Command(c)) => {
                Some((c.to_string(), s.expect.reply.clone()))
            }
            _ => None,
        })
        .collect()
}

/// What a capture writes for a reply the client received (`None`: it gave up).
fn as_recorded(reply: Option<&[u8]>) -> String {
    match reply {
        None => "(silence)".into(),
        Some(b"\x06") => "(ack)".into(),
        Some(b) if b.first() == Some(&0x07) => String::from_utf8_lossy(&b[1..b.len() - 1]).into_owned(),
        Some(b) => String::from_utf8_lossy(&b[..b.len() - 2]).into_owned(),
    }
}

/// Sends one line and reads its reply, giving up after `patience` (as a host does with a
/// card that went silent).
fn ask_or_give_up(c: &mut TcpStream, line: &str, patience: Duration) -> Option<Vec<u8>> {
    c.set_read_timeout(Some(patience)).unwrap();
    c.write_all(&Header::getresponse(line.len() as u16).to_bytes()).unwrap();
    c.write_all(line.as_bytes()).unwrap();
    let mut reply = Vec::new();
    let mut buf = [0u8; 4096];
    loop {
        match c.read(&mut buf) {
            Ok(0) => panic!("the proxy closed the session"),
            Ok(n) => {
                reply.extend_from_slice(&buf[..n]);
                let ends =
                    reply.last() == Some(&0x06) || (reply.first() == Some(&0x07) && reply.last() == Some(&b'\r'));
                if ends {
                    return Some(reply);
                }
            }
            Err(e) if matches!(e.kind(), std::io::ErrorKind::WouldBlock | std::io::ErrorKind::TimedOut) => {
                assert!(reply.is_empty(), "a partial reply {reply:?} to `{line}`");
                return None;
            }
            Err(e) => panic!("{e}"),
        }
    }
}

struct ControlClient(std::io::BufReader<TcpStream>);

impl ControlClient {
    fn send(&mut self, line: &str) -> String {
        use std::io::BufRead;
        writeln!(self.0.get_mut(), "{line}").unwrap();
        let mut reply = String::new();
        self.0.read_line(&mut reply).unwrap();
        assert!(reply.starts_with("ok"), "control `{line}`: {reply}");
        reply
    }
}

#[test]
fn every_recorded_reply_is_the_one_the_client_received_however_fast_or_impatient_the_client() {
    // Why: the proxy pairs reply bytes with requests. A client that sends its next command the
    // moment a reply arrives, or gives up on a silent card before the proxy's silence timeout
    // and then resets the card, must still find each reply in the capture under the command
    // that got it, and the reset after the silences it followed. Otherwise `replay` judges a
    // healthy session as unexplained. Hundreds of back-to-back exchanges make a race show.
    let spec = pmacwd_specs::Spec::embedded().unwrap();
    let model = pmacwd_specs::config::ModelConfig::from_spec(
        &spec,
        pmacwd_emulator::card::DEFAULT_CONFIGURATION,
        &spec.profiles.default_profile(),
    )
    .unwrap();
    let options = ServeOptions { control: Some("127.0.0.1:0".parse().unwrap()), ..ServeOptions::free_loopback_port(8) };
    let server = Server::start(Card::default_card(Clock::Virtual), options).unwrap();
    let path = std::env::temp_dir().join(format!("pmacwd-record-order-{}.jsonl", std::process::id()));
    let out: Box<dyn Write + Send> = Box::new(std::fs::File::create(&path).unwrap());
    let capture = CaptureWriter::new(
        out,
        "order test",
        pmacwd_emulator::card::DEFAULT_CONFIGURATION,
        Recorder::timing(model.servo_hz, true),
    )
    .unwrap();
    let silence = Duration::from_millis(150);
    let options = RecordOptions {
        listen: "127.0.0.1:0".parse().unwrap(),
        target: server.local_addr.to_string(),
        control: Some(("127.0.0.1:0".parse().unwrap(), server.control_addr.unwrap().to_string())),
        servo_hz: model.servo_hz,
        virtual_time: true,
        silence,
        sessions: Some(1),
        verbose: false,
        thread_stack_bytes: None,
    };
    let proxy = Proxy::start(Recorder::new(capture, model.servo_hz, true).unwrap(), options).unwrap();
    let mut control = ControlClient(std::io::BufReader::new(TcpStream::connect(proxy.control_addr.unwrap()).unwrap()));

    let mut received: Vec<(String, String)> = Vec::new();
    {
        let mut c = TcpStream::connect(proxy.local_addr).unwrap();
        c.set_nodelay(true).unwrap();
        let patient = Duration::from_secs(5);
        let mut exchange = |c: &mut TcpStream, line: &str, patience: Duration| {
            let reply = ask_or_give_up(c, line, patience);
            received.push((line.to_string(), as_recorded(reply.as_deref())));
        };
        exchange(&mut c, "I6=1", patient);
        exchange(&mut c, "I3=2", patient);
        for round in 0..3 {
            // Back to back: acknowledgements, errors, data, in a mix that pairs wrongly
            // if one reply is taken for another.
            for i in 0..100 {
                let line = match i % 5 {
                    0 => format!("I130={}", round * 1000 + i),
                    1 => "I130".to_string(),
                    2 => "ZZZ".to_string(),
                    3 => "???".to_string(),
                    _ => format!("I41={}", i % 2),
                };
                exchange(&mut c, &line, patient);
            }
            // Trip the card, then give up on it sooner than the proxy's silence timeout,
            // several times, and reset it straight away.
            control.send("starve");
            control.send("step 20000");
            for line in ["???", "I130", "???"] {
                exchange(&mut c, line, silence / 5);
            }
            control.send("plc0 30");
            control.send("init");
        }
        // After INIT/ the card has its saved I130 again, which the model does not know: written
        // first, its read is compared.
        exchange(&mut c, "I130=7", patient);
        exchange(&mut c, "I130", patient);
    }
    drop(control);
    let (exchanges, _, notes) = proxy.wait().unwrap();
    assert_eq!(exchanges, received.len() as u64);
    assert!(notes.is_empty(), "{notes:?}");

    let text = std::fs::read_to_string(&path).unwrap();
    let trace = pmacwd_trace::jsonl::read_all(&path, text.as_bytes()).unwrap();
    let recorded = recorded_replies(&trace);
    assert_eq!(recorded.len(), received.len());
    for (i, ((line, got), (command, expect))) in received.iter().zip(&recorded).enumerate() {
        assert!(line.eq_ignore_ascii_case(command), "exchange {i}: sent `{line}`, recorded `{command}`");
        assert_eq!(expect.as_deref(), Some(got.as_str()), "exchange {i} `{line}`: the client received `{got}`");
    }
    // Each reset comes after the three silences that preceded it.
    let order: Vec<&str> = trace
        .steps
        .iter()
        .filter_map(|s| match (&s.event, s.expect.reply.as_deref()) {
            (TraceEvent::Model(pmacwd_specs::vocab::event::Event::Reset(_)), _) => Some("reset"),
            (_, Some("(silence)")) => Some("silence"),
            _ => None,
        })
        .collect();
    assert_eq!(order, ["silence", "silence", "silence", "reset"].repeat(3));
    assert_explained_by_default(&spec, &path);
    std::fs::remove_file(&path).ok();
}

#[test]
fn a_session_whose_thread_cannot_start_is_closed_and_the_proxy_keeps_accepting() {
    // When the system refuses a session's thread (here: a stack larger than the address
    // space), that client's connection is closed and the proxy goes on accepting. Before, the
    // accept thread panicked and every later client waited in the listen backlog, unanswered.
    let server = Server::start(Card::default_card(Clock::Virtual), ServeOptions::free_loopback_port(8)).unwrap();
    let out: Box<dyn Write + Send> = Box::new(Vec::new());
    let capture = CaptureWriter::new(
        out,
        "spawn test",
        pmacwd_emulator::card::DEFAULT_CONFIGURATION,
        Recorder::timing(2250, false),
    )
    .unwrap();
    let options = RecordOptions {
        listen: "127.0.0.1:0".parse().unwrap(),
        target: server.local_addr.to_string(),
        control: None,
        servo_hz: 2250,
        virtual_time: false,
        silence: Duration::from_millis(200),
        sessions: None,
        verbose: false,
        thread_stack_bytes: Some(1 << 60),
    };
    let proxy = Proxy::start(Recorder::new(capture, 2250, false).unwrap(), options).unwrap();
    for k in 0..3 {
        let mut c = TcpStream::connect(proxy.local_addr).unwrap();
        c.set_read_timeout(Some(Duration::from_secs(5))).unwrap();
        c.write_all(&Header::getresponse(3).to_bytes()).unwrap();
        let _ = c.write_all(b"???");
        let mut b = [0u8; 16];
        let r = c.read(&mut b);
        assert!(
            matches!(r, Ok(0)) || matches!(&r, Err(e) if e.kind() == std::io::ErrorKind::ConnectionReset),
            "client {k}: closed, not left waiting: {r:?}"
        );
    }
    server.stop();
}

/// A capture written to memory that the test can read while the proxy still holds the writer.
#[derive(Clone, Default)]
struct SharedBuffer(std::sync::Arc<std::sync::Mutex<Vec<u8>>>);

impl Write for SharedBuffer {
    fn write(&mut self, b: &[u8]) -> std::io::Result<usize> {
        self.0.lock().unwrap().extend_from_slice(b);
        Ok(b.len())
    }
    fn flush(&mut self) -> std::io::Result<()> {
        Ok(())
    }
}

/// A proxy in front of an emulator in virtual time (control interface proxied too), writing
/// its capture to the returned buffer; it stops after one host session.
fn proxy_to_an_emulator() -> (Server, Proxy, SharedBuffer) {
    let options = ServeOptions { control: Some("127.0.0.1:0".parse().unwrap()), ..ServeOptions::free_loopback_port(8) };
    let server = Server::start(Card::default_card(Clock::Virtual), options).unwrap();
    let buffer = SharedBuffer::default();
    let out: Box<dyn Write + Send> = Box::new(buffer.clone());
    let capture = CaptureWriter::new(
        out,
        "bounds test",
        pmacwd_emulator::card::DEFAULT_CONFIGURATION,
        Recorder::timing(2250, true),
    )
    .unwrap();
    let options = RecordOptions {
        listen: "127.0.0.1:0".parse().unwrap(),
        target: server.local_addr.to_string(),
        control: Some(("127.0.0.1:0".parse().unwrap(), server.control_addr.unwrap().to_string())),
        servo_hz: 2250,
        virtual_time: true,
        silence: Duration::from_millis(500),
        sessions: Some(1),
        verbose: false,
        thread_stack_bytes: None,
    };
    let proxy = Proxy::start(Recorder::new(capture, 2250, true).unwrap(), options).unwrap();
    (server, proxy, buffer)
}

#[test]
fn forwarded_requests_the_capture_does_not_record_are_counted_not_noted_one_by_one() {
    // A host polling READREADY made one note per request, each waiting in memory for the next
    // step (118 MB for a million). They are now counted by request code and written as one
    // note with the next exchange, and what follows the last exchange as one note at the end.
    const POLLS: usize = 10_000;
    let (server, proxy, buffer) = proxy_to_an_emulator();
    let readready: [u8; 8] = [0xC0, 0xC2, 0, 0, 0, 0, 0, 2];
    {
        let mut c = TcpStream::connect(proxy.local_addr).unwrap();
        c.set_read_timeout(Some(Duration::from_secs(10))).unwrap();
        for _ in 0..2 {
            // Sent at once, then their 2-byte replies read back.
            c.write_all(&readready.repeat(POLLS)).unwrap();
            let mut replies = vec![0u8; 2 * POLLS];
            c.read_exact(&mut replies).unwrap();
            assert!(replies.chunks(2).all(|r| r == [0, 0]), "nothing waiting");
            assert_eq!(ask(&mut c, "???"), b"001000000000\r\x06");
        }
        c.write_all(&readready.repeat(3)).unwrap();
        let mut replies = [0u8; 6];
        c.read_exact(&mut replies).unwrap();
    }
    let (exchanges, _, left) = proxy.wait().unwrap();
    assert_eq!(exchanges, 2);
    assert_eq!(left, ["requests forwarded, not recorded (code x count): 0xC2 x 3"]);
    let text = String::from_utf8(buffer.0.lock().unwrap().clone()).unwrap();
    assert!(text.len() < 2_000, "{} bytes of capture", text.len());
    assert_eq!(text.matches("0xC2 x 10000").count(), 2, "{text}");
    server.stop();
}

#[test]
fn a_control_line_without_its_newline_closes_that_control_session_with_an_error() {
    // The proxy buffered a control line until its newline came, without limit (528 MB for a
    // client that never sent one). It now reads at most CONTROL_LINE_BYTES_MAX bytes, then
    // answers with an error line and closes that control connection; the proxy goes on.
    use pmacwd_emulator::control::CONTROL_LINE_BYTES_MAX;
    let (server, proxy, _) = proxy_to_an_emulator();
    let mut c = TcpStream::connect(proxy.control_addr.unwrap()).unwrap();
    c.set_read_timeout(Some(Duration::from_secs(5))).unwrap();
    // Twice the maximum with no newline, in one write: the proxy reads it all before it
    // closes, so that the close is a clean end and not a reset that could drop the reply.
    // (An endless line is `control::read_line_max`'s unit test.)
    c.write_all(&vec![b'x'; 2 * CONTROL_LINE_BYTES_MAX]).unwrap();
    let mut reply = String::new();
    let _ = c.read_to_string(&mut reply);
    assert_eq!(reply, format!("error: a control line is at most {CONTROL_LINE_BYTES_MAX} bytes\n"));
    let mut again = std::io::BufReader::new(TcpStream::connect(proxy.control_addr.unwrap()).unwrap());
    again.get_mut().write_all(b"state\n").unwrap();
    let mut state = String::new();
    std::io::BufRead::read_line(&mut again, &mut state).unwrap();
    assert!(state.starts_with("ok tripped=false"), "{state}");
    server.stop();
}

#[test]
fn a_reply_longer_than_the_proxy_keeps_is_forwarded_whole_and_recorded_cut() {
    // The proxy kept every byte of a reply until its end came: a card (or anything at the
    // target) that never ends its reply grew the session's memory without limit. It now keeps
    // REPLY_RECORDED_BYTES_MAX bytes for the capture and counts the rest, which it still
    // forwards unchanged. A fake card answers one line with 300 KiB, then CR and ACK.
    use pmacwd_emulator::proxy::REPLY_RECORDED_BYTES_MAX;
    const REPLY_BYTES: usize = 300 * 1024;
    let card = std::net::TcpListener::bind("127.0.0.1:0").unwrap();
    let target = card.local_addr().unwrap().to_string();
    let fake = std::thread::spawn(move || {
        let (mut c, _) = card.accept().unwrap();
        let mut request = [0u8; 11];
        c.read_exact(&mut request).unwrap();
        let mut reply = vec![b'A'; REPLY_BYTES];
        reply.extend_from_slice(b"\r\x06");
        c.write_all(&reply).unwrap();
        let _ = c.read_to_end(&mut Vec::new());
    });
    let buffer = SharedBuffer::default();
    let out: Box<dyn Write + Send> = Box::new(buffer.clone());
    let capture = CaptureWriter::new(
        out,
        "long reply",
        pmacwd_emulator::card::DEFAULT_CONFIGURATION,
        Recorder::timing(2250, false),
    )
    .unwrap();
    let options = RecordOptions {
        listen: "127.0.0.1:0".parse().unwrap(),
        target,
        control: None,
        servo_hz: 2250,
        virtual_time: false,
        silence: Duration::from_secs(2),
        sessions: Some(1),
        verbose: false,
        thread_stack_bytes: None,
    };
    let proxy = Proxy::start(Recorder::new(capture, 2250, false).unwrap(), options).unwrap();
    {
        let mut c = TcpStream::connect(proxy.local_addr).unwrap();
        c.set_read_timeout(Some(Duration::from_secs(10))).unwrap();
        c.write_all(&Header::getresponse(3).to_bytes()).unwrap();
        c.write_all(b"???").unwrap();
        let mut got = vec![0u8; REPLY_BYTES + 2];
        c.read_exact(&mut got).unwrap();
        assert!(got.ends_with(b"A\r\x06"), "forwarded whole");
    }
    let (exchanges, _, _) = proxy.wait().unwrap();
    fake.join().unwrap();
    assert_eq!(exchanges, 1);
    let text = String::from_utf8(buffer.0.lock().unwrap().clone()).unwrap();
    let dropped = REPLY_BYTES + 2 - REPLY_RECORDED_BYTES_MAX;
    assert!(text.contains(&format!("had {dropped} more bytes than the {REPLY_RECORDED_BYTES_MAX} kept")), "{text}");
    assert!(text.len() < 8_000, "the capture keeps notes, not the reply: {} bytes", text.len());
}

#[test]
fn the_emulator_s_own_capture_of_a_refused_i3_write_replays_as_consistent() {
    // `serve --record` with a client that writes I3=4 (refused by the emulator, MODEL; taken
    // by the model) and reads I3 back: the refused write is left out of the capture, so the
    // replay's model holds the I3 the card held and the read compares equal.
    let spec = pmacwd_specs::Spec::embedded().unwrap();
    let path = std::env::temp_dir().join(format!("pmacwd-record-i3-{}.jsonl", std::process::id()));
    let out: Box<dyn Write + Send> = Box::new(std::fs::File::create(&path).unwrap());
    let mut card = Card::default_card(Clock::Virtual);
    card.record(
        CaptureWriter::new(
            out,
            "I3=4",
            pmacwd_emulator::card::DEFAULT_CONFIGURATION,
            pmacwd_emulator::capture::Timing::Exact,
        )
        .unwrap(),
    )
    .unwrap();
    let server = Server::start(card, ServeOptions::free_loopback_port(8)).unwrap();
    {
        let mut c = TcpStream::connect(server.local_addr).unwrap();
        c.set_read_timeout(Some(Duration::from_secs(5))).unwrap();
        assert_eq!(ask(&mut c, "i6=1 i3=2 ver"), b"1.947\r\x06");
        assert_eq!(ask(&mut c, "I3=4"), b"\x07ERR003\r");
        assert_eq!(ask(&mut c, "I3"), b"2\r\x06");
    }
    assert!(server.with_card(|c| c.finish_recording()).is_empty());
    server.stop();
    assert_explained_by_default(&spec, &path);
    std::fs::remove_file(&path).ok();
}

#[test]
fn the_emulator_s_capture_of_the_grammar_s_new_commands_replays_as_consistent() {
    // Issue 28: `I130,4,100`, expressions, `I222=0.5`, `cpu`, `I130=*`, axis definitions and
    // their report, the EPICS driver's feedrate with a fraction and `Q71=Q81`, each answered
    // by the emulator and each a step the model follows or takes as the card's own, so that
    // `serve --record` writes a capture `replay` explains.
    let spec = pmacwd_specs::Spec::embedded().unwrap();
    let path = std::env::temp_dir().join(format!("pmacwd-record-grammar-{}.jsonl", std::process::id()));
    let out: Box<dyn Write + Send> = Box::new(std::fs::File::create(&path).unwrap());
    let mut card = Card::default_card(Clock::Virtual);
    card.record(
        CaptureWriter::new(
            out,
            "grammar",
            pmacwd_emulator::card::DEFAULT_CONFIGURATION,
            pmacwd_emulator::capture::Timing::Exact,
        )
        .unwrap(),
    )
    .unwrap();
    let server = Server::start(card, ServeOptions::free_loopback_port(8)).unwrap();
    {
        let mut c = TcpStream::connect(server.local_addr).unwrap();
        c.set_read_timeout(Some(Duration::from_secs(5))).unwrap();
        assert_eq!(ask(&mut c, "i6=1 i3=2 ver"), b"1.947\r\x06");
        assert_eq!(ask(&mut c, "cid cpu"), b"603382\rDSP56303\r\x06");
        assert_eq!(ask(&mut c, "I130=1000 I230=2 I330=3 I430=4"), b"\x06");
        assert_eq!(ask(&mut c, "I130,4,100"), b"1000\r2\r3\r4\r\x06");
        assert_eq!(ask(&mut c, "I130=1.25*I130 I130"), b"1250\r\x06");
        assert_eq!(ask(&mut c, "M162=1000/0.0009765625 M162"), b"1024000\r\x06");
        assert_eq!(ask(&mut c, "I222=0.5 I222"), b"0.5\r\x06");
        assert_eq!(ask(&mut c, "I130=* I130"), b"2000\r\x06", "the factory default (variables.yaml)");
        assert_eq!(ask(&mut c, "&1#1->1000X &1#1->, #2->"), b"1000X\r0\r\x06");
        assert_eq!(ask(&mut c, "&1%100.000000 &1%"), b"100\r\x06");
        assert_eq!(ask(&mut c, "&1A Q81=7 Q71=Q81 Q71"), b"7\r\x06");
        assert_eq!(ask(&mut c, "I40=5*2 I40"), b"10\r\x06");
        assert_eq!(ask(&mut c, "???").len(), 14, "12 hex digits, CR, ACK");
    }
    assert!(server.with_card(|c| c.finish_recording()).is_empty());
    server.stop();
    let text = std::fs::read_to_string(&path).unwrap();
    assert!(!text.contains("left out"), "every command is a step: {text}");
    assert_explained_by_default(&spec, &path);
    std::fs::remove_file(&path).ok();
}

#[test]
fn the_emulator_s_capture_of_motors_that_move_replays_as_consistent() {
    // Issue 30: the trajectories are a layer within the core's motor states and send the core
    // nothing a host did not send, so a session that moves, homes, stops and kills motors is
    // still a capture the model explains: lockstep of the core and the model is kept.
    use pmacwd_emulator::control::Control;
    let spec = pmacwd_specs::Spec::embedded().unwrap();
    let path = std::env::temp_dir().join(format!("pmacwd-record-motion-{}.jsonl", std::process::id()));
    let out: Box<dyn Write + Send> = Box::new(std::fs::File::create(&path).unwrap());
    let mut card = Card::default_card(Clock::Virtual);
    card.record(
        CaptureWriter::new(
            out,
            "motion",
            pmacwd_emulator::card::DEFAULT_CONFIGURATION,
            pmacwd_emulator::capture::Timing::Exact,
        )
        .unwrap(),
    )
    .unwrap();
    let server = Server::start(card, ServeOptions::free_loopback_port(8)).unwrap();
    let step = |cycles: u32| assert!(server.with_card(|c| c.control(Control::Step { cycles })).starts_with("ok"));
    {
        let mut c = TcpStream::connect(server.local_addr).unwrap();
        c.set_read_timeout(Some(Duration::from_secs(5))).unwrap();
        assert_eq!(ask(&mut c, "i6=1 i3=2 ver"), b"1.947\r\x06");
        assert_eq!(ask(&mut c, "#1 J/ #2 J/"), b"\x06");
        assert_eq!(ask(&mut c, "I122=2.000000 I120=100.000000 #1 J=2000.00 #2J+"), b"\x06");
        step(1000);
        assert_eq!(ask(&mut c, "#2 J/ M240=1"), b"\x06");
        step(3000);
        // Arrived: activated, amplifier on, integration mode, desired velocity zero; in position.
        assert_eq!(ask(&mut c, "#1P #1?"), b"2000\r892000008001\r\x06");
        assert!(
            server.with_card(|c| c.control(Control::parse("home-flag 2 100000").unwrap())) == "ok",
            "ahead of motor 2"
        );
        assert_eq!(ask(&mut c, "#2 HOME"), b"\x06");
        step(10_000);
        assert_eq!(ask(&mut c, "#2P"), b"0\r\x06");
        assert_eq!(ask(&mut c, "#1J+ &1A"), b"\x06");
        step(500);
        assert_eq!(ask(&mut c, "#1K #2K ???").len(), 14);
    }
    assert!(server.with_card(|c| c.finish_recording()).is_empty());
    server.stop();
    assert_explained_by_default(&spec, &path);
    std::fs::remove_file(&path).ok();
}

#[test]
fn the_emulator_s_capture_of_a_motion_program_replays_as_consistent() {
    // Issue 30: a program's end is heard by the core as `Q`, and `&1E` is the core's and the
    // model's `E` (issue 36: each killed motor of &1 closes its loop); the capture records
    // each as an exchange, so that the model follows the core: a K refused while the program
    // runs (ERR001, UM p.319) and accepted once it has ended is explained.
    use pmacwd_emulator::control::Control;
    let spec = pmacwd_specs::Spec::embedded().unwrap();
    let path = std::env::temp_dir().join(format!("pmacwd-record-program-{}.jsonl", std::process::id()));
    let out: Box<dyn Write + Send> = Box::new(std::fs::File::create(&path).unwrap());
    let mut card = Card::default_card(Clock::Virtual);
    card.record(
        CaptureWriter::new(
            out,
            "program",
            pmacwd_emulator::card::DEFAULT_CONFIGURATION,
            pmacwd_emulator::capture::Timing::Exact,
        )
        .unwrap(),
    )
    .unwrap();
    let server = Server::start(card, ServeOptions::free_loopback_port(8)).unwrap();
    let step = |cycles: u32| assert!(server.with_card(|c| c.control(Control::Step { cycles })).starts_with("ok"));
    {
        let mut c = TcpStream::connect(server.local_addr).unwrap();
        c.set_read_timeout(Some(Duration::from_secs(5))).unwrap();
        assert_eq!(ask(&mut c, "i6=1 i3=2 ver"), b"1.947\r\x06");
        for line in ["OPEN PROG 10", "CLEAR", "LINEAR ABS TM(Q70)", "X(Q77)", "DWELL0", "CLOSE", "&1#1->1000X"] {
            assert_eq!(ask(&mut c, line), b"\x06", "{line}");
        }
        assert_eq!(ask(&mut c, "LIST PROG 10"), b"LINEAR ABS TM(Q70)\rX(Q77)\rDWELL0\r\x06");
        assert_eq!(ask(&mut c, "&1E"), b"\x06");
        assert_eq!(ask(&mut c, "&1Q70=200 Q77=1 B10R"), b"\x06");
        step(100);
        assert_eq!(ask(&mut c, "#1K"), b"\x07ERR001\r", "the program runs");
        step(1000);
        assert_eq!(ask(&mut c, "#1P"), b"1000\r\x06");
        assert_eq!(ask(&mut c, "#1K ???").len(), 14, "the program has ended: K is taken");
    }
    assert!(server.with_card(|c| c.finish_recording()).is_empty());
    server.stop();
    let text = std::fs::read_to_string(&path).unwrap();
    assert!(text.contains("&1Q") && text.contains("&1E") && !text.contains("#8J/"), "{text}");
    assert_explained_by_default(&spec, &path);
    std::fs::remove_file(&path).ok();
}

/// Sends one control line and reads its reply line.
fn control_line(addr: std::net::SocketAddr, line: &str) -> String {
    use std::io::BufRead;
    let c = TcpStream::connect(addr).unwrap();
    c.set_read_timeout(Some(Duration::from_secs(20))).unwrap();
    (&c).write_all(format!("{line}\n").as_bytes()).unwrap();
    let mut reply = String::new();
    std::io::BufReader::new(&c).read_line(&mut reply).unwrap();
    reply
}

/// The servo cycles of a capture's `servo` steps, each at most STEP_CYCLES_MAX (the reader
/// refuses the capture otherwise).
fn servo_cycles(path: &std::path::Path, text: &str) -> u64 {
    let trace = pmacwd_trace::jsonl::read_all(path, text.as_bytes()).unwrap_or_else(|e| panic!("{e}\n{text}"));
    trace
        .steps
        .iter()
        .filter_map(|s| match s.event {
            TraceEvent::Model(pmacwd_specs::vocab::event::Event::Servo { cycles }) => Some(u64::from(cycles)),
            _ => None,
        })
        .sum()
}

#[test]
fn a_servo_control_longer_than_a_step_is_captured_as_steps_the_capture_s_own_replay_reads() {
    // Issue 33: `serve --record` and `record` wrote `servo 40000000` as one step of 40 million
    // cycles, which a trace reader (and so their own `replay`) refuses past 2^24 (exit 2).
    // Both now write it as steps of at most STEP_CYCLES_MAX; `servo 0` writes no step.
    let cycles = 2 * pmacwd_trace::STEP_CYCLES_MAX + 5;
    // The emulator's own capture.
    let path = std::env::temp_dir().join(format!("pmacwd-servo-steps-{}.jsonl", std::process::id()));
    let out: Box<dyn Write + Send> = Box::new(std::fs::File::create(&path).unwrap());
    let mut card = Card::default_card(Clock::Virtual);
    card.record(
        CaptureWriter::new(
            out,
            "servo",
            pmacwd_emulator::card::DEFAULT_CONFIGURATION,
            pmacwd_emulator::capture::Timing::Exact,
        )
        .unwrap(),
    )
    .unwrap();
    let options = ServeOptions { control: Some("127.0.0.1:0".parse().unwrap()), ..ServeOptions::free_loopback_port(8) };
    let server = Server::start(card, options).unwrap();
    let control = server.control_addr.unwrap();
    assert_eq!(control_line(control, &format!("servo {cycles}")), format!("ok {{\"servo\":{cycles}}}\n"));
    assert_eq!(control_line(control, "servo 0"), "ok {\"servo\":0}\n");
    server.with_card(|c| c.finish_recording());
    server.stop();
    let text = std::fs::read_to_string(&path).unwrap();
    assert_eq!(servo_cycles(&path, &text), u64::from(cycles), "{text}");
    std::fs::remove_file(&path).ok();
    // The recording proxy's, in front of an emulator that answers with the whole step.
    let (server, proxy, buffer) = proxy_to_an_emulator();
    let reply = control_line(proxy.control_addr.unwrap(), &format!("servo {cycles}"));
    assert_eq!(reply, format!("ok {{\"servo\":{cycles}}}\n"));
    drop(TcpStream::connect(proxy.local_addr).unwrap());
    let (_, _, left) = proxy.wait().unwrap();
    server.stop();
    assert!(left.is_empty(), "{left:?}");
    let text = String::from_utf8(buffer.0.lock().unwrap().clone()).unwrap();
    assert_eq!(servo_cycles(std::path::Path::new("capture.jsonl"), &text), u64::from(cycles), "{text}");
}

#[test]
fn a_host_that_does_not_wait_for_a_silent_card_is_closed_past_the_bound_on_waiting_requests() {
    // Issue 33: `record` kept every request of a host that does not wait for its replies, each
    // resolved only after `silence` when the card is silent: memory grew without bound. With
    // WAITING_BYTES_MAX waiting and the oldest silent for half the silence, the session is now
    // closed, and the capture says so. (A host pipelining to a card that answers is only
    // slowed: forwarded_requests_the_capture_does_not_record_are_counted_not_noted_one_by_one.)
    use pmacwd_emulator::proxy::{AWAITING_BYTES, WAITING_BYTES_MAX};
    // `???` requests fill the queue at this many.
    let waiting = WAITING_BYTES_MAX.div_ceil(AWAITING_BYTES + 3);
    // A silent card: it reads every request and answers none.
    let card = std::net::TcpListener::bind("127.0.0.1:0").unwrap();
    let card_addr = card.local_addr().unwrap();
    let silent = std::thread::spawn(move || {
        let (mut c, _) = card.accept().unwrap();
        let _ = std::io::copy(&mut c, &mut std::io::sink());
    });
    let buffer = SharedBuffer::default();
    let out: Box<dyn Write + Send> = Box::new(buffer.clone());
    let capture = CaptureWriter::new(
        out,
        "silent card",
        pmacwd_emulator::card::DEFAULT_CONFIGURATION,
        Recorder::timing(2250, false),
    )
    .unwrap();
    let options = RecordOptions {
        listen: "127.0.0.1:0".parse().unwrap(),
        target: card_addr.to_string(),
        control: None,
        servo_hz: 2250,
        virtual_time: false,
        // Long enough that no request is resolved as silent before the session closes, at
        // half of it.
        silence: Duration::from_secs(4),
        sessions: Some(1),
        verbose: false,
        thread_stack_bytes: None,
    };
    let proxy = Proxy::start(Recorder::new(capture, 2250, false).unwrap(), options).unwrap();
    let mut c = TcpStream::connect(proxy.local_addr).unwrap();
    c.set_read_timeout(Some(Duration::from_secs(20))).unwrap();
    let mut request = Header::getresponse(3).to_bytes().to_vec();
    request.extend_from_slice(b"???");
    // Sent without waiting; the proxy closes the session at the request past the bound, so
    // a write may fail once it has.
    for _ in 0..waiting + 10 {
        if c.write_all(&request).is_err() {
            break;
        }
    }
    let mut rest = Vec::new();
    let closed = c.read_to_end(&mut rest);
    assert!(
        closed.is_ok() || closed.as_ref().is_err_and(|e| e.kind() == std::io::ErrorKind::ConnectionReset),
        "{closed:?}: the session was not closed"
    );
    assert!(rest.is_empty(), "a silent card's proxy answered {rest:?}");
    let (exchanges, _, left) = proxy.wait().unwrap();
    silent.join().unwrap();
    assert_eq!(exchanges, waiting as u64, "the waiting requests are recorded, as silent");
    let text = String::from_utf8(buffer.0.lock().unwrap().clone()).unwrap();
    let said = format!(
        "{waiting} requests of a host session ({} bytes, at most {WAITING_BYTES_MAX}) were waiting",
        waiting * (AWAITING_BYTES + 3)
    );
    assert!(text.contains(&said), "the capture does not say why the session closed: {left:?}");
}
