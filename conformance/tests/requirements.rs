//! The requirements matrix (`specs/requirements.yaml`) against the code: every reference it
//! makes resolves, and every manual page the project cites (its sources and spec files) has statements in it.
//!
//! The spec loader already resolves the `spec` references and refuses a statement with neither
//! a check nor a reason; the references into other crates are resolved here: a property or
//! monitor name in the model, a scenario file, a test function in the file it names.

use pmacwd_model::monitor::MONITORS;
use pmacwd_model::properties::STATE_PROPERTIES;
use pmacwd_specs::requirements::{pages_of, Category, Reference, Requirements};
use pmacwd_specs::Spec;
use std::collections::BTreeSet;
use std::path::{Path, PathBuf};

/// Where the project writes its rules: every crate's sources and the spec files. A page cited
/// in any of them is a page the project relies on, so it needs statements in the matrix.
const CITING_DIRS: &[&str] =
    &["model/src", "impl/src", "bridge/src", "conformance/src", "trace/src", "emulator/src", "cli/src", "specs/src"];

/// Files whose citations are examples of the citation syntax, not rules: the citation parser.
const NOT_RULES: &[&str] = &["specs/src/cite.rs"];

/// Manual pages the project cites that the matrix does not cover yet, each with why. The seed
/// excerpts (UM p.215, p.217, p.236, SRM p.57, p.289) are quoted; the other pages the model and
/// the specs rely on are summarized. What is left are the pages of the host protocol the
/// emulator answers by: its command grammar, reply framing and variable formats. They are
/// checked by the emulator's own tests and by real clients (cli/tests/dls, cli/tests/gui), not
/// yet traced statement by statement. The test fails when a page here gets a statement (drop it
/// from this list), when it is no longer cited, and when a page is cited that is in neither.
const PAGES_NOT_YET_IN_THE_MATRIX: &[(&str, &str)] = &[
    ("SRM p.37", "emulator: I3, the handshake characters of replies"),
    ("SRM p.38", "emulator: I3 (continued), its examples of framed replies"),
    ("SRM p.170", "grammar: cited for what its 19-bit field is (a data-gathering source's address, I5001..I5048), not the range of M-variable addresses (docs/grammar.md, Addresses)"),
    ("SRM p.214", "emulator: the clock registers I7000-I7002 behind the servo clock bound"),
    ("SRM p.215", "emulator: the clock registers (continued)"),
    ("SRM p.216", "emulator: the clock registers (continued)"),
    ("SRM p.259", "emulator: the on-line command syntax"),
    ("SRM p.263", "emulator: the on-line command list"),
    ("SRM p.270", "emulator: the addressing commands #n and &n"),
    ("SRM p.282", "emulator: motor status words (continued)"),
    ("SRM p.283", "emulator: motor status words (continued)"),
    ("SRM p.284", "emulator: the end of the motor status words, the start of the coordinate system ones"),
    ("SRM p.285", "emulator: coordinate system status words (continued)"),
    ("SRM p.286", "emulator: coordinate system status words (continued)"),
    ("SRM p.287", "emulator: coordinate system status words (continued)"),
    ("UM p.46", "emulator: commands stored in an open buffer instead of run"),
    ("SRM p.95", "emulator motion (issue 30): Ixx12 units, Ixx13 the software limit"),
    ("SRM p.96", "emulator motion: Ixx13 (continued): 0 is none, off during a homing search, from the home position"),
    ("SRM p.97", "emulator motion: Ixx14, the negative software limit, decelerating at Ixx15"),
    ("SRM p.98", "emulator motion: Ixx16's default (a motor I-variable default, variables.yaml)"),
    ("SRM p.100", "emulator motion: Ixx19, the jog/home acceleration limit, and its default"),
    ("SRM p.101", "emulator motion: Ixx20-Ixx23, jog acceleration time, S-curve, jog speed, home speed"),
    ("SRM p.108", "emulator motion: Ixx27's default (variables.yaml)"),
    ("SRM p.152", "emulator motion: Ixx92's default (variables.yaml)"),
    ("SRM p.402", "emulator motion: V reports counts per servo cycle"),
    ("SRM p.39", "emulator user PLCs (issue 30): I5, which PLCs run, and its default"),
    ("SRM p.176", "emulator user PLCs: the countdown timers Isx11/Isx12 a PLC waits on"),
    ("SRM p.421", "emulator user PLCs and motion programs: CMD\"...\" statements"),
    ("SRM p.422", "emulator user PLCs and motion programs: CMD (continued), ADDRESS"),
    ("SRM p.423", "emulator user PLCs: CMD^x and the statements after it"),
    ("SRM p.429", "emulator motion programs: IF and ELSE on one line"),
    ("SRM p.430", "emulator motion programs: ELSE (continued)"),
    ("UM p.252", "emulator user PLCs: the conditions of IF and WHILE"),
    ("UM p.253", "emulator user PLCs and motion programs: AND/OR lines, one-line IF/WHILE"),
    ("UM p.341", "emulator motion programs: the double jump back that ends a program's calculation"),
    ("UM p.342", "emulator motion programs: WAIT, the next RTI"),
    ("SRM p.31", "emulator motion programs (issue 30): the move and axis attribute commands it executes"),
    ("SRM p.188", "emulator motion programs: Isx87 (TA), the minimum move time, what Isx87 reports"),
    ("SRM p.189", "emulator motion programs: Isx88 (TS), Isx89 (F, TM), Isx90, feedrate mode at power-up"),
    ("UM p.48", "emulator: program buffers, CLEAR, one buffer open at a time"),
    ("UM p.272", "emulator motion programs: modal commands, then the axis moves of a line together"),
];

