//! A soak of `pmacwd serve`: many host clients and a control client injecting faults for a
//! bounded time, then a check that memory stayed flat and that every client is answered
//! afterwards. It measures; it is not a timed unit test, so it is `#[ignore]`d and run by
//! hand (docs/emulator.md, "Limits", has the figures it printed):
//!
//! ```sh
//! PMACWD_SOAK_SECONDS=60 cargo test --release -p pmacwd-emulator --test soak -- --ignored --nocapture
//! ```
//!
//! What the clients do, each on its own connection, over and over: write and read back an
//! I-variable of their own (a reply meant for another client shows as a wrong value), `???`,
//! an unknown command (ERR003, and a note in the capture), READREADY, and now and then a
//! header the card cannot follow on a fresh connection (a protocol error). What the control
//! client does: starve the background until the card trips, INIT/, a checksum fault, power
//! cycles with and without reset-time faults, supply dips, load changes. While the card is
//! tripped the hosts' reads time out; a client whose read timed out starts a new connection,
//! as a host driver does. The emulator records the whole session (to nowhere), so the
//! capture's bounds are soaked too.

use pmacwd_emulator::capture::{CaptureWriter, Timing};
use pmacwd_emulator::card::{Card, Clock};
use pmacwd_emulator::protocol::Header;
use pmacwd_emulator::server::{ServeOptions, Server};
use std::io::{BufRead, BufReader, Read, Write};
use std::net::{SocketAddr, TcpStream};
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant};

/// Host clients at once: well under the 128 connections `serve` keeps by default, so what is
/// soaked is the load, not the eviction.
const CLIENTS: u16 = 50;
/// How long a host waits for a reply before it gives up on the connection (a tripped card
/// never answers).
const REPLY_TIMEOUT: Duration = Duration::from_millis(300);
/// Memory is sampled this often.
const SAMPLE_INTERVAL: Duration = Duration::from_millis(250);

/// A field of /proc/self/status in kB (`VmRSS`, `VmHWM`).
fn status_kb(field: &str) -> u64 {
    let status = std::fs::read_to_string("/proc/self/status").expect("/proc/self/status (Linux)");
    status
        .lines()
        .find_map(|l| l.strip_prefix(field)?.strip_prefix(':'))
        .and_then(|v| v.trim().trim_end_matches("kB").trim().parse().ok())
        .unwrap_or_else(|| panic!("{field} in /proc/self/status"))
}

#[derive(Default)]
struct Counts {
    answered: AtomicU64,
    timed_out: AtomicU64,
    wrong: AtomicU64,
    protocol_errors_sent: AtomicU64,
    faults: AtomicU64,
}

/// Whether a reply is the one expected.
type ReplyCheck = Box<dyn Fn(&[u8]) -> bool>;

/// One request and its reply, or `None` when no reply came in time.
fn exchange(c: &mut TcpStream, request: &[u8]) -> Option<Vec<u8>> {
    c.write_all(request).ok()?;
    let mut buf = [0u8; 256];
    match c.read(&mut buf) {
        Ok(n) if n > 0 => Some(buf[..n].to_vec()),
        _ => None,
    }
}

fn line(text: &str) -> Vec<u8> {
    let mut r = Header::getresponse(text.len() as u16).to_bytes().to_vec();
    r.extend_from_slice(text.as_bytes());
    r
}

fn connect(addr: SocketAddr) -> TcpStream {
    let c = TcpStream::connect(addr).expect("the server accepts");
    c.set_read_timeout(Some(REPLY_TIMEOUT)).unwrap();
    c.set_nodelay(true).unwrap();
    c
}

