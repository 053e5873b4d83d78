//! UM p.236: command processing is a background task, so when PLC 0 starves the background
//! "the first thing you will notice is that communications and background PLC tasks will
//! become sluggish" before the watchdog trips the card (issue 35). A host's line is answered
//! in the first background cycle that completes after it arrives (`card/line.rs`): counted in
//! the card's servo cycles in virtual time, and on the wall clock over real sockets.

use pmacwd_emulator::card::{Card, Clock};
use pmacwd_emulator::control::Control;
use pmacwd_emulator::protocol::Header;
use pmacwd_emulator::server::{ServeOptions, Server};
use std::io::{Read, Write};
use std::net::TcpStream;
use std::time::{Duration, Instant};

/// The default card's CPU (`check.yaml`, `emulated`): 100 units a servo cycle, 8 motors at 1
/// unit each (UM p.236: "about 1%" a motor), the RTI every I8 + 1 = 3 servo cycles (UM p.236),
/// a background cycle of 50 units (housekeeping and command processing, no background PLC:
/// MODEL, the configuration's summary).
const FREE_UNITS_PER_CYCLE: u32 = 100 - 8;
const RTI_PERIOD_CYCLES: u32 = 3;
const BACKGROUND_UNITS: u32 = 50;

/// Servo cycles between two background cycles when PLC 0 costs `plc0_units` each RTI and
/// leaves the background `share` units of every RTI period (at most one unit is lost to the
/// rounding of a period here: the loads below leave the share in whole periods).
fn background_spacing_cycles(plc0_units: u32) -> u32 {
    let share = FREE_UNITS_PER_CYCLE * RTI_PERIOD_CYCLES - plc0_units;
    BACKGROUND_UNITS.div_ceil(share) * RTI_PERIOD_CYCLES
}

/// `state`'s `name=value` field as a number.
fn field(state: &str, name: &str) -> i64 {
    let at = state.find(&format!(" {name}=")).unwrap_or_else(|| panic!("{name} in {state}"));
    state[at + name.len() + 2..].split([' ', ',']).next().unwrap().parse().unwrap()
}

fn control(c: &mut Card, line: &str) -> String {
    let reply = c.control(Control::parse(line).unwrap());
    assert!(reply.starts_with("ok"), "{line}: {reply}");
    reply
}

/// A virtual-time card under `plc0` that has run `cycles` servo cycles.
fn virtual_card(plc0: u32, cycles: u32) -> Card {
    let mut c = Card::default_card(Clock::Virtual);
    control(&mut c, &format!("plc0 {plc0}"));
    control(&mut c, &format!("step {cycles}"));
    c
}

#[test]
fn a_card_whose_plc0_spaces_the_background_out_answers_no_sooner_than_its_next_background_cycle_in_virtual_time() {
    // PLC 0 of 274 units leaves the background 2 units an RTI period: a background cycle
    // every 25 periods, 75 servo cycles (33 ms at 2.25 kHz), well inside the watchdog's 4096.
    let plc0 = 274;
    assert_eq!(background_spacing_cycles(plc0), 75);
    for start in [1000, 1010, 1040, 1074] {
        // The reference: the same card stepped one servo cycle at a time until the watchdog
        // counter is reloaded, which only a background cycle does (UM p.215).
        let mut reference = virtual_card(plc0, start);
        let mut counter = field(&control(&mut reference, "state"), "counter");
        let mut ahead = 0;
        loop {
            control(&mut reference, "step 1");
            ahead += 1;
            let now = field(&control(&mut reference, "state"), "counter");
            if now > counter {
                break;
            }
            counter = now;
            assert!(ahead <= 75, "no background cycle within 75 servo cycles");
        }
        // The host's `???` on the same card is answered in that cycle, not before.
        let mut card = virtual_card(plc0, start);
        let before = field(&control(&mut card, "state"), "cycles");
        assert_eq!(before, i64::from(start));
        let reply = card.line(b"???").expect("a running card answers");
        assert_eq!(reply.len(), 14, "{reply:?}");
        let after = field(&control(&mut card, "state"), "cycles");
        assert_eq!(
            after - before,
            ahead,
            "answered {} servo cycles after it arrived (from cycle {start})",
            after - before
        );
        // A second line with no time between is answered by the same background cycle.
        card.line(b"I130").unwrap();
        assert_eq!(field(&control(&mut card, "state"), "cycles"), after);
    }
}

