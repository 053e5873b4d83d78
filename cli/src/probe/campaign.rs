//! The campaign: which units of commands to send, in a seeded order with seeded parameters,
//! and how each one runs. Every unit starts with a read of the servo counter X:$0 and of the
//! configuration (I10, I8, I40, I41), so that the log stays judgeable with any unit left out
//! (`judge.rs`); every I-variable a unit writes is read first and written back before the unit
//! ends.

use super::check::Check;
use super::log::HostLog;
use super::wire::{ControlPort, Link, Reply};
use std::time::{Duration, Instant, SystemTime};

pub static CONFIGURATION: Check =
    Check { id: "configuration", what: "I10, I8, I40, I41 read back as held", cite: "SRM p.42-43, SRM p.57" };
pub static SERVO_COUNTER: Check =
    Check { id: "servo-counter", what: "X:$0 counts servo cycles", cite: "M-FILE M100->X:$000000,0,24,U" };
pub static STATUS: Check = Check {
    id: "status-words",
    what: "??? reports the global status words X:$6 and Y:$6 as they stand",
    cite: "SRM p.289",
};
pub static BIT22: Check = Check {
    id: "bit22-sticky",
    what: "bit 22 (RTI re-entry) stays set until the host writes it to 0 or the card resets",
    cite: "SRM p.289",
};
pub static WATCHDOG_COUNTER: Check = Check {
    id: "watchdog-counter",
    what: "Y:$25 counts down every servo cycle and is reloaded by each background cycle",
    cite: "SRM p.57, UM p.215",
};
pub static WATCHDOG_MINIMUM: Check = Check {
    id: "watchdog-minimum",
    what: "X:$25 holds the lowest value of Y:$25 since power-up or reset",
    cite: "UM p.240, SRM p.57",
};
pub static I40_RELOAD: Check = Check {
    id: "i40-reload",
    what: "a background cycle reloads Y:$25 with I40 (4096 or 4095 at I40 = 0)",
    cite: "SRM p.57, UM p.215, UM p.240",
};
pub static I41_LOCKOUT: Check = Check {
    id: "i41-lockout",
    what: "a write to an I-variable of a range I41 locks is ignored; I41 itself is never locked",
    cite: "SRM p.57",
};
pub static CHECKSUM: Check = Check {
    id: "checksum",
    what: "CHECKSUM, X:$1080 and X:$1090 answer on a running card; bits 12 and 13 of ???",
    cite: "UM p.217, SRM p.295, SRM p.289",
};
pub static STOP: Check =
    Check { id: "stop-commands", what: "a kill of an idle motor is acknowledged", cite: "UM p.217, UM p.319" };
pub static ERRORS: Check = Check {
    id: "error-numbers",
    what: "a command the card cannot read, or a value outside a variable's range, answers ERR003 and changes nothing",
    cite: "UM p.237, SRM p.57",
};
pub static RESET: Check = Check {
    id: "reset",
    what: "$$$ resets the card: X:$0 restarts, Y:$25 and X:$25 start over, sticky bits clear",
    cite: "UM p.243, UM p.240",
};
pub static REINITIALIZE: Check = Check {
    id: "reinitialize",
    what: "$$$*** resets the card with the factory defaults in use; the next $$$ brings the saved values back",
    cite: "UM p.243, SRM p.42, SRM p.57",
};
pub static TRIP: Check = Check {
    id: "trip-silence",
    what: "a card whose watchdog ran out does not communicate until INIT/ or a power cycle",
    cite: "UM p.215",
};

/// Every check, in the order the report lists them.
pub const CHECKS: [&Check; 14] = [
    &CONFIGURATION,
    &SERVO_COUNTER,
    &STATUS,
    &BIT22,
    &WATCHDOG_COUNTER,
    &WATCHDOG_MINIMUM,
    &I40_RELOAD,
    &I41_LOCKOUT,
    &CHECKSUM,
    &STOP,
    &ERRORS,
    &RESET,
    &REINITIALIZE,
    &TRIP,
];

/// The unit number of the reset that starts a campaign (never left out of a judgment).
pub const START: usize = usize::MAX;

