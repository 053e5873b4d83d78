//! The `pmacwd` command line as a user meets it: exit codes, and errors that name
//! file:line:col for a broken spec directory.

mod common;

use common::TempDir;
use std::path::{Path, PathBuf};
use std::process::Command;

fn pmacwd() -> Command {
    Command::new(env!("CARGO_BIN_EXE_pmacwd"))
}

fn specs_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../specs")
}

/// A copy of the shipped spec files in a fresh temporary directory, with `edit` applied to
/// one of them.
fn broken_specs(name: &str, file: &str, edit: impl Fn(&str) -> String) -> TempDir {
    let dir = TempDir::new(name);
    for f in pmacwd_specs::Spec::file_names() {
        let text = std::fs::read_to_string(specs_dir().join(f)).unwrap();
        let text = if f == file { edit(&text) } else { text };
        assert!(f != file || text != std::fs::read_to_string(specs_dir().join(f)).unwrap(), "the edit changed nothing");
        std::fs::write(dir.join(f), text).unwrap();
    }
    dir
}

fn line_of(text: &str, needle: &str) -> usize {
    text.lines().position(|l| l.contains(needle)).expect("needle present") + 1
}

#[test]
fn check_of_the_embedded_specs_passes_and_prints_its_figures() {
    let out = pmacwd().args(["check", "--configuration", "lockout", "--profile", "um-215"]).output().unwrap();
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert_eq!(out.status.code(), Some(0), "{stdout}");
    assert!(stdout.contains("states, depth"), "{stdout}");
    assert!(
        stdout.contains("holds    always    a locked I-variable never changes through an I-variable write"),
        "{stdout}"
    );
    assert!(stdout.contains("every property holds"), "{stdout}");
}

/// `check --witnesses --save DIR` writes each witness as a trace that `run` passes: what the
/// checker saw is what a run of the saved file sees, and the files land in DIR, which is
/// created. A DIR that cannot be a directory is unusable input, refused before checking.
#[test]
fn check_saves_witnesses_as_traces_that_run_passes() {
    let tmp = TempDir::new("saved-witnesses");
    let dir = tmp.join("witnesses");
    let out = pmacwd()
        .args([
            "check",
            "--configuration",
            "lockout",
            "--profile",
            "um-215",
            "--witnesses",
            "--no-conformance",
            "--save",
        ])
        .arg(&dir)
        .output()
        .unwrap();
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert_eq!(out.status.code(), Some(0), "{stdout}");
    assert!(stdout.contains(&format!("traces in {}", dir.display())), "{stdout}");
    let saved: Vec<_> = std::fs::read_dir(&dir).unwrap().map(|e| e.unwrap().path()).collect();
    assert!(!saved.is_empty(), "{stdout}");
    assert!(saved.iter().all(|p| p.file_name().unwrap().to_string_lossy().starts_with("lockout-um-215-")), "{saved:?}");
    let run = pmacwd().arg("run").arg(&dir).output().unwrap();
    let run_out = String::from_utf8_lossy(&run.stdout);
    assert_eq!(run.status.code(), Some(0), "{run_out}");
    assert!(run_out.contains(&format!("{} passed, 0 failed", saved.len())), "{run_out}");

    let file = tmp.join("a-file");
    std::fs::write(&file, "not a directory").unwrap();
    let out = pmacwd().args(["check", "--configuration", "lockout", "--save"]).arg(file.join("sub")).output().unwrap();
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("--save"), "{}", String::from_utf8_lossy(&out.stderr));
}

#[test]
fn check_of_the_shipped_spec_directory_from_disk_passes() {
    let out = pmacwd().args(["check", "--configuration", "lockout"]).arg("--specs").arg(specs_dir()).output().unwrap();
    assert_eq!(out.status.code(), Some(0), "{}", String::from_utf8_lossy(&out.stdout));
}

#[test]
fn a_misspelled_key_is_rejected_with_file_line_column_and_exit_2() {
    let dir = broken_specs("misspelled", "variables.yaml", |t| {
        t.replacen("    units: servo cycles\n", "    unit: servo cycles\n", 1)
    });
    let text = std::fs::read_to_string(dir.join("variables.yaml")).unwrap();
    let line = line_of(&text, "    unit: servo cycles");
    let out = pmacwd().arg("check").arg("--specs").arg(&dir).output().unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{stderr}");
    assert!(stderr.contains(&format!("variables.yaml:{line}:5: ")), "{stderr}");
    assert!(stderr.contains("unknown field `unit`"), "{stderr}");
}

#[test]
fn a_duplicated_status_bit_is_rejected_at_the_second_occurrence() {
    // Give bit 21 of the first word the key of bit 22: two `22:` entries in one word.
    let dir = broken_specs("dupbit", "status.yaml", |t| {
        let at = t.find("      21:").expect("bit 21 of the first word");
        format!("{}      22:{}", &t[..at], &t[at + "      21:".len()..])
    });
    let text = std::fs::read_to_string(dir.join("status.yaml")).unwrap();
    let second = text.lines().enumerate().filter(|(_, l)| l.starts_with("      22:")).nth(1).unwrap().0 + 1;
    let out = pmacwd().arg("check").arg("--specs").arg(&dir).output().unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{stderr}");
    assert!(stderr.contains(&format!("status.yaml:{second}:7: duplicate key `22`")), "{stderr}");
}

#[test]
fn an_i40_range_beyond_16_bits_is_rejected_at_the_range() {
    let dir =
        broken_specs("i40range", "variables.yaml", |t| t.replacen("{min: 0, max: 65535}", "{min: 0, max: 70000}", 1));
    let text = std::fs::read_to_string(dir.join("variables.yaml")).unwrap();
    let line = line_of(&text, "max: 70000");
    let out = pmacwd().arg("check").arg("--specs").arg(&dir).output().unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{stderr}");
    assert!(
        stderr.contains(&format!(
            "variables.yaml:{line}:5: I40: range 0..=70000 is outside what I40 can hold (0..=65535)"
        )),
        "{stderr}"
    );
}

#[test]
fn an_unknown_profile_or_a_missing_directory_is_unusable_input() {
    let out = pmacwd().args(["check", "--profile", "no-such-profile"]).output().unwrap();
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("no profile named `no-such-profile`"));
    let out = pmacwd().args(["check", "--specs", "/nonexistent/specs"]).output().unwrap();
    assert_eq!(out.status.code(), Some(2));
}

#[test]
fn a_host_command_the_model_cannot_represent_is_rejected_in_check_yaml() {
    // A write of I40 from the card's own I10: the model cannot follow its value.
    let dir = broken_specs("badcmd", "check.yaml", |t| t.replacen("\"RHX:$1080\"", "\"I40=I10/2\"", 1));
    let text = std::fs::read_to_string(dir.join("check.yaml")).unwrap();
    let line = line_of(&text, "I40=I10/2");
    let out = pmacwd().arg("check").arg("--specs").arg(&dir).output().unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{stderr}");
    assert!(stderr.contains(&format!("check.yaml:{line}:")), "{stderr}");
    assert!(stderr.contains("the model cannot follow its value"), "{stderr}");
}

#[test]
fn run_passes_the_scenario_library_and_a_wrong_expectation_exits_1_with_the_step() {
    let scenarios = specs_dir().join("scenarios");
    let out = pmacwd().arg("run").arg(&scenarios).output().unwrap();
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert_eq!(out.status.code(), Some(0), "{stdout}");
    assert!(stdout.lines().last().unwrap().ends_with(" passed, 0 failed"), "{stdout}");

    let dir = TempDir::new("run");
    let wrong = dir.join("wrong.yaml");
    std::fs::write(&wrong, "version: 1\ndescription: d\nconfiguration: timing\nprofiles: [um-215]\nsteps:\n  - servo: 1\n    expect: {counter: 3}\n").unwrap();
    let out = pmacwd().arg("run").arg(&wrong).output().unwrap();
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert_eq!(out.status.code(), Some(1), "{stdout}");
    assert!(stdout.contains("step 1 (line 6): Y:$25: expected 3, observed 2"), "{stdout}");

    std::fs::write(
        &wrong,
        "version: 1\ndescription: d\nconfiguration: timing\nprofiles: [um-215]\nsteps:\n  - srvo: 1\n",
    )
    .unwrap();
    let out = pmacwd().arg("run").arg(&wrong).output().unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{stderr}");
    assert!(stderr.contains("wrong.yaml:6:"), "{stderr}");
}

#[test]
fn decode_names_every_set_bit_and_the_epics_hardware_problem_flag() {
    // X bit 22 (RTI re-entry) and bit 13 (checksum error), Y bit 19 (motion buffer open).
    let out = pmacwd().args(["decode", "402000080000"]).output().unwrap();
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert_eq!(out.status.code(), Some(0), "{stdout}");
    assert!(stdout.contains("X:$000006 bit 22  rti_reentry"), "{stdout}");
    assert!(stdout.contains("X:$000006 bit 13  checksum_error"), "{stdout}");
    assert!(stdout.contains("Y:$000006 bit 19  motion_buffer_open"), "{stdout}");
    assert!(stdout.contains("FLAGGED by bit 13"), "{stdout}");

    let out = pmacwd().args(["decode", "400000000000", "--json"]).output().unwrap();
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(
        stdout.contains("\"epics_hardware_problem\":false") && stdout.contains("\"name\":\"rti_reentry\""),
        "{stdout}"
    );

    let out = pmacwd().args(["decode", "BOOTSTRAP PROM"]).output().unwrap();
    assert!(String::from_utf8_lossy(&out.stdout).contains("bootstrap mode"));
}

#[test]
fn decode_refuses_a_malformed_reply_with_exit_2() {
    for bad in ["12345", "40000000000G", "4000000000000"] {
        let out = pmacwd().args(["decode", bad]).output().unwrap();
        assert_eq!(out.status.code(), Some(2), "{bad}");
        assert!(!out.stderr.is_empty());
    }
}

