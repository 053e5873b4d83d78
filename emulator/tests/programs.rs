//! Stored buffers and motion programs (issue 30): what a host downloads with `OPEN ... CLOSE`
//! is kept and listed back, and a coordinate system runs a motion program so that its axes
//! arrive where the program says, within what the core says of each motor.

use pmacwd_emulator::card::{Card, Clock};
use pmacwd_emulator::control::Control;

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

fn download(c: &mut Card, lines: &[&str]) {
    for line in lines {
        assert_eq!(c.line(line.as_bytes()).unwrap(), b"\x06", "{line}");
    }
}

#[test]
fn a_downloaded_plc_and_program_list_back_whole_and_in_part() {
    let mut c = card();
    download(&mut c, &["OPEN PLC 1 CLEAR", "DISABLE PLC 1", "IF (M1=1) ; a comment", "  P1=P1+1", "ENDIF", "CLOSE"]);
    assert_eq!(values(&mut c, "LIST PLC 1"), ["DISABLE PLC 1", "IF (M1=1)", "P1=P1+1", "ENDIF"]);
    assert_eq!(values(&mut c, "LIST PLC 1,1,2"), ["IF (M1=1)", "P1=P1+1"]);
    assert_eq!(values(&mut c, "LIST PLC 1,3"), ["ENDIF"]);
    assert!(values(&mut c, "LIST PLC 2").is_empty(), "never downloaded");
    // One line opening, filling and closing a buffer; then an on-line command.
    assert_eq!(values(&mut c, "OPEN PROG 3 CLEAR X100 Y200 CLOSE I130"), ["2000"]);
    assert_eq!(values(&mut c, "LIST PROG 3"), ["X100 Y200"]);
    // A second download after OPEN without CLEAR adds to the end (UM p.48).
    download(&mut c, &["OPEN PROG 3", "X0", "CLOSE"]);
    assert_eq!(values(&mut c, "LIST PROG 3"), ["X100 Y200", "X0"]);
    // PLC 0, the one the control port's load stands for, is a buffer like the others, and
    // the starvation the control port causes still trips the card.
    download(&mut c, &["OPEN PLC 0 CLEAR", "P0=P0+1", "CLOSE"]);
    assert_eq!(values(&mut c, "LIST PLC 0"), ["P0=P0+1"]);
    c.control(Control::Starve);
    c.control(Control::Step { cycles: 5000 });
    assert_eq!(c.line(b"???"), None, "tripped");
}

#[test]
fn buffers_survive_a_reset_once_saved_and_reinitialization_empties_them() {
    let mut c = card();
    download(&mut c, &["OPEN PROG 1 CLEAR", "X1", "CLOSE", "SAVE", "OPEN PROG 2", "X2", "CLOSE"]);
    download(&mut c, &["$$$"]);
    assert_eq!(values(&mut c, "LIST PROG 1"), ["X1"]);
    assert!(values(&mut c, "LIST PROG 2").is_empty(), "not saved");
    c.line(b"$$$***");
    c.line(b"I3=2 I6=1");
    assert!(values(&mut c, "LIST PROG 1").is_empty());
}

/// Servo cycles of the default I10 (SRM p.42-43) in `ms` milliseconds.
fn cycles(ms: f64) -> u32 {
    (ms * 8_388_608.0 / 3_713_707.0).ceil() as u32
}

fn step(c: &mut Card, ms: f64) {
    assert!(c.control(Control::Step { cycles: cycles(ms) }).starts_with("ok"));
}

fn position(c: &mut Card, motor: u8) -> f64 {
    values(c, &format!("#{motor}P"))[0].parse().unwrap()
}

/// `&n??` as its three words.
fn cs_status(c: &mut Card, cs: u8) -> [u32; 3] {
    let w = values(c, &format!("&{cs}??"))[0].clone();
    assert_eq!(w.len(), 18, "{w}");
    [0, 6, 12].map(|i| u32::from_str_radix(&w[i..i + 6], 16).unwrap())
}

