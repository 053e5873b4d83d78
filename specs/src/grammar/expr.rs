//! Expressions, as the card reads them after `=` and inside `I(...)`: constants, variables and
//! functions joined by operators (UM p.248, "Turbo PMAC Computational Features"; SRM p.488-489,
//! "Turbo PMAC Mathematical Features").
//!
//! - Constants: decimal with an optional fraction (`0.0009765625`, `.5`), or `$` hex (`$FDFFFF`).
//! - Variables: `I`, `P`, `Q`, `M` followed by a number, or by a parenthesised expression for
//!   its number (`I(P1*100+20)`, UM p.248: "the variable number can be an expression").
//!   Q-variables are those of the coordinate system addressed when the line is read.
//! - Operators: `*`, `/`, `%` (modulo) and `&` (bit-by-bit and) bind tighter than `+`, `-`,
//!   `|` and `^` (exclusive or); operators of one priority apply left to right (SRM p.488-489).
//!   A unary minus binds tighter than both (UM p.248: negation).
//! - Functions: `SIN`, `COS`, `TAN`, `ASIN`, `ACOS`, `ATAN`, `ATAN2`, `LN`, `EXP`, `SQRT`,
//!   `ABS`, `INT` (UM p.248), each with its argument in parentheses; the trigonometric ones
//!   work in degrees when I15 = 0 and radians when I15 = 1 (UM p.248), and `ATAN2` takes its
//!   cosine argument from Q0 (SRM, ATAN2: "the value of Q0 is used as the cosine argument").
//!
//! Spaces are skipped between the parts of an expression, as the card skips them in a
//! command line; an expression ends at the first character that cannot continue it, and the
//! next command starts there (`i124=i124&$FDFFFF M140=1`: `M` is not an operator).
//!
//! The grammar only reads an expression; its value depends on the card's variables, so the
//! card that holds them evaluates it ([`Expr::eval`] with its own [`Env`]).

use super::VarKind;
use std::fmt;

/// A binary operator (SRM p.488-489).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Op {
    Add,
    Sub,
    Mul,
    Div,
    Mod,
    And,
    Or,
    Xor,
}

impl Op {
    fn symbol(self) -> char {
        match self {
            Op::Add => '+',
            Op::Sub => '-',
            Op::Mul => '*',
            Op::Div => '/',
            Op::Mod => '%',
            Op::And => '&',
            Op::Or => '|',
            Op::Xor => '^',
        }
    }

    /// SRM p.488: "Multiplication, division, modulo (remainder), and bit-by-bit and operations
    /// have higher priority than addition, subtraction, bit-by-bit or, and bit-by-bit
    /// exclusive-or operations."
    fn binds_tight(self) -> bool {
        matches!(self, Op::Mul | Op::Div | Op::Mod | Op::And)
    }

    fn of(c: u8) -> Option<Op> {
        Some(match c {
            b'+' => Op::Add,
            b'-' => Op::Sub,
            b'*' => Op::Mul,
            b'/' => Op::Div,
            b'%' => Op::Mod,
            b'&' => Op::And,
            b'|' => Op::Or,
            b'^' => Op::Xor,
            _ => return None,
        })
    }
}

/// A mathematical function (UM p.248).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Func {
    Sin,
    Cos,
    Tan,
    Asin,
    Acos,
    Atan,
    Atan2,
    Ln,
    Exp,
    Sqrt,
    Abs,
    Int,
}

impl Func {
    /// Longest first where one name starts another (`ATAN2` before `ATAN`).
    const NAMES: [(&'static str, Func); 12] = [
        ("ATAN2", Func::Atan2),
        ("ASIN", Func::Asin),
        ("ACOS", Func::Acos),
        ("ATAN", Func::Atan),
        ("SQRT", Func::Sqrt),
        ("SIN", Func::Sin),
        ("COS", Func::Cos),
        ("TAN", Func::Tan),
        ("EXP", Func::Exp),
        ("ABS", Func::Abs),
        ("INT", Func::Int),
        ("LN", Func::Ln),
    ];

    pub fn name(self) -> &'static str {
        Func::NAMES.iter().find(|(_, f)| *f == self).map(|(n, _)| *n).expect("every function is named")
    }
}