/// The least time between two polls ([`Session::space_polls`]): 22 servo cycles at 2.25 kHz.
pub const POLL_SPACING: Duration = Duration::from_millis(10);

/// The longest a line without an X:$0 read is sent after one ([`Session::send`]).
pub const READ_AGE_MAX: Duration = Duration::from_millis(4);

/// The least time after an error before the next line: `pmacwd serve` answers a connection's
/// errors at most one per 10 ms (docs/emulator.md), and an error answered late is a command
/// host time places far from its read.
pub const ERROR_SPACING: Duration = Duration::from_millis(11);

/// The poll line (see [`Session::poll`]).
pub const POLL: &str = "RHX:$0 RHY:$25 RHX:$25 RHX:$6 RHY:$6 ???";

/// What the user allows the probe to do to the card.
#[derive(Clone, Copy, Debug, Default)]
pub struct Allow {
    /// Only reads: no unit that writes anything, even reversibly.
    pub read_only: bool,
    pub writes: bool,
    pub reset: bool,
    pub trip: bool,
    /// The emulator's control port is given: load and INIT/ through it.
    pub control: bool,
    /// `--units` names bit22.
    pub bit22: bool,
}

/// One unit of the campaign.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Unit {
    /// `ver`, `cid`, I3, I6, and a poll.
    Identity,
    /// `polls` polls of X:$0, the status words, Y:$25 and X:$25, `gap_ms` apart.
    Poll {
        polls: u32,
        gap_ms: u64,
    },
    /// I40 = `value` for a few polls, then back.
    I40Reload {
        value: u32,
    },
    /// I41's `bit` against I-variable `var` of its range: locked, then not, then restored.
    I41Lockout {
        bit: u8,
        var: u16,
    },
    /// Commands a correct card refuses.
    Errors {
        unreadable: &'static str,
    },
    Checksums,
    /// A kill of each of motors 1..=8 found idle (amplifier off).
    StopIdle,
    /// PLC 0 made to overrun the RTI through the control port until bit 22 sets, then the
    /// load restored and bit 22 watched.
    Bit22,
    Reset,
    /// `$$$***`, the factory defaults read, then `$$$` (the saved values back).
    Reinitialize,
    /// The background starved until the card trips, then INIT/.
    Trip,
}

/// How a unit changes the card, for the plan.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
pub enum Touch {
    Reads,
    Reversible,
    Writes,
    Resets,
    Trips,
}

impl Unit {
    pub fn name(&self) -> String {
        match self {
            Unit::Identity => "identity".into(),
            Unit::Poll { polls, gap_ms } => format!("poll x{polls} every {gap_ms} ms"),
            Unit::I40Reload { value } => format!("i40-reload I40={value}"),
            Unit::I41Lockout { bit, var } => format!("i41-lockout bit {bit} (I{var})"),
            Unit::Errors { unreadable } => format!("error-numbers ({unreadable})"),
            Unit::Checksums => "checksum".into(),
            Unit::StopIdle => "stop-idle-motors".into(),
            Unit::Bit22 => "bit22 (control port: PLC 0 overruns the RTI)".into(),
            Unit::Reset => "reset ($$$)".into(),
            Unit::Reinitialize => "reinitialize ($$$*** then $$$)".into(),
            Unit::Trip => "trip (background starved) and INIT/".into(),
        }
    }

