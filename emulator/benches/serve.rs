//! `pmacwd serve` on loopback, as a host program feels it: the round trip of one `???`
//! (VR_PMAC_GETRESPONSE out, the 14-byte reply back) and the sustained rate with several
//! clients. Before criterion's figures it prints the percentiles of 10,000 single round trips.
//! Also the longest the card's lock is held at a time: one chunk of `CYCLES_PER_HOLD_MAX`
//! servo cycles with background (a catch-up or a part of `step`).
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

    let mut g = c.benchmark_group("serve");
    let mut one = Client::new(addr);
    g.throughput(Throughput::Elements(1));
    g.bench_function("??? round trip, one client", |b| b.iter(|| one.status()));

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