/// An expression as read; constants keep the value the text gave.
#[derive(Clone, Debug, PartialEq)]
pub enum Expr {
    Const(f64),
    /// A variable: its number, itself an expression for `I(...)`, and the C.S. of a Q-variable.
    Var {
        kind: VarKind,
        number: Box<Index>,
        cs: u8,
    },
    Neg(Box<Expr>),
    Bin(Op, Box<Expr>, Box<Expr>),
    Call(Func, Box<Expr>),
}

/// A variable's number: a constant (`I130`) or an expression (`I(P1*100+20)`).
#[derive(Clone, Debug, PartialEq)]
pub enum Index {
    Number(u16),
    Computed(Expr),
}

/// What an expression needs of the card that evaluates it.
pub trait Env {
    /// The value of variable `n` of `kind` (Q-variables of C.S. `cs`).
    fn var(&mut self, kind: VarKind, n: u16, cs: u8) -> f64;
}

/// Why an expression has no value on the card.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum EvalError {
    /// A computed variable number outside 0..8191.
    NoSuchVariable,
    /// A result that is not a number (a square root of a negative number, a division by zero,
    /// a logarithm of zero). MODEL: the manual pages give each function's domain (SRM p.489
    /// onwards) but not what the card does outside it; the command is refused.
    OutOfDomain,
}

impl Expr {
    /// The value, if the expression is made of constants only.
    pub fn constant(&self) -> Option<f64> {
        struct NoVars;
        impl Env for NoVars {
            fn var(&mut self, _: VarKind, _: u16, _: u8) -> f64 {
                f64::NAN
            }
        }
        if self.has_variables() {
            return None;
        }
        // Trigonometric functions of constants depend on I15: not a constant either.
        if self.uses_angles() {
            return None;
        }
        self.eval(&mut NoVars).ok()
    }

    /// Whether any variable takes part.
    pub fn has_variables(&self) -> bool {
        match self {
            Expr::Const(_) => false,
            Expr::Var { .. } => true,
            Expr::Neg(e) | Expr::Call(_, e) => e.has_variables(),
            Expr::Bin(_, a, b) => a.has_variables() || b.has_variables(),
        }
    }

    fn uses_angles(&self) -> bool {
        match self {
            Expr::Const(_) | Expr::Var { .. } => false,
            Expr::Neg(e) => e.uses_angles(),
            Expr::Bin(_, a, b) => a.uses_angles() || b.uses_angles(),
            Expr::Call(f, e) => {
                matches!(f, Func::Sin | Func::Cos | Func::Tan | Func::Asin | Func::Acos | Func::Atan | Func::Atan2)
                    || e.uses_angles()
            }
        }
    }

    /// The value on a card whose variables `env` holds.
    pub fn eval(&self, env: &mut dyn Env) -> Result<f64, EvalError> {
        let v = match self {
            Expr::Const(v) => *v,
            Expr::Var { kind, number, cs } => {
                let n = match number.as_ref() {
                    Index::Number(n) => *n,
                    Index::Computed(e) => {
                        let v = e.eval(env)?.round();
                        if !(0.0..=f64::from(super::VARIABLE_MAX)).contains(&v) {
                            return Err(EvalError::NoSuchVariable);
                        }
                        v as u16
                    }
                };
                env.var(*kind, n, *cs)
            }
            Expr::Neg(e) => -e.eval(env)?,
            Expr::Bin(op, a, b) => {
                let (a, b) = (a.eval(env)?, b.eval(env)?);
                match op {
                    Op::Add => a + b,
                    Op::Sub => a - b,
                    Op::Mul => a * b,
                    Op::Div => a / b,
                    Op::Mod => modulo(a, b),
                    Op::And => bitwise(a, b, |x, y| x & y),
                    Op::Or => bitwise(a, b, |x, y| x | y),
                    Op::Xor => bitwise(a, b, |x, y| x ^ y),
                }
            }
            Expr::Call(f, e) => {
                let x = e.eval(env)?;
                // UM p.248: I15 = 0 degrees, 1 radians.
                let radians = env.var(VarKind::I, 15, 1) != 0.0;
                let to_rad = |v: f64| if radians { v } else { v.to_radians() };
                let from_rad = |v: f64| if radians { v } else { v.to_degrees() };
                match f {
                    Func::Sin => to_rad(x).sin(),
                    Func::Cos => to_rad(x).cos(),
                    Func::Tan => to_rad(x).tan(),
                    Func::Asin => from_rad(x.asin()),
                    Func::Acos => from_rad(x.acos()),
                    Func::Atan => from_rad(x.atan()),
                    // SRM ATAN2: the expression is the sine argument, Q0 of the C.S. the cosine.
                    Func::Atan2 => from_rad(x.atan2(env.var(VarKind::Q, 0, 1))),
                    Func::Ln => x.ln(),
                    Func::Exp => x.exp(),
                    Func::Sqrt => x.sqrt(),
                    Func::Abs => x.abs(),
                    // UM p.248: "Truncation to integer (towards minus infinity)".
                    Func::Int => x.floor(),
                }
            }
        };
        if v.is_finite() {
            Ok(v)
        } else {
            Err(EvalError::OutOfDomain)
        }
    }
}