fn host(k: u16, addr: SocketAddr, stop: &AtomicBool, counts: &Counts) {
    let mut c = connect(addr);
    let readready: [u8; 8] = [0xC0, 0xC2, 0, 0, 0, 0, 0, 2];
    let mut round = 0u64;
    while !stop.load(Ordering::Relaxed) {
        round += 1;
        let value = u64::from(k) * 1_000_000 + round % 1_000_000;
        let steps: [(Vec<u8>, ReplyCheck); 4] = [
            (
                line(&format!("I{n}={value} I{n}", n = 1000 + k)),
                Box::new(move |r: &[u8]| r == format!("{value}\r\x06").as_bytes()),
            ),
            (line("???"), Box::new(|r: &[u8]| r.len() == 14 && r.ends_with(b"\r\x06"))),
            (line("ZZZ"), Box::new(|r: &[u8]| r == b"\x07ERR003\r")),
            (readready.to_vec(), Box::new(|r: &[u8]| r.len() == 2)),
        ];
        for (request, expected) in &steps {
            match exchange(&mut c, request) {
                Some(reply) => {
                    counts.answered.fetch_add(1, Ordering::Relaxed);
                    if !expected(&reply) {
                        counts.wrong.fetch_add(1, Ordering::Relaxed);
                    }
                }
                None => {
                    // A tripped card, or a slow server: a late reply must not be read as the
                    // next one's, so start over on a new connection.
                    counts.timed_out.fetch_add(1, Ordering::Relaxed);
                    c = connect(addr);
                    break;
                }
            }
        }
        if round % 200 == u64::from(k) % 200 {
            // A header the card cannot follow, on its own connection: the server closes it.
            let mut bad = connect(addr);
            let _ = bad.write_all(&[0x40, 0x12, 0, 0, 0, 0, 0, 0]);
            let _ = bad.read(&mut [0u8; 8]);
            counts.protocol_errors_sent.fetch_add(1, Ordering::Relaxed);
        }
    }
}

/// One control command and its reply line.
fn control(c: &mut BufReader<TcpStream>, command: &str) -> String {
    c.get_mut().write_all(format!("{command}\n").as_bytes()).unwrap();
    let mut reply = String::new();
    c.read_line(&mut reply).unwrap();
    assert!(reply.starts_with("ok"), "{command}: {reply}");
    reply
}

fn faults(addr: SocketAddr, stop: &AtomicBool, counts: &Counts) {
    let mut c = BufReader::new(TcpStream::connect(addr).unwrap());
    // The load as configured, to come back to after each change.
    let state = control(&mut c, "state");
    let load = state.split("load=").nth(1).unwrap().trim().replace(',', " ").replace(':', "=");
    let normal = format!("load {load}");
    // (command, how long to let it act): starving trips the card after about 1.84 s.
    let plan: [(String, u64); 16] = [
        ("starve".into(), 2_500),
        (normal.clone(), 0),
        ("init".into(), 500),
        ("checksum firmware".into(), 1_000),
        ("power".into(), 500),
        ("supply 4500".into(), 500),
        ("supply 5000".into(), 0),
        ("power".into(), 500),
        ("motors 200".into(), 500),
        (normal.clone(), 0),
        ("power dpram_fault flash_fault".into(), 500),
        ("clear_rti_reentry".into(), 200),
        ("checksum user_program".into(), 1_000),
        ("init".into(), 500),
        ("plc0 0".into(), 500),
        (normal.clone(), 0),
    ];
    'soak: loop {
        for (command, millis) in &plan {
            if stop.load(Ordering::Relaxed) {
                break 'soak;
            }
            control(&mut c, command);
            counts.faults.fetch_add(1, Ordering::Relaxed);
            std::thread::sleep(Duration::from_millis(*millis));
        }
    }
    // Leave the card answering: the configured load, supply up, a power cycle.
    control(&mut c, &normal);
    control(&mut c, "supply 5000");
    control(&mut c, "power");
}