    /// The kind of unit, as `--units` names it.
    pub fn kind(&self) -> &'static str {
        match self {
            Unit::Identity => "identity",
            Unit::Poll { .. } => "poll",
            Unit::I40Reload { .. } => "i40",
            Unit::I41Lockout { .. } => "i41",
            Unit::Errors { .. } => "errors",
            Unit::Checksums => "checksum",
            Unit::StopIdle => "stop",
            Unit::Bit22 => "bit22",
            Unit::Reset => "reset",
            Unit::Reinitialize => "reinitialize",
            Unit::Trip => "trip",
        }
    }

    pub fn touch(&self) -> Touch {
        match self {
            Unit::Identity | Unit::Poll { .. } | Unit::Checksums => Touch::Reads,
            Unit::I40Reload { .. } | Unit::I41Lockout { .. } | Unit::Errors { .. } | Unit::StopIdle => {
                Touch::Reversible
            }
            Unit::Bit22 => Touch::Writes,
            Unit::Reset | Unit::Reinitialize => Touch::Resets,
            Unit::Trip => Touch::Trips,
        }
    }

    /// What the unit sends that changes anything, in words.
    pub fn effect(&self, control: bool) -> String {
        match self {
            Unit::Identity | Unit::Poll { .. } | Unit::Checksums => "reads only".into(),
            Unit::I40Reload { value } => {
                format!("writes I40={value} (the watchdog's reload) for about 0.2 s, then the value read before")
            }
            Unit::I41Lockout { bit, var } => format!(
                "writes I41 with bit {bit} clear and set, and I{var} to the value read plus 1 and 2, then both back"
            ),
            Unit::Errors { .. } => {
                "sends an unreadable command and out-of-range writes of I41, I40, I8 (refused by a correct card; \
                 written back if not)"
                    .into()
            }
            Unit::StopIdle => "reads #1? to #8?; sends #nK only to motors whose amplifier is already off".into(),
            Unit::Bit22 => {
                "raises PLC 0's load on the emulator's control port, then restores it and clears bit 22".into()
            }
            Unit::Reset => "sends $$$ (a reset: unsaved changes are lost)".into(),
            Unit::Reinitialize => {
                "sends $$$*** (the factory defaults in use) then $$$ (the saved values back; unsaved changes lost)"
                    .into()
            }
            Unit::Trip if control => {
                "starves the background on the control port until the card trips, then INIT/ there".into()
            }
            Unit::Trip => {
                "downloads a PLC 0 that takes every RTI (OPEN PLC 0 CLEAR ... ENABLE PLC 0) until the card trips; \
                 then waits for you to assert INIT/ or cycle the power"
                    .into()
            }
        }
    }
}

/// A seeded generator (SplitMix64): the same seed gives the same campaign.
pub struct Rng(u64);

impl Rng {
    pub fn new(seed: u64) -> Rng {
        Rng(seed)
    }
    pub fn next(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }
    /// A number in `lo..=hi`.
    pub fn range(&mut self, lo: u64, hi: u64) -> u64 {
        lo + self.next() % (hi - lo + 1)
    }
    fn shuffle<T>(&mut self, v: &mut [T]) {
        for i in (1..v.len()).rev() {
            let j = self.range(0, i as u64) as usize;
            v.swap(i, j);
        }
    }
}

/// Text the card's grammar cannot read as its first command, so nothing of it runs
/// (checked against the grammar when the plan is made).
const UNREADABLE: [&str; 4] = ["XYZZY", "ZZTOP", "GARBAGE", "@@"];

/// The campaign for `seed` under what `allow` permits, `rounds` times the basic units.
pub fn plan(seed: u64, allow: Allow, rounds: u32, kinds: Option<&[String]>) -> Vec<Unit> {
    let mut units = plan_all(seed, allow, rounds);
    if let Some(kinds) = kinds {
        units.retain(|u| kinds.iter().any(|k| k == u.kind()));
    }
    units
}

