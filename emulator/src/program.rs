//! Motion program statements as a coordinate system executes them (UM p.272, "Writing and
//! Executing Motion Programs": modal commands, then move commands; SRM p.31, the move and axis
//! attribute commands). The emulator executes the statements of linear motion a beamline's
//! programs use (DLS's `PROG10_CS_motion.pmc` whole): `LINEAR`, `ABS` and `INC` (for every
//! axis or the axes listed), `FRAX(...)`/`NOFRAX`, `TA`, `TS`, `TM`, `F`, axis moves
//! (`X10 Y(Q72)`: "a one-letter axis-specifier followed by ... constant or expression", UM
//! p.272), `DWELL`/`DELAY`, variable assignments and `RETURN`. Any other statement stops the
//! program with a run-time error (SRM p.286, second status word bit 22: "the coordinate system
//! has stopped a motion program due to an error encountered while executing the program");
//! MODEL: that is the emulator's limit, not a card's, and it says so rather than ignore them.

use pmacwd_specs::grammar::{expr, Expr, VarKind};

/// The nine axes of a coordinate system, in the order of their status bits (SRM p.285: A is
/// bits 6-7 of the first word, then B, C, U, V, W, X, Y, Z up to bits 22-23).
pub const AXES: [u8; 9] = *b"ABCUVWXYZ";

/// The index of axis letter `c` in [`AXES`].
pub fn axis_index(c: u8) -> Option<usize> {
    AXES.iter().position(|a| *a == c.to_ascii_uppercase())
}

/// One statement of a motion program.
#[derive(Clone, Debug, PartialEq)]
pub enum Statement {
    Linear,
    /// `ABS` / `INC`, for the axes listed (bit k: axis `AXES[k]`), every axis without a list.
    Abs(u16),
    Inc(u16),
    /// `FRAX(...)`: the vector feedrate axes; `NOFRAX`: none.
    Frax(u16),
    /// `TA`, `TS` (ms), `TM` (ms, move-time mode), `F` (feedrate mode).
    Ta(Expr),
    Ts(Expr),
    Tm(Expr),
    F(Expr),
    /// Axis moves on one line: they move together (UM p.272).
    Move(Vec<(usize, Expr)>),
    /// `DWELL` and `DELAY` (ms).
    Dwell(Expr),
    /// `P1=...`, `Q71=...`, `M1=...`, `I5187=...`.
    Assign {
        kind: VarKind,
        number: Expr,
        value: Expr,
    },
    Return,
    /// A statement the emulator does not execute, as written.
    Unsupported(String),
}

/// The statements of one stored line (upper case, as `buffers.rs` keeps them), read in
/// order; what cannot be read ends the line as [`Statement::Unsupported`] with the rest.
/// `cs` is the coordinate system whose Q-variables the expressions name.
pub fn statements(line: &str, cs: u8) -> Vec<Statement> {
    let s = line.as_bytes();
    let mut i = 0;
    let mut out = Vec::new();
    let mut moves: Vec<(usize, Expr)> = Vec::new();
    loop {
        while s.get(i).is_some_and(|c| *c == b' ' || *c == b'\t') {
            i += 1;
        }
        let Some(&c) = s.get(i) else { break };
        let at = i;
        let word = |w: &str| s[at..].starts_with(w.as_bytes());
        let mut statement = None;
        // Keywords first (longest first where one starts another), so that `ABS` is not an
        // A-axis move and `CLEAR` not a C-axis move.
        for (w, simple) in [
            ("LINEAR", Some(Statement::Linear)),
            ("RETURN", Some(Statement::Return)),
            ("NOFRAX", Some(Statement::Frax(0))),
        ] {
            if word(w) {
                i += w.len();
                statement = simple;
                break;
            }
        }
        if statement.is_none() && i == at {
            for w in ["ABS", "INC", "FRAX"] {
                if word(w) {
                    i += w.len();
                    let Some(axes) = axis_list(s, &mut i, w != "FRAX") else {
                        return unsupported(out, moves, line, at);
                    };
                    statement = Some(match w {
                        "ABS" => Statement::Abs(axes),
                        "INC" => Statement::Inc(axes),
                        _ => Statement::Frax(axes),
                    });
                    break;
                }
            }
        }
        if statement.is_none() && i == at {
            for w in ["DWELL", "DELAY", "TA", "TS", "TM", "F"] {
                if word(w) {
                    i += w.len();
                    let Some(e) = expr::parse(s, &mut i, cs) else {
                        return unsupported(out, moves, line, at);
                    };
                    statement = Some(match w {
                        "DWELL" | "DELAY" => Statement::Dwell(e),
                        "TA" => Statement::Ta(e),
                        "TS" => Statement::Ts(e),
                        "TM" => Statement::Tm(e),
                        _ => Statement::F(e),
                    });
                    break;
                }
            }
        }
        if statement.is_none() && i == at {
            let kind = match c {
                b'P' => Some(VarKind::P),
                b'Q' => Some(VarKind::Q),
                b'M' => Some(VarKind::M),
                b'I' => Some(VarKind::I),
                _ => None,
            };
            if let Some(kind) = kind {
                i += 1;
                let number = if s.get(i) == Some(&b'(') {
                    expr::parse(s, &mut i, cs)
                } else {
                    let from = i;
                    while s.get(i).is_some_and(u8::is_ascii_digit) {
                        i += 1;
                    }
                    std::str::from_utf8(&s[from..i]).ok().and_then(|t| t.parse::<f64>().ok()).map(Expr::Const)
                };
                let value = match (number.is_some(), s.get(i)) {
                    (true, Some(b'=')) => {
                        i += 1;
                        expr::parse(s, &mut i, cs)
                    }
                    _ => None,
                };
                match (number, value) {
                    (Some(number), Some(value)) => statement = Some(Statement::Assign { kind, number, value }),
                    _ => return unsupported(out, moves, line, at),
                }
            } else if let Some(k) = axis_index(c) {
                i += 1;
                match expr::parse(s, &mut i, cs) {
                    Some(e) => {
                        // Axis moves gather until the line's next statement of another kind.
                        moves.retain(|(a, _)| *a != k);
                        moves.push((k, e));
                        continue;
                    }
                    None => return unsupported(out, moves, line, at),
                }
            } else {
                return unsupported(out, moves, line, at);
            }
        }
        if !moves.is_empty() {
            out.push(Statement::Move(std::mem::take(&mut moves)));
        }
        if let Some(st) = statement {
            out.push(st);
        }
    }
    if !moves.is_empty() {
        out.push(Statement::Move(moves));
    }
    out
}

