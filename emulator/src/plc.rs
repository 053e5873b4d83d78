//! User PLC programs as the card runs them: a stored PLC buffer (`buffers.rs`) read statement by
//! statement by the statement reader motion programs use (`program.rs`), its IF/ELSE/ENDIF and
//! WHILE/ENDWHILE blocks resolved to jumps, so that a scan can start anywhere and stop anywhere.
//! The scans themselves are `card/plc.rs`.
//!
//! - UM p.236: "Each background cycle, Turbo PMAC will execute one scan (to the end or to an
//!   ENDWHILE statement) of a single active interpreted background PLC program". A scan ends at
//!   the end of the program (the next starts at its top) or at an ENDWHILE (the next starts at
//!   its WHILE, whose condition is evaluated again): a WHILE loop is one pass a scan.
//! - UM p.252: conditions; an IF or WHILE whose condition goes on over the next lines takes
//!   them as `AND (...)` / `OR (...)` lines (PMAC-SRM p.357: "In PLC programs, extended compound
//!   WHILE" conditions; DLS's PLCs write `IF(P(4700+1)=1)` then `OR(P(4700+4)=1)`).
//!
//! MODEL, where the pages at hand leave the card's own behaviour open:
//!
//! - A PLC whose blocks do not match (an ELSE or ENDIF without its IF, an ENDWHILE without its
//!   WHILE, an IF or WHILE never closed) is not run: the card compiles the buffer at CLOSE and
//!   would refuse it there; the emulator keeps every line and refuses to run it.
//! - A statement that is not a PLC's (a move, `TA`, `DWELL`, `LINEAR` ..., or one the emulator
//!   does not read) stops the PLC when the scan reaches it: the PLC is disabled, and the
//!   console says where.
//! - An IF with a statement after its condition on the same line is that line's block (the
//!   one-line form of PMAC-SRM's IF); a one-line WHILE is a motion program's only (PMAC-SRM
//!   p.357: "Valid in motion program only"), so in a PLC it stops the PLC.

use crate::program::{statements, Condition, Statement};

/// One step of a compiled PLC.
#[derive(Clone, Debug)]
pub enum Op {
    /// An assignment, a COMMAND, SEND, ENABLE/DISABLE PLC or ADDRESS.
    Do(Statement),
    /// IF: on to the next op when the condition holds, else to `to` (its ELSE branch or past
    /// its ENDIF).
    Unless { condition: Condition, to: usize },
    /// The end of an IF's true branch before its ELSE: past the ENDIF.
    Jump(usize),
    /// WHILE: on when the condition holds, else to `exit` (past its ENDWHILE).
    While { condition: Condition, exit: usize },
    /// ENDWHILE: the scan ends; the next one starts at the WHILE (`back`).
    EndWhile { back: usize },
    /// A statement a PLC cannot run: the PLC stops there (the text says why).
    Stop(String),
}

enum Open {
    If { at: usize, else_at: Option<usize>, one_line: bool },
    While { at: usize, one_line: bool },
}

/// What a buffer is compiled as: the statements and block forms differ.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Kind {
    /// A PLC program: conditions may go on over AND/OR lines; a WHILE needs its ENDWHILE.
    Plc,
    /// A motion program of coordinate system `cs` (its Q-variables): moves and modes run;
    /// one-line IF, ELSE and WHILE forms (UM p.253: "In Turbo PMAC motion programs (but not in
    /// PLC programs), the action(s) to be executed on a true condition can be put on the same
    /// line as the condition itself. In this case, no ENDIF or ENDWHILE is required"; SRM
    /// p.429-430, ELSE: "ELSE {action} (Motion Program only)", an ELSE line after a one-line
    /// IF); no AND/OR lines (UM p.253: multiple-line conditions "In Turbo PMAC PLC programs
    /// (but not in motion programs)"), no ADDRESS (SRM p.422: "There is no modal ADDRESS
    /// command in motion programs").
    Motion { cs: u8 },
}

