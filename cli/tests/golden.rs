//! Golden tests of the `pmacwd` command line: for each case, the exact standard output, standard
//! error and exit code, compared with `cli/tests/golden/<case>.txt`.
//!
//! They pin what a user of the command line sees, so that moving code between crates can be
//! shown to change none of it. The binary runs from the repository root, as the README runs
//! it. Only what is genuinely nondeterministic is normalized, and only as described at
//! [`normalize`] and [`Extra`]; state counts, expectation counts, coverage counts, verdicts and
//! traces stay pinned.
//!
//! A golden file holds a header (`command:` the arguments, `exit:` the exit code), then
//! `--- stdout` and `--- stderr`, each followed by the text verbatim (carriage returns included).
//! A text that does not end with a newline is followed by the line `\ no newline at end`.
//!
//! To write the files anew after an intended change of behaviour:
//!
//! ```sh
//! PMACWD_BLESS=1 cargo test --release -p pmacwd-cli --test golden
//! ```
//!
//! then review the change with `git diff cli/tests/golden`.

mod common;

use common::TempDir;

use std::collections::BTreeSet;
use std::io::Read;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

/// One run of `pmacwd`. `<tmp>` in an argument stands for the test's temporary directory.
struct Case {
    /// The golden file's name (without `.txt`), read as a sentence.
    name: &'static str,
    args: &'static [&'static str],
    /// Normalizations beyond those every case gets.
    extra: &'static [Extra],
}

/// Normalizations that only some cases need.
#[derive(Clone, Copy, PartialEq)]
enum Extra {
    /// `pmacwd check: N runs from DIR, T threads`: T is the machine's core count when
    /// `--threads` is not given. Replaces T (regex on that line: `\d+ threads` ->
    /// `<threads> threads`).
    Threads,
    /// `depth N` of a model-checking run: with more than one checker thread, stateright's
    /// parallel breadth-first search reports a depth that varies from run to run (measured on 2
    /// cores: 25 or 26, 29 or 34, ... for the same run; the state counts do not vary). With
    /// `--threads 1` it is stable, so only cases that run several threads use this (regex:
    /// `depth \d+` -> `depth <depth>`). The cases with `--threads 1` pin every depth.
    Depth,
}

