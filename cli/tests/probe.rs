//! `pmacwd probe` against `pmacwd serve`: a correct emulator passes under its profile, which
//! the probe names supported; an emulator broken on purpose (`serve --fault`, hidden) is caught
//! and the broken behaviour named. And against a small simulator in Python
//! (`probe_sim/sim.py`), as a simulator author would write one: its faults are named, and its
//! mended variant passes.

use std::io::{BufRead, BufReader};
use std::process::{Child, Command, Stdio};

struct Serve(Child, String);

impl Drop for Serve {
    fn drop(&mut self) {
        let _ = self.0.kill();
        let _ = self.0.wait();
    }
}

/// `pmacwd serve` on a free port, broken by `fault` if given; its address.
fn serve(fault: Option<&str>) -> Serve {
    serve_with(fault, false).0
}

/// `pmacwd serve`, with its control port if `control`: the card's address and the control's.
fn serve_with(fault: Option<&str>, control: bool) -> (Serve, String) {
    let mut cmd = Command::new(env!("CARGO_BIN_EXE_pmacwd"));
    cmd.args(["serve", "--listen", "127.0.0.1:0"]);
    if control {
        cmd.args(["--control", "127.0.0.1:0"]);
    } else {
        cmd.arg("--no-control");
    }
    if let Some(f) = fault {
        cmd.args(["--fault", f]);
    }
    started(cmd)
}

/// Starts `cmd`, whose first line of standard output names the address(es) it listens on.
fn started(mut cmd: Command) -> (Serve, String) {
    let mut child = cmd.stdout(Stdio::piped()).stderr(Stdio::null()).spawn().expect("the server");
    let mut line = String::new();
    BufReader::new(child.stdout.take().expect("stdout")).read_line(&mut line).expect("the first line");
    let mut addrs = line
        .split_whitespace()
        .filter_map(|w| w.find("127.0.0.1:").map(|at| w[at..].trim_end_matches([',', ')']).to_string()));
    let addr = addrs.next().unwrap_or_else(|| panic!("no address in `{line}`"));
    let control = addrs.next().unwrap_or_default();
    (Serve(child, addr), control)
}

/// `pmacwd probe` with `args` against `addr`: exit code and standard output.
fn probe(addr: &str, args: &[&str]) -> (i32, String) {
    let dir = std::env::temp_dir().join(format!("pmacwd-probe-test-{}-{}", std::process::id(), addr.replace(':', "-")));
    std::fs::create_dir_all(&dir).unwrap();
    let log = dir.join("probe.log");
    let out = Command::new(env!("CARGO_BIN_EXE_pmacwd"))
        .args(["probe", addr, "--seed", "5", "--allow-reset", "--judge-seconds", "300", "--log"])
        .arg(&log)
        .args(args)
        .output()
        .expect("pmacwd probe");
    let _ = std::fs::remove_dir_all(&dir);
    let text = String::from_utf8_lossy(&out.stdout).into_owned();
    (out.status.code().unwrap_or(-1), text)
}

#[test]
fn a_correct_emulator_passes_and_its_profile_is_named_supported() {
    let s = serve(None);
    let (code, out) = probe(&s.1, &[]);
    assert!(out.starts_with(&format!("pmacwd probe {} (Ethernet): seed 5", s.1)), "{out}");
    assert_eq!(code, 0, "{out}");
    assert!(out.contains("faults: none"), "{out}");
    assert!(out.contains("um-215 (default): supported"), "{out}");
    assert!(out.contains("4095: RULED OUT"), "{out}");
}

#[test]
fn format_json_prints_the_report_as_one_document_with_its_schema_version() {
    // Issue 34: the report alone on standard output (the seed and plan lines go to standard
    // error), with `command` and the version docs/json.md gives.
    let s = serve(None);
    let (code, out) = probe(&s.1, &["--units", "poll", "--format", "json"]);
    let doc: serde_json::Value =
        serde_json::from_str(&out).unwrap_or_else(|e| panic!("not one JSON document: {e}\n{out}"));
    let docs = std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/../docs/json.md")).unwrap();
    let heading = "## `pmacwd probe --format json`, version ";
    let version: u64 = docs.lines().find_map(|l| l.strip_prefix(heading)).expect(heading).trim().parse().unwrap();
    assert_eq!((doc["command"].as_str(), doc["version"].as_u64()), (Some("probe"), Some(version)), "{out}");
    assert_eq!((doc["exit"].as_i64(), doc["seed"].as_u64()), (Some(i64::from(code)), Some(5)), "{out}");
}

