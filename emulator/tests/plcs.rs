//! User PLC programs 1-31 run in the card's background (issue 30): one scan of a single PLC per
//! background cycle (UM p.236), a WHILE loop a pass a scan, conditions as UM p.252 reads them,
//! COMMAND statements through the card's command path (SRM p.421), and a hostile PLC bounded.

use pmacwd_emulator::card::{Card, Clock};
use pmacwd_emulator::control::Control;
use std::time::Instant;

fn card() -> Card {
    Card::default_card(Clock::Virtual)
}

/// The data answers of a line that must be acknowledged without error.
fn values(c: &mut Card, line: &str) -> Vec<String> {
    let reply = c.line(line.as_bytes()).expect("the card answers");
    let text = String::from_utf8_lossy(&reply).into_owned();
    assert!(text.ends_with('\x06') && !text.contains('\x07'), "{line}: {text:?}");
    text.trim_end_matches('\x06').split('\r').filter(|v| !v.is_empty()).map(str::to_string).collect()
}

fn value(c: &mut Card, var: &str) -> f64 {
    values(c, var)[0].parse().unwrap_or_else(|_| panic!("{var}"))
}

fn download(c: &mut Card, lines: &[&str]) {
    for line in lines {
        assert_eq!(c.line(line.as_bytes()).unwrap(), b"\x06", "{line}");
    }
}

/// `cycles` servo cycles in virtual time; the default card completes a background cycle in
/// each one (docs/emulator.md, "The default card's background").
fn step(c: &mut Card, cycles: u32) {
    assert!(c.control(Control::Step { cycles }).starts_with("ok"));
}

fn plc(c: &mut Card, n: u8, lines: &[&str]) {
    download(c, &[&format!("OPEN PLC {n} CLEAR")]);
    download(c, lines);
    download(c, &["CLOSE"]);
}

#[test]
fn an_enabled_plc_scans_once_a_background_cycle_while_i5_lets_background_plcs_run() {
    let mut c = card();
    plc(&mut c, 1, &["P1=P1+1"]);
    download(&mut c, &["ENABLE PLC 1"]);
    step(&mut c, 100);
    assert_eq!(value(&mut c, "P1"), 0.0, "I5 = 1, the default: background PLCs off (SRM p.39)");
    download(&mut c, &["I5=2"]);
    step(&mut c, 100);
    assert_eq!(value(&mut c, "P1"), 100.0, "one scan each background cycle");
    download(&mut c, &["DISABLE PLC 1"]);
    step(&mut c, 100);
    assert_eq!(value(&mut c, "P1"), 100.0);
    download(&mut c, &["I5=3 ENABLE PLC 1"]);
    step(&mut c, 10);
    assert_eq!(value(&mut c, "P1"), 110.0, "I5 = 3: both kinds on");
    // A starved card completes no background cycle, so its PLCs stop too (UM p.236).
    c.control(Control::Load { motors: None, plc0_units: Some(275), background_units: None });
    step(&mut c, 300);
    assert!(value(&mut c, "P1") < 115.0, "a background cycle every 150 servo cycles");
}

#[test]
fn i5_is_the_turbo_default_1_at_power_up_and_after_a_factory_reset() {
    // SRM p.39: I5 defaults to 1, foreground PLCs on and background PLCs off.
    let mut c = card();
    assert_eq!(value(&mut c, "I5"), 1.0);
    download(&mut c, &["I5=3"]);
    c.line(b"$$$***");
    download(&mut c, &["I3=2 I6=1"]);
    assert_eq!(value(&mut c, "I5"), 1.0, "$$$*** restores the factory default");
    download(&mut c, &["I5=2 SAVE", "$$$"]);
    assert_eq!(value(&mut c, "I5"), 2.0, "a saved value survives a reset");
}

#[test]
fn two_plcs_take_turns_one_scan_of_a_single_plc_each_background_cycle() {
    // UM p.236: "Each background cycle, Turbo PMAC will execute one scan ... of a single
    // active interpreted background PLC program".
    let mut c = card();
    plc(&mut c, 1, &["P1=P1+1"]);
    plc(&mut c, 7, &["P7=P7+1"]);
    download(&mut c, &["I5=2 ENABLE PLC 1,7"]);
    step(&mut c, 100);
    assert_eq!((value(&mut c, "P1"), value(&mut c, "P7")), (50.0, 50.0));
}

