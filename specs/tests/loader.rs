//! The spec loader: the shipped facts load and say what the manuals say, and every kind of
//! broken input is refused with the position of the problem.

use pmacwd_specs::facts::StopScope;
use pmacwd_specs::status::{Latch, WordId};
use pmacwd_specs::{Position, Spec, SpecError};
use std::path::{Path, PathBuf};

fn specs_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).to_path_buf()
}

/// Loads a copy of the shipped spec directory with `edit` applied to `file`.
fn load_edited(tag: &str, file: &str, edit: impl Fn(&str) -> String) -> (Result<Spec, SpecError>, String) {
    let dir = std::env::temp_dir().join(format!("pmacwd-specs-{}-{tag}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    let mut edited = String::new();
    for f in Spec::file_names() {
        let text = std::fs::read_to_string(specs_dir().join(f)).unwrap();
        let text = if f == file {
            let e = edit(&text);
            assert_ne!(e, text, "the edit must change {file}");
            edited = e.clone();
            e
        } else {
            text
        };
        std::fs::write(dir.join(f), text).unwrap();
    }
    let result = Spec::load_dir(&dir);
    let _ = std::fs::remove_dir_all(&dir);
    (result, edited)
}

fn line_of(text: &str, needle: &str) -> usize {
    text.lines().position(|l| l.contains(needle)).unwrap_or_else(|| panic!("`{needle}` not in the edited file")) + 1
}

fn expect_error(result: Result<Spec, SpecError>, line: usize, message_part: &str) -> SpecError {
    let err = result.expect_err("the broken spec must be refused");
    assert_eq!(err.position.map(|p| p.line), Some(line), "{err}");
    assert!(err.message.contains(message_part), "{err}");
    err
}

#[test]
fn the_embedded_specs_and_the_directory_on_disk_are_the_same_and_load() {
    let embedded = Spec::embedded().unwrap();
    let disk = Spec::load_dir(&specs_dir()).unwrap();
    assert_eq!(format!("{:?}", embedded.status), format!("{:?}", disk.status));
    assert_eq!(format!("{:?}", embedded.profiles), format!("{:?}", disk.profiles));
}

#[test]
fn loading_the_specs_parses_each_file_once_and_the_embedded_copy_once_per_process() {
    // Issue 32: the requirements' `spec` references parsed their file again each (125
    // references, 134 documents for 9 files: 84% of every command's start-up). The parser
    // counts the documents it reads on this thread.
    let before = pmacwd_specs::yaml::documents_parsed();
    Spec::load_dir(&specs_dir()).unwrap();
    let parsed = pmacwd_specs::yaml::documents_parsed() - before;
    assert_eq!(parsed, Spec::file_names().count() as u64, "YAML documents parsed to load the spec directory");
    Spec::embedded().unwrap();
    let before = pmacwd_specs::yaml::documents_parsed();
    let again = Spec::embedded().unwrap();
    assert_eq!(pmacwd_specs::yaml::documents_parsed() - before, 0, "the embedded spec is parsed once per process");
    assert_eq!(again.requirements.statements.len(), Spec::embedded().unwrap().requirements.statements.len());
}

#[test]
fn the_i_variables_say_what_srm_p57_says() {
    let spec = Spec::embedded().unwrap();
    let iv = &spec.variables.i_variables;
    assert_eq!((iv.i40.range.min, iv.i40.range.max, iv.i40.default), (0, 65_535, 0));
    assert_eq!((iv.i41.range.min, iv.i41.range.max, iv.i41.default), (0, 15, 0));
    assert_eq!((iv.i8.range.min, iv.i8.range.max), (0, 255));
    let ranges: Vec<(u8, u16, u16)> = spec.variables.lockout.iter().map(|r| (r.bit, r.first, r.last)).collect();
    assert_eq!(ranges, [(0, 100, 4899), (1, 5100, 6699), (2, 6800, 7999), (3, 8000, 8191)]);
    assert_eq!(spec.variables.lockout_bit(130), Some(0));
    assert_eq!(spec.variables.lockout_bit(41), None, "I41 never locks itself");
}

#[test]
fn all_48_status_bits_are_described_and_the_model_driven_ones_sit_where_srm_p289_puts_them() {
    let spec = Spec::embedded().unwrap();
    assert_eq!(spec.status.words.x.bits.len() + spec.status.words.y.bits.len(), 48);
    for (name, word, bit) in [
        ("rti_reentry", WordId::X, 22),
        ("servo_error", WordId::X, 20),
        ("checksum_error", WordId::X, 13),
        ("prom_checksum_active", WordId::X, 12),
        ("dpram_error", WordId::X, 11),
        ("flash_error", WordId::X, 10),
        ("rti_warning", WordId::X, 9),
        ("motion_buffer_open", WordId::Y, 19),
        ("plc_buffer_open", WordId::Y, 17),
    ] {
        assert_eq!(spec.status.bit(name), Some((word, bit)), "{name}");
    }
    assert_eq!(spec.status.entry(WordId::X, 22).unwrap().latch, Latch::Sticky, "SRM p.289: bit 22 stays at 1");
    assert_eq!(spec.status.reply.bootstrap_reply, "BOOTSTRAP PROM");
}

#[test]
fn the_stop_table_has_its_11_rows_with_the_lost_commands_marked_reconstructed() {
    let spec = Spec::embedded().unwrap();
    let rows = &spec.stop_commands.rows;
    let commands: Vec<&str> = rows.iter().map(|r| r.command.as_str()).collect();
    // The sixth row is `/`, stop at the end of the currently executing move (FACTS s.5); `S` is
    // the single-step command that starts a program (UM p.319) and must not be in this table.
    assert_eq!(commands, ["J/", "A", "<CTRL-A>", "Q", "<CTRL-Q>", "/", "H", "<CTRL-O>", "\\", "K", "<CTRL-K>"]);
    assert!(!commands.contains(&"S"), "S starts a program (UM p.319); it stops nothing");
    let reconstructed: Vec<&str> =
        rows.iter().filter(|r| r.command_reconstructed).map(|r| r.command.as_str()).collect();
    assert_eq!(reconstructed, ["A", "Q", "/", "H", "\\", "K"]);
    assert!(rows.iter().filter(|r| r.command.starts_with("<CTRL")).all(|r| r.scope == StopScope::Global));
}

#[test]
fn every_reading_of_section_6_is_covered_and_the_default_profile_gives_its_reason() {
    let spec = Spec::embedded().unwrap();
    let d = spec.profiles.default_profile();
    assert_eq!(d.name, "um-215");
    assert!(spec.profiles.profiles[&d.name].reason.as_deref().unwrap().contains("UM p.215"));
    // Both options of every reading are chosen by some profile, so each can be checked.
    let all = spec.profiles.all();
    assert!(
        all.iter().map(|p| p.choices.reset_value_when_i40_zero).collect::<std::collections::BTreeSet<_>>().len() == 2
    );
    assert!(all.iter().map(|p| p.choices.strobe_stop).collect::<std::collections::BTreeSet<_>>().len() == 2);
    assert!(all.iter().map(|p| p.choices.strober).collect::<std::collections::BTreeSet<_>>().len() == 2);
    assert!(all.iter().map(|p| p.choices.bit12_meaning).collect::<std::collections::BTreeSet<_>>().len() == 2);
    assert!(all.iter().map(|p| p.choices.encoder_loss_clear).collect::<std::collections::BTreeSet<_>>().len() == 2);
    assert!(all.iter().map(|p| p.choices.strobe_hz_min).collect::<std::collections::BTreeSet<_>>().len() == 2);
    assert!(all.iter().map(|p| p.choices.rti_warning_latch).collect::<std::collections::BTreeSet<_>>().len() == 2);
    assert!(all.iter().map(|p| p.choices.strobe_detector).collect::<std::collections::BTreeSet<_>>().len() == 2);
    // Every profile but one keeps the half-period detector its delays had before the reading.
    assert_eq!(
        all.iter()
            .filter(|p| p.choices.strobe_detector == pmacwd_specs::profiles::StrobeDetector::FullPeriod)
            .map(|p| p.name.as_str())
            .collect::<Vec<_>>(),
        ["um-215-full-period"]
    );
}

#[test]
fn a_profile_that_skips_a_reading_is_refused_instead_of_defaulted() {
    let (r, text) = load_edited("skip", "profiles.yaml", |t| t.replacen("      rti_warning_latch: level\n", "", 1));
    let err = r.unwrap_err();
    assert!(err.message.contains("missing field `rti_warning_latch`"), "{err}");
    assert!(err.position.is_some() && err.position.unwrap().line < line_of(&text, "srm-57:"), "{err}");
}

#[test]
fn two_default_profiles_are_refused_at_the_second() {
    let (r, text) =
        load_edited("twodefaults", "profiles.yaml", |t| t.replacen("  srm-57:\n", "  srm-57:\n    default: true\n", 1));
    let line = line_of(&text, "  srm-57:") + 1;
    expect_error(r, line, "more than one profile is the default");
}

#[test]
fn an_unknown_citation_source_is_refused_at_the_citation() {
    let (r, text) = load_edited("cite", "watchdog.yaml", |t| t.replacen("cite: UM p.215", "cite: Manual p.215", 1));
    let line = line_of(&text, "cite: Manual p.215");
    expect_error(r, line, "unknown source `Manual`");
}

#[test]
fn a_status_word_with_a_missing_bit_is_refused_naming_the_missing_bit() {
    let (r, _) = load_edited("missingbit", "status.yaml", |t| {
        let start = t.find("      18:\n").unwrap();
        let end = t[start..].find("      17:\n").unwrap() + start;
        format!("{}{}", &t[..start], &t[end..])
    });
    let err = r.unwrap_err();
    assert!(err.message.contains("missing: 18"), "{err}");
}

#[test]
fn a_status_bit_name_used_twice_is_refused_at_the_second_use() {
    let (r, text) = load_edited("dupname", "status.yaml", |t| t.replacen("name: reserved_x18", "name: rti_reentry", 1));
    let line = line_of(&text, "name: rti_reentry");
    let second = text.lines().enumerate().filter(|(_, l)| l.contains("name: rti_reentry")).nth(1).unwrap().0 + 1;
    assert!(second > line);
    expect_error(r, second, "already used by words.X.bits.22");
}

#[test]
fn a_default_outside_its_range_and_a_lockout_overlap_are_refused() {
    let (r, text) =
        load_edited("default", "variables.yaml", |t| t.replacen("    default: 2\n", "    default: 300\n", 1));
    expect_error(r, line_of(&text, "default: 300"), "default 300 is outside its range");
    let (r, text) = load_edited("overlap", "variables.yaml", |t| t.replacen("first: 5100", "first: 4800", 1));
    expect_error(r, line_of(&text, "first: 4800"), "overlaps lockout.0");
}

#[test]
fn a_servo_clock_outside_the_range_of_scheduling_yaml_is_refused_at_its_line() {
    // Issue 15: `servo_hz: 4294967295` in check.yaml ran for about an hour (the hardware delay
    // derived from it is tens of millions of cycles). check.yaml's servo clocks, and the
    // default of scheduling.yaml itself, must lie in scheduling.yaml's servo_clock_hz_range.
    let spec = Spec::load_dir(&specs_dir()).unwrap();
    let range = &spec.scheduling.servo_clock_hz_range;
    assert!(range.contains(2250), "the manual's default, 2.25 kHz (UM p.236)");
    for hz in [0, range.max + 1, u32::MAX] {
        let (r, text) =
            load_edited("servo-hz", "check.yaml", |t| t.replacen("servo_hz: 2250", &format!("servo_hz: {hz}"), 1));
        let e = expect_error(r, line_of(&text, &format!("servo_hz: {hz}")), "servo_clock_hz_range");
        assert!(e.message.contains(&format!("servo_hz {hz} is outside")), "{e}");
        assert_eq!(e.position.map(|p| p.column), Some(5), "the column of the key, as every loader error: {e}");
    }
    let (r, text) = load_edited("servo-default", "scheduling.yaml", |t| t.replacen("value: 2250", "value: 200000", 1));
    expect_error(r, line_of(&text, "value: 200000"), "outside the servo clock range");
    let (r, text) = load_edited("servo-range", "scheduling.yaml", |t| t.replacen("  min: 1\n", "  min: 0\n", 1));
    expect_error(r, line_of(&text, "servo_clock_hz_range:"), "no range of servo clocks");
}

#[test]
fn a_stray_yaml_file_in_the_spec_directory_is_refused_rather_than_ignored() {
    let dir = std::env::temp_dir().join(format!("pmacwd-specs-{}-stray", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    for f in Spec::file_names() {
        std::fs::copy(specs_dir().join(f), dir.join(f)).unwrap();
    }
    std::fs::write(dir.join("extra.yaml"), "a: 1\n").unwrap();
    let err = Spec::load_dir(&dir).unwrap_err();
    let _ = std::fs::remove_dir_all(&dir);
    assert!(err.file.ends_with("extra.yaml") && err.message.contains("unexpected spec file"), "{err}");
    assert_eq!(err.position, None::<Position>);
}

#[test]
fn a_spec_file_that_is_not_a_regular_file_is_refused_not_read_or_skipped() {
    // A FIFO named like a spec file used to block forever, a symlink to /dev/zero to read until
    // memory ran out, and a directory named `*.yaml` was skipped silently. Each is an error
    // naming the file and what it is.
    type Make = fn(&Path);
    let cases: [(&str, Make); 3] = [
        ("fifo", |p| {
            let ok = std::process::Command::new("mkfifo").arg(p).status().is_ok_and(|s| s.success());
            assert!(ok, "mkfifo");
        }),
        ("device", |p| std::os::unix::fs::symlink("/dev/zero", p).unwrap()),
        ("directory", |p| std::fs::create_dir(p).unwrap()),
    ];
    for (tag, make) in cases {
        let dir = std::env::temp_dir().join(format!("pmacwd-specs-{}-{tag}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).unwrap();
        for f in Spec::file_names() {
            if f != "status.yaml" {
                std::fs::copy(specs_dir().join(f), dir.join(f)).unwrap();
            }
        }
        make(&dir.join("status.yaml"));
        let e = Spec::load_dir(&dir).unwrap_err();
        let _ = std::fs::remove_dir_all(&dir);
        assert!(e.to_string().contains("status.yaml"), "{tag}: {e}");
        assert!(e.message.contains("not a regular file"), "{tag}: {e}");
    }
}

#[test]
fn a_spec_file_cut_off_mid_line_is_refused_at_its_last_line_not_past_it() {
    // Found by the fuzz target spec_loader: check.yaml cut off after `commands:ld be used to d`
    // (no final line break) was refused at line 273 of a 272-line file.
    let (result, edited) = load_edited("cut-off", "check.yaml", |t| {
        let at = t.find("    commands:").expect("check.yaml has commands");
        format!("{}commands:ld be used to d", &t[..at + 4])
    });
    let last = edited.lines().count();
    let e = expect_error(result, last, "YAML syntax");
    assert_eq!(e.position.map(|p| p.column), Some(edited.lines().last().unwrap().chars().count() + 1), "{e}");
}

#[test]
fn an_approximate_hardware_figure_needs_a_band_that_holds_its_stated_value() {
    // UM p.215 gives the supply and strobe minimums only "about"/"approximately": replay
    // searches a band around each, so a band that is missing, or that leaves out the manual's
    // own figure, is refused where it is written.
    let (r, text) = load_edited("noband", "watchdog.yaml", |t| {
        let start = t.find("    interval:\n      min: 4.65").unwrap();
        let end = start + t[start..].find("  strobe_hz_min:").unwrap();
        format!("{}{}", &t[..start], &t[end..])
    });
    expect_error(r, line_of(&text, "supply_volts_min:"), "an `interval`");
    let (r, text) = load_edited("badband", "watchdog.yaml", |t| t.replacen("min: 20\n", "min: 26\n", 1));
    expect_error(r, line_of(&text, "min: 26") - 1, "must be positive and hold the stated value 25");
}

#[test]
fn a_requirement_whose_spec_key_does_not_exist_is_refused_where_the_reference_is_written() {
    let (r, text) = load_edited("reqkey", "requirements.yaml", |t| {
        t.replacen("spec: watchdog.yaml#rules.two_conditions", "spec: watchdog.yaml#rules.three_conditions", 1)
    });
    expect_error(r, line_of(&text, "rules.three_conditions"), "`rules.three_conditions` is not a key of watchdog.yaml");
    let (r, text) = load_edited("reqfile", "requirements.yaml", |t| {
        t.replacen("spec: watchdog.yaml#rules.two_conditions", "spec: watchdogs.yaml#rules.two_conditions", 1)
    });
    expect_error(r, line_of(&text, "watchdogs.yaml#"), "no spec file `watchdogs.yaml`");
}

#[test]
fn a_requirement_with_neither_a_check_nor_a_reason_is_refused() {
    // A statement that loses its last property, scenario and test must say why (data only,
    // missing, deviation) instead of passing as covered.
    let (r, text) = load_edited("reqnocheck", "requirements.yaml", |t| {
        t.replacen("      - property: a checksum error stops both checksums\n", "", 1)
    });
    expect_error(
        r,
        line_of(&text, "id: um217_firmware_mismatch_stops_checksums"),
        "no property, scenario or test checks this statement",
    );
    // A statement said to hold by definition must still name the checks that hold so.
    let (r, text) = load_edited("reqbydef", "requirements.yaml", |t| {
        t.replacen("      - property: a tripped Turbo PMAC2 changes its watchdog relay over\n", "", 1).replacen(
            "  - id: um215_drop_amplifier_power\n",
            "    status: by_definition\n  - id: um215_drop_amplifier_power\n",
            1,
        )
    });
    expect_error(r, line_of(&text, "id: um215_pmac2_relay"), "`status: by_definition` names the checks");
    // No statement is data only any more (issue 34): one is made so, without its spec keys.
    let (r, text) = load_edited("reqdataonly", "requirements.yaml", |t| {
        let start = t.find("  - id: srm289_x23_reserved\n").expect("the X23 statement");
        let end = start + t[start..].find("  - id: srm289_x22_rti_reentry\n").expect("the X22 statement after it");
        format!(
            "{}  - id: srm289_x23_reserved\n    source: SRM p.289\n    quote: \"Bit 23 (Reserved for future use)\"\n    status: data_only\n{}",
            &t[..start],
            &t[end..]
        )
    });
    expect_error(r, line_of(&text, "id: srm289_x23_reserved"), "`status: data_only` lists the spec keys");
    let (r, text) = load_edited("reqtwokeys", "requirements.yaml", |t| {
        t.replacen(
            "      - property: a tripped card lights the red watchdog LED\n",
            "      - {property: a tripped card lights the red watchdog LED, scenario: x}\n",
            1,
        )
    });
    expect_error(r, line_of(&text, "scenario: x}"), "exactly one of the keys");
    let (r, text) = load_edited("reqsource", "requirements.yaml", |t| {
        t.replacen("  - id: um215_red_led\n    source: UM p.215\n", "  - id: um215_red_led\n    source: MODEL\n", 1)
    });
    expect_error(r, line_of(&text, "source: MODEL"), "a statement's source is a manual page");
}

#[test]
fn a_requirement_gives_either_the_quote_or_a_summary() {
    // The seed pages are quoted, the pages read beyond them summarized; a statement with both
    // would be ambiguous about which words are the manual's, and one with neither states
    // nothing to check against its page.
    let (r, text) = load_edited("reqboth", "requirements.yaml", |t| {
        t.replacen(
            "    summary: >\n      The data gathering function",
            "    quote: invented\n    summary: >\n      The data gathering function",
            1,
        )
    });
    expect_error(r, line_of(&text, "id: um240_data_gathering_times_background"), "give a quote or a summary, not both");
    let (r, text) = load_edited("reqneither", "requirements.yaml", |t| {
        t.replacen(
            "    summary: >\n      The data gathering function is the suggested way to find out how long background cycles\n      take.\n",
            "",
            1,
        )
    });
    expect_error(r, line_of(&text, "id: um240_data_gathering_times_background"), "give the `quote`");
}

#[test]
fn a_processor_that_is_not_a_turbo_pmac_cpu_option_is_refused_at_its_line_naming_the_four() {
    // SRM p.289: the CPU type bits of ??? tell four DSP56300-family options apart; a
    // configuration names one of them, and a misspelt one is an error, not DSP56303.
    let (result, edited) =
        load_edited("processor", "check.yaml", |t| t.replacen("processor: DSP56321", "processor: DSP56300", 1));
    let err = expect_error(result, line_of(&edited, "processor: DSP56300"), "DSP56300");
    for option in ["DSP56303", "DSP56309", "DSP56311", "DSP56321"] {
        assert!(err.message.contains(option), "{err}");
    }
}

#[test]
fn a_processor_name_is_read_with_or_without_its_dsp_prefix_and_anything_else_says_the_four() {
    use pmacwd_specs::check::Processor;
    assert_eq!(Processor::parse("dsp56321"), Ok(Processor::Dsp56321));
    assert_eq!(Processor::parse("56309"), Ok(Processor::Dsp56309));
    let err = Processor::parse("56000").unwrap_err();
    assert!(err.contains("DSP56303, DSP56309, DSP56311, DSP56321 (SRM p.289)"), "{err}");
}
