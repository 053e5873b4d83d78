//! The timeline as a value change dump (IEEE 1364 VCD) for GTKWave: time in nanoseconds at the
//! configuration's servo clock, Y:$25 and X:$25 as 32-bit integers, the strobe, the trip, the
//! background cycles and every status bit as 1-bit wires. Host commands are not signals and are
//! left out (the CSV form lists them).

use super::Sink;
use pmacwd_capture::timeline::{Header, Item, Signals};
use pmacwd_specs::status::WordId;
use std::io::Write;

pub struct Vcd {
    out: Box<dyn Write>,
    last: Option<Signals>,
    last_time: Option<u64>,
}

impl Vcd {
    pub fn new(out: Box<dyn Write>) -> Vcd {
        Vcd { out, last: None, last_time: None }
    }
}

/// The short identifier of signal `n`: printable ASCII `!` to `~`, base 94.
fn id(mut n: usize) -> String {
    let mut s = String::new();
    loop {
        s.push(char::from(b'!' + (n % 94) as u8));
        n /= 94;
        if n == 0 {
            return s;
        }
        n -= 1;
    }
}

/// The signals in declaration order, as VCD values: (is_integer, value).
fn values(h: &Header, s: &Signals) -> Vec<(bool, u32)> {
    let mut v = vec![
        (true, s.counter as u32),
        (true, s.counter_min as u32),
        (false, u32::from(s.strobe)),
        (false, u32::from(s.tripped)),
        (false, u32::from(s.background)),
    ];
    for (w, b, _) in &h.bits {
        let word = match w {
            WordId::X => s.x,
            WordId::Y => s.y,
        };
        v.push((false, (word >> b) & 1));
    }
    v
}

impl Vcd {
    fn header(&mut self, h: &Header) -> std::io::Result<()> {
        let out = &mut self.out;
        writeln!(out, "$version pmacwd timeline $end")?;
        writeln!(
            out,
            "$comment configuration {}, profile {}, servo clock {} Hz; one servo cycle is {:.1} ns $end",
            h.configuration,
            h.profile,
            h.servo_hz,
            1e9 / f64::from(h.servo_hz)
        )?;
        writeln!(out, "$timescale 1 ns $end")?;
        writeln!(out, "$scope module pmac $end")?;
        for (n, name) in ["y25_counter", "x25_counter_min"].iter().enumerate() {
            writeln!(out, "$var integer 32 {} {name} $end", id(n))?;
        }
        for (n, name) in ["strobe", "tripped", "background"].iter().enumerate() {
            writeln!(out, "$var wire 1 {} {name} $end", id(2 + n))?;
        }
        for (word, scope) in [(WordId::X, "status_x"), (WordId::Y, "status_y")] {
            writeln!(out, "$scope module {scope} $end")?;
            for (n, (w, b, name)) in h.bits.iter().enumerate() {
                if *w == word {
                    writeln!(out, "$var wire 1 {} bit{b:02}_{name} $end", id(5 + n))?;
                }
            }
            writeln!(out, "$upscope $end")?;
        }
        writeln!(out, "$upscope $end")?;
        writeln!(out, "$enddefinitions $end")
    }
}

impl Sink for Vcd {
    fn item(&mut self, h: &Header, item: Item) -> std::io::Result<()> {
        let Item::Change(s) = item else { return Ok(()) };
        if self.last.is_none() {
            self.header(h)?;
        }
        let time = (s.cycle as f64 * 1e9 / f64::from(h.servo_hz)).round() as u64;
        let now = values(h, &s);
        let before = self.last.map(|l| values(h, &l));
        let first = before.is_none();
        if self.last_time != Some(time) {
            writeln!(self.out, "#{time}")?;
            self.last_time = Some(time);
        }
        if first {
            writeln!(self.out, "$dumpvars")?;
        }
        for (n, (integer, v)) in now.iter().enumerate() {
            if before.as_ref().is_some_and(|b| b[n].1 == *v) {
                continue;
            }
            if *integer {
                writeln!(self.out, "b{v:b} {}", id(n))?;
            } else {
                writeln!(self.out, "{v}{}", id(n))?;
            }
        }
        if first {
            writeln!(self.out, "$end")?;
        }
        self.last = Some(s);
        Ok(())
    }

    fn finish(&mut self, _: &Header) -> std::io::Result<()> {
        self.out.flush()
    }
}

#[cfg(test)]
mod tests {
    use super::id;

    #[test]
    fn signal_identifiers_are_distinct_printable_codes() {
        // VCD identifiers are printable ASCII without spaces; 53 signals need a second character.
        let ids: Vec<String> = (0..200).map(id).collect();
        assert!(ids.iter().all(|s| s.bytes().all(|b| (b'!'..=b'~').contains(&b))));
        let unique: std::collections::HashSet<_> = ids.iter().collect();
        assert_eq!(unique.len(), ids.len());
        assert_eq!((id(0).as_str(), id(93).as_str(), id(94).as_str()), ("!", "~", "!!"));
    }
}