/// The EPICS driver's C.S. "done" (pmacHardwareTurbo::parseCSStatus): not running a program,
/// and in position (second word bit 17).
fn cs_done(c: &mut Card, cs: u8) -> bool {
    let [a, b, _] = cs_status(c, cs);
    a & 1 == 0 && b & (1 << 17) != 0
}

/// DLS's PROG10_CS_motion.pmc (pmac/pmacApp/pmc), sent line by line as a download tool sends
/// a file: comments and blank lines left out.
const PROG10: &str = "CLOSE
i5213,15,100=10
i5220,15,100=50
i5250,15,100=1
OPEN PROG 10
CLEAR
LINEAR
ABS
FRAX(A,B,C,U,V,W,X,Y,Z)
TM(Q70)
A(Q71)B(Q72)C(Q73)U(Q74)V(Q75)W(Q76)X(Q77)Y(Q78)Z(Q79)
DWELL0
CLOSE";

/// A card with PROG10 downloaded, motors 1 and 2 as X and Y of C.S. 1 (1000 counts a unit),
/// their loops closed.
fn prog10_card() -> Card {
    let mut c = card();
    download(&mut c, &PROG10.lines().collect::<Vec<_>>());
    download(&mut c, &["&1#1->1000X", "&1#2->-500Y+10", "#1J/#2J/"]);
    c
}

#[test]
fn prog10_lists_back_as_downloaded() {
    let mut c = prog10_card();
    assert_eq!(
        values(&mut c, "LIST PROG 10"),
        [
            "LINEAR",
            "ABS",
            "FRAX(A,B,C,U,V,W,X,Y,Z)",
            "TM(Q70)",
            "A(Q71)B(Q72)C(Q73)U(Q74)V(Q75)W(Q76)X(Q77)Y(Q78)Z(Q79)",
            "DWELL0"
        ]
    );
    assert_eq!(values(&mut c, "&1#1-> &1#2->"), ["1000X", "-500Y+10"]);
}

#[test]
fn the_epics_drivers_cs_move_runs_prog10_and_the_axes_arrive_where_it_says() {
    let mut c = prog10_card();
    assert!(cs_done(&mut c, 1), "at rest, in position, no program");
    // pmacCSAxis::move: `&1E`, then `&1Q70=... I5187=... Q7n=... B10R`: 500 ms, TA 100 ms.
    assert_eq!(c.line(b"&1E").unwrap(), b"\x06");
    assert_eq!(c.line(b"&1Q70=500.000000 I5187=100.000000Q77=2.000000000000 Q78=3 B10R").unwrap(), b"\x06");
    let [a, _, _] = cs_status(&mut c, 1);
    assert_eq!(a & 0b11001, 0b11001, "running, by time, continuous: {a:06X}");
    assert!(!cs_done(&mut c, 1));
    step(&mut c, 300.0);
    let (x, y) = (position(&mut c, 1), position(&mut c, 2));
    // Halfway in time, halfway in distance (a symmetric profile).
    assert!((900.0..1100.0).contains(&x), "{x}");
    assert!((-800.0..-700.0).contains(&y), "{y}");
    assert!(!cs_done(&mut c, 1));
    step(&mut c, 295.0);
    assert!(!cs_done(&mut c, 1), "5 ms before the end (TM + TA = 600 ms) it still moves");
    step(&mut c, 10.0);
    assert!(cs_done(&mut c, 1), "{:06X?}", cs_status(&mut c, 1));
    // X = 2 units of 1000 counts; Y = 3 units of -500 counts plus 10.
    assert_eq!((position(&mut c, 1), position(&mut c, 2)), (2000.0, -1490.0));
    assert_eq!(values(&mut c, "#1?")[0].as_bytes()[11], b'1', "motor 1 in position");
    // TA and TM read back (SRM p.188-189).
    assert_eq!(values(&mut c, "I5187 I5189"), ["100", "500"]);
    // A jog after the program: the core's program stopped at its end.
    values(&mut c, "#1J^-1000");
    step(&mut c, 200.0);
    assert_eq!(position(&mut c, 1), 1000.0);
    // The jog ended at its target (the core heard J/ then, card/motion.rs): the program runs
    // again at once.
    // And the move again from there, to the same place.
    values(&mut c, "&1E &1Q70=100 B10R");
    step(&mut c, 250.0);
    assert_eq!((position(&mut c, 1), position(&mut c, 2)), (2000.0, -1490.0));
}

