//! The memory one client's line can take (issue 33: 128 connections each sending a line whose
//! reply is far larger than the line took the emulator to 1.6 GB). A test binary of its own,
//! with one test, so that the process's peak resident size is this test's.

use pmacwd_emulator::card::{Card, Clock};
use pmacwd_emulator::protocol::{Header, REPLY_PACKET_BYTES};
use pmacwd_emulator::server::{ServeOptions, Server};
use std::io::{Read, Write};
use std::net::TcpStream;
use std::time::Duration;

/// `VmHWM` of this process, in kB.
fn peak_kb() -> u64 {
    let status = std::fs::read_to_string("/proc/self/status").unwrap();
    let line = status.lines().find(|l| l.starts_with("VmHWM:")).unwrap();
    line.split_whitespace().nth(1).unwrap().parse().unwrap()
}

#[test]
fn sixteen_hosts_each_asking_a_19_mb_reply_take_a_few_megabytes() {
    let s = Server::start(Card::default_card(Clock::Virtual), ServeOptions::free_loopback_port(32)).unwrap();
    let line = "M0..8191-> ".repeat(1492 / 11);
    let mut definer = TcpStream::connect(s.local_addr).unwrap();
    let define = "M0..8191->X:$0,0,24,S";
    definer.write_all(&Header::getresponse(define.len() as u16).to_bytes()).unwrap();
    definer.write_all(define.as_bytes()).unwrap();
    let mut ack = [0u8; 1];
    definer.read_exact(&mut ack).unwrap();
    let before = peak_kb();
    let mut hosts = Vec::new();
    for _ in 0..16 {
        let mut c = TcpStream::connect(s.local_addr).unwrap();
        c.set_read_timeout(Some(Duration::from_secs(60))).unwrap();
        c.write_all(&Header::getresponse(line.len() as u16).to_bytes()).unwrap();
        c.write_all(line.as_bytes()).unwrap();
        hosts.push(c);
    }
    for c in &mut hosts {
        let mut first = vec![0u8; REPLY_PACKET_BYTES];
        c.read_exact(&mut first).unwrap();
    }
    let grown = peak_kb().saturating_sub(before);
    // Each host's reply would be about 19 MB built whole (16 of them, 300 MB); answered as
    // it is fetched, each holds a packet and one part of a command.
    assert!(grown < 32_000, "the peak grew by {grown} kB for 16 hosts");
    eprintln!("peak grew by {grown} kB for 16 hosts");
}
