//! `pmacwd explore` as a user meets it: the binary started on a free port, the Explorer's JSON
//! endpoints (`/.status`, `/.states/...`, `/.runtocompletion`, what the web page itself reads)
//! fetched over HTTP, and what they show compared with what `pmacwd check` reports for the same
//! configuration and profile: the property names, every witness path step by step from the
//! initial state (each step's event, reply, Y:$25, X:$25, status words and trip), and after a
//! run to completion the state count and which properties were found.

use serde_json::Value;
use std::io::{BufRead, BufReader, Read, Write};
use std::net::{SocketAddr, TcpListener, TcpStream};
use std::process::{Child, Command, Output, Stdio};
use std::time::{Duration, Instant};

const PMACWD: &str = env!("CARGO_BIN_EXE_pmacwd");
/// The smallest configuration that `check` runs with witnesses of several steps (1,224 states
/// under um-215, docs/model.md).
const CONFIGURATION: &str = "lockout-ic";
const PROFILE: &str = "um-215";

/// The explorer process, killed when the test ends however it ends.
struct Explorer {
    child: Child,
    address: SocketAddr,
}

impl Drop for Explorer {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

/// Starts `pmacwd explore ARGS --listen 127.0.0.1:0` and reads the address it serves on from
/// its first lines.
fn start(args: &[&str]) -> Explorer {
    let mut child = Command::new(PMACWD)
        .arg("explore")
        .args(args)
        .args(["--listen", "127.0.0.1:0"])
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("pmacwd starts");
    let stdout = child.stdout.take().unwrap();
    let mut lines = BufReader::new(stdout).lines();
    let mut banner = Vec::new();
    let address = loop {
        let Some(Ok(line)) = lines.next() else {
            let _ = child.kill();
            let mut err = String::new();
            let _ = child.stderr.take().unwrap().read_to_string(&mut err);
            panic!("pmacwd explore printed no address; stdout {banner:?}, stderr {err}");
        };
        if let Some(rest) = line.strip_prefix("Explorer at http://") {
            break rest.split('/').next().unwrap().parse::<SocketAddr>().expect("an address");
        }
        banner.push(line);
    };
    assert!(
        banner[0].starts_with(&format!("pmacwd explore: configuration {CONFIGURATION} / profile {PROFILE}")),
        "{banner:?}"
    );
    Explorer { child, address }
}

/// One HTTP/1.0 request; the answer's status code and body.
fn http(address: SocketAddr, method: &str, path: &str) -> (u16, String) {
    let mut s = TcpStream::connect(address).expect("the explorer accepts");
    s.set_read_timeout(Some(Duration::from_secs(30))).unwrap();
    write!(s, "{method} {path} HTTP/1.0\r\nHost: {address}\r\nContent-Length: 0\r\n\r\n").unwrap();
    let mut answer = String::new();
    s.read_to_string(&mut answer).expect("an answer");
    let (head, body) = answer.split_once("\r\n\r\n").expect("an HTTP answer");
    let code = head.split(' ').nth(1).and_then(|c| c.parse().ok()).expect("a status code");
    (code, body.to_string())
}

fn get_json(address: SocketAddr, path: &str) -> Value {
    let (code, body) = http(address, "GET", path);
    assert_eq!(code, 200, "GET {path}: {body}");
    serde_json::from_str(&body).unwrap_or_else(|e| panic!("GET {path}: {e}: {body}"))
}

fn pmacwd(args: &[&str]) -> Output {
    Command::new(PMACWD).args(args).output().expect("pmacwd runs")
}

/// `pmacwd check` of the configuration, one thread, every witness, as JSON: its one run.
fn check_report() -> Value {
    let out = pmacwd(&[
        "check",
        "--configuration",
        CONFIGURATION,
        "--profile",
        PROFILE,
        "--witnesses",
        "--threads",
        "1",
        "--no-conformance",
        "--format",
        "json",
    ]);
    assert_eq!(out.status.code(), Some(0), "{}", String::from_utf8_lossy(&out.stderr));
    let doc: Value = serde_json::from_slice(&out.stdout).unwrap();
    let runs = doc["runs"].as_array().unwrap();
    assert_eq!(runs.len(), 1);
    runs[0].clone()
}

/// The card line of a state or an outcome as the Explorer shows it: `Y:$25=.. X:$25=..
/// status=..` and the trip.
fn card_line(text: &str) -> &str {
    text.lines().find(|l| l.starts_with("Y:$25=")).unwrap_or_else(|| panic!("no card line in {text:?}"))
}

/// The same line built from a step of `check --format json`.
fn card_line_of_step(step: &Value) -> String {
    let mut line = format!(
        "Y:$25={} X:$25={} status={}",
        step["counter"].as_i64().unwrap(),
        step["counter_min"].as_i64().unwrap(),
        step["status"].as_str().unwrap()
    );
    if step["tripped"].as_bool().unwrap() {
        line.push_str(" TRIPPED (red LED, FEFCO/ on, relay over, outputs off)");
    }
    line
}

/// The outcome text the Explorer should show for a step of `check`'s path.
fn outcome_of_step(step: &Value) -> String {
    let mut s = format!("event: {}\n", step["event"].as_str().unwrap());
    if let Some(reply) = step["reply"].as_str() {
        s.push_str(&format!("reply: {reply}\n"));
    }
    s.push_str(&card_line_of_step(step));
    s
}

#[test]
fn the_explorer_shows_the_states_actions_and_properties_that_check_reports() {
    let report = check_report();
    let explorer = start(&["--configuration", CONFIGURATION, "--profile", PROFILE]);
    let at = explorer.address;

    // The page itself and its script are served.
    let (code, page) = http(at, "GET", "/");
    assert_eq!(code, 200);
    assert!(page.contains("<html") || page.contains("<!DOCTYPE"), "{page:.200}");

    // The properties: those `check` gives a verdict (n/a ones are not searched, as in check),
    // under the same names, in the same order.
    let checked: Vec<(&str, &str)> = report["properties"]
        .as_array()
        .unwrap()
        .iter()
        .filter(|p| p["verdict"] != "n/a")
        .map(|p| (p["name"].as_str().unwrap(), p["kind"].as_str().unwrap()))
        .collect();
    let status = get_json(at, "/.status");
    let shown: Vec<(String, String)> = status["properties"]
        .as_array()
        .unwrap()
        .iter()
        .map(|p| (p[1].as_str().unwrap().to_string(), p[0].as_str().unwrap().to_lowercase()))
        .collect();
    let shown_refs: Vec<(&str, &str)> = shown.iter().map(|(n, k)| (n.as_str(), k.as_str())).collect();
    assert_eq!(shown_refs, checked, "the Explorer's properties are check's, named and ordered as check names them");

    // One initial state: the card at power-up, Y:$25 and X:$25 at I40 = 3 (check.yaml's
    // lockout-ic), nothing tripped.
    let init = get_json(at, "/.states");
    let init = init.as_array().unwrap();
    assert_eq!(init.len(), 1, "one initial state");
    let init_text = init[0]["state"].as_str().unwrap();
    assert!(init_text.starts_with("card: running\nY:$25=3 X:$25=3 status="), "{init_text}");
    assert!(init_text.contains("I-variables: I8=1 I40=3 I41=0"), "{init_text}");
    let init_fp = init[0]["fingerprint"].as_str().unwrap().to_string();

    // Every witness of `check` walked in the Explorer from the initial state: at each step an
    // action of the state reached has exactly the step's outcome (event, reply, card line),
    // and the walk goes on from its state.
    let witnesses: Vec<&Value> = report["properties"]
        .as_array()
        .unwrap()
        .iter()
        .filter(|p| p["verdict"] == "reached" && p["path"].as_array().is_some_and(|s| !s.is_empty()))
        .collect();
    assert!(witnesses.len() >= 3, "check reports witnesses to walk: {}", witnesses.len());
    let mut steps_walked = 0;
    for w in &witnesses {
        let mut path = format!("/.states/{init_fp}");
        for (i, step) in w["path"].as_array().unwrap().iter().enumerate() {
            let want = outcome_of_step(step);
            let successors = get_json(at, &path);
            let found = successors
                .as_array()
                .unwrap()
                .iter()
                .find(|s| s["outcome"].as_str() == Some(want.as_str()))
                .unwrap_or_else(|| {
                    panic!(
                        "witness of `{}`, step {}: no action from {path} has the outcome {want:?}; the actions: {:#}",
                        w["name"],
                        i + 1,
                        successors
                    )
                });
            // The state's own card line is the outcome's.
            assert_eq!(card_line(found["state"].as_str().unwrap()), card_line_of_step(step));
            path.push('/');
            path.push_str(found["fingerprint"].as_str().unwrap());
            steps_walked += 1;
        }
    }
    assert!(steps_walked >= witnesses.len());

    // An unknown fingerprint is refused, not a crash: the Explorer still answers afterwards.
    let (code, _) = http(at, "GET", &format!("/.states/{init_fp}/1"));
    assert_eq!(code, 404);
    let (code, _) = http(at, "GET", "/.states/not-a-fingerprint");
    assert_eq!(code, 404);

    // Run to completion: the same reachable states as check, every `sometimes` property check
    // reached found, no `always` property violated.
    let (code, _) = http(at, "POST", "/.runtocompletion");
    assert_eq!(code, 200);
    let deadline = Instant::now() + Duration::from_secs(120);
    let status = loop {
        let s = get_json(at, "/.status");
        if s["done"] == true {
            break s;
        }
        assert!(Instant::now() < deadline, "the run to completion did not finish: {s}");
        std::thread::sleep(Duration::from_millis(100));
    };
    assert_eq!(status["unique_state_count"], report["states"], "the Explorer's states are check's");
    for p in status["properties"].as_array().unwrap() {
        let name = p[1].as_str().unwrap();
        let verdict = report["properties"].as_array().unwrap().iter().find(|q| q["name"] == name).unwrap()["verdict"]
            .as_str()
            .unwrap();
        let discovered = !p[2].is_null();
        match verdict {
            "holds" => assert!(!discovered, "`{name}` holds in check but the Explorer found a counterexample"),
            "reached" => assert!(discovered, "`{name}` is reached in check but not in the Explorer"),
            other => panic!("`{name}`: check's verdict {other}"),
        }
    }
}

#[test]
fn an_unknown_configuration_exits_2_naming_the_configurations() {
    let out = pmacwd(&["explore", "--configuration", "nope", "--listen", "127.0.0.1:0"]);
    assert_eq!(out.status.code(), Some(2));
    let err = String::from_utf8_lossy(&out.stderr);
    for name in ["timing", "lockout-ic", "motion", "encoder-loss"] {
        assert!(err.contains(name), "{err}");
    }
    assert!(err.contains("no configuration named `nope`"), "{err}");
    assert!(out.stdout.is_empty());
}

#[test]
fn an_unknown_profile_exits_2_naming_the_profiles() {
    let out = pmacwd(&["explore", "--profile", "nope", "--listen", "127.0.0.1:0"]);
    assert_eq!(out.status.code(), Some(2));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("no profile named `nope`") && err.contains("um-215") && err.contains("srm-57"), "{err}");
}

