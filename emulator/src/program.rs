//! Motion program statements as a coordinate system executes them (UM p.272, "Writing and
//! Executing Motion Programs": modal commands, then move commands; SRM p.31, the move and axis
//! attribute commands). The emulator executes the statements of linear motion a beamline's
//! programs use (DLS's `PROG10_CS_motion.pmc` whole): `LINEAR`, `ABS` and `INC` (for every
//! axis or the axes listed), `FRAX(...)`/`NOFRAX`, `TA`, `TS`, `TM`, `F`, axis moves
//! (`X10 Y(Q72)`: "a one-letter axis-specifier followed by ... constant or expression", UM
//! p.272), `DWELL`/`DELAY`, variable assignments and `RETURN`; the program flow and COMMAND
//! statements PLCs share (IF/ELSE/ENDIF, WHILE/ENDWHILE, `CMD"..."`), and `WAIT`, are
//! compiled into jumps by `plc.rs` for both kinds of program. Any other statement stops the
//! program with a run-time error (SRM p.286, second status word bit 22: "the coordinate system
//! has stopped a motion program due to an error encountered while executing the program");
//! MODEL: that is the emulator's limit, not a card's, and it says so rather than ignore them.

use pmacwd_specs::grammar::{expr, pieces, Addressing, Command, Expr, PlcSwitch, VarKind};

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
    /// PLC program flow (UM p.252 conditions; PMAC-SRM p.357 WHILE): `IF (...)`, `WHILE (...)`,
    /// and the `AND (...)` / `OR (...)` lines that extend the condition of the IF or WHILE
    /// just before them; `ELSE`, `ENDIF` (`ENDI`, `END IF`), `ENDWHILE` (`ENDW`, `END WHILE`).
    If(Condition),
    While(Condition),
    And(Condition),
    Or(Condition),
    Else,
    EndIf,
    EndWhile,
    /// `WAIT` (motion programs): calculation stops until the next real-time interrupt, as in
    /// `WHILE ({condition}) WAIT` (UM p.342: "As soon as the WAIT command is encountered,
    /// motion program calculations are suspended until the next real-time interrupt").
    Wait,
    /// `COMMAND"..."` / `CMD"..."` (SRM p.421): the text, issued as if a host sent it.
    Command(String),
    /// `COMMAND^K` / `CMD^K` (SRM p.423): the control character.
    Control(u8),
    /// `SEND"..."`: a message to a port.
    Send(String),
    /// `ENABLE PLC n` / `DISABLE PLC n` in a program, read by the card's grammar.
    Plc(PlcSwitch),
    /// `ADDRESS#n`, `ADDRESS&n`: the program's own addressing for its COMMAND statements.
    Address {
        motor: Option<u8>,
        cs: Option<u8>,
    },
    /// A statement the emulator does not execute, as written.
    Unsupported(String),
}

/// A comparator of a simple condition (UM p.252: `=`, `!=`, `>`, `!>`, `<`, `!<`, `~`, `!~`;
/// "`<=` and `>=` are not valid Turbo PMAC comparators").
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Comparator {
    Eq,
    Ne,
    Gt,
    NotGt,
    Lt,
    NotLt,
    Approx,
    NotApprox,
}

impl Comparator {
    /// MODEL: `~` (approximately equal) as within one unit of each other; the page at hand
    /// lists the comparator without its tolerance.
    pub fn holds(self, a: f64, b: f64) -> bool {
        match self {
            Comparator::Eq => a == b,
            Comparator::Ne => a != b,
            Comparator::Gt => a > b,
            Comparator::NotGt => a <= b,
            Comparator::Lt => a < b,
            Comparator::NotLt => a >= b,
            Comparator::Approx => (a - b).abs() < 1.0,
            Comparator::NotApprox => (a - b).abs() >= 1.0,
        }
    }
}

/// `{expression} {comparator} {expression}` (UM p.252).
#[derive(Clone, Debug, PartialEq)]
pub struct Simple {
    pub left: Expr,
    pub comparator: Comparator,
    pub right: Expr,
}

/// A compound condition: ORs of blocks of ANDed simple conditions (UM p.252: "AND has
/// execution precedence over OR (that is, ORs operate on blocks of ANDed simple conditions)").
#[derive(Clone, Debug, PartialEq)]
pub struct Condition {
    pub any_of: Vec<Vec<Simple>>,
}

