//! The timeline as an SVG plot: Y:$25 and X:$25 against milliseconds, the trip as a red line,
//! the values the trace expects of its Y:$25 and X:$25 reads as dots. However long the trace,
//! the plot keeps at most `BUCKETS_MAX` spans of time, each with the range its values took, so
//! memory stays flat and a run-down a few cycles long still shows.

use super::Sink;
use plotters::prelude::*;
use pmacwd_capture::timeline::{Header, Item, Signals};
use pmacwd_specs::vocab::command::Register;
use std::io::Write;

const BUCKETS_MAX: usize = 2000;
/// Reads drawn at most (the rest are counted in the caption).
const READS_MAX: usize = 5000;

#[derive(Clone, Copy)]
struct Bucket {
    y: (i32, i32),
    x: (i32, i32),
}

impl Bucket {
    fn of(s: &Signals) -> Bucket {
        Bucket { y: (s.counter, s.counter), x: (s.counter_min, s.counter_min) }
    }
    fn add(&mut self, o: Bucket) {
        self.y = (self.y.0.min(o.y.0), self.y.1.max(o.y.1));
        self.x = (self.x.0.min(o.x.0), self.x.1.max(o.x.1));
    }
}

pub struct Svg {
    out: Box<dyn Write>,
    title: String,
    /// Bucket i spans cycles [i * width, (i + 1) * width).
    buckets: Vec<Bucket>,
    width: u64,
    last: Option<Signals>,
    trip: Option<u64>,
    reads: Vec<(u64, Register, i32)>,
    reads_left_out: usize,
    silent_reads: usize,
}

impl Svg {
    pub fn new(out: Box<dyn Write>, title: String) -> Svg {
        Svg {
            out,
            title,
            buckets: Vec::new(),
            width: 1,
            last: None,
            trip: None,
            reads: Vec::new(),
            reads_left_out: 0,
            silent_reads: 0,
        }
    }

    /// Fills the buckets up to `cycle` with the last values, then adds `s`.
    fn record(&mut self, s: Signals) {
        while s.cycle / self.width >= BUCKETS_MAX as u64 {
            // Twice as wide: neighbours merge.
            self.buckets = self
                .buckets
                .chunks(2)
                .map(|pair| {
                    let mut b = pair[0];
                    if let Some(o) = pair.get(1) {
                        b.add(*o);
                    }
                    b
                })
                .collect();
            self.width *= 2;
        }
        let idx = (s.cycle / self.width) as usize;
        if let Some(last) = self.last {
            while self.buckets.len() < idx {
                self.buckets.push(Bucket::of(&last));
            }
        }
        match self.buckets.get_mut(idx) {
            Some(b) => b.add(Bucket::of(&s)),
            None => self.buckets.push(Bucket::of(&s)),
        }
        self.last = Some(s);
    }
}

/// A read's expected reply, 24-bit two's complement hex, as a number.
fn word(text: &str) -> Option<i32> {
    let v = u32::from_str_radix(text.trim(), 16).ok().filter(|v| *v <= 0xFF_FFFF)?;
    Some(((v << 8) as i32) >> 8)
}

impl Sink for Svg {
    fn item(&mut self, _: &Header, item: Item) -> std::io::Result<()> {
        match item {
            Item::Change(s) => {
                if s.tripped && self.trip.is_none() {
                    self.trip = Some(s.cycle);
                }
                self.record(s);
            }
            Item::Mark { cycle, reads: Some((r, v)), .. } => match word(&v) {
                Some(v) if self.reads.len() < READS_MAX => self.reads.push((cycle, r, v)),
                Some(_) => self.reads_left_out += 1,
                // A read the trace expects no value from (`(silence)`: a tripped card) is no dot.
                None => self.silent_reads += 1,
            },
            Item::Mark { .. } => {}
        }
        Ok(())
    }

    fn finish(&mut self, h: &Header) -> std::io::Result<()> {
        let mut text = String::new();
        draw(self, h, &mut text).map_err(|e| std::io::Error::other(format!("cannot draw the plot: {e}")))?;
        self.out.write_all(text.as_bytes())?;
        self.out.flush()
    }
}

