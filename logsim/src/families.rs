//! The families of generated logs (issue 29, issue 36) and the impossible variants.

use std::collections::BTreeMap;

use crate::card::{Answer, Area, Card, CardSpec, Cmd, Power, Readings, Why, CYCLE_UNITS, PLC0_ENDLESS};
use crate::host::{render, Exchange, Session, Stamps};
use crate::rng::Rng;
use crate::sidecar::{Facts, Sidecar};

/// Every family, in the order `--count` cycles through them. `healthy-week` is generated only
/// when asked for by name (a week at 2 Hz: 1.2 million polls).
pub const FAMILIES: &[&str] = &[
    "healthy",
    "plc0-burst",
    "starvation-trip",
    "supply-dip",
    "init-recovery",
    "dollar-reset",
    "i41-session",
    "checksum-error",
    "ivar-reads",
    "i40-write",
    "status-10hz",
    "status-slow",
    "silence-unstamped",
    "config-unread",
    "sluggish",
];

pub const LONG_FAMILIES: &[&str] = &["healthy-week"];

pub fn is_family(name: &str) -> bool {
    FAMILIES.contains(&name) || LONG_FAMILIES.contains(&name)
}

/// One generated log: its text and its sidecar.
pub struct Generated {
    pub name: String,
    pub log: String,
    pub sidecar: Sidecar,
}

/// Servo interrupt times (I10, SRM p.43) of common servo rates: 2.26 kHz (the default,
/// 3,713,707), 4.5, 9, 1.13, 1 and 5 kHz.
/// I10's range is 0 to 8,388,607 (PMAC SRM p.28), so 1 kHz is 8,388,607.
const I10_CHOICES: &[u32] = &[3_713_707, 3_713_707, 3_713_707, 1_856_853, 928_427, 7_427_414, 8_388_607, 1_677_722];

struct Setup {
    card: Card,
    stamps: Stamps,
    many_per_line: bool,
    wall_start_s: f64,
    started_with_reset: bool,
    /// The longest a starved card can stay untripped, in host seconds, under any card of the
    /// bands (UM p.215): the largest reload plus the longest hardware delay, plus 10 %.
    survival_s: f64,
}

fn random_readings(rng: &mut Rng) -> Readings {
    Readings {
        reset_4096: rng.chance(0.5),
        stop_below_zero: rng.chance(0.5),
        strober_rti: rng.chance(0.5),
        bit12_m83: rng.chance(0.3),
        hz_50: rng.chance(0.25),
        bit9_sticky: rng.chance(0.3),
    }
}

fn setup(rng: &mut Rng, family: &str) -> Setup {
    let readings = random_readings(rng);
    let i10 = rng.pick(I10_CHOICES);
    let ppm = rng.float(-40.0, 40.0);
    let servo_hz = 8_388_608_000.0 / f64::from(i10) * (1.0 + ppm * 1e-6);
    // The card's own minimum, inside the manual's "approximately" (UM p.215), away from the
    // edges of the band a reader might admit.
    let strobe_hz_min = if readings.hz_50 { rng.float(42.0, 58.0) } else { rng.float(21.0, 29.0) };
    let delay = (servo_hz / (2.0 * strobe_hz_min)).floor() as u32;
    // I8 (UM p.236: RTI every I8+1 servo cycles); with the RTI strobing (SRM p.57) its period
    // must be well inside the hardware delay or no card could run.
    let i8_choices: Vec<i64> =
        [0i64, 1, 2, 2, 3, 5, 7].into_iter().filter(|i8| (*i8 as u32 + 1) * 3 <= delay).collect();
    let i8 = rng.pick(&i8_choices);
    let i40 = match family {
        "healthy-week" => 0,
        "config-unread" => rng.pick(&[1000i64, 2000, 8000]),
        _ => rng.pick(&[0i64, 0, 0, 0, 1000, 2000, 4000, 8000]),
    };
    let mut saved = BTreeMap::new();
    saved.insert(8, i8);
    saved.insert(40, i40);
    saved.insert(41, 0);
    // The card's own I-variables (no rule of the watchdog fixes them).
    saved.insert(10, i64::from(i10));
    saved.insert(5, rng.range(0, 3) as i64);
    saved.insert(15, rng.range(0, 1) as i64);
    saved.insert(130, rng.range(100, 60_000) as i64);
    saved.insert(5113, rng.range(0, 1000) as i64);
    saved.insert(7000, rng.pick(&[6527i64, 1473, 3000]));
    saved.insert(8000, rng.pick(&[0x6800A0i64, 0x078000, 0]));
    let spec = CardSpec {
        i10,
        servo_hz,
        cpu: rng.range(0, 3) as u8,
        strobe_hz_min,
        supply_min_mv: rng.range(4680, 4820) as u32,
        firmware_pass_cycles: rng.pick(&[1u32, 1, 2, 7, 40, 300, 2000]),
        user_pass_cycles: rng.pick(&[1u32, 1, 3, 10, 60, 500]),
        servo_units: rng.range(1, 25) as u32,
        background_units: rng.pick(&[15u32, 30, 60, 120, 250, 600, 1200]),
        saved,
    };
    let reload_max = if i40 == 0 { 4096.0 } else { i40 as f64 };
    let delay_max = servo_hz / (2.0 * if readings.hz_50 { 40.0 } else { 20.0 });
    let survival_s = (reload_max + delay_max) / servo_hz * 1.1;
    let stamps = match family {
        "status-10hz" => rng.pick(&[Stamps::TimeMs, Stamps::DashMicros, Stamps::IsoMs]),
        "silence-unstamped" => Stamps::None,
        "healthy-week" => rng.pick(&[Stamps::None, Stamps::DashMicros]),
        _ => rng.pick(&[
            Stamps::None,
            Stamps::TimeMs,
            Stamps::TimeMs,
            Stamps::DashMicros,
            Stamps::SlashBracketMs,
            Stamps::IsoMs,
        ]),
    };
    let many_per_line = rng.chance(0.4);
    // Start of the log on the wall clock: some time on 2026-11-01, early enough that a
    // time-only stamp never passes midnight in the logs generated with one.
    let wall_start_s = rng.float(0.0, 10.0 * 3600.0);
    let mut card = Card::new(spec, readings, 0.0);
    // The card has been up a while before the log starts: run it a little, then give X:$0
    // an uptime of its own.
    card.run_until(rng.float(0.5, 2.0));
    card.x0 = rng.range(0, 0xFF_FFFF) as u32;
    let started_with_reset = rng.chance(0.5);
    Setup { card, stamps, many_per_line, wall_start_s, started_with_reset, survival_s }
}

