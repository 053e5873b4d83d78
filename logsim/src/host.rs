//! The host: sends command lines to the card, waits for each answer (or gives up after its
//! timeout), and writes what it saw in the host-log format of docs/capturing.md.

use crate::card::{Answer, Card, Cmd};
use crate::rng::Rng;

/// One command line and what came back.
#[derive(Clone, Debug)]
pub struct Exchange {
    pub cmds: Vec<Cmd>,
    pub sent_s: f64,
    pub reply_s: f64,
    /// `None`: silence (the host timed out).
    pub answers: Option<Vec<Answer>>,
    /// How many resets (seen or not) the card had gone through when the line was sent.
    pub epoch: u32,
    /// The counter's reload value when answered (I40, or 4095/4096).
    pub reload: i64,
    /// For each command: after a write of that I-variable (since the last reset), the value
    /// written and whether it took effect (SRM p.57, I41); for a write, its own.
    pub written: Vec<Option<(i64, bool)>>,
    /// The card was latched tripped when the host gave up on this line.
    pub tripped: bool,
}

/// How the host stamps its lines.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Stamps {
    None,
    /// `HH:MM:SS.fff`
    TimeMs,
    /// `YYYY-MM-DD HH:MM:SS.ffffff`
    DashMicros,
    /// `[YYYY/MM/DD HH:MM:SS.fff]` then a tab
    SlashBracketMs,
    /// `YYYY-MM-DDTHH:MM:SS.fff`
    IsoMs,
}

impl Stamps {
    pub fn name(&self) -> &'static str {
        match self {
            Stamps::None => "none",
            Stamps::TimeMs => "time-ms",
            Stamps::DashMicros => "dash-date-us",
            Stamps::SlashBracketMs => "slash-date-ms-bracketed",
            Stamps::IsoMs => "iso-ms",
        }
    }

    fn format(&self, wall_s: f64) -> String {
        // Stamps are truncated to their resolution, as a logger reading a clock does.
        let (digits, scale) = match self {
            Stamps::DashMicros => (6, 1_000_000u64),
            _ => (3, 1_000u64),
        };
        let ticks = (wall_s * scale as f64).floor() as u64;
        let frac = ticks % scale;
        let secs = ticks / scale;
        let day = secs / 86_400;
        let sod = secs % 86_400;
        let (h, m, s) = (sod / 3600, sod / 60 % 60, sod % 60);
        // Days from 2026-11-01 (days of November and December only; logs are shorter).
        let (month, dom) = if day < 30 { (11, day + 1) } else { (12, day - 29) };
        let time = format!("{h:02}:{m:02}:{s:02}.{frac:0digits$}");
        match self {
            Stamps::None => String::new(),
            Stamps::TimeMs => time,
            Stamps::DashMicros => format!("2026-{month:02}-{dom:02} {time}"),
            Stamps::SlashBracketMs => format!("[2026/{month:02}/{dom:02} {time}]"),
            Stamps::IsoMs => format!("2026-{month:02}-{dom:02}T{time}"),
        }
    }
}

/// A host session with one card.
pub struct Session {
    pub card: Card,
    pub rng: Rng,
    pub t: f64,
    pub exchanges: Vec<Exchange>,
    pub timeout_s: f64,
    pub epoch: u32,
    /// Host-side writes since the last reset: variable -> (value, took effect).
    writes: std::collections::BTreeMap<u32, (i64, bool)>,
    /// Several commands on one line (as clients send them) or one per line.
    pub many_per_line: bool,
    /// The reply separator for several answers on a line: a space or a written `\r`.
    pub reply_separator: &'static str,
}

impl Session {
    pub fn new(card: Card, rng: Rng, timeout_s: f64, many_per_line: bool) -> Session {
        let t = card.now_s;
        let mut rng = rng;
        let reply_separator = if rng.chance(0.5) { " " } else { "\\r" };
        Session {
            card,
            rng,
            t,
            exchanges: Vec::new(),
            timeout_s,
            epoch: 0,
            writes: Default::default(),
            many_per_line,
            reply_separator,
        }
    }

    /// The host waits (the card runs on).
    pub fn wait_until(&mut self, t: f64) {
        if t > self.t {
            self.t = t;
        }
        self.card.run_until(self.t);
    }