/// `pmacwd conform` runs the scenario library and generated traces on the core and ends with
/// a coverage report; a fixed seed makes the run repeatable, and it says so.
#[test]
fn conform_runs_scenarios_and_generated_traces_on_the_core_and_reports_coverage() {
    let out = pmacwd()
        .args(["conform", "--cases", "40", "--max-len", "200", "--seed", "7", "--no-exhaustive", "--scenarios"])
        .arg(specs_dir().join("scenarios"))
        .output()
        .unwrap();
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert_eq!(out.status.code(), Some(0), "{stdout}\n{}", String::from_utf8_lossy(&out.stderr));
    assert!(stdout.contains("expectations met by the core"), "{stdout}");
    assert!(stdout.contains("seed 7 (repeat with --seed 7)"), "{stdout}");
    assert!(stdout.contains("40 traces,"), "{stdout}");
    assert!(stdout.contains("model events applied:"), "{stdout}");
    assert!(stdout.contains("`sometimes` properties reached:"), "{stdout}");
}

/// A scenario directory that does not exist is unusable input: exit 2, not a silent pass.
#[test]
fn conform_with_a_missing_scenario_directory_exits_2() {
    let out = pmacwd().args(["conform", "--scenarios", "/nonexistent/scenarios", "--cases", "1"]).output().unwrap();
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("/nonexistent/scenarios"));
}

#[test]
fn serve_refuses_arguments_it_cannot_honour_with_exit_2_and_the_reason() {
    // Every refusal happens before the server binds a port, so none of these listens.
    for (args, reason) in [
        (&["--saved", "I40=70000"][..], "I40 ranges 0..65535"),
        (&["--saved", "I9000=1"][..], "Turbo PMAC has I0..I8191"),
        (&["--saved", "P1=3"][..], "expected IN=V"),
        (&["--configuration", "nope"][..], "no configuration named `nope`"),
        (&["--profile", "nope"][..], "no profile named `nope`"),
        (&["--servo-hz", "0"][..], "at least 1"),
        (&["--processor", "68000"][..], "one of DSP56303, DSP56309, DSP56311, DSP56321 (SRM p.289)"),
    ] {
        let out = pmacwd().arg("serve").args(args).output().unwrap();
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{args:?}: {stderr}");
        assert!(stderr.contains(reason), "{args:?}: {stderr}");
    }
}

#[test]
fn record_needs_a_target_and_an_output_and_says_so() {
    let out = pmacwd().args(["record", "--listen", "127.0.0.1:0"]).output().unwrap();
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("--target"));
    let dir = TempDir::new("record");
    let out = pmacwd()
        .args(["record", "--listen", "127.0.0.1:0", "--target", "127.0.0.1:1", "--out"])
        .arg(dir.join("no-such-dir/capture.jsonl"))
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("capture.jsonl"));
}

#[test]
fn the_command_line_exit_codes_follow_the_verdict_and_a_malformed_line_is_unusable_input() {
    let pmacwd = env!("CARGO_BIN_EXE_pmacwd");
    let capture = |name: &str| specs_dir().join("captures").join(name);
    let out = Command::new(pmacwd).arg("replay").arg(capture("reload-to-4095.jsonl")).output().unwrap();
    assert_eq!(out.status.code(), Some(0));
    let out = Command::new(pmacwd)
        .arg("replay")
        .arg(capture("no-profile-explains.jsonl"))
        .args(["--format", "json"])
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(1));
    assert!(String::from_utf8_lossy(&out.stdout).contains("\"explained\":false"));

    let dir = std::env::temp_dir().join(format!("pmacwd-replay-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let bad = dir.join("bad.jsonl");
    let text = std::fs::read_to_string(capture("reload-to-4095.jsonl")).unwrap();
    let mut lines: Vec<&str> = text.lines().collect();
    lines[3] = "{\"servo\": -4}";
    std::fs::write(&bad, lines.join("\n")).unwrap();
    let out = Command::new(pmacwd).arg("replay").arg(&bad).output().unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr).to_string();
    let _ = std::fs::remove_dir_all(&dir);
    assert_eq!(out.status.code(), Some(2), "{stderr}");
    assert!(stderr.contains("bad.jsonl:4:"), "{stderr}");
}

#[test]
fn the_scenario_library_is_found_from_any_folder() {
    // The scenarios are compiled in: a user who runs the binary outside the checkout (or an
    // installed `pmacwd`) gets the same library, not "specs/scenarios: no such file".
    let elsewhere = TempDir::new("elsewhere");
    let out = pmacwd().arg("run").current_dir(&*elsewhere).output().unwrap();
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert_eq!(out.status.code(), Some(0), "{stdout}{}", String::from_utf8_lossy(&out.stderr));
    assert!(
        stdout.contains("ok        specs/scenarios/x25-keeps-the-lowest-counter-value-since-reset.yaml"),
        "{stdout}"
    );
    let out = pmacwd()
        .args(["conform", "--cases", "10", "--seed", "1", "--no-exhaustive"])
        .current_dir(&*elsewhere)
        .output()
        .unwrap();
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert_eq!(out.status.code(), Some(0), "{stdout}");
    let scenarios = std::fs::read_dir(specs_dir().join("scenarios")).unwrap().count();
    assert!(stdout.contains(&format!("{scenarios} scenarios,")), "{stdout}");
}

#[test]
fn serve_and_record_refuse_a_servo_clock_outside_1_to_the_maximum_naming_the_range() {
    // `serve --servo-hz 4294967295` used to start, and each request then had to run every
    // servo cycle due (4 billion a second), which the card's lock never finished. Both
    // subcommands now refuse a rate outside 1..SERVO_HZ_MAX, before listening, with exit 2
    // and the range; `--help` names the range.
    use pmacwd_emulator::card::SERVO_HZ_MAX;
    let range = format!("ranges 1..{SERVO_HZ_MAX} Hz");
    let tmp = TempDir::new("servo-hz");
    for hz in ["4294967295".to_string(), (SERVO_HZ_MAX + 1).to_string(), "0".to_string()] {
        let serve =
            pmacwd().args(["serve", "--listen", "127.0.0.1:0", "--no-control", "--servo-hz", &hz]).output().unwrap();
        let stderr = String::from_utf8_lossy(&serve.stderr);
        assert_eq!(serve.status.code(), Some(2), "serve --servo-hz {hz}: {stderr}");
        assert!(stderr.contains(&format!("--servo-hz {hz}: the servo clock {range}")), "{stderr}");
        let record = pmacwd()
            .args(["record", "--listen", "127.0.0.1:0", "--target", "127.0.0.1:1", "--servo-hz", &hz, "--out"])
            .arg(tmp.join("c.jsonl"))
            .output()
            .unwrap();
        let stderr = String::from_utf8_lossy(&record.stderr);
        assert_eq!(record.status.code(), Some(2), "record --servo-hz {hz}: {stderr}");
        assert!(stderr.contains(&range), "{stderr}");
    }
    for subcommand in ["serve", "record"] {
        let help = pmacwd().args([subcommand, "--help"]).output().unwrap();
        assert!(String::from_utf8_lossy(&help.stdout).contains(&format!("1..{SERVO_HZ_MAX}")), "{subcommand} --help");
    }
}

/// A `pmacwd serve` on a free loopback port, and the address it printed.
/// Starts a server subcommand (`serve`, `record`) with its outputs piped, and returns it with
/// the first line it prints, which names the addresses it listens on.
fn spawn_server(args: &[&std::ffi::OsStr]) -> (std::process::Child, String) {
    use std::io::BufRead;
    let mut child =
        pmacwd().args(args).stdout(std::process::Stdio::piped()).stderr(std::process::Stdio::piped()).spawn().unwrap();
    let mut first = String::new();
    std::io::BufReader::new(child.stdout.as_mut().unwrap()).read_line(&mut first).unwrap();
    (child, first)
}

fn serve_on_a_free_port(extra: &[&str]) -> (std::process::Child, std::net::SocketAddr) {
    let args: Vec<&std::ffi::OsStr> =
        ["serve", "--listen", "127.0.0.1:0", "--no-control"].iter().chain(extra).map(std::ffi::OsStr::new).collect();
    let (child, first) = spawn_server(&args);
    // "pmacwd serve: Turbo PMAC emulator on 127.0.0.1:PORT (no control interface), ..."
    let addr = first.split(" on ").nth(1).and_then(|r| r.split(' ').next()).expect("the address line");
    (child, addr.parse().unwrap())
}

/// Sends `n` headers with an unknown request code, each on its own connection, and waits
/// until the server has closed each.
fn send_bad_headers(addr: std::net::SocketAddr, n: usize) {
    use std::io::{Read, Write};
    for _ in 0..n {
        let mut c = std::net::TcpStream::connect(addr).unwrap();
        c.set_read_timeout(Some(std::time::Duration::from_secs(5))).unwrap();
        c.write_all(&[0x40, 0x12, 0, 0, 0, 0, 0, 0]).unwrap();
        let mut b = [0u8; 8];
        let r = c.read(&mut b);
        assert!(matches!(r, Ok(0)) || r.is_err_and(|e| e.kind() != std::io::ErrorKind::WouldBlock), "closed");
    }
}

#[test]
fn serve_keeps_running_when_the_reader_of_its_console_goes_away() {
    // A script reads the address line of `pmacwd serve | head -1` and closes the pipe. The
    // card's next console line (a trip) used to end the emulator by SIGPIPE: hosts were then
    // refused. The console now ignores a closed output and the card keeps answering.
    use std::io::{BufRead, Read, Write};
    let mut child = pmacwd()
        .args(["serve", "--listen", "127.0.0.1:0", "--control", "127.0.0.1:0"])
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    let mut first = String::new();
    std::io::BufReader::new(child.stdout.take().unwrap()).read_line(&mut first).unwrap();
    // The reader is dropped here: the console's pipe is closed.
    let host = first.split(" on ").nth(1).and_then(|r| r.split(' ').next()).expect("the address line");
    let control = first.split("control on ").nth(1).and_then(|r| r.split(')').next()).expect("the control address");
    let mut c = std::io::BufReader::new(std::net::TcpStream::connect(control).unwrap());
    for command in ["supply 4500", "supply 5000", "init"] {
        // A trip, then INIT/ and the recovery: each a console line into the closed pipe.
        c.get_mut().write_all(format!("{command}\n").as_bytes()).unwrap();
        let mut reply = String::new();
        c.read_line(&mut reply).unwrap();
        assert!(reply.starts_with("ok"), "{command}: {reply}");
    }
    let mut h = std::net::TcpStream::connect(host).unwrap();
    h.set_read_timeout(Some(std::time::Duration::from_secs(5))).unwrap();
    h.write_all(&[0x40, 0xBF, 0, 0, 0, 0, 0, 3]).unwrap();
    h.write_all(b"???").unwrap();
    let mut reply = [0u8; 32];
    let n = h.read(&mut reply).expect("the emulator still answers");
    assert!(reply[..n].ends_with(b"\r\x06"), "{:?}", &reply[..n]);
    assert!(child.try_wait().unwrap().is_none(), "the emulator is still running");
    child.kill().unwrap();
    let out = child.wait_with_output().unwrap();
    assert!(!String::from_utf8_lossy(&out.stderr).contains("panicked"));
}

