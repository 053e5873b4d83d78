//! The grammar rule by rule: the command lines real clients send, the manual's examples, and
//! what ends a line.

use super::*;
use crate::vocab::command::{CsCommand, GlobalCommand, Motion, MotorCommand, Space};

fn parse(line: &str) -> Vec<Result<Command, Unreadable>> {
    parse_line(line.as_bytes(), &mut Addressing::default())
}

fn ok(line: &str) -> Vec<Command> {
    parse(line).into_iter().map(|r| r.unwrap_or_else(|e| panic!("{line}: {e:?}"))).collect()
}

fn read(kind: VarKind, n: u16, cs: u8) -> Command {
    Command::Read { kind, vars: Vars::Numbers(VarRange::one(n)), cs }
}

fn write(kind: VarKind, n: u16, v: f64, cs: u8) -> Command {
    Command::Write { kind, vars: Vars::Numbers(VarRange::one(n)), value: Assigned::Expr(Expr::Const(v)), cs }
}

#[test]
fn the_dls_pmaccontrol_poll_line_reads_as_its_52_requests() {
    // commsThread.py builds this for 8 axes; the GUI splits the answer at CR and expects
    // 4 + 6 x 8 values, so each piece must be one command.
    let mut line = String::from("i65???&1??%");
    for m in 1..=8 {
        line += &format!("#{m}?PVF m{m}90 p99");
    }
    let cmds = ok(&line);
    assert_eq!(cmds.len(), 52);
    assert_eq!(cmds[0], read(VarKind::I, 65, 1));
    assert_eq!(cmds[1], Command::GlobalStatus);
    assert_eq!(cmds[2], Command::CsStatus(1));
    assert_eq!(cmds[3], Command::FeedRead(1));
    for m in 1..=8u8 {
        let row = &cmds[4 + 6 * usize::from(m - 1)..][..6];
        assert_eq!(
            row,
            [
                Command::MotorStatus(m),
                Command::Position(m),
                Command::Velocity(m),
                Command::FollowingError(m),
                read(VarKind::M, u16::from(m) * 100 + 90, 1),
                read(VarKind::P, 99, 1),
            ]
        );
    }
    assert_eq!(cmds.iter().map(|c| c.values().unwrap()).sum::<usize>(), 52, "one value each");
}

#[test]
fn question_marks_count_one_two_or_three() {
    // `?` motor, `??` C.S., `???` global (SRM p.284 for ? and ??).
    let mut a = Addressing::default();
    let cmds: Vec<_> = parse_line(b"#3&2?????? ?", &mut a).into_iter().map(Result::unwrap).collect();
    assert_eq!(cmds, [Command::GlobalStatus, Command::GlobalStatus, Command::MotorStatus(3)]);
    assert_eq!(ok("&2??"), [Command::CsStatus(2)]);
}

#[test]
fn addressing_persists_across_lines_of_one_connection() {
    let mut a = Addressing::default();
    parse_line(b"#4&3", &mut a);
    assert_eq!(a, Addressing { motor: 4, cs: 3 });
    let cmds: Vec<_> = parse_line(b"P ?? K", &mut a).into_iter().map(Result::unwrap).collect();
    assert_eq!(
        cmds,
        [Command::Position(4), Command::CsStatus(3), Command::Motion(Motion::Motor(4, MotorCommand::Kill))]
    );
    assert_eq!(parse_line(b"#", &mut a), [Ok(Command::ReportMotor)]);
}