fn workspace_root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).parent().expect("conformance/ sits in the workspace").to_path_buf()
}

fn matrix() -> Requirements {
    match Spec::embedded() {
        Ok(spec) => spec.requirements,
        Err(e) => panic!("the shipped specs must load: {e}"),
    }
}

/// Whether `file` (workspace-relative) defines a test function `name`: `fn name(` preceded by
/// `#[test]` among the attributes and comments right above it, or inside a `proptest!` block.
fn test_function_exists(file: &str, name: &str) -> Result<(), String> {
    let path = workspace_root().join(file);
    let text = std::fs::read_to_string(&path).map_err(|e| format!("cannot read {}: {e}", path.display()))?;
    let lines: Vec<&str> = text.lines().collect();
    let needle = format!("fn {name}(");
    let Some(at) = lines.iter().position(|l| l.trim_start().starts_with(&needle)) else {
        return Err(format!("{file} has no function `{name}`"));
    };
    let mut i = at;
    while i > 0 {
        let above = lines[i - 1].trim();
        if above == "#[test]" {
            return Ok(());
        }
        if !(above.starts_with("#[") || above.starts_with("//")) {
            break;
        }
        i -= 1;
    }
    if text[..text.find(&needle).unwrap_or(0)].contains("proptest!") {
        return Ok(());
    }
    Err(format!("`{name}` in {file} is not a #[test] function"))
}

fn unresolved(m: &Requirements) -> Vec<String> {
    let scenarios: BTreeSet<&str> =
        pmacwd_specs::scenarios::SCENARIOS.iter().filter_map(|(n, _)| n.strip_suffix(".yaml")).collect();
    let mut errors = Vec::new();
    for s in &m.statements {
        for r in &s.encoded_by {
            let problem = match r {
                Reference::Spec(_) => None, // resolved by the spec loader
                Reference::Property(name) => {
                    let known =
                        STATE_PROPERTIES.iter().any(|p| p.name == name) || MONITORS.iter().any(|p| p.name == name);
                    (!known).then(|| "no model property or monitor has this name".to_string())
                }
                Reference::Scenario(stem) => {
                    (!scenarios.contains(stem.as_str())).then(|| "no such file in specs/scenarios/".to_string())
                }
                Reference::Test(target) => match target.split_once("::") {
                    None => Some("write PATH::function".to_string()),
                    Some((file, name)) => test_function_exists(file, name).err(),
                },
            };
            if let Some(p) = problem {
                errors.push(format!("{} -> {r}: {p}", s.id));
            }
        }
    }
    errors
}