/// What the host polls: everything docs/capturing.md asks for, or X:$25 without Y:$25, or
/// the status alone (always with X:$0, which times the log).
fn poll_style(rng: &mut Rng) -> (&'static str, Vec<Cmd>) {
    match rng.range(0, 19) {
        0..=7 => ("full", vec![Cmd::ReadX0, Cmd::Status, Cmd::ReadY25, Cmd::ReadX25]),
        8..=14 => ("no-y25", vec![Cmd::ReadX0, Cmd::Status, Cmd::ReadX25]),
        _ => ("status", vec![Cmd::ReadX0, Cmd::Status]),
    }
}

/// The start every host does (docs/capturing.md "What to log"): a reset, then the
/// configuration read once.
fn opening(s: &mut Session, started_with_reset: bool, read_config: bool) {
    opening_as(s, started_with_reset, read_config, true)
}

fn opening_as(s: &mut Session, started_with_reset: bool, read_config: bool, read_when_not_default: bool) {
    // A card off the default servo rate is read for I10 (docs/capturing.md asks for it: the
    // host clock is turned into servo cycles with it).
    // So is one whose saved I8 or I40 differ from the defaults (I8 = 2, I40 = 0): the importer
    // takes them from the log, as docs/capturing.md "What to log" asks. The family
    // `config-unread` leaves them unread on purpose.
    let defaults = s.card.spec.i10 == 3_713_707 && s.card.spec.saved[&8] == 2 && s.card.spec.saved[&40] == 0;
    let read_config = read_config || (read_when_not_default && !defaults);
    if started_with_reset {
        s.send(vec![Cmd::Reset]);
        let t = s.t + 1.0;
        s.wait_until(t);
    }
    if read_config {
        s.poll(vec![Cmd::ReadI(8), Cmd::ReadI(40), Cmd::ReadI(41), Cmd::ReadI(10)]);
    }
}

fn poll_for(s: &mut Session, poll_s: f64, duration_s: f64, cmds: &[Cmd]) {
    let end = s.t + duration_s;
    while s.t < end {
        let next = s.t + poll_s;
        s.poll(cmds.to_vec());
        s.wait_until(next);
    }
}

/// RTI capacity in CPU units: what the RTI period leaves after the servo tasks (UM p.236).
fn rti_capacity(card: &Card) -> u64 {
    (u64::from(card.i8()) + 1) * (CYCLE_UNITS - u64::from(card.spec.servo_units))
}

/// A stall of the background `fraction` of the counter's run from a reload (UM p.215: the
/// counter is decremented every servo cycle and reset each background cycle), which a card
/// survives whatever its hardware delay.
fn sluggish_stall_s(card: &Card, fraction: f64) -> f64 {
    card.reload() as f64 * card.servo_period_s() * fraction
}