#[test]
fn abort_stops_the_move_at_ixx15_and_the_program_runs_again_from_its_top() {
    let mut c = prog10_card();
    values(&mut c, "&1E &1Q70=1000 I5187=100 Q77=10 Q78=0 B10R");
    step(&mut c, 500.0);
    let v: f64 = values(&mut c, "#1V")[0].parse().unwrap();
    assert!(v > 4.0, "10,000 counts in 1,000 ms: 10 counts/ms, {v} counts/cycle");
    // The driver's stop: `&1A Q77=Q87`.
    values(&mut c, "&1A Q77=Q87");
    let at = position(&mut c, 1);
    // 10 counts/ms at Ixx15 = 0.25 counts/ms²: 40 ms and 200 counts.
    step(&mut c, 45.0);
    let stopped = position(&mut c, 1);
    assert!((stopped - at - 200.0).abs() < 20.0, "{at} -> {stopped}");
    assert!(cs_done(&mut c, 1));
    step(&mut c, 1000.0);
    assert_eq!(position(&mut c, 1), stopped, "no further motion");
    values(&mut c, "Q77=10 B10R");
    step(&mut c, 1200.0);
    assert_eq!(position(&mut c, 1), 10_000.0);
}

#[test]
fn hold_stops_on_the_path_and_run_resumes_to_the_end() {
    let mut c = prog10_card();
    values(&mut c, "&1E &1Q70=1000 I5187=100 Q77=4 Q78=2 B10R");
    step(&mut c, 400.0);
    values(&mut c, "&1H");
    step(&mut c, 150.0);
    let (x, y) = (position(&mut c, 1), position(&mut c, 2));
    assert_eq!(values(&mut c, "#1V #2V"), ["0", "0"]);
    // On the path: the axes started where the motors stood (Y = (0 - 10) / -500 = 0.02), so
    // Y's distance is -990 counts to X's 4000.
    assert!((y / x + 990.0 / 4000.0).abs() < 1e-3, "{x} {y}");
    step(&mut c, 500.0);
    assert_eq!(position(&mut c, 1), x, "held");
    assert_eq!(cs_status(&mut c, 1)[0] & 1, 1, "a held program still runs (SRM p.260)");
    values(&mut c, "&1R");
    step(&mut c, 1500.0);
    assert!(cs_done(&mut c, 1), "{:06X?} {:?}", cs_status(&mut c, 1), values(&mut c, "#1P #2P #1? #2?"));
    assert_eq!((position(&mut c, 1), position(&mut c, 2)), (4000.0, -990.0));
}