const fn case(name: &'static str, args: &'static [&'static str]) -> Case {
    Case { name, args, extra: &[] }
}

/// `pmacwd` alone, its help and version, and unknown subcommands.
const TOP_LEVEL: &[Case] = &[
    // The long help: the list of subcommands and the exit-code convention.
    case("the_long_help_lists_every_subcommand_and_the_exit_codes", &["--help"]),
    // The short help differs from the long one (no exit-code paragraph, one line per option).
    case("the_short_help_lists_every_subcommand", &["-h"]),
    // `help` with no subcommand prints the long help too.
    case("help_without_a_subcommand_prints_the_long_help", &["help"]),
    // The version line (the package version of the crate holding the binary).
    case("the_version_is_printed", &["--version"]),
    // No subcommand is a usage error: help on standard error, exit 2.
    case("no_arguments_prints_the_help_on_stderr_and_exits_2", &[]),
    // An unknown subcommand is a usage error, exit 2.
    case("an_unknown_subcommand_is_refused_with_exit_2", &["frobnicate"]),
    // A misspelt subcommand is refused with a suggestion of the right one.
    case("a_misspelt_subcommand_is_refused_with_a_suggestion", &["chek"]),
];

/// `help SUBCOMMAND` and `SUBCOMMAND --help` for every subcommand: the documented flags, their
/// defaults and descriptions.
const HELP: &[Case] = &[
    case("help_check_describes_the_model_check_and_its_flags", &["help", "check"]),
    case("check_dash_dash_help_describes_the_model_check_and_its_flags", &["check", "--help"]),
    case("help_run_describes_trace_runs_and_their_flags", &["help", "run"]),
    case("run_dash_dash_help_describes_trace_runs_and_their_flags", &["run", "--help"]),
    case("help_conform_describes_the_conformance_suite_and_its_flags", &["help", "conform"]),
    case("conform_dash_dash_help_describes_the_conformance_suite_and_its_flags", &["conform", "--help"]),
    case("help_requirements_describes_the_matrix_and_its_figures", &["help", "requirements"]),
    case("help_decode_describes_reply_decoding", &["help", "decode"]),
    case("decode_dash_dash_help_describes_reply_decoding", &["decode", "--help"]),
    case("help_replay_describes_capture_replay_and_its_formats", &["help", "replay"]),
    case("replay_dash_dash_help_describes_capture_replay_and_its_formats", &["replay", "--help"]),
    case("help_import_describes_host_log_import", &["help", "import"]),
    case("import_dash_dash_help_describes_host_log_import", &["import", "--help"]),
    case("help_serve_describes_the_emulator_and_its_defaults", &["help", "serve"]),
    case("serve_dash_dash_help_describes_the_emulator_and_its_defaults", &["serve", "--help"]),
    case("help_record_describes_the_recording_proxy", &["help", "record"]),
    case("help_explore_describes_the_explorer_and_its_defaults", &["help", "explore"]),
    case("explore_dash_dash_help_describes_the_explorer_and_its_defaults", &["explore", "--help"]),
    case("record_dash_dash_help_describes_the_recording_proxy", &["record", "--help"]),
];

const CHECK: &[Case] = &[
    // The README's first command: every run of check.yaml under every profile, then the
    // conformance summary (exhaustive product, scenarios on the core, 1,000 generated traces
    // with a fresh seed). Default threads: the thread count and the depths are normalized
    // (see `Extra`); the state counts and every verdict are pinned.
    Case {
        name: "check_of_the_embedded_specs_holds_everywhere_and_the_core_agrees",
        args: &["check"],
        extra: &[Extra::Threads, Extra::Depth],
    },
    // `check --no-conformance`: the same 25 runs, without the conformance summary. On one
    // thread, so that it pins every depth too (the default thread count is covered above).
    case("check_on_one_thread_without_conformance_pins_every_depth", &["check", "--no-conformance", "--threads", "1"]),
    // One small run with the shortest witness of every `sometimes` property. One thread, so
    // that the depth (and the choice among equally short witnesses) is stable.
    case(
        "check_of_one_run_with_witnesses_prints_each_shortest_witness",
        &["check", "--profile", "um-215", "--configuration", "lockout", "--witnesses", "--threads", "1"],
    ),
    // An unknown profile is unusable input: exit 2 naming the profiles there are.
    case("check_with_an_unknown_profile_exits_2_naming_the_profiles", &["check", "--profile", "nope"]),
    // An unknown configuration is unusable input: exit 2 naming the configurations there are.
    case(
        "check_with_an_unknown_configuration_exits_2_naming_the_configurations",
        &["check", "--configuration", "nope"],
    ),
    // A spec directory that does not exist: exit 2.
    case("check_of_a_missing_spec_directory_exits_2", &["check", "--specs", "<tmp>/no-such-specs"]),
];

/// The diverging trace `run` is given: a scenario whose `???` reply expectation is wrong.
const DIVERGING_TRACE: &str = "opening-a-motion-program-expecting-the-wrong-reply.yaml";

const RUN: &[Case] = &[
    // The whole scenario library under the profiles each scenario names: one line per
    // (scenario, profile) with its expectation count, then the tally.
    case("run_of_the_scenario_library_passes_every_scenario", &["run"]),
    // One scenario file under all profiles.
    case("run_of_one_scenario_passes_under_every_profile", &["run", "specs/scenarios/a-reset-clears-bit-22.yaml"]),
    // One scenario under one chosen profile.
    case(
        "run_of_one_scenario_under_one_profile_passes_once",
        &["run", "--profile", "srm-57", "specs/scenarios/a-reset-starts-x25-over-at-the-reset-value.yaml"],
    ),
    // The JSON Lines sample captures as one JSON document (docs/commands.md): both verdicts,
    // a divergence with its step and line, exit 1.
    case(
        "run_of_the_json_lines_captures_as_json_names_each_divergence",
        &["run", "--format", "json", "specs/captures/reload-to-4095.jsonl", "specs/captures/no-profile-explains.jsonl"],
    ),
    // A copy of a scenario with one expected reply changed (written by the test): the
    // divergence report (step, line, expected, observed, the events before it) and exit 1.
    case(
        "run_of_a_trace_with_a_wrong_expectation_reports_the_divergence_and_exits_1",
        &["run", "<tmp>/opening-a-motion-program-expecting-the-wrong-reply.yaml"],
    ),
    // A directory holding a trace that some profiles contradict (the 4096 capture): the
    // diverging profiles are reported, exit 1.
    case("run_of_the_captures_directory_diverges_under_the_4095_profiles", &["run", "specs/captures"]),
    // A path that does not exist: exit 2.
    case("run_of_a_missing_path_exits_2", &["run", "no-such-trace.yaml"]),
    // A profile that does not exist: exit 2.
    case(
        "run_under_an_unknown_profile_exits_2",
        &["run", "--profile", "nope", "specs/scenarios/a-reset-clears-bit-22.yaml"],
    ),
    // A file that is not a trace: exit 2 with the YAML error's position.
    case("run_of_a_file_that_is_not_a_trace_exits_2", &["run", "specs/captures/host-session.log"]),
];

const CONFORM: &[Case] = &[
    // The three parts of the suite and the coverage report, with a fixed seed so that the
    // generated traces, the event counts and the coverage counts are pinned; one thread so
    // that every depth of the exhaustive part is pinned as well.
    case(
        "conform_with_a_fixed_seed_covers_every_event_kind_without_divergence",
        &["conform", "--cases", "200", "--seed", "1", "--threads", "1"],
    ),
    // Without the exhaustive part: scenarios, generated traces and coverage only.
    case(
        "conform_without_the_exhaustive_part_runs_scenarios_and_generated_traces",
        &["conform", "--cases", "200", "--seed", "1", "--no-exhaustive"],
    ),
    // A scenario directory that does not exist: exit 2.
    case(
        "conform_with_a_missing_scenario_directory_exits_2",
        &["conform", "--cases", "1", "--seed", "1", "--scenarios", "<tmp>/no-such-scenarios"],
    ),
];

const DECODE: &[Case] = &[
    // A healthy card: only bit 12 (PROM checksum active), not flagged by the EPICS mask.
    case("decode_of_a_healthy_reply_names_bit_12", &["decode", "001000000000"]),
    case("decode_of_a_healthy_reply_as_json", &["decode", "001000000000", "--json"]),
    // A flash error: flagged by the EPICS hardware-problem mask.
    case("decode_of_a_flash_error_is_flagged_by_the_epics_mask", &["decode", "800400000000"]),
    case("decode_of_a_flash_error_as_json", &["decode", "800400000000", "--json"]),
    // The bootstrap reply has no status words.
    case("decode_of_bootstrap_prom_reports_bootstrap_mode", &["decode", "BOOTSTRAP PROM"]),
    case("decode_of_bootstrap_prom_as_json", &["decode", "BOOTSTRAP PROM", "--json"]),
    // An error reply, BEL ERRnnn CR, as the card sends it.
    case("decode_of_an_error_reply_explains_the_error_number", &["decode", "\u{7}ERR003\r"]),
    case("decode_of_an_error_reply_as_json", &["decode", "\u{7}ERR003\r", "--json"]),
    // A malformed reply: exit 2, with or without --json.
    case("decode_of_a_malformed_reply_exits_2", &["decode", "zzz"]),
    case("decode_of_a_malformed_reply_as_json_exits_2", &["decode", "zzz", "--json"]),
    // An error number as a log or a terminal writes it, without BEL and CR, is explained too.
    case("decode_of_an_error_number_as_a_log_writes_it_explains_it", &["decode", "ERR003"]),
    // No reply at all: a usage error.
    case("decode_without_a_reply_is_a_usage_error", &["decode"]),
];

/// `specs/captures/README.md` is left out: it is prose, not a capture, and pinning its
/// refusal would pin its whole text (serde reports it as a string).
const REPLAY: &[Case] = &[
    // A capture only the 4095 profiles explain: per-profile verdicts, the readings it
    // supports or rules out, exit 0.
    case("replay_of_the_4095_capture_rules_out_the_4096_reading", &["replay", "specs/captures/reload-to-4095.jsonl"]),
    case("replay_of_the_4095_capture_as_json", &["replay", "specs/captures/reload-to-4095.jsonl", "--format", "json"]),
    // The YAML capture only the 4096 profiles explain, exit 0.
    case("replay_of_the_4096_capture_rules_out_the_4095_reading", &["replay", "specs/captures/reload-to-4096.yaml"]),
    case("replay_of_the_4096_capture_as_json", &["replay", "specs/captures/reload-to-4096.yaml", "--format", "json"]),
    // A capture no profile explains: exit 1.
    case("replay_of_a_capture_no_profile_explains_exits_1", &["replay", "specs/captures/no-profile-explains.jsonl"]),
    case(
        "replay_of_a_capture_no_profile_explains_as_json_exits_1",
        &["replay", "specs/captures/no-profile-explains.jsonl", "--format", "json"],
    ),
    // A host log is imported on the fly and replayed with the log's own line numbers. Until
    // the replay search judges `elapsed` steps, the deterministic replay stops at the first.
    case("replay_of_a_host_log_imports_it_on_the_fly", &["replay", "specs/captures/host-session.log"]),
    // The EPICS IOC's trace has host stamps but no X:$0 read: every command is one instant.
    // Bit 12 of `???` changes between polls, which the search's passes of 1 and 2 background
    // cycles do not give at one instant (it was undecided); each poll is answered in a
    // background cycle of its own (UM p.236), and the card's passes are of its own length
    // (UM p.217 gives none), so the area at each read is the card's: explained.
    case(
        "replay_of_the_epics_asyn_trace_without_counter_reads_is_explained_by_passes_of_its_own_length",
        &["replay", "specs/captures/field/epics-asyn-trace.txt", "--host-time-seconds", "1"],
    ),
    case(
        "replay_of_the_tcpdump_capture_explains_the_trip_and_the_init",
        &["replay", "specs/captures/field/emulator-session.pcap", "--log-format", "pcap"],
    ),
    case(
        "replay_of_a_host_log_as_json_imports_it_on_the_fly",
        &["replay", "specs/captures/host-session.log", "--format", "json"],
    ),
    // A configuration for a trace, which names its own: exit 2.
    case(
        "replay_of_a_trace_with_a_configuration_is_refused_with_exit_2",
        &["replay", "specs/captures/reload-to-4095.jsonl", "--configuration", "i40-zero"],
    ),
    // A file that does not exist: exit 2.
    case("replay_of_a_missing_file_exits_2", &["replay", "no-such-capture.jsonl"]),
    // An unknown output format: a usage error.
    case(
        "replay_with_an_unknown_format_is_a_usage_error",
        &["replay", "specs/captures/reload-to-4095.jsonl", "--format", "xml"],
    ),
];

const IMPORT: &[Case] = &[
    // The sample host log as JSON Lines on standard output.
    case("import_of_the_host_log_writes_json_lines", &["import", "specs/captures/host-session.log"]),
    // The same as YAML.
    case("import_of_the_host_log_as_yaml", &["import", "specs/captures/host-session.log", "--yaml"]),
    // With --out: nothing on standard output, the step count on standard error.
    case(
        "import_to_a_file_reports_the_steps_written",
        &["import", "specs/captures/host-session.log", "--out", "<tmp>/imported.jsonl"],
    ),
    // An unknown configuration is refused before anything is written: the trace would name a
    // configuration that `replay` cannot find.
    case(
        "import_with_an_unknown_configuration_is_refused_with_exit_2",
        &["import", "specs/captures/host-session.log", "--configuration", "nope"],
    ),
    // A file that is not a host log: exit 2 with the line that is not one.
    case("import_of_a_file_that_is_not_a_host_log_exits_2", &["import", "specs/captures/README.md"]),
    // A file that does not exist: exit 2.
    case("import_of_a_missing_log_exits_2", &["import", "no-such-session.log"]),
    // The field's own records (specs/captures/field/README.md), each detected by its content.
    case(
        "import_of_an_epics_asyn_trace_reads_the_driver_s_exchanges_and_counts_what_it_passes_over",
        &["import", "specs/captures/field/epics-asyn-trace.txt", "--out", "<tmp>/asyn.jsonl"],
    ),
    case(
        "import_of_a_tcpdump_capture_of_port_1025_reads_each_getresponse",
        &["import", "specs/captures/field/emulator-session.pcap", "--out", "<tmp>/pcap.jsonl"],
    ),
    case(
        "import_of_an_asyn_trace_as_a_host_log_says_to_use_log_format_asyn",
        &["import", "specs/captures/field/epics-asyn-trace.txt", "--log-format", "host-log"],
    ),
    // `--format` names the trace written (jsonl, yaml), as every command's `--format` names its
    // output (issue 34); a kind of log there, what it meant before, says where it goes now.
    case(
        "import_with_a_kind_of_log_as_its_format_names_log_format",
        &["import", "specs/captures/field/epics-asyn-trace.txt", "--format", "asyn"],
    ),
    case(
        "import_of_the_host_log_with_format_yaml_is_the_yaml_form",
        &["import", "specs/captures/host-session.log", "--format", "yaml"],
    ),
];

/// Only the refusals: each of these exits before listening on any port.
const SERVE_AND_RECORD: &[Case] = &[
    case("serve_with_an_unknown_configuration_exits_2", &["serve", "--configuration", "nope"]),
    case("serve_with_an_unknown_profile_exits_2_naming_the_profiles", &["serve", "--profile", "nope"]),
    case("serve_with_a_saved_value_without_equals_exits_2", &["serve", "--saved", "I3"]),
    case("serve_with_a_saved_i_variable_beyond_i8191_exits_2", &["serve", "--saved", "I9999=1"]),
    case("serve_with_i40_out_of_range_exits_2", &["serve", "--saved", "I40=70000"]),
    case("serve_with_a_zero_servo_rate_exits_2", &["serve", "--servo-hz", "0"]),
    case(
        "serve_with_a_processor_that_is_no_turbo_pmac_cpu_option_exits_2_naming_the_four",
        &["serve", "--processor", "DSP56000"],
    ),
    case("serve_with_an_unparsable_listen_address_is_a_usage_error", &["serve", "--listen", "notanaddr"]),
    case("serve_with_an_unknown_flag_is_a_usage_error", &["serve", "--frob"]),
    case("record_without_arguments_is_a_usage_error_naming_the_required_flags", &["record"]),
    case(
        "record_with_control_listen_but_no_control_target_is_a_usage_error",
        &[
            "record",
            "--listen",
            "127.0.0.1:0",
            "--target",
            "127.0.0.1:1",
            "--out",
            "<tmp>/c.jsonl",
            "--control-listen",
            "127.0.0.1:0",
        ],
    ),
    case(
        "record_with_an_unknown_configuration_exits_2",
        &[
            "record",
            "--listen",
            "127.0.0.1:0",
            "--target",
            "127.0.0.1:1",
            "--out",
            "<tmp>/c.jsonl",
            "--configuration",
            "nope",
        ],
    ),
    case(
        "record_with_a_zero_servo_rate_exits_2",
        &["record", "--listen", "127.0.0.1:0", "--target", "127.0.0.1:1", "--out", "<tmp>/c.jsonl", "--servo-hz", "0"],
    ),
    case(
        "record_to_a_file_in_a_missing_directory_exits_2",
        &["record", "--listen", "127.0.0.1:0", "--target", "127.0.0.1:1", "--out", "<tmp>/no-such-dir/c.jsonl"],
    ),
];

/// `explore`'s refusals (a running Explorer is tested over HTTP in `cli/tests/explore.rs`).
const EXPLORE: &[Case] = &[
    case(
        "explore_with_an_unknown_configuration_exits_2_naming_the_configurations",
        &["explore", "--configuration", "nope", "--listen", "127.0.0.1:0"],
    ),
    case(
        "explore_with_an_unknown_profile_exits_2_naming_the_profiles",
        &["explore", "--profile", "nope", "--listen", "127.0.0.1:0"],
    ),
    case("explore_with_an_address_that_is_not_one_is_a_usage_error", &["explore", "--listen", "nowhere"]),
];

const ALL: &[&[Case]] = &[TOP_LEVEL, HELP, CHECK, RUN, CONFORM, DECODE, REPLAY, IMPORT, SERVE_AND_RECORD, EXPLORE];

#[test]
fn top_level() {
    verify("top-level", TOP_LEVEL, |_| {});
}

#[test]
fn help_of_every_subcommand() {
    verify("help", HELP, |_| {});
}

#[test]
fn check() {
    verify("check", CHECK, |_| {});
}

#[test]
fn run() {
    verify("run", RUN, |tmp| {
        let original = "specs/scenarios/opening-a-motion-program-sets-second-word-bit-19-until-close.yaml";
        let text = std::fs::read_to_string(repo_root().join(original)).unwrap();
        let wrong = text.replace("reply: \"001000080000\"", "reply: \"001000000000\"");
        assert_ne!(wrong, text, "the edit of {original} changed nothing");
        std::fs::write(tmp.join(DIVERGING_TRACE), wrong).unwrap();
    });
}

#[test]
fn conform() {
    verify("conform", CONFORM, |_| {});
}

#[test]
fn decode() {
    verify("decode", DECODE, |_| {});
}

#[test]
fn replay() {
    verify("replay", REPLAY, |_| {});
}

#[test]
fn import() {
    verify("import", IMPORT, |_| {});
}

#[test]
fn explore_refusals() {
    verify("explore", EXPLORE, |_| {});
}

#[test]
fn serve_and_record_refusals() {
    verify("serve-record", SERVE_AND_RECORD, |_| {});
}

/// Every golden file belongs to a case, and no two cases share a name: a renamed or removed
/// case leaves no stale file behind.
#[test]
fn every_golden_file_belongs_to_a_case() {
    let mut names = BTreeSet::new();
    for c in ALL.iter().flat_map(|g| g.iter()) {
        assert!(names.insert(c.name), "two cases are named {}", c.name);
    }
    if blessing() {
        return;
    }
    let files: BTreeSet<String> = std::fs::read_dir(golden_dir())
        .expect("cli/tests/golden exists (bless with PMACWD_BLESS=1)")
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    let expected: BTreeSet<String> = names.iter().map(|n| format!("{n}.txt")).collect();
    let stale: Vec<_> = files.difference(&expected).collect();
    let missing: Vec<_> = expected.difference(&files).collect();
    assert!(stale.is_empty(), "golden files without a case: {stale:?}");
    assert!(missing.is_empty(), "cases without a golden file (bless with PMACWD_BLESS=1): {missing:?}");
}

fn repo_root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("..")
}