#[test]
fn jog_home_and_kill_as_the_gui_buttons_send_them() {
    assert_eq!(ok("#1J^1000"), [Command::Jog(1, Jog::ByFromActual(1000.0))]);
    assert_eq!(ok("#1J^-250.5"), [Command::Jog(1, Jog::ByFromActual(-250.5))]);
    assert_eq!(ok("#1J:-5"), [Command::Jog(1, Jog::ByFromCommanded(-5.0))]);
    assert_eq!(ok("#1HM"), [Command::Home(1)]);
    assert_eq!(ok("#1 HOME"), [Command::Home(1)]);
    assert_eq!(ok("#2HMZ"), [Command::HomeZero(2)]);
    assert_eq!(ok("#1J/"), [Command::Motion(Motion::Motor(1, MotorCommand::JogStop))]);
    assert_eq!(ok("#1J=0"), [Command::Jog(1, Jog::To(Some(0.0)))]);
    assert_eq!(ok("#2J="), [Command::Jog(2, Jog::To(None))]);
    assert_eq!(ok("#1k"), [Command::Motion(Motion::Motor(1, MotorCommand::Kill))]);
    assert_eq!(
        ok("#1 J/ #2 K"),
        [
            Command::Motion(Motion::Motor(1, MotorCommand::JogStop)),
            Command::Motion(Motion::Motor(2, MotorCommand::Kill))
        ]
    );
}

#[test]
fn control_characters_are_commands_anywhere_in_a_line() {
    // KILL ALL in dls-pmaccontrol sends CTRL-K as a line of its own (SRM p.289's <CTRL-K>).
    assert_eq!(ok("\x0b"), [Command::Motion(Motion::Global(GlobalCommand::KillAll))]);
    assert_eq!(ok("P1\x01P2").len(), 3);
    assert_eq!(ok("\x11\x0f")[1], Command::Motion(Motion::Global(GlobalCommand::HoldAll)));
    assert_eq!(ok("<ctrl-k>"), [Command::Motion(Motion::Global(GlobalCommand::KillAll))], "as a trace writes it");
    assert!(parse("\x02").last().unwrap().is_err(), "CTRL-B is not emulated: ERR003");
}

#[test]
fn variables_read_write_and_ranges() {
    assert_eq!(ok("i20..23"), [Command::Read { kind: VarKind::I, vars: Vars::Numbers(VarRange::run(20, 23)), cs: 1 }]);
    assert_eq!(ok("I124=$20001"), [write(VarKind::I, 124, 131073.0, 1)]);
    assert_eq!(ok("P1=-1.5"), [write(VarKind::P, 1, -1.5, 1)]);
    assert_eq!(ok("&2Q81"), [read(VarKind::Q, 81, 2)]);
    assert_eq!(ok("i6=1 i3=2 ver").len(), 3);
    assert!(parse("I8192").last().unwrap().is_err());
    let y = Definition::parse("Y:$078F00,0,24,S").unwrap();
    assert_eq!(
        ok("M190->Y:$078F00,0,24,S M191->* M0..8191->*"),
        [
            Command::MDefine { first: 190, last: 190, definition: y },
            Command::MDefine { first: 191, last: 191, definition: Definition::SelfReferenced },
            Command::MDefine { first: 0, last: 8191, definition: Definition::SelfReferenced },
        ]
    );
    assert_eq!(ok("M1..3->"), [Command::MReport { first: 1, last: 3 }], "a report, not a definition");
    assert_eq!(
        ok("M1..8=0"),
        [Command::Write {
            kind: VarKind::M,
            vars: Vars::Numbers(VarRange::run(1, 8)),
            value: Assigned::Expr(Expr::Const(0.0)),
            cs: 1
        }]
    );
    let x = Definition::Word { space: Space::X, address: 0x2082, offset: 0, width: 24, format: Format::U };
    assert_eq!(ok("WX:$2082,7,-1"), [Command::MemoryWrite { kind: x, values: vec![7.0, -1.0] }]);
    assert!(parse("M1->X:$25").last().unwrap().is_err(), "an X definition gives its bit");
    assert!(parse("P1->X:$0").last().unwrap().is_err());
    assert!(parse("I23..20").last().unwrap().is_err());
}