#[test]
fn incremental_feedrate_moves_step_one_at_a_time_and_a_kill_ends_the_program() {
    let mut c = card();
    download(&mut c, &["&1#1->1000X", "&1E", "OPEN PROG 2 CLEAR", "INC TA50 TS0 F10", "X1", "X1", "X1", "CLOSE"]);
    // F10 units a second (Isx90 = 1000 ms): 1 unit in 100 ms, plus 50 ms of acceleration.
    values(&mut c, "&1B2S");
    assert_eq!(cs_status(&mut c, 1)[0] & 0b1010, 0b0010, "single-step mode, feedrate mode");
    step(&mut c, 200.0);
    assert_eq!(position(&mut c, 1), 1000.0);
    step(&mut c, 200.0);
    assert_eq!(position(&mut c, 1), 1000.0, "one move only");
    values(&mut c, "&1R");
    step(&mut c, 100.0);
    // UM p.319: K is not permitted while the motor's C.S. runs a program; <CTRL-K> is.
    assert_eq!(c.line(b"#1K").unwrap(), b"\x07ERR001\r");
    assert!(cs_status(&mut c, 1)[0] & 1 == 1, "running");
    let at = position(&mut c, 1);
    assert!(at > 1000.0 && at < 2000.0, "{at}");
    values(&mut c, "\x0b");
    step(&mut c, 500.0);
    assert_eq!(position(&mut c, 1), at, "killed where it was");
    assert_eq!(cs_status(&mut c, 1)[0] & 1, 0, "the program is lost (UM p.319)");
}

#[test]
fn a_statement_the_emulator_does_not_execute_stops_the_program_with_a_run_time_error() {
    let mut c = card();
    download(&mut c, &["&1#1->X", "&1E", "OPEN PROG 3 CLEAR", "TM100 TA10 X100", "CIRCLE1 X0 Y100 I50", "X0", "CLOSE"]);
    values(&mut c, "&1B3R");
    step(&mut c, 300.0);
    assert_eq!(position(&mut c, 1), 100.0, "the move before it ran");
    let [a, b, _] = cs_status(&mut c, 1);
    assert_eq!((a & 1, b & (1 << 22)), (0, 1 << 22), "stopped, run-time error (SRM p.286)");
    // B clears it; a program that was never downloaded ends at once.
    values(&mut c, "&1B4R");
    step(&mut c, 10.0);
    assert_eq!(cs_status(&mut c, 1)[1] & (1 << 22), 0);
    assert!(cs_done(&mut c, 1));
}

#[test]
fn a_running_program_that_sets_a_locked_i_variable_is_ignored_without_error() {
    // SRM p.57: with I41's controlling bit set, "a buffered program command" setting an
    // I-variable of the locked range "is ignored (no error is generated)": the program runs
    // on. Bit 0 locks the motor setup variables (I100..I4899), not P-variables or I5187's
    // C.S. range; I41 = 0 lets the same program's write through.
    let mut c = card();
    download(
        &mut c,
        &["&1#1->1000X", "&1E", "OPEN PROG 5 CLEAR", "TM50 TA10", "I130=77 P1=1 X1", "I5187=20 P2=2 X2", "CLOSE"],
    );
    assert_eq!(values(&mut c, "I130"), ["2000"]);
    values(&mut c, "I41=1 &1B5R");
    step(&mut c, 2000.0);
    assert!(cs_done(&mut c, 1), "the program ran to its end");
    let [_, b, _] = cs_status(&mut c, 1);
    assert_eq!(b & (1 << 22), 0, "no run-time error (SRM p.286)");
    assert_eq!(position(&mut c, 1), 2000.0, "both moves after the locked write ran");
    assert_eq!(values(&mut c, "I130 P1 P2 I5187"), ["2000", "1", "2", "20"], "only the locked write ignored");
    // Unlocked, the same statement writes.
    values(&mut c, "I41=0 &1B5R");
    step(&mut c, 2000.0);
    assert!(cs_done(&mut c, 1));
    assert_eq!(values(&mut c, "I130"), ["77"]);
}