#[test]
fn protocol_errors_are_summed_up_on_one_line_without_verbose_and_each_logged_with_it() {
    // Every protocol error used to be a line on standard error, verbose or not (53,595 lines
    // in 3 minutes from one misbehaving client). Without --verbose they are now counted and
    // summed up at most once per SUMMARY_INTERVAL (60 s): 200 errors in a moment make the
    // first summary line only. With --verbose each has its line.
    use std::io::{BufRead, Read};
    let (mut quiet, addr) = serve_on_a_free_port(&[]);
    send_bad_headers(addr, 200);
    let mut stderr = std::io::BufReader::new(quiet.stderr.take().unwrap());
    let mut first = String::new();
    stderr.read_line(&mut first).unwrap();
    quiet.kill().unwrap();
    quiet.wait().unwrap();
    assert!(first.contains("protocol errors, each closing its connection: 1 since the last summary"), "{first}");
    assert!(first.contains("unknown request code 0x12"), "{first}");
    let mut rest = String::new();
    stderr.read_to_string(&mut rest).unwrap();
    assert_eq!(rest, "", "one line for 200 errors");

    let (mut verbose, addr) = serve_on_a_free_port(&["--verbose"]);
    send_bad_headers(addr, 20);
    let stderr = std::io::BufReader::new(verbose.stderr.take().unwrap());
    let each = stderr.lines().map(Result::unwrap).filter(|l| l.contains("unknown request code 0x12")).take(20).count();
    verbose.kill().unwrap();
    verbose.wait().unwrap();
    assert_eq!(each, 20);
}

#[test]
fn serve_refuses_a_saved_framing_value_outside_0_to_3() {
    // A saved I3 or I6 outside 0..3 would frame every reply after a reset as its low bits do
    // (I3 = 4: no ACK at all); host writes of such values are refused (MODEL), and so are
    // saved ones, before the server starts.
    for saved in ["I3=4", "I6=-1"] {
        let out =
            pmacwd().args(["serve", "--listen", "127.0.0.1:0", "--no-control", "--saved", saved]).output().unwrap();
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{saved}: {stderr}");
        assert!(stderr.contains("ranges 0..3"), "{stderr}");
    }
}

#[test]
fn serve_s_help_names_the_limits_its_flags_bound_as_the_emulator_defines_them() {
    // The help text states limits as numbers; this keeps them equal to the constants that
    // enforce them (a constant changed without its help fails here).
    use pmacwd_emulator::bounded::SUMMARY_INTERVAL;
    use pmacwd_emulator::card::SERVO_HZ_MAX;
    use pmacwd_emulator::server::{CONTROL_CLIENTS_MAX, CONTROL_IDLE_TIMEOUT_DEFAULT_SECONDS};
    let help = pmacwd().args(["serve", "--help"]).output().unwrap();
    let help = String::from_utf8_lossy(&help.stdout);
    assert!(help.contains(&format!("1..{SERVO_HZ_MAX} ")), "{help}");
    assert!(help.contains(&format!("when {CONTROL_CLIENTS_MAX} are open")), "{help}");
    assert!(help.contains(&format!("[default: {CONTROL_IDLE_TIMEOUT_DEFAULT_SECONDS}]")), "{help}");
    assert_eq!(SUMMARY_INTERVAL.as_secs(), 60, "the help says `once a minute`");
    assert!(help.contains("at most once a minute"), "{help}");
}

#[test]
fn output_into_a_closed_pipe_ends_quietly_without_a_panic() {
    // `pmacwd check | head` closes the pipe early; a command-line tool stops there, it does not
    // print a panic. The check's report is far larger than a pipe's buffer.
    use std::io::Read;
    let mut child = pmacwd()
        .args(["check", "--no-conformance", "--threads", "1"])
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    let mut first = [0u8; 10];
    child.stdout.take().unwrap().read_exact(&mut first).unwrap();
    // The read end is dropped here: the next writes fail with EPIPE.
    let out = child.wait_with_output().unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(!stderr.contains("panicked"), "{stderr}");
    assert_ne!(out.status.code(), Some(101), "{stderr}");
}

#[test]
fn progress_into_a_log_is_whole_periodic_lines_without_carriage_returns() {
    // Issue 19: `check` wrote its progress with carriage returns, one 2,000-character line in a
    // CI log, and the exhaustive lockstep showed nothing for seconds. Into a pipe, progress is
    // now a plain line per interval (here 0.1 s instead of 5, through the environment variable)
    // naming the phase and what is under way, for the model check and the lockstep alike.
    let out = pmacwd()
        .args(["check", "--configuration", "i40-zero", "--threads", "1"])
        .env("PMACWD_PROGRESS_SECONDS", "0.1")
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(0), "{stderr}");
    assert!(!stderr.contains('\r'), "{stderr:?}");
    assert!(stderr.ends_with('\n'), "{stderr:?}");
    for line in stderr.lines() {
        assert!(line.starts_with("progress: "), "only progress lines: {line}");
    }
    assert!(stderr.contains("progress: model check: "), "{stderr}");
    // i40-zero runs 5 profiles (um-215-full-period since issue 36, its delay 90 cycles).
    assert!(stderr.contains(" of 5 runs done ("), "{stderr}");
    assert!(stderr.contains("progress: exhaustive lockstep: "), "{stderr}");
    // A phase shorter than the interval prints no progress at all. (The default interval is
    // 5 s; an hour here, so that a loaded machine cannot stretch the phase past it.)
    let out = pmacwd()
        .args(["check", "--configuration", "lockout", "--profile", "um-215"])
        .env("PMACWD_PROGRESS_SECONDS", "3600")
        .output()
        .unwrap();
    assert_eq!(String::from_utf8_lossy(&out.stderr), "");
    // A value that is not seconds is refused before any work, not taken as the default.
    for bad in ["0", "abc", "-1"] {
        let out = pmacwd()
            .args(["check", "--configuration", "lockout"])
            .env("PMACWD_PROGRESS_SECONDS", bad)
            .output()
            .unwrap();
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{bad}: {stderr}");
        assert!(stderr.contains(&format!("PMACWD_PROGRESS_SECONDS={bad}: give seconds")), "{stderr}");
        assert!(out.stdout.is_empty(), "{bad}: no work before the refusal");
    }
}

#[test]
fn run_and_replay_of_long_steps_report_progress_instead_of_running_silently() {
    // Issue 15: a step of millions of servo cycles is simulated cycle by cycle under every
    // profile; 20 steps of the largest one a step may take ran for a minute with nothing on
    // standard error, and replay of one such step for minutes. Both now say, every interval
    // (0.1 s here), which trace and profile or which capture line is under way.
    let dir = TempDir::new("long-steps");
    let trace = dir.join("long.jsonl");
    let header =
        r#"{"format":"pmacwd-trace","version":1,"description":"t","configuration":"i40-zero","profiles":["um-215"]}"#;
    std::fs::write(&trace, format!("{header}\n{{\"run\":16777216}}\n")).unwrap();
    let out = pmacwd().arg("run").arg(&trace).env("PMACWD_PROGRESS_SECONDS", "0.1").output().unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(0), "{stderr}");
    assert!(stderr.contains("progress: run: 0 of 1 traces done ("), "{stderr}");
    assert!(stderr.contains("long.jsonl [um-215]"), "{stderr}");
    std::fs::write(&trace, format!("{header}\n{{\"run\":2000000}}\n")).unwrap();
    let out = pmacwd().arg("replay").arg(&trace).env("PMACWD_PROGRESS_SECONDS", "0.1").output().unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(0), "{stderr}");
    assert!(stderr.contains("progress: replay: 0 of 1 captures done ("), "{stderr}");
    assert!(stderr.contains("searching at line 2"), "{stderr}");
    for line in stderr.lines() {
        assert!(line.starts_with("progress: "), "only progress lines: {line}");
    }
}

#[test]
fn checker_threads_outside_one_to_the_cores_are_refused_before_any_work() {
    // `--threads 0` used to check 1 state and report every `sometimes` property as never
    // reached (a false verdict); `--threads 100000` panicked spawning threads.
    for command in ["check", "conform"] {
        for n in ["0", "100000"] {
            let out = pmacwd().args([command, "--threads", n]).output().unwrap();
            let stderr = String::from_utf8_lossy(&out.stderr);
            assert_eq!(out.status.code(), Some(2), "{command} --threads {n}: {stderr}");
            assert!(stderr.contains(&format!("--threads {n}: give 1 to")), "{stderr}");
            assert!(out.stdout.is_empty(), "{command} --threads {n} did work before refusing");
        }
    }
}