#[test]
fn the_issue_s_lines_read_as_the_manual_writes_them() {
    // `I130,4,100`: four values, I130 to I430 (SRM on-line `I{constant},{constant},{constant}`).
    let r = VarRange { first: 130, count: 4, step: 100 };
    assert_eq!(ok("I130,4,100"), [Command::Read { kind: VarKind::I, vars: Vars::Numbers(r), cs: 1 }]);
    assert_eq!(r.numbers().collect::<Vec<_>>(), [130, 230, 330, 430]);
    assert_eq!(ok("I130,4,100")[0].values(), Some(4));
    assert_eq!(
        ok("I130,3")[0],
        Command::Read { kind: VarKind::I, vars: Vars::Numbers(VarRange::run(130, 132)), cs: 1 }
    );
    assert!(parse("I8000,4,100").last().unwrap().is_err(), "past I8191");
    // Expressions (UM p.248).
    let c = &ok("I130=1.25*I130")[0];
    assert_eq!(c.to_string(), "I130=1.25*I130");
    assert_eq!(ok("M162=1000/0.0009765625")[0].to_string(), "M162=1000/0.0009765625");
    assert_eq!(ok("I222=0.5"), [write(VarKind::I, 222, 0.5, 1)]);
    assert_eq!(
        ok("I130=*"),
        [Command::Write { kind: VarKind::I, vars: Vars::Numbers(VarRange::one(130)), value: Assigned::Default, cs: 1 }]
    );
    assert!(parse("P1=*").last().unwrap().is_err(), "only I-variables have a factory default");
    assert_eq!(ok("I(P1*100+20)=10")[0].to_string(), "I(P1*100+20)=10");
    assert_eq!(ok("&1A Q71=Q81")[1].to_string(), "&1Q71=Q81");
    assert_eq!(ok("cpu"), [Command::Cpu]);
    // The EPICS driver's axis definitions and their report (`&n#m->,`, every poll).
    assert_eq!(ok("&1#1->,"), [Command::AxisReport { cs: 1, motor: 1 }]);
    assert_eq!(ok("&2#3->"), [Command::AxisReport { cs: 2, motor: 3 }]);
    assert_eq!(ok("&1 #1->1000X"), [Command::AxisDefine { cs: 1, motor: 1, definition: "1000X".into() }]);
    assert_eq!(ok("&1#2->-500Y+10 #3->I").len(), 2);
    assert_eq!(ok("undefine all"), [Command::Undefine { cs: None }]);
    assert_eq!(ok("&3UNDEFINE"), [Command::Undefine { cs: Some(3) }]);
    assert!(parse("#1->X+").last().unwrap().is_err(), "a term after +");
    assert_eq!(
        ok("#1->Q"),
        [Command::AxisReport { cs: 1, motor: 1 }, Command::Motion(Motion::CoordinateSystem(1, CsCommand::Quit))]
    );
    // The feedrate with a fraction, as the driver writes it.
    assert_eq!(ok("&1%100.000000"), [Command::Feed { cs: 1, percent: 100.0 }]);
}

#[test]
fn the_epics_driver_s_lines_read_whole() {
    // pmacAxis.cpp, pmacController.cpp, pmacCsGroups.cpp, pmacCSController.cpp (DiamondLightSource/pmac).
    for (line, n) in [
        ("I122=2.000000 I120=500.000000 #1 J=2000.00", 3),
        (" i124=i124&$FDFFFF", 1),
        (" i124=i124|$20000", 1),
        ("#1 J/ M140=1", 2),
        ("&1A Q71=Q81", 2),
        ("#1K M161=0*32*I108 M162=0*32*I108", 3),
        ("I113=0 I114=0", 2),
        ("&1Q70=1.500000 ", 1),
        ("I5187=100.000000", 1),
        ("&1Q71=10.000000000000 B1R", 3),
        ("DELETE ALL TEMPS", 1),
        ("&1DEFINE LOOKAHEAD 50,10", 1),
        ("&1 list forward,0,1", 1),
        ("WL:$10000,$400000000801,$400000000802", 1),
        ("ms0,i912 ms0,i913 i124 i123 i126", 5),
        (" &1#1->, &1#2->, #1? #1P", 4),
        // pmacCSAxis::move: the enable, then the move line (issue 30).
        ("&1e", 1),
        ("&1&1Q70=500.000000 I5187=100.000000Q77=2.000000000000 B10R", 5),
        ("&1 I5187=100.000000Q77=1.000000000000 I5187=100.000000Q78=-1.000000000000 Q70=800.000000 B10R", 7),
    ] {
        assert_eq!(ok(line).len(), n, "{line}");
    }
}