fn golden_dir() -> PathBuf {
    repo_root().join("cli/tests/golden")
}

fn blessing() -> bool {
    std::env::var("PMACWD_BLESS").is_ok_and(|v| v == "1")
}

/// Runs every case of a group (after `setup` has prepared the temporary directory), then
/// either writes the golden files (PMACWD_BLESS=1) or compares with them and fails naming
/// every case that differs, with its first differing line.
fn verify(group: &str, cases: &[Case], setup: impl FnOnce(&Path)) {
    let tmp = TempDir::new(&format!("golden-{group}"));
    setup(&tmp.0);
    let mut failures = Vec::new();
    for c in cases {
        let observed = observe(c, &tmp.0);
        let path = golden_dir().join(format!("{}.txt", c.name));
        if blessing() {
            std::fs::create_dir_all(golden_dir()).unwrap();
            std::fs::write(&path, &observed).unwrap();
            continue;
        }
        match std::fs::read_to_string(&path) {
            Ok(expected) if expected == observed => {}
            Ok(expected) => failures.push(format!("{}\n{}", path.display(), first_difference(&expected, &observed))),
            Err(e) => failures.push(format!("{}: {e} (bless with PMACWD_BLESS=1)", path.display())),
        }
    }
    assert!(
        failures.is_empty(),
        "{} of {} cases differ from their golden files \
         (if the change is intended: PMACWD_BLESS=1 cargo test --release -p pmacwd-cli --test golden):\n\n{}",
        failures.len(),
        cases.len(),
        failures.join("\n\n")
    );
}