#[test]
fn import_of_a_log_without_timing_succeeds_with_a_warning_and_counts_what_it_could_not_model() {
    let dir = TempDir::new("import-warning");
    let log = dir.join("s.log");
    std::fs::write(&log, "> i6=1 i3=2 ver\n< 1.947\n> ???\n< 000000000000\n").unwrap();
    let out = pmacwd().arg("import").arg(&log).output().unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr).to_string();
    assert_eq!(out.status.code(), Some(0), "{stderr}");
    assert!(stderr.contains("warning: the log has no X:$0 reads: no timing can be derived"), "{stderr}");
    assert!(
        stderr.contains("4 commands on 2 lines") && stderr.contains("1 answered from the card's own state"),
        "{stderr}"
    );
    assert!(stderr.contains("from configuration `host-log`: servo_hz, i8, i40, i41"), "{stderr}");
    let stdout = String::from_utf8_lossy(&out.stdout).to_string();
    assert!(stdout.contains(r#"{"command":"VER","expect":{"reply":"1.947"}}"#), "{stdout}");
}

#[test]
fn import_takes_the_card_s_values_from_the_log_and_says_which_in_its_summary() {
    let dir = TempDir::new("import-card");
    let log = dir.join("s.log");
    std::fs::write(&log, "> I10 I8\n< 3713707 3\n> RHX:$0\n< 000010\n> RHX:$0\n< 000020\n").unwrap();
    let trace = dir.join("t.jsonl");
    let out = pmacwd().arg("import").arg(&log).arg("--out").arg(&trace).output().unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr).to_string();
    assert_eq!(out.status.code(), Some(0), "{stderr}");
    assert!(stderr.contains("from the log: i8 (I8 = 3, line 2), servo_hz (I10 = 3713707, line 2)"), "{stderr}");
    assert!(stderr.contains("from configuration `host-log`: i40, i41"), "{stderr}");
    assert!(!stderr.contains("warning"), "{stderr}");
    let text = std::fs::read_to_string(&trace).unwrap();
    assert!(text.lines().next().unwrap().contains(r#""card":{"i8":3,"servo_hz":2259}"#), "{text}");
}

#[test]
fn run_takes_json_lines_traces_and_directories_of_both_forms_and_names_the_host_logs_it_leaves() {
    // Issue 19: `run x.jsonl` failed with "unknown field `format`", and `run specs/captures/`
    // skipped the .jsonl captures silently. Both forms now run (told apart as `replay` does),
    // a divergence in a JSON Lines trace names its line, and host logs in a directory are
    // named on standard error with what to do with them.
    let tmp = TempDir::new("run-jsonl");
    let header =
        r#"{"format":"pmacwd-trace","version":1,"description":"d","configuration":"i40-zero","profiles":["um-215"]}"#;
    std::fs::write(tmp.join("a.jsonl"), format!("{header}\n{{\"command\":\"I40\",\"expect\":{{\"reply\":\"0\"}}}}\n"))
        .unwrap();
    let out = pmacwd().arg("run").arg(tmp.join("a.jsonl")).output().unwrap();
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert_eq!(out.status.code(), Some(0), "{stdout}{}", String::from_utf8_lossy(&out.stderr));
    assert!(stdout.contains("a.jsonl [um-215] (1 expectation)"), "{stdout}");
    // A wrong expectation on line 3 of a JSON Lines trace: a divergence at that line.
    std::fs::write(
        tmp.join("b.jsonl"),
        format!("{header}\n\n{{\"command\":\"I40\",\"expect\":{{\"reply\":\"7\"}}}}\n"),
    )
    .unwrap();
    std::fs::write(tmp.join("c.log"), "> ???\n< 000000000000\n").unwrap();
    let out = pmacwd().arg("run").arg(&tmp).output().unwrap();
    let (stdout, stderr) = (String::from_utf8_lossy(&out.stdout), String::from_utf8_lossy(&out.stderr));
    assert_eq!(out.status.code(), Some(1), "{stdout}{stderr}");
    assert!(stdout.contains("DIVERGED  ") && stdout.contains("b.jsonl [um-215]"), "{stdout}");
    assert!(stdout.contains("step 1 (line 3): reply: expected 7, observed 0"), "{stdout}");
    assert!(stdout.contains("1 passed, 1 failed"), "{stdout}");
    assert!(stderr.contains("not run: 1 host log, not a trace:") && stderr.contains("c.log"), "{stderr}");
    assert!(stderr.contains("pmacwd replay LOG"), "{stderr}");
    // A trace with an `elapsed` step (an imported host log) is for replay: exit 2 at its line,
    // not a divergence under every profile.
    std::fs::write(tmp.join("d.jsonl"), format!("{header}\n{{\"command\":\"I40\"}}\n{{\"elapsed\":16}}\n")).unwrap();
    let out = pmacwd().arg("run").arg(tmp.join("d.jsonl")).output().unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{stderr}");
    assert!(stderr.contains("d.jsonl:3:1: step 2: `16 servo cycles pass unseen`"), "{stderr}");
    assert!(stderr.contains("judge this trace with `pmacwd replay`"), "{stderr}");
}

#[test]
fn serve_listens_on_a_host_name_and_a_taken_port_is_named_with_its_role() {
    // Issue 19: `serve --listen localhost:1025` was refused ("invalid socket address syntax"),
    // and "Address already in use" did not say which port was taken. A name is resolved now
    // (the first IPv4 address, as the default 127.0.0.1), and a port in use is named with its
    // address and whether it was the host or the control port; exit 2 either way.
    let taken = std::net::TcpListener::bind("127.0.0.1:0").unwrap();
    let port = taken.local_addr().unwrap().port();
    let out = pmacwd().args(["serve", "--listen", &format!("localhost:{port}"), "--no-control"]).output().unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{stderr}");
    assert!(stderr.contains(&format!("cannot listen: host port 127.0.0.1:{port}: ")), "{stderr}");
    let out = pmacwd()
        .args(["serve", "--listen", "127.0.0.1:0", "--control", &format!("127.0.0.1:{port}")])
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{stderr}");
    assert!(stderr.contains(&format!("cannot listen: control port 127.0.0.1:{port}: ")), "{stderr}");
    drop(taken);
    // A free port by name: the emulator listens and says where.
    let mut child = pmacwd()
        .args(["serve", "--listen", "localhost:0", "--no-control"])
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    let mut first = String::new();
    std::io::BufRead::read_line(&mut std::io::BufReader::new(child.stdout.as_mut().unwrap()), &mut first).unwrap();
    child.kill().unwrap();
    child.wait().unwrap();
    assert!(first.starts_with("pmacwd serve: Turbo PMAC emulator on 127.0.0.1:"), "{first}");
}

/// Runs `pmacwd ARGS` and parses its standard output as one JSON document.
fn json_of(args: &[&str]) -> (Option<i32>, serde_json::Value) {
    let out = pmacwd().args(args).output().unwrap();
    let stdout = String::from_utf8_lossy(&out.stdout);
    let doc =
        serde_json::from_str(&stdout).unwrap_or_else(|e| panic!("{args:?}: not one JSON document: {e}\n{stdout}"));
    (out.status.code(), doc)
}

#[test]
fn check_run_and_conform_print_one_json_document_that_agrees_with_their_text_and_exit_code() {
    // Issue 19: only decode and replay had JSON, so CI jobs scraped text. Each document's
    // `exit` is the process's exit code, and its figures are the ones the text prints.
    let (code, doc) = json_of(&[
        "check",
        "--configuration",
        "lockout",
        "--profile",
        "um-215",
        "--threads",
        "1",
        "--no-conformance",
        "--format",
        "json",
    ]);
    assert_eq!(code, Some(0));
    assert_eq!((doc["command"].as_str(), doc["exit"].as_i64()), (Some("check"), Some(0)));
    let run = &doc["runs"][0];
    assert_eq!((run["configuration"].as_str(), run["profile"].as_str()), (Some("lockout"), Some("um-215")));
    let text = pmacwd()
        .args(["check", "--configuration", "lockout", "--profile", "um-215", "--threads", "1", "--no-conformance"])
        .output()
        .unwrap();
    let text = String::from_utf8_lossy(&text.stdout);
    let states = run["states"].as_u64().unwrap();
    assert!(text.contains(&format!("total: {states} states")), "{text}");
    let held = run["properties"].as_array().unwrap().iter().filter(|p| p["verdict"] == "holds").count();
    let table = text.lines().find(|l| l.trim_start().starts_with("lockout ")).expect("the summary table's row");
    assert_eq!(table.split_whitespace().nth(3), Some(held.to_string().as_str()), "{table}");
    assert!(text.contains("exit 0: every property holds and nothing diverged"), "{text}");

    let tmp = TempDir::new("json-run");
    let header =
        r#"{"format":"pmacwd-trace","version":1,"description":"d","configuration":"i40-zero","profiles":["um-215"]}"#;
    std::fs::write(tmp.join("b.jsonl"), format!("{header}\n{{\"command\":\"I40\",\"expect\":{{\"reply\":\"7\"}}}}\n"))
        .unwrap();
    let path = tmp.join("b.jsonl");
    let (code, doc) = json_of(&["run", "--format", "json", path.to_str().unwrap()]);
    assert_eq!((code, doc["exit"].as_i64()), (Some(1), Some(1)));
    assert_eq!((doc["passed"].as_u64(), doc["failed"].as_u64()), (Some(0), Some(1)));
    let d = &doc["runs"][0]["divergence"];
    assert_eq!((d["step"].as_u64(), d["line"].as_u64(), d["expected"].as_str()), (Some(1), Some(2), Some("7")));

    let (code, doc) = json_of(&["conform", "--cases", "10", "--seed", "1", "--no-exhaustive", "--format", "json"]);
    assert_eq!((code, doc["exit"].as_i64()), (Some(0), Some(0)));
    let text = pmacwd().args(["conform", "--cases", "10", "--seed", "1", "--no-exhaustive"]).output().unwrap();
    let text = String::from_utf8_lossy(&text.stdout);
    let g = &doc["generated"];
    assert!(text.contains(&format!("{} traces, {} events, no divergence", g["traces"], g["events"])), "{text}");
    let s = &doc["scenarios"];
    assert!(
        text.contains(&format!("{} scenario-profile runs, {} expectations", s["runs"], s["expectations"])),
        "{text}"
    );
    assert!(doc["exhaustive"].is_null());
    assert!(doc["coverage"]["events"].as_object().unwrap().values().any(|n| n.as_u64() > Some(0)));
}

/// The schema version docs/json.md gives for the document of `pmacwd COMMAND --format json`:
/// its section's heading reads ``## `pmacwd COMMAND --format json`, version N``.
fn documented_version(command: &str) -> u64 {
    let docs = std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/../docs/json.md")).unwrap();
    let heading = format!("## `pmacwd {command} --format json`, version ");
    let line =
        docs.lines().find(|l| l.starts_with(&heading)).unwrap_or_else(|| panic!("no `{heading}` in docs/json.md"));
    line[heading.len()..].trim().parse().unwrap_or_else(|_| panic!("{line}: no version number"))
}

#[test]
fn every_command_that_prints_a_report_takes_format_json_and_prints_one_document_with_its_schema_version() {
    // Issue 34: one convention. Each document names its command and carries the version of its
    // schema, the one docs/json.md documents; the old `--json` of decode and margin is the
    // same flag. (probe's document: cli/tests/probe.rs, against a running emulator.)
    let cases: &[(&str, &[&str])] = &[
        (
            "check",
            &["check", "--configuration", "lockout", "--profile", "um-215", "--threads", "1", "--no-conformance"],
        ),
        ("run", &["run", "specs/captures/reload-to-4095.jsonl", "--profile", "um-215"]),
        ("conform", &["conform", "--cases", "2", "--max-len", "20", "--seed", "1", "--no-exhaustive"]),
        ("decode", &["decode", "400000080000"]),
        ("replay", &["replay", "specs/captures/reload-to-4095.jsonl"]),
        ("margin", &["margin", "--profile", "um-215"]),
        ("requirements", &["requirements"]),
    ];
    let root = concat!(env!("CARGO_MANIFEST_DIR"), "/..");
    for (command, args) in cases {
        let out = pmacwd().current_dir(root).args(*args).args(["--format", "json"]).output().unwrap();
        let stdout = String::from_utf8_lossy(&out.stdout);
        let doc: serde_json::Value =
            serde_json::from_str(&stdout).unwrap_or_else(|e| panic!("{args:?}: not one JSON document: {e}\n{stdout}"));
        assert_eq!(doc["command"].as_str(), Some(*command), "{args:?}");
        assert_eq!(doc["version"].as_u64(), Some(documented_version(command)), "{args:?}: {stdout}");
        if let Some(exit) = doc.get("exit") {
            assert_eq!(exit.as_i64(), out.status.code().map(i64::from), "{args:?}");
        }
    }
    for args in [&["decode", "400000080000"][..], &["margin", "--profile", "um-215"]] {
        let new = pmacwd().args(args).args(["--format", "json"]).output().unwrap();
        let old = pmacwd().args(args).arg("--json").output().unwrap();
        assert_eq!((old.status.code(), &old.stdout), (new.status.code(), &new.stdout), "{args:?} --json");
        let both = pmacwd().args(args).args(["--json", "--format", "text"]).output().unwrap();
        assert_eq!(both.status.code(), Some(2), "{args:?} --json --format text");
        assert!(String::from_utf8_lossy(&both.stderr).contains("cannot be used with"), "{args:?}");
    }
}

#[test]
fn import_s_format_names_the_trace_written_and_a_kind_of_log_there_points_at_log_format() {
    let log = concat!(env!("CARGO_MANIFEST_DIR"), "/../specs/captures/host-session.log");
    let yaml = pmacwd().args(["import", log, "--format", "yaml"]).output().unwrap();
    let old = pmacwd().args(["import", log, "--yaml"]).output().unwrap();
    assert_eq!((yaml.status.code(), &yaml.stdout), (old.status.code(), &old.stdout));
    assert!(String::from_utf8_lossy(&yaml.stdout).starts_with("version: 1\n"));
    let jsonl = pmacwd().args(["import", log, "--format", "jsonl", "--log-format", "host-log"]).output().unwrap();
    assert_eq!(jsonl.stdout, pmacwd().args(["import", log]).output().unwrap().stdout);
    for kind in ["asyn", "pcap", "host-log"] {
        let out = pmacwd().args(["import", log, "--format", kind]).output().unwrap();
        assert_eq!(out.status.code(), Some(2));
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(err.contains(&format!("name it with --log-format {kind}")), "{err}");
    }
    let out = pmacwd().args(["import", log, "--format", "json"]).output().unwrap();
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("give --format jsonl"));
}

#[test]
fn requirements_prints_the_matrix_by_page_and_figures_that_add_up() {
    let out = pmacwd().args(["requirements", "--format", "json"]).output().unwrap();
    assert_eq!(out.status.code(), Some(0), "{}", String::from_utf8_lossy(&out.stderr));
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).expect("JSON on stdout");
    let total = v["statements"].as_u64().unwrap();
    let coverage = v["coverage"].as_object().unwrap();
    let keys: Vec<&str> = coverage.keys().map(String::as_str).collect();
    for k in ["checked", "by_definition", "data_only", "missing", "deviation"] {
        assert!(keys.contains(&k), "{k} in {keys:?}");
    }
    assert_eq!(coverage.values().map(|c| c.as_u64().unwrap()).sum::<u64>(), total);
    let pages = v["pages"].as_array().unwrap();
    let listed: usize = pages.iter().map(|p| p["statements"].as_array().unwrap().len()).sum();
    assert_eq!(listed as u64, total);
    let names: Vec<&str> = pages.iter().map(|p| p["page"].as_str().unwrap()).collect();
    // The five seed pages first, quoted; then the pages read beyond them, summarized.
    assert_eq!(names[..5], ["UM p.215", "SRM p.57", "UM p.217", "SRM p.289", "UM p.236"]);
    for p in pages {
        for s in p["statements"].as_array().unwrap() {
            let seed = names[..5].contains(&p["page"].as_str().unwrap());
            assert_eq!(s["quote"].is_string(), seed, "{s}");
            assert_eq!(s["summary"].is_string(), !seed, "{s}");
        }
    }

    let out = pmacwd().arg("requirements").output().unwrap();
    let text = String::from_utf8_lossy(&out.stdout);
    assert_eq!(out.status.code(), Some(0), "{text}");
    assert!(
        text.starts_with(&format!("Requirements matrix (specs/requirements.yaml): {total} statements\n")),
        "{text}"
    );
    assert!(
        text.contains("\nUM p.215: 27 statements (") && text.contains("  [checked] um215_two_conditions\n"),
        "{text}"
    );
    assert!(text.contains("      property: a trip is undone only by INIT/ or a power cycle\n"), "{text}");
}