#[test]
fn a_while_loop_is_one_pass_a_scan_and_if_else_and_or_choose_as_the_manual_says() {
    let mut c = card();
    plc(&mut c, 1, &["P2=P2+1", "WHILE(P1<5)", "P1=P1+1", "ENDWHILE", "P3=P3+1"]);
    download(&mut c, &["I5=2 ENABLE PLC 1"]);
    // Scan 1: P2, a pass; scans 2-5: a pass each (from the WHILE); scan 6: out, P3; scan 7:
    // from the top, P2, WHILE false, P3.
    step(&mut c, 7);
    assert_eq!([value(&mut c, "P1"), value(&mut c, "P2"), value(&mut c, "P3")], [5.0, 2.0, 2.0]);

    let mut c = card();
    plc(
        &mut c,
        2,
        &[
            // UM p.252: AND before OR; ELSE; `!>`; DLS's continuation line OR(...).
            "IF (P10>-20 AND P10<20 OR P11=1)",
            "P20=1",
            "ELSE",
            "P20=2",
            "ENDIF",
            "IF (P12!>3)",
            "OR (P13=7)",
            "P21=P21+1",
            "ENDIF",
            "IF (P14=1) P22=5 ELSE P22=6",
            "DISABLE PLC 2",
        ],
    );
    download(&mut c, &["I5=2 P10=50 P11=0 P12=4 P13=0 P14=1 ENABLE PLC 2"]);
    step(&mut c, 5);
    assert_eq!([value(&mut c, "P20"), value(&mut c, "P21"), value(&mut c, "P22")], [2.0, 0.0, 5.0]);
    download(&mut c, &["P11=1 P13=7 P14=0 ENABLE PLC 2"]);
    step(&mut c, 5);
    assert_eq!([value(&mut c, "P20"), value(&mut c, "P21"), value(&mut c, "P22")], [1.0, 1.0, 6.0]);
    download(&mut c, &["P11=0 P10=0 P13=0 P12=3 ENABLE PLC 2"]);
    step(&mut c, 5);
    assert_eq!([value(&mut c, "P20"), value(&mut c, "P21")], [1.0, 2.0], "a PLC that disables itself runs once");
}

#[test]
fn a_plc_s_commands_go_through_the_card_s_command_path_and_reach_the_core() {
    let mut c = card();
    download(&mut c, &["#1J/ M162->D:$00008B"]);
    // DLS's style: an edge, then the command (PMAC-SRM p.306: set a condition false at once).
    plc(&mut c, 3, &["IF (P1=0)", "P1=1", "CMD\"#1J+\"", "ENDIF", "IF (M162/(I108*32)>1000)", "CMD^K", "ENDIF"]);
    download(&mut c, &["I5=2 ENABLE PLC 3"]);
    step(&mut c, 2000);
    let status = &values(&mut c, "#1?")[0];
    let x = u32::from_str_radix(&status[..6], 16).unwrap();
    // Killed by the PLC's <CTRL-K>: open loop (bit 18), amplifier off (bit 19).
    assert!(x & (1 << 18) != 0 && x & (1 << 19) == 0, "{status}");
    let p = value(&mut c, "#1P");
    assert!(p > 1000.0 && p < 1020.0, "the jog ran until the PLC saw M162 past 1000 counts: {p}");
    let stopped = value(&mut c, "#1P");
    step(&mut c, 50);
    assert_eq!(value(&mut c, "#1P"), stopped, "killed: it moves no more");
    // A query from a PLC goes to no port, and a command it cannot read runs nothing after it.
    plc(&mut c, 4, &["CMD\"P5\"", "CMDS\"P6=6 FOO P7=7\"", "DISABLE PLC 4"]);
    download(&mut c, &["ENABLE PLC 4"]);
    step(&mut c, 10);
    assert_eq!([value(&mut c, "P6"), value(&mut c, "P7")], [6.0, 0.0]);
}

