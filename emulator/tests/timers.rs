//! UM p.239's foreground timer registers follow the load the card runs (issue 35): Y:$000037
//! the servo tasks, X:$00000B the last set of RTI tasks (PLC 0, move planning), Y:$00000B the
//! largest since power-up/reset; read as the EPICS pmac driver reads them, through a Geo
//! Brick's M-variable definitions (DiamondLightSource/pmac
//! `etc/bootstrap/BRICK_M_variables.pmc:70-73`), and turned into its CPU load figure.

use pmacwd_emulator::card::{Card, Clock};
use pmacwd_emulator::control::Control;
use pmacwd_emulator::protocol::Header;
use pmacwd_emulator::server::{ServeOptions, Server};
use std::io::{Read, Write};
use std::net::TcpStream;
use std::time::{Duration, Instant};

fn control(c: &mut Card, line: &str) {
    let reply = c.control(Control::parse(line).unwrap());
    assert!(reply.starts_with("ok"), "{line}: {reply}");
}

fn numbers(c: &mut Card, line: &str) -> Vec<f64> {
    let reply = c.line(line.as_bytes()).expect("a running card answers");
    let text = String::from_utf8_lossy(&reply).into_owned();
    assert!(text.ends_with('\x06') && !text.contains('\x07'), "{line}: {text:?}");
    text.trim_end_matches('\x06').split('\r').filter(|v| !v.is_empty()).map(|v| v.parse().unwrap()).collect()
}

/// The driver's definitions (`BRICK_M_variables.pmc:71-73`, format U by default), and M74 on
/// Y:$00000B, the largest RTI time (UM p.239; the driver reads no M-variable for it).
const DEFINITIONS: &str = "M71->X:$000037,0,24 M72->Y:$000037,0,24 M73->X:$00000B,0,24 M74->Y:$00000B,0,24";

/// M70..M74.
fn timers(c: &mut Card) -> [f64; 5] {
    numbers(c, "M70 M71 M72 M73 M74").try_into().unwrap()
}

/// The EPICS driver's CPU load in percent (`pmacApp/src/pmacController.cpp:1850-1890`, after
/// UM p.240's PLC): phase, servo and RTI duty cycles, each with the interrupting tasks taken
/// out; written here from the manual's PLC, not taken from the emulator's own code.
fn driver_cpu_percent(m: [f64; 5], i7002: f64, i8: f64) -> f64 {
    let [m70, m71, m72, m73, _] = m;
    let p70 = i7002 + 1.0;
    let p71 = m71 / m70;
    let p69 = (m72 / m70).floor();
    let p72 = (m72 - p69 * m71) / (m70 * p70);
    let p68 = (m73 / m70).floor();
    let p67 = (m73 / (m70 * p70)).floor();
    let p73 = (m73 - p68 * m71 - p67 * (m72 - p69 * m71)) / (m70 * p70 * (i8 + 1.0));
    100.0 * (p71 + p72 + p73)
}

#[test]
fn the_timer_registers_grow_with_plc0_the_largest_rti_time_holds_and_a_reset_clears_it() {
    let mut c = Card::default_card(Clock::Virtual);
    // Before any definition, M70-M73 hold their card-defined values (`variables.yaml`): those
    // of M72 and M73 are the registers at power-up.
    let spec = pmacwd_specs::Spec::embedded().unwrap();
    let yaml = |n: &str| spec.variables.host_m_variables.iter().find(|h| h.number == n).unwrap().value as f64;
    assert_eq!(numbers(&mut c, "M70 M71 M72 M73"), [yaml("M70"), yaml("M71"), yaml("M72"), yaml("M73")]);
    numbers(&mut c, DEFINITIONS);
    let (i7002, i8) = match numbers(&mut c, "I7002 I8")[..] {
        [a, b] => (a, b),
        ref other => panic!("{other:?}"),
    };
    // The default load: 8 motors of 1 unit in 100, PLC 0 of 30 units every 3 servo cycles.
    // The model's units are what the phase tasks (10% here) leave: the driver's figure is the
    // phase tasks' 10%, then 90% of 8% and of 30/3 = 10%.
    let light = timers(&mut c);
    let cpu = driver_cpu_percent(light, i7002, i8);
    assert!((cpu - (10.0 + 0.9 * 8.0 + 0.9 * 10.0)).abs() < 0.1, "{cpu}% from {light:?}");
    assert_eq!(light[4], light[3], "the largest RTI time so far is this one");
    // PLC 0 of 200 units: the RTI tasks take three servo cycles, interrupted by the servo
    // and phase tasks, and the driver's figure finds 90% of 200/3 in them.
    control(&mut c, "plc0 200");
    control(&mut c, "step 30");
    let heavy = timers(&mut c);
    let cpu = driver_cpu_percent(heavy, i7002, i8);
    assert!((cpu - (10.0 + 0.9 * 8.0 + 0.9 * 200.0 / 3.0)).abs() < 0.1, "{cpu}% from {heavy:?}");
    assert!(heavy[3] > 3.0 * light[3] + 2.0 * light[2], "{heavy:?} against {light:?}");
    assert_eq!(heavy[..3], light[..3], "the phase period, phase and servo tasks do not change with PLC 0");
    assert_eq!(heavy[4], heavy[3]);
    // Back to the light load: X:$0B follows it, Y:$0B keeps the largest.
    control(&mut c, "plc0 30");
    control(&mut c, "step 30");
    let after = timers(&mut c);
    assert_eq!(after[3], light[3]);
    assert_eq!(after[4], heavy[3], "Y:$00000B holds the largest since power-up/reset");
    // More motors: longer servo tasks (Y:$37).
    control(&mut c, "motors 16");
    assert!(timers(&mut c)[2] > light[2]);
    control(&mut c, "motors 8");
    // A reset clears the largest (UM p.239: "since the last power-up/reset"): INIT/ ...
    control(&mut c, "init");
    numbers(&mut c, DEFINITIONS);
    assert_eq!(timers(&mut c)[4], light[3], "after INIT/, only the RTI tasks run since");
    // ... and a host's `$$$`.
    control(&mut c, "plc0 200");
    control(&mut c, "step 30");
    control(&mut c, "plc0 30");
    assert_eq!(timers(&mut c)[4], heavy[3]);
    c.line(b"$$$").unwrap();
    numbers(&mut c, DEFINITIONS);
    assert_eq!(timers(&mut c)[4], light[3], "after $$$");
}