#[test]
fn requirements_with_a_broken_matrix_exits_2_naming_file_line_and_column() {
    let dir = broken_specs("req-broken", "requirements.yaml", |t| {
        t.replacen("spec: watchdog.yaml#rules.two_conditions", "spec: watchdog.yaml#rules.nothing", 1)
    });
    let edited = std::fs::read_to_string(dir.join("requirements.yaml")).unwrap();
    let out = pmacwd().args(["requirements", "--specs"]).arg(&dir).output().unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{stderr}");
    let at = format!("requirements.yaml:{}:", line_of(&edited, "rules.nothing"));
    assert!(stderr.contains(&at) && stderr.contains("is not a key of watchdog.yaml"), "{stderr}");
}

/// `pmacwd control` is the test bench's hand on a running emulator without `nc`: commands as
/// arguments, or as lines on standard input (comments skipped), each reply printed; exit 1 when
/// the emulator refused a command, 2 when there is no control port to talk to. The supply dip
/// trips the card (UM p.215), which `state` then shows.
#[test]
fn control_sends_commands_from_arguments_or_stdin_and_exits_by_the_replies() {
    use std::io::{BufRead, Write};
    let mut serve = pmacwd()
        .args(["serve", "--listen", "127.0.0.1:0", "--control", "127.0.0.1:0", "--virtual-time"])
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::null())
        .spawn()
        .unwrap();
    let mut first = String::new();
    std::io::BufReader::new(serve.stdout.as_mut().unwrap()).read_line(&mut first).unwrap();
    // "pmacwd serve: Turbo PMAC emulator on 127.0.0.1:PORT (control on 127.0.0.1:PORT), ..."
    let control = first.split("control on ").nth(1).and_then(|r| r.split(')').next()).expect("the control address");

    let out = pmacwd().args(["control", "--address", control, "state", "supply 4500", "state"]).output().unwrap();
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert_eq!(out.status.code(), Some(0), "{stdout}");
    let lines: Vec<&str> = stdout.lines().collect();
    assert_eq!(lines.len(), 3, "one reply per command: {stdout}");
    assert!(lines[0].starts_with("ok tripped=false"), "{stdout}");
    assert!(lines[2].starts_with("ok tripped=true"), "{stdout}");

    let mut piped = pmacwd()
        .args(["control", "--address", control])
        .stdin(std::process::Stdio::piped())
        .stdout(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    piped.stdin.take().unwrap().write_all(b"# set the bench up\nsupply 5000\n\nno_such_command\ninit\n").unwrap();
    let out = piped.wait_with_output().unwrap();
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert_eq!(out.status.code(), Some(1), "an error reply exits 1: {stdout}");
    let lines: Vec<&str> = stdout.lines().collect();
    assert_eq!(lines.len(), 3, "comments and blank lines are not sent: {stdout}");
    assert!(lines[1].starts_with("error: unknown command `no_such_command`"), "{stdout}");
    assert!(lines[2].starts_with("ok "), "the commands after an error still run: {stdout}");

    serve.kill().unwrap();
    serve.wait().unwrap();
    let out = pmacwd().args(["control", "--address", control, "state"]).output().unwrap();
    assert_eq!(out.status.code(), Some(2), "nothing listens any more");
    assert!(String::from_utf8_lossy(&out.stderr).contains(&format!("control port {control}")));
}

/// Sends `line` to a host port as a GETRESPONSE request and returns the reply's bytes.
fn ask_host(c: &mut std::net::TcpStream, line: &str) -> Vec<u8> {
    use std::io::{Read, Write};
    c.write_all(&[0x40, 0xBF, 0, 0, 0, 0, 0, line.len() as u8]).unwrap();
    c.write_all(line.as_bytes()).unwrap();
    let mut reply = vec![0u8; 256];
    let n = c.read(&mut reply).unwrap();
    reply.truncate(n);
    reply
}