    /// Send one command line now; returns the answers, or `None` on a timeout.
    pub fn send(&mut self, cmds: Vec<Cmd>) -> Option<Vec<Answer>> {
        let sent_s = self.t;
        // A fraction of a millisecond on the wire each way.
        let latency = self.rng.float(0.00005, 0.0004);
        self.card.run_until(sent_s + latency);
        let answers = self.card.exchange(cmds.clone(), sent_s + self.timeout_s);
        let reply_s = match answers {
            Some(_) => self.card.now_s + latency,
            None => sent_s + self.timeout_s,
        };
        let tripped = matches!(self.card.power, crate::card::Power::Tripped { .. });
        let reload = self.card.reload();
        let mut written = Vec::with_capacity(cmds.len());
        let epoch = self.epoch;
        for cmd in &cmds {
            match cmd {
                Cmd::ReadI(n) => written.push(self.writes.get(n).copied()),
                Cmd::WriteI(n, v) if answers.is_some() => {
                    // I41 itself is checked at the time of the write (SRM p.57).
                    let took = !crate::card::locked_by_i41(self.i41_before_write(), *n);
                    self.writes.insert(*n, (*v, took));
                    written.push(Some((*v, took)));
                }
                _ => written.push(None),
            }
        }
        if answers.is_some() && cmds.contains(&Cmd::Reset) {
            self.epoch += 1;
            self.writes.clear();
        }
        self.exchanges.push(Exchange {
            cmds,
            sent_s,
            reply_s,
            answers: answers.clone(),
            epoch,
            reload,
            written,
            tripped,
        });
        // The host reads the reply and sends on after a moment.
        self.t = reply_s + self.rng.float(0.0001, 0.001);
        self.card.run_until(self.t);
        answers
    }

    /// The lockout in force for writes: the host's own record of I41 (a write of I41 that
    /// took effect, else the card's value at the last reset).
    fn i41_before_write(&self) -> i64 {
        // A line is answered in one background cycle, commands in order: a write of I41
        // earlier on the same line counts, which the card's state already holds.
        self.card.i41()
    }

    /// Several commands: on one line, or each on its own line, by the session's style.
    pub fn poll(&mut self, cmds: Vec<Cmd>) {
        if self.many_per_line {
            self.send(cmds);
        } else {
            for cmd in cmds {
                self.send(vec![cmd]);
            }
        }
    }

    /// A reset the host does not see (INIT/ pulsed or power cycled at the card).
    pub fn unseen_reset(&mut self, boot_s: f64, dpram: bool, flash: bool) {
        self.card.reset(boot_s, dpram, flash);
        self.epoch += 1;
        self.writes.clear();
    }
}

/// The rendered log: its text and, for each exchange, the line numbers of its command and
/// reply lines (1-based).
pub struct Rendered {
    pub text: String,
    pub lines: Vec<(usize, usize)>,
}

pub fn render(
    header: &[String],
    exchanges: &[Exchange],
    stamps: Stamps,
    wall_start_s: f64,
    separator: &str,
) -> Rendered {
    let mut text = String::new();
    let mut line = 0usize;
    let mut lines = Vec::with_capacity(exchanges.len());
    for h in header {
        text.push_str("# ");
        text.push_str(h);
        text.push('\n');
        line += 1;
    }
    let stamp_sep = if stamps == Stamps::SlashBracketMs { "\t" } else { " " };
    for ex in exchanges {
        let cmd_text: Vec<String> = ex.cmds.iter().map(Cmd::text).collect();
        let reply = match &ex.answers {
            None => "(timeout)".to_string(),
            Some(answers) => answers.iter().filter_map(Answer::text).collect::<Vec<_>>().join(separator),
        };
        let (cs, rs) = if stamps == Stamps::None {
            (String::new(), String::new())
        } else {
            (
                format!("{}{stamp_sep}", stamps.format(wall_start_s + ex.sent_s)),
                format!("{}{stamp_sep}", stamps.format(wall_start_s + ex.reply_s)),
            )
        };
        text.push_str(&format!("{cs}> {}\n", cmd_text.join(" ")));
        line += 1;
        let cmd_line = line;
        if reply.is_empty() {
            text.push_str(&format!("{rs}<\n"));
        } else {
            text.push_str(&format!("{rs}< {reply}\n"));
        }
        line += 1;
        lines.push((cmd_line, line));
    }
    Rendered { text, lines }
}