fn plan_all(seed: u64, allow: Allow, rounds: u32) -> Vec<Unit> {
    let mut rng = Rng::new(seed);
    let mut units = Vec::new();
    for _ in 0..rounds {
        units.push(Unit::Poll { polls: rng.range(3, 6) as u32, gap_ms: rng.range(20, 150) });
        units.push(Unit::Checksums);
        if !allow.read_only {
            units.push(Unit::I40Reload { value: rng.range(2000, 3500) as u32 });
            units.push(Unit::I41Lockout { bit: 0, var: [122, 222][rng.range(0, 1) as usize] });
            units.push(Unit::I41Lockout { bit: 1, var: [5187, 6687][rng.range(0, 1) as usize] });
            if allow.writes {
                units.push(Unit::I41Lockout { bit: 2, var: 7999 });
                units.push(Unit::I41Lockout { bit: 3, var: 8191 });
            }
            let candidates: Vec<&str> = UNREADABLE.iter().copied().filter(|t| unreadable(t)).collect();
            if !candidates.is_empty() {
                units.push(Unit::Errors { unreadable: candidates[rng.range(0, candidates.len() as u64 - 1) as usize] });
            }
            units.push(Unit::StopIdle);
            // Only when named: a ramp of PLC 0 loads can overrun the RTI in patterns the replay
            // search's plans do not cover, and a correct emulator was judged faulty once in
            // three runs (docs/probe.md).
            if allow.control && allow.writes && allow.bit22 {
                units.push(Unit::Bit22);
            }
        }
    }
    rng.shuffle(&mut units);
    units.insert(0, Unit::Identity);
    if allow.reset && !allow.read_only {
        units.push(Unit::Reset);
        units.push(Unit::Reinitialize);
    }
    if allow.trip && !allow.read_only {
        units.push(Unit::Trip);
        units.push(Unit::Poll { polls: 3, gap_ms: 50 });
    }
    units
}

/// Whether the card's grammar fails on the first command of `text` (so that none of it runs).
fn unreadable(text: &str) -> bool {
    let mut addressing = pmacwd_specs::grammar::Addressing::default();
    matches!(pmacwd_specs::grammar::parse_commands(text.as_bytes(), &mut addressing).first(), Some((Err(_), _)))
}

/// A unit could not go on (the card fell silent where it must answer, the link broke).
#[derive(Debug)]
pub enum Stop {
    /// The rest of the campaign cannot run: the message says why.
    Link(String),
    /// The card was silent or answered unreadably where the unit needed a value: the unit ends.
    Unit(String),
}

pub struct Session<'a> {
    pub link: &'a mut Link,
    pub control: Option<&'a mut ControlPort>,
    pub log: &'a mut HostLog,
    pub unit: usize,
    /// The servo rate the card's I10 gives (for how long a trip takes).
    pub servo_hz: f64,
    /// The card's I40 as last read (0: the counter reloads to 4096 or 4095).
    pub i40: u32,
    /// How long the probe waits for a card to come back after a trip without a control port.
    pub recover: Duration,
    pub last_poll: Option<Instant>,
    /// When the last X:$0 read that the card answered was sent (None after a reset).
    pub last_read: Option<Instant>,
    /// When the card last answered an error.
    pub last_error: Option<Instant>,
}

