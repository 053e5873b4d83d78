//! Tests of the generator itself: determinism, the log format, the sidecars, and the card's
//! rules on their own (each against the manual sentence it encodes).

use std::collections::BTreeMap;

use pmacwd_logsim::card::{Card, CardSpec, Cmd, Power, Readings, Why, PLC0_ENDLESS};
use pmacwd_logsim::sidecar::Sidecar;
use pmacwd_logsim::{generate, generate_set, log_seed, FAMILIES};

#[test]
fn the_same_seed_writes_the_same_logs_and_another_seed_others() {
    let a = generate_set(7, FAMILIES.len() as u64, None);
    let b = generate_set(7, FAMILIES.len() as u64, None);
    let c = generate_set(8, FAMILIES.len() as u64, None);
    assert_eq!(a.len(), b.len());
    for (x, y) in a.iter().zip(&b) {
        assert_eq!(x.name, y.name);
        assert_eq!(x.log, y.log, "{}", x.name);
        assert_eq!(x.sidecar, y.sidecar, "{}", x.name);
    }
    let differ = a.iter().zip(&c).filter(|(x, y)| x.log != y.log).count();
    assert!(differ >= a.len().min(c.len()) / 2, "seed 8 should give other logs than seed 7");
}

#[test]
fn every_family_is_generated_in_turn() {
    let logs = generate_set(3, FAMILIES.len() as u64, None);
    for f in FAMILIES {
        assert!(logs.iter().any(|g| g.sidecar.family == *f && g.sidecar.expect == "explained"), "{f}");
    }
}

/// The host-log format of docs/capturing.md: comments, then `> command` / `< reply` pairs,
/// stamped throughout or not at all, stamps never going back.
fn check_format(name: &str, log: &str) {
    let lines: Vec<&str> = log.lines().collect();
    let mut expect_command = true;
    let mut stamped = None;
    let mut last_stamp = String::new();
    for (i, line) in lines.iter().enumerate() {
        if line.starts_with('#') {
            assert!(expect_command, "{name}:{}: a comment between a command and its reply", i + 1);
            continue;
        }
        let (stamp, rest) = match line.find(['>', '<']) {
            Some(p) => (line[..p].trim(), &line[p..]),
            None => panic!("{name}:{}: neither a command nor a reply: {line}", i + 1),
        };
        let is_command = rest.starts_with('>');
        assert_eq!(is_command, expect_command, "{name}:{}: out of turn: {line}", i + 1);
        expect_command = !expect_command;
        let has = !stamp.is_empty();
        assert_eq!(*stamped.get_or_insert(has), has, "{name}:{}: stamped and unstamped lines mixed", i + 1);
        if has {
            // Every format writes its fields most significant first, so text order is time order.
            assert!(stamp >= last_stamp.as_str(), "{name}:{}: stamp {stamp} before {last_stamp}", i + 1);
            last_stamp = stamp.to_string();
        }
        if !is_command {
            let reply = rest[1..].trim();
            for value in reply.split([' ']).flat_map(|v| v.split("\\r")).filter(|v| !v.is_empty()) {
                let ok = value == "(timeout)"
                    || (value.len() == 12 && value.chars().all(|c| c.is_ascii_hexdigit()))
                    || (value.len() == 6 && value.chars().all(|c| c.is_ascii_hexdigit()))
                    || value.parse::<i64>().is_ok();
                assert!(ok, "{name}:{}: a reply value replay cannot read: {value}", i + 1);
            }
        }
    }
    assert!(expect_command, "{name}: ends with a command and no reply");
}

#[test]
fn logs_are_in_the_host_log_format() {
    for g in generate_set(11, 2 * FAMILIES.len() as u64, None) {
        check_format(&g.name, &g.log);
    }
}

#[test]
fn sidecars_read_back_and_agree_with_their_logs() {
    let logs = generate_set(5, 2 * FAMILIES.len() as u64, None);
    let by_name: BTreeMap<&str, &str> = logs.iter().map(|g| (g.name.as_str(), g.log.as_str())).collect();
    let mut impossible = 0;
    for g in &logs {
        let back = Sidecar::from_yaml(&g.sidecar.to_yaml()).expect("reads back");
        assert_eq!(back, g.sidecar);
        assert_eq!(g.sidecar.name, g.name);
        assert_eq!(g.sidecar.readings.len(), 6, "every reading the card follows is named");
        assert!(g.sidecar.card.hardware_delay_cycles > 0);
        let pairs = g.log.lines().filter(|l| l.contains("> ")).count();
        assert_eq!(pairs, g.sidecar.exchanges, "{}", g.name);
        if g.sidecar.expect == "impossible" {
            impossible += 1;
            let line = g.sidecar.impossible_line.expect("a line");
            let base = g.name.split("-impossible-").next().expect("a base name");
            let base_log = by_name[base];
            // The variant differs from its correct log in the comments and at exactly one
            // reply line: the one the sidecar names.
            let a: Vec<&str> = g.log.lines().collect();
            let b: Vec<&str> = base_log.lines().collect();
            assert_eq!(a.len(), b.len(), "{}", g.name);
            let differ: Vec<usize> =
                (0..a.len()).filter(|&i| a[i] != b[i] && !a[i].starts_with('#')).map(|i| i + 1).collect();
            assert_eq!(differ, vec![line], "{}", g.name);
            assert!(a[line - 1].contains('<'), "{}: line {line} is a reply", g.name);
            assert!(g.sidecar.impossible_why.is_some());
        } else {
            assert!(g.sidecar.impossible_line.is_none());
        }
    }
    assert!(impossible >= logs.len() / 4, "impossible variants are generated ({impossible})");
}