fn unsupported(mut out: Vec<Statement>, moves: Vec<(usize, Expr)>, line: &str, at: usize) -> Vec<Statement> {
    if !moves.is_empty() {
        out.push(Statement::Move(moves));
    }
    out.push(Statement::Unsupported(line[at..].trim().to_string()));
    out
}

/// `(X,Y,Z)` after ABS, INC or FRAX, as bits of [`AXES`]; none (`optional`) is every axis.
fn axis_list(s: &[u8], i: &mut usize, optional: bool) -> Option<u16> {
    while s.get(*i) == Some(&b' ') {
        *i += 1;
    }
    if s.get(*i) != Some(&b'(') {
        return optional.then_some((1 << AXES.len()) - 1);
    }
    *i += 1;
    let mut bits = 0u16;
    loop {
        while s.get(*i) == Some(&b' ') {
            *i += 1;
        }
        let k = axis_index(*s.get(*i)?)?;
        bits |= 1 << k;
        *i += 1;
        while s.get(*i) == Some(&b' ') {
            *i += 1;
        }
        match s.get(*i)? {
            b',' => *i += 1,
            b')' => {
                *i += 1;
                return Some(bits);
            }
            _ => return None,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_dls_prog10_lines_read_as_their_statements() {
        assert_eq!(statements("LINEAR", 1), [Statement::Linear]);
        assert_eq!(statements("FRAX(A,B,C,U,V,W,X,Y,Z)", 1), [Statement::Frax(0x1FF)]);
        assert!(matches!(statements("TM(Q70)", 1).as_slice(), [Statement::Tm(_)]));
        let m = statements("A(Q71)B(Q72)C(Q73)U(Q74)V(Q75)W(Q76)X(Q77)Y(Q78)Z(Q79)", 1);
        match m.as_slice() {
            [Statement::Move(axes)] => {
                assert_eq!(axes.iter().map(|(k, _)| *k).collect::<Vec<_>>(), (0..9).collect::<Vec<_>>())
            }
            other => panic!("{other:?}"),
        }
        assert!(matches!(statements("DWELL0", 1).as_slice(), [Statement::Dwell(Expr::Const(v))] if *v == 0.0));
        assert_eq!(statements("ABS INC(X,Y)", 1), [Statement::Abs(0x1FF), Statement::Inc(0b1100_0000)]);
    }

    #[test]
    fn modes_moves_and_assignments_on_one_line_keep_their_order() {
        let st = statements("INC TA100 TS0 F50 X10 Y-5 P1=P1+1 DWELL 20", 2);
        assert_eq!(st.len(), 7, "{st:?}");
        assert!(matches!(&st[4], Statement::Move(m) if m.len() == 2));
        assert!(matches!(&st[5], Statement::Assign { kind: VarKind::P, .. }));
        assert_eq!(statements("NOFRAX RETURN", 1), [Statement::Frax(0), Statement::Return]);
    }

    #[test]
    fn what_the_emulator_does_not_execute_is_kept_as_unsupported_after_what_came_before() {
        assert_eq!(statements("X10 CIRCLE1 X20", 1)[1..], [Statement::Unsupported("CIRCLE1 X20".into())]);
        assert_eq!(statements("WHILE(P1<10)", 1), [Statement::Unsupported("WHILE(P1<10)".into())]);
        assert_eq!(statements("FRAX(X,Q)", 1), [Statement::Unsupported("FRAX(X,Q)".into())]);
    }
}
