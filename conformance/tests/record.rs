//! `pmacwd record` on the wall clock: the proxy forwards bytes unchanged, times the exchanges
//! with its own clock, and writes a capture that replays as consistent.

use pmacwd_conformance::emulator::capture::CaptureWriter;
use pmacwd_conformance::emulator::card::{Card, Clock};
use pmacwd_conformance::emulator::protocol::Header;
use pmacwd_conformance::emulator::proxy::{Proxy, RecordOptions, Recorder};
use pmacwd_conformance::emulator::server::{ServeOptions, Server};
use pmacwd_conformance::trace::TraceEvent;
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
        pmacwd_model::config::ModelConfig::from_spec(&spec, "i40-zero", &spec.profiles.default_profile()).unwrap();
    let card = Card::default_card(Clock::Wall { start: Instant::now(), servo_hz: model.servo_hz });
    let server = Server::start(card, ServeOptions::free_loopback_port(8)).unwrap();

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
    };
    let proxy = Proxy::start(Recorder::new(capture, model.servo_hz, false), options).unwrap();

    let started = Instant::now();
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
    let trace = pmacwd_conformance::trace_jsonl::read_all(&path, text.as_bytes()).unwrap();
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
