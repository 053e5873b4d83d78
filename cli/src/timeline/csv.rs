//! The timeline as CSV: a header line, then one line per change of any signal.

use super::Sink;
use pmacwd_capture::timeline::{Header, Item};
use std::io::Write;

pub struct Csv {
    out: Box<dyn Write>,
    started: bool,
}

impl Csv {
    pub fn new(out: Box<dyn Write>) -> Csv {
        Csv { out, started: false }
    }
}

impl Sink for Csv {
    fn item(&mut self, h: &Header, item: Item) -> std::io::Result<()> {
        if !self.started {
            self.started = true;
            writeln!(
                self.out,
                "# pmacwd timeline: configuration {}, profile {}, servo clock {} Hz",
                h.configuration, h.profile, h.servo_hz
            )?;
            let bits: Vec<&str> = h.bits.iter().map(|(_, _, n)| n.as_str()).collect();
            writeln!(self.out, "cycle,ms,y25,x25,strobe,tripped,background,{}", bits.join(","))?;
        }
        match item {
            Item::Change(s) => {
                let bit = |w: pmacwd_specs::status::WordId, b: u8| {
                    let word = match w {
                        pmacwd_specs::status::WordId::X => s.x,
                        pmacwd_specs::status::WordId::Y => s.y,
                    };
                    if word & (1 << b) != 0 {
                        "1"
                    } else {
                        "0"
                    }
                };
                let bits: Vec<&str> = h.bits.iter().map(|(w, b, _)| bit(*w, *b)).collect();
                writeln!(
                    self.out,
                    "{},{:.3},{},{},{},{},{},{}",
                    s.cycle,
                    h.ms(s.cycle),
                    s.counter,
                    s.counter_min,
                    u8::from(s.strobe),
                    u8::from(s.tripped),
                    u8::from(s.background),
                    bits.join(",")
                )
            }
            // Commands and reads are comments, so the data lines stay one table.
            Item::Mark { cycle, line, text, reads } => {
                let read = reads.map(|(_, v)| format!(" (the trace expects {v})")).unwrap_or_default();
                writeln!(self.out, "# cycle {cycle} (line {line}): {text}{read}")
            }
        }
    }

    fn finish(&mut self, _: &Header) -> std::io::Result<()> {
        self.out.flush()
    }
}