/// The ops of a PLC whose stored lines are `lines`; `Err` with the reason when its blocks do
/// not match (it is not run).
pub fn compile(lines: &[String]) -> Result<Vec<Op>, String> {
    compile_as(lines, Kind::Plc)
}

/// The ops of a PLC or motion program whose stored lines are `lines`.
pub fn compile_as(lines: &[String], kind: Kind) -> Result<Vec<Op>, String> {
    let motion = matches!(kind, Kind::Motion { .. });
    let cs = match kind {
        Kind::Plc => 1,
        Kind::Motion { cs } => cs,
    };
    let mut ops: Vec<Op> = Vec::new();
    let mut open: Vec<Open> = Vec::new();
    // A motion program's one-line IF closed at the end of the previous line: an ELSE line
    // right after it is its false branch (SRM p.429-430).
    let mut closed_one_line_if: Option<usize> = None;
    for (number, line) in lines.iter().enumerate() {
        let parsed = statements(line, cs);
        let after_one_line_if = closed_one_line_if.take();
        // The op whose condition an AND or OR line extends: only right after an IF or WHILE
        // (or another AND/OR line).
        let mut extendable: Option<usize> = match ops.last() {
            Some(Op::Unless { .. } | Op::While { .. }) if number > 0 && !motion => Some(ops.len() - 1),
            _ => None,
        };
        let count = parsed.len();
        for (k, st) in parsed.into_iter().enumerate() {
            let last_on_line = k + 1 == count;
            let here = ops.len();
            match st {
                Statement::If(condition) => {
                    ops.push(Op::Unless { condition, to: usize::MAX });
                    open.push(Open::If { at: here, else_at: None, one_line: !last_on_line });
                    extendable = Some(here);
                    continue;
                }
                Statement::While(condition) => {
                    if !last_on_line && !motion {
                        ops.push(Op::Stop(format!("line {}: a WHILE with its statement on the same line is a motion program's (PMAC-SRM p.357)", number + 1)));
                        extendable = None;
                        continue;
                    }
                    ops.push(Op::While { condition, exit: usize::MAX });
                    open.push(Open::While { at: here, one_line: !last_on_line });
                    extendable = Some(here);
                    continue;
                }
                Statement::And(_) | Statement::Or(_) if motion => {
                    return Err(format!(
                        "line {}: a condition over several lines (AND or OR lines) is a PLC's, not a motion program's (UM p.253)",
                        number + 1
                    ));
                }
                Statement::And(c) | Statement::Or(c) if extendable.is_none() => {
                    let _ = c;
                    return Err(format!("line {}: AND or OR with no IF or WHILE before it", number + 1));
                }
                Statement::And(c) => {
                    if let Some(Op::Unless { condition, .. } | Op::While { condition, .. }) =
                        extendable.and_then(|e| ops.get_mut(e))
                    {
                        condition.and(c);
                    }
                    continue;
                }
                Statement::Or(c) => {
                    if let Some(Op::Unless { condition, .. } | Op::While { condition, .. }) =
                        extendable.and_then(|e| ops.get_mut(e))
                    {
                        condition.or(c);
                    }
                    continue;
                }
                Statement::Else => {
                    if motion && k == 0 && !matches!(open.last(), Some(Open::If { else_at: None, .. })) {
                        // ELSE on the line after a one-line IF: that IF opens again, its true
                        // branch ending here.
                        if let Some(at) = after_one_line_if
                            .filter(|at| matches!(ops.get(*at), Some(Op::Unless { to, .. }) if *to == here))
                        {
                            open.push(Open::If { at, else_at: None, one_line: false });
                        }
                    }
                    match open.last_mut() {
                        Some(Open::If { at, else_at: else_at @ None, one_line }) => {
                            ops.push(Op::Jump(usize::MAX));
                            let at = *at;
                            *else_at = Some(here);
                            // The one-line ELSE of a motion program: its statements on the
                            // same line are the whole false branch, no ENDIF (SRM p.429-430).
                            if motion && !last_on_line {
                                *one_line = true;
                            }
                            if let Op::Unless { to, .. } = &mut ops[at] {
                                *to = here + 1;
                            }
                        }
                        _ => return Err(format!("line {}: ELSE with no IF open", number + 1)),
                    }
                }
                Statement::EndIf => close_if(&mut ops, &mut open).map_err(|e| format!("line {}: {e}", number + 1))?,
                Statement::EndWhile => match open.last() {
                    Some(Open::While { one_line: false, .. }) => close_while(&mut ops, &mut open),
                    _ => return Err(format!("line {}: ENDWHILE with no WHILE open", number + 1)),
                },
                st @ (Statement::Assign { .. }
                | Statement::Command(_)
                | Statement::Control(_)
                | Statement::Send(_)
                | Statement::Plc(_)) => ops.push(Op::Do(st)),
                st @ Statement::Address { .. } if !motion => ops.push(Op::Do(st)),
                Statement::Address { .. } => ops.push(Op::Stop(format!(
                    "line {}: ADDRESS is a PLC's: there is no modal ADDRESS in motion programs (SRM p.422)",
                    number + 1
                ))),
                Statement::Unsupported(text) => {
                    ops.push(Op::Stop(format!("line {}: `{text}` is not a statement the emulator runs", number + 1)))
                }
                st if motion => ops.push(Op::Do(st)),
                other => ops.push(Op::Stop(format!(
                    "line {}: `{other:?}` is a motion program's statement, not a PLC's",
                    number + 1
                ))),
            }
            extendable = None;
        }
        // One-line IF, ELSE and WHILE blocks end with their line, innermost first.
        loop {
            match open.last() {
                Some(Open::If { one_line: true, at, else_at }) => {
                    if motion && else_at.is_none() {
                        closed_one_line_if = Some(*at);
                    }
                    close_if(&mut ops, &mut open).map_err(|e| format!("line {}: {e}", number + 1))?;
                }
                Some(Open::While { one_line: true, .. }) => close_while(&mut ops, &mut open),
                _ => break,
            }
        }
    }
    match open.last() {
        Some(Open::If { .. }) => Err("an IF without its ENDIF".into()),
        Some(Open::While { .. }) => Err("a WHILE without its ENDWHILE".into()),
        None => Ok(ops),
    }
}