impl Session<'_> {
    /// Sends one line, logs it under `check`. A line without an X:$0 read goes at most
    /// [`READ_AGE_MAX`] after one (one is sent first if need be), and at least
    /// [`ERROR_SPACING`] after the last error: the replay search judges the campaign with each
    /// command at the read before it, and a command host time places more than 10 ms after its
    /// read makes the search judge the log again by host time (docs/replay.md), which judged
    /// correct units faulty when a later unit had a fault (`serve --fault never-trips`).
    pub fn send(&mut self, check: &'static Check, line: &str) -> Result<Reply, Stop> {
        let reads = line.split_whitespace().any(|c| c.eq_ignore_ascii_case("RHX:$0"));
        if let Some(e) = self.last_error {
            let since = e.elapsed();
            if since < ERROR_SPACING {
                std::thread::sleep(ERROR_SPACING - since);
            }
        }
        if !reads && self.last_read.is_some_and(|r| r.elapsed() > READ_AGE_MAX) {
            self.exchange(&SERVO_COUNTER, "RHX:$0")?;
        }
        self.exchange(check, line)
    }

    fn exchange(&mut self, check: &'static Check, line: &str) -> Result<Reply, Stop> {
        let started = Instant::now();
        let sent = SystemTime::now();
        let reply = self.link.exchange(line).map_err(Stop::Link)?;
        let got = SystemTime::now();
        self.log.record(line, reply.clone(), sent, got, check, self.unit).map_err(Stop::Link)?;
        if let Reply::Answers(a) = &reply {
            if line.split_whitespace().next().is_some_and(|c| c.eq_ignore_ascii_case("RHX:$0")) && !a.is_empty() {
                self.last_read = Some(started);
            }
            if a.last().is_some_and(|x| x.starts_with("ERR")) {
                self.last_error = Some(Instant::now());
            }
        }
        if line.trim() == "$$$" || line.trim() == "$$$***" {
            // The search times the next read from the reset.
            self.last_read = None;
        }
        Ok(reply)
    }

    /// Sends one line that must answer one value.
    fn value(&mut self, check: &'static Check, line: &str) -> Result<String, Stop> {
        match self.send(check, line)? {
            Reply::Answers(a) if a.len() == 1 && !a[0].starts_with("ERR") => Ok(a[0].clone()),
            other => Err(Stop::Unit(format!("`{line}` answered `{}`", other.log_text()))),
        }
    }

    fn control(&mut self, command: &str) -> Result<String, Stop> {
        match self.control.as_deref_mut() {
            Some(c) => {
                let r = c.send(command).map_err(Stop::Link)?;
                self.log.comment(&format!("control port: {command} -> {r}")).map_err(Stop::Link)?;
                Ok(r)
            }
            None => Err(Stop::Unit("no control port (--control)".into())),
        }
    }

    /// The first lines of every unit: X:$0, then the configuration the importer reads.
    fn start(&mut self, title: &str) -> Result<(), Stop> {
        self.log.comment(&format!("unit {}: {title}", self.unit)).map_err(Stop::Link)?;
        self.send(&SERVO_COUNTER, "RHX:$0")?;
        if let Reply::Answers(a) = self.send(&CONFIGURATION, "I10 I8 I40 I41")? {
            if let Some(i10) = a.first().and_then(|t| t.parse::<f64>().ok()).filter(|v| *v > 0.0) {
                // SRM p.43: I10 is the servo interrupt time in 1/8,388,608 ms.
                self.servo_hz = 8_388_608_000.0 / i10;
            }
            if let Some(i40) = a.get(2).and_then(|t| t.parse::<u32>().ok()) {
                self.i40 = i40;
            }
        }
        // A poll before anything else: the replay search is slow to place a command whose answer
        // is the card's own (`ver`, an I-variable it has no rule for) right after the first read
        // of a log, whose gap since power-up is unbounded; after a second X:$0 read it is fast.
        self.poll()?;
        Ok(())
    }

    /// One poll, one line: X:$0, Y:$25, X:$25, X:$6, Y:$6 and `???`. The card answers a line in
    /// one pass of its background, so these are one instant: the replay search places every
    /// command at the X:$0 read before it, and reads on lines of their own could straddle a
    /// servo cycle. Y:$25 before X:$25: a cycle between them can only lower X:$25 below it.
    pub fn poll(&mut self) -> Result<Reply, Stop> {
        self.poll_as(&STATUS)
    }

    /// [`Session::poll`], logged under `check` (a unit's own: the trip, bit 22).
    pub fn poll_as(&mut self, check: &'static Check) -> Result<Reply, Stop> {
        self.space_polls();
        self.send(check, POLL)
    }

    /// At least [`POLL_SPACING`] between two polls: two reads a servo cycle apart leave the
    /// replay search no choice of background cycles between them, and it takes checksum passes
    /// of one background cycle (MODEL, docs/replay.md), so a card with longer passes whose
    /// background ran once between them would be judged by a rule it need not follow.
    fn space_polls(&mut self) {
        if let Some(last) = self.last_poll {
            let since = last.elapsed();
            if since < POLL_SPACING {
                std::thread::sleep(POLL_SPACING - since);
            }
        }
        self.last_poll = Some(Instant::now());
    }

    fn polls(&mut self, n: u32, gap: Duration) -> Result<(), Stop> {
        for i in 0..n {
            if i > 0 {
                std::thread::sleep(gap);
            }
            self.poll()?;
        }
        Ok(())
    }

    /// Runs `unit`; what it could not do is written in the log and returned.
    pub fn run(&mut self, unit: &Unit, rng: &mut Rng) -> Result<Option<String>, String> {
        match self.run_unit(unit, rng) {
            Ok(()) => Ok(None),
            Err(Stop::Unit(why)) => {
                self.log.comment(&format!("unit {} ended early: {why}", self.unit))?;
                Ok(Some(why))
            }
            Err(Stop::Link(e)) => Err(e),
        }
    }

    fn run_unit(&mut self, unit: &Unit, rng: &mut Rng) -> Result<(), Stop> {
        let ms = Duration::from_millis;
        self.start(&unit.name())?;
        match *unit {
            Unit::Identity => {
                self.send(&CONFIGURATION, "I3 I6")?;
                self.polls(2, ms(30))?;
            }
            Unit::Poll { polls, gap_ms } => self.polls(polls, ms(gap_ms))?,
            Unit::Checksums => {
                self.poll()?;
                self.send(&CHECKSUM, "CHECKSUM")?;
                self.send(&CHECKSUM, "RHX:$1080")?;
                self.send(&CHECKSUM, "RHX:$1090")?;
                self.poll()?;
            }
            Unit::I40Reload { value } => {
                let before = self.value(&I40_RELOAD, "I40")?;
                self.poll()?;
                self.send(&I40_RELOAD, &format!("I40={value}"))?;
                let r = self.i40_polls(value, rng);
                // Back to the value read, whatever happened in between.
                self.send(&I40_RELOAD, &format!("I40={before}"))?;
                self.send(&I40_RELOAD, "I40")?;
                r?;
                self.polls(2, ms(30))?;
            }
            Unit::I41Lockout { bit, var } => self.i41(bit, var)?,
            Unit::Errors { unreadable } => {
                self.poll()?;
                self.send(&ERRORS, unreadable)?;
                for (n, bad) in [(41u16, "16"), (40, "65536"), (8, "256")] {
                    let before = self.value(&ERRORS, &format!("I{n}"))?;
                    self.send(&ERRORS, &format!("I{n}={bad}"))?;
                    let after = self.value(&ERRORS, &format!("I{n}"))?;
                    if after != before {
                        self.send(&ERRORS, &format!("I{n}={before}"))?;
                    }
                }
                self.send(&ERRORS, "I8192")?;
                self.poll()?;
            }
            Unit::StopIdle => {
                self.poll()?;
                let mut idle = Vec::new();
                for n in 1..=8u8 {
                    let status = self.value(&STOP, &format!("#{n}?"))?;
                    // Motor status X word bit 19: amplifier enabled (SRM p.282).
                    let x = u32::from_str_radix(status.get(..6).unwrap_or(""), 16).ok();
                    if x.is_some_and(|x| x & (1 << 19) == 0) {
                        idle.push(n);
                    }
                }
                for n in idle {
                    self.send(&STOP, &format!("#{n}K"))?;
                    self.send(&STOP, &format!("#{n}?"))?;
                }
                self.poll()?;
            }
            Unit::Bit22 => self.bit22()?,
            Unit::Reset => {
                self.polls(2, ms(30))?;
                self.send(&RESET, "$$$")?;
                self.recovered(ms(3000))?;
                self.polls(3, ms(40))?;
            }
            Unit::Reinitialize => {
                self.polls(2, ms(30))?;
                self.send(&REINITIALIZE, "$$$***")?;
                self.recovered(ms(3000))?;
                self.send(&REINITIALIZE, "I8 I40 I41")?;
                self.polls(2, ms(30))?;
                self.send(&RESET, "$$$")?;
                self.recovered(ms(3000))?;
                self.send(&REINITIALIZE, "I8 I40 I41")?;
                self.polls(2, ms(30))?;
            }
            Unit::Trip => self.trip()?,
        }
        Ok(())
    }

    fn i40_polls(&mut self, _value: u32, rng: &mut Rng) -> Result<(), Stop> {
        let gap = Duration::from_millis(rng.range(20, 80));
        self.polls(3, gap)?;
        self.send(&I40_RELOAD, "I40")?;
        Ok(())
    }

    fn i41(&mut self, bit: u8, var: u16) -> Result<(), Stop> {
        let mask = 1u32 << bit;
        let i41: u32 =
            self.value(&I41_LOCKOUT, "I41")?.trim().parse().map_err(|_| Stop::Unit("I41 is not a number".into()))?;
        let text = self.value(&I41_LOCKOUT, &format!("I{var}"))?;
        let Ok(before) = text.trim().parse::<i64>() else {
            return Err(Stop::Unit(format!("I{var} reads `{text}`, not a whole number: not written")));
        };
        let (a, b) = if before < 1_000_000 { (before + 1, before + 2) } else { (before - 1, before - 2) };
        let mut steps = || -> Result<(), Stop> {
            // Written unlocked first, so that the value is known to every reading: a locked
            // write must leave it so (the card's own value before is not the model's).
            self.send(&I41_LOCKOUT, &format!("I41={}", i41 & !mask))?;
            self.send(&I41_LOCKOUT, &format!("I{var}={a}"))?;
            self.send(&I41_LOCKOUT, &format!("I41={}", i41 | mask))?;
            self.send(&I41_LOCKOUT, &format!("I{var}={b}"))?;
            self.send(&I41_LOCKOUT, &format!("I{var}"))?;
            self.poll()?;
            self.send(&I41_LOCKOUT, &format!("I41={}", i41 & !mask))?;
            self.send(&I41_LOCKOUT, &format!("I{var}={b}"))?;
            self.send(&I41_LOCKOUT, &format!("I{var}"))?;
            Ok(())
        };
        let r = steps();
        // Back as found: the variable while unlocked, then I41.
        self.send(&I41_LOCKOUT, &format!("I41={}", i41 & !mask))?;
        self.send(&I41_LOCKOUT, &format!("I{var}={before}"))?;
        self.send(&I41_LOCKOUT, &format!("I41={i41}"))?;
        self.send(&I41_LOCKOUT, &format!("I{var} I41"))?;
        r
    }

    /// PLC 0's load raised on the control port, step by step, until the emulator's own state
    /// shows bit 22 (an RTI overrun); then the load as it was, and polls: bit 22 must stay.
    /// A poll after each step: left unread, a long gap of changing load is slow to search.
    fn bit22(&mut self) -> Result<(), Stop> {
        let ms = Duration::from_millis;
        self.polls(2, ms(30))?;
        let load = self
            .control
            .as_deref_mut()
            .ok_or(Stop::Unit("no control port".into()))?
            .state_field("load")
            .map_err(Stop::Link)?;
        let plc0: u32 = load
            .split(',')
            .find_map(|f| f.strip_prefix("plc0_units:"))
            .and_then(|v| v.parse().ok())
            .ok_or_else(|| Stop::Unit(format!("control `state` load `{load}` has no plc0_units")))?;
        let mut seen = false;
        let mut p = plc0;
        while !seen && p < plc0 + 2000 {
            p += 25;
            self.control(&format!("plc0 {p}"))?;
            std::thread::sleep(ms(60));
            let status = self.control.as_deref_mut().expect("checked").state_field("status").map_err(Stop::Link)?;
            seen = u32::from_str_radix(status.get(..6).unwrap_or(""), 16).is_ok_and(|x| x & (1 << 22) != 0);
            self.poll_as(&BIT22)?;
        }
        self.control(&format!("plc0 {plc0}"))?;
        for _ in 0..3 {
            std::thread::sleep(ms(50));
            // Two `???` in one line: nothing but the read itself comes between them.
            self.send(&BIT22, &format!("{POLL} ???"))?;
        }
        // Bit 22 stays set for the rest of the campaign (until a reset), as on a correct card:
        // clearing it on the control port would be a change the log cannot show.
        if !seen {
            return Err(Stop::Unit(format!("no RTI overrun on the control port up to plc0 {p}")));
        }
        Ok(())
    }

    /// `$$$` as the campaign's first command (with --allow-reset): the X:$0 read after it is
    /// timed from the reset, which spares the replay search the unbounded time since power-up
    /// that a log's first read leaves it (docs/replay.md), and makes X:$25 comparable.
    pub fn reset_first(&mut self) -> Result<(), String> {
        self.unit = START;
        self.log.comment("the campaign starts with a reset: X:$0 is timed from it")?;
        let r = self.send(&RESET, "$$$").and_then(|_| self.recovered(Duration::from_millis(3000)));
        match r {
            Ok(()) => Ok(()),
            Err(Stop::Link(e) | Stop::Unit(e)) => Err(e),
        }
    }

    /// Polls until the card answers again (after a reset), at most `limit`; the first poll
    /// [`POLL_SPACING`] after the reset. (Sent at once, it read `pmacwd serve` one servo cycle
    /// after its `$$$` with X:$25 two below Y:$25, which no reading explains: the emulator's
    /// counters restart a few cycles apart, noted in docs/probe.md; a real card takes far
    /// longer to start again.)
    fn recovered(&mut self, limit: Duration) -> Result<(), Stop> {
        std::thread::sleep(POLL_SPACING);
        let until = Instant::now() + limit;
        while self.poll_as(&RESET)? == Reply::Silent {
            if Instant::now() > until {
                return Err(Stop::Unit("the card did not answer after the reset".into()));
            }
        }
        Ok(())
    }

    /// Starves the background until the card goes silent, then brings it back.
    fn trip(&mut self) -> Result<(), Stop> {
        let ms = Duration::from_millis;
        self.polls(2, ms(30))?;
        let load = match self.control.as_deref_mut() {
            Some(c) => Some(c.state_field("load").map_err(Stop::Link)?),
            None => None,
        };
        if load.is_some() {
            self.control("starve")?;
        } else {
            self.send(&TRIP, "OPEN PLC 0 CLEAR")?;
            // MODEL: a PLC 0 of many statements per scan takes more than an RTI period on any
            // card; the probe cannot know a card's CPU speed, so it sends a long one.
            for _ in 0..40 {
                self.send(&TRIP, &"P8191=P8191+1 ".repeat(25))?;
            }
            self.send(&TRIP, "CLOSE")?;
            self.send(&TRIP, "ENABLE PLC 0")?;
        }
        // Long enough for the counter to run out from its reload (I40 = 0: 4096, SRM p.57) and
        // the hardware delay (at most 60 cycles at 2.25 kHz by watchdog.yaml's band), twice
        // over, and a second.
        let reload = if self.i40 == 0 { 4096.0 } else { f64::from(self.i40) };
        let window = Duration::from_secs_f64((reload + 60.0) / self.servo_hz * 2.0 + 1.0);
        let until = Instant::now() + window;
        // No read until a correct card has tripped (the counter's run and the delay, and a
        // quarter more): the replay search plans a starved stretch only before a silence, so
        // reads of a card still running while starved were "no correct card" on `pmacwd
        // serve` itself (docs/probe.md). A card that answers after this has not tripped.
        std::thread::sleep(Duration::from_secs_f64((reload + 60.0) / self.servo_hz * 1.25));
        let mut silent = 0;
        while silent < 3 && Instant::now() < until {
            std::thread::sleep(ms(100));
            if self.poll_as(&TRIP)? == Reply::Silent {
                silent += 1;
            } else {
                silent = 0;
            }
        }
        match &load {
            Some(load) => {
                self.control(&format!("load {}", load.replace(":", "=").replace(",", " ")))?;
                self.control("init")?;
            }
            None => {
                if silent >= 3 {
                    eprintln!(
                        "pmacwd probe: the card is silent (tripped): assert INIT/ or cycle its power; waiting up to {} s",
                        self.recover.as_secs()
                    );
                }
            }
        }
        let until = Instant::now() + if load.is_some() { ms(3000) } else { self.recover };
        loop {
            std::thread::sleep(ms(200));
            if self.poll_as(&TRIP)? != Reply::Silent {
                break;
            }
            if Instant::now() > until {
                return Err(Stop::Link("the card did not come back after the trip".into()));
            }
        }
        if load.is_none() {
            self.send(&TRIP, "DISABLE PLC 0")?;
        }
        self.polls(2, ms(50))?;
        if silent < 3 {
            return Err(Stop::Unit(format!(
                "the card never went silent in {:.1} s of starvation",
                window.as_secs_f64()
            )));
        }
        Ok(())
    }
}