#[test]
fn every_reference_of_the_matrix_resolves() {
    let m = matrix();
    assert!(m.statements.len() >= 100, "the five seed pages hold at least 100 statements, not {}", m.statements.len());
    let errors = unresolved(&m);
    assert!(errors.is_empty(), "unresolved references in specs/requirements.yaml:\n{}", errors.join("\n"));
}

#[test]
fn every_statement_is_checked_or_says_why_not() {
    for s in &matrix().statements {
        let checks = s.encoded_by.iter().filter(|r| r.is_check()).count();
        match s.category() {
            Category::Checked => assert!(checks > 0, "{}: counted as checked without a check", s.id),
            Category::ByDefinition => assert!(checks > 0 && s.note.is_some(), "{}: by definition", s.id),
            Category::DataOnly => assert!(checks == 0 && !s.encoded_by.is_empty(), "{}: data only", s.id),
            Category::Missing => assert!(s.encoded_by.is_empty(), "{}: missing with references", s.id),
            Category::Deviation => {
                let reason = s.deviation.as_ref().map(|d| d.reason.trim()).unwrap_or_default();
                assert!(!reason.is_empty(), "{}: a deviation without its reason", s.id);
            }
        }
    }
}

#[test]
fn a_broken_reference_is_reported() {
    // The resolver itself must fail on each kind of dangling reference, or the test above
    // could pass on anything.
    let mut m = matrix();
    let s = &mut m.statements[0];
    s.encoded_by = vec![
        Reference::Property("a property nobody wrote".into()),
        Reference::Scenario("no-such-scenario".into()),
        Reference::Test("model/tests/semantics.rs::no_such_test".into()),
        Reference::Test("model/tests/semantics.rs::config".into()),
        Reference::Test("model/tests/no_such_file.rs::x".into()),
        Reference::Test("no separator".into()),
        Reference::Property("a background cycle reloads the counter from I40".into()),
        Reference::Scenario("a-reset-clears-bit-22".into()),
        Reference::Test("model/tests/semantics.rs::with_i40_zero_each_profile_reloads_its_own_reset_value".into()),
        Reference::Test("impl/tests/advance.rs::advance_equals_n_single_servo_cycles".into()),
    ];
    let errors = unresolved(&m);
    assert_eq!(errors.len(), 6, "{errors:#?}");
    assert!(errors[3].contains("is not a #[test] function"), "{}", errors[3]);
}

/// Every `UM p.N` and `SRM p.N` (or `p.N-M`, one page each) written anywhere in `text`; not
/// `PMAC-UM`, `PMAC-SRM` or `PMAC2 SRM`, the older manuals.
fn cited_pages(text: &str, out: &mut BTreeSet<String>) {
    for token in ["UM", "SRM"] {
        let pattern = format!("{token} p.");
        let mut from = 0;
        while let Some(i) = text[from..].find(&pattern) {
            let at = from + i;
            from = at + pattern.len();
            let before = text[..at].chars().next_back();
            if before.is_some_and(|c| c.is_ascii_alphanumeric() || c == '-') || text[..at].ends_with("PMAC2 ") {
                continue;
            }
            let page: String = text[from..].chars().take_while(|c| c.is_ascii_digit() || *c == '-').collect::<String>();
            let page = page.trim_end_matches('-');
            if !page.is_empty() {
                out.extend(pages_of(token, page));
            }
        }
    }
}

fn rust_files(dir: &Path, out: &mut Vec<PathBuf>) {
    let mut entries: Vec<_> = std::fs::read_dir(dir).expect("a readable source directory").flatten().collect();
    entries.sort_by_key(|e| e.path());
    for e in entries {
        let p = e.path();
        if p.is_dir() {
            rust_files(&p, out);
        } else if p.extension().is_some_and(|x| x == "rs") {
            out.push(p);
        }
    }
}