#[test]
#[ignore = "a soak that measures for PMACWD_SOAK_SECONDS (default 60 s); run by hand, see the module's doc"]
fn many_clients_and_injected_faults_leave_memory_flat_and_every_client_answered() {
    let seconds: u64 = std::env::var("PMACWD_SOAK_SECONDS").ok().and_then(|s| s.parse().ok()).unwrap_or(60);
    let mut card = Card::default_card(Clock::Wall { start: Instant::now(), servo_hz: 2250 });
    let nowhere: Box<dyn Write + Send> = Box::new(std::io::sink());
    card.record(
        CaptureWriter::new(nowhere, "soak", pmacwd_emulator::card::DEFAULT_CONFIGURATION, Timing::Exact).unwrap(),
    )
    .unwrap();
    let options = ServeOptions {
        control: Some("127.0.0.1:0".parse().unwrap()),
        idle_timeout: Some(Duration::from_secs(600)),
        ..ServeOptions::free_loopback_port(128)
    };
    let server = Server::start(card, options).unwrap();
    let (addr, control_addr) = (server.local_addr, server.control_addr.unwrap());
    let stop = Arc::new(AtomicBool::new(false));
    let counts = Arc::new(Counts::default());
    let started = Instant::now();
    let (rss_before_kb, hwm_before_kb) = (status_kb("VmRSS"), status_kb("VmHWM"));
    let mut threads = Vec::new();
    for k in 0..CLIENTS {
        let (stop, counts) = (stop.clone(), counts.clone());
        threads.push(std::thread::spawn(move || host(k, addr, &stop, &counts)));
    }
    {
        let (stop, counts) = (stop.clone(), counts.clone());
        threads.push(std::thread::spawn(move || faults(control_addr, &stop, &counts)));
    }
    // Memory in the first and the second half of the run: what grows shows in the second.
    let (mut first_half_max_kb, mut second_half_max_kb) = (0u64, 0u64);
    let half = Duration::from_secs(seconds) / 2;
    while started.elapsed() < Duration::from_secs(seconds) {
        std::thread::sleep(SAMPLE_INTERVAL);
        let rss = status_kb("VmRSS");
        if started.elapsed() < half {
            first_half_max_kb = first_half_max_kb.max(rss);
        } else {
            second_half_max_kb = second_half_max_kb.max(rss);
        }
    }
    stop.store(true, Ordering::Relaxed);
    for t in threads {
        t.join().expect("no client saw a panic");
    }
    let duration = started.elapsed().as_secs_f64();
    let hwm_after_kb = status_kb("VmHWM");

    // Afterwards, every client is answered: one `???` on a fresh connection each.
    let mut answered_after = 0;
    for _ in 0..CLIENTS {
        let mut c = connect(addr);
        c.set_read_timeout(Some(Duration::from_secs(5))).unwrap();
        if exchange(&mut c, &line("???")).is_some_and(|r| r.ends_with(b"\r\x06")) {
            answered_after += 1;
        }
    }
    let stats = server.stats();
    let c = &counts;
    println!(
        "soak: {duration:.1} s, {CLIENTS} clients: {} requests answered ({:.0}/s), {} timed out (tripped card), {} wrong; \
         {} protocol errors sent, {} closed by the server; {} faults injected; {} connections in all",
        c.answered.load(Ordering::Relaxed),
        c.answered.load(Ordering::Relaxed) as f64 / duration,
        c.timed_out.load(Ordering::Relaxed),
        c.wrong.load(Ordering::Relaxed),
        c.protocol_errors_sent.load(Ordering::Relaxed),
        stats.refused_requests.load(Ordering::Relaxed),
        c.faults.load(Ordering::Relaxed),
        stats.connections.load(Ordering::Relaxed),
    );
    println!(
        "soak: before the clients RSS {rss_before_kb} kB, VmHWM {hwm_before_kb} kB; peak RSS sampled {first_half_max_kb} kB \
         in the first half, {second_half_max_kb} kB in the second; VmHWM {hwm_after_kb} kB at the end; \
         {answered_after}/{CLIENTS} clients answered afterwards"
    );
    server.stop();
    assert_eq!(c.wrong.load(Ordering::Relaxed), 0, "a client got an answer that was not its own");
    assert_eq!(answered_after, CLIENTS, "every client is answered after the soak");
    // Flat: the second half's peak within a quarter (and 4 MB of allocator slack) of the first's.
    assert!(
        second_half_max_kb <= first_half_max_kb + first_half_max_kb / 4 + 4096,
        "memory grew: {first_half_max_kb} kB -> {second_half_max_kb} kB"
    );
}