fn draw(p: &Svg, h: &Header, text: &mut String) -> Result<(), Box<dyn std::error::Error>> {
    let end_cycle = p.last.map_or(1, |l| l.cycle.max(1)).max(p.buckets.len() as u64 * p.width);
    let ms = |c: u64| h.ms(c);
    let (lo, hi) =
        p.buckets.iter().fold((i32::MAX, i32::MIN), |(lo, hi), b| (lo.min(b.x.0).min(b.y.0), hi.max(b.y.1).max(b.x.1)));
    let (lo, hi) = if lo > hi { (0, 1) } else { (lo, hi.max(lo + 1)) };
    let pad = ((hi - lo) / 20).max(1);
    let root = SVGBackend::with_string(text, (1200, 560)).into_drawing_area();
    root.fill(&WHITE)?;
    let mut notes = Vec::new();
    if p.silent_reads > 0 {
        notes.push(format!("{} reads met silence", p.silent_reads));
    }
    if p.reads_left_out > 0 {
        notes.push(format!("{} reads beyond {READS_MAX} not drawn", p.reads_left_out));
    }
    let notes = if notes.is_empty() { String::new() } else { format!(" ({})", notes.join(", ")) };
    let caption =
        format!("{}: configuration {}, profile {}, {} Hz{notes}", p.title, h.configuration, h.profile, h.servo_hz);
    let mut chart = ChartBuilder::on(&root)
        .caption(caption, ("sans-serif", 18))
        .margin(12)
        .x_label_area_size(40)
        .y_label_area_size(70)
        .build_cartesian_2d(0f64..ms(end_cycle) * 1.02, f64::from(lo - pad)..f64::from(hi + pad))?;
    chart
        .configure_mesh()
        .x_desc("ms since the start of the trace")
        .y_desc("counter value")
        .y_label_formatter(&|v| format!("{v:.0}"))
        .draw()?;
    let series = |pick: fn(&Bucket) -> (i32, i32)| -> Vec<(f64, f64)> {
        p.buckets
            .iter()
            .enumerate()
            .flat_map(|(i, b)| {
                let start = i as u64 * p.width;
                let (min, max) = pick(b);
                [(ms(start), f64::from(max)), (ms(start + p.width / 2), f64::from(min))]
            })
            .collect()
    };
    chart
        .draw_series(LineSeries::new(series(|b| b.x), GREEN.stroke_width(3)))?
        .label("X:$25, its lowest value since reset")
        .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], GREEN));
    chart
        .draw_series(LineSeries::new(series(|b| b.y), BLUE))?
        .label("Y:$25, the watchdog counter")
        .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], BLUE));
    let dots = |want: Register, color: RGBColor, size: i32| {
        p.reads
            .iter()
            .filter(move |(_, r, _)| *r == want)
            .map(move |(c, _, v)| Circle::new((ms(*c), f64::from(*v)), size, color.filled()))
    };
    chart
        .draw_series(dots(Register::WatchdogMinimum, GREEN, 6))?
        .label("a read of X:$25 in the trace")
        .legend(|(x, y)| Circle::new((x + 10, y), 6, GREEN.filled()));
    chart
        .draw_series(dots(Register::WatchdogCounter, BLUE, 3))?
        .label("a read of Y:$25 in the trace")
        .legend(|(x, y)| Circle::new((x + 10, y), 3, BLUE.filled()));
    if let Some(t) = p.trip {
        let x = ms(t);
        chart
            .draw_series(std::iter::once(PathElement::new(
                vec![(x, f64::from(lo - pad)), (x, f64::from(hi + pad))],
                RED.stroke_width(2),
            )))?
            .label(format!("the hardware timer trips ({x:.1} ms, UM p.215)"))
            .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], RED));
    }
    chart
        .configure_series_labels()
        .position(SeriesLabelPosition::LowerLeft)
        .border_style(BLACK)
        .background_style(WHITE.mix(0.9))
        .draw()?;
    root.present()?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn change(cycle: u64, counter: i32) -> Signals {
        Signals { cycle, counter, counter_min: counter, strobe: false, tripped: false, background: false, x: 0, y: 0 }
    }

    #[test]
    fn a_long_trace_keeps_at_most_the_bucket_limit_and_every_extreme() {
        // A day at 2.25 kHz is 194 million cycles: the plot must not keep one point each, and
        // a dip of one cycle must still be drawn.
        let mut svg = Svg::new(Box::new(std::io::sink()), String::new());
        for c in 0..100_000u64 {
            svg.record(change(c, if c == 77_777 { -5 } else { 4096 - (c % 13) as i32 }));
        }
        assert!(svg.buckets.len() <= BUCKETS_MAX);
        assert_eq!(svg.buckets.iter().map(|b| b.y.0).min(), Some(-5));
        assert_eq!(svg.buckets.iter().map(|b| b.y.1).max(), Some(4096));
    }

    #[test]
    fn a_read_reply_is_a_24_bit_twos_complement_word() {
        assert_eq!(word("001000"), Some(4096));
        assert_eq!(word("FFFFFD"), Some(-3));
        assert_eq!(word("1000000"), None);
    }
}
