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