/// Run one family's scenario on a session.
fn scenario(family: &str, s: &mut Session, r: &mut Rng, started_with_reset: bool, survival_s: f64) -> Facts {
    let mut facts = Facts { cause: None, trip_time_s: None, notes: Vec::new(), i40_written: false, poll: "" };
    let (style, poll) = poll_style(r);
    facts.poll = style;
    match family {
        "healthy" => {
            let poll_s = r.pick(&[0.1, 0.25, 0.5, 1.0, 1.5]);
            let duration = r.pick(&[5.0, 30.0, 120.0, 600.0, 1800.0, 3600.0, 3.0 * 3600.0]);
            let duration = f64::min(duration, poll_s * 6000.0);
            let read_config = r.chance(0.5);
            opening(s, started_with_reset, read_config);
            facts.notes.push(format!("poll every {poll_s} s for {duration} s"));
            poll_for(s, poll_s, duration, &poll);
        }
        "config-unread" => {
            // A card whose saved I8, I40 or servo rate are not the defaults, polled by a host
            // that never reads them (stamps or not).
            opening_as(s, started_with_reset, false, false);
            facts.notes.push("I8, I40 and I10 never read".into());
            poll_for(s, 0.5, r.float(5.0, 30.0), &poll);
        }
        "healthy-week" => {
            opening(s, true, true);
            facts.notes.push("poll every 0.5 s for 7 days".into());
            poll_for(s, 0.5, 7.0 * 86_400.0, &poll);
        }
        "plc0-burst" => {
            opening(s, started_with_reset, r.chance(0.5));
            poll_for(s, 0.5, r.float(2.0, 10.0), &poll);
            // PLC 0 between a third and 1.8 RTI periods: longer than a period and the RTI
            // re-enters (bits 22 and 9, SRM p.289-290) while the background slows (UM p.236).
            let factor = r.pick(&[0.4, 0.8, 1.2, 1.4, 1.7]);
            let units = (rti_capacity(&s.card) as f64 * factor) as u64;
            s.send(vec![Cmd::EnablePlc0]);
            s.card.set_plc0_units(units);
            facts.notes.push(format!("PLC 0 enabled at {factor} RTI periods"));
            poll_for(s, 0.5, r.float(1.0, 6.0), &poll);
            s.send(vec![Cmd::DisablePlc0]);
            s.card.set_plc0_units(0);
            poll_for(s, 0.5, r.float(2.0, 10.0), &poll);
        }
        "starvation-trip" | "init-recovery" | "silence-unstamped" => {
            opening(s, started_with_reset, r.chance(0.5));
            poll_for(s, r.pick(&[0.25, 0.5, 1.0]), r.float(2.0, 10.0), &poll);
            let dip = family == "silence-unstamped" && r.chance(0.5);
            if dip {
                let t = s.t + r.float(0.0, 0.3);
                s.wait_until(t);
                s.card.set_supply(r.range(4300, 4600) as u32);
                s.card.set_supply(5000);
                facts.notes.push("the supply dipped below the card's minimum".into());
            } else {
                // A PLC 0 that never ends its scan starves the background (UM p.236).
                s.send(vec![Cmd::EnablePlc0]);
                s.card.set_plc0_units(PLC0_ENDLESS);
                facts.notes.push("PLC 0 enabled, a scan that never ends".into());
            }
            poll_for(s, 0.5, survival_s * 2.0 + r.float(0.0, 4.0), &poll);
            if family == "init-recovery" {
                let kind = if r.chance(0.5) { "INIT/" } else { "power" };
                let dpram = r.chance(0.1);
                let flash = r.chance(0.1);
                facts.notes.push(format!("{kind} at {:.3} s (DPRAM error {dpram}, flash error {flash})", s.t));
                s.unseen_reset(r.float(0.2, 1.5), dpram, flash);
                poll_for(s, 0.5, r.float(3.0, 10.0), &poll);
            }
        }
        "sluggish" => {
            // A PLC 0 scan that takes the CPU for a while and then ends by itself, shorter
            // than the counter's run from a reload: the background is starved, so host
            // commands wait (UM p.236: "communications become sluggish") and the host, whose
            // timeout is shorter than the stall, gives up on some; the card never trips.
            opening(s, started_with_reset, r.chance(0.5));
            let poll_s = r.pick(&[0.1, 0.2, 0.25]);
            poll_for(s, poll_s, r.float(2.0, 6.0), &poll);
            let stall_s = sluggish_stall_s(&s.card, r.float(0.3, 0.6));
            s.send(vec![Cmd::EnablePlc0]);
            // One scan as long as the stall (the CPU the servo tasks leave, UM p.236); the
            // scans after it are short (the scan a PLC runs depends on its conditions).
            let period = s.card.servo_period_s();
            let units = (stall_s / period).ceil() as u64 * (CYCLE_UNITS - u64::from(s.card.spec.servo_units));
            s.card.set_plc0_units(units);
            let started = s.t + period * f64::from(s.card.i8() + 2);
            s.wait_until(started);
            s.card.set_plc0_units(0);
            facts.notes.push(format!("one PLC 0 scan took the CPU for {stall_s:.3} s, less than the counter's run"));
            let end = started + stall_s;
            while s.t < end {
                let next = s.t + poll_s;
                s.poll(poll.clone());
                s.wait_until(next.min(end));
            }
            s.wait_until(end);
            s.send(vec![Cmd::DisablePlc0]);
            poll_for(s, poll_s, r.float(2.0, 6.0), &poll);
        }
        "supply-dip" => {
            opening(s, started_with_reset, r.chance(0.5));
            poll_for(s, r.pick(&[0.25, 0.5, 1.0]), r.float(2.0, 10.0), &poll);
            let t = s.t + r.float(0.0, 0.4);
            s.wait_until(t);
            // Below the minimum the relay trips at once (UM p.215); the supply comes back but
            // the trip is latched.
            s.card.set_supply(r.range(4000, 4600) as u32);
            s.card.set_supply(5000);
            facts.notes.push("the supply dipped below the card's minimum".into());
            poll_for(s, 0.5, r.float(1.0, 5.0), &poll);
            if r.chance(0.6) {
                facts.notes.push(format!("power cycled at {:.3} s", s.t));
                s.unseen_reset(r.float(0.5, 2.0), false, false);
                poll_for(s, 0.5, r.float(3.0, 10.0), &poll);
            }
        }
        "dollar-reset" => {
            opening(s, started_with_reset, r.chance(0.5));
            poll_for(s, 0.5, r.float(2.0, 6.0), &poll);
            let saved = s.card.spec.saved[&130];
            let new = saved + r.range(1, 500) as i64;
            s.send(vec![Cmd::WriteI(130, new)]);
            s.send(vec![Cmd::ReadI(130)]);
            if r.chance(0.5) {
                let units = (rti_capacity(&s.card) as f64 * 1.4) as u64;
                s.send(vec![Cmd::EnablePlc0]);
                s.card.set_plc0_units(units);
                poll_for(s, 0.5, 2.0, &poll);
                s.send(vec![Cmd::DisablePlc0]);
                s.card.set_plc0_units(0);
            }
            poll_for(s, 0.5, r.float(1.0, 4.0), &poll);
            // `$$$`: the card resets; unsaved I-variables are lost (UM p.7: flash copied to
            // active memory at reset).
            s.send(vec![Cmd::Reset]);
            let t = s.t + 1.0;
            s.wait_until(t);
            s.send(vec![Cmd::ReadI(130)]);
            poll_for(s, 0.5, r.float(2.0, 6.0), &poll);
        }
        "i41-session" => {
            opening(s, started_with_reset, true);
            poll_for(s, 0.5, r.float(1.0, 4.0), &poll);
            for _ in 0..r.range(1, 3) {
                let (n, bit) = r.pick(&[(130u32, 1i64), (5113, 2), (7000, 4), (8000, 8)]);
                let mask = bit | if r.chance(0.5) { 0 } else { r.range(0, 15) as i64 };
                s.send(vec![Cmd::ReadI(n)]);
                s.send(vec![Cmd::WriteI(41, mask)]);
                s.send(vec![Cmd::ReadI(41)]);
                let value = r.range(1, 9000) as i64;
                s.send(vec![Cmd::WriteI(n, value)]);
                s.send(vec![Cmd::ReadI(n)]);
                poll_for(s, 0.5, 1.0, &poll);
                s.send(vec![Cmd::WriteI(41, 0)]);
                let value = r.range(1, 9000) as i64;
                s.send(vec![Cmd::WriteI(n, value)]);
                s.send(vec![Cmd::ReadI(n)]);
                poll_for(s, 0.5, 1.0, &poll);
            }
        }
        "checksum-error" => {
            opening(s, started_with_reset, r.chance(0.5));
            poll_for(s, 0.5, r.float(2.0, 8.0), &poll);
            let area = if r.chance(0.5) { Area::Firmware } else { Area::UserProgram };
            s.card.corrupt(area);
            facts.notes.push(format!("{area:?} memory corrupted at {:.3} s", s.t));
            poll_for(s, 0.5, r.float(5.0, 20.0), &poll);
        }
        "ivar-reads" => {
            opening(s, started_with_reset, false);
            // Reads of I-variables no watchdog rule fixes: the card's own values.
            let reads = vec![Cmd::ReadI(10), Cmd::ReadI(5), Cmd::ReadI(15), Cmd::ReadI(130)];
            s.poll(reads.clone());
            poll_for(s, 0.5, r.float(2.0, 8.0), &poll);
            let new = r.range(1, 50_000) as i64;
            s.send(vec![Cmd::WriteI(130, new)]);
            s.poll(reads);
            poll_for(s, 0.5, r.float(2.0, 8.0), &poll);
        }
        "i40-write" => {
            opening(s, started_with_reset, true);
            poll_for(s, 0.5, r.float(2.0, 5.0), &poll);
            let new = r.pick(&[0i64, 500, 1500, 3000, 6000, 12000]);
            // I40 sets the value the counter is reset to each background cycle (SRM p.57).
            s.send(vec![Cmd::WriteI(40, new)]);
            s.send(vec![Cmd::ReadI(40)]);
            facts.i40_written = true;
            facts.notes.push(format!("I40 written {new}"));
            poll_for(s, 0.5, r.float(3.0, 10.0), &poll);
        }
        "status-10hz" => {
            // Issue 36: `???` at 10 Hz, X:$0 read once a second.
            facts.poll = "status";
            opening(s, started_with_reset, false);
            let duration = r.pick(&[10.0, 30.0, 120.0]);
            let end = s.t + duration;
            let mut k = 0u64;
            while s.t < end {
                let next = s.t + 0.1;
                if k % 10 == 0 {
                    s.poll(vec![Cmd::ReadX0, Cmd::Status]);
                } else {
                    s.send(vec![Cmd::Status]);
                }
                k += 1;
                s.wait_until(next);
            }
        }
        "status-slow" => {
            // Issue 36: status-only polling slower than the reload period.
            facts.poll = "status";
            opening(s, started_with_reset, false);
            let poll_s = r.pick(&[2.0, 3.0, 5.0, 10.0]);
            let duration = r.pick(&[60.0, 600.0, 1800.0]);
            facts.notes.push(format!("`???` and X:$0 every {poll_s} s for {duration} s"));
            poll_for(s, poll_s, duration, &[Cmd::ReadX0, Cmd::Status]);
        }
        other => panic!("unknown family {other}"),
    }
    if let Power::Tripped { why, at_cycle } = s.card.power {
        facts.cause = Some(match why {
            Why::Starvation => "starvation",
            Why::SupplyDip => "supply_dip",
        });
        let _ = at_cycle;
    }
    facts
}