#[test]
fn a_healthy_card_answers_in_the_background_cycle_of_every_servo_cycle_in_virtual_time() {
    // The default load: PLC 0 of 30 units leaves 62 units even in the RTI cycle, more than the
    // background's 50: a background cycle completes in every servo cycle (0.44 ms), the most
    // the model allows. A line after a step is answered in the step's last cycle, at once;
    // after servo cycles without background (`servo N`), in the next servo cycle.
    let mut card = virtual_card(30, 1000);
    card.line(b"???").unwrap();
    let mut waits = Vec::new();
    for s in [1, 2, 3, 4, 5, 6, 7, 8] {
        control(&mut card, &format!("step {s}"));
        let before = field(&control(&mut card, "state"), "cycles");
        card.line(b"???").unwrap();
        waits.push(field(&control(&mut card, "state"), "cycles") - before);
    }
    assert_eq!(waits, [0; 8], "a background cycle in every servo cycle");
    for n in [1, 2, 3] {
        control(&mut card, &format!("servo {n}"));
        let before = field(&control(&mut card, "state"), "cycles");
        card.line(b"???").unwrap();
        assert_eq!(field(&control(&mut card, "state"), "cycles") - before, 1, "after servo {n}");
    }
    // i40-zero's background of 250 units (the model's configuration with background work)
    // comes every 4 servo cycles: the same card with that load waits up to 3.
    control(&mut card, "background 250");
    control(&mut card, "step 100");
    let mut waits = Vec::new();
    for s in [1, 2, 3, 4, 5, 6, 7, 8] {
        control(&mut card, &format!("step {s}"));
        let before = field(&control(&mut card, "state"), "cycles");
        card.line(b"???").unwrap();
        waits.push(field(&control(&mut card, "state"), "cycles") - before);
    }
    assert_eq!(waits, [3, 2, 1, 0, 3, 2, 1, 0], "a background cycle every 4 servo cycles");
}

fn connect(s: &Server) -> TcpStream {
    let c = TcpStream::connect(s.local_addr).unwrap();
    c.set_read_timeout(Some(Duration::from_secs(5))).unwrap();
    c.set_nodelay(true).unwrap();
    c
}

/// `???`'s round trip on a host connection.
fn question_marks(c: &mut TcpStream) -> Duration {
    let t = Instant::now();
    c.write_all(&Header::getresponse(3).to_bytes()).unwrap();
    c.write_all(b"???").unwrap();
    let mut buf = [0u8; 64];
    let n = c.read(&mut buf).expect("an answer");
    assert_eq!(n, 14, "{:?}", &buf[..n]);
    t.elapsed()
}

fn wall_server(plc0: u32) -> Server {
    let card = Card::default_card(Clock::Wall { start: Instant::now(), servo_hz: 2250 });
    let s = Server::start(card, ServeOptions::free_loopback_port(8)).expect("a free loopback port");
    s.with_card(|c| control(c, &format!("plc0 {plc0}")));
    s
}

#[test]
fn on_the_wall_clock_a_starving_card_answers_a_background_cycle_apart_and_a_healthy_one_at_once() {
    // PLC 0 of 275 units leaves the background one unit an RTI period: a background cycle
    // every 150 servo cycles, 67 ms at 2.25 kHz, 150 times the healthy card's (the watchdog's
    // 4096 cycles are 1.8 s, so the card answers, slowly, and does not trip).
    let spacing = Duration::from_secs_f64(f64::from(background_spacing_cycles(275)) / 2250.0);
    assert_eq!(background_spacing_cycles(275), 150);
    let s = wall_server(275);
    let mut c = connect(&s);
    // The first answer comes at the first background cycle after the load change; each next
    // `???`, sent as soon as the answer is read, waits for the next one. Each answer comes in
    // a background cycle of its own, a spacing after the one before, so k answers after the
    // first take more than k - 1 spacings however late the machine delivered the first (a
    // late answer leaves its successor less to wait: the card keeps its own time).
    question_marks(&mut c);
    let mut waits = Vec::new();
    for _ in 0..4 {
        let waited = question_marks(&mut c);
        assert!(
            waited <= spacing + Duration::from_millis(150),
            "answered after {waited:?}; background cycles {spacing:?} apart"
        );
        waits.push(waited);
    }
    let total: Duration = waits.iter().sum();
    assert!(total > spacing * 3, "4 answers in {total:?} ({waits:?}), sooner than background cycles {spacing:?} apart");
    assert!(s.with_card(|c| !c.tripped()), "a sluggish card, not a tripped one");
    s.stop();

    // The default load: a background cycle every servo cycle (0.44 ms). A debug build on a
    // shared machine: the median stays within that and a millisecond of the machine's own.
    let s = wall_server(30);
    let mut c = connect(&s);
    let mut round_trips: Vec<Duration> = (0..200).map(|_| question_marks(&mut c)).collect();
    round_trips.sort();
    let median = round_trips[100];
    assert!(median <= Duration::from_micros(444 + 1000), "median {median:?}");
    s.stop();
}

#[test]
fn in_virtual_time_a_line_in_the_instant_a_reset_ends_is_answered_in_it() {
    // MODEL: a reset leaves the counter loaded as a background cycle does (UM p.215), and
    // the card enters its background loop: the instant counts as a background cycle's end.
    let mut card = virtual_card(274, 0);
    let cycles = |c: &mut Card| field(&control(c, "state"), "cycles");
    card.line(b"???").unwrap();
    assert_eq!(cycles(&mut card), 0, "at power-up");
    control(&mut card, "step 10");
    control(&mut card, "init");
    card.line(b"???").unwrap();
    assert_eq!(cycles(&mut card), 10, "after INIT/");
    card.line(b"$$$").unwrap();
    card.line(b"???").unwrap();
    assert_eq!(cycles(&mut card), 10, "after $$$");
    // A step that ends between background cycles: the next line waits for one.
    control(&mut card, "step 10");
    card.line(b"???").unwrap();
    assert!(cycles(&mut card) > 20, "75 servo cycles apart under PLC 0 = 274");
}
