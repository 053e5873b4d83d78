//! The scenario library of `specs/scenarios/`: each file is one sentence of the manuals told
//! as a trace with expected observations. Every scenario must hold on the reference model under
//! each profile it names.

use pmacwd_conformance::runner::{profiles_of, run_on_model, Failure};
use pmacwd_specs::Spec;
use pmacwd_trace::{load_yaml, parse_yaml, to_yaml};
use std::path::{Path, PathBuf};

fn scenario_files() -> Vec<PathBuf> {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../specs/scenarios");
    let mut files: Vec<PathBuf> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "yaml"))
        .collect();
    files.sort();
    files
}

#[test]
fn every_scenario_holds_on_the_model_under_every_profile_it_names() {
    let spec = Spec::embedded().unwrap();
    let files = scenario_files();
    assert!(files.len() >= 30, "the library needs at least 30 scenarios; it has {}", files.len());
    let mut failures = Vec::new();
    let mut checked = 0;
    for file in &files {
        let loaded = load_yaml(file).unwrap_or_else(|e| panic!("{e}"));
        assert!(loaded.trace.cite.is_some(), "{}: a scenario cites its sentence", file.display());
        for profile in profiles_of(&spec, &loaded).unwrap() {
            match run_on_model(&spec, &loaded, &profile) {
                Ok(n) => {
                    assert!(n > 0, "{}: a scenario must expect something", file.display());
                    checked += n;
                }
                Err(Failure::Unusable(e)) => failures.push(format!("{}: {e}", file.display())),
                Err(Failure::Diverged(d)) => failures.push(format!("{} under {}: {d}", file.display(), profile.name)),
            }
        }
    }
    assert!(failures.is_empty(), "{} failures:\n{}", failures.len(), failures.join("\n"));
    assert!(checked > 100, "{checked} expectations checked");
}

#[test]
fn every_scenario_round_trips_through_the_yaml_writer() {
    for file in scenario_files() {
        let loaded = load_yaml(&file).unwrap();
        let written = to_yaml(&loaded.trace);
        let again = parse_yaml(&file, &written)
            .unwrap_or_else(|e| panic!("{}: rewritten form does not parse: {e}\n{written}", file.display()));
        assert_eq!(again.trace.steps, loaded.trace.steps, "{}", file.display());
        assert_eq!(again.trace.description, loaded.trace.description);
        assert_eq!(again.trace.configuration, loaded.trace.configuration);
    }
}

#[test]
fn a_trace_with_an_unknown_key_or_two_events_in_one_step_is_refused_with_its_position() {
    let base = "version: 1\ndescription: d\nconfiguration: timing\nprofiles: all\nsteps:\n";
    let err =
        parse_yaml(Path::new("t.yaml"), &format!("{base}  - servo: 1\n    expct: {{tripped: true}}\n")).err().unwrap();
    assert!(err.message.contains("unknown key `expct`"), "{err}");
    assert_eq!(err.position.map(|p| p.line), Some(6), "{err}");
    let err = parse_yaml(Path::new("t.yaml"), &format!("{base}  - servo: 1\n    background: 1\n")).err().unwrap();
    assert!(err.message.contains("exactly one event"), "{err}");
    let err =
        parse_yaml(Path::new("t.yaml"), &format!("{base}  - servo: 1\n    expect: {{trippd: true}}\n")).err().unwrap();
    assert!(err.message.contains("unknown field `trippd`"), "{err}");
    assert_eq!(err.position.map(|p| p.line), Some(7), "{err}");
    let err = parse_yaml(
        Path::new("t.yaml"),
        "version: 2\ndescription: d\nconfiguration: timing\nprofiles: all\nsteps: [background]\n",
    )
    .err()
    .unwrap();
    assert!(err.message.contains("version 2 is not supported"), "{err}");
}

#[test]
fn a_divergence_names_the_step_its_line_and_the_events_before_it() {
    let spec = Spec::embedded().unwrap();
    let text = "version: 1\ndescription: wrong on purpose\nconfiguration: timing\nprofiles: [um-215]\nsteps:\n  - servo: 1\n  - servo: 1\n    expect: {counter: 3}\n";
    let loaded = parse_yaml(Path::new("wrong.yaml"), text).unwrap();
    let profile = spec.profiles.get("um-215").unwrap();
    let Err(Failure::Diverged(d)) = run_on_model(&spec, &loaded, &profile) else { panic!("must diverge") };
    assert_eq!((d.step, d.position.line), (1, 7));
    assert_eq!((d.expected.as_str(), d.observed.as_str()), ("3", "1"));
    assert_eq!(d.recent, ["servo interrupt", "servo interrupt"]);
}

#[test]
fn every_scenario_round_trips_through_json_lines() {
    use pmacwd_trace::jsonl::{read_all, to_jsonl};
    for file in scenario_files() {
        let loaded = load_yaml(&file).unwrap();
        let text = to_jsonl(&loaded.trace);
        assert_eq!(text.lines().count(), loaded.trace.steps.len() + 1, "a header line, then one line per step");
        let back = read_all(Path::new("t.jsonl"), text.as_bytes())
            .unwrap_or_else(|e| panic!("{}: {e}\n{text}", file.display()));
        assert_eq!(back.steps, loaded.trace.steps, "{}", file.display());
        assert_eq!(back.configuration, loaded.trace.configuration);
    }
}

#[test]
fn a_malformed_json_lines_step_is_refused_with_its_line_and_column() {
    use pmacwd_trace::jsonl::read_all;
    let header = r#"{"format":"pmacwd-trace","version":1,"description":"d","configuration":"timing","profiles":"all"}"#;
    let text = format!("{header}\n{{\"servo\":1}}\n\n{{\"servo\":1,\"expect\":{{\"trippd\":true}}}}\n");
    let err = read_all(Path::new("c.jsonl"), text.as_bytes()).unwrap_err();
    assert_eq!(err.position.map(|p| p.line), Some(4), "{err}");
    assert!(err.message.contains("unknown field `trippd`"), "{err}");
    let err = read_all(Path::new("c.jsonl"), "{\"format\":\"other\",\"version\":1,\"description\":\"d\",\"configuration\":\"timing\",\"profiles\":\"all\"}\n".as_bytes()).unwrap_err();
    assert!(err.message.contains("expected `pmacwd-trace`"), "{err}");
}