/// ENDWHILE (or the end of a one-line WHILE's line): back to the WHILE, whose false condition
/// lands past here. The caller has checked that a WHILE is the innermost open block.
fn close_while(ops: &mut Vec<Op>, open: &mut Vec<Open>) {
    if let Some(Open::While { at, .. }) = open.pop() {
        ops.push(Op::EndWhile { back: at });
        let end = ops.len();
        if let Op::While { exit, .. } = &mut ops[at] {
            *exit = end;
        }
    }
}

/// ENDIF: the IF's false branch (or its ELSE's jump) lands here.
fn close_if(ops: &mut [Op], open: &mut Vec<Open>) -> Result<(), &'static str> {
    let end = ops.len();
    match open.pop() {
        Some(Open::If { at, else_at, .. }) => {
            match else_at {
                Some(j) => ops[j] = Op::Jump(end),
                None => {
                    if let Op::Unless { to, .. } = &mut ops[at] {
                        *to = end;
                    }
                }
            }
            Ok(())
        }
        _ => Err("ENDIF with no IF open"),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn lines(text: &[&str]) -> Vec<String> {
        text.iter().map(|l| l.to_string()).collect()
    }

    #[test]
    fn blocks_become_jumps_and_continuation_lines_extend_the_condition() {
        // DLS's PLC 17 (PMAC_CLIPPER_Startup.pmc): an IF whose condition goes on with OR.
        let ops = compile(&lines(&[
            "ADDRESS&2",
            "IF(ABS(Q328)>0.01)",
            "Q87=Q22/Q328",
            "ENDIF",
            "IF(P(4700+1)=1)",
            "OR(P(4700+4)=1)",
            "P(4700+1)=0",
            "ELSE",
            "Q77=Q87",
            "ENDIF",
            "WHILE(P1<10)",
            "P1=P1+1",
            "END WHILE",
        ]))
        .unwrap();
        assert!(matches!(ops[0], Op::Do(Statement::Address { motor: None, cs: Some(2) })));
        assert!(matches!(&ops[1], Op::Unless { to: 3, .. }));
        match &ops[3] {
            Op::Unless { condition, to } => {
                assert_eq!(condition.any_of.len(), 2, "the OR line is a second block");
                assert_eq!(*to, 6, "to the ELSE branch");
            }
            other => panic!("{other:?}"),
        }
        assert!(matches!(ops[5], Op::Jump(7)), "the true branch jumps past the ENDIF");
        assert!(matches!(&ops[7], Op::While { exit: 10, .. }));
        assert!(matches!(ops[9], Op::EndWhile { back: 7 }));
    }

    #[test]
    fn unmatched_blocks_are_refused_and_what_a_plc_cannot_run_stops_it() {
        assert!(compile(&lines(&["IF(P1=1)", "P2=1"])).is_err());
        assert!(compile(&lines(&["ENDIF"])).is_err());
        assert!(compile(&lines(&["WHILE(P1=1)", "ENDIF"])).is_err());
        assert!(compile(&lines(&["ELSE"])).is_err());
        assert!(compile(&lines(&["P1=1", "AND(P1=1)"])).is_err());
        let ops = compile(&lines(&["P1=1", "X10", "P2=1"])).unwrap();
        assert!(matches!(&ops[1], Op::Stop(why) if why.contains("motion program")));
        let ops = compile(&lines(&["IF(P1=1) P2=1 ELSE P2=2", "P3=3"])).unwrap();
        assert!(matches!(&ops[0], Op::Unless { to: 3, .. }), "{ops:?}");
        assert!(matches!(ops[2], Op::Jump(4)), "{ops:?}");
    }

    #[test]
    fn a_motion_programs_one_line_forms_close_with_their_line() {
        let motion = Kind::Motion { cs: 1 };
        // SRM p.429-430: a one-line IF, then its one-line ELSE on the next line.
        let ops = compile_as(&lines(&["IF (P1!<5) X10", "ELSE X-10", "P2=1"]), motion).unwrap();
        assert!(matches!(&ops[0], Op::Unless { to: 3, .. }), "{ops:?}");
        assert!(matches!(ops[2], Op::Jump(4)), "{ops:?}");
        assert!(matches!(&ops[3], Op::Do(Statement::Move(_))), "{ops:?}");
        // A one-line IF, then a multi-line ELSE closed by ENDIF.
        let ops = compile_as(&lines(&["IF (P1>0) X1", "ELSE", "X2", "X3", "ENDIF"]), motion).unwrap();
        assert!(matches!(&ops[0], Op::Unless { to: 3, .. }), "{ops:?}");
        assert!(matches!(ops[2], Op::Jump(5)), "{ops:?}");
        // UM p.253: `WHILE (M11=0) DWELL 10`, no ENDWHILE.
        let ops = compile_as(&lines(&["WHILE (M11=0) DWELL 10", "X1"]), motion).unwrap();
        assert!(matches!(&ops[0], Op::While { exit: 3, .. }), "{ops:?}");
        assert!(matches!(ops[2], Op::EndWhile { back: 0 }), "{ops:?}");
        // The same lines as a PLC's: the one-line WHILE stops it, the ELSE line has no IF.
        assert!(compile(&lines(&["IF (P1!<5) P1=1", "ELSE P1=2"])).is_err());
        assert!(compile_as(&lines(&["IF (P1=1)", "AND (P2=1)", "ENDIF"]), motion).is_err());
    }
}