/// Longest a case may run before it is killed (a refusal that unexpectedly starts a server
/// would otherwise hang the test).
const TIMEOUT: Duration = Duration::from_secs(300);

/// Runs one case from the repository root and renders it as its golden file, normalized.
fn observe(c: &Case, tmp: &Path) -> String {
    let tmp_text = tmp.display().to_string();
    let args: Vec<String> = c.args.iter().map(|a| a.replace("<tmp>", &tmp_text)).collect();
    let mut child = Command::new(env!("CARGO_BIN_EXE_pmacwd"))
        .args(&args)
        .current_dir(repo_root())
        // clap colours its messages only on a terminal or when forced.
        .env_remove("CLICOLOR_FORCE")
        .env("NO_COLOR", "1")
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("pmacwd starts");
    let read = |mut pipe: Box<dyn Read + Send>| {
        std::thread::spawn(move || {
            let mut bytes = Vec::new();
            pipe.read_to_end(&mut bytes).unwrap();
            bytes
        })
    };
    let stdout = read(Box::new(child.stdout.take().unwrap()));
    let stderr = read(Box::new(child.stderr.take().unwrap()));
    let start = Instant::now();
    let status = loop {
        if let Some(status) = child.try_wait().unwrap() {
            break status;
        }
        if start.elapsed() > TIMEOUT {
            let _ = child.kill();
            let _ = child.wait();
            panic!("{}: pmacwd {args:?} still running after {TIMEOUT:?}; killed", c.name);
        }
        std::thread::sleep(Duration::from_millis(10));
    };
    let stdout = String::from_utf8_lossy(&stdout.join().unwrap()).into_owned();
    let stderr = String::from_utf8_lossy(&stderr.join().unwrap()).into_owned();
    let exit = status.code().map_or_else(|| format!("killed ({status})"), |c| c.to_string());
    let command: String = c.args.iter().map(|a| format!(" {}", shell_word(a))).collect();
    let text = format!(
        "command: pmacwd{command}\nexit: {exit}\n--- stdout\n{}--- stderr\n{}",
        section(&stdout),
        section(&stderr)
    );
    normalize(&text.replace(&tmp_text, "<tmp>"), c.extra)
}

