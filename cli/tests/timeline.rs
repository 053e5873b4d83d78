//! `pmacwd timeline`: the signals it writes are the model's, in every format.

use std::path::Path;
use std::process::Command;

fn pmacwd(args: &[&str]) -> (i32, String, String) {
    let out = Command::new(env!("CARGO_BIN_EXE_pmacwd"))
        .args(args)
        .current_dir(Path::new(env!("CARGO_MANIFEST_DIR")).join(".."))
        .output()
        .unwrap();
    (
        out.status.code().unwrap_or(-1),
        String::from_utf8_lossy(&out.stdout).into(),
        String::from_utf8_lossy(&out.stderr).into(),
    )
}

const STARVED: &str =
    "specs/scenarios/a-starved-background-trips-the-um-215-card-46-cycles-after-the-counter-runs-out.yaml";

/// The data lines of a CSV timeline as (cycle, y25, strobe, tripped).
fn rows(csv: &str) -> Vec<(u64, i32, u8, u8)> {
    csv.lines()
        .filter(|l| !l.starts_with('#') && !l.starts_with("cycle"))
        .map(|l| {
            let f: Vec<&str> = l.split(',').collect();
            (f[0].parse().unwrap(), f[2].parse().unwrap(), f[4].parse().unwrap(), f[5].parse().unwrap())
        })
        .collect()
}

#[test]
fn the_csv_timeline_shows_the_trip_46_cycles_after_the_last_strobe_edge_as_the_scenario_says() {
    // UM p.215 at 2.25 kHz and 25 Hz: the timer trips once no strobe edge has come for more
    // than 45 servo cycles. The timeline must show exactly that, from the model's own signals.
    let (code, out, err) = pmacwd(&["timeline", STARVED]);
    assert_eq!(code, 0, "{err}");
    let rows = rows(&out);
    let trip = rows.iter().find(|r| r.3 == 1).expect("the scenario trips").0;
    let mut last_edge = 0;
    for w in rows.windows(2) {
        if w[1].2 != w[0].2 && w[1].0 <= trip {
            last_edge = w[1].0;
        }
    }
    assert_eq!(trip - last_edge, 46, "trip at {trip}, last strobe edge at {last_edge}");
    // The counter runs down one per servo cycle until it stops at zero.
    assert!(rows.iter().any(|r| r.1 == 0));
}

#[test]
fn the_vcd_timeline_declares_every_signal_and_its_times_never_go_back() {
    let (code, out, err) = pmacwd(&["timeline", "--format", "vcd", STARVED]);
    assert_eq!(code, 0, "{err}");
    assert!(out.contains("$var integer 32 ! y25_counter $end") && out.contains("$enddefinitions $end"));
    assert!(out.contains("bit22_rti_reentry") || out.contains("_rti_"), "the status bits are declared");
    let times: Vec<u64> = out.lines().filter_map(|l| l.strip_prefix('#')).map(|t| t.parse().unwrap()).collect();
    assert!(times.windows(2).all(|w| w[0] < w[1]), "time stamps strictly increase");
    // One servo cycle at 2,250 Hz is 444,444 ns.
    assert!(times.contains(&444_444), "{:?}", &times[..3]);
}

#[test]
fn the_svg_timeline_is_a_plot_with_the_trip_marked() {
    let (code, out, err) = pmacwd(&["timeline", "--format", "svg", STARVED]);
    assert_eq!(code, 0, "{err}");
    assert!(out.starts_with("<svg") && out.trim_end().ends_with("</svg>"));
    assert!(out.contains("the hardware timer trips"), "the trip is in the legend");
}

#[test]
fn a_capture_with_unseen_time_is_refused_with_its_line_and_told_to_take_a_witness() {
    // A host log is not a trace: what happened between its polls is for replay to find.
    let (code, _, err) = pmacwd(&["timeline", "specs/captures/healthy-dsp56321.log"]);
    assert_eq!(code, 2, "{err}");
    assert!(err.contains("--witness"), "{err}");
    let elapsed = std::path::PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("pmacwd-timeline.jsonl");
    std::fs::write(
        &elapsed,
        "{\"format\":\"pmacwd-trace\",\"version\":1,\"description\":\"t\",\"configuration\":\"host-log\",\"profiles\":\"all\"}\n{\"elapsed\":100}\n",
    )
    .unwrap();
    let (code, _, err) = pmacwd(&["timeline", elapsed.to_str().unwrap()]);
    assert_eq!(code, 2);
    assert!(err.contains(":2:") && err.contains("pmacwd replay"), "{err}");
}