/// SRM `%`: with a positive modulus the result lies in 0..n; with a negative one in -|n|..|n|,
/// which handles roll-over in both directions (Delta Tau's forum, "About Modulo operation",
/// 2012: `11%-4` = 3, `-11%-4` = -3, `3%-2.5` = -2, `-3%-2.5` = 2). A zero modulus gives 0
/// (the same thread). MODEL: the SRM pages at hand name the operator, not these ranges.
pub fn modulo(x: f64, n: f64) -> f64 {
    if n == 0.0 {
        0.0
    } else if n > 0.0 {
        x - n * (x / n).floor()
    } else {
        let m = -n;
        x - 2.0 * m * ((x + m) / (2.0 * m)).floor()
    }
}

/// The bits to the right of the binary point that `&`, `|` and `^` work on. SRM p.488: "the
/// operation is done both on integer bits and fractional bits". MODEL: the card's 48-bit
/// floating point keeps a 36-bit mantissa; 24 fractional bits reproduce the SRM's examples
/// (`0.875&-1.75` = 0.25) and every value a host writes to a register.
const FRACTION_BITS: i32 = 24;

fn bitwise(a: f64, b: f64, f: impl Fn(i128, i128) -> i128) -> f64 {
    let scale = f64::from(2u32.pow(FRACTION_BITS as u32));
    let fixed = |v: f64| (v * scale).floor() as i128;
    f(fixed(a), fixed(b)) as f64 / scale
}

impl fmt::Display for Expr {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Expr::Const(v) => write!(f, "{}", number_text(*v)),
            Expr::Var { kind, number, .. } => match number.as_ref() {
                Index::Number(n) => write!(f, "{kind:?}{n}"),
                Index::Computed(e) => write!(f, "{kind:?}({e})"),
            },
            // Parentheses only where the priorities need them, so that printing and reading
            // again give the same tree, no deeper than the text it was read from.
            Expr::Neg(e) => match e.as_ref() {
                Expr::Bin(..) => write!(f, "-({e})"),
                _ => write!(f, "-{e}"),
            },
            Expr::Bin(op, a, b) => {
                // Left to right within a priority: a left operand needs parentheses only when
                // it binds looser than `op`, a right one also when it binds as loosely.
                let looser = |x: &Expr, or_equal: bool| match x {
                    Expr::Bin(inner, ..) => {
                        (op.binds_tight() && !inner.binds_tight())
                            || (or_equal && op.binds_tight() == inner.binds_tight())
                    }
                    _ => false,
                };
                if looser(a, false) {
                    write!(f, "({a})")?;
                } else {
                    write!(f, "{a}")?;
                }
                write!(f, "{}", op.symbol())?;
                if looser(b, true) {
                    write!(f, "({b})")
                } else {
                    write!(f, "{b}")
                }
            }
            Expr::Call(func, e) => write!(f, "{}({e})", func.name()),
        }
    }
}

/// The most characters a decimal constant may have, as written and as printed by
/// [`number_text`]. MODEL: a bound on the reader's work; no host writes a constant this long.
pub const NUMBER_TEXT_MAX: usize = 40;

/// A decimal constant's text (digits and at most one dot, no sign) as its value; `None` when
/// it holds no digit, or when its value prints longer than [`NUMBER_TEXT_MAX`] (40 nines round
/// to 1e40, 41 digits; `.` and 38 zeros and a 1 prints as `0.` and 39 digits), so that every
/// constant read prints as text that reads back (found by the fuzz target `card_grammar`).
pub fn decimal_value(text: &str) -> Option<f64> {
    if !text.bytes().any(|c| c.is_ascii_digit()) {
        return None;
    }
    let v = text.parse::<f64>().ok()?;
    (number_text(v).len() <= NUMBER_TEXT_MAX).then_some(v)
}