/// The longest program line the emulator reads, in bytes. MODEL: a host's line is at most
/// 1,492 bytes (the Ethernet request), longer text is refused; a bound on the reader's work.
pub const LINE_BYTES_MAX: usize = 1492;

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
        // PLC flow and commands first: `WHILE` is not a W-axis move, `AND` not an A-axis
        // move, `CMD` not a C-axis move, `IF` not an I-variable.
        match flow_statement(s, &mut i, cs) {
            Some(Ok(st)) => {
                if !moves.is_empty() {
                    out.push(Statement::Move(std::mem::take(&mut moves)));
                }
                out.push(st);
                continue;
            }
            Some(Err(())) => return unsupported(out, moves, line, at),
            None => {}
        }
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

/// A flow statement made from its condition.
type MakeFlow = fn(Condition) -> Statement;

/// Whether `s` at `i` starts with `word` (upper case, as stored).
fn at_word(s: &[u8], i: usize, word: &str) -> bool {
    s[i..].starts_with(word.as_bytes())
}

fn skip_blanks(s: &[u8], i: &mut usize) {
    while s.get(*i).is_some_and(|c| *c == b' ' || *c == b'\t') {
        *i += 1;
    }
}

/// A PLC flow statement, a COMMAND, SEND, ENABLE/DISABLE PLC or ADDRESS at `*i`: `None` when
/// none starts there (`*i` unchanged), `Some(Err(()))` when one starts but cannot be read.
fn flow_statement(s: &[u8], i: &mut usize, cs: u8) -> Option<Result<Statement, ()>> {
    let start = *i;
    // Longest spelling first where one starts another.
    let words: [(&str, MakeFlow); 4] =
        [("WHILE", Statement::While), ("AND", Statement::And), ("IF", Statement::If), ("OR", Statement::Or)];
    for (w, make) in words {
        if at_word(s, start, w) {
            let mut j = start + w.len();
            skip_blanks(s, &mut j);
            if s.get(j) != Some(&b'(') {
                // `ORIGIN...`, `IFxx`: not a condition (nothing the emulator executes either).
                continue;
            }
            let c = condition(s, &mut j, cs);
            *i = j;
            return Some(c.map(make).ok_or(()));
        }
    }
    for (w, st) in [
        ("ENDWHILE", Statement::EndWhile),
        ("END WHILE", Statement::EndWhile),
        ("ENDW", Statement::EndWhile),
        ("ENDIF", Statement::EndIf),
        ("END IF", Statement::EndIf),
        ("ENDI", Statement::EndIf),
        ("ELSE", Statement::Else),
        ("WAIT", Statement::Wait),
    ] {
        if at_word(s, start, w) {
            *i = start + w.len();
            return Some(Ok(st));
        }
    }
    for w in ["COMMAND", "CMD", "SEND"] {
        if !at_word(s, start, w) {
            continue;
        }
        let mut j = start + w.len();
        // COMMANDS, COMMANDP, COMMANDR, COMMANDA: the port a reply goes to (SRM p.421).
        if w != "SEND" && matches!(s.get(j), Some(b'S' | b'P' | b'R' | b'A')) {
            j += 1;
        }
        skip_blanks(s, &mut j);
        match s.get(j) {
            Some(b'"') => {
                let from = j + 1;
                let Some(len) = s[from..].iter().position(|c| *c == b'"') else { return Some(Err(())) };
                *i = from + len + 1;
                let text = String::from_utf8_lossy(&s[from..from + len]).into_owned();
                return Some(Ok(if w == "SEND" { Statement::Send(text) } else { Statement::Command(text) }));
            }
            Some(b'^') if w != "SEND" => {
                let Some(letter) = s.get(j + 1).filter(|c| c.is_ascii_alphabetic()) else { return Some(Err(())) };
                *i = j + 2;
                return Some(Ok(Statement::Control(letter.to_ascii_uppercase() - b'A' + 1)));
            }
            _ => return Some(Err(())),
        }
    }
    if ["ENABLE", "ENA ", "ENA", "DISABLE", "DIS"].iter().any(|w| at_word(s, start, w)) {
        // The card's own grammar reads the switch (one parser of the command language).
        let mut addressing = Addressing::default();
        let rest = &s[start..];
        let Some(first) = pieces(rest, &mut addressing).into_iter().next() else { return Some(Err(())) };
        return match first.command {
            Ok(Command::PlcSwitch(p)) => {
                *i = start + first.end;
                Some(Ok(Statement::Plc(p)))
            }
            _ => Some(Err(())),
        };
    }
    if at_word(s, start, "ADDRESS") {
        let mut j = start + "ADDRESS".len();
        let (mut motor, mut cs_to) = (None, None);
        loop {
            skip_blanks(s, &mut j);
            let which = match s.get(j) {
                Some(b'#') => b'#',
                Some(b'&') => b'&',
                _ => break,
            };
            j += 1;
            let from = j;
            while s.get(j).is_some_and(u8::is_ascii_digit) && j - from < 3 {
                j += 1;
            }
            let Some(n) = std::str::from_utf8(&s[from..j]).ok().and_then(|t| t.parse::<u8>().ok()) else {
                return Some(Err(()));
            };
            match which {
                b'#' if (1..=32).contains(&n) => motor = Some(n),
                b'&' if (1..=16).contains(&n) => cs_to = Some(n),
                _ => return Some(Err(())),
            }
        }
        if motor.is_none() && cs_to.is_none() {
            return Some(Err(()));
        }
        *i = j;
        return Some(Ok(Statement::Address { motor, cs: cs_to }));
    }
    None
}

