//! `pmacwd probe` against `pmacwd serve`: a correct emulator passes under its profile, which
//! the probe names supported; an emulator broken on purpose (`serve --fault`, hidden) is caught
//! and the broken behaviour named.

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
    let mut cmd = Command::new(env!("CARGO_BIN_EXE_pmacwd"));
    cmd.args(["serve", "--listen", "127.0.0.1:0", "--no-control"]);
    if let Some(f) = fault {
        cmd.args(["--fault", f]);
    }
    let mut child = cmd.stdout(Stdio::piped()).stderr(Stdio::null()).spawn().expect("pmacwd serve");
    let mut line = String::new();
    BufReader::new(child.stdout.take().expect("stdout")).read_line(&mut line).expect("the first line");
    let addr = line
        .split_whitespace()
        .find(|w| w.starts_with("127.0.0.1:"))
        .unwrap_or_else(|| panic!("no address in `{line}`"))
        .to_string();
    Serve(child, addr)
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
fn each_broken_behaviour_is_caught_and_named() {
    for (fault, units, named) in [
        ("x25-not-latched", "poll", "watchdog-minimum x"),
        ("i41-ignored", "i41", "i41-lockout x"),
        ("status-constant", "poll", "status-words x"),
    ] {
        let s = serve(Some(fault));
        let (code, out) = probe(&s.1, &["--units", units]);
        assert_eq!(code, 1, "{fault}: {out}");
        assert!(out.contains(named), "{fault} should be named {named}: {out}");
    }
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