#[test]
fn each_broken_behaviour_is_caught_and_named() {
    for (fault, units, named) in [
        ("x25-not-latched", "poll", "watchdog-minimum x"),
        ("i41-ignored", "i41", "i41-lockout x"),
        // Not by the poll unit alone: a correct card whose checksum pass outlasts a few polls
        // shows bit 12 constant too (the pass length is the card's own, UM p.217, and replay
        // now searches one of 2 background cycles); the checksum unit's reads catch it.
        ("status-constant", "checksum", "status-words x"),
    ] {
        let s = serve(Some(fault));
        let (code, out) = probe(&s.1, &["--units", units]);
        assert_eq!(code, 1, "{fault}: {out}");
        assert!(out.contains(named), "{fault} should be named {named}: {out}");
    }
}

#[test]
fn a_card_that_never_trips_is_caught_by_the_trip_unit_which_a_correct_emulator_passes() {
    // The trip unit reads nothing while the background starves, then polls: a correct card is
    // silent (UM p.215), `--fault never-trips` answers on. The two run side by side.
    let run = |fault: Option<&'static str>| {
        std::thread::spawn(move || {
            let (s, control) = serve_with(fault, true);
            let out = probe(&s.1, &["--units", "trip", "--allow-trip", "--control", &control]);
            drop(s);
            out
        })
    };
    let (broken, correct) = (run(Some("never-trips")), run(None));
    let (code, out) = broken.join().unwrap();
    assert_eq!(code, 1, "{out}");
    assert!(out.contains("trip-silence x1"), "{out}");
    assert!(out.contains("the card never went silent"), "{out}");
    let (code, out) = correct.join().unwrap();
    assert_eq!(code, 0, "{out}");
    assert!(out.contains("faults: none"), "{out}");
}

#[test]
fn the_bit22_unit_passes_a_correct_emulator_and_catches_bit22_not_sticky() {
    // SRM p.289: bit 22 (RTI re-entry) stays set until the host clears it or the card resets.
    // The unit raises PLC 0's load on the control port until the emulator sets it. It judged the
    // correct emulator faulty (status-words x1) in one run of three before issue 31's
    // measurement; at 3977e6d it passed seeds 5, 6 and 7 (docs/probe.md). The two side by side.
    let run = |fault: Option<&'static str>| {
        std::thread::spawn(move || {
            let (s, control) = serve_with(fault, true);
            let out = probe(&s.1, &["--units", "bit22", "--allow-writes", "--control", &control]);
            drop(s);
            out
        })
    };
    let (broken, correct) = (run(Some("bit22-not-sticky")), run(None));
    let (code, out) = broken.join().unwrap();
    assert_eq!(code, 1, "{out}");
    assert!(out.contains("bit22-sticky x1"), "{out}");
    let (code, out) = correct.join().unwrap();
    assert_eq!(code, 0, "{out}");
    assert!(out.contains("faults: none"), "{out}");
}

/// `python3 probe_sim/sim.py` with `args` on a free port, or None without python3.
fn python_sim(args: &[&str]) -> Option<Serve> {
    if Command::new("python3").arg("--version").output().is_err() {
        eprintln!("python3 is not installed: the Python simulator was NOT probed");
        return None;
    }
    let mut cmd = Command::new("python3");
    cmd.arg(concat!(env!("CARGO_MANIFEST_DIR"), "/tests/probe_sim/sim.py")).args(["--port", "0"]).args(args);
    Some(started(cmd).0)
}