/// An argument as it would be typed: bare when plain, else quoted with Rust escapes.
fn shell_word(a: &str) -> String {
    if !a.is_empty() && a.chars().all(|ch| ch.is_ascii_alphanumeric() || "-_./:=<>".contains(ch)) {
        a.to_string()
    } else {
        format!("{a:?}")
    }
}

/// A captured text with its end marked when it has no final newline.
fn section(text: &str) -> String {
    if text.is_empty() || text.ends_with('\n') {
        text.to_string()
    } else {
        format!("{text}\n\\ no newline at end\n")
    }
}

/// The normalizations every case gets (the harness uses no regex crate; each is written out
/// by hand and documented by the regex it implements):
///
/// 1. the temporary directory's path -> `<tmp>` (done in [`observe`]; literal replacement);
/// 2. durations: `\b\d+\.\d+ s\b` -> `<time>`. Every duration pmacwd prints is wall-clock
///    time formatted `{:.1}` or `{:.2}` and followed by ` s` (a run's `0.15 s`, `total: ...
///    in 3.50 s`, the conformance summary's `(7.8 s)`, conform's `total 9.3 s`). Integers
///    are never touched, so no count is masked;
/// 3. rates: `\b[\d,]+ states/s` -> `<rate>` (states per second of wall-clock time,
///    printed with and without thousands separators);
/// 4. on the conformance-summary line of `check` only (`  generated: ...`), which always
///    uses a fresh seed (the time in nanoseconds; `check` has no flag to fix it):
///    `seed \d+` -> `seed <seed>` and `\d+ events` -> `<events> events` (the event count
///    depends on the seed; the trace count, 1000, stays pinned). conform's seed is fixed by
///    `--seed` and stays pinned.
fn normalize(text: &str, extra: &[Extra]) -> String {
    let mut lines = Vec::new();
    for line in text.split_inclusive('\n') {
        // Plain progress lines (`cli/src/progress.rs`) come every few seconds of a long phase:
        // how many a run prints depends on the machine's speed and load, so they are dropped.
        // `cli/tests/cli.rs` checks what they say and that they are whole lines.
        if line.starts_with("progress: ") {
            continue;
        }
        let mut line = line.to_string();
        if line.starts_with("  generated: ") {
            line = replace_after(&line, "seed ", "<seed>");
            line = replace_before(&line, " events", "<events>", false, Unit::Kept);
        }
        if extra.contains(&Extra::Threads) && line.starts_with("pmacwd check: ") {
            line = replace_before(&line, " threads", "<threads>", false, Unit::Kept);
        }
        if extra.contains(&Extra::Depth) {
            line = replace_after(&line, "depth ", "<depth>");
        }
        lines.push(line);
    }
    let text = lines.concat();
    let text = replace_before(&text, " states/s", "<rate>", false, Unit::Replaced);
    replace_before(&text, " s", "<time>", true, Unit::Replaced)
}