#[test]
fn a_motion_program_runs_if_else_while_and_cmd_and_its_axes_arrive_where_its_logic_says() {
    // UM p.252-253 (conditions; one-line IF and WHILE in motion programs), SRM p.429-430
    // (ELSE, and its one-line form after a one-line IF), SRM p.421-422 (COMMAND).
    let mut c = card();
    download(
        &mut c,
        &[
            "&1#1->1000X",
            "&1E",
            "OPEN PROG 6 CLEAR",
            "TM50 TA10 INC",
            "P1=0",
            "WHILE (P1<3)",
            "X1",
            "P1=P1+1",
            "ENDWHILE",
            "IF (P1=3)",
            "P2=1",
            "ELSE",
            "P2=2",
            "ENDIF",
            "IF (P1!<5) X10",
            "ELSE X-1",
            "IF (P1>2) P3=7",
            "WHILE (P4<4) P4=P4+1",
            "CMD\"P5=42\"",
            "CLOSE",
        ],
    );
    values(&mut c, "&1B6R");
    step(&mut c, 1000.0);
    let [_, b, _] = cs_status(&mut c, 1);
    assert_eq!(b & (1 << 22), 0, "no run-time error (SRM p.286)");
    assert!(cs_done(&mut c, 1), "the program ran to its end");
    assert_eq!(position(&mut c, 1), 2000.0, "three moves of 1 in the loop, then the ELSE line's -1");
    assert_eq!(values(&mut c, "P1 P2 P3 P4 P5"), ["3", "1", "7", "4", "42"]);
}

#[test]
fn a_while_loop_without_a_move_makes_two_passes_a_real_time_interrupt_and_wait_waits_for_one() {
    // UM p.341-342: the double-jump-back rule, and WHILE ({condition}) WAIT.
    let mut c = card();
    download(
        &mut c,
        &[
            "&1#1->1000X",
            "&1E",
            "OPEN PROG 7 CLEAR",
            "TM50 TA10",
            "WHILE (P4=0)",
            "P3=P3+1",
            "ENDWHILE",
            "WHILE (P6=0) WAIT",
            "X1",
            "CLOSE",
        ],
    );
    values(&mut c, "&1B7R");
    // 300 servo cycles: 100 real-time interrupts at the default I8 = 2 (SRM p.42).
    assert!(c.control(Control::Step { cycles: 300 }).starts_with("ok"));
    let passes: f64 = values(&mut c, "P3")[0].parse().unwrap();
    assert!((190.0..=204.0).contains(&passes), "two passes an RTI: {passes}");
    assert_eq!(cs_status(&mut c, 1)[0] & 1, 1, "still running");
    values(&mut c, "P4=1");
    step(&mut c, 200.0);
    let at: f64 = values(&mut c, "P3")[0].parse().unwrap();
    assert!(at - passes <= 2.0, "left the loop at the next RTI: {passes} -> {at}");
    assert_eq!(position(&mut c, 1), 0.0, "waiting on P6");
    values(&mut c, "P6=1");
    step(&mut c, 400.0);
    assert_eq!(position(&mut c, 1), 1000.0);
    assert!(cs_done(&mut c, 1), "{:06X?} {:?}", cs_status(&mut c, 1), values(&mut c, "#1? P3 P4 P6"));
}

#[test]
fn what_is_a_plcs_only_stops_a_motion_program_with_a_run_time_error() {
    // SRM p.422: "There is no modal ADDRESS command in motion programs"; UM p.253: conditions
    // over several lines are PLC programs' only.
    for (n, lines) in [(8, ["ADDRESS#2", "X1"]), (9, ["IF (P1=0)", "AND (P2=0)"])] {
        let mut c = card();
        download(&mut c, &["&1#1->1000X", "&1E", &format!("OPEN PROG {n} CLEAR"), "TM50 TA10"]);
        download(&mut c, &lines);
        download(&mut c, &["ENDIF", "CLOSE"][usize::from(n == 8)..]);
        values(&mut c, &format!("&1B{n}R"));
        step(&mut c, 200.0);
        let [a, b, _] = cs_status(&mut c, 1);
        assert_eq!((a & 1, b & (1 << 22)), (0, 1 << 22), "PROG {n}: stopped, run-time error");
        assert_eq!(position(&mut c, 1), 0.0);
    }
}