/// A whole reply over a host connection: GETRESPONSE with `line`, read up to the ACK (I3 = 2)
/// or an error's CR, the answers split at CR.
fn exchange(c: &mut TcpStream, line: &str) -> Vec<String> {
    c.write_all(&Header::getresponse(line.len() as u16).to_bytes()).unwrap();
    c.write_all(line.as_bytes()).unwrap();
    let mut reply = Vec::new();
    let mut buf = [0u8; 1400];
    let complete = |r: &[u8]| r.ends_with(b"\x06") || (r.first() == Some(&0x07) && r.ends_with(b"\r"));
    while !complete(&reply) {
        let n = c.read(&mut buf).expect("an answer");
        assert!(n > 0, "{line}: the connection closed");
        reply.extend_from_slice(&buf[..n]);
    }
    let text = String::from_utf8_lossy(&reply).into_owned();
    assert!(!text.contains('\x07'), "{line}: {text:?}");
    text.trim_end_matches('\x06').split('\r').filter(|v| !v.is_empty()).map(str::to_owned).collect()
}

#[test]
fn the_drivers_own_definitions_of_m70_to_m73_go_through_serve_and_read_the_timer_registers() {
    // The EPICS driver's Geo Brick file, `etc/bootstrap/BRICK_M_variables.pmc:70-73`, each line
    // as a downloader sends it (the statement, its `;` comment left out), M70 on the DSP's
    // X:$FFFF8C (UM p.239), a six-digit address past SRM p.170's 19-bit gathering field (UM
    // p.246); then the reads as the driver's fast poll sends them (`pmacController.h:197-200`,
    // a leading space, keys joined by spaces), and `RH` of the same registers.
    let card = Card::default_card(Clock::Wall { start: Instant::now(), servo_hz: 2250 });
    let s = Server::start(card, ServeOptions::free_loopback_port(8)).expect("a free loopback port");
    let mut c = TcpStream::connect(s.local_addr).unwrap();
    c.set_read_timeout(Some(Duration::from_secs(5))).unwrap();
    for definition in ["M70->X:$FFFF8C,0,24", "M71->X:$000037,0,24", "M72->Y:$000037,0,24", "M73->X:$00000B,0,24"] {
        assert_eq!(exchange(&mut c, definition), Vec::<String>::new(), "{definition} acknowledged");
    }
    assert_eq!(
        exchange(&mut c, "M70..73->"),
        ["X:$FFFF8C,0,24,U", "X:$000037,0,24,U", "Y:$000037,0,24,U", "X:$00000B,0,24,U"],
        "the definitions as the card reports them"
    );
    let expected = s.with_card(|card| card.timers());
    let want = [expected.phase_period, expected.phase_task, expected.servo_task, expected.rti_task];
    let read: Vec<u32> = exchange(&mut c, " M70 M71 M72 M73").iter().map(|v| v.parse().unwrap()).collect();
    assert_eq!(read, want, "the timer registers through the driver's own definitions");
    // M70 is the phase period of `variables.yaml`'s M70 (13279): read through its definition
    // now, not as its card-defined value.
    assert_eq!(read[0], 13279);
    let hex: Vec<u32> = exchange(&mut c, "RHX:$FFFF8C RHX:$37 RHY:$37 RHX:$0B")
        .iter()
        .map(|v| u32::from_str_radix(v, 16).unwrap())
        .collect();
    assert_eq!(hex, want, "RH of the same registers");
    // The load moves X:$00000B (PLC 0, UM p.239) and the driver's M73 follows it.
    s.with_card(|card| control(card, "plc0 200"));
    let heavy = s.with_card(|card| card.timers()).rti_task;
    assert!(heavy > want[3], "{heavy} against {}", want[3]);
    let m73: u32 = exchange(&mut c, " M73")[0].parse().unwrap();
    assert_eq!(m73, heavy);
    s.stop();
}