/// A constant as the card would print it: whole numbers without a fraction, others with as
/// many digits as they need (Rust's shortest round-trip form).
pub fn number_text(v: f64) -> String {
    if v.fract() == 0.0 && v.abs() < 1e15 {
        format!("{}", v as i64)
    } else {
        format!("{v}")
    }
}

/// Reads an expression over `s` from `*i`: returns it with `*i` just past it, or `None` with
/// `*i` unchanged when no expression starts there. `cs` is the addressed C.S. (for Q).
pub fn parse(s: &[u8], i: &mut usize, cs: u8) -> Option<Expr> {
    let mut p = ExprParser { s, i: *i, cs, depth: 0 };
    let e = p.sum()?;
    *i = p.i;
    Some(e)
}

/// How deeply parentheses and unary minus may nest: bounds the reader's stack on any input.
/// MODEL: a card's line is at most a few hundred characters; 64 levels is far beyond any host's.
const DEPTH_MAX: u32 = 64;

struct ExprParser<'a> {
    s: &'a [u8],
    i: usize,
    cs: u8,
    depth: u32,
}

impl ExprParser<'_> {
    fn peek(&self) -> Option<u8> {
        self.s.get(self.i).map(u8::to_ascii_uppercase)
    }

    fn skip_spaces(&mut self) {
        while matches!(self.s.get(self.i), Some(b' ' | b'\t')) {
            self.i += 1;
        }
    }

    /// The next operator, if one follows (spaces skipped), without taking it.
    fn operator(&mut self) -> Option<(Op, usize)> {
        let save = self.i;
        self.skip_spaces();
        let op = self.peek().and_then(Op::of);
        let at = self.i;
        self.i = save;
        op.map(|o| (o, at))
    }

    /// `term {(+|-|'|'|^) term}`
    fn sum(&mut self) -> Option<Expr> {
        let mut left = self.term()?;
        while let Some((op, at)) = self.operator().filter(|(o, _)| !o.binds_tight()) {
            let save = self.i;
            self.i = at + 1;
            match self.term() {
                Some(right) => left = Expr::Bin(op, Box::new(left), Box::new(right)),
                None => {
                    // An operator with nothing after it is not part of this expression.
                    self.i = save;
                    break;
                }
            }
        }
        Some(left)
    }

    /// `factor {(*|/|%|&) factor}`
    fn term(&mut self) -> Option<Expr> {
        let mut left = self.factor()?;
        while let Some((op, at)) = self.operator().filter(|(o, _)| o.binds_tight()) {
            let save = self.i;
            self.i = at + 1;
            match self.factor() {
                Some(right) => left = Expr::Bin(op, Box::new(left), Box::new(right)),
                None => {
                    self.i = save;
                    break;
                }
            }
        }
        Some(left)
    }

    fn nested<T>(&mut self, f: impl FnOnce(&mut Self) -> Option<T>) -> Option<T> {
        if self.depth >= DEPTH_MAX {
            return None;
        }
        self.depth += 1;
        let r = f(self);
        self.depth -= 1;
        r
    }

    /// `-factor | +factor | (sum) | function(sum) | variable | constant`
    fn factor(&mut self) -> Option<Expr> {
        let start = self.i;
        self.skip_spaces();
        let r = match self.peek() {
            Some(b'-') => {
                self.i += 1;
                self.nested(|p| p.factor()).map(|e| match e {
                    Expr::Const(v) => Expr::Const(-v),
                    e => Expr::Neg(Box::new(e)),
                })
            }
            Some(b'+') => {
                self.i += 1;
                self.nested(|p| p.factor())
            }
            Some(b'(') => {
                self.i += 1;
                self.nested(|p| p.parenthesised_rest())
            }
            Some(b'$') => self.hex(),
            Some(c) if c.is_ascii_digit() || c == b'.' => self.decimal(),
            Some(b'I' | b'P' | b'Q' | b'M') if !self.function_follows() => self.variable(),
            Some(c) if c.is_ascii_alphabetic() => self.call(),
            _ => None,
        };
        if r.is_none() {
            self.i = start;
        }
        r
    }

    /// After `(`: the expression and its `)`.
    fn parenthesised_rest(&mut self) -> Option<Expr> {
        let e = self.sum()?;
        self.skip_spaces();
        (self.peek() == Some(b')')).then(|| {
            self.i += 1;
            e
        })
    }

    fn function_follows(&self) -> bool {
        Func::NAMES.iter().any(|(n, _)| self.starts_with(n))
    }

    fn starts_with(&self, word: &str) -> bool {
        let w = word.as_bytes();
        self.s.len() >= self.i + w.len() && self.s[self.i..self.i + w.len()].eq_ignore_ascii_case(w)
    }

    fn call(&mut self) -> Option<Expr> {
        let (name, f) = Func::NAMES.iter().find(|(n, _)| self.starts_with(n))?;
        self.i += name.len();
        self.skip_spaces();
        if self.peek() != Some(b'(') {
            return None;
        }
        self.i += 1;
        let arg = self.nested(|p| p.parenthesised_rest())?;
        Some(Expr::Call(*f, Box::new(arg)))
    }

    fn variable(&mut self) -> Option<Expr> {
        let kind = match self.peek()? {
            b'I' => VarKind::I,
            b'P' => VarKind::P,
            b'Q' => VarKind::Q,
            _ => VarKind::M,
        };
        self.i += 1;
        let number = if self.peek() == Some(b'(') {
            self.i += 1;
            Index::Computed(self.nested(|p| p.parenthesised_rest())?)
        } else {
            let start = self.i;
            while self.peek().is_some_and(|c| c.is_ascii_digit()) && self.i - start < 5 {
                self.i += 1;
            }
            let n: u16 = std::str::from_utf8(&self.s[start..self.i]).ok()?.parse().ok()?;
            if n > super::VARIABLE_MAX {
                return None;
            }
            Index::Number(n)
        };
        Some(Expr::Var { kind, number: Box::new(number), cs: self.cs })
    }

    fn hex(&mut self) -> Option<Expr> {
        self.i += 1;
        let start = self.i;
        while self.peek().is_some_and(|c| c.is_ascii_hexdigit()) && self.i - start < 12 {
            self.i += 1;
        }
        let digits = std::str::from_utf8(&self.s[start..self.i]).ok()?;
        Some(Expr::Const(i64::from_str_radix(digits, 16).ok()? as f64))
    }

    fn decimal(&mut self) -> Option<Expr> {
        let start = self.i;
        let mut dot = false;
        while let Some(c) = self.peek() {
            if c == b'.' && !dot && !self.starts_with("..") {
                dot = true;
            } else if !c.is_ascii_digit() {
                break;
            }
            self.i += 1;
            if self.i - start > NUMBER_TEXT_MAX {
                return None;
            }
        }
        let text = std::str::from_utf8(&self.s[start..self.i]).ok()?;
        decimal_value(text).map(Expr::Const)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    struct Vars;
    impl Env for Vars {
        fn var(&mut self, kind: VarKind, n: u16, _: u8) -> f64 {
            match (kind, n) {
                (VarKind::I, 15) => 0.0,
                (VarKind::I, 130) => 1000.0,
                (VarKind::P, 1) => 1.0,
                (VarKind::Q, 0) => 1.0,
                _ => f64::from(n),
            }
        }
    }

    fn value(text: &str) -> f64 {
        let mut i = 0;
        let e = parse(text.as_bytes(), &mut i, 1).unwrap_or_else(|| panic!("{text} reads"));
        assert_eq!(i, text.len(), "{text}: read to the end");
        e.eval(&mut Vars).unwrap()
    }

    #[test]
    fn the_srm_examples_of_each_operator() {
        // SRM p.488-489.
        for (text, v) in [
            ("3&1", 1.0),
            ("3&2", 2.0),
            ("3&4", 0.0),
            ("3&-3", 1.0),
            ("0.875&1.75", 0.75),
            ("0.875&-1.75", 0.25),
            ("4|3", 7.0),
            ("$F0|$4", 244.0),
            ("3|-3", -1.0),
            ("0.5|0.375", 0.875),
            // MODEL: the SRM prints `0.875|-1.75` = -0.375; two's complement over the fraction
            // bits gives -1.125, as the same page's `0.875&-1.75` = 0.25 and `3|-3` = -1 need.
            ("0.875|-1.75", -1.125),
            ("2^1", 3.0),
            ("5^7", 2.0),
            ("$AA^$55", 255.0),
            ("3^-3", -2.0),
            ("0.5^0.875", 0.375),
            ("11%4", 3.0),
            ("11%-4", 3.0),
            ("-11%-4", -3.0),
            ("3%-2.5", -2.0),
            ("-3%-2.5", 2.0),
        ] {
            assert_eq!(value(text), v, "{text}");
        }
    }

    #[test]
    fn precedence_is_two_levels_left_to_right() {
        assert_eq!(value("1+2*3"), 7.0);
        assert_eq!(value("2+3&1"), 3.0, "& binds as * does");
        assert_eq!(value("8-2-1"), 5.0);
        assert_eq!(value("8/2/2"), 2.0);
        assert_eq!(value("(1+2)*3"), 9.0);
        assert_eq!(value("-2*3"), -6.0);
        assert_eq!(value("1000/0.0009765625"), 1_024_000.0);
        assert_eq!(value("1.25*I130"), 1250.0);
        assert_eq!(value("I(P1*100+30)"), 1000.0, "I130 through an index expression");
        assert_eq!(value("INT(-1.5)"), -2.0, "towards minus infinity");
        assert_eq!(value("SQRT(16)+ABS(-2)"), 6.0);
        assert!((value("SIN(30)") - 0.5).abs() < 1e-12, "degrees under I15 = 0");
        assert!((value("ATAN2(1)") - 45.0).abs() < 1e-12, "Q0 = 1 is the cosine argument");
    }

    #[test]
    fn an_expression_ends_where_the_next_command_starts() {
        let line = b"i124&$FDFFFF M140=1";
        let mut i = 0;
        let e = parse(line, &mut i, 1).unwrap();
        assert_eq!(&line[i..], b" M140=1");
        assert!(e.has_variables());
        // An operator with nothing after it is left for the next command.
        let mut i = 0;
        parse(b"5 #1J/", &mut i, 1).unwrap();
        assert_eq!(i, 1);
        let mut i = 0;
        parse(b"7..9", &mut i, 1).unwrap();
        assert_eq!(i, 1, "a range's `..` is not a decimal point");
    }

    #[test]
    fn printing_and_reading_again_give_the_same_tree() {
        for text in [
            "1+2*3",
            "(1+2)*3",
            "1-(2-3)",
            "1-2-3",
            "2*(3*4)",
            "-(1+2)",
            "--Q1",
            "I(P1*100+20)&$FF",
            "-Q81",
            "ATAN2(-1.5)",
            "3%-2.5",
            "M162/4096",
        ] {
            let mut i = 0;
            let e = parse(text.as_bytes(), &mut i, 1).unwrap();
            let printed = e.to_string();
            let mut j = 0;
            let again = parse(printed.as_bytes(), &mut j, 1).unwrap();
            assert_eq!(e, again, "{text} -> {printed}");
        }
    }

    #[test]
    fn a_long_chain_prints_no_deeper_than_it_was_written() {
        // Found by the fuzz target host_command: a chain of 12 subtractions and 32 minus signs
        // printed with a parenthesis per operation, past the nesting bound, so the printed
        // form did not read back.
        let text = format!("{}{}I400", "1-".repeat(100), "-".repeat(32));
        let mut i = 0;
        let e = parse(text.as_bytes(), &mut i, 1).unwrap();
        let printed = e.to_string();
        let mut j = 0;
        assert_eq!(parse(printed.as_bytes(), &mut j, 1), Some(e), "{printed}");
        assert_eq!(j, printed.len());
    }

    #[test]
    fn deep_nesting_is_refused_not_a_stack_overflow() {
        let deep = "(".repeat(100_000) + "1" + &")".repeat(100_000);
        let mut i = 0;
        assert!(parse(deep.as_bytes(), &mut i, 1).is_none());
        let minus = "-".repeat(100_000) + "1";
        let mut i = 0;
        assert!(parse(minus.as_bytes(), &mut i, 1).is_none());
    }

    #[test]
    fn results_outside_a_function_s_domain_are_errors() {
        let mut i = 0;
        let e = parse(b"SQRT(-1)", &mut i, 1).unwrap();
        assert_eq!(e.eval(&mut Vars), Err(EvalError::OutOfDomain));
        let mut i = 0;
        let e = parse(b"1/0", &mut i, 1).unwrap();
        assert_eq!(e.eval(&mut Vars), Err(EvalError::OutOfDomain));
    }
}