/// Waits at most 10 s for `child` to exit after a signal; kills it (and fails) otherwise.
fn exit_after_signal(mut child: std::process::Child, signal: libc::c_int) -> std::process::Output {
    // SAFETY: kill(2) on our own child's pid, with a signal it handles.
    assert_eq!(unsafe { libc::kill(child.id() as libc::pid_t, signal) }, 0);
    let deadline = std::time::Instant::now() + std::time::Duration::from_secs(10);
    while child.try_wait().unwrap().is_none() {
        if std::time::Instant::now() > deadline {
            child.kill().unwrap();
            panic!("still running 10 s after the signal");
        }
        std::thread::sleep(std::time::Duration::from_millis(50));
    }
    child.wait_with_output().unwrap()
}

#[test]
fn ctrl_c_stops_serve_in_order_keeping_the_protocol_error_summary_and_the_recording() {
    // Ctrl-C used to end `serve` where it stood: the protocol errors counted since the last
    // summary (up to a minute of them) and the notes of a recording still waiting for a step
    // were lost. Now SIGINT closes the connections, prints the summary, finishes the capture and
    // says what it could not place, and exits 0; the capture replays as consistent.
    let path = std::env::temp_dir().join(format!("pmacwd-ctrl-c-{}.jsonl", std::process::id()));
    let (child, addr) = serve_on_a_free_port(&["--virtual-time", "--record", path.to_str().unwrap()]);
    let mut host = std::net::TcpStream::connect(addr).unwrap();
    host.set_read_timeout(Some(std::time::Duration::from_secs(5))).unwrap();
    assert!(ask_host(&mut host, "???").ends_with(b"\r\x06"));
    // An M-variable definition is no step of the model: a note that waits for the next step.
    assert_eq!(ask_host(&mut host, "M100->X:$25,0,24,S"), b"\x06");
    // Two protocol errors after the first one's summary line: only a stop prints their count.
    send_bad_headers(addr, 3);
    let out = exit_after_signal(child, libc::SIGINT);
    let stdout = String::from_utf8_lossy(&out.stdout);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{:?}\n{stdout}\n{stderr}", out.status);
    assert!(stdout.contains("stopped by SIGINT after 4 host connections"), "{stdout}");
    assert!(stdout.contains("recorded 1 step in"), "{stdout}\n{stderr}\n{}", std::fs::read_to_string(&path).unwrap());
    assert!(stderr.contains("left over at the end of the recording: `M100->X:$25,0,24,S`"), "{stderr}");
    assert!(stderr.contains("protocol errors, each closing its connection: 2 since the last summary"), "{stderr}");
    let replay = pmacwd().arg("replay").arg(&path).output().unwrap();
    assert!(replay.status.success(), "{}", String::from_utf8_lossy(&replay.stdout));
    let _ = std::fs::remove_file(&path);
}

#[test]
fn sigterm_stops_record_in_order_closing_the_capture_and_saying_what_it_recorded() {
    // Without --sessions, `record` runs until it is stopped; a signal used to end it without
    // its closing notes or the line saying what it recorded. Now SIGTERM (as a service manager
    // sends it) closes the capture as the end of the sessions does, and exits 0.
    let path = std::env::temp_dir().join(format!("pmacwd-sigterm-record-{}.jsonl", std::process::id()));
    let (mut card, card_addr) = serve_on_a_free_port(&[]);
    let target = card_addr.to_string();
    let args = ["record", "--listen", "127.0.0.1:0", "--target", &target, "--out"].map(std::ffi::OsStr::new);
    let (record, first) = spawn_server(&[&args[..], &[path.as_os_str()]].concat());
    // "pmacwd record: 127.0.0.1:PORT -> TARGET, writing FILE"
    let proxy = first.split(": ").nth(1).and_then(|r| r.split(' ').next()).expect("the address line");
    {
        let mut host = std::net::TcpStream::connect(proxy).unwrap();
        host.set_read_timeout(Some(std::time::Duration::from_secs(5))).unwrap();
        assert!(ask_host(&mut host, "???").ends_with(b"\r\x06"));
    }
    let out = exit_after_signal(record, libc::SIGTERM);
    card.kill().unwrap();
    card.wait().unwrap();
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(out.status.success(), "{:?}\n{stdout}\n{}", out.status, String::from_utf8_lossy(&out.stderr));
    assert!(stdout.contains("pmacwd record: stopped by SIGTERM"), "{stdout}");
    assert!(stdout.contains("recorded 1 exchange as "), "{stdout}");
    let replay = pmacwd().arg("replay").arg(&path).output().unwrap();
    assert!(replay.status.success(), "{}", String::from_utf8_lossy(&replay.stdout));
    let _ = std::fs::remove_file(&path);
}

#[test]
fn every_numeric_flag_out_of_its_range_is_refused_with_the_range_before_any_work() {
    // Issue 33: `conform --max-len` with a huge value aborted (SIGABRT, exit 134) allocating
    // the generator's trees, and a server flag out of range started a server. Every numeric
    // flag is now checked when the command line is parsed: exit 2, the accepted range, nothing
    // done (a server that started would be killed after 10 s and fail here).
    let tmp = TempDir::new("ranges");
    let out = tmp.join("c.jsonl");
    let out = out.to_str().unwrap();
    let serve = ["serve", "--listen", "127.0.0.1:0", "--control", "127.0.0.1:0"];
    let record = ["record", "--listen", "127.0.0.1:0", "--target", "127.0.0.1:1", "--out", out];
    let cases: Vec<(Vec<&str>, &str)> = vec![
        (vec!["conform", "--max-len", "18446744073709551615"], "give 1 to 10000"),
        (vec!["conform", "--max-len", "100000000"], "give 1 to 10000"),
        (vec!["conform", "--max-len", "0"], "give 1 to 10000"),
        (vec!["conform", "--cases", "4294967296"], "give 0 to 4294967295"),
        (vec!["conform", "--seed", "18446744073709551616"], "give 0 to 18446744073709551615"),
        (vec!["conform", "--threads", "18446744073709551616"], "give 1 to"),
        (vec!["check", "--threads", "-1"], "give 1 to"),
        ([&serve[..], &["--clients-max", "0"]].concat(), "give 1 to 100000"),
        ([&serve[..], &["--clients-max", "18446744073709551615"]].concat(), "give 1 to 100000"),
        ([&serve[..], &["--idle-timeout", "18446744073709551615"]].concat(), "give 0 to 31536000 seconds"),
        ([&serve[..], &["--control-idle-timeout", "31536001"]].concat(), "give 0 to 31536000 seconds"),
        ([&serve[..], &["--servo-hz", "99999999999"]].concat(), "the servo clock ranges 1..100000 Hz"),
        ([&record[..], &["--silence-ms", "0"]].concat(), "give 1 to 3600000 ms"),
        ([&record[..], &["--silence-ms", "18446744073709551615"]].concat(), "give 1 to 3600000 ms"),
        ([&record[..], &["--sessions", "0"]].concat(), "give 1 to 18446744073709551615"),
        ([&record[..], &["--servo-hz", "-1"]].concat(), "the servo clock ranges 1..100000 Hz"),
        (vec!["margin", "--i40", "-5"], "give 0 to 65535"),
        (vec!["margin", "--i40", "18446744073709551615"], "give 0 to 65535"),
        (vec!["margin", "--i8", "256"], "give 0 to 255"),
        (vec!["margin", "--i10", "0"], "give 1 to 8388607"),
        (vec!["margin", "--motors", "256"], "give 0 to 255"),
        (vec!["margin", "--plc0-units", "65536"], "give 0 to 65535"),
        (vec!["margin", "--background-units", "-1"], "give 0 to 65535"),
        (vec!["margin", "--servo-hz", "4294967296"], "the servo clock ranges 1..100000 Hz"),
    ];
    for (args, range) in cases {
        let mut child = pmacwd()
            .args(&args)
            .stdout(std::process::Stdio::piped())
            .stderr(std::process::Stdio::piped())
            .spawn()
            .unwrap();
        let started = std::time::Instant::now();
        while child.try_wait().unwrap().is_none() && started.elapsed() < std::time::Duration::from_secs(10) {
            std::thread::sleep(std::time::Duration::from_millis(20));
        }
        let _ = child.kill();
        let done = child.wait_with_output().unwrap();
        let stderr = String::from_utf8_lossy(&done.stderr);
        assert_eq!(done.status.code(), Some(2), "{args:?}: {stderr}");
        assert!(stderr.contains(range), "{args:?}: {stderr}");
        assert!(done.stdout.is_empty(), "{args:?} did work before refusing");
    }
}

/// Sets the address-space soft limit of process `pid` (`None`: back to the hard limit).
#[cfg(target_os = "linux")]
fn set_address_space_limit(pid: u32, soft_bytes: Option<u64>) {
    let pid = libc::pid_t::try_from(pid).unwrap();
    let mut old = libc::rlimit { rlim_cur: 0, rlim_max: 0 };
    // SAFETY: prlimit reads `new` and writes `old`, both valid for the call.
    assert_eq!(unsafe { libc::prlimit(pid, libc::RLIMIT_AS, std::ptr::null(), &mut old) }, 0);
    let new =
        libc::rlimit { rlim_cur: soft_bytes.map_or(old.rlim_max, |b| b.min(old.rlim_max)), rlim_max: old.rlim_max };
    assert_eq!(unsafe { libc::prlimit(pid, libc::RLIMIT_AS, &new, std::ptr::null_mut()) }, 0);
}