/// Whether [`replace_before`] replaces the suffix along with the number.
#[derive(Clone, Copy, PartialEq)]
enum Unit {
    Kept,
    Replaced,
}

fn is_word(ch: char) -> bool {
    ch.is_alphanumeric() || ch == '_'
}

/// Replaces the number right before each `suffix` (a run of digits and commas or, when
/// `decimal`, of digits holding exactly one decimal point) with `placeholder`, when the number
/// starts at a word boundary and the suffix ends at one; the suffix too when `Unit::Replaced`.
fn replace_before(text: &str, suffix: &str, placeholder: &str, decimal: bool, unit: Unit) -> String {
    let mut out = String::new();
    let mut done = 0;
    for (at, _) in text.match_indices(suffix) {
        let end = at + suffix.len();
        if text[end..].chars().next().is_some_and(is_word) || at < done {
            continue;
        }
        let class = |ch: char| ch.is_ascii_digit() || if decimal { ch == '.' } else { ch == ',' };
        let start = text[done..at].rfind(|ch: char| !class(ch)).map_or(done, |i| {
            let i = done + i;
            i + text[i..].chars().next().unwrap().len_utf8()
        });
        let number = &text[start..at];
        let bounded = text[..start].chars().next_back().is_none_or(|ch| !is_word(ch));
        let well_formed = number.starts_with(|ch: char| ch.is_ascii_digit())
            && number.ends_with(|ch: char| ch.is_ascii_digit())
            && (!decimal || number.matches('.').count() == 1);
        if bounded && well_formed {
            out.push_str(&text[done..start]);
            out.push_str(placeholder);
            done = if unit == Unit::Replaced { end } else { at };
        }
    }
    out.push_str(&text[done..]);
    out
}

