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
    let model =
        pmacwd_specs::config::ModelConfig::from_spec(&spec, "i40-zero", &spec.profiles.default_profile()).unwrap();
    let card = Card::default_card(Clock::Wall { start: Instant::now(), servo_hz: model.servo_hz });
    let server = Server::start(card, ServeOptions::free_loopback_port(8)).unwrap();

    // Taken before the recorder's clock starts, so that the session's length bounds the
    // cycles the capture counts.
    let started = Instant::now();
    let path = std::env::temp_dir().join(format!("pmacwd-record-test-{}.jsonl", std::process::id()));
    let timing = Recorder::timing(model.servo_hz, false);
    let out: Box<dyn Write + Send> = Box::new(std::fs::File::create(&path).unwrap());
    let capture = CaptureWriter::new(out, "proxy test", "i40-zero", timing).unwrap();
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
    let proxy = Proxy::start(Recorder::new(capture, model.servo_hz, false), options).unwrap();

    {
        let mut c = TcpStream::connect(proxy.local_addr).unwrap();
        c.set_read_timeout(Some(Duration::from_secs(5))).unwrap();
        assert_eq!(ask(&mut c, "i6=1 i3=2 ver"), b"1.947\r\x06");
        assert_eq!(ask(&mut c, "I130=5 I130"), b"5\r\x06");
        std::thread::sleep(Duration::from_millis(100));
        assert_eq!(ask(&mut c, "RHY:$25 I40").last(), Some(&0x06));
        assert_eq!(ask(&mut c, "FOO"), b"\x07ERR003\r");
    }
    let (exchanges, _, notes) = proxy.wait().unwrap();
    let elapsed = started.elapsed().as_secs_f64();
    assert_eq!(exchanges, 4);
    assert!(notes.is_empty(), "{notes:?}");

    let text = std::fs::read_to_string(&path).unwrap();
    let trace = pmacwd_trace::jsonl::read_all(&path, text.as_bytes()).unwrap();
    // Time from the proxy's clock: about 2,250 cycles a second, at most the session's length.
    let cycles: u64 = trace
        .steps
        .iter()
        .map(|s| match s.event {
            TraceEvent::Run { cycles } => u64::from(cycles),
            _ => 0,
        })
        .sum();
    assert!(cycles >= 200 && cycles as f64 <= elapsed * 2250.0 + 1.0, "{cycles} cycles in {elapsed:.3} s");
    // Y:$25 is kept as a note: a host clock is not exact to the servo cycle.
    assert!(text.contains("not exact to a servo cycle"), "{text}");
    let report = pmacwd_conformance::replay::replay(&spec, &path).unwrap();
    let default = report.profiles.iter().find(|p| p.profile.name == model.profile.name).unwrap();
    assert!(default.consistent(), "{}", pmacwd_conformance::replay::to_text(&report, "um-215"));
    std::fs::remove_file(&path).ok();
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
    let model =
        pmacwd_specs::config::ModelConfig::from_spec(&spec, "i40-zero", &spec.profiles.default_profile()).unwrap();
    let options = ServeOptions { control: Some("127.0.0.1:0".parse().unwrap()), ..ServeOptions::free_loopback_port(8) };
    let server = Server::start(Card::default_card(Clock::Virtual), options).unwrap();
    let path = std::env::temp_dir().join(format!("pmacwd-record-order-{}.jsonl", std::process::id()));
    let out: Box<dyn Write + Send> = Box::new(std::fs::File::create(&path).unwrap());
    let capture = CaptureWriter::new(out, "order test", "i40-zero", Recorder::timing(model.servo_hz, true)).unwrap();
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
    let proxy = Proxy::start(Recorder::new(capture, model.servo_hz, true), options).unwrap();
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
                    2 => "FOO".to_string(),
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
    let report = pmacwd_conformance::replay::replay(&spec, &path).unwrap();
    let default = report.profiles.iter().find(|p| p.profile.name == model.profile.name).unwrap();
    assert!(default.consistent(), "{}", pmacwd_conformance::replay::to_text(&report, "um-215"));
    std::fs::remove_file(&path).ok();
}

#[test]
fn a_session_whose_thread_cannot_start_is_closed_and_the_proxy_keeps_accepting() {
    // When the system refuses a session's thread (here: a stack larger than the address
    // space), that client's connection is closed and the proxy goes on accepting. Before, the
    // accept thread panicked and every later client waited in the listen backlog, unanswered.
    let server = Server::start(Card::default_card(Clock::Virtual), ServeOptions::free_loopback_port(8)).unwrap();
    let out: Box<dyn Write + Send> = Box::new(Vec::new());
    let capture = CaptureWriter::new(out, "spawn test", "i40-zero", Recorder::timing(2250, false)).unwrap();
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
    let proxy = Proxy::start(Recorder::new(capture, 2250, false), options).unwrap();
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