#[test]
fn a_python_simulator_s_faults_are_named_and_its_mended_variant_passes() {
    // As first written, sim.py has X:$25 follow Y:$25 (UM p.240), I41 lock nothing (SRM p.57)
    // and any I-variable take any value (SRM p.42, p.57). Every unit polls X:$25, so that
    // fault shows in each and hides the others (a unit is named for its first fault).
    let Some(naive) = python_sim(&[]) else { return };
    let (code, out) = probe(&naive.1, &[]);
    assert_eq!(code, 1, "{out}");
    assert!(out.contains("watchdog-minimum x"), "{out}");
    // Each of the other two alone, with the units that show it.
    for (faults, units, named) in [("i41", "i41", "i41-lockout x2"), ("ranges", "errors", "error-numbers x1")] {
        let Some(sim) = python_sim(&["--faults", faults]) else { return };
        let (code, out) = probe(&sim.1, &["--units", units]);
        assert_eq!(code, 1, "{faults}: {out}");
        assert!(out.contains(named), "{faults} should be named {named}: {out}");
    }
    // Mended, it passes, and the report says which reading it takes: it never sets bit 12,
    // which the M83 profile reads as a firmware checksum error's bit, never set on a sound card.
    let Some(mended) = python_sim(&["--faults", ""]) else { return };
    let (code, out) = probe(&mended.1, &[]);
    assert_eq!(code, 0, "{out}");
    assert!(out.contains("faults: none"), "{out}");
    assert!(out.contains("um-215-m83: supported"), "{out}");
}

/// The options of `reading` in the probe's report: (option, its verdict's first word).
fn options_reported(out: &str, reading: &str) -> Vec<(String, String)> {
    let head = format!("  {reading}: ");
    let Some(at) = out.find(&head) else { return Vec::new() };
    out[at..]
        .lines()
        .skip(1)
        .take_while(|l| l.starts_with("      "))
        .filter_map(|l| {
            l.trim().split_once(": ").map(|(o, v)| (o.to_string(), v.split(' ').next().unwrap().to_string()))
        })
        .collect()
}

#[test]
fn the_errors_unit_decides_out_of_range_assignment_modulo_for_a_simulator_that_rolls_over_and_error_for_one_that_refuses(
) {
    // UM p.243: an out-of-range assignment gives no error and rolls over (I41=16 gives 0):
    // replay searches the reading out_of_range_assignment for a log that assigns out of range
    // (the errors unit does), so such a card is a correct card under `modulo` (profile
    // um-243-modulo), not a fault; the mended simulator's ERR003 is the reverse.
    let ruled = |o: &str, v: &str| (o.to_string(), v.to_string());
    let Some(sim) = python_sim(&["--faults", "", "--ranges", "modulo"]) else { return };
    let (code, out) = probe(&sim.1, &["--units", "errors"]);
    assert_eq!(code, 0, "{out}");
    assert!(out.contains("faults: none"), "{out}");
    assert!(out.contains("  out_of_range_assignment: decided"), "{out}");
    assert_eq!(
        options_reported(&out, "out_of_range_assignment"),
        [ruled("error", "RULED"), ruled("modulo", "supported")],
        "{out}"
    );
    assert!(out.contains("um-243-modulo: supported"), "{out}");
    let Some(sim) = python_sim(&["--faults", ""]) else { return };
    let (code, out) = probe(&sim.1, &["--units", "errors"]);
    assert_eq!(code, 0, "{out}");
    assert_eq!(
        options_reported(&out, "out_of_range_assignment"),
        [ruled("error", "supported"), ruled("modulo", "RULED")],
        "{out}"
    );
    assert!(out.contains("um-243-modulo: RULED OUT"), "{out}");
}

#[test]
fn bad_arguments_and_an_unreachable_card_exit_2() {
    let run = |args: &[&str]| Command::new(env!("CARGO_BIN_EXE_pmacwd")).args(args).output().unwrap();
    assert_eq!(run(&["probe", "127.0.0.1:9", "--rounds", "0"]).status.code(), Some(2));
    assert_eq!(run(&["probe", "127.0.0.1:9", "--judge-seconds", "-1"]).status.code(), Some(2));
    let out = run(&["probe", "127.0.0.1:9", "--read-only", "--log", "/dev/null"]);
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("cannot reach"), "{out:?}");
    // A write to a card that is not on loopback needs --yes; the plan is printed first.
    let out = run(&["probe", "192.0.2.1", "--seed", "1"]);
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("--yes"), "{out:?}");
    assert!(String::from_utf8_lossy(&out.stdout).contains("plan:"), "{out:?}");
}