/// `({simple} {AND|OR} {simple} ...)` at `*i` (UM p.252); `None` when it cannot be read.
fn condition(s: &[u8], i: &mut usize, cs: u8) -> Option<Condition> {
    skip_blanks(s, i);
    if s.get(*i) != Some(&b'(') {
        return None;
    }
    *i += 1;
    let mut any_of = vec![Vec::new()];
    loop {
        let left = expr::parse(s, i, cs)?;
        skip_blanks(s, i);
        let comparator = match (s.get(*i), s.get(*i + 1)) {
            (Some(b'!'), Some(b'=')) => Comparator::Ne,
            (Some(b'!'), Some(b'>')) => Comparator::NotGt,
            (Some(b'!'), Some(b'<')) => Comparator::NotLt,
            (Some(b'!'), Some(b'~')) => Comparator::NotApprox,
            (Some(b'<'), Some(b'=' | b'>')) | (Some(b'>'), Some(b'=')) => return None,
            (Some(b'='), _) => Comparator::Eq,
            (Some(b'>'), _) => Comparator::Gt,
            (Some(b'<'), _) => Comparator::Lt,
            (Some(b'~'), _) => Comparator::Approx,
            _ => return None,
        };
        *i += if matches!(comparator, Comparator::Ne | Comparator::NotGt | Comparator::NotLt | Comparator::NotApprox) {
            2
        } else {
            1
        };
        let right = expr::parse(s, i, cs)?;
        any_of.last_mut()?.push(Simple { left, comparator, right });
        skip_blanks(s, i);
        if s.get(*i) == Some(&b')') {
            *i += 1;
            return Some(Condition { any_of });
        }
        if at_word(s, *i, "AND") {
            *i += 3;
        } else if at_word(s, *i, "OR") {
            *i += 2;
            any_of.push(Vec::new());
        } else {
            return None;
        }
    }
}

impl Condition {
    /// This condition, then `AND` the other (a continuation line, PMAC-SRM p.357): every block
    /// of ANDed conditions takes the other's first block, and its other blocks are ORed
    /// (MODEL: AND over OR across lines as within one, UM p.252).
    pub fn and(&mut self, other: Condition) {
        let mut blocks = other.any_of.into_iter();
        if let Some(first) = blocks.next() {
            if let Some(last) = self.any_of.last_mut() {
                last.extend(first);
            }
        }
        self.any_of.extend(blocks);
    }

    /// This condition, then `OR` the other.
    pub fn or(&mut self, other: Condition) {
        self.any_of.extend(other.any_of);
    }

    /// Whether it holds, its expressions evaluated by `eval`; `None` when one has no value.
    /// UM p.252: evaluation of ANDed conditions stops at the first false one.
    pub fn holds(&self, eval: &mut dyn FnMut(&Expr) -> Option<f64>) -> Option<bool> {
        for block in &self.any_of {
            let mut all = true;
            for c in block {
                let (a, b) = (eval(&c.left)?, eval(&c.right)?);
                if !c.comparator.holds(a, b) {
                    all = false;
                    break;
                }
            }
            if all {
                return Some(true);
            }
        }
        Some(false)
    }
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
        assert_eq!(statements("WHILE(P1<=10)", 1), [Statement::Unsupported("WHILE(P1<=10)".into())]);
        assert_eq!(statements("FRAX(X,Q)", 1), [Statement::Unsupported("FRAX(X,Q)".into())]);
    }
}