/// Replaces the digits right after each `prefix` that starts at a word boundary with
/// `placeholder` (any spaces between keep their place: conform pads its depths).
fn replace_after(text: &str, prefix: &str, placeholder: &str) -> String {
    let mut out = String::new();
    let mut done = 0;
    for (at, _) in text.match_indices(prefix) {
        if at < done || text[..at].chars().next_back().is_some_and(is_word) {
            continue;
        }
        let after = at + prefix.len();
        let spaces = text[after..].len() - text[after..].trim_start_matches(' ').len();
        let digits_start = after + spaces;
        let digits =
            text[digits_start..].len() - text[digits_start..].trim_start_matches(|ch: char| ch.is_ascii_digit()).len();
        if digits > 0 && !text[digits_start + digits..].chars().next().is_some_and(is_word) {
            out.push_str(&text[done..digits_start]);
            out.push_str(placeholder);
            done = digits_start + digits;
        }
    }
    out.push_str(&text[done..]);
    out
}

/// The first line where the two texts differ, with its number and a little context.
fn first_difference(expected: &str, observed: &str) -> String {
    let e: Vec<&str> = expected.split_inclusive('\n').collect();
    let o: Vec<&str> = observed.split_inclusive('\n').collect();
    let n = e.iter().zip(&o).take_while(|(a, b)| a == b).count();
    let mut s = String::new();
    let from = n.saturating_sub(2);
    for (k, line) in e[from..n].iter().enumerate() {
        s.push_str(&format!("   {:>5} | {line:?}\n", from + k + 1));
    }
    let show = |l: Option<&&str>| l.map_or("(end of text)".to_string(), |l| format!("{l:?}"));
    s.push_str(&format!("  first difference at line {}:\n", n + 1));
    s.push_str(&format!("    expected {}\n", show(e.get(n))));
    s.push_str(&format!("    observed {}\n", show(o.get(n))));
    s.push_str(&format!("  ({} lines expected, {} observed)", e.len(), o.len()));
    s
}