#[test]
fn an_address_in_use_exits_2() {
    let taken = TcpListener::bind("127.0.0.1:0").unwrap();
    let address = taken.local_addr().unwrap().to_string();
    let out = pmacwd(&["explore", "--listen", &address]);
    assert_eq!(out.status.code(), Some(2), "{}", String::from_utf8_lossy(&out.stdout));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains(&format!("cannot listen on {address}")), "{err}");
    assert!(out.stdout.is_empty(), "nothing is printed before the address is bound");
}

#[test]
fn a_profile_check_does_not_run_the_configuration_under_is_said_so() {
    let mut explorer = {
        let mut child = Command::new(PMACWD)
            .args(["explore", "--configuration", "motion", "--profile", "um-215-4095", "--listen", "127.0.0.1:0"])
            .stdout(Stdio::piped())
            .stderr(Stdio::null())
            .spawn()
            .unwrap();
        let stdout = child.stdout.take().unwrap();
        let lines: Vec<String> = BufReader::new(stdout).lines().take(3).map(Result::unwrap).collect();
        (child, lines)
    };
    let _ = explorer.0.kill();
    let _ = explorer.0.wait();
    let lines = explorer.1;
    assert!(
        lines[1].contains("pmacwd check does not run this pair (it runs motion under: um-215, srm-57)"),
        "{lines:?}"
    );
    assert!(lines[2].starts_with("Explorer at http://127.0.0.1:"), "{lines:?}");
}