#[cfg(target_os = "linux")]
#[test]
fn a_server_out_of_address_space_closes_the_connections_it_has_no_room_for_and_never_aborts() {
    // Issue 33: under an address-space limit (`ulimit -v`) a connection's thread could get its
    // stack and then not its alternate signal stack or its first allocation, and Rust aborted
    // the whole server (SIGABRT: "memory allocation of 41 bytes failed"). The limit is set a
    // stack's worth (2 MiB) and a few KiB above the server's size, where that happened; the
    // server now closes the connection it has no room for, counts it, and answers again once
    // there is room.
    use std::io::{Read, Write};
    let mut request = vec![0x40, 0xBF, 0, 0, 0, 0, 0, 3];
    request.extend_from_slice(b"???");
    let ask = |addr: std::net::SocketAddr| -> Vec<u8> {
        let Ok(mut c) = std::net::TcpStream::connect(addr) else { return Vec::new() };
        c.set_read_timeout(Some(std::time::Duration::from_secs(3))).unwrap();
        let _ = c.write_all(&request);
        let mut reply = [0u8; 64];
        c.read(&mut reply).map(|n| reply[..n].to_vec()).unwrap_or_default()
    };
    /// Kills the server when an assertion fails, so that no server outlives its test.
    struct Killed(Option<std::process::Child>);
    impl Drop for Killed {
        fn drop(&mut self) {
            if let Some(mut c) = self.0.take() {
                let _ = c.kill();
                let _ = c.wait();
            }
        }
    }
    for extra_kib in [4u64, 8, 64] {
        let (server, addr) = serve_on_a_free_port(&["--verbose"]);
        let mut guard = Killed(Some(server));
        let server = guard.0.as_mut().unwrap();
        std::thread::sleep(std::time::Duration::from_millis(200));
        let status = std::fs::read_to_string(format!("/proc/{}/status", server.id())).unwrap();
        let size_kib: u64 = status
            .lines()
            .find_map(|l| l.strip_prefix("VmSize:"))
            .and_then(|v| v.trim().trim_end_matches("kB").trim().parse().ok())
            .unwrap();
        set_address_space_limit(server.id(), Some((size_kib + 2048 + extra_kib) * 1024));
        for _ in 0..3 {
            // Closed (or, with room after all, answered): either way the server lives on.
            let _ = ask(addr);
        }
        std::thread::sleep(std::time::Duration::from_millis(200));
        let alive = server.try_wait().unwrap();
        assert!(alive.is_none(), "+{extra_kib} KiB: the server ended: {alive:?}");
        set_address_space_limit(server.id(), None);
        let reply = ask(addr);
        assert!(
            reply.len() == 14 && reply.ends_with(b"\r\x06"),
            "+{extra_kib} KiB: not answered once there is room: {reply:?}"
        );
        let mut server = guard.0.take().unwrap();
        server.kill().unwrap();
        let out = server.wait_with_output().unwrap();
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert!(stderr.contains("cannot start its thread"), "+{extra_kib} KiB: {stderr}");
    }
}

#[test]
fn import_as_yaml_stops_before_its_trace_is_longer_than_the_readers_take() {
    // The YAML readers take at most yaml::NODES_MAX nodes (issue 33); `import --yaml` of a long
    // log wrote a trace that `run` and `replay` then refused. It now stops with exit 2, the
    // log's line and the way out (JSON Lines), and leaves no file under --out.
    let dir = TempDir::new("import-yaml-bound");
    let log = dir.join("long.log");
    let mut text = String::new();
    for i in 0..20_000u32 {
        text.push_str(&format!("> RHX:$0\n< {:06X}\n> ???\n< 001000000000\n", (i * 300) & 0xFF_FFFF));
    }
    std::fs::write(&log, text).unwrap();
    let out = dir.join("long.yaml");
    let done = pmacwd().arg("import").arg(&log).arg("--yaml").arg("--out").arg(&out).output().unwrap();
    let stderr = String::from_utf8_lossy(&done.stderr);
    assert_eq!(done.status.code(), Some(2), "{stderr}");
    assert!(stderr.contains("more than the 250000 `run` and `replay` read: import the log as JSON Lines"), "{stderr}");
    assert!(stderr.contains("long.log:"), "{stderr}");
    assert!(!out.exists(), "a refused import left {}", out.display());
    // As JSON Lines the same log imports, and its trace loads.
    let jsonl = dir.join("long.jsonl");
    let done = pmacwd().arg("import").arg(&log).arg("--out").arg(&jsonl).output().unwrap();
    assert_eq!(done.status.code(), Some(0), "{}", String::from_utf8_lossy(&done.stderr));
    // A shorter log as YAML loads too.
    let short = dir.join("short.log");
    std::fs::write(&short, "> RHX:$0\n< 000010\n> ???\n< 001000000000\n").unwrap();
    let yaml = dir.join("short.yaml");
    let done = pmacwd().arg("import").arg(&short).arg("--yaml").arg("--out").arg(&yaml).output().unwrap();
    assert_eq!(done.status.code(), Some(0), "{}", String::from_utf8_lossy(&done.stderr));
    pmacwd_trace::load(&yaml).unwrap();
}

