//! `pmacwd serve` on loopback, as a host program feels it: the round trip of one `???`
//! (VR_PMAC_GETRESPONSE out, the 14-byte reply back) and the sustained rate with several
//! clients. Before criterion's figures it prints the percentiles of 10,000 single round trips.
//! Also the longest the card's lock is held at a time: one chunk of `CYCLES_PER_HOLD_MAX`
//! servo cycles with background (a catch-up or a part of `step`).
//!
//! The GUI's poll line: dls-pmaccontrol sends `i65???&1??%#1?PVF m190 p99#2?PVF ...` (52 values)
//! every 0.1 s; its round trip's percentiles are printed, and criterion times it. Then ten
//! such clients poll at 10 Hz for 10 s and the process's CPU time (user + system, from
//! /proc/self/stat, clients included: an upper bound for the server's) is printed as a share
//! of one core.
//!
//! `cargo bench -p pmacwd-emulator --bench serve`

use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use pmacwd_emulator::card::{Card, Clock, CYCLES_PER_HOLD_MAX};
use pmacwd_emulator::control::Control;
use pmacwd_emulator::protocol::Header;
use pmacwd_emulator::server::{ServeOptions, Server};
use std::io::{Read, Write};
use std::net::{SocketAddr, TcpStream};
use std::time::{Duration, Instant};

const CLIENTS: usize = 4;
const LINES_PER_CLIENT: usize = 500;

fn start() -> Server {
    // The wall clock, as `pmacwd serve` runs by default: every request first runs the servo
    // cycles due since the last one (2.25 kHz).
    let card = Card::default_card(Clock::Wall { start: Instant::now(), servo_hz: 2250 });
    Server::start(card, ServeOptions::free_loopback_port(128)).unwrap()
}

struct Client {
    stream: TcpStream,
    request: Vec<u8>,
    buf: [u8; 64],
}

impl Client {
    fn new(addr: SocketAddr) -> Client {
        let stream = TcpStream::connect(addr).unwrap();
        stream.set_nodelay(true).unwrap();
        let mut request = Header::getresponse(3).to_bytes().to_vec();
        request.extend_from_slice(b"???");
        Client { stream, request, buf: [0; 64] }
    }

    /// One `???` and its whole reply (12 hex digits, CR, ACK).
    fn status(&mut self) {
        self.stream.write_all(&self.request).unwrap();
        let mut got = 0;
        while got < 14 {
            got += self.stream.read(&mut self.buf[got..]).unwrap();
        }
        assert_eq!(self.buf[13], 0x06);
    }
}

/// dls-pmaccontrol 3.2.3's poll line for a Geo Brick with 8 axes (commsThread.py).
fn gui_poll_line() -> String {
    let mut line = String::from("i65???&1??%");
    for m in 1..=8 {
        line += &format!("#{m}?PVF m{m}90 p99");
    }
    line
}

/// A client sending the GUI's poll line and reading its whole reply (up to the ACK).
struct Poller {
    stream: TcpStream,
    request: Vec<u8>,
    buf: Vec<u8>,
}

impl Poller {
    fn new(addr: SocketAddr) -> Poller {
        let stream = TcpStream::connect(addr).unwrap();
        stream.set_nodelay(true).unwrap();
        let line = gui_poll_line();
        let mut request = Header::getresponse(line.len() as u16).to_bytes().to_vec();
        request.extend_from_slice(line.as_bytes());
        Poller { stream, request, buf: vec![0; 2048] }
    }

    /// One poll line; the number of values in the reply.
    fn poll(&mut self) -> usize {
        self.stream.write_all(&self.request).unwrap();
        let mut got = 0;
        loop {
            got += self.stream.read(&mut self.buf[got..]).unwrap();
            if got > 0 && self.buf[got - 1] == 0x06 {
                break;
            }
        }
        self.buf[..got].iter().filter(|b| **b == b'\r').count()
    }
}

fn poll_percentiles(addr: SocketAddr) {
    let mut c = Poller::new(addr);
    assert_eq!(c.poll(), 52, "the GUI's 52 values");
    for _ in 0..500 {
        c.poll();
    }
    let mut times: Vec<Duration> = (0..5_000)
        .map(|_| {
            let t = Instant::now();
            c.poll();
            t.elapsed()
        })
        .collect();
    times.sort();
    let at = |q: f64| times[((times.len() as f64 - 1.0) * q) as usize].as_secs_f64() * 1e6;
    println!(
        "dls-pmaccontrol poll line (52 values) round trip over loopback, 5,000 in a row: p50 {:.1} us, p90 {:.1} us, p99 {:.1} us, max {:.1} us",
        at(0.5),
        at(0.9),
        at(0.99),
        at(1.0)
    );
}