#[test]
fn m162_reads_the_actual_position_in_its_units_and_m166_the_velocity() {
    let mut c = card();
    download(&mut c, &["M162->D:$00008B M166->X:$00009D,0,24,S M174->D:$0000EF M262->D:$00010B"]);
    download(&mut c, &["#1J/ #1J=2000"]);
    step(&mut c, 30_000);
    assert_eq!(value(&mut c, "#1P"), 2000.0);
    assert_eq!(value(&mut c, "M162"), 2000.0 * 96.0 * 32.0, "1/(I108*32) counts");
    assert_eq!(value(&mut c, "M262"), 0.0);
    download(&mut c, &["#1J+"]);
    step(&mut c, 10_000);
    // Ixx22 = 32 counts/ms: 32 x 0.4427 counts a servo cycle, in 1/(I109*32) counts.
    let per_cycle = 32.0 * 3_713_707.0 / 8_388_608.0;
    let m166 = value(&mut c, "M166");
    assert!((m166 - per_cycle * 96.0 * 32.0).abs() <= 1.0, "{m166}");
    assert_eq!(value(&mut c, "M174"), m166, "the averaged velocity, D:$0000EF (no filter)");
    // V, counts per servo cycle to a tenth (SRM p.402), is the same velocity.
    assert_eq!(value(&mut c, "#1V"), (per_cycle * 10.0).round() / 10.0);
    let rh = values(&mut c, "RHX:$8B")[0].clone();
    let m = value(&mut c, "M162") as i64;
    assert_eq!(i64::from_str_radix(&rh, 16).unwrap(), (m >> 24) & 0xFF_FFFF, "RH reads the same register");
}

#[test]
fn a_reset_enables_every_stored_plc_and_blocks_that_do_not_match_are_not_run() {
    let mut c = card();
    plc(&mut c, 1, &["P1=P1+1"]);
    plc(&mut c, 2, &["IF (P1>0)", "P2=1"]);
    plc(&mut c, 3, &["P3=P3+1", "X100", "P4=1"]);
    download(&mut c, &["I5=2 SAVE", "$$$"]);
    step(&mut c, 30);
    // PLC 1, then 2 (refused: an IF without its ENDIF), then 3 (stopped at its move), then
    // PLC 1 alone for the other 27 background cycles.
    assert_eq!(value(&mut c, "P1"), 28.0, "PLC 2 is never run, 3 stops at X100");
    assert_eq!([value(&mut c, "P2"), value(&mut c, "P3"), value(&mut c, "P4")], [0.0, 1.0, 0.0]);
    // $$$*** puts no programs in use.
    c.line(b"$$$***");
    download(&mut c, &["I3=2 I6=1 I5=2 P1=0"]);
    step(&mut c, 10);
    assert_eq!(value(&mut c, "P1"), 0.0);
}

#[test]
fn a_hostile_plc_cannot_hold_the_card_and_the_watchdog_stays_fed() {
    let mut c = card();
    // An endless loop: a pass a scan, so the background and the watchdog go on.
    plc(&mut c, 1, &["WHILE (1<2)", "P1=P1+1", "ENDWHILE"]);
    // Thousands of lines with no loop: a scan runs at most 256 statements (MODEL).
    let long: Vec<String> = (0..4000).map(|_| "P2=P2+1".to_string()).collect();
    let long: Vec<&str> = long.iter().map(String::as_str).collect();
    plc(&mut c, 2, &long);
    // A command storm: each scan queues as many commands as the queue takes.
    plc(&mut c, 3, &["CMD\"P100..8191=1\"", "CMD\"P9=P9+1\""]);
    download(&mut c, &["I5=2 ENABLE PLC 1..3"]);
    assert_eq!(c.cycles_per_hold(), 64, "the card runs 64 servo cycles a hold while PLCs run");
    let started = Instant::now();
    step(&mut c, 6000);
    let took = started.elapsed();
    assert!(c.line(b"???").is_some(), "not tripped: the background went on");
    assert_eq!(value(&mut c, "P1"), 2000.0);
    // 256 statements a scan, and a scan also ends at the program's end: 16 scans go through
    // the 4,000 lines (15 of 256, one of 160).
    assert_eq!(value(&mut c, "P2"), 2000.0 / 16.0 * 4000.0);
    assert!(value(&mut c, "P9") > 100.0);
    // Per hold of the card's lock: 64 cycles of these three PLCs.
    let per_hold = took / (6000 / 64);
    assert!(per_hold.as_millis() < 50, "a hold took {per_hold:?}");
    eprintln!("6000 servo cycles of three hostile PLCs: {took:?}, {per_hold:?} a hold of 64 cycles");
}

#[test]
fn the_countdown_timers_count_servo_cycles_down_to_their_floor_in_the_active_coordinate_systems() {
    // SRM p.176: "If Coordinate System 'x' is activated by I68, Isx11 will count down one unit
    // per servo cycle ... until it reaches its maximum negative value of -8,388,608. It will
    // not roll over."
    let mut c = card();
    download(&mut c, &["I5111=100 I5112=5 I6612=-8388600"]);
    step(&mut c, 60);
    assert_eq!([value(&mut c, "I5111"), value(&mut c, "I5112"), value(&mut c, "I6612")], [40.0, -55.0, -8_388_608.0]);
    step(&mut c, 10_000_000);
    assert_eq!(value(&mut c, "I5111"), -8_388_608.0, "no roll-over");
    // I68 = 0: C.S. 1 alone is active, so C.S. 2's timer stays.
    download(&mut c, &["I68=0 I5111=10 I5211=10"]);
    step(&mut c, 4);
    assert_eq!([value(&mut c, "I5111"), value(&mut c, "I5211")], [6.0, 10.0]);
}