/// The seed of the i-th log of a run.
pub fn log_seed(seed: u64, index: u64) -> u64 {
    let mut r = Rng::new(seed.wrapping_mul(0x1000_0000_01B3) ^ index.wrapping_mul(0x9E37_79B9));
    r.next_u64()
}

/// Generate one correct log of `family` and, if one applies, its impossible variant.
pub fn generate(family: &str, seed: u64) -> (Generated, Option<Generated>) {
    assert!(is_family(family), "unknown family {family}");
    let mut rng = Rng::new(seed);
    let setup = setup(&mut rng, family);
    let stamps = setup.stamps;
    let wall = setup.wall_start_s;
    let readings = setup.card.readings;
    let spec = setup.card.spec.clone();
    let timeout_s = if matches!(family, "starvation-trip" | "init-recovery" | "silence-unstamped" | "supply-dip") {
        // Long enough that one unanswered line proves a trip (UM p.215).
        f64::max(1.0, setup.survival_s + 0.5)
    } else if family == "sluggish" {
        // Shorter than the stall, so that the host gives up on some commands while it lasts.
        sluggish_stall_s(&setup.card, 0.3) * rng.float(0.2, 0.6)
    } else {
        rng.pick(&[0.5, 1.0, 2.0])
    };
    let mut session = Session::new(setup.card, Rng::new(rng.next_u64()), timeout_s, setup.many_per_line);
    let mut facts = scenario(family, &mut session, &mut rng, setup.started_with_reset, setup.survival_s);
    let name = format!("{family}-{seed:016x}");
    let header = vec![
        format!("pmacwd-logsim {family}, seed {seed} (independent generator, docs/independent-logs.md)"),
        "a correct card written from the manual pages alone; NAME.yaml says what it did".to_string(),
    ];
    let rendered = render(&header, &session.exchanges, stamps, wall, session.reply_separator);
    let first_silent_line =
        session.exchanges.iter().zip(&rendered.lines).find(|(ex, _)| ex.answers.is_none()).map(|(_, l)| l.1);
    if let Some(cause) = facts.cause {
        let _ = cause;
        facts.trip_time_s = Some(session.t);
    }
    let base = Sidecar::new(
        &name,
        family,
        seed,
        &readings,
        &spec,
        stamps.name(),
        session.many_per_line,
        timeout_s,
        session.exchanges.len(),
        &facts,
        first_silent_line,
    );
    let correct = Generated { name: name.clone(), log: rendered.text, sidecar: base.clone() };
    let impossible = mutate(&mut rng, family, &session.exchanges, &facts, setup.survival_s, spec.servo_hz, stamps).map(
        |(kind, exchanges, index, why)| {
            let header = vec![
                format!("pmacwd-logsim {family}, seed {seed}, IMPOSSIBLE: {kind} (docs/independent-logs.md)"),
                "a correct card's log with one observation no correct card can show; NAME.yaml says which".to_string(),
            ];
            let r = render(&header, &exchanges, stamps, wall, session.reply_separator);
            let line = r.lines[index].1;
            let mut side = base.clone();
            let iname = format!("{name}-impossible-{kind}");
            side.name = iname.clone();
            side.expect = "impossible".into();
            side.impossible_line = Some(line);
            side.impossible_kind = Some(kind.to_string());
            side.impossible_why = Some(why);
            Generated { name: iname, log: r.text, sidecar: side }
        },
    );
    (correct, impossible)
}