#[test]
fn keywords_win_over_single_letters() {
    assert_eq!(ok("SAVE"), [Command::Save]);
    assert_eq!(
        ok("define gather 1000 gather list gather delete gather endgather"),
        [
            Command::Gather(Gather::Define(Some(1000))),
            Command::Gather(Gather::Start),
            Command::Gather(Gather::List),
            Command::Gather(Gather::Delete),
            Command::Gather(Gather::End),
        ]
    );
    assert_eq!(
        ok("ENABLE PLC 1,2 DISABLE PLCC 0..3 DIS PLC 5 ENA PLC18 DISABLE PLC2..4, 31"),
        [
            Command::PlcSwitch(PlcSwitch { enable: true, compiled: false, plcs: 0b110 }),
            Command::PlcSwitch(PlcSwitch { enable: false, compiled: true, plcs: 0b1111 }),
            Command::PlcSwitch(PlcSwitch { enable: false, compiled: false, plcs: 1 << 5 }),
            Command::PlcSwitch(PlcSwitch { enable: true, compiled: false, plcs: 1 << 18 }),
            Command::PlcSwitch(PlcSwitch { enable: false, compiled: false, plcs: 0b11100 | 1 << 31 }),
        ]
    );
    // The printed form reads back as the same switch.
    let all = Command::PlcSwitch(PlcSwitch { enable: false, compiled: false, plcs: 0b11100 | 1 << 31 });
    assert_eq!(ok(&all.to_string()), [all]);
    assert!(pieces(b"ENABLE PLC 32", &mut Addressing::default())[0].command.is_err());
    assert!(pieces(b"DISABLE PLC 5..3", &mut Addressing::default())[0].command.is_err());
    assert_eq!(ok("ms0,i910"), [Command::MacroStation { station: 0, ivar: 910, value: None }]);
    assert_eq!(ok("OPEN PLC 1 CLOSE"), [Command::OpenPlc(1), Command::Close]);
    assert_eq!(ok("&1%50 %"), [Command::Feed { cs: 1, percent: 50.0 }, Command::FeedRead(1)]);
    assert_eq!(ok("RHX:$25"), [Command::ReadHex { space: Space::X, address: 0x25 }]);
    assert_eq!(
        ok("LIST PROG 3,10,5"),
        [Command::List(Listing::Program { number: 3, start: Some(10), length: Some(5) })]
    );
    assert_eq!(ok("LIST PLC 2"), [Command::List(Listing::Plc { number: 2, start: None, length: None })]);
    // SRM p.295: B{constant} points at program {constant}; E (the EPICS driver's enable).
    assert_eq!(
        ok("&2B10R B E"),
        [
            Command::Begin { cs: 2, program: Some(10) },
            Command::Motion(Motion::CoordinateSystem(2, CsCommand::Run)),
            Command::Begin { cs: 2, program: None },
            Command::Motion(Motion::CoordinateSystem(2, CsCommand::Enable)),
        ]
    );
    // UM p.243, SRM p.295, SRM p.57 (the memory write is the vocabulary's pseudo-command).
    assert_eq!(
        ok("$$$***CHKS checksum <memory-write i130=$10>I130"),
        [
            Command::Reinitialize,
            Command::Checksum,
            Command::Checksum,
            Command::WriteIMemory(130, 16),
            read(VarKind::I, 130, 1),
        ]
    );
    assert_eq!(ok("$$$ $$$***"), [Command::Reset, Command::Reinitialize]);
    assert!(parse("<MEMORY-WRITE I130>")[0].is_err(), "a memory write needs its value");
    assert!(parse("<MEMORY-WRITE I130=1")[0].is_err(), "and its closing `>`");
}