/// This process's CPU time so far (user + system), from /proc/self/stat; `None` elsewhere.
fn cpu_time() -> Option<Duration> {
    let stat = std::fs::read_to_string("/proc/self/stat").ok()?;
    // Fields after the command name in parentheses: state is field 3, utime 14, stime 15.
    let rest = &stat[stat.rfind(')')? + 2..];
    let fields: Vec<&str> = rest.split_whitespace().collect();
    let ticks: u64 = fields.get(11)?.parse::<u64>().ok()? + fields.get(12)?.parse::<u64>().ok()?;
    // USER_HZ is 100 on Linux.
    Some(Duration::from_millis(ticks * 10))
}

/// Ten clients each sending the poll line every 0.1 s for 10 s, as ten GUIs would.
fn ten_guis(addr: SocketAddr) {
    const GUIS: usize = 10;
    const RUN: Duration = Duration::from_secs(10);
    let Some(before) = cpu_time() else {
        println!("ten GUIs at 10 Hz: no /proc/self/stat here, CPU not measured");
        return;
    };
    let wall = Instant::now();
    std::thread::scope(|s| {
        for _ in 0..GUIS {
            s.spawn(|| {
                let mut c = Poller::new(addr);
                let start = Instant::now();
                let mut n = 0u32;
                while start.elapsed() < RUN {
                    assert_eq!(c.poll(), 52);
                    n += 1;
                    let next = Duration::from_millis(100) * n;
                    if let Some(wait) = next.checked_sub(start.elapsed()) {
                        std::thread::sleep(wait);
                    }
                }
            });
        }
    });
    let cpu = cpu_time().unwrap_or(before).saturating_sub(before);
    let wall = wall.elapsed();
    println!(
        "ten GUIs polling at 10 Hz for {:.1} s: {:.2} s CPU (server and clients), {:.2}% of one core",
        wall.as_secs_f64(),
        cpu.as_secs_f64(),
        100.0 * cpu.as_secs_f64() / wall.as_secs_f64()
    );
}

fn percentiles(addr: SocketAddr) {
    let mut c = Client::new(addr);
    for _ in 0..1000 {
        c.status();
    }
    let mut times: Vec<Duration> = (0..10_000)
        .map(|_| {
            let t = Instant::now();
            c.status();
            t.elapsed()
        })
        .collect();
    times.sort();
    let at = |q: f64| times[((times.len() as f64 - 1.0) * q) as usize].as_secs_f64() * 1e6;
    println!(
        "??? round trip over loopback, 10,000 in a row: p50 {:.1} us, p90 {:.1} us, p99 {:.1} us, max {:.1} us",
        at(0.5),
        at(0.9),
        at(0.99),
        at(1.0)
    );
}

fn bench(c: &mut Criterion) {
    let server = start();
    let addr = server.local_addr;
    percentiles(addr);
    poll_percentiles(addr);
    ten_guis(addr);

    let mut g = c.benchmark_group("serve");
    let mut one = Client::new(addr);
    g.throughput(Throughput::Elements(1));
    g.bench_function("??? round trip, one client", |b| b.iter(|| one.status()));
    let mut gui = Poller::new(addr);
    g.bench_function("GUI poll line (52 values) round trip, one client", |b| b.iter(|| gui.poll()));

    let mut clients: Vec<Client> = (0..CLIENTS).map(|_| Client::new(addr)).collect();
    g.throughput(Throughput::Elements((CLIENTS * LINES_PER_CLIENT) as u64));
    g.sample_size(20);
    g.bench_function(format!("{CLIENTS} clients x {LINES_PER_CLIENT} ???, sustained"), |b| {
        b.iter(|| {
            std::thread::scope(|s| {
                for c in clients.iter_mut() {
                    s.spawn(move || {
                        for _ in 0..LINES_PER_CLIENT {
                            c.status();
                        }
                    });
                }
            })
        })
    });
    g.finish();
    server.stop();

    let mut g = c.benchmark_group("card");
    let mut card = Card::default_card(Clock::Virtual);
    let chunk = Control::Step { cycles: CYCLES_PER_HOLD_MAX };
    g.throughput(Throughput::Elements(u64::from(CYCLES_PER_HOLD_MAX)));
    g.bench_function(format!("one lock hold: step {CYCLES_PER_HOLD_MAX}"), |b| b.iter(|| card.control(chunk)));
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