fn word(a: &Answer) -> Option<i64> {
    match a {
        Answer::Word(w) => Some(sign24(*w)),
        _ => None,
    }
}

fn sign24(w: u32) -> i64 {
    let w = i64::from(w & 0xFF_FFFF);
    if w >= 0x80_0000 {
        w - 0x100_0000
    } else {
        w
    }
}

fn enc24(v: i64) -> u32 {
    (v as u32) & 0xFF_FFFF
}

type Mutation = (&'static str, Vec<Exchange>, usize, String);

/// One observation no correct card can show, put into a copy of a correct log.
/// A position among the first few where a kind applies: an early impossible observation is
/// judged before whatever a long log does after it.
fn early(rng: &mut Rng, n: usize) -> usize {
    rng.range(0, n.min(3) as u64 - 1) as usize
}

fn mutate(
    rng: &mut Rng,
    family: &str,
    exchanges: &[Exchange],
    facts: &Facts,
    survival_s: f64,
    servo_hz: f64,
    stamps: Stamps,
) -> Option<Mutation> {
    // Where each kind applies: (exchange, command) positions.
    let mut x25_above_y25 = Vec::new();
    let mut x25_rising = Vec::new();
    let mut y25_above = Vec::new();
    let mut bit22_cleared = Vec::new();
    let mut bit13_cleared = Vec::new();
    let mut cpu_changed = Vec::new();
    let mut readback = Vec::new();
    let mut locked_took = Vec::new();
    let mut answer_after_trip = Vec::new();

    let mut last_y25: Option<i64> = None;
    let mut last_x25: Option<(i64, u32)> = None;
    let mut last_status: Option<(u32, u32, u32)> = None;
    let mut bit22_seen: Option<u32> = None;
    let mut bit13_seen: Option<u32> = None;
    let mut last_x0: Option<(u32, f64)> = None;
    // What the log shows of I41 and of each I-variable in the current epoch: an I-variable
    // read back is judged only where the log shows the write took (I41 read or written since
    // the last reset, SRM p.57: a lockout the log does not show is the card's own), and a
    // locked write only where the log read the value it keeps.
    let mut i41_shown: Option<(i64, u32)> = None;
    let mut read_shown: std::collections::HashMap<u32, (i64, u32)> = std::collections::HashMap::new();
    let mut backwards = false;
    let mut certain_trip: Option<u32> = None;
    for (i, ex) in exchanges.iter().enumerate() {
        let Some(answers) = &ex.answers else {
            if ex.tripped && ex.reply_s - ex.sent_s > survival_s {
                certain_trip = Some(ex.epoch);
            }
            last_y25 = None;
            continue;
        };
        if certain_trip == Some(ex.epoch) {
            // (never: a tripped card answers nothing)
        }
        for (ci, cmd) in ex.cmds.iter().enumerate() {
            // One answer per command, acknowledgements included (card::Card::exchange).
            let Some(answer) = answers.get(ci).cloned() else { continue };
            match cmd {
                Cmd::ReadX0 => {
                    let v = word(&answer).unwrap_or(0) as u32 & 0xFF_FFFF;
                    if let Some((prev, _)) = last_x0 {
                        if v < prev {
                            backwards = true;
                        }
                    }
                    last_x0 = Some((v, ex.reply_s));
                    last_y25 = None;
                }
                Cmd::ReadY25 => {
                    let v = word(&answer).unwrap_or(0);
                    last_y25 = Some(v);
                    if !facts.i40_written {
                        y25_above.push((i, ci, ex.reload));
                    }
                }
                Cmd::ReadX25 => {
                    let v = word(&answer).unwrap_or(0);
                    if let Some(y) = last_y25 {
                        x25_above_y25.push((i, ci, y));
                    }
                    if let Some((prev, epoch)) = last_x25 {
                        if epoch == ex.epoch && !backwards {
                            x25_rising.push((i, ci, prev));
                        }
                    }
                    last_x25 = Some((v, ex.epoch));
                }
                Cmd::Status => {
                    if let Answer::Status { x, y } = answer {
                        if last_status.is_some() {
                            cpu_changed.push((i, ci, x, y));
                        }
                        if bit22_seen == Some(ex.epoch) && !backwards && x & (1 << 22) != 0 {
                            bit22_cleared.push((i, ci, x, y));
                        }
                        if bit13_seen == Some(ex.epoch) && !backwards && x & (1 << 13) != 0 {
                            bit13_cleared.push((i, ci, x, y));
                        }
                        if x & (1 << 22) != 0 {
                            bit22_seen = Some(ex.epoch);
                        }
                        if x & (1 << 13) != 0 {
                            bit13_seen = Some(ex.epoch);
                        }
                        last_status = Some((x, y, ex.epoch));
                    }
                }
                Cmd::ReadI(41) => {
                    if let Answer::Value(v) = answer {
                        i41_shown = Some((v, ex.epoch));
                    }
                }
                Cmd::WriteI(41, v) => i41_shown = Some((*v, ex.epoch)),
                Cmd::WriteI(n, _) => {
                    // A write that took changes the value; a locked one leaves it.
                    if let Some((_, true)) = ex.written[ci] {
                        read_shown.remove(n);
                    }
                }
                Cmd::ReadI(n) => {
                    let shown = i41_shown.filter(|(_, epoch)| *epoch == ex.epoch).is_some();
                    if let (Some((v, took)), Answer::Value(_)) = (ex.written[ci], &answer) {
                        let before = read_shown.get(n).filter(|(_, epoch)| *epoch == ex.epoch).map(|(v, _)| *v);
                        // I8, I40 and I41: ranges the pages give, never locked (SRM p.57).
                        // Any other: a larger value than written is no card's (stored, or
                        // rolled over from above the range to a smaller one, UM p.243), where
                        // the log shows I41 leaves it writable.
                        let ruled = [8, 40, 41].contains(n);
                        if took && (ruled || (shown && v >= 1)) {
                            readback.push((i, ci, v));
                        } else if !took && shown && *n != 41 && before.is_some_and(|b| b != v) {
                            locked_took.push((i, ci, v));
                        }
                    }
                    if let Answer::Value(read) = answer {
                        read_shown.insert(*n, (read, ex.epoch));
                    }
                }
                _ => {}
            }
        }
    }
    // Silent lines after a certain trip, same epoch, that read X:$0: answer them.
    let mut certain: Option<u32> = None;
    for (i, ex) in exchanges.iter().enumerate() {
        if ex.answers.is_none() {
            if certain == Some(ex.epoch) && ex.cmds.first() == Some(&Cmd::ReadX0) {
                answer_after_trip.push(i);
            }
            if ex.tripped && ex.reply_s - ex.sent_s > survival_s {
                certain = Some(ex.epoch);
            }
        }
    }
    let _ = family;

    let mut kinds: Vec<&'static str> = Vec::new();
    if !x25_above_y25.is_empty() {
        kinds.push("x25-above-y25");
    }
    if !x25_rising.is_empty() {
        kinds.push("x25-rising");
    }
    if !y25_above.is_empty() {
        kinds.push("y25-above-reload");
    }
    if !bit22_cleared.is_empty() {
        kinds.extend(["bit22-cleared", "bit22-cleared"]);
    }
    if !bit13_cleared.is_empty() {
        kinds.extend(["bit13-cleared", "bit13-cleared"]);
    }
    if !cpu_changed.is_empty() {
        kinds.push("cpu-changed");
    }
    if !readback.is_empty() {
        kinds.extend(["ivar-read-back-different", "ivar-read-back-different"]);
    }
    if !locked_took.is_empty() {
        kinds.extend(["locked-write-took-effect", "locked-write-took-effect"]);
    }
    // An answer after a trip is impossible only where the log shows the host's wait: host
    // commands are processed in the background (UM p.236), so a card silent for a wait the
    // log does not time may have been slow, not tripped. The log stamps every line, the
    // `(timeout)` line included, when it stamps at all.
    if !answer_after_trip.is_empty() && last_x0.is_some() && stamps != Stamps::None {
        kinds.extend(["answer-after-trip", "answer-after-trip", "answer-after-trip"]);
    }
    if kinds.is_empty() {
        return None;
    }
    let kind = rng.pick(&kinds);
    let mut out = exchanges.to_vec();
    let set = |out: &mut Vec<Exchange>, i: usize, ci: usize, a: Answer| {
        // The answer slot of command ci: every command has one (acks included).
        let answers = out[i].answers.as_mut().expect("an answered line");
        answers[ci] = a;
    };
    let (index, why) = match kind {
        "x25-above-y25" => {
            let (i, ci, y) = x25_above_y25[early(rng, x25_above_y25.len())];
            let v = y + rng.range(1, 20) as i64;
            set(&mut out, i, ci, Answer::Word(enc24(v)));
            (
                i,
                format!(
                    "X:$25 reads {v} after Y:$25 read {y}: the lowest value since reset above the counter (SRM p.57)"
                ),
            )
        }
        "x25-rising" => {
            let (i, ci, prev) = x25_rising[early(rng, x25_rising.len())];
            let v = prev + rng.range(1, 30) as i64;
            set(&mut out, i, ci, Answer::Word(enc24(v)));
            (i, format!("X:$25 rises from {prev} to {v} with no reset (SRM p.57: lowest since reset)"))
        }
        "y25-above-reload" => {
            let (i, ci, reload) = y25_above[early(rng, y25_above.len())];
            let max = if reload == 4095 { 4096 } else { reload };
            let v = max + rng.range(1, 100) as i64;
            set(&mut out, i, ci, Answer::Word(enc24(v)));
            (i, format!("Y:$25 reads {v}, above any reload value ({max}; UM p.215, SRM p.57)"))
        }
        "bit22-cleared" => {
            let (i, ci, x, y) = bit22_cleared[early(rng, bit22_cleared.len())];
            set(&mut out, i, ci, Answer::Status { x: x & !(1 << 22), y });
            (i, "bit 22 clears with no reset and no write (SRM p.289: it stays 1 until reset)".to_string())
        }
        "bit13-cleared" => {
            let (i, ci, x, y) = bit13_cleared[early(rng, bit13_cleared.len())];
            set(&mut out, i, ci, Answer::Status { x: x & !(1 << 13), y });
            (i, "bit 13 clears after a checksum error with no reset (UM p.217: checksumming stops)".to_string())
        }
        "cpu-changed" => {
            let (i, ci, x, y) = cpu_changed[early(rng, cpu_changed.len())];
            let flip = rng.range(1, 3) as u32;
            let x2 = if flip & 2 != 0 { x ^ (1 << 21) } else { x };
            let y2 = if flip & 1 != 0 { y ^ (1 << 21) } else { y };
            set(&mut out, i, ci, Answer::Status { x: x2, y: y2 });
            (i, "the CPU type bits (21 of both words, SRM p.289) change".to_string())
        }
        "ivar-read-back-different" => {
            let (i, ci, v) = readback[early(rng, readback.len())];
            let w = v + rng.range(1, 99) as i64;
            set(&mut out, i, ci, Answer::Value(w));
            (i, format!("an I-variable written {v} (not locked, SRM p.57) reads back {w}"))
        }
        "locked-write-took-effect" => {
            let (i, ci, v) = locked_took[early(rng, locked_took.len())];
            set(&mut out, i, ci, Answer::Value(v));
            (i, format!("a write of {v} locked out by I41 is read back (SRM p.57: the write is ignored)"))
        }
        "answer-after-trip" => {
            let i = answer_after_trip[early(rng, answer_after_trip.len())];
            // The uninterrupted count: as if the card had kept running.
            let (x0, at) = last_x0_before(exchanges, i).expect("an X:$0 read before");
            let cycles = ((exchanges[i].sent_s - at) * servo_hz) as u64;
            let v = (u64::from(x0) + cycles) as u32 & 0xFF_FFFF;
            let mut answers = Vec::new();
            for cmd in &out[i].cmds {
                answers.push(match cmd {
                    Cmd::ReadX0 => Answer::Word(v),
                    Cmd::Status => Answer::Status { x: 0, y: 0 },
                    Cmd::ReadY25 => Answer::Word(4000),
                    Cmd::ReadX25 => Answer::Word(0),
                    _ => Answer::Ack,
                });
            }
            out[i].answers = Some(answers);
            out[i].reply_s = out[i].sent_s + 0.0005;
            (i, format!("the card answers after a silence longer than any starved card survives ({survival_s:.3} s), with no restart (UM p.215)"))
        }
        _ => unreachable!(),
    };
    Some((kind, out, index, why))
}

fn last_x0_before(exchanges: &[Exchange], i: usize) -> Option<(u32, f64)> {
    for ex in exchanges[..i].iter().rev() {
        if let Some(answers) = &ex.answers {
            if let Some(pos) = ex.cmds.iter().position(|c| *c == Cmd::ReadX0) {
                if let Some(Answer::Word(w)) = answers.get(pos) {
                    return Some((*w, ex.reply_s));
                }
            }
        }
    }
    None
}