#[test]
fn a_plc_too_long_to_run_is_kept_listed_and_stopped_with_the_reason() {
    let mut c = card();
    let lines: Vec<String> = (0..4097).map(|k| format!("P{}={k}", k % 100)).collect();
    let lines: Vec<&str> = lines.iter().map(String::as_str).collect();
    plc(&mut c, 5, &lines);
    let said = std::sync::Arc::new(std::sync::Mutex::new(Vec::new()));
    let to = said.clone();
    c.on_console(Box::new(move |l| to.lock().unwrap().push(l.to_string())));
    download(&mut c, &["I5=2 ENABLE PLC 5"]);
    step(&mut c, 10);
    assert_eq!(value(&mut c, "P99"), 0.0, "not run");
    assert_eq!(values(&mut c, "LIST PLC 5,4096"), ["P96=4096"]);
    let said = said.lock().unwrap();
    assert!(said.iter().any(|l| l.contains("PLC 5 stopped") && l.contains("4097 lines")), "{said:?}");
    // The longest that runs: 4,096 lines, compiled in one hold.
    let mut c = card();
    plc(&mut c, 5, &lines[..4096]);
    download(&mut c, &["I5=2 ENABLE PLC 5"]);
    let started = Instant::now();
    step(&mut c, 1);
    eprintln!("a PLC of 4,096 lines compiled and scanned once: {:?}", started.elapsed());
    // The first scan's 256 statements (lines 0..255) ran, the 257th not.
    assert_eq!([value(&mut c, "P55"), value(&mut c, "P56")], [255.0, 156.0]);
}

#[test]
fn a_plc_enabled_again_starts_at_its_top_and_one_running_goes_on() {
    let mut c = card();
    plc(&mut c, 1, &["P1=P1+1", "WHILE (P1<100)", "P2=P2+1", "ENDWHILE"]);
    download(&mut c, &["I5=2 ENABLE PLC 1"]);
    step(&mut c, 5);
    assert_eq!([value(&mut c, "P1"), value(&mut c, "P2")], [1.0, 5.0], "in its WHILE");
    download(&mut c, &["ENABLE PLC 1"]);
    step(&mut c, 1);
    assert_eq!(value(&mut c, "P1"), 1.0, "already running: it goes on in its WHILE");
    download(&mut c, &["DISABLE PLC 1", "ENABLE PLC 1"]);
    step(&mut c, 1);
    assert_eq!(value(&mut c, "P1"), 2.0, "enabled again: from its top (MODEL)");
}

#[test]
fn a_line_waiting_on_a_starved_card_with_plcs_holds_the_card_a_few_cycles_at_a_time() {
    use pmacwd_emulator::card::{LineRun, Progress};
    use pmacwd_specs::grammar::Addressing;
    let mut c = card();
    plc(&mut c, 1, &["P1=P1+1"]);
    download(&mut c, &["I5=2 ENABLE PLC 1"]);
    c.control(Control::Starve);
    // Past the instant of the last background cycle, which would answer the line at once.
    step(&mut c, 10);
    // In virtual time the waiting line runs the card itself until a background cycle comes,
    // which on a starved card is never: it trips (UM p.215). Each step holds the card for at
    // most a hold's cycles, 64 while PLCs run, one servo cycle at a time.
    let mut run = LineRun::new(b"???");
    let mut addressing = Addressing::default();
    let mut out = Vec::new();
    let (mut steps, mut longest) = (0, std::time::Duration::ZERO);
    loop {
        let started = Instant::now();
        let progress = c.line_step(&mut run, &mut addressing, &mut out);
        longest = longest.max(started.elapsed());
        steps += 1;
        match progress {
            Progress::Waiting(_) | Progress::More => continue,
            Progress::Silent => break,
            other => panic!("{other:?}"),
        }
    }
    assert!(steps > 4141 / 64, "{steps} steps of at most 64 cycles up to the trip");
    assert!(longest.as_millis() < 20, "the longest step held the card {longest:?}");
    eprintln!("{steps} steps up to the trip, the longest {longest:?}");
}