/// `pmacwd margin --profile um-215 ARGS`: exit code, standard output, standard error.
fn margin_um215(args: &[&str]) -> (Option<i32>, String, String) {
    let out = pmacwd().args(["margin", "--profile", "um-215"]).args(args).output().unwrap();
    (
        out.status.code(),
        String::from_utf8_lossy(&out.stdout).into_owned(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

#[test]
fn margin_reads_x25_and_y25_as_the_card_replies_them_in_hex_or_in_decimal() {
    // Issue 34: `RHX:$25` replies six hex digits; $ and hex digits are the card's notation;
    // anything else is decimal. Each form gives the same report as the decimal value.
    let (code, decimal, _) = margin_um215(&["--x25", "4080", "--y25", "4092"]);
    assert_eq!(code, Some(0), "{decimal}");
    assert!(decimal.contains("readings: X:$25 = 000FF0 (4080), Y:$25 = 000FFC (4092)"), "{decimal}");
    for (x, y) in [("000FF0", "000FFC"), ("$FF0", "$ffc"), ("000ff0", "4092")] {
        assert_eq!(margin_um215(&["--x25", x, "--y25", y]).1, decimal, "--x25 {x} --y25 {y}");
    }
    // FFFFFF is -1: the counter below zero, which only the SRM p.57 reading shows.
    let (_, minus, _) = margin_um215(&["--x25", "FFFFFF"]);
    assert_eq!(minus, margin_um215(&["--x25", "-1"]).1);
    assert!(minus.contains("X:$25 = FFFFFF (-1)"), "{minus}");
    let (_, json, _) = margin_um215(&["--x25", "000FF0", "--format", "json"]);
    let doc: serde_json::Value = serde_json::from_str(&json).unwrap();
    assert_eq!((doc["x25"].as_i64(), doc["y25"].is_null()), (Some(4080), true), "{json}");
    for bad in ["FF0", "0xFF0", "$", "$1000000", "0FF0FF0", "12.5", "8388608", "four"] {
        let (code, out, err) = margin_um215(&["--x25", bad]);
        assert_eq!(code, Some(2), "--x25 {bad}: {out}");
        assert!(err.contains("give the reading as RHX:$25 replies it"), "--x25 {bad}: {err}");
    }
}

#[test]
fn margin_takes_plc0_and_background_times_in_microseconds_and_refuses_both_forms_of_one_load() {
    // i40-zero: 100 units in a servo cycle of 444.4 µs (UM p.236), a unit 4.444 µs; the load
    // in µs rounded up to units is measured as that many units.
    let (code, us, _) = margin_um215(&["--plc0-us", "133.3", "--background-us", "1111", "--format", "json"]);
    assert_eq!(code, Some(0));
    let (_, units, _) = margin_um215(&["--plc0-units", "30", "--background-units", "250", "--format", "json"]);
    let (us, units): (serde_json::Value, serde_json::Value) =
        (serde_json::from_str(&us).unwrap(), serde_json::from_str(&units).unwrap());
    assert_eq!(us["profiles"], units["profiles"]);
    assert_eq!((us["load"]["plc0_units"].as_u64(), us["load"]["background_units"].as_u64()), (Some(30), Some(250)));
    assert_eq!((us["load"]["plc0_us"].as_f64(), us["load"]["background_us"].as_f64()), (Some(133.3), Some(1111.0)));
    assert!(units["load"]["plc0_us"].is_null());
    assert!((us["us_per_unit"].as_f64().unwrap() - 4.4444).abs() < 1e-3, "{us}");
    let (_, text, _) = margin_um215(&["--plc0-us", "133.4"]);
    assert!(text.contains("load: 8 motors, PLC 0 31 units per RTI"), "{text}");
    assert!(text.contains("in µs: PLC 0 133.4 µs = 31 units (30.015 exact, rounded up)"), "{text}");
    // At twice the servo clock a unit is half as long.
    let (_, fast, _) = margin_um215(&["--servo-hz", "4500", "--plc0-us", "133.3"]);
    assert!(fast.contains("PLC 0 60 units per RTI"), "{fast}");
    for both in [["--plc0-us", "10", "--plc0-units", "3"], ["--background-units", "3", "--background-us", "10"]] {
        let (code, _, err) = margin_um215(&both);
        assert_eq!(code, Some(2), "{both:?}");
        assert!(err.contains("cannot be used with"), "{both:?}: {err}");
    }
    for bad in ["-1", "NaN", "inf", "1e9", "ten"] {
        let (code, _, err) = margin_um215(&["--plc0-us", bad]);
        assert_eq!(code, Some(2), "--plc0-us {bad}: {err}");
        assert!(err.contains("--plc0-us") && !err.contains("panicked"), "{err}");
    }
}

/// The emulated Geo Brick's timer scale (`variables.yaml`: M70 = 13279, M71 = 1328, I7002 = 3),
/// at i40-zero's 100 units a servo cycle.
const BRICK: pmacwd_core::timers::TimerScale =
    pmacwd_core::timers::TimerScale { phase_period: 13279, phase_task: 1328, phases_per_servo: 4, cycle_units: 100 };

fn margin_json(args: &[&str]) -> serde_json::Value {
    let (code, out, err) = margin_um215(&[args, &["--format", "json"]].concat());
    assert!(matches!(code, Some(0 | 1)), "{args:?}: {err}");
    serde_json::from_str(&out).unwrap()
}

#[test]
fn margin_takes_the_epics_drivers_m70_to_m73_and_gives_the_margin_of_the_load_that_made_them() {
    // Issue 34: load -> registers through the one mapping (pmacwd_core::timers) -> margin's
    // inputs by its inverse -> the same load, the same margin; light, heavy, the starving 276
    // units and a load that spans servo cycles.
    for (motors, plc0) in [(8u8, 30u16), (8, 200), (16, 120), (8, 276), (0, 0), (32, 5)] {
        let t = BRICK.timers(u32::from(motors), u32::from(plc0));
        let regs = [t.phase_period, t.phase_task, t.servo_task, t.rti_task].map(|v| v.to_string());
        let from_regs = margin_json(&["--m70", &regs[0], "--m71", &regs[1], "--m72", &regs[2], "--m73", &regs[3]]);
        let direct = margin_json(&["--motors", &motors.to_string(), "--plc0-units", &plc0.to_string()]);
        assert_eq!(from_regs["profiles"], direct["profiles"], "{motors} motors, PLC 0 {plc0}: {regs:?}");
        assert_eq!(from_regs["load"], direct["load"]);
        let f = &from_regs["figures"];
        assert_eq!(f["candidates"], serde_json::json!([{"motors": motors, "plc0_units": plc0}]), "{f}");
        // The driver's CPU load of the same registers, with the motors known: the load again
        // among the readings, and a margin no larger than the load's own.
        let percent = format!("{:.4}", t.load_ppm(4, 2) as f64 / 10_000.0);
        let from_load = margin_json(&[
            "--cpu-load",
            &percent,
            "--motors",
            &motors.to_string(),
            "--m70",
            &regs[0],
            "--m71",
            &regs[1],
        ]);
        let c = &from_load["figures"]["candidates"];
        assert!(
            c.as_array().unwrap().contains(&serde_json::json!({"motors": motors, "plc0_units": plc0})),
            "{percent}%: {c}"
        );
        let margin = |doc: &serde_json::Value| doc["profiles"][0]["margin_cycles"].as_i64();
        assert!(margin(&from_load) <= margin(&direct), "{percent}%: {from_load}");
    }
    // A reading between two units' registers stands for both: the one with less margin is
    // measured (here PLC 0 of 276 units, which starves the background, against 275).
    let (at275, at276) = (BRICK.rti_task(275, 8), BRICK.rti_task(276, 8));
    let between = margin_json(&[
        "--m70",
        "13279",
        "--m71",
        "1328",
        "--m72",
        &BRICK.servo_task(8).to_string(),
        "--m73",
        &((at275 + at276) / 2).to_string(),
    ]);
    assert_eq!(between["figures"]["chosen"], serde_json::json!({"motors": 8, "plc0_units": 276}), "{between}");
    assert!(between["profiles"][0]["tripped"].as_bool().unwrap());
    let (_, text, _) = margin_um215(&[
        "--m70",
        "13279",
        "--m71",
        "1328",
        "--m72",
        "3824",
        "--m73",
        &((at275 + at276) / 2).to_string(),
    ]);
    assert!(text.contains("not unique: 2 loads read so (motors 8, PLC 0 275 to 276 units)"), "{text}");
}

#[test]
fn margin_s_cpu_load_alone_takes_the_split_between_servo_and_rti_with_the_least_margin() {
    // The driver's CPULOAD says nothing of how it splits between the servo and the RTI tasks,
    // nor (without M70/M71) of the phase tasks' share: every split is a reading, and the one
    // with the smallest margin is measured; no reading has less.
    let doc = margin_json(&["--cpu-load", "26.2"]);
    let f = &doc["figures"];
    assert_eq!(f["phase_share_assumed"], serde_json::json!(true));
    let candidates = f["candidates"].as_array().unwrap();
    assert!(candidates.len() > 20, "{f}");
    let chosen = doc["profiles"][0]["margin_cycles"].as_i64();
    for c in candidates.iter().step_by(5) {
        let other = margin_json(&["--motors", &c["motors"].to_string(), "--plc0-units", &c["plc0_units"].to_string()]);
        assert!(chosen <= other["profiles"][0]["margin_cycles"].as_i64(), "{c}: {other}");
    }
}

#[test]
fn margin_refuses_driver_figures_out_of_range_or_that_no_load_makes() {
    let cases: &[(&[&str], &str)] = &[
        (&["--m70", "0", "--m71", "0"], "give 1 to 16777215"),
        (&["--m70", "16777216", "--m71", "0"], "give 1 to 16777215"),
        (&["--m70", "13279", "--m71", "-1"], "give 0 to 16777215"),
        (&["--m70", "13279", "--m71", "1328", "--m73", "1e3"], "give 0 to 16777215"),
        (&["--m70", "13279", "--m71", "13279", "--m72", "0"], "--m71 13279: the phase tasks would take the whole"),
        (&["--m72", "3824"], "the following required arguments were not provided"),
        (&["--m70", "13279", "--m72", "3824"], "the following required arguments were not provided"),
        (&["--m70", "13279", "--m71", "1328", "--m72", "3824", "--motors", "8"], "cannot be used with"),
        (&["--m70", "13279", "--m71", "1328", "--m73", "9", "--plc0-units", "8"], "cannot be used with"),
        (&["--cpu-load", "20", "--m70", "13279", "--m71", "1328", "--m73", "9"], "cannot be used with"),
        (&["--cpu-load", "20", "--plc0-us", "9"], "cannot be used with"),
        (&["--cpu-load", "100.5"], "give a CPU load of 0 to 100 percent"),
        (&["--cpu-load", "-1"], "give a CPU load of 0 to 100 percent"),
        (&["--cpu-load", "NaN"], "give a CPU load of 0 to 100 percent"),
        (&["--cpu-load", "5", "--m70", "13279", "--m71", "1328"], "the phase tasks of --m70/--m71 alone make 10.00%"),
        (
            &["--cpu-load", "12", "--motors", "8", "--m70", "13279", "--m71", "1328"],
            "and the servo tasks of 8 motors alone",
        ),
        (&["--m70", "13279", "--m71", "1328", "--m72", "16777215"], "--m72 16777215: more than the servo tasks of 255"),
        (&["--i7002", "16", "--cpu-load", "20"], "give 0 to 15"),
    ];
    for (args, want) in cases {
        let (code, out, err) = margin_um215(args);
        assert_eq!(code, Some(2), "{args:?}: {out}{err}");
        assert!(err.contains(want) && !err.contains("panicked"), "{args:?}: {err}");
    }
}

#[test]
fn margin_warns_where_the_margin_rises_with_the_load_and_names_the_loads() {
    // 276 units of PLC 0 end exactly at the RTI and starve the background; 277 do not.
    let (code, text, _) = margin_um215(&["--plc0-units", "277"]);
    assert_eq!(code, Some(0), "{text}");
    assert!(
        text.contains(
            "warning: the margin is not monotonic in the load here, under um-215: PLC 0 276 units: the card trips; \
             277 units: margin 4135 servo cycles; 278 units: margin 4135 servo cycles"
        ),
        "{text}"
    );
    // Under every profile: one warning, after the profiles, naming them, each load's margins
    // over them as a range (they differ by reload and delay, not by where they fall).
    let out = pmacwd().args(["margin", "--plc0-units", "277"]).output().unwrap();
    let text = String::from_utf8_lossy(&out.stdout);
    assert_eq!(text.matches("not monotonic").count(), 1, "{text}");
    let warning = text.lines().last().unwrap();
    // The top, 4180, is um-215-full-period's (issue 36): its delay of 90 cycles, 45 more.
    assert!(
        warning.starts_with(
            "warning: the margin is not monotonic in the load here, under every profile measured (um-215, srm-57, "
        ) && warning.contains("PLC 0 276 units: the card trips; 277 units: margin 4112 to 4180 servo cycles"),
        "{text}"
    );
    let (code, json, _) = margin_um215(&["--plc0-units", "276", "--format", "json"]);
    assert_eq!(code, Some(1));
    let doc: serde_json::Value = serde_json::from_str(&json).unwrap();
    let n = &doc["profiles"][0]["not_monotonic"][0];
    assert_eq!(n["load"], "plc0_units");
    assert_eq!(n["units"], serde_json::json!([275, 276, 277]));
    assert_eq!(n["margin_cycles"], serde_json::json!([3391, null, 4135]));
    let (_, text, _) = margin_um215(&[]);
    assert!(!text.contains("warning"), "{text}");
}

#[test]
fn margin_s_plot_marks_the_load_given_and_names_the_profiles_whose_curves_coincide() {
    let tmp = TempDir::new("margin-plot");
    let svg = tmp.join("m.svg");
    let out = pmacwd().args(["margin", "--plc0-units", "120", "--plot"]).arg(&svg).output().unwrap();
    assert_eq!(out.status.code(), Some(0), "{}", String::from_utf8_lossy(&out.stderr));
    let svg = std::fs::read_to_string(&svg).unwrap();
    assert!(svg.contains("your load: PLC 0 120 units per RTI"), "the legend names the load given");
    // A ring on each distinct line at the load's PLC 0, and the legend's own ring.
    let rings = svg.matches("<circle").count();
    assert!(rings >= 2, "{rings} rings");
    // um-215, um-215-literal-plc and um-215-m83 make the same curve at i40-zero: one line.
    assert!(svg.contains("um-215 (default); same: um-215-literal-plc, um-215-m83"), "the legend groups them");
}

#[test]
fn every_subcommand_s_help_names_its_docs_page_by_its_path_and_the_page_exists() {
    // Issue 34: a help text points at the page that says more, by its path in the repository.
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
    let subcommands = [
        "serve",
        "control",
        "record",
        "probe",
        "check",
        "explore",
        "run",
        "decode",
        "replay",
        "margin",
        "timeline",
        "conform",
        "requirements",
        "import",
    ];
    for sub in subcommands {
        let out = pmacwd().args([sub, "--help"]).output().unwrap();
        let help = String::from_utf8_lossy(&out.stdout);
        let pages: Vec<&str> = help
            .split(|c: char| c.is_whitespace() || "(),;:`".contains(c))
            .filter(|w| w.starts_with("docs/") && w.contains(".md"))
            .map(|w| w.split('#').next().unwrap().trim_end_matches('.'))
            .collect();
        assert!(!pages.is_empty(), "`pmacwd {sub} --help` names no docs page:\n{help}");
        for page in pages {
            assert!(root.join(page).is_file(), "`pmacwd {sub} --help` names {page}, which does not exist");
        }
    }
}