#[test]
fn the_normalizations_replace_only_what_they_document() {
    let n = |t: &str| normalize(t, &[]);
    assert_eq!(
        n("   57,536 states, depth 25, 0.15 s, 389,501 states/s\n"),
        "   57,536 states, depth 25, <time>, <rate>\n"
    );
    assert_eq!(
        n("total: 660725 states in 3.50 s (188562 states/s); ok\n"),
        "total: 660725 states in <time> (<rate>); ok\n"
    );
    assert_eq!(
        n("no divergence (0.3 s with coverage bookkeeping)\n"),
        "no divergence (<time> with coverage bookkeeping)\n"
    );
    // Integers before ` s` and decimals not followed by ` s` are kept.
    assert_eq!(n("3 s, 1.947 so, v1.2 s, 4300 servo\n"), "3 s, 1.947 so, v1.2 s, 4300 servo\n");
    assert_eq!(
        n("  generated: 1000 traces, 363300 events, seed 1795424004729538968, no divergence (1.2 s)\n"),
        "  generated: 1000 traces, <events> events, seed <seed>, no divergence (<time>)\n"
    );
    // conform's seed and event counts are pinned.
    assert_eq!(
        n("seed 1 (repeat with --seed 1); 200 traces\n200 traces, 71500 events\n"),
        "seed 1 (repeat with --seed 1); 200 traces\n200 traces, 71500 events\n"
    );
    assert_eq!(
        normalize("pmacwd check: 25 runs from specs, 2 threads\n   3,408 states, depth 23, 0.01 s\nok  x  3578 pair states, depth  23, 0.50 s\n", &[Extra::Threads, Extra::Depth]),
        "pmacwd check: 25 runs from specs, <threads> threads\n   3,408 states, depth <depth>, <time>\nok  x  3578 pair states, depth  <depth>, <time>\n"
    );
}