#[test]
fn trips_say_their_cause_and_the_log_falls_silent() {
    for i in 0..6 {
        for family in ["starvation-trip", "supply-dip"] {
            let (g, _) = generate(family, log_seed(21, i));
            let recovered = g.sidecar.notes.iter().any(|n| n.contains("power cycled") || n.contains("INIT/"));
            if !recovered {
                let want = if family == "supply-dip" { "supply_dip" } else { "starvation" };
                assert_eq!(g.sidecar.cause.as_deref(), Some(want), "{}", g.name);
            }
            assert!(g.sidecar.first_silent_line.is_some(), "{}", g.name);
            assert!(g.log.contains("(timeout)"), "{}", g.name);
        }
    }
}

fn spec(i40: i64) -> CardSpec {
    let mut saved = BTreeMap::new();
    saved.insert(8, 2);
    saved.insert(40, i40);
    saved.insert(41, 0);
    saved.insert(130, 2000);
    CardSpec {
        i10: 3_713_707,
        servo_hz: 2258.8,
        cpu: 3,
        strobe_hz_min: 25.0,
        supply_min_mv: 4750,
        firmware_pass_cycles: 3,
        user_pass_cycles: 2,
        servo_units: 10,
        background_units: 300,
        saved,
    }
}

fn readings() -> Readings {
    Readings {
        reset_4096: true,
        stop_below_zero: false,
        strober_rti: false,
        bit12_m83: false,
        hz_50: false,
        bit9_sticky: false,
    }
}

#[test]
fn a_starved_card_trips_after_the_reload_and_the_hardware_delay() {
    // UM p.215: the counter runs down from its reload; the strobe stops at 0; the timer trips
    // when no edge comes for longer than its delay (2258.8 / 50 = 45 cycles).
    let mut card = Card::new(spec(0), readings(), 0.0);
    card.run_until(0.01);
    card.set_plc0_units(PLC0_ENDLESS);
    let start = card.cycles_total;
    let counter_at_start = card.counter as u64;
    // Let the pending RTI start PLC 0: from then on no background cycle completes.
    while card.is_running() {
        card.servo_cycle();
    }
    let Power::Tripped { why, at_cycle } = card.power else { panic!("tripped") };
    assert_eq!(why, Why::Starvation);
    let took = at_cycle - start;
    // From the counter's value now (or a reload before PLC 0's first RTI, at most I8+1 = 3
    // cycles away) down to 0, then 46 cycles without an edge.
    assert!(
        (counter_at_start + 46..=4096 + 46 + 3).contains(&took),
        "tripped after {took} cycles from {counter_at_start}"
    );
}

#[test]
fn the_reload_follows_i40_and_the_reading_for_zero() {
    // SRM p.57: reset to I40; with I40 = 0, 4095 (SRM) or 4096 (UM p.215).
    let mut card = Card::new(spec(0), readings(), 0.0);
    assert_eq!(card.reload(), 4096);
    card.readings.reset_4096 = false;
    assert_eq!(card.reload(), 4095);
    let card = Card::new(spec(1500), readings(), 0.0);
    assert_eq!(card.reload(), 1500);
}

#[test]
fn a_locked_write_is_ignored_and_an_unlocked_one_reads_back() {
    // SRM p.57: with the controlling bit of I41 set, the write "is ignored (no error is
    // generated)".
    let mut card = Card::new(spec(0), readings(), 0.0);
    card.run_until(0.01);
    let t = card.now_s + 1.0;
    card.exchange(vec![Cmd::WriteI(41, 1)], t).expect("answered");
    let t = card.now_s + 1.0;
    card.exchange(vec![Cmd::WriteI(130, 7)], t).expect("answered");
    let t = card.now_s + 1.0;
    let a = card.exchange(vec![Cmd::ReadI(130)], t).expect("answered");
    assert_eq!(a[0].text().as_deref(), Some("2000"));
    let t = card.now_s + 1.0;
    card.exchange(vec![Cmd::WriteI(41, 0), Cmd::WriteI(130, 7), Cmd::ReadI(130)], t).expect("answered");
    assert_eq!(card.ivars[&130], 7);
}

#[test]
fn x25_is_never_above_y25_and_never_rises_without_a_reset() {
    // SRM p.57: X:$25 is the lowest value the counter reached since the last reset.
    let mut card = Card::new(spec(0), readings(), 0.0);
    card.set_plc0_units(250);
    let mut last_x25 = card.x25;
    for _ in 0..20_000 {
        card.servo_cycle();
        assert!(card.x25 <= card.counter);
        assert!(card.x25 <= last_x25);
        last_x25 = card.x25;
    }
    assert!(card.is_running());
}