#[test]
fn the_first_unreadable_command_ends_the_line() {
    let r = parse("I40 ZZZ I41");
    assert_eq!(r.len(), 2);
    let e = r[1].clone().unwrap_err();
    assert_eq!(e.at, "ZZZ I41");
    assert_eq!(e.offset, 4);
    // Letters run together are commands of their own: `FOO` is `F` (following error),
    // then `O`, which starts nothing.
    let r = parse("FOO");
    assert_eq!(r[0], Ok(Command::FollowingError(1)));
    assert_eq!(r[1].clone().unwrap_err().at, "OO");
    assert!(parse("#33K").last().unwrap().is_err(), "motors are #1..#32");
    assert!(parse("&17A").last().unwrap().is_err());
    assert!(parse("$$$**").last().unwrap().is_err(), "`$$$` then `**`, which starts nothing");
    assert!(parse("I5=").last().unwrap().is_err(), "a write needs its value");
}

#[test]
fn printing_a_command_and_reading_it_again_gives_the_same_text() {
    // The fuzz target `grammar` checks this over any bytes; here, one line of each kind.
    let line = "???&2??#3?PVF%&1%50.5 I130,4,100 i20..23 I(P1+1) I130=I130*1.25 I130=* M1..3=0 M5->Y:$10,8 M5-> \
                WX:$2082,7 MS0,I910=1 RHY:$25 #1J+#1J^5#1J:6#1J=#1J=7 #1HM#1HMZ &1#1->1000X &1#1-> UNDEFINE ALL \
                OPEN PLC 3 CLOSE ENABLE PLC 1 LIST PROG 1,2,3 &1DEFINE LOOKAHEAD 50,10 DELETE ALL TEMPS $$$ $$$*** \
                CHKS <MEMORY-WRITE I130=5> SAVE VER CID CPU DEFINE GATHER 10 GATHER ENDGATHER LIST GATHER \
                DELETE GATHER \x0b\x18 &1A&1Q&1/&1H&1\\&1R&1S&1B";
    let mut a = Addressing::default();
    for c in parse_line(line.as_bytes(), &mut a) {
        let c = c.unwrap_or_else(|e| panic!("{e:?}"));
        let printed = c.to_string();
        let again = parse_line(printed.as_bytes(), &mut Addressing::default());
        assert_eq!(again.len(), 1, "{printed}");
        let again = again[0].clone().unwrap_or_else(|e| panic!("{printed}: {e:?}"));
        assert_eq!(again.to_string(), printed);
    }
}

#[test]
fn a_number_whose_printed_form_is_longer_than_a_number_may_be_is_refused_so_every_print_reads_back() {
    // Found by the fuzz target card_grammar (2026-11-27, after 381,000 runs): a constant is
    // read from at most 40 characters, but 40 nines round to 1e40, which prints as 41 digits,
    // and `.` with 38 zeros and a 1 is 1e-39, which prints as `0.` and 39 digits: the printed
    // command did not read back as one command. `I41=999-(40 nines)-5` printed as
    // `I41=999-10000000000000000000000000000000000000000-5`, read back as 2 commands.
    let nines = "9".repeat(40);
    let tiny = format!(".{}1", "0".repeat(38));
    for line in [
        format!("I41=999-{nines}-5"),
        format!("I41={nines}"),
        format!("P1={tiny}"),
        format!("#1J={nines}"),
        format!("#1J=-{nines}"),
        format!("&1%{tiny}"),
        "I41=999-10000000000000000000-10000000000000000000000000000000000000000-99999-5".to_string(),
    ] {
        for c in parse(&line).into_iter().flatten() {
            let printed = c.to_string();
            let again = parse(&printed);
            assert_eq!(again.len(), 1, "{line}: `{printed}` reads as {again:?}");
            assert_eq!(again[0].as_ref().map(ToString::to_string).as_deref(), Ok(printed.as_str()), "{line}");
        }
    }
    // A number of 40 characters that prints within 40 is still read.
    assert_eq!(ok(&format!("P1={}", "9".repeat(15))), [write(VarKind::P, 1, 999_999_999_999_999.0, 1)]);
    assert_eq!(ok(&format!("P1=0.{}1", "0".repeat(37))).len(), 1);
}