#[test]
fn every_manual_page_the_project_cites_has_statements_in_the_matrix() {
    let root = workspace_root();
    let mut files = Vec::new();
    for dir in CITING_DIRS {
        rust_files(&root.join(dir), &mut files);
    }
    files.retain(|f| !NOT_RULES.iter().any(|n| f.ends_with(n)));
    let mut spec_files: Vec<PathBuf> = std::fs::read_dir(root.join("specs"))
        .expect("a readable specs/")
        .flatten()
        .map(|e| e.path())
        .filter(|p| p.extension().is_some_and(|x| x == "yaml") && !p.ends_with("requirements.yaml"))
        .collect();
    spec_files.sort();
    assert!(spec_files.len() >= 8, "the scan finds the spec files: {spec_files:?}");
    files.extend(spec_files);
    let mut cited = BTreeSet::new();
    for f in &files {
        cited_pages(&std::fs::read_to_string(f).expect("a readable source file"), &mut cited);
    }
    assert!(
        cited.contains("UM p.215") && cited.contains("SRM p.57") && cited.contains("SRM p.259"),
        "the scan finds the citations of the model, the specs and the emulator: {cited:?}"
    );
    let quoted: BTreeSet<String> = matrix().statements.iter().flat_map(|s| s.pages()).collect();
    let allowed: BTreeSet<String> = PAGES_NOT_YET_IN_THE_MATRIX.iter().map(|(p, _)| p.to_string()).collect();
    let missing: Vec<&String> = cited.iter().filter(|p| !quoted.contains(*p) && !allowed.contains(*p)).collect();
    assert!(
        missing.is_empty(),
        "the project cites pages with no statement in specs/requirements.yaml: {missing:?} (summarize their \
         statements, or list them in PAGES_NOT_YET_IN_THE_MATRIX with a reason)"
    );
    let stale: Vec<&String> = allowed.iter().filter(|p| quoted.contains(*p) || !cited.contains(*p)).collect();
    assert!(stale.is_empty(), "PAGES_NOT_YET_IN_THE_MATRIX lists pages that are covered or no longer cited: {stale:?}");
}

#[test]
fn the_page_scan_reads_ranges_and_skips_the_older_manuals() {
    let mut pages = BTreeSet::new();
    cited_pages("// SRM p.289-290, UM p.215; PMAC-SRM p.44, PMAC2 SRM p.25 and PMAC-UM p.9, \"UM p.236\"", &mut pages);
    let pages: Vec<&str> = pages.iter().map(String::as_str).collect();
    assert_eq!(pages, ["SRM p.289", "SRM p.290", "UM p.215", "UM p.236"]);
}

#[test]
fn every_property_citing_a_quoted_page_is_named_by_a_statement_of_that_page() {
    // A property or monitor that cites a page of the matrix encodes one of its statements, so
    // the matrix must say which. Those citing only other sources (SRM p.290, UM p.240,
    // GlobalStatus.py) wait for their pages to be quoted.
    let m = matrix();
    let quoted: BTreeSet<String> = m.statements.iter().flat_map(|s| s.pages()).collect();
    let named = |name: &str, page: &str| {
        m.statements.iter().any(|s| {
            s.pages().iter().any(|p| p == page)
                && s.encoded_by.iter().any(|r| matches!(r, Reference::Property(n) if n == name))
        })
    };
    let all = STATE_PROPERTIES.iter().map(|p| (p.name, p.cite)).chain(MONITORS.iter().map(|p| (p.name, p.cite)));
    let mut orphans = Vec::new();
    for (name, cite) in all {
        let mut pages = BTreeSet::new();
        cited_pages(cite, &mut pages);
        if pages.iter().any(|p| quoted.contains(p)) && !pages.iter().any(|p| named(name, p)) {
            orphans.push(format!("{name} ({cite})"));
        }
    }
    assert!(
        orphans.is_empty(),
        "properties citing a quoted page that no statement of it names:\n{}",
        orphans.join("\n")
    );
}
